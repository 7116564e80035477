/*
 * stats.c: the statistics the unit tests share (stats.h): the incomplete
 * gamma function, Pearson's chi-square test and the histogram over the
 * sphere, once for every test of a sampler (test_sampling, test_bsdf,
 * test_merl).
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "stats.h"

/* Q(a, x) = 1 - P(a, x). */
double
stats_gamma_q(double a, double x)
{
	double lead, sum, term, b, c, d, h, an, del;
	int i;

	if (x <= 0.0)
		return 1.0;
	lead = exp(-x + a * log(x) - lgamma(a));
	if (x < a + 1.0) {
		/* series for P(a, x) */
		sum = term = 1.0 / a;
		for (i = 1; i < 100000; i++) {
			term *= x / (a + i);
			sum += term;
			if (fabs(term) < fabs(sum) * 1e-15)
				break;
		}
		return 1.0 - sum * lead;
	}
	/* continued fraction for Q(a, x), modified Lentz */
	b = x + 1.0 - a;
	c = 1e300;
	d = 1.0 / b;
	h = d;
	for (i = 1; i < 100000; i++) {
		an = -i * (i - a);
		b += 2.0;
		d = an * d + b;
		if (fabs(d) < 1e-300)
			d = 1e-300;
		c = b + an / c;
		if (fabs(c) < 1e-300)
			c = 1e-300;
		d = 1.0 / d;
		del = d * c;
		h *= del;
		if (fabs(del - 1.0) < 1e-15)
			break;
	}
	return lead * h;
}

/* STATS_POOL_JOIN: the statistic over the kept bins, the pool a bin of
 * its own or joined to the smallest; *k gets the number of bins, and
 * -1 means samples where none were expected (or no memory). */
static double
chi2_join(const double *obs, const double *expd, size_t n, size_t *k,
    const char *what)
{
	double pool_e = 0.0, pool_o = 0.0, chi2 = 0.0;
	double *ke = malloc((n + 1) * sizeof(double));
	double *ko = malloc((n + 1) * sizeof(double));
	size_t i, smallest = 0;

	*k = 0;
	if (ke == NULL || ko == NULL) {
		fprintf(stderr, "%s: out of memory\n", what);
		free(ke);
		free(ko);
		return -1.0;
	}
	for (i = 0; i < n; i++) {
		if (expd[i] < 5.0) {
			pool_e += expd[i];
			pool_o += obs[i];
		} else {
			ke[*k] = expd[i];
			ko[*k] = obs[i];
			(*k)++;
		}
	}
	if (pool_e <= 1e-9 && pool_o > 0.0) {
		fprintf(stderr, "%s: %g samples where none were expected\n",
		    what, pool_o);
		free(ke);
		free(ko);
		return -1.0;
	}
	if (pool_e > 0.0) {
		if (pool_e >= 5.0 || *k == 0) {
			ke[*k] = pool_e;
			ko[*k] = pool_o;
			(*k)++;
		} else {
			for (i = 1; i < *k; i++)
				if (ke[i] < ke[smallest])
					smallest = i;
			ke[smallest] += pool_e;
			ko[smallest] += pool_o;
		}
	}
	for (i = 0; i < *k; i++)
		chi2 += (ko[i] - ke[i]) * (ko[i] - ke[i]) / ke[i];
	free(ke);
	free(ko);
	return chi2;
}

/* STATS_POOL_OWN: as chi2_join, the pool always a bin of its own. */
static double
chi2_own(const double *obs, const double *expd, size_t n, size_t *k,
    const char *what)
{
	double chi2 = 0.0, pe = 0.0, po = 0.0;
	size_t i;

	*k = 0;
	for (i = 0; i < n; i++) {
		if (expd[i] < 5.0) {
			pe += expd[i];
			po += obs[i];
			continue;
		}
		chi2 += (obs[i] - expd[i]) * (obs[i] - expd[i]) / expd[i];
		(*k)++;
	}
	if (pe > 0.0) {
		chi2 += (po - pe) * (po - pe) / fmax(pe, 5.0);
		(*k)++;
	} else if (po > 0.0) {
		fprintf(stderr, "%s: %g samples where none were expected\n",
		    what, po);
		return -1.0;
	}
	return chi2;
}

/* The p-value of Pearson's statistic, 0 for an impossible sample. */
double
stats_chi2(const double *obs, const double *expd, size_t n,
    enum stats_pool pool, double report_below, const char *what)
{
	size_t k;
	double chi2, p;

	chi2 = pool == STATS_POOL_JOIN ? chi2_join(obs, expd, n, &k, what) :
	    chi2_own(obs, expd, n, &k, what);
	if (chi2 < 0.0)
		return 0.0;
	p = k > 1 ? stats_gamma_q(0.5 * (double)(k - 1), 0.5 * chi2) : 1.0;
	if (p < report_below)
		fprintf(stderr, "%s: chi2 %.1f with %zu dof, p = %g\n", what,
		    chi2, k - 1, p);
	return p;
}

#define TWO_PI 6.283185307179586

/* The (z, phi) bin of v, row-major in z. */
size_t
stats_sphere_bin(struct pm_vec3 v, int nz, int nphi)
{
	double phi = atan2(v.y, v.x);
	int iz, ip;

	if (phi < 0.0)
		phi += TWO_PI;
	iz = (int)floor((v.z + 1.0) * 0.5 * nz);
	ip = (int)floor(phi / TWO_PI * nphi);
	iz = iz < 0 ? 0 : iz >= nz ? nz - 1 : iz;
	ip = ip < 0 ? 0 : ip >= nphi ? nphi - 1 : ip;
	return (size_t)iz * nphi + (size_t)ip;
}

/* The expected counts of each bin, and their sum. */
double
stats_sphere_expected(double (*pdf)(struct pm_vec3, const void *),
    const void *ctx, double n, int nz, int nphi, int sub, double *expd)
{
	double dz = 2.0 / nz, dp = TWO_PI / nphi, z, phi, r, sum, total = 0.0;
	int iz, ip, a, c;

	for (iz = 0; iz < nz; iz++)
		for (ip = 0; ip < nphi; ip++) {
			sum = 0.0;
			for (a = 0; a < sub; a++)
				for (c = 0; c < sub; c++) {
					z = -1.0 + dz * (iz + (a + 0.5) / sub);
					phi = dp * (ip + (c + 0.5) / sub);
					r = sqrt(fmax(0.0, 1.0 - z * z));
					sum += pdf(pm_v3((float)(r * cos(phi)),
					    (float)(r * sin(phi)), (float)z),
					    ctx);
				}
			expd[iz * nphi + ip] = n * sum * dz * dp /
			    (sub * sub);
			total += expd[iz * nphi + ip];
		}
	return total;
}
