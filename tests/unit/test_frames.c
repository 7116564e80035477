/*
 * test_frames.c: shading frames that follow the surface's
 * parameterisation, and what needs them.
 *
 *   - anisotropic roughness (roughconductor, roughdielectric; GGX and
 *     Beckmann): alpha_u = alpha_v is the isotropic lobe; swapping them
 *     turns the lobe a quarter turn about the normal; chi-square tests
 *     that sampled directions follow pdf(); reciprocity; white furnaces
 *     (a perfect mirror's and a clear rough glass's albedo by two
 *     independent estimators, at most one, and close to one where the
 *     surface is nearly smooth);
 *   - normal and bump maps as the BSDF sees them: an untilted frame
 *     changes nothing, the tilted lobe's sampler agrees with its pdf and
 *     eval, importance is radiance's adjoint;
 *   - dp/du on every built-in shape against Mitsuba 3's parameterisation
 *     (analytic: the sphere's u = phi / 2 pi, v = theta / pi, the
 *     rectangle's and cube's uv layouts, the disk's radial u, the
 *     cylinder's azimuthal u), the barycentric tangents of a mesh
 *     without uv, and the Gram-Schmidt frame.
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

#include "../../common/accel.h"
#include "../../common/bsdf.h"
#include "../../common/frame.h"
#include "../../common/rng.h"
#include "../../common/sampling.h"
#include "../../common/texture.h"
#include "../../formats/scene_xml.h"
#include "bsdf_check.h"

#define NCHI2 10
#define SIGNIFICANCE (1e-3 / NCHI2)
#define NZ 50
#define NPHI 50
#define NSIGMA 6.0

/* A rough conductor, a perfect mirror (eta 0, k 1) unless a metal is
 * named, alpha_u ax and alpha_v ay. */
static struct pm_bsdf
mk_rc(float ax, float ay, bool beckmann, bool visible, const char *metal)
{
	struct pm_bsdf b;

	memset(&b, 0, sizeof(b));
	b.type = PM_BSDF_ROUGHCONDUCTOR;
	b.specular = pm_rgb1(1.0f);
	assert_true(pm_conductor_lookup(metal, &b.eta, &b.k));
	b.alpha = ax;
	b.alpha_v = ay;
	b.aniso = true;
	b.beckmann = beckmann;
	b.sample_visible = visible;
	pm_bsdf_prepare(&b);
	return b;
}

static struct pm_bsdf
mk_rd(float ax, float ay, bool beckmann, bool visible, float ior)
{
	struct pm_bsdf b;

	memset(&b, 0, sizeof(b));
	b.type = PM_BSDF_ROUGHDIELECTRIC;
	b.specular = pm_rgb1(1.0f);
	b.transmittance = pm_rgb1(1.0f);
	b.ior = ior;
	b.alpha = ax;
	b.alpha_v = ay;
	b.aniso = true;
	b.beckmann = beckmann;
	b.sample_visible = visible;
	pm_bsdf_prepare(&b);
	return b;
}

static struct pm_vec3
quarter_turn(struct pm_vec3 v)
{
	return pm_v3(-v.y, v.x, v.z);
}

/* ---- anisotropic roughness ---- */

/* alpha_u = alpha_v is the isotropic lobe, and (ax, ay) turned a quarter
 * about the normal is (ay, ax): alpha_u runs along s, alpha_v along t. */
