/*
 * test_irradiance.c: precomputed irradiance records, their grid, and the
 * final-gathering render built on them (irradiance.h, icache.h).
 *
 *  - every record's irradiance equals a brute-force estimate: all photons
 *    sorted by distance, the k - 1 nearest inside the k-th's disc (or all
 *    within the fixed radius), the compatible ones' power over pi r^2; on
 *    a corner, where half the neighbours face the other way and must not
 *    count;
 *  - records are the same bytes for 1 and 3 threads;
 *  - the grid lookup returns a compatible record, the exact one at a
 *    record's own position, and nothing for a normal no record has;
 *  - a closed diffuse sphere that emits Le inside and reflects rho renders
 *    Le / (1 - rho) through photons, records, the irradiance cache and
 *    final gathering (a white furnace has one answer everywhere); there, a
 *    gather ray from a first hit found in a packet returns what it does
 *    tracing that hit itself, bit for bit;
 *  - the photon render's camera path from a first hit found in a packet
 *    returns what it does tracing that hit itself, bit for bit;
 *  - the irradiance cache's lookup, four points a vector, returns what
 *    Ward's interpolation one point at a time does, bit for bit, inside
 *    and outside the grid, for normals it trusts and refuses, and NaN.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "../../common/icache.h"
#include "../../common/irradiance.h"
#include "../../common/kdtree.h"
#include "../../common/render.h"
#include "../../common/rng.h"
#include "../../common/shoot.h"
#include "../../common/world.h"

/* n photons on the corner of the floor z = 0 and the wall x = 0 (unit
 * squares), normals up and along +x, powers random. */
static struct pm_photon *
corner_set(size_t n, uint64_t seed)
{
	struct pm_photon *p = calloc(n, sizeof(*p));
	struct pm_rng rng = pm_rng_seed(seed, 0, 0);
	size_t i;

	assert_non_null(p);
	for (i = 0; i < n; i++) {
		float a = pm_rng_float(&rng), b = pm_rng_float(&rng);
		bool wall = pm_rng_float(&rng) < 0.5f;

		p[i].pos[0] = wall ? 0.0f : a;
		p[i].pos[1] = b;
		p[i].pos[2] = wall ? a : 0.0f;
		pm_dir_pack(wall ? pm_v3(1, 0, 0) : pm_v3(0, 0, 1), p[i].normal);
		pm_dir_pack(pm_normalize(pm_v3(0.3f, 0.2f, 1)), p[i].dir);
		pm_rgbe_pack(pm_rgb(pm_rng_float(&rng), 0.5f,
		    2.0f * pm_rng_float(&rng)), 0.5f, p[i].power);
		p[i].flags = PM_KD_LEAF;
		p[i].depth = (uint8_t)(pm_rng_u32(&rng) % 4);
	}
	return p;
}

struct by_d2 {
	float d2;
	size_t i;
};

static int
cmp_d2(const void *a, const void *b)
{
	const struct by_d2 *x = a, *y = b;

	if (x->d2 != y->d2)
		return x->d2 < y->d2 ? -1 : 1;
	return x->i < y->i ? -1 : x->i > y->i;
}

/* The brute-force estimate irradiance.h promises. */
static struct pm_rgb
brute(const struct pm_photon *p, size_t n, float scale, struct pm_vec3 q,
    struct pm_vec3 nrm, const struct pm_irradiance_opts *o, struct by_d2 *tmp)
{
	double s[3] = {0, 0, 0}, r2;
	size_t i, m = 0, k = (size_t)o->k;

	for (i = 0; i < n; i++) {
		float dx = p[i].pos[0] - q.x, dy = p[i].pos[1] - q.y,
		    dz = p[i].pos[2] - q.z;
		float d2 = dx * dx + dy * dy + dz * dz;

		if (d2 <= o->max_r2) {
			tmp[m].d2 = d2;
			tmp[m].i = i;
			m++;
		}
	}
	qsort(tmp, m, sizeof(*tmp), cmp_d2);
	if (!o->fixed_radius && m > k)
		m = k;
	/* k found: the k-th sets the radius and is left out of the sum. */
	for (i = 0; i < (!o->fixed_radius && m == k ? k - 1 : m); i++) {
		const struct pm_photon *x = &p[tmp[i].i];
		struct pm_rgb c;

		if (pm_dot(pm_dir_unpack(x->normal), nrm) <= PM_IRR_COS ||
		    (o->max_depth >= 0 && x->depth > o->max_depth))
			continue;
		c = pm_rgbe_unpack(x->power);
		s[0] += c.r;
		s[1] += c.g;
		s[2] += c.b;
	}
	r2 = o->fixed_radius || m < k ? o->max_r2 : tmp[k - 1].d2;
	return pm_rgb((float)(s[0] * scale / (M_PI * r2)),
	    (float)(s[1] * scale / (M_PI * r2)), (float)(s[2] * scale / (M_PI * r2)));
}

