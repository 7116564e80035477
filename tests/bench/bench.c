/*
 * bench.c: the measurements behind `make bench` that pm's tools cannot
 * take themselves; tests/bench/bench.sh runs it and prints the table.
 *
 *   bench knn SHOT.pmap N K[,K...] QUERIES
 *	the first N photons of the global map of SHOT.pmap (as pm-shoot
 *	wrote them, unbalanced): pm_kdtree_build on one thread and on all,
 *	then for each K, pm_knn_check against FLANN on the same photons
 *	with K neighbours (all QUERIES as one batch to both, and pm's one
 *	call a query as well); prints one JSON object per K.  FLANN's
 *	build is timed twice: by pm_knn_check, on the photons in pm's tree
 *	order (which FLANN's splits find already sorted), and here on the
 *	file's order, the input pm's build gets (up to 2M photons; -1
 *	beyond).
 *   bench range SHOT.pmap N K[,K...] QUERIES
 *	fixed-radius queries (pm_kdtree_range_init/next, progressive
 *	passes) on the first N global photons, balanced: for each K, one
 *	radius, the median over the queries of the distance to the K-th
 *	nearest photon, and queries made as pm_knn_check's; prints one JSON
 *	object per K with queries per second, one thread.
 *   bench rays SCENE.xml SECONDS
 *	the ceiling for photon tracing: closest-hit Embree ray casts in a
 *	plain loop on one thread, from points on the scene's lights (or
 *	inside its bounds, without area lights) in cosine-distributed
 *	directions, so the rays are much like first photon bounces; prints
 *	one JSON object with rays per second.
 *   bench casts SCENE.xml PATHS
 *	how much of photon tracing is Embree's: the global pass of PATHS
 *	photon paths (pm_shoot in memory, one thread, seed 0, the scene's
 *	max_depth as pm-shoot turns it) with every ray it casts recorded,
 *	then, in turns, best of 3 each, the same pass again unrecorded and
 *	the recorded rays alone cast in the same order and the same calls
 *	(pm_accel_intersect, or pm_accel_intersect_n's packets, the hits
 *	filled in too); prints one JSON object with both times, the rays and
 *	the photons stored.  The bench links with --wrap for both functions
 *	(pipelines/bench.mk), so the rays are the library's very own, taken
 *	without a hook in it.
 *   bench crc
 *	pm_crc32's throughput on every path this CPU has (zlib, PCLMULQDQ,
 *	VPCLMULQDQ), on a 256 KiB buffer in cache and a 64 MiB one from
 *	memory, the paths in turns, best of 5 each; prints one JSON object
 *	per path and size with GB/s.
 *   bench sizes
 *	bytes of one photon record in memory.
 *
 * A bench, never a test: nothing here passes or fails on speed.
 */
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include <flann/flann.h>

#include "../../common/accel.h"
#include "../../common/kdtree.h"
#include "../../common/knn_check.h"
#include "../../common/rng.h"
#include "../../common/sampling.h"
#include "../../common/shoot.h"
#include "../../common/world.h"
#include "../../formats/crc32.h"
#include "../../formats/pmap.h"
#include "../../formats/scene_xml.h"
#include "range_queries.h"

static double
now(void)
{
	struct timespec ts;

	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* FLANN's exact single kd-tree (pm_knn_check's parameters) built on
 * p[0..n) in the given order, one thread; seconds, or -1 on failure. */
static double
flann_build_time(const struct pm_photon *p, size_t n)
{
	struct FLANNParameters fp = DEFAULT_FLANN_PARAMETERS;
	flann_index_t ix;
	float *pos = malloc(n * 3 * sizeof(*pos)), speedup;
	double t;
	size_t i;

	if (pos == NULL || n > INT_MAX) {
		free(pos);
		return -1.0;
	}
	for (i = 0; i < n; i++)
		memcpy(&pos[3 * i], p[i].pos, sizeof(p[i].pos));
	fp.algorithm = FLANN_INDEX_KDTREE_SINGLE;
	fp.checks = FLANN_CHECKS_UNLIMITED;
	fp.eps = 0.0f;
	fp.cores = 1;
	fp.leaf_max_size = 10;
	fp.log_level = FLANN_LOG_NONE;
	fp.random_seed = 1;
	flann_set_distance_type(FLANN_DIST_EUCLIDEAN, 0);
	t = now();
	ix = flann_build_index_float(pos, (int)n, 3, &speedup, &fp);
	t = now() - t;
	if (ix == NULL)
		t = -1.0;
	else
		flann_free_index_float(ix, &fp);
	free(pos);
	return t;
}

