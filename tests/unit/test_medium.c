/*
 * test_medium.c: participating media (common/medium.c, the path tracer's
 * integrator_volume.c, formats/scene_xml/medium.c).
 *
 *   - Beer-Lambert: transmittance in closed form; a shadow ray through a
 *     null-BSDF slab of medium, straight and oblique, carries exactly
 *     exp(-sigma_t d); the free-flight estimator's weights average to the
 *     transmittance and to the scattered fraction; and the path tracer
 *     looking out of a purely absorbing sphere at a uniform emitter sees
 *     Le exp(-sigma_t R).
 *   - Phase functions: the Henyey-Greenstein density integrates to 1 and
 *     its sampler passes a chi-square test against it.
 *   - The furnace: inside a uniformly emitting sphere filled with a medium
 *     of albedo 1, radiance is Le everywhere, whatever the phase function,
 *     the colour of sigma_t, and with or without light sampling.
 *   - Single scattering: a sphere of medium behind a null surface, lit by
 *     a point light, to max_depth 2, against the numeric integral along
 *     the ray (light sampling at scatters, shadow rays through the
 *     boundary, Henyey-Greenstein's orientation).
 *   - Loading: every XML form of Mitsuba's media (nested, by reference, on
 *     shapes and on the sensor, phase nested), its defaults, its errors;
 *     and photon mapping's refusal, which names the medium.
 * Statistical checks hold a mean within four standard errors estimated
 * from the same samples (fixed seeds).
 */
#include <math.h>
#include <setjmp.h>
#include <stdio.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "../../common/render.h"
#include "../../common/shoot.h"
#include "../../common/world.h"
#include "../../formats/scene_xml.h"
#include "stats.h"

#define NZ 40
#define NPHI 40
#define SIGNIFICANCE 1e-4

static const struct pm_rgb LE = {1.0f, 2.0f, 0.5f};

static double
chan(struct pm_rgb c, int i)
{
	return i == 0 ? c.r : i == 1 ? c.g : c.b;
}

/* |got - want| within k standard errors se (and a float's rounding). */
static void
assert_within(double got, double want, double se, double k, const char *what)
{
	double tol = k * se + 1e-6 * fabs(want);

	print_message("%s: got %.6f want %.6f (se %.2g, %.2f sigma)\n", what, got,
	    want, se, se > 0 ? (got - want) / se : 0.0);
	assert_true(fabs(got - want) <= tol);
}

static struct pm_medium
mk_medium(struct pm_rgb sigma_t, struct pm_rgb albedo, enum pm_phase_type ph,
    float g, bool sample_emitters)
{
	struct pm_medium m;

	memset(&m, 0, sizeof(m));
	m.type = PM_MEDIUM_HOMOGENEOUS;
	m.sigma_t = sigma_t;
	m.albedo = albedo;
	m.phase.type = ph;
	m.phase.g = g;
	m.sample_emitters = sample_emitters;
	snprintf(m.name, sizeof(m.name), "test");
	return m;
}

/* ------------------------------------------------------- Beer-Lambert */

static void
test_transmittance_closed_form(void **state)
{
	struct pm_medium m = mk_medium(pm_rgb(0.5f, 1.0f, 0.0f), pm_rgb1(0.5f),
	    PM_PHASE_ISOTROPIC, 0.0f, true);
	const float ts[] = {0.0f, 0.3f, 2.5f};
	struct pm_rgb t;
	size_t i;
	int c;

	(void)state;
	for (i = 0; i < sizeof(ts) / sizeof(ts[0]); i++) {
		t = pm_medium_transmittance(&m, ts[i]);
		for (c = 0; c < 3; c++)
			assert_true(fabs(chan(t, c) - exp(-chan(m.sigma_t, c) *
			    ts[i])) < 1e-6);
	}
	/* infinitely far: opaque where sigma_t > 0, clear where it is 0 */
	t = pm_medium_transmittance(&m, INFINITY);
	assert_true(t.r == 0.0f && t.g == 0.0f && t.b == 1.0f);
}

