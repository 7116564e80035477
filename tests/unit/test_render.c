/*
 * test_render.c: the path tracer against analytic answers.
 *
 * Furnaces: inside a closed sphere that emits radiance Le inwards and
 * reflects diffusely with albedo rho, the radiance everywhere is
 * Le / (1 - rho); with max_depth d it is Le (1 + rho + ... + rho^(d-1)).
 * A convex diffuse object of albedo a inside a black emitting sphere
 * reflects a Le exactly, seen through any sensor: a thin lens or an
 * orthographic film filled by the object.  Also: the image is identical
 * with 1 and 2 threads (with a thin lens too, whose lens samples come from
 * each sample's own stream), and a watch sees only finished tiles, exactly
 * as they end up.  The same furnaces built of triangles (whose rays go to
 * Embree in packets) give the same answers, and the batched path tracer
 * gives pm_path_li's radiance bit for bit.
 */
#include <math.h>
#include <pthread.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "../../common/render.h"
#include "../../common/world.h"

struct furnace {
	struct pm_scene scene;
	struct pm_world world;
	struct pm_render_ctx ctx;
};

/* The furnaces' camera (inside the emitter, looking at the inner
 * object), scene preparation and render context. */
static void
furnace_finish(struct furnace *f, int max_depth)
{
	struct pm_scene *s = &f->scene;
	struct pm_error err;

	s->integrator.max_depth = max_depth;
	s->has_camera = true;
	s->camera.to_world = pm_mat4_lookat(pm_v3(0, 0, 5), pm_v3(0, 0, 0),
	    pm_v3(0, 1, 0));
	s->camera.fov = 20.0f;
	s->camera.fov_axis = PM_FOV_X;
	s->camera.near_clip = 0.01f;
	s->camera.far_clip = 1000.0f;
	s->camera.width = 32;
	s->camera.height = 32;
	s->camera.spp = 16;
	s->camera.rfilter = PM_RFILTER_BOX;
	assert_int_equal(pm_scene_prepare(s, &err), PM_OK);
	assert_int_equal(pm_world_init(&f->world, s, &err), PM_OK);
	f->ctx.scene = s;
	f->ctx.accel = f->world.accel;
	f->ctx.lights = &f->world.lights;
	f->ctx.max_depth = max_depth;
	f->ctx.rr_depth = 5;
	f->ctx.hide_emitters = false;
	f->ctx.maps = NULL;
}

/* A mesh shape of nverts vertices and ntris triangles, neither set yet,
 * that is no light. */
static int
add_mesh(struct pm_scene *s, uint32_t nverts, uint32_t ntris,
    struct pm_mesh **out)
{
	int sh = pm_scene_add_shape(s);
	struct pm_mesh *m;

	assert_true(sh >= 0);
	s->shapes[sh].type = PM_SHAPE_MESH;
	s->shapes[sh].light = -1;
	m = &s->shapes[sh].mesh;
	m->nverts = nverts;
	m->ntris = ntris;
	m->pos = malloc(sizeof(float) * 3 * nverts);
	m->idx = malloc(sizeof(uint32_t) * 3 * ntris);
	assert_non_null(m->pos);
	assert_non_null(m->idx);
	*out = m;
	return sh;
}

/* A cube of half size h about the origin as a 12-triangle mesh, facing
 * out (or in). */
static int
add_cube(struct pm_scene *s, float h, bool inward)
{
	static const int quad[6][4] = {
		{0, 4, 6, 2}, {1, 3, 7, 5}, {0, 1, 5, 4},
		{2, 6, 7, 3}, {0, 2, 3, 1}, {4, 5, 7, 6},
	};
	struct pm_mesh *m;
	int sh = add_mesh(s, 8, 12, &m), i;

	for (i = 0; i < 8; i++) {
		m->pos[3 * i] = (i & 1) ? h : -h;
		m->pos[3 * i + 1] = (i & 2) ? h : -h;
		m->pos[3 * i + 2] = (i & 4) ? h : -h;
	}
	for (i = 0; i < 6; i++) {
		const int *q = quad[i];
		uint32_t *t = &m->idx[6 * i];

		t[0] = (uint32_t)q[0];
		t[1] = (uint32_t)(inward ? q[2] : q[1]);
		t[2] = (uint32_t)(inward ? q[1] : q[2]);
		t[3] = (uint32_t)q[0];
		t[4] = (uint32_t)(inward ? q[3] : q[2]);
		t[5] = (uint32_t)(inward ? q[2] : q[3]);
	}
	return sh;
}