static int
bench_knn(const char *path, size_t n, const char *ks, size_t queries)
{
	struct pm_error err = {PM_OK, ""};
	struct pm_pmap pm;
	struct pm_map *m;
	struct pm_photon *p;
	struct pm_knn_check_result r;
	long threads = sysconf(_SC_NPROCESSORS_ONLN);
	double t1 = 0.0, tn = 0.0, b1 = 0.0, bn = 0.0, tf, fmax;
	int runs, i;
	const char *kp;
	size_t len = 0;

	if (pm_pmap_read(path, &pm, false, &err) != PM_OK) {
		fprintf(stderr, "bench: %s\n", err.msg);
		return 1;
	}
	m = pm_pmap_find(&pm, PM_MAP_GLOBAL);
	if (m == NULL || m->count < n) {
		fprintf(stderr, "bench: %s: fewer than %zu global photons\n", path, n);
		return 1;
	}
	p = malloc(n * sizeof(*p));
	if (p == NULL) {
		fprintf(stderr, "bench: out of memory\n");
		return 1;
	}
	/* One thread, then all, in turns, BENCH_SPEEDUP_RUNS times (3): the
	 * first pair against FLANN's one build each, the fastest of each
	 * side for the speed-up (one pair read 1.72x to 1.91x at one
	 * commit). */
	runs = getenv("BENCH_SPEEDUP_RUNS") != NULL ?
	    atoi(getenv("BENCH_SPEEDUP_RUNS")) : 3;
	if (runs < 1)
		runs = 1;
	for (i = 0; i < runs; i++) {
		double a, b;

		memcpy(p, m->photons, n * sizeof(*p));
		a = now();
		if (pm_kdtree_build(p, n, 1, &err) != PM_OK)
			goto fail;
		a = now() - a;
		memcpy(p, m->photons, n * sizeof(*p));
		b = now();
		if (pm_kdtree_build(p, n, threads < 1 ? 1 : (int)threads,
		    &err) != PM_OK)
			goto fail;
		b = now() - b;
		if (i == 0) {
			t1 = b1 = a;
			tn = bn = b;
		}
		b1 = a < b1 ? a : b1;
		bn = b < bn ? b : bn;
	}
	/* Not on 10M unless asked (BENCH_FLANN_FILE_ORDER_MAX photons, 2M
	 * unset): FLANN took 7 s to 27 s there, too much of the bench's
	 * two minutes. */
	fmax = getenv("BENCH_FLANN_FILE_ORDER_MAX") != NULL ?
	    strtod(getenv("BENCH_FLANN_FILE_ORDER_MAX"), NULL) : 2e6;
	tf = (double)n <= fmax ? flann_build_time(m->photons, n) : -1.0;
	for (kp = ks; *kp != '\0'; kp += kp[len] == ',' ? len + 1 : len) {
		size_t k = strtoull(kp, NULL, 10);

		len = strcspn(kp, ",");
		if (pm_knn_check(p, n, queries, k, 1, &r, &err) != PM_OK)
			goto fail;
		printf("{\"photons\": %zu, \"k\": %zu, \"queries\": %zu, "
		    "\"pm_build_s\": %.4f, \"pm_build_all_cores_s\": %.4f, "
		    "\"pm_build_best_s\": %.4f, "
		    "\"pm_build_all_cores_best_s\": %.4f, \"runs\": %d, "
		    "\"threads\": %ld, \"flann_build_s\": %.4f, "
		    "\"flann_build_file_order_s\": %.4f, "
		    "\"pm_qps\": %.1f, \"pm_qps_single\": %.1f, "
		    "\"flann_qps\": %.1f, "
		    "\"mismatches\": %zu, \"ties\": %zu}\n",
		    n, k, r.queries, t1, tn, b1, bn, runs, threads, r.flann_build_s, tf, r.pm_qps,
		    r.pm_qps_single, r.flann_qps, r.mismatches, r.ties);
		fflush(stdout);
	}
	free(p);
	pm_pmap_free(&pm);
	return 0;
fail:
	fprintf(stderr, "bench: %s\n", err.msg);
	free(p);
	pm_pmap_free(&pm);
	return 1;
}

