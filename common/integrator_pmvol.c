/*
 * integrator_pmvol.c: participating media in the photon-map camera pass
 * (integrator_pm.c), after Jensen and Christensen (1998).
 *
 * Radiance along a camera segment of length s in a homogeneous medium:
 *   L = integral_0^s T(t) L_s(x(t)) dt + T(s) L_surface,
 * L_s the in-scattered radiance sigma_s * integral(phase * L_i).  The
 * surface term's transmittance is exact (Beer-Lambert).  The integral is
 * estimated at n points along the segment (a ray march with jittered
 * points in transmittance, not in distance: each point is drawn from the
 * exponential of one channel truncated to the segment, chosen
 * uniformly, and weighted by T over the mixture of the three channels'
 * densities, stratified over the n points).  At each point
 *   - single scattering (light that arrives straight from an emitter,
 *     through media and index-matched boundaries) is computed exactly
 *     by a light sample, as the path tracer's next-event estimation,
 *     here and at a second point drawn by equiangular sampling toward
 *     a light point (equi_scatter), the two weighted by the balance
 *     heuristic;
 *   - everything else (multiple scattering, light from surfaces,
 *     volumetric caustics through glass) comes from the volume photon
 *     map: the photons of depth >= 1 among the k nearest (or, in a
 *     progressive pass, all within the fixed radius), each weighted by
 *     the phase function from its direction, over the sphere's volume
 *     4/3 pi r^3.  A volume photon's power already holds sigma_s / sigma_t
 *     (shoot.c), so the sum estimates L_s itself.
 * Depth-0 volume photons (single scattering) are left out, as direct
 * light is on surfaces.  Heterogeneous media: hetero_inscatter.  The density estimate is the ray-marching one;
 * Jarosz et al.'s beam radiance estimate was not built (docs/media.md).
 */
#include <float.h>
#include <math.h>

#include "integrator.h"
#include "kdtree.h"

static inline float
chan(struct pm_rgb c, int i)
{
	return i == 0 ? c.r : i == 1 ? c.g : c.b;
}

/* One volume photon's phase-weighted power into sum; with a
 * heterogeneous medium het, over sigma_s of het where the photon lies
 * (hetero_map_estimate says why), photons where het does not scatter left
 * out.  Depth-0 photons (single scattering, computed exactly) and those
 * past max_depth are left out too. */
static inline void
volume_add(double sum[3], const struct pm_photon *x, const struct pm_phase *ph,
    const struct pm_medium *het, struct pm_vec3 d, int max_depth)
{
	struct pm_rgb c;
	float w;

	if (x->depth == 0 || (max_depth >= 0 && x->depth > max_depth))
		return;
	w = pm_phase_eval(ph, pm_dir_unpack(x->dir), d);
	c = pm_rgbe_unpack(x->power);
	if (het == NULL) {
		sum[0] += (double)(c.r * w);
		sum[1] += (double)(c.g * w);
		sum[2] += (double)(c.b * w);
	} else {
		struct pm_vec3 y = pm_v3(x->pos[0], x->pos[1], x->pos[2]);
		struct pm_rgb sy = pm_rgb_mul(pm_medium_sigma_t_at(het, y),
		    pm_medium_albedo_at(het, y));

		sum[0] += sy.r > 0.0f ? (double)(c.r * w / sy.r) : 0.0;
		sum[1] += sy.g > 0.0f ? (double)(c.g * w / sy.g) : 0.0;
		sum[2] += sy.b > 0.0f ? (double)(c.b * w / sy.b) : 0.0;
	}
}

/*
 * The volume map's photons about p, summed by volume_add: all within the
 * fixed radius in a progressive pass, else the k nearest within the
 * map's radius.  Returns the squared radius of the sphere they were
 * gathered in, 0 when there is nothing to divide by; the caller divides
 * the sum by its volume.
 */
