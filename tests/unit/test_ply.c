/*
 * test_ply.c: the PLY reader on files this test writes itself, in ASCII,
 * little- and big-endian binary with assorted types and extra elements
 * and properties, which must all give the same mesh; truncated files,
 * absurd counts and malformed headers, which must fail cleanly; and the
 * Stanford bunny from Mitsuba's data when it is present.
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
#include "../../formats/ply.h"

#define BUNNY_PLY "/work/shared/scenes/bunny.ply"

enum { F_ASCII, F_LE, F_BE };

/* A growable byte buffer for writing test files. */
struct wbuf {
	unsigned char b[8192];
	size_t n;
};

/* cmocka's assert_float_equal works in float; these checks need double. */
#define assert_near(a, b, tol) do {					\
	double a_ = (a), b_ = (b);					\
	if (!(fabs(a_ - b_) <= (tol)))					\
		fail_msg("%s = %.17g, expected %.17g within %g", #a,	\
		    a_, b_, (double)(tol));				\
} while (0)

static void
put(struct wbuf *w, const void *p, size_t n)
{
	assert_true(w->n + n <= sizeof(w->b));
	memcpy(w->b + w->n, p, n);
	w->n += n;
}

static void
putf(struct wbuf *w, const char *fmt, ...)
{
	va_list ap;
	int n;

	va_start(ap, fmt);
	n = vsnprintf((char *)w->b + w->n, sizeof(w->b) - w->n, fmt, ap);
	va_end(ap);
	assert_true(n >= 0 && w->n + (size_t)n < sizeof(w->b));
	w->n += (size_t)n;
}

/*
 * Writes value v as type t ('b' int8, 'B' uint8, 'h' int16, 'H' uint16,
 * 'i' int32, 'I' uint32, 'f' float, 'd' double) in format fmt.
 */
static void
put_val(struct wbuf *w, int fmt, char t, double v)
{
	unsigned char raw[8], out[8];
	size_t n = 0, k;

	if (fmt == F_ASCII) {
		if (t == 'f' || t == 'd')
			putf(w, "%.17g ", v);
		else
			putf(w, "%lld ", (long long)v);
		return;
	}
	switch (t) {
	case 'b': { int8_t x = (int8_t)v; memcpy(raw, &x, n = 1); break; }
	case 'B': { uint8_t x = (uint8_t)v; memcpy(raw, &x, n = 1); break; }
	case 'h': { int16_t x = (int16_t)v; memcpy(raw, &x, n = 2); break; }
	case 'H': { uint16_t x = (uint16_t)v; memcpy(raw, &x, n = 2); break; }
	case 'i': { int32_t x = (int32_t)v; memcpy(raw, &x, n = 4); break; }
	case 'I': { uint32_t x = (uint32_t)v; memcpy(raw, &x, n = 4); break; }
	case 'f': { float x = (float)v; memcpy(raw, &x, n = 4); break; }
	case 'd': { double x = v; memcpy(raw, &x, n = 8); break; }
	default: fail();
	}
	/* The test machine is little-endian; big-endian reverses. */
	for (k = 0; k < n; k++)
		out[k] = fmt == F_BE ? raw[n - 1 - k] : raw[k];
	put(w, out, n);
}

static void
end_elem(struct wbuf *w, int fmt)
{
	if (fmt == F_ASCII)
		putf(w, "\n");
}

/* A square pyramid: one quad base and four triangles. */
static const float P[5][3] = {
	{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0.5f, 0.5f, 1},
};
static const float N[5][3] = {
	{0, 0, -2}, {0, 0, -1}, {0.6f, 0, 0.8f}, {0, 0.6f, -0.8f}, {0, 0, 1},
};
static const float UV[5][2] = {
	{0, 0}, {1, 0}, {1, 1}, {0, 1}, {0.5f, 0.25f},
};
static const int FACES[5][5] = {
	{4, 0, 3, 2, 1}, {3, 0, 1, 4}, {3, 1, 2, 4}, {3, 2, 3, 4}, {3, 3, 0, 4},
};

