/*
 * test_transform.c: 4x4 transforms against analytic answers: composition
 * order, inverses of random matrices, Mitsuba's lookat columns, rotations,
 * and normals under non-uniform scaling.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include "../../common/transform.h"

/* A small fixed-seed generator so that the random matrices are repeatable. */
static uint64_t rng_state = 0x9e3779b97f4a7c15ULL;

static double
urand(void)
{
	rng_state ^= rng_state << 13;
	rng_state ^= rng_state >> 7;
	rng_state ^= rng_state << 17;
	return (double)(rng_state >> 11) / 9007199254740992.0;
}

static float
srand1(void)
{
	return (float)(2.0 * urand() - 1.0);
}

static struct pm_vec3
rand_vec(void)
{
	return pm_v3(srand1(), srand1(), srand1());
}

static void
assert_vec_near(struct pm_vec3 a, struct pm_vec3 b, float tol)
{
	if (!(fabsf(a.x - b.x) <= tol && fabsf(a.y - b.y) <= tol &&
	    fabsf(a.z - b.z) <= tol))
		fail_msg("(%g %g %g) != (%g %g %g) within %g", a.x, a.y, a.z,
		    b.x, b.y, b.z, tol);
}

static void
test_identity_and_mul(void **state)
{
	struct pm_mat4 id = pm_mat4_identity(), a, r;
	int i, j;

	(void)state;
	for (i = 0; i < 4; i++)
		for (j = 0; j < 4; j++)
			a.m[i][j] = srand1();
	r = pm_mat4_mul(id, a);
	for (i = 0; i < 4; i++)
		for (j = 0; j < 4; j++)
			assert_float_equal(r.m[i][j], a.m[i][j], 0.0f);
	r = pm_mat4_mul(a, id);
	for (i = 0; i < 4; i++)
		for (j = 0; j < 4; j++)
			assert_float_equal(r.m[i][j], a.m[i][j], 0.0f);
}

/*
 * Mitsuba composes a <transform> block child by child as M = Op * M, so
 * <translate/> then <scale/> means p' = S (T p).
 */
static void
test_composition_order(void **state)
{
	struct pm_vec3 t = pm_v3(1.0f, -2.0f, 3.0f), s = pm_v3(2.0f, 3.0f, 4.0f);
	struct pm_vec3 p = pm_v3(0.5f, 0.25f, -1.0f), q;
	struct pm_mat4 m = pm_mat4_identity();

	(void)state;
	m = pm_mat4_mul(pm_mat4_translate(t), m);
	m = pm_mat4_mul(pm_mat4_scale(s), m);
	q = pm_xform_point(&m, p);
	assert_vec_near(q, pm_v3(2.0f * 1.5f, 3.0f * -1.75f, 4.0f * 2.0f), 1e-6f);

	/* The other order gives S p + t. */
	m = pm_mat4_mul(pm_mat4_translate(t), pm_mat4_scale(s));
	q = pm_xform_point(&m, p);
	assert_vec_near(q, pm_v3(2.0f, -1.25f, -1.0f), 1e-6f);

	/* Vectors ignore the translation. */
	q = pm_xform_vector(&m, p);
	assert_vec_near(q, pm_v3(1.0f, 0.75f, -4.0f), 1e-6f);
}

static void
test_rotation(void **state)
{
	struct pm_mat4 r, r2, r3;
	int i;

	(void)state;
	/* Right-handed: +90 degrees about z takes x to y, y to -x. */
	r = pm_mat4_rotate(pm_v3(0, 0, 1), 90.0f);
	assert_vec_near(pm_xform_vector(&r, pm_v3(1, 0, 0)), pm_v3(0, 1, 0), 1e-6f);
	assert_vec_near(pm_xform_vector(&r, pm_v3(0, 1, 0)), pm_v3(-1, 0, 0), 1e-6f);
	r = pm_mat4_rotate(pm_v3(1, 0, 0), 90.0f);
	assert_vec_near(pm_xform_vector(&r, pm_v3(0, 1, 0)), pm_v3(0, 0, 1), 1e-6f);
	r = pm_mat4_rotate(pm_v3(0, 2, 0), 90.0f);	/* axis normalised */
	assert_vec_near(pm_xform_vector(&r, pm_v3(0, 0, 1)), pm_v3(1, 0, 0), 1e-6f);

	for (i = 0; i < 100; i++) {
		struct pm_vec3 axis = rand_vec(), v = rand_vec();
		float a = 360.0f * srand1(), b = 360.0f * srand1();

		r = pm_mat4_rotate(axis, a);
		/* The axis stays put, lengths are kept. */
		assert_vec_near(pm_xform_vector(&r, axis), axis, 1e-5f);
		assert_float_equal(pm_length(pm_xform_vector(&r, v)),
		    pm_length(v), 1e-5f);
		/* Rotations about one axis add up. */
		r2 = pm_mat4_mul(pm_mat4_rotate(axis, b), r);
		r3 = pm_mat4_rotate(axis, a + b);
		assert_vec_near(pm_xform_vector(&r2, v),
		    pm_xform_vector(&r3, v), 1e-4f);
	}
}

