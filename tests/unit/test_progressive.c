/*
 * test_progressive.c: the two pieces progressive photon mapping adds to the
 * library.  The buffer-free radius walk of the kd-tree
 * (pm_kdtree_range_init/next) yields exactly the photons brute force finds
 * within the radius, each once, at its true distance and through the flag
 * filter, on random, duplicated and flat sets and for empty trees and zero
 * or huge radii.  The radius schedule (pm_pppm_radius_scale) starts at 1,
 * obeys Knaus and Zwicker's recurrence r_{i+1}^2 = r_i^2 (i + alpha) /
 * (i + 1) and falls like i^((alpha - 1) / 2), so that the variance of a
 * pass grows slower than the number of passes.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "../../common/kdtree.h"
#include "../../common/render.h"
#include "../../common/rng.h"

static float
dist2(const struct pm_photon *p, const float q[3])
{
	float dx = p->pos[0] - q[0], dy = p->pos[1] - q[1],
	    dz = p->pos[2] - q[2];

	return dx * dx + dy * dy + dz * dz;
}

/* n photons: uniform in the unit cube, on the plane z = 0.5 (flat), or
 * drawn from only 50 distinct points (dups); one flag bit at random. */
static struct pm_photon *
make_set(size_t n, int kind, uint64_t seed)
{
	struct pm_photon *p = calloc(n ? n : 1, sizeof(*p));
	struct pm_error err = {PM_OK, ""};
	size_t i;

	assert_non_null(p);
	for (i = 0; i < n; i++) {
		struct pm_rng r = pm_rng_seed(seed, kind == 2 ? i % 50 : i, 0);
		struct pm_rng f = pm_rng_seed(seed + 1, i, 0);

		p[i].pos[0] = pm_rng_float(&r);
		p[i].pos[1] = pm_rng_float(&r);
		p[i].pos[2] = kind == 1 ? 0.5f : pm_rng_float(&r);
		p[i].flags = pm_rng_float(&f) < 0.5f ? PM_PHOTON_VIA_DIFFUSE : 0;
	}
	assert_int_equal(pm_kdtree_build(p, n, 1, &err), PM_OK);
	return p;
}

/* The walk and brute force agree on one query. */
static void
check_query(const struct pm_photon *p, size_t n, const float q[3], float r2,
    uint8_t mask, uint8_t want)
{
	unsigned char *seen = calloc(n ? n : 1, 1);
	struct pm_kd_range it;
	size_t i, brute = 0, walked = 0;
	uint32_t idx;
	float d2;

	assert_non_null(seen);
	pm_kdtree_range_init(&it, p, n, q, r2, mask, want);
	while (pm_kdtree_range_next(&it, &idx, &d2)) {
		assert_true(idx < n);
		assert_int_equal(seen[idx], 0);
		seen[idx] = 1;
		assert_true(d2 == dist2(&p[idx], q));
		assert_true(d2 <= r2);
		assert_int_equal(p[idx].flags & mask, want);
		walked++;
	}
	for (i = 0; i < n; i++)
		if (dist2(&p[i], q) <= r2 && (p[i].flags & mask) == want) {
			assert_int_equal(seen[i], 1);
			brute++;
		}
	assert_int_equal(walked, brute);
	/* Exhausted walks stay exhausted. */
	assert_false(pm_kdtree_range_next(&it, &idx, &d2));
	free(seen);
}

static void
run_set(int kind, size_t n)
{
	static const float radii[] = {0.0f, 0.01f, 0.05f, 0.2f, 0.6f, 3.0f};
	struct pm_photon *p = make_set(n, kind, 7 + (uint64_t)kind);
	size_t qi, ri;

	for (qi = 0; qi < 40; qi++) {
		struct pm_rng r = pm_rng_seed(99, qi, 1);
		float q[3];

		q[0] = 1.2f * pm_rng_float(&r) - 0.1f;
		q[1] = 1.2f * pm_rng_float(&r) - 0.1f;
		q[2] = kind == 1 ? 0.5f : 1.2f * pm_rng_float(&r) - 0.1f;
		if (qi % 5 == 0 && n > 0)	/* exactly on a photon */
			memcpy(q, p[(qi * 7919) % n].pos, sizeof(q));
		for (ri = 0; ri < sizeof(radii) / sizeof(radii[0]); ri++) {
			float r2 = radii[ri] * radii[ri];

			check_query(p, n, q, r2, 0, 0);
			check_query(p, n, q, r2, PM_PHOTON_VIA_DIFFUSE,
			    PM_PHOTON_VIA_DIFFUSE);
		}
	}
	free(p);
}

static void test_range_uniform(void **s) { (void)s; run_set(0, 20000); }
static void test_range_flat(void **s) { (void)s; run_set(1, 5000); }
static void test_range_duplicates(void **s) { (void)s; run_set(2, 3000); }
static void test_range_tiny(void **s) { (void)s; run_set(0, 1); run_set(0, 47); run_set(0, 49); }

/* An empty tree and a NaN radius yield nothing; a huge radius yields all. */
static void
test_range_edges(void **s)
{
	struct pm_photon *p = make_set(1000, 0, 3);
	struct pm_kd_range it;
	float q[3] = {0.5f, 0.5f, 0.5f}, d2;
	uint32_t idx;
	size_t cnt = 0;

	(void)s;
	pm_kdtree_range_init(&it, p, 0, q, 1.0f, 0, 0);
	assert_false(pm_kdtree_range_next(&it, &idx, &d2));
	pm_kdtree_range_init(&it, p, 1000, q, NAN, 0, 0);
	assert_false(pm_kdtree_range_next(&it, &idx, &d2));
	pm_kdtree_range_init(&it, p, 1000, q, 1e30f, 0, 0);
	while (pm_kdtree_range_next(&it, &idx, &d2))
		cnt++;
	assert_int_equal(cnt, 1000);
	free(p);
}

/* The schedule: 1 at the first pass, the recurrence, the asymptote. */
static void
test_schedule(void **s)
{
	static const double alphas[] = {0.5, 2.0 / 3.0, 0.9};
	size_t a;
	long i;

	(void)s;
	assert_true(pm_pppm_radius_scale(0, 0.5) == 0.0);
	for (a = 0; a < 3; a++) {
		double al = alphas[a], prev = pm_pppm_radius_scale(1, al);

		assert_true(prev == 1.0);
		for (i = 1; i < 2000; i++) {
			double next = pm_pppm_radius_scale(i + 1, al);

			assert_true(fabs(next * next - prev * prev * (i + al) /
			    (i + 1)) < 1e-12);
			assert_true(next < prev);
			prev = next;
		}
		/* r_i^2 ~ C i^(alpha - 1): doubling i scales r^2 by 2^(alpha-1). */
		prev = pm_pppm_radius_scale(10000, al);
		assert_true(fabs(pow(pm_pppm_radius_scale(20000, al) / prev, 2.0) /
		    pow(2.0, al - 1.0) - 1.0) < 1e-3);
	}
}

int
main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_range_uniform),
		cmocka_unit_test(test_range_flat),
		cmocka_unit_test(test_range_duplicates),
		cmocka_unit_test(test_range_tiny),
		cmocka_unit_test(test_range_edges),
		cmocka_unit_test(test_schedule),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
