/*
 * ply.c: Stanford PLY reader (ascii, binary_little_endian and
 * binary_big_endian).
 *
 * The header is parsed strictly into a small table of elements and
 * properties; then every element is read in the order the header declares
 * it, vertex and face elements into the mesh, anything else skipped by its
 * declared sizes (a binary list is skipped by reading its count).  Before
 * anything is allocated, the element counts are checked against the bytes
 * that follow the header (each element needs at least its scalar sizes and
 * list counts in binary, one character per value in ASCII), so that a
 * corrupt count fails cleanly instead of asking for gigabytes.  Texture
 * coordinates are stored as the file gives them, and so are the colours
 * of vertices and faces (Mitsuba's vertex_color and face_color).
 */
#include <errno.h>
#include <limits.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "file.h"
#include "ply.h"

#define PLY_MAX_ELEMS	16
#define PLY_MAX_PROPS	64
#define PLY_NAME_MAX	64

enum ply_format { PLY_ASCII = 1, PLY_BLE, PLY_BBE };

enum ply_type {
	PT_NONE, PT_I8, PT_U8, PT_I16, PT_U16, PT_I32, PT_U32, PT_F32, PT_F64
};

/* Where a vertex property goes: x y z, nx ny nz, u v, the colour r g b. */
enum { S_X, S_Y, S_Z, S_NX, S_NY, S_NZ, S_U, S_V, S_R, S_G, S_B, S_COUNT };

struct ply_prop {
	char name[PLY_NAME_MAX];
	enum ply_type type;	/* of the value, or of a list's items */
	enum ply_type count;	/* PT_NONE for a scalar */
	int slot;		/* S_* for vertex properties pm uses, else -1 */
};

struct ply_elem {
	char name[PLY_NAME_MAX];
	unsigned long long count;
	int nprops;
	struct ply_prop props[PLY_MAX_PROPS];
};

struct ply_header {
	enum ply_format format;
	int nelems;
	struct ply_elem elems[PLY_MAX_ELEMS];
	int vertex, face;	/* element numbers, -1 if absent */
	int index_prop;		/* the face element's index list */
	int has_nrm, has_uv;
	int has_vcolor;		/* vertex r g b (or red green blue) */
	int fcolor[3];		/* the face element's r g b, or -1 */
};

/* The data section: a cursor with an end, and where we are for messages. */
struct ply_in {
	const char *name;
	const unsigned char *base, *p, *end;
	enum ply_format format;
	unsigned long line;	/* ASCII only */
	struct pm_error *err;
	const char *elem;	/* element being read, for messages */
	unsigned long long item;
};

static const struct {
	const char *name;
	enum ply_type type;
} type_names[] = {
	{"char", PT_I8}, {"int8", PT_I8}, {"uchar", PT_U8}, {"uint8", PT_U8},
	{"short", PT_I16}, {"int16", PT_I16}, {"ushort", PT_U16},
	{"uint16", PT_U16}, {"int", PT_I32}, {"int32", PT_I32},
	{"uint", PT_U32}, {"uint32", PT_U32}, {"float", PT_F32},
	{"float32", PT_F32}, {"double", PT_F64}, {"float64", PT_F64},
};

static int
type_size(enum ply_type t)
{
	switch (t) {
	case PT_I8: case PT_U8:		return 1;
	case PT_I16: case PT_U16:	return 2;
	case PT_I32: case PT_U32: case PT_F32: return 4;
	case PT_F64:			return 8;
	case PT_NONE:			break;
	}
	return 0;
}

static int
type_is_int(enum ply_type t)
{
	return t != PT_F32 && t != PT_F64;
}

static enum ply_type
parse_type(const char *s)
{
	size_t i;

	for (i = 0; i < sizeof(type_names) / sizeof(type_names[0]); i++)
		if (strcmp(s, type_names[i].name) == 0)
			return type_names[i].type;
	return PT_NONE;
}

/* Splits line in place at blanks; returns the number of tokens. */
static int
tokenize(char *line, char **tok, int max)
{
	int n = 0;
	char *s = line;

	for (;;) {
		while (*s == ' ' || *s == '\t')
			s++;
		if (*s == '\0')
			return n;
		if (n == max)
			return max + 1;
		tok[n++] = s;
		while (*s != '\0' && *s != ' ' && *s != '\t')
			s++;
		if (*s != '\0')
			*s++ = '\0';
	}
}

