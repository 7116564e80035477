/*
 * test_occupancy.c: the occupancy grid never says "none" where a photon
 * is within the radius, and says it where none is near.
 *
 * Against brute force on photons in clusters and on a plane, at random
 * queries and at queries just inside the radius of a photon (the cells'
 * edges, where rounding decides), with the grid far from the origin so
 * that float rounding is as coarse as it gets within the cell cap.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "../../common/occupancy.h"
#include "../../common/rng.h"

/* Whether a photon of p[0..n) is within squared distance r2 of q, as the
 * kd-tree walk measures it. */
static bool
any_within(const struct pm_photon *p, size_t n, const float q[3], float r2)
{
	size_t i;

	for (i = 0; i < n; i++) {
		float dx = p[i].pos[0] - q[0], dy = p[i].pos[1] - q[1];
		float dz = p[i].pos[2] - q[2];

		if (dx * dx + dy * dy + dz * dz <= r2)
			return true;
	}
	return false;
}

/* n photons from `origin` on: half in 12 clusters, half on a tilted
 * plane, over a box `size` wide and `size` times `stretch` long in x. */
static struct pm_photon *
scatter(size_t n, float origin, float size, float stretch, uint64_t seed)
{
	struct pm_photon *p = calloc(n, sizeof(*p));
	struct pm_rng rng = pm_rng_seed(seed, 0, 0);
	float c[12][3];
	size_t i;
	int k, a;

	assert_non_null(p);
	for (k = 0; k < 12; k++)
		for (a = 0; a < 3; a++)
			c[k][a] = origin + size * (a == 0 ? stretch : 1.0f) *
			    pm_rng_float(&rng);
	for (i = 0; i < n; i++) {
		if (i % 2 == 0) {
			k = (int)(pm_rng_float(&rng) * 12.0f);
			for (a = 0; a < 3; a++)
				p[i].pos[a] = c[k][a] + 0.02f * size *
				    (pm_rng_float(&rng) - 0.5f);
		} else {
			float u = pm_rng_float(&rng), v = pm_rng_float(&rng);

			p[i].pos[0] = origin + size * stretch * u;
			p[i].pos[1] = origin + size * v;
			p[i].pos[2] = origin + 0.5f * size + 0.1f * size * (u - v);
		}
	}
	return p;
}

static void
check_against_brute_force(float origin, float size, float stretch, float r,
    size_t n, float inside, size_t min_edges, uint64_t seed)
{
	struct pm_photon *p = scatter(n, origin, size, stretch, seed);
	struct pm_occupancy o;
	struct pm_rng rng = pm_rng_seed(seed, 1, 0);
	const float r2 = r * r;
	size_t i, none = 0, queries = 40000, edges = 0;

	pm_occupancy_build(&o, p, n, r2);
	assert_non_null(o.bits);
	/* random queries over the box and a margin around it */
	for (i = 0; i < queries; i++) {
		float q[3];
		int a;

		for (a = 0; a < 3; a++)
			q[a] = origin - 0.1f * size + 1.2f * size *
			    (a == 0 ? stretch : 1.0f) * pm_rng_float(&rng);
		if (!pm_occupancy_maybe(&o, q, r2)) {
			none++;
			assert_false(any_within(p, n, q, r2));
		}
	}
	/* queries just inside the radius of a photon, in every direction:
	 * the answer must be "maybe" */
	for (i = 0; i < 20000; i++) {
		const struct pm_photon *x = &p[(size_t)(pm_rng_float(&rng) *
		    (float)n)];
		float u = 2.0f * pm_rng_float(&rng) - 1.0f;
		float phi = 6.2831853f * pm_rng_float(&rng);
		float s = sqrtf(1.0f - u * u), q[3], d2;
		float t = r * (1.0f - inside);

		q[0] = x->pos[0] + t * s * cosf(phi);
		q[1] = x->pos[1] + t * s * sinf(phi);
		q[2] = x->pos[2] + t * u;
		d2 = (x->pos[0] - q[0]) * (x->pos[0] - q[0]) +
		    (x->pos[1] - q[1]) * (x->pos[1] - q[1]) +
		    (x->pos[2] - q[2]) * (x->pos[2] - q[2]);
		if (d2 > r2)
			continue;	/* rounding put it outside */
		edges++;
		assert_true(pm_occupancy_maybe(&o, q, r2));
	}
	print_message("origin %g, size %g x %g, r %g: %zu of %zu random "
	    "queries answered none; %zu queries at the radius; grid %d x %d "
	    "x %d\n", origin, size * stretch, size, r, none, queries, edges,
	    o.n[0], o.n[1], o.n[2]);
	/* selective: most of the box is far from every photon */
	assert_true(none > queries / 4);
	assert_true(edges >= min_edges);
	/* a smaller radius is answered too, a larger one never "none" */
	for (i = 0; i < 1000; i++) {
		float q[3] = {origin - 0.1f * size, origin + size *
		    pm_rng_float(&rng), origin + size * pm_rng_float(&rng)};

		if (!pm_occupancy_maybe(&o, q, 0.25f * r2))
			assert_false(any_within(p, n, q, 0.25f * r2));
		assert_true(pm_occupancy_maybe(&o, q, 1.01f * r2));
	}
	pm_occupancy_free(&o);
	assert_null(o.bits);
	free(p);
}

