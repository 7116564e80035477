/*
 * bsdf_check.c: what the BSDF unit tests share (bsdf_check.h), once
 * instead of a copy in each of them.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "../../common/rng.h"
#include "bsdf_check.h"
#include "stats.h"

void
est_add(struct est *e, double x)
{
	double d = x - e->mean;

	e->n += 1.0;
	e->mean += d / e->n;
	e->m2 += d * (x - e->mean);
}

double
est_err(const struct est *e)
{
	return e->n > 1.0 ? sqrt(e->m2 / (e->n - 1.0) / e->n) : 0.0;
}

bool
close_to(double a, double b, double tol, const char *what)
{
	if (fabs(a - b) <= tol)
		return true;
	fprintf(stderr, "%s: %.9g versus %.9g (tolerance %.3g)\n", what, a, b,
	    tol);
	return false;
}

struct pm_vec3
dir(double theta, double phi)
{
	return pm_v3((float)(sin(theta) * cos(phi)),
	    (float)(sin(theta) * sin(phi)), (float)cos(theta));
}

double
facet_cos(struct pm_vec3 wi, struct pm_vec3 wo, float ior)
{
	double ei = wi.z > 0 ? 1.0 : ior, eo = wo.z > 0 ? 1.0 : ior;
	double h[3], l, a, c;

	if (wi.z * wo.z > 0)
		ei = eo = 1.0;
	h[0] = ei * wi.x + eo * wo.x;
	h[1] = ei * wi.y + eo * wo.y;
	h[2] = ei * wi.z + eo * wo.z;
	l = sqrt(h[0] * h[0] + h[1] * h[1] + h[2] * h[2]);
	if (!(l > 0))
		return 0.0;
	a = fabs((wi.x * h[0] + wi.y * h[1] + wi.z * h[2]) / l);
	c = fabs((wo.x * h[0] + wo.y * h[1] + wo.z * h[2]) / l);
	return fmin(a, c);
}

/* pdf() of one BSDF for one wi, as stats_sphere_expected wants it. */
struct bsdf_at {
	const struct pm_bsdf *b;
	struct pm_vec3 wi;
};

static double
bsdf_pdf(struct pm_vec3 wo, const void *ctx)
{
	const struct bsdf_at *at = ctx;

	return pm_bsdf_pdf(at->b, at->wi, wo);
}

double
bsdf_chi2(const struct pm_bsdf *b, struct pm_vec3 wi, uint64_t seed,
    int nz, int nphi, double report, const char *what, bsdf_chi2_each *each,
    double *total)
{
	const int n = BSDF_CHI2_N;
	const size_t bins = (size_t)nz * (size_t)nphi;
	const struct bsdf_at at = { b, wi };
	struct pm_rng rng = pm_rng_seed(seed, 0, 0);
	struct pm_bsdf_sample s;
	double *obs = calloc(2 * (bins + 1), sizeof(*obs));
	double *expd = obs + bins + 1, p;
	int i;

	if (!obs) {
		fprintf(stderr, "bsdf_chi2: out of memory\n");
		abort();
	}
	for (i = 0; i < n; i++) {
		float u1 = pm_rng_float(&rng), u2 = pm_rng_float(&rng);
		float u3 = pm_rng_float(&rng);

		if (!pm_bsdf_sample(b, wi, u1, u2, u3, PM_RADIANCE, &s)) {
			obs[bins] += 1.0;
			continue;
		}
		if (each)
			each(b, wi, i, &s, what);
		if (s.lobe & PM_LOBE_DELTA)
			obs[bins] += 1.0;
		else
			obs[stats_sphere_bin(s.wo, nz, nphi)] += 1.0;
	}
	*total = stats_sphere_expected(bsdf_pdf, &at, n, nz, nphi, 12, expd);
	expd[bins] = fmax(0.0, n - *total);
	p = stats_chi2(obs, expd, bins + 1, STATS_POOL_JOIN, report, what);
	free(obs);
	return p;
}
