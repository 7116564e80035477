/*
 * test_shoot.c: photon tracing conserves energy and is reproducible.
 *
 * In a closed diffuse sphere of albedo rho lit by a small emitting sphere of
 * power P at its centre, every photon's first hit is the enclosure, so the
 * flux stored at depth 0 sums to P, and every bounce reflects rho of it, so
 * the flux stored at depth 1 sums to rho P (within noise).  Caustic photons
 * aimed at a glass sphere carry the same total flux onto the floor as the
 * caustic paths found by the unaimed global pass.  Shards concatenate into
 * one run bit for bit, whatever the thread count.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "../../common/accel.h"
#include "../../common/bsdf.h"
#include "../../common/frame.h"
#include "../../common/photon.h"
#include "../../common/rng.h"
#include "../../common/shoot.h"
#include "../../common/world.h"

struct world {
	struct pm_scene scene;
	struct pm_world world;
	struct pm_shooter shooter;
};

static int
add_diffuse(struct pm_scene *s, float albedo)
{
	int b = pm_scene_add_bsdf(s);

	s->bsdfs[b].type = PM_BSDF_DIFFUSE;
	s->bsdfs[b].diffuse = pm_rgb1(albedo);
	return b;
}

static int
add_sphere(struct pm_scene *s, struct pm_vec3 c, float r, int bsdf, bool flip)
{
	int sh = pm_scene_add_shape(s);

	s->shapes[sh].type = PM_SHAPE_SPHERE;
	s->shapes[sh].center = c;
	s->shapes[sh].radius = r;
	s->shapes[sh].bsdf = bsdf;
	s->shapes[sh].flip_normals = flip;
	return sh;
}

static void
world_finish(struct world *w)
{
	struct pm_error err;

	assert_int_equal(pm_scene_prepare(&w->scene, &err), PM_OK);
	assert_int_equal(pm_world_init(&w->world, &w->scene, &err), PM_OK);
	assert_int_equal(pm_shooter_init(&w->shooter, &w->scene, w->world.accel,
	    &w->world.lights, &err), PM_OK);
}

static void
world_free(struct world *w)
{
	pm_shooter_free(&w->shooter);
	pm_world_free(&w->world);
	pm_scene_free(&w->scene);
}

/* Closed enclosure of albedo rho around an emitting sphere. */
static void
furnace(struct world *w, float rho)
{
	struct pm_scene *s = &w->scene;
	int sh, l;

	pm_scene_init(s);
	add_sphere(s, pm_v3(0, 0, 0), 10.0f, add_diffuse(s, rho), true);
	sh = add_sphere(s, pm_v3(0, 0, 0), 1.0f, add_diffuse(s, 0.0f), false);
	l = pm_scene_add_light(s);
	s->lights[l].type = PM_LIGHT_AREA;
	s->lights[l].radiance = pm_rgb(1.0f, 0.5f, 2.0f);
	s->lights[l].shape = sh;
	s->shapes[sh].light = l;
	world_finish(w);
}

static void
shoot(struct world *w, enum pm_map_pass pass, uint64_t first, uint64_t count,
    int threads, struct pm_photon_buf *out)
{
	struct pm_shoot_opts o = {pass, 42, first, count, -1, threads, NULL,
	    NULL, NULL, NULL};
	struct pm_shoot_stats st;
	struct pm_error err;

	assert_int_equal(pm_shoot(&w->shooter, &o, out, &st, &err), PM_OK);
	assert_int_equal(st.dropped, 0);
}