static const char *
tname(char t)
{
	switch (t) {
	case 'b': return "char";
	case 'B': return "uchar";
	case 'h': return "int16";
	case 'H': return "ushort";
	case 'i': return "int";
	case 'I': return "uint32";
	case 'f': return "float";
	default:  return "double";
	}
}

/*
 * Writes the pyramid.  Variant 0: float positions, "u v", uchar/int
 * index lists.  Variant 1: double positions, "s t", ushort/uint lists.
 * Both carry properties and elements pm must skip, lists included.
 */
static void
make_pyramid(struct wbuf *w, int fmt, int variant)
{
	static const char *fmts[] = {"ascii", "binary_little_endian",
	    "binary_big_endian"};
	char pt = variant ? 'd' : 'f', ct = variant ? 'H' : 'B';
	char it = variant ? 'I' : 'i';
	int i, k;

	w->n = 0;
	putf(w, "ply\nformat %s 1.0\ncomment written by test_ply\n", fmts[fmt]);
	putf(w, "obj_info nothing\nelement material 2\nproperty float shine\n"
	    "property list uchar short tags\n");
	putf(w, "element vertex 5\nproperty %s x\nproperty %s y\n"
	    "property %s z\n", tname(pt), tname(pt), tname(pt));
	putf(w, "property uchar red\nproperty float nx\nproperty float ny\n"
	    "property float nz\nproperty list uchar float junk\n");
	putf(w, "property float %s\nproperty double %s\n", variant ? "s" : "u",
	    variant ? "t" : "v");
	putf(w, "element edge 1\nproperty int vertex1\nproperty int vertex2\n");
	putf(w, "element face 5\nproperty uchar flags\n"
	    "property list %s %s vertex_indices\nproperty float quality\n"
	    "end_header\n", tname(ct), tname(it));

	for (i = 0; i < 2; i++) {
		put_val(w, fmt, 'f', 0.5 * i);
		put_val(w, fmt, 'B', i + 1);
		for (k = 0; k <= i; k++)
			put_val(w, fmt, 'h', -k);
		end_elem(w, fmt);
	}
	for (i = 0; i < 5; i++) {
		for (k = 0; k < 3; k++)
			put_val(w, fmt, pt, P[i][k]);
		put_val(w, fmt, 'B', 200);
		for (k = 0; k < 3; k++)
			put_val(w, fmt, 'f', N[i][k]);
		put_val(w, fmt, 'B', i % 3);
		for (k = 0; k < i % 3; k++)
			put_val(w, fmt, 'f', 1.25 * k);
		put_val(w, fmt, 'f', UV[i][0]);
		put_val(w, fmt, 'd', UV[i][1]);
		end_elem(w, fmt);
	}
	put_val(w, fmt, 'i', 0);
	put_val(w, fmt, 'i', 1);
	end_elem(w, fmt);
	for (i = 0; i < 5; i++) {
		put_val(w, fmt, 'B', 7);
		put_val(w, fmt, ct, FACES[i][0]);
		for (k = 1; k <= FACES[i][0]; k++)
			put_val(w, fmt, it, FACES[i][k]);
		put_val(w, fmt, 'f', 0.5);
		end_elem(w, fmt);
	}
}

static enum pm_err
parse(const struct wbuf *w, struct pm_mesh *m, struct pm_error *err)
{
	memset(err, 0, sizeof(*err));
	return pm_ply_parse("t.ply", w->b, w->n, m, err);
}

static enum pm_err
parse_text(const char *text, struct pm_mesh *m, struct pm_error *err)
{
	memset(err, 0, sizeof(*err));
	return pm_ply_parse("t.ply", (const unsigned char *)text, strlen(text),
	    m, err);
}

