/*
 * render.c: the camera pass.  Threads take 8x8 tiles from a shared atomic
 * counter, so a costly region (glass, the bunny) never leaves a thread
 * idle while another grinds through a fixed half of the image.  Each pixel
 * writes only its own slot, and its random numbers depend only on (seed,
 * pixel, sample), so the result does not depend on the thread count.
 * The path tracer takes a tile's samples in batches (render_tile_paths),
 * whose rays go to Embree in packets.
 */
#include <math.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>

#include "render.h"

#define TILE PM_RENDER_TILE

/*
 * What a watcher sees of the running render: the image and one flag per
 * tile, set (release) by the worker that finished it, so that a watcher
 * that reads a set flag (acquire) also sees the tile's pixels.  The lock
 * only keeps the render from starting or ending under a snapshot; the
 * workers never take it.
 */
struct pm_render_watch {
	pthread_mutex_t lock;
	const struct pm_image *film;	/* NULL: no render running */
	_Atomic unsigned char *done;	/* one flag per tile */
	int tiles_x, ntiles;
};

struct job {
	const struct pm_render_ctx *ctx;
	const struct pm_camera *cam;
	const struct pm_render_opts *opts;
	struct pm_camera_rays rays;
	struct pm_image *out;
	int tiles_x, ntiles;
	_Atomic int next;
	_Atomic uint64_t dropped;
	bool moments;			/* opts' moment images are filled */
};

/* Offset from the pixel centre drawn from the reconstruction filter, so
 * that the plain mean of the samples equals the filtered pixel value; u
 * in [0, 1) picks it (stratified by the caller), rng serves rejection. */
static float
filter_offset(enum pm_rfilter f, float radius, float u, struct pm_rng *rng)
{
	switch (f) {
	case PM_RFILTER_TENT:
		return u < 0.5f ? radius * (sqrtf(2.0f * u) - 1.0f) :
		    radius * (1.0f - sqrtf(2.0f - 2.0f * u));
	case PM_RFILTER_GAUSSIAN:
		/* Truncated at four standard deviations, as Mitsuba's filter. */
		for (;;) {
			float u2 = pm_rng_float(rng);
			float x = radius * sqrtf(-2.0f * logf(1.0f - u)) *
			    cosf(2.0f * PM_PI * u2);

			if (fabsf(x) <= 4.0f * radius)
				return x;
			u = pm_rng_float(rng);
		}
	case PM_RFILTER_BOX:
		break;
	}
	return u - 0.5f;
}

/* At most this many light cells a side (the first LIGHT_STRATA^2 samples
 * of a pixel); beyond, independent samples are as good. */
#define LIGHT_STRATA 32

/* CIE XYZ of linear sRGB, the matrix Mitsuba's moment integrator applies
 * to an RGB render's samples. */
static const double srgb_to_xyz[3][3] = {
	{ 0.412453, 0.357580, 0.180423 },
	{ 0.212671, 0.715160, 0.072169 },
	{ 0.019334, 0.119193, 0.950227 },
};

/* Adds sample L to a pixel's sums of XYZ (m[0..2]) and of their squares
 * (m[3..5]), for the moment integrator. */
static void
moment_add(double m[6], struct pm_rgb L)
{
	int c;

	for (c = 0; c < 3; c++) {
		double v = srgb_to_xyz[c][0] * L.r + srgb_to_xyz[c][1] * L.g +
		    srgb_to_xyz[c][2] * L.b;

		m[c] += v;
		m[3 + c] += v * v;
	}
}

/* Stores pixel pix's moments, the sums m over spp samples. */
static void
moment_store(const struct job *j, size_t pix, const double m[6], int spp)
{
	float *d1 = &j->opts->moment1->rgb[3 * pix];
	float *d2 = &j->opts->moment2->rgb[3 * pix];
	int c;

	for (c = 0; c < 3; c++) {
		d1[c] = (float)(m[c] / spp);
		d2[c] = (float)(m[3 + c] / spp);
	}
}

/* How a tile's pixels stratify their samples (see render_tile). */
struct strata {
	int kx, ky;			/* film cells */
	int lx, ly;			/* light cells */
	uint16_t cell[LIGHT_STRATA * LIGHT_STRATA];	/* this pixel's shuffle */
};

