/*
 * test_mesh.c: the shape generators against their analytic areas and
 * normals, angle-weighted vertex normals, validation, transforms (mirrors
 * included) and flipping.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "../../common/mesh.h"

/* cmocka's assert_float_equal works in float; these checks need double. */
#define assert_near(a, b, tol) do {					\
	double a_ = (a), b_ = (b);					\
	if (!(fabs(a_ - b_) <= (tol)))					\
		fail_msg("%s = %.17g, expected %.17g within %g", #a,	\
		    a_, b_, (double)(tol));				\
} while (0)

static struct pm_vec3
nrm_at(const struct pm_mesh *m, uint32_t i)
{
	return pm_v3(m->nrm[3 * i], m->nrm[3 * i + 1], m->nrm[3 * i + 2]);
}

/* Unit normal of triangle t from its winding (counter-clockwise = front). */
static struct pm_vec3
geom_normal(const struct pm_mesh *m, uint32_t t)
{
	struct pm_vec3 a = pm_mesh_vertex(m, m->idx[3 * t]);
	struct pm_vec3 b = pm_mesh_vertex(m, m->idx[3 * t + 1]);
	struct pm_vec3 c = pm_mesh_vertex(m, m->idx[3 * t + 2]);

	return pm_normalize(pm_cross(pm_sub(b, a), pm_sub(c, a)));
}

static struct pm_vec3
centroid(const struct pm_mesh *m, uint32_t t)
{
	struct pm_vec3 s = pm_v3(0, 0, 0);
	int k;

	for (k = 0; k < 3; k++)
		s = pm_add(s, pm_mesh_vertex(m, m->idx[3 * t + k]));
	return pm_scale(s, 1.0f / 3.0f);
}

static double
angle_deg(struct pm_vec3 a, struct pm_vec3 b)
{
	double c = pm_dot(pm_normalize(a), pm_normalize(b));

	if (c > 1.0)
		c = 1.0;
	return acos(c) * 180.0 / M_PI;
}

/* Every triangle's winding agrees with the shading normals at its corners. */
static void
assert_winding_matches_normals(const struct pm_mesh *m)
{
	uint32_t t;
	int k;

	assert_non_null(m->nrm);
	for (t = 0; t < m->ntris; t++) {
		struct pm_vec3 g = geom_normal(m, t);
		for (k = 0; k < 3; k++)
			assert_true(pm_dot(g, nrm_at(m, m->idx[3 * t + k])) > 0.0f);
	}
}

static void
test_free_zeroed(void **state)
{
	struct pm_mesh m;

	(void)state;
	memset(&m, 0, sizeof(m));
	pm_mesh_free(&m);
	pm_mesh_free(&m);
	pm_mesh_free(NULL);
	assert_int_equal(m.nverts, 0);
}

static void
test_rectangle(void **state)
{
	struct pm_mesh m;
	struct pm_error err;
	uint32_t i, dropped;

	(void)state;
	assert_int_equal(pm_mesh_rectangle(&m, &err), PM_OK);
	assert_int_equal(m.nverts, 4);
	assert_int_equal(m.ntris, 2);
	assert_near(pm_mesh_area(&m), 4.0, 1e-12);
	for (i = 0; i < m.nverts; i++) {
		struct pm_vec3 p = pm_mesh_vertex(&m, i);
		assert_float_equal(fabsf(p.x), 1.0f, 0.0f);
		assert_float_equal(fabsf(p.y), 1.0f, 0.0f);
		assert_float_equal(p.z, 0.0f, 0.0f);
		/* uv runs with x and y over [0,1]. */
		assert_float_equal(m.uv[2 * i], (p.x + 1.0f) / 2.0f, 0.0f);
		assert_float_equal(m.uv[2 * i + 1], (p.y + 1.0f) / 2.0f, 0.0f);
		assert_float_equal(nrm_at(&m, i).z, 1.0f, 0.0f);
	}
	for (i = 0; i < m.ntris; i++)
		assert_float_equal(geom_normal(&m, i).z, 1.0f, 1e-7f);
	assert_int_equal(pm_mesh_validate(&m, &dropped, &err), PM_OK);
	assert_int_equal(dropped, 0);
	pm_mesh_free(&m);
	assert_null(m.pos);
}

