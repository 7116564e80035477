/*
 * test_composite.c: BSDFs made of others (blendbsdf, mask, twosided with
 * a different BSDF on each side), built in a scene as the loader builds
 * them (nested BSDFs by index, linked by pm_scene_prepare).
 *
 *   - white furnaces: blends and masks of BSDFs that conserve energy
 *     exactly conserve it, every sample weighing one;
 *   - albedo: a blend's is the weighted sum of its two BSDFs' (and a
 *     mask's is its BSDF's times the opacity plus the pass), within six
 *     standard errors of the independent estimates;
 *   - consistency: every non-delta sample's pdf and weight are pdf() and
 *     eval()/pdf() (one density for MIS); chi-square tests that sampled
 *     directions follow pdf(), delta or failed samples one more bin;
 *   - the photon render's split (`only`): the diffuse parts and the rest
 *     evaluate and sample to the whole;
 *   - twosided: each side is its own BSDF, the back seen as if from the
 *     front;
 *   - textures on the weight and inside nested BSDFs are looked up at
 *     the hit (the weight as Mitsuba's eval_1 reads it);
 *   - nested BSDFs come before the BSDF that holds them; a blend of
 *     anisotropic BSDFs takes the frame along dp/du, a normal map
 *     inside a blend is refused;
 *   - Mitsuba's named conductors are found by their names, and are
 *     metals.
 *
 * Random numbers use fixed seeds; chi-square tests reject at 1e-3 over
 * their number (Bonferroni).
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
#include "../../common/frame.h"
#include "../../common/rng.h"
#include "../../common/sampling.h"
#include "../../common/scene.h"
#include "../../common/texture.h"
#include "bsdf_check.h"

#define NCHI2 5
#define SIGNIFICANCE (1e-3 / NCHI2)
#define NZ 40
#define NPHI 40
#define NSIGMA 6.0
#define REST (PM_LOBE_GLOSSY | PM_LOBE_DELTA | PM_LOBE_TRANSMISSION)

/* ---- building ---- */

static struct pm_bsdf
leaf(enum pm_bsdf_type type)
{
	struct pm_bsdf b;

	memset(&b, 0, sizeof(b));
	b.type = type;
	b.diffuse = pm_rgb1(0.5f);
	b.specular = pm_rgb1(1.0f);
	b.transmittance = pm_rgb1(1.0f);
	b.eta = pm_rgb1(0.0f);
	b.k = pm_rgb1(1.0f);
	b.ior = 1.49f / 1.000277f;
	b.alpha = 0.1f;
	b.sample_visible = true;
	return b;
}

static struct pm_bsdf
diffuse(struct pm_rgb r)
{
	struct pm_bsdf b = leaf(PM_BSDF_DIFFUSE);

	b.diffuse = r;
	return b;
}

static struct pm_bsdf
rough(const char *metal, float alpha)
{
	struct pm_bsdf b = leaf(PM_BSDF_ROUGHCONDUCTOR);

	assert_true(pm_conductor_lookup(metal, &b.eta, &b.k));
	b.alpha = alpha;
	return b;
}

static struct pm_bsdf
mirror(void)
{
	struct pm_bsdf b = leaf(PM_BSDF_CONDUCTOR);

	assert_true(pm_conductor_lookup("none", &b.eta, &b.k));
	return b;
}

static struct pm_bsdf
plastic(struct pm_rgb d)
{
	struct pm_bsdf b = leaf(PM_BSDF_PLASTIC);

	b.diffuse = d;
	return b;
}

static int
add(struct pm_scene *s, struct pm_bsdf b)
{
	int i = pm_scene_add_bsdf(s);

	assert_true(i >= 0);
	s->bsdfs[i] = b;
	return i;
}

/* A composite of type t over scene BSDFs i0 (and i1), weight w. */
static int
add_mix(struct pm_scene *s, enum pm_bsdf_type t, int i0, int i1, float w)
{
	struct pm_bsdf b;

	memset(&b, 0, sizeof(b));
	b.type = t;
	b.nested[0] = i0;
	b.nested[1] = i1;
	b.weight = w;
	return add(s, b);
}

