/*
 * test_bsdf.c: every material against analytic answers and against itself.
 *
 *   - Fresnel: normal incidence, Brewster's angle, total internal
 *     reflection, Snell's law, the conductor's normal-incidence formula;
 *   - energy: the albedo integrated from eval over the sphere agrees with
 *     the mean sample weight, and neither exceeds one (white furnaces:
 *     a white diffuse surface and clear glass give exactly one);
 *   - consistency: each sample's pdf and weight equal pdf() and
 *     eval()/pdf(); reciprocity of the non-delta BSDFs;
 *   - sampling: chi-square tests that sampled directions follow pdf(),
 *     with the delta or failed samples as one more bin;
 *   - the delta materials' directions, weights and relative IORs.
 *
 * Random numbers use fixed seeds.  Chi-square tests reject at 1e-3 over
 * their number (Bonferroni); Monte Carlo comparisons allow six standard
 * errors, estimated from the samples themselves.
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

#include "../../common/bsdf.h"
#include "../../common/rng.h"
#include "../../common/sampling.h"
#include "bsdf_check.h"

#define NCHI2 6
#define SIGNIFICANCE (1e-3 / NCHI2)
#define NZ 50
#define NPHI 50
#define NSIGMA 6.0

/* ---- materials ---- */

static struct pm_bsdf
mk(enum pm_bsdf_type type)
{
	struct pm_bsdf b;

	memset(&b, 0, sizeof(b));
	b.type = type;
	b.diffuse = pm_rgb1(0.5f);
	b.specular = pm_rgb1(1.0f);
	b.transmittance = pm_rgb1(1.0f);
	b.eta = pm_rgb1(0.0f);
	b.k = pm_rgb1(1.0f);
	b.ior = 1.5046f / 1.000277f;
	b.alpha = 0.1f;
	b.sample_visible = true;
	pm_bsdf_prepare(&b);
	return b;
}

static struct pm_bsdf
mk_diffuse(float r, bool twosided)
{
	struct pm_bsdf b = mk(PM_BSDF_DIFFUSE);

	b.diffuse = pm_rgb(r, r * 0.5f, r * 0.25f);
	b.twosided = twosided;
	pm_bsdf_prepare(&b);
	return b;
}

static struct pm_bsdf
mk_rough(float alpha, bool visible, const char *metal)
{
	struct pm_bsdf b = mk(PM_BSDF_ROUGHCONDUCTOR);

	b.alpha = alpha;
	b.sample_visible = visible;
	assert_true(pm_conductor_lookup(metal, &b.eta, &b.k));
	pm_bsdf_prepare(&b);
	return b;
}

static struct pm_bsdf
mk_plastic(float ior, struct pm_rgb diffuse, bool nonlinear)
{
	struct pm_bsdf b = mk(PM_BSDF_PLASTIC);

	b.ior = ior;
	b.diffuse = diffuse;
	b.nonlinear = nonlinear;
	pm_bsdf_prepare(&b);
	return b;
}

static struct pm_bsdf
mk_dielectric(enum pm_bsdf_type type, float ior)
{
	struct pm_bsdf b = mk(type);

	b.ior = ior;
	pm_bsdf_prepare(&b);
	return b;
}

/* ---- Fresnel ---- */

static void
test_fresnel_dielectric(void **state)
{
	static const float ns[] = { 1.000277f, 1.333f, 1.5f, 2.419f };
	double n, r0, tb, ci, ct, st, rs, ra, cts;
	float cos_t, r;
	size_t i;
	int k;

	(void)state;
	for (i = 0; i < sizeof(ns) / sizeof(ns[0]); i++) {
		n = ns[i];
		r0 = (n - 1.0) * (n - 1.0) / ((n + 1.0) * (n + 1.0));
		/* normal incidence, from outside and from inside */
		r = pm_fresnel_dielectric(1.0f, ns[i], &cos_t);
		assert_true(close_to(r, r0, 1e-6, "R(0) outside"));
		assert_true(close_to(cos_t, -1.0, 1e-6, "cos_t(0) outside"));
		r = pm_fresnel_dielectric(-1.0f, ns[i], &cos_t);
		assert_true(close_to(r, r0, 1e-6, "R(0) inside"));
		assert_true(close_to(cos_t, 1.0, 1e-6, "cos_t(0) inside"));

		/* Brewster: R_p vanishes, so R = R_s / 2 (both sides) */
		for (k = 0; k < 2; k++) {
			double m = k == 0 ? n : 1.0 / n;

			tb = atan(m);
			ci = cos(tb);
			st = sin(tb) / m;
			ct = sqrt(1.0 - st * st);
			rs = (ci - m * ct) / (ci + m * ct);
			rs *= rs;
			r = pm_fresnel_dielectric(k == 0 ? (float)ci :
			    -(float)ci, ns[i], &cos_t);
			assert_true(close_to(r, 0.5 * rs, 2e-6, "Brewster"));
			assert_true(close_to(fabs(cos_t), ct, 1e-5,
			    "Brewster cos_t"));
		}

		/* Snell's law at assorted angles, and R grows with angle */
		ra = -1.0;
		for (k = 0; k < 89; k++) {
			ci = cos(k * M_PI / 180.0);
			r = pm_fresnel_dielectric((float)ci, ns[i], &cos_t);
			cts = 1.0 - (1.0 - ci * ci) / (n * n);
			assert_true(close_to(cos_t, -sqrt(cts), 1e-5,
			    "Snell"));
			assert_true(r >= 0.0f && r <= 1.0f);
			assert_true(r >= ra - 1e-7);
			ra = r;
		}

		/* total internal reflection beyond the critical angle */
		if (n > 1.1) {
			for (k = 0; k < 20; k++) {
				double tc = asin(1.0 / n);
				double t = tc + (M_PI / 2 - tc) *
				    (k + 0.5) / 20.0;

				r = pm_fresnel_dielectric(-(float)cos(t),
				    ns[i], &cos_t);
				assert_true(r == 1.0f);
				assert_true(cos_t == 0.0f);
			}
			/* just inside the critical angle some light leaves */
			r = pm_fresnel_dielectric(-(float)cos(asin(1.0 / n) -
			    0.01), ns[i], &cos_t);
			assert_true(r < 1.0f && cos_t > 0.0f);
		}
	}
	/* matched indices reflect nothing and do not bend */
	r = pm_fresnel_dielectric(0.3f, 1.0f, &cos_t);
	assert_true(r == 0.0f);
	assert_true(close_to(cos_t, -0.3, 1e-6, "matched"));
	/* grazing incidence reflects everything */
	assert_true(pm_fresnel_dielectric(0.0f, 1.5f, NULL) == 1.0f);
}

static void
test_fresnel_conductor(void **state)
{
	static const char *metals[] = { "Au", "Ag", "Cu", "Al", "Cr" };
	struct pm_rgb eta, k, r;
	float cos_t, rd;
	double e, kk, r0[3];
	size_t i;
	int c, a;

	(void)state;
	for (i = 0; i < sizeof(metals) / sizeof(metals[0]); i++) {
		assert_true(pm_conductor_lookup(metals[i], &eta, &k));
		r = pm_fresnel_conductor(1.0f, eta, k);
		for (c = 0; c < 3; c++) {
			e = c == 0 ? eta.r : c == 1 ? eta.g : eta.b;
			kk = c == 0 ? k.r : c == 1 ? k.g : k.b;
			r0[c] = ((e - 1) * (e - 1) + kk * kk) /
			    ((e + 1) * (e + 1) + kk * kk);
		}
		assert_true(close_to(r.r, r0[0], 1e-5, metals[i]));
		assert_true(close_to(r.g, r0[1], 1e-5, metals[i]));
		assert_true(close_to(r.b, r0[2], 1e-5, metals[i]));
		/* metals reflect strongly, more so at grazing angles */
		assert_true(r.r > 0.4f && r.r < 1.0f);
		assert_true(pm_fresnel_conductor(0.05f, eta, k).g > r.g);
	}
	/* gold is yellow: red reflects more than blue */
	assert_true(pm_conductor_lookup("Au", &eta, &k));
	r = pm_fresnel_conductor(1.0f, eta, k);
	assert_true(r.r > r.b + 0.3f);

	/* "none" is a perfect mirror at every angle */
	assert_true(pm_conductor_lookup("none", &eta, &k));
	assert_true(eta.r == 0.0f && k.g == 1.0f);
	for (a = 0; a < 90; a++) {
		r = pm_fresnel_conductor((float)cos(a * M_PI / 180.0), eta, k);
		assert_true(close_to(r.r, 1.0, 1e-6, "none"));
		assert_true(close_to(r.b, 1.0, 1e-6, "none"));
	}
	/* with k = 0 a conductor is a dielectric */
	for (a = 0; a < 89; a++) {
		float ci = (float)cos(a * M_PI / 180.0);

		r = pm_fresnel_conductor(ci, pm_rgb1(1.5f), pm_rgb1(0.0f));
		rd = pm_fresnel_dielectric(ci, 1.5f, &cos_t);
		assert_true(close_to(r.g, rd, 1e-5, "k = 0"));
	}
	assert_false(pm_conductor_lookup("au", &eta, &k));
	assert_false(pm_conductor_lookup("unobtainium", &eta, &k));
}

