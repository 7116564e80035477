/*
 * test_sampling.c: the warps produce the densities they claim, frames are
 * orthonormal and right-handed, and the discrete distribution picks each
 * index with its weight's share and never an index of weight zero.
 *
 * Distributions are checked with Pearson's chi-square test on histograms
 * of a million samples (fixed seeds), expected counts coming from the pdf
 * functions integrated numerically over each bin.  Bins expecting fewer
 * than five samples are pooled.  Each test rejects at 1e-3 divided by the
 * number of chi-square tests in this file (Bonferroni), so a correct
 * implementation fails once in a thousand seeds at most.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "../../common/rng.h"
#include "../../common/light.h"
#include "../../common/sampling.h"
#include "stats.h"

#define NCHI2 11
#define SIGNIFICANCE (1e-3 / NCHI2)
#define NSAMPLES 1000000
#define NZ 50
#define NPHI 50
#define TWO_PI 6.283185307179586

static double
cosine_pdf(struct pm_vec3 v, const void *ctx)
{
	(void)ctx;
	return pm_cosine_hemisphere_pdf(v);
}

static double
hemisphere_pdf(struct pm_vec3 v, const void *ctx)
{
	(void)ctx;
	return pm_uniform_hemisphere_pdf(v);
}

static double
sphere_pdf(struct pm_vec3 v, const void *ctx)
{
	(void)ctx;
	(void)v;
	return pm_uniform_sphere_pdf();
}

enum warp { WARP_COSINE, WARP_HEMISPHERE, WARP_SPHERE };

static void
check_direction_warp(enum warp w, double (*pdf)(struct pm_vec3, const void *),
    uint64_t seed, const char *what)
{
	static double obs[NZ * NPHI], expd[NZ * NPHI];
	struct pm_rng rng = pm_rng_seed(seed, 0, 0);
	struct pm_vec3 v;
	float u1, u2;
	int i;

	memset(obs, 0, sizeof(obs));
	for (i = 0; i < NSAMPLES; i++) {
		u1 = pm_rng_float(&rng);
		u2 = pm_rng_float(&rng);
		v = w == WARP_COSINE ? pm_square_to_cosine_hemisphere(u1, u2) :
		    w == WARP_HEMISPHERE ?
		    pm_square_to_uniform_hemisphere(u1, u2) :
		    pm_square_to_uniform_sphere(u1, u2);
		assert_true(fabsf(pm_length(v) - 1.0f) < 1e-5f);
		if (w != WARP_SPHERE)
			assert_true(v.z >= 0.0f);
		obs[stats_sphere_bin(v, NZ, NPHI)] += 1.0;
	}
	stats_sphere_expected(pdf, NULL, NSAMPLES, NZ, NPHI, 8, expd);
	assert_true(stats_chi2(obs, expd, NZ * NPHI, STATS_POOL_JOIN,
	    SIGNIFICANCE, what) > SIGNIFICANCE);
}

static void
test_cosine_hemisphere(void **state)
{
	(void)state;
	check_direction_warp(WARP_COSINE, cosine_pdf, 1, "cosine hemisphere");
}

static void
test_uniform_hemisphere(void **state)
{
	(void)state;
	check_direction_warp(WARP_HEMISPHERE, hemisphere_pdf, 2,
	    "uniform hemisphere");
}

static void
test_uniform_sphere(void **state)
{
	(void)state;
	check_direction_warp(WARP_SPHERE, sphere_pdf, 3, "uniform sphere");
}

/*
 * The concentric map's polynomial sine and cosine (sampling.h) against
 * libm's in double at 200,001 points of [-1, 1]: within 1.5 float
 * spacings at 1 (1.8e-7; they reach 0.8), where the sine without its x^9
 * term errs by 3.1e-7 and a wrong coefficient by more; and the disk
 * points against the angle form of the map on a 512 x 512 grid.  The
 * warp's distribution itself is test_cosine_hemisphere's chi-square.
 */