static void
prepare(struct pm_scene *s)
{
	struct pm_error err;

	memset(&err, 0, sizeof(err));
	if (pm_scene_prepare(s, &err) != PM_OK)
		fail_msg("pm_scene_prepare: %s", err.msg);
}

/* ---- estimates ---- */

/*
 * The albedo towards wi by sampling (mean weight, channel c), checking
 * on the way that every non-delta sample's pdf and weight are what pdf()
 * and eval() say.  Also the largest sample weight seen.
 */
static void
albedo(const struct pm_bsdf *b, struct pm_vec3 wi, int c, int n,
    uint64_t seed, struct est *e, double *wmax)
{
	struct pm_rng rng = pm_rng_seed(seed, 3, 4);
	struct pm_bsdf_sample s;
	int i;

	memset(e, 0, sizeof(*e));
	*wmax = 0.0;
	for (i = 0; i < n; i++) {
		float u1 = pm_rng_float(&rng), u2 = pm_rng_float(&rng);
		float u3 = pm_rng_float(&rng), w, pdf;
		struct pm_rgb f;

		if (!pm_bsdf_sample(b, wi, u1, u2, u3, PM_RADIANCE, &s)) {
			est_add(e, 0.0);
			continue;
		}
		assert_true(pm_rgb_is_finite(s.weight));
		w = c == 0 ? s.weight.r : c == 1 ? s.weight.g : s.weight.b;
		est_add(e, w);
		*wmax = fmax(*wmax, w);
		if (s.lobe & PM_LOBE_DELTA) {
			assert_true(s.pdf == 1.0f);
			continue;
		}
		pdf = pm_bsdf_pdf(b, wi, s.wo);
		if (!close_to(s.pdf, pdf, 2e-3 * pdf + 1e-6, "sample pdf"))
			fail();
		f = pm_bsdf_eval(b, wi, s.wo, PM_RADIANCE);
		if (!close_to(s.weight.r, f.r / s.pdf, 2e-3 * s.weight.r + 1e-6,
		    "sample weight"))
			fail();
	}
}

/* ---- white furnaces ---- */

/* Blends and masks of lossless BSDFs: every sample weighs exactly one. */
static void
test_furnace(void **state)
{
	static const double thetas[] = { 0.0, 0.6, 1.2, 1.5 };
	struct pm_scene s;
	int white, white2, mir, bl[3], mask, mask0;
	size_t i, j;

	(void)state;
	pm_scene_init(&s);
	white = add(&s, diffuse(pm_rgb1(1.0f)));
	white2 = add(&s, diffuse(pm_rgb1(1.0f)));
	mir = add(&s, mirror());
	bl[0] = add_mix(&s, PM_BSDF_BLEND, white, mir, 0.3f);
	bl[1] = add_mix(&s, PM_BSDF_BLEND, white, white2, 0.8f);
	/* a blend of blends */
	bl[2] = add_mix(&s, PM_BSDF_BLEND, bl[0], mir, 0.5f);
	mask = add_mix(&s, PM_BSDF_MASK, bl[2], 0, 0.4f);
	mask0 = add_mix(&s, PM_BSDF_MASK, white, 0, 0.0f);
	prepare(&s);
	for (j = 0; j < 5; j++) {
		const struct pm_bsdf *b = &s.bsdfs[j < 3 ? bl[j] :
		    j == 3 ? mask : mask0];

		for (i = 0; i < sizeof(thetas) / sizeof(thetas[0]); i++) {
			struct pm_vec3 wi = dir(thetas[i], 0.4 + (double)i);
			struct pm_rng rng = pm_rng_seed(40 + j, i, 0);
			int k;

			for (k = 0; k < 20000; k++) {
				struct pm_bsdf_sample bs;

				assert_true(pm_bsdf_sample(b, wi,
				    pm_rng_float(&rng), pm_rng_float(&rng),
				    pm_rng_float(&rng), PM_RADIANCE, &bs));
				if (!close_to(bs.weight.g, 1.0, 1e-5, "furnace"))
					fail_msg("composite %zu at theta %g", j,
					    thetas[i]);
				/* opacity 0: always through, unchanged */
				if (j == 4)
					assert_true(bs.lobe ==
					    PM_LOBE_DELTA_TRANSMISSION &&
					    bs.wo.x == -wi.x && bs.wo.y == -wi.y &&
					    bs.wo.z == -wi.z);
			}
		}
	}
	/* a mask shows nothing of its BSDF at opacity 0, lets light
	 * through otherwise, and is never a pure delta over a diffuse one */
	assert_true(pm_rgb_is_black(pm_bsdf_eval(&s.bsdfs[mask0], dir(0.3, 0),
	    dir(0.5, 2), PM_RADIANCE)));
	assert_true(s.bsdfs[mask].lobes & PM_LOBE_DELTA_TRANSMISSION);
	assert_false(pm_bsdf_is_delta(&s.bsdfs[mask0]));
	pm_scene_free(&s);
}

