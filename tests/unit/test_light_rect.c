/*
 * test_light_rect.c: an area light that is one parallelogram (Mitsuba's
 * rectangle) is sampled as a parallelogram (light.h, struct
 * pm_light_quad): recognised where it is one and only there, its points
 * uniform over it (chi-square over a grid in its own coordinates), and
 * the irradiance its samples estimate equal to the rectangle's closed
 * form, with the density a ray that finds the point agrees on; photons
 * leave it (common/shoot.c) with its whole power and on its lit side.
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

#include "../../common/light.h"
#include "../../common/photon.h"
#include "../../common/rng.h"
#include "../../common/sampling.h"
#include "../../common/shoot.h"
#include "../../common/world.h"
#include "../../formats/scene_xml.h"

static void
load(const char *body, struct pm_scene *s, struct pm_world *w)
{
	char xml[4096];
	struct pm_error err;

	snprintf(xml, sizeof(xml), "<scene version=\"3.0.0\">\n%s</scene>\n",
	    body);
	memset(&err, 0, sizeof(err));
	if (pm_scene_load_string(xml, strlen(xml), "t.xml", ".", NULL, 0, s,
	    &err) != PM_OK)
		fail_msg("%s", err.msg);
	if (pm_world_init(w, s, &err) != PM_OK)
		fail_msg("%s", err.msg);
}

/* A 2 x 1.2 rectangle (scaled, turned, moved) emitting 1: its lights
 * are one quad; what other meshes are is checked below. */
#define RECT "<shape type=\"rectangle\"><transform name=\"to_world\">" \
	"<scale x=\"1\" y=\"0.6\"/><rotate x=\"1\" angle=\"160\"/>" \
	"<rotate z=\"1\" angle=\"25\"/><translate z=\"1\"/></transform>" \
	"<emitter type=\"area\"><rgb name=\"radiance\" value=\"1\"/>" \
	"</emitter></shape>\n"

static void
test_recognised(void **state)
{
	struct pm_scene s;
	struct pm_world w;

	(void)state;
	load(RECT, &s, &w);
	assert_true(w.lights.quad[0].on);
	pm_world_free(&w);
	pm_scene_free(&s);
	/* two triangles that share an edge but are no parallelogram (an
	 * OBJ kite), a cube's twelve, a disk: triangles as before */
	load("<shape type=\"cube\"><emitter type=\"area\"><rgb name="
	    "\"radiance\" value=\"1\"/></emitter></shape>\n"
	    "<shape type=\"disk\"><transform name=\"to_world\"><translate "
	    "z=\"3\"/></transform><emitter type=\"area\"><rgb name="
	    "\"radiance\" value=\"1\"/></emitter></shape>\n", &s, &w);
	assert_int_equal(s.nlights, 2);
	assert_false(w.lights.quad[0].on);
	assert_false(w.lights.quad[1].on);
	pm_world_free(&w);
	pm_scene_free(&s);
}

/* The quad's own test on a kite: two triangles sharing an edge whose
 * far vertices do not sum to the shared ones. */
static void
test_kite_is_not_a_quad(void **state)
{
	struct pm_scene s;
	struct pm_world w;
	float *p;

	(void)state;
	load(RECT, &s, &w);
	pm_world_free(&w);
	/* move one corner out of the plane's parallelogram, in plane */
	p = s.shapes[0].mesh.pos;
	p[3 * 1 + 0] += 0.3f * (p[3 * 1 + 0] - p[3 * 3 + 0]);
	p[3 * 1 + 1] += 0.3f * (p[3 * 1 + 1] - p[3 * 3 + 1]);
	p[3 * 1 + 2] += 0.3f * (p[3 * 1 + 2] - p[3 * 3 + 2]);
	assert_int_equal(pm_world_init(&w, &s, &(struct pm_error){0}), PM_OK);
	assert_false(w.lights.quad[0].on);
	pm_world_free(&w);
	pm_scene_free(&s);
}

/*
 * Samples from a point below the light: their positions in the quad's
 * coordinates fall evenly on a 10 x 10 grid (chi-square, 99 degrees of
 * freedom, below 160: p ~ 1e-4), and E = sum L cos / pdf matches the
 * closed form of a uniform rectangle's irradiance, found here by
 * quadrature in double.
 */
