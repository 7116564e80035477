/*
 * test_shapes.c: the cylinder, Mitsuba's serialized meshes and the new
 * sensors as the scene loader reads them.
 *
 * Cylinder: the tessellation's area is the cylinder's 2 pi r L, every
 * vertex normal is the exact radial one, the winding faces outwards, and
 * the interpolated shading normal at any point of a facet points straight
 * away from the axis; p0, p1, radius, to_world and flip_normals place it
 * as Mitsuba does.  Serialized: files written here (versions 3 and 4,
 * single and double precision, with and without normals, uv and colours,
 * several meshes per file) read back exactly, and every truncation,
 * corrupt byte, bad header or impossible count is refused with a message.
 * An emitting shape given no BSDF reflects nothing, as in Mitsuba.
 * Instances copy a shapegroup's shapes under their own to_world.
 */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <zlib.h>

#include "../../common/mesh.h"
#include "../../common/scene.h"
#include "../../formats/scene_xml.h"
#include "../../formats/serialized.h"
#include "tmpdir.h"

#define NEAR(a, b, tol) assert_true(fabs((double)(a) - (double)(b)) <= (tol))
#define PI 3.14159265358979323846

/* ---- a little writer of the serialized format, from its description ---- */

struct buf {
	unsigned char *p;
	size_t n, cap;
};

static void
put(struct buf *b, const void *d, size_t n)
{
	if (b->n + n > b->cap) {
		b->cap = 2 * (b->n + n) + 64;
		b->p = realloc(b->p, b->cap);
		assert_non_null(b->p);
	}
	memcpy(b->p + b->n, d, n);
	b->n += n;
}

/* little-endian integers of w bytes */
static void
put_le(struct buf *b, uint64_t v, int w)
{
	unsigned char c[8];
	int i;

	for (i = 0; i < w; i++)
		c[i] = (unsigned char)(v >> (8 * i));
	put(b, c, (size_t)w);
}

static void
put_real(struct buf *b, double v, bool dbl)
{
	if (dbl) {
		uint64_t u;

		memcpy(&u, &v, 8);
		put_le(b, u, 8);
	} else {
		float f = (float)v;
		uint32_t u;

		memcpy(&u, &f, 4);
		put_le(b, u, 4);
	}
}

struct smesh {
	uint32_t nv, nt;
	const float *pos, *nrm, *uv, *col;
	const uint32_t *idx;
	bool dbl, face_normals;
};

/* Appends one mesh (header and zlib stream) to out. */
static void
put_mesh(struct buf *out, const struct smesh *m, int version)
{
	struct buf raw = {NULL, 0, 0};
	uint32_t flags = (m->nrm ? 1 : 0) | (m->uv ? 2 : 0) | (m->col ? 8 : 0) |
	    (m->face_normals ? 0x10 : 0) | (m->dbl ? 0x2000 : 0x1000);
	uLongf zlen;
	unsigned char *z;
	uint32_t i;

	put_le(&raw, flags, 4);
	if (version == 4)
		put(&raw, "a mesh", 7);
	put_le(&raw, m->nv, 8);
	put_le(&raw, m->nt, 8);
	for (i = 0; i < 3 * m->nv; i++)
		put_real(&raw, m->pos[i], m->dbl);
	for (i = 0; m->nrm && i < 3 * m->nv; i++)
		put_real(&raw, m->nrm[i], m->dbl);
	for (i = 0; m->uv && i < 2 * m->nv; i++)
		put_real(&raw, m->uv[i], m->dbl);
	for (i = 0; m->col && i < 3 * m->nv; i++)
		put_real(&raw, m->col[i], m->dbl);
	for (i = 0; i < 3 * m->nt; i++)
		put_le(&raw, m->idx[i], 4);
	zlen = compressBound(raw.n);
	z = malloc(zlen);
	assert_non_null(z);
	assert_int_equal(compress2(z, &zlen, raw.p, raw.n, 9), Z_OK);
	put_le(out, 0x041C, 2);
	put_le(out, (uint64_t)version, 2);
	put(out, z, zlen);
	free(z);
	free(raw.p);
}