/* The furnace's emitter (half size 10, seen from inside) or its inner
 * object (half size 1): a sphere, or a cube of 12 triangles. */
static int
furnace_shape(struct pm_scene *s, float h, bool inward, bool mesh)
{
	int sh;

	if (mesh)
		return add_cube(s, h, inward);
	sh = pm_scene_add_shape(s);
	s->shapes[sh].type = PM_SHAPE_SPHERE;
	s->shapes[sh].center = pm_v3(0, 0, 0);
	s->shapes[sh].radius = h;
	s->shapes[sh].flip_normals = inward;
	s->shapes[sh].light = -1;
	return sh;
}

/* A diffuse emitter of albedo rho around the camera and, unless
 * inner_albedo < 0, a diffuse object in it: spheres, or (mesh) cubes;
 * with back, a cube whose faces look inwards, so that the camera and the
 * light see their backs, and diffuse twosided if back is 2. */
static void
furnace_make_back(struct furnace *f, float rho, float inner_albedo,
    int max_depth, bool mesh, int back)
{
	struct pm_scene *s = &f->scene;
	int b, sh, l;

	pm_scene_init(s);
	b = pm_scene_add_bsdf(s);
	s->bsdfs[b].type = PM_BSDF_DIFFUSE;
	s->bsdfs[b].diffuse = pm_rgb1(rho);
	sh = furnace_shape(s, 10.0f, true, mesh);
	s->shapes[sh].bsdf = b;
	l = pm_scene_add_light(s);
	s->lights[l].type = PM_LIGHT_AREA;
	s->lights[l].radiance = pm_rgb(1.0f, 2.0f, 0.5f);
	s->lights[l].shape = sh;
	s->shapes[sh].light = l;
	if (inner_albedo >= 0.0f) {
		b = pm_scene_add_bsdf(s);
		s->bsdfs[b].type = PM_BSDF_DIFFUSE;
		s->bsdfs[b].diffuse = pm_rgb1(inner_albedo);
		s->bsdfs[b].twosided = back == 2;
		sh = furnace_shape(s, 1.0f, back != 0, mesh || back != 0);
		s->shapes[sh].bsdf = b;
	}
	furnace_finish(f, max_depth);
}

static void
furnace_make(struct furnace *f, float rho, float inner_albedo, int max_depth,
    bool mesh)
{
	furnace_make_back(f, rho, inner_albedo, max_depth, mesh, 0);
}

/* A square of half size h at height y facing down, centred on (0, y, z),
 * two triangles: a rectangle light as Mitsuba's rectangle is made. */
static int
add_square(struct pm_scene *s, float y, float z, float h)
{
	static const float corner[4][2] = {
		{-1, -1}, {1, -1}, {1, 1}, {-1, 1},
	};
	static const uint32_t tri[6] = { 0, 1, 2, 0, 2, 3 };
	struct pm_mesh *m;
	int sh = add_mesh(s, 4, 2, &m), i;

	for (i = 0; i < 4; i++) {
		m->pos[3 * i] = h * corner[i][0];
		m->pos[3 * i + 1] = y;
		m->pos[3 * i + 2] = z + h * corner[i][1];
	}
	memcpy(m->idx, tri, sizeof(tri));
	return sh;
}

/* A diffuse cube of albedo 0.7 lit by a constant environment (sky) or
 * by a rectangle light above it and in front of the face the camera
 * sees (rect). */