/* The pyramid as it should come out. */
static void
check_pyramid(const struct pm_mesh *m)
{
	static const uint32_t tris[6][3] = {
		{0, 3, 2}, {0, 2, 1}, {0, 1, 4}, {1, 2, 4}, {2, 3, 4}, {3, 0, 4},
	};
	uint32_t i, k;

	assert_int_equal(m->nverts, 5);
	assert_int_equal(m->ntris, 6);
	assert_non_null(m->nrm);
	assert_non_null(m->uv);
	for (i = 0; i < 5; i++) {
		struct pm_vec3 n = pm_normalize(pm_v3(N[i][0], N[i][1], N[i][2]));
		for (k = 0; k < 3; k++)
			assert_float_equal(m->pos[3 * i + k], P[i][k], 0.0f);
		assert_float_equal(m->nrm[3 * i], n.x, 1e-7f);
		assert_float_equal(m->nrm[3 * i + 1], n.y, 1e-7f);
		assert_float_equal(m->nrm[3 * i + 2], n.z, 1e-7f);
		assert_float_equal(m->uv[2 * i], UV[i][0], 0.0f);
		assert_float_equal(m->uv[2 * i + 1], UV[i][1], 0.0f);
	}
	for (i = 0; i < 6; i++)
		for (k = 0; k < 3; k++)
			assert_int_equal(m->idx[3 * i + k], tris[i][k]);
	/* Base 1 plus four triangles of base 1 and slant height sqrt(5)/2. */
	assert_near(pm_mesh_area(m), 1.0 + sqrt(5.0), 1e-6);
}

static void
assert_same_mesh(const struct pm_mesh *a, const struct pm_mesh *b)
{
	assert_int_equal(a->nverts, b->nverts);
	assert_int_equal(a->ntris, b->ntris);
	assert_memory_equal(a->pos, b->pos, 3 * a->nverts * sizeof(float));
	assert_memory_equal(a->nrm, b->nrm, 3 * a->nverts * sizeof(float));
	assert_memory_equal(a->uv, b->uv, 2 * a->nverts * sizeof(float));
	assert_memory_equal(a->idx, b->idx, 3 * a->ntris * sizeof(uint32_t));
}

static void
test_formats_agree(void **state)
{
	struct wbuf *w = malloc(sizeof(*w));
	struct pm_mesh ref, m;
	struct pm_error err;
	int fmt, variant;

	(void)state;
	assert_non_null(w);
	make_pyramid(w, F_ASCII, 0);
	if (parse(w, &ref, &err) != PM_OK)
		fail_msg("%s", err.msg);
	check_pyramid(&ref);
	for (variant = 0; variant < 2; variant++)
		for (fmt = F_ASCII; fmt <= F_BE; fmt++) {
			make_pyramid(w, fmt, variant);
			if (parse(w, &m, &err) != PM_OK)
				fail_msg("format %d variant %d: %s", fmt,
				    variant, err.msg);
			assert_same_mesh(&ref, &m);
			pm_mesh_free(&m);
		}
	pm_mesh_free(&ref);
	free(w);
}

/* A big-endian file written byte by byte, so the test does not rely on
 * its own encoder: one triangle with short coordinates and uint indices. */
static void
test_big_endian_bytes(void **state)
{
	static const char head[] = "ply\nformat binary_big_endian 1.0\n"
	    "element vertex 3\nproperty short x\nproperty short y\n"
	    "property short z\nelement face 1\n"
	    "property list uchar uint vertex_index\nend_header\n";
	static const unsigned char data[] = {
		0x00, 0x00, 0x00, 0x00, 0x00, 0x00,	/* (0, 0, 0) */
		0x01, 0x00, 0x00, 0x00, 0xff, 0xfe,	/* (256, 0, -2) */
		0x00, 0x00, 0x00, 0x02, 0x00, 0x03,	/* (0, 2, 3) */
		0x03, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x01,
		0x00, 0x00, 0x00, 0x02,
	};
	unsigned char buf[512];
	struct pm_mesh m;
	struct pm_error err;

	(void)state;
	memcpy(buf, head, sizeof(head) - 1);
	memcpy(buf + sizeof(head) - 1, data, sizeof(data));
	assert_int_equal(pm_ply_parse("be.ply", buf, sizeof(head) - 1 +
	    sizeof(data), &m, &err), PM_OK);
	assert_int_equal(m.nverts, 3);
	assert_int_equal(m.ntris, 1);
	assert_null(m.nrm);
	assert_null(m.uv);
	assert_float_equal(m.pos[3], 256.0f, 0.0f);
	assert_float_equal(m.pos[5], -2.0f, 0.0f);
	assert_float_equal(m.pos[7], 2.0f, 0.0f);
	assert_float_equal(m.pos[8], 3.0f, 0.0f);
	assert_int_equal(m.idx[2], 2);
	pm_mesh_free(&m);
}

