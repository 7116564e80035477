/*
 * icache.c: the image-space irradiance cache of icache.h.
 *
 * A grid point's gather rays are cosine-distributed over the hemisphere
 * of the surface it sees and stratified (k x k cells of the unit square,
 * one jittered ray each), so that smooth indirect light is estimated with
 * far less noise than independent rays would leave.  Each ray ends where
 * a final-gathering ray does (pm_photon_gather): in the nearest
 * precomputed irradiance record.
 *
 * Interpolation follows Ward et al. 1988: a point i is trusted at x, n
 * when eps_i = |x - x_i| / R_i + sqrt(1 - n . n_i) < a, R_i the harmonic
 * mean distance to the surfaces its rays met, and is weighted by
 * 1 / eps_i - 1 / a (falling to zero at the edge of its trust, so the
 * interpolant is continuous); points in front of x (the surface bends
 * towards them) are skipped.  Candidates are the grid points of the 4 x 4
 * cells around the sample, so a lookup costs no search.
 */
#include <math.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

#include "camera.h"
#include "icache.h"
#include "integrator.h"
#include "parallel.h"
#include "sampling.h"

/* Stream index of grid-point random numbers: apart from pixel samples'. */
#define ICACHE_STREAM	0x1cac4e00000000ull

struct icache_job {
	struct pm_icache *c;
	const struct pm_render_ctx *ctx;
	const struct pm_camera_rays *cr;
	int k;				/* k x k strata */
	uint64_t seed;
	float r_min, r_max;
	_Atomic int next;
};

int
pm_icache_default_rays(int spp)
{
	long rays = (long)PM_ICACHE_RAYS_PER_SPP * spp;

	return rays < PM_ICACHE_RAYS_MIN ? PM_ICACHE_RAYS_MIN :
	    (rays > PM_ICACHE_RAYS ? PM_ICACHE_RAYS : (int)rays);
}

int
pm_icache_default_step(int spp, int rays)
{
	int s;

	/* a budget of at least 4 rays per pixel: below, the cache's points
	 * would be too few or too noisy for what they cost to matter */
	if (spp < 4)
		spp = 4;
	for (s = 1; s < PM_ICACHE_STEP; s *= 2)
		if ((long)rays <= (long)spp * s * s)
			return s;
	return PM_ICACHE_STEP;
}

/* Gather rays traced together: at most PM_ICACHE_RAYS a point. */
#define GATHER_BATCH	64