static int
bench_range(const char *path, size_t n, const char *ks, size_t queries)
{
	struct pm_error err = {PM_OK, ""};
	struct pm_pmap pm;
	struct pm_map *m;
	struct pm_photon *p = NULL;
	struct pm_knn *nb = NULL;
	float *qp = NULL, *kd = NULL;
	const char *kp;
	size_t len = 0, j;
	int rc = 1;

	if (pm_pmap_read(path, &pm, false, &err) != PM_OK) {
		fprintf(stderr, "bench: %s\n", err.msg);
		return 1;
	}
	m = pm_pmap_find(&pm, PM_MAP_GLOBAL);
	if (m == NULL || m->count < n || n == 0 || queries == 0) {
		fprintf(stderr, "bench: %s: fewer than %zu global photons\n", path, n);
		goto out;
	}
	p = malloc(n * sizeof(*p));
	qp = malloc(queries * 3 * sizeof(*qp));
	kd = malloc(queries * sizeof(*kd));
	if (p == NULL || qp == NULL || kd == NULL) {
		fprintf(stderr, "bench: out of memory\n");
		goto out;
	}
	memcpy(p, m->photons, n * sizeof(*p));
	if (pm_kdtree_build(p, n, 1, &err) != PM_OK) {
		fprintf(stderr, "bench: %s\n", err.msg);
		goto out;
	}
	range_queries(m->photons, p, n, qp, queries);
	for (kp = ks; *kp != '\0'; kp += kp[len] == ',' ? len + 1 : len) {
		size_t k = strtoull(kp, NULL, 10), found = 0;
		struct pm_knn *t;
		double t0;
		float r2;

		len = strcspn(kp, ",");
		if (k == 0)
			continue;
		t = realloc(nb, k * sizeof(*nb));
		if (t == NULL) {
			fprintf(stderr, "bench: out of memory\n");
			goto out;
		}
		nb = t;
		r2 = range_radius2(p, n, qp, queries, k, nb, kd);
		t0 = now();
		for (j = 0; j < queries; j++) {
			struct pm_kd_range it;
			uint32_t idx;
			float d2;

			pm_kdtree_range_init(&it, p, n, &qp[3 * j], r2, 0, 0);
			while (pm_kdtree_range_next(&it, &idx, &d2))
				found++;
		}
		t0 = now() - t0;
		printf("{\"photons\": %zu, \"k\": %zu, \"queries\": %zu, "
		    "\"r2\": %.9g, \"found_per_query\": %.2f, "
		    "\"range_qps\": %.1f}\n", n, k, queries, r2,
		    (double)found / (double)queries, (double)queries / t0);
		fflush(stdout);
	}
	rc = 0;
out:
	free(p);
	free(qp);
	free(kd);
	free(nb);
	pm_pmap_free(&pm);
	return rc;
}

/* The library's pm_accel_intersect and pm_accel_intersect_n, unwrapped
 * (bench casts, below). */
bool __real_pm_accel_intersect(const struct pm_accel *a, struct pm_vec3 o,
    struct pm_vec3 d, float tmin, float tmax, struct pm_hit *h);
void __real_pm_accel_intersect_n(const struct pm_accel *a,
    const struct pm_ray *r, size_t n, struct pm_hit *h, bool *hit);

