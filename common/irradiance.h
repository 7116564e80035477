/*
 * irradiance.h: precomputed irradiance (Christensen 1999, "Faster photon
 * map global illumination").
 *
 * At a fraction of the global photons (every `stride`-th in kd-tree order,
 * which spreads them evenly over the surfaces) the irradiance E is
 * estimated once from the photons around them whose surface normal is
 * compatible, and stored as a record in the photon layout: position,
 * normal, and E in the power field (W/m^2, already divided by the photon
 * paths emitted).  Records get a balanced kd-tree of their own.  A final
 * gathering ray then ends in one lookup of the nearest record with a
 * compatible normal instead of a k-nearest density estimate: the cost of a
 * gather ray no longer grows with the map, and light does not leak through
 * walls, because photons of the other side of a surface have the opposite
 * normal and never count.
 */
#ifndef PM_IRRADIANCE_H
#define PM_IRRADIANCE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "error.h"
#include "photon.h"
#include "vec.h"

/* Normals are compatible when their cosine exceeds this (about 25
 * degrees): Christensen's test, loose enough for curved meshes. */
#define PM_IRR_COS 0.9f
/* Largest k of an irradiance estimate: neighbours live on the stack. */
#define PM_IRR_MAX_K 1024

struct pm_irradiance_opts {
	size_t stride;		/* one record per stride global photons, >= 1 */
	int k;			/* photons per estimate (k-nearest mode) */
	float max_r2;		/* squared radius: the k-nearest cap, or the
				 * fixed radius */
	bool fixed_radius;	/* every photon within max_r2 counts (the
				 * progressive passes); k unused */
	int max_depth;		/* photons of more bounces do not count
				 * (the scene's max_depth); -1: all do */
	int threads;
};

/*
 * Irradiance at p on a surface of normal nrm (unit, on the lit side) from
 * the balanced global map g[0..n) whose photons carry scale times their
 * power (scale = 1 / paths emitted): the sum of compatible photons' power
 * over pi r^2, r the distance to the k-th nearest photon of any normal
 * (or max_r2 when fewer are found), or the fixed radius.  Photons of
 * depth above o->max_depth (when it is not negative) count nothing.
 */
struct pm_rgb pm_irradiance_estimate(const struct pm_photon *g, size_t n,
    float scale, struct pm_vec3 p, struct pm_vec3 nrm,
    const struct pm_irradiance_opts *o);

/*
 * Records for the balanced global map g[0..n): one per stride photons, E
 * by pm_irradiance_estimate, in parallel and deterministic whatever the
 * thread count.  *out (allocated here, owned by the caller; NULL when
 * there are none) is not balanced: pass it to pm_kdtree_build.
 */
enum pm_err pm_irradiance_records(const struct pm_photon *g, size_t n,
    float scale, const struct pm_irradiance_opts *o, struct pm_photon **out,
    size_t *nout, struct pm_error *err);

/*
 * A uniform grid over the records for gather rays' lookups: a k-nearest
 * search per gather ray cost half a render; a grid cell holds a few
 * records, so a lookup reads one cell (and its 26 neighbours only when
 * that has none of compatible normal).  Cells are about twice the
 * records' typical spacing; their count is capped, so a sparse scene gets
 * larger cells rather than more memory.
 */
struct pm_irr_grid {
	float lo[3], inv_cell;
	int nx, ny, nz;
	uint32_t *start;		/* nx*ny*nz + 1 offsets into rec */
	struct pm_irr_rec *rec;		/* the records, cell by cell */
};

/* A record as the grid keeps it: unpacked once, so that a lookup does
 * no decoding (32 bytes). */
struct pm_irr_rec {
	float p[3];
	float n[3];
	uint8_t E[4];			/* RGBE, as in the file */
	float pad;
};

/* Builds g over the balanced records r[0..n) (copied: r need not
 * outlive g) on up to `threads` threads, the same grid for any count;
 * free with pm_irr_grid_free. */
enum pm_err pm_irr_grid_build(struct pm_irr_grid *g, const struct pm_photon *r,
    size_t n, int threads, struct pm_error *err);
void pm_irr_grid_free(struct pm_irr_grid *g);

/*
 * Starts loading what pm_irradiance_lookup at each of p[0..n) will read
 * first (its cell, then the cell's first records), so that a batch's
 * lookups made next wait on memory once, not once each.  A hint: the
 * lookups give the same answers with or without it.
 */
void pm_irradiance_prefetch(const struct pm_irr_grid *g, const struct pm_vec3 *p,
    size_t n);

/*
 * The irradiance of the nearest record of compatible normal in p's grid
 * cell, or failing that in the 27 cells around p; false (and *E
 * untouched) when there is none.
 */
bool pm_irradiance_lookup(const struct pm_irr_grid *g, struct pm_vec3 p,
    struct pm_vec3 nrm, struct pm_rgb *E);

#endif