static void
furnace_make_lit(struct furnace *f, bool rect, int max_depth)
{
	struct pm_scene *s = &f->scene;
	int b, sh, l;

	pm_scene_init(s);
	b = pm_scene_add_bsdf(s);
	s->bsdfs[b].type = PM_BSDF_DIFFUSE;
	s->bsdfs[b].diffuse = pm_rgb1(0.7f);
	sh = add_cube(s, 1.0f, false);
	s->shapes[sh].bsdf = b;
	l = pm_scene_add_light(s);
	if (rect) {
		s->lights[l].type = PM_LIGHT_AREA;
		s->lights[l].radiance = pm_rgb(4.0f, 8.0f, 2.0f);
		sh = add_square(s, 3.0f, 3.0f, 0.5f);
		s->shapes[sh].bsdf = b;
		s->shapes[sh].light = l;
		s->lights[l].shape = sh;
	} else {
		s->lights[l].type = PM_LIGHT_CONSTANT;
		s->lights[l].radiance = pm_rgb(1.0f, 2.0f, 0.5f);
		s->env_light = l;
	}
	furnace_finish(f, max_depth);
}

static void
furnace_build(struct furnace *f, float rho, float inner_albedo, int max_depth)
{
	furnace_make(f, rho, inner_albedo, max_depth, false);
}

static void
furnace_build_mesh(struct furnace *f, float rho, float inner_albedo,
    int max_depth)
{
	furnace_make(f, rho, inner_albedo, max_depth, true);
}

static void
furnace_free(struct furnace *f)
{
	pm_world_free(&f->world);
	pm_scene_free(&f->scene);
}

/* Renders and returns the per-channel mean over the central square of half
 * width `half` pixels. */
static void
render_mean(struct furnace *f, int threads, int half, double mean[3],
    struct pm_image *keep)
{
	struct pm_render_opts o;
	struct pm_render_stats st;
	struct pm_image im;
	struct pm_error err;
	const struct pm_camera *c = &f->scene.camera;
	int x, y, n = 0;

	memset(&o, 0, sizeof(o));
	o.method = PM_METHOD_PATH;
	o.spp = c->spp;
	o.seed = 3;
	o.threads = threads;
	assert_int_equal(pm_render(&f->ctx, c, &o, &im, &st, &err), PM_OK);
	assert_int_equal(st.dropped, 0);
	mean[0] = mean[1] = mean[2] = 0;
	for (y = c->height / 2 - half; y < c->height / 2 + half; y++)
		for (x = c->width / 2 - half; x < c->width / 2 + half; x++) {
			const float *p = &im.rgb[3 * (y * c->width + x)];

			mean[0] += p[0];
			mean[1] += p[1];
			mean[2] += p[2];
			n++;
		}
	mean[0] /= n;
	mean[1] /= n;
	mean[2] /= n;
	if (keep != NULL)
		*keep = im;
	else
		pm_image_free(&im);
}

static void
assert_close(const double got[3], struct pm_rgb want, double rel)
{
	print_message("got %.5f %.5f %.5f, want %.5f %.5f %.5f (rel %g)\n",
	    got[0], got[1], got[2], want.r, want.g, want.b, rel);
	assert_true(fabs(got[0] - want.r) <= rel * want.r);
	assert_true(fabs(got[1] - want.g) <= rel * want.g);
	assert_true(fabs(got[2] - want.b) <= rel * want.b);
}

/* A diffuse sphere under uniform light Le reflects albedo * Le. */
static void
test_convex_object_in_furnace(void **state)
{
	struct furnace f;
	double m[3];

	(void)state;
	furnace_build(&f, 0.0f, 0.6f, -1);
	f.scene.camera.spp = 256;
	/* The unit sphere at distance 5 fills the central 2 * 11 pixels. */
	render_mean(&f, 2, 8, m, NULL);
	assert_close(m, pm_rgb(0.6f, 1.2f, 0.3f), 0.01);
	furnace_free(&f);
}

