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
#include <string.h>

#include "integrator.h"
#include "frame.h"
#include "texture.h"
#include "lanes.h"

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
static inline struct pm_rgb
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
 * order and with the same random numbers, to the bit; a light sample's
 * contribution only waits for its shadow ray until the end of the round,
 * before anything else changes the path's L.
 */
#define PATH_BATCH 256
_Static_assert(PATH_BATCH % 4 == 0 && PATH_BATCH <= PM_LIGHT_LANES &&
    PATH_BATCH <= 256, "a round's vertices fill whole groups of four "
    "light lanes, and a byte indexes a path");

struct path_lane {
	struct pm_path pa;
	struct pm_rgb L;
	struct pm_rgb dl, dl_beta;	/* a light sample waiting for its ray */
	int depth;
	bool alive;
};

/* A round's vertex between drawing its numbers and shading (its frame
 * and wi are in the round's arrays, struct round_soa). */
struct vertex {
	const struct pm_bsdf *b;
	float u1;			/* the BSDF's first number */
	size_t k;			/* its path in the round */
	int light;			/* its light sample's index, or -1 */
};

/*
 * A round's vertices field by field (structure of arrays), vertex j at
 * [j]: the ray's direction, the shading frame (found by frame_lanes
 * unless tan is -1: a frame that follows the surface, pm_bsdf_frame_at's
 * other case) and wi in it, the geometric normal and scale (the hit point
 * is the light lanes' ref), the path's throughput and eta_scale, and
 * whether its BSDF is plain diffuse (dm, -1 or 0), with its albedo and
 * twosided mask.
 */
struct round_soa {
	float dir[3][PATH_BATCH];
	int32_t tan[PATH_BATCH];
	float fs[3][PATH_BATCH], ft[3][PATH_BATCH], fn[3][PATH_BATCH];
	float wix[PATH_BATCH], wiy[PATH_BATCH], wiz[PATH_BATCH];
	float ng[3][PATH_BATCH], scale[PATH_BATCH];
	float beta[3][PATH_BATCH], eta[PATH_BATCH];
	float alb[3][PATH_BATCH];
	int32_t tw[PATH_BATCH], dm[PATH_BATCH];
};

/*
 * diffuse_lanes: loop 2 of path_li_batch (below) for the round's plain
 * diffuse vertices, four at a time in SSE lanes: the light sample's
 * value, MIS weight and shadow ray, the BSDF's sample and the path's next
 * ray.  Each lane does the scalar code's operations in its order, its
 * branches as selects (IEEE division and square root are exact in SIMD as
 * in scalar code, and -ffp-contract=off fuses nothing), so every path
 * gets the bits it got one vertex at a time; what each lane then writes
 * (its light's contribution or shadow ray, its next ray, Russian
 * roulette's number from its own stream) is done in lane order, scalar.
 * Its inputs are the round's arrays, read four vertices to a load; in a
 * path-traced Cornell box this loop, one vertex at a time, was a fifth of
 * the time.  Marks done[j] for each vertex it shaded, in groups of four
 * from 0 to m; the rest go through the scalar loop.
 */
#if PM_LANES
/*
 * frame_lanes: pm_frame_from_normal at the round's vertices 0..m (m a
 * multiple of 4), four at a time, except where tan keeps the frame loop
 * 1 found, and wi = pm_to_local(frame, -d) at every one; its operations
 * in pm_frame_from_normal's and pm_to_local's order, so the same bits.
 */
