/*
 * shoot.h: tracing photons from the lights (the first pass of photon
 * mapping, Jensen 1996/2004) into flat arrays of records.
 *
 * Photon path i of a map depends only on (seed, map kind, i), so shards
 * shot over different index ranges concatenate into exactly the map one
 * run over the whole range would give, whatever the thread count.
 */
#ifndef PM_SHOOT_H
#define PM_SHOOT_H

#include <stdbool.h>
#include <stdint.h>

#include "accel.h"
#include "error.h"
#include "light.h"
#include "photon.h"
#include "rng.h"
#include "scene.h"

/* One effect's verdict, as -v prints it and the map's header keeps it
 * (effect.NAME=TEXT). */
struct pm_effect_note {
	const char *name;	/* "global", "caustics", "refraction" */
	char text[160];		/* "yes (2 shapes reflect diffusely ...)" */
};

#define PM_EFFECT_NOTES 3

/* What the scene calls for, and why, decided before any photon is shot. */
struct pm_effects {
	bool global;		/* some surface reflects diffusely or glossily */
	bool caustic;		/* specular surfaces and a diffuse receiver */
	bool refraction;	/* dielectrics present */
	int nspecular;		/* shapes with a specular (delta) component */
	bool media;		/* participating media: a volume map, shot
				 * with the global map's paths */
	struct pm_effect_note notes[PM_EFFECT_NOTES];	/* in that order */
};

/* Decides which maps a scene needs (see pm_effects). */
void pm_shoot_effects(const struct pm_scene *s, struct pm_effects *e);

/*
 * Photon paths per map when neither the command line nor the scene's
 * photonmapper integrator gives a count: one path per PM_SAMPLES_PER_PATH
 * camera samples of the scene's own film and sampler, within
 * [PM_PATHS_MIN, PM_PATHS_MAX]; PM_PATHS_NO_CAMERA without a sensor.
 */
#define PM_SAMPLES_PER_PATH 10
#define PM_PATHS_MIN 10000
#define PM_PATHS_MAX 1000000
#define PM_PATHS_NO_CAMERA 100000
long long pm_shoot_default_paths(const struct pm_scene *s);

/*
 * The bounces a photon may make (pm_shoot_opts.max_depth) for the
 * scene's max_depth, which counts path segments from camera to light: a
 * photon of d bounces seen from a camera's first hit makes d + 2.  -1:
 * unlimited.
 */
int pm_shoot_default_max_depth(const struct pm_scene *s);

/* A growable array of photons. */
struct pm_photon_buf {
	struct pm_photon *p;
	size_t n, cap;
};
void pm_photon_buf_free(struct pm_photon_buf *b);

enum pm_map_pass {
	PM_PASS_GLOBAL = 1,	/* photons stored at every non-specular hit */
	PM_PASS_CAUSTIC = 2,	/* aimed at specular shapes; L S+ D stored */
};

/* Bytes a chunk keeps for its sink_prepare's note (pm_shoot_opts). */
#define PM_SHOOT_NOTE	64

struct pm_shoot_opts {
	enum pm_map_pass pass;
	uint64_t seed;
	uint64_t first;		/* index of the first photon path */
	uint64_t count;		/* photon paths to shoot */
	int max_depth;		/* bounces a photon may make; -1: unlimited */
	int threads;
	/* Global pass in a scene with media: where the photons that
	 * scatter in a medium go (the volume map), in path order; NULL:
	 * not stored.  Scatters count as bounces (depth, max_depth). */
	struct pm_photon_buf *volume;
	/* NULL, or where the (surface) photons go instead of the output
	 * buffer: called with each chunk's photons in path order, one
	 * call at a time, while other threads go on tracing; an error
	 * from it stops the shoot and is pm_shoot's.  pm-shoot writes the
	 * map file from here, so that no map is held in memory whole.
	 * sink_prepare, if set, is first called with the same photons on
	 * the thread that traced them, in no order and in parallel, and
	 * leaves in note what sink is then given: the per-chunk work that
	 * need not wait its turn (pm-shoot: checksums and bounds). */
	void (*sink_prepare)(void *arg, const struct pm_photon *p, size_t n,
	    unsigned char note[PM_SHOOT_NOTE]);
	enum pm_err (*sink)(void *arg, const struct pm_photon *p, size_t n,
	    const unsigned char note[PM_SHOOT_NOTE], struct pm_error *err);
	void *sink_arg;
};

struct pm_shoot_stats {
	uint64_t stored;	/* photons stored */
	uint64_t dropped;	/* non-finite photons dropped */
	uint64_t paths_specular;	/* paths that hit a specular surface first */
	uint64_t volume_stored;	/* photons stored in opts->volume */
};

/* Everything tracing needs; built once per scene. */
struct pm_shooter {
	const struct pm_scene *scene;
	const struct pm_accel *accel;
	const struct pm_lights *lights;
	/* Bounding spheres of the specular shapes, to aim caustic photons. */
	struct pm_vec3 *aim_center;
	float *aim_radius;
	int naim;
	/* Per light, the medium its photons start in (an index into
	 * scene.media, -1: vacuum); NULL in a scene without media. */
	int *light_medium;
	/* Per shape, which SIMD lanes take a global photon's bounces there
	 * (shoot.c's enum lane_kind), found once rather than at every hit. */
	uint8_t *lane;
};

enum pm_err pm_shooter_init(struct pm_shooter *sh, const struct pm_scene *s,
    const struct pm_accel *a, const struct pm_lights *ls, struct pm_error *err);
void pm_shooter_free(struct pm_shooter *sh);

/*
 * Shoots opts->count photon paths and appends the photons they store to
 * out, in path order.  Each photon's power is the flux it would carry were
 * it the only path shot: divide by the number of paths to normalise.
 */
enum pm_err pm_shoot(const struct pm_shooter *sh, const struct pm_shoot_opts *opts,
    struct pm_photon_buf *out, struct pm_shoot_stats *stats, struct pm_error *err);

/*
 * One light path's start as the global pass emits it (ptracer's light
 * paths): origin, unit direction and flux; false if it carries nothing.
 */
bool pm_shooter_emit(const struct pm_shooter *sh, struct pm_rng *rng,
    struct pm_vec3 *o, struct pm_vec3 *d, struct pm_rgb *flux);

/* A point of area light `light`'s shape, uniform by area, with its
 * geometric and shading normals; *lh says where it lies (shape, prim,
 * u, v) for pm_area_emitted_at's textured radiance. */
void pm_shooter_shape_point(const struct pm_shooter *sh, int light, float u1,
    float u2, struct pm_vec3 *p, struct pm_vec3 *ng, struct pm_vec3 *ns,
    struct pm_hit *lh);

/* A 64-bit identity of what photons depend on: geometry, materials and
 * lights (not the camera or the sampler). */
uint64_t pm_scene_hash(const struct pm_scene *s);

#endif