static void
test_ior_lookup(void **state)
{
	static const struct {
		const char *name;
		float ior;
	} known[] = {
		{ "vacuum", 1.0f }, { "helium", 1.000036f },
		{ "hydrogen", 1.000132f }, { "air", 1.000277f },
		{ "carbon dioxide", 1.00045f }, { "water", 1.333f },
		{ "acetone", 1.36f }, { "ethanol", 1.361f },
		{ "carbon tetrachloride", 1.461f }, { "glycerol", 1.4729f },
		{ "benzene", 1.501f }, { "silicone oil", 1.52045f },
		{ "bromine", 1.661f }, { "water ice", 1.31f },
		{ "fused quartz", 1.458f }, { "pyrex", 1.47f },
		{ "acrylic glass", 1.49f }, { "polypropylene", 1.49f },
		{ "bk7", 1.5046f }, { "sodium chloride", 1.544f },
		{ "amber", 1.55f }, { "pet", 1.575f }, { "diamond", 2.419f },
	};
	float ior;
	size_t i;

	(void)state;
	for (i = 0; i < sizeof(known) / sizeof(known[0]); i++) {
		ior = 0.0f;
		assert_true(pm_ior_lookup(known[i].name, &ior));
		assert_true(ior == known[i].ior);
	}
	assert_true(pm_ior_lookup("BK7", &ior) && ior == 1.5046f);
	assert_false(pm_ior_lookup("glass", &ior));
	assert_false(pm_ior_lookup("", &ior));
}

/* fdr_int is the cosine-weighted internal reflectance of the coating. */
static void
test_plastic_tables(void **state)
{
	static const float iors[] = { 1.33f, 1.49f, 1.7f, 1.9f };
	struct pm_bsdf b;
	double sum, mu;
	size_t i;
	int k;
	const int n = 100000;

	(void)state;
	for (i = 0; i < sizeof(iors) / sizeof(iors[0]); i++) {
		b = mk_plastic(iors[i], pm_rgb(0.2f, 0.4f, 0.6f), false);
		/* 2 * integral of R(mu) mu dmu from inside, midpoint rule */
		for (sum = 0.0, k = 0; k < n; k++) {
			mu = (k + 0.5) / n;
			sum += pm_fresnel_dielectric(-(float)mu, iors[i],
			    NULL) * mu;
		}
		sum *= 2.0 / n;
		assert_true(close_to(b.fdr_int, sum, 0.01 * sum, "fdr_int"));
		/* the coated base: rho/(1 - fdr), or rho/(1 - rho fdr) */
		for (k = 0; k < 6; k++) {
			struct pm_vec3 wi = dir(0.4, 0.0), wo = dir(1.1, 2.0);
			double fi = pm_fresnel_dielectric(wi.z, iors[i], NULL);
			double fo = pm_fresnel_dielectric(wo.z, iors[i], NULL);
			double rho = 0.2 * (k % 3 + 1), eff, f, got;
			struct pm_rgb e;

			b.nonlinear = k >= 3;
			eff = b.nonlinear ? rho / (1.0 - rho * b.fdr_int) :
			    rho / (1.0 - b.fdr_int);
			f = eff * (1.0 - fi) * (1.0 - fo) /
			    ((double)iors[i] * iors[i]) * wo.z / M_PI;
			e = pm_bsdf_eval(&b, wi, wo, PM_IMPORTANCE);
			got = k % 3 == 0 ? e.r : k % 3 == 1 ? e.g : e.b;
			assert_true(close_to(got, f, 1e-5 * f, "plastic eval"));
		}
		/* Mitsuba's lobe choice: F ssw against (1 - F)(1 - ssw) */
		{
			struct pm_vec3 wi = dir(1.2, 0.0), wo = dir(0.3, 1.0);
			double fi = pm_fresnel_dielectric(wi.z, iors[i], NULL);
			double w = b.specular_sampling_weight;
			double ps = fi * w / (fi * w + (1.0 - fi) * (1.0 - w));

			assert_true(close_to(pm_bsdf_pdf(&b, wi, wo),
			    (1.0 - ps) * wo.z / M_PI, 1e-6, "plastic pdf"));
		}
		b.nonlinear = false;
		/* mean specular 1 against mean diffuse 0.4 */
		assert_true(close_to(b.specular_sampling_weight, 1.0 / 1.4,
		    1e-6, "specular_sampling_weight"));
	}
}

static void
test_lobes(void **state)
{
	struct pm_bsdf b;

	(void)state;
	b = mk(PM_BSDF_DIFFUSE);
	assert_int_equal(b.lobes, PM_LOBE_DIFFUSE);
	assert_false(pm_bsdf_is_delta(&b));
	b = mk(PM_BSDF_CONDUCTOR);
	assert_int_equal(b.lobes, PM_LOBE_DELTA_REFLECTION);
	assert_true(pm_bsdf_is_delta(&b));
	b = mk(PM_BSDF_ROUGHCONDUCTOR);
	assert_int_equal(b.lobes, PM_LOBE_GLOSSY);
	assert_false(pm_bsdf_is_delta(&b));
	b = mk(PM_BSDF_DIELECTRIC);
	assert_int_equal(b.lobes, PM_LOBE_DELTA);
	assert_true(pm_bsdf_is_delta(&b));
	b = mk(PM_BSDF_THINDIELECTRIC);
	assert_int_equal(b.lobes, PM_LOBE_DELTA);
	assert_true(pm_bsdf_is_delta(&b));
	b = mk(PM_BSDF_PLASTIC);
	assert_int_equal(b.lobes, PM_LOBE_DELTA_REFLECTION | PM_LOBE_DIFFUSE);
	assert_false(pm_bsdf_is_delta(&b));
	b = mk(PM_BSDF_NULL);
	assert_int_equal(b.lobes, PM_LOBE_DELTA_TRANSMISSION);
	assert_true(pm_bsdf_is_delta(&b));
}

/* Rough conductor against GGX written out in its textbook form. */
static void
test_rough_analytic(void **state)
{
	static const float alphas[] = { 0.05f, 0.3f, 0.8f };
	struct pm_bsdf b;
	struct pm_vec3 wi, wo, h;
	struct pm_rgb f, fr;
	double a2, th, d, g1i, g1o, ti, to, expect;
	size_t i;
	int k;

	(void)state;
	for (i = 0; i < sizeof(alphas) / sizeof(alphas[0]); i++) {
		b = mk_rough(alphas[i], true, "Cu");
		b.specular = pm_rgb(1.0f, 0.5f, 0.25f);
		a2 = (double)alphas[i] * alphas[i];
		/* normal incidence and exit: D = 1/(pi a^2), G = 1 */
		f = pm_bsdf_eval(&b, pm_v3(0, 0, 1), pm_v3(0, 0, 1),
		    PM_RADIANCE);
		fr = pm_fresnel_conductor(1.0f, b.eta, b.k);
		assert_true(close_to(f.g, 0.5 * fr.g / (4.0 * M_PI * a2),
		    1e-5 * f.g, "rough normal"));
		for (k = 0; k < 10; k++) {
			wi = dir(0.1 + 0.15 * k, 0.3);
			wo = dir(1.3 - 0.1 * k, 0.3 + 0.4 * k);
			h = pm_normalize(pm_add(wi, wo));
			th = acos(h.z);
			d = a2 / (M_PI * pow(cos(th), 4.0) *
			    pow(a2 + tan(th) * tan(th), 2.0));
			ti = tan(acos(wi.z));
			to = tan(acos(wo.z));
			g1i = 2.0 / (1.0 + sqrt(1.0 + a2 * ti * ti));
			g1o = 2.0 / (1.0 + sqrt(1.0 + a2 * to * to));
			fr = pm_fresnel_conductor(pm_dot(wi, h), b.eta, b.k);
			expect = fr.r * d * g1i * g1o / (4.0 * wi.z);
			f = pm_bsdf_eval(&b, wi, wo, PM_RADIANCE);
			if (!close_to(f.r, expect, 1e-4 * expect + 1e-12,
			    "rough eval"))
				fail();
		}
	}
}

/* Beckmann's rough conductor against its textbook form: D(m) =
 * exp(-tan^2 / a^2) / (pi a^2 cos^4), Smith's G1 by Walter et al.'s
 * rational fit (what Mitsuba 3 evaluates). */
static double
beckmann_g1_ref(double a2, double tan_t)
{
	double a = 1.0 / (sqrt(a2) * tan_t);

	if (tan_t == 0.0 || a >= 1.6)
		return 1.0;
	return (3.535 * a + 2.181 * a * a) / (1.0 + 2.276 * a + 2.577 * a * a);
}

