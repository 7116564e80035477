/*
 * light.h: sampling the scene's lights from a point (next-event estimation)
 * and the matching densities for multiple importance sampling.
 *
 * For next-event estimation a light is chosen half in proportion to its
 * power and half uniformly: by power alone, an environment (whose power is
 * taken over the scene's bounding sphere) or a large light starves small
 * ones that dominate where they shine (a spot picked 2% of the time made
 * such a scene several times noisier than Mitsuba's uniform choice), and
 * uniformly alone wastes samples on dim lights.  In the half by power,
 * an environment's power (constant or envmap, taken through the disk of
 * the scene's bounding sphere) is scaled down to what the geometry can
 * catch: half the surfaces' area over the disk's, when less than one.
 * On a small spot under an environment map (tests/mitsuba/emitters.sh)
 * this brought pm's variance per sample from 2.25 times Mitsuba's (whose
 * choice is uniform) to 1.64 times.  Photons are emitted by power alone
 * (pick).  A point on an area light is chosen uniformly by
 * area (triangles by area, then uniformly within; a light that is one
 * parallelogram, such as Mitsuba's rectangle, directly on it).
 */
#ifndef PM_LIGHT_H
#define PM_LIGHT_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "accel.h"
#include "error.h"
#include "sampling.h"
#include "scene.h"
#include "vec.h"

/*
 * Walker's alias table (Vose's construction) over n weights: an index in
 * O(1) from one uniform number, which also leaves a fresh one, as
 * pm_distrib_sample does; light samples draw lights and triangles by it,
 * where the cdf's binary search in double was 5% of a path tracer's time.
 */
struct pm_alias {
	float q;		/* keep this bin with probability q ... */
	uint32_t alias;		/* ... else take this one */
	float inv_q, inv_rest;	/* 1 / q and 1 / (1 - q) (0 where
				 * infinite): no division per sample */
};

/* A triangle of an area light, as light samples need it. */
struct pm_light_tri {
	struct pm_vec3 p0, e1, e2;	/* p1 - p0, p2 - p0 */
	struct pm_vec3 n;		/* unit geometric normal */
	struct pm_vec3 ns;		/* the shading normal when the vertex
					 * normals agree (flat), else unused */
	uint32_t prim;
	bool flat;			/* no vertex normals, or three equal */
};

/*
 * An area light that is one parallelogram (two triangles sharing a
 * diagonal: Mitsuba's rectangle), sampled as Mitsuba samples its
 * rectangle, p0 + u1 e1 + u2 e2: uniform by area as the triangles' way,
 * without drawing a triangle and a square root first.
 */
struct pm_light_quad {
	struct pm_vec3 p0, e1, e2;
	struct pm_vec3 n, ns;		/* geometric and shading normal */
	struct pm_frame f;		/* pm_frame_from_normal(n), found
					 * once for photons' directions */
	bool on;			/* the light is such a parallelogram,
					 * untextured, flat */
};

struct pm_lights {
	struct pm_distrib pick;		/* over scene.lights, by power: photons */
	struct pm_distrib nee;		/* half by power (an environment's
					 * as the geometry catches it), half
					 * uniform: light samples from a
					 * point */
	struct pm_distrib *tris;	/* per light: over a mesh's triangles,
					 * or a projector image's texels
					 * (photons; empty when not drawn
					 * by texel) */
	size_t n;
	/* for light samples: nee as an alias table (n bins) with each
	 * light's probability in float; per area mesh light i, its
	 * triangles tri[tri0[i] .. tri0[i + 1]) and their alias table by
	 * area in the same bins of tri_alias */
	struct pm_alias *nee_alias;
	float *nee_p;
	struct pm_light_tri *tri;
	struct pm_alias *tri_alias;
	size_t *tri0;
	struct pm_light_quad *quad;	/* per light (n) */
};

/* Builds an alias table over w[0..n) (n >= 1, finite w >= 0 with a
 * positive sum, n < 2^32). */
enum pm_err pm_alias_build(struct pm_alias *t, const double *w, size_t n,
    struct pm_error *err);

/* An index drawn from t (n bins) by u in [0,1), and u's fresh remainder
 * in *u_reuse when not NULL. */