static void
frame_lanes(struct round_soa *r, size_t m)
{
	const __m128 sign = _mm_set1_ps(-0.0f);
	size_t j;

	for (j = 0; j < m; j += 4) {
		__m128 nx = _mm_loadu_ps(r->fn[0] + j);
		__m128 ny = _mm_loadu_ps(r->fn[1] + j);
		__m128 nz = _mm_loadu_ps(r->fn[2] + j);
		__m128 s[3], t[3], v[3], tan = pm_mask4(r->tan + j);
		int c;

		pm_frame4(nx, ny, nz, s, t);
		for (c = 0; c < 3; c++) {
			if (_mm_movemask_ps(tan) != 0) {
				s[c] = pm_sel4(tan, _mm_loadu_ps(r->fs[c] + j), s[c]);
				t[c] = pm_sel4(tan, _mm_loadu_ps(r->ft[c] + j), t[c]);
			}
			_mm_storeu_ps(r->fs[c] + j, s[c]);
			_mm_storeu_ps(r->ft[c] + j, t[c]);
			v[c] = _mm_xor_ps(_mm_loadu_ps(r->dir[c] + j), sign);
		}
		_mm_storeu_ps(r->wix + j, pm_dot4(v[0], v[1], v[2], s[0], s[1],
		    s[2]));
		_mm_storeu_ps(r->wiy + j, pm_dot4(v[0], v[1], v[2], t[0], t[1],
		    t[2]));
		_mm_storeu_ps(r->wiz + j, pm_dot4(v[0], v[1], v[2], nx, ny, nz));
	}
}