static void
test_uniform_and_unbiased(void **state)
{
	enum { G = 10, N = 400000 };
	struct pm_scene s;
	struct pm_world w;
	struct pm_light_sample ls;
	struct pm_rng rng = pm_rng_seed(17, 0, 0);
	struct pm_vec3 ref = pm_v3(0.2f, -0.1f, -0.3f), nrm = pm_v3(0, 0, 1);
	const struct pm_light_quad *q;
	long count[G * G] = {0};
	double sum = 0, sq = 0, chi2 = 0, quad = 0, se, e11, e12, e22;
	int i, j, checked = 0;

	(void)state;
	load(RECT, &s, &w);
	q = &w.lights.quad[0];
	assert_true(q->on);
	e11 = pm_dot(q->e1, q->e1);
	e12 = pm_dot(q->e1, q->e2);
	e22 = pm_dot(q->e2, q->e2);
	for (i = 0; i < N; i++) {
		struct pm_vec3 d;
		double b1, b2, det = e11 * e22 - e12 * e12, x = 0;

		assert_true(pm_lights_sample(&w.lights, &s, ref,
		    pm_rng_float(&rng), pm_rng_float(&rng), pm_rng_float(&rng),
		    &ls));
		/* the point's coordinates (b1, b2) along e1, e2 */
		d = pm_sub(ls.p, q->p0);
		b1 = (e22 * pm_dot(d, q->e1) - e12 * pm_dot(d, q->e2)) / det;
		b2 = (e11 * pm_dot(d, q->e2) - e12 * pm_dot(d, q->e1)) / det;
		assert_true(b1 > -1e-5 && b1 < 1 + 1e-5);
		assert_true(b2 > -1e-5 && b2 < 1 + 1e-5);
		count[(int)fmin(b1 * G, G - 1) * G + (int)fmin(b2 * G, G - 1)]++;
		if (pm_dot(ls.wi, nrm) > 0)
			x = ls.value.g * pm_dot(ls.wi, nrm) / ls.pdf;
		sum += x;
		sq += x * x;
		if (i % 101 == 0) {
			struct pm_hit h;

			/* a ray along the sample finds the light there,
			 * with the same density */
			assert_true(pm_accel_intersect(w.accel, ref, ls.wi,
			    0.0f, INFINITY, &h));
			assert_true(fabsf(h.t - ls.dist) <= 1e-4f * ls.dist);
			assert_true(fabsf(pm_lights_pdf_area(&w.lights, &s, 0,
			    ref, h.p, h.ng) - ls.pdf) <= 1e-3f * ls.pdf);
			checked++;
		}
	}
	for (i = 0; i < G * G; i++)
		chi2 += (count[i] - N / (double)(G * G)) *
		    (count[i] - N / (double)(G * G)) / (N / (double)(G * G));
	/* irradiance at ref facing +z by a 1000 x 1000 midpoint rule */
	for (j = 0; j < 1000; j++)
		for (i = 0; i < 1000; i++) {
			struct pm_vec3 p = pm_madd(pm_madd(q->p0, q->e1,
			    (i + 0.5f) / 1000), q->e2, (j + 0.5f) / 1000);
			struct pm_vec3 d = pm_sub(p, ref);
			double d2 = pm_dot(d, d), dl = sqrt(d2);
			double cr = d.z / dl, cl = -pm_dot(q->n, d) / dl;

			if (cr > 0 && cl > 0)
				quad += cr * cl / d2;
		}
	quad *= pm_length(pm_cross(q->e1, q->e2)) / 1e6;
	se = sqrt((sq / N - (sum / N) * (sum / N)) / N);
	print_message("quad light: chi2 %.1f (99 dof), E %.5f against %.5f "
	    "(standard error %.5f)\n", chi2, sum / N, quad, se);
	assert_true(checked > 1000);
	assert_true(chi2 < 160.0);
	assert_true(fabs(sum / N - quad) < 4 * se + 1e-4 * quad);
	pm_world_free(&w);
	pm_scene_free(&s);
}

/*
 * Photons from a rectangle light (a quad) inside a closed black box: every
 * path's first hit stores the light's power, pi A Le, whole (cosine
 * sampling makes each photon's flux that exactly, up to RGBE rounding),
 * and none starts on the dark side: the box's floor (below the light,
 * which faces -z after its turn) takes every photon, centred under it as
 * the light is on its centre (a point map bent towards a corner moves
 * the mean by many standard errors).
 */
