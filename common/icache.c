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
	int a, b, nrays;

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
	for (a = 0; a < j->k; a++)
		for (b = 0; b < j->k; b++) {
			float u1 = ((float)a + pm_rng_float(&rng)) / (float)j->k;
			float u2 = ((float)b + pm_rng_float(&rng)) / (float)j->k;
			struct pm_vec3 w = pm_normalize(pm_to_world(fr,
			    pm_square_to_cosine_hemisphere(u1, u2)));
			float t = INFINITY;
			struct pm_rgb L = pm_photon_gather(ctx, pm_hit_origin(&h, w),
			    w, &rng, &t);

			sum[0] += L.r;
			sum[1] += L.g;
			sum[2] += L.b;
			if (isfinite(t) && t > 0.0f)
				inv_t += 1.0 / (double)pm_fmaxf(t, j->r_min);
		}
	/* Cosine-distributed rays: E = pi * mean radiance. */
	nrays = j->k * j->k;
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
	return PM_OK;
}

bool
pm_icache_lookup(const struct pm_icache *c, float fx, float fy,
    struct pm_vec3 p, struct pm_vec3 n, struct pm_rgb *E)
{
	int gx0, gy0, gx, gy;
	double sum[3] = {0, 0, 0}, wsum = 0.0;
	float inv_a, min_cos;

	if (c == NULL || c->pt == NULL || !isfinite(fx) || !isfinite(fy))
		return false;
	inv_a = 1.0f / c->a;
	/* sqrt(1 - cos) alone must stay below a. */
	min_cos = 1.0f - c->a * c->a;
	gx0 = (int)floorf(fx / (float)c->step) - 1;
	gy0 = (int)floorf(fy / (float)c->step) - 1;
	for (gy = gy0; gy < gy0 + 4; gy++) {
		if (gy < 0 || gy >= c->gh)
			continue;
		for (gx = gx0; gx < gx0 + 4; gx++) {
			const struct pm_icache_point *q;
			struct pm_vec3 dv;
			float cosn, eps, w;

			if (gx < 0 || gx >= c->gw)
				continue;
			q = &c->pt[(size_t)gy * c->gw + gx];
			if (!q->valid)
				continue;
			cosn = pm_dot(n, q->n);
			if (cosn <= min_cos || cosn <= 0.0f)
				continue;
			dv = pm_sub(p, q->p);
			/* In front: the surface curves towards the point. */
			if (pm_dot(dv, pm_add(n, q->n)) * 0.5f * q->inv_r < -0.05f)
				continue;
			eps = pm_length(dv) * q->inv_r + sqrtf(pm_fmaxf(0.0f,
			    1.0f - cosn));
			if (!(eps < c->a))
				continue;
			w = eps > 1e-6f ? 1.0f / eps - inv_a : 1e6f;
			sum[0] += (double)w * q->E.r;
			sum[1] += (double)w * q->E.g;
			sum[2] += (double)w * q->E.b;
			wsum += w;
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
	c->pt = NULL;
}
