/*
 * test_knn_check.c: FLANN, configured as pm_knn_check configures it, is
 * exact (its k nearest equal brute force), and pm_knn_check finds no
 * mismatch between pm's tree and FLANN on 100k photons, on duplicate-
 * riddled data and on tiny sets, while it does find them in a damaged
 * tree; it rejects k = 0 and returns nothing to compare for no photons.
 */
#include <limits.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>
#include <flann/flann.h>

#include "../../common/kdtree.h"
#include "../../common/knn_check.h"
#include "../../common/rng.h"

static float
dist2(const float p[3], const float q[3])
{
	float dx = p[0] - q[0], dy = p[1] - q[1], dz = p[2] - q[2];

	return dx * dx + dy * dy + dz * dz;
}

/*
 * Photons clustered on surfaces, as a photon map's are: four walls of a
 * unit box (denser towards one corner) and a sphere; with dup, every
 * position appears twice, so that ties at the k-th distance are common.
 */
static struct pm_photon *
make_photons(size_t n, uint64_t seed, int dup)
{
	struct pm_photon *p = calloc(n ? n : 1, sizeof(*p));
	size_t i;

	assert_non_null(p);
	for (i = 0; i < n; i++) {
		struct pm_rng r = pm_rng_seed(seed, dup ? i / 2 : i, 0);
		float u = pm_rng_float(&r), v = pm_rng_float(&r);
		float w = pm_rng_float(&r), *x = p[i].pos;

		u *= u;
		v *= v;
		switch (pm_rng_u32(&r) % 5) {
		case 0:
			x[0] = u, x[1] = 0.0f, x[2] = v;
			break;
		case 1:
			x[0] = 0.0f, x[1] = u, x[2] = v;
			break;
		case 2:
			x[0] = u, x[1] = v, x[2] = 0.0f;
			break;
		case 3:
			x[0] = 1.0f, x[1] = u, x[2] = v;
			break;
		default: {
			float z = 2.0f * w - 1.0f, s = sqrtf(1.0f - z * z);
			float phi = 6.2831853f * u;

			x[0] = 0.5f + 0.2f * s * cosf(phi);
			x[1] = 0.5f + 0.2f * s * sinf(phi);
			x[2] = 0.3f + 0.2f * z;
			break;
		}
		}
		p[i].flags = (uint8_t)(i & 1 ? PM_PHOTON_CAUSTIC : 0);
	}
	return p;
}

/* The k smallest distances from q among pos[0..n), ascending. */
static void
brute_dists(const float *pos, size_t n, const float q[3], size_t k,
    float *best)
{
	size_t i, j, have = 0;

	for (i = 0; i < n; i++) {
		float d = dist2(&pos[3 * i], q);

		if (have == k && !(d < best[k - 1]))
			continue;
		j = have < k ? have++ : k - 1;
		while (j > 0 && best[j - 1] > d) {
			best[j] = best[j - 1];
			j--;
		}
		best[j] = d;
	}
}

/* FLANN's single kd-tree with unlimited checks answers exactly. */
static void
test_flann_exact(void **state)
{
	size_t n = 100000, nq = 300, k = 50, i, j;
	struct pm_photon *p = make_photons(n, 1, 0);
	float *pos = malloc(n * 3 * sizeof(*pos)), *qs, *fd, best[50], *got;
	struct FLANNParameters fp = DEFAULT_FLANN_PARAMETERS;
	flann_index_t ix;
	float speedup;
	int *fi;

	(void)state;
	assert_non_null(pos);
	qs = malloc(nq * 3 * sizeof(*qs));
	fi = malloc(nq * k * sizeof(*fi));
	fd = malloc(nq * k * sizeof(*fd));
	got = malloc(k * sizeof(*got));
	assert_true(qs && fi && fd && got);
	for (i = 0; i < n; i++)
		memcpy(&pos[3 * i], p[i].pos, sizeof(p[i].pos));
	for (i = 0; i < nq; i++) {
		struct pm_rng r = pm_rng_seed(2, i, 0);

		for (j = 0; j < 3; j++)
			qs[3 * i + j] = pm_rng_float(&r) * 1.2f - 0.1f;
	}
	fp.algorithm = FLANN_INDEX_KDTREE_SINGLE;
	fp.checks = FLANN_CHECKS_UNLIMITED;
	fp.eps = 0.0f;
	fp.cores = 1;
	fp.leaf_max_size = 10;
	fp.log_level = FLANN_LOG_NONE;
	flann_set_distance_type(FLANN_DIST_EUCLIDEAN, 0);
	ix = flann_build_index_float(pos, (int)n, 3, &speedup, &fp);
	assert_non_null(ix);
	assert_true(flann_find_nearest_neighbors_index_float(ix, qs, (int)nq,
	    fi, fd, (int)k, &fp) >= 0);
	for (i = 0; i < nq; i++) {
		brute_dists(pos, n, &qs[3 * i], k, best);
		for (j = 0; j < k; j++) {
			int id = fi[i * k + j];

			assert_true(id >= 0 && (size_t)id < n);
			got[j] = dist2(&pos[3 * id], &qs[3 * i]);
			/* FLANN's own distance: pm's formula, near enough. */
			assert_true(fabsf(fd[i * k + j] - got[j]) <=
			    1e-6f * got[j]);
		}
		/* FLANN returns its neighbours in order of distance. */
		for (j = 0; j < k; j++)
			assert_true(got[j] == best[j]);
	}
	flann_free_index_float(ix, &fp);
	free(pos);
	free(qs);
	free(fi);
	free(fd);
	free(got);
	free(p);
}