static void
check_records(bool fixed)
{
	const size_t n = 6000;
	struct pm_photon *p = corner_set(n, 5), *r1, *r3;
	struct by_d2 *tmp = malloc(n * sizeof(*tmp));
	/* The fixed-radius check also leaves out photons of more than one
	 * bounce, as a scene's max_depth asks. */
	struct pm_irradiance_opts o = {.stride = 7, .k = 40, .max_r2 = 0.01f,
	    .fixed_radius = fixed, .max_depth = fixed ? 1 : -1, .threads = 1};
	struct pm_error err;
	size_t n1, n3, i, near_wall = 0;
	float scale = 1.0f / 1000.0f;

	assert_non_null(tmp);
	assert_int_equal(pm_kdtree_build(p, n, 2, &err), PM_OK);
	assert_int_equal(pm_irradiance_records(p, n, scale, &o, &r1, &n1, &err),
	    PM_OK);
	o.threads = 3;
	assert_int_equal(pm_irradiance_records(p, n, scale, &o, &r3, &n3, &err),
	    PM_OK);
	assert_int_equal(n1, n / 7);
	assert_int_equal(n3, n1);
	assert_memory_equal(r1, r3, n1 * sizeof(*r1));
	for (i = 0; i < n1; i++) {
		struct pm_vec3 q = pm_photon_pos(&r1[i]);
		struct pm_vec3 nrm = pm_dir_unpack(r1[i].normal);
		struct pm_rgb want = brute(p, n, scale, q, nrm, &o, tmp);
		struct pm_rgb got = pm_rgbe_unpack(r1[i].power);
		float m = pm_rgb_max(want);

		/* A record sits on one of the photons, keeps its normal and
		 * stores E in RGBE: within one step of the largest channel. */
		assert_memory_equal(r1[i].normal, p[i * 7 + 3].normal, 2);
		assert_true(fabsf(got.r - want.r) <= m / 100.0f);
		assert_true(fabsf(got.g - want.g) <= m / 100.0f);
		assert_true(fabsf(got.b - want.b) <= m / 100.0f);
		if (q.x < 0.05f && q.z < 0.05f)
			near_wall++;
	}
	assert_true(near_wall > 0);
	free(r1);
	free(r3);
	free(tmp);
	free(p);
}

static void
test_records_knn(void **state)
{
	(void)state;
	check_records(false);
}

static void
test_records_fixed_radius(void **state)
{
	(void)state;
	check_records(true);
}

/*
 * Records many chunks long, their k-nearest queries batched (a batch per
 * chunk at k = 32, 32 a batch at the largest k): the same bytes for 1, 2
 * and 5 threads, and each record the estimate pm_irradiance_estimate
 * makes for its photon alone, within RGBE's step.
 */
static void
test_records_batched(void **state)
{
	static const int ks[] = { 32, 300, PM_IRR_MAX_K };
	const size_t n = 24000, stride = 3;
	struct pm_photon *p = corner_set(n, 11), *r[3];
	struct pm_error err;
	size_t nr[3], i, c;
	int t;

	(void)state;
	assert_int_equal(pm_kdtree_build(p, n, 1, &err), PM_OK);
	for (c = 0; c < sizeof(ks) / sizeof(ks[0]); c++) {
		struct pm_irradiance_opts o = {.stride = stride,
		    .k = ks[c], .max_r2 = 0.02f, .max_depth = -1};

		for (t = 0; t < 3; t++) {
			o.threads = t == 0 ? 1 : 3 * t - 1;
			assert_int_equal(pm_irradiance_records(p, n, 1e-3f, &o,
			    &r[t], &nr[t], &err), PM_OK);
			assert_int_equal(nr[t], n / stride);
		}
		assert_memory_equal(r[0], r[1], nr[0] * sizeof(*r[0]));
		assert_memory_equal(r[0], r[2], nr[0] * sizeof(*r[0]));
		for (i = 0; i < nr[0]; i += ks[c] > 32 ? 17 : 1) {
			const struct pm_photon *x = &p[i * stride + stride / 2];
			struct pm_rgb want = pm_irradiance_estimate(p, n, 1e-3f,
			    pm_photon_pos(x), pm_dir_unpack(x->normal), &o);
			struct pm_rgb got = pm_rgbe_unpack(r[0][i].power);
			float m = pm_rgb_max(want);

			assert_true(fabsf(got.r - want.r) <= m / 100.0f);
			assert_true(fabsf(got.g - want.g) <= m / 100.0f);
			assert_true(fabsf(got.b - want.b) <= m / 100.0f);
		}
		for (t = 0; t < 3; t++)
			free(r[t]);
	}
	free(p);
}