static void
test_disk_sincos(void **state)
{
	double worst = 0.0;
	int i, j;

	(void)state;
	for (i = -100000; i <= 100000; i++) {
		float t = (float)i / 100000.0f, s, c;
		double x = (double)t * M_PI / 4.0;

		pm_sincos_quarter_pi(t, &s, &c);
		worst = fmax(worst, fabs(s - sin(x)));
		worst = fmax(worst, fabs(c - cos(x)));
	}
	assert_true(worst < 1.5 * 0x1p-23);
	for (i = 0; i < 512; i++)
		for (j = 0; j < 512; j++) {
			float u1 = ((float)i + 0.5f) / 512.0f;
			float u2 = ((float)j + 0.5f) / 512.0f;
			double a = 2.0 * u1 - 1.0, b = 2.0 * u2 - 1.0, r, phi;
			float x, y;

			if (fabs(a) > fabs(b)) {
				r = a;
				phi = M_PI / 4.0 * (b / a);
			} else {
				r = b;
				phi = M_PI / 2.0 - M_PI / 4.0 * (a / b);
			}
			pm_square_to_disk(u1, u2, &x, &y);
			assert_true(fabs(x - r * cos(phi)) < 4.0 * 0x1p-23);
			assert_true(fabs(y - r * sin(phi)) < 4.0 * 0x1p-23);
		}
}

/*
 * pm_square_to_cosine_hemisphere_n is the scalar warp bit for bit: on a
 * 1024 x 1024 grid of the square (its centre, both diagonals, where the
 * wedges meet, and the axes, where one coordinate is 0, among them), at
 * the corners 0 and the largest u below 1, and at 2^20 random pairs;
 * all in one call (the SIMD lanes take all but the last few), then in
 * runs of lengths that leave every remainder of the SIMD width.
 * It fails with the lanes' wedges chosen by >= instead of >, a Horner
 * step reordered, or the centre's lanes left unmasked.
 */
static void
test_cosine_lanes(void **state)
{
	enum { G = 1024, R = 1 << 20, N = G * G + 4 + R };
	float *u1 = malloc(N * sizeof(*u1)), *u2 = malloc(N * sizeof(*u2));
	float *x = malloc(N * sizeof(*x)), *y = malloc(N * sizeof(*y));
	float *z = malloc(N * sizeof(*z));
	const float top = 0x1.fffffep-1f;	/* pm_rng_float's largest */
	struct pm_rng rng = pm_rng_seed(3, 1, 4);
	size_t i, at, run, bad = 0;
	int pass;

	(void)state;
	assert_non_null(u1);
	assert_non_null(u2);
	assert_non_null(x);
	assert_non_null(y);
	assert_non_null(z);
	for (i = 0; i < (size_t)G * G; i++) {
		u1[i] = (float)(i % G) / (float)G;
		u2[i] = (float)(i / G) / (float)G;
	}
	u1[i] = 0.0f, u2[i++] = 0.0f;
	u1[i] = top, u2[i++] = top;
	u1[i] = 0.0f, u2[i++] = top;
	u1[i] = top, u2[i++] = 0.0f;
	for (; i < N; i++) {
		u1[i] = pm_rng_float(&rng);
		u2[i] = pm_rng_float(&rng);
	}
	for (pass = 0; pass < 2; pass++) {
		for (at = 0, run = pass == 0 ? N : 1; at < N;
		    at += run, run = run % 13 + 1) {
			if (run > N - at)
				run = N - at;
			pm_square_to_cosine_hemisphere_n(u1 + at, u2 + at,
			    x + at, y + at, z + at, run);
		}
		for (i = 0; i < N; i++) {
			struct pm_vec3 v = pm_square_to_cosine_hemisphere(u1[i],
			    u2[i]);

			if ((memcmp(&v.x, &x[i], sizeof(float)) != 0 ||
			    memcmp(&v.y, &y[i], sizeof(float)) != 0 ||
			    memcmp(&v.z, &z[i], sizeof(float)) != 0) &&
			    bad++ < 5)
				print_message("(%a, %a): scalar (%a, %a, %a), "
				    "lanes (%a, %a, %a)\n", u1[i], u2[i],
				    v.x, v.y, v.z, x[i], y[i], z[i]);
		}
		assert_int_equal(bad, 0);
	}
	free(u1);
	free(u2);
	free(x);
	free(y);
	free(z);
}

