/*
 * range_vs.c: fixed-radius queries of one commit's kd-tree against
 * another's, on the same photons, queries and radii (tests/bench/range_vs.sh
 * builds and runs it).  Two programs from one file:
 *
 *   range_vs_dump SHOT.pmap N QUERIES OUT K...   (linked with this tree's
 *	library) writes the first N global photons of SHOT.pmap as the file
 *	has them, QUERIES points made as pm_knn_check makes them, and per K
 *	the median over the queries of the squared distance to the K-th
 *	nearest photon (bench range's radii);
 *   range_vs_walk DUMP ROUNDS   (built with -DRANGE_VS_WALK against a
 *	commit's common/kdtree.c alone) balances the photons with that
 *	commit's build, then runs every query through its
 *	pm_kdtree_range_init/next, ROUNDS times per radius, and prints the
 *	best rate (thread CPU time).
 *
 * Only pm_kdtree_build, pm_kdtree_knn, pm_kdtree_range_init/next and the
 * 24-byte struct pm_photon are used, which every commit since the issue
 * that asked for the fixed-radius rate (17fe3fd) has.  A bench: nothing
 * passes or fails.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "common/kdtree.h"

#ifdef RANGE_VS_WALK

static double
cpu_s(void)
{
	struct timespec ts;

	clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
	return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

int
main(int argc, char **argv)
{
	struct pm_error err = {PM_OK, ""};
	struct pm_photon *p;
	uint64_t hdr[3];
	float *q, *r2;
	FILE *f;
	size_t i, j;
	int rounds, r;

	if (argc != 3 || (f = fopen(argv[1], "rb")) == NULL) {
		fprintf(stderr, "usage: range_vs_walk DUMP ROUNDS\n");
		return 2;
	}
	rounds = atoi(argv[2]);
	if (fread(hdr, sizeof(hdr), 1, f) != 1 || hdr[2] == 0 ||
	    (p = malloc(hdr[0] * sizeof(*p))) == NULL ||
	    (q = malloc(hdr[1] * 3 * sizeof(*q))) == NULL ||
	    (r2 = malloc(hdr[2] * sizeof(*r2))) == NULL ||
	    fread(p, sizeof(*p), hdr[0], f) != hdr[0] ||
	    fread(q, 3 * sizeof(*q), hdr[1], f) != hdr[1] ||
	    fread(r2, sizeof(*r2), hdr[2], f) != hdr[2]) {
		fprintf(stderr, "range_vs_walk: %s: short or bad dump\n", argv[1]);
		return 1;
	}
	fclose(f);
	if (pm_kdtree_build(p, hdr[0], 1, &err) != PM_OK) {
		fprintf(stderr, "range_vs_walk: %s\n", err.msg);
		return 1;
	}
	for (i = 0; i < hdr[2]; i++) {
		double best = INFINITY;
		size_t found = 0;

		for (r = 0; r < rounds; r++) {
			double t = cpu_s();

			found = 0;
			for (j = 0; j < hdr[1]; j++) {
				struct pm_kd_range it;
				uint32_t idx;
				float d2;

				pm_kdtree_range_init(&it, p, hdr[0], &q[3 * j],
				    r2[i], 0, 0);
				while (pm_kdtree_range_next(&it, &idx, &d2))
					found++;
			}
			t = cpu_s() - t;
			best = t < best ? t : best;
		}
		printf("r2 %.9g found %.2f queries/s %.4g\n", r2[i],
		    (double)found / (double)hdr[1], (double)hdr[1] / best);
	}
	return 0;
}

#else

#include "formats/pmap.h"
#include "range_queries.h"

#define RANGE_VS_MAX_K	1024	/* the largest K asked for */

int
main(int argc, char **argv)
{
	struct pm_error err = {PM_OK, ""};
	struct pm_pmap pm;
	struct pm_map *m;
	struct pm_photon *p;
	struct pm_knn *nb;
	uint64_t hdr[3];
	float *q, *kd;
	FILE *f;
	size_t n, nq, i;

	if (argc < 6) {
		fprintf(stderr, "usage: range_vs_dump SHOT.pmap N QUERIES OUT K...\n");
		return 2;
	}
	n = strtoull(argv[2], NULL, 10);
	nq = strtoull(argv[3], NULL, 10);
	if (pm_pmap_read(argv[1], &pm, false, &err) != PM_OK) {
		fprintf(stderr, "range_vs_dump: %s\n", err.msg);
		return 1;
	}
	m = pm_pmap_find(&pm, PM_MAP_GLOBAL);
	if (m == NULL || m->count < n || n == 0 || nq == 0) {
		fprintf(stderr, "range_vs_dump: fewer than %zu global photons\n", n);
		return 1;
	}
	p = malloc(n * sizeof(*p));
	q = malloc(nq * 3 * sizeof(*q));
	kd = malloc(nq * sizeof(*kd));
	nb = malloc(RANGE_VS_MAX_K * sizeof(*nb));
	if (p == NULL || q == NULL || kd == NULL || nb == NULL ||
	    (f = fopen(argv[4], "wb")) == NULL) {
		fprintf(stderr, "range_vs_dump: out of memory or %s\n", argv[4]);
		return 1;
	}
	memcpy(p, m->photons, n * sizeof(*p));
	if (pm_kdtree_build(p, n, 1, &err) != PM_OK) {
		fprintf(stderr, "range_vs_dump: %s\n", err.msg);
		return 1;
	}
	range_queries(m->photons, p, n, q, nq);	/* bench range's */
	hdr[0] = n;
	hdr[1] = nq;
	hdr[2] = (uint64_t)(argc - 5);
	fwrite(hdr, sizeof(hdr), 1, f);
	fwrite(m->photons, sizeof(*p), n, f);
	fwrite(q, 3 * sizeof(*q), nq, f);
	for (i = 5; i < (size_t)argc; i++) {
		size_t k = strtoull(argv[i], NULL, 10);
		float r2;

		if (k == 0 || k > RANGE_VS_MAX_K) {
			fprintf(stderr, "range_vs_dump: k %s out of range\n", argv[i]);
			return 1;
		}
		r2 = range_radius2(p, n, q, nq, k, nb, kd);
		fwrite(&r2, sizeof(r2), 1, f);
	}
	if (fclose(f) != 0) {
		fprintf(stderr, "range_vs_dump: %s: write failed\n", argv[4]);
		return 1;
	}
	pm_pmap_free(&pm);
	return 0;
}

#endif