/* The light cells of pixel pix, shuffled. */
static void
pixel_cells(const struct job *j, uint64_t pix, struct strata *st)
{
	struct pm_rng prng = pm_rng_seed(j->opts->seed, pix, UINT64_MAX);
	int i;

	for (i = 0; i < st->lx * st->ly; i++) {
		int r = (int)(pm_rng_u32(&prng) % (uint32_t)(i + 1));

		st->cell[i] = st->cell[r];
		st->cell[r] = (uint16_t)i;
	}
}

/* Where sample i of pixel (x, y) falls: its film position (cs->fx, fy),
 * its lens numbers (*lu, *lv), its random numbers (*rng, to go on with
 * along the path) and what else the photon render needs of it (*cs). */
static void
camera_film(const struct job *j, const struct strata *st, int x, int y,
    int i, float *plu, float *plv, struct pm_camera_sample *cs,
    struct pm_rng *rng)
{
	const struct pm_camera *cam = j->cam;
	uint64_t pix = (uint64_t)y * (uint64_t)cam->width + (uint64_t)x;
	float ux, uy, fx, fy, lu = 0.5f, lv = 0.5f;
	int kx = st->kx, ky = st->ky, lx = st->lx, ly = st->ly;

	*rng = pm_rng_seed(j->opts->seed, pix, (uint64_t)i);
	ux = pm_rng_float(rng);
	uy = pm_rng_float(rng);
	cs->lu[0] = cs->lu[1] = -1.0f;
	if (i < kx * ky) {
		ux = ((float)(i % kx) + ux) / (float)kx;
		uy = ((float)(i / kx) + uy) / (float)ky;
	}
	if (i < lx * ly) {
		/* its own stream, so that the path's numbers stay as they
		 * were */
		struct pm_rng lr = pm_rng_seed(j->opts->seed, pix,
		    UINT64_MAX - 1 - (uint64_t)i);

		cs->lu[0] = ((float)(st->cell[i] % lx) + pm_rng_float(&lr)) /
		    (float)lx;
		cs->lu[1] = ((float)(st->cell[i] / lx) + pm_rng_float(&lr)) /
		    (float)ly;
	}
	fx = (float)x + 0.5f + filter_offset(cam->rfilter, cam->filter_radius,
	    ux, rng);
	fy = (float)y + 0.5f + filter_offset(cam->rfilter, cam->filter_radius,
	    uy, rng);
	/* A thin lens's aperture point: two more numbers of the sample's
	 * own stream, drawn only for such cameras so that other images stay
	 * as they were. */
	if (pm_camera_needs_lens(&j->rays)) {
		lu = pm_rng_float(rng);
		lv = pm_rng_float(rng);
	}
	cs->fx = fx;
	cs->fy = fy;
	*plu = lu;
	*plv = lv;
}

/* The camera ray of sample i of pixel (x, y), and what camera_film gives. */
static void
camera_sample(const struct job *j, const struct strata *st, int x, int y,
    int i, struct pm_vec3 *o, struct pm_vec3 *d, float *tmin, float *tmax,
    struct pm_camera_sample *cs, struct pm_rng *rng)
{
	float lu, lv;

	camera_film(j, st, x, y, i, &lu, &lv, cs, rng);
	*d = pm_camera_ray(&j->rays, cs->fx, cs->fy, lu, lv, o, tmin, tmax);
}

/* Samples path-traced together (pm_path_li_batch): 256 rather than 64,
 * so that a round's later bounces, when few paths are left, still fill
 * whole packets, and its fixed costs are paid a quarter as often
 * (cornell-box 1.02-1.03x, caustics 1.04x, stop 35). */
#define PATH_CHUNK 256
/* Camera rays the photon render casts together (render_tile_photon):
 * its paths go on one at a time, and 256 were no faster than 64. */
#define CAMERA_CHUNK 64
_Static_assert(CAMERA_CHUNK <= PATH_CHUNK, "chunk_rays holds either");

/* The camera rays of a chunk's n film positions and lens numbers, in
 * SIMD lanes (pm_camera_rays_n). */
static void
chunk_rays(const struct job *j, const float *fx, const float *fy,
    const float *lu, const float *lv, int n, struct pm_ray *ray)
{
	struct pm_vec3 o[PATH_CHUNK], d[PATH_CHUNK];
	float tmin[PATH_CHUNK], tmax[PATH_CHUNK];
	int k;

	pm_camera_rays_n(&j->rays, fx, fy, lu, lv, (size_t)n, o, d, tmin,
	    tmax);
	for (k = 0; k < n; k++) {
		ray[k].o = o[k];
		ray[k].d = d[k];
		ray[k].tmin = tmin[k];
		ray[k].tmax = tmax[k];
	}
}