/* The pdfs integrate to one over their domains. */
static void
test_pdf_normalisation(void **state)
{
	static double expd[NZ * NPHI];
	double sum;
	size_t i;

	(void)state;
	stats_sphere_expected(cosine_pdf, NULL, 1.0, NZ, NPHI, 8, expd);
	for (sum = 0.0, i = 0; i < NZ * NPHI; i++)
		sum += expd[i];
	assert_true(fabs(sum - 1.0) < 1e-4);
	stats_sphere_expected(hemisphere_pdf, NULL, 1.0, NZ, NPHI, 8,
	    expd);
	for (sum = 0.0, i = 0; i < NZ * NPHI; i++)
		sum += expd[i];
	assert_true(fabs(sum - 1.0) < 1e-4);
	assert_true(fabs(pm_uniform_sphere_pdf() * 4.0 * M_PI - 1.0) < 1e-6);
	assert_true(fabs(pm_uniform_cone_pdf(0.25f) * TWO_PI * 0.75 - 1.0) <
	    1e-6);
	assert_true(pm_cosine_hemisphere_pdf(pm_v3(0, 0, -1)) == 0.0f);
	assert_true(pm_uniform_hemisphere_pdf(pm_v3(0, 0.6f, -0.8f)) == 0.0f);
}

/*
 * Cones: the normalised distance from the axis, (1 - z) / (1 - cos_max),
 * and phi must both be uniform.  1 - z comes from x^2 + y^2 to keep its
 * precision in narrow cones.
 */
static double
check_cone(float cos_max, uint64_t seed, int nt, int np, const char *what)
{
	double *obs = calloc((size_t)(nt * np), sizeof(double));
	double *expd = malloc((size_t)(nt * np) * sizeof(double));
	struct pm_rng rng = pm_rng_seed(seed, 0, 0);
	struct pm_vec3 v;
	double t, phi, p;
	int i, it, ip;

	assert_non_null(obs);
	assert_non_null(expd);
	for (i = 0; i < NSAMPLES; i++) {
		v = pm_square_to_uniform_cone(pm_rng_float(&rng),
		    pm_rng_float(&rng), cos_max);
		assert_true(fabsf(pm_length(v) - 1.0f) < 1e-5f);
		assert_true(v.z >= cos_max - 1e-6f);
		t = ((double)v.x * v.x + (double)v.y * v.y) / (1.0 + v.z) /
		    (1.0 - cos_max);
		phi = atan2(v.y, v.x);
		if (phi < 0.0)
			phi += TWO_PI;
		it = (int)floor(t * nt);
		ip = (int)floor(phi / TWO_PI * np);
		it = it < 0 ? 0 : it >= nt ? nt - 1 : it;
		ip = ip < 0 ? 0 : ip >= np ? np - 1 : ip;
		obs[it * np + ip] += 1.0;
	}
	for (i = 0; i < nt * np; i++)
		expd[i] = (double)NSAMPLES / (nt * np);
	p = stats_chi2(obs, expd, (size_t)(nt * np), STATS_POOL_JOIN,
	    SIGNIFICANCE, what);
	free(obs);
	free(expd);
	return p;
}

static void
test_uniform_cone(void **state)
{
	(void)state;
	assert_true(check_cone(0.3f, 4, NZ, NPHI, "cone 0.3") >
	    SIGNIFICANCE);
	/* a cone a tenth of a degree wide: the distant-sun case */
	assert_true(check_cone(0.99999f, 5, 100, 8, "cone 0.99999") >
	    SIGNIFICANCE);
}

/* Uniform disk: r^2 and phi are uniform. */
static void
test_disk(void **state)
{
	static double obs[NZ * NPHI], expd[NZ * NPHI];
	struct pm_rng rng = pm_rng_seed(6, 0, 0);
	double r2, phi;
	float x, y;
	int i, ir, ip;

	(void)state;
	memset(obs, 0, sizeof(obs));
	for (i = 0; i < NSAMPLES; i++) {
		pm_square_to_disk(pm_rng_float(&rng), pm_rng_float(&rng), &x,
		    &y);
		r2 = (double)x * x + (double)y * y;
		assert_true(r2 <= 1.0 + 1e-6);
		phi = atan2(y, x);
		if (phi < 0.0)
			phi += TWO_PI;
		ir = (int)floor(r2 * NZ);
		ip = (int)floor(phi / TWO_PI * NPHI);
		ir = ir >= NZ ? NZ - 1 : ir;
		ip = ip >= NPHI ? NPHI - 1 : ip;
		obs[ir * NPHI + ip] += 1.0;
	}
	for (i = 0; i < NZ * NPHI; i++)
		expd[i] = (double)NSAMPLES / (NZ * NPHI);
	assert_true(stats_chi2(obs, expd, NZ * NPHI, STATS_POOL_JOIN,
	    SIGNIFICANCE, "disk") > SIGNIFICANCE);
	/* the centre of the square is the centre of the disk */
	pm_square_to_disk(0.5f, 0.5f, &x, &y);
	assert_true(x == 0.0f && y == 0.0f);
}

