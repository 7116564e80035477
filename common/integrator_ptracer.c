/*
 * integrator_ptracer.c: Mitsuba 3's particle tracer (ptracer).  Paths
 * start at the lights as pm-shoot's photons do (shoot.c), and every vertex
 * is connected to the camera through a shadow ray; what arrives is
 * splatted onto the film through the reconstruction filter.  Lights seen
 * directly are sampled apart, a point on a light connected to the camera,
 * as Mitsuba's ptracer does.  Depths, Russian roulette and the shading
 * normal corrections (Veach 1997, p. 155) follow Mitsuba's.
 *
 * Light path i depends only on (seed, i), and splats land anywhere on the
 * film, so threads cannot own pixels as the camera pass does.  Each
 * thread splats into a film of its own in 64-bit fixed point (2^-32 of a
 * unit of radiance times samples per pixel); integer sums do not depend
 * on their order, so the films add up to the same bits whatever the
 * number of threads and however the paths were shared out.
 */
#include <math.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>

#include "camera.h"
#include "frame.h"
#include "render.h"
#include "shoot.h"
#include "texture.h"

/* Light paths per unit of work handed to a thread. */
#define CHUNK 4096
/* Fixed point: a splat value v is stored as round(v * FIX_ONE). */
#define FIX_ONE 4294967296.0
/* Light path i's random numbers: (seed, i, PTRACER_STREAM), apart from
 * the camera pass's (seed, pixel, sample) and the photons' passes. */
#define PTRACER_STREAM 0x70747261636572ULL
/* Stuck between mirrors: as shoot.c's photons. */
#define HARD_MAX_DEPTH 1000

struct job {
	const struct pm_render_ctx *ctx;
	const struct pm_camera *cam;
	const struct pm_render_opts *opts;
	struct pm_camera_rays rays;
	struct pm_shooter sh;
	/* Lights a camera can see: area lights and the environment. */
	int *visible;
	int nvisible;
	float a_px;		/* a pixel's area on the plane at z = 1
				 * (perspective, thinlens) or, orthographic,
				 * in world units */
	double splat_scale;	/* 1 / (width * height): per-path splats
				 * summed then divided by spp make the
				 * image */
	float filter_support;	/* pixels from the centre */
	float filter_norm;	/* 1D filter's integral */
	uint64_t npaths;
	long nchunks;
	_Atomic long next;
	_Atomic uint64_t dropped;
};

/* One thread's film and what it counted. */
struct film {
	int64_t *px;		/* 3 per pixel */
	uint64_t dropped;
};

/* The 1D reconstruction filter at offset x (pixels), unnormalised: the
 * densities the camera pass draws its offsets from (render.c). */
static float
filter_eval(const struct job *j, float x)
{
	float r = j->cam->filter_radius;

	x = fabsf(x);
	switch (j->cam->rfilter) {
	case PM_RFILTER_TENT:
		return x < r ? 1.0f - x / r : 0.0f;
	case PM_RFILTER_GAUSSIAN:
		return x <= 4.0f * r ? expf(-x * x / (2.0f * r * r)) : 0.0f;
	case PM_RFILTER_BOX:
		break;
	}
	return x < 0.5f ? 1.0f : 0.0f;
}

/* Adds v to one fixed-point channel, saturating (and counting) rather
 * than wrapping. */
static void
fix_add(struct film *f, int64_t *dst, double v)
{
	double q = v * FIX_ONE;
	int64_t s;

	if (!(fabs(q) < 9.0e18) ||
	    __builtin_add_overflow(*dst, (int64_t)llrint(q), &s)) {
		f->dropped++;
		return;
	}
	*dst = s;
}

/*
 * Splats value v at film position (fx, fy) (pixels from the top-left
 * corner) with the filter normalised to integrate to one, so that its
 * expectation over the film is the filtered pixel value the camera pass
 * estimates.
 */