/* A blend's albedo is the weighted sum of its BSDFs'; a mask's, the
 * opacity times its BSDF's plus the rest. */
static void
test_albedo(void **state)
{
	static const double thetas[] = { 0.2, 0.9, 1.4 };
	static const float weights[] = { 0.25f, 0.7f };
	struct pm_scene s;
	int a, b, c, bl[2], bl2, mask;
	size_t i, j;
	const int n = 200000;

	(void)state;
	pm_scene_init(&s);
	a = add(&s, diffuse(pm_rgb(0.8f, 0.4f, 0.2f)));
	b = add(&s, rough("Au", 0.3f));
	c = add(&s, plastic(pm_rgb(0.1f, 0.5f, 0.3f)));
	for (j = 0; j < 2; j++)
		bl[j] = add_mix(&s, PM_BSDF_BLEND, a, b, weights[j]);
	bl2 = add_mix(&s, PM_BSDF_BLEND, c, b, 0.4f);
	mask = add_mix(&s, PM_BSDF_MASK, c, 0, 0.65f);
	prepare(&s);
	for (i = 0; i < sizeof(thetas) / sizeof(thetas[0]); i++) {
		struct pm_vec3 wi = dir(thetas[i], 1.0);
		struct est ea, eb, ec, em;
		double wmax, want, tol;

		albedo(&s.bsdfs[a], wi, 1, n, 50 + i, &ea, &wmax);
		albedo(&s.bsdfs[b], wi, 1, n, 60 + i, &eb, &wmax);
		albedo(&s.bsdfs[c], wi, 1, n, 70 + i, &ec, &wmax);
		for (j = 0; j < 2; j++) {
			float w = weights[j];

			albedo(&s.bsdfs[bl[j]], wi, 1, n, 80 + i, &em, &wmax);
			want = (1.0 - w) * ea.mean + w * eb.mean;
			tol = NSIGMA * sqrt(est_err(&em) * est_err(&em) +
			    pow((1.0 - w) * est_err(&ea), 2) +
			    pow(w * est_err(&eb), 2));
			if (!close_to(em.mean, want, tol, "blend albedo"))
				fail_msg("weight %g theta %g", w, thetas[i]);
			assert_true(em.mean <= 1.0 + tol);
		}
		albedo(&s.bsdfs[bl2], wi, 1, n, 90 + i, &em, &wmax);
		want = 0.6 * ec.mean + 0.4 * eb.mean;
		tol = NSIGMA * sqrt(pow(est_err(&em), 2) +
		    pow(0.6 * est_err(&ec), 2) + pow(0.4 * est_err(&eb), 2));
		if (!close_to(em.mean, want, tol, "plastic blend albedo"))
			fail_msg("theta %g", thetas[i]);
		/* the mask: its BSDF's share, and all of the pass */
		albedo(&s.bsdfs[mask], wi, 1, n, 100 + i, &em, &wmax);
		want = 0.65 * ec.mean + 0.35;
		tol = NSIGMA * hypot(est_err(&em), 0.65 * est_err(&ec));
		if (!close_to(em.mean, want, tol, "mask albedo"))
			fail_msg("theta %g", thetas[i]);
	}
	pm_scene_free(&s);
}

