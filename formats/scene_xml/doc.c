/*
 * doc.c: the scene loader's first pass (see load.c).  Reads a document
 * with expat into a tree of elements, expanding <include>, <default>,
 * <path> and $name substitutions as it goes, so that every element keeps
 * the file and line it came from; then indexes the tree's ids.  Also the
 * helpers every other part uses: the arena, messages naming file and
 * line, attributes, and finding the files a scene names.
 */
#include "private.h"

void *
sx_arena_alloc(struct arena *a, size_t n)
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
	char *p = sx_arena_alloc(a, n + 1);

	if (p != NULL) {
		memcpy(p, s, n);
		p[n] = '\0';
	}
	return p;
}

char *
sx_arena_strdup(struct arena *a, const char *s)
{
	return arena_strndup(a, s, strlen(s));
}

void
sx_arena_free(struct arena *a)
{
	struct blk *b, *next;

	for (b = a->head; b != NULL; b = next) {
		next = b->next;
		free(b);
	}
	a->head = NULL;
}

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

enum pm_err
sx_fail(struct ld *ld, const struct xnode *n, enum pm_err code,
    const char *fmt, ...)
{
	va_list ap;
	enum pm_err e;

	va_start(ap, fmt);
	e = vfail_at(ld, n->file, n->line, code, fmt, ap);
	va_end(ap);
	return e;
}

enum pm_err
sx_nomem(struct ld *ld)
{
	ld->failed = true;
	return pm_fail(ld->err, PM_ERR_NOMEM, "out of memory reading the scene");
}

const char *
sx_attr(const struct xnode *n, const char *name)
{
	const char **a;

	for (a = n->attr; a[0] != NULL; a += 2)
		if (strcmp(a[0], name) == 0)
			return a[1];
	return NULL;
}

/* Fails on an attribute not named in allowed (NULL-terminated). */
enum pm_err
sx_check_attrs(struct ld *ld, const struct xnode *n, const char *const *allowed)
{
	const char **a;
	const char *const *ok;

	for (a = n->attr; a[0] != NULL; a += 2) {
		for (ok = allowed; *ok != NULL; ok++)
			if (strcmp(a[0], *ok) == 0)
				break;
		if (*ok == NULL)
			return sx_fail(ld, n, PM_ERR_UNSUPPORTED,
			    "unexpected attribute \"%s\" in <%s>", a[0], n->tag);
	}
	return PM_OK;
}

enum pm_err
sx_need_attr(struct ld *ld, const struct xnode *n, const char *name,
    const char **out)
{
	*out = sx_attr(n, name);
	if (*out == NULL)
		return sx_fail(ld, n, PM_ERR_INVALID,
		    "<%s> needs the attribute \"%s\"", n->tag, name);
	return PM_OK;
}

/* ---------------------------------------------------------------- files */

char *
sx_dir_of(struct arena *a, const char *path)
{
	const char *slash = strrchr(path, '/');

	if (slash == NULL)
		return sx_arena_strdup(a, ".");
	if (slash == path)
		return sx_arena_strdup(a, "/");
	return arena_strndup(a, path, (size_t)(slash - path));
}