/* A chunked tile's sums: per pixel of the tile, the radiance and (with
 * moments) its moments, and the samples dropped as non-finite. */
struct tile_acc {
	double acc[TILE * TILE][3], mom[TILE * TILE][6];
	uint64_t dropped;
};

static void
tile_acc_init(const struct job *j, struct tile_acc *t)
{
	memset(t->acc, 0, sizeof(t->acc));
	if (j->moments)
		memset(t->mom, 0, sizeof(t->mom));
	t->dropped = 0;
}

static inline void
tile_acc_add(const struct job *j, struct tile_acc *t, int slot,
    struct pm_rgb L)
{
	if (!pm_rgb_is_finite(L)) {
		t->dropped++;
		return;
	}
	t->acc[slot][0] += L.r;
	t->acc[slot][1] += L.g;
	t->acc[slot][2] += L.b;
	if (j->moments)
		moment_add(t->mom[slot], L);
}

/* The tile's pixels into the image; dropped samples count as zero, as
 * in render_tile. */
static void
tile_acc_store(struct job *j, const struct tile_acc *t, int x0, int y0,
    int x1, int y1)
{
	const struct pm_camera *cam = j->cam;
	int spp = j->opts->spp, x, y;

	for (y = y0; y < y1; y++) {
		for (x = x0; x < x1; x++) {
			size_t pix = (size_t)y * (size_t)cam->width + (size_t)x;
			float *dst = &j->out->rgb[3 * pix];
			int slot = (y - y0) * TILE + (x - x0);
			const double *a = t->acc[slot];

			dst[0] = (float)(a[0] / spp);
			dst[1] = (float)(a[1] / spp);
			dst[2] = (float)(a[2] / spp);
			if (j->moments)
				moment_store(j, pix, t->mom[slot], spp);
		}
	}
	if (t->dropped)
		atomic_fetch_add(&j->dropped, t->dropped);
}

/* render_tile for the path tracer: the tile's samples, in the order
 * render_tile takes them, go to pm_path_li_batch in chunks, and each
 * pixel sums its own in sample order, so the image is the same bit for
 * bit. */
static void
render_tile_paths(struct job *j, struct strata *st, int x0, int y0, int x1,
    int y1)
{
	struct pm_path_sample smp[PATH_CHUNK];
	uint16_t slot[PATH_CHUNK];
	float fx[PATH_CHUNK], fy[PATH_CHUNK], lu[PATH_CHUNK], lv[PATH_CHUNK];
	struct pm_ray ray[PATH_CHUNK];
	struct tile_acc t;
	int spp = j->opts->spp, x, y, i, n = 0, k;

	tile_acc_init(j, &t);
	for (y = y0; y < y1; y++) {
		for (x = x0; x < x1; x++) {
			for (i = 0; i < spp; i++) {
				struct pm_camera_sample cs;

				camera_film(j, st, x, y, i, &lu[n], &lv[n], &cs,
				    &smp[n].rng);
				fx[n] = cs.fx;
				fy[n] = cs.fy;
				slot[n] = (uint16_t)((y - y0) * TILE + (x - x0));
				if (++n < PATH_CHUNK &&
				    !(y == y1 - 1 && x == x1 - 1 && i == spp - 1))
					continue;
				chunk_rays(j, fx, fy, lu, lv, n, ray);
				for (k = 0; k < n; k++) {
					smp[k].o = ray[k].o;
					smp[k].d = ray[k].d;
					smp[k].tmin = ray[k].tmin;
					smp[k].tmax = ray[k].tmax;
				}
				pm_path_li_batch(j->ctx, smp, (size_t)n);
				for (k = 0; k < n; k++)
					tile_acc_add(j, &t, slot[k], smp[k].L);
				n = 0;
			}
		}
	}
	tile_acc_store(j, &t, x0, y0, x1, y1);
}

/*
 * render_tile for the photon render in a scene without media: the
 * camera rays of up to CAMERA_CHUNK of the tile's samples, in render_tile's
 * order, find their first hits together (Embree packets; coherent rays,
 * which packets cast fastest), and each sample's path goes on from its
 * hit one at a time (pm_photon_li_px_hit) in the same order as before,
 * each pixel summing its own in sample order: the same image bit for
 * bit.
 */