/* ---- sampling follows pdf() ---- */

/* Histogram of sampled directions on a (z, phi) grid against pdf(),
 * delta and failed samples in one more bin (bsdf_chi2). */
static void
check_sampling(const struct pm_bsdf *b, struct pm_vec3 wi, uint64_t seed,
    const char *what)
{
	const double n = BSDF_CHI2_N;
	double total, p;

	p = bsdf_chi2(b, wi, seed, NZ, NPHI, SIGNIFICANCE, what, NULL,
	    &total);
	assert_true(total <= n * 1.001);
	assert_true(total > 0.2 * n);
	assert_true(p > SIGNIFICANCE);
}

static void
test_sampling(void **state)
{
	struct pm_scene s;
	int a, b, c, d, bl, bl2, mask, two;

	(void)state;
	pm_scene_init(&s);
	a = add(&s, diffuse(pm_rgb(0.8f, 0.4f, 0.2f)));
	b = add(&s, rough("Au", 0.3f));
	c = add(&s, plastic(pm_rgb(0.1f, 0.5f, 0.3f)));
	d = add(&s, rough("Cu", 0.6f));
	bl = add_mix(&s, PM_BSDF_BLEND, a, b, 0.35f);
	bl2 = add_mix(&s, PM_BSDF_BLEND, c, d, 0.5f);
	mask = add_mix(&s, PM_BSDF_MASK, bl, 0, 0.6f);
	two = add_mix(&s, PM_BSDF_TWOSIDED, c, b, 0.0f);
	prepare(&s);
	check_sampling(&s.bsdfs[bl], dir(0.8, 0.3), 31, "blend diffuse+rough");
	check_sampling(&s.bsdfs[bl2], dir(1.1, 2.0), 32,
	    "blend plastic+rough");
	check_sampling(&s.bsdfs[mask], dir(0.5, -1.0), 33, "mask of a blend");
	check_sampling(&s.bsdfs[two], dir(0.7, 0.2), 34, "twosided front");
	check_sampling(&s.bsdfs[two], dir(M_PI - 0.9, 1.2), 35,
	    "twosided back");
	pm_scene_free(&s);
}

/* ---- the photon render's split ---- */

/* The diffuse parts and the rest (b with `only` set) add up to b, in
 * eval and in the mean sample weight. */
static void
check_split(const struct pm_bsdf *b, const char *what)
{
	struct pm_bsdf base = *b, rest = *b;
	struct pm_rng rng = pm_rng_seed(77, 0, 0);
	struct est ef, eb, er;
	double wmax, tol;
	int i;

	base.only = PM_LOBE_DIFFUSE;
	rest.only = REST;
	for (i = 0; i < 20000; i++) {
		struct pm_vec3 wi = pm_square_to_cosine_hemisphere(
		    pm_rng_float(&rng), pm_rng_float(&rng));
		struct pm_vec3 wo = pm_square_to_uniform_hemisphere(
		    pm_rng_float(&rng), pm_rng_float(&rng));
		struct pm_rgb f = pm_bsdf_eval(b, wi, wo, PM_RADIANCE);
		struct pm_rgb g = pm_rgb_add(pm_bsdf_eval(&base, wi, wo,
		    PM_RADIANCE), pm_bsdf_eval(&rest, wi, wo, PM_RADIANCE));

		if (!close_to(f.g, g.g, 1e-5 * f.g + 1e-7, what))
			fail();
	}
	for (i = 0; i < 3; i++) {
		struct pm_vec3 wi = dir(0.3 + 0.5 * i, 0.7);

		albedo(b, wi, 1, 200000, 120 + i, &ef, &wmax);
		albedo(&base, wi, 1, 200000, 130 + i, &eb, &wmax);
		albedo(&rest, wi, 1, 200000, 140 + i, &er, &wmax);
		tol = NSIGMA * sqrt(pow(est_err(&ef), 2) + pow(est_err(&eb), 2) +
		    pow(est_err(&er), 2));
		if (!close_to(eb.mean + er.mean, ef.mean, tol, what))
			fail_msg("%s: split albedo at %d", what, i);
	}
}