/*
 * Uniform triangle in barycentrics: density 2 on b1 + b2 <= 1.  The grid
 * is aligned with the hypotenuse, so the diagonal bins are exactly half.
 */
static void
test_triangle(void **state)
{
	static double obs[NZ * NZ], expd[NZ * NZ];
	struct pm_rng rng = pm_rng_seed(7, 0, 0);
	float b1, b2;
	int i, j, a, c;

	(void)state;
	memset(obs, 0, sizeof(obs));
	for (i = 0; i < NSAMPLES; i++) {
		pm_square_to_triangle(pm_rng_float(&rng), pm_rng_float(&rng),
		    &b1, &b2);
		assert_true(b1 >= 0.0f && b2 >= 0.0f);
		assert_true(b1 + b2 <= 1.0f + 1e-6f);
		a = (int)floorf(b1 * NZ);
		c = (int)floorf(b2 * NZ);
		a = a >= NZ ? NZ - 1 : a;
		c = c >= NZ ? NZ - 1 : c;
		obs[a * NZ + c] += 1.0;
	}
	for (i = 0; i < NZ; i++)
		for (j = 0; j < NZ; j++)
			expd[i * NZ + j] = (double)NSAMPLES / (NZ * NZ) *
			    (i + j < NZ - 1 ? 2.0 : i + j == NZ - 1 ? 1.0 :
			    0.0);
	assert_true(stats_chi2(obs, expd, NZ * NZ, STATS_POOL_JOIN,
	    SIGNIFICANCE, "triangle") > SIGNIFICANCE);
}

static void
check_frame(struct pm_vec3 n)
{
	struct pm_frame f;
	struct pm_vec3 c, v, back;
	const float tol = 2e-6f;

	n = pm_normalize(n);
	f = pm_frame_from_normal(n);
	assert_true(fabsf(pm_length(f.s) - 1.0f) < tol);
	assert_true(fabsf(pm_length(f.t) - 1.0f) < tol);
	assert_true(fabsf(pm_dot(f.s, f.t)) < tol);
	assert_true(fabsf(pm_dot(f.s, n)) < tol);
	assert_true(fabsf(pm_dot(f.t, n)) < tol);
	/* right-handed: s x t = n */
	c = pm_cross(f.s, f.t);
	assert_true(pm_length(pm_sub(c, n)) < 4.0f * tol);
	/* to_local and to_world are inverses, and n maps to +z */
	v = pm_to_local(f, n);
	assert_true(fabsf(v.z - 1.0f) < tol);
	v = pm_normalize(pm_v3(0.3f, -0.5f, 0.81f));
	back = pm_to_world(f, pm_to_local(f, v));
	assert_true(pm_length(pm_sub(back, v)) < 4.0f * tol);
}

static void
test_frame(void **state)
{
	struct pm_rng rng = pm_rng_seed(8, 0, 0);
	static const float special[][3] = {
		{ 0, 0, 1 }, { 0, 0, -1 }, { 1, 0, 0 }, { 0, -1, 0 },
		{ 1e-4f, 0, -1 }, { 0, 1e-3f, -1 }, { 1e-7f, 1e-7f, -1 },
		{ -3e-4f, 2e-4f, -1 }, { 1, 1, -1e-6f }, { 1, 0, -0.0f },
		{ 0.01f, -0.02f, -1 }, { -1e-5f, -1e-5f, 1 },
	};
	size_t i;
	int k;

	(void)state;
	for (i = 0; i < sizeof(special) / sizeof(special[0]); i++)
		check_frame(pm_v3(special[i][0], special[i][1],
		    special[i][2]));
	for (k = 0; k < 100000; k++)
		check_frame(pm_square_to_uniform_sphere(pm_rng_float(&rng),
		    pm_rng_float(&rng)));
	/* concentrate on the southern cap, where the branch flips */
	for (k = 0; k < 100000; k++) {
		struct pm_vec3 v = pm_square_to_uniform_cone(
		    pm_rng_float(&rng), pm_rng_float(&rng), 0.9999f);
		check_frame(pm_v3(v.x, v.y, -v.z));
	}
}

static const double weights[] = { 0, 2, 0, 0, 5, 1, 0, 0.5, 0 };
#define NW (sizeof(weights) / sizeof(weights[0]))