static int
parse_count(const char *s, unsigned long long *out)
{
	unsigned long long v = 0;

	if (*s == '\0')
		return 0;
	for (; *s != '\0'; s++) {
		if (*s < '0' || *s > '9' || v > (ULLONG_MAX - 9) / 10)
			return 0;
		v = v * 10 + (unsigned long long)(*s - '0');
	}
	*out = v;
	return 1;
}

/* The scalar properties r g b, or else red green blue, of an element
 * (Mitsuba's vertex_color and face_color): their numbers in rgb[], all
 * -1 unless all three are there. */
static void
find_color(const struct ply_elem *e, int rgb[3])
{
	static const char *const names[2][3] = {{"r", "g", "b"},
	    {"red", "green", "blue"}};
	int set, c, i;

	for (set = 0; set < 2; set++) {
		for (c = 0; c < 3; c++) {
			rgb[c] = -1;
			for (i = 0; i < e->nprops && rgb[c] < 0; i++)
				if (e->props[i].count == PT_NONE &&
				    strcmp(e->props[i].name, names[set][c]) == 0)
					rgb[c] = i;
			if (rgb[c] < 0)
				break;
		}
		if (c == 3)
			return;
	}
	rgb[0] = rgb[1] = rgb[2] = -1;
}

/* Gives vertex properties their slots once the whole header is known. */
static void
assign_slots(struct ply_header *h)
{
	static const char *const uv_names[][2] = {
		{"u", "v"}, {"s", "t"}, {"texture_u", "texture_v"},
		{"texture_s", "texture_t"},
	};
	static const char *const xyz[] = {"x", "y", "z", "nx", "ny", "nz"};
	struct ply_elem *e = &h->elems[h->vertex];
	int found[S_COUNT], i, k, pair;

	for (k = 0; k < S_COUNT; k++)
		found[k] = -1;
	for (i = 0; i < e->nprops; i++) {
		e->props[i].slot = -1;
		if (e->props[i].count != PT_NONE)
			continue;
		for (k = 0; k < 6; k++)
			if (found[k] < 0 && strcmp(e->props[i].name, xyz[k]) == 0)
				found[k] = i;
	}
	/* The first naming convention with both halves present wins. */
	for (pair = 0; pair < 4 && found[S_U] < 0; pair++) {
		int iu = -1, iv = -1;
		for (i = 0; i < e->nprops; i++) {
			if (e->props[i].count != PT_NONE)
				continue;
			if (iu < 0 && strcmp(e->props[i].name, uv_names[pair][0]) == 0)
				iu = i;
			if (iv < 0 && strcmp(e->props[i].name, uv_names[pair][1]) == 0)
				iv = i;
		}
		if (iu >= 0 && iv >= 0) {
			found[S_U] = iu;
			found[S_V] = iv;
		}
	}
	find_color(e, &found[S_R]);
	h->has_nrm = found[S_NX] >= 0 && found[S_NY] >= 0 && found[S_NZ] >= 0;
	h->has_uv = found[S_U] >= 0;
	h->has_vcolor = found[S_R] >= 0;
	for (k = 0; k < S_COUNT; k++) {
		if (found[k] < 0)
			continue;
		if ((k >= S_NX && k <= S_NZ && !h->has_nrm))
			continue;
		e->props[found[k]].slot = k;
	}
	h->fcolor[0] = h->fcolor[1] = h->fcolor[2] = -1;
	if (h->face >= 0)
		find_color(&h->elems[h->face], h->fcolor);
}

/*
 * Parses the header, leaving *data_off at the first byte of the data.
 * Every line is checked: an unknown keyword, type or format is an error.
 */
static enum pm_err
parse_header(const char *name, const unsigned char *buf, size_t len,
    struct ply_header *h, size_t *data_off, unsigned long *data_line,
    struct pm_error *err)
{
	size_t off = 0;
	unsigned long line = 0;
	char text[256], *tok[8];
	int ntok, i, done = 0;

