/*
 * bsdf_check.h: what the BSDF unit tests (test_bsdf, test_frames,
 * test_principled, test_composite) share: a running mean with its
 * standard error, a tolerance check that says what differed, a direction
 * from spherical angles, the cosine at a microfacet, and the chi-square
 * test of a BSDF's sampler against its pdf().
 */
#ifndef PM_TEST_BSDF_CHECK_H
#define PM_TEST_BSDF_CHECK_H

#include <stdbool.h>
#include <stdint.h>

#include "../../common/bsdf.h"
#include "../../common/vec.h"

/* Running mean and variance (Welford). */
struct est {
	double n, mean, m2;
};

void est_add(struct est *e, double x);

/* Standard error of the mean (0 below two values). */
double est_err(const struct est *e);

/* |a - b| <= tol; says on stderr, labelled what, when not. */
bool close_to(double a, double b, double tol, const char *what);

/* The unit vector at polar angle theta from +z and azimuth phi. */
struct pm_vec3 dir(double theta, double phi);

/* The smaller cosine between the facet normal joining wi and wo (for a
 * glass of relative IOR ior) and either direction, in double: where it is
 * near zero, refraction is near its critical angle, 1 - F changes
 * steeply, and float answers differ in their third digit. */
double facet_cos(struct pm_vec3 wi, struct pm_vec3 wo, float ior);

/* How many samples bsdf_chi2 draws. */
#define BSDF_CHI2_N 1000000

/* Called on each sample pm_bsdf_sample gives (delta ones too), i its
 * index among the BSDF_CHI2_N, for checks of single samples. */
typedef void bsdf_chi2_each(const struct pm_bsdf *b, struct pm_vec3 wi,
    int i, const struct pm_bsdf_sample *s, const char *what);

/*
 * Samples b at wi (radiance) BSDF_CHI2_N times from pm_rng_seed(seed,
 * 0, 0), three numbers a sample, into a histogram over the nz x nphi
 * (z, phi) grid of stats_sphere_bin plus one bin for samples that failed
 * or are delta; the expected counts integrate pdf() over each bin
 * (stats_sphere_expected, 12 x 12 midpoints), the extra bin expects the
 * rest.  Returns the p-value of stats_chi2 (bins under five pooled,
 * STATS_POOL_JOIN; the statistic printed, labelled what, below report)
 * and sets *total to the expected count over the grid, which should
 * be at most BSDF_CHI2_N.  each, unless NULL, sees every sample.
 */
double bsdf_chi2(const struct pm_bsdf *b, struct pm_vec3 wi, uint64_t seed,
    int nz, int nphi, double report, const char *what, bsdf_chi2_each *each,
    double *total);

#endif
