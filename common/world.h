/*
 * world.h: a scene made ready to trace: its ray caster and its lights,
 * set up in one place for every tool and test that shoots photons or
 * renders.
 */
#ifndef PM_WORLD_H
#define PM_WORLD_H

#include "accel.h"
#include "error.h"
#include "light.h"
#include "scene.h"

struct pm_world {
	const struct pm_scene *scene;	/* the caller's; outlives the world */
	struct pm_accel *accel;
	struct pm_lights lights;
};

/*
 * Builds the ray caster and the light tables over s (prepared, as a
 * loader leaves it).  On failure nothing is left to free; otherwise the
 * caller frees the world with pm_world_free, before the scene.
 */
enum pm_err pm_world_init(struct pm_world *w, const struct pm_scene *s,
    struct pm_error *err);
void pm_world_free(struct pm_world *w);

#endif