static float
volume_sum(const struct pm_photon_maps *m, const struct pm_phase *ph,
    const struct pm_medium *het, struct pm_vec3 p, struct pm_vec3 d,
    int max_depth, double sum[3])
{
	float q[3] = {p.x, p.y, p.z};

	sum[0] = sum[1] = sum[2] = 0.0;
	if (m->nvolume == 0 || !(m->volume_r2 > 0.0f))
		return 0.0f;
	if (m->fixed_radius) {
		struct pm_kd_range it;
		uint32_t idx;
		float d2;

		pm_kdtree_range_init(&it, m->volume, m->nvolume, q,
		    m->volume_r2, 0, 0);
		while (pm_kdtree_range_next(&it, &idx, &d2))
			volume_add(sum, &m->volume[idx], ph, het, d, max_depth);
		return m->volume_r2;
	} else {
		struct pm_knn nb[PM_MAX_LOOKUP];
		size_t found, i, k = (size_t)m->lookup_size;

		if (k < 1)
			k = 1;
		if (k > PM_MAX_LOOKUP)
			k = PM_MAX_LOOKUP;
		found = pm_kdtree_knn_unordered(m->volume, m->nvolume, q, k,
		    m->volume_r2, 0, 0, nb);
		if (found == 0)
			return 0.0f;
		for (i = 0; i < found; i++)
			volume_add(sum, &m->volume[nb[i].idx], ph, het, d,
			    max_depth);
		return found == k ? nb[0].d2 : m->volume_r2;
	}
}

struct pm_rgb
pm_volume_map_estimate(const struct pm_photon_maps *m,
    const struct pm_phase *ph, struct pm_vec3 p, struct pm_vec3 d,
    int max_depth)
{
	double sum[3];
	float r2 = volume_sum(m, ph, NULL, p, d, max_depth, sum), w;

	if (!(r2 > 0.0f))
		return pm_rgb1(0.0f);
	w = m->volume_scale / (4.0f / 3.0f * PM_PI * r2 * sqrtf(r2));
	return pm_rgb((float)(sum[0] * w), (float)(sum[1] * w),
	    (float)(sum[2] * w));
}

/*
 * The beam radiance estimate (Jarosz, Zwicker and Jensen 2008) with a
 * fixed radius: every volume photon within distance r of the camera
 * segment contributes its phase-weighted power times the transmittance
 * from the segment's start to its projection, over pi r^2 (the photon's
 * power spread over a disc across the ray).  The implicit kd-tree
 * (kdtree.h's layout) is walked with each subtree's box, pruning boxes
 * that the segment, widened by r, misses.
 */
struct beam {
	const struct pm_photon *p;
	const struct pm_medium *m;
	float o[3], d[3], t0, t1, r2;
	int max_depth;
	double sum[3];
};

struct box {
	float lo[3], hi[3];
};

/* Whether the segment, widened by r, meets the box. */
static bool
beam_meets(const struct beam *b, const struct box *bx)
{
	float t0 = b->t0, t1 = b->t1, r = sqrtf(b->r2);
	int a;

	for (a = 0; a < 3; a++) {
		float l = bx->lo[a] - r, h = bx->hi[a] + r, inv, ta, tb;

		if (fabsf(b->d[a]) < 1e-12f) {
			if (b->o[a] < l || b->o[a] > h)
				return false;
			continue;
		}
		inv = 1.0f / b->d[a];
		ta = (l - b->o[a]) * inv;
		tb = (h - b->o[a]) * inv;
		if (ta > tb) {
			float t = ta;

			ta = tb;
			tb = t;
		}
		t0 = pm_fmaxf(t0, ta);
		t1 = pm_fminf(t1, tb);
		if (t0 > t1)
			return false;
	}
	return true;
}

/* The subtree over [lo, hi) whose photons lie in bx (a copy: each
 * call narrows its own). */
static void
beam_walk(struct beam *b, uint32_t lo, uint32_t hi, struct box bx)
{
	while (lo < hi) {
		uint32_t mid = lo + (hi - lo) / 2;
		const struct pm_photon *x = &b->p[mid];
		float v[3], t, d2;
		int axis = x->flags & PM_KD_AXIS_MASK;
		struct box left;

		if (!beam_meets(b, &bx))
			return;
		v[0] = x->pos[0] - b->o[0];
		v[1] = x->pos[1] - b->o[1];
		v[2] = x->pos[2] - b->o[2];
		t = v[0] * b->d[0] + v[1] * b->d[1] + v[2] * b->d[2];
		d2 = v[0] * v[0] + v[1] * v[1] + v[2] * v[2] - t * t;
		if (t >= b->t0 && t <= b->t1 && d2 < b->r2 && x->depth > 0 &&
		    (b->max_depth < 0 || x->depth <= b->max_depth)) {
			struct pm_rgb c = pm_rgb_mul(pm_rgbe_unpack(x->power),
			    pm_medium_transmittance(b->m, t - b->t0));
			float w = pm_phase_eval(&b->m->phase,
			    pm_dir_unpack(x->dir), pm_v3(b->d[0], b->d[1],
			    b->d[2]));

			b->sum[0] += (double)(c.r * w);
			b->sum[1] += (double)(c.g * w);
			b->sum[2] += (double)(c.b * w);
		}
		if (axis == PM_KD_LEAF || hi - lo == 1)
			return;
		/* the left subtree by recursion, the right one here */
		left = bx;
		left.hi[axis] = x->pos[axis];
		beam_walk(b, lo, mid, left);
		bx.lo[axis] = x->pos[axis];
		lo = mid + 1;
	}
}