static void
test_aniso_symmetry(void **state)
{
	struct pm_rng rng = pm_rng_seed(5, 0, 0);
	struct pm_bsdf a, iso, b, c;
	struct pm_bsdf_sample sa, si;
	struct pm_vec3 wi, wo;
	struct pm_rgb fa, fi, fb, fc;
	int k, i, nonzero = 0;

	(void)state;
	for (k = 0; k < 4; k++) {
		bool beck = k & 1, glass = k & 2;

		a = glass ? mk_rd(0.3f, 0.3f, beck, true, 1.5f) :
		    mk_rc(0.3f, 0.3f, beck, true, "Cu");
		iso = a;
		iso.aniso = false;
		iso.alpha_v = 0.0f;
		b = glass ? mk_rd(0.08f, 0.5f, beck, true, 1.5f) :
		    mk_rc(0.08f, 0.5f, beck, true, "Cu");
		c = glass ? mk_rd(0.5f, 0.08f, beck, true, 1.5f) :
		    mk_rc(0.5f, 0.08f, beck, true, "Cu");
		for (i = 0; i < 5000; i++) {
			float u1 = pm_rng_float(&rng), u2 = pm_rng_float(&rng);
			float u3 = pm_rng_float(&rng);

			wi = pm_square_to_uniform_sphere(pm_rng_float(&rng),
			    pm_rng_float(&rng));
			wo = pm_square_to_uniform_sphere(pm_rng_float(&rng),
			    pm_rng_float(&rng));
			if (fabsf(wi.z) < 1e-2f || fabsf(wo.z) < 1e-2f)
				continue;
			fa = pm_bsdf_eval(&a, wi, wo, PM_RADIANCE);
			fi = pm_bsdf_eval(&iso, wi, wo, PM_RADIANCE);
			assert_true(close_to(fa.g, fi.g, 1e-5 * fi.g + 1e-9,
			    "alpha_u = alpha_v"));
			assert_true(close_to(pm_bsdf_pdf(&a, wi, wo),
			    pm_bsdf_pdf(&iso, wi, wo),
			    1e-5 * pm_bsdf_pdf(&iso, wi, wo) + 1e-9,
			    "alpha_u = alpha_v pdf"));
			if (pm_bsdf_sample(&a, wi, u1, u2, u3, PM_RADIANCE,
			    &sa)) {
				assert_true(pm_bsdf_sample(&iso, wi, u1, u2, u3,
				    PM_RADIANCE, &si));
				assert_true(close_to(sa.wo.x, si.wo.x, 1e-5,
				    "same sample"));
				assert_true(close_to(sa.weight.g, si.weight.g,
				    1e-5 * si.weight.g, "same weight"));
			}
			fb = pm_bsdf_eval(&b, wi, wo, PM_RADIANCE);
			fc = pm_bsdf_eval(&c, quarter_turn(wi),
			    quarter_turn(wo), PM_RADIANCE);
			nonzero += fb.g > 0.0f;
			assert_true(close_to(fb.g, fc.g, 1e-4 * fb.g + 1e-7,
			    "quarter turn"));
			assert_true(close_to(pm_bsdf_pdf(&b, wi, wo),
			    pm_bsdf_pdf(&c, quarter_turn(wi), quarter_turn(wo)),
			    1e-4 * pm_bsdf_pdf(&b, wi, wo) + 1e-7,
			    "quarter turn pdf"));
		}
	}
	assert_true(nonzero > 2000);
	/* and the lobe is not round: a reflection tilted along s (rough
	 * 0.5 there under c) is brighter than the same tilt along t */
	c = mk_rc(0.5f, 0.08f, false, true, "none");
	wi = dir(0.4, 0.0);
	fb = pm_bsdf_eval(&c, wi, dir(0.9, M_PI), PM_RADIANCE);
	fc = pm_bsdf_eval(&c, quarter_turn(wi), quarter_turn(dir(0.9, M_PI)),
	    PM_RADIANCE);
	assert_true(fb.g > 2.0f * fc.g);
}

/* Every 97th sample that is not delta (and not too unlikely): its pdf
 * and weight against pdf() and eval(). */
