/*
 * icache.h: an irradiance cache in image space (Ward, Rubinstein and
 * Clear 1988, with the points on a pixel grid).
 *
 * Indirect light on diffuse surfaces changes slowly, yet estimating it at
 * every camera sample by final gathering pays the gather's noise at every
 * sample.  Before the camera pass, the indirect irradiance is gathered
 * once, with many stratified rays, at the first surface seen through
 * every `step`-th pixel of a grid; camera samples then interpolate it from
 * the grid points around them with Ward's weights, which trust a point
 * only within a distance set by how far its surroundings are (the
 * harmonic mean of its gather rays' lengths) and only for similar
 * normals.  Where no grid point is trusted (edges, corners, surfaces seen
 * through glass) the sample gathers for itself.
 *
 * The grid is a pure function of the camera, the maps and the seed, and
 * is computed before the camera pass, so images stay bit-identical
 * whatever the thread count.
 */
#ifndef PM_ICACHE_H
#define PM_ICACHE_H

#include <stdbool.h>
#include <stdint.h>

#include "error.h"
#include "vec.h"

/* Defaults: measured on the study's scenes (docs/accuracy.md).  At equal
 * cost a finer grid with fewer rays per point wins: the cache's error is
 * mostly the blur of interpolating over its footprint, not its points'
 * noise.  So by default the rays per point are 4 per sample per pixel
 * (16 to 256) and the grid spacing is the finest of 1, 2 and 4 pixels at
 * which the cache's rays per pixel stay within the samples per pixel (at
 * least 4): every 2nd pixel below 256 samples, every pixel from 256.  The
 * cache then costs at most about what the camera pass does. */
#define PM_ICACHE_STEP		4	/* the coarsest default spacing */
#define PM_ICACHE_RAYS_PER_SPP	4
#define PM_ICACHE_RAYS_MIN	16
#define PM_ICACHE_RAYS		256
/* Ward's a: 0.6 beats 0.3 by 10% to 24% in relMSE at 4 to 64 spp on the
 * study's scenes and ties from 256 (the clamped validity distances keep
 * it from smearing across edges); 0.8 and 1.0 lose again from 64 spp. */
#define PM_ICACHE_ACCURACY	0.6f

struct pm_render_ctx;
struct pm_camera_rays;

/* Rays per grid point and grid spacing for spp samples per pixel when the
 * user gives neither: so that the cache costs at most about what the
 * camera pass does, while its interpolation error, which more samples do
 * not average away, falls as the samples grow. */
int pm_icache_default_rays(int spp);
int pm_icache_default_step(int spp, int rays);

struct pm_icache_point {
	struct pm_vec3 p, n;		/* position, normal on the seen side */
	struct pm_rgb E;		/* indirect irradiance */
	float inv_r;			/* 1 / Ward's validity distance */
	bool valid;
};

struct pm_icache {
	int step;			/* pixels between grid points */
	int gw, gh;			/* grid points across and down */
	float a;			/* Ward's accuracy: larger, smoother */
	struct pm_icache_point *pt;	/* gw * gh, row by row; owned */
	/* The points again for pm_icache_lookup, one array per quantity
	 * (icache.c's L_* name them), each gh rows of gw + 6 with three
	 * invalid points before and after a row's own: a lookup's four
	 * candidates in a row are then one load of each array, tested
	 * together in SIMD lanes.  Owned. */
	float *lanes;
};

/*
 * Fills c for the camera rays cr: grid points every `step` pixels (from
 * the top-left corner to the far edges), each gathering with `rays` rays
 * (rounded down to a square, stratified), seeded from seed; `threads`
 * threads.  ctx->maps must hold irradiance records or a global map.
 */
enum pm_err pm_icache_build(struct pm_icache *c, const struct pm_render_ctx *ctx,
    const struct pm_camera_rays *cr, int step, int rays, float a,
    uint64_t seed, int threads, struct pm_error *err);

/* Fills c->lanes from c->pt, as pm_icache_build does last (for a cache
 * whose points were set otherwise); false when out of memory. */
bool pm_icache_pack(struct pm_icache *c);

/*
 * The indirect irradiance at p (normal n, on the seen side) for a camera
 * sample at film position (fx, fy), interpolated from the grid points
 * around it; false when none is trusted there.
 */
bool pm_icache_lookup(const struct pm_icache *c, float fx, float fy,
    struct pm_vec3 p, struct pm_vec3 n, struct pm_rgb *E);

void pm_icache_free(struct pm_icache *c);

#endif