static void
test_grid_lookup(void **state)
{
	const size_t n = 3000;
	struct pm_photon *p = corner_set(n, 9);
	struct pm_irr_grid g;
	struct pm_error err;
	struct pm_rng rng = pm_rng_seed(4, 4, 4);
	size_t i;
	int found = 0;

	(void)state;
	assert_int_equal(pm_kdtree_build(p, n, 1, &err), PM_OK);
	assert_int_equal(pm_irr_grid_build(&g, p, n, 1, &err), PM_OK);
	/* At a record's own position, that record. */
	for (i = 0; i < n; i += 37) {
		struct pm_rgb E, want = pm_rgbe_unpack(p[i].power);

		assert_true(pm_irradiance_lookup(&g, pm_photon_pos(&p[i]),
		    pm_dir_unpack(p[i].normal), &E));
		/* Coincident records are possible only by chance; then
		 * another's E is as good an answer. */
		if (E.r == want.r && E.g == want.g && E.b == want.b)
			found++;
	}
	assert_true(found >= (int)(n / 37) - 1);
	/* Anywhere near the corner, a record facing the right way. */
	for (i = 0; i < 2000; i++) {
		struct pm_vec3 q = pm_v3(pm_rng_float(&rng), pm_rng_float(&rng), 0);
		struct pm_rgb E = pm_rgb1(-1.0f);

		assert_true(pm_irradiance_lookup(&g, q, pm_v3(0, 0, 1), &E));
		assert_true(E.r >= 0.0f);
		/* Nothing faces down. */
		assert_false(pm_irradiance_lookup(&g, q, pm_v3(0, 0, -1), &E));
	}
	pm_irr_grid_free(&g);
	free(p);
}

/* A fresh scene: a sphere of radius 10 at the origin, seen from inside,
 * that reflects rho diffusely and emits Le inward. */
static void
emitting_sphere(struct pm_scene *s, float rho, struct pm_rgb Le)
{
	int b, shp, l;

	pm_scene_init(s);
	b = pm_scene_add_bsdf(s);
	s->bsdfs[b].type = PM_BSDF_DIFFUSE;
	s->bsdfs[b].diffuse = pm_rgb1(rho);
	shp = pm_scene_add_shape(s);
	s->shapes[shp].type = PM_SHAPE_SPHERE;
	s->shapes[shp].center = pm_v3(0, 0, 0);
	s->shapes[shp].radius = 10.0f;
	s->shapes[shp].flip_normals = true;
	s->shapes[shp].bsdf = b;
	l = pm_scene_add_light(s);
	s->lights[l].type = PM_LIGHT_AREA;
	s->lights[l].radiance = Le;
	s->lights[l].shape = shp;
	s->shapes[shp].light = l;
}

/* The photon render's context over a world inside a sphere of radius 10,
 * every path length allowed. */
static void
photon_ctx(struct pm_render_ctx *ctx, const struct pm_scene *s,
    const struct pm_world *w, const struct pm_photon_maps *maps)
{
	memset(ctx, 0, sizeof(*ctx));
	ctx->scene = s;
	ctx->accel = w->accel;
	ctx->lights = &w->lights;
	ctx->max_depth = -1;
	ctx->rr_depth = 5;
	ctx->maps = maps;
	ctx->scene_radius = 10.0f;
}

/* Inside a sphere of radius 10 that emits Le inward and reflects rho. */
/* The grid built on 1, 2, 3 and 7 threads: the same cells, the same
 * records in each, byte for byte (enough records that the build splits
 * into parts; some coincident, so that ties keep their order). */
