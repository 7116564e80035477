/*
 * stats.h: the statistics the unit tests share: the regularised upper
 * incomplete gamma function, Pearson's chi-square test of a histogram
 * against expected counts, with the p-value it gives, and the histogram of
 * directions over the sphere those tests fill.
 */
#ifndef PM_TEST_STATS_H
#define PM_TEST_STATS_H

#include <stddef.h>

#include "../../common/vec.h"

/* Regularised upper incomplete gamma Q(a, x), for chi-square p-values:
 * a series for P(a, x) below x = a + 1, a continued fraction above. */
double stats_gamma_q(double a, double x);

/* What becomes of the bins expecting fewer than five samples, which are
 * always pooled into one. */
enum stats_pool {
	/* The pool is a bin of its own if it expects five or more (or is
	 * all there is), else it joins the bin expecting least; a sample
	 * where the pool expects at most 1e-9 gives p = 0. */
	STATS_POOL_JOIN,
	/* The pool is a bin of its own whose expectation counts as at
	 * least five; a sample where nothing at all was pooled in
	 * expectation gives p = 0. */
	STATS_POOL_OWN,
};

/*
 * Pearson's test of obs[0..n) against expd[0..n): the p-value of the
 * chi-square statistic with one degree of freedom fewer than the bins
 * after pooling (1 when only one is left).  Prints the statistic on
 * stderr, labelled what, when p falls below report_below, and says so
 * when samples fell where none were expected.
 */
double stats_chi2(const double *obs, const double *expd, size_t n,
    enum stats_pool pool, double report_below, const char *what);

/* Bin of a direction on the nz x nphi grid of (z, phi) over the sphere,
 * z from -1 to 1 and phi from 0 to 2 pi, clamped to the grid. */
size_t stats_sphere_bin(struct pm_vec3 v, int nz, int nphi);

/*
 * n times the integral of pdf (with ctx) over each bin of that grid,
 * dw = dz dphi, by a sub x sub midpoint rule, into expd[0..nz * nphi);
 * returns their sum.
 */
double stats_sphere_expected(double (*pdf)(struct pm_vec3, const void *),
    const void *ctx, double n, int nz, int nphi, int sub, double *expd);

#endif
