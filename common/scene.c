/*
 * scene.c: the scene model's life cycle: defaults, growth of the flat
 * arrays, and the preparation every tool needs after loading (BSDF tables,
 * the bounding sphere, light areas and powers, index checks).
 *
 * Nothing here knows about files; formats/scene_xml/ fills the arrays.
 */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "merl.h"
#include "scene.h"
#include "texture.h"

/* Mitsuba's perspective camera defaults to a 50 mm lens on 36 x 24 mm film,
 * that is a diagonal field of view of 2 atan(sqrt(36^2 + 24^2) / 100). */
#define PM_DEFAULT_DIAGONAL_FOV 46.79300f

/* Empties s and sets Mitsuba's defaults for the camera and integrator. */
void
pm_scene_init(struct pm_scene *s)
{
	memset(s, 0, sizeof(*s));
	s->env_light = -1;

	s->camera.to_world = pm_mat4_identity();
	s->camera.fov = PM_DEFAULT_DIAGONAL_FOV;
	s->camera.fov_axis = PM_FOV_DIAGONAL;
	s->camera.near_clip = 0.01f;
	s->camera.far_clip = 10000.0f;
	s->camera.width = 768;
	s->camera.height = 576;
	s->camera.spp = 4;
	s->camera.rfilter = PM_RFILTER_GAUSSIAN;
	s->camera.filter_radius = 0.5f;
	s->has_camera = false;

	s->integrator.type = PM_INTEGRATOR_PATH;
	s->integrator.max_depth = -1;
	s->integrator.rr_depth = 5;
	s->integrator.hide_emitters = false;
	s->integrator.samples_per_pass = -1;
	s->integrator.photon.global_photons = -1;	/* pm-shoot decides */
	s->integrator.photon.caustic_photons = -1;
	s->integrator.photon.global_lookup_radius = 0.05f;
	s->integrator.photon.caustic_lookup_radius = 0.0125f;
	s->integrator.photon.lookup_size = 120;
	s->integrator.photon.direct_samples = 1;
	s->integrator.photon.final_gather = true;
	s->integrator.photon.final_gather_samples = 1;
}

/* Frees the arrays, meshes and path; s is left empty. */
void
pm_scene_free(struct pm_scene *s)
{
	size_t i;

	for (i = 0; i < s->nshapes; i++)
		pm_mesh_free(&s->shapes[i].mesh);
	free(s->shapes);
	free(s->bsdfs);
	free(s->rough_t);
	for (i = 0; i < s->nlights; i++)
		if (s->lights[i].env != NULL) {
			pm_envmap_free(s->lights[i].env);
			free(s->lights[i].env);
		}
	free(s->lights);
	for (i = 0; i < s->nmedia; i++)
		pm_medium_release(&s->media[i]);
	free(s->media);
	for (i = 0; i < s->nmerls; i++)
		pm_merl_free(s->merls[i]);
	free(s->merls);
	for (i = 0; i < s->ntextures; i++)
		pm_texture_free(&s->textures[i]);
	free(s->textures);
	free(s->path);
	memset(s, 0, sizeof(*s));
	s->env_light = -1;
}

/*
 * Grows *arr so that it can hold n + 1 elements of size sz.  The capacity
 * is implicit: the next power of two at or above n (at least 8), so the
 * array is reallocated only when n reaches one.
 */
static int
grow(void **arr, size_t n, size_t sz)
{
	size_t cap;
	void *p;

	if (n >= (size_t)INT32_MAX)
		return -1;
	if (n >= 8 && (n & (n - 1)) != 0)
		return 0;
	cap = n < 8 ? 8 : 2 * n;
	p = realloc(*arr, cap * sz);
	if (p == NULL)
		return -1;
	*arr = p;
	return 0;
}

/* Appends a zeroed shape (with light -1); its index, or -1. */
int
pm_scene_add_shape(struct pm_scene *s)
{
	struct pm_shape *sh;

	if (grow((void **)&s->shapes, s->nshapes, sizeof(*s->shapes)) < 0)
		return -1;
	sh = &s->shapes[s->nshapes];
	memset(sh, 0, sizeof(*sh));
	sh->light = -1;		/* zero would name a light that may not exist */
	return (int)s->nshapes++;
}