static void
splat(const struct job *j, struct film *f, float fx, float fy, struct pm_rgb v)
{
	const int w = j->cam->width, h = j->cam->height;
	float R = j->filter_support, wx[64], wy[64];
	int x0, x1, y0, y1, x, y, nx, ny;

	if (!pm_rgb_is_finite(v)) {
		f->dropped++;
		return;
	}
	if (j->cam->rfilter == PM_RFILTER_BOX) {
		x = (int)floorf(fx);
		y = (int)floorf(fy);
		if (x >= 0 && x < w && y >= 0 && y < h) {
			int64_t *d = &f->px[3 * ((size_t)y * (size_t)w +
			    (size_t)x)];

			fix_add(f, &d[0], v.r * j->splat_scale);
			fix_add(f, &d[1], v.g * j->splat_scale);
			fix_add(f, &d[2], v.b * j->splat_scale);
		}
		return;
	}
	x0 = (int)ceilf(fx - R - 0.5f);
	x1 = (int)floorf(fx + R - 0.5f);
	y0 = (int)ceilf(fy - R - 0.5f);
	y1 = (int)floorf(fy + R - 0.5f);
	if (x0 < 0)
		x0 = 0;
	if (y0 < 0)
		y0 = 0;
	if (x1 > w - 1)
		x1 = w - 1;
	if (y1 > h - 1)
		y1 = h - 1;
	nx = x1 - x0 + 1;
	ny = y1 - y0 + 1;
	if (nx < 1 || ny < 1 || nx > 64 || ny > 64)
		return;
	for (x = 0; x < nx; x++)
		wx[x] = filter_eval(j, (float)(x0 + x) + 0.5f - fx) /
		    j->filter_norm;
	for (y = 0; y < ny; y++)
		wy[y] = filter_eval(j, (float)(y0 + y) + 0.5f - fy) /
		    j->filter_norm;
	for (y = 0; y < ny; y++)
		for (x = 0; x < nx; x++) {
			double k = (double)wx[x] * wy[y] * j->splat_scale;
			int64_t *d;

			if (k == 0.0)
				continue;
			d = &f->px[3 * ((size_t)(y0 + y) * (size_t)w +
			    (size_t)(x0 + x))];
			fix_add(f, &d[0], v.r * k);
			fix_add(f, &d[1], v.g * k);
			fix_add(f, &d[2], v.b * k);
		}
}

/* The camera as seen from a point (or, far, from a direction). */
struct conn {
	float fx, fy;			/* film position, pixels */
	float importance;		/* what multiplies the arriving
					 * radiance-like value: 1 / (pixel
					 * area cos^3 d^2) and its kin */
	struct pm_vec3 cam;		/* the camera point (lens, film) */
	struct pm_vec3 to_cam;		/* unit, from p towards cam */
	float dist;			/* from p to cam; INFINITY if far */
};

/*
 * Connects p to the camera (far: p is a unit direction from the camera
 * towards an infinitely distant point); (lu, lv) picks the thin lens's
 * point.  False if the camera cannot see p: behind it, outside the clip
 * range, or, orthographic, a direction.
 */