static void
render_tile_photon(struct job *j, struct strata *st, int x0, int y0, int x1,
    int y1)
{
	const struct pm_camera *cam = j->cam;
	struct pm_ray ray[CAMERA_CHUNK];
	struct pm_camera_sample cs[CAMERA_CHUNK];
	struct pm_rng rng[CAMERA_CHUNK];
	struct pm_hit hit[CAMERA_CHUNK];
	bool hitf[CAMERA_CHUNK];
	uint16_t slot[CAMERA_CHUNK];
	float fx[CAMERA_CHUNK], fy[CAMERA_CHUNK];
	float lu[CAMERA_CHUNK], lv[CAMERA_CHUNK];
	struct tile_acc t;
	int spp = j->opts->spp, x, y, i, n = 0, k;

	tile_acc_init(j, &t);
	for (y = y0; y < y1; y++) {
		for (x = x0; x < x1; x++) {
			pixel_cells(j, (uint64_t)y * (uint64_t)cam->width +
			    (uint64_t)x, st);
			for (i = 0; i < spp; i++) {
				camera_film(j, st, x, y, i, &lu[n], &lv[n], &cs[n],
				    &rng[n]);
				fx[n] = cs[n].fx;
				fy[n] = cs[n].fy;
				slot[n] = (uint16_t)((y - y0) * TILE + (x - x0));
				if (++n < CAMERA_CHUNK &&
				    !(y == y1 - 1 && x == x1 - 1 && i == spp - 1))
					continue;
				chunk_rays(j, fx, fy, lu, lv, n, ray);
				pm_accel_intersect_n(j->ctx->accel, ray, (size_t)n,
				    hit, hitf);
				for (k = 0; k < n; k++)
					tile_acc_add(j, &t, slot[k],
					    pm_photon_li_px_hit(j->ctx, ray[k].o,
					    ray[k].d, ray[k].tmin, ray[k].tmax,
					    &cs[k], &rng[k], hitf[k], &hit[k]));
				n = 0;
			}
		}
	}
	tile_acc_store(j, &t, x0, y0, x1, y1);
}

static void
render_tile(struct job *j, int tile)
{
	const struct pm_camera *cam = j->cam;
	int x0 = (tile % j->tiles_x) * TILE, y0 = (tile / j->tiles_x) * TILE;
	int x1 = x0 + TILE < cam->width ? x0 + TILE : cam->width;
	int y1 = y0 + TILE < cam->height ? y0 + TILE : cam->height;
	int spp = j->opts->spp, x, y, i, kx, ky;
	struct strata st;
	uint64_t dropped = 0;

	/* The first kx x ky samples of a pixel are stratified over its
	 * filter (jittered: one per cell of a kx x ky grid, k x k or
	 * (k + 1) x k, the largest within spp), the rest independent: an
	 * edge or a small bright light inside the pixel is then covered in
	 * proportion, not by chance.  Each sample still depends only on
	 * (seed, pixel, sample index). */
	for (ky = 1; (ky + 1) * (ky + 1) <= spp; ky++)
		;
	kx = (ky + 1) * ky <= spp ? ky + 1 : ky;
	st.kx = kx;
	st.ky = ky;
	/* The first light sample of those samples is stratified the same
	 * way over the light, in cells shuffled per pixel so that the
	 * light's cell does not follow the film's. */
	st.lx = kx < LIGHT_STRATA ? kx : LIGHT_STRATA;
	st.ly = ky < LIGHT_STRATA ? ky : LIGHT_STRATA;
	if (j->opts->method == PM_METHOD_PATH) {
		/* the path tracer draws its light samples from the path's
		 * own stream and never reads the light cells: no cells, so
		 * that no pixel shuffles them and no sample seeds their
		 * stream */
		st.lx = st.ly = 0;
		render_tile_paths(j, &st, x0, y0, x1, y1);
		return;
	}
	if (j->opts->method == PM_METHOD_PHOTON && j->ctx->scene->nmedia == 0) {
		render_tile_photon(j, &st, x0, y0, x1, y1);
		return;
	}
	for (y = y0; y < y1; y++) {
		for (x = x0; x < x1; x++) {
			uint64_t pix = (uint64_t)y * (uint64_t)cam->width + (uint64_t)x;
			double acc[3] = {0, 0, 0}, mom[6] = {0, 0, 0, 0, 0, 0};
			float *dst = &j->out->rgb[3 * pix];

			pixel_cells(j, pix, &st);
			for (i = 0; i < spp; i++) {
				struct pm_camera_sample cs;
				struct pm_rng rng;
				float tmin, tmax;
				struct pm_vec3 o, d;
				struct pm_rgb L;

				camera_sample(j, &st, x, y, i, &o, &d, &tmin, &tmax,
				    &cs, &rng);
				L = j->opts->method == PM_METHOD_PHOTON ?
				    pm_photon_li_px(j->ctx, o, d, tmin, tmax, &cs,
				    &rng) :
				    pm_path_li(j->ctx, o, d, tmin, tmax, &rng);
				if (!pm_rgb_is_finite(L)) {
					dropped++;
					continue;
				}
				acc[0] += L.r;
				acc[1] += L.g;
				acc[2] += L.b;
				if (j->moments)
					moment_add(mom, L);
			}
			/* Dropped samples count as zero: dividing by the kept
			 * count instead would bias the pixel upwards. */
			dst[0] = (float)(acc[0] / spp);
			dst[1] = (float)(acc[1] / spp);
			dst[2] = (float)(acc[2] / spp);
			if (j->moments)
				moment_store(j, (size_t)pix, mom, spp);
		}
	}
	if (dropped)
		atomic_fetch_add(&j->dropped, dropped);
}