static void
test_rough_beckmann_analytic(void **state)
{
	static const float alphas[] = { 0.05f, 0.3f, 0.8f };
	struct pm_bsdf b;
	struct pm_vec3 wi, wo, h;
	struct pm_rgb f, fr;
	double a2, th, d, expect;
	size_t i;
	int k;

	(void)state;
	for (i = 0; i < sizeof(alphas) / sizeof(alphas[0]); i++) {
		b = mk_rough(alphas[i], true, "Cu");
		b.beckmann = true;
		a2 = (double)alphas[i] * alphas[i];
		for (k = 0; k < 10; k++) {
			wi = dir(0.1 + 0.15 * k, 0.3);
			wo = dir(1.3 - 0.1 * k, 0.3 + 0.4 * k);
			h = pm_normalize(pm_add(wi, wo));
			th = acos(h.z);
			d = exp(-tan(th) * tan(th) / a2) /
			    (M_PI * a2 * pow(cos(th), 4.0));
			fr = pm_fresnel_conductor(pm_dot(wi, h), b.eta, b.k);
			expect = fr.r * d * beckmann_g1_ref(a2, tan(acos(wi.z))) *
			    beckmann_g1_ref(a2, tan(acos(wo.z))) / (4.0 * wi.z);
			f = pm_bsdf_eval(&b, wi, wo, PM_RADIANCE);
			if (!close_to(f.r, expect, 1e-4 * expect + 1e-12,
			    "beckmann eval"))
				fail();
		}
	}
}

/* ---- energy and consistency ---- */

struct albedo {
	struct est eval;	/* integral of eval over the sphere */
	struct est smooth;	/* non-delta sample weights (0 if delta) */
	struct est delta;	/* weights of delta samples (0 otherwise) */
	double maxc_eval, maxc_smooth;	/* largest channel means */
};

/*
 * Both estimates of the albedo from wi, plus per-sample checks that the
 * sampler's pdf and weight agree with pdf() and eval().  Tracks the red
 * channel statistically and every channel's mean for the bound.
 *
 * The integral of eval is estimated independently of the sampler under
 * test: directions come from a one-sample mixture of the uniform sphere
 * (a quarter, so that nothing is missed) and a guide, either the cosine
 * lobe or, for peaked BSDFs, another BSDF's sampler (the other normal
 * sampling technique) with its pdf().
 */
static void
albedo(const struct pm_bsdf *b, const struct pm_bsdf *guide,
    struct pm_vec3 wi, int n, uint64_t seed, struct albedo *a)
{
	const float frac = 0.25f;
	struct pm_rng rng = pm_rng_seed(seed, 1, 2);
	struct pm_bsdf_sample s;
	struct pm_rgb f, e, sum_e = pm_rgb1(0), sum_s = pm_rgb1(0);
	struct pm_vec3 wo;
	float pdf, u1, u2, u3;
	int i;

	memset(a, 0, sizeof(*a));
	for (i = 0; i < n; i++) {
		u1 = pm_rng_float(&rng);
		u2 = pm_rng_float(&rng);
		u3 = pm_rng_float(&rng);
		if (u1 < frac)
			wo = pm_square_to_uniform_sphere(u2, u3);
		else if (guide == NULL)
			wo = pm_square_to_cosine_hemisphere(u2, u3);
		else if (pm_bsdf_sample(guide, wi, 0.5f, u2, u3, PM_RADIANCE,
		    &s))
			wo = s.wo;
		else {
			est_add(&a->eval, 0.0);
			continue;
		}
		if (guide != NULL)
			pdf = pm_bsdf_pdf(guide, wi, wo);
		else
			pdf = pm_cosine_hemisphere_pdf(wo);
		pdf = frac / (4.0f * PM_PI) + (1.0f - frac) * pdf;
		f = pm_rgb_scale(pm_bsdf_eval(b, wi, wo, PM_RADIANCE),
		    1.0f / pdf);
		assert_true(pm_rgb_is_finite(f));
		assert_true(f.r >= 0.0f && f.g >= 0.0f && f.b >= 0.0f);
		est_add(&a->eval, f.r);
		sum_e = pm_rgb_add(sum_e, f);
	}
	for (i = 0; i < n; i++) {
		u1 = pm_rng_float(&rng);
		u2 = pm_rng_float(&rng);
		u3 = pm_rng_float(&rng);
		if (!pm_bsdf_sample(b, wi, u1, u2, u3, PM_RADIANCE, &s)) {
			est_add(&a->smooth, 0.0);
			est_add(&a->delta, 0.0);
			continue;
		}
		assert_true(pm_rgb_is_finite(s.weight));
		assert_true(fabsf(pm_length(s.wo) - 1.0f) < 1e-4f);
		if (s.lobe & PM_LOBE_DELTA) {
			assert_true(s.pdf == 1.0f);
			est_add(&a->delta, s.weight.r);
			est_add(&a->smooth, 0.0);
			continue;
		}
		est_add(&a->delta, 0.0);
		est_add(&a->smooth, s.weight.r);
		sum_s = pm_rgb_add(sum_s, s.weight);
		/* the sampler agrees with pdf() and eval() */
		pdf = pm_bsdf_pdf(b, wi, s.wo);
		assert_true(s.pdf > 0.0f);
		if (!close_to(s.pdf, pdf, 2e-3 * pdf + 1e-6, "sample pdf"))
			fail();
		e = pm_bsdf_eval(b, wi, s.wo, PM_RADIANCE);
		if (!close_to(s.weight.r, e.r / s.pdf,
		    2e-3 * s.weight.r + 1e-6, "sample weight"))
			fail();
	}
	a->maxc_eval = pm_rgb_max(sum_e) / n;
	a->maxc_smooth = pm_rgb_max(sum_s) / n;
}

/* The two estimates agree and the albedo is at most one. */
static void
check_albedo(const struct pm_bsdf *b, const char *name, float r_delta)
{
	static const double thetas[] = { 0.0, 0.7, 1.25, 1.5 };
	struct pm_bsdf other = *b;
	struct albedo a;
	double tol, tot;
	size_t i;

	/* rough conductors: guide with the other normal sampling technique */
	other.sample_visible = !b->sample_visible;
	for (i = 0; i < sizeof(thetas) / sizeof(thetas[0]); i++) {
		struct pm_vec3 wi = dir(thetas[i], 0.3 + i);

		albedo(b, b->type == PM_BSDF_ROUGHCONDUCTOR ? &other : NULL,
		    wi, 200000, 100 + i, &a);
		tol = NSIGMA * hypot(est_err(&a.eval), est_err(&a.smooth)) +
		    1e-4;
		if (!close_to(a.eval.mean, a.smooth.mean, tol, name))
			fail_msg("%s at theta %g", name, thetas[i]);
		/* delta part of plastic: specular * F(wi) exactly */
		if (r_delta >= 0.0f) {
			float fi = pm_fresnel_dielectric(wi.z, b->ior, NULL);

			struct pm_bsdf_sample cs;

			if (!close_to(a.delta.mean, r_delta * fi,
			    NSIGMA * est_err(&a.delta) + 1e-5, name))
				fail_msg("%s: delta part", name);
			/* pm-render follows the coating every time with this
			 * weight: it must be what the sampler's coating
			 * averages to */
			assert_true(pm_bsdf_coating(b, wi, &cs));
			if (!close_to(cs.weight.r, a.delta.mean,
			    NSIGMA * est_err(&a.delta) + 1e-5, name))
				fail_msg("%s: coating weight", name);
			assert_true(close_to(cs.weight.r, r_delta * fi, 1e-6,
			    name));
			assert_true(close_to(cs.wo.x, -wi.x, 1e-6, name) &&
			    close_to(cs.wo.y, -wi.y, 1e-6, name) &&
			    close_to(cs.wo.z, wi.z, 1e-6, name));
		}
		tot = fmax(a.maxc_eval, a.maxc_smooth) + a.delta.mean;
		if (tot > 1.0 + NSIGMA * est_err(&a.eval) + 1e-3)
			fail_msg("%s at theta %g: albedo %g > 1", name,
			    thetas[i], tot);
	}
}

/* Only plastic has a coating to follow, and only from above. */
static void
test_coating_only_plastic(void **state)
{
	struct pm_bsdf_sample cs;
	struct pm_bsdf b;

	(void)state;
	b = mk_plastic(1.49f, pm_rgb(0.5f, 0.5f, 0.5f), false);
	assert_true(pm_bsdf_coating(&b, dir(0.4, 0.1), &cs));
	assert_false(pm_bsdf_coating(&b, pm_neg(dir(0.4, 0.1)), &cs));
	b = mk_diffuse(0.8f, false);
	assert_false(pm_bsdf_coating(&b, dir(0.4, 0.1), &cs));
	b = mk_dielectric(PM_BSDF_DIELECTRIC, 1.5f);
	assert_false(pm_bsdf_coating(&b, dir(0.4, 0.1), &cs));
}

static void
test_albedo(void **state)
{
	static const float alphas[] = { 0.05f, 0.3f, 0.8f };
	struct pm_bsdf b;
	char name[64];
	size_t i;

	(void)state;
	b = mk_diffuse(0.8f, false);
	check_albedo(&b, "diffuse", -1.0f);
	for (i = 0; i < sizeof(alphas) / sizeof(alphas[0]); i++) {
		snprintf(name, sizeof(name), "rough none %g visible",
		    alphas[i]);
		b = mk_rough(alphas[i], true, "none");
		check_albedo(&b, name, -1.0f);
		snprintf(name, sizeof(name), "rough Au %g all normals",
		    alphas[i]);
		b = mk_rough(alphas[i], false, "Au");
		check_albedo(&b, name, -1.0f);
		snprintf(name, sizeof(name), "rough none %g beckmann",
		    alphas[i]);
		b = mk_rough(alphas[i], true, "none");
		b.beckmann = true;
		check_albedo(&b, name, -1.0f);
	}
	b = mk_plastic(1.49f, pm_rgb(0.5f, 0.5f, 0.5f), false);
	check_albedo(&b, "plastic", 1.0f);
	b = mk_plastic(1.9f, pm_rgb(0.1f, 0.27f, 0.36f), true);
	b.specular = pm_rgb(0.8f, 0.8f, 0.8f);
	pm_bsdf_prepare(&b);
	check_albedo(&b, "plastic nonlinear", 0.8f);
}