static void
test_flux_by_depth(void **state)
{
	struct world w;
	struct pm_photon_buf b = {NULL, 0, 0};
	const uint64_t n = 200000;
	double sum[2][3] = {{0}}, sq1 = 0, power[3];
	float rho = 0.6f;
	size_t i;
	int c;

	(void)state;
	furnace(&w, rho);
	shoot(&w, PM_PASS_GLOBAL, 0, n, 2, &b);
	for (i = 0; i < b.n; i++) {
		struct pm_rgb f = pm_rgbe_unpack(b.p[i].power);

		if (b.p[i].depth > 1)
			continue;
		sum[b.p[i].depth][0] += f.r;
		sum[b.p[i].depth][1] += f.g;
		sum[b.p[i].depth][2] += f.b;
		if (b.p[i].depth == 1)
			sq1 += (double)f.g * f.g;
	}
	/* P = pi * area * Le for a Lambertian emitter. */
	power[0] = M_PI * 4 * M_PI * 1.0;
	power[1] = M_PI * 4 * M_PI * 0.5;
	power[2] = M_PI * 4 * M_PI * 2.0;
	for (c = 0; c < 3; c++) {
		double d0 = sum[0][c] / n, d1 = sum[1][c] / n;

		print_message("channel %d: depth 0 %.5f (want %.5f), depth 1 %.5f "
		    "(want %.5f)\n", c, d0, power[c], d1, rho * power[c]);
		/* Every photon leaves with the same flux and hits the
		 * enclosure: depth 0 is exact up to RGBE rounding. */
		assert_true(fabs(d0 - power[c]) < 0.001 * power[c]);
		/* Depth 1 is a binomial survival: allow 5 standard errors. */
		{
			double se = sqrt(sq1 / n) / sqrt((double)n) * power[c] / power[1];

			assert_true(fabs(d1 - rho * power[c]) < 5 * se + 0.004 * power[c]);
		}
	}
	pm_photon_buf_free(&b);
	world_free(&w);
}

/*
 * trace_path's definition in the global pass (no media), one path at a
 * time from the general functions: emission by pm_shooter_emit, every
 * bounce by pm_bsdf_sample.  pm_shoot emits eight paths together and
 * warps their first bounces' diffuse directions ahead in SIMD lanes
 * (emit_batch), which must give these photons bit for bit.  Returns the
 * photons of path i written to out[0..].
 */
static size_t
reference_path(const struct world *w, uint64_t seed, uint64_t i,
    int max_depth, struct pm_photon *out, size_t cap)
{
	const struct pm_scene *s = &w->scene;
	struct pm_rng rng = pm_rng_seed(seed, i, PM_PASS_GLOBAL);
	struct pm_vec3 o, d;
	struct pm_rgb flux;
	bool specular_only = true, via_diffuse = false;
	size_t k = 0;
	int depth;

	if (!pm_shooter_emit(&w->shooter, &rng, &o, &d, &flux))
		return 0;
	for (depth = 0;; depth++) {
		struct pm_hit h;
		struct pm_bsdf bt;
		struct pm_frame fr;
		struct pm_bsdf_sample bs;
		const struct pm_bsdf *b;
		float u1, u2, u3, q;

		if (!pm_accel_intersect(w->world.accel, o, d, 0.0f, INFINITY, &h))
			break;
		b = pm_bsdf_frame_at(s, &h, d, &bt, &fr);
		if (b->lobes & (PM_LOBE_DIFFUSE | PM_LOBE_GLOSSY)) {
			struct pm_photon *ph = &out[k++];

			assert_true(k <= cap);
			memset(ph, 0, sizeof(*ph));
			ph->pos[0] = h.p.x;
			ph->pos[1] = h.p.y;
			ph->pos[2] = h.p.z;
			pm_rgbe_pack(flux, pm_rng_float(&rng), ph->power);
			pm_dir_pack(pm_neg(d), ph->dir);
			pm_dir_pack(pm_dot(h.ng, d) < 0.0f ? h.ns : pm_neg(h.ns),
			    ph->normal);
			ph->flags = PM_KD_LEAF |
			    (via_diffuse ? PM_PHOTON_VIA_DIFFUSE : 0) |
			    (specular_only && depth > 0 ? PM_PHOTON_CAUSTIC : 0);
			ph->depth = (uint8_t)depth;
		}
		if (depth >= max_depth)
			break;
		u1 = pm_rng_float(&rng);
		u2 = pm_rng_float(&rng);
		u3 = pm_rng_float(&rng);
		if (!pm_bsdf_sample(b, pm_to_local(fr, pm_neg(d)), u1, u2, u3,
		    PM_IMPORTANCE, &bs))
			break;
		q = pm_fminf(pm_rgb_max(bs.weight), 1.0f);
		if (!(q > 0.0f) || pm_rng_float(&rng) >= q)
			break;
		flux = pm_rgb_scale(pm_rgb_mul(flux, bs.weight), 1.0f / q);
		if (!(bs.lobe & PM_LOBE_DELTA)) {
			specular_only = false;
			via_diffuse = true;
		}
		d = pm_normalize(pm_to_world(fr, bs.wo));
		o = pm_hit_origin(&h, d);
	}
	return k;
}

