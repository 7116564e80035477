/*
 * range_queries.h: the queries and radii of the bench's fixed-radius row,
 * shared by tests/bench/bench.c and tests/bench/range_vs.c so that both
 * time the same work.  Static functions, included by each program once.
 */
#ifndef PM_BENCH_RANGE_QUERIES_H
#define PM_BENCH_RANGE_QUERIES_H

#include <math.h>
#include <stdlib.h>

#include "../../common/kdtree.h"
#include "../../common/knn_check.h"
#include "../../common/rng.h"

/*
 * nq query points into q[3 * nq], as pm_knn_check makes them: photons
 * moved by about their spacing (h, from the balanced tree), the photons
 * taken from file[0..n) in the file's order, so that the queries do not
 * depend on how the tree is built.
 */
static void
range_queries(const struct pm_photon *file, const struct pm_photon *tree,
    size_t n, float *q, size_t nq)
{
	float h = pm_knn_offset_scale(tree, n);
	size_t j;
	int a;

	for (j = 0; j < nq; j++) {
		struct pm_rng g = pm_rng_seed(1, j, 0x6b6e6e);
		size_t s = (size_t)(pm_rng_double(&g) * (double)n);

		s = s < n ? s : n - 1;
		for (a = 0; a < 3; a++)
			q[3 * j + a] = file[s].pos[a] +
			    (pm_rng_float(&g) - 0.5f) * h;
	}
}

static int
range_cmp_float(const void *a, const void *b)
{
	float x = *(const float *)a, y = *(const float *)b;

	return x < y ? -1 : x > y;
}

/* The radius for k: the median over the queries of the squared distance
 * to the k-th nearest photon of the balanced tree[0..n).  nb holds k
 * neighbours, kd nq floats. */
static float
range_radius2(const struct pm_photon *tree, size_t n, const float *q,
    size_t nq, size_t k, struct pm_knn *nb, float *kd)
{
	size_t j;

	for (j = 0; j < nq; j++)
		kd[j] = pm_kdtree_knn(tree, n, &q[3 * j], k, INFINITY, 0, 0,
		    nb) > 0 ? nb[0].d2 : 0.0f;
	qsort(kd, nq, sizeof(*kd), range_cmp_float);
	return kd[nq / 2];
}

#endif
