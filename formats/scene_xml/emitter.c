/*
 * emitter.c: <emitter> elements: area emitters carried by shapes (their
 * radiance may be a texture), and the point, spot (with its texture),
 * projector, directional, constant and envmap lights.
 */
#include "private.h"
#include "../../common/camera.h"
#include "../rgbe.h"
#include "../texture.h"

/* True if parameter name is given as a texture, nested or by <ref>. */
static bool
has_texture(const struct plist *pl, const char *name)
{
	const char *nm;
	size_t i;

	for (i = 0; i < pl->ntex; i++)
		if ((nm = sx_attr(pl->tex[i], "name")) != NULL &&
		    strcmp(nm, name) == 0)
			return true;
	for (i = 0; i < pl->nobj; i++)
		if (strcmp(pl->obj[i]->tag, "ref") == 0 &&
		    (nm = sx_attr(pl->obj[i], "name")) != NULL &&
		    strcmp(nm, name) == 0)
			return true;
	return false;
}

/* The environment: at most one constant or envmap, as in Mitsuba. */
static enum pm_err
claim_environment(struct ld *ld, const struct xnode *n, int i)
{
	if (ld->s->env_light >= 0)
		return sx_fail(ld, n, PM_ERR_UNSUPPORTED, "more than one "
		    "environment emitter (constant or envmap)");
	ld->s->env_light = i;
	return PM_OK;
}

/* envmap: a latitude-longitude image, OpenEXR, Radiance HDR, PNG or JPEG
 * (see common/envmap.h). */
static enum pm_err
load_envmap(struct ld *ld, struct xnode *n, struct plist *pl,
    struct pm_light *l)
{
	const char *fname, *path, *dot;
	struct pm_image im = {0, 0, NULL};
	struct pm_mat4 M;
	double scale;
	bool mis;
	float sc;
	enum pm_err e;

	if (!sx_has(pl, "filename"))
		return sx_missing(ld, pl, "filename", "a <string>, the image");
	if ((e = sx_get_string(ld, pl, "filename", NULL, &fname)) != PM_OK ||
	    (e = sx_get_float(ld, pl, "scale", 1.0, 0.0, 3.4e38, &scale))
	    != PM_OK ||
	    (e = sx_get_transform(ld, pl, "to_world", &M)) != PM_OK ||
	    /* it changes how Mitsuba samples, never what it converges to */
	    (e = sx_get_bool(ld, pl, "mis_compensation", false, &mis)) != PM_OK)
		return e;
	if (!sx_similarity_scale(&M, &sc))
		return sx_fail(ld, sx_prop_find(pl, "to_world")->n,
		    PM_ERR_UNSUPPORTED, "%s: to_world must be a rotation "
		    "(uniform scale and translation are ignored)", pl->what);
	M.m[0][3] = M.m[1][3] = M.m[2][3] = 0.0f;
	if ((e = sx_resolve(ld, sx_prop_find(pl, "filename")->n, n->dir, fname,
	    &path)) != PM_OK)
		return e;
	/* Radiance HDR by its name; OpenEXR, PNG and JPEG by their first
	 * bytes, through the bitmap reader (8-bit images decoded from
	 * sRGB, as Mitsuba decodes them) */
	dot = strrchr(fname, '.');
	if (dot != NULL && (strcasecmp(dot, ".hdr") == 0 ||
	    strcasecmp(dot, ".rgbe") == 0 || strcasecmp(dot, ".pic") == 0)) {
		e = pm_rgbe_read(path, &im, ld->err);
	} else {
		struct pm_texture t;

		pm_texture_init(&t, PM_TEXTURE_BITMAP);
		e = pm_bitmap_read(path, false, &t, ld->err);
		if (e == PM_OK) {
			/* the texels move to the image */
			im.width = t.width;
			im.height = t.height;
			im.rgb = t.rgb;
			t.rgb = NULL;
		}
		pm_texture_free(&t);
	}
	if (e != PM_OK)
		return sx_wrap(ld, sx_prop_find(pl, "filename")->n, pl->what, e);
	if ((l->env = calloc(1, sizeof(*l->env))) == NULL) {
		pm_image_free(&im);
		return sx_nomem(ld);
	}
	e = pm_envmap_init(l->env, im.rgb, im.width, im.height, (float)scale,
	    &M, ld->err);
	pm_image_free(&im);
	if (e != PM_OK) {
		free(l->env);
		l->env = NULL;
		return sx_wrap(ld, sx_prop_find(pl, "filename")->n, fname, e);
	}
	return claim_environment(ld, n, (int)(l - ld->s->lights));
}

/* directional: irradiance along direction, or to_world's +z. */
static enum pm_err
load_directional(struct ld *ld, struct xnode *n, struct plist *pl,
    struct pm_light *l)
{
	struct prop *dp = sx_prop_find(pl, "direction");
	struct pm_mat4 M;
	struct pm_vec3 d;
	enum pm_err e;