struct pm_render_watch *
pm_render_watch_new(void)
{
	struct pm_render_watch *w = calloc(1, sizeof(*w));

	if (w != NULL && pthread_mutex_init(&w->lock, NULL) != 0) {
		free(w);
		w = NULL;
	}
	return w;
}

void
pm_render_watch_free(struct pm_render_watch *w)
{
	if (w == NULL)
		return;
	pthread_mutex_destroy(&w->lock);
	free(w);
}

/* Shows film to the watcher, every tile unfinished; false when out of
 * memory. */
static bool
watch_begin(struct pm_render_watch *w, const struct pm_image *film,
    int tiles_x, int ntiles)
{
	_Atomic unsigned char *done = calloc((size_t)ntiles, sizeof(*done));
	int i;

	if (done == NULL)
		return false;
	for (i = 0; i < ntiles; i++)
		atomic_init(&done[i], 0);
	pthread_mutex_lock(&w->lock);
	w->film = film;
	w->done = done;
	w->tiles_x = tiles_x;
	w->ntiles = ntiles;
	pthread_mutex_unlock(&w->lock);
	return true;
}

static void
watch_end(struct pm_render_watch *w)
{
	pthread_mutex_lock(&w->lock);
	free(w->done);
	w->done = NULL;
	w->film = NULL;
	pthread_mutex_unlock(&w->lock);
}

bool
pm_render_snapshot(struct pm_render_watch *w, struct pm_image *im)
{
	const struct pm_image *f;
	int t, y, x0, x1, y0, y1;
	bool ok = false;

	pthread_mutex_lock(&w->lock);
	f = w->film;
	if (f == NULL)
		goto out;
	if (im->rgb == NULL || im->width != f->width ||
	    im->height != f->height) {
		struct pm_error err;

		pm_image_free(im);
		if (pm_image_alloc(im, f->width, f->height, &err) != PM_OK)
			goto out;
	}
	for (t = 0; t < w->ntiles; t++) {
		bool done = atomic_load_explicit(&w->done[t],
		    memory_order_acquire) != 0;

		x0 = (t % w->tiles_x) * TILE;
		y0 = (t / w->tiles_x) * TILE;
		x1 = x0 + TILE < f->width ? x0 + TILE : f->width;
		y1 = y0 + TILE < f->height ? y0 + TILE : f->height;
		for (y = y0; y < y1; y++) {
			size_t off = 3 * ((size_t)y * (size_t)f->width +
			    (size_t)x0), n = 3 * (size_t)(x1 - x0) *
			    sizeof(float);

			if (done)
				memcpy(im->rgb + off, f->rgb + off, n);
			else
				memset(im->rgb + off, 0, n);
		}
	}
	ok = true;
out:
	pthread_mutex_unlock(&w->lock);
	return ok;
}

/* Frees what pm_render allocated for a render that failed. */
static void
free_outputs(struct pm_image *out, const struct pm_render_opts *opts)
{
	pm_image_free(out);
	if (opts->moment1 != NULL && opts->moment2 != NULL) {
		pm_image_free(opts->moment1);
		pm_image_free(opts->moment2);
	}
}