/*
 * Free flights in a chromatic medium, a channel chosen uniformly and
 * weighted by the average density: E[w; passed] = T(tmax) and
 * E[w; scattered] = albedo (1 - T(tmax)) per channel, the integral of
 * T sigma_s.
 */
static void
test_free_flight_unbiased(void **state)
{
	struct pm_medium m = mk_medium(pm_rgb(0.4f, 1.5f, 4.0f),
	    pm_rgb(0.9f, 0.5f, 0.2f), PM_PHASE_ISOTROPIC, 0.0f, true);
	const float tmax = 0.7f;
	const int n = 400000;
	struct pm_rng rng = pm_rng_seed(11, 0, 0);
	struct pm_medium_sample ms;
	double sp[3] = {0}, sp2[3] = {0}, ss[3] = {0}, ss2[3] = {0}, w, T, se;
	int i, c;

	(void)state;
	for (i = 0; i < n; i++) {
		float uc = pm_rng_float(&rng), ud = pm_rng_float(&rng);

		pm_medium_sample(&m, tmax, uc < 1.0f / 3 ? 0 : uc < 2.0f / 3 ?
		    1 : 2, ud, &ms);
		assert_true(ms.scattered ? ms.t < tmax : ms.t == tmax);
		for (c = 0; c < 3; c++) {
			/* one-sample MIS over the uniformly chosen channel */
			w = chan(ms.f, c) / pm_rgb_mean(ms.pdf);
			if (ms.scattered) {
				ss[c] += w;
				ss2[c] += w * w;
			} else {
				sp[c] += w;
				sp2[c] += w * w;
			}
		}
	}
	for (c = 0; c < 3; c++) {
		T = exp(-chan(m.sigma_t, c) * tmax);
		se = sqrt((sp2[c] / n - (sp[c] / n) * (sp[c] / n)) / n);
		assert_within(sp[c] / n, T, se, 4.0, "passed");
		se = sqrt((ss2[c] / n - (ss[c] / n) * (ss[c] / n)) / n);
		assert_within(ss[c] / n, chan(m.albedo, c) * (1.0 - T), se, 4.0,
		    "scattered");
	}
}

/* A scene of spheres and an optional slab built in code. */
struct box {
	struct pm_scene scene;
	struct pm_world world;
	struct pm_render_ctx ctx;
};

static int
add_bsdf(struct pm_scene *s, enum pm_bsdf_type t, float rho)
{
	int b = pm_scene_add_bsdf(s);

	assert_true(b >= 0);
	s->bsdfs[b].type = t;
	s->bsdfs[b].diffuse = pm_rgb1(rho);
	return b;
}

static int
add_medium(struct pm_scene *s, struct pm_medium m)
{
	int i = pm_scene_add_medium(s);

	assert_true(i >= 0);
	s->media[i] = m;
	return i;
}

/* A black sphere of radius r emitting LE inwards, around the origin. */
static void
add_emitter_sphere(struct pm_scene *s, float r)
{
	int sh = pm_scene_add_shape(s), l;

	s->shapes[sh].type = PM_SHAPE_SPHERE;
	s->shapes[sh].center = pm_v3(0, 0, 0);
	s->shapes[sh].radius = r;
	s->shapes[sh].flip_normals = true;
	s->shapes[sh].bsdf = add_bsdf(s, PM_BSDF_DIFFUSE, 0.0f);
	l = pm_scene_add_light(s);
	s->lights[l].type = PM_LIGHT_AREA;
	s->lights[l].radiance = LE;
	s->lights[l].shape = sh;
	s->shapes[sh].light = l;
}