static void
test_photons_leave_the_lit_side(void **state)
{
	const uint64_t n = 100000;
	struct pm_scene s;
	struct pm_world w;
	struct pm_shooter sh;
	struct pm_photon_buf b = {NULL, 0, 0};
	struct pm_shoot_opts o = {PM_PASS_GLOBAL, 7, 0, n, 0, 1, NULL, NULL,
	    NULL, NULL};
	struct pm_shoot_stats st;
	struct pm_error err;
	double sum[3] = {0, 0, 0}, mx = 0, my = 0, sx = 0, sy = 0;
	size_t i, below = 0;

	(void)state;
	load("<shape type=\"cube\"><transform name=\"to_world\"><scale "
	    "value=\"2\"/></transform><bsdf type=\"diffuse\"><rgb name="
	    "\"reflectance\" value=\"0\"/></bsdf></shape>\n"
	    "<shape type=\"rectangle\"><transform name=\"to_world\">"
	    "<scale x=\"0.5\" y=\"0.25\"/><rotate x=\"1\" angle=\"180\"/>"
	    "<translate z=\"1\"/></transform><emitter type=\"area\">"
	    "<rgb name=\"radiance\" value=\"1, 2, 3\"/></emitter></shape>\n",
	    &s, &w);
	assert_true(w.lights.quad[0].on);
	memset(&err, 0, sizeof(err));
	assert_int_equal(pm_shooter_init(&sh, &s, w.accel, &w.lights, &err),
	    PM_OK);
	assert_int_equal(pm_shoot(&sh, &o, &b, &st, &err), PM_OK);
	for (i = 0; i < b.n; i++) {
		struct pm_rgb f = pm_rgbe_unpack(b.p[i].power);

		assert_int_equal(b.p[i].depth, 0);
		sum[0] += f.r;
		sum[1] += f.g;
		sum[2] += f.b;
		below += b.p[i].pos[2] < 1.0f;
		mx += b.p[i].pos[0];
		my += b.p[i].pos[1];
		sx += (double)b.p[i].pos[0] * b.p[i].pos[0];
		sy += (double)b.p[i].pos[1] * b.p[i].pos[1];
	}
	mx /= n;
	my /= n;
	sx = sqrt((sx / n - mx * mx) / n);
	sy = sqrt((sy / n - my * my) / n);
	print_message("quad light photons: %zu stored, %zu below it, power "
	    "%.5f %.5f %.5f (want pi/2 times 1, 2, 3), mean x %.5f +- %.5f, "
	    "y %.5f +- %.5f\n", b.n, below, sum[0] / n, sum[1] / n,
	    sum[2] / n, mx, sx, my, sy);
	assert_true(fabs(mx) < 4 * sx);
	assert_true(fabs(my) < 4 * sy);
	assert_int_equal(b.n, n);
	assert_int_equal(below, n);
	for (i = 0; i < 3; i++)
		assert_true(fabs(sum[i] / n - M_PI / 2 * (i + 1)) <
		    1e-3 * M_PI / 2 * (i + 1));
	pm_photon_buf_free(&b);
	pm_shooter_free(&sh);
	pm_world_free(&w);
	pm_scene_free(&s);
}

/*
 * pm_lights_sample_n, whose SIMD lanes take a parallelogram's light
 * samples four at a time, against pm_lights_sample one at a time, bit
 * for bit: 100003 points around the turned light, in front of it and
 * behind it (samples refused there), on its plane, and at its corners,
 * where a sample may land on the point itself, in batches of
 * PM_LIGHT_LANES and a last one of fewer (not a multiple of 4); every
 * seventh point is not wanted, and its sample must not be ok.  It fails
 * with the distance's reciprocal folded into a division or the light's
 * back accepted.
 */
