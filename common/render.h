/*
 * render.h: the camera pass: pixels handed to threads in tiles, each pixel
 * sample a pure function of (seed, pixel, sample index), so the image is
 * bit-identical whatever the number of threads.
 */
#ifndef PM_RENDER_H
#define PM_RENDER_H

#include <stdatomic.h>
#include <stdint.h>

#include "camera.h"
#include "error.h"
#include "image.h"
#include "integrator.h"

/* The side of a tile in pixels: the unit of work a thread takes, of the
 * progress counts and of what a watch sees finished (8x8: at 16x16 the
 * 64 tiles of a 128x128 render left a thread idle at the end). */
#define PM_RENDER_TILE	8

enum pm_method {
	PM_METHOD_PATH,
	PM_METHOD_PHOTON,
	PM_METHOD_PTRACER,	/* Mitsuba's particle tracer */
};

struct pm_render_opts {
	enum pm_method method;
	int spp;
	uint64_t seed;
	int threads;			/* >= 1 */
	/* Optional progress: tiles done so far, updated as tiles finish,
	 * and their total, set when the render starts; both may be read by
	 * another thread while the render runs. */
	_Atomic long *tiles_done;
	_Atomic long *tiles_total;
	/* Optional: lets another thread copy the finished tiles while the
	 * render runs (pm_render_snapshot). */
	struct pm_render_watch *watch;
	/* Optional (Mitsuba's moment integrator): when both are set, each
	 * gets (allocated here, owned by the caller) per pixel the mean of
	 * the samples' CIE XYZ values and the mean of their squares, as
	 * Mitsuba's moment integrator writes them; m2 - m1^2 is the
	 * variance of one sample, dropped samples counting as zero. */
	struct pm_image *moment1, *moment2;
};

/*
 * A window on a running render for another thread (a preview): which
 * tiles are finished, and a copy of them.  One watch serves one render at
 * a time; it owns only its own bookkeeping, never the image.
 */
struct pm_render_watch *pm_render_watch_new(void);
void pm_render_watch_free(struct pm_render_watch *w);

/*
 * Copies the image of the render w watches as it stands: finished tiles as
 * they will be, the others black.  im is (re)allocated to the image's size
 * here and owned by the caller.  Safe to call from any thread at any time;
 * returns false (im untouched) when no render is running.
 */
bool pm_render_snapshot(struct pm_render_watch *w, struct pm_image *im);

struct pm_render_stats {
	uint64_t samples;		/* camera samples taken */
	uint64_t dropped;		/* samples that were NaN or infinite */
};

/*
 * Renders the scene's camera into out (allocated here, cam->width by
 * cam->height): the mean of spp samples per pixel, drawn through the film's
 * reconstruction filter by importance sampling.
 */
enum pm_err pm_render(const struct pm_render_ctx *ctx, const struct pm_camera *cam,
    const struct pm_render_opts *opts, struct pm_image *out,
    struct pm_render_stats *stats, struct pm_error *err);

/*
 * pm_render for PM_METHOD_PTRACER (integrator_ptracer.c): width x height x
 * spp light paths, each connected to the camera at every vertex and
 * splatted; bit-identical whatever the thread count.  The watch and the
 * moments are not served; tiles count chunks of light paths.
 */
enum pm_err pm_ptracer_render(const struct pm_render_ctx *ctx,
    const struct pm_camera *cam, const struct pm_render_opts *opts,
    struct pm_image *out, struct pm_render_stats *stats,
    struct pm_error *err);

#endif
