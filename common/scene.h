/*
 * scene.h: the scene model every tool works on, independent of files.
 *
 * formats/scene_xml/ fills it from a Mitsuba 3 XML file; geometry is baked
 * into world space at load time.  Shapes, BSDFs and lights live in flat
 * arrays and refer to each other by index.
 */
#ifndef PM_SCENE_H
#define PM_SCENE_H

#include <stdbool.h>
#include <stddef.h>

#include "bsdf.h"
#include "envmap.h"
#include "error.h"
#include "medium.h"
#include "mesh.h"
#include "transform.h"
#include "vec.h"

struct pm_texture;

enum pm_shape_type {
	PM_SHAPE_MESH,		/* obj, ply, rectangle, cube, disk */
	PM_SHAPE_SPHERE,
};

struct pm_shape {
	enum pm_shape_type type;
	struct pm_mesh mesh;		/* PM_SHAPE_MESH, world space */
	struct pm_vec3 center;		/* PM_SHAPE_SPHERE */
	float radius;
	struct pm_frame axes;		/* sphere: its object x, y, z axes in
					 * world space, for uv; all zero: the
					 * world's */
	bool flip_normals;		/* spheres: normals point inwards */
	int bsdf;			/* index into scene.bsdfs */
	int light;			/* index into scene.lights, or -1 */
	/* Media on either side, as 1 + an index into scene.media, 0 for
	 * none (vacuum), so that a zeroed shape names none: interior
	 * behind the normal, exterior in front; a ray crossing a shape
	 * that names either enters the one on its far side. */
	int interior, exterior;
	char name[64];			/* id, or type and ordinal, for messages */
};

enum pm_light_type {
	PM_LIGHT_AREA,
	PM_LIGHT_POINT,
	PM_LIGHT_SPOT,
	PM_LIGHT_CONSTANT,
	PM_LIGHT_ENVMAP,	/* Mitsuba's envmap: an image around the scene */
	PM_LIGHT_DIRECTIONAL,	/* parallel light from one direction */
	PM_LIGHT_PROJECTOR,	/* Mitsuba's projector: a pinhole casting
				 * an irradiance texture */
};

struct pm_light {
	enum pm_light_type type;
	struct pm_rgb radiance;		/* area, constant: emitted radiance */
	struct pm_rgb intensity;	/* point, spot: radiant intensity */
	int shape;			/* area: the shape it is attached to */
	struct pm_vec3 position;	/* point, spot */
	struct pm_frame frame;		/* spot: frame.n is the axis */
	float cutoff_angle;		/* spot, degrees (Mitsuba default 20) */
	float beam_width;		/* spot, degrees (default 3/4 of cutoff) */
	struct pm_envmap *env;		/* envmap: owned by the scene */
	struct pm_vec3 direction;	/* directional: unit, the way light
					 * travels; intensity holds its
					 * irradiance (W/m^2 on a surface
					 * facing it) */
	/* Textured emitters: 1 + an index into scene.textures, 0 for none.
	 * area: the radiance (at the shape's uv); spot: Mitsuba's texture,
	 * times intensity; projector: the irradiance on the image plane at
	 * z = 1 (required), times intensity.r, Mitsuba's scale. */
	int tex;
	/* spot, projector: world to the light's own frame (+z the axis,
	 * the texture's u along -x for the projector, +x for the spot) */
	struct pm_mat4 to_local;
	float tan_fov;			/* projector: tan(x_fov / 2) */
	float aspect;			/* projector: texture width / height */
	/* Filled by pm_scene_prepare: */
	double power;			/* luminous-ish power (mean of RGB), watts */
	double area;			/* area: surface area of the shape */
};

enum pm_fov_axis {
	PM_FOV_X,
	PM_FOV_Y,
	PM_FOV_DIAGONAL,
	PM_FOV_SMALLER,
	PM_FOV_LARGER,
};

enum pm_rfilter {
	PM_RFILTER_BOX,
	PM_RFILTER_TENT,
	PM_RFILTER_GAUSSIAN,
};

enum pm_sensor_type {
	PM_SENSOR_PERSPECTIVE,
	PM_SENSOR_ORTHOGRAPHIC,
	PM_SENSOR_THINLENS,
};

struct pm_camera {
	enum pm_sensor_type type;
	struct pm_mat4 to_world;	/* camera looks down +z, +y up, +x left;
					 * orthographic: may scale the film */
	float fov;			/* degrees, along fov_axis */
	enum pm_fov_axis fov_axis;
	float near_clip, far_clip;
	float aperture_radius;		/* thinlens: lens radius, scene units */
	float focus_distance;		/* thinlens: to the plane in focus */
	int width, height;		/* film size in pixels */
	int spp;			/* sampler sample_count */
	enum pm_rfilter rfilter;
	float filter_radius;		/* tent: radius; gaussian: stddev */
};

enum pm_integrator_type {
	PM_INTEGRATOR_PATH,
	PM_INTEGRATOR_PHOTONMAPPER,
	PM_INTEGRATOR_PTRACER,		/* Mitsuba's particle tracer */
};