static void
test_cube(void **state)
{
	struct pm_mesh m;
	struct pm_error err;
	uint32_t t, i;
	int faces[6] = {0};

	(void)state;
	assert_int_equal(pm_mesh_cube(&m, &err), PM_OK);
	assert_int_equal(m.nverts, 24);
	assert_int_equal(m.ntris, 12);
	assert_near(pm_mesh_area(&m), 24.0, 1e-12);
	for (t = 0; t < m.ntris; t++) {
		struct pm_vec3 g = geom_normal(&m, t), c = centroid(&m, t);
		int axis = fabsf(g.x) > 0.5f ? 0 : fabsf(g.y) > 0.5f ? 1 : 2;

		/* Outward, axis-aligned, and agreeing with the flat normals. */
		assert_float_equal(fabsf(pm_vget(g, axis)), 1.0f, 1e-6f);
		assert_true(pm_dot(g, c) > 0.0f);
		faces[2 * axis + (pm_vget(g, axis) < 0.0f)]++;
		for (i = 0; i < 3; i++)
			assert_float_equal(pm_dot(g,
			    nrm_at(&m, m.idx[3 * t + i])), 1.0f, 1e-6f);
	}
	for (i = 0; i < 6; i++)
		assert_int_equal(faces[i], 2);
	for (i = 0; i < m.nverts; i++) {
		struct pm_vec3 p = pm_mesh_vertex(&m, i);
		assert_float_equal(fabsf(p.x) + fabsf(p.y) + fabsf(p.z), 3.0f, 0.0f);
		assert_true(m.uv[2 * i] == 0.0f || m.uv[2 * i] == 1.0f);
		assert_true(m.uv[2 * i + 1] == 0.0f || m.uv[2 * i + 1] == 1.0f);
	}
	pm_mesh_free(&m);
}

static void
test_disk(void **state)
{
	static const uint32_t segs[] = {3, 4, 5, 7, 16, 64, 1000};
	struct pm_mesh m;
	struct pm_error err;
	size_t s;
	uint32_t t, i;

	(void)state;
	for (s = 0; s < sizeof(segs) / sizeof(segs[0]); s++) {
		uint32_t n = segs[s];
		double rim = sqrt(2.0 * M_PI / (n * sin(2.0 * M_PI / n)));

		assert_int_equal(pm_mesh_disk(&m, n, &err), PM_OK);
		assert_int_equal(m.ntris, n);
		/* The pushed-out rim makes the area pi, not the n-gon's. */
		assert_near(pm_mesh_area(&m), M_PI, 1e-5);
		for (t = 0; t < m.ntris; t++)
			assert_float_equal(geom_normal(&m, t).z, 1.0f, 1e-6f);
		for (i = 0; i < m.nverts; i++) {
			struct pm_vec3 p = pm_mesh_vertex(&m, i);
			float r = sqrtf(p.x * p.x + p.y * p.y);
			assert_true(r == 0.0f || fabs(r - rim) < 1e-5);
			assert_float_equal(p.z, 0.0f, 0.0f);
			assert_float_equal(nrm_at(&m, i).z, 1.0f, 0.0f);
			/* uv is (radius, angle / 2 pi) as Mitsuba's disk. */
			assert_float_equal(m.uv[2 * i], r > 0.0f ? 1.0f : 0.0f, 0.0f);
			assert_true(m.uv[2 * i + 1] >= 0.0f &&
			    m.uv[2 * i + 1] <= 1.0f);
			if (r > 0.0f && m.uv[2 * i + 1] > 0.0f &&
			    m.uv[2 * i + 1] < 1.0f) {
				double phi = atan2(p.y, p.x);
				if (phi < 0)
					phi += 2.0 * M_PI;
				assert_near(m.uv[2 * i + 1],
				    phi / (2.0 * M_PI), 1e-5);
			}
		}
		pm_mesh_free(&m);
	}
	assert_int_equal(pm_mesh_disk(&m, 2, &err), PM_ERR_INVALID);
}

static void
test_uv_sphere_normals(void **state)
{
	struct pm_mesh m;
	struct pm_error err;
	uint32_t i, dropped;
	double worst = 0.0, area;

	(void)state;
	assert_int_equal(pm_mesh_uv_sphere(&m, 32, 64, &err), PM_OK);
	assert_int_equal(pm_mesh_validate(&m, &dropped, &err), PM_OK);
	assert_int_equal(dropped, 0);
	area = pm_mesh_area(&m);
	assert_true(area < 4.0 * M_PI && area > 0.99 * 4.0 * M_PI);
	assert_winding_matches_normals(&m);

	/* Replace the exact normals by computed ones and compare. */
	for (i = 0; i < 3 * m.nverts; i++)
		m.nrm[i] = 0.0f;
	assert_int_equal(pm_mesh_compute_normals(&m, &err), PM_OK);
	for (i = 0; i < m.nverts; i++) {
		struct pm_vec3 p = pm_mesh_vertex(&m, i), n = nrm_at(&m, i);
		double a = angle_deg(n, p);

		assert_float_equal(pm_length(n), 1.0f, 1e-5f);
		if (a > worst)
			worst = a;
	}
	assert_true(worst < 1.0);
	assert_true(worst > 0.0);	/* not trivially the same array */
	pm_mesh_free(&m);

	/* A coarse sphere's normals still point outwards. */
	assert_int_equal(pm_mesh_uv_sphere(&m, 2, 3, &err), PM_OK);
	assert_int_equal(m.ntris, 6);
	assert_int_equal(pm_mesh_compute_normals(&m, &err), PM_OK);
	for (i = 0; i < m.nverts; i++)
		assert_true(pm_dot(nrm_at(&m, i), pm_mesh_vertex(&m, i)) > 0.0f);
	pm_mesh_free(&m);
}

