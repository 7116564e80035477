/*
 * spectrum.c: the CIE tables and the reduction of spectra to linear sRGB
 * (see spectrum.h for the method and why it is Mitsuba's).
 */
#include <math.h>

#include "spectrum.h"

/*
 * The CIE 1931 2-degree standard colour matching functions x, y, z at
 * 5 nm from 360 to 830 nm (CIE 015:2004, Table T.4; the same 95 rows
 * Mitsuba 3 tabulates, checked against its cie1931_xyz by
 * tests/mitsuba/spectra.py).
 */
static const float cie1931[PM_CIE_SAMPLES][3] = {
	{0.0001299f, 0.000003917f, 0.0006061f},	/* 360 */
	{0.0002321f, 0.000006965f, 0.001086f},	/* 365 */
	{0.0004149f, 0.00001239f, 0.001946f},	/* 370 */
	{0.0007416f, 0.00002202f, 0.003486f},	/* 375 */
	{0.001368f, 0.000039f, 0.006450001f},	/* 380 */
	{0.002236f, 0.000064f, 0.01054999f},	/* 385 */
	{0.004243f, 0.00012f, 0.02005001f},	/* 390 */
	{0.00765f, 0.000217f, 0.03621f},	/* 395 */
	{0.01431f, 0.000396f, 0.06785001f},	/* 400 */
	{0.02319f, 0.00064f, 0.1102f},	/* 405 */
	{0.04351f, 0.00121f, 0.2074f},	/* 410 */
	{0.07763f, 0.00218f, 0.3713f},	/* 415 */
	{0.13438f, 0.004f, 0.6456f},	/* 420 */
	{0.21477f, 0.0073f, 1.0390501f},	/* 425 */
	{0.2839f, 0.0116f, 1.3856f},	/* 430 */
	{0.3285f, 0.01684f, 1.62296f},	/* 435 */
	{0.34828f, 0.023f, 1.74706f},	/* 440 */
	{0.34806f, 0.0298f, 1.7826f},	/* 445 */
	{0.3362f, 0.038f, 1.77211f},	/* 450 */
	{0.3187f, 0.048f, 1.7441f},	/* 455 */
	{0.2908f, 0.06f, 1.6692f},	/* 460 */
	{0.2511f, 0.0739f, 1.5281f},	/* 465 */
	{0.19536f, 0.09098f, 1.28764f},	/* 470 */
	{0.1421f, 0.1126f, 1.0419f},	/* 475 */
	{0.09564f, 0.13902f, 0.8129501f},	/* 480 */
	{0.05795001f, 0.1693f, 0.6162f},	/* 485 */
	{0.03201f, 0.20802f, 0.46518f},	/* 490 */
	{0.0147f, 0.2586f, 0.3533f},	/* 495 */
	{0.0049f, 0.323f, 0.272f},	/* 500 */
	{0.0024f, 0.4073f, 0.2123f},	/* 505 */
	{0.0093f, 0.503f, 0.1582f},	/* 510 */
	{0.0291f, 0.6082f, 0.1117f},	/* 515 */
	{0.06327f, 0.71f, 0.07824999f},	/* 520 */
	{0.1096f, 0.7932f, 0.05725001f},	/* 525 */
	{0.1655f, 0.862f, 0.04216f},	/* 530 */
	{0.2257499f, 0.9148501f, 0.02984f},	/* 535 */
	{0.2904f, 0.954f, 0.0203f},	/* 540 */
	{0.3597f, 0.9803f, 0.0134f},	/* 545 */
	{0.4334499f, 0.9949501f, 0.008749999f},	/* 550 */
	{0.5120501f, 1.0f, 0.005749999f},	/* 555 */
	{0.5945f, 0.995f, 0.0039f},	/* 560 */
	{0.6784f, 0.9786f, 0.002749999f},	/* 565 */
	{0.7621f, 0.952f, 0.0021f},	/* 570 */
	{0.8425f, 0.9154f, 0.0018f},	/* 575 */
	{0.9163f, 0.87f, 0.001650001f},	/* 580 */
	{0.9786f, 0.8163f, 0.0014f},	/* 585 */
	{1.0263f, 0.757f, 0.0011f},	/* 590 */
	{1.0567f, 0.6949f, 0.001f},	/* 595 */
	{1.0622f, 0.631f, 0.0008f},	/* 600 */
	{1.0456f, 0.5668f, 0.0006f},	/* 605 */
	{1.0026f, 0.503f, 0.00034f},	/* 610 */
	{0.9384f, 0.4412f, 0.00024f},	/* 615 */
	{0.8544499f, 0.381f, 0.00019f},	/* 620 */
	{0.7514f, 0.321f, 0.0001f},	/* 625 */
	{0.6424f, 0.265f, 0.00004999999f},	/* 630 */
	{0.5419f, 0.217f, 0.00003f},	/* 635 */
	{0.4479f, 0.175f, 0.00002f},	/* 640 */
	{0.3608f, 0.1382f, 0.00001f},	/* 645 */
	{0.2835f, 0.107f, 0.0f},	/* 650 */
	{0.2187f, 0.0816f, 0.0f},	/* 655 */
	{0.1649f, 0.061f, 0.0f},	/* 660 */
	{0.1212f, 0.04458f, 0.0f},	/* 665 */
	{0.0874f, 0.032f, 0.0f},	/* 670 */
	{0.0636f, 0.0232f, 0.0f},	/* 675 */
	{0.04677f, 0.017f, 0.0f},	/* 680 */
	{0.0329f, 0.01192f, 0.0f},	/* 685 */
	{0.0227f, 0.00821f, 0.0f},	/* 690 */
	{0.01584f, 0.005723f, 0.0f},	/* 695 */
	{0.01135916f, 0.004102f, 0.0f},	/* 700 */
	{0.008110916f, 0.002929f, 0.0f},	/* 705 */
	{0.005790346f, 0.002091f, 0.0f},	/* 710 */
	{0.004109457f, 0.001484f, 0.0f},	/* 715 */
	{0.002899327f, 0.001047f, 0.0f},	/* 720 */
	{0.00204919f, 0.00074f, 0.0f},	/* 725 */
	{0.001439971f, 0.00052f, 0.0f},	/* 730 */
	{0.0009999493f, 0.0003611f, 0.0f},	/* 735 */
	{0.0006900786f, 0.0002492f, 0.0f},	/* 740 */
	{0.0004760213f, 0.0001719f, 0.0f},	/* 745 */
	{0.0003323011f, 0.00012f, 0.0f},	/* 750 */
	{0.0002348261f, 0.0000848f, 0.0f},	/* 755 */
	{0.0001661505f, 0.00006f, 0.0f},	/* 760 */
	{0.000117413f, 0.0000424f, 0.0f},	/* 765 */
	{0.00008307527f, 0.00003f, 0.0f},	/* 770 */
	{0.00005870652f, 0.0000212f, 0.0f},	/* 775 */
	{0.00004150994f, 0.00001499f, 0.0f},	/* 780 */
	{0.00002935326f, 0.0000106f, 0.0f},	/* 785 */
	{0.00002067383f, 0.0000074657f, 0.0f},	/* 790 */
	{0.00001455977f, 0.0000052578f, 0.0f},	/* 795 */
	{0.00001025398f, 0.0000037029f, 0.0f},	/* 800 */
	{0.000007221456f, 0.0000026078f, 0.0f},	/* 805 */
	{0.000005085868f, 0.0000018366f, 0.0f},	/* 810 */
	{0.000003581652f, 0.0000012934f, 0.0f},	/* 815 */
	{0.000002522525f, 0.00000091093f, 0.0f},	/* 820 */
	{0.000001776509f, 0.00000064153f, 0.0f},	/* 825 */
	{0.000001251141f, 0.00000045181f, 0.0f},	/* 830 */
};

