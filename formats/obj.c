/*
 * obj.c: Wavefront OBJ reader.
 *
 * The file is read whole into one NUL-terminated buffer and parsed in a
 * single pass with hand-written number parsers (strtof for the floats
 * that are not short decimals); nothing is
 * allocated per line.  As in Mitsuba 3, a mesh vertex is a distinct
 * (v, vt, vn) triple: triples are deduplicated with a hash table whose
 * buckets are the position indices, chained through the unique vertices,
 * so that vertices sharing a position but not a normal or uv stay apart.
 * Polygons are fanned from their first corner.  Texture coordinates are
 * stored as (u, 1 - v), the flip_tex_coords default of Mitsuba 3's OBJ
 * loader, since most OBJ files put v = 0 at the bottom of the image.
 * Numbers are read as in the C locale.
 */
#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "file.h"
#include "obj.h"

#define NONE UINT32_MAX

struct obj_parser {
	const char *name;
	const char *p, *end;	/* cursor and end of the NUL-terminated text */
	unsigned long line;
	struct pm_error *err;

	float *pos;		/* 3 per v */
	uint32_t *head;		/* per v: first unique vertex using it */
	size_t npos, cappos, caphead;
	float *tex;		/* 2 per vt */
	size_t ntex, captex;
	float *nor;		/* 3 per vn */
	size_t nnor, capnor;

	uint32_t *key;		/* 3 per unique vertex: v, vt, vn (NONE if absent) */
	uint32_t *next;		/* chain of unique vertices sharing a v */
	size_t nuniq, capkey, capnext;

	uint32_t *tri;		/* 3 per triangle */
	size_t ntri, captri;

	int missing_vt, missing_vn;
};

static void
parser_free(struct obj_parser *o)
{
	free(o->pos);
	free(o->head);
	free(o->tex);
	free(o->nor);
	free(o->key);
	free(o->next);
	free(o->tri);
}

/*
 * Grows the array whose pointer lives at arrp to hold `need` elements of
 * `size` bytes, doubling so that appends cost amortised constant time.
 * Returns 0, leaving the array untouched, when memory runs out.  The
 * pointer is moved with memcpy so that one helper serves every element
 * type without aliasing a float * as a void *.
 */
static int
grow(void *arrp, size_t *cap, size_t need, size_t size)
{
	size_t ncap;
	void *arr, *np;

	if (need <= *cap)
		return 1;
	ncap = *cap < 1024 ? 1024 : *cap;
	while (ncap < need) {
		if (ncap > SIZE_MAX / 2)
			return 0;
		ncap *= 2;
	}
	if (ncap > SIZE_MAX / size)
		return 0;
	memcpy(&arr, arrp, sizeof(arr));
	if ((np = realloc(arr, ncap * size)) == NULL)
		return 0;
	memcpy(arrp, &np, sizeof(np));
	*cap = ncap;
	return 1;
}

#define GROW(o, arr, cap, need) \
	grow(&(o)->arr, &(o)->cap, (need), sizeof(*(o)->arr))

static enum pm_err
nomem(struct obj_parser *o)
{
	return pm_fail(o->err, PM_ERR_NOMEM, "%s:%lu: out of memory", o->name,
	    o->line);
}

static int
is_blank(char c)
{
	return c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v';
}

/* True at the end of a statement: newline, comment or end of text. */
static int
at_eol(const struct obj_parser *o)
{
	return o->p >= o->end || *o->p == '\n' || *o->p == '#';
}

static void
skip_blanks(struct obj_parser *o)
{
	while (o->p < o->end && is_blank(*o->p))
		o->p++;
}

static void
skip_line(struct obj_parser *o)
{
	const char *nl = memchr(o->p, '\n', (size_t)(o->end - o->p));

	o->p = nl != NULL ? nl : o->end;
}