/* Appends a zeroed BSDF; its index, or -1. */
int
pm_scene_add_bsdf(struct pm_scene *s)
{
	if (grow((void **)&s->bsdfs, s->nbsdfs, sizeof(*s->bsdfs)) < 0)
		return -1;
	memset(&s->bsdfs[s->nbsdfs], 0, sizeof(*s->bsdfs));
	return (int)s->nbsdfs++;
}

/* Appends a zeroed light (with shape -1); its index, or -1. */
int
pm_scene_add_light(struct pm_scene *s)
{
	struct pm_light *l;

	if (grow((void **)&s->lights, s->nlights, sizeof(*s->lights)) < 0)
		return -1;
	l = &s->lights[s->nlights];
	memset(l, 0, sizeof(*l));
	l->shape = -1;
	return (int)s->nlights++;
}

/* Appends a zeroed medium; its index, or -1. */
int
pm_scene_add_medium(struct pm_scene *s)
{
	if (grow((void **)&s->media, s->nmedia, sizeof(*s->media)) < 0)
		return -1;
	memset(&s->media[s->nmedia], 0, sizeof(*s->media));
	return (int)s->nmedia++;
}

/* Takes ownership of a MERL table; its index, or -1. */
int
pm_scene_add_merl(struct pm_scene *s, struct pm_merl *m)
{
	if (grow((void **)&s->merls, s->nmerls, sizeof(*s->merls)) < 0)
		return -1;
	s->merls[s->nmerls] = m;
	return (int)s->nmerls++;
}

/* Takes ownership of a texture's texels; its index, or -1. */
int
pm_scene_add_texture(struct pm_scene *s, const struct pm_texture *t)
{
	if (grow((void **)&s->textures, s->ntextures, sizeof(*s->textures)) < 0)
		return -1;
	s->textures[s->ntextures] = *t;
	return (int)s->ntextures++;
}

/*
 * The sphere around the bounding box of what the ray caster sees: the
 * vertices of the meshes' triangles (not unused vertices) and the
 * spheres.  In float, min and max being exact, so that it is the box
 * Embree reports (pm_accel_bounds) to the bit.
 */
static void
scene_bsphere(struct pm_scene *s)
{
	float lo[3] = {INFINITY, INFINITY, INFINITY};
	float hi[3] = {-INFINITY, -INFINITY, -INFINITY};
	size_t i, t;
	int a, k;

	for (i = 0; i < s->nshapes; i++) {
		const struct pm_shape *sh = &s->shapes[i];

		if (sh->type == PM_SHAPE_SPHERE) {
			float c[3] = {sh->center.x, sh->center.y, sh->center.z};

			for (a = 0; a < 3; a++) {
				lo[a] = pm_fminf(lo[a], c[a] - sh->radius);
				hi[a] = pm_fmaxf(hi[a], c[a] + sh->radius);
			}
			continue;
		}
		for (t = 0; t < sh->mesh.ntris; t++)
			for (k = 0; k < 3; k++) {
				const float *p = &sh->mesh.pos[3 *
				    (size_t)sh->mesh.idx[3 * t + (size_t)k]];

				for (a = 0; a < 3; a++) {
					lo[a] = pm_fminf(lo[a], p[a]);
					hi[a] = pm_fmaxf(hi[a], p[a]);
				}
			}
	}
	if (!(lo[0] <= hi[0] && lo[1] <= hi[1] && lo[2] <= hi[2])) {
		s->center = pm_v3(0, 0, 0);
		s->radius = 0.0f;
		return;
	}
	s->center = pm_scale(pm_add(pm_v3(lo[0], lo[1], lo[2]),
	    pm_v3(hi[0], hi[1], hi[2])), 0.5f);
	s->radius = 0.5f * pm_length(pm_sub(pm_v3(hi[0], hi[1], hi[2]),
	    pm_v3(lo[0], lo[1], lo[2])));
}