/* Every proper prefix of a binary file fails as truncated, cleanly. */
static void
test_truncated(void **state)
{
	struct wbuf *w = malloc(sizeof(*w));
	struct pm_mesh m;
	struct pm_error err;
	size_t n, header;
	int fmt, ok;

	(void)state;
	assert_non_null(w);
	for (fmt = F_LE; fmt <= F_BE; fmt++) {
		make_pyramid(w, fmt, fmt == F_BE);
		header = (size_t)((unsigned char *)strstr((char *)w->b,
		    "end_header\n") - w->b) + strlen("end_header\n");
		for (n = 0; n < w->n; n++) {
			enum pm_err e = pm_ply_parse("t.ply", w->b, n, &m, &err);
			assert_int_not_equal(e, PM_OK);
			assert_int_equal(err.code, e);
			assert_null(m.pos);
			if (n >= header - 1 && e != PM_ERR_TRUNCATED)
				fail_msg("cut at %zu: %s", n, err.msg);
		}
	}
	/* ASCII prefixes may end on a number boundary, so only some fail;
	 * none may crash or leak. */
	make_pyramid(w, F_ASCII, 0);
	for (n = 0, ok = 0; n < w->n; n++) {
		enum pm_err e = pm_ply_parse("t.ply", w->b, n, &m, &err);
		if (e == PM_OK) {
			ok++;
			pm_mesh_free(&m);
		} else
			assert_true(e == PM_ERR_TRUNCATED || e == PM_ERR_PARSE ||
			    e == PM_ERR_FORMAT);
	}
	assert_true(ok < 10);
	free(w);
}

struct bad_case {
	const char *text;
	enum pm_err code;
	const char *words;	/* a piece of the message */
};

