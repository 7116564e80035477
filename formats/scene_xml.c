/*
 * scene_xml.c: reads the subset of Mitsuba 3's XML scene format that pm
 * supports (man/pm-scene.5) into a struct pm_scene.
 *
 * Loading runs in two passes.  The first reads the document with expat
 * into a small tree of elements, expanding <include>, <default>, <path>
 * and $name substitutions as it goes, so that every element keeps the file
 * and line it came from.  The second walks the tree and builds shapes,
 * BSDFs, lights, the camera and the integrator.  Building only after the
 * whole tree is known lets a shape refer to a BSDF or an area emitter
 * declared further down, as Mitsuba's own Cornell box does.
 *
 * Nothing is skipped silently: an element, plugin type or parameter
 * outside the subset is an error naming the file, the line and what was
 * expected.  Every allocation of the first pass lives in one arena that
 * is freed when loading ends.
 */
#include <ctype.h>
#include <errno.h>
#include <expat.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <unistd.h>

#include "../common/merl.h"
#include "../common/parse.h"
#include "merl.h"
#include "obj.h"
#include "ply.h"
#include "scene_xml.h"

#define MAX_DEPTH		64	/* element nesting */
#define MAX_INCLUDE_DEPTH	32
#define MAX_FILE_SIZE		(256L << 20)
#define DISK_SEGMENTS		256
#define PI_D			3.14159265358979323846

/* Default indices of refraction (Mitsuba's table). */
#define IOR_BK7			1.5046f
#define IOR_AIR			1.000277f
#define IOR_POLYPROPYLENE	1.49f

/* ---------------------------------------------------------------- arena */

struct blk {
	struct blk *next;
	size_t used, cap;
	max_align_t data[];
};

struct arena {
	struct blk *head;
};

static void *
arena_alloc(struct arena *a, size_t n)
{
	struct blk *b = a->head;
	size_t al = sizeof(max_align_t);
	void *p;

	n = (n + al - 1) / al * al;
	if (b == NULL || b->cap - b->used < n) {
		size_t cap = n > 65536 ? n : 65536;

		b = malloc(sizeof(*b) + cap);
		if (b == NULL)
			return NULL;
		b->next = a->head;
		b->used = 0;
		b->cap = cap;
		a->head = b;
	}
	p = (char *)b->data + b->used;
	b->used += n;
	memset(p, 0, n);
	return p;
}

static char *
arena_strndup(struct arena *a, const char *s, size_t n)
{
	char *p = arena_alloc(a, n + 1);

	if (p != NULL) {
		memcpy(p, s, n);
		p[n] = '\0';
	}
	return p;
}

static char *
arena_strdup(struct arena *a, const char *s)
{
	return arena_strndup(a, s, strlen(s));
}

static void
arena_free(struct arena *a)
{
	struct blk *b, *next;

	for (b = a->head; b != NULL; b = next) {
		next = b->next;
		free(b);
	}
	a->head = NULL;
}

/* ---------------------------------------------------------------- tree */

struct xnode {
	const char *tag;
	const char **attr;		/* name, value, ..., NULL */
	const char *file;
	const char *dir;		/* of file: where its names resolve */
	int line;
	int seq;			/* document order, for messages */
	struct xnode *parent, *kids, *last, *next;
	int inst;			/* bsdf index, or carrying shape; -1 */
	bool busy;			/* being built: catches reference cycles */
};

struct param {				/* a -D define or a <default> */
	const char *name, *value;
	struct param *next;
};

struct dir {				/* a <path> search directory */
	const char *path;
	struct dir *next;
};

struct idmap {
	const char *id;
	struct xnode *node;
};

struct ld {
	struct pm_scene *s;
	struct pm_error *err;
	struct arena arena;
	bool failed;
	struct param *params, *params_last;
	struct dir *dirs, *dirs_last;
	const char *top_dir;
	struct xnode *root;
	struct idmap *ids;
	size_t nids;
	const char *incl[MAX_INCLUDE_DEPTH + 1];	/* real paths */
	int nincl;
	int default_bsdf;
	struct xnode *sensor, *integrator;
	int seq;
};

struct doc {				/* one file being read by expat */
	struct ld *ld;
	XML_Parser p;
	const char *file;
	const char *dir;
	struct xnode *cur;
	struct xnode *graft;		/* include: where children go */
	int depth;
};

static enum pm_err
vfail_at(struct ld *ld, const char *file, int line, enum pm_err code,
    const char *fmt, va_list ap)
{
	char msg[900];

	vsnprintf(msg, sizeof(msg), fmt, ap);
	ld->failed = true;
	return pm_fail(ld->err, code, "%s:%d: %s", file, line, msg);
}

static enum pm_err
fail_at(struct ld *ld, const char *file, int line, enum pm_err code,
    const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 5, 6)))
#endif
    ;

static enum pm_err
fail_at(struct ld *ld, const char *file, int line, enum pm_err code,
    const char *fmt, ...)
{
	va_list ap;
	enum pm_err e;

	va_start(ap, fmt);
	e = vfail_at(ld, file, line, code, fmt, ap);
	va_end(ap);
	return e;
}

static enum pm_err
fail(struct ld *ld, const struct xnode *n, enum pm_err code,
    const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 4, 5)))
#endif
    ;

static enum pm_err
fail(struct ld *ld, const struct xnode *n, enum pm_err code,
    const char *fmt, ...)
{
	va_list ap;
	enum pm_err e;

	va_start(ap, fmt);
	e = vfail_at(ld, n->file, n->line, code, fmt, ap);
	va_end(ap);
	return e;
}

static enum pm_err
nomem(struct ld *ld)
{
	ld->failed = true;
	return pm_fail(ld->err, PM_ERR_NOMEM, "out of memory reading the scene");
}

static const char *
attr(const struct xnode *n, const char *name)
{
	const char **a;

	for (a = n->attr; a[0] != NULL; a += 2)
		if (strcmp(a[0], name) == 0)
			return a[1];
	return NULL;
}

/* Fails on an attribute not named in allowed (NULL-terminated). */
static enum pm_err
check_attrs(struct ld *ld, const struct xnode *n, const char *const *allowed)
{
	const char **a;
	const char *const *ok;

	for (a = n->attr; a[0] != NULL; a += 2) {
		for (ok = allowed; *ok != NULL; ok++)
			if (strcmp(a[0], *ok) == 0)
				break;
		if (*ok == NULL)
			return fail(ld, n, PM_ERR_UNSUPPORTED,
			    "unexpected attribute \"%s\" in <%s>", a[0], n->tag);
	}
	return PM_OK;
}

static enum pm_err
need_attr(struct ld *ld, const struct xnode *n, const char *name,
    const char **out)
{
	*out = attr(n, name);
	if (*out == NULL)
		return fail(ld, n, PM_ERR_INVALID,
		    "<%s> needs the attribute \"%s\"", n->tag, name);
	return PM_OK;
}

/* ---------------------------------------------------------------- files */

static char *
dir_of(struct arena *a, const char *path)
{
	const char *slash = strrchr(path, '/');

	if (slash == NULL)
		return arena_strdup(a, ".");
	if (slash == path)
		return arena_strdup(a, "/");
	return arena_strndup(a, path, (size_t)(slash - path));
}

static char *
join(struct arena *a, const char *dir, const char *name)
{
	size_t nd, nn;
	char *p;

	if (name[0] == '/' || dir == NULL || strcmp(dir, ".") == 0)
		return arena_strdup(a, name);
	nd = strlen(dir);
	nn = strlen(name);
	p = arena_alloc(a, nd + nn + 2);
	if (p == NULL)
		return NULL;
	memcpy(p, dir, nd);
	p[nd] = '/';
	memcpy(p + nd + 1, name, nn + 1);
	return p;
}

/*
 * Finds a file named in the scene: absolute names as they are, relative
 * ones in the directory of the file that names them, then that of the
 * top-level scene file, then each <path> in order.
 */
static enum pm_err
resolve(struct ld *ld, const struct xnode *n, const char *naming_dir,
    const char *name, const char **out)
{
	const char *cand[2];
	struct dir *d;
	int i;

	if (name[0] == '\0')
		return fail(ld, n, PM_ERR_INVALID, "empty file name in <%s>",
		    n->tag);
	if (name[0] == '/') {
		*out = name;
		if (access(name, F_OK) != 0)
			return fail(ld, n, PM_ERR_IO, "%s: %s", name,
			    strerror(errno));
		return PM_OK;
	}
	cand[0] = naming_dir != NULL ? naming_dir : ".";
	cand[1] = ld->top_dir;
	for (i = 0; i < 2; i++) {
		if (cand[i] == NULL)
			continue;
		if ((*out = join(&ld->arena, cand[i], name)) == NULL)
			return nomem(ld);
		if (access(*out, F_OK) == 0)
			return PM_OK;
	}
	for (d = ld->dirs; d != NULL; d = d->next) {
		if ((*out = join(&ld->arena, d->path, name)) == NULL)
			return nomem(ld);
		if (access(*out, F_OK) == 0)
			return PM_OK;
	}
	if (cand[1] == NULL || strcmp(cand[0], cand[1]) == 0)
		cand[1] = NULL;
	return fail(ld, n, PM_ERR_IO,
	    "cannot find \"%s\" (looked in %s%s%s%s)", name, cand[0],
	    cand[1] != NULL ? ", " : "", cand[1] != NULL ? cand[1] : "",
	    ld->dirs != NULL ? " and each <path>" : "");
}

static enum pm_err
read_whole(const char *path, char **buf, size_t *len, struct pm_error *err)
{
	FILE *f;
	char *p = NULL, *q;
	size_t cap = 0, n = 0, got;

	if ((f = fopen(path, "rb")) == NULL)
		return pm_fail(err, PM_ERR_IO, "%s: %s", path, strerror(errno));
	for (;;) {
		if (cap - n < 65536) {
			if (cap >= (size_t)MAX_FILE_SIZE) {
				free(p);
				fclose(f);
				return pm_fail(err, PM_ERR_LIMIT,
				    "%s: larger than %ld bytes", path,
				    MAX_FILE_SIZE);
			}
			cap = cap == 0 ? 65536 : 2 * cap;
			if ((q = realloc(p, cap)) == NULL) {
				free(p);
				fclose(f);
				return pm_fail(err, PM_ERR_NOMEM,
				    "%s: out of memory", path);
			}
			p = q;
		}
		got = fread(p + n, 1, cap - n, f);
		n += got;
		if (got == 0)
			break;
	}
	if (ferror(f)) {
		free(p);
		fclose(f);
		return pm_fail(err, PM_ERR_IO, "%s: read error", path);
	}
	fclose(f);
	*buf = p;
	*len = n;
	return PM_OK;
}

/* ---------------------------------------------------------------- pass 1 */

static bool
is_ident_start(int c)
{
	return isalpha(c) || c == '_';
}

static bool
is_ident(int c)
{
	return isalnum(c) || c == '_';
}

static const char *
param_lookup(struct ld *ld, const char *name, size_t n)
{
	struct param *p;

	for (p = ld->params; p != NULL; p = p->next)
		if (strlen(p->name) == n && strncmp(p->name, name, n) == 0)
			return p->value;
	return NULL;
}

static enum pm_err
param_add(struct ld *ld, const char *name, const char *value)
{
	struct param *p = arena_alloc(&ld->arena, sizeof(*p));

	if (p == NULL)
		return nomem(ld);
	p->name = name;
	p->value = value;
	if (ld->params_last != NULL)
		ld->params_last->next = p;
	else
		ld->params = p;
	ld->params_last = p;
	return PM_OK;
}