/* The mesh attributes the textures of shape i look up (its BSDF's, its
 * area light's): a set of enum pm_mesh_attr bits. */
static unsigned
shape_needs(const struct pm_scene *s, size_t i)
{
	const struct pm_shape *sh = &s->shapes[i];
	const struct pm_bsdf *b = &s->bsdfs[sh->bsdf];
	int tex[5] = {b->tex_diffuse, b->tex_specular, b->tex_alpha,
	    b->tex_transmittance, sh->light >= 0 ? s->lights[sh->light].tex : 0};
	unsigned n = 0;
	int k;

	for (k = 0; k < 5; k++)
		if (tex[k] > 0)
			n |= pm_texture_needs(&s->textures[tex[k] - 1]);
	return n;
}

/* An error if a shape's textures look up a mesh attribute the shape
 * lacks (Mitsuba fails there too); called once indices are checked. */
static enum pm_err
mesh_attributes_present(const struct pm_scene *s, struct pm_error *err)
{
	size_t i;

	for (i = 0; i < s->nshapes; i++) {
		const struct pm_shape *sh = &s->shapes[i];
		unsigned n;

		if (s->ntextures == 0 || (n = shape_needs(s, i)) == 0)
			continue;
		if (sh->type == PM_SHAPE_MESH) {
			if (sh->mesh.vcolor != NULL)
				n &= ~(unsigned)PM_ATTR_VERTEX_COLOR;
			if (sh->mesh.fcolor != NULL)
				n &= ~(unsigned)PM_ATTR_FACE_COLOR;
		}
		if (n != 0)
			return pm_fail(err, PM_ERR_INVALID, "shape %s: a "
			    "mesh_attribute texture looks up %s, which the "
			    "shape lacks (a PLY file's r g b or red green blue "
			    "properties)", sh->name, (n & PM_ATTR_VERTEX_COLOR) ?
			    "vertex_color" : "face_color");
	}
	return PM_OK;
}

/* One table of PM_ROUGH_T_RES floats for each roughplastic BSDF, in one
 * array the scene owns; false when out of memory. */
static bool
give_rough_tables(struct pm_scene *s)
{
	size_t i, n = 0;

	for (i = 0; i < s->nbsdfs; i++)
		n += s->bsdfs[i].type == PM_BSDF_ROUGHPLASTIC;
	free(s->rough_t);
	s->rough_t = NULL;
	if (n == 0)
		return true;
	if ((s->rough_t = calloc(n, PM_ROUGH_T_RES * sizeof(float))) == NULL)
		return false;
	for (i = 0, n = 0; i < s->nbsdfs; i++)
		if (s->bsdfs[i].type == PM_BSDF_ROUGHPLASTIC)
			s->bsdfs[i].rough_t = &s->rough_t[PM_ROUGH_T_RES * n++];
	return true;
}

/* Points a BSDF made of others at its nested ones, which must come
 * before it (so they are prepared first, and nesting cannot loop). */
static enum pm_err
link_nested(struct pm_scene *s, size_t i, struct pm_error *err)
{
	struct pm_bsdf *b = &s->bsdfs[i];
	int k, n = b->type == PM_BSDF_MASK ? 1 : 2;

	b->sub[0] = b->sub[1] = NULL;
	b->textures = s->textures;
	b->nested_textures = false;
	for (k = 0; k < n; k++) {
		const struct pm_bsdf *c;

		if (b->nested[k] < 0 || (size_t)b->nested[k] >= i) {
			return pm_fail(err, PM_ERR_INVALID, "BSDF %zu: nested "
			    "BSDF index %d not below its own", i, b->nested[k]);
		}
		c = &s->bsdfs[b->nested[k]];
		b->sub[k] = c;
		/* the perturbed frame is made for the BSDF at the hit
		 * (frame.h), not for one nested in it */
		if (c->tex_normal != 0 || c->tex_bump != 0) {
			return pm_fail(err, PM_ERR_UNSUPPORTED, "BSDF %zu: a "
			    "normalmap or bumpmap inside a blendbsdf, mask or "
			    "two-sided pair is not supported (wrap the whole "
			    "BSDF instead)", i);
		}
		if (c->tex_diffuse > 0 || c->tex_specular > 0 ||
		    c->tex_alpha > 0 || c->tex_alpha_v > 0 ||
		    c->tex_weight > 0 || c->tex_transmittance > 0 ||
		    c->pr.textured || c->nested_textures)
			b->nested_textures = true;
	}
	return PM_OK;
}