/* Multiple bounces: Le / (1 - rho), through recursion and roulette. */
static void
test_closed_furnace_infinite_depth(void **state)
{
	struct furnace f;
	double m[3];

	(void)state;
	furnace_build(&f, 0.8f, -1.0f, -1);
	f.scene.camera.spp = 64;
	render_mean(&f, 2, 16, m, NULL);
	assert_close(m, pm_rgb(5.0f, 10.0f, 2.5f), 0.015);
	furnace_free(&f);
}

/* Mitsuba's max_depth: 1 shows emitters only, 3 adds two bounces. */
static void
test_max_depth_meaning(void **state)
{
	struct furnace f;
	double m[3];

	(void)state;
	furnace_build(&f, 0.8f, -1.0f, 1);
	render_mean(&f, 2, 16, m, NULL);
	assert_close(m, pm_rgb(1.0f, 2.0f, 0.5f), 1e-6);
	furnace_free(&f);

	furnace_build(&f, 0.8f, -1.0f, 3);
	f.scene.camera.spp = 32;
	render_mean(&f, 2, 16, m, NULL);
	/* 1 + 0.8 + 0.64 */
	assert_close(m, pm_rgb(2.44f, 4.88f, 1.22f), 0.01);
	furnace_free(&f);
}

/* The same furnaces of triangles: a cube of albedo a facing the camera
 * reflects a Le; the closed box gives Le / (1 - rho) at any depth. */
static void
test_mesh_furnaces(void **state)
{
	struct furnace f;
	double m[3];

	(void)state;
	furnace_build_mesh(&f, 0.0f, 0.6f, -1);
	f.scene.camera.spp = 64;
	/* The cube's front face at distance 4 fills the central 2 * 14
	 * pixels; a diffuse face reflects a Le exactly, sample by sample
	 * but for the light's sampling noise. */
	render_mean(&f, 2, 8, m, NULL);
	assert_close(m, pm_rgb(0.6f, 1.2f, 0.3f), 0.01);
	furnace_free(&f);

	furnace_build_mesh(&f, 0.8f, -1.0f, -1);
	f.scene.camera.spp = 64;
	render_mean(&f, 2, 16, m, NULL);
	assert_close(m, pm_rgb(5.0f, 10.0f, 2.5f), 0.015);
	furnace_free(&f);
}

/* pm_path_li_batch against pm_path_li on the same rays and random
 * numbers, with packets (triangles) and without (spheres), any depth,
 * emitters shown or hidden, batches of sizes from 1 to 300 (more than
 * one round of PATH_BATCH = 256 paths at the end); with the
 * inner cube seen from behind, one-sided and twosided, for the diffuse
 * SIMD lanes' flip (variants 6 to 9); and a cube under the sky, whose
 * shadow rays have no end, and under a rectangle light, which
 * pm_lights_sample_n samples in lanes (10 to 13). */
static void
test_path_batch_equals_single(void **state)
{
	int variant;

	(void)state;
	for (variant = 0; variant < 14; variant++) {
		struct furnace f;
		struct pm_path_sample smp[300];
		struct pm_rng r = pm_rng_seed(5, (uint64_t)variant, 0);
		int max_depth = variant % 3 == 0 ? -1 : variant % 3 == 1 ? 3 : 1;
		size_t n, i, lit = 0;

		if (variant >= 10) {
			furnace_make_lit(&f, variant >= 12, max_depth);
			assert_int_equal(f.world.lights.quad[0].on,
			    variant >= 12);
		} else if (variant >= 6)
			furnace_make_back(&f, 0.5f, 0.7f, max_depth, true,
			    1 + variant % 2);
		else if (variant < 3)
			furnace_build_mesh(&f, 0.5f, 0.7f, max_depth);
		else
			furnace_build(&f, 0.5f, 0.7f, max_depth);
		f.ctx.hide_emitters = variant % 2 == 1;
		for (n = 1; n <= 300; n += 23) {
			for (i = 0; i < n; i++) {
				struct pm_rng rc;

				smp[i].o = pm_v3(0, 0, 5);
				smp[i].d = pm_normalize(pm_v3(
				    0.4f * (pm_rng_float(&r) - 0.5f),
				    0.4f * (pm_rng_float(&r) - 0.5f), -1.0f));
				smp[i].tmin = 0.0f;
				smp[i].tmax = INFINITY;
				smp[i].rng = pm_rng_seed(9, (uint64_t)variant,
				    (uint64_t)(100 * n + i));
				rc = smp[i].rng;
				smp[i].L = pm_path_li(&f.ctx, smp[i].o, smp[i].d,
				    0.0f, INFINITY, &rc);
			}
			{
				struct pm_rgb want[300];

				for (i = 0; i < n; i++) {
					want[i] = smp[i].L;
					lit += want[i].g > 0.0f;
				}
				pm_path_li_batch(&f.ctx, smp, n);
				for (i = 0; i < n; i++)
					assert_memory_equal(&smp[i].L, &want[i],
					    sizeof(want[i]));
			}
		}
		/* light reached the camera on most paths: the paths
		 * compared carried something */
		/* light reached the camera, so the paths compared carried
		 * something: everywhere but where max_depth 1 shows only the
		 * cube, which fills the view, and the one-sided cube's backs */
		if (max_depth != 1 && variant != 6 && variant != 8)
			assert_true(lit > 0);
		furnace_free(&f);
	}
}

