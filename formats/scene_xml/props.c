/*
 * props.c: the typed properties of an object (<float>, <rgb>, ...): they
 * are collected once per object, each read at most once by name with its
 * type and range checked, and any left unread is an error.
 */
#include "private.h"

static const char *const ptype_name[] = {
	"float", "integer", "boolean", "string", "rgb", "spectrum",
	"point", "vector", "transform",
};

bool
sx_is_object_tag(const char *t)
{
	static const char *const tags[] = {"bsdf", "emitter", "shape",
	    "sensor", "sampler", "film", "rfilter", "integrator", "ref", "medium",
	    "phase", "volume", NULL};
	const char *const *p;

	for (p = tags; *p != NULL; p++)
		if (strcmp(t, *p) == 0)
			return true;
	return false;
}

int
sx_ptype_of(const char *t)
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
	if (t == P_SPECTRUM)
		return sx_parse_spectrum(ld, k, p);
	if ((e = sx_check_attrs(ld, k, t == P_TRANSFORM ? ok_t :
	    t == P_POINT || t == P_VECTOR ? ok_xyz : ok_nv)) != PM_OK ||
	    (e = sx_need_attr(ld, k, "name", &p->name)) != PM_OK)
		return e;
	if (t != P_TRANSFORM && (e = sx_no_kids(ld, k)) != PM_OK)
		return e;
	if (t != P_TRANSFORM && t != P_POINT && t != P_VECTOR &&
	    (e = sx_need_attr(ld, k, "value", &v)) != PM_OK)
		return e;
	switch (t) {
	case P_FLOAT:
		if (!sx_number(v, &p->f))
			return sx_fail(ld, k, PM_ERR_PARSE, "<float name=\"%s\">: "
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
			return sx_fail(ld, k, PM_ERR_PARSE, "<integer name=\"%s\">"
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
			return sx_fail(ld, k, PM_ERR_PARSE, "<boolean name=\"%s\">"
			    ": \"%s\" is neither true nor false", p->name, v);
		break;
	case P_STRING:
		p->s = v;
		break;
	case P_RGB:
		if ((e = sx_numbers(ld, k, "value", v, d, 1, 3, &cnt)) != PM_OK)
			return e;
		p->c = cnt == 1 ? pm_rgb1((float)d[0]) :
		    pm_rgb((float)d[0], (float)d[1], (float)d[2]);
		break;
	case P_SPECTRUM:	/* sx_parse_spectrum, above */
		break;
	case P_POINT:
	case P_VECTOR:
		if (sx_attr(k, "value") == NULL && sx_attr(k, "x") == NULL &&
		    sx_attr(k, "y") == NULL && sx_attr(k, "z") == NULL)
			return sx_fail(ld, k, PM_ERR_INVALID, "<%s name=\"%s\"> "
			    "needs value or x, y, z", k->tag, p->name);
		if ((e = sx_xyz(ld, k, 0.0, &p->v)) != PM_OK)
			return e;
		break;
	case P_TRANSFORM:
		if ((e = sx_parse_transform(ld, k, &p->m)) != PM_OK)
			return e;
		break;
	}
	return PM_OK;
}

/* Starts pl for owner's children, with room for every one of them as a
 * property. */
static enum pm_err
plist_start(struct ld *ld, const struct xnode *owner, struct plist *pl)
{
	struct xnode *k;
	size_t n = 0;

	memset(pl, 0, sizeof(*pl));
	pl->owner = owner;
	for (k = owner->kids; k != NULL; k = k->next)
		n++;
	if (n > 0 && (pl->p = sx_arena_alloc(&ld->arena, n * sizeof(*pl->p)))
	    == NULL)
		return sx_nomem(ld);
	return PM_OK;
}

/* Adds the property element k (of type t) to pl; a name given twice is
 * an error. */
static enum pm_err
plist_add(struct ld *ld, struct plist *pl, const struct xnode *k, int t)
{
	struct prop *p = &pl->p[pl->n];
	size_t i;
	enum pm_err e;

	if ((e = parse_prop(ld, k, (enum ptype)t, p)) != PM_OK)
		return e;
	for (i = 0; i < pl->n; i++)
		if (strcmp(pl->p[i].name, p->name) == 0)
			return sx_fail(ld, k, PM_ERR_INVALID, "%s: parameter "
			    "\"%s\" given twice (also at line %d)", pl->what,
			    p->name, pl->p[i].n->line);
	pl->n++;
	return PM_OK;
}

/*
 * Reads the children of an object element: properties into pl->p, nested
 * objects and refs into pl->obj.  Anything else is an error.
 */
enum pm_err
sx_collect(struct ld *ld, const struct xnode *owner, const char *kind,
    const char *type, struct plist *pl)
{
	struct xnode *k;
	int t;
	enum pm_err e;

	if ((e = plist_start(ld, owner, pl)) != PM_OK)
		return e;
	snprintf(pl->what, sizeof(pl->what), "%s \"%s\"", kind, type);
	for (k = owner->kids; k != NULL; k = k->next) {
		if ((t = sx_ptype_of(k->tag)) >= 0) {
			if ((e = plist_add(ld, pl, k, t)) != PM_OK)
				return e;
		} else if (strcmp(k->tag, "texture") == 0) {
			if (pl->ntex == sizeof(pl->tex) / sizeof(pl->tex[0]))
				return sx_fail(ld, k, PM_ERR_LIMIT,
				    "%s: too many nested textures", pl->what);
			pl->tex[pl->ntex++] = k;
		} else if (sx_is_object_tag(k->tag)) {
			if (pl->nobj == sizeof(pl->obj) / sizeof(pl->obj[0]))
				return sx_fail(ld, k, PM_ERR_LIMIT,
				    "%s: too many nested objects", pl->what);
			pl->obj[pl->nobj++] = k;
		} else {
			return sx_fail(ld, k, PM_ERR_UNSUPPORTED,
			    "unknown element <%s> in %s", k->tag, pl->what);
		}
	}
	return PM_OK;
}

/* The property children of <scene> (its own parameters), leaving its
 * objects to the caller. */
enum pm_err
sx_collect_scene(struct ld *ld, const struct xnode *root, struct plist *pl)
{
	struct xnode *k;
	int t;
	enum pm_err e;

	if ((e = plist_start(ld, root, pl)) != PM_OK)
		return e;
	snprintf(pl->what, sizeof(pl->what), "<scene>");
	for (k = root->kids; k != NULL; k = k->next)
		if ((t = sx_ptype_of(k->tag)) >= 0 &&
		    (e = plist_add(ld, pl, k, t)) != PM_OK)
			return e;
	return PM_OK;
}

struct prop *
sx_prop_find(struct plist *pl, const char *name)
{
	size_t i;

	for (i = 0; i < pl->n; i++)
		if (strcmp(pl->p[i].name, name) == 0)
			return &pl->p[i];
	return NULL;
}

bool
sx_has(struct plist *pl, const char *name)
{
	return sx_prop_find(pl, name) != NULL;
}

enum pm_err
sx_wrong_type(struct ld *ld, struct plist *pl, struct prop *p, const char *want)
{
	return sx_fail(ld, p->n, PM_ERR_INVALID, "%s: parameter \"%s\" must be "
	    "%s, found <%s>", pl->what, p->name, want, ptype_name[p->type]);
}

/* A nested <texture> that no parameter took: pm does not read a texture
 * there. */
static enum pm_err
texture_error(struct ld *ld, struct plist *pl)
{
	const char *nm = sx_attr(pl->tex[0], "name");

	if (nm == NULL)
		return sx_fail(ld, pl->tex[0], PM_ERR_INVALID, "%s: a nested "
		    "<texture> needs a name, the parameter it gives", pl->what);
	return sx_fail(ld, pl->tex[0], PM_ERR_UNSUPPORTED, "%s: textures are "
	    "not supported here (<texture name=\"%s\">)", pl->what, nm);
}

enum pm_err
sx_missing(struct ld *ld, struct plist *pl, const char *name, const char *want)
{
	/* a parameter given as a texture is missing for that reason */
	if (pl->ntex > 0)
		return texture_error(ld, pl);
	return sx_fail(ld, pl->owner, PM_ERR_INVALID, "%s: missing required "
	    "parameter \"%s\" (%s)", pl->what, name, want);
}

/* A float (an integer will do) in [lo, hi]; def if absent. */
enum pm_err
sx_get_float(struct ld *ld, struct plist *pl, const char *name, double def,
    double lo, double hi, double *out)
{
	struct prop *p = sx_prop_find(pl, name);

	*out = def;
	if (p == NULL)
		return PM_OK;
	p->used = true;
	if (p->type != P_FLOAT && p->type != P_INTEGER)
		return sx_wrong_type(ld, pl, p, "a <float>");
	if (p->f < lo || p->f > hi)
		return sx_fail(ld, p->n, PM_ERR_INVALID, "%s: parameter \"%s\" = "
		    "%g is outside [%g, %g]", pl->what, name, p->f, lo, hi);
	*out = p->f;
	return PM_OK;
}

enum pm_err
sx_get_int(struct ld *ld, struct plist *pl, const char *name, long def,
    long lo, long hi, long *out)
{
	struct prop *p = sx_prop_find(pl, name);

	*out = def;
	if (p == NULL)
		return PM_OK;
	p->used = true;
	if (p->type != P_INTEGER)
		return sx_wrong_type(ld, pl, p, "an <integer>");
	if (p->i < lo || p->i > hi)
		return sx_fail(ld, p->n, PM_ERR_INVALID, "%s: parameter \"%s\" = "
		    "%ld is outside [%ld, %ld]", pl->what, name, p->i, lo, hi);
	*out = p->i;
	return PM_OK;
}

enum pm_err
sx_get_bool(struct ld *ld, struct plist *pl, const char *name, bool def,
    bool *out)
{
	struct prop *p = sx_prop_find(pl, name);

	*out = def;
	if (p == NULL)
		return PM_OK;
	p->used = true;
	if (p->type != P_BOOLEAN)
		return sx_wrong_type(ld, pl, p, "a <boolean>");
	*out = p->b;
	return PM_OK;
}

enum pm_err
sx_get_string(struct ld *ld, struct plist *pl, const char *name,
    const char *def, const char **out)
{
	struct prop *p = sx_prop_find(pl, name);

	*out = def;
	if (p == NULL)
		return PM_OK;
	p->used = true;
	if (p->type != P_STRING)
		return sx_wrong_type(ld, pl, p, "a <string>");
	*out = p->s;
	return PM_OK;
}

/*
 * A colour: <rgb>, <spectrum> or <float>; non-negative.  A spectrum's RGB
 * depends on whether an emitter uses it, and on whether the parameter is
 * bounded by one (Mitsuba reads a conductor's eta and k unbounded).
 */
enum pm_err
sx_get_color(struct ld *ld, struct plist *pl, const char *name, float def,
    struct pm_rgb *out)
{
	struct prop *p = sx_prop_find(pl, name);

	*out = pm_rgb1(def);
	if (p == NULL)
		return PM_OK;
	p->used = true;
	if (p->type == P_FLOAT || p->type == P_INTEGER)
		*out = pm_rgb1((float)p->f);
	else if (p->type == P_RGB)
		*out = p->c;
	else if (p->type == P_SPECTRUM)
		*out = sx_spectrum_rgb(p->spec,
		    strcmp(pl->owner->tag, "emitter") == 0,
		    strcmp(name, "eta") == 0 || strcmp(name, "k") == 0);
	else
		return sx_wrong_type(ld, pl, p, "an <rgb>, <spectrum> or <float>");
	if (!(out->r >= 0.0f && out->g >= 0.0f && out->b >= 0.0f))
		return sx_fail(ld, p->n, PM_ERR_INVALID, "%s: parameter \"%s\" "
		    "must not be negative", pl->what, name);
	return PM_OK;
}

enum pm_err
sx_get_point(struct ld *ld, struct plist *pl, const char *name,
    struct pm_vec3 def, struct pm_vec3 *out)
{
	struct prop *p = sx_prop_find(pl, name);

	*out = def;
	if (p == NULL)
		return PM_OK;
	p->used = true;
	if (p->type != P_POINT)
		return sx_wrong_type(ld, pl, p, "a <point>");
	*out = p->v;
	return PM_OK;
}

enum pm_err
sx_get_transform(struct ld *ld, struct plist *pl, const char *name,
    struct pm_mat4 *out)
{
	struct prop *p = sx_prop_find(pl, name);

	*out = pm_mat4_identity();
	if (p == NULL)
		return PM_OK;
	p->used = true;
	if (p->type != P_TRANSFORM)
		return sx_wrong_type(ld, pl, p, "a <transform>");
	*out = p->m;
	return PM_OK;
}

/* Fails on the first parameter no getter asked for. */
enum pm_err
sx_finish(struct ld *ld, struct plist *pl)
{
	size_t i;

	if (pl->ntex > 0)
		return texture_error(ld, pl);
	for (i = 0; i < pl->n; i++)
		if (!pl->p[i].used)
			return sx_fail(ld, pl->p[i].n, PM_ERR_UNSUPPORTED,
			    "unknown parameter \"%s\" for %s", pl->p[i].name,
			    pl->what);
	return PM_OK;
}

enum pm_err
sx_no_objects(struct ld *ld, struct plist *pl)
{
	struct xnode *t;

	if (pl->nobj == 0)
		return PM_OK;
	/* A <ref> to a texture is a texture given by reference. */
	if (strcmp(pl->obj[0]->tag, "ref") == 0 &&
	    sx_deref(ld, pl->obj[0], &t) == PM_OK &&
	    strcmp(t->tag, "texture") == 0)
		return sx_fail(ld, pl->obj[0], PM_ERR_UNSUPPORTED, "%s: textures "
		    "are not supported here (<ref id=\"%s\"> names the "
		    "<texture> at line %d)", pl->what, sx_attr(pl->obj[0], "id"),
		    t->line);
	return sx_fail(ld, pl->obj[0], PM_ERR_INVALID,
	    "unexpected <%s> inside %s", pl->obj[0]->tag, pl->what);
}

/* The type attribute of an object element, with id and name allowed. */
enum pm_err
sx_object_type(struct ld *ld, const struct xnode *n, const char **type)
{
	static const char *const ok[] = {"type", "id", "name", NULL};
	enum pm_err e;

	if ((e = sx_check_attrs(ld, n, ok)) != PM_OK)
		return e;
	return sx_need_attr(ld, n, "type", type);
}

enum pm_err
sx_unknown_plugin(struct ld *ld, const struct xnode *n, const char *type,
    const char *known)
{
	return sx_fail(ld, n, PM_ERR_UNSUPPORTED, "unknown %s type \"%s\" "
	    "(pm supports %s)", n->tag, type, known);
}