static char *
join(struct arena *a, const char *dir, const char *name)
{
	size_t nd, nn;
	char *p;

	if (name[0] == '/' || dir == NULL || strcmp(dir, ".") == 0)
		return sx_arena_strdup(a, name);
	nd = strlen(dir);
	nn = strlen(name);
	p = sx_arena_alloc(a, nd + nn + 2);
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
enum pm_err
sx_resolve(struct ld *ld, const struct xnode *n, const char *naming_dir,
    const char *name, const char **out)
{
	const char *cand[2];
	struct dir *d;
	int i;

	if (name[0] == '\0')
		return sx_fail(ld, n, PM_ERR_INVALID, "empty file name in <%s>",
		    n->tag);
	if (name[0] == '/') {
		*out = name;
		if (access(name, F_OK) != 0)
			return sx_fail(ld, n, PM_ERR_IO, "%s: %s", name,
			    strerror(errno));
		return PM_OK;
	}
	cand[0] = naming_dir != NULL ? naming_dir : ".";
	cand[1] = ld->top_dir;
	for (i = 0; i < 2; i++) {
		if (cand[i] == NULL)
			continue;
		if ((*out = join(&ld->arena, cand[i], name)) == NULL)
			return sx_nomem(ld);
		if (access(*out, F_OK) == 0)
			return PM_OK;
	}
	for (d = ld->dirs; d != NULL; d = d->next) {
		if ((*out = join(&ld->arena, d->path, name)) == NULL)
			return sx_nomem(ld);
		if (access(*out, F_OK) == 0)
			return PM_OK;
	}
	if (cand[1] == NULL || strcmp(cand[0], cand[1]) == 0)
		cand[1] = NULL;
	return sx_fail(ld, n, PM_ERR_IO,
	    "cannot find \"%s\" (looked in %s%s%s%s)", name, cand[0],
	    cand[1] != NULL ? ", " : "", cand[1] != NULL ? cand[1] : "",
	    ld->dirs != NULL ? " and each <path>" : "");
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

enum pm_err
sx_param_add(struct ld *ld, const char *name, const char *value)
{
	struct param *p = sx_arena_alloc(&ld->arena, sizeof(*p));

	if (p == NULL)
		return sx_nomem(ld);
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
		*out = sx_arena_strdup(&ld->arena, s);
		return *out == NULL ? sx_nomem(ld) : PM_OK;
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
	if ((buf = sx_arena_alloc(&ld->arena, cap)) == NULL)
		return sx_nomem(ld);
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

	if ((e = sx_check_attrs(ld, n, ok)) != PM_OK ||
	    (e = sx_need_attr(ld, n, "filename", &name)) != PM_OK ||
	    (e = sx_resolve(ld, n, d->dir, name, &path)) != PM_OK)
		return e;
	if ((real = realpath(path, NULL)) == NULL)
		return sx_fail(ld, n, PM_ERR_IO, "%s: %s", path, strerror(errno));
	for (i = 0; i < ld->nincl; i++) {
		if (strcmp(ld->incl[i], real) == 0) {
			free(real);
			return sx_fail(ld, n, PM_ERR_INVALID,
			    "include cycle: \"%s\" includes itself, directly "
			    "or through the files it includes", path);
		}
	}
	if (ld->nincl >= MAX_INCLUDE_DEPTH) {
		free(real);
		return sx_fail(ld, n, PM_ERR_LIMIT,
		    "includes nested deeper than %d", MAX_INCLUDE_DEPTH);
	}
	ld->incl[ld->nincl] = sx_arena_strdup(&ld->arena, real);
	free(real);
	if (ld->incl[ld->nincl] == NULL)
		return sx_nomem(ld);
	ld->nincl++;
	e = pm_read_file(path, MAX_FILE_SIZE, &buf, &len, ld->err);
	if (e != PM_OK) {
		char msg[sizeof(ld->err->msg)];

		snprintf(msg, sizeof(msg), "%s", ld->err->msg);
		ld->nincl--;
		return sx_fail(ld, n, e, "<include>: %s", msg);
	}
	e = sx_parse_doc(ld, path, buf, len, ld->root);
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

	if ((e = sx_check_attrs(ld, n, ok)) != PM_OK ||
	    (e = sx_need_attr(ld, n, "name", &name)) != PM_OK ||
	    (e = sx_need_attr(ld, n, "value", &value)) != PM_OK)
		return e;
	if (!is_ident_start((unsigned char)name[0]))
		return sx_fail(ld, n, PM_ERR_INVALID,
		    "<default> name \"%s\" is not an identifier", name);
	for (p = name; *p != '\0'; p++)
		if (!is_ident((unsigned char)*p))
			return sx_fail(ld, n, PM_ERR_INVALID,
			    "<default> name \"%s\" is not an identifier", name);
	/* A -D define, or an earlier default, wins. */
	if (param_lookup(ld, name, strlen(name)) != NULL)
		return PM_OK;
	return sx_param_add(ld, name, value);
}

static enum pm_err
do_path(struct ld *ld, struct doc *d, struct xnode *n)
{
	static const char *const ok[] = {"value", NULL};
	const char *value;
	struct dir *dir;
	enum pm_err e;

	if ((e = sx_check_attrs(ld, n, ok)) != PM_OK ||
	    (e = sx_need_attr(ld, n, "value", &value)) != PM_OK)
		return e;
	if ((dir = sx_arena_alloc(&ld->arena, sizeof(*dir))) == NULL ||
	    (dir->path = join(&ld->arena, d->dir, value)) == NULL)
		return sx_nomem(ld);
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
	if ((n = sx_arena_alloc(&ld->arena, sizeof(*n))) == NULL)
		goto oom;
	for (na = 0; atts[2 * na] != NULL; na++)
		;
	if ((n->attr = sx_arena_alloc(&ld->arena,
	    (2 * na + 1) * sizeof(*n->attr))) == NULL ||
	    (n->tag = sx_arena_strdup(&ld->arena, tag)) == NULL)
		goto oom;
	n->file = d->file;
	n->dir = d->dir;
	n->line = line;
	n->seq = ld->seq++;
	n->inst = -1;
	for (i = 0; i < na; i++) {
		if ((n->attr[2 * i] = sx_arena_strdup(&ld->arena,
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
			sx_fail(ld, n, PM_ERR_INVALID,
			    "expected <scene> as the root element, found <%s>",
			    tag);
			goto stop;
		}
		if (sx_check_attrs(ld, n, ok) != PM_OK ||
		    sx_need_attr(ld, n, "version", &v) != PM_OK)
			goto stop;
		if (!version_ok(v)) {
			sx_fail(ld, n, PM_ERR_UNSUPPORTED,
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
		sx_fail(ld, n, PM_ERR_INVALID, "<%s> takes no child elements, "
		    "found <%s>", d->cur->tag, tag);
		goto stop;
	}
	n->parent = d->cur;
	if (is_directive(tag)) {
		/* Handled now, so that later elements see their effect;
		 * never linked into the tree. */
		if (d->depth != 1) {
			sx_fail(ld, n, PM_ERR_INVALID,
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
	sx_nomem(ld);
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
enum pm_err
sx_parse_doc(struct ld *ld, const char *file, const char *buf, size_t len,
    struct xnode *graft)
{
	struct doc d;
	enum XML_Status st;

	memset(&d, 0, sizeof(d));
	d.ld = ld;
	d.graft = graft;
	if ((d.file = sx_arena_strdup(&ld->arena, file)) == NULL ||
	    (d.dir = sx_dir_of(&ld->arena, file)) == NULL)
		return sx_nomem(ld);
	if (graft == NULL && ld->top_dir != NULL)
		d.dir = ld->top_dir;
	if (len > (size_t)INT_MAX)
		return fail_at(ld, d.file, 1, PM_ERR_LIMIT, "file too large");
	if (is_blank(buf, len))
		return fail_at(ld, d.file, 1, PM_ERR_PARSE,
		    "empty file: expected a <scene> element");
	if ((d.p = XML_ParserCreate(NULL)) == NULL)
		return sx_nomem(ld);
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
	const char *id = sx_attr(n, "id");
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

enum pm_err
sx_build_idmap(struct ld *ld)
{
	size_t count = 0, i;
	enum pm_err e;

	collect_ids(ld, ld->root, &count, false);
	if (count == 0)
		return PM_OK;
	if ((ld->ids = sx_arena_alloc(&ld->arena, count * sizeof(*ld->ids))) == NULL)
		return sx_nomem(ld);
	if ((e = collect_ids(ld, ld->root, &count, true)) != PM_OK)
		return e;
	qsort(ld->ids, ld->nids, sizeof(*ld->ids), idcmp_seq);
	for (i = 1; i < ld->nids; i++) {
		if (strcmp(ld->ids[i - 1].id, ld->ids[i].id) == 0) {
			const struct xnode *a = ld->ids[i - 1].node;

			return sx_fail(ld, ld->ids[i].node, PM_ERR_INVALID,
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
enum pm_err
sx_deref(struct ld *ld, struct xnode *ref, struct xnode **out)
{
	static const char *const ok[] = {"id", "name", NULL};
	const char *id;
	enum pm_err e;

	if ((e = sx_check_attrs(ld, ref, ok)) != PM_OK ||
	    (e = sx_need_attr(ld, ref, "id", &id)) != PM_OK)
		return e;
	if (ref->kids != NULL)
		return sx_fail(ld, ref->kids, PM_ERR_INVALID,
		    "<ref> takes no child elements, found <%s>", ref->kids->tag);
	if ((*out = find_id(ld, id)) == NULL)
		return sx_fail(ld, ref, PM_ERR_INVALID,
		    "<ref id=\"%s\">: no object has this id", id);
	return PM_OK;
}
