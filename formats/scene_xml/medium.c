/*
 * medium.c: <medium> and <phase> elements: Mitsuba 3's homogeneous and
 * heterogeneous media (the latter's sigma_t and albedo as nested
 * <volume>s, gridvolume or constvolume, or plain values) with the
 * isotropic or Henyey-Greenstein phase function.  A medium is
 * built once, when a shape (as its interior or exterior) or the sensor
 * first uses it, nested or through <ref>; media declared at the top
 * level are checked but join the scene only when used.
 */
#include <stdlib.h>

#include "../vol.h"
#include "private.h"

static enum pm_err
build_phase(struct ld *ld, struct xnode *n, struct pm_phase *ph)
{
	struct plist pl;
	const char *type;
	double g;
	enum pm_err e;

	if ((e = sx_object_type(ld, n, &type)) != PM_OK ||
	    (e = sx_collect(ld, n, "phase", type, &pl)) != PM_OK)
		return e;
	if (strcmp(type, "isotropic") == 0) {
		ph->type = PM_PHASE_ISOTROPIC;
		ph->g = 0.0f;
	} else if (strcmp(type, "hg") == 0) {
		if ((e = sx_get_float(ld, &pl, "g", 0.8, -1.0, 1.0, &g)) != PM_OK)
			return e;
		if (!(g > -1.0 && g < 1.0))
			return sx_fail(ld, sx_prop_find(&pl, "g")->n,
			    PM_ERR_INVALID, "%s: g must lie strictly between "
			    "-1 and 1", pl.what);
		ph->type = PM_PHASE_HG;
		ph->g = (float)g;
	} else {
		return sx_unknown_plugin(ld, n, type, "isotropic and hg");
	}
	if ((e = sx_finish(ld, &pl)) != PM_OK)
		return e;
	return sx_no_objects(ld, &pl);
}

/* Checks a <phase> given at the top level (to be used through <ref>). */
enum pm_err
sx_check_phase(struct ld *ld, struct xnode *n)
{
	struct pm_phase ph;

	return build_phase(ld, n, &ph);
}

/* One of a closed set of words (the first is the default); its index. */
static enum pm_err
get_word(struct ld *ld, struct plist *pl, const char *name,
    const char *const *words, int *out)
{
	const char *v;
	enum pm_err e;
	int i;

	*out = 0;
	if ((e = sx_get_string(ld, pl, name, words[0], &v)) != PM_OK)
		return e;
	for (i = 0; words[i] != NULL; i++)
		if (strcmp(v, words[i]) == 0) {
			*out = i;
			return PM_OK;
		}
	return sx_fail(ld, sx_prop_find(pl, name)->n, PM_ERR_INVALID, "%s: %s "
	    "\"%s\" is none of Mitsuba's (\"%s\", ...)", pl->what, name, v,
	    words[0]);
}

/*
 * A nested <volume>: gridvolume (a .vol file) or constvolume, placed by
 * to_world over the unit cube (gridvolume's use_grid_bbox: over the box
 * the file gives).  v->grid.data is the caller's to free, also on failure.
 */