static void
test_bad_inputs(void **state)
{
#define V3 "element vertex 3\nproperty float x\nproperty float y\n" \
	"property float z\n"
#define F1 "element face 1\nproperty list uchar int vertex_indices\n"
#define A "ply\nformat ascii 1.0\n"
#define OK3 "0 0 0\n1 0 0\n0 1 0\n"
	static const struct bad_case cases[] = {
		{"plx\n", PM_ERR_FORMAT, "t.ply:1: expected 'ply'"},
		{"", PM_ERR_TRUNCATED, "header"},
		{"ply\n" V3 F1 "end_header\n", PM_ERR_FORMAT, "no 'format'"},
		{"ply\nformat binary_middle_endian 1.0\n", PM_ERR_FORMAT,
		    "t.ply:2:"},
		{"ply\nformat ascii 2.0\n", PM_ERR_UNSUPPORTED, "version"},
		{A "property float x\n", PM_ERR_FORMAT, "before any"},
		{A "element vertex 3\nproperty float128 x\n", PM_ERR_FORMAT,
		    "t.ply:4: type 'float128'"},
		{A "element vertex 3\nproperty list float int x\n",
		    PM_ERR_FORMAT, "count type"},
		{A V3 F1, PM_ERR_TRUNCATED, "end_header"},
		{A V3 F1 "end_header extra\n", PM_ERR_FORMAT, "after"},
		{A "elephant 3\n", PM_ERR_FORMAT, "t.ply:3: 'elephant'"},
		{A V3 "element vertex 2\n", PM_ERR_FORMAT, "twice"},
		{A "element vertex 3\nproperty float x\nproperty float y\n" F1
		    "end_header\n" "0 0\n1 0\n0 1\n3 0 1 2\n", PM_ERR_FORMAT,
		    "lacks scalar property z"},
		{A V3 "end_header\n" OK3, PM_ERR_UNSUPPORTED, "no 'face'"},
		{A V3 "element face 1\nproperty list uchar float "
		    "vertex_indices\nend_header\n", PM_ERR_FORMAT,
		    "floating-point"},
		{A V3 "element face 1\nproperty list uchar int other\n"
		    "end_header\n", PM_ERR_FORMAT, "vertex_indices"},
		{A V3 "element face 1\nend_header\n", PM_ERR_FORMAT,
		    "no properties"},
		/* Absurd counts fail before anything is allocated. */
		{A "element vertex 4000000000\nproperty float x\n"
		    "property float y\nproperty float z\n" F1 "end_header\n"
		    OK3 "3 0 1 2\n", PM_ERR_TRUNCATED, "4000000000 'vertex'"},
		{A "element vertex 99999999999999\nproperty float x\n"
		    "property float y\nproperty float z\n" F1 "end_header\n",
		    PM_ERR_LIMIT, "99999999999999"},
		{A "element vertex 99999999999999999999999\n", PM_ERR_FORMAT,
		    "element count"},
		{A V3 "element face 3000000000\n"
		    "property list uchar int vertex_indices\nend_header\n" OK3
		    "3 0 1 2\n", PM_ERR_TRUNCATED, "3000000000 'face'"},
		{"ply\nformat binary_little_endian 1.0\n" V3
		    "element face 1\nproperty list int int vertex_indices\n"
		    "end_header\n"
		    "\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0"
		    "\0\0\0\0\0\0\0\0\0\0\0\0\xff\xff\xff\x7f",
		    PM_ERR_TRUNCATED, "'face' element 0"},
		/* ASCII values. */
		{A V3 F1 "end_header\n0 0 0\n1 abc 0\n0 1 0\n3 0 1 2\n",
		    PM_ERR_PARSE, "t.ply:11: 'abc'"},
		{A V3 F1 "end_header\n" OK3 "300 0 1 2\n", PM_ERR_PARSE,
		    "t.ply:13: '300'"},
		{A V3 F1 "end_header\n" OK3 "3 0 1.5 2\n", PM_ERR_PARSE,
		    "'1.5'"},
		{A V3 F1 "end_header\n" OK3 "3 0 1\n", PM_ERR_TRUNCATED,
		    "file ends inside 'face' element 0"},
		/* Faces. */
		{A V3 F1 "end_header\n" OK3 "3 0 1 3\n", PM_ERR_FORMAT,
		    "vertex index 3 out of range"},
		{A V3 F1 "end_header\n" OK3 "3 0 -1 2\n", PM_ERR_FORMAT,
		    "vertex index -1"},
		{A V3 F1 "end_header\n" OK3 "2 0 1\n", PM_ERR_FORMAT,
		    "face 0 has 2 vertices"},
		{A V3 "element face 1\nproperty list char int vertex_indices\n"
		    "end_header\n" OK3 "-3 0 1 2\n", PM_ERR_FORMAT, "count"},
		{A V3 "element face 0\nproperty list uchar int vertex_indices\n"
		    "end_header\n" OK3, PM_ERR_FORMAT, "no faces"},
	};
#undef V3
#undef F1
#undef A
#undef OK3
	size_t i;

	(void)state;
	for (i = 0; i < sizeof(cases) / sizeof(cases[0]); i++) {
		struct pm_mesh m;
		struct pm_error err;
		const char *t = cases[i].text;
		size_t len = strlen(t);
		enum pm_err e;

		/* The binary case carries NUL bytes: measure it by its tail. */
		if (strstr(t, "binary_little_endian") != NULL)
			len = (size_t)(strstr(t, "end_header\n") - t) + 11 + 40;
		memset(&err, 0, sizeof(err));
		e = pm_ply_parse("t.ply", (const unsigned char *)t, len, &m,
		    &err);
		if (e != cases[i].code)
			fail_msg("case %zu: got %d (%s), expected %d", i, e,
			    err.msg, cases[i].code);
		assert_null(m.pos);
		if (strstr(err.msg, cases[i].words) == NULL)
			fail_msg("case %zu: '%s' lacks '%s'", i, err.msg,
			    cases[i].words);
	}
}

