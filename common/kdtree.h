/*
 * kdtree.h: balanced kd-trees over photons, stored as an implicit array.
 *
 * Layout: the subtree over the index range [lo, hi) has its root at
 * m = lo + (hi - lo) / 2, its left subtree over [lo, m) and its right
 * subtree over [m + 1, hi).  Every photon in the left subtree has
 * pos[axis] <= the root's, every one in the right subtree >= it, where axis
 * is stored in the root's flags (PM_KD_AXIS_MASK; PM_KD_LEAF for a range of
 * one).  No pointers, no padding: the photons themselves are the tree.
 * The split axis is the one of largest extent (for ranges of 512 photons
 * or more, of an evenly spaced sample of them), the split the median,
 * found by selection (linear time) rather than sorting.
 *
 * Queries allocate nothing and keep their state on the caller's stack, so
 * any number of threads may query one tree.
 */
#ifndef PM_KDTREE_H
#define PM_KDTREE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "error.h"
#include "photon.h"

/* One neighbour: the photon's index in the tree and its squared distance. */
struct pm_knn {
	float d2;
	uint32_t idx;
};

/*
 * Reorders p[0..n) in place into the balanced layout and sets each
 * photon's split axis.  Uses up to `threads` threads for the upper levels.
 * Fails only for n >= 2^32 (indices are 32-bit) or out of memory.
 */
enum pm_err pm_kdtree_build(struct pm_photon *p, size_t n, int threads,
    struct pm_error *err);

/*
 * The k nearest photons to q within squared distance max_d2 whose flags
 * satisfy (flags & mask) == want.  Results go into out[0..k) as a max-heap
 * on d2 (out[0] is the farthest found); returns how many were found.
 * Ties at equal distance are broken arbitrarily.
 */
size_t pm_kdtree_knn(const struct pm_photon *p, size_t n, const float q[3],
    size_t k, float max_d2, uint8_t mask, uint8_t want, struct pm_knn *out);

/*
 * pm_kdtree_knn's neighbours without its last step: out[0..k) is a
 * max-heap only when k were found, and fewer come in no order.  For a
 * density estimate, which needs the k-th distance only when there are k
 * (fewer: its radius is max_d2), and not the order; making the heap of
 * what a bounded query found was a tenth of a caustic render's time.
 */
size_t pm_kdtree_knn_unordered(const struct pm_photon *p, size_t n,
    const float q[3], size_t k, float max_d2, uint8_t mask, uint8_t want,
    struct pm_knn *out);

/*
 * k-nearest queries for nq points q[3 * i .. 3 * i + 3) at once, with the
 * filter and the bound of pm_kdtree_knn: query i's neighbours go to
 * out[i * k ..] (room for k) as a max-heap and their count to found[i].
 * The same neighbours as pm_kdtree_knn's, up to the choice among photons
 * tied at the k-th distance, but faster: the points are walked in an
 * order that keeps the caches warm (allocated once per call; without
 * memory, the given order), each bounded first by a guess at its k-th
 * distance from its predecessor's, then, if fewer than k photons lie
 * within the guess, by a bound its predecessor's neighbours make sure.
 * The results do not depend on the thread or the order of the calls,
 * only on the batch.
 */
void pm_kdtree_knn_batch(const struct pm_photon *p, size_t n, const float *q,
    size_t nq, size_t k, float max_d2, uint8_t mask, uint8_t want,
    struct pm_knn *out, size_t *found);

/* Sorts the result of pm_kdtree_knn by increasing distance (then index). */
void pm_knn_sort(struct pm_knn *r, size_t count);

/*
 * Every photon within squared distance max_d2 of q (with the same flag
 * filter), up to cap of them written to out; returns how many there are in
 * all (which may exceed cap).
 */
size_t pm_kdtree_radius(const struct pm_photon *p, size_t n, const float q[3],
    float max_d2, uint8_t mask, uint8_t want, struct pm_knn *out, size_t cap);

/*
 * A radius query that yields its photons one at a time, for estimates
 * that must see every photon within the radius however many there are
 * (progressive photon mapping's fixed-radius estimate): no buffer, no
 * cap, no callback; the traversal state lives in the caller's struct.
 * Start it with pm_kdtree_range_init, then call pm_kdtree_range_next until
 * it returns false.  The tree must not change meanwhile.
 */
#ifndef PM_KD_RANGE_BUF
#define PM_KD_RANGE_BUF	256
#endif
struct pm_kd_range {
	const struct pm_photon *p;
	float q[3], max_d2;
	uint8_t mask, want;
	uint8_t isa;			/* the bucket scan's instruction set */
	uint32_t sp;			/* deferred subtrees on the stack */
	uint32_t nbuf, ibuf;		/* matches found, and returned */
	/* Deferred subtrees: their index ranges and the distances from q
	 * to their cells along each axis. */
	struct {
		uint32_t lo, hi;
		float off[3];
	} st[64];
	/* The matches of the last descent, returned one at a time. */
	uint32_t bidx[PM_KD_RANGE_BUF];
	float bd2[PM_KD_RANGE_BUF];
};

/* Starts a query for the photons of p[0..n) within squared distance
 * max_d2 of q whose flags satisfy (flags & mask) == want. */
void pm_kdtree_range_init(struct pm_kd_range *r, const struct pm_photon *p,
    size_t n, const float q[3], float max_d2, uint8_t mask, uint8_t want);

/* Part of pm_kdtree_range_next: the next descent's matches into r's
 * buffer; false when there are no more. */
bool pm_kdtree_range_refill(struct pm_kd_range *r);

/* The next photon of the query: its index in *idx and squared distance in
 * *d2; false when there are no more.  Photons come in no useful order.
 * Inline: most calls only hand out a buffered match. */
static inline bool
pm_kdtree_range_next(struct pm_kd_range *r, uint32_t *idx, float *d2)
{
	if (r->ibuf == r->nbuf && !pm_kdtree_range_refill(r))
		return false;
	*idx = r->bidx[r->ibuf];
	*d2 = r->bd2[r->ibuf++];
	return true;
}

/*
 * For tests: the instruction set of the bucket scans of range (and
 * radius) queries started from now on, 1 plain C, 2 SSE2, 3 AVX2, 0 (the
 * default) the best the CPU runs; one the CPU lacks falls back to the best
 * it has.  Returns the one queries will use.  Every choice yields the
 * same photons in the same order with the same distances.
 */
int pm_kdtree_range_isa(int isa);

/*
 * Checks the ordering invariant of every node; returns true if it holds,
 * else false with the index of the first bad node in *bad.
 */
bool pm_kdtree_verify(const struct pm_photon *p, size_t n, size_t *bad);

#endif
