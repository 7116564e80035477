/*
 * test_obj.c: the OBJ reader on small texts written here: every index
 * form, negative indices, polygons, vertex sharing, and malformed inputs
 * that must fail naming the right line; then the Stanford bunny from
 * glmark2-data, which must load quickly.
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

#include "../../common/mesh.h"
#include "../../formats/obj.h"

#define BUNNY_OBJ "/usr/share/glmark2/models/bunny.obj"

/* cmocka's assert_float_equal works in float; these checks need double. */
#define assert_near(a, b, tol) do {					\
	double a_ = (a), b_ = (b);					\
	if (!(fabs(a_ - b_) <= (tol)))					\
		fail_msg("%s = %.17g, expected %.17g within %g", #a,	\
		    a_, b_, (double)(tol));				\
} while (0)

static enum pm_err
parse(const char *text, struct pm_mesh *m, struct pm_error *err)
{
	memset(err, 0, sizeof(*err));
	return pm_obj_parse("t.obj", text, strlen(text), m, err);
}

static struct pm_vec3
nrm_at(const struct pm_mesh *m, uint32_t i)
{
	return pm_v3(m->nrm[3 * i], m->nrm[3 * i + 1], m->nrm[3 * i + 2]);
}

static void
assert_tri(const struct pm_mesh *m, uint32_t t, uint32_t a, uint32_t b,
    uint32_t c)
{
	assert_int_equal(m->idx[3 * t], a);
	assert_int_equal(m->idx[3 * t + 1], b);
	assert_int_equal(m->idx[3 * t + 2], c);
}

/*
 * Numbers are read without strtof where that is exact (at most 7
 * significant digits, no exponent): every form, random and at the edges,
 * must give strtof's float bit for bit.
 */
static void
test_numbers_as_strtof(void **state)
{
	static const char *edge[] = { "0", "-0", "+0", "0.", ".5", "-.5",
	    "1.", "9999999", "16777217", "0.1", "0.0000000001",
	    "0.00000000001", "1e3", "-2.5E-3", "123.4567", "1234567.",
	    "0000001.5", "3.4028235e38", "1.17549435e-38", "7.0000001",
	    "0.30000001", "-0.0378297" };
	enum { NV = 3000 };
	char *text, *q, num[3 * NV][40];
	struct pm_mesh m;
	struct pm_error err;
	uint32_t x = 7, i;
	size_t n;

	(void)state;
	n = 3 * NV * 48 + NV * 16;
	text = malloc(n);
	assert_non_null(text);
	q = text;
	for (i = 0; i < 3 * NV; i++) {
		char *d = num[i];
		int k, ni, nf;

		if (i < sizeof(edge) / sizeof(edge[0])) {
			snprintf(d, sizeof(num[i]), "%s", edge[i]);
			continue;
		}
		x = x * 1664525u + 1013904223u;
		if (x >> 30 == 1)
			*d++ = '-';
		else if (x >> 30 == 2 && (x & 1))
			*d++ = '+';
		ni = (int)((x >> 20) % 9);
		nf = (int)((x >> 10) % 13);
		for (k = 0; k < ni; k++) {
			x = x * 1664525u + 1013904223u;
			*d++ = (char)('0' + (x >> 24) % 10);
		}
		if (nf > 0 || ni == 0)
			*d++ = '.';
		for (k = 0; k < nf || (ni == 0 && k == 0); k++) {
			x = x * 1664525u + 1013904223u;
			*d++ = (char)('0' + (x >> 24) % 10);
		}
		if ((x >> 8) % 16 == 0)
			d += sprintf(d, "e%d", (int)((x >> 4) % 21) - 10);
		*d = '\0';
	}
	for (i = 0; i < NV; i++)
		q += sprintf(q, "v %s %s %s\n", num[3 * i], num[3 * i + 1],
		    num[3 * i + 2]);
	for (i = 0; i < NV; i += 3)
		q += sprintf(q, "f %u %u %u\n", i + 1, i + 2, i + 3);
	assert_int_equal(parse(text, &m, &err), PM_OK);
	assert_int_equal(m.nverts, NV);
	for (i = 0; i < 3 * NV; i++) {
		float want = strtof(num[i], NULL);

		if (memcmp(&want, &m.pos[i], sizeof(want)) != 0)
			fail_msg("'%s': %.9g, strtof gives %.9g", num[i],
			    m.pos[i], want);
	}
	pm_mesh_free(&m);
	free(text);
}