static bool
connect_camera(const struct job *j, struct pm_vec3 p, bool far, float lu,
    float lv, struct conn *c)
{
	const struct pm_camera_rays *r = &j->rays;
	float ix = 1.0f / pm_dot(r->dx, r->dx), iy = 1.0f / pm_dot(r->dy, r->dy);
	float iz = 1.0f / pm_dot(r->dz, r->dz);
	struct pm_vec3 v, q;
	float ax = 0.0f, ay = 0.0f, sx, sy, film_x, film_y, len, cos_t;

	if (r->type == PM_SENSOR_ORTHOGRAPHIC) {
		float t;

		if (far)
			return false;
		v = pm_sub(p, r->origin);
		q = pm_v3(pm_dot(v, r->dx) * ix, pm_dot(v, r->dy) * iy,
		    pm_dot(v, r->dz) * iz);
		t = (q.z - r->near_clip) * sqrtf(pm_dot(r->dz, r->dz));
		if (!(t > 0.0f) || t >= r->far_clip - r->near_clip)
			return false;
		sx = -q.x / r->tan_x;
		sy = q.y / r->tan_y;
		c->cam = pm_madd(pm_madd(pm_madd(r->origin, r->dx, q.x), r->dy,
		    q.y), r->dz, r->near_clip);
		c->to_cam = pm_neg(r->axis);
		c->dist = t;
		c->importance = 1.0f / j->a_px;
	} else {
		if (r->type == PM_SENSOR_THINLENS) {
			pm_square_to_disk(lu, lv, &ax, &ay);
			ax *= r->aperture_radius;
			ay *= r->aperture_radius;
		}
		c->cam = pm_madd(pm_madd(r->origin, r->dx, ax), r->dy, ay);
		v = far ? p : pm_sub(p, c->cam);
		q = pm_v3(pm_dot(v, r->dx) * ix, pm_dot(v, r->dy) * iy,
		    pm_dot(v, r->dz) * iz);
		if (far ? !(q.z > 0.0f) :
		    !(q.z > r->near_clip && q.z < r->far_clip))
			return false;
		film_x = q.x / q.z;
		film_y = q.y / q.z;
		if (r->type == PM_SENSOR_THINLENS) {
			/* Where the ray from the lens point meets the focal
			 * plane, seen through the pinhole. */
			film_x += ax / r->focus_distance;
			film_y += ay / r->focus_distance;
		}
		sx = -film_x / r->tan_x;
		sy = film_y / r->tan_y;
		len = pm_length(q);
		cos_t = q.z / len;
		c->dist = far ? INFINITY : pm_length(v);
		c->to_cam = far ? pm_neg(p) : pm_scale(v, -1.0f / c->dist);
		c->importance = 1.0f / (j->a_px * cos_t * cos_t * cos_t);
		if (!far)
			c->importance /= c->dist * c->dist;
	}
	c->fx = (sx + 1.0f) * 0.5f * (float)r->width;
	c->fy = (1.0f - sy) * 0.5f * (float)r->height;
	/* Beyond the film and its filter's reach nothing lands. */
	return c->fx > -j->filter_support - 1.0f &&
	    c->fx < (float)r->width + j->filter_support + 1.0f &&
	    c->fy > -j->filter_support - 1.0f &&
	    c->fy < (float)r->height + j->filter_support + 1.0f &&
	    isfinite(c->importance);
}

/* Whether anything blocks the segment from origin o (already offset off
 * its surface) to the camera. */
static bool
camera_blocked(const struct job *j, struct pm_vec3 o, const struct conn *c)
{
	return pm_accel_occluded(j->ctx->accel, o, c->to_cam, 0.0f,
	    isinf(c->dist) ? INFINITY : c->dist * (1.0f - 1e-4f));
}

/* A light that a camera may see, sampled and connected: area lights at a
 * point of their shape, the environment along a direction from the
 * camera (Mitsuba's sample_visible_emitters). */