static void
test_inverse_random(void **state)
{
	int n, i, j;

	(void)state;
	for (n = 0; n < 1000; n++) {
		struct pm_mat4 a, inv, p, q;

		for (i = 0; i < 4; i++)
			for (j = 0; j < 4; j++)
				a.m[i][j] = srand1();
		/* Keep the condition number modest so float error stays small. */
		for (i = 0; i < 4; i++)
			a.m[i][i] += i % 2 ? 3.0f : -3.0f;
		assert_true(pm_mat4_inverse(a, &inv));
		p = pm_mat4_mul(a, inv);
		q = pm_mat4_mul(inv, a);
		for (i = 0; i < 4; i++)
			for (j = 0; j < 4; j++) {
				assert_float_equal(p.m[i][j], i == j, 1e-5f);
				assert_float_equal(q.m[i][j], i == j, 1e-5f);
			}
	}
}

static void
test_inverse_affine(void **state)
{
	int n;

	(void)state;
	for (n = 0; n < 200; n++) {
		struct pm_mat4 m = pm_mat4_identity(), inv;
		struct pm_vec3 p = rand_vec(), q;

		m = pm_mat4_mul(pm_mat4_scale(pm_v3(0.5f + (float)urand(),
		    0.5f + (float)urand(), -0.5f - (float)urand())), m);
		m = pm_mat4_mul(pm_mat4_rotate(rand_vec(), 180.0f * srand1()), m);
		m = pm_mat4_mul(pm_mat4_translate(pm_scale(rand_vec(), 100.0f)), m);
		assert_true(pm_mat4_inverse(m, &inv));
		/* Affine stays affine. */
		assert_float_equal(inv.m[3][0], 0.0f, 1e-6f);
		assert_float_equal(inv.m[3][3], 1.0f, 1e-6f);
		q = pm_xform_point(&inv, pm_xform_point(&m, p));
		assert_vec_near(q, p, 1e-4f);
	}
}

static void
test_inverse_singular(void **state)
{
	struct pm_mat4 inv = pm_mat4_identity(), a;

	(void)state;
	assert_false(pm_mat4_inverse(pm_mat4_scale(pm_v3(1, 0, 1)), &inv));
	a = pm_mat4_identity();
	a.m[1][1] = NAN;
	assert_false(pm_mat4_inverse(a, &inv));
	/* Two equal rows. */
	a = pm_mat4_identity();
	a.m[2][0] = 1.0f;
	a.m[2][2] = 0.0f;
	assert_false(pm_mat4_inverse(a, &inv));
	/* Untouched on failure. */
	assert_float_equal(inv.m[0][0], 1.0f, 0.0f);
}

static void
assert_column(const struct pm_mat4 *m, int c, struct pm_vec3 v)
{
	assert_vec_near(pm_v3(m->m[0][c], m->m[1][c], m->m[2][c]), v, 1e-6f);
}