static void
test_near_the_origin(void **state)
{
	(void)state;
	check_against_brute_force(0.0f, 2.0f, 1.0f, 0.02f, 4000, 1e-5f, 19000,
	    3);
}

static void
test_far_from_the_origin(void **state)
{
	(void)state;
	/* 3000 cells along x, 1000 to 1600 units from 0, where a float's
	 * ulp is 1/1600 of a cell: queries a millionth of the radius inside
	 * it (half of them round to outside), which cells exactly the
	 * radius wide would misplace */
	check_against_brute_force(1000.0f, 2.0f, 300.0f, 0.2f, 3000, 1e-6f, 5000,
	    4);
}

/* Photons on a line along x, 1000 to 1600 units from 0, each queried
 * at the farthest float within the radius along +x and -x: with 200k of
 * them, some sit a rounding error below a cell's edge, where such a
 * query lands two cells on if the cells are exactly the radius wide. */
static void
test_radius_edges(void **state)
{
	const size_t n = 200000;
	const float r = 0.2f, r2 = r * r;
	struct pm_photon *p = calloc(n, sizeof(*p));
	struct pm_rng rng = pm_rng_seed(5, 0, 0);
	struct pm_occupancy o;
	size_t i, asked = 0;
	int side;

	(void)state;
	assert_non_null(p);
	for (i = 0; i < n; i++)
		p[i].pos[0] = 1000.0f + 600.0f * pm_rng_float(&rng);
	pm_occupancy_build(&o, p, n, r2);
	assert_non_null(o.bits);
	for (i = 0; i < n; i++)
		for (side = -1; side <= 1; side += 2) {
			float q[3] = {p[i].pos[0] + (float)side * r, 0.0f, 0.0f};
			float dx = q[0] - p[i].pos[0];

			/* the farthest float a walk still counts */
			while (dx * dx > r2) {
				q[0] = nextafterf(q[0], p[i].pos[0]);
				dx = q[0] - p[i].pos[0];
			}
			asked++;
			assert_true(pm_occupancy_maybe(&o, q, r2));
		}
	print_message("%zu queries at the radius\n", asked);
	assert_int_equal(asked, 2 * n);
	pm_occupancy_free(&o);
	free(p);
}

static void
test_degenerate(void **state)
{
	struct pm_photon p[2];
	struct pm_occupancy o;
	float q[3] = {0.0f, 0.0f, 0.0f}, far[3] = {100.0f, 0.0f, 0.0f};
	float nan3[3] = {NAN, 0.0f, 0.0f};

	(void)state;
	memset(p, 0, sizeof(p));
	/* no photons, or no radius: "maybe" everywhere */
	pm_occupancy_build(&o, p, 0, 1.0f);
	assert_null(o.bits);
	assert_true(pm_occupancy_maybe(&o, far, 1.0f));
	pm_occupancy_build(&o, p, 2, 0.0f);
	assert_true(pm_occupancy_maybe(&o, far, 1.0f));
	assert_true(pm_occupancy_maybe(NULL, far, 1.0f));
	/* one point twice: a single cell and its ring */
	pm_occupancy_build(&o, p, 2, 1.0f);
	assert_non_null(o.bits);
	assert_true(pm_occupancy_maybe(&o, q, 1.0f));
	assert_false(pm_occupancy_maybe(&o, far, 1.0f));
	assert_true(pm_occupancy_maybe(&o, nan3, 1.0f));
	pm_occupancy_free(&o);
	/* a non-finite photon: "maybe" everywhere, as without the grid */
	p[1].pos[2] = INFINITY;
	pm_occupancy_build(&o, p, 2, 1.0f);
	assert_null(o.bits);
	assert_true(pm_occupancy_maybe(&o, far, 1.0f));
}

int
main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_near_the_origin),
		cmocka_unit_test(test_far_from_the_origin),
		cmocka_unit_test(test_radius_edges),
		cmocka_unit_test(test_degenerate),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