static enum pm_err
build_volume(struct ld *ld, struct xnode *n, struct pm_volume *v)
{
	static const char *const filters[] = {"trilinear", "nearest", NULL};
	static const char *const wraps[] = {"clamp", "repeat", "mirror", NULL};
	struct plist pl;
	struct pm_mat4 to_world, B;
	const char *type, *fname, *path;
	bool raw, accel, grid_bbox = false;
	int filter = 0, wrap = 0, k;
	enum pm_err e;

	if ((e = sx_object_type(ld, n, &type)) != PM_OK ||
	    (e = sx_collect(ld, n, "volume", type, &pl)) != PM_OK)
		return e;
	if ((e = sx_get_transform(ld, &pl, "to_world", &to_world)) != PM_OK)
		return e;
	if (strcmp(type, "constvolume") == 0) {
		if ((e = sx_get_color(ld, &pl, "value", 1.0f, &v->value))
		    != PM_OK)
			return e;
	} else if (strcmp(type, "gridvolume") == 0) {
		if (!sx_has(&pl, "filename"))
			return sx_missing(ld, &pl, "filename", "a <string>");
		if ((e = sx_get_string(ld, &pl, "filename", NULL, &fname))
		    != PM_OK ||
		    (e = get_word(ld, &pl, "filter_type", filters, &filter))
		    != PM_OK ||
		    (e = get_word(ld, &pl, "wrap_mode", wraps, &wrap)) != PM_OK ||
		    (e = sx_get_bool(ld, &pl, "use_grid_bbox", false,
		    &grid_bbox)) != PM_OK ||
		    /* raw changes nothing in RGB, accel only on GPUs */
		    (e = sx_get_bool(ld, &pl, "raw", false, &raw)) != PM_OK ||
		    (e = sx_get_bool(ld, &pl, "accel", true, &accel)) != PM_OK)
			return e;
		if ((e = sx_resolve(ld, sx_prop_find(&pl, "filename")->n, n->dir,
		    fname, &path)) != PM_OK)
			return e;
		if ((e = pm_vol_read(path, &v->grid, ld->err)) != PM_OK)
			return sx_wrap(ld, n, pl.what, e);
	} else {
		return sx_unknown_plugin(ld, n, type, "gridvolume and "
		    "constvolume");
	}
	if ((e = sx_finish(ld, &pl)) != PM_OK ||
	    (e = sx_no_objects(ld, &pl)) != PM_OK)
		return e;
	v->nearest = filter == 1;
	v->wrap = wrap == 1 ? PM_VOL_REPEAT : wrap == 2 ? PM_VOL_MIRROR :
	    PM_VOL_CLAMP;
	if (!pm_mat4_inverse(to_world, &v->to_local))
		return sx_fail(ld, n, PM_ERR_INVALID, "%s: to_world is singular",
		    pl.what);
	if (grid_bbox) {
		const float *b = v->grid.bbox;
		float ext[3];

		for (k = 0; k < 3; k++) {
			ext[k] = b[3 + k] - b[k];
			if (!(ext[k] > 0.0f) || !isfinite(ext[k]))
				return sx_fail(ld, n, PM_ERR_INVALID, "%s: "
				    "use_grid_bbox with an empty box in the "
				    "file", pl.what);
		}
		/* the file's box onto the unit cube, after to_world^-1 */
		B = pm_mat4_mul(pm_mat4_scale(pm_v3(1.0f / ext[0], 1.0f / ext[1],
		    1.0f / ext[2])), pm_mat4_translate(pm_v3(-b[0], -b[1],
		    -b[2])));
		v->to_local = pm_mat4_mul(B, v->to_local);
	}
	return PM_OK;
}

/* The smallest and largest channel of a volume over its voxels. */
static void
volume_range(const struct pm_volume *v, float *lo, float *hi)
{
	size_t i, nv = (size_t)v->grid.nx * (size_t)v->grid.ny *
	    (size_t)v->grid.nz * (size_t)v->grid.nch;

	if (v->grid.data == NULL) {
		*lo = pm_fminf(v->value.r, pm_fminf(v->value.g, v->value.b));
		*hi = pm_fmaxf(v->value.r, pm_fmaxf(v->value.g, v->value.b));
		return;
	}
	*lo = *hi = v->grid.data[0];
	for (i = 1; i < nv; i++) {
		*lo = pm_fminf(*lo, v->grid.data[i]);
		*hi = pm_fmaxf(*hi, v->grid.data[i]);
	}
}

/* sigma_t and albedo of a heterogeneous medium: nested <volume>s under
 * those names, else plain values (constant volumes over the unit cube,
 * as Mitsuba makes them). */
static enum pm_err
build_hetero(struct ld *ld, struct xnode *n, struct plist *pl,
    struct pm_hetero *h, double scale)
{
	struct xnode *vol[2] = {NULL, NULL};
	const char *names[2] = {"sigma_t", "albedo"};
	struct pm_volume *vs[2] = {&h->sigma_t, &h->albedo};
	struct pm_mat4 to_world;
	float lo, hi;
	size_t i;
	int k, c;
	enum pm_err e;

