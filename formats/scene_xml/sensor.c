/*
 * sensor.c: <sensor> with its <film>, <rfilter> and <sampler>, into the
 * scene's camera.
 */
#include <float.h>

#include "private.h"

static enum pm_err
load_rfilter(struct ld *ld, struct xnode *n, struct pm_camera *c)
{
	struct plist pl;
	const char *type;
	double r;
	enum pm_err e;

	if ((e = sx_object_type(ld, n, &type)) != PM_OK ||
	    (e = sx_collect(ld, n, "rfilter", type, &pl)) != PM_OK)
		return e;
	if (strcmp(type, "box") == 0) {
		c->rfilter = PM_RFILTER_BOX;
		c->filter_radius = 0.5f;
	} else if (strcmp(type, "tent") == 0) {
		c->rfilter = PM_RFILTER_TENT;
		if ((e = sx_get_float(ld, &pl, "radius", 1.0, 1e-3, 64.0, &r))
		    != PM_OK)
			return e;
		c->filter_radius = (float)r;
	} else if (strcmp(type, "gaussian") == 0) {
		c->rfilter = PM_RFILTER_GAUSSIAN;
		if ((e = sx_get_float(ld, &pl, "stddev", 0.5, 1e-3, 16.0, &r))
		    != PM_OK)
			return e;
		c->filter_radius = (float)r;
	} else {
		return sx_unknown_plugin(ld, n, type, "box, tent and gaussian");
	}
	if ((e = sx_finish(ld, &pl)) != PM_OK)
		return e;
	return sx_no_objects(ld, &pl);
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

	if ((e = sx_get_string(ld, pl, name, NULL, &s)) != PM_OK)
		return e;
	if (s != NULL && !one_of(s, list))
		return sx_fail(ld, sx_prop_find(pl, name)->n, PM_ERR_UNSUPPORTED,
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

	if ((e = sx_object_type(ld, n, &type)) != PM_OK ||
	    (e = sx_collect(ld, n, "film", type, &pl)) != PM_OK)
		return e;
	if (strcmp(type, "hdrfilm") != 0)
		return sx_unknown_plugin(ld, n, type, "hdrfilm");
	if ((e = sx_get_int(ld, &pl, "width", 768, 1, 1 << 16, &w)) != PM_OK ||
	    (e = sx_get_int(ld, &pl, "height", 576, 1, 1 << 16, &h)) != PM_OK ||
	    (e = check_choice(ld, &pl, "pixel_format", pix, "luminance, "
	    "luminance_alpha, rgb, rgba, xyz, xyza")) != PM_OK ||
	    (e = check_choice(ld, &pl, "component_format", comp, "float16, "
	    "float32, uint32")) != PM_OK ||
	    (e = check_choice(ld, &pl, "file_format", file, "openexr, exr, "
	    "rgbe, pfm")) != PM_OK ||
	    (e = sx_finish(ld, &pl)) != PM_OK)
		return e;
	c->width = (int)w;
	c->height = (int)h;
	c->rfilter = PM_RFILTER_GAUSSIAN;
	c->filter_radius = 0.5f;
	for (i = 0; i < pl.nobj; i++) {
		if (strcmp(pl.obj[i]->tag, "rfilter") != 0)
			return sx_fail(ld, pl.obj[i], PM_ERR_INVALID, "unexpected "
			    "<%s> inside %s", pl.obj[i]->tag, pl.what);
		if (seen)
			return sx_fail(ld, pl.obj[i], PM_ERR_INVALID, "%s has more "
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

	if ((e = sx_object_type(ld, n, &type)) != PM_OK ||
	    (e = sx_collect(ld, n, "sampler", type, &pl)) != PM_OK)
		return e;
	if (strcmp(type, "independent") != 0)
		return sx_unknown_plugin(ld, n, type, "independent");
	if ((e = sx_get_int(ld, &pl, "sample_count", 4, 1, 1L << 24, &spp))
	    != PM_OK || (e = sx_finish(ld, &pl)) != PM_OK ||
	    (e = sx_no_objects(ld, &pl)) != PM_OK)
		return e;
	c->spp = (int)spp;
	return PM_OK;
}

/* The medium the camera sits in, nested or by <ref> (any name, as in
 * Mitsuba); anything else is out of place in a sensor. */
static enum pm_err
sensor_medium(struct ld *ld, struct plist *pl, struct xnode *o)
{
	struct xnode *t = o;
	int m;
	enum pm_err e;

	if (strcmp(o->tag, "ref") == 0 && (e = sx_deref(ld, o, &t)) != PM_OK)
		return e;
	if (strcmp(t->tag, "medium") != 0)
		return sx_fail(ld, o, PM_ERR_INVALID, "unexpected <%s> inside %s",
		    t->tag, pl->what);
	if (ld->s->camera_medium > 0)
		return sx_fail(ld, o, PM_ERR_INVALID, "%s has more than one "
		    "medium", pl->what);
	if ((e = sx_medium_index(ld, t, &m)) != PM_OK)
		return e;
	ld->s->camera_medium = m + 1;
	return PM_OK;
}

/* perspective and thinlens (and the projector emitter): fov and
 * fov_axis, or focal_length, into c's fov and fov_axis. */
enum pm_err
sx_load_fov(struct ld *ld, struct plist *pl, const struct xnode *n,
    struct pm_camera *c)
{
	static const char *const axes[] = {"x", "y", "diagonal", "smaller",
	    "larger", NULL};
	const char *axis, *focal;
	double fov;
	int k;
	enum pm_err e;

	if (sx_has(pl, "fov") && sx_has(pl, "focal_length"))
		return sx_fail(ld, sx_prop_find(pl, "focal_length")->n,
		    PM_ERR_INVALID, "%s: give either fov or focal_length, "
		    "not both", pl->what);
	if (sx_has(pl, "fov_axis") && !sx_has(pl, "fov"))
		return sx_fail(ld, sx_prop_find(pl, "fov_axis")->n, PM_ERR_INVALID,
		    "%s: fov_axis applies only with fov", pl->what);
	if (sx_has(pl, "fov")) {
		if ((e = sx_get_float(ld, pl, "fov", 90.0, 1e-6, 180.0, &fov))
		    != PM_OK || (e = sx_get_string(ld, pl, "fov_axis", "x",
		    &axis)) != PM_OK)
			return e;
		if (fov >= 180.0)
			return sx_fail(ld, sx_prop_find(pl, "fov")->n,
			    PM_ERR_INVALID, "%s: fov must be below 180 "
			    "degrees", pl->what);
		for (k = 0; axes[k] != NULL; k++)
			if (strcasecmp(axis, axes[k]) == 0)
				break;
		if (axes[k] == NULL)
			return sx_fail(ld, sx_prop_find(pl, "fov_axis")->n,
			    PM_ERR_INVALID, "%s: fov_axis \"%s\" is not one "
			    "of x, y, diagonal, smaller, larger", pl->what,
			    axis);
		c->fov = (float)fov;
		c->fov_axis = (enum pm_fov_axis)k;
	} else {
		/* 35 mm film (36 x 24 mm): the focal length gives the
		 * diagonal field of view. */
		char buf[64];
		size_t len;
		double f;

		if ((e = sx_get_string(ld, pl, "focal_length", "50mm", &focal))
		    != PM_OK)
			return e;
		len = strlen(focal);
		if (len >= 2 && strcmp(focal + len - 2, "mm") == 0)
			len -= 2;
		snprintf(buf, sizeof(buf), "%.*s", (int)len, focal);
		if (len >= sizeof(buf) || !sx_number(buf, &f) || !(f > 0.0))
			return sx_fail(ld, sx_has(pl, "focal_length") ?
			    sx_prop_find(pl, "focal_length")->n : n,
			    PM_ERR_PARSE, "%s: focal_length \"%s\" is not of "
			    "the form <x>mm with x positive", pl->what, focal);
		c->fov = (float)(2.0 * atan(sqrt(36.0 * 36.0 + 24.0 * 24.0) /
		    (2.0 * f)) * 180.0 / PI_D);
		c->fov_axis = PM_FOV_DIAGONAL;
	}
	return PM_OK;
}

enum pm_err
sx_load_sensor(struct ld *ld, struct xnode *n)
{
	struct pm_camera *c = &ld->s->camera;
	struct plist pl;
	struct xnode *film = NULL, *sampler = NULL, *o;
	struct pm_mat4 inv;
	const char *type;
	double near, far, focus, aperture;
	float scale;
	size_t i;
	enum pm_err e;

	if (ld->sensor != NULL)
		return sx_fail(ld, n, PM_ERR_UNSUPPORTED, "more than one <sensor> "
		    "(the first is at %s:%d): pm takes one camera per scene",
		    ld->sensor->file, ld->sensor->line);
	ld->sensor = n;
	if ((e = sx_object_type(ld, n, &type)) != PM_OK ||
	    (e = sx_collect(ld, n, "sensor", type, &pl)) != PM_OK)
		return e;
	if (strcmp(type, "perspective") == 0)
		c->type = PM_SENSOR_PERSPECTIVE;
	else if (strcmp(type, "orthographic") == 0)
		c->type = PM_SENSOR_ORTHOGRAPHIC;
	else if (strcmp(type, "thinlens") == 0)
		c->type = PM_SENSOR_THINLENS;
	else
		return sx_unknown_plugin(ld, n, type, "perspective, "
		    "orthographic and thinlens");
	if (c->type == PM_SENSOR_THINLENS && !sx_has(&pl, "aperture_radius"))
		return sx_missing(ld, &pl, "aperture_radius", "a <float>");
	if (c->type == PM_SENSOR_THINLENS) {
		if ((e = sx_get_float(ld, &pl, "aperture_radius", 0.0, 0.0,
		    3.4e38, &aperture)) != PM_OK)
			return e;
		/* Mitsuba warns and takes its float epsilon for 0. */
		c->aperture_radius = aperture > 0.0 ? (float)aperture :
		    FLT_EPSILON;
	}
	if ((e = sx_get_float(ld, &pl, "near_clip", 0.01, 1e-30, 3.4e38, &near))
	    != PM_OK ||
	    (e = sx_get_float(ld, &pl, "far_clip", 10000.0, 1e-30, 3.4e38, &far))
	    != PM_OK ||
	    (e = sx_get_float(ld, &pl, "focus_distance", far, 0.0, 3.4e38,
	    &focus)) != PM_OK ||
	    (e = sx_get_transform(ld, &pl, "to_world", &c->to_world)) != PM_OK)
		return e;
	if (!(near < far))
		return sx_fail(ld, n, PM_ERR_INVALID, "%s: near_clip %g must be "
		    "smaller than far_clip %g", pl.what, near, far);
	c->near_clip = (float)near;
	c->far_clip = (float)far;
	c->focus_distance = (float)focus;
	if (c->type == PM_SENSOR_THINLENS && !(focus > 0.0))
		return sx_fail(ld, sx_prop_find(&pl, "focus_distance")->n,
		    PM_ERR_INVALID, "%s: focus_distance must be positive",
		    pl.what);
	if (c->type != PM_SENSOR_ORTHOGRAPHIC &&
	    (e = sx_load_fov(ld, &pl, n, c)) != PM_OK)
		return e;
	if ((e = sx_finish(ld, &pl)) != PM_OK)
		return e;
	/* An orthographic to_world sizes the film, so it may scale. */
	if (c->type == PM_SENSOR_ORTHOGRAPHIC) {
		if (!pm_mat4_inverse(c->to_world, &inv))
			return sx_fail(ld, n, PM_ERR_INVALID, "%s: to_world is "
			    "singular", pl.what);
	} else if (!sx_similarity_scale(&c->to_world, &scale) ||
	    fabsf(scale - 1.0f) > 1e-3f)
		return sx_fail(ld, n, PM_ERR_INVALID, "%s: to_world must not "
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
				return sx_fail(ld, o, PM_ERR_INVALID, "%s has more "
				    "than one <film>", pl.what);
			film = o;
			if ((e = load_film(ld, o, c)) != PM_OK)
				return e;
		} else if (strcmp(o->tag, "sampler") == 0) {
			if (sampler != NULL)
				return sx_fail(ld, o, PM_ERR_INVALID, "%s has more "
				    "than one <sampler>", pl.what);
			sampler = o;
			if ((e = load_sampler(ld, o, c)) != PM_OK)
				return e;
		} else if ((e = sensor_medium(ld, &pl, o)) != PM_OK) {
			return e;
		}
	}
	ld->s->has_camera = true;
	return PM_OK;
}