/* Replaces each $name in s by its value; an unknown name is an error. */
static enum pm_err
substitute(struct ld *ld, struct doc *d, int line, const char *s,
    const char **out)
{
	const char *p, *v, *name;
	size_t n = 0, cap, len;
	char *buf;

	if (strchr(s, '$') == NULL) {
		*out = arena_strdup(&ld->arena, s);
		return *out == NULL ? nomem(ld) : PM_OK;
	}
	/* First pass: the length of the result. */
	for (p = s; *p != '\0'; ) {
		if (p[0] == '$' && is_ident_start((unsigned char)p[1])) {
			name = ++p;
			while (is_ident((unsigned char)*p))
				p++;
			v = param_lookup(ld, name, (size_t)(p - name));
			if (v == NULL)
				return fail_at(ld, d->file, line, PM_ERR_INVALID,
				    "undefined parameter $%.*s (no <default> "
				    "or -D defines it)", (int)(p - name), name);
			n += strlen(v);
		} else {
			n++;
			p++;
		}
	}
	cap = n + 1;
	if ((buf = arena_alloc(&ld->arena, cap)) == NULL)
		return nomem(ld);
	n = 0;
	for (p = s; *p != '\0'; ) {
		if (p[0] == '$' && is_ident_start((unsigned char)p[1])) {
			name = ++p;
			while (is_ident((unsigned char)*p))
				p++;
			v = param_lookup(ld, name, (size_t)(p - name));
			len = strlen(v);
			memcpy(buf + n, v, len);
			n += len;
		} else {
			buf[n++] = *p++;
		}
	}
	buf[n] = '\0';
	*out = buf;
	return PM_OK;
}

static enum pm_err parse_doc(struct ld *ld, const char *file, const char *buf,
    size_t len, struct xnode *graft);

static bool
is_blank(const char *s, size_t len)
{
	size_t i;

	for (i = 0; i < len; i++)
		if (!isspace((unsigned char)s[i]))
			return false;
	return true;
}

/* Checks a version attribute: Mitsuba 2 or 3, "M.m.p" or "M.m". */
static bool
version_ok(const char *v)
{
	const char *p;

	if (!(v[0] == '2' || v[0] == '3') || v[1] != '.')
		return false;
	for (p = v + 2; *p != '\0'; p++)
		if (!isdigit((unsigned char)*p) && *p != '.')
			return false;
	return isdigit((unsigned char)v[2]) && p[-1] != '.';
}

static enum pm_err
do_include(struct ld *ld, struct doc *d, struct xnode *n)
{
	static const char *const ok[] = {"filename", NULL};
	const char *name, *path;
	char *real, *buf;
	size_t len;
	enum pm_err e;
	int i;

	if ((e = check_attrs(ld, n, ok)) != PM_OK ||
	    (e = need_attr(ld, n, "filename", &name)) != PM_OK ||
	    (e = resolve(ld, n, d->dir, name, &path)) != PM_OK)
		return e;
	if ((real = realpath(path, NULL)) == NULL)
		return fail(ld, n, PM_ERR_IO, "%s: %s", path, strerror(errno));
	for (i = 0; i < ld->nincl; i++) {
		if (strcmp(ld->incl[i], real) == 0) {
			free(real);
			return fail(ld, n, PM_ERR_INVALID,
			    "include cycle: \"%s\" includes itself, directly "
			    "or through the files it includes", path);
		}
	}
	if (ld->nincl >= MAX_INCLUDE_DEPTH) {
		free(real);
		return fail(ld, n, PM_ERR_LIMIT,
		    "includes nested deeper than %d", MAX_INCLUDE_DEPTH);
	}
	ld->incl[ld->nincl] = arena_strdup(&ld->arena, real);
	free(real);
	if (ld->incl[ld->nincl] == NULL)
		return nomem(ld);
	ld->nincl++;
	if ((e = read_whole(path, &buf, &len, ld->err)) != PM_OK) {
		char msg[sizeof(ld->err->msg)];

		snprintf(msg, sizeof(msg), "%s", ld->err->msg);
		ld->nincl--;
		return fail(ld, n, e, "<include>: %s", msg);
	}
	e = parse_doc(ld, path, buf, len, ld->root);
	free(buf);
	ld->nincl--;
	return e;
}

static enum pm_err
do_default(struct ld *ld, struct xnode *n)
{
	static const char *const ok[] = {"name", "value", NULL};
	const char *name, *value, *p;
	enum pm_err e;

	if ((e = check_attrs(ld, n, ok)) != PM_OK ||
	    (e = need_attr(ld, n, "name", &name)) != PM_OK ||
	    (e = need_attr(ld, n, "value", &value)) != PM_OK)
		return e;
	if (!is_ident_start((unsigned char)name[0]))
		return fail(ld, n, PM_ERR_INVALID,
		    "<default> name \"%s\" is not an identifier", name);
	for (p = name; *p != '\0'; p++)
		if (!is_ident((unsigned char)*p))
			return fail(ld, n, PM_ERR_INVALID,
			    "<default> name \"%s\" is not an identifier", name);
	/* A -D define, or an earlier default, wins. */
	if (param_lookup(ld, name, strlen(name)) != NULL)
		return PM_OK;
	return param_add(ld, name, value);
}

static enum pm_err
do_path(struct ld *ld, struct doc *d, struct xnode *n)
{
	static const char *const ok[] = {"value", NULL};
	const char *value;
	struct dir *dir;
	enum pm_err e;

	if ((e = check_attrs(ld, n, ok)) != PM_OK ||
	    (e = need_attr(ld, n, "value", &value)) != PM_OK)
		return e;
	if ((dir = arena_alloc(&ld->arena, sizeof(*dir))) == NULL ||
	    (dir->path = join(&ld->arena, d->dir, value)) == NULL)
		return nomem(ld);
	if (ld->dirs_last != NULL)
		ld->dirs_last->next = dir;
	else
		ld->dirs = dir;
	ld->dirs_last = dir;
	return PM_OK;
}

static bool
is_directive(const char *tag)
{
	return strcmp(tag, "include") == 0 || strcmp(tag, "default") == 0 ||
	    strcmp(tag, "path") == 0;
}

static void XMLCALL
on_start(void *ud, const XML_Char *tag, const XML_Char **atts)
{
	struct doc *d = ud;
	struct ld *ld = d->ld;
	struct xnode *n;
	size_t na, i;
	int line;
	enum pm_err e = PM_OK;

	if (ld->failed)
		return;
	line = (int)XML_GetCurrentLineNumber(d->p);
	if (d->depth >= MAX_DEPTH) {
		fail_at(ld, d->file, line, PM_ERR_LIMIT,
		    "elements nested deeper than %d", MAX_DEPTH);
		goto stop;
	}
	if ((n = arena_alloc(&ld->arena, sizeof(*n))) == NULL)
		goto oom;
	for (na = 0; atts[2 * na] != NULL; na++)
		;
	if ((n->attr = arena_alloc(&ld->arena,
	    (2 * na + 1) * sizeof(*n->attr))) == NULL ||
	    (n->tag = arena_strdup(&ld->arena, tag)) == NULL)
		goto oom;
	n->file = d->file;
	n->dir = d->dir;
	n->line = line;
	n->seq = ld->seq++;
	n->inst = -1;
	for (i = 0; i < na; i++) {
		if ((n->attr[2 * i] = arena_strdup(&ld->arena,
		    atts[2 * i])) == NULL)
			goto oom;
		if (substitute(ld, d, line, atts[2 * i + 1],
		    &n->attr[2 * i + 1]) != PM_OK)
			goto stop;
	}
	n->attr[2 * na] = NULL;

	if (d->depth == 0) {
		static const char *const ok[] = {"version", NULL};
		const char *v;

		if (strcmp(tag, "scene") != 0) {
			fail(ld, n, PM_ERR_INVALID,
			    "expected <scene> as the root element, found <%s>",
			    tag);
			goto stop;
		}
		if (check_attrs(ld, n, ok) != PM_OK ||
		    need_attr(ld, n, "version", &v) != PM_OK)
			goto stop;
		if (!version_ok(v)) {
			fail(ld, n, PM_ERR_UNSUPPORTED,
			    "<scene> version \"%s\": pm reads Mitsuba 2 and 3 "
			    "scenes (version 2.x or 3.x)", v);
			goto stop;
		}
		if (d->graft != NULL) {
			d->cur = d->graft;
		} else {
			ld->root = n;
			d->cur = n;
		}
		d->depth++;
		return;
	}

	if (is_directive(d->cur->tag)) {
		fail(ld, n, PM_ERR_INVALID, "<%s> takes no child elements, "
		    "found <%s>", d->cur->tag, tag);
		goto stop;
	}
	n->parent = d->cur;
	if (is_directive(tag)) {
		/* Handled now, so that later elements see their effect;
		 * never linked into the tree. */
		if (d->depth != 1) {
			fail(ld, n, PM_ERR_INVALID,
			    "<%s> must be a child of <scene>, not of <%s>",
			    tag, d->cur->tag);
			goto stop;
		}
		if (strcmp(tag, "include") == 0)
			e = do_include(ld, d, n);
		else if (strcmp(tag, "default") == 0)
			e = do_default(ld, n);
		else
			e = do_path(ld, d, n);
		if (e != PM_OK)
			goto stop;
	} else {
		if (d->cur->last != NULL)
			d->cur->last->next = n;
		else
			d->cur->kids = n;
		d->cur->last = n;
	}
	d->cur = n;
	d->depth++;
	return;
oom:
	nomem(ld);
stop:
	XML_StopParser(d->p, XML_FALSE);
}

static void XMLCALL
on_end(void *ud, const XML_Char *tag)
{
	struct doc *d = ud;

	(void)tag;
	if (d->ld->failed)
		return;
	d->depth--;
	d->cur = d->depth > 0 ? d->cur->parent : NULL;
}

static void XMLCALL
on_text(void *ud, const XML_Char *s, int len)
{
	struct doc *d = ud;
	int i;
	int line;

	if (d->ld->failed)
		return;
	/* The chunk may start on an earlier line than its text. */
	line = (int)XML_GetCurrentLineNumber(d->p);
	for (i = 0; i < len; i++) {
		if (s[i] == '\n')
			line++;
		if (!isspace((unsigned char)s[i])) {
			int n = 0;

			while (i + n < len && n < 40 && s[i + n] != '\n')
				n++;
			fail_at(d->ld, d->file, line, PM_ERR_PARSE,
			    "unexpected text \"%.*s\" in <%s>", n, s + i,
			    d->cur != NULL ? d->cur->tag : "document");
			XML_StopParser(d->p, XML_FALSE);
			return;
		}
	}
}

/* Reads one file (or string) into the tree; graft is the <scene> node
 * that receives an included file's elements. */
static enum pm_err
parse_doc(struct ld *ld, const char *file, const char *buf, size_t len,
    struct xnode *graft)
{
	struct doc d;
	enum XML_Status st;

	memset(&d, 0, sizeof(d));
	d.ld = ld;
	d.graft = graft;
	if ((d.file = arena_strdup(&ld->arena, file)) == NULL ||
	    (d.dir = dir_of(&ld->arena, file)) == NULL)
		return nomem(ld);
	if (graft == NULL && ld->top_dir != NULL)
		d.dir = ld->top_dir;
	if (len > (size_t)INT_MAX)
		return fail_at(ld, d.file, 1, PM_ERR_LIMIT, "file too large");
	if (is_blank(buf, len))
		return fail_at(ld, d.file, 1, PM_ERR_PARSE,
		    "empty file: expected a <scene> element");
	if ((d.p = XML_ParserCreate(NULL)) == NULL)
		return nomem(ld);
	XML_SetUserData(d.p, &d);
	XML_SetElementHandler(d.p, on_start, on_end);
	XML_SetCharacterDataHandler(d.p, on_text);
	st = XML_Parse(d.p, buf, (int)len, 1);
	if (st != XML_STATUS_OK && !ld->failed)
		fail_at(ld, d.file, (int)XML_GetCurrentLineNumber(d.p),
		    PM_ERR_PARSE, "malformed XML: %s",
		    XML_ErrorString(XML_GetErrorCode(d.p)));
	XML_ParserFree(d.p);
	return ld->failed ? ld->err->code : PM_OK;
}

/* ---------------------------------------------------------------- ids */

static int
idcmp(const void *a, const void *b)
{
	const struct idmap *x = a, *y = b;

	return strcmp(x->id, y->id);
}

/* By id, then in document order. */
static int
idcmp_seq(const void *a, const void *b)
{
	const struct idmap *x = a, *y = b;
	int c = strcmp(x->id, y->id);

	if (c != 0)
		return c;
	return (x->node->seq > y->node->seq) - (x->node->seq < y->node->seq);
}