/*
 * A cube with shared corners: each corner meets three faces, one split
 * into two triangles there and others not.  Angle weighting gives every
 * face 90 degrees, so the normal is exactly the diagonal; weighting by
 * triangle count or area would tilt it.
 */
static void
test_normals_angle_weighted(void **state)
{
	static const uint32_t quads[6][4] = {
		{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
		{2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5},
	};
	float pos[24];
	uint32_t idx[36], q, i;
	struct pm_mesh m = {0};
	struct pm_error err;

	(void)state;
	for (i = 0; i < 8; i++) {
		pos[3 * i] = i & 1 ? 1.0f : -1.0f;
		pos[3 * i + 1] = i & 2 ? 1.0f : -1.0f;
		pos[3 * i + 2] = i & 4 ? 1.0f : -1.0f;
	}
	for (q = 0; q < 6; q++) {
		const uint32_t *v = quads[q];
		uint32_t t[6] = {v[0], v[1], v[2], v[0], v[2], v[3]};
		memcpy(idx + 6 * q, t, sizeof(t));
	}
	m.nverts = 8;
	m.ntris = 12;
	m.pos = pos;
	m.idx = idx;
	for (q = 0; q < m.ntris; q++)
		assert_true(pm_dot(geom_normal(&m, q), centroid(&m, q)) > 0.0f);
	assert_int_equal(pm_mesh_compute_normals(&m, &err), PM_OK);
	for (i = 0; i < 8; i++) {
		struct pm_vec3 want = pm_normalize(pm_mesh_vertex(&m, i));
		struct pm_vec3 n = nrm_at(&m, i);
		assert_float_equal(n.x, want.x, 1e-6f);
		assert_float_equal(n.y, want.y, 1e-6f);
		assert_float_equal(n.z, want.z, 1e-6f);
	}
	free(m.nrm);
}

/* Faces whose normals cancel: the first face's normal wins. */
static void
test_normals_cancel(void **state)
{
	float pos[] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 5, 5, 5};
	uint32_t idx[] = {0, 1, 2, 0, 2, 1};
	struct pm_mesh m = {0};
	struct pm_error err;
	uint32_t i;

	(void)state;
	m.nverts = 4;	/* vertex 3 belongs to no face */
	m.ntris = 2;
	m.pos = pos;
	m.idx = idx;
	assert_int_equal(pm_mesh_compute_normals(&m, &err), PM_OK);
	for (i = 0; i < 3; i++)
		assert_float_equal(nrm_at(&m, i).z, 1.0f, 0.0f);
	assert_float_equal(pm_length(nrm_at(&m, 3)), 1.0f, 1e-6f);

	/* Reversing the order of the faces reverses the answer. */
	idx[1] = 2;
	idx[2] = 1;
	idx[4] = 1;
	idx[5] = 2;
	assert_int_equal(pm_mesh_compute_normals(&m, &err), PM_OK);
	for (i = 0; i < 3; i++)
		assert_float_equal(nrm_at(&m, i).z, -1.0f, 0.0f);
	free(m.nrm);
}

