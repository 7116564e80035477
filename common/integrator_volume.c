/*
 * integrator_volume.c: what the path tracer (integrator_path.c) does in
 * participating media, with Mitsuba 3's volpath as the specification:
 *   - the medium a ray travels in is tracked: it starts as the camera's
 *     and changes where the ray crosses a shape that names an interior or
 *     exterior medium, to the one on the side it leaves towards;
 *   - along each segment a free flight is sampled (medium.h: one channel
 *     per path, weighted by the density averaged over channels); a scatter
 *     before the surface is a path vertex like a surface bounce: it counts
 *     towards max_depth and Russian roulette, samples a light (when the
 *     medium's sample_emitters is set) weighted by the power heuristic
 *     against the phase function, and continues in a direction sampled
 *     from the phase function;
 *   - shadow rays carry the transmittance of every medium they cross and
 *     pass through null-BSDF (index-matched) boundaries, switching medium
 *     there; any other surface blocks them.  The transmittance of a
 *     homogeneous medium is computed exactly (Beer-Lambert) where Mitsuba
 *     estimates it by tracking, which has the same expectation; that of a
 *     heterogeneous one is estimated by ratio tracking (medium.h).
 * Only scenes with media come here; the others keep the plain path
 * tracer's behaviour to the bit.
 */
#include <math.h>
#include <stdint.h>

#include "integrator.h"

/* Bound on the surfaces a shadow ray passes through: a null-BSDF box is
 * two, nested ones a few more; past this the light counts as blocked. */
#define MAX_SHADOW_CROSSINGS 64

int
pm_medium_after(const struct pm_scene *s, const struct pm_hit *h,
    struct pm_vec3 d, int medium)
{
	const struct pm_shape *sh = &s->shapes[h->shape];

	if (sh->interior == 0 && sh->exterior == 0)
		return medium;
	return (pm_dot(d, h->ng) > 0.0f ? sh->exterior : sh->interior) - 1;
}

/* The transmittance of `medium` (-1: none) from the point `from` along
 * unit d for len (may be INFINITY). */
static struct pm_rgb
segment_tr(const struct pm_scene *s, int medium, struct pm_vec3 from,
    struct pm_vec3 d, float len, struct pm_rng *rng)
{
	if (medium < 0)
		return pm_rgb1(1.0f);
	return pm_medium_transmittance_ray(&s->media[medium], from, d, 0.0f,
	    len, rng);
}

struct pm_rgb
pm_volume_shadow(const struct pm_render_ctx *ctx, struct pm_vec3 o,
    int medium, const struct pm_light_sample *ls)
{
	/* Without the caller's generator, one seeded from the ray itself:
	 * only a heterogeneous medium draws from it. */
	union {
		float f[6];
		uint32_t u[6];
	} k = {{o.x, o.y, o.z, ls->wi.x, ls->wi.y, ls->wi.z}};
	uint64_t a = ((uint64_t)k.u[0] << 32 | k.u[1]) ^ k.u[2];
	uint64_t b = ((uint64_t)k.u[3] << 32 | k.u[4]) ^ k.u[5];
	struct pm_rng rng = pm_rng_seed(0x7e7e, a, b);

	return pm_volume_tr(ctx, o, medium, ls, &rng);
}

struct pm_rgb
pm_volume_tr(const struct pm_render_ctx *ctx, struct pm_vec3 o,
    int medium, const struct pm_light_sample *ls, struct pm_rng *rng)
{
	const struct pm_scene *s = ctx->scene;
	struct pm_rgb tr = pm_rgb1(1.0f);
	struct pm_vec3 d = ls->wi, from = o;
	struct pm_hit h;
	float dist = INFINITY;
	int i;

	/* Medium lengths run between the true points (o, the surfaces
	 * crossed, the light), not from the offset origins the rays start
	 * at, so that each crossing loses no medium to its offset. */
	for (i = 0; i <= MAX_SHADOW_CROSSINGS; i++) {
		if (!isinf(ls->dist)) {
			/* Towards the light point itself, stopping short of
			 * its surface (as pm_light_occluded does). */
			d = pm_sub(ls->p, o);
			dist = pm_length(d);
			if (!(dist > 0.0f))
				return tr;
			d = pm_scale(d, 1.0f / dist);
			dist *= 1.0f - 1e-4f;
		}
		if (!pm_accel_intersect(ctx->accel, o, d, 0.0f, dist, &h)) {
			if (medium >= 0)
				tr = pm_rgb_mul(tr, segment_tr(s, medium, from,
				    d, isinf(ls->dist) ? INFINITY :
				    pm_length(pm_sub(ls->p, from)), rng));
			return tr;
		}
		if (s->bsdfs[s->shapes[h.shape].bsdf].type != PM_BSDF_NULL)
			return pm_rgb1(0.0f);
		if (medium >= 0)
			tr = pm_rgb_mul(tr, segment_tr(s, medium, from, d,
			    pm_length(pm_sub(h.p, from)), rng));
		if (pm_rgb_is_black(tr))
			return tr;
		medium = pm_medium_after(s, &h, d, medium);
		o = pm_hit_origin(&h, d);
		from = h.p;
	}
	return pm_rgb1(0.0f);
}