/* The CIE standard illuminant D65, relative spectral power (100 at
 * 560 nm), at the same wavelengths (CIE 015:2004, Table T.1). */
static const float d65[PM_CIE_SAMPLES] = {
	46.6383f, 49.3637f, 52.0891f, 51.0323f, 49.9755f, 52.3118f, 54.6482f,
	68.7015f, 82.7549f, 87.1204f, 91.486f,  92.4589f, 93.4318f, 90.057f,
	86.6823f, 95.7736f, 104.865f, 110.936f, 117.008f, 117.41f,  117.812f,
	116.336f, 114.861f, 115.392f, 115.923f, 112.367f, 108.811f, 109.082f,
	109.354f, 108.578f, 107.802f, 106.296f, 104.79f,  106.239f, 107.689f,
	106.047f, 104.405f, 104.225f, 104.046f, 102.023f, 100.0f,   98.1671f,
	96.3342f, 96.0611f, 95.788f,  92.2368f, 88.6856f, 89.3459f, 90.0062f,
	89.8026f, 89.5991f, 88.6489f, 87.6987f, 85.4936f, 83.2886f, 83.4939f,
	83.6992f, 81.863f,  80.0268f, 80.1207f, 80.2146f, 81.2462f, 82.2778f,
	80.281f,  78.2842f, 74.0027f, 69.7213f, 70.6652f, 71.6091f, 72.979f,
	74.349f,  67.9765f, 61.604f,  65.7448f, 69.8856f, 72.4863f, 75.087f,
	69.3398f, 63.5927f, 55.0054f, 46.4182f, 56.6118f, 66.8054f, 65.0941f,
	63.3828f, 63.8434f, 64.304f,  61.8779f, 59.4519f, 55.7054f, 51.959f,
	54.6998f, 57.4406f, 58.8765f, 60.3125f
};