	memset(h, 0, sizeof(*h));
	h->vertex = h->face = h->index_prop = -1;
	while (!done) {
		const unsigned char *nl;
		size_t n;
		struct ply_elem *e;

		if (off >= len)
			return pm_fail(err, PM_ERR_TRUNCATED, "%s:%lu: file ends "
			    "in the header (expected 'end_header')", name, line);
		nl = memchr(buf + off, '\n', len - off);
		if (nl == NULL)
			return pm_fail(err, PM_ERR_TRUNCATED, "%s:%lu: file ends "
			    "in the header (expected 'end_header')", name,
			    line + 1);
		n = (size_t)(nl - (buf + off));
		line++;
		if (n > 0 && buf[off + n - 1] == '\r')
			n--;
		if (line == 1) {
			if (n != 3 || memcmp(buf + off, "ply", 3) != 0)
				return pm_fail(err, PM_ERR_FORMAT, "%s:1: expected "
				    "'ply' (not a PLY file)", name);
			off = (size_t)(nl - buf) + 1;
			continue;
		}
		/* Comments may be as long as they like. */
		if ((n >= 7 && memcmp(buf + off, "comment", 7) == 0 &&
		    (n == 7 || buf[off + 7] == ' ' || buf[off + 7] == '\t')) ||
		    (n >= 8 && memcmp(buf + off, "obj_info", 8) == 0 &&
		    (n == 8 || buf[off + 8] == ' ' || buf[off + 8] == '\t'))) {
			off = (size_t)(nl - buf) + 1;
			continue;
		}
		if (n >= sizeof(text))
			return pm_fail(err, PM_ERR_FORMAT, "%s:%lu: header line "
			    "of %zu characters (expected at most %zu)", name,
			    line, n, sizeof(text) - 1);
		memcpy(text, buf + off, n);
		text[n] = '\0';
		if (memchr(text, '\0', n) != NULL)
			return pm_fail(err, PM_ERR_FORMAT, "%s:%lu: NUL byte in "
			    "the header", name, line);
		off = (size_t)(nl - buf) + 1;
		ntok = tokenize(text, tok, 6);
		if (ntok == 0)
			return pm_fail(err, PM_ERR_FORMAT, "%s:%lu: empty header "
			    "line", name, line);

		if (strcmp(tok[0], "format") == 0) {
			if (h->format != 0 || ntok != 3)
				return pm_fail(err, PM_ERR_FORMAT, "%s:%lu: expected "
				    "one 'format <type> 1.0' line", name, line);
			if (strcmp(tok[1], "ascii") == 0)
				h->format = PLY_ASCII;
			else if (strcmp(tok[1], "binary_little_endian") == 0)
				h->format = PLY_BLE;
			else if (strcmp(tok[1], "binary_big_endian") == 0)
				h->format = PLY_BBE;
			else
				return pm_fail(err, PM_ERR_FORMAT, "%s:%lu: format "
				    "'%s' (expected ascii, binary_little_endian "
				    "or binary_big_endian)", name, line, tok[1]);
			if (strcmp(tok[2], "1.0") != 0)
				return pm_fail(err, PM_ERR_UNSUPPORTED, "%s:%lu: "
				    "version '%s' (expected 1.0)", name, line,
				    tok[2]);
		} else if (strcmp(tok[0], "element") == 0) {
			if (ntok != 3)
				return pm_fail(err, PM_ERR_FORMAT, "%s:%lu: expected "
				    "'element <name> <count>'", name, line);
			if (h->nelems == PLY_MAX_ELEMS)
				return pm_fail(err, PM_ERR_LIMIT, "%s:%lu: more "
				    "than %d elements", name, line, PLY_MAX_ELEMS);
			if (strlen(tok[1]) >= PLY_NAME_MAX)
				return pm_fail(err, PM_ERR_LIMIT, "%s:%lu: element "
				    "name longer than %d characters", name, line,
				    PLY_NAME_MAX - 1);
			e = &h->elems[h->nelems];
			strcpy(e->name, tok[1]);
			if (!parse_count(tok[2], &e->count))
				return pm_fail(err, PM_ERR_FORMAT, "%s:%lu: element "
				    "count '%s' (expected a non-negative integer)",
				    name, line, tok[2]);
			for (i = 0; i < h->nelems; i++)
				if (strcmp(h->elems[i].name, e->name) == 0)
					return pm_fail(err, PM_ERR_FORMAT,
					    "%s:%lu: element '%s' declared twice",
					    name, line, e->name);
			if (strcmp(e->name, "vertex") == 0)
				h->vertex = h->nelems;
			else if (strcmp(e->name, "face") == 0)
				h->face = h->nelems;
			h->nelems++;
		} else if (strcmp(tok[0], "property") == 0) {
			struct ply_prop *p;
			const char *pname;

			if (h->nelems == 0)
				return pm_fail(err, PM_ERR_FORMAT, "%s:%lu: "
				    "'property' before any 'element'", name,
				    line);
			e = &h->elems[h->nelems - 1];
			if (e->nprops == PLY_MAX_PROPS)
				return pm_fail(err, PM_ERR_LIMIT, "%s:%lu: more "
				    "than %d properties in element '%s'", name,
				    line, PLY_MAX_PROPS, e->name);
			p = &e->props[e->nprops];
			p->slot = -1;
			if (ntok == 5 && strcmp(tok[1], "list") == 0) {
				p->count = parse_type(tok[2]);
				p->type = parse_type(tok[3]);
				pname = tok[4];
				if (p->count == PT_NONE || p->type == PT_NONE)
					return pm_fail(err, PM_ERR_FORMAT, "%s:%lu: "
					    "list types '%s %s' (expected scalar "
					    "types such as uchar int)", name, line,
					    tok[2], tok[3]);
				if (!type_is_int(p->count))
					return pm_fail(err, PM_ERR_FORMAT, "%s:%lu: "
					    "list count type '%s' (expected an "
					    "integer type)", name, line, tok[2]);
			} else if (ntok == 3) {
				p->count = PT_NONE;
				p->type = parse_type(tok[1]);
				pname = tok[2];
				if (p->type == PT_NONE)
					return pm_fail(err, PM_ERR_FORMAT, "%s:%lu: "
					    "type '%s' (expected char, uchar, short, "
					    "ushort, int, uint, float or double)", name,
					    line, tok[1]);
			} else
				return pm_fail(err, PM_ERR_FORMAT, "%s:%lu: expected "
				    "'property <type> <name>' or 'property list "
				    "<count type> <type> <name>'", name, line);
			if (strlen(pname) >= PLY_NAME_MAX)
				return pm_fail(err, PM_ERR_LIMIT, "%s:%lu: property "
				    "name longer than %d characters", name, line,
				    PLY_NAME_MAX - 1);
			strcpy(p->name, pname);
			e->nprops++;
		} else if (strcmp(tok[0], "end_header") == 0) {
			if (ntok != 1)
				return pm_fail(err, PM_ERR_FORMAT, "%s:%lu: text "
				    "after 'end_header'", name, line);
			done = 1;
		} else
			return pm_fail(err, PM_ERR_FORMAT, "%s:%lu: '%s' (expected "
			    "format, element, property, comment or end_header)",
			    name, line, tok[0]);
	}