static void
test_lookat(void **state)
{
	struct pm_mat4 m;
	int n;

	(void)state;
	/* The Cornell box camera: looking down +z with y up is the identity
	 * rotation (left = up x dir = +x). */
	m = pm_mat4_lookat(pm_v3(278, 273, -800), pm_v3(278, 273, -799),
	    pm_v3(0, 1, 0));
	assert_column(&m, 0, pm_v3(1, 0, 0));
	assert_column(&m, 1, pm_v3(0, 1, 0));
	assert_column(&m, 2, pm_v3(0, 0, 1));
	assert_column(&m, 3, pm_v3(278, 273, -800));
	assert_float_equal(m.m[3][3], 1.0f, 0.0f);

	/* Looking along +x with z up: left = z x x = +y, up' = x x y = +z. */
	m = pm_mat4_lookat(pm_v3(0, 0, 0), pm_v3(5, 0, 0), pm_v3(0, 0, 1));
	assert_column(&m, 0, pm_v3(0, 1, 0));
	assert_column(&m, 1, pm_v3(0, 0, 1));
	assert_column(&m, 2, pm_v3(1, 0, 0));

	/* Looking along -z with y up: left = y x -z = -x. */
	m = pm_mat4_lookat(pm_v3(1, 2, 3), pm_v3(1, 2, -3), pm_v3(0, 1, 0));
	assert_column(&m, 0, pm_v3(-1, 0, 0));
	assert_column(&m, 1, pm_v3(0, 1, 0));
	assert_column(&m, 2, pm_v3(0, 0, -1));

	for (n = 0; n < 100; n++) {
		struct pm_vec3 o = pm_scale(rand_vec(), 10.0f);
		struct pm_vec3 t = pm_add(o, rand_vec()), up = rand_vec();
		struct pm_vec3 dir = pm_normalize(pm_sub(t, o));
		struct pm_vec3 l, u, d;

		m = pm_mat4_lookat(o, t, up);
		l = pm_v3(m.m[0][0], m.m[1][0], m.m[2][0]);
		u = pm_v3(m.m[0][1], m.m[1][1], m.m[2][1]);
		d = pm_v3(m.m[0][2], m.m[1][2], m.m[2][2]);
		assert_vec_near(d, dir, 1e-5f);
		assert_vec_near(l, pm_normalize(pm_cross(up, dir)), 1e-4f);
		assert_vec_near(u, pm_cross(d, l), 1e-5f);
		/* Orthonormal and right-handed, up' in the plane of up and dir. */
		assert_float_equal(pm_dot(l, u), 0.0f, 1e-5f);
		assert_float_equal(pm_length(u), 1.0f, 1e-5f);
		assert_float_equal(pm_dot(pm_cross(l, u), d), 1.0f, 1e-5f);
		assert_true(pm_dot(u, up) >= -1e-6f);
		assert_vec_near(pm_xform_point(&m, pm_v3(0, 0, 0)), o, 1e-5f);
		assert_vec_near(pm_xform_point(&m, pm_v3(0, 0, 1)),
		    pm_add(o, dir), 1e-4f);
	}

	/* up parallel to the view: still a finite orthonormal frame. */
	m = pm_mat4_lookat(pm_v3(0, 0, 0), pm_v3(0, 3, 0), pm_v3(0, 1, 0));
	assert_true(isfinite(m.m[0][0]) && isfinite(m.m[1][1]));
	assert_column(&m, 2, pm_v3(0, 1, 0));
}

/*
 * A normal transformed by the inverse transpose stays perpendicular to the
 * transformed surface; transforming it as a vector would not.
 */
static void
test_normals_nonuniform(void **state)
{
	int n, bent = 0;

	(void)state;
	for (n = 0; n < 200; n++) {
		struct pm_mat4 m = pm_mat4_identity(), inv;
		struct pm_vec3 t1 = rand_vec(), t2 = rand_vec();
		struct pm_vec3 nrm = pm_normalize(pm_cross(t1, t2));
		struct pm_vec3 a, b, nn, wrong;

		m = pm_mat4_mul(pm_mat4_rotate(rand_vec(), 90.0f * srand1()), m);
		m = pm_mat4_mul(pm_mat4_scale(pm_v3(1.0f, 5.0f, 0.2f)), m);
		m = pm_mat4_mul(pm_mat4_translate(rand_vec()), m);
		assert_true(pm_mat4_inverse(m, &inv));
		a = pm_normalize(pm_xform_vector(&m, t1));
		b = pm_normalize(pm_xform_vector(&m, t2));
		nn = pm_normalize(pm_xform_normal(&inv, nrm));
		assert_float_equal(pm_dot(nn, a), 0.0f, 1e-4f);
		assert_float_equal(pm_dot(nn, b), 0.0f, 1e-4f);
		/* It also keeps the side: same sign as the cross product. */
		assert_true(pm_dot(nn, pm_cross(a, b)) > 0.0f);
		wrong = pm_normalize(pm_xform_vector(&m, nrm));
		bent += fabsf(pm_dot(wrong, a)) > 1e-2f;
	}
	/* The naive transform fails often, so the check above means something. */
	assert_true(bent > 100);
}

static void
test_projective_point(void **state)
{
	struct pm_mat4 m = pm_mat4_identity();

	(void)state;
	m.m[3][2] = 1.0f;	/* w = z */
	m.m[3][3] = 0.0f;
	assert_vec_near(pm_xform_point(&m, pm_v3(2, 4, 2)), pm_v3(1, 2, 1), 1e-6f);
}

int
main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_identity_and_mul),
		cmocka_unit_test(test_composition_order),
		cmocka_unit_test(test_rotation),
		cmocka_unit_test(test_inverse_random),
		cmocka_unit_test(test_inverse_affine),
		cmocka_unit_test(test_inverse_singular),
		cmocka_unit_test(test_lookat),
		cmocka_unit_test(test_normals_nonuniform),
		cmocka_unit_test(test_projective_point),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
