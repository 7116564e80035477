/*
 * test_envmap.c: the envmap emitter.  Radiance follows Mitsuba 3's
 * latitude-longitude mapping (texel centres, poles, the image's middle
 * looking along +z, to_world); sampling picks each cell with its share of
 * luminance times solid angle (chi-square over the cells) and uniformly
 * within it (chi-square over positions within cells); the density that
 * sampling reports is the one pm_envmap_pdf gives, and it integrates to
 * one over the sphere; importance-sampled estimates of the radiance
 * integral are unbiased; and, rendered, a flat envmap lights a plane
 * exactly as a constant emitter does, and a map with a bright patch gives
 * the irradiance integrated from the map by quadrature.
 *
 * Statistical checks use fixed seeds; means are held to four standard
 * errors, chi-square tests to p > 1e-3 / (number of them).
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <cmocka.h>

#include "../../common/envmap.h"
#include "../../common/render.h"
#include "../../common/rng.h"
#include "../../common/world.h"
#include "../../formats/exr.h"
#include "../../formats/scene_xml.h"
#include "stats.h"
#include "tmpdir.h"

#define NCHI2 2
#define SIGNIFICANCE (1e-3 / NCHI2)
#define TWO_PI 6.283185307179586
#define W 24
#define H 13

static char tmpdir[64];
static float img[W * H * 3];

/* A dim gradient with a bright patch and one black texel: light of very
 * different strengths, and zero where a sampler must never go. */
static void
make_image(void)
{
	int x, y;

	for (y = 0; y < H; y++)
		for (x = 0; x < W; x++) {
			float *p = &img[3 * (y * W + x)];

			p[0] = 0.1f + 0.02f * (float)x;
			p[1] = 0.2f + 0.01f * (float)y;
			p[2] = 0.3f;
			if (x >= 15 && x <= 17 && y >= 3 && y <= 4) {
				p[0] = 400.0f;
				p[1] = 300.0f;
				p[2] = 100.0f;
			}
		}
	/* a black block of four texels: the cell between them is black */
	for (y = 8; y <= 9; y++)
		for (x = 4; x <= 5; x++) {
			float *p = &img[3 * (y * W + x)];

			p[0] = p[1] = p[2] = 0.0f;
		}
}

static int
setup(void **state)
{
	(void)state;
	make_image();
	return pm_tmpdir_make(tmpdir, sizeof(tmpdir), "envmap");
}

static int
teardown(void **state)
{
	(void)state;
	return pm_tmpdir_remove(tmpdir);
}

static void
init(struct pm_envmap *e, const struct pm_mat4 *M, float scale)
{
	struct pm_error err;
	struct pm_mat4 I = pm_mat4_identity();

	if (pm_envmap_init(e, img, W, H, scale, M != NULL ? M : &I, &err)
	    != PM_OK) {
		print_error("%s\n", err.msg);
		fail();
	}
}

/* Direction of (u, v) in the emitter's frame, Mitsuba's convention. */
static struct pm_vec3
uv_dir(double u, double v)
{
	double phi = TWO_PI * u, th = M_PI * v;

	return pm_v3((float)(sin(phi) * sin(th)), (float)cos(th),
	    (float)(-cos(phi) * sin(th)));
}