/* Describes what the cursor sits on, for error messages. */
static void
describe(const struct obj_parser *o, char *out, size_t n)
{
	size_t k = 0;
	const char *q = o->p;

	if (at_eol(o)) {
		snprintf(out, n, "end of line");
		return;
	}
	out[k++] = '\'';
	for (; q < o->end && !is_blank(*q) && *q != '\n' && k + 2 < n; q++)
		out[k++] = *q >= 0x20 && *q < 0x7f ? *q : '?';
	out[k++] = '\'';
	out[k] = '\0';
}

static enum pm_err
expected(struct obj_parser *o, const char *what)
{
	char found[32];

	describe(o, found, sizeof(found));
	return pm_fail(o->err, PM_ERR_PARSE, "%s:%lu: expected %s, found %s",
	    o->name, o->line, what, found);
}

/* A number ends at a blank, a newline, a comment or the end of text. */
static int
ends_number(const struct obj_parser *o, const char *q)
{
	return q >= o->end || is_blank(*q) || *q == '\n' || *q == '#';
}

/*
 * Parses one float after optional blanks.  Returns 1 on success, 0 at the
 * end of the statement (nothing consumed), -1 on text that is not a
 * number.  strtof cannot run past the statement: it starts on a character
 * that is not white space and stops at the first one that is.
 */
/*
 * The common case without strtof, which was a fifth of loading a large
 * OBJ: an optional sign, at most 7 significant digits and a point, no
 * exponent.  Then the digits m < 2^24 and 10^k (k <= 10) are exact floats
 * and m / 10^k is one correctly rounded division (Clinger 1990), the float
 * strtof would give.  Anything else returns NULL for strtof to read.
 */
static const char *
fast_float(const struct obj_parser *o, const char *q, float *out)
{
	static const float pow10[] = { 1e0f, 1e1f, 1e2f, 1e3f, 1e4f, 1e5f,
	    1e6f, 1e7f, 1e8f, 1e9f, 1e10f };
	uint32_t m = 0;
	int seen = 0, sig = 0, frac = 0, point = 0, neg = 0;

	if (q < o->end && (*q == '-' || *q == '+'))
		neg = *q++ == '-';
	for (; q < o->end; q++) {
		if (*q >= '0' && *q <= '9') {
			seen++;
			/* Leading zeros are not significant digits. */
			if ((m != 0 || *q != '0') && ++sig > 7)
				return NULL;
			m = 10 * m + (uint32_t)(*q - '0');
			frac += point;
		} else if (*q == '.' && !point) {
			point = 1;
		} else {
			break;
		}
	}
	/* No digits ("." or "-"), an exponent or "inf" next: strtof's. */
	if (seen == 0 || frac > 10 || !ends_number(o, q))
		return NULL;
	*out = (float)m / pow10[frac];
	if (neg)
		*out = -*out;
	return q;
}

static int
parse_float(struct obj_parser *o, float *out)
{
	const char *f;
	char *e;

	skip_blanks(o);
	if (at_eol(o))
		return 0;
	if ((f = fast_float(o, o->p, out)) != NULL) {
		o->p = f;
		return 1;
	}
	*out = strtof(o->p, &e);
	if (e == o->p || !ends_number(o, e))
		return -1;
	o->p = e;
	return 1;
}

/*
 * Reads `need` numbers and up to `extra` optional ones into v (which has
 * room for need + extra), then requires the end of the statement.
 */
static enum pm_err
parse_floats(struct obj_parser *o, float *v, int need, int extra,
    const char *what)
{
	int i, r;

	for (i = 0; i < need + extra; i++) {
		r = parse_float(o, &v[i]);
		if (r < 0 || (r == 0 && i < need))
			return expected(o, what);
		if (r == 0)
			break;
	}
	skip_blanks(o);
	if (!at_eol(o))
		return expected(o, "end of line");
	return PM_OK;
}

static enum pm_err
parse_v(struct obj_parser *o)
{
	float v[7];
	enum pm_err e;

	/*
	 * v x y z, then w (rational curves) or r g b [a] (vertex colours
	 * some exporters add): pm uses neither, but accepts both.
	 */
	if ((e = parse_floats(o, v, 3, 4, "3 numbers (x y z) after 'v'")))
		return e;
	if (o->npos >= NONE - 1)
		return pm_fail(o->err, PM_ERR_LIMIT, "%s:%lu: more than %u "
		    "vertex positions", o->name, o->line, NONE - 1);
	if (!GROW(o, pos, cappos, 3 * (o->npos + 1)) ||
	    !GROW(o, head, caphead, o->npos + 1))
		return nomem(o);
	memcpy(o->pos + 3 * o->npos, v, 3 * sizeof(float));
	o->head[o->npos] = NONE;
	o->npos++;
	return PM_OK;
}