static void
box_finish(struct box *bx, int max_depth)
{
	struct pm_scene *s = &bx->scene;
	struct pm_error err;

	s->integrator.max_depth = max_depth;
	s->has_camera = true;
	s->camera.to_world = pm_mat4_lookat(pm_v3(0, 0, 0), pm_v3(0.3f, 0.2f,
	    -1.0f), pm_v3(0, 1, 0));
	s->camera.fov = 60.0f;
	s->camera.fov_axis = PM_FOV_X;
	/* The medium starts at the near plane, as in Mitsuba: keep it
	 * negligible next to the tolerances. */
	s->camera.near_clip = 1e-5f;
	s->camera.far_clip = 1000.0f;
	s->camera.width = 24;
	s->camera.height = 24;
	s->camera.spp = 16;
	s->camera.rfilter = PM_RFILTER_BOX;
	assert_int_equal(pm_scene_prepare(s, &err), PM_OK);
	assert_int_equal(pm_world_init(&bx->world, s, &err), PM_OK);
	memset(&bx->ctx, 0, sizeof(bx->ctx));
	bx->ctx.scene = s;
	bx->ctx.accel = bx->world.accel;
	bx->ctx.lights = &bx->world.lights;
	bx->ctx.max_depth = max_depth;
	bx->ctx.rr_depth = 5;
}

static void
box_free(struct box *bx)
{
	pm_world_free(&bx->world);
	pm_scene_free(&bx->scene);
}

/* Renders and returns the mean over all pixels with its standard error
 * (pixels are independent). */
static void
render_stats(struct box *bx, double mean[3], double se[3])
{
	struct pm_render_opts o;
	struct pm_render_stats st;
	struct pm_image im;
	struct pm_error err;
	const struct pm_camera *c = &bx->scene.camera;
	double s1[3] = {0}, s2[3] = {0}, v;
	size_t i, n = (size_t)c->width * (size_t)c->height;
	int k;

	memset(&o, 0, sizeof(o));
	o.method = PM_METHOD_PATH;
	o.spp = c->spp;
	o.seed = 5;
	o.threads = 2;
	assert_int_equal(pm_render(&bx->ctx, c, &o, &im, &st, &err), PM_OK);
	assert_int_equal(st.dropped, 0);
	for (i = 0; i < n; i++)
		for (k = 0; k < 3; k++) {
			v = im.rgb[3 * i + (size_t)k];
			s1[k] += v;
			s2[k] += v * v;
		}
	for (k = 0; k < 3; k++) {
		mean[k] = s1[k] / (double)n;
		se[k] = sqrt(fmax(0.0, s2[k] / (double)n - mean[k] * mean[k]) /
		    (double)(n - 1));
	}
	pm_image_free(&im);
}

/*
 * A slab of medium 0.5 thick (a cube squashed along z, null BSDF, the
 * medium inside) between a point in vacuum and a light: the shadow ray's
 * transmittance is exp(-sigma_t 0.5 / cos theta) exactly.
 */
static void
test_slab_shadow_ray(void **state)
{
	struct box bx;
	struct pm_scene *s = &bx.scene;
	struct pm_error err;
	struct pm_mat4 M;
	struct pm_light_sample ls;
	struct pm_vec3 o[2] = {{0, 0, -3}, {-1.5f, 0.5f, -3}};
	struct pm_rgb tr;
	int sh, k, c;
	double len;

	(void)state;
	pm_scene_init(s);
	add_emitter_sphere(s, 50.0f);
	sh = pm_scene_add_shape(s);
	s->shapes[sh].type = PM_SHAPE_MESH;
	assert_int_equal(pm_mesh_cube(&s->shapes[sh].mesh, &err), PM_OK);
	M = pm_mat4_scale(pm_v3(10.0f, 10.0f, 0.25f));
	pm_mesh_transform(&s->shapes[sh].mesh, &M);
	s->shapes[sh].bsdf = add_bsdf(s, PM_BSDF_NULL, 0.0f);
	s->shapes[sh].interior = 1 + add_medium(s, mk_medium(pm_rgb(0.8f,
	    1.6f, 3.2f), pm_rgb1(0.5f), PM_PHASE_ISOTROPIC, 0.0f, true));
	box_finish(&bx, -1);
	for (k = 0; k < 2; k++) {
		memset(&ls, 0, sizeof(ls));
		ls.p = pm_v3(1.0f, -0.5f, 3.0f);
		ls.wi = pm_normalize(pm_sub(ls.p, o[k]));
		ls.dist = pm_length(pm_sub(ls.p, o[k]));
		len = 0.5 / fabs((double)ls.wi.z);
		tr = pm_volume_shadow(&bx.ctx, o[k], -1, &ls);
		/* Each crossing's ray origin is moved off the surface by
		 * 2e-5 of the slab's extent of 10 (pm_offset_origin), which
		 * shifts an oblique line by as much: two crossings bound
		 * the error in length by 4 x 2e-4. */
		for (c = 0; c < 3; c++) {
			double sig = chan(s->media[0].sigma_t, c);
			double want = exp(-sig * len);

			assert_true(fabs(chan(tr, c) - want) <=
			    want * sig * 8e-4 + 1e-6);
		}
	}
	/* any other surface blocks the light */
	s->bsdfs[s->shapes[sh].bsdf].type = PM_BSDF_DIFFUSE;
	tr = pm_volume_shadow(&bx.ctx, o[0], -1, &ls);
	assert_true(pm_rgb_is_black(tr));
	box_free(&bx);
}