/* Every photon pm_shoot stores is reference_path's, in order: in the
 * furnace with a diffuse, then a plastic enclosure, then a twosided one
 * seen from its back (twosided's flip) with the nonlinear base and a
 * coloured coating (pm_shoot takes plastic's bounces in SIMD lanes too),
 * with a mirror sphere beside the light, where a path's numbers shift and
 * the guess made ahead must be refused. */
static void
test_paths_are_the_definition(void **state)
{
	const uint64_t seed = 42, first = 3, n = 4001;
	const int max_depth = 12;
	int variant;

	(void)state;
	for (variant = 0; variant < 3; variant++) {
		struct world w;
		struct pm_scene *s = &w.scene;
		struct pm_photon_buf b = {NULL, 0, 0};
		struct pm_shoot_opts o = {PM_PASS_GLOBAL, seed, first, n,
		    max_depth, 2, NULL, NULL, NULL, NULL};
		struct pm_shoot_stats st;
		struct pm_error err;
		struct pm_photon ref[64];
		size_t k = 0, bounced = 0, j, m;
		uint64_t i;
		int wall, mirror, sh, l;

		pm_scene_init(s);
		wall = add_diffuse(s, 0.8f);
		if (variant >= 1) {
			s->bsdfs[wall].type = PM_BSDF_PLASTIC;
			s->bsdfs[wall].diffuse = pm_rgb(0.7f, 0.5f, 0.3f);
			s->bsdfs[wall].specular = pm_rgb1(1.0f);
			s->bsdfs[wall].ior = 1.5f;
		}
		if (variant == 2) {
			s->bsdfs[wall].twosided = true;
			s->bsdfs[wall].nonlinear = true;
			s->bsdfs[wall].diffuse = pm_rgb(0.9f, 0.8f, 0.7f);
			s->bsdfs[wall].specular = pm_rgb(0.9f, 0.6f, 1.2f);
			s->bsdfs[wall].ior = 1.33f;
		}
		mirror = add_diffuse(s, 0.0f);
		s->bsdfs[mirror].type = PM_BSDF_CONDUCTOR;
		s->bsdfs[mirror].specular = pm_rgb1(0.9f);
		s->bsdfs[mirror].eta = pm_rgb1(0.0f);
		s->bsdfs[mirror].k = pm_rgb1(1.0f);
		add_sphere(s, pm_v3(0, 0, 0), 10.0f, wall, variant != 2);
		add_sphere(s, pm_v3(4, 0, 0), 2.5f, mirror, false);
		sh = add_sphere(s, pm_v3(0, 0, 0), 1.0f, add_diffuse(s, 0.0f),
		    false);
		l = pm_scene_add_light(s);
		s->lights[l].type = PM_LIGHT_AREA;
		s->lights[l].radiance = pm_rgb(1.0f, 0.5f, 2.0f);
		s->lights[l].shape = sh;
		s->shapes[sh].light = l;
		world_finish(&w);
		assert_int_equal(pm_shoot(&w.shooter, &o, &b, &st, &err), PM_OK);
		for (i = first; i < first + n; i++) {
			m = reference_path(&w, seed, i, max_depth, ref, 64);
			bounced += m > 1;
			for (j = 0; j < m; j++, k++) {
				assert_true(k < b.n);
				assert_memory_equal(&b.p[k], &ref[j], sizeof(ref[j]));
			}
		}
		assert_int_equal(k, b.n);
		/* most paths bounce, many more than the lanes' two times */
		print_message("variant %d: %zu photons, %zu paths that bounced\n",
		    variant, k, bounced);
		assert_true(bounced > n / 2);
		assert_true(k > 3 * n);
		pm_photon_buf_free(&b);
		world_free(&w);
	}
}