static void
test_triangle(void **state)
{
	struct pm_mesh m;
	struct pm_error err;
	uint32_t i;

	(void)state;
	assert_int_equal(parse("# a triangle\nv 0 0 0\nv 1 0 0\nv 0 1 0\n"
	    "f 1 2 3\n", &m, &err), PM_OK);
	assert_int_equal(m.nverts, 3);
	assert_int_equal(m.ntris, 1);
	assert_null(m.nrm);
	assert_null(m.uv);
	assert_tri(&m, 0, 0, 1, 2);
	for (i = 0; i < 3; i++) {
		struct pm_vec3 p = pm_mesh_vertex(&m, i);
		assert_float_equal(p.x, i == 1, 0.0f);
		assert_float_equal(p.y, i == 2, 0.0f);
		assert_float_equal(p.z, 0.0f, 0.0f);
	}
	pm_mesh_free(&m);
}

/* Polygons are fans from the first corner; the area shows nothing lost. */
static void
test_polygons(void **state)
{
	struct pm_mesh m;
	struct pm_error err;
	uint32_t t;

	(void)state;
	assert_int_equal(parse("v 0 0 0\nv 2 0 0\nv 2 1 0\nv 0 1 0\n"
	    "f 1 2 3 4\n", &m, &err), PM_OK);
	assert_int_equal(m.ntris, 2);
	assert_tri(&m, 0, 0, 1, 2);
	assert_tri(&m, 1, 0, 2, 3);
	assert_near(pm_mesh_area(&m), 2.0, 1e-12);
	pm_mesh_free(&m);

	/* A regular hexagon of circumradius 1 has area 3 sqrt(3) / 2. */
	{
		char text[512];
		size_t n = 0;
		int k;

		for (k = 0; k < 6; k++)
			n += (size_t)snprintf(text + n, sizeof(text) - n,
			    "v %.9f %.9f 0\n", cos(k * M_PI / 3), sin(k * M_PI / 3));
		snprintf(text + n, sizeof(text) - n, "f 1 2 3 4 5 6\n");
		assert_int_equal(parse(text, &m, &err), PM_OK);
		assert_int_equal(m.ntris, 4);
		for (t = 0; t < m.ntris; t++)
			assert_tri(&m, t, 0, t + 1, t + 2);
		assert_near(pm_mesh_area(&m), 1.5 * sqrt(3.0), 1e-6);
		pm_mesh_free(&m);
	}
}

static void
test_index_forms(void **state)
{
	const char *base = "v 0 0 0\nv 1 0 0\nv 0 1 0\n"
	    "vt 0.25 0.75\nvt 1 0\nvt 0 1\nvn 0 0 2\nvn 0 0 1\nvn 0 0 1\n";
	char text[512];
	struct pm_mesh m;
	struct pm_error err;

	(void)state;
	snprintf(text, sizeof(text), "%sf 1/1 2/2 3/3\n", base);
	assert_int_equal(parse(text, &m, &err), PM_OK);
	assert_int_equal(m.nverts, 3);
	assert_null(m.nrm);
	assert_non_null(m.uv);
	/* Stored as (u, 1 - v), Mitsuba's default flip. */
	assert_float_equal(m.uv[0], 0.25f, 0.0f);
	assert_float_equal(m.uv[1], 0.25f, 0.0f);
	assert_float_equal(m.uv[2], 1.0f, 0.0f);
	assert_float_equal(m.uv[3], 1.0f, 0.0f);
	assert_float_equal(m.uv[5], 0.0f, 0.0f);
	pm_mesh_free(&m);

	snprintf(text, sizeof(text), "%sf 1//1 2//2 3//3\n", base);
	assert_int_equal(parse(text, &m, &err), PM_OK);
	assert_null(m.uv);
	assert_non_null(m.nrm);
	/* Normalised on the way in. */
	assert_float_equal(nrm_at(&m, 0).z, 1.0f, 0.0f);
	pm_mesh_free(&m);

	snprintf(text, sizeof(text), "%sf 1/1/1 2/2/2 3/3/3\n", base);
	assert_int_equal(parse(text, &m, &err), PM_OK);
	assert_non_null(m.uv);
	assert_non_null(m.nrm);
	assert_float_equal(m.uv[0], 0.25f, 0.0f);
	pm_mesh_free(&m);

	/* vt with only u: v defaults to 0, stored as 1. */
	assert_int_equal(parse("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0.5\n"
	    "f 1/1 2/1 3/1\n", &m, &err), PM_OK);
	assert_float_equal(m.uv[1], 1.0f, 0.0f);
	pm_mesh_free(&m);

	/* Normals are dropped unless every face vertex has one. */
	snprintf(text, sizeof(text), "%sv 1 1 0\nf 1//1 2//2 3//3\nf 2 4 3\n",
	    base);
	assert_int_equal(parse(text, &m, &err), PM_OK);
	assert_null(m.nrm);
	assert_int_equal(m.ntris, 2);
	pm_mesh_free(&m);
}