	if (h->format == 0)
		return pm_fail(err, PM_ERR_FORMAT, "%s: no 'format' line in the "
		    "header", name);
	if (h->vertex < 0 || h->face < 0)
		return pm_fail(err, PM_ERR_UNSUPPORTED, "%s: no '%s' element "
		    "(expected a triangle mesh with vertex and face elements)",
		    name, h->vertex < 0 ? "vertex" : "face");
	for (i = 0; i < h->nelems; i++)
		if (h->elems[i].nprops == 0 && h->elems[i].count > 0)
			return pm_fail(err, PM_ERR_FORMAT, "%s: element '%s' has "
			    "no properties", name, h->elems[i].name);
	assign_slots(h);
	{
		struct ply_elem *v = &h->elems[h->vertex];
		int seen = 0;

		for (i = 0; i < v->nprops; i++)
			if (v->props[i].slot >= S_X && v->props[i].slot <= S_Z)
				seen |= 1 << v->props[i].slot;
		if (seen != 7)
			return pm_fail(err, PM_ERR_FORMAT, "%s: the vertex element "
			    "lacks scalar property %s", name,
			    !(seen & 1) ? "x" : !(seen & 2) ? "y" : "z");
	}
	{
		struct ply_elem *f = &h->elems[h->face];

		for (i = 0; i < f->nprops && h->index_prop < 0; i++)
			if (f->props[i].count != PT_NONE &&
			    (strcmp(f->props[i].name, "vertex_indices") == 0 ||
			    strcmp(f->props[i].name, "vertex_index") == 0))
				h->index_prop = i;
		if (h->index_prop < 0)
			return pm_fail(err, PM_ERR_FORMAT, "%s: the face element "
			    "lacks a list property vertex_indices or "
			    "vertex_index", name);
		if (!type_is_int(f->props[h->index_prop].type))
			return pm_fail(err, PM_ERR_FORMAT, "%s: face indices of "
			    "a floating-point type (expected an integer type)",
			    name);
	}
	if (h->elems[h->vertex].count >= UINT32_MAX)
		return pm_fail(err, PM_ERR_LIMIT, "%s: %llu vertices (at most "
		    "%u supported)", name, h->elems[h->vertex].count,
		    UINT32_MAX - 1);
	if (h->elems[h->face].count >= UINT32_MAX)
		return pm_fail(err, PM_ERR_LIMIT, "%s: %llu faces (at most %u "
		    "supported)", name, h->elems[h->face].count,
		    UINT32_MAX - 1);
	*data_off = off;
	*data_line = line + 1;
	return PM_OK;
}