static void
test_mapping(void **state)
{
	struct pm_envmap e, r;
	struct pm_mat4 M = pm_mat4_rotate(pm_v3(1, 2, 3), 70.0f);
	struct pm_rgb c;
	int x, y;

	(void)state;
	init(&e, NULL, 2.0f);
	/* texel centres: u = (x + 1/2) / W, v = y / (H - 1) */
	for (y = 1; y < H - 1; y += 3)
		for (x = 0; x < W; x += 5) {
			const float *p = &img[3 * (y * W + x)];

			c = pm_envmap_eval(&e, uv_dir((x + 0.5) / W,
			    (double)y / (H - 1)));
			assert_true(fabsf(c.r - 2.0f * p[0]) <= 1e-3f * (1 + p[0]));
			assert_true(fabsf(c.g - 2.0f * p[1]) <= 1e-3f * (1 + p[1]));
			assert_true(fabsf(c.b - 2.0f * p[2]) <= 1e-3f * (1 + p[2]));
		}
	/* +z looks at the middle of the image: u = 1/2 lies between
	 * columns W/2 - 1 and W/2, v = 1/2 on row (H - 1) / 2 */
	c = pm_envmap_eval(&e, pm_v3(0, 0, 1));
	y = (H - 1) / 2;
	assert_true(fabsf(c.r - (img[3 * (y * W + W / 2 - 1)] +
	    img[3 * (y * W + W / 2)])) <= 1e-4f);
	/* up is the top row; its pixels are averaged along u only */
	c = pm_envmap_eval(&e, pm_v3(0, 1, 0));
	assert_true(c.g > 2.0f * 0.2f - 1e-4f && c.g < 2.0f * 0.2f + 1e-4f);
	c = pm_envmap_eval(&e, pm_v3(0, -1, 0));
	assert_true(fabsf(c.g - 2.0f * (0.2f + 0.01f * (H - 1))) <= 1e-4f);
	/* to_world turns the map: what e shows at d, r shows at M d */
	init(&r, &M, 2.0f);
	for (x = 0; x < 20; x++) {
		struct pm_vec3 d = uv_dir(0.05 * x + 0.01, 0.04 * x + 0.1);
		struct pm_rgb a = pm_envmap_eval(&e, d);
		struct pm_rgb b = pm_envmap_eval(&r, pm_normalize(
		    pm_xform_vector(&M, d)));

		assert_true(fabsf(a.r - b.r) <= 1e-3f * (1.0f + a.r));
		assert_true(fabsf(a.b - b.b) <= 1e-3f * (1.0f + a.b));
	}
	pm_envmap_free(&e);
	pm_envmap_free(&r);
	/* scale 0 (or a black image): valid, dark, never sampled */
	init(&e, NULL, 0.0f);
	{
		float pdf = 1.0f;

		(void)pm_envmap_sample(&e, 0.3f, 0.6f, &pdf);
		assert_true(pdf == 0.0f);
		assert_true(pm_envmap_pdf(&e, pm_v3(0, 1, 0)) == 0.0f);
		assert_true(pm_envmap_eval(&e, pm_v3(0.6f, 0.8f, 0)).r == 0.0f);
	}
	pm_envmap_free(&e);
}

/* Cell, and position within it, of a local direction (as sampling lays
 * them out: phi from the half-texel shift, cos theta between rows). */
static void
cell_of(struct pm_vec3 d, int *cx, int *cy, double *fx, double *fy)
{
	double u = atan2(d.x, -d.z) / TWO_PI - 0.5 / W, x, v, c0, c1;

	u -= floor(u);
	x = u * W;
	*cx = (int)x < W ? (int)x : W - 1;
	*fx = x - *cx;
	v = acos(fmax(-1.0, fmin(1.0, d.y))) / M_PI * (H - 1);
	*cy = (int)v < H - 1 ? (int)v : H - 2;
	c0 = cos(M_PI * *cy / (H - 1));
	c1 = cos(M_PI * (*cy + 1) / (H - 1));
	*fy = (c0 - d.y) / (c0 - c1);
}

static double
lum(const float *p)
{
	return 0.212671 * p[0] + 0.715160 * p[1] + 0.072169 * p[2];
}