/* A unit spectrum integrates against y to this (Mitsuba's
 * MI_CIE_Y_NORMALIZATION is its inverse), and D65 against y to this
 * times the D65 scale below. */
#define CIE_Y_INTEGRAL	106.7502593994140625
#define D65_SCALE	(1.0 / 98.99741751876255)
/* Mitsuba integrates by this many evenly spaced samples over 360..830 nm
 * and weighs each by (830 - 360) / STEPS. */
#define STEPS		1000

/* Table position of nm: entry i and the weight of entry i + 1; false
 * outside the table. */
static bool
table_pos(double nm, int *i, double *w)
{
	double t;

	if (!(nm >= PM_CIE_MIN && nm <= PM_CIE_MAX))
		return false;
	t = (nm - PM_CIE_MIN) * ((PM_CIE_SAMPLES - 1) / (PM_CIE_MAX - PM_CIE_MIN));
	*i = (int)t;
	if (*i > PM_CIE_SAMPLES - 2)
		*i = PM_CIE_SAMPLES - 2;
	*w = t - *i;
	return true;
}

void
pm_cie1931_xyz(double nm, double xyz[3])
{
	double w;
	int i, k;

	if (!table_pos(nm, &i, &w)) {
		xyz[0] = xyz[1] = xyz[2] = 0.0;
		return;
	}
	for (k = 0; k < 3; k++)
		xyz[k] = (1.0 - w) * cie1931[i][k] + w * cie1931[i + 1][k];
}

double
pm_cie_d65(double nm)
{
	double w;
	int i;

	if (!table_pos(nm, &i, &w))
		return 0.0;
	return ((1.0 - w) * d65[i] + w * d65[i + 1]) * D65_SCALE;
}

