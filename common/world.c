/*
 * world.c: the scene, its ray caster and its lights, set up and torn
 * down together (see world.h).
 */
#include <string.h>

#include "world.h"

enum pm_err
pm_world_init(struct pm_world *w, const struct pm_scene *s,
    struct pm_error *err)
{
	struct pm_vec3 lo, hi;
	enum pm_err e;

	memset(w, 0, sizeof(*w));
	w->scene = s;
	if ((e = pm_accel_build(s, &w->accel, err)) != PM_OK)
		return e;
	/* Embree's bounds of a scene without geometry are empty (lo > hi):
	 * a point, then. */
	pm_accel_bounds(w->accel, &lo, &hi);
	if (!(pm_max_comp(pm_sub(hi, lo)) >= 0.0f)) {
		lo = pm_v3(0, 0, 0);
		hi = lo;
	}
	w->center = pm_scale(pm_add(lo, hi), 0.5f);
	w->radius = 0.5f * pm_length(pm_sub(hi, lo));
	if ((e = pm_lights_init(&w->lights, s, w->center, w->radius, err)) !=
	    PM_OK) {
		pm_accel_free(w->accel);
		w->accel = NULL;
		return e;
	}
	return PM_OK;
}

void
pm_world_free(struct pm_world *w)
{
	pm_lights_free(&w->lights);
	pm_accel_free(w->accel);
	w->accel = NULL;
}