/* A whole file of n meshes with its table of offsets. */
static struct buf
ser_file(const struct smesh *m, int n, int version)
{
	struct buf b = {NULL, 0, 0};
	uint64_t off[8];
	int i;

	for (i = 0; i < n; i++) {
		off[i] = b.n;
		put_mesh(&b, &m[i], version);
	}
	for (i = 0; i < n; i++)
		put_le(&b, off[i], version == 4 ? 8 : 4);
	put_le(&b, (uint64_t)n, 4);
	return b;
}

/* a tetrahedron with everything */
static const float tet_pos[] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
static const float tet_nrm[] = {-0.57735f, -0.57735f, -0.57735f, 1, 0, 0,
    0, 1, 0, 0, 0, 1};
static const float tet_uv[] = {0, 0, 1, 0, 0, 1, 0.5f, 0.25f};
static const float tet_col[] = {1, 0, 0, 0, 1, 0, 0, 0, 1, 1, 1, 1};
static const uint32_t tet_idx[] = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};
/* a quad, positions only */
static const float quad_pos[] = {-1, -1, 2, 1, -1, 2, 1, 1, 2, -1, 1, 2};
static const uint32_t quad_idx[] = {0, 1, 2, 0, 2, 3};

static void
assert_floats(const float *got, const float *want, size_t n, double tol)
{
	size_t i;

	assert_non_null(got);
	for (i = 0; i < n; i++)
		NEAR(got[i], want[i], tol);
}

static void
test_serialized_round_trip(void **state)
{
	struct smesh ms[2] = {
		{4, 4, tet_pos, tet_nrm, tet_uv, tet_col, tet_idx, false, false},
		{4, 2, quad_pos, NULL, NULL, NULL, quad_idx, true, true},
	};
	struct pm_mesh m;
	struct pm_error err;
	bool fn;
	int version, dbl;

	(void)state;
	for (version = 3; version <= 4; version++)
		for (dbl = 0; dbl <= 1; dbl++) {
			struct buf b;

			ms[0].dbl = dbl;
			b = ser_file(ms, 2, version);
			assert_int_equal(pm_serialized_parse("t.serialized", b.p,
			    b.n, 0, &m, &fn, &err), PM_OK);
			assert_int_equal(m.nverts, 4);
			assert_int_equal(m.ntris, 4);
			assert_false(fn);
			assert_floats(m.pos, tet_pos, 12, 0);
			assert_floats(m.nrm, tet_nrm, 12, 0);
			assert_floats(m.uv, tet_uv, 8, 0);
			assert_memory_equal(m.idx, tet_idx, sizeof(tet_idx));
			pm_mesh_free(&m);

			assert_int_equal(pm_serialized_parse("t.serialized", b.p,
			    b.n, 1, &m, &fn, &err), PM_OK);
			assert_int_equal(m.nverts, 4);
			assert_int_equal(m.ntris, 2);
			assert_true(fn);
			assert_null(m.nrm);
			assert_null(m.uv);
			assert_floats(m.pos, quad_pos, 12, 0);
			assert_memory_equal(m.idx, quad_idx, sizeof(quad_idx));
			pm_mesh_free(&m);

			assert_int_equal(pm_serialized_parse("t.serialized", b.p,
			    b.n, 2, &m, &fn, &err), PM_ERR_INVALID);
			assert_non_null(strstr(err.msg, "shape_index 2 is out of "
			    "range: the file holds 2 meshes"));
			assert_null(m.pos);
			free(b.p);
		}
}

/* Every prefix of a file fails cleanly, as does every single corrupt byte
 * (or it still reads as a mesh whose indices are in range). */