/*
 * The camera inside a purely absorbing sphere of radius 2 (null BSDF),
 * inside an emitter: every pixel sees LE exp(-sigma_t 2), through the
 * free-flight weights of a chromatic medium.
 */
static void
test_absorbing_sphere_render(void **state)
{
	struct box bx;
	struct pm_scene *s = &bx.scene;
	double mean[3], se[3];
	int sh, m, c;

	(void)state;
	pm_scene_init(s);
	add_emitter_sphere(s, 10.0f);
	m = add_medium(s, mk_medium(pm_rgb(0.2f, 0.5f, 1.0f), pm_rgb1(0.0f),
	    PM_PHASE_ISOTROPIC, 0.0f, true));
	sh = pm_scene_add_shape(s);
	s->shapes[sh].type = PM_SHAPE_SPHERE;
	s->shapes[sh].center = pm_v3(0, 0, 0);
	s->shapes[sh].radius = 2.0f;
	s->shapes[sh].bsdf = add_bsdf(s, PM_BSDF_NULL, 0.0f);
	s->shapes[sh].interior = 1 + m;
	s->camera_medium = 1 + m;
	box_finish(&bx, -1);
	render_stats(&bx, mean, se);
	for (c = 0; c < 3; c++)
		assert_within(mean[c], chan(LE, c) * exp(-2.0 *
		    chan(s->media[m].sigma_t, c)), se[c], 4.0, "absorbed");
	box_free(&bx);
}

/* ---------------------------------------------------- phase functions */

static double
phase_pdf(struct pm_vec3 wo, const void *ctx)
{
	const struct pm_phase *ph = ctx;
	static const struct pm_vec3 d = {0.48f, -0.6f, 0.64f};

	return pm_phase_eval(ph, d, wo);
}

static void
check_phase(struct pm_phase ph, uint64_t seed, const char *what)
{
	static double obs[NZ * NPHI], expd[NZ * NPHI];
	const struct pm_vec3 d = {0.48f, -0.6f, 0.64f};
	const int n = 400000, m = 200000;
	struct pm_rng rng = pm_rng_seed(seed, 0, 0);
	struct pm_vec3 wo;
	double integral = 0.0, c;
	float pdf;
	int i;

	/* The density over cos theta, 2 pi p(cos theta), integrates to 1
	 * (midpoint rule in cos theta about d). */
	for (i = 0; i < m; i++) {
		struct pm_vec3 w;
		struct pm_frame fr = pm_frame_from_normal(d);

		c = -1.0 + (i + 0.5) * 2.0 / m;
		w = pm_to_world(fr, pm_v3((float)sqrt(1.0 - c * c), 0.0f,
		    (float)c));
		integral += 2.0 * 3.14159265358979323846 * pm_phase_eval(&ph, d,
		    w) * 2.0 / m;
	}
	print_message("%s: integral %.6f\n", what, integral);
	assert_true(fabs(integral - 1.0) < 2e-3);

	memset(obs, 0, sizeof(obs));
	for (i = 0; i < n; i++) {
		float u1 = pm_rng_float(&rng), u2 = pm_rng_float(&rng);

		wo = pm_phase_sample(&ph, d, u1, u2, &pdf);
		assert_true(fabs(pm_length(wo) - 1.0f) < 1e-4f);
		assert_true(fabs(pdf - pm_phase_eval(&ph, d, wo)) <=
		    1e-5f * pdf);
		obs[stats_sphere_bin(wo, NZ, NPHI)] += 1.0;
	}
	c = stats_sphere_expected(phase_pdf, &ph, n, NZ, NPHI, 12, expd);
	assert_true(fabs(c - n) < 2e-3 * n);
	assert_true(stats_chi2(obs, expd, NZ * NPHI, STATS_POOL_JOIN,
	    SIGNIFICANCE, what) > SIGNIFICANCE);
}