/*
 * The photonmapper integrator's parameters, under Mitsuba 0.6's names; the
 * photon tools use them, the path tracer ignores them.
 */
struct pm_photon_params {
	long global_photons;		/* globalPhotons, 250000 as in Mitsuba
				 * 0.6: photon paths emitted; -1 (no
				 * photonmapper): pm_shoot_default_paths */
	long caustic_photons;		/* causticPhotons, likewise */
	float global_lookup_radius;	/* globalLookupRadius, 0.05: a fraction */
	float caustic_lookup_radius;	/* causticLookupRadius, 0.0125: of the
					 * scene's bounding-sphere radius */
	int lookup_size;		/* lookupSize, 120 */
	int direct_samples;		/* directSamples, 1 (Mitsuba 0.6: 16) */
	bool final_gather;		/* finalGather, true (Mitsuba 0.6: false) */
	int final_gather_samples;	/* finalGatherSamples, 1 (Mitsuba 0.6: 64):
				 * per camera sample where the cache
				 * does not serve */
};

struct pm_integrator {
	enum pm_integrator_type type;
	int max_depth;			/* -1: unlimited (Mitsuba's default) */
	int rr_depth;			/* Mitsuba default 5 */
	bool hide_emitters;
	struct pm_photon_params photon;	/* PM_INTEGRATOR_PHOTONMAPPER */
	/* ptracer: samples_per_pass (-1: all in one pass); passes change
	 * only how the work is split, never the image. */
	long samples_per_pass;
	/* Given as Mitsuba's moment wrapper: its nested integrator is the
	 * one above, and pm-render writes the moments as the channels
	 * moment_name.X, .Y, .Z and m2_moment_name.X, ...: the nested
	 * integrator's name attribute, "_arg_0" without one (Mitsuba 3.9's
	 * name for an unnamed nested object). */
	bool moment;
	char moment_name[64];
};

struct pm_scene {
	struct pm_shape *shapes;
	size_t nshapes;
	struct pm_bsdf *bsdfs;
	size_t nbsdfs;
	struct pm_light *lights;
	size_t nlights;
	struct pm_camera camera;
	bool has_camera;
	struct pm_medium *media;
	size_t nmedia;
	int camera_medium;		/* 1 + index into media, 0: vacuum
					 * (as pm_shape's interior) */
	struct pm_integrator integrator;
	int env_light;			/* index of the constant or envmap
					 * light (at most one), or -1 */
	char *path;			/* the file it was loaded from */
	/* Mitsuba's scene parameter embree_use_robust_intersections:
	 * Embree's watertight triangle test and conservative traversal
	 * (RTC_SCENE_FLAG_ROBUST), off by default as in Mitsuba 3, whose
	 * rays then go where pm's do (common/accel.c) */
	bool robust;
	size_t dropped_triangles;	/* degenerate triangles left out of meshes */
	/* Measured BRDF tables, one per file however many BSDFs use it;
	 * freed with the scene. */
	struct pm_merl **merls;
	size_t nmerls;
	/* Textures that BSDFs name by index (texture.h); their texels are
	 * freed with the scene. */
	struct pm_texture *textures;
	size_t ntextures;
	/* roughplastic's tables (bsdf.h), PM_ROUGH_T_RES floats per
	 * roughplastic BSDF, allocated by pm_scene_prepare */
	float *rough_t;
	/* Filled by pm_scene_prepare: the sphere around the geometry's
	 * bounding box, computed here once for everything that needs the
	 * scene's extent (the environment's power and its photons' disk,
	 * lookup radii); radius 0 at the origin without geometry. */
	struct pm_vec3 center;
	float radius;
};

/* Sets the defaults of an empty scene (Mitsuba's where they exist). */
void pm_scene_init(struct pm_scene *s);
/* Frees everything the scene owns, including meshes; s may be re-initialised. */
void pm_scene_free(struct pm_scene *s);

/* Appends a zeroed element and returns its index, or -1 when out of memory. */
int pm_scene_add_shape(struct pm_scene *s);
int pm_scene_add_bsdf(struct pm_scene *s);
int pm_scene_add_light(struct pm_scene *s);
int pm_scene_add_medium(struct pm_scene *s);
/* Hands the scene a MERL table to own; its index, or -1 when out of
 * memory (m is then still the caller's). */
int pm_scene_add_merl(struct pm_scene *s, struct pm_merl *m);
/* Appends a copy of *t, whose texels the scene then owns; its index, or
 * -1 when out of memory (t is then still the caller's). */
int pm_scene_add_texture(struct pm_scene *s, const struct pm_texture *t);

/*
 * After loading: prepares BSDFs, computes the bounding sphere, light areas
 * and powers, checks that indices are in range.  Geometry and ray casting
 * are built elsewhere.
 */
enum pm_err pm_scene_prepare(struct pm_scene *s, struct pm_error *err);

#endif