static enum pm_err
collect_ids(struct ld *ld, struct xnode *n, size_t *count, bool store)
{
	struct xnode *k;
	const char *id = attr(n, "id");
	enum pm_err e;

	if (id != NULL && strcmp(n->tag, "ref") != 0) {
		if (store) {
			ld->ids[ld->nids].id = id;
			ld->ids[ld->nids].node = n;
			ld->nids++;
		} else {
			(*count)++;
		}
	}
	for (k = n->kids; k != NULL; k = k->next)
		if ((e = collect_ids(ld, k, count, store)) != PM_OK)
			return e;
	return PM_OK;
}

static enum pm_err
build_idmap(struct ld *ld)
{
	size_t count = 0, i;
	enum pm_err e;

	collect_ids(ld, ld->root, &count, false);
	if (count == 0)
		return PM_OK;
	if ((ld->ids = arena_alloc(&ld->arena, count * sizeof(*ld->ids))) == NULL)
		return nomem(ld);
	if ((e = collect_ids(ld, ld->root, &count, true)) != PM_OK)
		return e;
	qsort(ld->ids, ld->nids, sizeof(*ld->ids), idcmp_seq);
	for (i = 1; i < ld->nids; i++) {
		if (strcmp(ld->ids[i - 1].id, ld->ids[i].id) == 0) {
			const struct xnode *a = ld->ids[i - 1].node;

			return fail(ld, ld->ids[i].node, PM_ERR_INVALID,
			    "duplicate id \"%s\" (first at %s:%d)",
			    ld->ids[i].id, a->file, a->line);
		}
	}
	return PM_OK;
}

static struct xnode *
find_id(struct ld *ld, const char *id)
{
	struct idmap key, *hit;

	if (ld->nids == 0)
		return NULL;
	key.id = id;
	key.node = NULL;
	hit = bsearch(&key, ld->ids, ld->nids, sizeof(*ld->ids), idcmp);
	return hit != NULL ? hit->node : NULL;
}

/* The element a <ref> names; the caller checks its kind. */
static enum pm_err
deref(struct ld *ld, struct xnode *ref, struct xnode **out)
{
	static const char *const ok[] = {"id", "name", NULL};
	const char *id;
	enum pm_err e;

	if ((e = check_attrs(ld, ref, ok)) != PM_OK ||
	    (e = need_attr(ld, ref, "id", &id)) != PM_OK)
		return e;
	if (ref->kids != NULL)
		return fail(ld, ref->kids, PM_ERR_INVALID,
		    "<ref> takes no child elements, found <%s>", ref->kids->tag);
	if ((*out = find_id(ld, id)) == NULL)
		return fail(ld, ref, PM_ERR_INVALID,
		    "<ref id=\"%s\">: no object has this id", id);
	return PM_OK;
}

/* ---------------------------------------------------------------- values */

/* Splits s at runs of commas and white space, as Mitsuba does. */
static int
tokenize(char *s, char **tok, int max)
{
	int n = 0;

	for (;;) {
		while (*s == ',' || isspace((unsigned char)*s))
			s++;
		if (*s == '\0')
			return n;
		if (n == max)
			return max + 1;
		tok[n++] = s;
		while (*s != '\0' && *s != ',' && !isspace((unsigned char)*s))
			s++;
		if (*s != '\0')
			*s++ = '\0';
	}
}

static bool
number(const char *s, double *out)
{
	float f;
	char buf[128];
	size_t a = 0, b = strlen(s);

	while (a < b && isspace((unsigned char)s[a]))
		a++;
	while (b > a && isspace((unsigned char)s[b - 1]))
		b--;
	if (b - a >= sizeof(buf))
		return false;
	memcpy(buf, s + a, b - a);
	buf[b - a] = '\0';
	if (!pm_parse_float(buf, -3.4e38f, 3.4e38f, &f))
		return false;
	*out = f;
	return true;
}

/*
 * Parses between nmin and nmax numbers (only the counts 1 and 3 when nmin
 * is 1 and nmax 3) from attribute what of n.
 */
static enum pm_err
numbers(struct ld *ld, const struct xnode *n, const char *what,
    const char *s, double *out, int nmin, int nmax, int *count)
{
	char *copy, *tok[17];
	int k, i;

	if ((copy = arena_strdup(&ld->arena, s)) == NULL)
		return nomem(ld);
	k = tokenize(copy, tok, 16);
	if (k < nmin || k > nmax || (nmin == 1 && nmax == 3 && k == 2)) {
		if (nmin == nmax)
			return fail(ld, n, PM_ERR_PARSE, "<%s> %s=\"%s\": "
			    "expected %d numbers", n->tag, what, s, nmin);
		if (nmin == 9 && nmax == 16)
			return fail(ld, n, PM_ERR_PARSE, "<%s> %s=\"%s\": "
			    "expected 16 (4x4) or 9 (3x3) numbers", n->tag,
			    what, s);
		if (nmin == 1 && nmax == 3)
			return fail(ld, n, PM_ERR_PARSE, "<%s> %s=\"%s\": "
			    "expected 1 or 3 numbers", n->tag, what, s);
		return fail(ld, n, PM_ERR_PARSE, "<%s> %s=\"%s\": "
		    "expected %d to %d numbers", n->tag, what, s, nmin, nmax);
	}
	for (i = 0; i < k; i++)
		if (!number(tok[i], &out[i]))
			return fail(ld, n, PM_ERR_PARSE, "<%s> %s=\"%s\": "
			    "\"%s\" is not a finite number", n->tag, what, s,
			    tok[i]);
	*count = k;
	return PM_OK;
}

/*
 * x/y/z attributes, or value with 1 or 3 numbers (Mitsuba's
 * expand_value_to_xyz); missing components take def.
 */
static enum pm_err
xyz(struct ld *ld, const struct xnode *n, double def, struct pm_vec3 *out)
{
	static const char *const names[3] = {"x", "y", "z"};
	double v[3] = {def, def, def}, t[3];
	const char *val = attr(n, "value"), *c;
	int i, k;
	enum pm_err e;

	if (val != NULL) {
		if (attr(n, "x") || attr(n, "y") || attr(n, "z"))
			return fail(ld, n, PM_ERR_INVALID, "<%s>: give either "
			    "value or x, y, z, not both", n->tag);
		if ((e = numbers(ld, n, "value", val, t, 1, 3, &k)) != PM_OK)
			return e;
		for (i = 0; i < 3; i++)
			v[i] = k == 1 ? t[0] : t[i];
	} else {
		for (i = 0; i < 3; i++) {
			if ((c = attr(n, names[i])) == NULL)
				continue;
			if ((e = numbers(ld, n, names[i], c, &v[i], 1, 1, &k))
			    != PM_OK)
				return e;
		}
	}
	*out = pm_v3((float)v[0], (float)v[1], (float)v[2]);
	return PM_OK;
}

static enum pm_err
vec3_attr(struct ld *ld, const struct xnode *n, const char *name,
    struct pm_vec3 *out)
{
	double v[3];
	int k;
	enum pm_err e;

	if ((e = numbers(ld, n, name, attr(n, name), v, 3, 3, &k)) != PM_OK)
		return e;
	*out = pm_v3((float)v[0], (float)v[1], (float)v[2]);
	return PM_OK;
}

static enum pm_err
no_kids(struct ld *ld, const struct xnode *n)
{
	if (n->kids != NULL)
		return fail(ld, n->kids, PM_ERR_INVALID,
		    "unexpected <%s> inside <%s>", n->kids->tag, n->tag);
	return PM_OK;
}

/* A <transform>: each operation is applied after the previous ones,
 * M = Op * M, as Mitsuba does. */
static enum pm_err
parse_transform(struct ld *ld, const struct xnode *t, struct pm_mat4 *out)
{
	static const char *const ok_xyz[] = {"x", "y", "z", "value", NULL};
	static const char *const ok_rot[] = {"x", "y", "z", "value", "angle",
	    NULL};
	static const char *const ok_mat[] = {"value", NULL};
	static const char *const ok_look[] = {"origin", "target", "up", NULL};
	struct pm_mat4 M = pm_mat4_identity(), op;
	const struct xnode *k;
	struct pm_vec3 v, o, tg, up, dir;
	const char *s;
	double a, m[16];
	int cnt, i, j;
	enum pm_err e;

	for (k = t->kids; k != NULL; k = k->next) {
		if ((e = no_kids(ld, k)) != PM_OK)
			return e;
		if (strcmp(k->tag, "translate") == 0) {
			if ((e = check_attrs(ld, k, ok_xyz)) != PM_OK ||
			    (e = xyz(ld, k, 0.0, &v)) != PM_OK)
				return e;
			op = pm_mat4_translate(v);
		} else if (strcmp(k->tag, "scale") == 0) {
			if ((e = check_attrs(ld, k, ok_xyz)) != PM_OK ||
			    (e = xyz(ld, k, 1.0, &v)) != PM_OK)
				return e;
			op = pm_mat4_scale(v);
		} else if (strcmp(k->tag, "rotate") == 0) {
			if ((e = check_attrs(ld, k, ok_rot)) != PM_OK ||
			    (e = need_attr(ld, k, "angle", &s)) != PM_OK ||
			    (e = numbers(ld, k, "angle", s, &a, 1, 1, &cnt))
			    != PM_OK)
				return e;
			/* The angle is not part of value="x, y, z". */
			{
				struct xnode tmp = *k;
				const char *attrs[9];
				const char **src;
				int na = 0;

				for (src = k->attr; src[0] != NULL; src += 2) {
					if (strcmp(src[0], "angle") == 0)
						continue;
					attrs[na++] = src[0];
					attrs[na++] = src[1];
				}
				attrs[na] = NULL;
				tmp.attr = attrs;
				if ((e = xyz(ld, &tmp, 0.0, &v)) != PM_OK)
					return e;
			}
			if (pm_dot(v, v) == 0.0f)
				return fail(ld, k, PM_ERR_INVALID,
				    "<rotate> needs a non-zero axis");
			op = pm_mat4_rotate(v, (float)a);
		} else if (strcmp(k->tag, "matrix") == 0) {
			if ((e = check_attrs(ld, k, ok_mat)) != PM_OK ||
			    (e = need_attr(ld, k, "value", &s)) != PM_OK ||
			    (e = numbers(ld, k, "value", s, m, 9, 16, &cnt))
			    != PM_OK)
				return e;
			if (cnt != 9 && cnt != 16)
				return fail(ld, k, PM_ERR_PARSE, "<matrix> "
				    "value=\"%s\": expected 16 (4x4) or 9 "
				    "(3x3) numbers", s);
			op = pm_mat4_identity();
			for (i = 0; i < (cnt == 16 ? 4 : 3); i++)
				for (j = 0; j < (cnt == 16 ? 4 : 3); j++)
					op.m[i][j] = (float)m[i *
					    (cnt == 16 ? 4 : 3) + j];
		} else if (strcmp(k->tag, "lookat") == 0 ||
		    strcmp(k->tag, "look_at") == 0) {
			if ((e = check_attrs(ld, k, ok_look)) != PM_OK ||
			    (e = need_attr(ld, k, "origin", &s)) != PM_OK ||
			    (e = need_attr(ld, k, "target", &s)) != PM_OK ||
			    (e = vec3_attr(ld, k, "origin", &o)) != PM_OK ||
			    (e = vec3_attr(ld, k, "target", &tg)) != PM_OK)
				return e;
			dir = pm_sub(tg, o);
			if (pm_dot(dir, dir) == 0.0f)
				return fail(ld, k, PM_ERR_INVALID,
				    "<%s>: origin and target coincide", k->tag);
			if (attr(k, "up") != NULL) {
				if ((e = vec3_attr(ld, k, "up", &up)) != PM_OK)
					return e;
			} else {
				up = pm_v3(0, 0, 0);
			}
			if (pm_dot(up, up) == 0.0f) {
				/* Mitsuba: any vector perpendicular to dir. */
				up = pm_frame_from_normal(pm_normalize(dir)).s;
			}
			v = pm_cross(pm_normalize(up), pm_normalize(dir));
			if (pm_dot(v, v) < 1e-12f)
				return fail(ld, k, PM_ERR_INVALID,
				    "<%s>: up is parallel to the view "
				    "direction", k->tag);
			op = pm_mat4_lookat(o, tg, up);
		} else {
			return fail(ld, k, PM_ERR_UNSUPPORTED,
			    "unknown element <%s> in <transform> (expected "
			    "translate, rotate, scale, matrix or lookat)",
			    k->tag);
		}
		M = pm_mat4_mul(op, M);
	}
	for (i = 0; i < 4; i++)
		for (j = 0; j < 4; j++)
			if (!isfinite(M.m[i][j]))
				return fail(ld, t, PM_ERR_INVALID,
				    "<transform> is not finite");
	*out = M;
	return PM_OK;
}