static void
test_grid_threads(void **state)
{
	const size_t n = 150000;
	struct pm_photon *p = corner_set(n, 21);
	struct pm_irr_grid g1, gt;
	struct pm_error err;
	const int threads[] = {2, 3, 7};
	size_t i, ncell;
	int t;

	(void)state;
	for (i = 0; i < n; i += 97)
		memcpy(p[i].pos, p[i / 2].pos, sizeof(p[i].pos));
	assert_int_equal(pm_kdtree_build(p, n, 2, &err), PM_OK);
	assert_int_equal(pm_irr_grid_build(&g1, p, n, 1, &err), PM_OK);
	ncell = (size_t)g1.nx * (size_t)g1.ny * (size_t)g1.nz;
	assert_true(ncell > 1000);
	assert_int_equal(g1.start[0], 0);
	assert_int_equal(g1.start[ncell], n);
	for (i = 0; i < ncell; i++)
		assert_true(g1.start[i] <= g1.start[i + 1]);
	for (t = 0; t < 3; t++) {
		assert_int_equal(pm_irr_grid_build(&gt, p, n, threads[t], &err),
		    PM_OK);
		assert_int_equal(gt.nx, g1.nx);
		assert_int_equal(gt.ny, g1.ny);
		assert_int_equal(gt.nz, g1.nz);
		assert_memory_equal(gt.lo, g1.lo, sizeof(g1.lo));
		assert_memory_equal(gt.start, g1.start,
		    (ncell + 1) * sizeof(*g1.start));
		assert_memory_equal(gt.rec, g1.rec, n * sizeof(*g1.rec));
		pm_irr_grid_free(&gt);
	}
	pm_irr_grid_free(&g1);
	free(p);
}

/* The irradiance cache's gather rays cast in packets (icache.c):
 * pm_photon_gather_hit from the hits pm_accel_intersect_n gives returns
 * pm_photon_gather's radiance and distance and leaves the random state
 * where it does, bit for bit, for rays from the centre (hitting the
 * sphere) and from outside it pointing away (hitting nothing). */
static void
gather_first_hits(const struct pm_render_ctx *ctx, const struct pm_accel *a)
{
	enum { N = 48 };
	struct pm_ray ray[N];
	struct pm_hit hit[N];
	bool hitf[N];
	struct pm_rng r = pm_rng_seed(6, 0, 0);
	int i, nhit = 0, nmiss = 0, nlit = 0;

	for (i = 0; i < N; i++) {
		ray[i].o = i % 4 == 3 ? pm_v3(0, 0, 20) : pm_v3(0, 0, 0);
		ray[i].d = pm_normalize(pm_v3(pm_rng_float(&r) - 0.5f,
		    pm_rng_float(&r) - 0.5f, i % 4 == 3 ? 1.0f :
		    pm_rng_float(&r) - 0.5f));
		ray[i].tmin = 0.0f;
		ray[i].tmax = INFINITY;
	}
	pm_accel_intersect_n(a, ray, N, hit, hitf);
	for (i = 0; i < N; i++) {
		struct pm_rng r1 = pm_rng_seed(9, 2, (uint64_t)i), r2 = r1;
		struct pm_rgb want, got;
		float t1, t2;

		want = pm_photon_gather(ctx, ray[i].o, ray[i].d, &r1, &t1);
		got = pm_photon_gather_hit(ctx, ray[i].o, ray[i].d, &r2, &t2,
		    hitf[i], &hit[i]);
		assert_memory_equal(&got, &want, sizeof(want));
		assert_memory_equal(&t1, &t2, sizeof(t1));
		assert_memory_equal(&r1, &r2, sizeof(r1));
		nhit += hitf[i];
		nmiss += !hitf[i];
		nlit += want.g > 0.0f;
	}
	assert_true(nhit > 0 && nmiss > 0 && nlit > 0);
}

