/*
 * integrator_path.c: the reference integrator.  A unidirectional path
 * tracer with next-event estimation and multiple importance sampling
 * (power heuristic, Veach 1997), Russian roulette after rr_depth, and
 * Mitsuba 3's meaning of max_depth: the longest path, counted in segments
 * from the camera, that may carry light (1: emitters seen directly only).
 *
 * In a scene with participating media it is Mitsuba's volpath: the parts
 * marked "media" hand the ray's segment to integrator_volume.c, which may
 * scatter it, and null-BSDF boundaries only change the ray's medium (they
 * are no bounce, and shadow rays pass through them), as volpath has it.
 *
 * Every photon-map result is checked against this, so it favours being
 * obviously right over being fast.
 */
#include <math.h>

#include "integrator.h"
#include "frame.h"
#include "texture.h"

/*
 * A plain diffuse BSDF (pm_bsdf_plain_diffuse), the commonest at a
 * path's vertices, goes to bsdf.h's inline diffuse lobe without the calls
 * and the dispatch (the same bits as through bsdf.c); every other BSDF
 * goes through bsdf.c.  Diffuse reflection transmits nothing, so
 * twosided's flip needs only wi below the surface.
 */
static inline struct pm_rgb
bsdf_eval(const struct pm_bsdf *b, struct pm_vec3 wi, struct pm_vec3 wo)
{
	if (!pm_bsdf_plain_diffuse(b))
		return pm_bsdf_eval(b, wi, wo, PM_RADIANCE);
	if (b->twosided && wi.z < 0.0f) {
		wi.z = -wi.z;
		wo.z = -wo.z;
	}
	return pm_diffuse_eval(b->diffuse, wi, wo);
}

static inline float
bsdf_pdf(const struct pm_bsdf *b, struct pm_vec3 wi, struct pm_vec3 wo)
{
	if (!pm_bsdf_plain_diffuse(b))
		return pm_bsdf_pdf(b, wi, wo);
	if (b->twosided && wi.z < 0.0f) {
		wi.z = -wi.z;
		wo.z = -wo.z;
	}
	return pm_diffuse_pdf(wi, wo);
}

/* pm_bsdf_sample_v for radiance. */
static inline bool
bsdf_sample_v(const struct pm_bsdf *b, struct pm_vec3 wi, float u1, float u2,
    float u3, const struct pm_vec3 *v, struct pm_bsdf_sample *bs)
{
	return pm_bsdf_sample_v(b, wi, u1, u2, u3, PM_RADIANCE, v, bs);
}

static inline bool
bsdf_sample(const struct pm_bsdf *b, struct pm_vec3 wi, float u1, float u2,
    float u3, struct pm_bsdf_sample *bs)
{
	return bsdf_sample_v(b, wi, u1, u2, u3, NULL, bs);
}

/* The BSDF's value f for light sample ls (false when f is black, and
 * then nothing arrives). */
static inline bool
light_eval(const struct pm_bsdf *b, struct pm_frame fr, struct pm_vec3 wi_local,
    const struct pm_light_sample *ls, struct pm_vec3 *wo_local,
    struct pm_rgb *f)
{
	*wo_local = pm_to_local(fr, ls->wi);
	*f = bsdf_eval(b, wi_local, *wo_local);
	return !pm_rgb_is_black(*f);
}

/* A light sample for direct_light, and the BSDF's value f for it (false
 * when there is none or f is black). */
static bool
light_sample(const struct pm_render_ctx *ctx, const struct pm_bsdf *b,
    const struct pm_hit *h, struct pm_frame fr, struct pm_vec3 wi_local,
    struct pm_rng *rng, struct pm_light_sample *ls, struct pm_vec3 *wo_local,
    struct pm_rgb *f)
{
	float u0 = pm_rng_float(rng), u1 = pm_rng_float(rng);
	float u2 = pm_rng_float(rng);