/* ---------------------------------------------------------------- props */

enum ptype {
	P_FLOAT, P_INTEGER, P_BOOLEAN, P_STRING, P_RGB, P_SPECTRUM,
	P_POINT, P_VECTOR, P_TRANSFORM,
};

static const char *const ptype_name[] = {
	"float", "integer", "boolean", "string", "rgb", "spectrum",
	"point", "vector", "transform",
};

struct prop {
	const char *name;
	enum ptype type;
	const struct xnode *n;
	bool used;
	double f;		/* float, integer */
	long i;			/* integer */
	bool b;
	const char *s;
	struct pm_rgb c;	/* rgb, spectrum */
	struct pm_vec3 v;	/* point, vector */
	struct pm_mat4 m;
};

struct plist {
	const struct xnode *owner;
	char what[96];		/* "bsdf \"diffuse\"", for messages */
	struct prop *p;
	size_t n;
	struct xnode *obj[16];	/* nested objects and refs */
	size_t nobj;
};

static bool
is_object_tag(const char *t)
{
	static const char *const tags[] = {"bsdf", "emitter", "shape",
	    "sensor", "sampler", "film", "rfilter", "integrator", "ref", NULL};
	const char *const *p;

	for (p = tags; *p != NULL; p++)
		if (strcmp(t, *p) == 0)
			return true;
	return false;
}

static int
ptype_of(const char *t)
{
	int i;

	for (i = 0; i <= P_TRANSFORM; i++)
		if (strcmp(t, ptype_name[i]) == 0)
			return i;
	return -1;
}

static enum pm_err
parse_prop(struct ld *ld, const struct xnode *k, enum ptype t, struct prop *p)
{
	static const char *const ok_nv[] = {"name", "value", NULL};
	static const char *const ok_xyz[] = {"name", "value", "x", "y", "z",
	    NULL};
	static const char *const ok_t[] = {"name", NULL};
	const char *v = NULL;
	double d[3];
	int cnt;
	enum pm_err e;

	p->type = t;
	p->n = k;
	if ((e = check_attrs(ld, k, t == P_TRANSFORM ? ok_t :
	    t == P_POINT || t == P_VECTOR ? ok_xyz : ok_nv)) != PM_OK ||
	    (e = need_attr(ld, k, "name", &p->name)) != PM_OK)
		return e;
	if (t != P_TRANSFORM && (e = no_kids(ld, k)) != PM_OK)
		return e;
	if (t != P_TRANSFORM && t != P_POINT && t != P_VECTOR &&
	    (e = need_attr(ld, k, "value", &v)) != PM_OK)
		return e;
	switch (t) {
	case P_FLOAT:
		if (!number(v, &p->f))
			return fail(ld, k, PM_ERR_PARSE, "<float name=\"%s\">: "
			    "\"%s\" is not a finite number", p->name, v);
		break;
	case P_INTEGER: {
		char buf[64];
		size_t a = 0, b = strlen(v);

		while (a < b && isspace((unsigned char)v[a]))
			a++;
		while (b > a && isspace((unsigned char)v[b - 1]))
			b--;
		if (b - a >= sizeof(buf) || (memcpy(buf, v + a, b - a),
		    buf[b - a] = '\0', !pm_parse_long(buf, LONG_MIN, LONG_MAX,
		    &p->i)))
			return fail(ld, k, PM_ERR_PARSE, "<integer name=\"%s\">"
			    ": \"%s\" is not an integer", p->name, v);
		p->f = (double)p->i;
		break;
	}
	case P_BOOLEAN:
		if (strcasecmp(v, "true") == 0)
			p->b = true;
		else if (strcasecmp(v, "false") == 0)
			p->b = false;
		else
			return fail(ld, k, PM_ERR_PARSE, "<boolean name=\"%s\">"
			    ": \"%s\" is neither true nor false", p->name, v);
		break;
	case P_STRING:
		p->s = v;
		break;
	case P_RGB:
		if ((e = numbers(ld, k, "value", v, d, 1, 3, &cnt)) != PM_OK)
			return e;
		p->c = cnt == 1 ? pm_rgb1((float)d[0]) :
		    pm_rgb((float)d[0], (float)d[1], (float)d[2]);
		break;
	case P_SPECTRUM:
		if (strchr(v, ':') != NULL)
			return fail(ld, k, PM_ERR_UNSUPPORTED, "<spectrum "
			    "name=\"%s\">: wavelength:value lists are not "
			    "supported, only a single uniform value", p->name);
		if ((e = numbers(ld, k, "value", v, d, 1, 1, &cnt)) != PM_OK)
			return e;
		p->c = pm_rgb1((float)d[0]);
		break;
	case P_POINT:
	case P_VECTOR:
		if (attr(k, "value") == NULL && attr(k, "x") == NULL &&
		    attr(k, "y") == NULL && attr(k, "z") == NULL)
			return fail(ld, k, PM_ERR_INVALID, "<%s name=\"%s\"> "
			    "needs value or x, y, z", k->tag, p->name);
		if ((e = xyz(ld, k, 0.0, &p->v)) != PM_OK)
			return e;
		break;
	case P_TRANSFORM:
		if ((e = parse_transform(ld, k, &p->m)) != PM_OK)
			return e;
		break;
	}
	return PM_OK;
}

/*
 * Reads the children of an object element: properties into pl->p, nested
 * objects and refs into pl->obj.  Anything else is an error.
 */
static enum pm_err
collect(struct ld *ld, const struct xnode *owner, const char *kind,
    const char *type, struct plist *pl)
{
	struct xnode *k;
	size_t n = 0, i;
	int t;
	enum pm_err e;

	memset(pl, 0, sizeof(*pl));
	pl->owner = owner;
	snprintf(pl->what, sizeof(pl->what), "%s \"%s\"", kind, type);
	for (k = owner->kids; k != NULL; k = k->next)
		n++;
	if (n > 0 && (pl->p = arena_alloc(&ld->arena, n * sizeof(*pl->p)))
	    == NULL)
		return nomem(ld);
	for (k = owner->kids; k != NULL; k = k->next) {
		if ((t = ptype_of(k->tag)) >= 0) {
			struct prop *p = &pl->p[pl->n];

			if ((e = parse_prop(ld, k, (enum ptype)t, p)) != PM_OK)
				return e;
			for (i = 0; i < pl->n; i++)
				if (strcmp(pl->p[i].name, p->name) == 0)
					return fail(ld, k, PM_ERR_INVALID,
					    "%s: parameter \"%s\" given twice "
					    "(also at line %d)", pl->what,
					    p->name, pl->p[i].n->line);
			pl->n++;
		} else if (strcmp(k->tag, "texture") == 0) {
			const char *nm = attr(k, "name");

			return fail(ld, k, PM_ERR_UNSUPPORTED, "%s: textures "
			    "are not supported (<texture%s%s%s>)", pl->what,
			    nm ? " name=\"" : "", nm ? nm : "", nm ? "\"" : "");
		} else if (is_object_tag(k->tag)) {
			if (pl->nobj == sizeof(pl->obj) / sizeof(pl->obj[0]))
				return fail(ld, k, PM_ERR_LIMIT,
				    "%s: too many nested objects", pl->what);
			pl->obj[pl->nobj++] = k;
		} else {
			return fail(ld, k, PM_ERR_UNSUPPORTED,
			    "unknown element <%s> in %s", k->tag, pl->what);
		}
	}
	return PM_OK;
}

static struct prop *
prop_find(struct plist *pl, const char *name)
{
	size_t i;

	for (i = 0; i < pl->n; i++)
		if (strcmp(pl->p[i].name, name) == 0)
			return &pl->p[i];
	return NULL;
}

static bool
has(struct plist *pl, const char *name)
{
	return prop_find(pl, name) != NULL;
}

static enum pm_err
wrong_type(struct ld *ld, struct plist *pl, struct prop *p, const char *want)
{
	return fail(ld, p->n, PM_ERR_INVALID, "%s: parameter \"%s\" must be "
	    "%s, found <%s>", pl->what, p->name, want, ptype_name[p->type]);
}

static enum pm_err
missing(struct ld *ld, struct plist *pl, const char *name, const char *want)
{
	return fail(ld, pl->owner, PM_ERR_INVALID, "%s: missing required "
	    "parameter \"%s\" (%s)", pl->what, name, want);
}

/* A float (an integer will do) in [lo, hi]; def if absent. */
static enum pm_err
get_float(struct ld *ld, struct plist *pl, const char *name, double def,
    double lo, double hi, double *out)
{
	struct prop *p = prop_find(pl, name);

	*out = def;
	if (p == NULL)
		return PM_OK;
	p->used = true;
	if (p->type != P_FLOAT && p->type != P_INTEGER)
		return wrong_type(ld, pl, p, "a <float>");
	if (p->f < lo || p->f > hi)
		return fail(ld, p->n, PM_ERR_INVALID, "%s: parameter \"%s\" = "
		    "%g is outside [%g, %g]", pl->what, name, p->f, lo, hi);
	*out = p->f;
	return PM_OK;
}

static enum pm_err
get_int(struct ld *ld, struct plist *pl, const char *name, long def,
    long lo, long hi, long *out)
{
	struct prop *p = prop_find(pl, name);

	*out = def;
	if (p == NULL)
		return PM_OK;
	p->used = true;
	if (p->type != P_INTEGER)
		return wrong_type(ld, pl, p, "an <integer>");
	if (p->i < lo || p->i > hi)
		return fail(ld, p->n, PM_ERR_INVALID, "%s: parameter \"%s\" = "
		    "%ld is outside [%ld, %ld]", pl->what, name, p->i, lo, hi);
	*out = p->i;
	return PM_OK;
}

static enum pm_err
get_bool(struct ld *ld, struct plist *pl, const char *name, bool def,
    bool *out)
{
	struct prop *p = prop_find(pl, name);

	*out = def;
	if (p == NULL)
		return PM_OK;
	p->used = true;
	if (p->type != P_BOOLEAN)
		return wrong_type(ld, pl, p, "a <boolean>");
	*out = p->b;
	return PM_OK;
}

static enum pm_err
get_string(struct ld *ld, struct plist *pl, const char *name,
    const char *def, const char **out)
{
	struct prop *p = prop_find(pl, name);

	*out = def;
	if (p == NULL)
		return PM_OK;
	p->used = true;
	if (p->type != P_STRING)
		return wrong_type(ld, pl, p, "a <string>");
	*out = p->s;
	return PM_OK;
}

/* A colour: <rgb>, a uniform <spectrum>, or a <float>; non-negative. */
static enum pm_err
get_color(struct ld *ld, struct plist *pl, const char *name, float def,
    struct pm_rgb *out)
{
	struct prop *p = prop_find(pl, name);

	*out = pm_rgb1(def);
	if (p == NULL)
		return PM_OK;
	p->used = true;
	if (p->type == P_FLOAT || p->type == P_INTEGER)
		*out = pm_rgb1((float)p->f);
	else if (p->type == P_RGB || p->type == P_SPECTRUM)
		*out = p->c;
	else
		return wrong_type(ld, pl, p, "an <rgb>, <spectrum> or <float>");
	if (!(out->r >= 0.0f && out->g >= 0.0f && out->b >= 0.0f))
		return fail(ld, p->n, PM_ERR_INVALID, "%s: parameter \"%s\" "
		    "must not be negative", pl->what, name);
	return PM_OK;
}

static enum pm_err
get_point(struct ld *ld, struct plist *pl, const char *name,
    struct pm_vec3 def, struct pm_vec3 *out)
{
	struct prop *p = prop_find(pl, name);