static void
test_shards_equal_one_run(void **state)
{
	struct world w;
	struct pm_photon_buf one = {NULL, 0, 0}, shards = {NULL, 0, 0};
	struct pm_photon_buf t1 = {NULL, 0, 0};

	(void)state;
	furnace(&w, 0.5f);
	shoot(&w, PM_PASS_GLOBAL, 0, 30000, 2, &one);
	shoot(&w, PM_PASS_GLOBAL, 0, 12345, 2, &shards);
	shoot(&w, PM_PASS_GLOBAL, 12345, 30000 - 12345, 1, &shards);
	shoot(&w, PM_PASS_GLOBAL, 0, 30000, 1, &t1);
	assert_int_equal(one.n, shards.n);
	assert_memory_equal(one.p, shards.p, one.n * sizeof(*one.p));
	assert_int_equal(one.n, t1.n);
	assert_memory_equal(one.p, t1.p, one.n * sizeof(*one.p));
	pm_photon_buf_free(&one);
	pm_photon_buf_free(&shards);
	pm_photon_buf_free(&t1);
	world_free(&w);
}

/* A sink that gathers what it is given into a buffer, and fails once it
 * has been given `fail_after` photons or more. */
struct gather {
	struct pm_photon_buf b;
	size_t calls, fail_after;
};

/* Notes the number of photons, which gather_sink checks. */
static void
gather_prepare(void *arg, const struct pm_photon *p, size_t n,
    unsigned char note[PM_SHOOT_NOTE])
{
	(void)arg;
	(void)p;
	memcpy(note, &n, sizeof(n));
}

static enum pm_err
gather_sink(void *arg, const struct pm_photon *p, size_t n,
    const unsigned char note[PM_SHOOT_NOTE], struct pm_error *err)
{
	struct gather *g = arg;
	size_t noted;

	memcpy(&noted, note, sizeof(noted));
	assert_true(noted == n);
	g->calls++;
	if (g->b.n >= g->fail_after)
		return pm_fail(err, PM_ERR_IO, "sink full at %zu", g->b.n);
	g->b.p = realloc(g->b.p, (g->b.n + n + 1) * sizeof(*p));
	assert_non_null(g->b.p);
	memcpy(g->b.p + g->b.n, p, n * sizeof(*p));
	g->b.n += n;
	return PM_OK;
}

/* With a sink, the photons go there in path order, whatever the number
 * of threads, and not to the output; the sink's error is pm_shoot's and
 * stops it. */
static void
test_sink(void **state)
{
	struct world w;
	struct pm_photon_buf one = {NULL, 0, 0}, none = {NULL, 0, 0};
	struct pm_shoot_opts o = {PM_PASS_GLOBAL, 42, 0, 30000, -1, 1, NULL,
	    gather_prepare, gather_sink, NULL};
	struct pm_shoot_stats st;
	struct pm_error err;
	int t;

	(void)state;
	furnace(&w, 0.5f);
	shoot(&w, PM_PASS_GLOBAL, 0, 30000, 2, &one);
	for (t = 1; t <= 3; t++) {
		struct gather g = {{NULL, 0, 0}, 0, (size_t)-1};

		o.threads = t;
		o.sink_arg = &g;
		assert_int_equal(pm_shoot(&w.shooter, &o, &none, &st, &err),
		    PM_OK);
		assert_int_equal(none.n, 0);
		assert_true(st.stored == one.n);
		assert_int_equal(g.b.n, one.n);
		assert_memory_equal(g.b.p, one.p, one.n * sizeof(*one.p));
		assert_true(g.calls > 1);
		pm_photon_buf_free(&g.b);
	}
	for (t = 1; t <= 3; t++) {
		struct gather g = {{NULL, 0, 0}, 0, 1000};

		o.threads = t;
		o.sink_arg = &g;
		assert_int_equal(pm_shoot(&w.shooter, &o, &none, &st, &err),
		    PM_ERR_IO);
		assert_non_null(strstr(err.msg, "sink full at"));
		/* called no more once it failed */
		assert_true(g.calls * 2048 < 30000);
		pm_photon_buf_free(&g.b);
	}
	pm_photon_buf_free(&one);
	world_free(&w);
}