	return pm_lights_sample(ctx->lights, ctx->scene, h->p, u0, u1, u2,
	    ls) && light_eval(b, fr, wi_local, ls, wo_local, f);
}

/* What the light sample ls brings through f if nothing blocks it,
 * weighted for MIS. */
static struct pm_rgb
light_weighted(const struct pm_bsdf *b, struct pm_vec3 wi_local,
    struct pm_vec3 wo_local, const struct pm_light_sample *ls, struct pm_rgb f)
{
	float w = ls->delta ? 1.0f :
	    pm_power_heuristic(ls->pdf, bsdf_pdf(b, wi_local, wo_local));

	return pm_rgb_scale(pm_rgb_mul(f, ls->value), w / ls->pdf);
}

/* Light arriving at the hit point from one light sample, weighted for MIS. */
static struct pm_rgb
direct_light(const struct pm_render_ctx *ctx, const struct pm_bsdf *b,
    const struct pm_hit *h, struct pm_frame fr, struct pm_vec3 wi_local,
    int medium, struct pm_rng *rng)
{
	struct pm_light_sample ls;
	struct pm_vec3 wo_local;
	struct pm_rgb f;

	if (!light_sample(ctx, b, h, fr, wi_local, rng, &ls, &wo_local, &f))
		return pm_rgb1(0.0f);
	if (ctx->scene->nmedia > 0) {
		/* media: the shadow ray's transmittance */
		f = pm_rgb_mul(f, pm_volume_tr(ctx, pm_hit_origin(h, ls.wi),
		    pm_medium_after(ctx->scene, h, ls.wi, medium), &ls, rng));
		if (pm_rgb_is_black(f))
			return f;
	} else if (pm_light_occluded(ctx->accel, h, &ls)) {
		return pm_rgb1(0.0f);
	}
	return light_weighted(b, wi_local, wo_local, &ls, f);
}

struct pm_rgb
pm_path_li(const struct pm_render_ctx *ctx, struct pm_vec3 o, struct pm_vec3 d,
    float tmin, float tmax, struct pm_rng *rng)
{
	const struct pm_scene *s = ctx->scene;
	struct pm_rgb L = pm_rgb1(0.0f);
	struct pm_path pa;
	int depth;
	int medium = s->camera_medium - 1;	/* media: the ray's, -1: none */
	int crossings = 0;

	pm_path_start(&pa, o, d, tmin, tmax);
	for (depth = 1;; depth++) {
		struct pm_hit h;
		bool hit;
		const struct pm_bsdf *b;
		struct pm_bsdf bt;	/* b with its textures looked up */
		struct pm_bsdf_sample bs;
		struct pm_frame fr;
		struct pm_vec3 wi_local;

		hit = pm_accel_intersect(ctx->accel, pa.o, pa.d, pa.tmin, pa.tmax, &h);
		if (medium >= 0) {
			/* media: a scatter before the surface is this vertex */
			enum pm_vol_event ev = pm_volume_step(ctx, &pa, medium,
			    hit ? h.t : pa.tmax, depth, &L, rng);

			if (ev == PM_VOL_SCATTER)
				continue;
			if (ev == PM_VOL_END)
				break;
		}
		if (!(depth == 1 && ctx->hide_emitters))
			L = pm_rgb_madd(L, pa.beta, pm_lights_emitted(ctx->lights, s,
			    hit ? &h : NULL, pa.d, pa.prev_p, pa.prev_pdf, pa.prev_delta));
		if (!hit)
			break;
		if (s->nmedia > 0 &&
		    s->bsdfs[s->shapes[h.shape].bsdf].type == PM_BSDF_NULL) {
			/* media: an index-matched boundary, no vertex; the
			 * bound guards against a ray stuck on one */
			if (++crossings > 1024)
				break;
			medium = pm_medium_after(s, &h, pa.d, medium);
			pa.o = pm_hit_origin(&h, pa.d);
			pa.tmin = 0.0f;
			pa.tmax = INFINITY;
			depth--;
			continue;
		}
		if (ctx->max_depth >= 0 && depth >= ctx->max_depth)
			break;

		b = pm_bsdf_frame_at(s, &h, pa.d, &bt, &fr);
		wi_local = pm_to_local(fr, pm_neg(pa.d));
		if (!pm_bsdf_is_delta(b))
			L = pm_rgb_madd(L, pa.beta,
			    direct_light(ctx, b, &h, fr, wi_local, medium, rng));

		{
			float u1 = pm_rng_float(rng), u2 = pm_rng_float(rng);
			float u3 = pm_rng_float(rng);

			if (!bsdf_sample(b, wi_local, u1, u2, u3, &bs))
				break;
		}
		if (!pm_path_continue(&pa, &h, fr, &bs, depth, ctx->rr_depth, rng))
			break;
		medium = pm_medium_after(s, &h, pa.d, medium);	/* media */
	}
	return L;
}