	*out = def;
	if (p == NULL)
		return PM_OK;
	p->used = true;
	if (p->type != P_POINT)
		return wrong_type(ld, pl, p, "a <point>");
	*out = p->v;
	return PM_OK;
}

static enum pm_err
get_transform(struct ld *ld, struct plist *pl, const char *name,
    struct pm_mat4 *out)
{
	struct prop *p = prop_find(pl, name);

	*out = pm_mat4_identity();
	if (p == NULL)
		return PM_OK;
	p->used = true;
	if (p->type != P_TRANSFORM)
		return wrong_type(ld, pl, p, "a <transform>");
	*out = p->m;
	return PM_OK;
}

/* Fails on the first parameter no getter asked for. */
static enum pm_err
finish(struct ld *ld, struct plist *pl)
{
	size_t i;

	for (i = 0; i < pl->n; i++)
		if (!pl->p[i].used)
			return fail(ld, pl->p[i].n, PM_ERR_UNSUPPORTED,
			    "unknown parameter \"%s\" for %s", pl->p[i].name,
			    pl->what);
	return PM_OK;
}

static enum pm_err
no_objects(struct ld *ld, struct plist *pl)
{
	if (pl->nobj > 0)
		return fail(ld, pl->obj[0], PM_ERR_INVALID,
		    "unexpected <%s> inside %s", pl->obj[0]->tag, pl->what);
	return PM_OK;
}

/* The type attribute of an object element, with id and name allowed. */
static enum pm_err
object_type(struct ld *ld, const struct xnode *n, const char **type)
{
	static const char *const ok[] = {"type", "id", "name", NULL};
	enum pm_err e;

	if ((e = check_attrs(ld, n, ok)) != PM_OK)
		return e;
	return need_attr(ld, n, "type", type);
}

static enum pm_err
unknown_plugin(struct ld *ld, const struct xnode *n, const char *type,
    const char *known)
{
	return fail(ld, n, PM_ERR_UNSUPPORTED, "unknown %s type \"%s\" "
	    "(pm supports %s)", n->tag, type, known);
}

/* ---------------------------------------------------------------- bsdfs */

/* An index of refraction: a number or one of Mitsuba's names. */
static enum pm_err
get_ior(struct ld *ld, struct plist *pl, const char *name, float def,
    float *out)
{
	struct prop *p = prop_find(pl, name);

	*out = def;
	if (p == NULL)
		return PM_OK;
	p->used = true;
	if (p->type == P_STRING) {
		if (!pm_ior_lookup(p->s, out))
			return fail(ld, p->n, PM_ERR_INVALID, "%s: unknown "
			    "material \"%s\" for \"%s\"", pl->what, p->s, name);
	} else if (p->type == P_FLOAT || p->type == P_INTEGER) {
		*out = (float)p->f;
	} else {
		return wrong_type(ld, pl, p, "a <float> or a <string>");
	}
	if (!(*out > 0.0f))
		return fail(ld, p->n, PM_ERR_INVALID, "%s: \"%s\" must be "
		    "positive", pl->what, name);
	return PM_OK;
}

static enum pm_err
conductor_params(struct ld *ld, struct plist *pl, struct pm_bsdf *b)
{
	const char *mat;
	enum pm_err e;

	if ((e = get_string(ld, pl, "material", "none", &mat)) != PM_OK)
		return e;
	if (has(pl, "eta") || has(pl, "k")) {
		if (has(pl, "material"))
			return fail(ld, prop_find(pl, "material")->n,
			    PM_ERR_INVALID, "%s: give either material or "
			    "eta and k, not both", pl->what);
		if (!has(pl, "eta"))
			return missing(ld, pl, "eta", "k is given");
		if (!has(pl, "k"))
			return missing(ld, pl, "k", "eta is given");
		if ((e = get_color(ld, pl, "eta", 0.0f, &b->eta)) != PM_OK ||
		    (e = get_color(ld, pl, "k", 0.0f, &b->k)) != PM_OK)
			return e;
	} else if (!pm_conductor_lookup(mat, &b->eta, &b->k)) {
		return fail(ld, prop_find(pl, "material")->n, PM_ERR_INVALID,
		    "%s: unknown conductor material \"%s\"", pl->what, mat);
	}
	return get_color(ld, pl, "specular_reflectance", 1.0f, &b->specular);
}

static enum pm_err wrap(struct ld *ld, const struct xnode *n,
    const char *what, enum pm_err e);

/*
 * A measured BRDF: the file resolves like any other, and its table is
 * read once per real path and shared by every BSDF that names it.
 */
static enum pm_err
build_merl(struct ld *ld, struct xnode *n, struct plist *pl,
    struct pm_bsdf *b)
{
	const char *fname, *path, *sampling, *key;
	struct pm_merl *m;
	char *real;
	bool interp;
	size_t i;
	enum pm_err e;

	if (!has(pl, "filename"))
		return missing(ld, pl, "filename", "a <string>");
	if ((e = get_string(ld, pl, "filename", NULL, &fname)) != PM_OK ||
	    (e = get_bool(ld, pl, "interpolate", false, &interp)) != PM_OK ||
	    (e = get_string(ld, pl, "sampling", "data", &sampling)) != PM_OK)
		return e;
	if (strcmp(sampling, "data") != 0 && strcmp(sampling, "cosine") != 0)
		return fail(ld, prop_find(pl, "sampling")->n, PM_ERR_INVALID,
		    "%s: sampling \"%s\" is neither \"data\" nor \"cosine\"",
		    pl->what, sampling);
	b->merl_flags = (interp ? PM_MERL_INTERPOLATE : 0) |
	    (sampling[0] == 'c' ? PM_MERL_COSINE : 0);
	if ((e = resolve(ld, n, n->dir, fname, &path)) != PM_OK)
		return e;
	real = realpath(path, NULL);
	key = real != NULL ? real : path;
	for (i = 0; i < ld->s->nmerls; i++)
		if (strcmp(ld->s->merls[i]->path, key) == 0) {
			b->merl = ld->s->merls[i];
			free(real);
			return PM_OK;
		}
	e = pm_merl_read(key, &m, ld->err);
	free(real);
	if (e != PM_OK)
		return wrap(ld, n, pl->what, e);
	if (pm_scene_add_merl(ld->s, m) < 0) {
		pm_merl_free(m);
		return nomem(ld);
	}
	b->merl = m;
	return PM_OK;
}

static enum pm_err build_bsdf(struct ld *ld, struct xnode *n,
    struct pm_bsdf *b);

static enum pm_err
build_twosided(struct ld *ld, struct plist *pl, struct pm_bsdf *b)
{
	struct xnode *inner;
	enum pm_err e;

	if (pl->nobj == 0)
		return fail(ld, pl->owner, PM_ERR_INVALID, "%s needs one "
		    "nested <bsdf> or <ref>", pl->what);
	if (pl->nobj > 1)
		return fail(ld, pl->obj[1], PM_ERR_UNSUPPORTED, "%s: different "
		    "BSDFs on the two sides are not supported", pl->what);
	inner = pl->obj[0];
	if (strcmp(inner->tag, "ref") == 0) {
		if ((e = deref(ld, inner, &inner)) != PM_OK)
			return e;
		if (strcmp(inner->tag, "bsdf") != 0)
			return fail(ld, pl->obj[0], PM_ERR_INVALID, "%s: <ref> "
			    "names a <%s>, expected a <bsdf>", pl->what,
			    inner->tag);
	} else if (strcmp(inner->tag, "bsdf") != 0) {
		return fail(ld, inner, PM_ERR_INVALID, "unexpected <%s> inside "
		    "%s", inner->tag, pl->what);
	}
	if ((e = build_bsdf(ld, inner, b)) != PM_OK)
		return e;
	b->twosided = true;
	return PM_OK;
}

/* Builds the BSDF an element describes into *b (not into the scene). */
static enum pm_err
build_bsdf(struct ld *ld, struct xnode *n, struct pm_bsdf *b)
{
	struct plist pl;
	const char *type, *s;
	double a, au, av;
	float iint, iext;
	enum pm_err e;

	if (n->busy)
		return fail(ld, n, PM_ERR_INVALID, "<bsdf> refers to itself");
	if ((e = object_type(ld, n, &type)) != PM_OK ||
	    (e = collect(ld, n, "bsdf", type, &pl)) != PM_OK)
		return e;
	memset(b, 0, sizeof(*b));
	n->busy = true;
	if (strcmp(type, "diffuse") == 0) {
		b->type = PM_BSDF_DIFFUSE;
		e = get_color(ld, &pl, "reflectance", 0.5f, &b->diffuse);
	} else if (strcmp(type, "conductor") == 0) {
		b->type = PM_BSDF_CONDUCTOR;
		e = conductor_params(ld, &pl, b);
	} else if (strcmp(type, "roughconductor") == 0) {
		b->type = PM_BSDF_ROUGHCONDUCTOR;
		if ((e = conductor_params(ld, &pl, b)) != PM_OK ||
		    (e = get_string(ld, &pl, "distribution", "beckmann", &s))
		    != PM_OK ||
		    (e = get_bool(ld, &pl, "sample_visible", true,
		    &b->sample_visible)) != PM_OK)
			goto out;
		if (strcmp(s, "ggx") != 0) {
			e = fail(ld, has(&pl, "distribution") ?
			    prop_find(&pl, "distribution")->n : n,
			    PM_ERR_UNSUPPORTED, "%s: distribution \"%s\" is "
			    "not supported, only \"ggx\"%s", pl.what, s,
			    has(&pl, "distribution") ? "" : " (Mitsuba's "
			    "default is beckmann: say <string "
			    "name=\"distribution\" value=\"ggx\"/>)");
			goto out;
		}
		if (has(&pl, "alpha_u") || has(&pl, "alpha_v")) {
			if (has(&pl, "alpha")) {
				e = fail(ld, prop_find(&pl, "alpha")->n,
				    PM_ERR_INVALID, "%s: give either alpha or "
				    "alpha_u and alpha_v", pl.what);
				goto out;
			}
			if ((e = get_float(ld, &pl, "alpha_u", -1, 1e-4, 10,
			    &au)) != PM_OK || (e = get_float(ld, &pl,
			    "alpha_v", -1, 1e-4, 10, &av)) != PM_OK)
				goto out;
			if (au != av) {
				e = fail(ld, n, PM_ERR_UNSUPPORTED, "%s: "
				    "anisotropic roughness (alpha_u %g != "
				    "alpha_v %g) is not supported", pl.what,
				    au, av);
				goto out;
			}
			a = au;
		} else if ((e = get_float(ld, &pl, "alpha", 0.1, 1e-4, 10,
		    &a)) != PM_OK) {
			goto out;
		}
		b->alpha = (float)a;
	} else if (strcmp(type, "dielectric") == 0 ||
	    strcmp(type, "thindielectric") == 0) {
		b->type = type[0] == 'd' ? PM_BSDF_DIELECTRIC :
		    PM_BSDF_THINDIELECTRIC;
		if ((e = get_ior(ld, &pl, "int_ior", IOR_BK7, &iint)) != PM_OK ||
		    (e = get_ior(ld, &pl, "ext_ior", IOR_AIR, &iext)) != PM_OK ||
		    (e = get_color(ld, &pl, "specular_reflectance", 1.0f,
		    &b->specular)) != PM_OK ||
		    (e = get_color(ld, &pl, "specular_transmittance", 1.0f,
		    &b->transmittance)) != PM_OK)
			goto out;
		b->ior = iint / iext;
	} else if (strcmp(type, "plastic") == 0) {
		b->type = PM_BSDF_PLASTIC;
		if ((e = get_color(ld, &pl, "diffuse_reflectance", 0.5f,
		    &b->diffuse)) != PM_OK ||
		    (e = get_color(ld, &pl, "specular_reflectance", 1.0f,
		    &b->specular)) != PM_OK ||
		    (e = get_ior(ld, &pl, "int_ior", IOR_POLYPROPYLENE, &iint))
		    != PM_OK ||
		    (e = get_ior(ld, &pl, "ext_ior", IOR_AIR, &iext)) != PM_OK ||
		    (e = get_bool(ld, &pl, "nonlinear", false, &b->nonlinear))
		    != PM_OK)
			goto out;
		b->ior = iint / iext;
	} else if (strcmp(type, "twosided") == 0) {
		if ((e = finish(ld, &pl)) != PM_OK ||
		    (e = build_twosided(ld, &pl, b)) != PM_OK)
			goto out;
		n->busy = false;
		return PM_OK;
	} else if (strcmp(type, "null") == 0) {
		b->type = PM_BSDF_NULL;
	} else if (strcmp(type, "merl") == 0) {
		b->type = PM_BSDF_MERL;
		e = build_merl(ld, n, &pl, b);
	} else {
		e = unknown_plugin(ld, n, type, "diffuse, conductor, "
		    "roughconductor, dielectric, thindielectric, plastic, "
		    "merl, twosided and null");
		goto out;
	}
	if (e == PM_OK && (e = finish(ld, &pl)) == PM_OK)
		e = no_objects(ld, &pl);
out:
	n->busy = false;
	return e;
}