static void
test_furnace_final_gather(void **state)
{
	const float rho = 0.5f;
	const struct pm_rgb Le = pm_rgb(1.0f, 2.0f, 0.5f);
	struct pm_scene s;
	struct pm_world world;
	struct pm_shooter sh;
	struct pm_shoot_opts so;
	struct pm_shoot_stats st;
	struct pm_photon_buf buf = {NULL, 0, 0};
	struct pm_photon *rec;
	struct pm_irradiance_opts io = {.stride = 4, .k = 64, .max_r2 = 4.0f,
	    .fixed_radius = false, .max_depth = -1, .threads = 2};
	struct pm_irr_grid grid;
	struct pm_photon_maps maps;
	struct pm_render_ctx ctx;
	struct pm_render_opts ro;
	struct pm_render_stats rs;
	struct pm_image im;
	struct pm_error err;
	double mean[3] = {0, 0, 0};
	size_t nrec, i, npix;
	int c;

	(void)state;
	emitting_sphere(&s, rho, Le);
	s.integrator.max_depth = -1;
	s.has_camera = true;
	s.camera.to_world = pm_mat4_lookat(pm_v3(0, 0, 5), pm_v3(0, 0, 0),
	    pm_v3(0, 1, 0));
	s.camera.fov = 40.0f;
	s.camera.fov_axis = PM_FOV_X;
	s.camera.near_clip = 0.01f;
	s.camera.far_clip = 1000.0f;
	s.camera.width = 24;
	s.camera.height = 24;
	s.camera.spp = 4;
	s.camera.rfilter = PM_RFILTER_BOX;
	assert_int_equal(pm_scene_prepare(&s, &err), PM_OK);
	assert_int_equal(pm_world_init(&world, &s, &err), PM_OK);
	assert_int_equal(pm_shooter_init(&sh, &s, world.accel, &world.lights,
	    &err), PM_OK);
	memset(&so, 0, sizeof(so));
	so.pass = PM_PASS_GLOBAL;
	so.seed = 3;
	so.count = 100000;
	so.max_depth = -1;
	so.threads = 2;
	assert_int_equal(pm_shoot(&sh, &so, &buf, &st, &err), PM_OK);
	assert_int_equal(pm_kdtree_build(buf.p, buf.n, 2, &err), PM_OK);
	assert_int_equal(pm_irradiance_records(buf.p, buf.n, 1.0f / 100000.0f,
	    &io, &rec, &nrec, &err), PM_OK);
	assert_int_equal(pm_kdtree_build(rec, nrec, 2, &err), PM_OK);
	assert_int_equal(pm_irr_grid_build(&grid, rec, nrec, 2, &err), PM_OK);

	memset(&maps, 0, sizeof(maps));
	maps.global = buf.p;
	maps.nglobal = buf.n;
	maps.global_scale = 1.0f / 100000.0f;
	maps.global_r2 = 4.0f;
	maps.caustic_r2 = 0.25f;
	maps.lookup_size = 64;
	maps.direct_samples = 1;
	maps.final_gather = true;
	maps.final_gather_samples = 4;
	maps.irradiance = rec;
	maps.nirradiance = nrec;
	maps.irradiance_grid = &grid;
	maps.icache_step = 4;
	maps.icache_rays = 64;
	maps.icache_a = 0.3f;
	photon_ctx(&ctx, &s, &world, &maps);
	memset(&ro, 0, sizeof(ro));
	ro.method = PM_METHOD_PHOTON;
	ro.spp = s.camera.spp;
	ro.seed = 1;
	ro.threads = 2;
	assert_int_equal(pm_render(&ctx, &s.camera, &ro, &im, &rs, &err), PM_OK);
	assert_int_equal(rs.dropped, 0);
	npix = (size_t)im.width * (size_t)im.height;
	for (i = 0; i < npix; i++)
		for (c = 0; c < 3; c++)
			mean[c] += im.rgb[3 * i + c] / (double)npix;
	print_message("furnace through final gathering: %.4f %.4f %.4f, want "
	    "%.4f %.4f %.4f\n", mean[0], mean[1], mean[2], Le.r / (1 - rho),
	    Le.g / (1 - rho), Le.b / (1 - rho));
	assert_true(fabs(mean[0] / (Le.r / (1 - rho)) - 1.0) < 0.02);
	assert_true(fabs(mean[1] / (Le.g / (1 - rho)) - 1.0) < 0.02);
	assert_true(fabs(mean[2] / (Le.b / (1 - rho)) - 1.0) < 0.02);
	pm_image_free(&im);
	gather_first_hits(&ctx, world.accel);

	/* Without records, gather rays end in the whole global map, every
	 * photon of every depth when the depth is unlimited (pm-render's
	 * gather_max_depth -1): the same answer. */
	maps.irradiance_grid = NULL;
	maps.gather_max_depth = -1;
	assert_int_equal(pm_render(&ctx, &s.camera, &ro, &im, &rs, &err), PM_OK);
	mean[0] = mean[1] = mean[2] = 0.0;
	for (i = 0; i < npix; i++)
		for (c = 0; c < 3; c++)
			mean[c] += im.rgb[3 * i + c] / (double)npix;
	print_message("the same from the global map: %.4f %.4f %.4f\n", mean[0],
	    mean[1], mean[2]);
	assert_true(fabs(mean[0] / (Le.r / (1 - rho)) - 1.0) < 0.02);
	assert_true(fabs(mean[1] / (Le.g / (1 - rho)) - 1.0) < 0.02);
	assert_true(fabs(mean[2] / (Le.b / (1 - rho)) - 1.0) < 0.02);

	pm_image_free(&im);
	pm_irr_grid_free(&grid);
	free(rec);
	pm_photon_buf_free(&buf);
	pm_shooter_free(&sh);
	pm_world_free(&world);
	pm_scene_free(&s);
}

/* The camera pass's stratified light points (pm_camera_sample.lu): a
 * diffuse sphere of albedo a inside a black sphere that emits Le inward
 * reflects a Le exactly (direct light only).  16 samples of one camera
 * ray, their light points in a 4 x 4 grid of cells or independent: both
 * means are a Le and the stratified one varies less. */