static void
test_sampling(void **state)
{
	enum { N = 1000000, NS = 8 };
	static double obs[W * (H - 1)], expd[W * (H - 1)];
	static double sobs[NS * NS], sexp[NS * NS];
	struct pm_envmap e;
	struct pm_rng rng = pm_rng_seed(17, 0, 0);
	double sum = 0.0;
	int i, x, y, mismatch = 0;

	(void)state;
	init(&e, NULL, 1.0f);
	memset(obs, 0, sizeof(obs));
	memset(sobs, 0, sizeof(sobs));
	for (i = 0; i < N; i++) {
		float pdf, u1 = pm_rng_float(&rng), u2 = pm_rng_float(&rng);
		struct pm_vec3 d = pm_envmap_sample(&e, u1, u2, &pdf);
		double fx, fy;
		int cx, cy, sx, sy;

		assert_true(pdf > 0.0f);
		assert_true(fabsf(pm_length(d) - 1.0f) < 1e-5f);
		if (fabsf(pm_envmap_pdf(&e, d) - pdf) > 1e-3f * pdf)
			mismatch++;	/* only on cell borders */
		cell_of(d, &cx, &cy, &fx, &fy);
		obs[cy * W + cx] += 1.0;
		sx = (int)(fx * NS);
		sy = (int)(fy * NS);
		sobs[(sy < NS ? (sy < 0 ? 0 : sy) : NS - 1) * NS +
		    (sx < NS ? sx : NS - 1)] += 1.0;
	}
	print_message("pdf of a sample differs from pm_envmap_pdf %d times "
	    "in %d\n", mismatch, N);
	assert_true(mismatch <= N / 10000);
	/* expected: mean corner luminance times the cell's solid angle */
	for (y = 0; y < H - 1; y++)
		for (x = 0; x < W; x++) {
			int x1 = (x + 1) % W;
			double l = 0.25 * (lum(&img[3 * (y * W + x)]) +
			    lum(&img[3 * (y * W + x1)]) +
			    lum(&img[3 * ((y + 1) * W + x)]) +
			    lum(&img[3 * ((y + 1) * W + x1)]));

			expd[y * W + x] = l * (cos(M_PI * y / (H - 1)) -
			    cos(M_PI * (y + 1) / (H - 1)));
			sum += expd[y * W + x];
		}
	for (i = 0; i < W * (H - 1); i++)
		expd[i] *= N / sum;
	assert_true(expd[8 * W + 4] == 0.0);	/* the black cell */
	assert_true(obs[8 * W + 4] == 0.0);
	assert_true(stats_chi2(obs, expd, W * (H - 1), STATS_POOL_JOIN,
	    SIGNIFICANCE, "envmap cells") > SIGNIFICANCE);
	for (i = 0; i < NS * NS; i++)
		sexp[i] = (double)N / (NS * NS);
	assert_true(stats_chi2(sobs, sexp, NS * NS, STATS_POOL_JOIN,
	    SIGNIFICANCE, "within cells") > SIGNIFICANCE);
	pm_envmap_free(&e);
}

static void
test_pdf_integral(void **state)
{
	enum { N = 2000000 };
	struct pm_envmap e;
	struct pm_mat4 M = pm_mat4_rotate(pm_v3(-1, 0.5f, 2), 130.0f);
	struct pm_rng rng = pm_rng_seed(23, 0, 0);
	double s = 0.0, s2 = 0.0, m, se;
	int i;

	(void)state;
	init(&e, &M, 1.0f);
	/* 4 pi E[pdf(w)] over uniform directions is the pdf's integral */
	for (i = 0; i < N; i++) {
		struct pm_vec3 w = pm_square_to_uniform_sphere(
		    pm_rng_float(&rng), pm_rng_float(&rng));
		double p = 4.0 * M_PI * pm_envmap_pdf(&e, w);

		s += p;
		s2 += p * p;
	}
	m = s / N;
	se = sqrt((s2 / N - m * m) / N);
	print_message("integral of the pdf %.5f +- %.5f\n", m, se);
	assert_true(fabs(m - 1.0) <= 4.0 * se);
	pm_envmap_free(&e);
}

/* Integral of the radiance's red channel over the sphere, by a fine
 * midpoint rule in (cos theta, phi): the reference for the estimators. */
static double
quadrature(const struct pm_envmap *e, bool upper_cos)
{
	enum { NZQ = 1200, NPQ = 2400 };
	double s = 0.0;
	int i, j;

	for (i = 0; i < NZQ; i++) {
		double z = -1.0 + (i + 0.5) * 2.0 / NZQ, r = sqrt(1 - z * z);

		if (upper_cos && z <= 0.0)
			continue;
		for (j = 0; j < NPQ; j++) {
			double ph = (j + 0.5) * TWO_PI / NPQ;
			struct pm_vec3 w = pm_v3((float)(r * cos(ph)), (float)z,
			    (float)(r * sin(ph)));

			s += pm_envmap_eval(e, w).r * (upper_cos ? z : 1.0);
		}
	}
	return s * (2.0 / NZQ) * (TWO_PI / NPQ);
}