static enum pm_err
parse_vt(struct obj_parser *o)
{
	float v[3] = {0.0f, 0.0f, 0.0f};
	enum pm_err e;

	/* vt u [v [w]]: v defaults to 0 as the OBJ specification says. */
	if ((e = parse_floats(o, v, 1, 2, "texture coordinates (u v) after 'vt'")))
		return e;
	if (o->ntex >= NONE - 1)
		return pm_fail(o->err, PM_ERR_LIMIT, "%s:%lu: more than %u "
		    "texture coordinates", o->name, o->line, NONE - 1);
	if (!GROW(o, tex, captex, 2 * (o->ntex + 1)))
		return nomem(o);
	o->tex[2 * o->ntex] = v[0];
	o->tex[2 * o->ntex + 1] = 1.0f - v[1];
	o->ntex++;
	return PM_OK;
}

static enum pm_err
parse_vn(struct obj_parser *o)
{
	float v[3];
	enum pm_err e;

	if ((e = parse_floats(o, v, 3, 0, "3 numbers (x y z) after 'vn'")))
		return e;
	if (o->nnor >= NONE - 1)
		return pm_fail(o->err, PM_ERR_LIMIT, "%s:%lu: more than %u "
		    "normals", o->name, o->line, NONE - 1);
	if (!GROW(o, nor, capnor, 3 * (o->nnor + 1)))
		return nomem(o);
	memcpy(o->nor + 3 * o->nnor, v, 3 * sizeof(float));
	o->nnor++;
	return PM_OK;
}

/*
 * Parses one index of a face corner and resolves it against the `count`
 * elements defined so far: 1-based, or negative to count back from the
 * last one.
 */
static enum pm_err
parse_index(struct obj_parser *o, size_t count, const char *what,
    uint32_t *out)
{
	const char *q = o->p;
	int neg = 0;
	long long v = 0, given;

	if (q < o->end && (*q == '-' || *q == '+'))
		neg = *q++ == '-';
	if (q >= o->end || *q < '0' || *q > '9') {
		char buf[64];

		snprintf(buf, sizeof(buf), "a %s index", what);
		return expected(o, buf);
	}
	while (q < o->end && *q >= '0' && *q <= '9') {
		/* Saturate: anything this large is out of range anyway. */
		if (v < (1LL << 40))
			v = v * 10 + (*q - '0');
		q++;
	}
	o->p = q;
	given = neg ? -v : v;
	if (v == 0)
		return pm_fail(o->err, PM_ERR_PARSE, "%s:%lu: %s index 0 "
		    "(expected 1-based or negative indices)", o->name, o->line,
		    what);
	if (neg)
		v = (long long)count - v;
	else
		v = v - 1;
	if (v < 0 || v >= (long long)count)
		return pm_fail(o->err, PM_ERR_PARSE, "%s:%lu: %s index %lld "
		    "out of range (%zu defined so far)", o->name, o->line, what,
		    given, count);
	*out = (uint32_t)v;
	return PM_OK;
}

/* Finds or adds the unique vertex for (v, vt, vn). */
static enum pm_err
unique_vertex(struct obj_parser *o, uint32_t v, uint32_t vt, uint32_t vn,
    uint32_t *id)
{
	uint32_t u;

	for (u = o->head[v]; u != NONE; u = o->next[u])
		if (o->key[3 * u + 1] == vt && o->key[3 * u + 2] == vn) {
			*id = u;
			return PM_OK;
		}
	if (o->nuniq >= NONE - 1)
		return pm_fail(o->err, PM_ERR_LIMIT, "%s:%lu: more than %u "
		    "distinct vertices", o->name, o->line, NONE - 1);
	if (!GROW(o, key, capkey, 3 * (o->nuniq + 1)) ||
	    !GROW(o, next, capnext, o->nuniq + 1))
		return nomem(o);
	u = (uint32_t)o->nuniq++;
	o->key[3 * u] = v;
	o->key[3 * u + 1] = vt;
	o->key[3 * u + 2] = vn;
	o->next[u] = o->head[v];
	o->head[v] = u;
	*id = u;
	return PM_OK;
}