/* The scene index of the BSDF element n, built once however often used. */
static enum pm_err
bsdf_index(struct ld *ld, struct xnode *n, int *out)
{
	struct pm_bsdf b;
	enum pm_err e;
	int i;

	if (n->inst >= 0) {
		*out = n->inst;
		return PM_OK;
	}
	if ((e = build_bsdf(ld, n, &b)) != PM_OK)
		return e;
	if ((i = pm_scene_add_bsdf(ld->s)) < 0)
		return nomem(ld);
	ld->s->bsdfs[i] = b;
	n->inst = i;
	*out = i;
	return PM_OK;
}

static int
default_bsdf(struct ld *ld)
{
	int i;

	if (ld->default_bsdf >= 0)
		return ld->default_bsdf;
	if ((i = pm_scene_add_bsdf(ld->s)) < 0)
		return -1;
	ld->s->bsdfs[i].type = PM_BSDF_DIFFUSE;
	ld->s->bsdfs[i].diffuse = pm_rgb1(0.5f);
	ld->default_bsdf = i;
	return i;
}

/* ---------------------------------------------------------------- emitters */

static enum pm_err
build_area(struct ld *ld, struct xnode *n, struct pm_rgb *radiance)
{
	struct plist pl;
	const char *type;
	enum pm_err e;

	if ((e = object_type(ld, n, &type)) != PM_OK)
		return e;
	if (strcmp(type, "area") != 0)
		return fail(ld, n, PM_ERR_INVALID, "a shape can carry only an "
		    "\"area\" emitter, not \"%s\"", type);
	if ((e = collect(ld, n, "emitter", type, &pl)) != PM_OK)
		return e;
	if (!has(&pl, "radiance"))
		return missing(ld, &pl, "radiance", "an <rgb>");
	if ((e = get_color(ld, &pl, "radiance", 0.0f, radiance)) != PM_OK ||
	    (e = finish(ld, &pl)) != PM_OK)
		return e;
	return no_objects(ld, &pl);
}

static enum pm_err
load_emitter(struct ld *ld, struct xnode *n)
{
	struct plist pl;
	struct pm_light *l;
	struct pm_mat4 M;
	struct pm_vec3 pos;
	const char *type;
	double cutoff, beam;
	int i;
	enum pm_err e;

	if ((e = object_type(ld, n, &type)) != PM_OK)
		return e;
	if (strcmp(type, "area") == 0)
		return PM_OK;	/* built by the shape that carries it */
	if ((e = collect(ld, n, "emitter", type, &pl)) != PM_OK)
		return e;
	if (strcmp(type, "point") != 0 && strcmp(type, "spot") != 0 &&
	    strcmp(type, "constant") != 0)
		return unknown_plugin(ld, n, type, "area, point, spot and "
		    "constant");
	if ((i = pm_scene_add_light(ld->s)) < 0)
		return nomem(ld);
	l = &ld->s->lights[i];
	if (strcmp(type, "point") == 0) {
		l->type = PM_LIGHT_POINT;
		if (has(&pl, "position") && has(&pl, "to_world"))
			return fail(ld, prop_find(&pl, "position")->n,
			    PM_ERR_INVALID, "%s: give either position or "
			    "to_world, not both", pl.what);
		if ((e = get_color(ld, &pl, "intensity", 1.0f, &l->intensity))
		    != PM_OK ||
		    (e = get_transform(ld, &pl, "to_world", &M)) != PM_OK ||
		    (e = get_point(ld, &pl, "position",
		    pm_xform_point(&M, pm_v3(0, 0, 0)), &pos)) != PM_OK)
			return e;
		l->position = pos;
	} else if (strcmp(type, "spot") == 0) {
		l->type = PM_LIGHT_SPOT;
		if ((e = get_color(ld, &pl, "intensity", 1.0f, &l->intensity))
		    != PM_OK ||
		    (e = get_float(ld, &pl, "cutoff_angle", 20.0, 1e-3, 180.0,
		    &cutoff)) != PM_OK ||
		    (e = get_float(ld, &pl, "beam_width", cutoff * 0.75, 0.0,
		    cutoff, &beam)) != PM_OK ||
		    (e = get_transform(ld, &pl, "to_world", &M)) != PM_OK)
			return e;
		l->cutoff_angle = (float)cutoff;
		l->beam_width = (float)beam;
		l->position = pm_xform_point(&M, pm_v3(0, 0, 0));
		pos = pm_xform_vector(&M, pm_v3(0, 0, 1));
		if (pm_dot(pos, pos) == 0.0f)
			return fail(ld, n, PM_ERR_INVALID, "%s: to_world maps "
			    "the axis to zero", pl.what);
		l->frame = pm_frame_from_normal(pm_normalize(pos));
	} else {
		if (ld->s->env_light >= 0)
			return fail(ld, n, PM_ERR_UNSUPPORTED, "more than one "
			    "constant emitter");
		l->type = PM_LIGHT_CONSTANT;
		if ((e = get_color(ld, &pl, "radiance", 1.0f, &l->radiance))
		    != PM_OK)
			return e;
		ld->s->env_light = i;
	}
	if ((e = finish(ld, &pl)) != PM_OK)
		return e;
	return no_objects(ld, &pl);
}

/* ---------------------------------------------------------------- shapes */

static enum pm_err
wrap(struct ld *ld, const struct xnode *n, const char *what, enum pm_err e)
{
	char msg[sizeof(ld->err->msg)];

	snprintf(msg, sizeof(msg), "%s", ld->err->msg);
	return fail(ld, n, e, "%s: %s", what, msg);
}

/* Column lengths of M's linear part must agree and be orthogonal. */
static bool
similarity_scale(const struct pm_mat4 *M, float *scale)
{
	struct pm_vec3 c[3];
	float l[3];
	int i;

	for (i = 0; i < 3; i++) {
		c[i] = pm_v3(M->m[0][i], M->m[1][i], M->m[2][i]);
		l[i] = pm_length(c[i]);
	}
	if (!(l[0] > 0.0f))
		return false;
	for (i = 1; i < 3; i++)
		if (fabsf(l[i] - l[0]) > 1e-4f * l[0])
			return false;
	if (fabsf(pm_dot(c[0], c[1])) > 1e-4f * l[0] * l[0] ||
	    fabsf(pm_dot(c[0], c[2])) > 1e-4f * l[0] * l[0] ||
	    fabsf(pm_dot(c[1], c[2])) > 1e-4f * l[0] * l[0])
		return false;
	*scale = l[0];
	return true;
}

/* Validation, normals, world space and orientation, in Mitsuba's order. */
static enum pm_err
finish_mesh(struct ld *ld, const struct xnode *n, const char *what,
    struct pm_mesh *m, const struct pm_mat4 *M, bool face_normals, bool flip)
{
	struct pm_mat4 inv;
	uint32_t dropped = 0;
	enum pm_err e;

	if (!pm_mat4_inverse(*M, &inv))
		return fail(ld, n, PM_ERR_INVALID, "%s: to_world is singular",
		    what);
	if ((e = pm_mesh_validate(m, &dropped, ld->err)) != PM_OK)
		return wrap(ld, n, what, e);
	ld->s->dropped_triangles += dropped;
	if (m->ntris == 0)
		return fail(ld, n, PM_ERR_INVALID, "%s: no triangles%s", what,
		    dropped ? " left after dropping degenerate ones" : "");
	if (face_normals) {
		free(m->nrm);
		m->nrm = NULL;
	}
	pm_mesh_transform(m, M);
	/* Mitsuba 3 computes smooth normals when a file has none. */
	if (!face_normals && m->nrm == NULL &&
	    (e = pm_mesh_compute_normals(m, ld->err)) != PM_OK)
		return wrap(ld, n, what, e);
	if (flip)
		pm_mesh_flip(m);
	return PM_OK;
}

/* The BSDF and area light of a shape, from nested elements or refs. */
static enum pm_err
shape_objects(struct ld *ld, struct plist *pl, int *bsdf, struct xnode **em)
{
	struct xnode *o, *t, *bnode = NULL;
	size_t i;
	enum pm_err e;

	*em = NULL;
	for (i = 0; i < pl->nobj; i++) {
		o = pl->obj[i];
		t = o;
		if (strcmp(o->tag, "ref") == 0 &&
		    (e = deref(ld, o, &t)) != PM_OK)
			return e;
		if (strcmp(t->tag, "bsdf") == 0) {
			if (bnode != NULL)
				return fail(ld, o, PM_ERR_INVALID, "%s has more "
				    "than one BSDF (first at line %d)",
				    pl->what, bnode->line);
			bnode = o;
			if ((e = bsdf_index(ld, t, bsdf)) != PM_OK)
				return e;
		} else if (strcmp(t->tag, "emitter") == 0) {
			if (*em != NULL)
				return fail(ld, o, PM_ERR_INVALID, "%s has more "
				    "than one emitter", pl->what);
			*em = t;
		} else if (o != t) {
			return fail(ld, o, PM_ERR_INVALID, "%s: <ref id=\"%s\"> "
			    "names a <%s>, expected a <bsdf> or an <emitter>",
			    pl->what, attr(o, "id"), t->tag);
		} else {
			return fail(ld, o, PM_ERR_INVALID, "unexpected <%s> "
			    "inside %s", o->tag, pl->what);
		}
	}
	if (bnode == NULL && (*bsdf = default_bsdf(ld)) < 0)
		return nomem(ld);
	return PM_OK;
}

