/*
 * load.c: reads the subset of Mitsuba 3's XML scene format that pm
 * supports (man/pm-scene.5) into a struct pm_scene.
 *
 * Loading runs in two passes.  The first (doc.c) reads the document with expat
 * into a small tree of elements, expanding <include>, <default>, <path>
 * and $name substitutions as it goes, so that every element keeps the file
 * and line it came from.  The second (here) walks the tree and builds shapes,
 * BSDFs, lights, the camera and the integrator.  Building only after the
 * whole tree is known lets a shape refer to a BSDF or an area emitter
 * declared further down, as Mitsuba's own Cornell box does.
 *
 * Nothing is skipped silently: an element, plugin type or parameter
 * outside the subset is an error naming the file, the line and what was
 * expected.  Every allocation of the first pass lives in one arena that
 * is freed when loading ends.
 */
#include "private.h"

static enum pm_err
build_scene(struct ld *ld)
{
	struct xnode *k;
	struct pm_bsdf tmp;
	struct pm_medium mtmp;
	const char *type;
	enum pm_err e;
	int ti;

	if ((e = sx_build_idmap(ld)) != PM_OK)
		return e;
	/* The scene's own parameters (Mitsuba's Scene plugin): only its
	 * choice of Embree's robust mode, which pm follows. */
	{
		struct plist pl;

		if ((e = sx_collect_scene(ld, ld->root, &pl)) != PM_OK ||
		    (e = sx_get_bool(ld, &pl, "embree_use_robust_intersections",
		    false, &ld->s->robust)) != PM_OK ||
		    (e = sx_finish(ld, &pl)) != PM_OK)
			return e;
	}
	/* BSDF definitions first, so that their errors come in order. */
	for (k = ld->root->kids; k != NULL; k = k->next)
		if (strcmp(k->tag, "bsdf") == 0 &&
		    (e = sx_build_bsdf(ld, k, &tmp)) != PM_OK)
			return e;
	for (k = ld->root->kids; k != NULL; k = k->next) {
		if (strcmp(k->tag, "bsdf") == 0)
			continue;
		if (strcmp(k->tag, "shape") == 0)
			e = sx_load_shape(ld, k, k->dir);
		else if (strcmp(k->tag, "emitter") == 0)
			e = sx_load_emitter(ld, k);
		else if (strcmp(k->tag, "sensor") == 0)
			e = sx_load_sensor(ld, k);
		else if (strcmp(k->tag, "integrator") == 0)
			e = sx_load_integrator(ld, k);
		else if (strcmp(k->tag, "medium") == 0) {
			e = sx_build_medium(ld, k, &mtmp);	/* checked only */
			pm_medium_release(&mtmp);
		} else if (strcmp(k->tag, "phase") == 0)
			e = sx_check_phase(ld, k);
		else if (strcmp(k->tag, "texture") == 0)
			e = sx_texture_index(ld, k, &ti);	/* once, if used */
		else if (sx_ptype_of(k->tag) >= 0)
			continue;	/* the scene's own, read above */
		else if (sx_is_object_tag(k->tag))
			e = sx_fail(ld, k, PM_ERR_INVALID, "<%s> cannot appear "
			    "directly inside <scene>", k->tag);
		else
			e = sx_fail(ld, k, PM_ERR_UNSUPPORTED, "unknown element "
			    "<%s> in <scene>", k->tag);
		if (e != PM_OK)
			return e;
	}
	/* Area emitters are definitions that some shape must use. */
	for (k = ld->root->kids; k != NULL; k = k->next) {
		if (strcmp(k->tag, "emitter") != 0 || k->inst >= 0)
			continue;
		if (sx_object_type(ld, k, &type) != PM_OK)
			return ld->err->code;
		if (strcmp(type, "area") != 0)
			continue;
		if (sx_attr(k, "id") != NULL)
			return sx_fail(ld, k, PM_ERR_INVALID, "area emitter \"%s\" "
			    "is not referenced by any shape", sx_attr(k, "id"));
		return sx_fail(ld, k, PM_ERR_INVALID, "an area emitter must be "
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
	if (top_dir != NULL && (ld.top_dir = sx_arena_strdup(&ld.arena, top_dir))
	    == NULL) {
		e = sx_nomem(&ld);
		goto out;
	}
	for (i = 0; i < ndefs; i++) {
		if (defs[i].name == NULL || defs[i].value == NULL) {
			e = pm_fail(ld.err, PM_ERR_INVALID, "define %zu has no "
			    "name or value", i);
			goto out;
		}
		if ((e = sx_param_add(&ld, defs[i].name, defs[i].value)) != PM_OK)
			goto out;
	}
	/* A file can then spot that it includes itself. */
	if (is_file && (real = realpath(name, NULL)) != NULL) {
		ld.incl[0] = sx_arena_strdup(&ld.arena, real);
		free(real);
		if (ld.incl[0] == NULL) {
			e = sx_nomem(&ld);
			goto out;
		}
		ld.nincl = 1;
	}
	if ((e = sx_parse_doc(&ld, name, buf, len, NULL)) != PM_OK)
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
	sx_arena_free(&ld.arena);
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
	if ((e = pm_read_file(path, MAX_FILE_SIZE, &buf, &len, err)) != PM_OK)
		return e;
	if ((dir = sx_dir_of(&a, path)) == NULL) {
		free(buf);
		return pm_fail(err, PM_ERR_NOMEM, "out of memory");
	}
	e = load(path, true, buf, len, dir, defs, ndefs, s, err);
	free(buf);
	sx_arena_free(&a);
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