struct pm_rgb
pm_volume_beam_estimate(const struct pm_photon_maps *m,
    const struct pm_medium *med, struct pm_vec3 o, struct pm_vec3 d,
    float tmin, float t_end, int max_depth)
{
	struct beam b;
	struct box all = {{-FLT_MAX, -FLT_MAX, -FLT_MAX},
	    {FLT_MAX, FLT_MAX, FLT_MAX}};
	float w;

	if (m->nvolume == 0 || !(m->volume_r2 > 0.0f) || !(t_end > tmin))
		return pm_rgb1(0.0f);
	b.p = m->volume;
	b.m = med;
	b.o[0] = o.x;
	b.o[1] = o.y;
	b.o[2] = o.z;
	b.d[0] = d.x;
	b.d[1] = d.y;
	b.d[2] = d.z;
	b.t0 = tmin;
	b.t1 = t_end;
	b.r2 = m->volume_r2;
	b.max_depth = max_depth;
	b.sum[0] = b.sum[1] = b.sum[2] = 0.0;
	beam_walk(&b, 0, (uint32_t)m->nvolume, all);
	w = m->volume_scale / (PM_PI * m->volume_r2);
	return pm_rgb((float)(b.sum[0] * w), (float)(b.sum[1] * w),
	    (float)(b.sum[2] * w));
}

/* Single scattering at p toward -d: one light sample, through media.
 * With y, the light point sampled (when it lies at a finite distance,
 * else *finite false), for equiangular sampling's weight; u, when not
 * NULL, the light sample's three numbers instead of fresh ones. */
static struct pm_rgb
single_scatter(const struct pm_render_ctx *ctx, int medium, struct pm_vec3 p,
    struct pm_vec3 d, struct pm_rng *rng, const float *u, struct pm_vec3 *y,
    bool *finite)
{
	const struct pm_medium *m = &ctx->scene->media[medium];
	struct pm_light_sample ls;
	struct pm_rgb tr;
	float u0, u1, u2, ph;

	if (u != NULL) {
		u0 = u[0];
		u1 = u[1];
		u2 = u[2];
	} else {
		u0 = pm_rng_float(rng);
		u1 = pm_rng_float(rng);
		u2 = pm_rng_float(rng);
	}
	if (finite != NULL)
		*finite = false;
	if (!pm_lights_sample(ctx->lights, ctx->scene, p, u0, u1, u2, &ls))
		return pm_rgb1(0.0f);
	if (finite != NULL && isfinite(ls.dist)) {
		*finite = true;
		*y = ls.p;
	}
	ph = pm_phase_eval(&m->phase, d, ls.wi);
	if (!(ph > 0.0f))
		return pm_rgb1(0.0f);
	tr = pm_volume_shadow(ctx, p, medium, &ls);
	if (pm_rgb_is_black(tr))
		return tr;
	return pm_rgb_scale(pm_rgb_mul(tr, ls.value), ph / ls.pdf);
}

/*
 * The volume map's in-scattered radiance at p in a heterogeneous medium
 * m: each photon's power over sigma_s of m where it lies, times sigma_s
 * at p.  A photon stored at y holds, in expectation, sigma_s(y) times the
 * light arriving there (shoot.c), so the plain estimate averages
 * sigma_s * S over the kernel, S = integral(phase L_i): where sigma_s
 * changes within the kernel (a plume's edge) that average is not
 * sigma_s(p) S(p), and the points placed where sigma_t(p) is small see the
 * denser neighbourhood's light (measured on smoke.xml: 8/768 blocks
 * beyond 4 sigma at the plume's base).  Divided by sigma_s(y) the sum
 * averages S alone, which varies as smoothly as the light does.  Photons
 * where m does not scatter (another medium's) are left out.
 */