/* pm_lights_emitted, with its commonest answer in line: a hit on a
 * shape that is no light (or a miss with no environment) emits nothing. */
static inline struct pm_rgb
emitted(const struct pm_render_ctx *ctx, const struct pm_hit *h,
    const struct pm_path *pa)
{
	const struct pm_scene *s = ctx->scene;

	if (h != NULL ? s->shapes[h->shape].light < 0 : s->env_light < 0)
		return pm_rgb1(0.0f);
	return pm_lights_emitted(ctx->lights, s, h, pa->d, pa->prev_p,
	    pa->prev_pdf, pa->prev_delta);
}

/* pm_path_continue, in line for path_li_batch (the frame by pointer,
 * not copied through the stack for each call) */
static inline bool
path_continue(struct pm_path *pa, const struct pm_hit *h,
    const struct pm_frame *fr, const struct pm_bsdf_sample *bs, int depth,
    int rr_depth, struct pm_rng *rng)
{
	pa->beta = pm_rgb_mul(pa->beta, bs->weight);
	if (pm_rgb_is_black(pa->beta))
		return false;
	pa->eta_scale *= bs->eta * bs->eta;
	pa->prev_p = h->p;
	pa->prev_pdf = bs->pdf;
	pa->prev_delta = (bs->lobe & PM_LOBE_DELTA) != 0;
	/* A BSDF's sample is a unit vector to rounding, and the frame is
	 * orthonormal: only a direction that is not is normalised (the
	 * square root and the division, at the end of each bounce's chain
	 * of latencies, were half of this function's time) */
	pa->d = pm_to_world(*fr, bs->wo);
	if (!(fabsf(pm_dot(pa->d, pa->d) - 1.0f) <= 1e-6f))
		pa->d = pm_normalize(pa->d);
	pa->o = pm_hit_origin(h, pa->d);
	pa->tmin = 0.0f;
	pa->tmax = INFINITY;
	if (depth >= rr_depth) {
		float q = pm_fminf(pm_rgb_max(pa->beta) * pa->eta_scale, 0.95f);

		if (!(pm_rng_float(rng) < q))
			return false;
		pa->beta = pm_rgb_scale(pa->beta, 1.0f / q);
	}
	return true;
}

/*
 * pm_path_li for many camera rays at once, without media: the paths
 * advance together one bounce per round, and each round's closest-hit
 * rays, then its shadow rays, go to the accelerator as one batch (Embree
 * packets).  Every path does exactly what pm_path_li does, in the same
 * order and with the same random numbers; a light sample's contribution
 * only waits for its shadow ray until the end of the round, before
 * anything else changes the path's L.
 */
#define PATH_BATCH 64

struct path_lane {
	struct pm_path pa;
	struct pm_rgb L;
	struct pm_rgb dl, dl_beta;	/* a light sample waiting for its ray */
	int depth;
	bool alive;
};