static void
visible_emitter(const struct job *j, struct film *f, struct pm_rng *rng)
{
	const struct pm_scene *s = j->ctx->scene;
	float u0 = pm_rng_float(rng), u1 = pm_rng_float(rng);
	float u2 = pm_rng_float(rng), lu = pm_rng_float(rng);
	float lv = pm_rng_float(rng);
	int k = (int)(u0 * (float)j->nvisible), li;
	const struct pm_light *l;
	struct conn c;
	struct pm_rgb v;

	if (k >= j->nvisible)
		k = j->nvisible - 1;
	li = j->visible[k];
	l = &s->lights[li];
	if (l->type == PM_LIGHT_AREA) {
		struct pm_vec3 p, ng, ns;
		struct pm_hit lh;
		float cos_l;

		pm_shooter_shape_point(&j->sh, li, u1, u2, &p, &ng, &ns, &lh);
		if (!connect_camera(j, p, false, lu, lv, &c))
			return;
		cos_l = pm_dot(ng, c.to_cam);
		if (!(cos_l > 0.0f) || pm_dot(ns, c.to_cam) <= 0.0f)
			return;
		if (camera_blocked(j, pm_offset_origin(p, ng, c.to_cam), &c))
			return;
		/* Le cos / (p(light) p(point)), p(point) = 1 / area */
		lh.p = p;
		lh.ng = ng;
		lh.ns = ns;
		v = pm_rgb_scale(pm_area_emitted_at(s, l, &lh, c.to_cam), cos_l *
		    (float)l->area * (float)j->nvisible * c.importance);
	} else {
		struct pm_vec3 w;
		float pdf;

		if (l->type == PM_LIGHT_ENVMAP) {
			w = pm_envmap_sample(l->env, u1, u2, &pdf);
			if (!(pdf > 0.0f))
				return;
		} else {
			w = pm_square_to_uniform_sphere(u1, u2);
			pdf = pm_uniform_sphere_pdf();
		}
		if (!connect_camera(j, w, true, lu, lv, &c))
			return;
		/* From the camera's (lens) point on, past the near plane
		 * as camera rays start. */
		if (pm_accel_occluded(j->ctx->accel, c.cam, w,
		    j->rays.near_clip / pm_dot(w, j->rays.axis), INFINITY))
			return;
		v = pm_rgb_scale(l->type == PM_LIGHT_ENVMAP ?
		    pm_envmap_eval(l->env, w) : l->radiance,
		    (float)j->nvisible * c.importance / pdf);
	}
	splat(j, f, c.fx, c.fy, v);
}

/* Light path `index`: emitted, traced and connected at every vertex. */
static void
light_path(const struct job *j, struct film *f, uint64_t index)
{
	const struct pm_render_ctx *ctx = j->ctx;
	const struct pm_scene *s = ctx->scene;
	struct pm_rng rng = pm_rng_seed(j->opts->seed, index, PTRACER_STREAM);
	int max_depth = ctx->max_depth, depth = 1;
	struct pm_vec3 o, d;
	struct pm_rgb beta;
	struct pm_hit h;
	float eta = 1.0f;

	if (max_depth == 0)
		return;
	if (!ctx->hide_emitters && j->nvisible > 0)
		visible_emitter(j, f, &rng);
	if (!pm_shooter_emit(&j->sh, &rng, &o, &d, &beta))
		return;
	if (!pm_accel_intersect(ctx->accel, o, d, 0.0f, INFINITY, &h))
		return;
	while (max_depth < 0 || depth < max_depth) {
		struct pm_bsdf bt;
		struct pm_frame fr;
		/* the frame along dp/du where the BSDF needs one
		 * (anisotropic, normal and bump maps), as pm-shoot's */
		const struct pm_bsdf *b = pm_bsdf_frame_at(s, &h, d, &bt, &fr);
		struct pm_vec3 wi = pm_to_local(fr, pm_neg(d)), wo_w;
		float wi_ng = pm_dot(h.ng, pm_neg(d)), wo_ng, lu, lv;
		float u1, u2, u3, q;
		struct pm_bsdf_sample bs;
		struct conn c;

		lu = pm_rng_float(&rng);
		lv = pm_rng_float(&rng);
		if (!pm_bsdf_is_delta(b) && wi_ng * wi.z > 0.0f &&
		    connect_camera(j, h.p, false, lu, lv, &c)) {
			struct pm_vec3 wc = pm_to_local(fr, c.to_cam);
			float wc_ng = pm_dot(h.ng, c.to_cam);

			/* Light may leak through shading normals; the
			 * adjoint BSDF's correction for them. */
			if (wc_ng * wc.z > 0.0f && wc.z != 0.0f &&
			    !camera_blocked(j, pm_hit_origin(&h, c.to_cam),
			    &c)) {
				struct pm_rgb fv = pm_bsdf_eval(b, wi, wc,
				    PM_IMPORTANCE);
				float corr = fabsf(wi.z * wc_ng /
				    (wc.z * wi_ng));

				splat(j, f, c.fx, c.fy, pm_rgb_scale(
				    pm_rgb_mul(beta, fv), corr * c.importance));
			}
		}
		u1 = pm_rng_float(&rng);
		u2 = pm_rng_float(&rng);
		u3 = pm_rng_float(&rng);
		if (!pm_bsdf_sample(b, wi, u1, u2, u3, PM_IMPORTANCE, &bs))
			return;
		wo_w = pm_normalize(pm_to_world(fr, bs.wo));
		wo_ng = pm_dot(h.ng, wo_w);
		if (!(wi_ng * wi.z > 0.0f) || !(wo_ng * bs.wo.z > 0.0f))
			return;
		beta = pm_rgb_scale(pm_rgb_mul(beta, bs.weight),
		    fabsf(wi.z * wo_ng / (bs.wo.z * wi_ng)));
		eta *= bs.eta;
		if (!(pm_rgb_max(beta) > 0.0f))
			return;
		o = pm_hit_origin(&h, wo_w);
		d = wo_w;
		if (!pm_accel_intersect(ctx->accel, o, d, 0.0f, INFINITY, &h))
			return;
		depth++;
		if (depth >= HARD_MAX_DEPTH)
			return;
		if (depth > ctx->rr_depth) {
			q = pm_fminf(pm_rgb_max(beta) * eta * eta, 0.95f);
			if (!(pm_rng_float(&rng) < q))
				return;
			beta = pm_rgb_scale(beta, 1.0f / q);
		}
	}
}

