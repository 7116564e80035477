/*
 * test_camera.c: camera rays against the analytic projections of Mitsuba's
 * sensors.  Perspective: the ray through a film position reaches the point
 * of the image plane its pixel maps to.  Orthographic: parallel rays along
 * to_world's z from the film rectangle ([-1, 1] x [-h/w, h/w] scaled by
 * to_world) on the near plane.  Thinlens: rays start on the aperture disk
 * and every ray of a film position passes through the point of the focal
 * plane its pinhole ray reaches; the lens samples cover the disk uniformly
 * (chi-square over rings and sectors).
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "../../common/camera.h"
#include "../../common/rng.h"
#include "stats.h"

#define W 64
#define H 32

static struct pm_camera
camera(enum pm_sensor_type type, struct pm_mat4 to_world)
{
	struct pm_camera c;

	memset(&c, 0, sizeof(c));
	c.type = type;
	c.to_world = to_world;
	c.fov = 40.0f;
	c.fov_axis = PM_FOV_X;
	c.near_clip = 0.5f;
	c.far_clip = 10.0f;
	c.aperture_radius = 0.2f;
	c.focus_distance = 3.0f;
	c.width = W;
	c.height = H;
	return c;
}

static struct pm_mat4
look(void)
{
	return pm_mat4_lookat(pm_v3(1, 2, 5), pm_v3(0, 0.5f, 0),
	    pm_v3(0, 1, 0));
}

static void
near_v3(struct pm_vec3 a, struct pm_vec3 b, float tol)
{
	if (pm_length(pm_sub(a, b)) > tol) {
		print_message("got (%g %g %g), want (%g %g %g)\n", a.x, a.y, a.z,
		    b.x, b.y, b.z);
		fail();
	}
}

/* The camera-space point of film position (fx, fy) at depth z = 1. */
static struct pm_vec3
image_point(const struct pm_camera *c, float fx, float fy)
{
	float tx, ty;

	pm_camera_tangents(c->fov, c->fov_axis, c->width, c->height, &tx, &ty);
	return pm_v3(-(2.0f * fx / W - 1.0f) * tx, (1.0f - 2.0f * fy / H) * ty,
	    1.0f);
}

static void
test_perspective_projection(void **state)
{
	struct pm_camera c = camera(PM_SENSOR_PERSPECTIVE, look());
	struct pm_camera_rays r;
	struct pm_rng rng = pm_rng_seed(1, 2, 3);
	int i;

	(void)state;
	pm_camera_setup(&r, &c);
	for (i = 0; i < 1000; i++) {
		float fx = W * pm_rng_float(&rng), fy = H * pm_rng_float(&rng);
		struct pm_vec3 o, d, want;
		float tmin, tmax;

		d = pm_camera_ray(&r, fx, fy, pm_rng_float(&rng),
		    pm_rng_float(&rng), &o, &tmin, &tmax);
		want = pm_xform_point(&c.to_world, image_point(&c, fx, fy));
		near_v3(o, pm_xform_point(&c.to_world, pm_v3(0, 0, 0)), 1e-5f);
		/* depth 1 along the axis is reached at t = tmin / near */
		near_v3(pm_madd(o, d, tmin / c.near_clip), want, 1e-4f);
		assert_float_equal(tmax / tmin, c.far_clip / c.near_clip, 1e-3);
	}
}