/* A round's vertex between drawing its numbers and shading. */
struct vertex {
	const struct pm_bsdf *b;
	struct pm_frame fr;
	struct pm_vec3 wi;		/* local */
	float u1;			/* the BSDF's first number */
	size_t k;			/* its path in the round */
	int light;			/* its light sample's index, or -1 */
};

static void
path_li_batch(const struct pm_render_ctx *ctx, struct pm_path_sample *smp,
    size_t n)
{
	const struct pm_scene *s = ctx->scene;
	struct path_lane l[PATH_BATCH];
	struct pm_ray rays[PATH_BATCH], srays[PATH_BATCH];
	struct pm_hit hits[PATH_BATCH];
	struct vertex vx[PATH_BATCH];
	struct pm_bsdf bt[PATH_BATCH];	/* textured BSDFs looked up */
	float u2[PATH_BATCH], u3[PATH_BATCH];
	float wx[PATH_BATCH], wy[PATH_BATCH], wz[PATH_BATCH];
	struct pm_vec3 lref[PATH_BATCH];
	float lu[PATH_BATCH][3];
	struct pm_light_sample lsmp[PATH_BATCH];
	bool lok[PATH_BATCH];
	bool hitf[PATH_BATCH], occ[PATH_BATCH];
	uint8_t idx[PATH_BATCH], sidx[PATH_BATCH];
	size_t i, j, k, m, nl, na = n, ns;

	for (i = 0; i < n; i++) {
		pm_path_start(&l[i].pa, smp[i].o, smp[i].d, smp[i].tmin,
		    smp[i].tmax);
		l[i].L = pm_rgb1(0.0f);
		l[i].depth = 1;
		l[i].alive = true;
		idx[i] = (uint8_t)i;
	}
	for (;;) {
		/* the paths still alive, in idx[0..na) */
		for (k = i = 0; k < na; k++) {
			struct path_lane *q = &l[idx[k]];

			if (!q->alive)
				continue;
			idx[i] = idx[k];
			rays[i].o = q->pa.o;
			rays[i].d = q->pa.d;
			rays[i].tmin = q->pa.tmin;
			rays[i].tmax = q->pa.tmax;
			i++;
		}
		na = i;
		if (na == 0)
			break;
		pm_accel_intersect_n(ctx->accel, rays, na, hits, hitf);
		/* The vertices' random numbers drawn first, in each path's
		 * order (the light sample's three, then the BSDF's), so that
		 * the round's light samples and BSDF directions are taken
		 * together in SIMD lanes (pm_lights_sample_n,
		 * pm_square_to_cosine_hemisphere_n); then each vertex shades
		 * as before. */
		for (k = m = nl = 0; k < na; k++) {
			struct path_lane *q = &l[idx[k]];
			struct pm_rng *rng = &smp[idx[k]].rng;
			const struct pm_hit *h = &hits[k];
			struct vertex *v = &vx[m];

			if (!(q->depth == 1 && ctx->hide_emitters))
				q->L = pm_rgb_madd(q->L, q->pa.beta,
				    emitted(ctx, hitf[k] ? h : NULL, &q->pa));
			if (!hitf[k] ||
			    (ctx->max_depth >= 0 && q->depth >= ctx->max_depth)) {
				q->alive = false;
				continue;
			}
			/* bt[m] holds a textured BSDF through the round */
			v->b = pm_bsdf_frame_at(s, h, q->pa.d, &bt[m], &v->fr);
			v->wi = pm_to_local(v->fr, pm_neg(q->pa.d));
			v->light = -1;
			if (!pm_bsdf_is_delta(v->b)) {
				lu[nl][0] = pm_rng_float(rng);
				lu[nl][1] = pm_rng_float(rng);
				lu[nl][2] = pm_rng_float(rng);
				lref[nl] = h->p;
				v->light = (int)nl++;
			}
			v->u1 = pm_rng_float(rng);
			u2[m] = pm_rng_float(rng);
			u3[m] = pm_rng_float(rng);
			v->k = k;
			m++;
		}
		pm_lights_sample_n(ctx->lights, s, lref, (const float (*)[3])lu,
		    nl, lsmp, lok);
		pm_square_to_cosine_hemisphere_n(u2, u3, wx, wy, wz, m);
		for (j = ns = 0; j < m; j++) {
			const struct vertex *v = &vx[j];
			struct path_lane *q = &l[idx[v->k]];
			struct pm_rng *rng = &smp[idx[v->k]].rng;
			const struct pm_hit *h = &hits[v->k];
			struct pm_vec3 wv = pm_v3(wx[j], wy[j], wz[j]);
			struct pm_bsdf_sample bs;

			if (v->light >= 0) {
				const struct pm_light_sample *ls =
				    &lsmp[v->light];
				struct pm_vec3 wo_local;
				struct pm_rgb f, c = pm_rgb1(0.0f);
				bool pending = false;

				if (lok[v->light] && light_eval(v->b, v->fr,
				    v->wi, ls, &wo_local, &f)) {
					c = light_weighted(v->b, v->wi, wo_local,
					    ls, f);
					pending = pm_light_shadow_ray(h, ls,
					    &srays[ns]);
				}
				if (pending) {
					q->dl = c;
					q->dl_beta = q->pa.beta;
					sidx[ns++] = idx[v->k];
				} else {
					q->L = pm_rgb_madd(q->L, q->pa.beta, c);
				}
			}
			if (!bsdf_sample_v(v->b, v->wi, v->u1, u2[j], u3[j], &wv,
			    &bs) ||
			    !path_continue(&q->pa, h, &v->fr, &bs, q->depth,
			    ctx->rr_depth, rng)) {
				q->alive = false;
				continue;
			}
			q->depth++;
		}
		pm_accel_occluded_n(ctx->accel, srays, ns, occ);
		for (k = 0; k < ns; k++) {
			struct path_lane *q = &l[sidx[k]];

			q->L = pm_rgb_madd(q->L, q->dl_beta,
			    occ[k] ? pm_rgb1(0.0f) : q->dl);
		}
	}
	for (i = 0; i < n; i++)
		smp[i].L = l[i].L;
}