static void
test_stratified_light_points(void **state)
{
	enum { R = 400, N = 16 };
	const float a = 0.5f, Le = 2.0f;
	struct pm_scene s;
	struct pm_world world;
	struct pm_photon_maps maps;
	struct pm_render_ctx ctx;
	struct pm_error err;
	struct pm_vec3 o = pm_v3(0, 0, 5), d;
	double m[2] = {0, 0}, m2[2] = {0, 0}, var[2];
	int b, shp, r, j, mode;

	(void)state;
	emitting_sphere(&s, 0.0f, pm_rgb1(Le));
	b = pm_scene_add_bsdf(&s);
	s.bsdfs[b].type = PM_BSDF_DIFFUSE;
	s.bsdfs[b].diffuse = pm_rgb1(a);
	shp = pm_scene_add_shape(&s);
	s.shapes[shp].type = PM_SHAPE_SPHERE;
	s.shapes[shp].center = pm_v3(0, 0, 0);
	s.shapes[shp].radius = 1.0f;
	s.shapes[shp].bsdf = b;
	s.shapes[shp].light = -1;
	s.integrator.max_depth = -1;
	assert_int_equal(pm_scene_prepare(&s, &err), PM_OK);
	assert_int_equal(pm_world_init(&world, &s, &err), PM_OK);
	/* empty maps: no caustics, no indirect light (the black sphere
	 * reflects none), so the estimate is direct light alone */
	memset(&maps, 0, sizeof(maps));
	maps.global_r2 = 1.0f;
	maps.caustic_r2 = 1.0f;
	maps.lookup_size = 16;
	maps.direct_samples = 1;
	photon_ctx(&ctx, &s, &world, &maps);
	ctx.hide_emitters = true;
	d = pm_normalize(pm_v3(0.1f, 0.12f, -1.0f));
	for (mode = 0; mode < 2; mode++)
		for (r = 0; r < R; r++) {
			double sum = 0;

			for (j = 0; j < N; j++) {
				struct pm_rng rng = pm_rng_seed(9, (uint64_t)r,
				    (uint64_t)j);
				struct pm_camera_sample cs = { 0, 0,
				    { -1.0f, -1.0f } };

				if (mode == 1) {
					cs.lu[0] = ((float)(j % 4) +
					    pm_rng_float(&rng)) / 4.0f;
					cs.lu[1] = ((float)(j / 4) +
					    pm_rng_float(&rng)) / 4.0f;
				}
				sum += pm_photon_li_px(&ctx, o, d, 0.0f,
				    INFINITY, &cs, &rng).g;
			}
			m[mode] += sum / N / R;
			m2[mode] += (sum / N) * (sum / N) / R;
		}
	var[0] = m2[0] - m[0] * m[0];
	var[1] = m2[1] - m[1] * m[1];
	print_message("16 light samples: mean %.4f / %.4f (want %.4f), "
	    "variance %.3g independent, %.3g stratified\n", m[0], m[1],
	    (double)(a * Le), var[0], var[1]);
	/* means within four standard errors */
	assert_true(fabs(m[0] - a * Le) < 4.0 * sqrt(var[0] / R));
	assert_true(fabs(m[1] - a * Le) < 4.0 * sqrt(var[1] / R));
	assert_true(var[1] < 0.5 * var[0]);
	pm_world_free(&world);
	pm_scene_free(&s);
}

/* The photon render's camera rays cast in packets (render_tile_photon):
 * pm_photon_li_px_hit from the hits pm_accel_intersect_n gives returns
 * pm_photon_li_px's radiance bit for bit, for rays that hit the inner
 * sphere, the outer one, or nothing (tmax short of both). */