static void
test_orthographic_projection(void **state)
{
	/* a film 4 x 3 units wide (2 x 1 and 3 x h/w), 4 deep per unit */
	struct pm_mat4 M = pm_mat4_mul(look(),
	    pm_mat4_scale(pm_v3(2.0f, 3.0f, 4.0f)));
	struct pm_camera c = camera(PM_SENSOR_ORTHOGRAPHIC, M);
	struct pm_camera_rays r;
	struct pm_rng rng = pm_rng_seed(4, 5, 6);
	struct pm_vec3 axis = pm_normalize(pm_xform_vector(&M, pm_v3(0, 0, 1)));
	int i;

	(void)state;
	pm_camera_setup(&r, &c);
	for (i = 0; i < 1000; i++) {
		float fx = W * pm_rng_float(&rng), fy = H * pm_rng_float(&rng);
		struct pm_vec3 o, d, local;
		float tmin, tmax;

		d = pm_camera_ray(&r, fx, fy, 0.5f, 0.5f, &o, &tmin, &tmax);
		/* Mitsuba's film: x from +1 (left) to -1, y from h/w (top)
		 * to -h/w, on the near plane */
		local = pm_v3(1.0f - 2.0f * fx / W,
		    (1.0f - 2.0f * fy / H) * (float)H / (float)W, c.near_clip);
		near_v3(o, pm_xform_point(&M, local), 1e-4f);
		near_v3(d, axis, 1e-6f);
		assert_float_equal(tmin, 0.0f, 0.0);
		assert_float_equal(tmax, c.far_clip - c.near_clip, 1e-5);
	}
	/* the corners of the film, in world units */
	{
		struct pm_vec3 o0, o1, d;
		float t0, t1;

		d = pm_camera_ray(&r, 0, 0, 0.5f, 0.5f, &o0, &t0, &t1);
		d = pm_camera_ray(&r, W, H, 0.5f, 0.5f, &o1, &t0, &t1);
		(void)d;
		assert_float_equal(pm_length(pm_sub(o0, o1)),
		    sqrtf(4.0f * 4.0f + 3.0f * 3.0f), 1e-4);
	}
}

static void
test_thinlens_focus(void **state)
{
	struct pm_camera c = camera(PM_SENSOR_THINLENS, look());
	struct pm_camera_rays r;
	struct pm_rng rng = pm_rng_seed(7, 8, 9);
	struct pm_vec3 eye = pm_xform_point(&c.to_world, pm_v3(0, 0, 0));
	struct pm_vec3 axis = pm_xform_vector(&c.to_world, pm_v3(0, 0, 1));
	int i, k;

	(void)state;
	pm_camera_setup(&r, &c);
	assert_true(pm_camera_needs_lens(&r));
	for (i = 0; i < 200; i++) {
		float fx = W * pm_rng_float(&rng), fy = H * pm_rng_float(&rng);
		struct pm_vec3 focus = pm_xform_point(&c.to_world,
		    pm_scale(image_point(&c, fx, fy), c.focus_distance));

		for (k = 0; k < 20; k++) {
			struct pm_vec3 o, d, rel;
			float tmin, tmax, t;

			d = pm_camera_ray(&r, fx, fy, pm_rng_float(&rng),
			    pm_rng_float(&rng), &o, &tmin, &tmax);
			rel = pm_sub(o, eye);
			/* on the aperture: in the lens plane, within radius */
			assert_true(fabsf(pm_dot(rel, axis)) < 1e-5f);
			assert_true(pm_length(rel) <= c.aperture_radius * 1.0001f);
			/* through the focal plane's point of the pixel */
			t = c.focus_distance / pm_dot(d, axis);
			near_v3(pm_madd(o, d, t), focus, 2e-5f * c.focus_distance);
			/* clip planes along the axis */
			assert_float_equal(pm_dot(pm_scale(d, tmin), axis),
			    c.near_clip, 1e-5);
			assert_float_equal(pm_dot(pm_scale(d, tmax), axis),
			    c.far_clip, 1e-3);
		}
	}
}