static void
diffuse_lanes(const struct pm_render_ctx *ctx, size_t m,
    const struct round_soa *r, const struct pm_light_lanes *ll,
    const struct vertex *vx, struct path_lane *l, const uint8_t *idx,
    struct pm_path_sample *smp, const float *wx, const float *wy,
    const float *wz, struct pm_ray *srays, uint8_t *sidx, size_t *pns,
    bool *done)
{
	const __m128 zero = _mm_setzero_ps(), one = _mm_set1_ps(1.0f);
	const __m128 sign = _mm_set1_ps(-0.0f), inv_pi = _mm_set1_ps(PM_INV_PI);
	const __m128 inf = _mm_set1_ps(INFINITY);
	size_t j, c, ns = *pns;

	for (j = 0; j + 4 <= m; j += 4) {
		float cr[4], cg[4], cb[4], sox[4], soy[4], soz[4], sdx[4];
		float sdy[4], sdz[4], stm[4], br[4], bg[4], bb[4], pdfv[4];
		float ndx[4], ndy[4], ndz[4], nox[4], noy[4], noz[4];
		float qv[4], iq[4];
		int dm, lm, pend, alive;
		__m128 wiz, flip, lwx, lwy, lwz, woz, val, sc, fr_, fg, fb;
		__m128 a2, b2, ph, w, wl, p[3], g[3], lw[3], o[3], pdfl;
		__m128 eps, ox, oy, oz, dx, dy, dz, d2, isinf_;
		__m128 ar, ag, ab, vz, pdf, nbr, nbg, nbb, dd, nl, nrm;
		__m128 qq, nx, ny, nz, wox, woy, woz2;

		dm = _mm_movemask_ps(pm_mask4(r->dm + j));
		if (dm == 0)
			continue;
		wiz = _mm_loadu_ps(r->wiz + j);
		flip = _mm_and_ps(pm_mask4(r->tw + j), _mm_cmplt_ps(wiz, zero));
		wiz = _mm_xor_ps(wiz, _mm_and_ps(flip, sign));
		nx = _mm_loadu_ps(r->fn[0] + j);
		ny = _mm_loadu_ps(r->fn[1] + j);
		nz = _mm_loadu_ps(r->fn[2] + j);
		/* light_eval: the light's direction's z in the frame, and
		 * pm_diffuse_eval and pm_diffuse_pdf, zero unless both are
		 * above the surface */
		lwx = _mm_loadu_ps(ll->wi[0] + j);
		lwy = _mm_loadu_ps(ll->wi[1] + j);
		lwz = _mm_loadu_ps(ll->wi[2] + j);
		woz = pm_dot4(lwx, lwy, lwz, nx, ny, nz);
		woz = _mm_xor_ps(woz, _mm_and_ps(flip, sign));
		val = _mm_andnot_ps(_mm_or_ps(_mm_cmple_ps(wiz, zero),
		    _mm_cmple_ps(woz, zero)), _mm_cmpeq_ps(zero, zero));
		ar = _mm_loadu_ps(r->alb[0] + j);
		ag = _mm_loadu_ps(r->alb[1] + j);
		ab = _mm_loadu_ps(r->alb[2] + j);
		sc = _mm_mul_ps(woz, inv_pi);
		fr_ = _mm_and_ps(val, _mm_mul_ps(ar, sc));
		fg = _mm_and_ps(val, _mm_mul_ps(ag, sc));
		fb = _mm_and_ps(val, _mm_mul_ps(ab, sc));
		lm = _mm_movemask_ps(_mm_andnot_ps(_mm_and_ps(_mm_and_ps(
		    _mm_cmpeq_ps(fr_, zero), _mm_cmpeq_ps(fg, zero)),
		    _mm_cmpeq_ps(fb, zero)), pm_mask4(ll->ok + j)));
		/* light_weighted: the power heuristic against the BSDF's pdf */
		pdfl = _mm_loadu_ps(ll->pdf + j);
		a2 = _mm_mul_ps(pdfl, pdfl);
		b2 = _mm_and_ps(val, sc);
		b2 = _mm_mul_ps(b2, b2);
		ph = _mm_add_ps(a2, b2);
		ph = _mm_and_ps(_mm_cmpgt_ps(ph, zero), _mm_div_ps(a2, ph));
		ph = pm_sel4(_mm_cmpeq_ps(a2, inf), one, ph);
		w = pm_sel4(pm_mask4(ll->delta + j), one, ph);
		wl = _mm_div_ps(w, pdfl);
		_mm_storeu_ps(cr, _mm_mul_ps(_mm_mul_ps(fr_,
		    _mm_loadu_ps(ll->value[0] + j)), wl));
		_mm_storeu_ps(cg, _mm_mul_ps(_mm_mul_ps(fg,
		    _mm_loadu_ps(ll->value[1] + j)), wl));
		_mm_storeu_ps(cb, _mm_mul_ps(_mm_mul_ps(fb,
		    _mm_loadu_ps(ll->value[2] + j)), wl));
		/* pm_light_shadow_ray: pm_hit_origin towards the light */
		for (c = 0; c < 3; c++) {
			p[c] = _mm_loadu_ps(ll->ref[c] + j);
			g[c] = _mm_loadu_ps(r->ng[c] + j);
		}
		lw[0] = lwx;
		lw[1] = lwy;
		lw[2] = lwz;
		eps = pm_offset_eps4(p, _mm_loadu_ps(r->scale + j));
		pm_offset4(p, g, eps, lw, o);
		ox = o[0];
		oy = o[1];
		oz = o[2];
		isinf_ = _mm_cmpeq_ps(_mm_andnot_ps(sign,
		    _mm_loadu_ps(ll->dist + j)), inf);
		dx = _mm_sub_ps(_mm_loadu_ps(ll->p[0] + j), ox);
		dy = _mm_sub_ps(_mm_loadu_ps(ll->p[1] + j), oy);
		dz = _mm_sub_ps(_mm_loadu_ps(ll->p[2] + j), oz);
		d2 = pm_dot4(dx, dy, dz, dx, dy, dz);
		pend = lm & _mm_movemask_ps(_mm_or_ps(isinf_,
		    _mm_cmpgt_ps(d2, zero)));
		_mm_storeu_ps(sox, ox);
		_mm_storeu_ps(soy, oy);
		_mm_storeu_ps(soz, oz);
		_mm_storeu_ps(sdx, pm_sel4(isinf_, lwx, dx));
		_mm_storeu_ps(sdy, pm_sel4(isinf_, lwy, dy));
		_mm_storeu_ps(sdz, pm_sel4(isinf_, lwz, dz));
		_mm_storeu_ps(stm, pm_sel4(isinf_, inf, _mm_set1_ps(1.0f - 1e-4f)));
		/* the BSDF's sample (pm_diffuse_sample_warped) */
		vz = _mm_loadu_ps(wz + j);
		pdf = _mm_and_ps(_mm_cmpgt_ps(vz, zero), _mm_mul_ps(vz, inv_pi));
		alive = _mm_movemask_ps(_mm_andnot_ps(_mm_cmple_ps(wiz, zero),
		    _mm_cmpgt_ps(pdf, zero)));
		_mm_storeu_ps(pdfv, pdf);
		wox = _mm_loadu_ps(wx + j);
		woy = _mm_loadu_ps(wy + j);
		woz2 = _mm_xor_ps(vz, _mm_and_ps(flip, sign));
		/* path_continue */
		nbr = _mm_mul_ps(_mm_loadu_ps(r->beta[0] + j), ar);
		nbg = _mm_mul_ps(_mm_loadu_ps(r->beta[1] + j), ag);
		nbb = _mm_mul_ps(_mm_loadu_ps(r->beta[2] + j), ab);
		alive &= ~_mm_movemask_ps(_mm_and_ps(_mm_and_ps(
		    _mm_cmpeq_ps(nbr, zero), _mm_cmpeq_ps(nbg, zero)),
		    _mm_cmpeq_ps(nbb, zero)));
		_mm_storeu_ps(br, nbr);
		_mm_storeu_ps(bg, nbg);
		_mm_storeu_ps(bb, nbb);
		dx = _mm_add_ps(_mm_add_ps(
		    _mm_mul_ps(_mm_loadu_ps(r->fs[0] + j), wox),
		    _mm_mul_ps(_mm_loadu_ps(r->ft[0] + j), woy)),
		    _mm_mul_ps(nx, woz2));
		dy = _mm_add_ps(_mm_add_ps(
		    _mm_mul_ps(_mm_loadu_ps(r->fs[1] + j), wox),
		    _mm_mul_ps(_mm_loadu_ps(r->ft[1] + j), woy)),
		    _mm_mul_ps(ny, woz2));
		dz = _mm_add_ps(_mm_add_ps(
		    _mm_mul_ps(_mm_loadu_ps(r->fs[2] + j), wox),
		    _mm_mul_ps(_mm_loadu_ps(r->ft[2] + j), woy)),
		    _mm_mul_ps(nz, woz2));
		dd = pm_dot4(dx, dy, dz, dx, dy, dz);
		/* normalised only where not unit to rounding (pm_normalize:
		 * a zero vector, or NaN, stays as it is) */
		nrm = _mm_cmple_ps(_mm_andnot_ps(sign, _mm_sub_ps(dd, one)),
		    _mm_set1_ps(1e-6f));
		nl = _mm_sqrt_ps(dd);
		nrm = _mm_or_ps(nrm, _mm_cmpngt_ps(nl, zero));
		nl = _mm_div_ps(one, nl);
		dx = pm_sel4(nrm, dx, _mm_mul_ps(dx, nl));
		dy = pm_sel4(nrm, dy, _mm_mul_ps(dy, nl));
		dz = pm_sel4(nrm, dz, _mm_mul_ps(dz, nl));
		_mm_storeu_ps(ndx, dx);
		_mm_storeu_ps(ndy, dy);
		_mm_storeu_ps(ndz, dz);
		lw[0] = dx;
		lw[1] = dy;
		lw[2] = dz;
		pm_offset4(p, g, eps, lw, o);
		_mm_storeu_ps(nox, o[0]);
		_mm_storeu_ps(noy, o[1]);
		_mm_storeu_ps(noz, o[2]);
		/* Russian roulette's probability and its reciprocal */
		qq = pm_min4(_mm_mul_ps(pm_max4(nbr, pm_max4(nbg, nbb)),
		    _mm_loadu_ps(r->eta + j)), _mm_set1_ps(0.95f));
		_mm_storeu_ps(qv, qq);
		_mm_storeu_ps(iq, _mm_div_ps(one, qq));
		for (c = 0; c < 4; c++) {
			const struct vertex *v;
			struct path_lane *q;
			struct pm_rgb cc = pm_rgb(cr[c], cg[c], cb[c]);

			/* (a padding lane has no vertex: nothing of it read) */
			if (!(dm >> c & 1))
				continue;
			v = &vx[j + c];
			q = &l[idx[v->k]];
			done[j + c] = true;
			if (!(lm >> c & 1))
				cc = pm_rgb1(0.0f);
			if (pend >> c & 1) {
				q->dl = cc;
				q->dl_beta = q->pa.beta;
				srays[ns].o = pm_v3(sox[c], soy[c], soz[c]);
				srays[ns].d = pm_v3(sdx[c], sdy[c], sdz[c]);
				srays[ns].tmin = 0.0f;
				srays[ns].tmax = stm[c];
				sidx[ns++] = idx[v->k];
			} else {
				q->L = pm_rgb_madd(q->L, q->pa.beta, cc);
			}
			if (!(alive >> c & 1)) {
				q->alive = false;
				continue;
			}
			q->pa.beta = pm_rgb(br[c], bg[c], bb[c]);
			q->pa.prev_p = pm_v3(ll->ref[0][j + c], ll->ref[1][j + c],
			    ll->ref[2][j + c]);
			q->pa.prev_pdf = pdfv[c];
			q->pa.prev_delta = false;
			q->pa.d = pm_v3(ndx[c], ndy[c], ndz[c]);
			q->pa.o = pm_v3(nox[c], noy[c], noz[c]);
			q->pa.tmin = 0.0f;
			q->pa.tmax = INFINITY;
			if (q->depth >= ctx->rr_depth) {
				if (!(pm_rng_float(&smp[idx[v->k]].rng) < qv[c])) {
					q->alive = false;
					continue;
				}
				q->pa.beta = pm_rgb_scale(q->pa.beta, iq[c]);
			}
			q->depth++;
		}
	}
	*pns = ns;
}
#else
static void
frame_lanes(struct round_soa *r, size_t m)
{
	size_t j;
	int c;

	for (j = 0; j < m; j++) {
		struct pm_frame fr;
		struct pm_vec3 d = pm_v3(r->dir[0][j], r->dir[1][j],
		    r->dir[2][j]), wi;

		if (r->tan[j]) {
			fr.s = pm_v3(r->fs[0][j], r->fs[1][j], r->fs[2][j]);
			fr.t = pm_v3(r->ft[0][j], r->ft[1][j], r->ft[2][j]);
			fr.n = pm_v3(r->fn[0][j], r->fn[1][j], r->fn[2][j]);
		} else {
			fr = pm_frame_from_normal(pm_v3(r->fn[0][j],
			    r->fn[1][j], r->fn[2][j]));
		}
		wi = pm_to_local(fr, pm_neg(d));
		for (c = 0; c < 3; c++) {
			r->fs[c][j] = (&fr.s.x)[c];
			r->ft[c][j] = (&fr.t.x)[c];
		}
		r->wix[j] = wi.x;
		r->wiy[j] = wi.y;
		r->wiz[j] = wi.z;
	}
}