static void
test_unbiased(void **state)
{
	enum { N = 400000 };
	struct pm_envmap e;
	struct pm_rng rng = pm_rng_seed(29, 0, 0);
	double ref, s = 0.0, s2 = 0.0, m, se;
	int i;

	(void)state;
	init(&e, NULL, 1.0f);
	ref = quadrature(&e, false);
	for (i = 0; i < N; i++) {
		float pdf;
		struct pm_vec3 w = pm_envmap_sample(&e, pm_rng_float(&rng),
		    pm_rng_float(&rng), &pdf);
		double f = pm_envmap_eval(&e, w).r / pdf;

		s += f;
		s2 += f * f;
	}
	m = s / N;
	se = sqrt((s2 / N - m * m) / N);
	print_message("integral of red: sampled %.5f +- %.5f, quadrature "
	    "%.5f\n", m, se, ref);
	/* the quadrature's own error is far below this */
	assert_true(fabs(m - ref) <= 4.0 * se + 1e-4 * ref);
	pm_envmap_free(&e);
}

/* A diffuse disk filling the camera's view, lit by the environment only
 * (max_depth 2: direct light); every pixel's expectation is rho E / pi. */
static void
render_plane(const char *emitter, double *mean, double *se)
{
	char xml[4096];
	struct pm_scene s;
	struct pm_world w;
	struct pm_render_ctx ctx;
	struct pm_render_opts o;
	struct pm_render_stats st;
	struct pm_image im;
	struct pm_error err;
	double s1 = 0.0, s2 = 0.0;
	size_t i, n;

	snprintf(xml, sizeof(xml),
	    "<scene version=\"3.0.0\">\n"
	    "<integrator type=\"path\"><integer name=\"max_depth\" "
	    "value=\"2\"/></integrator>\n"
	    "<sensor type=\"perspective\"><float name=\"fov\" value=\"10\"/>"
	    "<transform name=\"to_world\"><lookat origin=\"0, 5, 0\" "
	    "target=\"0, 0, 0\" up=\"0, 0, 1\"/></transform>"
	    "<sampler type=\"independent\"><integer name=\"sample_count\" "
	    "value=\"16\"/></sampler>"
	    "<film type=\"hdrfilm\"><integer name=\"width\" value=\"32\"/>"
	    "<integer name=\"height\" value=\"32\"/><rfilter type=\"box\"/>"
	    "</film></sensor>\n"
	    "%s\n"
	    "<shape type=\"disk\"><transform name=\"to_world\"><rotate x=\"1\" "
	    "angle=\"-90\"/></transform><bsdf type=\"diffuse\">"
	    "<rgb name=\"reflectance\" value=\"0.5\"/></bsdf></shape>\n"
	    "</scene>\n", emitter);
	if (pm_scene_load_string(xml, strlen(xml), "p.xml", tmpdir, NULL, 0,
	    &s, &err) != PM_OK) {
		print_error("%s\n", err.msg);
		fail();
	}
	assert_int_equal(pm_world_init(&w, &s, &err), PM_OK);
	memset(&ctx, 0, sizeof(ctx));
	ctx.scene = &s;
	ctx.accel = w.accel;
	ctx.lights = &w.lights;
	ctx.max_depth = s.integrator.max_depth;
	ctx.rr_depth = s.integrator.rr_depth;
	memset(&o, 0, sizeof(o));
	o.method = PM_METHOD_PATH;
	o.spp = s.camera.spp;
	o.seed = 3;
	o.threads = 2;
	assert_int_equal(pm_render(&ctx, &s.camera, &o, &im, &st, &err), PM_OK);
	n = (size_t)im.width * (size_t)im.height;
	for (i = 0; i < n; i++) {
		double v = im.rgb[3 * i];

		s1 += v;
		s2 += v * v;
	}
	*mean = s1 / (double)n;
	*se = sqrt((s2 / (double)n - *mean * *mean) / (double)n);
	pm_image_free(&im);
	pm_world_free(&w);
	pm_scene_free(&s);
}