/* White furnaces: energy is conserved exactly where physics says so. */
static void
test_furnace(void **state)
{
	struct pm_bsdf b;
	struct pm_bsdf_sample s;
	struct albedo a;
	struct pm_rng rng = pm_rng_seed(7, 0, 0);
	static const double thetas[] = { 0.0, 0.5, 1.0, 1.4, 1.55 };
	static const float iors[] = { 1.5f, 1.0f / 1.5f };
	double nref, r, expect;
	size_t i, j;
	int k, n = 100000;

	(void)state;
	/* white Lambertian: every weight is one, the integral is one */
	b = mk(PM_BSDF_DIFFUSE);
	b.diffuse = pm_rgb1(1.0f);
	for (i = 0; i < sizeof(thetas) / sizeof(thetas[0]); i++) {
		albedo(&b, NULL, dir(thetas[i], 1.0), n, 200 + i, &a);
		assert_true(close_to(a.smooth.mean, 1.0, 1e-6, "white"));
		assert_true(close_to(a.eval.mean, 1.0,
		    NSIGMA * est_err(&a.eval), "white integral"));
	}

	/* clear glass: R + T = 1, each event chosen with its probability */
	for (j = 0; j < 2; j++) {
		b = mk_dielectric(PM_BSDF_DIELECTRIC, iors[j]);
		for (i = 0; i < sizeof(thetas) / sizeof(thetas[0]); i++) {
			struct pm_vec3 wi = dir(thetas[i], 0.5);
			double sum = 0.0;

			r = pm_fresnel_dielectric(wi.z, iors[j], NULL);
			nref = 0.0;
			for (k = 0; k < n; k++) {
				assert_true(pm_bsdf_sample(&b, wi,
				    pm_rng_float(&rng), 0.5f, 0.5f,
				    PM_IMPORTANCE, &s));
				nref += s.lobe == PM_LOBE_DELTA_REFLECTION;
				sum += s.weight.g;
			}
			assert_true(close_to(sum / n, 1.0, 1e-6,
			    "glass importance"));
			expect = n * r;
			assert_true(close_to(nref, expect,
			    NSIGMA * sqrt(n * r * (1 - r)) + 1.0,
			    "glass reflection count"));
		}
	}

	/* white plastic: only the accuracy of the Fdr fit stands between
	 * its albedo and one */
	b = mk_plastic(1.49f, pm_rgb1(1.0f), false);
	for (i = 0; i < 3; i++) {
		albedo(&b, NULL, dir(thetas[i], 0.2), n, 300 + i, &a);
		assert_true(close_to(a.smooth.mean + a.delta.mean, 1.0, 0.02,
		    "white plastic"));
	}
}

static void
check_reciprocity(const struct pm_bsdf *b, const char *name, bool below)
{
	struct pm_rng rng = pm_rng_seed(11, 0, 0);
	struct pm_vec3 wi, wo;
	struct pm_rgb f1, f2;
	int i;

	for (i = 0; i < 20000; i++) {
		wi = pm_square_to_uniform_hemisphere(pm_rng_float(&rng),
		    pm_rng_float(&rng));
		wo = pm_square_to_uniform_hemisphere(pm_rng_float(&rng),
		    pm_rng_float(&rng));
		if (wi.z < 1e-3f || wo.z < 1e-3f)
			continue;
		if (below) {
			wi.z = -wi.z;
			wo.z = -wo.z;
		}
		f1 = pm_rgb_scale(pm_bsdf_eval(b, wi, wo, PM_RADIANCE),
		    1.0f / fabsf(wo.z));
		f2 = pm_rgb_scale(pm_bsdf_eval(b, wo, wi, PM_RADIANCE),
		    1.0f / fabsf(wi.z));
		if (!close_to(f1.r, f2.r, 1e-4 * fmax(f1.r, f2.r) + 1e-7,
		    name) || !close_to(f1.b, f2.b,
		    1e-4 * fmax(f1.b, f2.b) + 1e-7, name))
			fail();
		if (!below)
			assert_true(f1.r > 0.0f || b->type ==
			    PM_BSDF_ROUGHCONDUCTOR);
		/* one-sided materials see nothing through the surface */
		if (!b->twosided) {
			wo.z = -wo.z;
			f1 = pm_bsdf_eval(b, wi, wo, PM_RADIANCE);
			assert_true(pm_rgb_is_black(f1));
			assert_true(pm_bsdf_pdf(b, wi, wo) == 0.0f);
		}
	}
}

static void
test_reciprocity(void **state)
{
	struct pm_bsdf b;

	(void)state;
	b = mk_diffuse(0.6f, false);
	check_reciprocity(&b, "diffuse", false);
	b = mk_diffuse(0.6f, true);
	check_reciprocity(&b, "diffuse twosided", true);
	b = mk_rough(0.05f, true, "Au");
	check_reciprocity(&b, "rough 0.05", false);
	b = mk_rough(0.3f, true, "Cu");
	check_reciprocity(&b, "rough 0.3", false);
	b = mk_rough(0.8f, false, "Al");
	check_reciprocity(&b, "rough 0.8", false);
	b = mk_rough(0.3f, true, "Cu");
	b.beckmann = true;
	check_reciprocity(&b, "beckmann 0.3", false);
	b.twosided = true;
	check_reciprocity(&b, "rough 0.8 twosided", true);
	b = mk_plastic(1.49f, pm_rgb(0.3f, 0.5f, 0.7f), false);
	check_reciprocity(&b, "plastic", false);
	b = mk_plastic(1.7f, pm_rgb(0.3f, 0.5f, 0.9f), true);
	check_reciprocity(&b, "plastic nonlinear", false);
}

/* ---- sampling follows pdf() ---- */

/* Sampled directions against pdf() on an NZ x NPHI grid, delta or
 * failed samples one more bin (bsdf_chi2). */
static void
check_sampling(const struct pm_bsdf *b, struct pm_vec3 wi, uint64_t seed,
    const char *what)
{
	const double n = BSDF_CHI2_N;
	double total, p;

	p = bsdf_chi2(b, wi, seed, NZ, NPHI, SIGNIFICANCE, what, NULL,
	    &total);
	assert_true(total <= n * 1.001);
	/* every case here samples a lobe most of the time */
	assert_true(total > 0.5 * n);
	assert_true(p > SIGNIFICANCE);
}

static void
test_sampling_diffuse(void **state)
{
	struct pm_bsdf b = mk_diffuse(0.5f, false);

	(void)state;
	check_sampling(&b, dir(0.5, 0.2), 21, "diffuse");
}

static void
test_sampling_rough(void **state)
{
	struct pm_bsdf b;

	(void)state;
	b = mk_rough(0.3f, true, "Au");
	check_sampling(&b, dir(0.9, 0.4), 22, "rough 0.3 visible");
	b = mk_rough(0.8f, true, "none");
	check_sampling(&b, dir(1.3, 2.0), 23, "rough 0.8 visible");
	b = mk_rough(0.2f, false, "Cu");
	check_sampling(&b, dir(1.0, -1.0), 24, "rough 0.2 all normals");
	b = mk_rough(0.3f, true, "Au");
	b.beckmann = true;
	check_sampling(&b, dir(0.9, 0.4), 26, "beckmann 0.3");
	b = mk_rough(0.7f, false, "none");
	b.beckmann = true;
	check_sampling(&b, dir(1.2, 1.0), 27, "beckmann 0.7");
	/* twosided, seen from below */
	b = mk_rough(0.5f, true, "Ag");
	b.twosided = true;
	check_sampling(&b, dir(M_PI - 0.6, 0.1), 25, "rough 0.5 below");
}

static void
test_sampling_plastic(void **state)
{
	struct pm_bsdf b = mk_plastic(1.49f, pm_rgb(0.5f, 0.3f, 0.2f), false);

	(void)state;
	check_sampling(&b, dir(1.2, 0.3), 26, "plastic");
}

/* ---- roughdielectric and roughplastic ---- */

static struct pm_bsdf
mk_roughglass(float alpha, bool beckmann, bool visible, float ior)
{
	struct pm_bsdf b = mk(PM_BSDF_ROUGHDIELECTRIC);

	b.alpha = alpha;
	b.beckmann = beckmann;
	b.sample_visible = visible;
	b.ior = ior;
	pm_bsdf_prepare(&b);
	return b;
}