static void
diffuse_lanes(const struct pm_render_ctx *ctx, size_t m,
    const struct round_soa *r, const struct pm_light_lanes *ll,
    const struct vertex *vx, struct path_lane *l, const uint8_t *idx,
    struct pm_path_sample *smp, const float *wx, const float *wy,
    const float *wz, struct pm_ray *srays, uint8_t *sidx, size_t *pns,
    bool *done)
{
	(void)ctx, (void)m, (void)r, (void)ll, (void)vx, (void)l, (void)idx;
	(void)smp, (void)wx, (void)wy, (void)wz, (void)srays, (void)sidx;
	(void)pns, (void)done;
}
#endif

/* A batch's working memory, on the heap (pm_path_li_batch): with
 * PATH_BATCH paths it is about 220 KB, more than a stack a caller made
 * small can hold. */
struct batch_mem {
	struct path_lane l[PATH_BATCH];
	struct pm_ray rays[PATH_BATCH], srays[PATH_BATCH];
	struct pm_hit hits[PATH_BATCH];
	struct vertex vx[PATH_BATCH];
	struct pm_bsdf bt[PATH_BATCH];	/* textured BSDFs looked up */
	float u2[PATH_BATCH], u3[PATH_BATCH];
	float wx[PATH_BATCH], wy[PATH_BATCH], wz[PATH_BATCH];
	struct pm_light_lanes ll;
	struct round_soa rs;
	bool hitf[PATH_BATCH], occ[PATH_BATCH];
	uint8_t idx[PATH_BATCH], sidx[PATH_BATCH];
	bool done[PATH_BATCH];
};

