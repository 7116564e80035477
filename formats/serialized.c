/*
 * serialized.c: Mitsuba's .serialized triangle meshes.
 *
 * Layout (all little-endian), as Mitsuba's serialized plugin documents it:
 * each mesh starts with uint16 0x041C and uint16 version (3 or 4); the rest
 * of the mesh is a zlib stream holding uint32 flags, in version 4 the
 * mesh's name as a NUL-terminated string, uint64 vertex and triangle
 * counts, then arrays of positions, normals (flag 0x1), uv (0x2) and
 * colours (0x8) in float32, or float64 with flag 0x2000, and uint32
 * indices, three per triangle.  Meshes are concatenated; the file ends with
 * each mesh's offset (uint64 in version 4, uint32 in version 3) and the
 * uint32 count of meshes.
 *
 * Every count is checked against what the compressed bytes left could
 * possibly inflate to (zlib's deflate compresses at most 1032:1) before
 * anything is allocated, so that a corrupt count fails cleanly rather than
 * asking for gigabytes; the inflated data then has to be all there.
 */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

#include "endian.h"
#include "file.h"
#include "serialized.h"

#define SER_MAGIC		0x041Cu
#define SER_MAX_FILE		((size_t)1 << 31)
#define SER_MAX_NAME		4096
#define SER_DEFLATE_RATIO	1032u	/* zlib's largest expansion */

enum {
	F_NORMALS = 0x0001, F_TEXCOORDS = 0x0002, F_TANGENTS = 0x0004,
	F_COLORS = 0x0008, F_FACE_NORMALS = 0x0010, F_SINGLE = 0x1000,
	F_DOUBLE = 0x2000,
};

struct zin {
	z_stream z;
	const char *name;
	struct pm_error *err;
};

/* Inflates exactly n bytes into dst; a stream that ends first is
 * truncated, one that zlib cannot decode is not a serialized mesh. */
static enum pm_err
zread(struct zin *in, void *dst, size_t n, const char *what)
{
	int rc;

	in->z.next_out = dst;
	while (n > 0) {
		uInt chunk = n > (1u << 30) ? 1u << 30 : (uInt)n;

		in->z.avail_out = chunk;
		rc = inflate(&in->z, Z_NO_FLUSH);
		n -= chunk - in->z.avail_out;
		if (n == 0)
			break;
		if (rc == Z_STREAM_END || rc == Z_BUF_ERROR ||
		    (rc == Z_OK && in->z.avail_in == 0 && in->z.avail_out > 0))
			return pm_fail(in->err, PM_ERR_TRUNCATED, "%s: the "
			    "compressed data ends inside the %s", in->name, what);
		if (rc != Z_OK)
			return pm_fail(in->err, PM_ERR_FORMAT, "%s: corrupt "
			    "compressed data in the %s (zlib: %s)", in->name, what,
			    in->z.msg != NULL ? in->z.msg : "error");
	}
	return PM_OK;
}

/* Reads count reals (float32 or float64) into dst, or skips them when dst
 * is NULL, through a small buffer: nothing as large as the array is
 * allocated twice. */
static enum pm_err
read_reals(struct zin *in, float *dst, size_t count, bool dbl,
    const char *what)
{
	unsigned char buf[4096];
	size_t size = dbl ? 8 : 4, per = sizeof(buf) / size, i, k, n;
	enum pm_err e;

	for (i = 0; i < count; i += n) {
		n = count - i < per ? count - i : per;
		if ((e = zread(in, buf, n * size, what)) != PM_OK)
			return e;
		if (dst == NULL)
			continue;
		for (k = 0; k < n; k++) {
			if (dbl) {
				uint64_t b = pm_get_le64(buf + 8 * k);
				double d;

				memcpy(&d, &b, sizeof(d));
				dst[i + k] = (float)d;
			} else {
				uint32_t b = pm_get_le32(buf + 4 * k);
				float f;

				memcpy(&f, &b, sizeof(f));
				dst[i + k] = f;
			}
		}
	}
	return PM_OK;
}