static struct pm_rgb
hetero_map_estimate(const struct pm_photon_maps *maps,
    const struct pm_medium *m, struct pm_vec3 p, struct pm_vec3 d,
    int max_depth)
{
	struct pm_rgb ss;
	double sum[3];
	float r2, w;

	if (maps->nvolume == 0 || !(maps->volume_r2 > 0.0f))
		return pm_rgb1(0.0f);
	ss = pm_rgb_mul(pm_medium_sigma_t_at(m, p), pm_medium_albedo_at(m, p));
	if (pm_rgb_is_black(ss))
		return pm_rgb1(0.0f);
	r2 = volume_sum(maps, &m->phase, m, p, d, max_depth, sum);
	if (!(r2 > 0.0f))
		return pm_rgb1(0.0f);
	w = maps->volume_scale / (4.0f / 3.0f * PM_PI * r2 * sqrtf(r2));
	return pm_rgb_mul(ss, pm_rgb((float)(sum[0] * w),
	    (float)(sum[1] * w), (float)(sum[2] * w)));
}

/*
 * pm_volume_inscatter in a heterogeneous medium.  The surface term's
 * transmittance is a ratio-tracking estimate (unbiased, as the path
 * tracer's shadow rays).  Each of the n points is a free flight delta-
 * tracked from the segment's start (medium.h; one channel per flight,
 * weighted over the mixture of channels, as photons fly): a real
 * collision at x before the segment's end has the density
 * sigma_t(x) T(x) per channel, so it adds
 *   T(x) / (sigma_t(x) T(x)) * L_s(x) = L_s(x) / sigma_t(x),
 * L_s = sigma_s(x) (single scattering + the volume map's estimate of the
 * phase-weighted light, hetero_map_estimate); a flight that leaves the
 * segment adds nothing.
 * The weight f / mean(pdf) of the flight, in a grey medium the albedo at
 * x, is sigma_s(x) / sigma_t(x) times this point's weight: the ratio of
 * the two per channel is taken from pdf (sigma_t at the collision),
 * which is never 0 in the channel that sampled it.  The beam estimate
 * (it needs the transmittance to every photon along the beam) is not
 * used here: heterogeneous media always take the point estimate.
 */
static struct pm_rgb
hetero_inscatter(const struct pm_render_ctx *ctx, int medium,
    struct pm_vec3 o, struct pm_vec3 d, float tmin, float t_end, int depth,
    struct pm_rgb *tr, struct pm_rng *rng)
{
	const struct pm_medium *m = &ctx->scene->media[medium];
	const struct pm_photon_maps *maps = ctx->maps;
	struct pm_rgb L = pm_rgb1(0.0f);
	int n = maps->volume_samples > 0 ? maps->volume_samples : 1, i, c;
	int dcap = ctx->max_depth < 0 ? -1 : ctx->max_depth - depth - 1;

	*tr = pm_rgb1(1.0f);
	if (!(t_end > tmin))
		return L;
	*tr = pm_medium_transmittance_ray(m, o, d, tmin, t_end, rng);
	if (ctx->max_depth >= 0 && depth >= ctx->max_depth)
		return L;
	for (i = 0; i < n; i++) {
		struct pm_medium_sample ms;
		struct pm_rgb st, w, Ls;
		struct pm_vec3 p;
		float q;

		c = (int)(pm_rng_float(rng) * 3.0f);
		pm_medium_sample_ray(m, o, d, tmin, t_end, c > 2 ? 2 : c, rng,
		    &ms);
		q = pm_rgb_mean(ms.pdf);
		if (!ms.scattered || !(q > 0.0f))
			continue;
		p = pm_madd(o, d, tmin + ms.t);
		st = pm_medium_sigma_t_at(m, p);
		/* per channel: (null ratios) / mean(pdf) = pdf / sigma_t(x) /
		 * mean(pdf), 0 where the channel is clear at x */
		w = pm_rgb(st.r > 0.0f ? ms.pdf.r / (st.r * q) : 0.0f,
		    st.g > 0.0f ? ms.pdf.g / (st.g * q) : 0.0f,
		    st.b > 0.0f ? ms.pdf.b / (st.b * q) : 0.0f);
		Ls = pm_rgb_mul(pm_rgb_mul(st, pm_medium_albedo_at(m, p)),
		    single_scatter(ctx, medium, p, d, rng, NULL, NULL, NULL));
		if (dcap != 0)
			Ls = pm_rgb_add(Ls, hetero_map_estimate(maps, m, p, d,
			    dcap));
		L = pm_rgb_madd(L, w, Ls);
	}
	return pm_rgb_scale(L, 1.0f / (float)n);
}