static struct pm_bsdf
mk_roughplastic(float alpha, bool beckmann, float ior, struct pm_rgb diffuse,
    bool nonlinear)
{
	/* the tables' storage (a scene's, in pm): a ring, each BSDF made
	 * here keeping its own for the next 15 */
	static float tables[16][PM_ROUGH_T_RES];
	static int next;
	struct pm_bsdf b = mk(PM_BSDF_ROUGHPLASTIC);

	b.rough_t = tables[next++ % 16];

	b.alpha = alpha;
	b.beckmann = beckmann;
	b.ior = ior;
	b.diffuse = diffuse;
	b.nonlinear = nonlinear;
	pm_bsdf_prepare(&b);
	return b;
}

/* Roughdielectric against Walter et al.'s formulas written out: GGX's
 * D and G1 in their textbook form, the half vectors of eqs. 13 and 16,
 * the BTDF of eq. 21 (radiance: its eta_o^2 cancelled by the 1/eta^2 of
 * crossing, Mitsuba's convention). */
static void
test_roughglass_analytic(void **state)
{
	static const float alphas[] = { 0.05f, 0.3f, 0.8f };
	struct pm_rng rng = pm_rng_seed(41, 0, 0);
	struct pm_bsdf b;
	struct pm_vec3 wi, wo;
	double a2, th, d, g, f, ei, eo, expect, im, om, mx[3], l;
	struct pm_rgb e;
	size_t i;
	int k, checked = 0;

	(void)state;
	for (i = 0; i < sizeof(alphas) / sizeof(alphas[0]); i++) {
		b = mk_roughglass(alphas[i], false, true, 1.5f);
		b.transmittance = pm_rgb(1.0f, 0.5f, 0.25f);
		a2 = (double)alphas[i] * alphas[i];
		for (k = 0; k < 400; k++) {
			wi = pm_square_to_uniform_sphere(pm_rng_float(&rng),
			    pm_rng_float(&rng));
			wo = pm_square_to_uniform_sphere(pm_rng_float(&rng),
			    pm_rng_float(&rng));
			if (fabsf(wi.z) < 0.05f || fabsf(wo.z) < 0.05f)
				continue;
			ei = wi.z > 0 ? 1.0 : 1.5;
			eo = wo.z > 0 ? 1.0 : 1.5;
			if (wi.z * wo.z > 0)
				ei = eo = 1.0;
			mx[0] = ei * wi.x + eo * wo.x;
			mx[1] = ei * wi.y + eo * wo.y;
			mx[2] = ei * wi.z + eo * wo.z;
			l = sqrt(mx[0] * mx[0] + mx[1] * mx[1] +
			    mx[2] * mx[2]);
			if (mx[2] < 0)
				l = -l;
			mx[0] /= l;
			mx[1] /= l;
			mx[2] /= l;
			im = wi.x * mx[0] + wi.y * mx[1] + wi.z * mx[2];
			om = wo.x * mx[0] + wo.y * mx[1] + wo.z * mx[2];
			e = pm_bsdf_eval(&b, wi, wo, PM_RADIANCE);
			if (im * wi.z <= 0 || om * wo.z <= 0) {
				assert_true(pm_rgb_is_black(e));
				continue;
			}
			if (facet_cos(wi, wo, 1.5f) < 0.02)
				continue;
			th = acos(mx[2]);
			d = a2 / (M_PI * pow(cos(th), 4.0) *
			    pow(a2 + tan(th) * tan(th), 2.0));
			g = 2.0 / (1.0 + sqrt(1.0 + a2 * (1.0 - wi.z * wi.z) /
			    (wi.z * wi.z)));
			g *= 2.0 / (1.0 + sqrt(1.0 + a2 * (1.0 - wo.z * wo.z) /
			    (wo.z * wo.z)));
			f = pm_fresnel_dielectric((float)im, 1.5f, NULL);
			if (wi.z * wo.z > 0)
				expect = f * d * g / (4.0 * fabs(wi.z));
			else
				expect = 0.25 * fabs(im * om) * (1.0 - f) * d *
				    g * ei * ei / (fabs(wi.z) *
				    pow(ei * im + eo * om, 2.0));
			if (!close_to(wi.z * wo.z > 0 ? e.r : e.b, expect,
			    2e-4 * expect + 1e-9, "roughglass eval"))
				fail();
			checked++;
		}
	}
	assert_true(checked > 500);
}

/* Sampler, pdf() and eval() agree sample by sample, in both modes; the
 * mean weight (the albedo, reflection plus transmission, in importance
 * mode) never exceeds one, is near one for a nearly smooth interface,
 * and equals the integral of eval() under the other sampling technique
 * (GGX: all normals against visible normals). */
static void
check_roughglass_energy(const struct pm_bsdf *b, struct pm_vec3 wi,
    uint64_t seed, const char *name, double want_min)
{
	struct pm_rng rng = pm_rng_seed(seed, 3, 4);
	struct pm_bsdf other = *b;
	struct pm_bsdf_sample s;
	struct est w, e;
	struct pm_rgb f;
	float pdf;
	int i, n = 200000;

	memset(&w, 0, sizeof(w));
	memset(&e, 0, sizeof(e));
	other.sample_visible = !b->sample_visible;
	for (i = 0; i < n; i++) {
		float u1 = pm_rng_float(&rng), u2 = pm_rng_float(&rng);
		float u3 = pm_rng_float(&rng);

		if (!pm_bsdf_sample(b, wi, u1, u2, u3, PM_IMPORTANCE, &s)) {
			est_add(&w, 0.0);
		} else {
			assert_true(s.lobe == PM_LOBE_GLOSSY ||
			    s.lobe == PM_LOBE_GLOSSY_TRANSMISSION);
			assert_true((s.lobe == PM_LOBE_GLOSSY) ==
			    (s.wo.z * wi.z > 0.0f));
			assert_true(fabsf(pm_length(s.wo) - 1.0f) < 1e-4f);
			est_add(&w, s.weight.g);
			if (facet_cos(wi, s.wo, b->ior) < 0.02)
				goto other;
			pdf = pm_bsdf_pdf(b, wi, s.wo);
			if (!close_to(s.pdf, pdf, 2e-3 * pdf + 1e-6,
			    "roughglass sample pdf"))
				fail_msg("%s", name);
			f = pm_bsdf_eval(b, wi, s.wo, PM_IMPORTANCE);
			if (!close_to(s.weight.g, f.g / s.pdf,
			    2e-3 * s.weight.g + 1e-6, "roughglass weight"))
				fail_msg("%s", name);
			/* radiance differs by 1/eta^2 across */
			assert_true(pm_bsdf_sample(b, wi, u1, u2, u3,
			    PM_RADIANCE, &s));
			f = pm_bsdf_eval(b, wi, s.wo, PM_RADIANCE);
			if (!close_to(s.weight.g, f.g / s.pdf,
			    2e-3 * s.weight.g + 1e-6, "roughglass weight R"))
				fail_msg("%s", name);
		}
other:
		if (b->beckmann)
			continue;
		if (!pm_bsdf_sample(&other, wi, u1, u2, u3, PM_IMPORTANCE,
		    &s)) {
			est_add(&e, 0.0);
			continue;
		}
		f = pm_bsdf_eval(b, wi, s.wo, PM_IMPORTANCE);
		est_add(&e, f.g / pm_bsdf_pdf(&other, wi, s.wo));
	}
	print_message("%s: albedo %.5f +- %.5f\n", name, w.mean, est_err(&w));
	if (w.mean > 1.0 + NSIGMA * est_err(&w))
		fail_msg("%s: albedo %g > 1", name, w.mean);
	if (w.mean < want_min)
		fail_msg("%s: albedo %g < %g", name, w.mean, want_min);
	if (!b->beckmann && !close_to(w.mean, e.mean, NSIGMA *
	    hypot(est_err(&w), est_err(&e)) + 1e-4, name))
		fail_msg("%s: the two techniques disagree", name);
}

static void
test_roughglass_energy(void **state)
{
	static const double thetas[] = { 0.0, 0.7, 1.25 };
	char name[96];
	struct pm_bsdf b;
	size_t i;
	int k, side;

	(void)state;
	for (k = 0; k < 6; k++) {
		float alpha = k % 3 == 0 ? 0.01f : k % 3 == 1 ? 0.3f : 0.7f;
		bool beck = k >= 3;

		b = mk_roughglass(alpha, beck, true, 1.5f);
		for (side = 0; side < 2; side++)
			for (i = 0; i < 3; i++) {
				double th = side ? M_PI - thetas[i] :
				    thetas[i];
				/* masking costs little at low roughness,
				 * except at grazing angles */
				double want = alpha < 0.05f && i < 2 ?
				    0.99 : 0.5;

				snprintf(name, sizeof(name), "roughglass %s "
				    "%g theta %.2f", beck ? "beckmann" : "ggx",
				    alpha, th);
				check_roughglass_energy(&b, dir(th, 0.4),
				    500 + 10 * k + 3 * side + i, name, want);
			}
	}
}

/* Reflection is symmetric; transmission in radiance mode gains eta^2
 * (the relative IOR of wo's side over wi's) when the directions swap, and
 * the importance BTDF is the radiance BTDF with its arguments swapped. */