static void
check_sample(const struct pm_bsdf *b, struct pm_vec3 wi, int i,
    const struct pm_bsdf_sample *s, const char *what)
{
	float pdf;
	struct pm_rgb f;

	if ((s->lobe & PM_LOBE_DELTA) || i % 97 != 0 || !(s->pdf > 1e-2f))
		return;
	pdf = pm_bsdf_pdf(b, wi, s->wo);
	f = pm_bsdf_eval(b, wi, s->wo, PM_RADIANCE);
	if (!close_to(s->pdf, pdf, 2e-3 * pdf, "sample pdf") ||
	    !close_to(s->weight.g, f.g / s->pdf, 2e-3 * s->weight.g + 1e-6,
	    "sample weight"))
		fail_msg("%s", what);
}

/* Histogram of sampled directions against pdf(), failed or delta samples
 * one more bin (bsdf_chi2); also each sample's pdf and weight against
 * pdf() and eval() (check_sample). */
static void
check_sampling(const struct pm_bsdf *b, struct pm_vec3 wi, uint64_t seed,
    const char *what)
{
	const double n = BSDF_CHI2_N;
	double total, p;

	p = bsdf_chi2(b, wi, seed, NZ, NPHI, SIGNIFICANCE, what, check_sample,
	    &total);
	assert_true(total <= n * 1.001);
	assert_true(total > 0.5 * n);
	assert_true(p > SIGNIFICANCE);
}

static void
test_aniso_sampling(void **state)
{
	struct pm_bsdf b;

	(void)state;
	b = mk_rc(0.08f, 0.5f, false, true, "Au");
	check_sampling(&b, dir(0.9, 0.4), 31, "ggx 0.08 x 0.5 visible");
	b = mk_rc(0.6f, 0.15f, false, false, "Cu");
	check_sampling(&b, dir(0.7, 2.2), 32, "ggx 0.6 x 0.15 all normals");
	b = mk_rc(0.1f, 0.4f, true, true, "Al");
	check_sampling(&b, dir(1.1, -0.8), 33, "beckmann 0.1 x 0.4");
	b = mk_rd(0.1f, 0.45f, false, true, 1.5f);
	check_sampling(&b, dir(0.6, 0.9), 34, "roughglass ggx 0.1 x 0.45");
	check_sampling(&b, dir(M_PI - 0.5, 2.0), 35,
	    "roughglass ggx 0.1 x 0.45 inside");
	b = mk_rd(0.5f, 0.12f, false, false, 1.33f);
	check_sampling(&b, dir(1.0, 0.3), 36, "roughglass ggx all normals");
	b = mk_rd(0.4f, 0.1f, true, true, 1.5f);
	check_sampling(&b, dir(0.8, -1.2), 37, "roughglass beckmann");
}

/* Reflection is symmetric in its arguments; refraction gains eta^2 in
 * radiance, and importance is radiance with the arguments swapped. */
static void
test_aniso_reciprocity(void **state)
{
	struct pm_rng rng = pm_rng_seed(41, 0, 0);
	struct pm_bsdf bs[4];
	struct pm_vec3 wi, wo;
	struct pm_rgb a, b2, c;
	float eta;
	size_t j;
	int i, nz = 0;

	(void)state;
	bs[0] = mk_rc(0.1f, 0.5f, false, true, "Cu");
	bs[1] = mk_rc(0.5f, 0.2f, true, false, "Au");
	bs[2] = mk_rd(0.15f, 0.6f, false, true, 1.5f);
	bs[3] = mk_rd(0.6f, 0.2f, true, true, 1.33f);
	for (j = 0; j < 4; j++)
		for (i = 0; i < 20000; i++) {
			wi = pm_square_to_uniform_sphere(pm_rng_float(&rng),
			    pm_rng_float(&rng));
			wo = pm_square_to_uniform_sphere(pm_rng_float(&rng),
			    pm_rng_float(&rng));
			if (fabsf(wi.z) < 1e-2f || fabsf(wo.z) < 1e-2f)
				continue;
			if (j < 2) {
				wi.z = fabsf(wi.z);
				wo.z = fabsf(wo.z);
			} else if (facet_cos(wi, wo, bs[j].ior) < 0.02)
				continue;
			a = pm_rgb_scale(pm_bsdf_eval(&bs[j], wi, wo,
			    PM_RADIANCE), 1.0f / fabsf(wo.z));
			b2 = pm_rgb_scale(pm_bsdf_eval(&bs[j], wo, wi,
			    PM_RADIANCE), 1.0f / fabsf(wi.z));
			c = pm_rgb_scale(pm_bsdf_eval(&bs[j], wi, wo,
			    PM_IMPORTANCE), 1.0f / fabsf(wo.z));
			eta = wi.z * wo.z > 0.0f ? 1.0f :
			    wi.z > 0.0f ? bs[j].ior : 1.0f / bs[j].ior;
			nz += a.g > 0.0f;
			if (!close_to(a.g * eta * eta, b2.g, 2e-3 * b2.g + 1e-6,
			    "reciprocity") || !close_to(c.g, b2.g,
			    2e-3 * b2.g + 1e-6, "adjoint"))
				fail_msg("bsdf %zu", j);
		}
	assert_true(nz > 25000);
}

