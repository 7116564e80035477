/*
 * medium.c: <medium> and <phase> elements: Mitsuba 3's homogeneous medium
 * with its isotropic or Henyey-Greenstein phase function.  A medium is
 * built once, when a shape (as its interior or exterior) or the sensor
 * first uses it, nested or through <ref>; media declared at the top
 * level are checked but join the scene only when used.
 */
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

enum pm_err
sx_build_medium(struct ld *ld, struct xnode *n, struct pm_medium *m)
{
	struct plist pl;
	struct xnode *o, *t, *phase = NULL;
	const char *type, *id;
	double scale;
	size_t i;
	enum pm_err e;

	memset(m, 0, sizeof(*m));
	if ((e = sx_object_type(ld, n, &type)) != PM_OK ||
	    (e = sx_collect(ld, n, "medium", type, &pl)) != PM_OK)
		return e;
	if (strcmp(type, "homogeneous") != 0)
		return sx_unknown_plugin(ld, n, type, "homogeneous");
	m->type = PM_MEDIUM_HOMOGENEOUS;
	if ((e = sx_get_color(ld, &pl, "sigma_t", 1.0f, &m->sigma_t)) != PM_OK ||
	    (e = sx_get_color(ld, &pl, "albedo", 0.75f, &m->albedo)) != PM_OK ||
	    (e = sx_get_float(ld, &pl, "scale", 1.0, 0.0, 3.4e38, &scale))
	    != PM_OK ||
	    (e = sx_get_bool(ld, &pl, "sample_emitters", true,
	    &m->sample_emitters)) != PM_OK)
		return e;
	if (m->albedo.r > 1.0f || m->albedo.g > 1.0f || m->albedo.b > 1.0f)
		return sx_fail(ld, sx_prop_find(&pl, "albedo")->n, PM_ERR_INVALID,
		    "%s: albedo must not exceed 1 (a medium scatters no more "
		    "than it extinguishes)", pl.what);
	m->sigma_t = pm_rgb_scale(m->sigma_t, (float)scale);
	if (!pm_rgb_is_finite(m->sigma_t))
		return sx_fail(ld, n, PM_ERR_INVALID, "%s: sigma_t times scale "
		    "overflows", pl.what);
	if ((e = sx_finish(ld, &pl)) != PM_OK)
		return e;
	m->phase.type = PM_PHASE_ISOTROPIC;	/* Mitsuba's default */
	for (i = 0; i < pl.nobj; i++) {
		o = pl.obj[i];
		t = o;
		if (strcmp(o->tag, "ref") == 0 && (e = sx_deref(ld, o, &t)) != PM_OK)
			return e;
		if (strcmp(t->tag, "phase") != 0)
			return sx_fail(ld, o, PM_ERR_INVALID, "unexpected <%s> "
			    "inside %s (only a <phase>)", t->tag, pl.what);
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