/*
 * Checks that the declared counts can fit in what follows the header:
 * each element takes at least its scalar sizes plus its list counts in
 * binary, and at least one character per value in ASCII.
 */
static enum pm_err
check_counts(const char *name, const struct ply_header *h, size_t remain,
    struct pm_error *err)
{
	unsigned long long need = 0;
	int i, k;

	for (i = 0; i < h->nelems; i++) {
		const struct ply_elem *e = &h->elems[i];
		unsigned long long min = 0;

		for (k = 0; k < e->nprops; k++) {
			const struct ply_prop *p = &e->props[k];
			if (h->format == PLY_ASCII)
				min += 1;
			else
				min += (unsigned long long)type_size(
				    p->count != PT_NONE ? p->count : p->type);
		}
		if (min > 0 && e->count > (remain - need) / min)
			return pm_fail(err, PM_ERR_TRUNCATED, "%s: %llu '%s' "
			    "elements need at least %llu bytes, but %zu bytes "
			    "follow the header", name, e->count, e->name,
			    min, remain);
		need += e->count * min;
	}
	return PM_OK;
}

static enum pm_err
truncated(struct ply_in *in, size_t want)
{
	if (in->format == PLY_ASCII)
		return pm_fail(in->err, PM_ERR_TRUNCATED, "%s:%lu: file ends "
		    "inside '%s' element %llu (expected a number)", in->name,
		    in->line, in->elem, in->item);
	return pm_fail(in->err, PM_ERR_TRUNCATED, "%s: byte %zu: file ends "
	    "inside '%s' element %llu (expected %zu more bytes)", in->name,
	    (size_t)(in->p - in->base), in->elem, in->item, want);
}

/* Reads one ASCII value of type t: integers must be integers in range. */
static enum pm_err
read_ascii(struct ply_in *in, enum ply_type t, double *out)
{
	char tok[72], *e;
	size_t n = 0;

	while (in->p < in->end && (*in->p == ' ' || *in->p == '\t' ||
	    *in->p == '\r' || *in->p == '\n')) {
		if (*in->p == '\n')
			in->line++;
		in->p++;
	}
	if (in->p >= in->end)
		return truncated(in, 1);
	while (in->p + n < in->end && n < sizeof(tok) - 1 &&
	    in->p[n] != ' ' && in->p[n] != '\t' && in->p[n] != '\r' &&
	    in->p[n] != '\n' && in->p[n] != '\0') {
		tok[n] = (char)in->p[n];
		n++;
	}
	tok[n] = '\0';
	if (n == 0 || n == sizeof(tok) - 1)
		goto bad;
	if (type_is_int(t)) {
		long long v;
		long long lo, hi;

		errno = 0;
		v = strtoll(tok, &e, 10);
		if (*e != '\0' || errno != 0)
			goto bad;
		switch (t) {
		case PT_I8:	lo = INT8_MIN; hi = INT8_MAX; break;
		case PT_U8:	lo = 0; hi = UINT8_MAX; break;
		case PT_I16:	lo = INT16_MIN; hi = INT16_MAX; break;
		case PT_U16:	lo = 0; hi = UINT16_MAX; break;
		case PT_I32:	lo = INT32_MIN; hi = INT32_MAX; break;
		default:	lo = 0; hi = UINT32_MAX; break;
		}
		if (v < lo || v > hi)
			goto bad;
		*out = (double)v;
	} else {
		*out = strtod(tok, &e);
		if (*e != '\0')
			goto bad;
	}
	in->p += n;
	return PM_OK;
bad:
	return pm_fail(in->err, PM_ERR_PARSE, "%s:%lu: '%.*s' in '%s' element "
	    "%llu (expected %s)", in->name, in->line, (int)(n > 40 ? 40 : n),
	    tok, in->elem, in->item, type_is_int(t) ? "an integer in the "
	    "range of its type" : "a number");
}