/*
 * White furnaces: a perfect mirror's (F = 1) and a clear rough glass's
 * albedo, as the mean sample weight and as the integral of eval over the
 * sphere (directions from the other normal-sampling technique mixed with
 * the uniform sphere), agree within six standard errors, are at most
 * one, and are within 1% of one where the lobe is narrow and wi steep
 * (masking costs little there).
 */
static void
check_furnace(const struct pm_bsdf *b, struct pm_vec3 wi, double want_min,
    uint64_t seed, const char *what)
{
	struct pm_rng rng = pm_rng_seed(seed, 1, 2);
	struct pm_bsdf other = *b;
	struct pm_bsdf_sample s;
	struct est w, e;
	const float frac = 0.25f;
	int i, n = 200000;

	memset(&w, 0, sizeof(w));
	memset(&e, 0, sizeof(e));
	other.sample_visible = !b->sample_visible;
	for (i = 0; i < n; i++) {
		float u1 = pm_rng_float(&rng), u2 = pm_rng_float(&rng);
		float u3 = pm_rng_float(&rng), pdf;
		struct pm_vec3 wo;

		est_add(&w, pm_bsdf_sample(b, wi, u1, u2, u3, PM_IMPORTANCE,
		    &s) ? s.weight.g : 0.0);
		u1 = pm_rng_float(&rng);
		u2 = pm_rng_float(&rng);
		u3 = pm_rng_float(&rng);
		if (u1 < frac)
			wo = pm_square_to_uniform_sphere(u2, u3);
		else if (pm_bsdf_sample(&other, wi, pm_rng_float(&rng), u2, u3,
		    PM_IMPORTANCE, &s))
			wo = s.wo;
		else {
			est_add(&e, 0.0);
			continue;
		}
		pdf = frac / (4.0f * PM_PI) + (1.0f - frac) *
		    pm_bsdf_pdf(&other, wi, wo);
		est_add(&e, pm_bsdf_eval(b, wi, wo, PM_IMPORTANCE).g / pdf);
	}
	print_message("%s: albedo %.5f +- %.5f, integral %.5f +- %.5f\n",
	    what, w.mean, est_err(&w), e.mean, est_err(&e));
	if (!close_to(w.mean, e.mean, NSIGMA * hypot(est_err(&w),
	    est_err(&e)) + 1e-4, what))
		fail_msg("%s: the two estimates disagree", what);
	if (w.mean > 1.0 + NSIGMA * est_err(&w))
		fail_msg("%s: albedo %g > 1", what, w.mean);
	if (w.mean < want_min)
		fail_msg("%s: albedo %g < %g", what, w.mean, want_min);
}