static void
build_point(struct icache_job *j, int gx, int gy)
{
	const struct pm_render_ctx *ctx = j->ctx;
	struct pm_icache *c = j->c;
	struct pm_icache_point *pt = &c->pt[(size_t)gy * c->gw + gx];
	float fx = (float)(gx * c->step), fy = (float)(gy * c->step);
	struct pm_rng rng = pm_rng_seed(j->seed, ICACHE_STREAM +
	    (uint64_t)gy * (uint64_t)c->gw + (uint64_t)gx, 0);
	struct pm_vec3 o, d, n;
	struct pm_frame fr;
	struct pm_hit h;
	double sum[3] = {0, 0, 0}, inv_t = 0.0;
	float tmin, tmax;
	int i0, nrays;

	pt->valid = false;
	if (fx > (float)j->cr->width - 0.5f)
		fx = (float)j->cr->width - 0.5f;
	if (fy > (float)j->cr->height - 0.5f)
		fy = (float)j->cr->height - 0.5f;
	if (fx < 0.5f)
		fx = 0.5f;
	if (fy < 0.5f)
		fy = 0.5f;
	/* the lens's centre: a thin lens's grid point is its pinhole's */
	d = pm_camera_ray(j->cr, fx, fy, 0.5f, 0.5f, &o, &tmin, &tmax);
	if (!pm_accel_intersect(ctx->accel, o, d, tmin, tmax, &h) ||
	    !pm_photon_cacheable(&ctx->scene->bsdfs[ctx->scene->shapes[h.shape].bsdf]))
		return;
	n = pm_dot(h.ng, d) < 0.0f ? h.ns : pm_neg(h.ns);
	fr = pm_frame_from_normal(n);
	nrays = j->k * j->k;
	/* GATHER_BATCH rays at a time: their directions drawn first, their
	 * first hits found together (Embree packets: the rays share an
	 * origin), then each gather goes on from its hit, drawing its own
	 * random numbers after the batch's directions. */
	for (i0 = 0; i0 < nrays; i0 += GATHER_BATCH) {
		struct pm_ray ray[GATHER_BATCH];
		struct pm_hit gh[GATHER_BATCH];
		bool gf[GATHER_BATCH];
		float u1[GATHER_BATCH], u2[GATHER_BATCH];
		float x[GATHER_BATCH], y[GATHER_BATCH], z[GATHER_BATCH];
		int i, m = nrays - i0 < GATHER_BATCH ? nrays - i0 : GATHER_BATCH;

		for (i = 0; i < m; i++) {
			int a = (i0 + i) / j->k, b = (i0 + i) % j->k;

			u1[i] = ((float)a + pm_rng_float(&rng)) / (float)j->k;
			u2[i] = ((float)b + pm_rng_float(&rng)) / (float)j->k;
		}
		/* the batch's cosine warps in SIMD lanes (sampling.h) */
		pm_square_to_cosine_hemisphere_n(u1, u2, x, y, z, (size_t)m);
		for (i = 0; i < m; i++) {
			ray[i].d = pm_normalize(pm_to_world(fr,
			    pm_v3(x[i], y[i], z[i])));
			ray[i].o = pm_hit_origin(&h, ray[i].d);
			ray[i].tmin = 0.0f;
			ray[i].tmax = INFINITY;
		}
		pm_accel_intersect_n(j->ctx->accel, ray, (size_t)m, gh, gf);
		if (ctx->maps != NULL && ctx->maps->irradiance_grid != NULL) {
			struct pm_vec3 at[GATHER_BATCH];
			size_t nat = 0;

			for (i = 0; i < m; i++)
				if (gf[i])
					at[nat++] = gh[i].p;
			pm_irradiance_prefetch(ctx->maps->irradiance_grid, at, nat);
		}
		for (i = 0; i < m; i++) {
			float t = INFINITY;
			struct pm_rgb L = pm_photon_gather_hit(ctx, ray[i].o,
			    ray[i].d, &rng, &t, gf[i], &gh[i]);

			sum[0] += L.r;
			sum[1] += L.g;
			sum[2] += L.b;
			if (isfinite(t) && t > 0.0f)
				inv_t += 1.0 / (double)pm_fmaxf(t, j->r_min);
		}
	}
	/* Cosine-distributed rays: E = pi * mean radiance. */
	pt->E = pm_rgb((float)(PM_PI * sum[0] / nrays),
	    (float)(PM_PI * sum[1] / nrays), (float)(PM_PI * sum[2] / nrays));
	if (!pm_rgb_is_finite(pt->E))
		return;
	{
		/* Rays that escape count as far: the harmonic mean over all. */
		double R = inv_t > 0.0 ? (double)nrays / inv_t : j->r_max;

		if (R > j->r_max)
			R = j->r_max;
		if (R < j->r_min)
			R = j->r_min;
		pt->inv_r = (float)(1.0 / R);
	}
	pt->p = h.p;
	pt->n = n;
	pt->valid = true;
}

/*
 * Neighbour clamping (Krivanek et al. 2006): R_i <= R_j + |x_i - x_j| for
 * the grid neighbours j on a similar surface, applied twice.  A point by
 * a corner has a small R; without this its neighbours a little farther
 * off keep large ones, and a sample at the corner would extrapolate their
 * irradiance across the region where it changes fastest.  With it, such
 * samples find no point they trust and gather for themselves.  Rows in
 * order, in place, on one thread: deterministic.
 */
static void
clamp_neighbours(struct pm_icache *c)
{
	int it, gx, gy, dx, dy;

	for (it = 0; it < 2; it++)
		for (gy = 0; gy < c->gh; gy++)
			for (gx = 0; gx < c->gw; gx++) {
				struct pm_icache_point *q = &c->pt[(size_t)gy * c->gw + gx];
				float R;

				if (!q->valid)
					continue;
				R = 1.0f / q->inv_r;
				for (dy = -1; dy <= 1; dy++)
					for (dx = -1; dx <= 1; dx++) {
						const struct pm_icache_point *o;
						float Rn;

						if ((dx == 0 && dy == 0) || gx + dx < 0 ||
						    gx + dx >= c->gw || gy + dy < 0 ||
						    gy + dy >= c->gh)
							continue;
						o = &c->pt[(size_t)(gy + dy) * c->gw + gx + dx];
						if (!o->valid || pm_dot(o->n, q->n) < 0.9f)
							continue;
						Rn = 1.0f / o->inv_r +
						    pm_length(pm_sub(q->p, o->p));
						if (Rn < R)
							R = Rn;
					}
				q->inv_r = 1.0f / R;
			}
}