static void
test_distrib_frequencies(void **state)
{
	struct pm_distrib d;
	struct pm_error err;
	struct pm_rng rng = pm_rng_seed(9, 0, 0);
	double obs[NW] = { 0 }, expd[NW], robs[100] = { 0 }, rexp[100];
	double sum = 0.0, total = 0.0;
	float ur;
	size_t i, k;
	int s;

	(void)state;
	assert_int_equal(pm_distrib_init(&d, weights, NW, &err), PM_OK);
	assert_int_equal(d.n, NW);
	for (i = 0; i < NW; i++)
		sum += weights[i];
	assert_true(fabs(d.sum - sum) < 1e-12);
	for (i = 0; i < NW; i++) {
		assert_true(fabs(pm_distrib_prob(&d, i) - weights[i] / sum) <
		    1e-12);
		total += pm_distrib_prob(&d, i);
	}
	assert_true(fabs(total - 1.0) < 1e-12);
	assert_true(d.cdf[0] == 0.0 && d.cdf[NW] == 1.0);
	for (s = 0; s < NSAMPLES; s++) {
		k = pm_distrib_sample(&d, pm_rng_float(&rng), &ur);
		assert_true(k < NW);
		assert_true(weights[k] > 0.0);
		assert_true(ur >= 0.0f && ur < 1.0f);
		obs[k] += 1.0;
		robs[(int)(ur * 100.0f)] += 1.0;
	}
	for (i = 0; i < NW; i++)
		expd[i] = NSAMPLES * weights[i] / sum;
	assert_true(stats_chi2(obs, expd, NW, STATS_POOL_JOIN,
	    SIGNIFICANCE, "distrib") > SIGNIFICANCE);
	/* what is left of u is itself uniform */
	for (i = 0; i < 100; i++)
		rexp[i] = NSAMPLES / 100.0;
	assert_true(stats_chi2(robs, rexp, 100, STATS_POOL_JOIN,
	    SIGNIFICANCE, "u_reuse") > SIGNIFICANCE);
	pm_distrib_free(&d);
	assert_null(d.cdf);
}

/*
 * The alias table (light.h) draws index i with probability w[i] / sum
 * (chi-square) and leaves a uniform remainder (chi-square); every one of
 * the 2^24 values pm_rng_float can give avoids the zero weights and
 * leaves a remainder in [0, 1); one bin gives index 0 and u itself.
 */
static void
test_alias(void **state)
{
	struct pm_alias t[NW], one;
	struct pm_rng rng = pm_rng_seed(11, 0, 0);
	double obs[NW] = { 0 }, expd[NW], robs[100] = { 0 }, rexp[100];
	double sum = 0.0, w1 = 3.0;
	float ur;
	size_t i, k;
	uint32_t j;

	(void)state;
	assert_int_equal(pm_alias_build(t, weights, NW, NULL), PM_OK);
	for (i = 0; i < NW; i++)
		sum += weights[i];
	for (i = 0; i < NSAMPLES; i++) {
		k = pm_alias_sample(t, NW, pm_rng_float(&rng), &ur);
		assert_true(k < NW);
		obs[k] += 1.0;
		robs[(int)(ur * 100.0f)] += 1.0;
	}
	for (i = 0; i < NW; i++)
		expd[i] = NSAMPLES * weights[i] / sum;
	assert_true(stats_chi2(obs, expd, NW, STATS_POOL_JOIN,
	    SIGNIFICANCE, "alias") > SIGNIFICANCE);
	for (i = 0; i < 100; i++)
		rexp[i] = NSAMPLES / 100.0;
	assert_true(stats_chi2(robs, rexp, 100, STATS_POOL_JOIN,
	    SIGNIFICANCE, "alias u_reuse") > SIGNIFICANCE);
	for (j = 0; j < (1u << 24); j++) {
		k = pm_alias_sample(t, NW, (float)j * 0x1p-24f, &ur);
		assert_true(weights[k] > 0.0);
		assert_true(ur >= 0.0f && ur < 1.0f);
	}
	assert_int_equal(pm_alias_build(&one, &w1, 1, NULL), PM_OK);
	assert_true(pm_alias_sample(&one, 1, 0.375f, &ur) == 0);
	assert_true(ur == 0.375f);
}