static void
test_phase_functions(void **state)
{
	(void)state;
	check_phase((struct pm_phase){PM_PHASE_ISOTROPIC, 0.0f}, 1, "isotropic");
	check_phase((struct pm_phase){PM_PHASE_HG, 0.0f}, 2, "hg 0");
	check_phase((struct pm_phase){PM_PHASE_HG, 0.5f}, 3, "hg 0.5");
	check_phase((struct pm_phase){PM_PHASE_HG, -0.3f}, 4, "hg -0.3");
	check_phase((struct pm_phase){PM_PHASE_HG, 0.8f}, 5, "hg 0.8");
	check_phase((struct pm_phase){PM_PHASE_HG, 0.0005f}, 6, "hg 0.0005");
}

/* Mitsuba's convention: g > 0 scatters forwards, along d. */
static void
test_hg_forward(void **state)
{
	struct pm_phase ph = {PM_PHASE_HG, 0.7f};
	struct pm_vec3 d = {0, 0, 1};

	(void)state;
	assert_true(pm_phase_eval(&ph, d, d) > pm_phase_eval(&ph, d,
	    pm_neg(d)));
}

/* ------------------------------------------------------------ furnace */

static void
furnace(struct pm_medium m, int max_depth, const char *what)
{
	struct box bx;
	struct pm_scene *s = &bx.scene;
	double mean[3], se[3], want;
	int c;

	pm_scene_init(s);
	add_emitter_sphere(s, 3.0f);
	s->camera_medium = 1 + add_medium(s, m);
	box_finish(&bx, max_depth);
	s->camera.spp = 64;
	render_stats(&bx, mean, se);
	for (c = 0; c < 3; c++) {
		/* max_depth 1: the emitter through the medium, unscattered */
		want = chan(LE, c) * (max_depth == 1 ?
		    exp(-3.0 * chan(m.sigma_t, c)) : 1.0);
		assert_within(mean[c], want, se[c], 4.0, what);
	}
	box_free(&bx);
}

static void
test_furnace(void **state)
{
	(void)state;
	furnace(mk_medium(pm_rgb(0.5f, 1.0f, 2.0f), pm_rgb1(1.0f),
	    PM_PHASE_ISOTROPIC, 0.0f, true), -1, "isotropic, chromatic");
	furnace(mk_medium(pm_rgb1(1.0f), pm_rgb1(1.0f), PM_PHASE_HG, 0.7f,
	    true), -1, "hg 0.7");
	furnace(mk_medium(pm_rgb(1.0f, 0.6f, 0.3f), pm_rgb1(1.0f), PM_PHASE_HG,
	    -0.4f, false), -1, "hg -0.4, no light sampling");
	furnace(mk_medium(pm_rgb(0.2f, 0.4f, 0.8f), pm_rgb1(1.0f),
	    PM_PHASE_ISOTROPIC, 0.0f, true), 1, "max_depth 1");
}

/* --------------------------------------------------- single scattering */

/* Distance from x (inside the unit sphere at the origin) along unit w to
 * its surface. */
static double
exit_dist(const double x[3], const double w[3])
{
	double b = x[0] * w[0] + x[1] * w[1] + x[2] * w[2];
	double c = x[0] * x[0] + x[1] * x[1] + x[2] * x[2] - 1.0;

	return -b + sqrt(b * b - c);
}

