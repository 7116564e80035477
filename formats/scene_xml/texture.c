/*
 * texture.c: <texture> elements (checkerboard, bitmap, rawconstant,
 * mesh_attribute), nested in a plugin under a parameter's name or defined
 * at the top level and named by <ref name="..." id="..."/>, into the
 * scene's texture table; each is built once however often it is used.
 */
#include "private.h"

/* Mitsuba's to_uv: a 3x3 transform of (u, v, 1); a 4x4 one loses its z
 * row and column. */
static void
to_uv_of(const struct pm_mat4 *M, float a[6])
{
	a[0] = M->m[0][0];
	a[1] = M->m[0][1];
	a[2] = M->m[0][3];
	a[3] = M->m[1][0];
	a[4] = M->m[1][1];
	a[5] = M->m[1][3];
}

/* One of a closed set of words; *out is its index. */
static enum pm_err
get_choice(struct ld *ld, struct plist *pl, const char *name,
    const char *const *words, int *out)
{
	const char *s;
	enum pm_err e;
	int i;

	*out = 0;
	if ((e = sx_get_string(ld, pl, name, words[0], &s)) != PM_OK)
		return e;
	for (i = 0; words[i] != NULL; i++)
		if (strcmp(s, words[i]) == 0) {
			*out = i;
			return PM_OK;
		}
	return sx_fail(ld, sx_prop_find(pl, name)->n, PM_ERR_INVALID, "%s: "
	    "%s \"%s\" is not one of Mitsuba's (\"%s\", ...)", pl->what, name,
	    s, words[0]);
}

/* A checkerboard's colour: a colour, or a texture of the scene's table,
 * whose copy *sub then owns. */
static enum pm_err
checker_color(struct ld *ld, struct plist *pl, const char *name, float def,
    struct pm_rgb *out, struct pm_texture **sub)
{
	enum pm_err e;
	int tex;

	if ((e = sx_get_color_tex(ld, pl, name, def, out, &tex)) != PM_OK ||
	    tex == 0)
		return e;
	if ((*sub = calloc(1, sizeof(**sub))) == NULL)
		return sx_nomem(ld);
	if (!pm_texture_copy(*sub, &ld->s->textures[tex - 1])) {
		free(*sub);
		*sub = NULL;
		return sx_nomem(ld);
	}
	return PM_OK;
}

static enum pm_err
build_texture(struct ld *ld, struct xnode *n, struct pm_texture *t)
{
	static const char *const filters[] = {"bilinear", "nearest", NULL};
	static const char *const wraps[] = {"repeat", "mirror", "clamp", NULL};
	static const char *const formats[] = {"auto", "variant", "fp16", NULL};
	struct plist pl;
	struct pm_mat4 M;
	const char *type, *fname, *path;
	bool raw, accel;
	int filter, wrap, format;
	enum pm_err e;

	if ((e = sx_object_type(ld, n, &type)) != PM_OK ||
	    (e = sx_collect(ld, n, "texture", type, &pl)) != PM_OK)
		return e;
	if (strcmp(type, "checkerboard") == 0) {
		pm_texture_init(t, PM_TEXTURE_CHECKERBOARD);
		if ((e = checker_color(ld, &pl, "color0", 0.4f, &t->color0,
		    &t->sub[0])) != PM_OK ||
		    (e = checker_color(ld, &pl, "color1", 0.2f, &t->color1,
		    &t->sub[1])) != PM_OK)
			return e;
	} else if (strcmp(type, "mesh_attribute") == 0) {
		/* the colours a PLY file gives its vertices or faces */
		static const char *const attrs[] = {"vertex_color",
		    "face_color", NULL};
		int which;
		double scale;

		pm_texture_init(t, PM_TEXTURE_MESH_ATTRIBUTE);
		if (!sx_has(&pl, "name"))
			return sx_missing(ld, &pl, "name", "a <string>, "
			    "vertex_color or face_color");
		if ((e = get_choice(ld, &pl, "name", attrs, &which)) != PM_OK ||
		    (e = sx_get_float(ld, &pl, "scale", 1.0, 0.0, 3.4e38,
		    &scale)) != PM_OK)
			return e;
		t->attr = which == 0 ? PM_ATTR_VERTEX_COLOR : PM_ATTR_FACE_COLOR;
		t->scale = (float)scale;
		t->color0 = pm_rgb1(0.5f * t->scale);
	} else if (strcmp(type, "rawconstant") == 0) {
		/* a float or a <vector> (Mitsuba's), or an <rgb>, taken as
		 * it is */
		struct prop *vp = sx_prop_find(&pl, "value");

		pm_texture_init(t, PM_TEXTURE_CONSTANT);
		if (vp == NULL)
			return sx_missing(ld, &pl, "value", "a <float> or "
			    "<vector>");
		if (vp->type == P_VECTOR) {
			vp->used = true;
			t->color0 = pm_rgb(vp->v.x, vp->v.y, vp->v.z);
			if (!(t->color0.r >= 0.0f && t->color0.g >= 0.0f &&
			    t->color0.b >= 0.0f))
				return sx_fail(ld, vp->n, PM_ERR_INVALID, "%s: "
				    "value must not be negative", pl.what);
		} else if ((e = sx_get_color(ld, &pl, "value", 0.0f,
		    &t->color0)) != PM_OK) {
			return e;
		}
	} else if (strcmp(type, "bitmap") == 0) {
		pm_texture_init(t, PM_TEXTURE_BITMAP);
		if (!sx_has(&pl, "filename"))
			return sx_missing(ld, &pl, "filename", "a <string>");
		if ((e = sx_get_string(ld, &pl, "filename", NULL, &fname))
		    != PM_OK ||
		    (e = get_choice(ld, &pl, "filter_type", filters, &filter))
		    != PM_OK ||
		    (e = get_choice(ld, &pl, "wrap_mode", wraps, &wrap)) != PM_OK ||
		    (e = sx_get_bool(ld, &pl, "raw", false, &raw)) != PM_OK ||
		    /* storage and GPU choices: no effect on the image */
		    (e = get_choice(ld, &pl, "format", formats, &format))
		    != PM_OK ||
		    (e = sx_get_bool(ld, &pl, "accel", true, &accel)) != PM_OK)
			return e;
		t->nearest = filter == 1;
		t->wrap = wrap == 1 ? PM_WRAP_MIRROR : wrap == 2 ? PM_WRAP_CLAMP :
		    PM_WRAP_REPEAT;
	} else {
		return sx_unknown_plugin(ld, n, type, "checkerboard, bitmap, "
		    "rawconstant and mesh_attribute");
	}
	/* to_uv: the checkerboard's and the bitmap's only, as in Mitsuba
	 * (elsewhere sx_finish reports it unused) */
	M = pm_mat4_identity();
	if ((t->type == PM_TEXTURE_CHECKERBOARD ||
	    t->type == PM_TEXTURE_BITMAP) &&
	    (e = sx_get_transform(ld, &pl, "to_uv", &M)) != PM_OK)
		return e;
	if ((e = sx_finish(ld, &pl)) != PM_OK ||
	    (e = sx_no_objects(ld, &pl)) != PM_OK)
		return e;
	to_uv_of(&M, t->to_uv);
	if (t->type == PM_TEXTURE_BITMAP) {
		if ((e = sx_resolve(ld, n, n->dir, fname, &path)) != PM_OK)
			return e;
		if ((e = pm_bitmap_read(path, raw, t, ld->err)) != PM_OK)
			return sx_wrap(ld, n, pl.what, e);
	}
	return PM_OK;
}