/* No u at all, however unlucky, returns an index of zero weight. */
static void
test_distrib_zero_weights(void **state)
{
	struct pm_distrib d;
	struct pm_rng rng = pm_rng_seed(10, 0, 0);
	static const float edge[] = { 0.0f, 0x1.fffffep-1f, 1.0f, -0.5f, 2.0f,
	    1e-30f, 0.5f };
	double *w;
	float u, ur;
	size_t i, k, n = 100000;
	int j, step;

	(void)state;
	assert_int_equal(pm_distrib_init(&d, weights, NW, NULL), PM_OK);
	for (i = 0; i < sizeof(edge) / sizeof(edge[0]); i++) {
		k = pm_distrib_sample(&d, edge[i], &ur);
		assert_true(weights[k] > 0.0);
		assert_true(ur >= 0.0f && ur < 1.0f);
	}
	assert_int_equal(pm_distrib_sample(&d, 0.0f, NULL), 1);
	assert_int_equal(pm_distrib_sample(&d, 0x1.fffffep-1f, NULL), 7);
	k = pm_distrib_sample(&d, NAN, NULL);
	assert_true(weights[k] > 0.0);
	/* every float in a neighbourhood of every cdf step */
	for (i = 0; i <= NW; i++) {
		u = (float)d.cdf[i];
		for (step = 0; step < 64; step++)
			u = nextafterf(u, -1.0f);
		for (step = 0; step < 128; step++, u = nextafterf(u, 2.0f))
			if (u >= 0.0f && u < 1.0f)
				assert_true(weights[pm_distrib_sample(&d, u,
				    NULL)] > 0.0);
	}
	pm_distrib_free(&d);

	/* many weights, a third of them zero, some tiny */
	w = malloc(n * sizeof(double));
	assert_non_null(w);
	for (i = 0; i < n; i++) {
		double r = pm_rng_double(&rng);
		w[i] = r < 0.33 ? 0.0 : r < 0.4 ? 1e-12 * r : r;
	}
	assert_int_equal(pm_distrib_init(&d, w, n, NULL), PM_OK);
	for (j = 0; j < 200000; j++) {
		k = pm_distrib_sample(&d, pm_rng_float(&rng), NULL);
		assert_true(k < n);
		assert_true(w[k] > 0.0);
		assert_true(pm_distrib_prob(&d, k) > 0.0);
	}
	pm_distrib_free(&d);
	free(w);

	/* a single weight */
	{
		double one = 3.0;

		assert_int_equal(pm_distrib_init(&d, &one, 1, NULL), PM_OK);
		assert_int_equal(pm_distrib_sample(&d, 0.7f, &ur), 0);
		assert_true(fabsf(ur - 0.7f) < 1e-6f);
		assert_true(pm_distrib_prob(&d, 0) == 1.0);
		pm_distrib_free(&d);
	}
}

static void
test_distrib_invalid(void **state)
{
	struct pm_distrib d;
	struct pm_error err;
	double zeros[3] = { 0, 0, 0 }, neg[3] = { 1, -1, 2 };
	double nan[2] = { 1, NAN }, inf[2] = { 1, INFINITY };
	double ok = 1.0;

	(void)state;
	err.msg[0] = '\0';
	assert_int_equal(pm_distrib_init(&d, &ok, 0, &err), PM_ERR_INVALID);
	assert_true(strlen(err.msg) > 0);
	assert_null(d.cdf);
	assert_int_equal(pm_distrib_init(&d, zeros, 3, &err), PM_ERR_INVALID);
	assert_int_equal(pm_distrib_init(&d, neg, 3, &err), PM_ERR_INVALID);
	assert_int_equal(pm_distrib_init(&d, nan, 2, &err), PM_ERR_INVALID);
	assert_int_equal(pm_distrib_init(&d, inf, 2, NULL), PM_ERR_INVALID);
	assert_null(d.cdf);
	pm_distrib_free(&d);
}

int
main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_cosine_hemisphere),
		cmocka_unit_test(test_disk_sincos),
		cmocka_unit_test(test_cosine_lanes),
		cmocka_unit_test(test_alias),
		cmocka_unit_test(test_uniform_hemisphere),
		cmocka_unit_test(test_uniform_sphere),
		cmocka_unit_test(test_pdf_normalisation),
		cmocka_unit_test(test_uniform_cone),
		cmocka_unit_test(test_disk),
		cmocka_unit_test(test_triangle),
		cmocka_unit_test(test_frame),
		cmocka_unit_test(test_distrib_frequencies),
		cmocka_unit_test(test_distrib_zero_weights),
		cmocka_unit_test(test_distrib_invalid),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