/*
 * A unit sphere of medium behind a null surface, lit by a point light
 * outside it, seen along one ray, to max_depth 2: the radiance is single
 * scattering alone,
 *     L = int T(t0, t) sigma_s p(d, w) I / r^2 T(x, light) dt
 * over the ray's chord, T through the medium only.  Against that integral
 * by Simpson's rule (10^4 intervals: exact to far below the noise).
 */
static void
test_single_scattering(void **state)
{
	struct box bx;
	struct pm_scene *s = &bx.scene;
	struct pm_medium med = mk_medium(pm_rgb(0.5f, 1.0f, 2.0f),
	    pm_rgb(0.8f, 0.6f, 0.9f), PM_PHASE_HG, 0.3f, true);
	const double o[3] = {0.3, 0.2, 5.0}, lp[3] = {0.4, 3.0, 0.5};
	const double I = 10.0;
	const int n = 200000, nint = 10000;
	struct pm_rng rng;
	double s1[3] = {0}, s2[3] = {0}, want[3] = {0}, t0, t1, b, c, h;
	int sh, l, i, k;

	(void)state;
	pm_scene_init(s);
	sh = pm_scene_add_shape(s);
	s->shapes[sh].type = PM_SHAPE_SPHERE;
	s->shapes[sh].center = pm_v3(0, 0, 0);
	s->shapes[sh].radius = 1.0f;
	s->shapes[sh].bsdf = add_bsdf(s, PM_BSDF_NULL, 0.0f);
	s->shapes[sh].interior = 1 + add_medium(s, med);
	l = pm_scene_add_light(s);
	s->lights[l].type = PM_LIGHT_POINT;
	s->lights[l].position = pm_v3((float)lp[0], (float)lp[1], (float)lp[2]);
	s->lights[l].intensity = pm_rgb1((float)I);
	box_finish(&bx, 2);

	/* the ray o + t (0, 0, -1) meets the sphere at 5 -+ sqrt(1 - 0.13) */
	b = 5.0;
	c = sqrt(1.0 - (o[0] * o[0] + o[1] * o[1]));
	t0 = b - c;
	t1 = b + c;
	h = (t1 - t0) / nint;
	for (i = 0; i <= nint; i++) {
		double t = t0 + i * h, x[3] = {o[0], o[1], o[2] - t}, w[3], r;
		double se, cosang, pg, g = med.phase.g, wt;

		w[0] = lp[0] - x[0];
		w[1] = lp[1] - x[1];
		w[2] = lp[2] - x[2];
		r = sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
		for (k = 0; k < 3; k++)
			w[k] /= r;
		se = exit_dist(x, w);
		/* the path travels along -z: cos between it and w */
		cosang = -w[2];
		pg = (1.0 - g * g) / (4.0 * 3.14159265358979323846 *
		    pow(1.0 + g * g - 2.0 * g * cosang, 1.5));
		wt = (i == 0 || i == nint) ? 1.0 : (i % 2 ? 4.0 : 2.0);
		for (k = 0; k < 3; k++) {
			double sig = chan(med.sigma_t, k);

			want[k] += wt * h / 3.0 * exp(-sig * (t - t0)) * sig *
			    chan(med.albedo, k) * pg * I / (r * r) *
			    exp(-sig * se);
		}
	}
	for (i = 0; i < n; i++) {
		struct pm_rgb L;

		rng = pm_rng_seed(9, (uint64_t)i, 0);
		L = pm_path_li(&bx.ctx, pm_v3((float)o[0], (float)o[1],
		    (float)o[2]), pm_v3(0, 0, -1), 0.0f, INFINITY, &rng);
		for (k = 0; k < 3; k++) {
			s1[k] += chan(L, k);
			s2[k] += chan(L, k) * chan(L, k);
		}
	}
	for (k = 0; k < 3; k++) {
		double m = s1[k] / n;

		assert_within(m, want[k], sqrt((s2[k] / n - m * m) / n), 4.0,
		    "single scattering");
	}
	box_free(&bx);
}

/* -------------------------------------------------------------- loading */