static void
test_light_samples_in_lanes(void **state)
{
	enum { N = 100003 };
	struct pm_scene s;
	struct pm_world w;
	struct pm_vec3 *ref = malloc(N * sizeof(*ref));
	float (*u)[3] = malloc(N * sizeof(*u));
	struct pm_light_lanes *ll = malloc(sizeof(*ll));
	struct pm_rng rng = pm_rng_seed(23, 0, 0);
	const struct pm_light_quad *q;
	size_t i, j, m, lit = 0;

	(void)state;
	assert_non_null(ref);
	assert_non_null(u);
	assert_non_null(ll);
	load(RECT, &s, &w);
	q = &w.lights.quad[0];
	assert_true(q->on);
	for (i = 0; i < N; i++) {
		float a = pm_rng_float(&rng), b = pm_rng_float(&rng);

		switch (i % 5) {
		case 0:		/* on the light's plane */
			ref[i] = pm_madd(pm_madd(q->p0, q->e1, 2 * a - 0.5f),
			    q->e2, 2 * b - 0.5f);
			break;
		case 1:		/* a corner, which u = 0 samples */
			ref[i] = q->p0;
			u[i][0] = u[i][1] = u[i][2] = 0.0f;
			continue;
		default:	/* anywhere around it */
			ref[i] = pm_v3(4 * a - 2, 4 * b - 2,
			    4 * pm_rng_float(&rng) - 1);
		}
		u[i][0] = pm_rng_float(&rng);
		u[i][1] = pm_rng_float(&rng);
		u[i][2] = pm_rng_float(&rng);
	}
	for (i = 0; i < N; i += m) {
		m = N - i < PM_LIGHT_LANES ? N - i : PM_LIGHT_LANES;
		for (j = 0; j < m; j++) {
			ll->ref[0][j] = ref[i + j].x;
			ll->ref[1][j] = ref[i + j].y;
			ll->ref[2][j] = ref[i + j].z;
			ll->u[0][j] = u[i + j][0];
			ll->u[1][j] = u[i + j][1];
			ll->u[2][j] = u[i + j][2];
			ll->want[j] = (i + j) % 7 != 3;
		}
		pm_lights_sample_n(&w.lights, &s, ll, m);
		for (j = 0; j < m; j++) {
			struct pm_light_sample want, got;
			bool w_ok = pm_lights_sample(&w.lights, &s, ref[i + j],
			    u[i + j][0], u[i + j][1], u[i + j][2], &want);

			if (!ll->want[j]) {
				assert_int_equal(ll->ok[j], 0);
				continue;
			}
			assert_int_equal(ll->ok[j], w_ok ? -1 : 0);
			if (!w_ok)
				continue;
			lit++;
			pm_light_lanes_get(ll, j, &got);
			assert_memory_equal(&got.wi, &want.wi, sizeof(want.wi));
			assert_memory_equal(&got.dist, &want.dist,
			    sizeof(want.dist));
			assert_memory_equal(&got.p, &want.p, sizeof(want.p));
			assert_memory_equal(&got.value, &want.value,
			    sizeof(want.value));
			assert_memory_equal(&got.pdf, &want.pdf,
			    sizeof(want.pdf));
			assert_int_equal(got.delta, want.delta);
		}
	}
	print_message("light samples in lanes: %zu of %d lit, all the "
	    "scalar ones' bits\n", lit, N);
	assert_true(lit > N / 4 && lit < N - N / 4);
	free(ref);
	free(u);
	free(ll);
	pm_world_free(&w);
	pm_scene_free(&s);
}

/* A second rectangle, brighter and elsewhere, for a scene of two lights. */
#define RECT2 "<shape type=\"rectangle\"><transform name=\"to_world\">" \
	"<scale x=\"0.5\" y=\"0.8\"/><rotate y=\"1\" angle=\"70\"/>" \
	"<translate x=\"-0.7\" z=\"-0.5\"/></transform>" \
	"<emitter type=\"area\"><rgb name=\"radiance\" value=\"3, 2, 1\"/>" \
	"</emitter></shape>\n"
/* A black box around them. */
#define BLACK_BOX "<shape type=\"cube\"><transform name=\"to_world\">" \
	"<scale value=\"2\"/></transform><bsdf type=\"diffuse\"><rgb name=" \
	"\"reflectance\" value=\"0\"/></bsdf></shape>\n"

/*
 * pm_shoot emits photons eight paths at a time, their cosine directions
 * warped in SIMD lanes (common/shoot.c, emit_batch), four paths that
 * picked the same parallelogram in lanes too (emit_quad4), and
 * pm_shooter_emit one at a time:
 * both must be emission as defined, the light's pick, the shape's point,
 * the cosine direction in pm_frame_from_normal's frame, the flux and the
 * offset origin, computed here from the general functions:
 * pm_shooter_emit's results bit for bit, pm_shoot's photons byte for
 * byte (position, and power as RGBE stores it).  Turned lights in a
 * black box store each path's first hit only, so the k-th photon is the
 * k-th path that carries flux; 1003 paths from path 5 leave a batch of
 * three, whose warps take the scalar tail.  Of two lights, the groups of
 * four paths that picked both go one at a time.  (test_sampling checks
 * the lanes' warp.)  Returns how many paths picked each light.
 */