static void
test_serialized_truncated_and_corrupt(void **state)
{
	struct smesh ms[2] = {
		{4, 4, tet_pos, tet_nrm, tet_uv, tet_col, tet_idx, false, false},
		{4, 2, quad_pos, NULL, NULL, NULL, quad_idx, false, false},
	};
	struct buf b = ser_file(ms, 2, 4);
	struct pm_mesh m;
	struct pm_error err;
	size_t len, i;
	uint32_t k;
	bool fn;
	enum pm_err e;

	(void)state;
	for (len = 0; len < b.n; len++) {
		/* shape 1 needs the table at the end: every cut loses it */
		e = pm_serialized_parse("cut.serialized", b.p, len, 1, &m, &fn,
		    &err);
		assert_int_not_equal(e, PM_OK);
		assert_true(strlen(err.msg) > 0);
		assert_null(m.pos);
	}
	/* mesh 0 alone: any cut inside its stream */
	for (len = 0; len < 40; len++) {
		e = pm_serialized_parse("cut.serialized", b.p, len, 0, &m, &fn,
		    &err);
		assert_int_not_equal(e, PM_OK);
		assert_non_null(strstr(err.msg, "cut.serialized: "));
	}
	for (i = 0; i < b.n; i++) {
		unsigned char save = b.p[i];

		b.p[i] ^= 0x5a;
		e = pm_serialized_parse("flip.serialized", b.p, b.n, 1, &m, &fn,
		    &err);
		if (e == PM_OK) {
			for (k = 0; k < 3 * m.ntris; k++)
				assert_true(m.idx[k] < m.nverts);
			pm_mesh_free(&m);
		}
		b.p[i] = save;
	}
	free(b.p);
}

static void
test_serialized_bad_headers(void **state)
{
	struct smesh ms = {4, 4, tet_pos, NULL, NULL, NULL, tet_idx, false,
	    false};
	struct buf b = ser_file(&ms, 1, 4);
	struct pm_mesh m;
	struct pm_error err;
	bool fn;

	(void)state;
	b.p[0] = 0x1d;
	assert_int_equal(pm_serialized_parse("t", b.p, b.n, 0, &m, &fn, &err),
	    PM_ERR_FORMAT);
	assert_non_null(strstr(err.msg, "not a Mitsuba serialized mesh"));
	b.p[0] = 0x1c;
	b.p[2] = 5;
	assert_int_equal(pm_serialized_parse("t", b.p, b.n, 0, &m, &fn, &err),
	    PM_ERR_UNSUPPORTED);
	assert_non_null(strstr(err.msg, "version 5"));
	b.p[2] = 4;
	assert_int_equal(pm_serialized_parse("t", b.p, b.n, -1, &m, &fn, &err),
	    PM_ERR_INVALID);
	free(b.p);

	/* an index past the vertices */
	{
		static const uint32_t bad[] = {0, 1, 4, 0, 1, 3, 0, 3, 2, 1,
		    2, 3};

		ms.idx = bad;
		b = ser_file(&ms, 1, 4);
		assert_int_equal(pm_serialized_parse("t", b.p, b.n, 0, &m, &fn,
		    &err), PM_ERR_FORMAT);
		assert_non_null(strstr(err.msg, "triangle 0 names vertex 4 "
		    "of 4"));
		free(b.p);
	}
}

/* Counts that the compressed bytes cannot hold are refused before any
 * allocation: 2^31 vertices from a few dozen bytes. */
static void
test_serialized_impossible_counts(void **state)
{
	struct buf raw = {NULL, 0, 0}, b = {NULL, 0, 0};
	unsigned char z[256];
	uLongf zlen = sizeof(z);
	struct pm_mesh m;
	struct pm_error err;
	bool fn;

	(void)state;
	put_le(&raw, 0x1000, 4);
	put(&raw, "", 1);
	put_le(&raw, 1ull << 31, 8);
	put_le(&raw, 1ull << 30, 8);
	assert_int_equal(compress2(z, &zlen, raw.p, raw.n, 9), Z_OK);
	put_le(&b, 0x041C, 2);
	put_le(&b, 4, 2);
	put(&b, z, zlen);
	assert_int_equal(pm_serialized_parse("huge", b.p, b.n, 0, &m, &fn,
	    &err), PM_ERR_TRUNCATED);
	assert_non_null(strstr(err.msg, "more than the"));
	assert_null(m.pos);
	free(raw.p);
	free(b.p);
}