/* A point on one of the scene's emitting shapes: a ray cast from the
 * scene's centre towards a random direction finds the surfaces, and we
 * keep hits on emitters; fallback, points inside the bounds. */
static int
bench_rays(const char *path, double seconds)
{
	struct pm_error err = {PM_OK, ""};
	struct pm_scene scene;
	struct pm_accel *accel;
	struct pm_vec3 lo, hi, c, o[256], ng[256];
	size_t norig = 0, i;
	uint64_t rays = 0, hits = 0;
	double t0, t;

	if (pm_scene_load(path, NULL, 0, &scene, &err) != PM_OK ||
	    pm_accel_build(&scene, &accel, &err) != PM_OK) {
		fprintf(stderr, "bench: %s\n", err.msg);
		return 1;
	}
	pm_accel_bounds(accel, &lo, &hi);
	c = pm_scale(pm_add(lo, hi), 0.5f);
	for (i = 0; i < 100000 && norig < 256; i++) {
		struct pm_rng rng = pm_rng_seed(5, i, 0);
		struct pm_vec3 d = pm_square_to_uniform_sphere(pm_rng_float(&rng),
		    pm_rng_float(&rng));
		struct pm_hit h;

		if (__real_pm_accel_intersect(accel, c, d, 0.0f, INFINITY,
		    &h) && scene.shapes[h.shape].light >= 0) {
			o[norig] = h.p;
			ng[norig++] = pm_dot(h.ng, d) > 0 ? pm_neg(h.ng) : h.ng;
		}
	}
	t0 = now();
	do {
		for (i = 0; i < 4096; i++) {
			struct pm_rng rng = pm_rng_seed(9, rays, 0);
			struct pm_vec3 org, dir, l;
			struct pm_frame fr;
			struct pm_hit h;

			if (norig > 0) {
				size_t j = rays % norig;

				fr = pm_frame_from_normal(ng[j]);
				l = pm_square_to_cosine_hemisphere(pm_rng_float(&rng),
				    pm_rng_float(&rng));
				dir = pm_to_world(fr, l);
				org = pm_offset_origin(o[j], ng[j], dir);
			} else {
				org = pm_v3(lo.x + (hi.x - lo.x) * pm_rng_float(&rng),
				    lo.y + (hi.y - lo.y) * pm_rng_float(&rng),
				    lo.z + (hi.z - lo.z) * pm_rng_float(&rng));
				dir = pm_square_to_uniform_sphere(pm_rng_float(&rng),
				    pm_rng_float(&rng));
			}
			/* unwrapped: the ceiling pays no recording test */
			hits += __real_pm_accel_intersect(accel, org, dir, 0.0f,
			    INFINITY, &h);
			rays++;
		}
		t = now() - t0;
	} while (t < seconds);
	printf("{\"scene\": \"%s\", \"rays\": %llu, \"hits\": %llu, "
	    "\"seconds\": %.3f, \"rays_per_s\": %.1f, \"from_lights\": %s}\n",
	    path, (unsigned long long)rays, (unsigned long long)hits, t,
	    (double)rays / t, norig > 0 ? "true" : "false");
	pm_accel_free(accel);
	pm_scene_free(&scene);
	return 0;
}

/* pm_crc32 on each path in turns, on buffers in cache and from memory
 * (the same bytes and crc on every path, checked). */