static void
path_li_batch(const struct pm_render_ctx *ctx, struct pm_path_sample *smp,
    size_t n, struct batch_mem *bm)
{
	const struct pm_scene *s = ctx->scene;
	struct path_lane *l = bm->l;
	struct pm_ray *rays = bm->rays, *srays = bm->srays;
	struct pm_hit *hits = bm->hits;
	struct vertex *vx = bm->vx;
	struct pm_bsdf *bt = bm->bt;
	float *u2 = bm->u2, *u3 = bm->u3;
	float *wx = bm->wx, *wy = bm->wy, *wz = bm->wz;
	struct pm_light_lanes *ll = &bm->ll;
	struct round_soa *rs = &bm->rs;
	bool *hitf = bm->hitf, *occ = bm->occ;
	uint8_t *idx = bm->idx, *sidx = bm->sidx;
	bool *done = bm->done;
	size_t i, j, k, m, na = n, ns;
	int a;

	/* frame_lanes reads a group's loop-1 frames where any of its
	 * vertices has one: never memory left unset */
	memset(rs->fs, 0, sizeof(rs->fs));
	memset(rs->ft, 0, sizeof(rs->ft));
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
		/* Loop 1: the vertices' random numbers drawn first, in each
		 * path's order (the light sample's three, then the BSDF's),
		 * and what the lanes read stored field by field, so that the
		 * round's frames, light samples and BSDF directions are taken
		 * together in SIMD lanes (frame_lanes, pm_lights_sample_n,
		 * pm_square_to_cosine_hemisphere_n); then the plain diffuse
		 * vertices shade in lanes (diffuse_lanes) and the others one
		 * at a time, as before (loop 2). */
		for (k = m = 0; k < na; k++) {
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
			/* pm_bsdf_frame_at, its frame from the normal alone
			 * left to frame_lanes; bt[m] holds a textured BSDF
			 * through the round */
			v->b = &s->bsdfs[s->shapes[h->shape].bsdf];
			if (pm_bsdf_textured(v->b))
				v->b = pm_bsdf_at(s, h, &bt[m]);
			rs->tan[m] = pm_bsdf_needs_tangent(v->b) ? -1 : 0;
			if (rs->tan[m]) {
				struct pm_frame fr;

				v->b = pm_bsdf_frame_tangent(s, h, q->pa.d, v->b,
				    &bt[m], &fr);
				for (a = 0; a < 3; a++) {
					rs->fs[a][m] = (&fr.s.x)[a];
					rs->ft[a][m] = (&fr.t.x)[a];
					rs->fn[a][m] = (&fr.n.x)[a];
				}
			} else {
				for (a = 0; a < 3; a++)
					rs->fn[a][m] = (&h->ns.x)[a];
			}
			v->light = -1;
			ll->want[m] = !pm_bsdf_is_delta(v->b);
			if (ll->want[m]) {
				ll->u[0][m] = pm_rng_float(rng);
				ll->u[1][m] = pm_rng_float(rng);
				ll->u[2][m] = pm_rng_float(rng);
				v->light = (int)m;
			} else {
				ll->u[0][m] = ll->u[1][m] = ll->u[2][m] = 0.0f;
			}
			v->u1 = pm_rng_float(rng);
			u2[m] = pm_rng_float(rng);
			u3[m] = pm_rng_float(rng);
			v->k = k;
			/* what diffuse_lanes reads, field by field */
			for (a = 0; a < 3; a++) {
				rs->dir[a][m] = (&q->pa.d.x)[a];
				ll->ref[a][m] = (&h->p.x)[a];
				rs->ng[a][m] = (&h->ng.x)[a];
			}
			rs->scale[m] = h->scale;
			rs->beta[0][m] = q->pa.beta.r;
			rs->beta[1][m] = q->pa.beta.g;
			rs->beta[2][m] = q->pa.beta.b;
			rs->eta[m] = q->pa.eta_scale;
			if (ll->want[m] && pm_bsdf_plain_diffuse(v->b)) {
				rs->dm[m] = -1;
				rs->tw[m] = v->b->twosided ? -1 : 0;
				rs->alb[0][m] = v->b->diffuse.r;
				rs->alb[1][m] = v->b->diffuse.g;
				rs->alb[2][m] = v->b->diffuse.b;
			} else {
				rs->dm[m] = rs->tw[m] = 0;
				rs->alb[0][m] = rs->alb[1][m] = rs->alb[2][m] = 0.0f;
			}
			done[m] = false;
			m++;
		}
		/* up to a whole group of four with lanes that do nothing
		 * (PATH_BATCH is a multiple of 4), so that no vertex is left
		 * to the scalar code for want of three others */
		for (j = m; j % 4 != 0; j++) {
			for (a = 0; a < 3; a++) {
				rs->fn[a][j] = rs->dir[a][j] = 0.0f;
				rs->ng[a][j] = rs->beta[a][j] = rs->alb[a][j] = 0.0f;
				ll->ref[a][j] = ll->u[a][j] = 0.0f;
			}
			rs->scale[j] = rs->eta[j] = 0.0f;
			rs->dm[j] = rs->tw[j] = rs->tan[j] = 0;
			ll->want[j] = false;
			u2[j] = u3[j] = 0.0f;
		}
		frame_lanes(rs, j);
		pm_lights_sample_n(ctx->lights, s, ll, j);
		pm_square_to_cosine_hemisphere_n(u2, u3, wx, wy, wz, j);
		/* the plain diffuse vertices in SIMD lanes first */
		ns = 0;
		diffuse_lanes(ctx, j, rs, ll, vx, l, idx, smp, wx, wy, wz,
		    srays, sidx, &ns, done);
		for (j = 0; j < m; j++) {
			const struct vertex *v = &vx[j];
			struct path_lane *q = &l[idx[v->k]];
			struct pm_rng *rng = &smp[idx[v->k]].rng;
			const struct pm_hit *h = &hits[v->k];
			struct pm_vec3 wv = pm_v3(wx[j], wy[j], wz[j]);
			struct pm_bsdf_sample bs;
			struct pm_frame fr;
			struct pm_vec3 wi;

			if (done[j])
				continue;
			fr.s = pm_v3(rs->fs[0][j], rs->fs[1][j], rs->fs[2][j]);
			fr.t = pm_v3(rs->ft[0][j], rs->ft[1][j], rs->ft[2][j]);
			fr.n = pm_v3(rs->fn[0][j], rs->fn[1][j], rs->fn[2][j]);
			wi = pm_v3(rs->wix[j], rs->wiy[j], rs->wiz[j]);
			if (v->light >= 0) {
				struct pm_light_sample lsv;
				const struct pm_light_sample *ls = &lsv;
				struct pm_vec3 wo_local;
				struct pm_rgb f, c = pm_rgb1(0.0f);
				bool pending = false;

				pm_light_lanes_get(ll, (size_t)v->light, &lsv);
				if (ll->ok[v->light] && light_eval(v->b, fr, wi, ls,
				    &wo_local, &f)) {
					c = light_weighted(v->b, wi, wo_local,
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
			if (!bsdf_sample_v(v->b, wi, v->u1, u2[j], u3[j], &wv,
			    &bs) ||
			    !path_continue(&q->pa, h, &fr, &bs, q->depth,
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
	struct batch_mem *bm;
	size_t i, m;

	if (ctx->scene->nmedia > 0) {
		/* media: one path at a time, as volpath */
		for (i = 0; i < n; i++)
			smp[i].L = pm_path_li(ctx, smp[i].o, smp[i].d,
			    smp[i].tmin, smp[i].tmax, &smp[i].rng);
		return;
	}
	/* Without memory for a batch, one path at a time: the same
	 * results, only slower. */
	if ((bm = malloc(sizeof(*bm))) == NULL) {
		for (i = 0; i < n; i++)
			smp[i].L = pm_path_li(ctx, smp[i].o, smp[i].d,
			    smp[i].tmin, smp[i].tmax, &smp[i].rng);
		return;
	}
	for (i = 0; i < n; i += m) {
		m = n - i < PATH_BATCH ? n - i : PATH_BATCH;
		path_li_batch(ctx, smp + i, m, bm);
	}
	free(bm);
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