void
pm_path_li_batch(const struct pm_render_ctx *ctx, struct pm_path_sample *smp,
    size_t n)
{
	size_t i, m;

	if (ctx->scene->nmedia > 0) {
		/* media: one path at a time, as volpath */
		for (i = 0; i < n; i++)
			smp[i].L = pm_path_li(ctx, smp[i].o, smp[i].d,
			    smp[i].tmin, smp[i].tmax, &smp[i].rng);
		return;
	}
	for (i = 0; i < n; i += m) {
		m = n - i < PATH_BATCH ? n - i : PATH_BATCH;
		path_li_batch(ctx, smp + i, m);
	}
}

void
pm_path_start(struct pm_path *pa, struct pm_vec3 o, struct pm_vec3 d, float tmin,
    float tmax)
{
	pa->o = o;
	pa->d = d;
	pa->tmin = tmin;
	pa->tmax = tmax;
	pa->beta = pm_rgb1(1.0f);
	pa->eta_scale = 1.0f;
	pa->prev_p = o;
	pa->prev_pdf = 1.0f;
	pa->prev_delta = true;	/* the camera "sampled" the first direction */
	pa->hero = -1;
	pa->chan_ratio = pm_rgb1(1.0f);
}

bool
pm_path_continue(struct pm_path *pa, const struct pm_hit *h, struct pm_frame fr,
    const struct pm_bsdf_sample *bs, int depth, int rr_depth, struct pm_rng *rng)
{
	return path_continue(pa, h, &fr, bs, depth, rr_depth, rng);
}