static enum pm_err
load(const char *xml, struct pm_scene *s, struct pm_error *err)
{
	enum pm_err e;

	memset(err, 0, sizeof(*err));
	e = pm_scene_load_string(xml, strlen(xml), "t.xml", ".", NULL, 0, s,
	    err);
	if (e != PM_OK)
		print_message("load: %s\n", err->msg);
	return e;
}

#define HEAD "<scene version=\"3.0.0\">"
#define BALL(inner) "<shape type=\"sphere\"><bsdf type=\"dielectric\"/>" \
	inner "</shape>"

static void
test_load_forms(void **state)
{
	struct pm_scene s;
	struct pm_error err;
	const struct pm_medium *m;

	(void)state;
	/* defaults; nested in a shape as its interior */
	assert_int_equal(load(HEAD BALL("<medium type=\"homogeneous\" "
	    "name=\"interior\"/>") "</scene>", &s, &err), PM_OK);
	assert_int_equal(s.nmedia, 1);
	assert_int_equal(s.shapes[0].interior, 1);	/* 1 + index */
	assert_int_equal(s.shapes[0].exterior, 0);
	assert_int_equal(s.camera_medium, 0);
	m = &s.media[0];
	assert_true(m->sigma_t.r == 1.0f && m->sigma_t.g == 1.0f &&
	    m->sigma_t.b == 1.0f);
	assert_true(m->albedo.r == 0.75f && m->albedo.b == 0.75f);
	assert_true(m->sample_emitters);
	assert_int_equal(m->phase.type, PM_PHASE_ISOTROPIC);
	pm_scene_free(&s);

	/* by id: one medium shared by a shape's exterior and the sensor,
	 * built once; scale multiplies sigma_t; hg nested, its g */
	assert_int_equal(load(HEAD
	    "<medium type=\"homogeneous\" id=\"fog\">"
	    "<rgb name=\"sigma_t\" value=\"1, 2, 3\"/>"
	    "<float name=\"albedo\" value=\"0.5\"/>"
	    "<float name=\"scale\" value=\"0.5\"/>"
	    "<boolean name=\"sample_emitters\" value=\"false\"/>"
	    "<phase type=\"hg\"><float name=\"g\" value=\"-0.25\"/></phase>"
	    "</medium>"
	    "<medium type=\"homogeneous\" id=\"unused\"/>"
	    "<sensor type=\"perspective\"><ref id=\"fog\"/></sensor>"
	    BALL("<ref name=\"exterior\" id=\"fog\"/>"
	    "<medium type=\"homogeneous\" name=\"interior\">"
	    "<phase type=\"hg\"/></medium>")
	    "</scene>", &s, &err), PM_OK);
	assert_int_equal(s.nmedia, 2);
	assert_int_equal(s.camera_medium, 1);
	assert_int_equal(s.shapes[0].exterior, 1);
	assert_int_equal(s.shapes[0].interior, 2);
	m = &s.media[0];
	assert_string_equal(m->name, "fog");
	assert_true(m->sigma_t.r == 0.5f && m->sigma_t.g == 1.0f &&
	    m->sigma_t.b == 1.5f);
	assert_true(m->albedo.g == 0.5f);
	assert_false(m->sample_emitters);
	assert_int_equal(m->phase.type, PM_PHASE_HG);
	assert_true(m->phase.g == -0.25f);
	/* hg's default g, as Mitsuba's */
	assert_int_equal(s.media[1].phase.type, PM_PHASE_HG);
	assert_true(s.media[1].phase.g == 0.8f);
	pm_scene_free(&s);

	/* nested in the sensor; volpath and volpathmis load */
	assert_int_equal(load(HEAD "<integrator type=\"volpathmis\"/>"
	    "<sensor type=\"perspective\"><medium type=\"homogeneous\">"
	    "<rgb name=\"albedo\" value=\"0.1, 0.2, 0.3\"/></medium></sensor>"
	    "</scene>", &s, &err), PM_OK);
	assert_int_equal(s.camera_medium, 1);
	assert_true(s.media[0].albedo.b == 0.3f);
	pm_scene_free(&s);
}