static void
test_aniso_furnace(void **state)
{
	struct pm_bsdf b;

	(void)state;
	b = mk_rc(0.01f, 0.03f, false, true, "none");
	check_furnace(&b, dir(0.3, 0.7), 0.99, 51, "mirror ggx 0.01 x 0.03");
	b = mk_rc(0.05f, 0.6f, false, true, "none");
	check_furnace(&b, dir(1.0, 0.2), 0.5, 52, "mirror ggx 0.05 x 0.6");
	b = mk_rc(0.4f, 0.1f, true, true, "none");
	check_furnace(&b, dir(0.8, 2.0), 0.5, 53, "mirror beckmann 0.4 x 0.1");
	b = mk_rd(0.01f, 0.02f, false, true, 1.5f);
	check_furnace(&b, dir(0.4, 0.3), 0.99, 54, "glass ggx 0.01 x 0.02");
	check_furnace(&b, dir(M_PI - 0.4, 0.3), 0.99, 55,
	    "glass ggx 0.01 x 0.02 inside");
	b = mk_rd(0.1f, 0.5f, false, true, 1.5f);
	check_furnace(&b, dir(0.9, 1.3), 0.5, 56, "glass ggx 0.1 x 0.5");
	b = mk_rd(0.5f, 0.15f, true, true, 1.33f);
	check_furnace(&b, dir(M_PI - 0.7, -0.5), 0.5, 57,
	    "glass beckmann 0.5 x 0.15 inside");
}

/* ---- normal and bump maps, as the BSDF sees them ---- */

/* A perturbed frame whose normal is n (unit), built as pm_bsdf_frame_at
 * builds it. */
static void
perturb(struct pm_bsdf *b, struct pm_vec3 n)
{
	struct pm_vec3 s = pm_normalize(pm_v3(1.0f - n.x * n.x, -n.x * n.y,
	    -n.x * n.z));

	b->perturbed = true;
	b->pframe.n = n;
	b->pframe.s = s;
	b->pframe.t = pm_cross(n, s);
}

static void
test_perturbed(void **state)
{
	struct pm_rng rng = pm_rng_seed(61, 0, 0);
	struct pm_bsdf plain, flat, tilt;
	struct pm_vec3 wi, wo;
	struct pm_rgb a, b2, c;
	int i, k, nz = 0;

	(void)state;
	/* an untilted map changes nothing (the shadowing term is 1) */
	plain = mk_rc(0.1f, 0.4f, false, true, "Au");
	flat = plain;
	perturb(&flat, pm_v3(0.0f, 0.0f, 1.0f));
	for (i = 0; i < 5000; i++) {
		wi = pm_square_to_uniform_hemisphere(pm_rng_float(&rng),
		    pm_rng_float(&rng));
		wo = pm_square_to_uniform_hemisphere(pm_rng_float(&rng),
		    pm_rng_float(&rng));
		a = pm_bsdf_eval(&plain, wi, wo, PM_RADIANCE);
		b2 = pm_bsdf_eval(&flat, wi, wo, PM_RADIANCE);
		assert_true(close_to(a.g, b2.g, 1e-5 * a.g + 1e-9, "flat map"));
	}
	/* a tilted one: sampling against pdf and eval, a diffuse surface
	 * and a rough metal */
	for (k = 0; k < 2; k++) {
		memset(&tilt, 0, sizeof(tilt));
		if (k == 0) {
			tilt.type = PM_BSDF_DIFFUSE;
			tilt.diffuse = pm_rgb1(0.8f);
			pm_bsdf_prepare(&tilt);
		} else
			tilt = mk_rc(0.3f, 0.1f, false, true, "Cu");
		perturb(&tilt, pm_normalize(pm_v3(0.5f, -0.3f, 0.8f)));
		check_sampling(&tilt, dir(0.7, 0.5), 62 + k,
		    k ? "normal-mapped rough metal" : "normal-mapped diffuse");
		/* importance is radiance's adjoint: f*(wi, wo) = f(wo, wi),
		 * each over the unperturbed cosine of its wo */
		for (i = 0; i < 20000; i++) {
			wi = pm_square_to_uniform_hemisphere(pm_rng_float(&rng),
			    pm_rng_float(&rng));
			wo = pm_square_to_uniform_hemisphere(pm_rng_float(&rng),
			    pm_rng_float(&rng));
			if (wi.z < 1e-2f || wo.z < 1e-2f)
				continue;
			b2 = pm_rgb_scale(pm_bsdf_eval(&tilt, wo, wi,
			    PM_RADIANCE), 1.0f / wi.z);
			c = pm_rgb_scale(pm_bsdf_eval(&tilt, wi, wo,
			    PM_IMPORTANCE), 1.0f / wo.z);
			nz += c.g > 0.0f;
			if (!close_to(c.g, b2.g, 1e-4 * b2.g + 1e-7,
			    "perturbed adjoint"))
				fail();
			/* nothing leaves below either frame */
			if (pm_to_local(tilt.pframe, wo).z <= 0.0f)
				assert_true(pm_rgb_is_black(pm_bsdf_eval(&tilt,
				    wi, wo, PM_RADIANCE)));
		}
	}
	assert_true(nz > 10000);
}