static int
bench_crc(void)
{
	static const size_t size[2] = { (size_t)256 << 10, (size_t)64 << 20 };
	int widest = pm_crc32_path(), k, path, rep;
	unsigned char *b = malloc(size[1]);
	size_t i;

	if (b == NULL)
		return 1;
	for (i = 0; i < size[1]; i++)
		b[i] = (unsigned char)(i * 2654435761u >> 13);
	for (k = 0; k < 2; k++) {
		/* enough passes over the small buffer for a measurable time */
		int passes = k == 0 ? 2048 : 8;
		double best[3] = {INFINITY, INFINITY, INFINITY};
		uint32_t crc[3] = {0, 0, 0};

		for (rep = 0; rep < 5; rep++)
			for (path = 0; path <= widest; path++) {
				double t;
				uint32_t c = 0;
				int j;

				pm_crc32_limit(path);
				t = now();
				for (j = 0; j < passes; j++)
					c = pm_crc32(c, b, size[k]);
				t = now() - t;
				best[path] = t < best[path] ? t : best[path];
				crc[path] = c;
			}
		for (path = 0; path <= widest; path++)
			printf("{\"path\": %d, \"bytes\": %zu, \"gb_per_s\": %.2f, "
			    "\"same_crc\": %s}\n", path, size[k],
			    (double)size[k] * passes / best[path] * 1e-9,
			    crc[path] == crc[0] ? "true" : "false");
	}
	pm_crc32_limit(widest);
	free(b);
	return 0;
}

/*
 * pm_accel_intersect and pm_accel_intersect_n as the library's callers
 * reach them (the link's --wrap): while rec_on is set, each call's rays
 * are appended to rec, and the call to calls (a batch's size, or 0 for
 * one ray), before they are cast.  One thread only (bench casts shoots on
 * one).
 */
bool __wrap_pm_accel_intersect(const struct pm_accel *a, struct pm_vec3 o,
    struct pm_vec3 d, float tmin, float tmax, struct pm_hit *h);
void __wrap_pm_accel_intersect_n(const struct pm_accel *a,
    const struct pm_ray *r, size_t n, struct pm_hit *h, bool *hit);

static bool rec_on;
static struct pm_ray *rec;
static size_t nrec, caprec;
static uint32_t *calls;
static size_t ncalls, capcalls;

static void *
grow(void *p, size_t *cap, size_t need, size_t size)
{
	size_t c = *cap ? *cap : 1 << 20;

	while (c < need)
		c *= 2;
	if (c != *cap) {
		p = realloc(p, c * size);
		if (p == NULL) {
			fprintf(stderr, "bench: no memory to record rays\n");
			exit(1);
		}
		*cap = c;
	}
	return p;
}

static void
record(const struct pm_ray *r, size_t n, bool batch)
{
	rec = grow(rec, &caprec, nrec + n, sizeof(*rec));
	calls = grow(calls, &capcalls, ncalls + 1, sizeof(*calls));
	memcpy(rec + nrec, r, n * sizeof(*r));
	nrec += n;
	calls[ncalls++] = batch ? (uint32_t)n : 0;
}

bool
__wrap_pm_accel_intersect(const struct pm_accel *a, struct pm_vec3 o,
    struct pm_vec3 d, float tmin, float tmax, struct pm_hit *h)
{
	if (rec_on) {
		struct pm_ray r = { o, d, tmin, tmax };

		record(&r, 1, false);
	}
	return __real_pm_accel_intersect(a, o, d, tmin, tmax, h);
}

void
__wrap_pm_accel_intersect_n(const struct pm_accel *a, const struct pm_ray *r,
    size_t n, struct pm_hit *h, bool *hit)
{
	if (rec_on && n > 0)
		record(r, n, true);
	__real_pm_accel_intersect_n(a, r, n, h, hit);
}

