/*
 * test_lanes.c: the photon packers of the SIMD lanes (lanes.h) against
 * photon.h's, bit for bit: pm_rgbe_pack4 against pm_rgbe_pack on random
 * fluxes over forty binades, with dithers that push the maximum up to 256
 * (the exponent's carry), zeros, values below the cut-off, and NaN;
 * pm_dir_pack4 against pm_dir_pack on random directions of every octant,
 * the axes, the zero vector and unnormalised ones; pm_fresnel4 against
 * pm_fresnel_dielectric on cosines of both signs and indices of
 * refraction on either side of one, and one.  Where the compiler
 * has no SSE2 (PM_LANES 0) there are no lanes to test.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "../../common/bsdf.h"
#include "../../common/lanes.h"
#include "../../common/photon.h"
#include "../../common/rng.h"

#if PM_LANES
/* A flux channel: now and then zero, tiny or a power of two (a
 * maximum's mantissa at its ends), else a random magnitude. */
static float
channel(struct pm_rng *r)
{
	float u = pm_rng_float(r), e = 40.0f * pm_rng_float(r) - 20.0f;

	if (u < 0.05f)
		return 0.0f;
	if (u < 0.08f)
		return 1e-33f * pm_rng_float(r);
	if (u < 0.12f)
		return ldexpf(1.0f, (int)e);
	if (u < 0.16f)	/* just under a power of two: the carry */
		return ldexpf(1.0f - 0x1p-24f * (float)(1 + (int)(8 *
		    pm_rng_float(r))), (int)e);
	return ldexpf(0.5f + 0.5f * pm_rng_float(r), (int)e);
}

static void
test_rgbe_pack4(void **state)
{
	struct pm_rng r = pm_rng_seed(7, 1, 2);
	int i, k, carried = 0;

	(void)state;
	for (i = 0; i < 400000; i += 4) {
		float c[3][4], u[4];
		int32_t o[4][4];

		for (k = 0; k < 4; k++) {
			c[0][k] = channel(&r);
			c[1][k] = channel(&r);
			c[2][k] = channel(&r);
			/* dithers near 1 carry a maximum near 256 over */
			u[k] = i % 3 == 0 ? 1.0f - 0x1p-24f * (float)(1 +
			    (int)(64 * pm_rng_float(&r))) : pm_rng_float(&r);
			if (i % 4001 == 0 && k == 1)
				c[1][k] = NAN;
		}
		pm_rgbe_pack4(_mm_loadu_ps(c[0]), _mm_loadu_ps(c[1]),
		    _mm_loadu_ps(c[2]), _mm_loadu_ps(u), o[0], o[1], o[2], o[3]);
		for (k = 0; k < 4; k++) {
			uint8_t want[4];
			int q;

			pm_rgbe_pack(pm_rgb(c[0][k], c[1][k], c[2][k]), u[k],
			    want);
			for (q = 0; q < 4; q++)
				assert_int_equal(o[q][k], want[q]);
			if (want[3] != 0) {
				float top = fmaxf(c[0][k], fmaxf(c[1][k],
				    c[2][k]));

				carried += (int)want[3] - 128 > ilogbf(top) + 1;
			}
		}
	}
	print_message("rgbe lanes: 400000 fluxes, %d carried to the next "
	    "exponent, all the scalar bytes\n", carried);
	assert_true(carried > 100);
}

static void
test_dir_pack4(void **state)
{
	struct pm_rng r = pm_rng_seed(7, 3, 4);
	int i, k;

	(void)state;
	for (i = 0; i < 400000; i += 4) {
		float v[3][4];
		int32_t o[2][4];

		for (k = 0; k < 4; k++) {
			int a;

			for (a = 0; a < 3; a++)
				v[a][k] = 4.0f * pm_rng_float(&r) - 2.0f;
			if (i % 97 == 0)	/* an axis, either way */
				for (a = 0; a < 3; a++)
					v[a][k] = a == k % 3 ?
					    (k & 1 ? -1.0f : 1.0f) : 0.0f;
			if (i % 1009 == 0 && k == 2)
				v[0][k] = v[1][k] = v[2][k] = 0.0f;
		}
		pm_dir_pack4(_mm_loadu_ps(v[0]), _mm_loadu_ps(v[1]),
		    _mm_loadu_ps(v[2]), o[0], o[1]);
		for (k = 0; k < 4; k++) {
			uint8_t want[2];

			pm_dir_pack(pm_v3(v[0][k], v[1][k], v[2][k]), want);
			assert_int_equal(o[0][k], want[0]);
			assert_int_equal(o[1][k], want[1]);
		}
	}
}

/* pm_fresnel4 against pm_fresnel_dielectric, bit for bit: cosines of
 * both signs, zero (grazing), one and near one; indices of refraction
 * below and above one, and one itself (index matched). */
static void
test_fresnel4(void **state)
{
	static const float etas[] = { 1.5f, 1.33f, 1.0f, 0.75f, 2.4f,
	    1.000277f };
	struct pm_rng r = pm_rng_seed(7, 5, 6);
	int i, k, inside = 0;

	(void)state;
	for (i = 0; i < 400000; i += 4) {
		float c[4], e[4], o[4];

		for (k = 0; k < 4; k++) {
			c[k] = 2.0f * pm_rng_float(&r) - 1.0f;
			if (i % 89 == 0)
				c[k] = k == 0 ? 0.0f : k == 1 ? -0.0f : k == 2 ?
				    1.0f : -1.0f;
			if (i % 53 == 4)	/* near the normal */
				c[k] = 1.0f - 0x1p-24f * (float)(1 + (int)(64 *
				    pm_rng_float(&r)));
			e[k] = etas[(i / 4 + k) % 6];
			inside += c[k] < 0.0f;
		}
		_mm_storeu_ps(o, pm_fresnel4(_mm_loadu_ps(c), _mm_loadu_ps(e)));
		for (k = 0; k < 4; k++) {
			float want = pm_fresnel_dielectric(c[k], e[k], NULL);

			assert_memory_equal(&o[k], &want, sizeof(want));
		}
	}
	assert_true(inside > 100000);
}
#else
static void
test_fresnel4(void **state)
{
	(void)state;
}

static void
test_rgbe_pack4(void **state)
{
	(void)state;
	print_message("no SIMD lanes in this build\n");
}

static void
test_dir_pack4(void **state)
{
	(void)state;
}
#endif

int
main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_rgbe_pack4),
		cmocka_unit_test(test_dir_pack4),
		cmocka_unit_test(test_fresnel4),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