static void
batched_emission(const char *xml, size_t picked[2])
{
	const uint64_t first = 5, n = 1003, seed = 7;
	struct pm_scene s;
	struct pm_world w;
	struct pm_shooter sh;
	struct pm_photon_buf b = {NULL, 0, 0};
	struct pm_shoot_opts o = {PM_PASS_GLOBAL, seed, first, n, 0, 1, NULL,
	    NULL, NULL, NULL};
	struct pm_shoot_stats st;
	struct pm_error err;
	size_t k = 0, li;
	uint64_t i;

	load(xml, &s, &w);
	assert_true(s.nlights <= 2);
	for (li = 0; li < s.nlights; li++) {
		assert_true(w.lights.quad[li].on);
		picked[li] = 0;
	}
	memset(&err, 0, sizeof(err));
	assert_int_equal(pm_shooter_init(&sh, &s, w.accel, &w.lights, &err),
	    PM_OK);
	assert_int_equal(pm_shoot(&sh, &o, &b, &st, &err), PM_OK);
	for (i = first; i < first + n; i++) {
		struct pm_rng rng = pm_rng_seed(seed, i, PM_PASS_GLOBAL);
		struct pm_rng r2 = rng;
		struct pm_vec3 p, ng, ns, d, org, eo, ed;
		struct pm_rgb flux, ef;
		struct pm_hit lh, h;
		const struct pm_light *l;
		float u[6], c, pdf, psel;
		uint8_t power[4];
		int j;
		bool ok;

		for (j = 0; j < 6; j++)
			u[j] = pm_rng_float(&rng);
		li = pm_distrib_sample(&w.lights.pick, u[0], NULL);
		l = &s.lights[li];
		psel = (float)pm_distrib_prob(&w.lights.pick, li);
		picked[li]++;
		pm_shooter_shape_point(&sh, (int)li, u[1], u[2], &p, &ng, &ns,
		    &lh);
		d = pm_to_world(pm_frame_from_normal(ng),
		    pm_square_to_cosine_hemisphere(u[3], u[4]));
		c = pm_dot(d, ng);
		pdf = pm_fmaxf(c, 0.0f) * PM_INV_PI;
		ok = c > 0.0f && pm_dot(d, ns) > 0.0f && pdf > 0.0f;
		flux = pm_rgb_scale(l->radiance, c * (float)l->area /
		    (psel * pdf));
		org = pm_offset_origin(p, ng, d);
		/* one at a time */
		assert_int_equal(pm_shooter_emit(&sh, &r2, &eo, &ed, &ef), ok);
		if (!ok)
			continue;
		assert_memory_equal(&eo, &org, sizeof(org));
		assert_memory_equal(&ed, &d, sizeof(d));
		assert_memory_equal(&ef, &flux, sizeof(flux));
		/* in lanes: the photon at the first hit */
		assert_true(pm_accel_intersect(w.accel, org, d, 0.0f, INFINITY,
		    &h));
		pm_rgbe_pack(flux, pm_rng_float(&rng), power);
		assert_true(k < b.n);
		assert_int_equal(b.p[k].depth, 0);
		assert_memory_equal(b.p[k].pos, &h.p.x, sizeof(float));
		assert_memory_equal(b.p[k].pos + 1, &h.p.y, sizeof(float));
		assert_memory_equal(b.p[k].pos + 2, &h.p.z, sizeof(float));
		assert_memory_equal(b.p[k].power, power, sizeof(power));
		k++;
	}
	assert_int_equal(k, b.n);
	assert_true(k > n / 2);
	pm_photon_buf_free(&b);
	pm_shooter_free(&sh);
	pm_world_free(&w);
	pm_scene_free(&s);
}

static void
test_batched_emission_is_the_definition(void **state)
{
	size_t picked[2];

	(void)state;
	batched_emission(BLACK_BOX RECT, picked);
	batched_emission(BLACK_BOX RECT RECT2, picked);
	/* both lights emit, the brighter one more */
	assert_true(picked[1] > picked[0] && picked[0] > 100);
}

int
main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_recognised),
		cmocka_unit_test(test_kite_is_not_a_quad),
		cmocka_unit_test(test_uniform_and_unbiased),
		cmocka_unit_test(test_photons_leave_the_lit_side),
		cmocka_unit_test(test_batched_emission_is_the_definition),
		cmocka_unit_test(test_light_samples_in_lanes),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