static enum pm_err
load_shape(struct ld *ld, struct xnode *n, const char *naming_dir)
{
	struct plist pl;
	struct pm_mesh mesh;
	struct pm_shape *sh;
	struct pm_mat4 M;
	struct pm_vec3 center;
	struct pm_rgb radiance;
	struct xnode *em;
	const char *type, *fname = NULL, *path, *id;
	double radius = 1.0;
	bool face_normals = false, flip = false, flip_tc = true;
	bool is_file, is_obj;
	float scale;
	int idx, bsdf = -1, li;
	uint32_t v;
	enum pm_err e;

	memset(&mesh, 0, sizeof(mesh));
	if ((e = object_type(ld, n, &type)) != PM_OK ||
	    (e = collect(ld, n, "shape", type, &pl)) != PM_OK)
		return e;
	is_obj = strcmp(type, "obj") == 0;
	is_file = is_obj || strcmp(type, "ply") == 0;
	if (!is_file && strcmp(type, "sphere") != 0 &&
	    strcmp(type, "rectangle") != 0 && strcmp(type, "cube") != 0 &&
	    strcmp(type, "disk") != 0)
		return unknown_plugin(ld, n, type, "obj, ply, sphere, "
		    "rectangle, cube and disk");

	if ((e = get_transform(ld, &pl, "to_world", &M)) != PM_OK ||
	    (e = get_bool(ld, &pl, "flip_normals", false, &flip)) != PM_OK)
		return e;
	if (is_file) {
		if (!has(&pl, "filename"))
			return missing(ld, &pl, "filename", "a <string>");
		if ((e = get_string(ld, &pl, "filename", NULL, &fname))
		    != PM_OK ||
		    (e = get_bool(ld, &pl, "face_normals", false,
		    &face_normals)) != PM_OK)
			return e;
		if (is_obj && (e = get_bool(ld, &pl, "flip_tex_coords", true,
		    &flip_tc)) != PM_OK)
			return e;
	} else if (strcmp(type, "sphere") == 0) {
		if ((e = get_point(ld, &pl, "center", pm_v3(0, 0, 0), &center))
		    != PM_OK ||
		    (e = get_float(ld, &pl, "radius", 1.0, 0.0, 3.4e38,
		    &radius)) != PM_OK)
			return e;
		if (!(radius > 0.0))
			return fail(ld, prop_find(&pl, "radius")->n,
			    PM_ERR_INVALID, "%s: radius must be positive",
			    pl.what);
	}
	if ((e = finish(ld, &pl)) != PM_OK ||
	    (e = shape_objects(ld, &pl, &bsdf, &em)) != PM_OK)
		return e;

	if (is_file) {
		if ((e = resolve(ld, n, naming_dir, fname, &path)) != PM_OK)
			return e;
		e = is_obj ? pm_obj_read(path, &mesh, ld->err) :
		    pm_ply_read(path, &mesh, ld->err);
		if (e == PM_OK && is_obj && flip_tc && mesh.uv != NULL)
			for (v = 0; v < mesh.nverts; v++)
				mesh.uv[2 * v + 1] = 1.0f - mesh.uv[2 * v + 1];
	} else if (strcmp(type, "rectangle") == 0) {
		e = pm_mesh_rectangle(&mesh, ld->err);
	} else if (strcmp(type, "cube") == 0) {
		e = pm_mesh_cube(&mesh, ld->err);
	} else if (strcmp(type, "disk") == 0) {
		e = pm_mesh_disk(&mesh, DISK_SEGMENTS, ld->err);
	}
	if (e != PM_OK) {
		pm_mesh_free(&mesh);
		return wrap(ld, n, pl.what, e);
	}

	if ((idx = pm_scene_add_shape(ld->s)) < 0) {
		pm_mesh_free(&mesh);
		return nomem(ld);
	}
	sh = &ld->s->shapes[idx];
	sh->mesh = mesh;	/* owned by the scene from here on */
	sh->bsdf = bsdf;
	sh->flip_normals = flip;
	id = attr(n, "id");
	if (id != NULL)
		snprintf(sh->name, sizeof(sh->name), "%s", id);
	else
		snprintf(sh->name, sizeof(sh->name), "%s#%d", type, idx);
	if (strcmp(type, "sphere") == 0) {
		if (!similarity_scale(&M, &scale))
			return fail(ld, n, PM_ERR_UNSUPPORTED, "%s: to_world "
			    "must be a rotation, uniform scale and "
			    "translation", pl.what);
		sh->type = PM_SHAPE_SPHERE;
		sh->center = pm_xform_point(&M, center);
		sh->radius = (float)radius * scale;
	} else {
		sh->type = PM_SHAPE_MESH;
		if ((e = finish_mesh(ld, n, pl.what, &sh->mesh, &M,
		    face_normals, flip)) != PM_OK)
			return e;
	}

	if (em != NULL) {
		if (em->inst >= 0)
			return fail(ld, n, PM_ERR_INVALID, "%s: emitter at "
			    "line %d is already attached to shape %s", pl.what,
			    em->line, ld->s->shapes[em->inst].name);
		if ((e = build_area(ld, em, &radiance)) != PM_OK)
			return e;
		if ((li = pm_scene_add_light(ld->s)) < 0)
			return nomem(ld);
		ld->s->lights[li].type = PM_LIGHT_AREA;
		ld->s->lights[li].radiance = radiance;
		ld->s->lights[li].shape = idx;
		ld->s->shapes[idx].light = li;
		em->inst = idx;
	}
	return PM_OK;
}

/* ---------------------------------------------------------------- sensor */

static enum pm_err
load_rfilter(struct ld *ld, struct xnode *n, struct pm_camera *c)
{
	struct plist pl;
	const char *type;
	double r;
	enum pm_err e;

	if ((e = object_type(ld, n, &type)) != PM_OK ||
	    (e = collect(ld, n, "rfilter", type, &pl)) != PM_OK)
		return e;
	if (strcmp(type, "box") == 0) {
		c->rfilter = PM_RFILTER_BOX;
		c->filter_radius = 0.5f;
	} else if (strcmp(type, "tent") == 0) {
		c->rfilter = PM_RFILTER_TENT;
		if ((e = get_float(ld, &pl, "radius", 1.0, 1e-3, 64.0, &r))
		    != PM_OK)
			return e;
		c->filter_radius = (float)r;
	} else if (strcmp(type, "gaussian") == 0) {
		c->rfilter = PM_RFILTER_GAUSSIAN;
		if ((e = get_float(ld, &pl, "stddev", 0.5, 1e-3, 16.0, &r))
		    != PM_OK)
			return e;
		c->filter_radius = (float)r;
	} else {
		return unknown_plugin(ld, n, type, "box, tent and gaussian");
	}
	if ((e = finish(ld, &pl)) != PM_OK)
		return e;
	return no_objects(ld, &pl);
}

static bool
one_of(const char *s, const char *const *list)
{
	for (; *list != NULL; list++)
		if (strcmp(s, *list) == 0)
			return true;
	return false;
}

static enum pm_err
check_choice(struct ld *ld, struct plist *pl, const char *name,
    const char *const *list, const char *shown)
{
	const char *s;
	enum pm_err e;

	if ((e = get_string(ld, pl, name, NULL, &s)) != PM_OK)
		return e;
	if (s != NULL && !one_of(s, list))
		return fail(ld, prop_find(pl, name)->n, PM_ERR_UNSUPPORTED,
		    "%s: %s \"%s\" is not one of %s", pl->what, name, s, shown);
	return PM_OK;
}

static enum pm_err
load_film(struct ld *ld, struct xnode *n, struct pm_camera *c)
{
	static const char *const pix[] = {"luminance", "luminance_alpha",
	    "rgb", "rgba", "xyz", "xyza", NULL};
	static const char *const comp[] = {"float16", "float32", "uint32",
	    NULL};
	static const char *const file[] = {"openexr", "exr", "rgbe", "pfm",
	    NULL};
	struct plist pl;
	const char *type;
	long w, h;
	size_t i;
	bool seen = false;
	enum pm_err e;

	if ((e = object_type(ld, n, &type)) != PM_OK ||
	    (e = collect(ld, n, "film", type, &pl)) != PM_OK)
		return e;
	if (strcmp(type, "hdrfilm") != 0)
		return unknown_plugin(ld, n, type, "hdrfilm");
	if ((e = get_int(ld, &pl, "width", 768, 1, 1 << 16, &w)) != PM_OK ||
	    (e = get_int(ld, &pl, "height", 576, 1, 1 << 16, &h)) != PM_OK ||
	    (e = check_choice(ld, &pl, "pixel_format", pix, "luminance, "
	    "luminance_alpha, rgb, rgba, xyz, xyza")) != PM_OK ||
	    (e = check_choice(ld, &pl, "component_format", comp, "float16, "
	    "float32, uint32")) != PM_OK ||
	    (e = check_choice(ld, &pl, "file_format", file, "openexr, exr, "
	    "rgbe, pfm")) != PM_OK ||
	    (e = finish(ld, &pl)) != PM_OK)
		return e;
	c->width = (int)w;
	c->height = (int)h;
	c->rfilter = PM_RFILTER_GAUSSIAN;
	c->filter_radius = 0.5f;
	for (i = 0; i < pl.nobj; i++) {
		if (strcmp(pl.obj[i]->tag, "rfilter") != 0)
			return fail(ld, pl.obj[i], PM_ERR_INVALID, "unexpected "
			    "<%s> inside %s", pl.obj[i]->tag, pl.what);
		if (seen)
			return fail(ld, pl.obj[i], PM_ERR_INVALID, "%s has more "
			    "than one <rfilter>", pl.what);
		seen = true;
		if ((e = load_rfilter(ld, pl.obj[i], c)) != PM_OK)
			return e;
	}
	return PM_OK;
}

static enum pm_err
load_sampler(struct ld *ld, struct xnode *n, struct pm_camera *c)
{
	struct plist pl;
	const char *type;
	long spp;
	enum pm_err e;

	if ((e = object_type(ld, n, &type)) != PM_OK ||
	    (e = collect(ld, n, "sampler", type, &pl)) != PM_OK)
		return e;
	if (strcmp(type, "independent") != 0)
		return unknown_plugin(ld, n, type, "independent");
	if ((e = get_int(ld, &pl, "sample_count", 4, 1, 1L << 24, &spp))
	    != PM_OK || (e = finish(ld, &pl)) != PM_OK ||
	    (e = no_objects(ld, &pl)) != PM_OK)
		return e;
	c->spp = (int)spp;
	return PM_OK;
}

static enum pm_err
load_sensor(struct ld *ld, struct xnode *n)
{
	static const char *const axes[] = {"x", "y", "diagonal", "smaller",
	    "larger", NULL};
	struct pm_camera *c = &ld->s->camera;
	struct plist pl;
	struct xnode *film = NULL, *sampler = NULL, *o;
	const char *type, *axis, *focal;
	double fov, near, far, focus;
	float scale;
	size_t i;
	int k;
	enum pm_err e;

	if (ld->sensor != NULL)
		return fail(ld, n, PM_ERR_UNSUPPORTED, "more than one <sensor> "
		    "(the first is at %s:%d): pm takes one camera per scene",
		    ld->sensor->file, ld->sensor->line);
	ld->sensor = n;
	if ((e = object_type(ld, n, &type)) != PM_OK ||
	    (e = collect(ld, n, "sensor", type, &pl)) != PM_OK)
		return e;
	if (strcmp(type, "perspective") != 0)
		return unknown_plugin(ld, n, type, "perspective");
	if (has(&pl, "fov") && has(&pl, "focal_length"))
		return fail(ld, prop_find(&pl, "focal_length")->n,
		    PM_ERR_INVALID, "%s: give either fov or focal_length, "
		    "not both", pl.what);
	if (has(&pl, "fov_axis") && !has(&pl, "fov"))
		return fail(ld, prop_find(&pl, "fov_axis")->n, PM_ERR_INVALID,
		    "%s: fov_axis applies only with fov", pl.what);
	if ((e = get_float(ld, &pl, "near_clip", 0.01, 1e-30, 3.4e38, &near))
	    != PM_OK ||
	    (e = get_float(ld, &pl, "far_clip", 10000.0, 1e-30, 3.4e38, &far))
	    != PM_OK ||
	    (e = get_float(ld, &pl, "focus_distance", far, 0.0, 3.4e38,
	    &focus)) != PM_OK ||
	    (e = get_transform(ld, &pl, "to_world", &c->to_world)) != PM_OK)
		return e;
	if (!(near < far))
		return fail(ld, n, PM_ERR_INVALID, "%s: near_clip %g must be "
		    "smaller than far_clip %g", pl.what, near, far);
	c->near_clip = (float)near;
	c->far_clip = (float)far;
	if (has(&pl, "fov")) {
		if ((e = get_float(ld, &pl, "fov", 90.0, 1e-6, 180.0, &fov))
		    != PM_OK || (e = get_string(ld, &pl, "fov_axis", "x",
		    &axis)) != PM_OK)
			return e;
		if (fov >= 180.0)
			return fail(ld, prop_find(&pl, "fov")->n,
			    PM_ERR_INVALID, "%s: fov must be below 180 "
			    "degrees", pl.what);
		for (k = 0; axes[k] != NULL; k++)
			if (strcasecmp(axis, axes[k]) == 0)
				break;
		if (axes[k] == NULL)
			return fail(ld, prop_find(&pl, "fov_axis")->n,
			    PM_ERR_INVALID, "%s: fov_axis \"%s\" is not one "
			    "of x, y, diagonal, smaller, larger", pl.what,
			    axis);
		c->fov = (float)fov;
		c->fov_axis = (enum pm_fov_axis)k;
	} else {
		/* 35 mm film (36 x 24 mm): the focal length gives the
		 * diagonal field of view. */
		char buf[64];
		size_t len;
		double f;

		if ((e = get_string(ld, &pl, "focal_length", "50mm", &focal))
		    != PM_OK)
			return e;
		len = strlen(focal);
		if (len >= 2 && strcmp(focal + len - 2, "mm") == 0)
			len -= 2;
		snprintf(buf, sizeof(buf), "%.*s", (int)len, focal);
		if (len >= sizeof(buf) || !number(buf, &f) || !(f > 0.0))
			return fail(ld, has(&pl, "focal_length") ?
			    prop_find(&pl, "focal_length")->n : n,
			    PM_ERR_PARSE, "%s: focal_length \"%s\" is not of "
			    "the form <x>mm with x positive", pl.what, focal);
		c->fov = (float)(2.0 * atan(sqrt(36.0 * 36.0 + 24.0 * 24.0) /
		    (2.0 * f)) * 180.0 / PI_D);
		c->fov_axis = PM_FOV_DIAGONAL;
	}
	if ((e = finish(ld, &pl)) != PM_OK)
		return e;
	if (!similarity_scale(&c->to_world, &scale) ||
	    fabsf(scale - 1.0f) > 1e-3f)
		return fail(ld, n, PM_ERR_INVALID, "%s: to_world must not "
		    "scale (as in Mitsuba)", pl.what);

	c->width = 768;
	c->height = 576;
	c->spp = 4;
	c->rfilter = PM_RFILTER_GAUSSIAN;
	c->filter_radius = 0.5f;
	for (i = 0; i < pl.nobj; i++) {
		o = pl.obj[i];
		if (strcmp(o->tag, "film") == 0) {
			if (film != NULL)
				return fail(ld, o, PM_ERR_INVALID, "%s has more "
				    "than one <film>", pl.what);
			film = o;
			if ((e = load_film(ld, o, c)) != PM_OK)
				return e;
		} else if (strcmp(o->tag, "sampler") == 0) {
			if (sampler != NULL)
				return fail(ld, o, PM_ERR_INVALID, "%s has more "
				    "than one <sampler>", pl.what);
			sampler = o;
			if ((e = load_sampler(ld, o, c)) != PM_OK)
				return e;
		} else {
			return fail(ld, o, PM_ERR_INVALID, "unexpected <%s> "
			    "inside %s", o->tag, pl.what);
		}
	}
	ld->s->has_camera = true;
	return PM_OK;
}