/* ---- the scene loader ---- */

static void
write_file(const char *name, const void *p, size_t n)
{
	char path[256];
	FILE *f;

	snprintf(path, sizeof(path), "%s/%s", pm_test_dir, name);
	f = fopen(path, "wb");
	assert_non_null(f);
	assert_int_equal(fwrite(p, 1, n, f), n);
	assert_int_equal(fclose(f), 0);
}

static enum pm_err
load(const char *xml, struct pm_scene *s, struct pm_error *err)
{
	memset(err, 0, sizeof(*err));
	return pm_scene_load_string(xml, strlen(xml), "t.xml", pm_test_dir, NULL, 0,
	    s, err);
}

static void
load_ok(const char *xml, struct pm_scene *s)
{
	struct pm_error err;
	enum pm_err e = load(xml, s, &err);

	if (e != PM_OK)
		print_error("unexpected failure: %s\n", err.msg);
	assert_int_equal(e, PM_OK);
}

static void
load_fails(const char *xml, enum pm_err want, const char *msg)
{
	struct pm_scene s;
	struct pm_error err;
	enum pm_err e = load(xml, &s, &err);

	if (e != want || strstr(err.msg, msg) == NULL)
		print_error("got %d \"%s\", want %d with \"%s\"\n", e, err.msg,
		    want, msg);
	assert_int_equal(e, want);
	assert_non_null(strstr(err.msg, msg));
}

static void
test_serialized_in_scene(void **state)
{
	struct smesh ms[2] = {
		{4, 4, tet_pos, tet_nrm, NULL, NULL, tet_idx, false, false},
		{4, 2, quad_pos, NULL, NULL, NULL, quad_idx, false, false},
	};
	struct buf b = ser_file(ms, 2, 4);
	struct pm_scene s;
	const struct pm_mesh *m;

	(void)state;
	write_file("two.serialized", b.p, b.n);
	free(b.p);
	load_ok("<scene version=\"3.0.0\"><shape type=\"serialized\">"
	    "<string name=\"filename\" value=\"two.serialized\"/>"
	    "<integer name=\"shape_index\" value=\"1\"/>"
	    "<transform name=\"to_world\"><translate x=\"1\"/></transform>"
	    "<boolean name=\"flip_normals\" value=\"true\"/>"
	    "</shape></scene>", &s);
	assert_int_equal(s.nshapes, 1);
	m = &s.shapes[0].mesh;
	assert_int_equal(m->ntris, 2);
	NEAR(m->pos[0], 0.0, 0);	/* -1 + 1 */
	NEAR(m->pos[2], 2.0, 0);
	/* computed smooth normals of the quad (+z), flipped */
	assert_non_null(m->nrm);
	NEAR(m->nrm[2], -1.0, 1e-6);
	pm_scene_free(&s);

	load_ok("<scene version=\"3.0.0\"><shape type=\"serialized\">"
	    "<string name=\"filename\" value=\"two.serialized\"/>"
	    "<boolean name=\"face_normals\" value=\"true\"/>"
	    "</shape></scene>", &s);
	assert_int_equal(s.shapes[0].mesh.ntris, 4);
	assert_null(s.shapes[0].mesh.nrm);
	pm_scene_free(&s);

	load_fails("<scene version=\"3.0.0\"><shape type=\"serialized\">"
	    "<string name=\"filename\" value=\"two.serialized\"/>"
	    "<integer name=\"shape_index\" value=\"7\"/>"
	    "</shape></scene>", PM_ERR_INVALID, "shape_index 7 is out of range");
	{
		static const char junk[] = "PK\003\004 not a mesh";

		write_file("junk.serialized", junk, sizeof(junk) - 1);
	}
	load_fails("<scene version=\"3.0.0\"><shape type=\"serialized\">"
	    "<string name=\"filename\" value=\"junk.serialized\"/>"
	    "</shape></scene>", PM_ERR_FORMAT, "not a Mitsuba serialized mesh");
}