/* The aperture is covered uniformly: 4 rings of equal area x 8 sectors. */
static void
test_thinlens_aperture_uniform(void **state)
{
	struct pm_camera c = camera(PM_SENSOR_THINLENS, look());
	struct pm_camera_rays r;
	struct pm_rng rng = pm_rng_seed(10, 11, 12);
	struct pm_vec3 eye = pm_xform_point(&c.to_world, pm_v3(0, 0, 0));
	struct pm_vec3 ex = pm_xform_vector(&c.to_world, pm_v3(1, 0, 0));
	struct pm_vec3 ey = pm_xform_vector(&c.to_world, pm_v3(0, 1, 0));
	double obs[32] = {0}, expd[32];
	int i, n = 64000;

	(void)state;
	pm_camera_setup(&r, &c);
	for (i = 0; i < n; i++) {
		struct pm_vec3 o, rel;
		float tmin, tmax, x, y, rr, phi;
		int ring, sector;

		(void)pm_camera_ray(&r, W / 2.0f, H / 2.0f, pm_rng_float(&rng),
		    pm_rng_float(&rng), &o, &tmin, &tmax);
		rel = pm_sub(o, eye);
		x = pm_dot(rel, ex) / c.aperture_radius;
		y = pm_dot(rel, ey) / c.aperture_radius;
		rr = x * x + y * y;
		phi = atan2f(y, x) + (float)M_PI;
		ring = (int)(rr * 4.0f);
		sector = (int)(phi / (2.0f * (float)M_PI) * 8.0f);
		ring = ring > 3 ? 3 : ring;
		sector = sector > 7 ? 7 : sector;
		obs[ring * 8 + sector] += 1.0;
	}
	for (i = 0; i < 32; i++)
		expd[i] = n / 32.0;
	assert_true(stats_chi2(obs, expd, 32, STATS_POOL_JOIN, 1e-3,
	    "thinlens aperture") > 1e-3);
}

/* pm_camera_rays_n against pm_camera_ray one at a time, bit for bit, for
 * each sensor (the perspective one in SIMD lanes), at 1003 film positions
 * (not a multiple of 4) over the film and on its edges. */
static void
test_rays_n_equal_one_at_a_time(void **state)
{
	enum { N = 1003 };
	static const enum pm_sensor_type types[] = {
		PM_SENSOR_PERSPECTIVE, PM_SENSOR_ORTHOGRAPHIC,
		PM_SENSOR_THINLENS,
	};
	static float fx[N], fy[N], lu[N], lv[N], tmin[N], tmax[N];
	static struct pm_vec3 o[N], d[N];
	struct pm_rng rng = pm_rng_seed(4, 5, 6);
	size_t t, i;

	(void)state;
	for (i = 0; i < N; i++) {
		fx[i] = i % 7 == 0 ? 0.0f : i % 7 == 1 ? (float)W :
		    W * pm_rng_float(&rng);
		fy[i] = i % 5 == 0 ? (float)H : H * pm_rng_float(&rng);
		lu[i] = pm_rng_float(&rng);
		lv[i] = pm_rng_float(&rng);
	}
	for (t = 0; t < sizeof(types) / sizeof(types[0]); t++) {
		struct pm_camera c = camera(types[t], look());
		struct pm_camera_rays r;

		pm_camera_setup(&r, &c);
		pm_camera_rays_n(&r, fx, fy, lu, lv, N, o, d, tmin, tmax);
		for (i = 0; i < N; i++) {
			struct pm_vec3 wo, wd;
			float wmin, wmax;

			wd = pm_camera_ray(&r, fx[i], fy[i], lu[i], lv[i], &wo,
			    &wmin, &wmax);
			assert_memory_equal(&o[i], &wo, sizeof(wo));
			assert_memory_equal(&d[i], &wd, sizeof(wd));
			assert_memory_equal(&tmin[i], &wmin, sizeof(wmin));
			assert_memory_equal(&tmax[i], &wmax, sizeof(wmax));
		}
	}
}

static void
test_pinhole_needs_no_lens(void **state)
{
	struct pm_camera c = camera(PM_SENSOR_PERSPECTIVE, look());
	struct pm_camera_rays r;

	(void)state;
	pm_camera_setup(&r, &c);
	assert_false(pm_camera_needs_lens(&r));
	c.type = PM_SENSOR_ORTHOGRAPHIC;
	pm_camera_setup(&r, &c);
	assert_false(pm_camera_needs_lens(&r));
}

int
main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_perspective_projection),
		cmocka_unit_test(test_orthographic_projection),
		cmocka_unit_test(test_thinlens_focus),
		cmocka_unit_test(test_thinlens_aperture_uniform),
		cmocka_unit_test(test_pinhole_needs_no_lens),
		cmocka_unit_test(test_rays_n_equal_one_at_a_time),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