static void *
worker(void *arg)
{
	struct job *j = arg;
	int t;

	while ((t = atomic_fetch_add(&j->next, 1)) < j->ntiles) {
		render_tile(j, t);
		if (j->opts->watch != NULL)
			atomic_store_explicit(&j->opts->watch->done[t], 1,
			    memory_order_release);
		if (j->opts->tiles_done != NULL)
			atomic_fetch_add(j->opts->tiles_done, 1);
	}
	return NULL;
}

enum pm_err
pm_render(const struct pm_render_ctx *ctx, const struct pm_camera *cam,
    const struct pm_render_opts *opts, struct pm_image *out,
    struct pm_render_stats *stats, struct pm_error *err)
{
	struct job j;
	struct pm_render_ctx cctx = *ctx;
	struct pm_icache cache = {0, 0, 0, 0.0f, NULL, NULL};
	pthread_t *tid;
	int i, nthreads = opts->threads < 1 ? 1 : opts->threads, started = 0;
	enum pm_err rc;

	if (opts->method == PM_METHOD_PTRACER)
		return pm_ptracer_render(ctx, cam, opts, out, stats, err);
	if (cam->width < 1 || cam->height < 1 || opts->spp < 1)
		return pm_fail(err, PM_ERR_INVALID,
		    "image size and samples per pixel must be positive");
	rc = pm_image_alloc(out, cam->width, cam->height, err);
	if (rc != PM_OK)
		return rc;
	if (opts->moment1 != NULL && opts->moment2 != NULL) {
		if ((rc = pm_image_alloc(opts->moment1, cam->width, cam->height,
		    err)) != PM_OK) {
			pm_image_free(out);
			return rc;
		}
		if ((rc = pm_image_alloc(opts->moment2, cam->width, cam->height,
		    err)) != PM_OK) {
			pm_image_free(opts->moment1);
			pm_image_free(out);
			return rc;
		}
	}
	j.ctx = &cctx;
	j.moments = opts->moment1 != NULL && opts->moment2 != NULL;
	j.cam = cam;
	j.opts = opts;
	j.out = out;
	pm_camera_setup(&j.rays, cam);
	j.tiles_x = (cam->width + TILE - 1) / TILE;
	j.ntiles = j.tiles_x * ((cam->height + TILE - 1) / TILE);
	atomic_init(&j.next, 0);
	atomic_init(&j.dropped, 0);
	/* Indirect light on the surfaces seen, gathered once on a grid. */
	if (opts->method == PM_METHOD_PHOTON && ctx->maps != NULL &&
	    ctx->maps->final_gather && ctx->maps->icache_step != 0) {
		int rays = ctx->maps->icache_rays;
		int step = ctx->maps->icache_step;

		if (rays <= 0)
			rays = pm_icache_default_rays(opts->spp);
		if (step < 0)
			step = pm_icache_default_step(opts->spp, rays);
		rc = pm_icache_build(&cache, ctx, &j.rays, step,
		    rays, ctx->maps->icache_a, opts->seed, nthreads, err);
		if (rc != PM_OK) {
			free_outputs(out, opts);
			return rc;
		}
		cctx.icache = &cache;
	}
	if (opts->tiles_total != NULL)
		atomic_store(opts->tiles_total, j.ntiles);

	tid = calloc((size_t)nthreads, sizeof(*tid));
	if (tid == NULL) {
		pm_icache_free(&cache);
		free_outputs(out, opts);
		return pm_fail(err, PM_ERR_NOMEM, "no memory for threads");
	}
	if (opts->watch != NULL && !watch_begin(opts->watch, out, j.tiles_x,
	    j.ntiles)) {
		free(tid);
		free_outputs(out, opts);
		return pm_fail(err, PM_ERR_NOMEM, "no memory for the watch");
	}
	/* The calling thread works too; if a thread cannot be started the
	 * others simply take more tiles. */
	for (i = 1; i < nthreads; i++)
		if (pthread_create(&tid[i], NULL, worker, &j) == 0)
			tid[started++] = tid[i];
	worker(&j);
	for (i = 0; i < started; i++)
		pthread_join(tid[i], NULL);
	free(tid);
	pm_icache_free(&cache);
	if (opts->watch != NULL)
		watch_end(opts->watch);
	if (stats != NULL) {
		stats->samples = (uint64_t)cam->width * (uint64_t)cam->height *
		    (uint64_t)opts->spp;
		stats->dropped = atomic_load(&j.dropped);
	}
	return PM_OK;
}