static void
test_roughglass_reciprocity(void **state)
{
	struct pm_rng rng = pm_rng_seed(43, 0, 0);
	struct pm_bsdf bs[3];
	struct pm_vec3 wi, wo;
	struct pm_rgb a, b2, c;
	float eta;
	size_t j;
	int i, nt = 0;

	(void)state;
	bs[0] = mk_roughglass(0.3f, false, true, 1.5f);
	bs[1] = mk_roughglass(0.3f, true, true, 1.33f);
	bs[2] = mk_roughglass(0.7f, false, false, 1.0f / 1.5f);
	for (j = 0; j < 3; j++)
		for (i = 0; i < 20000; i++) {
			wi = pm_square_to_uniform_sphere(pm_rng_float(&rng),
			    pm_rng_float(&rng));
			wo = pm_square_to_uniform_sphere(pm_rng_float(&rng),
			    pm_rng_float(&rng));
			if (fabsf(wi.z) < 1e-3f || fabsf(wo.z) < 1e-3f)
				continue;
			a = pm_rgb_scale(pm_bsdf_eval(&bs[j], wi, wo,
			    PM_RADIANCE), 1.0f / fabsf(wo.z));
			b2 = pm_rgb_scale(pm_bsdf_eval(&bs[j], wo, wi,
			    PM_RADIANCE), 1.0f / fabsf(wi.z));
			c = pm_rgb_scale(pm_bsdf_eval(&bs[j], wi, wo,
			    PM_IMPORTANCE), 1.0f / fabsf(wo.z));
			if (facet_cos(wi, wo, bs[j].ior) < 0.02)
				continue;
			eta = wi.z * wo.z > 0.0f ? 1.0f :
			    wi.z > 0.0f ? bs[j].ior : 1.0f / bs[j].ior;
			nt += wi.z * wo.z < 0.0f && a.g > 0.0f;
			if (!close_to(a.g * eta * eta, b2.g, 1e-3 * b2.g + 1e-7,
			    "roughglass reciprocity") ||
			    !close_to(c.g, b2.g, 1e-3 * b2.g + 1e-7,
			    "roughglass adjoint"))
				fail();
		}
	assert_true(nt > 1000);
}

static void
test_sampling_roughglass(void **state)
{
	struct pm_bsdf b;

	(void)state;
	b = mk_roughglass(0.3f, false, true, 1.5f);
	check_sampling(&b, dir(0.6, 0.4), 61, "roughglass ggx 0.3 visible");
	check_sampling(&b, dir(M_PI - 0.5, 1.0), 62,
	    "roughglass ggx 0.3 from inside");
	b = mk_roughglass(0.5f, false, false, 1.5f);
	check_sampling(&b, dir(1.1, -0.4), 63, "roughglass ggx 0.5 all");
	b = mk_roughglass(0.3f, true, true, 1.5f);
	check_sampling(&b, dir(0.9, 0.4), 64, "roughglass beckmann 0.3");
	check_sampling(&b, dir(M_PI - 0.3, 2.0), 65,
	    "roughglass beckmann 0.3 from inside");
	b = mk_roughglass(0.6f, true, true, 1.33f);
	check_sampling(&b, dir(1.3, 0.0), 66, "roughglass beckmann 0.6");
}

/* The coating's tables: transmittance against the rough dielectric's own
 * transmitted energy (importance weights of its sampler), 1 - Fresnel as
 * the coating smooths out, and the internal reflectance by Mitsuba's
 * rule against the rough dielectric's reflected energy from inside. */
static void
test_roughplastic_tables(void **state)
{
	static const int nodes[] = { 0, 9, 31, 50, 63 };
	struct pm_bsdf p, g;
	struct pm_bsdf_sample s;
	size_t i;
	int k, j, n = 100000;

	(void)state;
	for (k = 0; k < 4; k++) {
		float alpha = k % 2 ? 0.4f : 0.1f;
		bool beck = k >= 2;
		double rint = 0.0;

		p = mk_roughplastic(alpha, beck, 1.49f, pm_rgb1(0.5f), false);
		g = mk_roughglass(alpha, beck, true, 1.49f);
		for (i = 0; i < sizeof(nodes) / sizeof(nodes[0]); i++) {
			struct pm_rng rng = pm_rng_seed(70 + k, i, 0);
			float mu = fmaxf(1e-6f, nodes[i] / 63.0f);
			struct pm_vec3 wi = pm_v3(sqrtf(1 - mu * mu), 0, mu);
			struct est t;

			memset(&t, 0, sizeof(t));
			for (j = 0; j < n; j++) {
				if (pm_bsdf_sample(&g, wi, pm_rng_float(&rng),
				    pm_rng_float(&rng), pm_rng_float(&rng),
				    PM_IMPORTANCE, &s) &&
				    s.lobe == PM_LOBE_GLOSSY_TRANSMISSION)
					est_add(&t, s.weight.g);
				else
					est_add(&t, 0.0);
			}
			if (!close_to(p.rough_t[nodes[i]], t.mean,
			    NSIGMA * est_err(&t) + 2e-3, "rough_t"))
				fail_msg("alpha %g beckmann %d node %d", alpha,
				    beck, nodes[i]);
		}
		/* internal reflectance: 2 mean(R(mu) mu) over the nodes */
		g.ior = 1.0f / 1.49f;
		for (i = 0; i < 64; i++) {
			struct pm_rng rng = pm_rng_seed(80 + k, i, 0);
			float mu = fmaxf(1e-6f, i / 63.0f);
			struct pm_vec3 wi = pm_v3(sqrtf(1 - mu * mu), 0, mu);
			double r = 0.0;

			for (j = 0; j < 20000; j++)
				if (pm_bsdf_sample(&g, wi, pm_rng_float(&rng),
				    pm_rng_float(&rng), pm_rng_float(&rng),
				    PM_IMPORTANCE, &s) &&
				    s.lobe == PM_LOBE_GLOSSY)
					r += s.weight.g;
			rint += r / 20000.0 * mu;
		}
		rint *= 2.0 / 64.0;
		print_message("roughplastic alpha %g beckmann %d: fdr_int %.4f "
		    "(Monte Carlo %.4f)\n", alpha, beck, p.fdr_int, rint);
		assert_true(close_to(p.fdr_int, rint, 3e-3, "fdr_int"));
	}
	/* a nearly smooth coating transmits 1 - F */
	p = mk_roughplastic(1e-3f, false, 1.49f, pm_rgb1(0.5f), false);
	for (k = 1; k < 60; k++) {
		float mu = k / 63.0f;

		assert_true(close_to(p.rough_t[k], 1.0 -
		    pm_fresnel_dielectric(mu, 1.49f, NULL), 2e-3,
		    "smooth rough_t"));
	}
}

/* Roughplastic: the coating plus the base; `only` selects either, their
 * sum is the whole; the sampler steers by Mitsuba's rule. */
static void
test_roughplastic_eval(void **state)
{
	struct pm_rng rng = pm_rng_seed(45, 0, 0);
	struct pm_bsdf b, c, d;
	struct pm_bsdf_sample s;
	struct pm_vec3 wi, wo, h;
	struct pm_rgb e, ec, ed;
	double a2, th, dd, g, f, t, expect;
	int k;

	(void)state;
	b = mk_roughplastic(0.3f, false, 1.49f, pm_rgb(0.2f, 0.4f, 0.6f),
	    false);
	b.specular = pm_rgb1(0.8f);
	pm_bsdf_prepare(&b);
	c = d = b;
	c.only = PM_LOBE_GLOSSY;
	d.only = PM_LOBE_DIFFUSE;
	a2 = 0.09;
	for (k = 0; k < 200; k++) {
		wi = pm_square_to_uniform_hemisphere(pm_rng_float(&rng),
		    pm_rng_float(&rng));
		wo = pm_square_to_uniform_hemisphere(pm_rng_float(&rng),
		    pm_rng_float(&rng));
		if (wi.z < 0.02f || wo.z < 0.02f)
			continue;
		e = pm_bsdf_eval(&b, wi, wo, PM_RADIANCE);
		ec = pm_bsdf_eval(&c, wi, wo, PM_RADIANCE);
		ed = pm_bsdf_eval(&d, wi, wo, PM_RADIANCE);
		assert_true(close_to(e.b, ec.b + ed.b, 1e-5 * e.b, "sum"));
		h = pm_normalize(pm_add(wi, wo));
		th = acos(h.z);
		dd = a2 / (M_PI * pow(cos(th), 4.0) *
		    pow(a2 + tan(th) * tan(th), 2.0));
		g = 2.0 / (1.0 + sqrt(1.0 + a2 * (1.0 - wi.z * wi.z) /
		    (wi.z * wi.z)));
		g *= 2.0 / (1.0 + sqrt(1.0 + a2 * (1.0 - wo.z * wo.z) /
		    (wo.z * wo.z)));
		f = pm_fresnel_dielectric(pm_dot(wi, h), 1.49f, NULL);
		expect = 0.8 * f * dd * g / (4.0 * wi.z);
		assert_true(close_to(ec.g, expect, 2e-4 * expect + 1e-9,
		    "roughplastic coating"));
		/* the base: rho / (1 - fdr) T(wi) T(wo) cos / (pi eta^2),
		 * T interpolated in the table */
		t = 1.0;
		for (int q = 0; q < 2; q++) {
			double x = (q ? wo.z : wi.z) * 63.0;
			int ix = (int)x < 62 ? (int)x : 62;

			t *= b.rough_t[ix] + (x - ix) *
			    (b.rough_t[ix + 1] - b.rough_t[ix]);
		}
		expect = 0.6 / (1.0 - b.fdr_int) * t * wo.z /
		    (M_PI * 1.49 * 1.49);
		assert_true(close_to(ed.b, expect, 1e-4 * expect,
		    "roughplastic base"));
		/* each part samples itself alone */
		assert_true(close_to(pm_bsdf_pdf(&d, wi, wo), wo.z / M_PI,
		    1e-6, "base pdf"));
		if (pm_bsdf_sample(&c, wi, pm_rng_float(&rng),
		    pm_rng_float(&rng), pm_rng_float(&rng), PM_RADIANCE, &s))
			assert_true(s.lobe == PM_LOBE_GLOSSY);
		assert_true(pm_bsdf_sample(&d, wi, pm_rng_float(&rng),
		    pm_rng_float(&rng), pm_rng_float(&rng), PM_RADIANCE, &s));
		assert_true(s.lobe == PM_LOBE_DIFFUSE);
	}
	/* Mitsuba's steering: (1 - T) w against T (1 - w) */
	wi = dir(1.0, 0.0);
	wo = dir(0.5, 2.0);
	{
		double ti = b.rough_t[(int)(wi.z * 63.0)] + (wi.z * 63.0 -
		    (int)(wi.z * 63.0)) * (b.rough_t[(int)(wi.z * 63.0) + 1] -
		    b.rough_t[(int)(wi.z * 63.0)]);
		double w = b.specular_sampling_weight;
		double ps = (1 - ti) * w / ((1 - ti) * w + ti * (1 - w));

		assert_true(close_to(w, 0.8 / 1.2, 1e-6, "ssw"));
		assert_true(close_to(pm_bsdf_pdf(&b, wi, wo),
		    ps * pm_bsdf_pdf(&c, wi, wo) + (1 - ps) * wo.z / M_PI,
		    1e-5 * pm_bsdf_pdf(&b, wi, wo), "steering"));
	}
}