/* Grid points handed out together: a row was the unit, 33 of them at
 * 128x128 and 16 spp, so that the last row's thread finished alone; a
 * few points keep the tail short on many cores (each point writes only
 * its own slot, so the cache is the same whoever builds which). */
#define ICACHE_CHUNK	8

static void *
icache_worker(void *arg)
{
	struct icache_job *j = arg;
	int np = j->c->gw * j->c->gh, i, at;

	while ((at = atomic_fetch_add(&j->next, ICACHE_CHUNK)) < np)
		for (i = at; i < at + ICACHE_CHUNK && i < np; i++)
			build_point(j, i % j->c->gw, i / j->c->gw);
	return NULL;
}

/*
 * The lookup's arrays (pm_icache.lanes): one per quantity, each a grid of
 * LANE_PAD + gw + LANE_PAD points a row.  A row's four candidates start
 * at gx0 >= -3 (fewer would leave none of the row's points) and end at
 * gx0 + 3 <= gw + 2, so three points of padding on each side hold every
 * load.  Padding and invalid points have inv_r NaN: eps is then NaN and
 * fails eps < a whatever the query, which is what skipping them did.
 */
enum { L_PX, L_PY, L_PZ, L_NX, L_NY, L_NZ, L_ER, L_EG, L_EB, L_INV_R,
	L_COUNT };
#define LANE_PAD	3

static inline size_t
lanes_row(const struct pm_icache *c)
{
	return (size_t)c->gw + 2 * LANE_PAD;
}

static inline float *
lanes_at(const struct pm_icache *c, int q)
{
	return c->lanes + (size_t)q * (size_t)c->gh * lanes_row(c);
}

bool
pm_icache_pack(struct pm_icache *c)
{
	size_t w = lanes_row(c), n = (size_t)c->gh * w, i;
	int q, gx, gy;

	free(c->lanes);
	c->lanes = malloc((size_t)L_COUNT * n * sizeof(*c->lanes));
	if (c->lanes == NULL)
		return false;
	for (q = 0; q < L_COUNT; q++)
		for (i = 0; i < n; i++)
			lanes_at(c, q)[i] = q == L_INV_R ? NAN : 0.0f;
	for (gy = 0; gy < c->gh; gy++)
		for (gx = 0; gx < c->gw; gx++) {
			const struct pm_icache_point *pt =
			    &c->pt[(size_t)gy * c->gw + gx];
			const float v[L_COUNT] = { pt->p.x, pt->p.y, pt->p.z,
			    pt->n.x, pt->n.y, pt->n.z, pt->E.r, pt->E.g, pt->E.b,
			    pt->inv_r };

			if (!pt->valid)
				continue;
			i = (size_t)gy * w + (size_t)(gx + LANE_PAD);
			for (q = 0; q < L_COUNT; q++)
				lanes_at(c, q)[i] = v[q];
		}
	return true;
}

/* What a lookup compares every candidate with. */
struct lane_query {
	struct pm_vec3 p, n;
	float a, inv_a, min_cos;
};

/* SSE where the compiler has it (PM_NO_SIMD: the plain C below, which
 * tests build to check it gives the same bits) */
#if (defined(__x86_64__) || defined(__i386__)) && defined(__SSE2__) && \
    (defined(__GNUC__) || defined(__clang__)) && !defined(PM_NO_SIMD)
#include <immintrin.h>

/*
 * Ward's test and weight for the four points from index i on, in SSE
 * lanes: the scalar expressions below, operation for operation (IEEE
 * sqrt and division are exact in both), so the weights are the same bits.
 * Returns the lanes trusted as a bit mask, their weights in w.
 */