struct worker_arg {
	struct job *j;
	struct film film;
};

static void *
worker(void *arg)
{
	struct worker_arg *wa = arg;
	struct job *j = wa->j;
	long c;

	while ((c = atomic_fetch_add(&j->next, 1)) < j->nchunks) {
		uint64_t i = (uint64_t)c * CHUNK, end = i + CHUNK;

		if (end > j->npaths)
			end = j->npaths;
		for (; i < end; i++)
			light_path(j, &wa->film, i);
		if (j->opts->tiles_done != NULL)
			atomic_fetch_add(j->opts->tiles_done, 1);
	}
	return NULL;
}

/* The filter's reach and its 1D integral, for splat's normalisation. */
static void
filter_setup(struct job *j)
{
	float r = j->cam->filter_radius;

	switch (j->cam->rfilter) {
	case PM_RFILTER_TENT:
		j->filter_support = r;
		j->filter_norm = r;
		break;
	case PM_RFILTER_GAUSSIAN:
		/* Truncated at 4 standard deviations, as render.c draws it. */
		j->filter_support = 4.0f * r;
		j->filter_norm = r * sqrtf(2.0f * PM_PI) *
		    erff(4.0f / sqrtf(2.0f));
		break;
	case PM_RFILTER_BOX:
	default:
		j->filter_support = 0.5f;
		j->filter_norm = 1.0f;
		break;
	}
}

enum pm_err
pm_ptracer_render(const struct pm_render_ctx *ctx, const struct pm_camera *cam,
    const struct pm_render_opts *opts, struct pm_image *out,
    struct pm_render_stats *stats, struct pm_error *err)
{
	const struct pm_scene *s = ctx->scene;
	struct job j;
	struct worker_arg *wa;
	pthread_t *tid;
	int i, nthreads = opts->threads < 1 ? 1 : opts->threads, started = 0;
	size_t npx, k;
	enum pm_err rc;