static void
test_split(void **state)
{
	struct pm_scene s;
	int a, b, c, d, bl, bl2, mask;
	struct pm_bsdf_sample bs;

	(void)state;
	pm_scene_init(&s);
	a = add(&s, diffuse(pm_rgb(0.8f, 0.4f, 0.2f)));
	b = add(&s, rough("Ag", 0.2f));
	c = add(&s, plastic(pm_rgb(0.1f, 0.5f, 0.3f)));
	d = add(&s, mirror());
	bl = add_mix(&s, PM_BSDF_BLEND, c, b, 0.4f);
	bl2 = add_mix(&s, PM_BSDF_BLEND, a, d, 0.3f);
	mask = add_mix(&s, PM_BSDF_MASK, bl, 0, 0.7f);
	prepare(&s);
	check_split(&s.bsdfs[bl], "blend plastic+rough");
	check_split(&s.bsdfs[bl2], "blend diffuse+mirror");
	check_split(&s.bsdfs[mask], "mask of a blend");
	/* the rest of a mask over a diffuse BSDF is its pass alone, with
	 * the weight of the light that passes */
	{
		struct pm_scene t;
		int x, m;
		struct pm_bsdf rest;

		pm_scene_init(&t);
		x = add(&t, diffuse(pm_rgb1(0.5f)));
		m = add_mix(&t, PM_BSDF_MASK, x, 0, 0.25f);
		prepare(&t);
		rest = t.bsdfs[m];
		rest.only = REST;
		assert_true(pm_bsdf_sample(&rest, dir(0.4, 0.1), 0.9f, 0.5f,
		    0.5f, PM_RADIANCE, &bs));
		assert_true(bs.lobe == PM_LOBE_DELTA_TRANSMISSION);
		assert_true(close_to(bs.weight.r, 0.75, 1e-6, "mask pass"));
		pm_scene_free(&t);
	}
	pm_scene_free(&s);
}

/* ---- twosided with two BSDFs ---- */

static void
test_twosided(void **state)
{
	struct pm_scene s;
	struct pm_rng rng = pm_rng_seed(5, 0, 0);
	int front, back, two;
	int i;

	(void)state;
	pm_scene_init(&s);
	front = add(&s, diffuse(pm_rgb(0.8f, 0.4f, 0.1f)));
	back = add(&s, rough("Au", 0.3f));
	two = add_mix(&s, PM_BSDF_TWOSIDED, front, back, 0.0f);
	prepare(&s);
	assert_true(s.bsdfs[two].lobes ==
	    (PM_LOBE_DIFFUSE | PM_LOBE_GLOSSY));
	for (i = 0; i < 2000; i++) {
		struct pm_vec3 wi = pm_square_to_uniform_hemisphere(
		    pm_rng_float(&rng), pm_rng_float(&rng));
		struct pm_vec3 wo = pm_square_to_uniform_hemisphere(
		    pm_rng_float(&rng), pm_rng_float(&rng));
		struct pm_vec3 wib = pm_v3(wi.x, wi.y, -wi.z);
		struct pm_vec3 wob = pm_v3(wo.x, wo.y, -wo.z);
		struct pm_rgb f, g;

		f = pm_bsdf_eval(&s.bsdfs[two], wi, wo, PM_RADIANCE);
		g = pm_bsdf_eval(&s.bsdfs[front], wi, wo, PM_RADIANCE);
		assert_true(f.r == g.r && f.g == g.g && f.b == g.b);
		f = pm_bsdf_eval(&s.bsdfs[two], wib, wob, PM_RADIANCE);
		g = pm_bsdf_eval(&s.bsdfs[back], wi, wo, PM_RADIANCE);
		assert_true(f.r == g.r && f.g == g.g && f.b == g.b);
		assert_true(pm_bsdf_pdf(&s.bsdfs[two], wib, wob) ==
		    pm_bsdf_pdf(&s.bsdfs[back], wi, wo));
		/* nothing passes from one side to the other */
		assert_true(pm_rgb_is_black(pm_bsdf_eval(&s.bsdfs[two], wi, wob,
		    PM_RADIANCE)));
		assert_true(pm_rgb_is_black(pm_bsdf_eval(&s.bsdfs[two], wib, wo,
		    PM_RADIANCE)));
	}
	pm_scene_free(&s);
}