static enum pm_err
parse_f(struct obj_parser *o)
{
	uint32_t first = 0, prev = 0, id = 0, v = 0, vt, vn;
	unsigned long corners = 0;
	enum pm_err e;

	for (;;) {
		skip_blanks(o);
		if (at_eol(o))
			break;
		vt = vn = NONE;
		if ((e = parse_index(o, o->npos, "vertex", &v)))
			return e;
		if (o->p < o->end && *o->p == '/') {
			o->p++;
			if (o->p < o->end && *o->p != '/' &&
			    (e = parse_index(o, o->ntex, "texture coordinate",
			    &vt)))
				return e;
			if (o->p < o->end && *o->p == '/') {
				o->p++;
				if ((e = parse_index(o, o->nnor, "normal", &vn)))
					return e;
			} else if (vt == NONE)
				return expected(o, "a texture coordinate index");
		}
		if (!ends_number(o, o->p))
			return expected(o, "a face corner (v, v/vt, v//vn or "
			    "v/vt/vn)");
		o->missing_vt |= vt == NONE;
		o->missing_vn |= vn == NONE;
		if ((e = unique_vertex(o, v, vt, vn, &id)))
			return e;
		corners++;
		if (corners == 1)
			first = id;
		else if (corners >= 3) {
			if (o->ntri >= NONE / 3)
				return pm_fail(o->err, PM_ERR_LIMIT, "%s:%lu: "
				    "more than %u triangles", o->name, o->line,
				    NONE / 3);
			if (!GROW(o, tri, captri, 3 * (o->ntri + 1)))
				return nomem(o);
			o->tri[3 * o->ntri] = first;
			o->tri[3 * o->ntri + 1] = prev;
			o->tri[3 * o->ntri + 2] = id;
			o->ntri++;
		}
		prev = id;
	}
	if (corners < 3)
		return pm_fail(o->err, PM_ERR_PARSE, "%s:%lu: face with %lu "
		    "vertices (expected at least 3)", o->name, o->line,
		    corners);
	return PM_OK;
}

/* Turns the parser's tables into the caller's mesh. */
static enum pm_err
build_mesh(struct obj_parser *o, struct pm_mesh *m)
{
	int with_uv = !o->missing_vt, with_nrm = !o->missing_vn;
	uint32_t n = (uint32_t)o->nuniq, u;

	m->pos = malloc((size_t)n * 3 * sizeof(float));
	m->nrm = with_nrm ? malloc((size_t)n * 3 * sizeof(float)) : NULL;
	m->uv = with_uv ? malloc((size_t)n * 2 * sizeof(float)) : NULL;
	if (m->pos == NULL || (with_nrm && m->nrm == NULL) ||
	    (with_uv && m->uv == NULL)) {
		pm_mesh_free(m);
		return pm_fail(o->err, PM_ERR_NOMEM, "%s: out of memory for "
		    "%u vertices", o->name, n);
	}
	for (u = 0; u < n; u++) {
		const uint32_t *k = o->key + 3 * (size_t)u;

		memcpy(m->pos + 3 * (size_t)u, o->pos + 3 * (size_t)k[0],
		    3 * sizeof(float));
		if (with_uv)
			memcpy(m->uv + 2 * (size_t)u, o->tex + 2 * (size_t)k[1],
			    2 * sizeof(float));
		if (with_nrm) {
			const float *s = o->nor + 3 * (size_t)k[2];
			struct pm_vec3 v = pm_v3(s[0], s[1], s[2]);
			float len = pm_length(v);

			/* A zero or broken normal would poison shading;
			 * fall back to flat shading for the whole mesh. */
			if (!(len > 0.0f) || !isfinite(len)) {
				free(m->nrm);
				m->nrm = NULL;
				with_nrm = 0;
				continue;
			}
			v = pm_scale(v, 1.0f / len);
			m->nrm[3 * (size_t)u] = v.x;
			m->nrm[3 * (size_t)u + 1] = v.y;
			m->nrm[3 * (size_t)u + 2] = v.z;
		}
	}
	/* The triangle array becomes the mesh's, trimmed to size. */
	m->idx = realloc(o->tri, o->ntri * 3 * sizeof(uint32_t));
	if (m->idx == NULL)
		m->idx = o->tri;
	o->tri = NULL;
	m->nverts = n;
	m->ntris = (uint32_t)o->ntri;
	return PM_OK;
}