static inline int
lane_weights(const struct pm_icache *c, size_t i, const struct lane_query *lq,
    float w[4])
{
	const __m128 qx = _mm_loadu_ps(lanes_at(c, L_PX) + i);
	const __m128 qy = _mm_loadu_ps(lanes_at(c, L_PY) + i);
	const __m128 qz = _mm_loadu_ps(lanes_at(c, L_PZ) + i);
	const __m128 mx = _mm_loadu_ps(lanes_at(c, L_NX) + i);
	const __m128 my = _mm_loadu_ps(lanes_at(c, L_NY) + i);
	const __m128 mz = _mm_loadu_ps(lanes_at(c, L_NZ) + i);
	const __m128 inv_r = _mm_loadu_ps(lanes_at(c, L_INV_R) + i);
	const __m128 nx = _mm_set1_ps(lq->n.x), ny = _mm_set1_ps(lq->n.y);
	const __m128 nz = _mm_set1_ps(lq->n.z), zero = _mm_setzero_ps();
	__m128 cosn, dx, dy, dz, front, eps, ok, wv;

	cosn = _mm_add_ps(_mm_add_ps(_mm_mul_ps(nx, mx), _mm_mul_ps(ny, my)),
	    _mm_mul_ps(nz, mz));
	dx = _mm_sub_ps(_mm_set1_ps(lq->p.x), qx);
	dy = _mm_sub_ps(_mm_set1_ps(lq->p.y), qy);
	dz = _mm_sub_ps(_mm_set1_ps(lq->p.z), qz);
	front = _mm_mul_ps(_mm_mul_ps(_mm_add_ps(_mm_add_ps(
	    _mm_mul_ps(dx, _mm_add_ps(nx, mx)), _mm_mul_ps(dy, _mm_add_ps(ny, my))),
	    _mm_mul_ps(dz, _mm_add_ps(nz, mz))), _mm_set1_ps(0.5f)), inv_r);
	/* max(1 - cos, 0) with a NaN as 0, as pm_fmaxf(0, 1 - cos) */
	eps = _mm_add_ps(_mm_mul_ps(_mm_sqrt_ps(_mm_add_ps(_mm_add_ps(
	    _mm_mul_ps(dx, dx), _mm_mul_ps(dy, dy)), _mm_mul_ps(dz, dz))), inv_r),
	    _mm_sqrt_ps(_mm_max_ps(_mm_sub_ps(_mm_set1_ps(1.0f), cosn), zero)));
	ok = _mm_and_ps(_mm_cmpnle_ps(cosn, _mm_set1_ps(lq->min_cos)),
	    _mm_cmpnle_ps(cosn, zero));
	ok = _mm_and_ps(ok, _mm_cmpnlt_ps(front, _mm_set1_ps(-0.05f)));
	ok = _mm_and_ps(ok, _mm_cmplt_ps(eps, _mm_set1_ps(lq->a)));
	wv = _mm_sub_ps(_mm_div_ps(_mm_set1_ps(1.0f), eps),
	    _mm_set1_ps(lq->inv_a));
	_mm_storeu_ps(w, _mm_or_ps(_mm_and_ps(_mm_cmpgt_ps(eps,
	    _mm_set1_ps(1e-6f)), wv), _mm_andnot_ps(_mm_cmpgt_ps(eps,
	    _mm_set1_ps(1e-6f)), _mm_set1_ps(1e6f))));
	return _mm_movemask_ps(ok);
}
#else
/* The same, a point at a time. */
static inline int
lane_weights(const struct pm_icache *c, size_t i, const struct lane_query *lq,
    float w[4])
{
	int k, mask = 0;

	for (k = 0; k < 4; k++) {
		struct pm_vec3 q = pm_v3(lanes_at(c, L_PX)[i + k],
		    lanes_at(c, L_PY)[i + k], lanes_at(c, L_PZ)[i + k]);
		struct pm_vec3 m = pm_v3(lanes_at(c, L_NX)[i + k],
		    lanes_at(c, L_NY)[i + k], lanes_at(c, L_NZ)[i + k]);
		float inv_r = lanes_at(c, L_INV_R)[i + k];
		float cosn = pm_dot(lq->n, m), eps;
		struct pm_vec3 dv = pm_sub(lq->p, q);

		if (cosn <= lq->min_cos || cosn <= 0.0f)
			continue;
		/* In front: the surface curves towards the point. */
		if (pm_dot(dv, pm_add(lq->n, m)) * 0.5f * inv_r < -0.05f)
			continue;
		eps = pm_length(dv) * inv_r + sqrtf(pm_fmaxf(0.0f,
		    1.0f - cosn));
		if (!(eps < lq->a))
			continue;
		w[k] = eps > 1e-6f ? 1.0f / eps - lq->inv_a : 1e6f;
		mask |= 1 << k;
	}
	return mask;
}
#endif