	if (cam->width < 1 || cam->height < 1 || opts->spp < 1)
		return pm_fail(err, PM_ERR_INVALID,
		    "image size and samples per pixel must be positive");
	if (s->nmedia > 0)
		return pm_fail(err, PM_ERR_UNSUPPORTED, "ptracer: the scene "
		    "has participating media, which Mitsuba's particle tracer "
		    "does not support either; use path");
	memset(&j, 0, sizeof(j));
	j.ctx = ctx;
	j.cam = cam;
	j.opts = opts;
	pm_camera_setup(&j.rays, cam);
	filter_setup(&j);
	if (!(j.filter_support < 31.0f))
		return pm_fail(err, PM_ERR_UNSUPPORTED, "ptracer: the "
		    "reconstruction filter reaches %g pixels; at most 31",
		    (double)j.filter_support);
	npx = (size_t)cam->width * (size_t)cam->height;
	j.npaths = (uint64_t)npx * (uint64_t)opts->spp;
	j.nchunks = (long)((j.npaths + CHUNK - 1) / CHUNK);
	j.splat_scale = 1.0 / (double)npx;
	if (cam->type == PM_SENSOR_ORTHOGRAPHIC)
		j.a_px = 4.0f * j.rays.tan_x * j.rays.tan_y *
		    pm_length(j.rays.dx) * pm_length(j.rays.dy) /
		    (float)npx;
	else
		j.a_px = 4.0f * j.rays.tan_x * j.rays.tan_y / (float)npx;
	atomic_init(&j.next, 0);
	atomic_init(&j.dropped, 0);
	if ((rc = pm_shooter_init(&j.sh, s, ctx->accel, ctx->lights, err)) !=
	    PM_OK)
		return rc;
	j.visible = calloc(s->nlights + 1, sizeof(*j.visible));
	tid = calloc((size_t)nthreads, sizeof(*tid));
	wa = calloc((size_t)nthreads, sizeof(*wa));
	if (j.visible == NULL || tid == NULL || wa == NULL) {
		rc = pm_fail(err, PM_ERR_NOMEM, "no memory for the particle "
		    "tracer");
		goto out;
	}
	for (k = 0; k < s->nlights; k++)
		if (s->lights[k].type == PM_LIGHT_AREA ||
		    s->lights[k].type == PM_LIGHT_CONSTANT ||
		    s->lights[k].type == PM_LIGHT_ENVMAP)
			j.visible[j.nvisible++] = (int)k;
	for (i = 0; i < nthreads; i++) {
		wa[i].j = &j;
		wa[i].film.px = calloc(3 * npx, sizeof(int64_t));
		if (wa[i].film.px == NULL) {
			rc = pm_fail(err, PM_ERR_NOMEM, "no memory for %d "
			    "films of %dx%d", nthreads, cam->width,
			    cam->height);
			goto out;
		}
	}
	if ((rc = pm_image_alloc(out, cam->width, cam->height, err)) != PM_OK)
		goto out;
	if (opts->tiles_total != NULL)
		atomic_store(opts->tiles_total, j.nchunks);
	/* The calling thread works too; if a thread cannot be started the
	 * others simply take more chunks. */
	for (i = 1; i < nthreads; i++)
		if (pthread_create(&tid[started], NULL, worker, &wa[i]) == 0)
			started++;
	worker(&wa[0]);
	for (i = 0; i < started; i++)
		pthread_join(tid[i], NULL);
	/* Integer sums: the same whatever the order. */
	for (i = 1; i < nthreads; i++) {
		for (k = 0; k < 3 * npx; k++) {
			int64_t t;

			if (__builtin_add_overflow(wa[0].film.px[k],
			    wa[i].film.px[k], &t))
				wa[0].film.dropped++;
			else
				wa[0].film.px[k] = t;
		}
		wa[0].film.dropped += wa[i].film.dropped;
	}
	for (k = 0; k < 3 * npx; k++)
		out->rgb[k] = (float)((double)wa[0].film.px[k] /
		    (FIX_ONE * (double)opts->spp));
	if (stats != NULL) {
		stats->samples = j.npaths;
		stats->dropped = wa[0].film.dropped;
	}
	rc = PM_OK;
out:
	for (i = 0; wa != NULL && i < nthreads; i++)
		free(wa[i].film.px);
	free(wa);
	free(tid);
	free(j.visible);
	pm_shooter_free(&j.sh);
	return rc;
}