/* ---- textures ---- */

/* A textured weight and a textured nested BSDF are looked up at the hit
 * the parent was looked up at. */
static void
test_textures(void **state)
{
	struct pm_scene s;
	struct pm_texture t;
	struct pm_bsdf child, hit;
	struct pm_vec3 wi = dir(0.2, 0.0), wo = dir(0.5, 1.0);
	struct pm_rgb f;
	int tc, tw, c, white, bl;

	(void)state;
	pm_scene_init(&s);
	/* color0 where u and v are both below 1/2 (or both above) */
	pm_texture_init(&t, PM_TEXTURE_CHECKERBOARD);
	t.color0 = pm_rgb1(0.9f);
	t.color1 = pm_rgb1(0.1f);
	tc = pm_scene_add_texture(&s, &t);
	pm_texture_init(&t, PM_TEXTURE_CHECKERBOARD);
	t.color0 = pm_rgb1(0.2f);
	t.color1 = pm_rgb(0.6f, 0.3f, 0.9f);
	tw = pm_scene_add_texture(&s, &t);
	assert_true(tc >= 0 && tw >= 0);
	child = diffuse(pm_rgb1(0.5f));
	child.tex_diffuse = tc + 1;
	c = add(&s, child);
	white = add(&s, diffuse(pm_rgb1(1.0f)));
	bl = add_mix(&s, PM_BSDF_BLEND, c, white, 0.5f);
	s.bsdfs[bl].tex_weight = tw + 1;
	prepare(&s);
	assert_true(s.bsdfs[bl].nested_textures);
	assert_false(s.bsdfs[white].nested_textures);

	/* (0.25, 0.25): the child's color0; the weight, as Mitsuba's
	 * eval_1 reads a checkerboard, color1 reduced by its mean */
	hit = s.bsdfs[bl];
	pm_bsdf_lookup(s.textures, &hit, 0.25f, 0.25f);
	assert_true(close_to(hit.weight, 0.6, 1e-6, "weight at color0"));
	f = pm_bsdf_eval(&hit, wi, wo, PM_RADIANCE);
	assert_true(close_to(f.g, (0.4 * 0.9 + 0.6 * 1.0) * wo.z / M_PI,
	    1e-6, "blend at color0"));
	/* (0.75, 0.25): the child's color1, the weight color0's 0.2 */
	hit = s.bsdfs[bl];
	pm_bsdf_lookup(s.textures, &hit, 0.75f, 0.25f);
	assert_true(close_to(hit.weight, 0.2, 1e-6, "weight at color1"));
	f = pm_bsdf_eval(&hit, wi, wo, PM_RADIANCE);
	assert_true(close_to(f.g, (0.8 * 0.1 + 0.2 * 1.0) * wo.z / M_PI,
	    1e-6, "blend at color1"));
	pm_scene_free(&s);
}

/* Nested BSDFs must come before the one that holds them. */
static void
test_order(void **state)
{
	struct pm_scene s;
	struct pm_error err;
	int a, m;

	(void)state;
	pm_scene_init(&s);
	a = add(&s, diffuse(pm_rgb1(0.5f)));
	m = add_mix(&s, PM_BSDF_BLEND, a, a, 0.5f);
	s.bsdfs[m].nested[1] = m;
	memset(&err, 0, sizeof(err));
	assert_int_equal(pm_scene_prepare(&s, &err), PM_ERR_INVALID);
	assert_non_null(strstr(err.msg, "not below its own"));
	pm_scene_free(&s);
}

