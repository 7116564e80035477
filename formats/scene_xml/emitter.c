/*
 * emitter.c: <emitter> elements: area emitters carried by shapes, and
 * the point, spot and constant lights.
 */
#include "private.h"

enum pm_err
sx_build_area(struct ld *ld, struct xnode *n, struct pm_rgb *radiance)
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
	if (!sx_has(&pl, "radiance"))
		return sx_missing(ld, &pl, "radiance", "an <rgb>");
	if ((e = sx_get_color(ld, &pl, "radiance", 0.0f, radiance)) != PM_OK ||
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
	int i;
	enum pm_err e;

	if ((e = sx_object_type(ld, n, &type)) != PM_OK)
		return e;
	if (strcmp(type, "area") == 0)
		return PM_OK;	/* built by the shape that carries it */
	if ((e = sx_collect(ld, n, "emitter", type, &pl)) != PM_OK)
		return e;
	if (strcmp(type, "point") != 0 && strcmp(type, "spot") != 0 &&
	    strcmp(type, "constant") != 0)
		return sx_unknown_plugin(ld, n, type, "area, point, spot and "
		    "constant");
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
		    (e = sx_get_transform(ld, &pl, "to_world", &M)) != PM_OK)
			return e;
		l->cutoff_angle = (float)cutoff;
		l->beam_width = (float)beam;
		l->position = pm_xform_point(&M, pm_v3(0, 0, 0));
		pos = pm_xform_vector(&M, pm_v3(0, 0, 1));
		if (pm_dot(pos, pos) == 0.0f)
			return sx_fail(ld, n, PM_ERR_INVALID, "%s: to_world maps "
			    "the axis to zero", pl.what);
		l->frame = pm_frame_from_normal(pm_normalize(pos));
	} else {
		if (ld->s->env_light >= 0)
			return sx_fail(ld, n, PM_ERR_UNSUPPORTED, "more than one "
			    "constant emitter");
		l->type = PM_LIGHT_CONSTANT;
		if ((e = sx_get_color(ld, &pl, "radiance", 1.0f, &l->radiance))
		    != PM_OK)
			return e;
		ld->s->env_light = i;
	}
	if ((e = sx_finish(ld, &pl)) != PM_OK)
		return e;
	return sx_no_objects(ld, &pl);
}
