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
	enum pm_err e;

	memset(w, 0, sizeof(*w));
	w->scene = s;
	if ((e = pm_accel_build(s, &w->accel, err)) != PM_OK)
		return e;
	if ((e = pm_lights_init(&w->lights, s, err)) != PM_OK) {
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