/*
 * Equiangular sampling (Kulla and Fajardo 2012) of a point on the segment
 * [a, b] of the ray o + t d toward a light point y: density proportional
 * to 1 / |y - x(t)|^2, which follows the 1 / r^2 of single scattering from
 * a small light.  Transmittance sampling alone puts the segment's one
 * point anywhere along a camera ray that crosses a narrow beam; this puts
 * it near the lamp.  The two are combined by the balance heuristic.
 */
struct equi {
	float tc, h, th0, th1;	/* foot of y on the ray, distance, angles */
};

static bool
equi_setup(struct pm_vec3 o, struct pm_vec3 d, float a, float b,
    struct pm_vec3 y, struct equi *e)
{
	struct pm_vec3 v = pm_sub(y, o);

	if (!isfinite(b) || !(b > a))
		return false;
	e->tc = pm_dot(v, d);
	e->h = pm_length(pm_sub(v, pm_scale(d, e->tc)));
	/* on the ray's line: the density is a delta, no use */
	if (!(e->h > 1e-5f * (b - a)))
		return false;
	e->th0 = atan2f(a - e->tc, e->h);
	e->th1 = atan2f(b - e->tc, e->h);
	return e->th1 > e->th0;
}

static inline float
equi_sample(const struct equi *e, float u)
{
	return e->tc + e->h * tanf(e->th0 + u * (e->th1 - e->th0));
}

static inline float
equi_pdf(const struct equi *e, float t)
{
	float x = t - e->tc;

	return e->h / ((e->th1 - e->th0) * (e->h * e->h + x * x));
}

/* The light point that pm_lights_sample picks with u, whatever the
 * reference point (area lights are sampled by area, point lights are one
 * point); false for lights at infinity. */
static bool
light_point(const struct pm_render_ctx *ctx, struct pm_vec3 ref,
    const float *u, struct pm_vec3 *y)
{
	struct pm_light_sample ls;
	const struct pm_light *l;

	ls.light = -1;
	ls.dist = INFINITY;
	(void)pm_lights_sample(ctx->lights, ctx->scene, ref, u[0], u[1], u[2],
	    &ls);
	if (ls.light < 0)
		return false;
	l = &ctx->scene->lights[ls.light];
	switch (l->type) {
	case PM_LIGHT_AREA:
		*y = ls.p;
		return true;
	case PM_LIGHT_POINT:
	case PM_LIGHT_SPOT:
	case PM_LIGHT_PROJECTOR:
		*y = l->position;
		return true;
	default:
		return false;
	}
}

/* The transmittance sampler's density at t (from the segment's start):
 * the mixture of the channels' truncated exponentials, as
 * pm_volume_inscatter draws it. */
static float
tr_pdf(const struct pm_medium *m, const float *norm, float s, float t)
{
	float pdf = 0.0f;
	int c;

	for (c = 0; c < 3; c++) {
		float sk = chan(m->sigma_t, c);

		if (sk > 0.0f && norm[c] > 0.0f)
			pdf += sk * expf(-sk * t) / norm[c];
		else if (isfinite(s))
			pdf += 1.0f / s;
	}
	return pdf / 3.0f;
}

/* Single scattering at one point of the segment drawn by equiangular
 * sampling about a light point, balance-weighted against transmittance
 * sampling; black where the light is at infinity or the segment is. */
static struct pm_rgb
equi_scatter(const struct pm_render_ctx *ctx, int medium, struct pm_vec3 o,
    struct pm_vec3 d, float tmin, float t_end, const float *norm,
    struct pm_rng *rng)
{
	const struct pm_medium *m = &ctx->scene->media[medium];
	float u[3], ut = pm_rng_float(rng), t, pe, pt;
	struct pm_vec3 y, p;
	struct equi e;
	struct pm_rgb f;