static void
test_render(void **state)
{
	static float flat[W * H * 3];
	char path[128], em[512];
	struct pm_image im = {W, H, NULL};
	struct pm_error err;
	struct pm_envmap e;
	double m, se, E;
	int i;

	(void)state;
	for (i = 0; i < W * H * 3; i++)
		flat[i] = 0.75f;
	im.rgb = flat;
	snprintf(path, sizeof(path), "%s/flat.exr", tmpdir);
	assert_int_equal(pm_exr_write(path, &im, false, &err), PM_OK);
	im.rgb = img;
	snprintf(path, sizeof(path), "%s/patch.exr", tmpdir);
	assert_int_equal(pm_exr_write(path, &im, false, &err), PM_OK);

	/* Uniform radiance L over the upper hemisphere: rho L. */
	render_plane("<emitter type=\"constant\"><rgb name=\"radiance\" "
	    "value=\"1.5\"/></emitter>", &m, &se);
	print_message("constant: %.5f +- %.5f (exact 0.75)\n", m, se);
	assert_true(fabs(m - 0.75) <= 4.0 * se + 1e-6);
	render_plane("<emitter type=\"envmap\"><string name=\"filename\" "
	    "value=\"flat.exr\"/><float name=\"scale\" value=\"2\"/>"
	    "</emitter>", &m, &se);
	print_message("flat envmap: %.5f +- %.5f (exact 0.75)\n", m, se);
	assert_true(fabs(m - 0.75) <= 4.0 * se + 1e-6);

	/* The patch, turned so that it shines on the plane's front. */
	snprintf(em, sizeof(em), "<emitter type=\"envmap\"><string "
	    "name=\"filename\" value=\"patch.exr\"/><transform "
	    "name=\"to_world\"><rotate z=\"1\" angle=\"30\"/></transform>"
	    "</emitter>");
	{
		struct pm_mat4 M = pm_mat4_rotate(pm_v3(0, 0, 1), 30.0f);

		init(&e, &M, 1.0f);
		E = quadrature(&e, true);
		pm_envmap_free(&e);
	}
	render_plane(em, &m, &se);
	print_message("patch envmap: %.5f +- %.5f (quadrature %.5f)\n", m, se,
	    0.5 * E / M_PI);
	assert_true(fabs(m - 0.5 * E / M_PI) <= 4.0 * se + 1e-4 * m);
}

/* A directional light of irradiance E at 45 degrees to the plane: every
 * pixel is rho E cos(45) / pi, exactly (a delta light has no noise). */
static void
test_directional(void **state)
{
	double m, se, want = 0.5 * 2.0 * sqrt(0.5) / M_PI;

	(void)state;
	render_plane("<emitter type=\"directional\"><vector name=\"direction\" "
	    "x=\"0\" y=\"-1\" z=\"-1\"/><rgb name=\"irradiance\" "
	    "value=\"2\"/></emitter>", &m, &se);
	print_message("directional: %.6f +- %.6f (exact %.6f)\n", m, se, want);
	assert_true(fabs(m - want) <= 1e-4 * want);
	/* the same light given by to_world (its +z turned to -y) */
	render_plane("<emitter type=\"directional\"><transform name=\"to_world\">"
	    "<rotate x=\"1\" angle=\"135\"/></transform><rgb name=\"irradiance\" "
	    "value=\"2\"/></emitter>", &m, &se);
	assert_true(fabs(m - want) <= 1e-4 * want);
}

int
main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_mapping),
		cmocka_unit_test(test_sampling),
		cmocka_unit_test(test_pdf_integral),
		cmocka_unit_test(test_unbiased),
		cmocka_unit_test(test_render),
		cmocka_unit_test(test_directional),
	};

	return cmocka_run_group_tests(tests, setup, teardown);
}
