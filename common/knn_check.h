/*
 * knn_check.h: a cross-check of pm's kd-tree against FLANN, the library
 * everyone trusts for nearest neighbours, for pm-inspect --knn-check.
 *
 * FLANN's single kd-tree is exact (no approximation when eps is zero), so
 * both must return the same k-nearest sets, up to the choice among photons
 * tied at the k-th distance; the check also times both on the same queries.
 */
#ifndef PM_KNN_CHECK_H
#define PM_KNN_CHECK_H

#include <stddef.h>
#include <stdint.h>

#include "error.h"
#include "photon.h"

struct pm_knn_check_result {
	size_t queries;		/* queries run */
	size_t mismatches;	/* queries whose sets differ beyond ties */
	size_t ties;		/* queries whose sets differ only by photons
				 * tied at the k-th distance */
	double pm_qps;		/* pm's k-nearest queries per second, as
				 * a batch (pm_kdtree_knn_batch) */
	double pm_qps_single;	/* the same, one pm_kdtree_knn call a query */
	double flann_qps;	/* FLANN's, single thread, same queries */
	double pm_build_s;	/* pm_kdtree_build of a copy, one thread */
	double flann_build_s;	/* FLANN's index over the same positions */
};

/* The scale of the check's query offsets: about the spacing of n points
 * filling a cube of the bounding box's largest extent (n >= 1). */
float pm_knn_offset_scale(const struct pm_photon *p, size_t n);

/*
 * Queries the balanced tree p[0..n) (as pm_kdtree_build left it; it is
 * queried as it is, so a damaged tree shows up as mismatches) and a FLANN
 * index over the same positions with `queries` points, each a random
 * photon's position plus a small offset (deterministic from seed), and
 * compares their k nearest, pm's both as a batch and one query at a time
 * (each answer compared with FLANN's).  Fills *r.  Fails for n or k beyond FLANN's
 * int, out of memory, or when FLANN fails.
 */
enum pm_err pm_knn_check(const struct pm_photon *p, size_t n, size_t queries,
    size_t k, uint64_t seed, struct pm_knn_check_result *r,
    struct pm_error *err);

#endif