/*
 * Aiming is unbiased: a small light above a glass sphere over a diffuse
 * floor; the flux of caustic photons from the aimed pass equals the flux of
 * the caustic-flagged photons of the plain global pass.
 */
/* A glass sphere (clear, or rough: roughdielectric counts as glass for
 * photons) over a floor under a small light: the caustic photons the
 * global pass leaves on the floor carry the flux the aimed caustic pass
 * finds there, and none is stored on the glass. */
/*
 * The caustic flux reaching the floor (y <= 0.01) per path, from the global
 * pass g (its photons flagged caustic) and the aimed caustic pass c, which
 * stores only caustic photons: both find some and agree within 4 standard
 * errors.
 */
static void
assert_floor_caustics_agree(const struct pm_photon_buf *g, uint64_t ng,
    const struct pm_photon_buf *c, uint64_t nc, const char *what)
{
	double fg = 0, fc = 0, sqg = 0, sqc = 0, se;
	size_t i;

	for (i = 0; i < g->n; i++) {
		float f;

		if (!(g->p[i].flags & PM_PHOTON_CAUSTIC) || g->p[i].pos[1] > 0.01f)
			continue;
		f = pm_rgbe_unpack(g->p[i].power).g;
		fg += f;
		sqg += (double)f * f;
	}
	for (i = 0; i < c->n; i++) {
		float f = pm_rgbe_unpack(c->p[i].power).g;

		assert_true(c->p[i].flags & PM_PHOTON_CAUSTIC);
		if (c->p[i].pos[1] > 0.01f)
			continue;
		fc += f;
		sqc += (double)f * f;
	}
	se = sqrt(sqg / ng / ng + sqc / nc / nc);
	print_message("%s: caustic flux on the floor: global pass %.4f, aimed "
	    "pass %.4f, standard error %.4f; aimed photons %zu of %llu paths, "
	    "global caustic photons %zu\n", what, fg / ng, fc / nc, se, c->n,
	    (unsigned long long)nc, g->n);
	assert_true(fc > 0 && fg > 0);
	assert_true(fabs(fg / ng - fc / nc) < 4 * se);
}

static void
caustic_aiming(enum pm_bsdf_type type, float alpha, bool beckmann)
{
	struct world w;
	struct pm_scene *s = &w.scene;
	struct pm_photon_buf g = {NULL, 0, 0}, c = {NULL, 0, 0};
	struct pm_error err;
	const uint64_t ng = 400000, nc = 100000;
	int b, sh, l;
	size_t i;

	pm_scene_init(s);
	/* The floor: a large flat-shaded disk, facing up. */
	sh = pm_scene_add_shape(s);
	s->shapes[sh].type = PM_SHAPE_MESH;
	assert_int_equal(pm_mesh_disk(&s->shapes[sh].mesh, 64, &err), PM_OK);
	{
		struct pm_mat4 m = pm_mat4_mul(pm_mat4_rotate(pm_v3(1, 0, 0), -90.0f),
		    pm_mat4_scale(pm_v3(20, 20, 20)));

		pm_mesh_transform(&s->shapes[sh].mesh, &m);
	}
	s->shapes[sh].bsdf = add_diffuse(s, 0.8f);
	b = pm_scene_add_bsdf(s);
	s->bsdfs[b].type = type;
	s->bsdfs[b].alpha = alpha;
	s->bsdfs[b].beckmann = beckmann;
	s->bsdfs[b].sample_visible = true;
	s->bsdfs[b].ior = 1.5f;
	s->bsdfs[b].specular = pm_rgb1(1.0f);
	s->bsdfs[b].transmittance = pm_rgb1(1.0f);
	add_sphere(s, pm_v3(0, 1.5f, 0), 1.0f, b, false);
	sh = add_sphere(s, pm_v3(0.3f, 4.0f, 0.2f), 0.1f, add_diffuse(s, 0.0f), false);
	l = pm_scene_add_light(s);
	s->lights[l].type = PM_LIGHT_AREA;
	s->lights[l].radiance = pm_rgb1(100.0f);
	s->lights[l].shape = sh;
	s->shapes[sh].light = l;
	world_finish(&w);
	assert_int_equal(w.shooter.naim, 1);

	shoot(&w, PM_PASS_GLOBAL, 0, ng, 2, &g);
	shoot(&w, PM_PASS_CAUSTIC, 0, nc, 2, &c);
	/* nothing stored on the glass */
	for (i = 0; i < g.n; i++) {
		float dx = g.p[i].pos[0], dy = g.p[i].pos[1] - 1.5f;
		float dz = g.p[i].pos[2];

		assert_true(fabsf(sqrtf(dx * dx + dy * dy + dz * dz) - 1.0f) >
		    1e-3f);
	}
	assert_floor_caustics_agree(&g, ng, &c, nc, "area light");
	pm_photon_buf_free(&g);
	pm_photon_buf_free(&c);
	world_free(&w);
}

