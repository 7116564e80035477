/*
 * render.h: the camera pass: pixels handed to threads in tiles, each pixel
 * sample a pure function of (seed, pixel, sample index), so the image is
 * bit-identical whatever the number of threads.
 */
#ifndef PM_RENDER_H
#define PM_RENDER_H

#include <stdatomic.h>
#include <stdint.h>

#include "accel.h"
#include "camera.h"
#include "error.h"
#include "image.h"
#include "light.h"
#include "rng.h"
#include "scene.h"

/* What an integrator needs to look at; read-only while rendering. */
struct pm_render_ctx {
	const struct pm_scene *scene;
	const struct pm_accel *accel;
	const struct pm_lights *lights;
	int max_depth;			/* -1: unlimited */
	int rr_depth;
	bool hide_emitters;
};

enum pm_method {
	PM_METHOD_PATH,
};

struct pm_render_opts {
	enum pm_method method;
	int spp;
	uint64_t seed;
	int threads;			/* >= 1 */
	/* Optional progress: tiles done so far, updated as tiles finish. */
	_Atomic long *tiles_done;
	long *tiles_total;
};

struct pm_render_stats {
	uint64_t samples;		/* camera samples taken */
	uint64_t dropped;		/* samples that were NaN or infinite */
};

/* Radiance along a camera ray by path tracing with next-event estimation
 * and multiple importance sampling (integrator_path.c). */
struct pm_rgb pm_path_li(const struct pm_render_ctx *ctx, struct pm_vec3 o,
    struct pm_vec3 d, float tmin, float tmax, struct pm_rng *rng);

/*
 * Renders the scene's camera into out (allocated here, cam->width by
 * cam->height): the mean of spp samples per pixel, drawn through the film's
 * reconstruction filter by importance sampling.
 */
enum pm_err pm_render(const struct pm_render_ctx *ctx, const struct pm_camera *cam,
    const struct pm_render_opts *opts, struct pm_image *out,
    struct pm_render_stats *stats, struct pm_error *err);

#endif