static void
load_fails(const char *xml, const char *what)
{
	struct pm_scene s;
	struct pm_error err;

	if (load(xml, &s, &err) == PM_OK) {
		pm_scene_free(&s);
		print_error("loaded, expected \"%s\"\n", what);
		fail();
	}
	if (strstr(err.msg, what) == NULL) {
		print_error("got \"%s\", expected \"%s\"\n", err.msg, what);
		fail();
	}
	assert_int_equal(s.nmedia, 0);
}

static void
test_load_errors(void **state)
{
	(void)state;
	load_fails(HEAD BALL("<medium type=\"homogeneous\"/>") "</scene>",
	    "named \"interior\" or \"exterior\"");
	load_fails(HEAD BALL("<medium type=\"homogeneous\" name=\"inside\"/>")
	    "</scene>", "(found \"inside\")");
	load_fails(HEAD BALL("<medium type=\"homogeneous\" name=\"interior\"/>"
	    "<medium type=\"homogeneous\" name=\"interior\"/>") "</scene>",
	    "more than one interior medium");
	load_fails(HEAD BALL("<medium type=\"nebula\" name=\"interior\"/>")
	    "</scene>", "unknown medium type \"nebula\"");
	load_fails(HEAD "<medium type=\"homogeneous\"><phase type=\"hg\">"
	    "<float name=\"g\" value=\"1\"/></phase></medium></scene>",
	    "strictly between -1 and 1");
	load_fails(HEAD "<medium type=\"homogeneous\"><phase type=\"rayleigh\"/>"
	    "</medium></scene>", "unknown phase type \"rayleigh\"");
	load_fails(HEAD "<medium type=\"homogeneous\"><phase type=\"isotropic\"/>"
	    "<phase type=\"isotropic\"/></medium></scene>",
	    "more than one <phase>");
	load_fails(HEAD "<medium type=\"homogeneous\"><float name=\"albedo\" "
	    "value=\"1.5\"/></medium></scene>", "albedo must not exceed 1");
	load_fails(HEAD "<medium type=\"homogeneous\"><float name=\"density\" "
	    "value=\"1\"/></medium></scene>", "unknown parameter \"density\"");
	load_fails(HEAD "<sensor type=\"perspective\"><medium "
	    "type=\"homogeneous\"/><medium type=\"homogeneous\"/></sensor>"
	    "</scene>", "more than one medium");
	load_fails(HEAD "<bsdf type=\"diffuse\" id=\"b\"/><sensor "
	    "type=\"perspective\"><ref id=\"b\"/></sensor></scene>",
	    "unexpected <bsdf>");
}

/* Photon mapping takes homogeneous media (the volume map) and
 * heterogeneous ones (delta tracking) alike. */
static void
test_photon_takes_media(void **state)
{
	struct pm_scene s;
	struct pm_error err;
	struct pm_world w;
	struct pm_shooter sh;

	(void)state;
	assert_int_equal(load(HEAD "<medium type=\"homogeneous\" id=\"haze\"/>"
	    BALL("<ref name=\"interior\" id=\"haze\"/>"
	    "<emitter type=\"area\"><rgb name=\"radiance\" value=\"1\"/>"
	    "</emitter>") "</scene>", &s, &err), PM_OK);
	assert_int_equal(pm_world_init(&w, &s, &err), PM_OK);
	assert_int_equal(pm_shooter_init(&sh, &s, w.accel, &w.lights, &err),
	    PM_OK);
	pm_shooter_free(&sh);
	pm_world_free(&w);
	pm_scene_free(&s);
}

int
main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_transmittance_closed_form),
		cmocka_unit_test(test_free_flight_unbiased),
		cmocka_unit_test(test_slab_shadow_ray),
		cmocka_unit_test(test_absorbing_sphere_render),
		cmocka_unit_test(test_phase_functions),
		cmocka_unit_test(test_hg_forward),
		cmocka_unit_test(test_furnace),
		cmocka_unit_test(test_single_scattering),
		cmocka_unit_test(test_load_forms),
		cmocka_unit_test(test_load_errors),
		cmocka_unit_test(test_photon_takes_media),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