/* Reads one value of type t, converting it to double (exact for all). */
static enum pm_err
read_value(struct ply_in *in, enum ply_type t, double *out)
{
	unsigned char b[8];
	int size = type_size(t), i;
	uint64_t u = 0;

	if (in->format == PLY_ASCII)
		return read_ascii(in, t, out);
	if (in->end - in->p < size)
		return truncated(in, (size_t)size - (size_t)(in->end - in->p));
	if (in->format == PLY_BLE)
		for (i = 0; i < size; i++)
			b[i] = in->p[i];
	else
		for (i = 0; i < size; i++)
			b[i] = in->p[size - 1 - i];
	in->p += size;
	for (i = size - 1; i >= 0; i--)
		u = u << 8 | b[i];
	switch (t) {
	case PT_I8:	*out = (int8_t)(uint8_t)u; break;
	case PT_U8:	*out = (uint8_t)u; break;
	case PT_I16:	*out = (int16_t)(uint16_t)u; break;
	case PT_U16:	*out = (uint16_t)u; break;
	case PT_I32:	*out = (int32_t)(uint32_t)u; break;
	case PT_U32:	*out = (uint32_t)u; break;
	case PT_F32: {
		uint32_t w = (uint32_t)u;
		float f;
		memcpy(&f, &w, sizeof(f));
		*out = f;
		break;
	}
	case PT_F64: {
		double d;
		memcpy(&d, &u, sizeof(d));
		*out = d;
		break;
	}
	case PT_NONE:
		*out = 0.0;
		break;
	}
	return PM_OK;
}

/* Reads a list's count, which must be a non-negative integer. */
static enum pm_err
read_list_count(struct ply_in *in, const struct ply_prop *p, uint32_t *n)
{
	double v;
	enum pm_err e;

	if ((e = read_value(in, p->count, &v)) != PM_OK)
		return e;
	if (v < 0)
		return pm_fail(in->err, PM_ERR_FORMAT, "%s: '%s' element %llu: "
		    "list '%s' of %.0f items (expected a count of zero or more)",
		    in->name, in->elem, in->item, p->name, v);
	*n = (uint32_t)v;
	return PM_OK;
}

/* Skips one property of an element, list or scalar. */
static enum pm_err
skip_prop(struct ply_in *in, const struct ply_prop *p)
{
	uint32_t n = 1, i;
	double v;
	enum pm_err e;

	if (p->count != PT_NONE &&
	    (e = read_list_count(in, p, &n)) != PM_OK)
		return e;
	if (in->format != PLY_ASCII) {
		size_t bytes = (size_t)n * (size_t)type_size(p->type);
		if ((size_t)(in->end - in->p) < bytes)
			return truncated(in, bytes - (size_t)(in->end - in->p));
		in->p += bytes;
		return PM_OK;
	}
	for (i = 0; i < n; i++)
		if ((e = read_value(in, p->type, &v)) != PM_OK)
			return e;
	return PM_OK;
}

static enum pm_err
read_vertices(struct ply_in *in, const struct ply_header *h,
    struct pm_mesh *m)
{
	const struct ply_elem *el = &h->elems[h->vertex];
	double s[S_COUNT] = {0};
	enum pm_err e;
	int k;