enum pm_err
pm_icache_build(struct pm_icache *c, const struct pm_render_ctx *ctx,
    const struct pm_camera_rays *cr, int step, int rays, float a,
    uint64_t seed, int threads, struct pm_error *err)
{
	struct icache_job j;
	float radius = ctx->scene_radius > 0.0f ? ctx->scene_radius : 1.0f;

	memset(c, 0, sizeof(*c));
	if (step < 1 || rays < 1 || !(a > 0.0f))
		return pm_fail(err, PM_ERR_INVALID, "irradiance cache: step, "
		    "rays and accuracy must be positive");
	c->step = step;
	c->a = a;
	c->gw = (cr->width + step - 1) / step + 1;
	c->gh = (cr->height + step - 1) / step + 1;
	c->pt = calloc((size_t)c->gw * (size_t)c->gh, sizeof(*c->pt));
	if (c->pt == NULL)
		return pm_fail(err, PM_ERR_NOMEM, "no memory for the irradiance "
		    "cache (%d x %d points)", c->gw, c->gh);
	j.c = c;
	j.ctx = ctx;
	j.cr = cr;
	for (j.k = 1; (j.k + 1) * (j.k + 1) <= rays; j.k++)
		;
	j.seed = seed;
	/* Validity distances are clamped to sensible fractions of the
	 * scene: a point by a wall would otherwise trust nobody, one in
	 * open space everybody. */
	j.r_min = 1e-3f * radius;
	j.r_max = 0.5f * radius;
	atomic_init(&j.next, 0);
	pm_parallel(threads, icache_worker, &j);
	clamp_neighbours(c);
	if (!pm_icache_pack(c)) {
		pm_icache_free(c);
		return pm_fail(err, PM_ERR_NOMEM, "no memory for the irradiance "
		    "cache (%d x %d points)", c->gw, c->gh);
	}
	return PM_OK;
}

bool
pm_icache_lookup(const struct pm_icache *c, float fx, float fy,
    struct pm_vec3 p, struct pm_vec3 n, struct pm_rgb *E)
{
	struct lane_query lq;
	int gx0, gy0, gy;
	double sum[3] = {0, 0, 0}, wsum = 0.0;

	if (c == NULL || c->pt == NULL || !isfinite(fx) || !isfinite(fy))
		return false;
	lq.p = p;
	lq.n = n;
	lq.a = c->a;
	lq.inv_a = 1.0f / c->a;
	/* sqrt(1 - cos) alone must stay below a. */
	lq.min_cos = 1.0f - c->a * c->a;
	gx0 = (int)floorf(fx / (float)c->step) - 1;
	gy0 = (int)floorf(fy / (float)c->step) - 1;
	/* a row's points gx0 .. gx0 + 3: none on the grid, or all within
	 * its padding */
	if (gx0 + 3 < 0 || gx0 >= c->gw)
		return false;
	for (gy = gy0; gy < gy0 + 4; gy++) {
		size_t i = (size_t)gy * lanes_row(c) + (size_t)(gx0 + LANE_PAD);
		float w[4];
		int k, mask;

		if (gy < 0 || gy >= c->gh)
			continue;
		mask = lane_weights(c, i, &lq, w);
		/* summed in the order of the points, as one at a time */
		for (k = 0; k < 4; k++) {
			if (!(mask & 1 << k))
				continue;
			sum[0] += (double)w[k] * lanes_at(c, L_ER)[i + k];
			sum[1] += (double)w[k] * lanes_at(c, L_EG)[i + k];
			sum[2] += (double)w[k] * lanes_at(c, L_EB)[i + k];
			wsum += w[k];
		}
	}
	if (!(wsum > 0.0))
		return false;
	*E = pm_rgb((float)(sum[0] / wsum), (float)(sum[1] / wsum),
	    (float)(sum[2] / wsum));
	return true;
}

void
pm_icache_free(struct pm_icache *c)
{
	free(c->pt);
	free(c->lanes);
	c->pt = NULL;
	c->lanes = NULL;
}