	for (i = 0; i < pl->nobj; i++) {
		struct xnode *o = pl->obj[i];
		const char *nm = sx_attr(o, "name");

		if (strcmp(o->tag, "volume") != 0)
			continue;
		for (k = 0; k < 2; k++)
			if (nm != NULL && strcmp(nm, names[k]) == 0)
				break;
		if (k == 2)
			return sx_fail(ld, o, PM_ERR_INVALID, "%s: a <volume> "
			    "must be named \"sigma_t\" or \"albedo\"", pl->what);
		if (vol[k] != NULL || sx_has(pl, names[k]))
			return sx_fail(ld, o, PM_ERR_INVALID, "%s: %s given "
			    "twice", pl->what, names[k]);
		vol[k] = o;
	}
	for (k = 0; k < 2; k++) {
		vs[k]->to_local = pm_mat4_identity();
		if (vol[k] != NULL) {
			if ((e = build_volume(ld, vol[k], vs[k])) != PM_OK)
				return e;
		} else if ((e = sx_get_color(ld, pl, names[k], k == 0 ? 1.0f :
		    0.75f, &vs[k]->value)) != PM_OK) {
			return e;
		}
	}
	volume_range(&h->sigma_t, &lo, &hi);
	if (lo < 0.0f)
		return sx_fail(ld, vol[0] ? vol[0] : n, PM_ERR_INVALID, "%s: "
		    "sigma_t must not be negative (found %g)", pl->what, lo);
	h->scale = (float)scale;
	h->majorant = (float)scale * hi;
	if (!isfinite(h->majorant))
		return sx_fail(ld, n, PM_ERR_INVALID, "%s: sigma_t times scale "
		    "overflows", pl->what);
	volume_range(&h->albedo, &lo, &hi);
	if (lo < 0.0f || hi > 1.0f)
		return sx_fail(ld, vol[1] ? vol[1] : n, PM_ERR_INVALID, "%s: "
		    "albedo must lie in [0, 1] (found %g to %g)", pl->what, lo,
		    hi);
	/* Where the medium is: the world box around sigma_t's unit cube. */
	if (!pm_mat4_inverse(h->sigma_t.to_local, &to_world))
		return sx_fail(ld, n, PM_ERR_INVALID, "%s: sigma_t's to_world is "
		    "singular", pl->what);
	h->lo = pm_v3(INFINITY, INFINITY, INFINITY);
	h->hi = pm_v3(-INFINITY, -INFINITY, -INFINITY);
	for (c = 0; c < 8; c++) {
		struct pm_vec3 q = pm_xform_point(&to_world, pm_v3((float)(c & 1),
		    (float)(c >> 1 & 1), (float)(c >> 2 & 1)));

		h->lo = pm_v3(pm_fminf(h->lo.x, q.x), pm_fminf(h->lo.y, q.y),
		    pm_fminf(h->lo.z, q.z));
		h->hi = pm_v3(pm_fmaxf(h->hi.x, q.x), pm_fmaxf(h->hi.y, q.y),
		    pm_fmaxf(h->hi.z, q.z));
	}
	if (!pm_hetero_prepare(h))
		return sx_nomem(ld);
	return PM_OK;
}