/*
 * The same for lights from far away, whose aimed photons start in the
 * shadow disks of the specular spheres: a directional light, slanted,
 * and a constant environment, over a glass sphere and, to make the disks
 * overlap, a smaller mirror sphere beside it.
 */
static void
far_aiming(enum pm_light_type type)
{
	struct world w;
	struct pm_scene *s = &w.scene;
	struct pm_photon_buf g = {NULL, 0, 0}, c = {NULL, 0, 0};
	struct pm_error err;
	const uint64_t ng = 1000000, nc = 100000;
	int b, m, sh, l;

	pm_scene_init(s);
	sh = pm_scene_add_shape(s);
	s->shapes[sh].type = PM_SHAPE_MESH;
	assert_int_equal(pm_mesh_disk(&s->shapes[sh].mesh, 64, &err), PM_OK);
	{
		struct pm_mat4 mt = pm_mat4_mul(pm_mat4_rotate(pm_v3(1, 0, 0),
		    -90.0f), pm_mat4_scale(pm_v3(5, 5, 5)));

		pm_mesh_transform(&s->shapes[sh].mesh, &mt);
	}
	s->shapes[sh].bsdf = add_diffuse(s, 0.8f);
	b = pm_scene_add_bsdf(s);
	s->bsdfs[b].type = PM_BSDF_DIELECTRIC;
	s->bsdfs[b].ior = 1.5f;
	s->bsdfs[b].specular = pm_rgb1(1.0f);
	s->bsdfs[b].transmittance = pm_rgb1(1.0f);
	add_sphere(s, pm_v3(0, 1.5f, 0), 1.0f, b, false);
	m = pm_scene_add_bsdf(s);
	s->bsdfs[m].type = PM_BSDF_CONDUCTOR;
	s->bsdfs[m].eta = pm_rgb1(0.0f);
	s->bsdfs[m].k = pm_rgb1(1.0f);
	s->bsdfs[m].specular = pm_rgb1(1.0f);
	add_sphere(s, pm_v3(1.2f, 1.0f, 0.3f), 0.5f, m, false);
	l = pm_scene_add_light(s);
	s->lights[l].type = type;
	if (type == PM_LIGHT_DIRECTIONAL) {
		s->lights[l].intensity = pm_rgb1(3.0f);
		s->lights[l].direction = pm_normalize(pm_v3(-0.3f, -1, 0.2f));
	} else {
		s->lights[l].radiance = pm_rgb1(1.0f);
		s->env_light = l;
	}
	world_finish(&w);
	assert_int_equal(w.shooter.naim, 2);

	shoot(&w, PM_PASS_GLOBAL, 0, ng, 2, &g);
	shoot(&w, PM_PASS_CAUSTIC, 0, nc, 2, &c);
	assert_floor_caustics_agree(&g, ng, &c, nc, type == PM_LIGHT_DIRECTIONAL ?
	    "directional" : "constant");
	pm_photon_buf_free(&g);
	pm_photon_buf_free(&c);
	world_free(&w);
}

static void
test_far_light_aiming_is_unbiased(void **state)
{
	(void)state;
	far_aiming(PM_LIGHT_DIRECTIONAL);
	far_aiming(PM_LIGHT_CONSTANT);
}

