/*
 * test_spectrum.c: the reduction of spectra to linear sRGB.  Checked
 * against what can be worked out by hand: the sRGB matrix maps D65's
 * white to (1, 1, 1); a flat reflectance under D65 stays grey with Y = 1;
 * a flat emitted spectrum has XYZ = (1, 1, 1); the conversion is linear;
 * Planck's law obeys Wien's displacement law and the Stefan-Boltzmann
 * law; the colour matching functions interpolate their 5 nm table.
 */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>

#include "../../common/spectrum.h"

#define NEAR(a, b, tol) assert_true(fabs((double)(a) - (double)(b)) <= (tol))

static void
test_matrix_white(void **state)
{
	/* D65's white point, Y = 1 (x = 0.3127, y = 0.3290). */
	double x = 0.3127, y = 0.3290;
	double xyz[3] = {x / y, 1.0, (1.0 - x - y) / y};
	struct pm_rgb c = pm_xyz_to_srgb(xyz);

	(void)state;
	NEAR(c.r, 1.0, 1e-3);
	NEAR(c.g, 1.0, 1e-3);
	NEAR(c.b, 1.0, 1e-3);
}

static void
test_cmf_table(void **state)
{
	double a[3], b[3], m[3];
	int k;

	(void)state;
	pm_cie1931_xyz(555.0, a);
	NEAR(a[1], 1.0, 1e-7);		/* y peaks at 1 at 555 nm */
	pm_cie1931_xyz(560.0, b);
	pm_cie1931_xyz(557.5, m);
	for (k = 0; k < 3; k++)
		NEAR(m[k], 0.5 * (a[k] + b[k]), 1e-6);
	pm_cie1931_xyz(359.0, a);
	pm_cie1931_xyz(831.0, b);
	for (k = 0; k < 3; k++) {
		NEAR(a[k], 0.0, 0.0);
		NEAR(b[k], 0.0, 0.0);
	}
	NEAR(pm_cie_d65(560.0), 100.0 / 98.99741751876255, 1e-6);
}

static void
test_flat_reflectance_is_grey(void **state)
{
	static const double wl[2] = {300.0, 900.0}, v[2] = {0.5, 0.5};
	bool clamped = true;
	struct pm_rgb c = pm_spectrum_to_srgb(wl, v, 2, true, true, &clamped);

	(void)state;
	/* D65 is sRGB's white and scaled to Y = 1: grey 0.5, to the
	 * accuracy of Mitsuba's 1000-step sum. */
	NEAR(c.r, 0.5, 2e-3);
	NEAR(c.g, 0.5, 2e-3);
	NEAR(c.b, 0.5, 2e-3);
	assert_false(clamped);
}

static void
test_flat_emission(void **state)
{
	static const double wl[2] = {360.0, 830.0}, v[2] = {1.0, 1.0};
	static const double one[3] = {1.0, 1.0, 1.0};
	struct pm_rgb c = pm_spectrum_to_srgb(wl, v, 2, false, false, NULL);
	struct pm_rgb e = pm_xyz_to_srgb(one);

	(void)state;
	/* Without D65 a unit spectrum has X = Y = Z = 1 (the curves have
	 * equal areas), a reddish white in sRGB. */
	NEAR(e.r, 3.240479 - 1.537150 - 0.498535, 1e-6);
	NEAR(c.r, e.r, 1e-3);
	NEAR(c.g, e.g, 1e-3);
	NEAR(c.b, e.b, 1e-3);
}

static void
test_linear_and_clamped(void **state)
{
	static const double wl[4] = {400.0, 500.0, 600.0, 700.0};
	static const double v1[4] = {0.1, 0.9, 0.2, 0.5};
	double v3[4];
	struct pm_rgb a, b;
	bool clamped;
	int i;

	(void)state;
	for (i = 0; i < 4; i++)
		v3[i] = 3.0 * v1[i];
	a = pm_spectrum_to_srgb(wl, v1, 4, false, false, NULL);
	b = pm_spectrum_to_srgb(wl, v3, 4, false, false, NULL);
	NEAR(b.r, 3.0 * a.r, 1e-5);
	NEAR(b.g, 3.0 * a.g, 1e-5);
	NEAR(b.b, 3.0 * a.b, 1e-5);
	/* Bounded (a reflectance), three times too bright is clamped. */
	b = pm_spectrum_to_srgb(wl, v3, 4, true, true, &clamped);
	assert_true(clamped);
	assert_true(b.g <= 1.0f && b.r >= 0.0f && b.b <= 1.0f);
	/* Entirely outside 360..830 nm: black. */
	{
		static const double w2[2] = {200.0, 300.0}, o[2] = {1.0, 1.0};

		a = pm_spectrum_to_srgb(w2, o, 2, true, true, NULL);
		NEAR(a.r, 0.0, 0.0);
		NEAR(a.g, 0.0, 0.0);
		NEAR(a.b, 0.0, 0.0);
	}
}

static void
test_planck(void **state)
{
	const double T = 5000.0, sigma = 5.670374419e-8;
	double best = 0.0, at = 0.0, sum = 0.0, nm;

	(void)state;
	/* Wien: the peak of B(lambda) is at 2897.77 um K / T. */
	for (nm = 400.0; nm <= 800.0; nm += 0.25) {
		double b = pm_blackbody(nm, T);

		if (b > best) {
			best = b;
			at = nm;
		}
	}
	NEAR(at, 2897771.955 / T, 0.25);
	/* Stefan-Boltzmann: pi * integral of B over all wavelengths is
	 * sigma T^4 (B per nm, so sum in nm). */
	for (nm = 10.0; nm < 200000.0; nm += 1.0)
		sum += pm_blackbody(nm + 0.5, T);
	NEAR(PM_PI * sum / (sigma * pow(T, 4.0)), 1.0, 1e-4);
	assert_true(pm_blackbody(500.0, 0.0) == 0.0);
}

static void
test_blackbody_colour(void **state)
{
	struct pm_rgb lo = pm_blackbody_to_srgb(2000.0, 360.0, 830.0);
	struct pm_rgb hi = pm_blackbody_to_srgb(12000.0, 360.0, 830.0);
	struct pm_rgb cut = pm_blackbody_to_srgb(5000.0, 500.0, 600.0);
	struct pm_rgb all = pm_blackbody_to_srgb(5000.0, 360.0, 830.0);

	(void)state;
	/* A cool body is red, a hot one blue. */
	assert_true(lo.r > lo.g && lo.g > lo.b);
	assert_true(hi.b > hi.r);
	/* Cutting the range removes light. */
	assert_true(cut.r < all.r && cut.b < all.b);
}

int
main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_matrix_white),
		cmocka_unit_test(test_cmf_table),
		cmocka_unit_test(test_flat_reflectance_is_grey),
		cmocka_unit_test(test_flat_emission),
		cmocka_unit_test(test_linear_and_clamped),
		cmocka_unit_test(test_planck),
		cmocka_unit_test(test_blackbody_colour),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