/* Light sampled from the scattering point p in medium m (index medium)
 * for a path that arrived along d, weighted for MIS against the phase
 * function. */
static struct pm_rgb
medium_direct(const struct pm_render_ctx *ctx, int medium, struct pm_vec3 p,
    struct pm_vec3 d, struct pm_rng *rng)
{
	const struct pm_medium *m = &ctx->scene->media[medium];
	struct pm_light_sample ls;
	struct pm_rgb tr;
	float u0 = pm_rng_float(rng), u1 = pm_rng_float(rng);
	float u2 = pm_rng_float(rng), ph, w;

	if (!pm_lights_sample(ctx->lights, ctx->scene, p, u0, u1, u2, &ls))
		return pm_rgb1(0.0f);
	ph = pm_phase_eval(&m->phase, d, ls.wi);
	if (!(ph > 0.0f))
		return pm_rgb1(0.0f);
	tr = pm_volume_tr(ctx, p, medium, &ls, rng);
	if (pm_rgb_is_black(tr))
		return tr;
	w = ls.delta ? 1.0f :
	    pm_power_heuristic(ls.pdf, pm_phase_pdf(&m->phase, d, ls.wi));
	return pm_rgb_scale(pm_rgb_mul(tr, ls.value), ph * w / ls.pdf);
}

enum pm_vol_event
pm_volume_step(const struct pm_render_ctx *ctx, struct pm_path *pa,
    int medium, float t_end, int depth, struct pm_rgb *L, struct pm_rng *rng)
{
	const struct pm_medium *m = &ctx->scene->media[medium];
	struct pm_medium_sample ms;
	struct pm_vec3 p, wo;
	struct pm_rgb r;
	float pdf, ph, mr;

	if (pa->hero < 0) {
		pa->hero = (int)(pm_rng_float(rng) * 3.0f);
		if (pa->hero > 2)
			pa->hero = 2;
	}
	pm_medium_sample_ray(m, pa->o, pa->d, pa->tmin, t_end, pa->hero, rng,
	    &ms);
	/*
	 * Spectral MIS over the whole path: with beta = f / p_hero / mean(r)
	 * and r_c = p_c / p_hero so far (mean 1), this flight multiplies f
	 * by ms.f and each p_c by ms.pdf[c]; r is scaled back to mean 1.
	 */
	ph = pa->hero == 0 ? ms.pdf.r : pa->hero == 1 ? ms.pdf.g : ms.pdf.b;
	if (!(ph > 0.0f))
		return PM_VOL_END;
	r = pm_rgb_mul(pa->chan_ratio, pm_rgb_scale(ms.pdf, 1.0f / ph));
	mr = pm_rgb_mean(r);
	if (!(mr > 0.0f && mr < INFINITY))	/* underflow after many flights */
		return PM_VOL_END;
	pa->chan_ratio = pm_rgb_scale(r, 1.0f / mr);
	pa->beta = pm_rgb_scale(pm_rgb_mul(pa->beta, ms.f), 1.0f / (ph * mr));
	if (pm_rgb_is_black(pa->beta))
		return PM_VOL_END;
	if (!ms.scattered)
		return PM_VOL_PASS;

	/* A vertex: the path so far has depth segments. */
	if (ctx->max_depth >= 0 && depth >= ctx->max_depth)
		return PM_VOL_END;
	p = pm_madd(pa->o, pa->d, pa->tmin + ms.t);
	if (m->sample_emitters)
		*L = pm_rgb_madd(*L, pa->beta, medium_direct(ctx, medium, p,
		    pa->d, rng));
	{
		float u1 = pm_rng_float(rng), u2 = pm_rng_float(rng);

		wo = pm_phase_sample(&m->phase, pa->d, u1, u2, &pdf);
	}
	if (!(pdf > 0.0f))
		return PM_VOL_END;
	/* The phase function is sampled exactly: its weight is 1. */
	pa->prev_p = p;
	pa->prev_pdf = pdf;
	/* Without light sampling here, emitters the phase sample finds
	 * count in full, as after a specular bounce. */
	pa->prev_delta = !m->sample_emitters;
	pa->o = p;
	pa->d = wo;
	pa->tmin = 0.0f;
	pa->tmax = INFINITY;
	if (depth >= ctx->rr_depth) {
		float q = pm_fminf(pm_rgb_max(pa->beta) * pa->eta_scale, 0.95f);

		if (!(pm_rng_float(rng) < q))
			return PM_VOL_END;
		pa->beta = pm_rgb_scale(pa->beta, 1.0f / q);
	}
	return PM_VOL_SCATTER;
}