static void
test_threads_give_identical_images(void **state)
{
	struct furnace f;
	struct pm_image a, b;
	double m[3];

	(void)state;
	furnace_build(&f, 0.5f, 0.7f, -1);
	f.scene.camera.width = 40;	/* not a multiple of the tile size */
	f.scene.camera.height = 24;
	render_mean(&f, 1, 4, m, &a);
	render_mean(&f, 2, 4, m, &b);
	assert_memory_equal(a.rgb, b.rgb, sizeof(float) * 3 * 40 * 24);
	pm_image_free(&a);
	pm_image_free(&b);
	furnace_free(&f);
}

/* A thin lens focused before the object and an orthographic film inside
 * its outline both see a Le where the object fills the view. */
static void
test_other_sensors_in_furnace(void **state)
{
	struct furnace f;
	double m[3];

	(void)state;
	furnace_build(&f, 0.0f, 0.6f, -1);
	f.scene.camera.type = PM_SENSOR_THINLENS;
	f.scene.camera.aperture_radius = 0.3f;
	f.scene.camera.focus_distance = 2.0f;
	f.scene.camera.spp = 64;
	render_mean(&f, 2, 4, m, NULL);
	assert_close(m, pm_rgb(0.6f, 1.2f, 0.3f), 0.01);
	furnace_free(&f);

	furnace_build(&f, 0.0f, 0.6f, -1);
	f.scene.camera.type = PM_SENSOR_ORTHOGRAPHIC;
	/* the film spans [-0.6, 0.6]^2, inside the unit sphere's outline */
	f.scene.camera.to_world = pm_mat4_mul(f.scene.camera.to_world,
	    pm_mat4_scale(pm_v3(0.6f, 0.6f, 1.0f)));
	f.scene.camera.spp = 64;
	render_mean(&f, 2, 16, m, NULL);
	assert_close(m, pm_rgb(0.6f, 1.2f, 0.3f), 0.01);
	furnace_free(&f);
}

static void
test_thinlens_threads_give_identical_images(void **state)
{
	struct furnace f;
	struct pm_image a, b;
	double m[3];

	(void)state;
	furnace_build(&f, 0.5f, 0.7f, -1);
	f.scene.camera.type = PM_SENSOR_THINLENS;
	f.scene.camera.aperture_radius = 0.5f;
	f.scene.camera.focus_distance = 3.0f;
	f.scene.camera.width = 40;
	f.scene.camera.height = 24;
	render_mean(&f, 1, 4, m, &a);
	render_mean(&f, 2, 4, m, &b);
	assert_memory_equal(a.rgb, b.rgb, sizeof(float) * 3 * 40 * 24);
	pm_image_free(&a);
	pm_image_free(&b);
	furnace_free(&f);
}

#define MAX_SNAPS 64