static void
test_photon_first_hits(void **state)
{
	enum { N = 40 };
	struct pm_scene s;
	struct pm_world world;
	struct pm_photon_maps maps;
	struct pm_render_ctx ctx;
	struct pm_error err;
	struct pm_ray ray[N];
	struct pm_hit hit[N];
	bool hitf[N];
	struct pm_rng r = pm_rng_seed(4, 0, 0);
	int b, shp, i, nmiss = 0, nhit = 0;

	(void)state;
	emitting_sphere(&s, 0.3f, pm_rgb1(2.0f));
	b = pm_scene_add_bsdf(&s);
	s.bsdfs[b].type = PM_BSDF_DIFFUSE;
	s.bsdfs[b].diffuse = pm_rgb1(0.5f);
	shp = pm_scene_add_shape(&s);
	s.shapes[shp].type = PM_SHAPE_SPHERE;
	s.shapes[shp].center = pm_v3(0, 0, 0);
	s.shapes[shp].radius = 1.0f;
	s.shapes[shp].bsdf = b;
	s.shapes[shp].light = -1;
	s.integrator.max_depth = -1;
	assert_int_equal(pm_scene_prepare(&s, &err), PM_OK);
	assert_int_equal(pm_world_init(&world, &s, &err), PM_OK);
	memset(&maps, 0, sizeof(maps));
	maps.global_r2 = 1.0f;
	maps.caustic_r2 = 1.0f;
	maps.lookup_size = 16;
	maps.direct_samples = 2;
	photon_ctx(&ctx, &s, &world, &maps);
	for (i = 0; i < N; i++) {
		ray[i].o = pm_v3(0, 0, 5);
		ray[i].d = pm_normalize(pm_v3(0.8f * (pm_rng_float(&r) - 0.5f),
		    0.8f * (pm_rng_float(&r) - 0.5f), -1.0f));
		ray[i].tmin = 0.0f;
		ray[i].tmax = i % 5 == 4 ? 2.0f : INFINITY;
	}
	pm_accel_intersect_n(world.accel, ray, N, hit, hitf);
	for (i = 0; i < N; i++) {
		struct pm_camera_sample cs = { 3.5f, 7.5f, { -1.0f, -1.0f } };
		struct pm_rng r1 = pm_rng_seed(8, 1, (uint64_t)i), r2 = r1;
		struct pm_rgb want, got;

		want = pm_photon_li_px(&ctx, ray[i].o, ray[i].d, ray[i].tmin,
		    ray[i].tmax, &cs, &r1);
		got = pm_photon_li_px_hit(&ctx, ray[i].o, ray[i].d,
		    ray[i].tmin, ray[i].tmax, &cs, &r2, hitf[i], &hit[i]);
		assert_memory_equal(&got, &want, sizeof(want));
		assert_memory_equal(&r1, &r2, sizeof(r1));
		nhit += hitf[i];
		nmiss += !hitf[i];
	}
	assert_true(nhit > 0 && nmiss > 0);
	pm_world_free(&world);
	pm_scene_free(&s);
}

/* The cache's default spacing: the finest of 4, 2, 1 whose gather rays
 * per pixel stay within the samples per pixel (pm-render(1)). */
static void
test_icache_default_step(void **state)
{
	int spp;

	(void)state;
	for (spp = 1; spp <= 4096; spp++) {
		int rays = pm_icache_default_rays(spp);
		int step = pm_icache_default_step(spp, rays);

		assert_true(rays >= PM_ICACHE_RAYS_MIN && rays <= PM_ICACHE_RAYS);
		assert_true(step == 1 || step == 2 || step == PM_ICACHE_STEP);
		int budget = spp < 4 ? 4 : spp;

		if (step < PM_ICACHE_STEP)
			assert_true(rays <= budget * step * step);
		if (step > 1)
			assert_true(rays > budget * (step / 2) * (step / 2));
	}
	/* the documented ranges: every 2nd pixel below 256 spp, then every
	 * pixel */
	assert_int_equal(pm_icache_default_rays(1), 16);
	assert_int_equal(pm_icache_default_rays(16), 64);
	assert_int_equal(pm_icache_default_rays(64), 256);
	assert_int_equal(pm_icache_default_step(1, pm_icache_default_rays(1)), 2);
	assert_int_equal(pm_icache_default_step(255, pm_icache_default_rays(255)), 2);
	assert_int_equal(pm_icache_default_step(256, pm_icache_default_rays(256)), 1);
}

/* Ward's interpolation as icache.h defines it, one grid point at a time
 * (the lookup as it was before its SIMD lanes): the reference. */
static bool
icache_reference(const struct pm_icache *c, float fx, float fy,
    struct pm_vec3 p, struct pm_vec3 n, struct pm_rgb *E)
{
	int gx0, gy0, gx, gy;
	double sum[3] = {0, 0, 0}, wsum = 0.0;
	float inv_a = 1.0f / c->a, min_cos = 1.0f - c->a * c->a;