/* Prepares BSDFs, computes the bounding sphere, light areas and powers,
 * checks indices. */
enum pm_err
pm_scene_prepare(struct pm_scene *s, struct pm_error *err)
{
	const double pi = 3.14159265358979323846;
	size_t i;
	enum pm_err e;

	if (!give_rough_tables(s))
		return pm_fail(err, PM_ERR_NOMEM, "no memory for roughplastic's "
		    "tables");
	for (i = 0; i < s->nbsdfs; i++) {
		struct pm_bsdf *b = &s->bsdfs[i];
		size_t nt = s->ntextures;

		if (b->tex_diffuse < 0 || (size_t)b->tex_diffuse > nt ||
		    b->tex_specular < 0 || (size_t)b->tex_specular > nt ||
		    b->tex_alpha < 0 || (size_t)b->tex_alpha > nt ||
		    b->tex_transmittance < 0 ||
		    (size_t)b->tex_transmittance > nt ||
		    b->tex_weight < 0 || (size_t)b->tex_weight > nt)
			return pm_fail(err, PM_ERR_INVALID, "BSDF %zu: texture "
			    "index out of range (%zu textures)", i, nt);
		if (pm_bsdf_is_composite(b) &&
		    (e = link_nested(s, i, err)) != PM_OK)
			return e;
		pm_bsdf_prepare(b);
	}
	scene_bsphere(s);

	for (i = 0; i < s->nshapes; i++) {
		const struct pm_shape *sh = &s->shapes[i];

		if (sh->bsdf < 0 || (size_t)sh->bsdf >= s->nbsdfs)
			return pm_fail(err, PM_ERR_INVALID,
			    "shape %s: BSDF index %d out of range (%zu BSDFs)",
			    sh->name, sh->bsdf, s->nbsdfs);
		if (sh->interior < 0 || sh->interior > (int)s->nmedia ||
		    sh->exterior < 0 || sh->exterior > (int)s->nmedia)
			return pm_fail(err, PM_ERR_INVALID,
			    "shape %s: medium index out of range (%zu media)",
			    sh->name, s->nmedia);
		if (sh->light == -1)
			continue;
		if (sh->light < 0 || (size_t)sh->light >= s->nlights)
			return pm_fail(err, PM_ERR_INVALID,
			    "shape %s: light index %d out of range (%zu lights)",
			    sh->name, sh->light, s->nlights);
		if (s->lights[sh->light].type != PM_LIGHT_AREA ||
		    s->lights[sh->light].shape != (int)i)
			return pm_fail(err, PM_ERR_INVALID,
			    "shape %s: light %d is not its area light",
			    sh->name, sh->light);
	}

	if (s->camera_medium < 0 || s->camera_medium > (int)s->nmedia)
		return pm_fail(err, PM_ERR_INVALID, "camera medium %d out of "
		    "range (%zu media)", s->camera_medium, s->nmedia);

	if (s->env_light != -1 && (s->env_light < 0 ||
	    (size_t)s->env_light >= s->nlights ||
	    (s->lights[s->env_light].type != PM_LIGHT_CONSTANT &&
	    s->lights[s->env_light].type != PM_LIGHT_ENVMAP)))
		return pm_fail(err, PM_ERR_INVALID,
		    "environment light index %d is not a constant or envmap "
		    "light",
		    s->env_light);

	for (i = 0; i < s->nlights; i++) {
		struct pm_light *l = &s->lights[i];
		const struct pm_shape *sh;
		double mean, theta;
		struct pm_rgb tmean = pm_rgb1(1.0f);

		if (l->tex < 0 || (size_t)l->tex > s->ntextures ||
		    (l->type == PM_LIGHT_PROJECTOR && l->tex == 0))
			return pm_fail(err, PM_ERR_INVALID, "light %zu: texture "
			    "index %d out of range (%zu textures)", i, l->tex,
			    s->ntextures);
		/* a textured light's power counts the texture's mean */
		if (l->tex > 0)
			tmean = pm_texture_mean(&s->textures[l->tex - 1]);
		switch (l->type) {
		case PM_LIGHT_AREA:
			if (l->shape < 0 || (size_t)l->shape >= s->nshapes ||
			    s->shapes[l->shape].light != (int)i)
				return pm_fail(err, PM_ERR_INVALID,
				    "area light %zu: shape index %d does not "
				    "name a shape that carries it", i, l->shape);
			sh = &s->shapes[l->shape];
			if (sh->type == PM_SHAPE_SPHERE)
				l->area = 4.0 * pi * (double)sh->radius *
				    (double)sh->radius;
			else
				l->area = pm_mesh_area(&sh->mesh);
			mean = pm_rgb_mean(l->tex > 0 ? tmean : l->radiance);
			/* One-sided Lambertian emitter: M = pi L. */
			l->power = pi * l->area * mean;
			break;
		case PM_LIGHT_POINT:
			l->area = 0.0;
			l->power = 4.0 * pi * pm_rgb_mean(l->intensity);
			break;
		case PM_LIGHT_SPOT:
			/* The cone whose half-angle lies halfway along the
			 * linear falloff from beam_width to cutoff_angle. */
			l->area = 0.0;
			theta = 0.5 * ((double)l->cutoff_angle +
			    (double)l->beam_width) * pi / 180.0;
			l->power = 2.0 * pi * (1.0 - cos(theta)) *
			    pm_rgb_mean(pm_rgb_mul(l->intensity, tmean));
			break;
		case PM_LIGHT_PROJECTOR:
			/* Mitsuba's scale pi E on the image plane at z = 1,
			 * whose area is (2 tan_fov)^2 / aspect: all of it
			 * leaves the pinhole. */
			l->area = 0.0;
			l->power = pi * pm_rgb_mean(pm_rgb_mul(l->intensity,
			    tmean)) * 4.0 * (double)l->tan_fov *
			    (double)l->tan_fov / (double)l->aspect;
			break;
		case PM_LIGHT_CONSTANT:
			if (s->env_light != (int)i)
				return pm_fail(err, PM_ERR_INVALID,
				    "constant light %zu is not the scene's "
				    "environment light", i);
			l->area = 0.0;
			/* Radiance L arriving over the disk of the bounding
			 * sphere from every direction: pi L times 4 pi R^2. */
			l->power = pi * pm_rgb_mean(l->radiance) * 4.0 * pi *
			    (double)s->radius * s->radius;
			break;
		case PM_LIGHT_ENVMAP:
			if (s->env_light != (int)i || l->env == NULL)
				return pm_fail(err, PM_ERR_INVALID,
				    "envmap light %zu is not the scene's "
				    "environment light", i);
			l->area = 0.0;
			/* As for constant: the radiance over the sphere of
			 * directions, through the bounding sphere's disk. */
			l->power = pi * l->env->integral * (double)s->radius *
			    s->radius;
			break;
		case PM_LIGHT_DIRECTIONAL:
			l->area = 0.0;
			/* Irradiance E through the bounding sphere's disk. */
			l->power = pm_rgb_mean(l->intensity) * pi *
			    (double)s->radius * s->radius;
			break;
		default:
			return pm_fail(err, PM_ERR_INVALID,
			    "light %zu: unknown type %d", i, (int)l->type);
		}
		if (!isfinite(l->power) || l->power < 0.0)
			return pm_fail(err, PM_ERR_INVALID,
			    "light %zu: power %g is not a finite non-negative "
			    "number", i, l->power);
	}
	return mesh_attributes_present(s, err);
}