static enum pm_err
build_medium(struct ld *ld, struct xnode *n, struct pm_medium *m)
{
	struct plist pl;
	struct xnode *o, *t, *phase = NULL;
	const char *type, *id;
	double scale;
	size_t i;
	bool het;
	enum pm_err e;

	memset(m, 0, sizeof(*m));
	if ((e = sx_object_type(ld, n, &type)) != PM_OK ||
	    (e = sx_collect(ld, n, "medium", type, &pl)) != PM_OK)
		return e;
	het = strcmp(type, "heterogeneous") == 0;
	if (!het && strcmp(type, "homogeneous") != 0)
		return sx_unknown_plugin(ld, n, type, "homogeneous and "
		    "heterogeneous");
	if ((e = sx_get_float(ld, &pl, "scale", 1.0, 0.0, 3.4e38, &scale))
	    != PM_OK ||
	    (e = sx_get_bool(ld, &pl, "sample_emitters", true,
	    &m->sample_emitters)) != PM_OK)
		return e;
	if (het) {
		m->type = PM_MEDIUM_HETEROGENEOUS;
		if ((m->het = calloc(1, sizeof(*m->het))) == NULL)
			return sx_nomem(ld);
		if ((e = build_hetero(ld, n, &pl, m->het, scale)) != PM_OK)
			return e;
		/* the flat fields: the largest extinction, for messages */
		m->sigma_t = pm_rgb1(m->het->majorant);
		m->albedo = m->het->albedo.value;
	} else {
		m->type = PM_MEDIUM_HOMOGENEOUS;
		if ((e = sx_get_color(ld, &pl, "sigma_t", 1.0f, &m->sigma_t))
		    != PM_OK ||
		    (e = sx_get_color(ld, &pl, "albedo", 0.75f, &m->albedo))
		    != PM_OK)
			return e;
		if (m->albedo.r > 1.0f || m->albedo.g > 1.0f ||
		    m->albedo.b > 1.0f)
			return sx_fail(ld, sx_prop_find(&pl, "albedo")->n,
			    PM_ERR_INVALID, "%s: albedo must not exceed 1 (a "
			    "medium scatters no more than it extinguishes)",
			    pl.what);
		m->sigma_t = pm_rgb_scale(m->sigma_t, (float)scale);
		if (!pm_rgb_is_finite(m->sigma_t))
			return sx_fail(ld, n, PM_ERR_INVALID, "%s: sigma_t times "
			    "scale overflows", pl.what);
	}
	if ((e = sx_finish(ld, &pl)) != PM_OK)
		return e;
	m->phase.type = PM_PHASE_ISOTROPIC;	/* Mitsuba's default */
	for (i = 0; i < pl.nobj; i++) {
		o = pl.obj[i];
		t = o;
		if (het && strcmp(o->tag, "volume") == 0)
			continue;	/* build_hetero's */
		if (strcmp(o->tag, "ref") == 0 && (e = sx_deref(ld, o, &t)) != PM_OK)
			return e;
		if (strcmp(t->tag, "phase") != 0)
			return sx_fail(ld, o, PM_ERR_INVALID, "unexpected <%s> "
			    "inside %s (only a <phase>%s)", t->tag, pl.what,
			    het ? " and <volume>s" : "");
		if (phase != NULL)
			return sx_fail(ld, o, PM_ERR_INVALID, "%s has more than "
			    "one <phase> (first at line %d)", pl.what,
			    phase->line);
		phase = o;
		if ((e = build_phase(ld, t, &m->phase)) != PM_OK)
			return e;
	}
	id = sx_attr(n, "id");
	if (id != NULL)
		snprintf(m->name, sizeof(m->name), "%s", id);
	else
		snprintf(m->name, sizeof(m->name), "%s#%zu", type, ld->s->nmedia);
	return PM_OK;
}

/* Builds *m; on failure nothing is left to free. */
enum pm_err
sx_build_medium(struct ld *ld, struct xnode *n, struct pm_medium *m)
{
	enum pm_err e = build_medium(ld, n, m);

	if (e != PM_OK)
		pm_medium_release(m);
	return e;
}

enum pm_err
sx_medium_index(struct ld *ld, struct xnode *n, int *out)
{
	struct pm_medium m;
	enum pm_err e;
	int i;

	if (n->inst >= 0) {
		*out = n->inst;
		return PM_OK;
	}
	if ((e = sx_build_medium(ld, n, &m)) != PM_OK)
		return e;
	if ((i = pm_scene_add_medium(ld->s)) < 0)
		return sx_nomem(ld);
	ld->s->media[i] = m;
	n->inst = i;
	*out = i;
	return PM_OK;
}

enum pm_err
sx_shape_medium(struct ld *ld, struct plist *pl, struct xnode *o,
    struct xnode *t, int *interior, int *exterior)
{
	const char *name = sx_attr(o, "name");
	int *slot;

	if (name != NULL && strcmp(name, "interior") == 0)
		slot = interior;
	else if (name != NULL && strcmp(name, "exterior") == 0)
		slot = exterior;
	else
		return sx_fail(ld, o, PM_ERR_INVALID, "%s: a medium must be "
		    "named \"interior\" or \"exterior\"%s%s%s", pl->what,
		    name ? " (found \"" : "", name ? name : "", name ? "\")" : "");
	if (*slot >= 0)
		return sx_fail(ld, o, PM_ERR_INVALID, "%s has more than one %s "
		    "medium", pl->what, name);
	return sx_medium_index(ld, t, slot);
}