	if (!isfinite(fx) || !isfinite(fy))
		return false;
	gx0 = (int)floorf(fx / (float)c->step) - 1;
	gy0 = (int)floorf(fy / (float)c->step) - 1;
	for (gy = gy0; gy < gy0 + 4; gy++)
		for (gx = gx0; gx < gx0 + 4; gx++) {
			const struct pm_icache_point *q;
			struct pm_vec3 dv;
			float cosn, eps, w;

			if (gy < 0 || gy >= c->gh || gx < 0 || gx >= c->gw)
				continue;
			q = &c->pt[(size_t)gy * c->gw + gx];
			if (!q->valid)
				continue;
			cosn = pm_dot(n, q->n);
			if (cosn <= min_cos || cosn <= 0.0f)
				continue;
			dv = pm_sub(p, q->p);
			if (pm_dot(dv, pm_add(n, q->n)) * 0.5f * q->inv_r < -0.05f)
				continue;
			eps = pm_length(dv) * q->inv_r + sqrtf(pm_fmaxf(0.0f,
			    1.0f - cosn));
			if (!(eps < c->a))
				continue;
			w = eps > 1e-6f ? 1.0f / eps - inv_a : 1e6f;
			sum[0] += (double)w * q->E.r;
			sum[1] += (double)w * q->E.g;
			sum[2] += (double)w * q->E.b;
			wsum += w;
		}
	if (!(wsum > 0.0))
		return false;
	*E = pm_rgb((float)(sum[0] / wsum), (float)(sum[1] / wsum),
	    (float)(sum[2] / wsum));
	return true;
}

/* A bumpy grid of points (some invalid, some tilted, one each way of the
 * validity distance), queried at random film positions from outside the
 * grid on one side to outside it on the other, with normals near and far
 * from the points' and now and then NaN: the lookup equals the reference
 * in its answer and, where it has one, in every bit. */
static void
test_icache_lookup_lanes(void **state)
{
	struct pm_icache c;
	struct pm_rng rng = pm_rng_seed(11, 0, 0);
	const float h = 0.1f;	/* world units between grid points */
	int gx, gy, i, found = 0, refused = 0;

	(void)state;
	memset(&c, 0, sizeof(c));
	c.step = 2;
	c.gw = 9;
	c.gh = 7;
	c.a = 0.6f;
	c.pt = calloc((size_t)c.gw * (size_t)c.gh, sizeof(*c.pt));
	assert_non_null(c.pt);
	for (gy = 0; gy < c.gh; gy++)
		for (gx = 0; gx < c.gw; gx++) {
			struct pm_icache_point *q = &c.pt[gy * c.gw + gx];

			q->valid = pm_rng_float(&rng) < 0.85f;
			q->p = pm_v3(gx * h + 0.02f * pm_rng_float(&rng),
			    gy * h + 0.02f * pm_rng_float(&rng),
			    0.03f * pm_rng_float(&rng));
			q->n = pm_normalize(pm_v3(pm_rng_float(&rng) - 0.5f,
			    pm_rng_float(&rng) - 0.5f, 1.0f));
			q->E = pm_rgb(pm_rng_float(&rng), pm_rng_float(&rng),
			    pm_rng_float(&rng));
			q->inv_r = 2.0f + 18.0f * pm_rng_float(&rng);
		}
	assert_true(pm_icache_pack(&c));
	for (i = 0; i < 200000; i++) {
		float fx = -6.0f + (2 * c.gw + 8) * pm_rng_float(&rng);
		float fy = -6.0f + (2 * c.gh + 8) * pm_rng_float(&rng);
		struct pm_vec3 p = pm_v3(fx / c.step * h +
		    0.05f * (pm_rng_float(&rng) - 0.5f), fy / c.step * h +
		    0.05f * (pm_rng_float(&rng) - 0.5f),
		    0.1f * (pm_rng_float(&rng) - 0.5f));
		struct pm_vec3 n = pm_normalize(pm_v3(pm_rng_float(&rng) - 0.5f,
		    pm_rng_float(&rng) - 0.5f, 1.0f));
		struct pm_rgb e1, e2;
		bool a, b;

		if (i % 1000 == 0)
			n.y = NAN;
		else if (i % 7 == 0)
			n = pm_neg(n);
		a = pm_icache_lookup(&c, fx, fy, p, n, &e1);
		b = icache_reference(&c, fx, fy, p, n, &e2);
		assert_int_equal(a, b);
		if (a)
			assert_memory_equal(&e1, &e2, sizeof(e1));
		found += a;
		refused += !a;
	}
	assert_true(found > 10000 && refused > 10000);
	pm_icache_free(&c);
	assert_null(c.pt);
	assert_null(c.lanes);
}

int
main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_records_knn),
		cmocka_unit_test(test_records_fixed_radius),
		cmocka_unit_test(test_records_batched),
		cmocka_unit_test(test_grid_lookup),
		cmocka_unit_test(test_grid_threads),
		cmocka_unit_test(test_furnace_final_gather),
		cmocka_unit_test(test_stratified_light_points),
		cmocka_unit_test(test_photon_first_hits),
		cmocka_unit_test(test_icache_default_step),
		cmocka_unit_test(test_icache_lookup_lanes),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