/* ---- dp/du on the built-in shapes ---- */

static void
assert_vec_near(struct pm_vec3 a, struct pm_vec3 b, double tol,
    const char *what)
{
	if (!close_to(a.x, b.x, tol, what) || !close_to(a.y, b.y, tol, what) ||
	    !close_to(a.z, b.z, tol, what))
		fail_msg("%s: (%g %g %g) versus (%g %g %g)", what, a.x, a.y, a.z,
		    b.x, b.y, b.z);
}

/* The hit of the ray o + t d on shape `shape` (the only thing there). */
static struct pm_hit
hit(const struct pm_accel *acc, int shape, struct pm_vec3 o, struct pm_vec3 d)
{
	struct pm_hit h;

	assert_true(pm_accel_intersect(acc, o, d, 0.0f, INFINITY, &h));
	assert_int_equal(h.shape, shape);
	return h;
}

static void
test_dpdu_shapes(void **state)
{
	static const char xml[] =
	    "<scene version=\"3.0.0\">\n"
	    /* 0: a sphere of radius 2 at (10, 0, 0) turned 90 degrees about
	     * x: its object z axis is the world's -y */
	    "<shape type=\"sphere\"><float name=\"radius\" value=\"2\"/>"
	    "<transform name=\"to_world\"><rotate x=\"1\" angle=\"90\"/>"
	    "<translate x=\"10\"/></transform></shape>\n"
	    /* 1: a rectangle scaled 3 along x at z = -10 */
	    "<shape type=\"rectangle\"><transform name=\"to_world\">"
	    "<scale x=\"3\"/><translate z=\"-10\"/></transform></shape>\n"
	    /* 2: the unit cube at (0, 20, 0) */
	    "<shape type=\"cube\"><transform name=\"to_world\">"
	    "<translate y=\"20\"/></transform></shape>\n"
	    /* 3: the unit disk at (0, -20, 0), facing +z */
	    "<shape type=\"disk\"><transform name=\"to_world\">"
	    "<translate y=\"-20\"/></transform></shape>\n"
	    /* 4: a cylinder of radius 1 along z from (-20, 0, 0) */
	    "<shape type=\"cylinder\"><point name=\"p0\" x=\"-20\" y=\"0\" "
	    "z=\"0\"/><point name=\"p1\" x=\"-20\" y=\"0\" z=\"1\"/></shape>\n"
	    "</scene>\n";
	/* the cube's faces as Mitsuba 3 parameterises them: outward
	 * normal, dp/du, dp/dv */
	static const float cube[6][3][3] = {
		{ { 1, 0, 0 }, { 0, 2, 0 }, { 0, 0, -2 } },
		{ { -1, 0, 0 }, { 0, 2, 0 }, { 0, 0, 2 } },
		{ { 0, 1, 0 }, { -2, 0, 0 }, { 0, 0, -2 } },
		{ { 0, -1, 0 }, { 0, 0, 2 }, { 2, 0, 0 } },
		{ { 0, 0, 1 }, { 0, 2, 0 }, { 2, 0, 0 } },
		{ { 0, 0, -1 }, { 0, -2, 0 }, { 2, 0, 0 } },
	};
	struct pm_scene s;
	struct pm_error err;
	struct pm_accel *acc;
	struct pm_hit h;
	struct pm_vec3 du, dv, c, n, o;
	struct pm_frame f;
	double phi, th;
	int i, j;

	(void)state;
	memset(&err, 0, sizeof(err));
	if (pm_scene_load_string(xml, strlen(xml), "t.xml", ".", NULL, 0, &s,
	    &err) != PM_OK)
		fail_msg("%s", err.msg);
	assert_int_equal(pm_accel_build(&s, &acc, &err), PM_OK);

	/* sphere: the object point (sin th cos phi, sin th sin phi, cos th)
	 * sits at world (x, -z, y) * 2 + (10, 0, 0); dp/du = 2 pi r
	 * (-sin th sin phi, sin th cos phi, 0), dp/dv = pi r (cos th cos
	 * phi, cos th sin phi, -sin th), both mapped the same way */
	for (i = 0; i < 12; i++) {
		struct pm_vec3 l, wdu, wdv;

		th = 0.2 + 0.22 * i;
		phi = 0.3 + 0.5 * i;
		l = dir(th, phi);
		c = pm_v3(10.0f + 2.0f * l.x, -2.0f * l.z, 2.0f * l.y);
		n = pm_normalize(pm_sub(c, pm_v3(10.0f, 0.0f, 0.0f)));
		h = hit(acc, 0, pm_madd(c, n, 5.0f), pm_neg(n));
		pm_hit_dpdu(&s, &h, &du, &dv);
		wdu = pm_scale(pm_v3((float)(-sin(th) * sin(phi)), 0.0f,
		    (float)(sin(th) * cos(phi))), (float)(4.0 * M_PI));
		wdv = pm_scale(pm_v3((float)(cos(th) * cos(phi)),
		    (float)sin(th), (float)(cos(th) * sin(phi))),
		    (float)(2.0 * M_PI));
		assert_vec_near(du, wdu, 1e-3 * 4.0 * M_PI, "sphere dp/du");
		assert_vec_near(dv, wdv, 1e-3 * 2.0 * M_PI, "sphere dp/dv");
		/* the frame: s along dp/du, made orthogonal to the normal */
		f = pm_frame_gram_schmidt(h.ns, du);
		assert_vec_near(f.s, pm_normalize(wdu), 1e-3, "sphere s");
		assert_vec_near(f.t, pm_cross(h.ns, f.s), 1e-5, "sphere t");
	}

	/* rectangle: u = (x + 1) / 2 before the scale: dp/du = (6, 0, 0) */
	h = hit(acc, 1, pm_v3(0.7f, 0.2f, -5.0f), pm_v3(0.0f, 0.0f, -1.0f));
	pm_hit_dpdu(&s, &h, &du, &dv);
	assert_vec_near(du, pm_v3(6.0f, 0.0f, 0.0f), 1e-4, "rectangle dp/du");
	assert_vec_near(dv, pm_v3(0.0f, 2.0f, 0.0f), 1e-4, "rectangle dp/dv");
	/* without uv, Mitsuba's uv are the barycentrics of vertices 1 and
	 * 2: dp/du = p1 - p0 */
	{
		struct pm_mesh *m = &s.shapes[1].mesh;
		const uint32_t *t = &m->idx[3 * (size_t)h.prim];
		float *uv = m->uv;

		m->uv = NULL;
		pm_hit_dpdu(&s, &h, &du, &dv);
		m->uv = uv;
		assert_vec_near(du, pm_sub(pm_mesh_vertex(m, t[1]),
		    pm_mesh_vertex(m, t[0])), 1e-5, "no uv dp/du");
		assert_vec_near(dv, pm_sub(pm_mesh_vertex(m, t[2]),
		    pm_mesh_vertex(m, t[0])), 1e-5, "no uv dp/dv");
	}

	/* cube: both triangles of every face */
	for (i = 0; i < 6; i++)
		for (j = 0; j < 2; j++) {
			n = pm_v3(cube[i][0][0], cube[i][0][1], cube[i][0][2]);
			/* off the diagonal, on either side of it */
			c = pm_add(pm_v3(0.0f, 20.0f, 0.0f), pm_madd(pm_madd(n,
			    pm_v3(cube[i][1][0], cube[i][1][1], cube[i][1][2]),
			    j ? 0.3f : -0.2f), pm_v3(cube[i][2][0],
			    cube[i][2][1], cube[i][2][2]), j ? -0.15f : 0.35f));
			h = hit(acc, 2, pm_madd(c, n, 3.0f), pm_neg(n));
			assert_vec_near(h.ng, n, 1e-5, "cube face");
			pm_hit_dpdu(&s, &h, &du, &dv);
			assert_vec_near(du, pm_v3(cube[i][1][0], cube[i][1][1],
			    cube[i][1][2]), 1e-4, "cube dp/du");
			assert_vec_near(dv, pm_v3(cube[i][2][0], cube[i][2][1],
			    cube[i][2][2]), 1e-4, "cube dp/dv");
		}

	/* disk: u is the radius, dp/du the unit radial direction (to
	 * within the facets: half a wedge of 256, 0.7 degrees) */
	for (i = 0; i < 10; i++) {
		phi = 0.1 + 0.63 * i;
		c = pm_v3((float)(0.6 * cos(phi)), (float)(-20.0 +
		    0.6 * sin(phi)), 0.0f);
		h = hit(acc, 3, pm_add(c, pm_v3(0, 0, 3)), pm_v3(0, 0, -1));
		pm_hit_dpdu(&s, &h, &du, &dv);
		assert_vec_near(du, pm_v3((float)cos(phi), (float)sin(phi),
		    0.0f), 0.015, "disk dp/du");
		assert_true(pm_dot(pm_normalize(dv), pm_v3((float)-sin(phi),
		    (float)cos(phi), 0.0f)) > 0.999f);
	}

	/* cylinder: u = phi / 2 pi, v = z: dp/du = 2 pi (-y, x, 0) (to
	 * within the facets: a chord of 1024 turns up to half a facet,
	 * pi / 1024, from the tangent), dp/dv = (0, 0, 1), and s exactly
	 * azimuthal (the chord and the exact normal are both across the
	 * axis) */
	for (i = 0; i < 10; i++) {
		phi = 0.2 + 0.6 * i;
		n = pm_v3((float)cos(phi), (float)sin(phi), 0.0f);
		o = pm_add(pm_v3(-20.0f, 0.0f, 0.3f + 0.05f * i),
		    pm_scale(n, 3.0f));
		h = hit(acc, 4, o, pm_neg(n));
		pm_hit_dpdu(&s, &h, &du, &dv);
		assert_vec_near(du, pm_scale(pm_v3(-n.y, n.x, 0.0f),
		    (float)(2.0 * M_PI)), 1.1 * 2.0 * M_PI * M_PI / 1024,
		    "cylinder dp/du");
		assert_vec_near(dv, pm_v3(0.0f, 0.0f, 1.0f), 1e-4,
		    "cylinder dp/dv");
		f = pm_frame_gram_schmidt(h.ns, du);
		assert_vec_near(f.s, pm_v3(-n.y, n.x, 0.0f), 1e-4,
		    "cylinder s");
	}
	pm_accel_free(acc);
	pm_scene_free(&s);
}

int
main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_aniso_symmetry),
		cmocka_unit_test(test_aniso_sampling),
		cmocka_unit_test(test_aniso_reciprocity),
		cmocka_unit_test(test_aniso_furnace),
		cmocka_unit_test(test_perturbed),
		cmocka_unit_test(test_dpdu_shapes),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