static void
test_validate(void **state)
{
	float pos[] = {
		0, 0, 0,  1, 0, 0,  0, 1, 0,  2, 0, 0,  NAN, 0, 0,
		1, 1, 0,  INFINITY, 1, 1,
	};
	uint32_t idx[] = {
		0, 1, 2,	/* good */
		0, 1, 3,	/* collinear: zero area */
		1, 2, 4,	/* NaN vertex */
		1, 5, 2,	/* good */
		2, 2, 5,	/* repeated index */
		0, 6, 1,	/* infinite vertex */
		2, 1, 5,	/* good */
	};
	uint32_t kept[] = {0, 1, 2, 1, 5, 2, 2, 1, 5};
	uint32_t bad[] = {0, 1, 2, 0, 7, 1};
	struct pm_mesh m = {0};
	struct pm_error err;
	uint32_t dropped = 99;

	(void)state;
	m.nverts = 7;
	m.ntris = 7;
	m.pos = pos;
	m.idx = idx;
	assert_int_equal(pm_mesh_validate(&m, &dropped, &err), PM_OK);
	assert_int_equal(dropped, 4);
	assert_int_equal(m.ntris, 3);
	assert_memory_equal(m.idx, kept, sizeof(kept));

	/* An index out of range is an error that names it. */
	m.ntris = 2;
	m.idx = bad;
	err.msg[0] = '\0';
	assert_int_equal(pm_mesh_validate(&m, &dropped, &err), PM_ERR_INVALID);
	assert_int_equal(err.code, PM_ERR_INVALID);
	assert_non_null(strstr(err.msg, "7"));
	assert_non_null(strstr(err.msg, "triangle 1"));
	assert_int_equal(m.ntris, 2);
}

/* Mirrors flip the winding so that geometric and shading normals agree. */
static void
test_transform_mirror(void **state)
{
	struct pm_mesh m;
	struct pm_error err;
	struct pm_mat4 M = pm_mat4_identity();
	uint32_t t;

	(void)state;
	assert_int_equal(pm_mesh_cube(&m, &err), PM_OK);
	M = pm_mat4_mul(pm_mat4_scale(pm_v3(-2.0f, 3.0f, 0.5f)), M);
	M = pm_mat4_mul(pm_mat4_rotate(pm_v3(1, 1, 0), 30.0f), M);
	M = pm_mat4_mul(pm_mat4_translate(pm_v3(10, 0, -1)), M);
	pm_mesh_transform(&m, &M);
	assert_winding_matches_normals(&m);
	/* Still outward: away from the transformed centre. */
	for (t = 0; t < m.ntris; t++) {
		struct pm_vec3 c = pm_sub(centroid(&m, t), pm_v3(10, 0, -1));
		assert_true(pm_dot(geom_normal(&m, t), c) > 0.0f);
		assert_true(angle_deg(geom_normal(&m, t),
		    nrm_at(&m, m.idx[3 * t])) < 1e-3);
	}
	/* Area of a 4 x 6 x 1 box. */
	assert_near(pm_mesh_area(&m), 2.0 * (24 + 6 + 4), 1e-3);
	pm_mesh_free(&m);

	/* Without a mirror the winding stays as it is. */
	assert_int_equal(pm_mesh_rectangle(&m, &err), PM_OK);
	M = pm_mat4_scale(pm_v3(2.0f, 3.0f, 4.0f));
	pm_mesh_transform(&m, &M);
	assert_int_equal(m.idx[1], 1);
	assert_winding_matches_normals(&m);
	assert_near(pm_mesh_area(&m), 24.0, 1e-6);
	pm_mesh_free(&m);

	/* A mirror of the sphere with computed normals, checked per vertex. */
	assert_int_equal(pm_mesh_uv_sphere(&m, 8, 16, &err), PM_OK);
	M = pm_mat4_scale(pm_v3(1.0f, -1.0f, 2.0f));
	pm_mesh_transform(&m, &M);
	assert_winding_matches_normals(&m);
	pm_mesh_free(&m);

	/* A singular transform leaves no normals to trust. */
	assert_int_equal(pm_mesh_rectangle(&m, &err), PM_OK);
	M = pm_mat4_scale(pm_v3(1.0f, 0.0f, 1.0f));
	pm_mesh_transform(&m, &M);
	assert_null(m.nrm);
	pm_mesh_free(&m);
}

static void
test_flip(void **state)
{
	struct pm_mesh m;
	struct pm_error err;
	uint32_t t;

	(void)state;
	assert_int_equal(pm_mesh_cube(&m, &err), PM_OK);
	pm_mesh_flip(&m);
	assert_winding_matches_normals(&m);
	for (t = 0; t < m.ntris; t++)
		assert_true(pm_dot(geom_normal(&m, t), centroid(&m, t)) < 0.0f);
	assert_near(pm_mesh_area(&m), 24.0, 1e-12);
	pm_mesh_free(&m);
}

int
main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_free_zeroed),
		cmocka_unit_test(test_rectangle),
		cmocka_unit_test(test_cube),
		cmocka_unit_test(test_disk),
		cmocka_unit_test(test_uv_sphere_normals),
		cmocka_unit_test(test_normals_angle_weighted),
		cmocka_unit_test(test_normals_cancel),
		cmocka_unit_test(test_validate),
		cmocka_unit_test(test_transform_mirror),
		cmocka_unit_test(test_flip),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