static void
test_roughplastic_albedo(void **state)
{
	struct pm_bsdf b;

	(void)state;
	b = mk_roughplastic(0.3f, false, 1.49f, pm_rgb(0.5f, 0.5f, 0.5f),
	    false);
	check_albedo(&b, "roughplastic ggx 0.3", -1.0f);
	b = mk_roughplastic(0.2f, true, 1.7f, pm_rgb(0.9f, 0.3f, 0.1f), true);
	check_albedo(&b, "roughplastic beckmann 0.2 nonlinear", -1.0f);
	b = mk_roughplastic(0.6f, true, 1.49f, pm_rgb1(1.0f), false);
	check_albedo(&b, "roughplastic white beckmann 0.6", -1.0f);
	b = mk_roughplastic(0.3f, false, 1.49f, pm_rgb(0.3f, 0.5f, 0.7f), false);
	check_reciprocity(&b, "roughplastic ggx", false);
	b = mk_roughplastic(0.3f, true, 1.6f, pm_rgb(0.3f, 0.5f, 0.7f), true);
	check_reciprocity(&b, "roughplastic beckmann nonlinear", false);
	b.twosided = true;
	check_reciprocity(&b, "roughplastic twosided", true);
}

static void
test_sampling_roughplastic(void **state)
{
	struct pm_bsdf b;

	(void)state;
	b = mk_roughplastic(0.3f, false, 1.49f, pm_rgb(0.5f, 0.3f, 0.2f), false);
	check_sampling(&b, dir(1.0, 0.3), 91, "roughplastic ggx 0.3");
	b = mk_roughplastic(0.2f, true, 1.49f, pm_rgb(0.2f, 0.3f, 0.2f), false);
	check_sampling(&b, dir(0.5, 0.3), 92, "roughplastic beckmann 0.2");
	b.sample_visible = false;
	check_sampling(&b, dir(1.3, 2.3), 93, "roughplastic beckmann 0.2 b");
	b = mk_roughplastic(0.4f, false, 1.49f, pm_rgb(0.2f, 0.3f, 0.2f), false);
	b.sample_visible = false;
	check_sampling(&b, dir(1.3, 2.3), 94, "roughplastic ggx 0.4 all");
}

/*
 * Twosided: from below, a material is its mirror image through the
 * surface; without the adapter it is black from below.
 */
static void
test_twosided(void **state)
{
	struct pm_bsdf bs[4];
	struct pm_bsdf_sample s1, s2;
	struct pm_vec3 wi = dir(0.7, 0.4), wo = dir(0.8, 3.5), mi, mo;
	struct pm_rgb f1, f2;
	size_t i;

	(void)state;
	bs[0] = mk_diffuse(0.7f, true);
	bs[1] = mk_rough(0.4f, true, "Au");
	bs[2] = mk_plastic(1.5f, pm_rgb(0.2f, 0.3f, 0.4f), false);
	bs[3] = mk(PM_BSDF_CONDUCTOR);
	mi = pm_v3(wi.x, wi.y, -wi.z);
	mo = pm_v3(wo.x, wo.y, -wo.z);
	for (i = 0; i < 4; i++) {
		struct pm_bsdf *b = &bs[i];

		b->twosided = true;
		f1 = pm_bsdf_eval(b, wi, wo, PM_RADIANCE);
		f2 = pm_bsdf_eval(b, mi, mo, PM_RADIANCE);
		assert_true(f1.r == f2.r && f1.g == f2.g && f1.b == f2.b);
		assert_true(pm_bsdf_pdf(b, wi, wo) == pm_bsdf_pdf(b, mi, mo));
		if (b->type != PM_BSDF_CONDUCTOR)
			assert_true(f1.r > 0.0f && pm_bsdf_pdf(b, mi, mo) > 0);
		/* the other side stays dark */
		assert_true(pm_rgb_is_black(pm_bsdf_eval(b, mi, wo,
		    PM_RADIANCE)));
		assert_true(pm_bsdf_sample(b, wi, 0.9f, 0.3f, 0.6f,
		    PM_RADIANCE, &s1));
		assert_true(pm_bsdf_sample(b, mi, 0.9f, 0.3f, 0.6f,
		    PM_RADIANCE, &s2));
		assert_true(s2.wo.x == s1.wo.x && s2.wo.y == s1.wo.y &&
		    s2.wo.z == -s1.wo.z);
		assert_true(s1.weight.g == s2.weight.g && s1.pdf == s2.pdf);
		assert_true(s1.lobe == s2.lobe);
		/* without the adapter: black and unsampled from below */
		b->twosided = false;
		assert_true(pm_rgb_is_black(pm_bsdf_eval(b, mi, mo,
		    PM_RADIANCE)));
		assert_true(pm_bsdf_pdf(b, mi, mo) == 0.0f);
		assert_false(pm_bsdf_sample(b, mi, 0.9f, 0.3f, 0.6f,
		    PM_RADIANCE, &s2));
	}
}

/*
 * pm_bsdf_lambertian, which the photon estimate trusts in place of
 * pm_bsdf_eval: for plain diffuse, one- and two-sided, seen from either
 * side, eval / |wo.z| is rho / pi exactly where wo.z * side > 0 and black
 * elsewhere; every other kind of material says no.
 */
static void
test_lambertian(void **state)
{
	struct pm_rng rng = pm_rng_seed(47, 0, 0);
	struct pm_bsdf b;
	struct pm_rgb rho, f;
	float side;
	int i, twosided, below;

	(void)state;
	for (twosided = 0; twosided < 2; twosided++) {
		b = mk_diffuse(0.7f, twosided);
		for (below = 0; below < 2; below++) {
			struct pm_vec3 wi = dir(0.6, 1.1);

			if (below)
				wi.z = -wi.z;
			assert_true(pm_bsdf_lambertian(&b, wi, &rho, &side));
			assert_true(side == (twosided && below ? -1.0f : 1.0f));
			for (i = 0; i < 200; i++) {
				float u = pm_rng_float(&rng), v = pm_rng_float(&rng);
				struct pm_vec3 wo = dir(acos(2.0 * u - 1.0),
				    6.283185307 * v);

				f = pm_bsdf_eval(&b, wi, wo, PM_RADIANCE);
				if (!(wo.z * side > 0.0f)) {
					assert_true(pm_rgb_is_black(f));
					continue;
				}
				assert_float_equal(f.r / fabsf(wo.z),
				    rho.r * PM_INV_PI, 1e-6);
				assert_float_equal(f.g / fabsf(wo.z),
				    rho.g * PM_INV_PI, 1e-6);
				assert_float_equal(f.b / fabsf(wo.z),
				    rho.b * PM_INV_PI, 1e-6);
			}
			/* from below a one-sided surface: black throughout */
			assert_true(pm_rgb_is_black(rho) == (!twosided && below));
		}
	}
	b = mk_rough(0.4f, true, "Au");
	assert_false(pm_bsdf_lambertian(&b, dir(0.6, 1.1), &rho, &side));
	b = mk_plastic(1.5f, pm_rgb(0.2f, 0.3f, 0.4f), false);
	assert_false(pm_bsdf_lambertian(&b, dir(0.6, 1.1), &rho, &side));
	b = mk(PM_BSDF_DIELECTRIC);
	assert_false(pm_bsdf_lambertian(&b, dir(0.6, 1.1), &rho, &side));
	/* a diffuse copy whose `only` leaves nothing */
	b = mk_diffuse(0.7f, false);
	b.only = PM_LOBE_GLOSSY;
	assert_false(pm_bsdf_lambertian(&b, dir(0.6, 1.1), &rho, &side));
}