/* A blend of anisotropic BSDFs asks for the frame along dp/du, as they
 * would alone; a normal-mapped BSDF inside a blend is refused (its
 * perturbed frame is made for the BSDF at the hit only). */
static void
test_frames_of_nested(void **state)
{
	struct pm_scene s;
	struct pm_error err;
	struct pm_bsdf aniso;
	int a, d, m;

	(void)state;
	pm_scene_init(&s);
	memset(&aniso, 0, sizeof(aniso));
	aniso.type = PM_BSDF_ROUGHCONDUCTOR;
	aniso.specular = pm_rgb1(1.0f);
	aniso.eta = pm_rgb1(0.0f);
	aniso.k = pm_rgb1(1.0f);
	aniso.alpha = 0.1f;
	aniso.alpha_v = 0.4f;
	aniso.aniso = true;
	a = add(&s, aniso);
	d = add(&s, diffuse(pm_rgb1(0.5f)));
	m = add_mix(&s, PM_BSDF_BLEND, d, a, 0.5f);
	prepare(&s);
	assert_true(pm_bsdf_needs_tangent(&s.bsdfs[m]));
	assert_false(pm_bsdf_needs_tangent(&s.bsdfs[d]));
	pm_scene_free(&s);

	pm_scene_init(&s);
	d = add(&s, diffuse(pm_rgb1(0.5f)));
	s.bsdfs[d].tex_normal = 1;
	{
		struct pm_texture t;

		pm_texture_init(&t, PM_TEXTURE_CHECKERBOARD);
		assert_true(pm_scene_add_texture(&s, &t) == 0);
	}
	m = add_mix(&s, PM_BSDF_MASK, d, -1, 0.5f);
	memset(&err, 0, sizeof(err));
	assert_int_equal(pm_scene_prepare(&s, &err), PM_ERR_UNSUPPORTED);
	assert_non_null(strstr(err.msg, "normalmap or bumpmap inside"));
	pm_scene_free(&s);
}

/* Mitsuba's table of named conductors: every name it ships data for,
 * case-sensitive as its file names; each a physical metal (reflectance
 * in (0, 1] at every angle); "none" the perfect mirror.  (That the
 * numbers are Mitsuba's own is checked against Mitsuba by
 * tests/mitsuba/conductors.py in compare.sh.) */
static void
test_conductor_names(void **state)
{
	static const char *names[] = { "none", "Au", "Ag", "Al", "Cu", "a-C",
	    "d-C_palik", "Cu2O_palik", "TiO2-e", "V_palik", "W", "Se-e" };
	struct pm_rgb eta, k, f;
	size_t i;
	int j;

	(void)state;
	for (i = 0; i < sizeof(names) / sizeof(names[0]); i++) {
		if (!pm_conductor_lookup(names[i], &eta, &k))
			fail_msg("%s: not found", names[i]);
		for (j = 0; j <= 10; j++) {
			f = pm_fresnel_conductor(0.05f + 0.095f * (float)j, eta, k);
			assert_true(f.r > 0.0f && f.r <= 1.0f + 1e-6f);
			assert_true(f.g > 0.0f && f.g <= 1.0f + 1e-6f);
			assert_true(f.b > 0.0f && f.b <= 1.0f + 1e-6f);
		}
	}
	assert_true(pm_conductor_lookup("none", &eta, &k));
	f = pm_fresnel_conductor(0.3f, eta, k);
	assert_true(close_to(f.g, 1.0, 1e-6, "none"));
	assert_false(pm_conductor_lookup("au", &eta, &k));
	assert_false(pm_conductor_lookup("V", &eta, &k));
	assert_false(pm_conductor_lookup("", &eta, &k));
}

int
main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_furnace),
		cmocka_unit_test(test_albedo),
		cmocka_unit_test(test_sampling),
		cmocka_unit_test(test_split),
		cmocka_unit_test(test_twosided),
		cmocka_unit_test(test_textures),
		cmocka_unit_test(test_order),
		cmocka_unit_test(test_frames_of_nested),
		cmocka_unit_test(test_conductor_names),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
