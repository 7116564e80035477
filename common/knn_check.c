/*
 * knn_check.c: pm's kd-tree against FLANN's exact single kd-tree, on the
 * same photons and the same query points, for pm-inspect --knn-check.
 *
 * Both answers are compared by recomputing every returned photon's squared
 * distance with pm's formula, so that how FLANN rounds its own distances
 * cannot matter: the two sorted distance lists must agree, and the two
 * index sets must agree on every photon strictly closer than the k-th
 * distance.  A query that passes but whose sets differ is a tie (photons
 * at the k-th distance chosen differently), which is no error.  A relative
 * tolerance of 1e-6 on distances allows for a FLANN built with fused
 * multiply-adds ranking near-equal candidates differently.
 *
 * Queries run in batches, pm's and FLANN's timed separately, each on one
 * thread; both are given a batch at a time, as a caller would, in the
 * order the seed drew them (pm_kdtree_knn_batch reorders its own); pm is
 * also timed one pm_kdtree_knn call a query.
 */
#include <limits.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <flann/flann.h>

#include "kdtree.h"
#include "knn_check.h"
#include "rng.h"

/* Results held per batch: batch * k of them, bounded by this (64 MB of
 * results and FLANN's copies).  Batches as large as this let
 * pm_kdtree_knn_batch order them. */
#define CHECK_BATCH_RESULTS (1u << 22)
#define CHECK_BATCH_MAX (1u << 16)
#define CHECK_TOL 1e-6f

enum verdict {
	SAME,
	TIE,
	MISMATCH,
};

static double
now_s(void)
{
	struct timespec t;

	clock_gettime(CLOCK_MONOTONIC, &t);
	return (double)t.tv_sec + (double)t.tv_nsec * 1e-9;
}

/* pm's distance formula, as in kdtree.c. */
static float
dist2(const struct pm_photon *p, const float q[3])
{
	float dx = p->pos[0] - q[0], dy = p->pos[1] - q[1],
	    dz = p->pos[2] - q[2];

	return dx * dx + dy * dy + dz * dz;
}

/* How many of the sorted r[0..kk) are closer than lim. */
static size_t
count_below(const struct pm_knn *r, size_t kk, float lim)
{
	size_t i = 0;

	while (i < kk && r[i].d2 < lim)
		i++;
	return i;
}

/* Same photons in both sorted prefixes of length m (sa, sb reordered). */
static int
same_sets(struct pm_knn *sa, struct pm_knn *sb, size_t m)
{
	size_t i;

	/* With equal keys pm_knn_sort orders by index alone. */
	for (i = 0; i < m; i++)
		sa[i].d2 = sb[i].d2 = 0.0f;
	pm_knn_sort(sa, m);
	pm_knn_sort(sb, m);
	for (i = 0; i < m; i++)
		if (sa[i].idx != sb[i].idx)
			return 0;
	return 1;
}

/*
 * Compares pm's answer a[0..na) with FLANN's indices fi[0..kk) for query
 * q, using sa and sb (kk each) as scratch.
 */
static enum verdict
compare(const struct pm_photon *p, size_t n, const float q[3],
    const struct pm_knn *a, size_t na, const int *fi, size_t kk,
    struct pm_knn *sa, struct pm_knn *sb)
{
	float d, tol;
	size_t i, in;
	int same = 1;

	if (na != kk)
		return MISMATCH;
	for (i = 0; i < kk; i++) {
		if (a[i].idx >= n || fi[i] < 0 || (size_t)fi[i] >= n)
			return MISMATCH;
		sa[i].idx = a[i].idx;
		sa[i].d2 = dist2(&p[a[i].idx], q);
		sb[i].idx = (uint32_t)fi[i];
		sb[i].d2 = dist2(&p[fi[i]], q);
	}
	pm_knn_sort(sa, kk);
	pm_knn_sort(sb, kk);
	for (i = 1; i < kk; i++)
		if (sa[i].idx == sa[i - 1].idx || sb[i].idx == sb[i - 1].idx)
			return MISMATCH;	/* a photon returned twice */
	d = pm_fmaxf(sa[kk - 1].d2, sb[kk - 1].d2);
	tol = d * CHECK_TOL;
	for (i = 0; i < kk; i++) {
		if (fabsf(sa[i].d2 - sb[i].d2) > tol)
			return MISMATCH;
		if (sa[i].idx != sb[i].idx)
			same = 0;
	}
	if (same)
		return SAME;
	in = count_below(sa, kk, d - tol);
	if (in != count_below(sb, kk, d - tol))
		return MISMATCH;
	return same_sets(sa, sb, in) ? TIE : MISMATCH;
}