static void
test_negative_indices(void **state)
{
	struct pm_mesh a, b;
	struct pm_error err;

	(void)state;
	assert_int_equal(parse("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
	    "f 1 2 3 4\n", &a, &err), PM_OK);
	assert_int_equal(parse("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
	    "f -4 -3 -2 -1\n", &b, &err), PM_OK);
	assert_int_equal(a.nverts, b.nverts);
	assert_int_equal(a.ntris, b.ntris);
	assert_memory_equal(a.pos, b.pos, 3 * a.nverts * sizeof(float));
	assert_memory_equal(a.idx, b.idx, 3 * a.ntris * sizeof(uint32_t));
	pm_mesh_free(&a);
	pm_mesh_free(&b);

	/* Relative to what is defined so far, for vt and vn too. */
	assert_int_equal(parse("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\n"
	    "f -3/-1/-1 -2/-1/-1 -1/-1/-1\n"
	    "v 5 5 5\nvt 1 1\nvn 1 0 0\n"
	    "f -4/-1/-1 -3/-1/-1 -1/-1/-1\n", &a, &err), PM_OK);
	assert_int_equal(a.ntris, 2);
	assert_int_equal(a.nverts, 6);
	assert_float_equal(pm_mesh_vertex(&a, a.idx[5]).x, 5.0f, 0.0f);
	assert_float_equal(nrm_at(&a, a.idx[3]).x, 1.0f, 0.0f);
	assert_float_equal(nrm_at(&a, a.idx[0]).z, 1.0f, 0.0f);
	pm_mesh_free(&a);
}

/* Vertices are shared exactly when their (v, vt, vn) triples match. */
static void
test_dedup(void **state)
{
	static const char *cube =
	    "v -1 -1 -1\nv 1 -1 -1\nv -1 1 -1\nv 1 1 -1\n"
	    "v -1 -1 1\nv 1 -1 1\nv -1 1 1\nv 1 1 1\n"
	    "vn -1 0 0\nvn 1 0 0\nvn 0 -1 0\nvn 0 1 0\nvn 0 0 -1\nvn 0 0 1\n"
	    "f 1//5 3//5 4//5 2//5\nf 5//6 6//6 8//6 7//6\n"
	    "f 1//3 2//3 6//3 5//3\nf 3//4 7//4 8//4 4//4\n"
	    "f 1//1 5//1 7//1 3//1\nf 2//2 4//2 8//2 6//2\n";
	struct pm_mesh m;
	struct pm_error err;
	uint32_t t, k;

	(void)state;
	/* Two quads sharing an edge: six vertices, not eight. */
	assert_int_equal(parse("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
	    "v 2 0 0\nv 2 1 0\nf 1 2 3 4\nf 2 5 6 3\n", &m, &err), PM_OK);
	assert_int_equal(m.nverts, 6);
	assert_int_equal(m.ntris, 4);
	pm_mesh_free(&m);

	/* A cube with face normals: 8 positions become 24 vertices. */
	assert_int_equal(parse(cube, &m, &err), PM_OK);
	assert_int_equal(m.nverts, 24);
	assert_int_equal(m.ntris, 12);
	assert_near(pm_mesh_area(&m), 24.0, 1e-9);
	for (t = 0; t < m.ntris; t++) {
		struct pm_vec3 a = pm_mesh_vertex(&m, m.idx[3 * t]);
		struct pm_vec3 b = pm_mesh_vertex(&m, m.idx[3 * t + 1]);
		struct pm_vec3 c = pm_mesh_vertex(&m, m.idx[3 * t + 2]);
		struct pm_vec3 g = pm_normalize(pm_cross(pm_sub(b, a),
		    pm_sub(c, a)));
		for (k = 0; k < 3; k++)
			assert_float_equal(pm_dot(g, nrm_at(&m, m.idx[3 * t + k])),
			    1.0f, 1e-6f);
	}
	pm_mesh_free(&m);

	/* Unused positions are not vertices of the mesh (the Cornell box
	 * floor lists holes it never uses). */
	assert_int_equal(parse("v 0 0 0\nv 9 9 9\nv 1 0 0\nv 0 1 0\nf 1 3 4\n",
	    &m, &err), PM_OK);
	assert_int_equal(m.nverts, 3);
	pm_mesh_free(&m);
}