/* The offset of mesh index from the table at the end of the file. */
static enum pm_err
find_mesh(const char *name, const unsigned char *buf, size_t len,
    uint32_t version, long index, size_t *off, struct pm_error *err)
{
	uint32_t count;
	size_t width = version == 4 ? 8 : 4, at;
	uint64_t o;

	if (len < 8)
		return pm_fail(err, PM_ERR_TRUNCATED, "%s: no table of meshes "
		    "at the end of the file", name);
	count = pm_get_le32(buf + len - 4);
	if ((uint64_t)index >= count)
		return pm_fail(err, PM_ERR_INVALID, "%s: shape_index %ld is out "
		    "of range: the file holds %u mesh%s", name, index, count,
		    count == 1 ? "" : "es");
	if ((uint64_t)count * width > len - 4)
		return pm_fail(err, PM_ERR_TRUNCATED, "%s: the table of %u "
		    "meshes is longer than the file", name, count);
	at = len - 4 - (size_t)(count - (uint64_t)index) * width;
	o = width == 8 ? pm_get_le64(buf + at) : pm_get_le32(buf + at);
	if (o > at || at - o < 4 || pm_get_le16(buf + o) != SER_MAGIC ||
	    pm_get_le16(buf + o + 2) != version)
		return pm_fail(err, PM_ERR_FORMAT, "%s: the table's offset %llu "
		    "of mesh %ld is not the start of a mesh", name,
		    (unsigned long long)o, index);
	*off = (size_t)o;
	return PM_OK;
}

static enum pm_err
parse_mesh(struct zin *in, uint32_t version, struct pm_mesh *m,
    bool *face_normals)
{
	unsigned char b[16];
	uint32_t flags, i;
	uint64_t nv, nt, per_vertex, need, room;
	size_t fs;
	bool dbl;
	char c;
	int k;
	enum pm_err e;

	if ((e = zread(in, b, 4, "flags")) != PM_OK)
		return e;
	flags = pm_get_le32(b);
	if (flags & ~(uint32_t)(F_NORMALS | F_TEXCOORDS | F_TANGENTS |
	    F_COLORS | F_FACE_NORMALS | F_SINGLE | F_DOUBLE))
		return pm_fail(in->err, PM_ERR_FORMAT, "%s: unknown flags 0x%x",
		    in->name, flags);
	if ((flags & F_SINGLE) && (flags & F_DOUBLE))
		return pm_fail(in->err, PM_ERR_FORMAT, "%s: flags say both single "
		    "and double precision", in->name);
	dbl = (flags & F_DOUBLE) != 0;
	fs = dbl ? 8 : 4;
	if (version == 4)
		for (k = 0;; k++) {
			if (k == SER_MAX_NAME)
				return pm_fail(in->err, PM_ERR_FORMAT, "%s: the "
				    "mesh's name is not terminated within %d "
				    "bytes", in->name, SER_MAX_NAME);
			if ((e = zread(in, &c, 1, "name")) != PM_OK)
				return e;
			if (c == '\0')
				break;
		}
	if ((e = zread(in, b, 16, "counts")) != PM_OK)
		return e;
	nv = pm_get_le64(b);
	nt = pm_get_le64(b + 8);
	if (nv > UINT32_MAX || nt > UINT32_MAX / 3)
		return pm_fail(in->err, PM_ERR_LIMIT, "%s: %llu vertices and "
		    "%llu triangles: pm takes at most 2^32 - 1 and 2^32 / 3",
		    in->name, (unsigned long long)nv, (unsigned long long)nt);
	per_vertex = 3;
	if (flags & F_NORMALS)
		per_vertex += 3;
	if (flags & F_TEXCOORDS)
		per_vertex += 2;
	if (flags & F_COLORS)
		per_vertex += 3;
	need = nv * per_vertex * fs + nt * 12;	/* < 2^40: no overflow */
	room = (uint64_t)in->z.avail_in * SER_DEFLATE_RATIO + 1024;
	if (need > room)
		return pm_fail(in->err, PM_ERR_TRUNCATED, "%s: %llu vertices and "
		    "%llu triangles need %llu bytes, more than the %u "
		    "compressed bytes left can hold", in->name,
		    (unsigned long long)nv, (unsigned long long)nt,
		    (unsigned long long)need, (unsigned)in->z.avail_in);
	if (nv == 0 || nt == 0)
		return pm_fail(in->err, PM_ERR_INVALID, "%s: the mesh has no %s",
		    in->name, nv == 0 ? "vertices" : "triangles");

	m->nverts = (uint32_t)nv;
	m->ntris = (uint32_t)nt;
	m->pos = malloc((size_t)nv * 3 * sizeof(float));
	m->idx = malloc((size_t)nt * 3 * sizeof(uint32_t));
	if (flags & F_NORMALS)
		m->nrm = malloc((size_t)nv * 3 * sizeof(float));
	if (flags & F_TEXCOORDS)
		m->uv = malloc((size_t)nv * 2 * sizeof(float));
	if (m->pos == NULL || m->idx == NULL ||
	    ((flags & F_NORMALS) && m->nrm == NULL) ||
	    ((flags & F_TEXCOORDS) && m->uv == NULL))
		return pm_fail(in->err, PM_ERR_NOMEM, "%s: out of memory for "
		    "%llu vertices", in->name, (unsigned long long)nv);
	if ((e = read_reals(in, m->pos, (size_t)nv * 3, dbl, "positions"))
	    != PM_OK ||
	    ((flags & F_NORMALS) && (e = read_reals(in, m->nrm, (size_t)nv * 3,
	    dbl, "normals")) != PM_OK) ||
	    ((flags & F_TEXCOORDS) && (e = read_reals(in, m->uv,
	    (size_t)nv * 2, dbl, "texture coordinates")) != PM_OK) ||
	    ((flags & F_COLORS) && (e = read_reals(in, NULL, (size_t)nv * 3,
	    dbl, "colours")) != PM_OK) ||
	    (e = zread(in, m->idx, (size_t)nt * 3 * sizeof(uint32_t),
	    "triangles")) != PM_OK)
		return e;
	for (i = 0; i < 3 * m->ntris; i++) {
		unsigned char *p = (unsigned char *)&m->idx[i];

		m->idx[i] = pm_get_le32(p);
		if (m->idx[i] >= m->nverts)
			return pm_fail(in->err, PM_ERR_FORMAT, "%s: triangle %u "
			    "names vertex %u of %u", in->name, i / 3, m->idx[i],
			    m->nverts);
	}
	*face_normals = (flags & F_FACE_NORMALS) != 0;
	return PM_OK;
}