/* ---------------------------------------------------------------- integrator */

static enum pm_err
load_integrator(struct ld *ld, struct xnode *n)
{
	struct pm_integrator *it = &ld->s->integrator;
	struct pm_photon_params *ph = &it->photon;
	struct plist pl;
	const char *type;
	long md, rr, v;
	double r;
	enum pm_err e;

	if (ld->integrator != NULL)
		return fail(ld, n, PM_ERR_UNSUPPORTED, "more than one "
		    "<integrator> (the first is at %s:%d)",
		    ld->integrator->file, ld->integrator->line);
	ld->integrator = n;
	if ((e = object_type(ld, n, &type)) != PM_OK ||
	    (e = collect(ld, n, "integrator", type, &pl)) != PM_OK)
		return e;
	if (strcmp(type, "path") == 0) {
		it->type = PM_INTEGRATOR_PATH;
		if ((e = get_int(ld, &pl, "max_depth", -1, -1, INT_MAX, &md))
		    != PM_OK ||
		    (e = get_int(ld, &pl, "rr_depth", 5, 1, INT_MAX, &rr))
		    != PM_OK ||
		    (e = get_bool(ld, &pl, "hide_emitters", false,
		    &it->hide_emitters)) != PM_OK)
			return e;
	} else if (strcmp(type, "photonmapper") == 0) {
		it->type = PM_INTEGRATOR_PHOTONMAPPER;
		if ((e = get_int(ld, &pl, "maxDepth", -1, -1, INT_MAX, &md))
		    != PM_OK ||
		    (e = get_int(ld, &pl, "rrDepth", 5, 1, INT_MAX, &rr))
		    != PM_OK ||
		    (e = get_bool(ld, &pl, "hideEmitters", false,
		    &it->hide_emitters)) != PM_OK ||
		    (e = get_int(ld, &pl, "globalPhotons", 250000, 0,
		    LONG_MAX, &ph->global_photons)) != PM_OK ||
		    (e = get_int(ld, &pl, "causticPhotons", 250000, 0,
		    LONG_MAX, &ph->caustic_photons)) != PM_OK)
			return e;
		if ((e = get_float(ld, &pl, "globalLookupRadius", 0.05, 1e-9,
		    1e9, &r)) != PM_OK)
			return e;
		ph->global_lookup_radius = (float)r;
		if ((e = get_float(ld, &pl, "causticLookupRadius", 0.0125,
		    1e-9, 1e9, &r)) != PM_OK)
			return e;
		ph->caustic_lookup_radius = (float)r;
		if ((e = get_int(ld, &pl, "lookupSize", 120, 1, 1 << 20, &v))
		    != PM_OK)
			return e;
		ph->lookup_size = (int)v;
		if ((e = get_int(ld, &pl, "directSamples", 16, 0, 1 << 20, &v))
		    != PM_OK)
			return e;
		ph->direct_samples = (int)v;
		/* Mitsuba 0.6's glossySamples and granularity are checked and
		 * ignored (pm-scene(5)): glossy surfaces are path traced with
		 * one sample a vertex, and work is split by the tools, so
		 * neither changes the image a scene converges to. */
		if ((e = get_int(ld, &pl, "glossySamples", 32, 0, 1 << 20, &v))
		    != PM_OK ||
		    (e = get_int(ld, &pl, "granularity", 0, 0, INT_MAX, &v))
		    != PM_OK)
			return e;
		if ((e = get_bool(ld, &pl, "finalGather", false,
		    &ph->final_gather)) != PM_OK)
			return e;
		if ((e = get_int(ld, &pl, "finalGatherSamples", 64, 1, 1 << 20,
		    &v)) != PM_OK)
			return e;
		ph->final_gather_samples = (int)v;
	} else {
		return unknown_plugin(ld, n, type, "path and photonmapper");
	}
	it->max_depth = (int)md;
	it->rr_depth = (int)rr;
	if ((e = finish(ld, &pl)) != PM_OK)
		return e;
	return no_objects(ld, &pl);
}

/* ---------------------------------------------------------------- pass 2 */

static enum pm_err
build_scene(struct ld *ld)
{
	struct xnode *k;
	struct pm_bsdf tmp;
	const char *type;
	enum pm_err e;

	if ((e = build_idmap(ld)) != PM_OK)
		return e;
	/* BSDF definitions first, so that their errors come in order. */
	for (k = ld->root->kids; k != NULL; k = k->next)
		if (strcmp(k->tag, "bsdf") == 0 &&
		    (e = build_bsdf(ld, k, &tmp)) != PM_OK)
			return e;
	for (k = ld->root->kids; k != NULL; k = k->next) {
		if (strcmp(k->tag, "bsdf") == 0)
			continue;
		if (strcmp(k->tag, "shape") == 0)
			e = load_shape(ld, k, k->dir);
		else if (strcmp(k->tag, "emitter") == 0)
			e = load_emitter(ld, k);
		else if (strcmp(k->tag, "sensor") == 0)
			e = load_sensor(ld, k);
		else if (strcmp(k->tag, "integrator") == 0)
			e = load_integrator(ld, k);
		else if (strcmp(k->tag, "texture") == 0)
			e = fail(ld, k, PM_ERR_UNSUPPORTED, "textures are not "
			    "supported (<texture%s%s%s>)",
			    attr(k, "id") ? " id=\"" : "",
			    attr(k, "id") ? attr(k, "id") : "",
			    attr(k, "id") ? "\"" : "");
		else if (is_object_tag(k->tag) || ptype_of(k->tag) >= 0)
			e = fail(ld, k, PM_ERR_INVALID, "<%s> cannot appear "
			    "directly inside <scene>", k->tag);
		else
			e = fail(ld, k, PM_ERR_UNSUPPORTED, "unknown element "
			    "<%s> in <scene>", k->tag);
		if (e != PM_OK)
			return e;
	}
	/* Area emitters are definitions that some shape must use. */
	for (k = ld->root->kids; k != NULL; k = k->next) {
		if (strcmp(k->tag, "emitter") != 0 || k->inst >= 0)
			continue;
		if (object_type(ld, k, &type) != PM_OK)
			return ld->err->code;
		if (strcmp(type, "area") != 0)
			continue;
		if (attr(k, "id") != NULL)
			return fail(ld, k, PM_ERR_INVALID, "area emitter \"%s\" "
			    "is not referenced by any shape", attr(k, "id"));
		return fail(ld, k, PM_ERR_INVALID, "an area emitter must be "
		    "nested in a <shape> or referenced by one through its id");
	}
	return PM_OK;
}

static enum pm_err
load(const char *name, bool is_file, const char *buf, size_t len,
    const char *top_dir, const struct pm_define *defs, size_t ndefs,
    struct pm_scene *s, struct pm_error *err)
{
	struct ld ld;
	char *real;
	size_t i;
	enum pm_err e;

	memset(&ld, 0, sizeof(ld));
	ld.s = s;
	ld.err = err != NULL ? err : &(struct pm_error){0};
	ld.default_bsdf = -1;
	if (top_dir != NULL && (ld.top_dir = arena_strdup(&ld.arena, top_dir))
	    == NULL) {
		e = nomem(&ld);
		goto out;
	}
	for (i = 0; i < ndefs; i++) {
		if (defs[i].name == NULL || defs[i].value == NULL) {
			e = pm_fail(ld.err, PM_ERR_INVALID, "define %zu has no "
			    "name or value", i);
			goto out;
		}
		if ((e = param_add(&ld, defs[i].name, defs[i].value)) != PM_OK)
			goto out;
	}
	/* A file can then spot that it includes itself. */
	if (is_file && (real = realpath(name, NULL)) != NULL) {
		ld.incl[0] = arena_strdup(&ld.arena, real);
		free(real);
		if (ld.incl[0] == NULL) {
			e = nomem(&ld);
			goto out;
		}
		ld.nincl = 1;
	}
	if ((e = parse_doc(&ld, name, buf, len, NULL)) != PM_OK)
		goto out;
	if (ld.root == NULL) {
		e = pm_fail(ld.err, PM_ERR_PARSE, "%s:1: no <scene> element",
		    name);
		goto out;
	}
	if ((e = build_scene(&ld)) != PM_OK)
		goto out;
	e = pm_scene_prepare(s, ld.err);
out:
	arena_free(&ld.arena);
	if (e != PM_OK) {
		pm_scene_free(s);
		pm_scene_init(s);
	}
	return e;
}

/* Loads a scene file into s, which the caller frees with pm_scene_free. */
enum pm_err
pm_scene_load(const char *path, const struct pm_define *defs, size_t ndefs,
    struct pm_scene *s, struct pm_error *err)
{
	struct arena a = {NULL};
	char *buf, *dir;
	size_t len;
	enum pm_err e;

	pm_scene_init(s);
	if ((e = read_whole(path, &buf, &len, err)) != PM_OK)
		return e;
	if ((dir = dir_of(&a, path)) == NULL) {
		free(buf);
		return pm_fail(err, PM_ERR_NOMEM, "out of memory");
	}
	e = load(path, true, buf, len, dir, defs, ndefs, s, err);
	free(buf);
	arena_free(&a);
	if (e == PM_OK && (s->path = strdup(path)) == NULL) {
		pm_scene_free(s);
		pm_scene_init(s);
		return pm_fail(err, PM_ERR_NOMEM, "out of memory");
	}
	return e;
}

/* Loads a scene held in memory; name is used in messages. */
enum pm_err
pm_scene_load_string(const char *xml, size_t len, const char *name,
    const char *base_dir, const struct pm_define *defs, size_t ndefs,
    struct pm_scene *s, struct pm_error *err)
{
	enum pm_err e;

	pm_scene_init(s);
	if (name == NULL)
		name = "<string>";
	e = load(name, false, xml, len, base_dir != NULL ? base_dir : ".",
	    defs, ndefs, s, err);
	if (e == PM_OK && (s->path = strdup(name)) == NULL) {
		pm_scene_free(s);
		pm_scene_init(s);
		return pm_fail(err, PM_ERR_NOMEM, "out of memory");
	}
	return e;
}