	if (dp != NULL && sx_has(pl, "to_world"))
		return sx_fail(ld, dp->n, PM_ERR_INVALID, "%s: give either "
		    "direction or to_world, not both", pl->what);
	if ((e = sx_get_color(ld, pl, "irradiance", 1.0f, &l->intensity))
	    != PM_OK ||
	    (e = sx_get_transform(ld, pl, "to_world", &M)) != PM_OK)
		return e;
	if (dp != NULL) {
		dp->used = true;
		if (dp->type != P_VECTOR)
			return sx_wrong_type(ld, pl, dp, "a <vector>");
		d = dp->v;
	} else {
		d = pm_xform_vector(&M, pm_v3(0, 0, 1));
	}
	if (!(pm_dot(d, d) > 0.0f))
		return sx_fail(ld, dp != NULL ? dp->n : n, PM_ERR_INVALID,
		    "%s: the direction is zero", pl->what);
	l->direction = pm_normalize(d);
	return PM_OK;
}

/*
 * projector: Mitsuba's pinhole casting its irradiance texture (or a
 * colour, made a constant texture here) through the image plane at
 * z = 1 of a perspective camera whose film is the texture's resolution.
 */
static enum pm_err
load_projector(struct ld *ld, struct xnode *n, struct plist *pl,
    struct pm_light *l)
{
	struct pm_camera cam;
	struct pm_mat4 M;
	struct pm_rgb c;
	double scale;
	float sc, tan_x, tan_y;
	int w = 1, h = 1, idx = (int)(l - ld->s->lights), tex;
	enum pm_err e;

	if ((e = sx_get_color_tex(ld, pl, "irradiance", 1.0f, &c, &tex))
	    != PM_OK ||
	    (e = sx_get_float(ld, pl, "scale", 1.0, 0.0, 3.4e38, &scale))
	    != PM_OK ||
	    (e = sx_get_transform(ld, pl, "to_world", &M)) != PM_OK)
		return e;
	if (tex == 0) {
		struct pm_texture t;
		int i;

		pm_texture_init(&t, PM_TEXTURE_CONSTANT);
		t.color0 = c;
		snprintf(t.name, sizeof(t.name), "projector#%d", idx);
		if ((i = pm_scene_add_texture(ld->s, &t)) < 0)
			return sx_nomem(ld);
		tex = i + 1;
	} else if (ld->s->textures[tex - 1].type == PM_TEXTURE_BITMAP) {
		/* the film's size; any other texture has 1 x 1, as in
		 * Mitsuba */
		w = ld->s->textures[tex - 1].width;
		h = ld->s->textures[tex - 1].height;
	}
	l->tex = tex;
	memset(&cam, 0, sizeof(cam));
	if ((e = sx_load_fov(ld, pl, n, &cam)) != PM_OK)
		return e;
	if (!sx_similarity_scale(&M, &sc) ||
	    !pm_mat4_inverse(M, &l->to_local))
		return sx_fail(ld, sx_has(pl, "to_world") ?
		    sx_prop_find(pl, "to_world")->n : n, PM_ERR_UNSUPPORTED,
		    "%s: to_world must be a rotation, uniform scale and "
		    "translation", pl->what);
	pm_camera_tangents(cam.fov, cam.fov_axis, w, h, &tan_x, &tan_y);
	l->tan_fov = tan_x;
	l->aspect = (float)w / (float)h;
	/* Mitsuba measures the distance to the image plane in the
	 * projector's own units: a scale of sc brightens by sc^2 */
	l->intensity = pm_rgb1((float)scale * sc * sc);
	l->position = pm_xform_point(&M, pm_v3(0, 0, 0));
	l->frame.s = pm_normalize(pm_xform_vector(&M, pm_v3(1, 0, 0)));
	l->frame.t = pm_normalize(pm_xform_vector(&M, pm_v3(0, 1, 0)));
	l->frame.n = pm_normalize(pm_xform_vector(&M, pm_v3(0, 0, 1)));
	return PM_OK;
}

enum pm_err
sx_build_area(struct ld *ld, struct xnode *n, struct pm_rgb *radiance,
    int *tex)
{
	struct plist pl;
	const char *type;
	enum pm_err e;

	if ((e = sx_object_type(ld, n, &type)) != PM_OK)
		return e;
	if (strcmp(type, "area") != 0)
		return sx_fail(ld, n, PM_ERR_INVALID, "a shape can carry only an "
		    "\"area\" emitter, not \"%s\"", type);
	if ((e = sx_collect(ld, n, "emitter", type, &pl)) != PM_OK)
		return e;
	if (!sx_has(&pl, "radiance") && !has_texture(&pl, "radiance"))
		return sx_missing(ld, &pl, "radiance", "an <rgb> or a "
		    "<texture>");
	if ((e = sx_get_color_tex(ld, &pl, "radiance", 0.0f, radiance, tex))
	    != PM_OK ||
	    (e = sx_finish(ld, &pl)) != PM_OK)
		return e;
	return sx_no_objects(ld, &pl);
}