	u[0] = pm_rng_float(rng);
	u[1] = pm_rng_float(rng);
	u[2] = pm_rng_float(rng);
	if (!light_point(ctx, o, u, &y) || !equi_setup(o, d, tmin, t_end, y, &e))
		return pm_rgb1(0.0f);
	t = equi_sample(&e, ut);
	if (!(t >= tmin && t <= t_end))
		return pm_rgb1(0.0f);
	pe = equi_pdf(&e, t);
	pt = tr_pdf(m, norm, t_end - tmin, t - tmin);
	if (!(pe > 0.0f))
		return pm_rgb1(0.0f);
	p = pm_madd(o, d, t);
	f = single_scatter(ctx, medium, p, d, rng, u, NULL, NULL);
	if (pm_rgb_is_black(f))
		return f;
	f = pm_rgb_mul(f, pm_rgb_mul(pm_rgb_mul(m->sigma_t, m->albedo),
	    pm_medium_transmittance(m, t - tmin)));
	return pm_rgb_scale(f, 1.0f / (pe + pt));
}

struct pm_rgb
pm_volume_inscatter(const struct pm_render_ctx *ctx, int medium,
    struct pm_vec3 o, struct pm_vec3 d, float tmin, float t_end, int depth,
    struct pm_rgb *tr, struct pm_rng *rng)
{
	const struct pm_medium *m = &ctx->scene->media[medium];
	const struct pm_photon_maps *maps = ctx->maps;
	struct pm_rgb L = pm_rgb1(0.0f), sigma_s;
	float s = t_end - tmin, norm[3];
	int n = maps->volume_samples > 0 ? maps->volume_samples : 1, i, c;
	/* photons of k bounces close paths of depth + k + 1 segments */
	int dcap = ctx->max_depth < 0 ? -1 : ctx->max_depth - depth - 1;

	if (m->het != NULL)
		return hetero_inscatter(ctx, medium, o, d, tmin, t_end, depth,
		    tr, rng);
	if (!(s > 0.0f))
		s = 0.0f;
	*tr = pm_medium_transmittance(m, s);
	if (!(s > 0.0f) || (ctx->max_depth >= 0 && depth >= ctx->max_depth))
		return L;
	sigma_s = pm_rgb_mul(m->sigma_t, m->albedo);
	/* Per channel, the chance of a collision within the segment: the
	 * truncated exponential's normaliser. */
	for (c = 0; c < 3; c++) {
		float sc = chan(m->sigma_t, c);

		norm[c] = sc > 0.0f ? -expm1f(-sc * s) : 0.0f;
	}
	for (i = 0; i < n; i++) {
		float u = ((float)i + pm_rng_float(rng)) / (float)n;
		float sc, t, pdf = 0.0f;
		struct pm_rgb w, Ls;
		struct pm_vec3 p;

		c = (int)(pm_rng_float(rng) * 3.0f);
		c = c > 2 ? 2 : c;
		sc = chan(m->sigma_t, c);
		if (sc > 0.0f && norm[c] > 0.0f)
			t = -log1pf(-u * norm[c]) / sc;
		else if (isfinite(s))
			t = u * s;	/* clear channel: uniform */
		else
			continue;
		t = pm_fminf(t, s);
		for (c = 0; c < 3; c++) {
			float sk = chan(m->sigma_t, c);

			if (sk > 0.0f && norm[c] > 0.0f)
				pdf += sk * expf(-sk * t) / norm[c];
			else if (isfinite(s))
				pdf += 1.0f / s;
		}
		pdf /= 3.0f;
		if (!(pdf > 0.0f))
			continue;
		w = pm_rgb_scale(pm_medium_transmittance(m, t), 1.0f / pdf);
		p = pm_madd(o, d, tmin + t);
		{
			/* single scattering here, weighted against the
			 * equiangular sample about its light point */
			struct pm_vec3 y;
			struct equi e;
			bool fin;
			float pe = 0.0f;

			Ls = pm_rgb_mul(sigma_s, single_scatter(ctx, medium, p,
			    d, rng, NULL, &y, &fin));
			if (fin && equi_setup(o, d, tmin, t_end, y, &e))
				pe = equi_pdf(&e, tmin + t);
			Ls = pm_rgb_scale(Ls, pdf / (pdf + pe));
		}
		if (dcap != 0 && !maps->volume_beam)
			Ls = pm_rgb_add(Ls, pm_volume_map_estimate(maps,
			    &m->phase, p, d, dcap));
		L = pm_rgb_madd(L, w, Ls);
		L = pm_rgb_add(L, equi_scatter(ctx, medium, o, d, tmin, t_end,
		    norm, rng));
	}
	L = pm_rgb_scale(L, 1.0f / (float)n);
	if (dcap != 0 && maps->volume_beam)
		L = pm_rgb_add(L, pm_volume_beam_estimate(maps, m, o, d, tmin,
		    t_end, dcap));
	return L;
}