static void
test_cylinder_mesh(void **state)
{
	struct pm_mesh m;
	struct pm_error err;
	uint32_t i, t;
	double area;

	(void)state;
	assert_int_equal(pm_mesh_cylinder(&m, 64, &err), PM_OK);
	area = pm_mesh_area(&m);
	NEAR(area, 2 * PI, 1e-5 * 2 * PI);
	for (i = 0; i < m.nverts; i++) {
		struct pm_vec3 p = pm_mesh_vertex(&m, i);
		const float *n = m.nrm + 3 * i;
		float r = hypotf(p.x, p.y);

		assert_true(p.z == 0.0f || p.z == 1.0f);
		NEAR(n[2], 0, 0);
		NEAR(n[0], p.x / r, 1e-6);
		NEAR(n[1], p.y / r, 1e-6);
		NEAR(m.uv[2 * i + 1], p.z, 0);
	}
	for (t = 0; t < m.ntris; t++) {
		const uint32_t *ix = m.idx + 3 * t;
		struct pm_vec3 a = pm_mesh_vertex(&m, ix[0]);
		struct pm_vec3 b = pm_mesh_vertex(&m, ix[1]);
		struct pm_vec3 c = pm_mesh_vertex(&m, ix[2]);
		struct pm_vec3 ng = pm_cross(pm_sub(b, a), pm_sub(c, a));
		struct pm_vec3 mid = pm_scale(pm_add(pm_add(a, b), c), 1.0f / 3);
		struct pm_vec3 ns = pm_v3(0, 0, 0), radial;
		int k;

		/* outward winding */
		assert_true(pm_dot(ng, pm_v3(mid.x, mid.y, 0)) > 0);
		/* the interpolated normal at the centroid is radial there */
		for (k = 0; k < 3; k++)
			ns = pm_add(ns, pm_v3(m.nrm[3 * ix[k]],
			    m.nrm[3 * ix[k] + 1], m.nrm[3 * ix[k] + 2]));
		ns = pm_normalize(ns);
		radial = pm_normalize(pm_v3(mid.x, mid.y, 0));
		NEAR(pm_dot(ns, radial), 1.0, 1e-6);
	}
	pm_mesh_free(&m);
	assert_int_equal(pm_mesh_cylinder(&m, 2, &err), PM_ERR_INVALID);
}