static void
test_caustic_aiming_is_unbiased(void **state)
{
	(void)state;
	caustic_aiming(PM_BSDF_DIELECTRIC, 0.0f, false);
	caustic_aiming(PM_BSDF_ROUGHDIELECTRIC, 0.3f, true);
	caustic_aiming(PM_BSDF_ROUGHDIELECTRIC, 0.1f, false);
}

static void
test_effects(void **state)
{
	struct world w;
	struct pm_effects e;

	(void)state;
	furnace(&w, 0.5f);
	pm_shoot_effects(&w.scene, &e);
	assert_true(e.global);
	assert_false(e.caustic);
	assert_false(e.refraction);
	w.scene.integrator.max_depth = 2;
	pm_shoot_effects(&w.scene, &e);
	assert_false(e.global);
	world_free(&w);
}

static void
test_scene_hash(void **state)
{
	struct world a, b;
	uint64_t ha, hb;

	(void)state;
	furnace(&a, 0.5f);
	furnace(&b, 0.5f);
	ha = pm_scene_hash(&a.scene);
	hb = pm_scene_hash(&b.scene);
	assert_true(ha == hb);
	b.scene.bsdfs[0].diffuse.g = 0.51f;
	assert_true(ha != pm_scene_hash(&b.scene));
	b.scene.bsdfs[0].diffuse.g = 0.5f;
	b.scene.camera.fov = 10.0f;	/* the camera is not part of it */
	assert_true(ha == pm_scene_hash(&b.scene));
	world_free(&a);
	world_free(&b);
}

/* The default photon count follows the scene's own film and sampler. */
static void
test_default_paths(void **state)
{
	struct pm_scene s;

	(void)state;
	pm_scene_init(&s);
	assert_int_equal(pm_shoot_default_paths(&s), PM_PATHS_NO_CAMERA);
	s.has_camera = true;
	s.camera.width = s.camera.height = 128;
	s.camera.spp = 16;		/* 262144 samples */
	assert_int_equal(pm_shoot_default_paths(&s), 26214);
	s.camera.spp = 2;		/* below the floor */
	assert_int_equal(pm_shoot_default_paths(&s), PM_PATHS_MIN);
	s.camera.width = s.camera.height = 512;
	s.camera.spp = 64;		/* above the ceiling */
	assert_int_equal(pm_shoot_default_paths(&s), PM_PATHS_MAX);
	s.camera.width = 640;
	s.camera.height = 480;
	s.camera.spp = 1;
	assert_int_equal(pm_shoot_default_paths(&s), 30720);
	pm_scene_free(&s);
}

/* A photon's bounces for a scene's max_depth: two segments fewer (the
 * camera's ray and the gather from the photon's surface), none where
 * max_depth leaves no room, unlimited where it is. */
static void
test_default_max_depth(void **state)
{
	struct pm_scene s;

	(void)state;
	pm_scene_init(&s);
	s.integrator.max_depth = -1;
	assert_int_equal(pm_shoot_default_max_depth(&s), -1);
	s.integrator.max_depth = 1;
	assert_int_equal(pm_shoot_default_max_depth(&s), 0);
	s.integrator.max_depth = 2;
	assert_int_equal(pm_shoot_default_max_depth(&s), 0);
	s.integrator.max_depth = 3;
	assert_int_equal(pm_shoot_default_max_depth(&s), 1);
	s.integrator.max_depth = 65;
	assert_int_equal(pm_shoot_default_max_depth(&s), 63);
	pm_scene_free(&s);
}

int
main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_flux_by_depth),
		cmocka_unit_test(test_paths_are_the_definition),
		cmocka_unit_test(test_shards_equal_one_run),
		cmocka_unit_test(test_sink),
		cmocka_unit_test(test_caustic_aiming_is_unbiased),
		cmocka_unit_test(test_far_light_aiming_is_unbiased),
		cmocka_unit_test(test_effects),
		cmocka_unit_test(test_scene_hash),
		cmocka_unit_test(test_default_paths),
		cmocka_unit_test(test_default_max_depth),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