/* ---- delta materials ---- */

static void
test_delta_directions(void **state)
{
	struct pm_rng rng = pm_rng_seed(31, 0, 0);
	struct pm_bsdf_sample s;
	struct pm_bsdf b;
	struct pm_rgb f;
	struct pm_vec3 wi;
	float r, cos_t, eta_it;
	int i, refl, n = 100000;

	(void)state;
	/* conductor: mirror direction, weight specular * F */
	b = mk(PM_BSDF_CONDUCTOR);
	assert_true(pm_conductor_lookup("Cu", &b.eta, &b.k));
	b.specular = pm_rgb(0.9f, 0.8f, 0.7f);
	wi = dir(0.8, 1.1);
	assert_true(pm_bsdf_sample(&b, wi, 0.3f, 0.2f, 0.1f, PM_RADIANCE,
	    &s));
	assert_true(s.lobe == PM_LOBE_DELTA_REFLECTION && s.eta == 1.0f);
	assert_true(s.wo.x == -wi.x && s.wo.y == -wi.y && s.wo.z == wi.z);
	f = pm_fresnel_conductor(wi.z, b.eta, b.k);
	assert_true(close_to(s.weight.r, 0.9 * f.r, 1e-6, "conductor"));
	assert_true(close_to(s.weight.b, 0.7 * f.b, 1e-6, "conductor"));
	assert_true(pm_rgb_is_black(pm_bsdf_eval(&b, wi, s.wo, PM_RADIANCE)));
	assert_true(pm_bsdf_pdf(&b, wi, s.wo) == 0.0f);
	/* one-sided unless wrapped in twosided */
	assert_false(pm_bsdf_sample(&b, pm_neg(wi), 0.3f, 0.2f, 0.1f,
	    PM_RADIANCE, &s));
	b.twosided = true;
	assert_true(pm_bsdf_sample(&b, pm_v3(wi.x, wi.y, -wi.z), 0.3f, 0.2f,
	    0.1f, PM_RADIANCE, &s));
	assert_true(s.wo.z < 0.0f && close_to(s.wo.z, -wi.z, 1e-7, "flip"));
	assert_true(close_to(s.weight.r, 0.9 * f.r, 1e-6, "flip weight"));

	/* null: straight through, untouched */
	b = mk(PM_BSDF_NULL);
	assert_true(pm_bsdf_sample(&b, wi, 0.9f, 0.2f, 0.1f, PM_RADIANCE,
	    &s));
	assert_true(s.wo.x == -wi.x && s.wo.y == -wi.y && s.wo.z == -wi.z);
	assert_true(s.weight.r == 1.0f && s.weight.g == 1.0f &&
	    s.weight.b == 1.0f);
	assert_true(s.lobe == PM_LOBE_DELTA_TRANSMISSION && s.pdf == 1.0f);
	assert_true(pm_rgb_is_black(pm_bsdf_eval(&b, wi, s.wo, PM_RADIANCE)));
	assert_true(pm_bsdf_pdf(&b, wi, s.wo) == 0.0f);

	/* dielectric: Snell's law, relative IOR, and the 1/eta^2 of radiance */
	b = mk_dielectric(PM_BSDF_DIELECTRIC, 1.5f);
	b.specular = pm_rgb1(0.9f);
	b.transmittance = pm_rgb(0.5f, 0.6f, 0.7f);
	for (i = 0; i < 2; i++) {
		wi = dir(i == 0 ? 0.6 : M_PI - 0.4, 0.7);
		r = pm_fresnel_dielectric(wi.z, 1.5f, &cos_t);
		eta_it = wi.z > 0.0f ? 1.5f : 1.0f / 1.5f;
		/* u1 below R reflects, above refracts */
		assert_true(pm_bsdf_sample(&b, wi, r * 0.5f, 0.5f, 0.5f,
		    PM_RADIANCE, &s));
		assert_true(s.lobe == PM_LOBE_DELTA_REFLECTION);
		assert_true(s.wo.x == -wi.x && s.wo.y == -wi.y &&
		    s.wo.z == wi.z);
		assert_true(s.eta == 1.0f && s.weight.r == 0.9f);
		assert_true(pm_bsdf_sample(&b, wi, 0.5f * (1.0f + r), 0.5f,
		    0.5f, PM_RADIANCE, &s));
		assert_true(s.lobe == PM_LOBE_DELTA_TRANSMISSION);
		assert_true(s.wo.z * wi.z < 0.0f);
		assert_true(close_to(pm_length(s.wo), 1.0, 1e-6, "refracted"));
		/* sin_t = sin_i / eta_it, in the plane of incidence */
		assert_true(close_to(s.wo.x, -wi.x / eta_it, 1e-6, "Snell x"));
		assert_true(close_to(s.wo.y, -wi.y / eta_it, 1e-6, "Snell y"));
		assert_true(close_to(s.eta, eta_it, 1e-6, "eta"));
		assert_true(close_to(s.weight.g, 0.6 / (eta_it * eta_it),
		    1e-6, "radiance weight"));
		assert_true(pm_bsdf_sample(&b, wi, 0.5f * (1.0f + r), 0.5f,
		    0.5f, PM_IMPORTANCE, &s));
		assert_true(close_to(s.weight.g, 0.6, 1e-6,
		    "importance weight"));
		assert_true(pm_rgb_is_black(pm_bsdf_eval(&b, wi, s.wo,
		    PM_RADIANCE)));
		assert_true(pm_bsdf_pdf(&b, wi, s.wo) == 0.0f);
	}
	/* beyond the critical angle inside, everything reflects */
	wi = dir(M_PI - 1.0, 0.0);
	assert_true(pm_bsdf_sample(&b, wi, 0x1.fffffep-1f, 0.5f, 0.5f,
	    PM_RADIANCE, &s));
	assert_true(s.lobe == PM_LOBE_DELTA_REFLECTION);

	/* thin sheet: R' = R + T^2 R / (1 - R^2), transmission undeviated */
	b = mk_dielectric(PM_BSDF_THINDIELECTRIC, 1.5f);
	for (i = 0; i < 2; i++) {
		double rr;

		wi = dir(i == 0 ? 1.2 : M_PI - 1.2, 0.3);
		r = pm_fresnel_dielectric(fabsf(wi.z), 1.5f, NULL);
		rr = r + (1.0 - r) * (1.0 - r) * r / (1.0 - r * r);
		refl = 0;
		for (int k = 0; k < n; k++) {
			assert_true(pm_bsdf_sample(&b, wi, pm_rng_float(&rng),
			    0.5f, 0.5f, PM_RADIANCE, &s));
			assert_true(s.eta == 1.0f && s.weight.g == 1.0f);
			if (s.lobe == PM_LOBE_DELTA_REFLECTION) {
				refl++;
				assert_true(s.wo.z == wi.z &&
				    s.wo.x == -wi.x);
			} else {
				assert_true(s.lobe ==
				    PM_LOBE_DELTA_TRANSMISSION);
				assert_true(s.wo.x == -wi.x &&
				    s.wo.y == -wi.y && s.wo.z == -wi.z);
			}
		}
		assert_true(close_to(refl, n * rr,
		    NSIGMA * sqrt(n * rr * (1.0 - rr)) + 1.0, "thin R'"));
	}
}

int
main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_fresnel_dielectric),
		cmocka_unit_test(test_fresnel_conductor),
		cmocka_unit_test(test_ior_lookup),
		cmocka_unit_test(test_plastic_tables),
		cmocka_unit_test(test_lobes),
		cmocka_unit_test(test_rough_analytic),
		cmocka_unit_test(test_rough_beckmann_analytic),
		cmocka_unit_test(test_albedo),
		cmocka_unit_test(test_coating_only_plastic),
		cmocka_unit_test(test_furnace),
		cmocka_unit_test(test_reciprocity),
		cmocka_unit_test(test_sampling_diffuse),
		cmocka_unit_test(test_sampling_rough),
		cmocka_unit_test(test_sampling_plastic),
		cmocka_unit_test(test_roughglass_analytic),
		cmocka_unit_test(test_roughglass_energy),
		cmocka_unit_test(test_roughglass_reciprocity),
		cmocka_unit_test(test_sampling_roughglass),
		cmocka_unit_test(test_roughplastic_tables),
		cmocka_unit_test(test_roughplastic_eval),
		cmocka_unit_test(test_roughplastic_albedo),
		cmocka_unit_test(test_sampling_roughplastic),
		cmocka_unit_test(test_twosided),
		cmocka_unit_test(test_lambertian),
		cmocka_unit_test(test_delta_directions),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