static inline size_t pm_alias_sample(const struct pm_alias *t, size_t n,
    float u, float *u_reuse)
{
	double x;
	int64_t i;
	double f, q;
	float r;

	if (n == 1) {
		/* one bin keeps itself (q = 1, inv_q = 1): u is its own
		 * remainder, as below, without the arithmetic */
		if (u_reuse != NULL)
			*u_reuse = u < 0x1.fffffep-1f ? u : 0x1.fffffep-1f;
		return 0;
	}
	x = (double)u * (double)(int64_t)n;	/* exact: u has 24 bits */
	/* signed 64-bit conversions (n < 2^32): one instruction each,
	 * where size_t's take a branch and several on x86-64 */
	i = (int64_t)x;
	if (i >= (int64_t)n)
		i = (int64_t)n - 1;
	f = x - (double)i;
	q = (double)t[i].q;
	if (f < q) {
		r = (float)(f * (double)t[i].inv_q);
	} else {
		r = (float)((f - q) * (double)t[i].inv_rest);
		i = t[i].alias;
	}
	if (u_reuse != NULL)
		*u_reuse = r < 0x1.fffffep-1f ? r : 0x1.fffffep-1f;
	return (size_t)i;
}

struct pm_light_sample {
	struct pm_vec3 wi;		/* unit direction from the reference point */
	float dist;			/* to the light point; INFINITY for the environment */
	struct pm_vec3 p, n;		/* point on the light and its normal */
	struct pm_rgb value;		/* radiance arriving along wi, unoccluded
					 * (point lights: intensity / dist^2) */
	float pdf;			/* solid angle, selection included; 1 for delta */
	bool delta;			/* point, spot and directional lights */
	int light;
};

/* Builds the distributions over the lights of s (prepared). */
enum pm_err pm_lights_init(struct pm_lights *ls, const struct pm_scene *s,
    struct pm_error *err);
void pm_lights_free(struct pm_lights *ls);

/* Samples a light point as seen from ref; false if nothing can be sampled
 * (no lights, or the chosen point cannot light ref). */
bool pm_lights_sample(const struct pm_lights *ls, const struct pm_scene *s,
    struct pm_vec3 ref, float u0, float u1, float u2, struct pm_light_sample *ls_out);
/* The most points pm_lights_sample_n takes at once. */
#define PM_LIGHT_LANES 256

/*
 * pm_lights_sample_n's input and results field by field (structure of
 * arrays, for SIMD lanes): point i is (ref[0][i], ref[1][i], ref[2][i])
 * with numbers u[0..3][i], sampled only where want[i]; its sample's wi,
 * dist, p, value, pdf and delta are those of struct pm_light_sample, ok[i]
 * and delta[i] masks (-1 true, 0 false).  A sample not ok, or not wanted,
 * has ok 0 and every other field defined but meaningless.  The light's
 * normal and index are not kept: a path's vertex needs neither.
 */
struct pm_light_lanes {
	float ref[3][PM_LIGHT_LANES], u[3][PM_LIGHT_LANES];
	bool want[PM_LIGHT_LANES];
	float wi[3][PM_LIGHT_LANES], dist[PM_LIGHT_LANES];
	float p[3][PM_LIGHT_LANES], value[3][PM_LIGHT_LANES];
	float pdf[PM_LIGHT_LANES];
	int32_t delta[PM_LIGHT_LANES], ok[PM_LIGHT_LANES];
};

/* pm_lights_sample at points 0..n of ll (n <= PM_LIGHT_LANES), the same
 * bits: in a scene with one light that is a parallelogram (the common
 * case of a rectangle light), four points at a time in SIMD lanes, else
 * one by one. */
void pm_lights_sample_n(const struct pm_lights *ls, const struct pm_scene *s,
    struct pm_light_lanes *ll, size_t n);

/* Sample i of ll as a struct pm_light_sample (n zero and light -1: the
 * lanes keep neither). */
static inline void
pm_light_lanes_get(const struct pm_light_lanes *ll, size_t i,
    struct pm_light_sample *o)
{
	o->wi = pm_v3(ll->wi[0][i], ll->wi[1][i], ll->wi[2][i]);
	o->dist = ll->dist[i];
	o->p = pm_v3(ll->p[0][i], ll->p[1][i], ll->p[2][i]);
	o->n = pm_v3(0.0f, 0.0f, 0.0f);
	o->value = pm_rgb(ll->value[0][i], ll->value[1][i], ll->value[2][i]);
	o->pdf = ll->pdf[i];
	o->delta = ll->delta[i] != 0;
	o->light = -1;
}