float
pm_knn_offset_scale(const struct pm_photon *p, size_t n)
{
	float mn[3], mx[3], e = 0.0f;
	size_t i;
	int a;

	for (a = 0; a < 3; a++)
		mn[a] = mx[a] = p[0].pos[a];
	for (i = 1; i < n; i++)
		for (a = 0; a < 3; a++) {
			mn[a] = pm_fminf(mn[a], p[i].pos[a]);
			mx[a] = pm_fmaxf(mx[a], p[i].pos[a]);
		}
	for (a = 0; a < 3; a++)
		e = pm_fmaxf(e, mx[a] - mn[a]);
	return e / cbrtf((float)n);
}

struct check_buf {
	float *pos;		/* n * 3, FLANN's copy of the positions */
	float *qp;		/* batch * 3 */
	int *fi;		/* batch * kk */
	float *fd;		/* batch * kk */
	struct pm_knn *pr;	/* batch * kk */
	size_t *pc;		/* batch */
	struct pm_knn *sa, *sb;	/* kk each */
	unsigned char *vd;	/* batch: the first answers' verdicts */
};

static void
free_bufs(struct check_buf *b)
{
	free(b->pos);
	free(b->qp);
	free(b->fi);
	free(b->fd);
	free(b->pr);
	free(b->pc);
	free(b->sa);
	free(b->sb);
	free(b->vd);
}

static enum pm_err
time_pm_build(const struct pm_photon *p, size_t n, double *secs,
    struct pm_error *err)
{
	struct pm_photon *c = malloc(n * sizeof(*c));
	enum pm_err e;
	double t0;

	if (c == NULL)
		return pm_fail(err, PM_ERR_NOMEM,
		    "knn_check: no memory to copy %zu photons", n);
	memcpy(c, p, n * sizeof(*c));
	t0 = now_s();
	e = pm_kdtree_build(c, n, 1, err);
	*secs = now_s() - t0;
	free(c);
	return e;
}

/*
 * Compares pm's answers to the batch's m queries with FLANN's: the
 * first time (r NULL) into b->vd, the second time with the worse of both
 * verdicts counted in r.
 */
static void
count_verdicts(const struct pm_photon *p, size_t n, struct check_buf *b,
    size_t m, size_t kk, struct pm_knn_check_result *r)
{
	size_t j;

	for (j = 0; j < m; j++) {
		enum verdict v = compare(p, n, &b->qp[3 * j], &b->pr[j * kk],
		    b->pc[j], &b->fi[j * kk], kk, b->sa, b->sb);

		if (r == NULL) {
			b->vd[j] = (unsigned char)v;
			continue;
		}
		switch (v > b->vd[j] ? v : (enum verdict)b->vd[j]) {
		case SAME:
			break;
		case TIE:
			r->ties++;
			break;
		case MISMATCH:
			r->mismatches++;
			break;
		}
	}
}