	for (in->item = 0; in->item < el->count; in->item++) {
		size_t i = (size_t)in->item;

		for (k = 0; k < el->nprops; k++) {
			const struct ply_prop *p = &el->props[k];
			if (p->slot < 0)
				e = skip_prop(in, p);
			else
				e = read_value(in, p->type, &s[p->slot]);
			if (e != PM_OK)
				return e;
		}
		m->pos[3 * i] = (float)s[S_X];
		m->pos[3 * i + 1] = (float)s[S_Y];
		m->pos[3 * i + 2] = (float)s[S_Z];
		if (m->nrm != NULL) {
			m->nrm[3 * i] = (float)s[S_NX];
			m->nrm[3 * i + 1] = (float)s[S_NY];
			m->nrm[3 * i + 2] = (float)s[S_NZ];
		}
		if (m->uv != NULL) {
			m->uv[2 * i] = (float)s[S_U];
			m->uv[2 * i + 1] = (float)s[S_V];
		}
		/* as the file gives them, 8-bit ones too (Mitsuba 3 does
		 * not scale those to [0, 1] either) */
		if (m->vcolor != NULL) {
			m->vcolor[3 * i] = (float)s[S_R];
			m->vcolor[3 * i + 1] = (float)s[S_G];
			m->vcolor[3 * i + 2] = (float)s[S_B];
		}
	}
	return PM_OK;
}

/* Appends triangle (a, b, c), growing the index array by doubling. */
static enum pm_err
push_tri(struct ply_in *in, struct pm_mesh *m, size_t *cap, uint32_t a,
    uint32_t b, uint32_t c)
{
	if (m->ntris >= UINT32_MAX - 1)
		return pm_fail(in->err, PM_ERR_LIMIT, "%s: more than %u "
		    "triangles", in->name, UINT32_MAX - 1);
	if ((size_t)m->ntris == *cap) {
		size_t ncap = *cap < 1024 ? 1024 : *cap * 2;
		uint32_t *ni = realloc(m->idx, ncap * 3 * sizeof(uint32_t));
		if (ni == NULL)
			return pm_fail(in->err, PM_ERR_NOMEM, "%s: out of memory "
			    "for %zu triangles", in->name, ncap);
		m->idx = ni;
		if (m->fcolor != NULL) {
			float *nc = realloc(m->fcolor, ncap * 3 * sizeof(float));

			if (nc == NULL)
				return pm_fail(in->err, PM_ERR_NOMEM, "%s: out "
				    "of memory for %zu triangles", in->name,
				    ncap);
			m->fcolor = nc;
		}
		*cap = ncap;
	}
	m->idx[3 * (size_t)m->ntris] = a;
	m->idx[3 * (size_t)m->ntris + 1] = b;
	m->idx[3 * (size_t)m->ntris + 2] = c;
	m->ntris++;
	return PM_OK;
}

static enum pm_err
read_faces(struct ply_in *in, const struct ply_header *h, struct pm_mesh *m,
    size_t *cap)
{
	const struct ply_elem *el = &h->elems[h->face];
	uint32_t nv = (uint32_t)h->elems[h->vertex].count;
	enum pm_err e;
	int k;

	for (in->item = 0; in->item < el->count; in->item++) {
		uint32_t t0 = m->ntris, t;
		double col[3] = {0, 0, 0};

		for (k = 0; k < el->nprops; k++) {
			const struct ply_prop *p = &el->props[k];
			uint32_t n, j, first = 0, prev = 0, cur;
			double v;
			int c;

			for (c = 0; c < 3 && m->fcolor != NULL; c++)
				if (k == h->fcolor[c])
					break;
			if (m->fcolor != NULL && c < 3) {
				if ((e = read_value(in, p->type, &col[c]))
				    != PM_OK)
					return e;
				continue;
			}
			if (k != h->index_prop) {
				if ((e = skip_prop(in, p)) != PM_OK)
					return e;
				continue;
			}
			if ((e = read_list_count(in, p, &n)) != PM_OK)
				return e;
			if (n < 3)
				return pm_fail(in->err, PM_ERR_FORMAT, "%s: face "
				    "%llu has %u vertices (expected at least 3)",
				    in->name, in->item, n);
			for (j = 0; j < n; j++) {
				if ((e = read_value(in, p->type, &v)) != PM_OK)
					return e;
				if (v < 0 || v >= nv)
					return pm_fail(in->err, PM_ERR_FORMAT,
					    "%s: face %llu: vertex index %.0f "
					    "out of range (%u vertices)",
					    in->name, in->item, v, nv);
				cur = (uint32_t)v;
				if (j == 0)
					first = cur;
				else if (j >= 2 &&
				    (e = push_tri(in, m, cap, first, prev, cur)))
					return e;
				prev = cur;
			}
		}
		/* the face's colour on each of its triangles */
		for (t = t0; m->fcolor != NULL && t < m->ntris; t++) {
			m->fcolor[3 * (size_t)t] = (float)col[0];
			m->fcolor[3 * (size_t)t + 1] = (float)col[1];
			m->fcolor[3 * (size_t)t + 2] = (float)col[2];
		}
	}
	return PM_OK;
}