/*
 * True if something lies between the hit and the light sample.  The shadow
 * ray runs from the hit's offset origin to the light point itself (not
 * along wi, which starts at the unoffset point) and stops just short of it,
 * so that neither the offset nor the light's own surface casts a shadow.
 * Its direction is the whole way there, not a unit vector, and it stops
 * at 1 - 1e-4 of it (Mitsuba's spawn_ray_to): the same segment without
 * a square root and a division, which were a fifth of the path tracer's
 * own time per bounce outside the BSDF and the light sample.
 */
bool pm_light_occluded(const struct pm_accel *a, const struct pm_hit *h,
    const struct pm_light_sample *ls);
/* That shadow ray, for casting in a batch; false when there is none to
 * cast (the light point is the origin: nothing can block it).  Inline:
 * the path tracer makes one per light sample. */
static inline bool
pm_light_shadow_ray(const struct pm_hit *h,
    const struct pm_light_sample *ls, struct pm_ray *r)
{
	struct pm_vec3 o = pm_hit_origin(h, ls->wi), d;

	r->o = o;
	r->tmin = 0.0f;
	if (isinf(ls->dist)) {
		r->d = ls->wi;
		r->tmax = INFINITY;
		return true;
	}
	d = pm_sub(ls->p, o);
	if (!(pm_dot(d, d) > 0.0f))
		return false;
	r->d = d;
	r->tmax = 1.0f - 1e-4f;
	return true;
}

/* Solid-angle density with which pm_lights_sample picks the point p (normal
 * n) of area light `light` from ref. */
float pm_lights_pdf_area(const struct pm_lights *ls, const struct pm_scene *s,
    int light, struct pm_vec3 ref, struct pm_vec3 p, struct pm_vec3 n);
/* The same for the environment in direction w (unit, towards the sky). */
float pm_lights_pdf_env(const struct pm_lights *ls, const struct pm_scene *s,
    struct pm_vec3 w);
/* Radiance the environment (constant or envmap) sends along -w, that is
 * what a ray leaving in direction w finds; black without one. */
struct pm_rgb pm_lights_env_radiance(const struct pm_scene *s,
    struct pm_vec3 w);

/* Veach's power heuristic for a sample of density a against one of b. */
static inline float pm_power_heuristic(float a, float b)
{
	float a2 = a * a, b2 = b * b;

	if (isinf(a2))
		return 1.0f;
	return a2 + b2 > 0.0f ? a2 / (a2 + b2) : 0.0f;
}

/* Mitsuba's spot falloff: 1 inside beam_width, a linear ramp in angle down
 * to 0 at cutoff_angle; w is the unit direction leaving the light. */
float pm_spot_falloff(const struct pm_light *l, struct pm_vec3 w);

/* Radiant intensity a point, spot or projector light sends in direction
 * w (unit, leaving it): the spot's falloff and texture and the
 * projector's image included; black for other lights. */
struct pm_rgb pm_light_intensity(const struct pm_scene *s,
    const struct pm_light *l, struct pm_vec3 w);

/* Radiance area light l emits from its point h (p, ns, and shape, prim,
 * u, v for the uv of a textured radiance) towards w (unit): zero behind
 * the shading normal. */
struct pm_rgb pm_area_emitted_at(const struct pm_scene *s,
    const struct pm_light *l, const struct pm_hit *h, struct pm_vec3 w);

/*
 * Emitted radiance a ray finds along direction d: at hit h (an area light
 * seen from its front), or in the environment when h is NULL.  The ray was
 * sampled from prev_p with solid-angle density prev_pdf; unless prev_delta
 * (a camera ray or a specular bounce, which light sampling cannot produce)
 * it is weighted against light sampling by the power heuristic.
 */
struct pm_rgb pm_lights_emitted(const struct pm_lights *ls,
    const struct pm_scene *s, const struct pm_hit *h, struct pm_vec3 d,
    struct pm_vec3 prev_p, float prev_pdf, bool prev_delta);

/* Radiance an untextured area light emits from a point with shading
 * normal n towards w (unit): its radiance on the front side, zero
 * behind (pm_area_emitted_at also takes textures). */
static inline struct pm_rgb pm_area_emitted(const struct pm_light *l,
    struct pm_vec3 n, struct pm_vec3 w)
{
	return pm_dot(n, w) > 0.0f ? l->radiance : pm_rgb1(0.0f);
}

#endif