static void
test_cylinder_in_scene(void **state)
{
	struct pm_scene s;
	const struct pm_mesh *m;
	struct pm_vec3 p0 = pm_v3(1, 2, 3), axis;
	uint32_t i;
	double len = sqrt(1.0 + 4.0 + 4.0);	/* p1 - p0 = (1, 2, -2)... */

	(void)state;
	load_ok("<scene version=\"3.0.0\"><shape type=\"cylinder\">"
	    "<point name=\"p0\" x=\"1\" y=\"2\" z=\"3\"/>"
	    "<point name=\"p1\" x=\"2\" y=\"4\" z=\"1\"/>"
	    "<float name=\"radius\" value=\"0.5\"/>"
	    "<transform name=\"to_world\"><scale value=\"2\"/></transform>"
	    "</shape></scene>", &s);
	m = &s.shapes[0].mesh;
	/* ...scaled by 2: radius 1, length 2 len */
	NEAR(pm_mesh_area(m), 2 * PI * 1.0 * 2 * len, 1e-4 * 4 * PI * len);
	axis = pm_normalize(pm_v3(1, 2, -2));
	p0 = pm_scale(p0, 2);
	for (i = 0; i < m->nverts; i++) {
		struct pm_vec3 d = pm_sub(pm_mesh_vertex(m, i), p0);
		float h = pm_dot(d, axis);
		struct pm_vec3 rad = pm_sub(d, pm_scale(axis, h));
		const float *n = m->nrm + 3 * i;

		assert_true(fabsf(h) < 1e-4f || fabsf(h - 2 * (float)len) <
		    1e-4f);
		NEAR(pm_length(rad), 1.0, 1e-4);	/* and a rim pushed out
							 * by 1e-5 at most */
		NEAR(n[0] * rad.x + n[1] * rad.y + n[2] * rad.z,
		    pm_length(rad), 1e-5);
	}
	pm_scene_free(&s);

	/* flip_normals and a negative radius both turn normals inwards,
	 * and together cancel */
	load_ok("<scene version=\"3.0.0\"><shape type=\"cylinder\">"
	    "<boolean name=\"flip_normals\" value=\"true\"/></shape>"
	    "<shape type=\"cylinder\"><float name=\"radius\" value=\"-1\"/>"
	    "</shape><shape type=\"cylinder\">"
	    "<float name=\"radius\" value=\"-1\"/>"
	    "<boolean name=\"flip_normals\" value=\"true\"/></shape></scene>",
	    &s);
	for (i = 0; i < 3; i++) {
		const struct pm_mesh *c = &s.shapes[i].mesh;
		float dot = c->nrm[0] * c->pos[0] + c->nrm[1] * c->pos[1];

		assert_true(i < 2 ? dot < 0 : dot > 0);
	}
	pm_scene_free(&s);

	load_fails("<scene version=\"3.0.0\"><shape type=\"cylinder\">"
	    "<point name=\"p1\" x=\"0\" y=\"0\" z=\"0\"/></shape></scene>",
	    PM_ERR_INVALID, "p0 and p1 must differ");
	load_fails("<scene version=\"3.0.0\"><shape type=\"cylinder\">"
	    "<transform name=\"to_world\"><scale x=\"2\"/></transform>"
	    "</shape></scene>", PM_ERR_UNSUPPORTED, "cross-section round");
	load_fails("<scene version=\"3.0.0\"><shape type=\"cylinder\">"
	    "<boolean name=\"face_normals\" value=\"true\"/></shape></scene>",
	    PM_ERR_UNSUPPORTED, "unknown parameter \"face_normals\"");
}

static void
test_sensors_in_scene(void **state)
{
	struct pm_scene s;

	(void)state;
	load_ok("<scene version=\"3.0.0\"><sensor type=\"orthographic\">"
	    "<float name=\"near_clip\" value=\"0.5\"/>"
	    "<transform name=\"to_world\"><scale x=\"2\" y=\"3\"/>"
	    "<lookat origin=\"0,0,5\" target=\"0,0,0\" up=\"0,1,0\"/>"
	    "</transform></sensor></scene>", &s);
	assert_int_equal(s.camera.type, PM_SENSOR_ORTHOGRAPHIC);
	NEAR(s.camera.near_clip, 0.5, 0);
	NEAR(s.camera.to_world.m[1][1], 3, 1e-6);
	pm_scene_free(&s);

	load_ok("<scene version=\"3.0.0\"><sensor type=\"thinlens\">"
	    "<float name=\"aperture_radius\" value=\"0.1\"/>"
	    "<float name=\"focus_distance\" value=\"4\"/>"
	    "<float name=\"fov\" value=\"30\"/>"
	    "<string name=\"fov_axis\" value=\"y\"/>"
	    "</sensor></scene>", &s);
	assert_int_equal(s.camera.type, PM_SENSOR_THINLENS);
	NEAR(s.camera.aperture_radius, 0.1, 1e-7);
	NEAR(s.camera.focus_distance, 4, 0);
	NEAR(s.camera.fov, 30, 0);
	assert_int_equal(s.camera.fov_axis, PM_FOV_Y);
	pm_scene_free(&s);

	/* Mitsuba's default focus: the far clip plane */
	load_ok("<scene version=\"3.0.0\"><sensor type=\"thinlens\">"
	    "<float name=\"aperture_radius\" value=\"0.1\"/>"
	    "<float name=\"far_clip\" value=\"50\"/></sensor></scene>", &s);
	NEAR(s.camera.focus_distance, 50, 0);
	pm_scene_free(&s);

	load_fails("<scene version=\"3.0.0\"><sensor type=\"thinlens\"/>"
	    "</scene>", PM_ERR_INVALID, "aperture_radius");
	load_fails("<scene version=\"3.0.0\"><sensor type=\"thinlens\">"
	    "<float name=\"aperture_radius\" value=\"0.1\"/>"
	    "<float name=\"focus_distance\" value=\"0\"/></sensor></scene>",
	    PM_ERR_INVALID, "focus_distance must be positive");
	load_fails("<scene version=\"3.0.0\"><sensor type=\"thinlens\">"
	    "<float name=\"aperture_radius\" value=\"0.1\"/>"
	    "<transform name=\"to_world\"><scale value=\"2\"/></transform>"
	    "</sensor></scene>", PM_ERR_INVALID, "must not scale");
	load_fails("<scene version=\"3.0.0\"><sensor type=\"orthographic\">"
	    "<float name=\"fov\" value=\"30\"/></sensor></scene>",
	    PM_ERR_UNSUPPORTED, "unknown parameter \"fov\"");
	load_fails("<scene version=\"3.0.0\"><sensor type=\"fisheye\"/>"
	    "</scene>", PM_ERR_UNSUPPORTED, "perspective, orthographic and "
	    "thinlens");
}