/* Normals must be unit length; a file with broken ones is shaded flat. */
static void
fix_normals(struct pm_mesh *m)
{
	uint32_t i;

	for (i = 0; i < m->nverts; i++) {
		float *n = m->nrm + 3 * (size_t)i;
		struct pm_vec3 v = pm_v3(n[0], n[1], n[2]);
		float len = pm_length(v);

		if (!(len > 0.0f) || !isfinite(len)) {
			free(m->nrm);
			m->nrm = NULL;
			return;
		}
		n[0] = v.x / len;
		n[1] = v.y / len;
		n[2] = v.z / len;
	}
}

/* Parses a PLY file held in memory into m; see ply.h. */
enum pm_err
pm_ply_parse(const char *name, const unsigned char *buf, size_t len,
    struct pm_mesh *m, struct pm_error *err)
{
	struct ply_header h;
	struct ply_in in;
	size_t off = 0, cap, nv;
	unsigned long line = 0;
	enum pm_err e;
	int i;

	memset(m, 0, sizeof(*m));
	if ((e = parse_header(name, buf, len, &h, &off, &line, err)) != PM_OK)
		return e;
	if ((e = check_counts(name, &h, len - off, err)) != PM_OK)
		return e;

	/* Counts are now known to be bounded by the file's size. */
	nv = (size_t)h.elems[h.vertex].count;
	cap = (size_t)h.elems[h.face].count;
	m->pos = malloc(nv * 3 * sizeof(float) + 1);
	m->nrm = h.has_nrm ? malloc(nv * 3 * sizeof(float) + 1) : NULL;
	m->uv = h.has_uv ? malloc(nv * 2 * sizeof(float) + 1) : NULL;
	m->idx = malloc(cap * 3 * sizeof(uint32_t) + 1);
	m->vcolor = h.has_vcolor ? malloc(nv * 3 * sizeof(float) + 1) : NULL;
	m->fcolor = h.fcolor[0] >= 0 ? malloc(cap * 3 * sizeof(float) + 1) :
	    NULL;
	if (m->pos == NULL || m->idx == NULL || (h.has_nrm && m->nrm == NULL) ||
	    (h.has_uv && m->uv == NULL) ||
	    (h.has_vcolor && m->vcolor == NULL) ||
	    (h.fcolor[0] >= 0 && m->fcolor == NULL)) {
		pm_mesh_free(m);
		return pm_fail(err, PM_ERR_NOMEM, "%s: out of memory for %zu "
		    "vertices", name, nv);
	}
	m->nverts = (uint32_t)nv;

	memset(&in, 0, sizeof(in));
	in.name = name;
	in.base = buf;
	in.p = buf + off;
	in.end = buf + len;
	in.format = h.format;
	in.line = line;
	in.err = err;
	for (i = 0; i < h.nelems && e == PM_OK; i++) {
		const struct ply_elem *el = &h.elems[i];
		int k;

		in.elem = el->name;
		if (i == h.vertex)
			e = read_vertices(&in, &h, m);
		else if (i == h.face)
			e = read_faces(&in, &h, m, &cap);
		else
			for (in.item = 0; in.item < el->count && e == PM_OK;
			    in.item++)
				for (k = 0; k < el->nprops && e == PM_OK; k++)
					e = skip_prop(&in, &el->props[k]);
	}
	if (e == PM_OK && m->ntris == 0)
		e = pm_fail(err, PM_ERR_FORMAT, "%s: no faces (expected at least "
		    "one triangle)", name);
	if (e != PM_OK) {
		pm_mesh_free(m);
		return e;
	}
	if (m->nrm != NULL)
		fix_normals(m);
	return PM_OK;
}

/* Reads the PLY file at path into m; see ply.h. */
enum pm_err
pm_ply_read(const char *path, struct pm_mesh *m, struct pm_error *err)
{
	char *buf;
	size_t len;
	enum pm_err e;

	memset(m, 0, sizeof(*m));
	if ((e = pm_read_file(path, SIZE_MAX, &buf, &len, err)) != PM_OK)
		return e;
	e = pm_ply_parse(path, (const unsigned char *)buf, len, m, err);
	free(buf);
	return e;
}