/* Cross-checks pm's kd-tree p[0..n) with FLANN; see knn_check.h. */
enum pm_err
pm_knn_check(const struct pm_photon *p, size_t n, size_t queries, size_t k,
    uint64_t seed, struct pm_knn_check_result *r, struct pm_error *err)
{
	struct FLANNParameters fp = DEFAULT_FLANN_PARAMETERS;
	struct check_buf b;
	flann_index_t ix;
	size_t kk, batch, i, j, m, done;
	double t0, t_pm = 0.0, t_fl = 0.0, t_one = 0.0;
	float speedup, h;
	enum pm_err e;

	memset(r, 0, sizeof(*r));
	memset(&b, 0, sizeof(b));
	if (k == 0)
		return pm_fail(err, PM_ERR_INVALID,
		    "knn_check: k is 0, expected at least 1");
	if (n > INT_MAX || k > INT_MAX)
		return pm_fail(err, PM_ERR_LIMIT, "knn_check: %zu photons, "
		    "k = %zu: FLANN takes at most %d of either", n, k, INT_MAX);
	if (n == 0 || queries == 0)
		return PM_OK;
	if ((e = time_pm_build(p, n, &r->pm_build_s, err)) != PM_OK)
		return e;

	kk = k < n ? k : n;
	batch = CHECK_BATCH_RESULTS / kk;
	batch = batch < 1 ? 1 : batch > CHECK_BATCH_MAX ? CHECK_BATCH_MAX :
	    batch;
	b.pos = malloc(n * 3 * sizeof(*b.pos));
	b.qp = malloc(batch * 3 * sizeof(*b.qp));
	b.fi = malloc(batch * kk * sizeof(*b.fi));
	b.fd = malloc(batch * kk * sizeof(*b.fd));
	b.pr = malloc(batch * kk * sizeof(*b.pr));
	b.pc = malloc(batch * sizeof(*b.pc));
	b.sa = malloc(kk * sizeof(*b.sa));
	b.sb = malloc(kk * sizeof(*b.sb));
	b.vd = malloc(batch);
	if (b.vd == NULL || b.pos == NULL || b.qp == NULL || b.fi == NULL || b.fd == NULL ||
	    b.pr == NULL || b.pc == NULL || b.sa == NULL || b.sb == NULL) {
		free_bufs(&b);
		return pm_fail(err, PM_ERR_NOMEM,
		    "knn_check: no memory for %zu photons, k = %zu", n, kk);
	}
	for (i = 0; i < n; i++)
		memcpy(&b.pos[3 * i], p[i].pos, sizeof(p[i].pos));

	/* Exact: one kd-tree, eps 0, no limit on leaves checked. */
	fp.algorithm = FLANN_INDEX_KDTREE_SINGLE;
	fp.checks = FLANN_CHECKS_UNLIMITED;
	fp.eps = 0.0f;
	fp.cores = 1;
	fp.leaf_max_size = 10;
	fp.log_level = FLANN_LOG_NONE;
	fp.random_seed = (long)(seed & LONG_MAX);
	flann_set_distance_type(FLANN_DIST_EUCLIDEAN, 0);
	t0 = now_s();
	ix = flann_build_index_float(b.pos, (int)n, 3, &speedup, &fp);
	r->flann_build_s = now_s() - t0;
	if (ix == NULL) {
		free_bufs(&b);
		return pm_fail(err, PM_ERR_INVALID,
		    "knn_check: FLANN could not build an index of %zu points",
		    n);
	}

	h = pm_knn_offset_scale(p, n);
	for (done = 0; done < queries; done += m) {
		m = queries - done < batch ? queries - done : batch;
		for (j = 0; j < m; j++) {
			struct pm_rng g = pm_rng_seed(seed, done + j,
			    0x6b6e6e);
			size_t s = (size_t)(pm_rng_double(&g) * (double)n);
			int a;

			s = s < n ? s : n - 1;
			for (a = 0; a < 3; a++)
				b.qp[3 * j + a] = p[s].pos[a] +
				    (pm_rng_float(&g) - 0.5f) * h;
		}
		/* pm's batch first, which finds the caches coldest. */
		t0 = now_s();
		pm_kdtree_knn_batch(p, n, b.qp, m, kk, INFINITY, 0, 0, b.pr,
		    b.pc);
		t_pm += now_s() - t0;
		t0 = now_s();
		if (flann_find_nearest_neighbors_index_float(ix, b.qp, (int)m,
		    b.fi, b.fd, (int)kk, &fp) < 0) {
			flann_free_index_float(ix, &fp);
			free_bufs(&b);
			return pm_fail(err, PM_ERR_INVALID,
			    "knn_check: FLANN's search failed");
		}
		t_fl += now_s() - t0;
		count_verdicts(p, n, &b, m, kk, NULL);
		t0 = now_s();
		for (j = 0; j < m; j++)
			b.pc[j] = pm_kdtree_knn(p, n, &b.qp[3 * j], kk,
			    INFINITY, 0, 0, &b.pr[j * kk]);
		t_one += now_s() - t0;
		count_verdicts(p, n, &b, m, kk, r);
	}
	r->queries = queries;
	r->pm_qps = t_pm > 0.0 ? (double)queries / t_pm : 0.0;
	r->pm_qps_single = t_one > 0.0 ? (double)queries / t_one : 0.0;
	r->flann_qps = t_fl > 0.0 ? (double)queries / t_fl : 0.0;
	flann_free_index_float(ix, &fp);
	free_bufs(&b);
	return PM_OK;
}