/* A shapegroup is drawn only through instances, each a copy of the
 * group's shapes with the instance's to_world after the shape's own. */
static void
test_shapegroup_instances(void **state)
{
	char xml[8192];
	struct pm_scene s;
	size_t len, i;

	(void)state;
	load_ok("<scene version=\"3.0.0\">"
	    "<bsdf type=\"diffuse\" id=\"grey\"/>"
	    "<shape type=\"shapegroup\" id=\"g\">"
	    "<shape type=\"rectangle\"><transform name=\"to_world\">"
	    "<scale value=\"2\"/></transform><ref id=\"grey\"/></shape>"
	    "<shape type=\"sphere\"><point name=\"center\" x=\"1\" y=\"0\""
	    " z=\"0\"/></shape></shape>"
	    "<shape type=\"instance\"><ref id=\"g\"/></shape>"
	    "<shape type=\"instance\"><ref id=\"g\"/>"
	    "<transform name=\"to_world\"><rotate z=\"1\" angle=\"90\"/>"
	    "<translate z=\"5\"/></transform></shape>"
	    "</scene>", &s);
	assert_int_equal(s.nshapes, 4);
	assert_int_equal(s.shapes[0].type, PM_SHAPE_MESH);
	assert_int_equal(s.shapes[1].type, PM_SHAPE_SPHERE);
	/* the rectangle's corner (-1, -1, 0), scaled by 2 */
	NEAR(s.shapes[0].mesh.pos[0], -2, 1e-6);
	NEAR(s.shapes[0].mesh.pos[1], -2, 1e-6);
	NEAR(s.shapes[0].mesh.pos[2], 0, 1e-6);
	/* ...then turned about z and moved up 5: (2, -2, 5) */
	NEAR(s.shapes[2].mesh.pos[0], 2, 1e-5);
	NEAR(s.shapes[2].mesh.pos[1], -2, 1e-5);
	NEAR(s.shapes[2].mesh.pos[2], 5, 1e-6);
	assert_int_equal(s.shapes[0].bsdf, s.shapes[2].bsdf);
	NEAR(s.shapes[1].center.x, 1, 1e-6);
	NEAR(s.shapes[3].center.x, 0, 1e-5);
	NEAR(s.shapes[3].center.y, 1, 1e-5);
	NEAR(s.shapes[3].center.z, 5, 1e-6);
	pm_scene_free(&s);

	/* a group alone draws nothing; a large one is fine */
	len = (size_t)snprintf(xml, sizeof(xml), "<scene version=\"3.0.0\">"
	    "<shape type=\"shapegroup\" id=\"g\">");
	for (i = 0; i < 40; i++)
		len += (size_t)snprintf(xml + len, sizeof(xml) - len,
		    "<shape type=\"cube\"/>");
	snprintf(xml + len, sizeof(xml) - len, "</shape></scene>");
	load_ok(xml, &s);
	assert_int_equal(s.nshapes, 0);
	pm_scene_free(&s);
	snprintf(xml + len, sizeof(xml) - len, "</shape><shape type="
	    "\"instance\"><ref id=\"g\"/></shape></scene>");
	load_ok(xml, &s);
	assert_int_equal(s.nshapes, 40);
	pm_scene_free(&s);

	load_fails("<scene version=\"3.0.0\"><shape type=\"instance\"/>"
	    "</scene>", PM_ERR_INVALID, "exactly one <ref> to a shapegroup");
	load_fails("<scene version=\"3.0.0\"><bsdf type=\"diffuse\" "
	    "id=\"b\"/><shape type=\"instance\"><ref id=\"b\"/></shape>"
	    "</scene>", PM_ERR_INVALID, "expected a shape \"shapegroup\"");
	load_fails("<scene version=\"3.0.0\"><shape type=\"shapegroup\" "
	    "id=\"g\"><shape type=\"cube\"><emitter type=\"area\">"
	    "<rgb name=\"radiance\" value=\"1\"/></emitter></shape></shape>"
	    "<shape type=\"instance\"><ref id=\"g\"/></shape></scene>",
	    PM_ERR_UNSUPPORTED, "cannot emit");
	load_fails("<scene version=\"3.0.0\"><shape type=\"shapegroup\" "
	    "id=\"g\"><shape type=\"shapegroup\"/></shape></scene>",
	    PM_ERR_INVALID, "cannot hold a shape \"shapegroup\"");
	load_fails("<scene version=\"3.0.0\"><shape type=\"shapegroup\" "
	    "id=\"g\"><bsdf type=\"diffuse\"/></shape></scene>",
	    PM_ERR_INVALID, "holds only <shape> elements");
}

