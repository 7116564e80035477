/*
 * envmap.h: Mitsuba's envmap emitter: an image in latitude-longitude
 * layout, infinitely far away, and the distribution that samples its
 * directions by luminance.
 *
 * The mapping is Mitsuba 3's.  In the emitter's own frame (to_world maps
 * it to the world) a direction d = (sin phi sin theta, cos theta,
 * -cos phi sin theta) has u = phi / 2 pi and v = theta / pi: +y (up) is
 * the image's top row, -z is its left edge and the middle of the image
 * (u = 1/2) looks along +z, u growing towards +x.  Radiance is bilinear
 * between texels, with texel x's centre at u = (x + 1/2) / width (the
 * image wraps around in u) and row y at v = y / (height - 1), so the top
 * and bottom rows sit on the poles.
 *
 * Directions are sampled from a piecewise-constant distribution over the
 * cells between texel centres (width x (height - 1) of them), each weighted
 * by the mean luminance of its four corners times its solid angle, and
 * uniform in (phi, cos theta) within a cell: a cell whose corners are all
 * black is never chosen, and no other cell has density zero, so the
 * estimate is unbiased, and the density has no pole singularity.  One flat
 * cumulative table over all cells, built once.
 */
#ifndef PM_ENVMAP_H
#define PM_ENVMAP_H

#include "error.h"
#include "sampling.h"
#include "transform.h"
#include "vec.h"

struct pm_envmap {
	int width, height;		/* the image's size */
	float *rgb;			/* (width + 1) x height texels, RGB, scale
					 * applied, column 0 repeated last */
	struct pm_mat4 to_world;	/* directions: emitter -> world */
	struct pm_mat4 to_local;	/* its inverse */
	struct pm_distrib cells;	/* width x (height - 1) cells, row-major */
	double integral;		/* of the mean of RGB over the sphere */
};

/*
 * Builds e from an RGB image (width >= 2, height >= 3, rows top first,
 * copied) times scale, seen through to_world (a rotation, possibly with a
 * uniform scale, which does not matter to directions).  Negative texels
 * are read as zero.  An image with no light at all is valid: it emits
 * nothing and samples nothing (pdf 0).
 */
enum pm_err pm_envmap_init(struct pm_envmap *e, const float *rgb, int width,
    int height, float scale, const struct pm_mat4 *to_world,
    struct pm_error *err);
void pm_envmap_free(struct pm_envmap *e);

/* Radiance arriving from world direction w (unit; w points at the sky). */
struct pm_rgb pm_envmap_eval(const struct pm_envmap *e, struct pm_vec3 w);
/* A world direction towards the sky, and its solid-angle density *pdf
 * (0 when nothing can be sampled). */
struct pm_vec3 pm_envmap_sample(const struct pm_envmap *e, float u1, float u2,
    float *pdf);
/* The solid-angle density with which pm_envmap_sample picks w. */
float pm_envmap_pdf(const struct pm_envmap *e, struct pm_vec3 w);

#endif