enum pm_err
sx_load_emitter(struct ld *ld, struct xnode *n)
{
	struct plist pl;
	struct pm_light *l;
	struct pm_mat4 M;
	struct pm_vec3 pos;
	const char *type;
	double cutoff, beam;
	int i, tex;
	enum pm_err e;

	if ((e = sx_object_type(ld, n, &type)) != PM_OK)
		return e;
	if (strcmp(type, "area") == 0)
		return PM_OK;	/* built by the shape that carries it */
	if ((e = sx_collect(ld, n, "emitter", type, &pl)) != PM_OK)
		return e;
	if (strcmp(type, "point") != 0 && strcmp(type, "spot") != 0 &&
	    strcmp(type, "constant") != 0 && strcmp(type, "envmap") != 0 &&
	    strcmp(type, "directional") != 0 &&
	    strcmp(type, "projector") != 0)
		return sx_unknown_plugin(ld, n, type, "area, point, spot, "
		    "projector, directional, constant and envmap");
	if ((i = pm_scene_add_light(ld->s)) < 0)
		return sx_nomem(ld);
	l = &ld->s->lights[i];
	if (strcmp(type, "point") == 0) {
		l->type = PM_LIGHT_POINT;
		if (sx_has(&pl, "position") && sx_has(&pl, "to_world"))
			return sx_fail(ld, sx_prop_find(&pl, "position")->n,
			    PM_ERR_INVALID, "%s: give either position or "
			    "to_world, not both", pl.what);
		if ((e = sx_get_color(ld, &pl, "intensity", 1.0f, &l->intensity))
		    != PM_OK ||
		    (e = sx_get_transform(ld, &pl, "to_world", &M)) != PM_OK ||
		    (e = sx_get_point(ld, &pl, "position",
		    pm_xform_point(&M, pm_v3(0, 0, 0)), &pos)) != PM_OK)
			return e;
		l->position = pos;
	} else if (strcmp(type, "spot") == 0) {
		l->type = PM_LIGHT_SPOT;
		if ((e = sx_get_color(ld, &pl, "intensity", 1.0f, &l->intensity))
		    != PM_OK ||
		    (e = sx_get_float(ld, &pl, "cutoff_angle", 20.0, 1e-3, 180.0,
		    &cutoff)) != PM_OK ||
		    (e = sx_get_float(ld, &pl, "beam_width", cutoff * 0.75, 0.0,
		    cutoff, &beam)) != PM_OK ||
		    (e = sx_get_transform(ld, &pl, "to_world", &M)) != PM_OK ||
		    (e = sx_get_texture(ld, &pl, "texture", &tex)) != PM_OK)
			return e;
		/* texture: Mitsuba's uv maps the cutoff cone onto the unit
		 * square, measured in to_world's own frame */
		l->tex = tex;
		l->tan_fov = tanf((float)cutoff * (PM_PI / 180.0f));
		if (tex > 0 && !pm_mat4_inverse(M, &l->to_local))
			return sx_fail(ld, n, PM_ERR_INVALID, "%s: to_world is "
			    "singular", pl.what);
		l->cutoff_angle = (float)cutoff;
		l->beam_width = (float)beam;
		l->position = pm_xform_point(&M, pm_v3(0, 0, 0));
		pos = pm_xform_vector(&M, pm_v3(0, 0, 1));
		if (pm_dot(pos, pos) == 0.0f)
			return sx_fail(ld, n, PM_ERR_INVALID, "%s: to_world maps "
			    "the axis to zero", pl.what);
		l->frame = pm_frame_from_normal(pm_normalize(pos));
	} else if (strcmp(type, "projector") == 0) {
		l->type = PM_LIGHT_PROJECTOR;
		if ((e = load_projector(ld, n, &pl, l)) != PM_OK)
			return e;
	} else if (strcmp(type, "directional") == 0) {
		l->type = PM_LIGHT_DIRECTIONAL;
		if ((e = load_directional(ld, n, &pl, l)) != PM_OK)
			return e;
	} else if (strcmp(type, "envmap") == 0) {
		l->type = PM_LIGHT_ENVMAP;
		if ((e = load_envmap(ld, n, &pl, l)) != PM_OK)
			return e;
	} else {
		l->type = PM_LIGHT_CONSTANT;
		if ((e = sx_get_color(ld, &pl, "radiance", 1.0f, &l->radiance))
		    != PM_OK ||
		    (e = claim_environment(ld, n, i)) != PM_OK)
			return e;
	}
	if ((e = sx_finish(ld, &pl)) != PM_OK)
		return e;
	return sx_no_objects(ld, &pl);
}
