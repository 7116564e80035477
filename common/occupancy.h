/*
 * occupancy.h: where a photon map has no photon near, one bit a cell.
 *
 * A k-nearest or fixed-radius estimate that finds no photon within its
 * radius costs a whole kd-tree walk to learn it, and in a scene whose
 * caustics are few and gathered in places (the demo bunny's: 55% of its
 * caustic estimates found none) most camera hits ask exactly that.  A
 * grid of cells at least the radius wide, each bit set where the cell or
 * one of its 26 neighbours holds a photon, answers it with one load: a
 * photon within the radius of q lies in q's cell or a neighbour.  The
 * answer is "none" or "maybe", never a wrong "none", so estimates skip
 * only walks that would have found nothing, and images keep their bits.
 */
#ifndef PM_OCCUPANCY_H
#define PM_OCCUPANCY_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "error.h"
#include "photon.h"

struct pm_occupancy {
	float lo[3];		/* the photons' lower bounds */
	float inv_cell;		/* 1 / the cell's width */
	float r2;		/* the largest squared radius it answers for */
	int n[3];		/* cells an axis, a border ring included */
	size_t words;		/* 64-bit words a row of cells along x */
	uint64_t *bits;		/* NULL: it answers "maybe" everywhere */
};

/* Builds o for the photons p[0..n) and squared radii up to r2; with no
 * photons, no radius or no memory, o answers "maybe" everywhere (which
 * is always right).  Free with pm_occupancy_free. */
void pm_occupancy_build(struct pm_occupancy *o, const struct pm_photon *p,
    size_t n, float r2);
void pm_occupancy_free(struct pm_occupancy *o);

/*
 * False only if no photon of the map lies within squared distance r2 of
 * q (as a kd-tree walk measures it); true when one may.  o may be NULL.
 * The cell along an axis is floor(v) + 1, v = (q - lo) / cell and the
 * +1 for the border ring, with v computed as the build computes it, so
 * that rounding is the same on both sides (occupancy.c says why one cell
 * of slack is enough); floor by comparisons and truncation, since floorf
 * is a call on plain x86-64.
 */
static inline bool pm_occupancy_maybe(const struct pm_occupancy *o,
    const float q[3], float r2)
{
	size_t c[3];
	int a;

	if (o == NULL || o->bits == NULL || !(r2 <= o->r2))
		return true;
	for (a = 0; a < 3; a++) {
		float v = (q[a] - o->lo[a]) * o->inv_cell;

		if (v != v)
			return true;	/* NaN: let the walk decide */
		/* beyond the ring: nothing near */
		if (v < -1.0f || v >= (float)(o->n[a] - 1))
			return false;
		c[a] = v < 0.0f ? 0 : (size_t)v + 1;
	}
	return (o->bits[(c[2] * (size_t)o->n[1] + c[1]) * o->words +
	    (c[0] >> 6)] >> (c[0] & 63)) & 1u;
}

#endif