static int
bench_casts(const char *path, uint64_t paths)
{
	struct pm_error err = {PM_OK, ""};
	struct pm_scene scene;
	struct pm_world world;
	struct pm_shooter sh;
	struct pm_shoot_opts so;
	struct pm_shoot_stats st;
	struct pm_photon_buf buf = {0};
	double shoot_s = INFINITY, casts_s = INFINITY, t;
	uint64_t hits = 0, stored;
	int turn;
	size_t i, k;

	if (pm_scene_load(path, NULL, 0, &scene, &err) != PM_OK)
		goto fail_scene;
	if (pm_world_init(&world, &scene, &err) != PM_OK)
		goto fail_world;
	if (pm_shooter_init(&sh, &scene, world.accel, &world.lights, &err) !=
	    PM_OK)
		goto fail_shooter;
	memset(&so, 0, sizeof(so));
	so.pass = PM_PASS_GLOBAL;
	so.count = paths;
	so.threads = 1;
	so.max_depth = pm_shoot_default_max_depth(&scene);	/* pm-shoot's */
	rec_on = true;
	if (pm_shoot(&sh, &so, &buf, &st, &err) != PM_OK)
		goto fail;
	rec_on = false;
	stored = st.stored;
	for (turn = 0; turn < 3; turn++) {
		buf.n = 0;	/* the capacity stays: no growth timed */
		t = now();
		if (pm_shoot(&sh, &so, &buf, &st, &err) != PM_OK)
			goto fail;
		t = now() - t;
		shoot_s = t < shoot_s ? t : shoot_s;
		if (st.stored != stored) {
			fprintf(stderr, "bench: %s: %llu photons, then %llu\n",
			    path, (unsigned long long)stored,
			    (unsigned long long)st.stored);
			return 1;
		}
		hits = 0;
		t = now();
		for (i = k = 0; i < ncalls; i++) {
			struct pm_hit h[256];
			bool f[256];
			size_t n = calls[i] ? calls[i] : 1, q;

			if (n > 256) {
				fprintf(stderr, "bench: a batch of %zu rays\n", n);
				return 1;
			}
			if (calls[i] == 0)
				f[0] = __real_pm_accel_intersect(world.accel,
				    rec[k].o, rec[k].d, rec[k].tmin, rec[k].tmax,
				    h);
			else
				__real_pm_accel_intersect_n(world.accel, rec + k,
				    n, h, f);
			for (q = 0; q < n; q++)
				hits += f[q];
			k += n;
		}
		t = now() - t;
		casts_s = t < casts_s ? t : casts_s;
	}
	printf("{\"scene\": \"%s\", \"paths\": %llu, \"rays\": %zu, "
	    "\"hits\": %llu, \"stored\": %llu, \"shoot_s\": %.4f, "
	    "\"casts_s\": %.4f}\n", path, (unsigned long long)paths, nrec,
	    (unsigned long long)hits, (unsigned long long)stored, shoot_s,
	    casts_s);
	pm_photon_buf_free(&buf);
	free(rec);
	free(calls);
	pm_shooter_free(&sh);
	pm_world_free(&world);
	pm_scene_free(&scene);
	return 0;
fail:
	pm_photon_buf_free(&buf);
	pm_shooter_free(&sh);
fail_shooter:
	pm_world_free(&world);
fail_world:
	pm_scene_free(&scene);
fail_scene:
	fprintf(stderr, "bench: %s: %s\n", path, err.msg);
	return 1;
}

int
main(int argc, char **argv)
{
	if (argc == 6 && strcmp(argv[1], "knn") == 0)
		return bench_knn(argv[2], strtoull(argv[3], NULL, 10), argv[4],
		    strtoull(argv[5], NULL, 10));
	if (argc == 6 && strcmp(argv[1], "range") == 0)
		return bench_range(argv[2], strtoull(argv[3], NULL, 10), argv[4],
		    strtoull(argv[5], NULL, 10));
	if (argc == 4 && strcmp(argv[1], "rays") == 0)
		return bench_rays(argv[2], strtod(argv[3], NULL));
	if (argc == 4 && strcmp(argv[1], "casts") == 0)
		return bench_casts(argv[2], strtoull(argv[3], NULL, 10));
	if (argc == 2 && strcmp(argv[1], "crc") == 0)
		return bench_crc();
	if (argc == 2 && strcmp(argv[1], "sizes") == 0) {
		printf("{\"photon_bytes_in_memory\": %zu}\n",
		    sizeof(struct pm_photon));
		return 0;
	}
	fprintf(stderr, "usage: bench knn SHOT.pmap N K[,K...] QUERIES | "
	    "bench range SHOT.pmap N K[,K...] QUERIES | "
	    "bench rays SCENE.xml SECONDS | bench casts SCENE.xml PATHS | "
	    "bench crc | bench sizes\n");
	return 2;
}