/* The scene index of the texture element n, built once however often
 * used. */
enum pm_err
sx_texture_index(struct ld *ld, struct xnode *n, int *out)
{
	struct pm_texture t;
	const char *id;
	enum pm_err e;
	int i;

	if (n->inst >= 0) {
		*out = n->inst;
		return PM_OK;
	}
	memset(&t, 0, sizeof(t));
	if ((e = build_texture(ld, n, &t)) != PM_OK) {
		pm_texture_free(&t);
		return e;
	}
	id = sx_attr(n, "id");
	if (id != NULL)
		snprintf(t.name, sizeof(t.name), "%s", id);
	else
		snprintf(t.name, sizeof(t.name), "%s#%zu", sx_attr(n, "type"),
		    ld->s->ntextures);
	if ((i = pm_scene_add_texture(ld->s, &t)) < 0) {
		pm_texture_free(&t);
		return sx_nomem(ld);
	}
	n->inst = i;
	*out = i;
	return PM_OK;
}

/*
 * The texture given for parameter name, nested or by reference: *tex is
 * 1 + its scene index, or 0 when the parameter is not a texture.  What is
 * taken leaves pl, so that sx_finish and sx_no_objects see the rest.
 */
enum pm_err
sx_get_texture(struct ld *ld, struct plist *pl, const char *name, int *tex)
{
	struct xnode *node = NULL, *t;
	const char *nm;
	size_t i;
	enum pm_err e;
	int idx;

	*tex = 0;
	for (i = 0; i < pl->ntex; i++)
		if ((nm = sx_attr(pl->tex[i], "name")) != NULL &&
		    strcmp(nm, name) == 0) {
			node = pl->tex[i];
			memmove(&pl->tex[i], &pl->tex[i + 1],
			    (pl->ntex - i - 1) * sizeof(pl->tex[0]));
			pl->ntex--;
			break;
		}
	for (i = 0; node == NULL && i < pl->nobj; i++) {
		if (strcmp(pl->obj[i]->tag, "ref") != 0 ||
		    (nm = sx_attr(pl->obj[i], "name")) == NULL ||
		    strcmp(nm, name) != 0)
			continue;
		if ((e = sx_deref(ld, pl->obj[i], &t)) != PM_OK)
			return e;
		if (strcmp(t->tag, "texture") != 0)
			return sx_fail(ld, pl->obj[i], PM_ERR_INVALID, "%s: <ref "
			    "name=\"%s\"> names a <%s>, expected a <texture>",
			    pl->what, name, t->tag);
		node = t;
		memmove(&pl->obj[i], &pl->obj[i + 1],
		    (pl->nobj - i - 1) * sizeof(pl->obj[0]));
		pl->nobj--;
	}
	if (node == NULL)
		return PM_OK;
	if (sx_has(pl, name))
		return sx_fail(ld, node, PM_ERR_INVALID, "%s: parameter \"%s\" "
		    "given twice (also at line %d)", pl->what, name,
		    sx_prop_find(pl, name)->n->line);
	if ((e = sx_texture_index(ld, node, &idx)) != PM_OK)
		return e;
	*tex = idx + 1;
	return PM_OK;
}

/* A colour that may be a texture: *tex as sx_get_texture sets it, and
 * *out the texture's mean then (what plastic steers its sampling by). */
enum pm_err
sx_get_color_tex(struct ld *ld, struct plist *pl, const char *name,
    float def, struct pm_rgb *out, int *tex)
{
	enum pm_err e;

	if ((e = sx_get_texture(ld, pl, name, tex)) != PM_OK)
		return e;
	if (*tex == 0)
		return sx_get_color(ld, pl, name, def, out);
	*out = pm_texture_mean(&ld->s->textures[*tex - 1]);
	return PM_OK;
}