/* Mitsuba's default BSDF: diffuse 0.5, but black on an emitting shape. */
static void
test_default_bsdf_of_emitters(void **state)
{
	struct pm_scene s;
	const struct pm_bsdf *b;

	(void)state;
	load_ok("<scene version=\"3.0.0\"><shape type=\"cylinder\">"
	    "<emitter type=\"area\"><rgb name=\"radiance\" value=\"1\"/>"
	    "</emitter></shape><shape type=\"cylinder\"/>"
	    "</scene>", &s);
	b = &s.bsdfs[s.shapes[0].bsdf];
	assert_int_equal(b->type, PM_BSDF_DIFFUSE);
	NEAR(b->diffuse.r + b->diffuse.g + b->diffuse.b, 0, 0);
	b = &s.bsdfs[s.shapes[1].bsdf];
	assert_int_equal(b->type, PM_BSDF_DIFFUSE);
	NEAR(b->diffuse.g, 0.5, 0);
	pm_scene_free(&s);
}

int
main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_serialized_round_trip),
		cmocka_unit_test(test_serialized_truncated_and_corrupt),
		cmocka_unit_test(test_serialized_bad_headers),
		cmocka_unit_test(test_serialized_impossible_counts),
		cmocka_unit_test(test_serialized_in_scene),
		cmocka_unit_test(test_cylinder_mesh),
		cmocka_unit_test(test_cylinder_in_scene),
		cmocka_unit_test(test_sensors_in_scene),
		cmocka_unit_test(test_default_bsdf_of_emitters),
		cmocka_unit_test(test_shapegroup_instances),
	};

	return cmocka_run_group_tests(tests, pm_tmpdir_setup, pm_tmpdir_teardown);
}