double
pm_blackbody(double nm, double kelvin)
{
	/* SI values of the speed of light, Planck's and Boltzmann's
	 * constants (CODATA 2018). */
	const double c = 2.99792458e8, h = 6.62607015e-34, k = 1.380649e-23;
	double l = nm * 1e-9;

	if (!(kelvin > 0.0) || !(l > 0.0))
		return 0.0;
	/* 2 h c^2 / l^5 / (exp(h c / (l k T)) - 1) per metre of wavelength;
	 * 1e-9 of that per nanometre. */
	return 1e-9 * 2.0 * h * c * c / (pow(l, 5.0) *
	    expm1(h * c / (l * k * kelvin)));
}

struct pm_rgb
pm_xyz_to_srgb(const double xyz[3])
{
	double r = 3.240479 * xyz[0] - 1.537150 * xyz[1] - 0.498535 * xyz[2];
	double g = -0.969256 * xyz[0] + 1.875991 * xyz[1] + 0.041556 * xyz[2];
	double b = 0.055648 * xyz[0] - 0.204043 * xyz[1] + 1.057311 * xyz[2];

	return pm_rgb((float)r, (float)g, (float)b);
}

/* The rgb of the integral in xyz, clamped as pm_spectrum_to_srgb says. */
static struct pm_rgb
finish(double xyz[3], bool bounded, bool *clamped)
{
	struct pm_rgb c;
	bool cl = false;
	int k;

	for (k = 0; k < 3; k++)
		xyz[k] *= (PM_CIE_MAX - PM_CIE_MIN) / STEPS / CIE_Y_INTEGRAL;
	c = pm_xyz_to_srgb(xyz);
	if (c.r < 0.0f || c.g < 0.0f || c.b < 0.0f)
		cl = true;
	if (bounded && (c.r > 1.0f || c.g > 1.0f || c.b > 1.0f))
		cl = true;
	if (cl) {
		c.r = pm_fmaxf(c.r, 0.0f);
		c.g = pm_fmaxf(c.g, 0.0f);
		c.b = pm_fmaxf(c.b, 0.0f);
		if (bounded) {
			c.r = pm_fminf(c.r, 1.0f);
			c.g = pm_fminf(c.g, 1.0f);
			c.b = pm_fminf(c.b, 1.0f);
		}
	}
	if (clamped != NULL)
		*clamped = cl;
	return c;
}

static double
step_nm(int i)
{
	return PM_CIE_MIN + (i / (double)(STEPS - 1)) * (PM_CIE_MAX - PM_CIE_MIN);
}

struct pm_rgb
pm_spectrum_to_srgb(const double *wl, const double *v, size_t n, bool use_d65,
    bool bounded, bool *clamped)
{
	double xyz[3] = {0.0, 0.0, 0.0}, cmf[3];
	size_t j = 0;
	int i, k;

	for (i = 0; i < STEPS; i++) {
		double x = step_nm(i), y;

		if (x < wl[0] || x > wl[n - 1])
			continue;
		/* The last interval whose start is at or below x; the
		 * steps increase, so the search only moves forward. */
		while (j + 2 < n && wl[j + 1] <= x)
			j++;
		y = ((x - wl[j + 1]) * v[j] + (wl[j] - x) * v[j + 1]) /
		    (wl[j] - wl[j + 1]);
		if (use_d65)
			y *= pm_cie_d65(x);
		pm_cie1931_xyz(x, cmf);
		for (k = 0; k < 3; k++)
			xyz[k] += cmf[k] * y;
	}
	return finish(xyz, bounded, clamped);
}

struct pm_rgb
pm_blackbody_to_srgb(double kelvin, double wmin, double wmax)
{
	double xyz[3] = {0.0, 0.0, 0.0}, cmf[3];
	int i, k;

	for (i = 0; i < STEPS; i++) {
		double x = step_nm(i), y;

		if (x < wmin || x > wmax)
			continue;
		y = pm_blackbody(x, kelvin);
		pm_cie1931_xyz(x, cmf);
		for (k = 0; k < 3; k++)
			xyz[k] += cmf[k] * y;
	}
	return finish(xyz, false, NULL);
}