enum pm_err
pm_serialized_parse(const char *name, const unsigned char *buf, size_t len,
    long shape_index, struct pm_mesh *m, bool *face_normals,
    struct pm_error *err)
{
	struct zin in;
	uint32_t version;
	size_t off = 0;
	enum pm_err e;

	memset(m, 0, sizeof(*m));
	*face_normals = false;
	if (len < 4)
		return pm_fail(err, PM_ERR_TRUNCATED, "%s: %zu bytes, too short "
		    "for a serialized mesh", name, len);
	if (pm_get_le16(buf) != SER_MAGIC)
		return pm_fail(err, PM_ERR_FORMAT, "%s: not a Mitsuba serialized "
		    "mesh (no 0x041C at the start)", name);
	version = pm_get_le16(buf + 2);
	if (version != 3 && version != 4)
		return pm_fail(err, PM_ERR_UNSUPPORTED, "%s: serialized format "
		    "version %u (pm reads 3 and 4)", name, version);
	if (shape_index < 0)
		return pm_fail(err, PM_ERR_INVALID, "%s: shape_index %ld is "
		    "negative", name, shape_index);
	if (shape_index > 0 && (e = find_mesh(name, buf, len, version,
	    shape_index, &off, err)) != PM_OK)
		return e;

	memset(&in, 0, sizeof(in));
	in.name = name;
	in.err = err;
	in.z.next_in = (unsigned char *)(uintptr_t)(buf + off + 4);
	in.z.avail_in = (uInt)(len - off - 4);
	/* 15 + 32: a zlib stream, as Mitsuba writes, or a gzip one. */
	if (inflateInit2(&in.z, 15 + 32) != Z_OK)
		return pm_fail(err, PM_ERR_NOMEM, "%s: cannot start zlib", name);
	e = parse_mesh(&in, version, m, face_normals);
	inflateEnd(&in.z);
	if (e != PM_OK)
		pm_mesh_free(m);
	return e;
}

enum pm_err
pm_serialized_read(const char *path, long shape_index, struct pm_mesh *m,
    bool *face_normals, struct pm_error *err)
{
	char *buf;
	size_t len;
	enum pm_err e;

	memset(m, 0, sizeof(*m));
	*face_normals = false;
	if ((e = pm_read_file(path, SER_MAX_FILE - 1, &buf, &len, err))
	    != PM_OK)
		return e;
	e = pm_serialized_parse(path, (const unsigned char *)buf, len,
	    shape_index, m, face_normals, err);
	free(buf);
	return e;
}