/*
 * True, with the cursor moved past it, if the statement at the cursor is
 * the keyword kw: kw followed by a blank or by the end of the statement.
 */
static int
keyword(struct obj_parser *o, const char *kw)
{
	size_t n = strlen(kw);
	const char *after = o->p + n;

	if ((size_t)(o->end - o->p) < n || memcmp(o->p, kw, n) != 0)
		return 0;
	if (after < o->end && !is_blank(*after) && *after != '\n' &&
	    *after != '#')
		return 0;
	o->p = after;
	return 1;
}

/* Parses text[0..len), which must be followed by a NUL byte. */
static enum pm_err
parse_text(const char *name, const char *text, size_t len, struct pm_mesh *m,
    struct pm_error *err)
{
	struct obj_parser o;
	enum pm_err e = PM_OK;

	memset(&o, 0, sizeof(o));
	memset(m, 0, sizeof(*m));
	o.name = name;
	o.p = text;
	o.end = text + len;
	o.line = 1;
	o.err = err;

	while (o.p < o.end) {
		skip_blanks(&o);
		if (o.p >= o.end)
			break;
		if (keyword(&o, "v")) {
			e = parse_v(&o);
		} else if (keyword(&o, "vt")) {
			e = parse_vt(&o);
		} else if (keyword(&o, "vn")) {
			e = parse_vn(&o);
		} else if (keyword(&o, "f")) {
			e = parse_f(&o);
		} else {
			/* Comments, groups, materials, lines, points and
			 * anything else pm does not use. */
			skip_line(&o);
		}
		if (e != PM_OK)
			break;
		/* Statements stop at a newline or at a comment. */
		skip_line(&o);
		if (o.p < o.end) {
			o.p++;
			o.line++;
		}
	}
	if (e == PM_OK && o.ntri == 0)
		e = pm_fail(err, PM_ERR_PARSE, "%s: no faces (expected at least "
		    "one 'f' statement)", name);
	if (e == PM_OK)
		e = build_mesh(&o, m);
	parser_free(&o);
	return e;
}

/* Parses an OBJ text from memory into m; see obj.h. */
enum pm_err
pm_obj_parse(const char *name, const char *buf, size_t len,
    struct pm_mesh *m, struct pm_error *err)
{
	char *text = NULL;
	enum pm_err e;

	/* strtof needs a terminator after the last number. */
	if (len == SIZE_MAX || (text = malloc(len + 1)) == NULL) {
		memset(m, 0, sizeof(*m));
		return pm_fail(err, PM_ERR_NOMEM, "%s: out of memory for "
		    "%zu bytes", name, len);
	}
	if (len > 0)
		memcpy(text, buf, len);
	text[len] = '\0';
	e = parse_text(name, text, len, m, err);
	free(text);
	return e;
}

/* Reads the OBJ file at path into m; see obj.h. */
enum pm_err
pm_obj_read(const char *path, struct pm_mesh *m, struct pm_error *err)
{
	char *text = NULL;
	size_t len = 0;
	enum pm_err e;

	memset(m, 0, sizeof(*m));
	if ((e = pm_read_file(path, SIZE_MAX, &text, &len, err)) != PM_OK)
		return e;
	e = parse_text(path, text, len, m, err);
	free(text);
	return e;
}