static void
test_ignored_statements(void **state)
{
	struct pm_mesh m;
	struct pm_error err;

	(void)state;
	assert_int_equal(parse("mtllib box.mtl\no box\ng side\ns off\n"
	    "usemtl white\n\n   \t\n# comment\nv 0 0 0 # origin\n"
	    "v 1 0 0 1.0\nv\t0\t1\t0\nvp 0.5\nl 1 2\np 1\n"
	    "f 1 2 3 # done\n", &m, &err), PM_OK);
	assert_int_equal(m.ntris, 1);
	pm_mesh_free(&m);

	/* CRLF line ends, no newline at the end. */
	assert_int_equal(parse("v 0 0 0\r\nv 1 0 0\r\nv 0 1 0\r\nf 1 2 3",
	    &m, &err), PM_OK);
	assert_int_equal(m.ntris, 1);
	pm_mesh_free(&m);
}

struct bad_case {
	const char *text;
	unsigned line;		/* 0: the message names no line */
	const char *words;	/* a piece of the message */
};

static void
test_malformed(void **state)
{
	static const struct bad_case cases[] = {
		{"v 1 2\n", 1, "expected 3 numbers"},
		{"v 1 2 3\nv 1 x 3\n", 2, "'x'"},
		{"v 1 2 3\nv 1 2 3x\n", 2, "expected"},
		{"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n", 4, "face with 2"},
		{"v 0 0 0\nv 1 0 0\nv 0 1 0\n\nf 1 2 4\n", 5, "out of range"},
		{"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", 4, "index 0"},
		{"v 0 0 0\nv 1 0 0\nv 0 1 0\nf -4 1 2\n", 4, "out of range"},
		{"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/5 2/5 3/5\n", 4,
		    "texture coordinate index 5"},
		{"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1//1 2//1 3//1\n", 4,
		    "normal index 1"},
		{"v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/ 2/ 3/\n", 5,
		    "texture coordinate index"},
		{"v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1// 2// 3//\n", 5,
		    "normal index"},
		{"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3x\n", 4, "face corner"},
		{"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 a\n", 4, "vertex index"},
		{"vn 1 2\n", 1, "after 'vn'"},
		{"vt\n", 1, "after 'vt'"},
		{"vt 1 2 3 4\n", 1, "end of line"},
		{"# c\r\n# c\r\nv 1 2\r\n", 3, "expected"},
		{"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2", 4, "face with 2"},
		{"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 3 9999999999999\n",
		    5, "out of range"},
		{"", 0, "no faces"},
		{"# only a comment\n", 0, "no faces"},
		{"v 0 0 0\nv 1 0 0\nv 0 1 0\n", 0, "no faces"},
	};
	size_t i;

	(void)state;
	for (i = 0; i < sizeof(cases) / sizeof(cases[0]); i++) {
		struct pm_mesh m;
		struct pm_error err;
		char where[32];
		enum pm_err e = parse(cases[i].text, &m, &err);

		if (e == PM_OK)
			fail_msg("case %zu parsed", i);
		assert_int_equal(err.code, e);
		assert_null(m.pos);
		assert_null(m.idx);
		if (cases[i].line > 0) {
			snprintf(where, sizeof(where), "t.obj:%u:",
			    cases[i].line);
			if (strncmp(err.msg, where, strlen(where)) != 0)
				fail_msg("case %zu: '%s' lacks '%s'", i, err.msg,
				    where);
		} else if (strncmp(err.msg, "t.obj:", 6) != 0)
			fail_msg("case %zu: '%s' names no file", i, err.msg);
		if (strstr(err.msg, cases[i].words) == NULL)
			fail_msg("case %zu: '%s' lacks '%s'", i, err.msg,
			    cases[i].words);
	}
}