static void
test_polygons_and_names(void **state)
{
	struct pm_mesh m;
	struct pm_error err;

	(void)state;
	/* A pentagon fans into three triangles; texture_u/texture_v names;
	 * incomplete normals (no nz) are ignored. */
	assert_int_equal(parse_text("ply\nformat ascii 1.0\nelement vertex 5\n"
	    "property double x\nproperty double y\nproperty double z\n"
	    "property float nx\nproperty float ny\n"
	    "property float texture_u\nproperty float texture_v\n"
	    "element face 1\nproperty list uchar uint vertex_index\n"
	    "end_header\n"
	    "0 0 0 1 0 0 0\n2 0 0 1 0 1 0\n2 1 0 1 0 1 1\n1 2 0 1 0 0.5 1\n"
	    "0 1 0 1 0 0 1\n5 0 1 2 3 4\n", &m, &err), PM_OK);
	assert_int_equal(m.ntris, 3);
	assert_null(m.nrm);
	assert_non_null(m.uv);
	assert_float_equal(m.uv[6], 0.5f, 0.0f);
	assert_int_equal(m.idx[6], 0);
	assert_int_equal(m.idx[7], 3);
	assert_int_equal(m.idx[8], 4);
	assert_near(pm_mesh_area(&m), 3.0, 1e-9);
	pm_mesh_free(&m);

	/* CRLF header lines and a missing newline at the very end. */
	assert_int_equal(parse_text("ply\r\nformat ascii 1.0\r\n"
	    "element vertex 3\r\nproperty float x\r\nproperty float y\r\n"
	    "property float z\r\nelement face 1\r\n"
	    "property list uchar int vertex_indices\r\nend_header\r\n"
	    "0 0 0\r\n1 0 0\r\n0 1 0\r\n3 0 1 2", &m, &err), PM_OK);
	assert_int_equal(m.ntris, 1);
	pm_mesh_free(&m);
}

static void
test_read_file(void **state)
{
	char path[] = "/tmp/pm-test-ply-XXXXXX";
	struct wbuf *w = malloc(sizeof(*w));
	struct pm_mesh m;
	struct pm_error err;
	FILE *f;
	int fd;

	(void)state;
	assert_non_null(w);
	make_pyramid(w, F_BE, 1);
	fd = mkstemp(path);
	assert_true(fd >= 0);
	f = fdopen(fd, "wb");
	assert_non_null(f);
	assert_int_equal(fwrite(w->b, 1, w->n, f), w->n);
	fclose(f);
	if (pm_ply_read(path, &m, &err) != PM_OK)
		fail_msg("%s", err.msg);
	check_pyramid(&m);
	pm_mesh_free(&m);
	unlink(path);
	assert_int_equal(pm_ply_read(path, &m, &err), PM_ERR_IO);
	assert_non_null(strstr(err.msg, path));
	free(w);
}

static void
test_bunny(void **state)
{
	struct pm_mesh m;
	struct pm_error err;
	uint32_t dropped;

	(void)state;
	if (access(BUNNY_PLY, R_OK) != 0) {
		print_message("skipped: %s not present\n", BUNNY_PLY);
		skip();
	}
	if (pm_ply_read(BUNNY_PLY, &m, &err) != PM_OK)
		fail_msg("%s", err.msg);
	assert_int_equal(m.nverts, 35947);
	assert_int_equal(m.ntris, 69451);
	assert_null(m.nrm);
	assert_null(m.uv);
	assert_int_equal(pm_mesh_validate(&m, &dropped, &err), PM_OK);
	assert_true(dropped < 100);
	assert_true(pm_mesh_area(&m) > 0.0);
	assert_int_equal(pm_mesh_compute_normals(&m, &err), PM_OK);
	pm_mesh_free(&m);
}

int
main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_formats_agree),
		cmocka_unit_test(test_big_endian_bytes),
		cmocka_unit_test(test_truncated),
		cmocka_unit_test(test_bad_inputs),
		cmocka_unit_test(test_polygons_and_names),
		cmocka_unit_test(test_read_file),
		cmocka_unit_test(test_bunny),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