/* Another thread's view of a render: snapshots taken while it runs. */
struct watcher {
	struct pm_render_watch *w;
	_Atomic int stop;
	struct pm_image snaps[MAX_SNAPS];
	int nsnaps;
};

static void *
watch_main(void *arg)
{
	struct watcher *wa = arg;

	while (!atomic_load(&wa->stop)) {
		struct pm_image *im = &wa->snaps[wa->nsnaps];

		if (wa->nsnaps < MAX_SNAPS && pm_render_snapshot(wa->w, im))
			wa->nsnaps++;
	}
	return NULL;
}

static void
test_watch_sees_finished_tiles_only(void **state)
{
	struct furnace f;
	struct watcher wa;
	struct pm_render_opts o;
	struct pm_render_stats st;
	struct pm_image im = {0, 0, NULL}, none = {0, 0, NULL};
	struct pm_error err;
	_Atomic long done, total;
	pthread_t tid;
	int i, tx, ty, x, y, w = 76, h = 44;
	const int T = PM_RENDER_TILE;

	(void)state;
	furnace_build(&f, 0.5f, 0.7f, -1);
	f.scene.camera.width = w;	/* the last column and row of tiles
					 * partial, at a side of 8 or 16 */
	f.scene.camera.height = h;
	memset(&wa, 0, sizeof(wa));
	wa.w = pm_render_watch_new();
	assert_non_null(wa.w);
	assert_false(pm_render_snapshot(wa.w, &none));	/* nothing running */
	atomic_init(&wa.stop, 0);
	atomic_init(&done, 0);
	atomic_init(&total, 0);
	memset(&o, 0, sizeof(o));
	o.method = PM_METHOD_PATH;
	o.spp = 64;
	o.seed = 3;
	o.threads = 2;
	o.tiles_done = &done;
	o.tiles_total = &total;
	o.watch = wa.w;
	assert_int_equal(pthread_create(&tid, NULL, watch_main, &wa), 0);
	assert_int_equal(pm_render(&f.ctx, &f.scene.camera, &o, &im, &st, &err),
	    PM_OK);
	atomic_store(&wa.stop, 1);
	pthread_join(tid, NULL);
	/* T: the tile's side */
	assert_int_equal(atomic_load(&total), ((w + T - 1) / T) *
	    ((h + T - 1) / T));
	assert_int_equal(atomic_load(&done), atomic_load(&total));
	assert_false(pm_render_snapshot(wa.w, &none));	/* over */
	/* Every tile of every snapshot is black or exactly as it ended. */
	for (i = 0; i < wa.nsnaps; i++) {
		const struct pm_image *s = &wa.snaps[i];

		assert_int_equal(s->width, w);
		assert_int_equal(s->height, h);
		for (ty = 0; ty < h; ty += T)
			for (tx = 0; tx < w; tx += T) {
				int black = 0, same = 0, n = 0;

				for (y = ty; y < ty + T && y < h; y++)
					for (x = tx; x < tx + T && x < w; x++) {
						const float *a = &s->rgb[3 * (y * w + x)];
						const float *b = &im.rgb[3 * (y * w + x)];

						n++;
						black += a[0] == 0 && a[1] == 0 &&
						    a[2] == 0;
						same += memcmp(a, b, 3 * sizeof(*a)) == 0;
					}
				assert_true(black == n || same == n);
			}
	}
	for (i = 0; i < MAX_SNAPS; i++)
		pm_image_free(&wa.snaps[i]);
	pm_image_free(&im);
	pm_render_watch_free(wa.w);
	furnace_free(&f);
}

int
main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_convex_object_in_furnace),
		cmocka_unit_test(test_closed_furnace_infinite_depth),
		cmocka_unit_test(test_max_depth_meaning),
		cmocka_unit_test(test_mesh_furnaces),
		cmocka_unit_test(test_path_batch_equals_single),
		cmocka_unit_test(test_threads_give_identical_images),
		cmocka_unit_test(test_other_sensors_in_furnace),
		cmocka_unit_test(test_thinlens_threads_give_identical_images),
		cmocka_unit_test(test_watch_sees_finished_tiles_only),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