/* Every prefix of a valid file either parses or fails cleanly. */
static void
test_truncated_prefixes(void **state)
{
	static const char text[] = "v 0 0 0\nv 1.5e0 0 0\nv 0 1 0\nv 1 1 0\n"
	    "vt 0 0\nvt 1 0\nvt 0 1\nvt 1 1\nvn 0 0 1\n"
	    "f 1/1/1 2/2/1 4/4/1 3/3/1\n";
	size_t len = sizeof(text) - 1, n;
	int ok = 0;

	(void)state;
	for (n = 0; n <= len; n++) {
		struct pm_mesh m;
		struct pm_error err;
		enum pm_err e = pm_obj_parse("t.obj", text, n, &m, &err);

		if (e == PM_OK) {
			assert_true(m.ntris >= 1);
			ok++;
			pm_mesh_free(&m);
		} else
			assert_null(m.pos);
	}
	/*
	 * Cut inside the face, a prefix parses when its third or fourth
	 * corner is complete in some form: "4", "4/4", "4/4/1", "4/4/1 ",
	 * "3", "3/3", "3/3/1" and the whole text; "4/" and "3/3/" fail.
	 */
	assert_int_equal(ok, 8);
}

static void
test_nan_dropped_by_validate(void **state)
{
	struct pm_mesh m;
	struct pm_error err;
	uint32_t dropped;

	(void)state;
	assert_int_equal(parse("v 0 0 0\nv 1 0 0\nv 0 1 0\nv nan 0 0\n"
	    "v 1 1 0\nf 1 2 3\nf 2 4 3\nf 2 5 3\n", &m, &err), PM_OK);
	assert_int_equal(m.ntris, 3);
	assert_true(isnan(pm_mesh_vertex(&m, m.idx[4]).x));
	assert_int_equal(pm_mesh_validate(&m, &dropped, &err), PM_OK);
	assert_int_equal(dropped, 1);
	assert_int_equal(m.ntris, 2);
	assert_near(pm_mesh_area(&m), 1.0, 1e-9);
	pm_mesh_free(&m);
}

static void
test_read_file(void **state)
{
	char path[] = "/tmp/pm-test-obj-XXXXXX";
	struct pm_mesh m;
	struct pm_error err;
	FILE *f;
	int fd;

	(void)state;
	fd = mkstemp(path);
	assert_true(fd >= 0);
	f = fdopen(fd, "w");
	assert_non_null(f);
	fputs("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2\n", f);
	fclose(f);
	assert_int_equal(pm_obj_read(path, &m, &err), PM_ERR_PARSE);
	/* The path is in the message, with the line. */
	assert_non_null(strstr(err.msg, path));
	assert_non_null(strstr(err.msg, ":5:"));
	unlink(path);
	assert_int_equal(pm_obj_read(path, &m, &err), PM_ERR_IO);
	assert_non_null(strstr(err.msg, path));
}

static void
test_bunny(void **state)
{
	struct pm_mesh m;
	struct pm_error err;
	uint32_t dropped, faces = 0, verts = 0;
	char line[256];
	FILE *f;

	(void)state;
	if ((f = fopen(BUNNY_OBJ, "r")) == NULL) {
		print_message("skipped: %s not installed (glmark2-data)\n",
		    BUNNY_OBJ);
		skip();
	}
	/* Count statements independently (the bunny has only triangles). */
	while (fgets(line, sizeof(line), f) != NULL) {
		faces += line[0] == 'f' && line[1] == ' ';
		verts += line[0] == 'v' && line[1] == ' ';
	}
	fclose(f);

	/* Its parse time is a benchmark's business, not a test's: a test
	 * that times itself fails on a loaded machine. */
	assert_int_equal(pm_obj_read(BUNNY_OBJ, &m, &err), PM_OK);
	assert_int_equal(m.ntris, faces);
	assert_true(m.nverts <= verts && m.nverts > verts * 9 / 10);
	assert_true(m.nverts > 30000 && m.ntris > 60000);
	assert_null(m.uv);
	assert_int_equal(pm_mesh_validate(&m, &dropped, &err), PM_OK);
	assert_true(dropped < 100);
	assert_int_equal(pm_mesh_compute_normals(&m, &err), PM_OK);
	assert_true(pm_mesh_area(&m) > 0.0);
	pm_mesh_free(&m);
}

int
main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_triangle),
		cmocka_unit_test(test_polygons),
		cmocka_unit_test(test_index_forms),
		cmocka_unit_test(test_negative_indices),
		cmocka_unit_test(test_dedup),
		cmocka_unit_test(test_ignored_statements),
		cmocka_unit_test(test_malformed),
		cmocka_unit_test(test_truncated_prefixes),
		cmocka_unit_test(test_nan_dropped_by_validate),
		cmocka_unit_test(test_read_file),
		cmocka_unit_test(test_bunny),
		cmocka_unit_test(test_numbers_as_strtof),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