static void
run_check(struct pm_photon *p, size_t n, size_t queries, size_t k,
    struct pm_knn_check_result *r)
{
	struct pm_error err;

	assert_int_equal(pm_knn_check(p, n, queries, k, 99, r, &err), PM_OK);
	assert_int_equal(r->queries, queries);
	assert_true(r->ties <= queries);
}

/* 100k photons: not one mismatch, k = 50 and k = 200. */
static void
test_check_100k(void **state)
{
	size_t n = 100000;
	struct pm_photon *p = make_photons(n, 3, 0);
	struct pm_knn_check_result r;
	struct pm_error err;

	(void)state;
	assert_int_equal(pm_kdtree_build(p, n, 2, &err), PM_OK);
	run_check(p, n, 4000, 50, &r);
	assert_int_equal(r.mismatches, 0);
	assert_true(r.pm_qps > 0.0 && r.flann_qps > 0.0 &&
	    r.pm_qps_single > 0.0);
	assert_true(r.pm_build_s > 0.0 && r.flann_build_s > 0.0);
	print_message("knn_check 100k, k=50: pm %.0f q/s (one call a query "
	    "%.0f), FLANN %.0f q/s, build pm %.3f s, FLANN %.3f s, ties %zu\n",
	    r.pm_qps, r.pm_qps_single, r.flann_qps, r.pm_build_s,
	    r.flann_build_s, r.ties);
	run_check(p, n, 1000, 200, &r);
	assert_int_equal(r.mismatches, 0);
	free(p);
}

/* Every position twice: ties are counted as ties, never as mismatches. */
static void
test_check_duplicates(void **state)
{
	size_t n = 40000;
	struct pm_photon *p = make_photons(n, 4, 1);
	struct pm_knn_check_result r;
	struct pm_error err;

	(void)state;
	assert_int_equal(pm_kdtree_build(p, n, 1, &err), PM_OK);
	run_check(p, n, 2000, 31, &r);
	assert_int_equal(r.mismatches, 0);
	print_message("knn_check duplicates: %zu ties in %zu queries\n",
	    r.ties, r.queries);
	free(p);
}

/* Tiny sets, k beyond n. */
static void
test_check_tiny(void **state)
{
	size_t n;

	(void)state;
	for (n = 1; n <= 9; n++) {
		struct pm_photon *p = make_photons(n, 5 + n, 0);
		struct pm_knn_check_result r;
		struct pm_error err;

		assert_int_equal(pm_kdtree_build(p, n, 1, &err), PM_OK);
		run_check(p, n, 50, 4, &r);
		assert_int_equal(r.mismatches, 0);
		run_check(p, n, 50, 20, &r);
		assert_int_equal(r.mismatches, 0);
		free(p);
	}
}

/* A tree with part of it reversed answers wrongly, and the check says so. */
static void
test_check_detects_damage(void **state)
{
	size_t n = 20000, i;
	struct pm_photon *p = make_photons(n, 6, 0);
	struct pm_knn_check_result r;
	struct pm_error err;

	(void)state;
	assert_int_equal(pm_kdtree_build(p, n, 1, &err), PM_OK);
	for (i = 0; i < n / 4; i++) {
		struct pm_photon t = p[i];

		p[i] = p[n - 1 - i];
		p[n - 1 - i] = t;
	}
	assert_false(pm_kdtree_verify(p, n, NULL));
	run_check(p, n, 500, 20, &r);
	assert_true(r.mismatches > 50);
	free(p);
}

static void
test_check_args(void **state)
{
	struct pm_photon *p = make_photons(10, 7, 0);
	struct pm_knn_check_result r;
	struct pm_error err;

	(void)state;
	assert_int_equal(pm_knn_check(p, 10, 10, 0, 1, &r, &err),
	    PM_ERR_INVALID);
	assert_int_equal(pm_knn_check(p, 0, 10, 5, 1, &r, &err), PM_OK);
	assert_int_equal(r.queries, 0);
	assert_int_equal(r.mismatches, 0);
	if (sizeof(size_t) > sizeof(int))
		assert_int_equal(pm_knn_check(p, (size_t)INT_MAX + 1, 10, 5,
		    1, &r, &err), PM_ERR_LIMIT);
	free(p);
}

int
main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_flann_exact),
		cmocka_unit_test(test_check_100k),
		cmocka_unit_test(test_check_duplicates),
		cmocka_unit_test(test_check_tiny),
		cmocka_unit_test(test_check_detects_damage),
		cmocka_unit_test(test_check_args),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
