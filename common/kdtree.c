/*
 * kdtree.c: building and querying the implicit, balanced photon kd-tree
 * described in kdtree.h.
 *
 * The build splits each index range at its median along the axis of
 * largest extent of the range's bounding box (of a sample, for large
 * ranges).  The median of a large range is first bracketed by two keys of
 * a sample (Floyd and Rivest), which leaves a small middle part after one
 * pass; the rest is found by an iterative introselect: median-of-3
 * (ninther for large ranges) pivots and a three-way partition, so that
 * ranges full of equal keys (every photon on one point, plane or line)
 * cost one pass instead of degrading to quadratic time, with a heapsort
 * fallback bounding the worst case at O(n log n).  Subtrees of up to 65536
 * photons (most levels) are built on compact 16-byte records (position and
 * index), the photons permuted to their places once at the end, and their
 * ranges are split by a radix select, which has no branch on the data;
 * selection moves records exactly as it would move photons, so the tree is
 * the same either way.  Subtrees are
 * independent once their parent is split, so large ones (inside compact
 * subtrees too) are handed to idle threads, and the bracketing pass of a
 * range of 2^19 photons or more runs in two halves, the second lent too;
 * each range is processed by the same deterministic code whichever thread
 * runs it, so the result does not depend on the thread count.
 *
 * Queries descend iteratively with a small stack of deferred far children
 * and scan small ranges (contiguous records) linearly, which is faster than
 * branching on the last few levels; both children of each node are
 * prefetched while the node is decided, and buckets are scanned without a
 * branch per photon (four at a time with SSE; the radius walk, eight at a
 * time with AVX2 where the CPU has it, chosen at run time).  Both kinds of query prune
 * a far child by the squared distance from q to its cell, kept
 * incrementally per axis (Arya and Mount 1993).  Batches of k-nearest
 * queries are walked in Morton order, each bounded first by a guess at
 * its k-th distance from its predecessor's.  Squared distances are
 * computed everywhere as dx*dx + dy*dy + dz*dz in float, so results
 * compare exactly with brute force, and both
 * bounds are true lower bounds in float arithmetic too (rounding is
 * monotonic), so pruning never loses a neighbour at the boundary.
 */
#include <math.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "kdtree.h"

/*
 * Ranges this small are scanned rather than descended by queries: a scan
 * of contiguous records beats the branches, up to a point (measured: 32
 * to 64 is best for k = 50..200 on a million photons).
 */
#ifndef KD_BUCKET
#define KD_BUCKET	48
#endif
/* The same for radius queries (measured: 12 to 32 no better than 48 for
 * the radii of the 50th and 200th neighbours). */
#ifndef KD_RBUCKET
#define KD_RBUCKET	48
#endif
/* Inlined by force where a call would keep a walk's state out of
 * registers. */
#if defined(__GNUC__) || defined(__clang__)
#define KD_INLINE	static inline __attribute__((always_inline))
#else
#define KD_INLINE	static inline
#endif
/* Tree height is at most 33 for n < 2^32; one deferred child per level. */
#define KD_STACK	64
/* Selection sorts ranges this small by insertion. */
#define SELECT_SMALL	12
/* Ranges below this size are not worth a thread of their own. */
#define BUILD_SPAWN_MIN	8192
#define BUILD_MAX_THREADS 256

static inline float
kd_dist2(const float a[3], const float q[3])
{
	float dx = a[0] - q[0], dy = a[1] - q[1], dz = a[2] - q[2];

	return dx * dx + dy * dy + dz * dz;
}

/*
 * Subtrees of up to RADIX_MAX photons -- the lower dozen and more levels
 * of the tree, most of the build's passes -- are built on compact records
 * instead, the position and the photon's index in 16 bytes rather than
 * 24, and the photons permuted to their places once at the end: every
 * pass moves two thirds of the bytes, and a whole subtree's records fit in
 * the second-level cache.  The split axis goes in the index's top bits.
 */
struct kd_rec {
	float pos[3];
	uint32_t idx;		/* the photon's offset in the subtree, and its
				 * split axis (or PM_KD_LEAF) from bit 30 */
};

#define REC_AXIS_SHIFT	30
#define REC_IDX_MASK	((UINT32_C(1) << REC_AXIS_SHIFT) - 1)

static int
floor_log2(size_t x)
{
	int r = 0;

	while (x >>= 1)
		r++;
	return r;
}

/*
 * Large ranges are first narrowed around the median by a sample of their
 * keys (Floyd and Rivest 1975): two keys of the sorted sample that
 * bracket the median's rank split the range in one pass, and the median
 * is almost always in the small middle part, which select_kth finishes.
 * Quickselect alone would take two to three passes over the whole range
 * of 24-byte records.
 */
#define FR_MIN		4096
#define FR_SAMPLE	256
#define FR_GAP		20	/* sample ranks either side: 2.5 sigma */

/* Shell sort (gaps 121, 40, 13, 4, 1): short, and fast enough here. */
static void
sort_floats(float *a, size_t n)
{
	static const size_t gaps[] = { 121, 40, 13, 4, 1 };
	size_t i, j, g;

	for (g = 0; g < sizeof(gaps) / sizeof(gaps[0]); g++) {
		size_t h = gaps[g];

		for (i = h; i < n; i++) {
			float t = a[i];

			for (j = i; j >= h && a[j - h] > t; j -= h)
				a[j] = a[j - h];
			a[j] = t;
		}
	}
}

/*
 * The split axis is the one of largest extent of the bounding box of the
 * range, or for a range of more than 8 * AXIS_SAMPLE photons, of an evenly
 * spaced sample of AXIS_SAMPLE to 2 * AXIS_SAMPLE of them.  Cheaper (a
 * pass over every photon of every level was a fifth of the build), and
 * better: a few outliers (photons on another wall) no longer decide the
 * axis of a range that is mostly flat; measured, 1.15x the k-nearest
 * queries per second on 1M cornell-box photons against the exact box.
 */
#ifndef AXIS_SAMPLE
#define AXIS_SAMPLE	64
#endif

static void sort_small_ph(struct pm_photon *, ptrdiff_t, ptrdiff_t, int);
static void sort_small_rec(struct kd_rec *, ptrdiff_t, ptrdiff_t, int);

#define KT	struct pm_photon
#define KN(f)	f##_ph
#include "kdtree_select.h"
#undef KT
#undef KN
#define KT	struct kd_rec
#define KN(f)	f##_rec
#if defined(__SSE2__)
#define KT_OWN_AXIS
#endif
#include "kdtree_select.h"
#undef KT
#undef KN
#undef KT_OWN_AXIS

#if defined(__SSE2__)
/* widest_axis for records, a record's position (and index) one vector:
 * _mm_min_ps(x, lo) is x < lo ? x : lo, the scalar code's choice, so the
 * axis is the same whatever the keys, NaN included. */
static int
widest_axis_rec(const struct kd_rec *p, size_t lo, size_t hi)
{
	__m128 mn, mx;
	float l[4], h[4], e0, e1, e2;
	size_t i, step = 1;

	if (hi - lo >= 8 * AXIS_SAMPLE)
		step = (hi - lo) / AXIS_SAMPLE;
	mn = mx = _mm_loadu_ps(p[lo].pos);
	for (i = lo + step; i < hi; i += step) {
		__m128 v = _mm_loadu_ps(p[i].pos);

		mn = _mm_min_ps(v, mn);
		mx = _mm_max_ps(v, mx);
	}
	_mm_storeu_ps(l, mn);
	_mm_storeu_ps(h, mx);
	e0 = h[0] - l[0];
	e1 = h[1] - l[1];
	e2 = h[2] - l[2];
	if (e0 >= e1 && e0 >= e2)
		return 0;
	return e1 >= e2 ? 1 : 2;
}
#endif

static void
sort_small_ph(struct pm_photon *p, ptrdiff_t lo, ptrdiff_t hi, int ax)
{
	insertion_sort_ph(p, lo, hi, ax);
}

/*
 * The last few records of a selection, sorted as the insertion sort
 * would (stably): each record's place is its rank, the number of keys
 * below it plus the number of equal ones before it, counted for all
 * records at once, one key against the three vectors of all keys at a
 * time.  Insertion sort's branches are a coin toss to the predictor.
 * NaN keys, which have no rank, go to the insertion sort.
 */
static void
sort_small_rec(struct kd_rec *p, ptrdiff_t lo, ptrdiff_t hi, int ax)
{
#if defined(__SSE2__) && SELECT_SMALL <= 12
	float k[12];
	int32_t rank[12];
	struct kd_rec t[12];
	ptrdiff_t n = hi - lo, i;
	__m128 k0, k1, k2;
	__m128i c0, c1, c2, l0, l1, l2;
	int nan = 0;

	if (n < 2)
		return;
	for (i = 0; i < n; i++) {
		k[i] = p[lo + i].pos[ax];
		nan |= k[i] != k[i];
	}
	if (nan || n > 12) {
		insertion_sort_rec(p, lo, hi, ax);
		return;
	}
	/* Padding that no key is below or equal to (NaN): its rank is
	 * never read. */
	for (i = n; i < 12; i++)
		k[i] = NAN;
	k0 = _mm_loadu_ps(&k[0]);
	k1 = _mm_loadu_ps(&k[4]);
	k2 = _mm_loadu_ps(&k[8]);
	l0 = _mm_setr_epi32(0, 1, 2, 3);
	l1 = _mm_setr_epi32(4, 5, 6, 7);
	l2 = _mm_setr_epi32(8, 9, 10, 11);
	c0 = c1 = c2 = _mm_setzero_si128();
	for (i = 0; i < n; i++) {
		/* Key j = i counts for each lane's key if below it, or
		 * equal to it and before it (j < lane). */
		__m128 x = _mm_set1_ps(k[i]);
		__m128i j = _mm_set1_epi32((int)i);

		c0 = _mm_sub_epi32(c0, _mm_castps_si128(_mm_or_ps(
		    _mm_cmplt_ps(x, k0), _mm_and_ps(_mm_cmpeq_ps(x, k0),
		    _mm_castsi128_ps(_mm_cmplt_epi32(j, l0))))));
		c1 = _mm_sub_epi32(c1, _mm_castps_si128(_mm_or_ps(
		    _mm_cmplt_ps(x, k1), _mm_and_ps(_mm_cmpeq_ps(x, k1),
		    _mm_castsi128_ps(_mm_cmplt_epi32(j, l1))))));
		c2 = _mm_sub_epi32(c2, _mm_castps_si128(_mm_or_ps(
		    _mm_cmplt_ps(x, k2), _mm_and_ps(_mm_cmpeq_ps(x, k2),
		    _mm_castsi128_ps(_mm_cmplt_epi32(j, l2))))));
	}
	_mm_storeu_si128((__m128i *)&rank[0], c0);
	_mm_storeu_si128((__m128i *)&rank[4], c1);
	_mm_storeu_si128((__m128i *)&rank[8], c2);
	for (i = 0; i < n; i++)
		t[rank[i]] = p[lo + i];
	memcpy(&p[lo], t, (size_t)n * sizeof(*t));
#else
	insertion_sort_rec(p, lo, hi, ax);
#endif
}

/*
 * Ranges of RADIX_MIN to RADIX_MAX photons are split by a radix select
 * instead: their keys as order-preserving integers, the median's key by
 * counting passes of 8 bits (no branch on the data), then one pass that
 * copies the records below, at and above it into a scratch range and
 * back, in their order.  Introselect's three-way partitions branch on
 * every key, a coin toss to the predictor; measured, the build took a
 * third less time.
 */
#ifndef RADIX_MIN
#define RADIX_MIN	32
#endif
#ifndef RADIX_MAX
#define RADIX_MAX	65536
#endif
#ifndef COMPACT_MAX
#define COMPACT_MAX	RADIX_MAX
#endif

/* The widest digit of the radix select (select_radix). */
#define RADIX_BITS	11

struct build_scratch {
	size_t cap, kcap;
	struct kd_rec *rec;	/* cap: the compact subtree */
	void *buf;		/* cap photons: the compact subtree's second
				 * buffer of records, then the permuted
				 * photons */
	uint32_t *fin;		/* cap: each place's record, when decided */
	uint32_t *key;		/* 3 kcap: the keys, and two of candidates */
	uint32_t cnt[2][1 << RADIX_BITS];	/* two histograms, so that
				 * runs of equal digits do not wait on one
				 * counter */
};

/* A float's bits as an integer of the same order (-0 just below +0). */
static inline uint32_t
key_bits(float f)
{
	uint32_t u;

	memcpy(&u, &f, sizeof(u));
	return u ^ ((uint32_t)-(int32_t)(u >> 31) | 0x80000000u);
}

/* The highest set bit of x != 0. */
static inline int
top_bit(uint32_t x)
{
#if defined(__GNUC__) || defined(__clang__)
	return 31 - __builtin_clz(x);
#else
	int r = 0;

	while (x >>= 1)
		r++;
	return r;
#endif
}

/*
 * select_kth for ranges of at most RADIX_MAX records, with scratch.  The
 * median's key t is found on the keys alone, a digit at a time from the
 * highest bit in which the candidates differ (bits all of them share need
 * no pass, and a range of nearby photons shares the sign, the exponent and
 * more), with digits of RADIX_BITS bits for large ranges and fewer for
 * small ones, whose histograms would cost more to clear and scan than to
 * fill.  After each pass only the keys in the median's digit go on (copied
 * without a branch), and the passes stop as soon as those are all equal.
 * Then one pass copies the records below, at and above t to a scratch
 * range, in their order, and back: the layout depends on t alone, not on
 * how it was found.
 */
static void
select_radix(const struct kd_rec *p, struct kd_rec *tmp, size_t lo,
    size_t hi, size_t k, int ax, struct build_scratch *s)
{
	size_t m = hi - lo, r = k - lo, i, a, b, e, neq, nin = m;
	uint32_t kmin = UINT32_MAX, kmax = 0, *key = s->key, *in = key,
	    *out = key + s->kcap, t;
	int bits = m >= 4096 ? RADIX_BITS : m >= 512 ? 8 : 6;

	for (i = 0; i < m; i++) {
		uint32_t x = key_bits(p[lo + i].pos[ax]);

		key[i] = x;
		kmin = x < kmin ? x : kmin;
		kmax = x > kmax ? x : kmax;
	}
	/* The r-th smallest key; r becomes its rank among the candidates
	 * left, nin their number. */
	while (kmin != kmax) {
		int hb = top_bit(kmin ^ kmax), w = hb + 1 < bits ? hb + 1 : bits;
		int sh = hb + 1 - w;
		uint32_t dmask = (UINT32_C(1) << w) - 1, d, sum = 0;
		size_t j, nb = (size_t)1 << w;
		uint32_t (*cnt)[1 << RADIX_BITS] = s->cnt;

		memset(cnt[0], 0, nb * sizeof(cnt[0][0]));
		memset(cnt[1], 0, nb * sizeof(cnt[0][0]));
		for (i = 0; i + 1 < nin; i += 2) {
			cnt[0][(in[i] >> sh) & dmask]++;
			cnt[1][(in[i + 1] >> sh) & dmask]++;
		}
		if (i < nin)
			cnt[0][(in[i] >> sh) & dmask]++;
		for (d = 0;; d++) {
			uint32_t c = cnt[0][d] + cnt[1][d];

			if (sum + c > r)
				break;
			sum += c;
		}
		r -= sum;
		/* The candidates in digit d go on, with their bounds. */
		kmin = UINT32_MAX;
		kmax = 0;
		for (i = j = 0; i < nin; i++) {
			uint32_t x = in[i];

			out[j] = x;
			j += ((x >> sh) & dmask) == d;
		}
		nin = j;
		for (i = 0; i < nin; i++) {
			uint32_t x = out[i];

			kmin = x < kmin ? x : kmin;
			kmax = x > kmax ? x : kmax;
		}
		in = out;
		out = s->key + s->kcap +
		    (in == s->key + s->kcap ? s->kcap : 0);
	}
	t = kmin;
	neq = nin;
	/* Below t to the front, above it to the back, equal in between. */
	a = lo;
	e = k - r;
	b = e + neq;
	for (i = 0; i < m; i++) {
		uint32_t x = key[i];
		size_t lt = x < t, gt = x > t, eq = 1 - lt - gt;

		tmp[lt * a + eq * e + gt * b] = p[lo + i];
		a += lt;
		e += eq;
		b += gt;
	}
}

/*
 * Scratch for compact subtrees of up to cap photons (none for cap 0: a
 * thread lent inside one uses its owner's) and radix selects of up to
 * kcap; NULL without memory.
 */
static struct build_scratch *
scratch_new(size_t cap, size_t kcap)
{
	struct build_scratch *s = malloc(sizeof(*s));

	if (s == NULL)
		return NULL;
	s->cap = cap;
	s->kcap = kcap;
	s->rec = cap ? malloc(cap * sizeof(*s->rec)) : NULL;
	s->buf = cap ? malloc(cap * sizeof(struct pm_photon)) : NULL;
	s->fin = cap ? malloc(cap * sizeof(*s->fin)) : NULL;
	s->key = malloc(3 * (kcap ? kcap : 1) * sizeof(*s->key));
	if ((cap && (s->rec == NULL || s->buf == NULL || s->fin == NULL)) ||
	    s->key == NULL) {
		free(s->rec);
		free(s->fin);
		free(s->buf);
		free(s->key);
		free(s);
		return NULL;
	}
	return s;
}

static void
scratch_free(struct build_scratch *s)
{
	if (s != NULL) {
		free(s->rec);
		free(s->fin);
		free(s->buf);
		free(s->key);
		free(s);
	}
}

/*
 * Threads are lent to the build by a counter of idle ones: a split of a
 * large range takes one if any is free and hands it the left half.  A
 * thread that waits for its helper gives its place back meanwhile, so that
 * a core never idles while some range is still unsplit.
 */
struct build_ctx {
	struct pm_photon *p;
	atomic_int idle;
};

/*
 * A compact subtree: its records in two buffers, a radix select copying
 * each range from one to the other, and the record each place ends with
 * (its index and split axis) in fin.
 */
struct kd_sub {
	struct kd_rec *rec[2];
	uint32_t *fin;
};

struct build_job {
	struct build_ctx *ctx;
	struct kd_sub *sub;	/* the compact subtree, or NULL for a range
				 * of photons */
	int side;		/* which of sub's buffers holds the range */
	size_t lo, hi;
	struct build_scratch *sc;	/* the thread's, freed by it */
};

static void build_range(struct build_ctx *, size_t, size_t,
    struct build_scratch *);
static void build_rec(struct build_ctx *, struct kd_sub *, int, size_t,
    size_t, struct build_scratch *);

static bool
take_thread(struct build_ctx *c)
{
	int v = atomic_load(&c->idle);

	while (v > 0)
		if (atomic_compare_exchange_weak(&c->idle, &v, v - 1))
			return true;
	return false;
}

static void *
build_thread(void *arg)
{
	struct build_job *j = arg;

	if (j->sub != NULL)
		build_rec(j->ctx, j->sub, j->side, j->lo, j->hi, j->sc);
	else
		build_range(j->ctx, j->lo, j->hi, j->sc);
	scratch_free(j->sc);
	atomic_fetch_add(&j->ctx->idle, 1);
	return NULL;
}

/*
 * Hands [lo, m) (of the compact subtree sub's buffer side, or of the
 * photons when sub is NULL) to an idle thread and builds [m + 1, hi)
 * meanwhile; false, and nothing done, when no thread is idle or none can
 * be started.
 */
static bool
build_lend(struct build_ctx *c, struct kd_sub *sub, int side, size_t lo,
    size_t m, size_t hi, struct build_scratch *sc)
{
	struct build_job j;
	pthread_t t;

	if (hi - lo < BUILD_SPAWN_MIN || !take_thread(c))
		return false;
	j.ctx = c;
	j.sub = sub;
	j.side = side;
	j.lo = lo;
	j.hi = m;
	/* The thread's scratch comes from here, so that a failure leaves
	 * the range to this thread. */
	j.sc = sub != NULL ? scratch_new(0, m - lo < RADIX_MAX ? m - lo :
	    RADIX_MAX) : scratch_new(m - lo < COMPACT_MAX ? m - lo :
	    COMPACT_MAX, m - lo < RADIX_MAX ? m - lo : RADIX_MAX);
	if (j.sc != NULL && pthread_create(&t, NULL, build_thread, &j) == 0) {
		if (sub != NULL)
			build_rec(c, sub, side, m + 1, hi, sc);
		else
			build_range(c, m + 1, hi, sc);
		/* Idle while joining: lend this place. */
		atomic_fetch_add(&c->idle, 1);
		pthread_join(t, NULL);
		atomic_fetch_sub(&c->idle, 1);
		return true;
	}
	scratch_free(j.sc);
	/* No thread after all: carry on alone. */
	atomic_fetch_add(&c->idle, 1);
	return false;
}

/*
 * Builds the subtree over the compact records [lo, hi) (in sub's buffer
 * side) of a subtree of at most RADIX_MAX photons, as build_range would
 * over its photons.
 */
static void
build_rec(struct build_ctx *c, struct kd_sub *sub, int side, size_t lo,
    size_t hi, struct build_scratch *sc)
{
	while (hi - lo > 1) {
		size_t m = lo + (hi - lo) / 2;
		struct kd_rec *r = sub->rec[side];
		int ax = widest_axis_rec(r, lo, hi);

		if (hi - lo >= RADIX_MIN && hi - lo <= RADIX_MAX) {
			side = !side;
			select_radix(r, sub->rec[side], lo, hi, m, ax, sc);
			r = sub->rec[side];
		} else
			select_kth_rec(r, (ptrdiff_t)lo, (ptrdiff_t)hi,
			    (ptrdiff_t)m, ax);
		sub->fin[m] = r[m].idx | (uint32_t)ax << REC_AXIS_SHIFT;
		if (build_lend(c, sub, side, lo, m, hi, sc))
			return;
		/* Recurse on the left, loop on the right. */
		build_rec(c, sub, side, lo, m, sc);
		lo = m + 1;
	}
	if (hi - lo == 1)
		sub->fin[lo] = sub->rec[side][lo].idx |
		    (uint32_t)PM_KD_LEAF << REC_AXIS_SHIFT;
}

static inline void
set_axis(struct pm_photon *ph, int axis)
{
	ph->flags = (uint8_t)((ph->flags & ~PM_KD_AXIS_MASK) | axis);
}

/* The subtree over the photons [lo, hi), at most RADIX_MAX of them, built
 * on compact records, then the photons moved to their places. */
static void
build_compact(struct build_ctx *c, size_t lo, size_t hi,
    struct build_scratch *sc)
{
	struct pm_photon *p = c->p + lo, *out = sc->buf;
	struct kd_sub sub;
	size_t n = hi - lo, i;

	sub.rec[0] = sc->rec;
	sub.rec[1] = sc->buf;
	sub.fin = sc->fin;
	for (i = 0; i < n; i++) {
		memcpy(sub.rec[0][i].pos, p[i].pos, sizeof(p[i].pos));
		sub.rec[0][i].idx = (uint32_t)i;
	}
	build_rec(c, &sub, 0, 0, n, sc);
	/* The records are done with: buf takes the photons. */
	for (i = 0; i < n; i++) {
		out[i] = p[sub.fin[i] & REC_IDX_MASK];
		set_axis(&out[i], (int)(sub.fin[i] >> REC_AXIS_SHIFT));
	}
	memcpy(p, out, n * sizeof(*p));
}

/*
 * The top levels' selections are where one thread works while the others
 * wait: on 1M photons the first level's pass was 8.3 of the build's 130
 * ms, and all of it serial.  So a range of SPLIT_MIN photons or more is
 * narrowed around its sampled keys in two halves, each partitioned on
 * its own (by an idle thread when there is one), then the halves' parts
 * exchanged into place: [< a | in [a, b] | > b] of each half makes the
 * whole range's.  Every range that large is split so, whatever the
 * thread count, so the tree stays the same bits on any number of
 * threads.
 */
#ifndef SPLIT_MIN
#define SPLIT_MIN	(1 << 19)
#endif
/* A larger sample for these (FR_SAMPLE's 256 left 16% of 1M photons
 * between the keys, a serial pass of their own after the split): the
 * same 2.5 sigma either side, 1.25 sqrt(SPLIT_SAMPLE) ranks, leaves 4%. */
#define SPLIT_SAMPLE	4096
#define SPLIT_GAP	80

struct split_job {
	struct pm_photon *p;
	ptrdiff_t lo, hi, lt, gt;
	float a, b;
	int ax;
};

static void *
split_thread(void *arg)
{
	struct split_job *j = arg;

	partition_ab_ph(j->p, j->lo, j->hi, j->a, j->b, j->ax, &j->lt, &j->gt);
	return NULL;
}

/* The blocks [s, s + x) and [s + x, s + x + y), each of one kind, as
 * the second's records then the first's, in min(x, y) swaps: the order
 * within a block is not kept. */
static void
exchange(struct pm_photon *p, ptrdiff_t s, ptrdiff_t x, ptrdiff_t y)
{
	if (y <= x)
		swap_blocks_ph(p, s, s + x, y);
	else
		swap_blocks_ph(p, s, s + y, x);
}

static void
narrow_split(struct build_ctx *c, ptrdiff_t *lo, ptrdiff_t *hi, ptrdiff_t k,
    int ax)
{
	struct pm_photon *p = c->p;
	struct split_job j[2];
	float smp[SPLIT_SAMPLE];
	ptrdiff_t mid = *lo + (*hi - *lo) / 2, la, ma, ha, lb, mb, lt, gt;
	pthread_t t;
	bool lent = false;
	float a, b;

	bracket_ph(p, *lo, *hi, k, ax, smp, SPLIT_SAMPLE, SPLIT_GAP, &a, &b);
	j[0] = (struct split_job){ p, *lo, mid, 0, 0, a, b, ax };
	j[1] = (struct split_job){ p, mid, *hi, 0, 0, a, b, ax };
	if (take_thread(c)) {
		lent = pthread_create(&t, NULL, split_thread, &j[1]) == 0;
		if (!lent)
			atomic_fetch_add(&c->idle, 1);
	}
	split_thread(&j[0]);
	if (lent) {
		pthread_join(t, NULL);
		atomic_fetch_add(&c->idle, 1);
	} else
		split_thread(&j[1]);
	/* [LA MA HA | LB MB HB] -> [LA LB MA MB HA HB] */
	la = j[0].lt - *lo;
	ma = j[0].gt - j[0].lt;
	ha = mid - j[0].gt;
	lb = j[1].lt - mid;
	mb = j[1].gt - j[1].lt;
	exchange(p, *lo + la + ma, ha, lb);		/* LA MA LB HA MB HB */
	exchange(p, *lo + la, ma, lb);			/* LA LB MA HA MB HB */
	exchange(p, *lo + la + lb + ma, ha, mb);	/* LA LB MA MB HA HB */
	lt = *lo + la + lb;
	gt = lt + ma + mb;
	narrow_to_ph(lo, hi, k, lt, gt);
}

/*
 * Builds the subtree over [lo, hi), lending its left half to another
 * thread when one is idle.  Recursion depth is the tree height, at most
 * 33.  Every range is split by the same code whichever thread runs it, so
 * the result does not depend on how the threads were lent.
 */
static void
build_range(struct build_ctx *c, size_t lo, size_t hi,
    struct build_scratch *sc)
{
	struct pm_photon *p = c->p;

	while (hi - lo > COMPACT_MAX) {
		size_t m = lo + (hi - lo) / 2;
		int ax = widest_axis_ph(p, lo, hi);
		ptrdiff_t l = (ptrdiff_t)lo, h = (ptrdiff_t)hi, w;

		/* select_kth's narrowing, in halves; a sample that does not
		 * halve the range (many equal keys) leaves it to select_kth */
		while ((w = h - l) >= SPLIT_MIN) {
			narrow_split(c, &l, &h, (ptrdiff_t)m, ax);
			if (h - l > w / 2)
				break;
		}
		select_kth_ph(p, l, h, (ptrdiff_t)m, ax);
		set_axis(&p[m], ax);
		if (build_lend(c, NULL, 0, lo, m, hi, sc))
			return;
		/* Recurse on the left, loop on the right. */
		build_range(c, lo, m, sc);
		lo = m + 1;
	}
	build_compact(c, lo, hi, sc);
}

/* Balances p[0..n) in place into the implicit layout of kdtree.h. */
enum pm_err
pm_kdtree_build(struct pm_photon *p, size_t n, int threads,
    struct pm_error *err)
{
	struct build_ctx c;
	struct build_scratch *sc;

	if ((uint64_t)n >= (uint64_t)1 << 32)
		return pm_fail(err, PM_ERR_LIMIT,
		    "kdtree: %zu photons, expected fewer than 2^32", n);
	if (n == 0)
		return PM_OK;
	if (threads < 1)
		threads = 1;
	if (threads > BUILD_MAX_THREADS)
		threads = BUILD_MAX_THREADS;
	sc = scratch_new(n < COMPACT_MAX ? n : COMPACT_MAX,
	    n < RADIX_MAX ? n : RADIX_MAX);
	if (sc == NULL)
		return pm_fail(err, PM_ERR_NOMEM,
		    "kdtree: no memory to build a tree of %zu photons", n);
	c.p = p;
	atomic_init(&c.idle, threads - 1);
	build_range(&c, 0, n, sc);
	scratch_free(sc);
	return PM_OK;
}
/*
 * The largest float strictly below w (w >= 0), so that "d2 < w" becomes
 * "d2 <= below(w)" and one inclusive test serves before and after the
 * heap is full.
 */
static inline float
below(float w)
{
	uint32_t u;

	if (!(w > 0.0f))
		return -1.0f;
	memcpy(&u, &w, sizeof(u));
	u--;
	memcpy(&w, &u, sizeof(w));
	return w;
}

/*
 * Replaces the top of the max-heap h[0..cnt) with (d2, idx).  The choice
 * of the larger child is arithmetic rather than a branch: it is a coin
 * toss to the branch predictor.
 */
static inline void
heap_replace(struct pm_knn *h, size_t cnt, float d2, uint32_t idx)
{
	size_t i = 0, c;

	while ((c = 2 * i + 1) < cnt) {
		if (c + 1 < cnt)
			c += h[c + 1].d2 > h[c].d2;
		if (!(h[c].d2 > d2))
			break;
		h[i] = h[c];
		i = c;
	}
	h[i].d2 = d2;
	h[i].idx = idx;
}

/*
 * A deferred far child of a k-nearest query, with the distances from q to
 * its cell along each axis (each one a lower bound on |q - photon| there,
 * in float as well, since rounding is monotonic) and the squared distance
 * they bound, summed in the same order as kd_dist2 so that it never
 * exceeds the float distance of any photon in the cell.
 */
struct kd_iframe {
	uint32_t lo, hi;
	float d2, off[3];
};

/* The k-nearest search state, kept in registers by inlining. */
struct knn_state {
	struct pm_knn *out;	/* the max-heap */
	size_t k, cnt;
	float lim;		/* only d2 <= lim can still be a neighbour */
};

/* Makes h[0..cnt) a max-heap on d2 (Floyd: sift-downs from the last
 * parent up, O(cnt)). */
static void
heap_make(struct pm_knn *h, size_t cnt)
{
	size_t r;

	for (r = cnt / 2; r-- > 0;) {
		struct pm_knn t = h[r];
		size_t i = r, c;

		while ((c = 2 * i + 1) < cnt) {
			if (c + 1 < cnt)
				c += h[c + 1].d2 > h[c].d2;
			if (!(h[c].d2 > t.d2))
				break;
			h[i] = h[c];
			i = c;
		}
		h[i] = t;
	}
}

/*
 * Until k photons are found the bound does not move, so the first k are
 * appended as they come and made a heap once, when the k-th arrives (or
 * at the end, if fewer): a sift-up per photon cost more, and with a
 * batch's guessed bound most offers come before the heap is full.
 */
static inline void
knn_offer(struct knn_state *s, float d2, uint32_t idx)
{
	if (s->cnt < s->k) {
		s->out[s->cnt].d2 = d2;
		s->out[s->cnt++].idx = idx;
		if (s->cnt == s->k) {
			heap_make(s->out, s->k);
			s->lim = below(s->out[0].d2);
		}
	} else {
		heap_replace(s->out, s->cnt, d2, idx);
		s->lim = below(s->out[0].d2);
	}
}

#if defined(__GNUC__) || defined(__clang__)
#define kd_prefetch_line(a)	__builtin_prefetch(a)
#else
#define kd_prefetch_line(a)	((void)(a))
#endif

/*
 * Prefetches what a walk reads after node m of [lo, hi): the roots of
 * both children, or every line of the range when they are buckets.  A
 * macro, since GCC drops a function made of prefetches.
 */
#define KD_PREFETCH_CHILDREN(p, lo, m, hi)				\
	KD_PREFETCH_CHILDREN_B(p, lo, m, hi, KD_BUCKET)
#define KD_PREFETCH_CHILDREN_B(p, lo, m, hi, bucket) do {		\
	if ((m) - (lo) > (bucket)) {					\
		kd_prefetch_line(&(p)[(lo) + ((m) - (lo)) / 2]);	\
		kd_prefetch_line(&(p)[(m) + 1 + ((hi) - (m) - 1) / 2]);	\
	} else {							\
		const char *x_ = (const char *)&(p)[lo];		\
		const char *e_ = (const char *)&(p)[hi];		\
									\
		for (; x_ < e_; x_ += 64)				\
			kd_prefetch_line(x_);				\
	}								\
} while (0)

#if defined(__SSE2__)
/* The squared distances to (qx, qy, qz) of the four photons at ph, their
 * positions loaded as rows and transposed: kd_dist2's arithmetic, in its
 * order, four at a time (the k-nearest and the range scans). */
static inline __m128
d2_sse2(const struct pm_photon *ph, __m128 qx, __m128 qy, __m128 qz)
{
	__m128 x = _mm_loadu_ps(ph[0].pos), y = _mm_loadu_ps(ph[1].pos),
	    z = _mm_loadu_ps(ph[2].pos), w = _mm_loadu_ps(ph[3].pos);
	__m128 dx, dy, dz;

	_MM_TRANSPOSE4_PS(x, y, z, w);
	dx = _mm_sub_ps(x, qx);
	dy = _mm_sub_ps(y, qy);
	dz = _mm_sub_ps(z, qz);
	return _mm_add_ps(_mm_add_ps(_mm_mul_ps(dx, dx), _mm_mul_ps(dy, dy)),
	    _mm_mul_ps(dz, dz));
}
#endif

/*
 * The squared distances from q of the bucket p[lo, lo + nb) into
 * dd[0..nb), and into ci[0..) the offsets of those within lim that pass
 * the filter, in order; returns how many there are.  No branch per photon
 * (most fail, and a branch on each would be mispredicted about as often
 * as not, and would stall the loads behind it).  With SSE, four photons
 * at a time: their positions loaded as rows and transposed, the same
 * products and sums in the same order as kd_dist2, so the same floats.
 */
KD_INLINE uint32_t
bucket_scan(const struct pm_photon *p, uint32_t lo, uint32_t nb,
    const float q[3], float lim, uint8_t mask, uint8_t want, float *dd,
    uint32_t *ci)
{
	uint32_t i = 0, c = 0;
	/* Most lookups filter nothing (mask 0, want 0): then the flags'
	 * bytes need not be read, a third of the scan's instructions. */
	bool filter = (mask | want) != 0;

#if defined(__SSE2__)
	__m128 qx = _mm_set1_ps(q[0]), qy = _mm_set1_ps(q[1]),
	    qz = _mm_set1_ps(q[2]), vl = _mm_set1_ps(lim);

	for (; i + 4 <= nb; i += 4) {
		const struct pm_photon *ph = &p[lo + i];
		__m128 d2 = d2_sse2(ph, qx, qy, qz);
		unsigned in;

		_mm_storeu_ps(&dd[i], d2);
		/* <= is false for NaN, as in the scalar test. */
		in = (unsigned)_mm_movemask_ps(_mm_cmple_ps(d2, vl));
		if (filter)
			in &= (unsigned)((ph[0].flags & mask) == want) |
			    (unsigned)((ph[1].flags & mask) == want) << 1 |
			    (unsigned)((ph[2].flags & mask) == want) << 2 |
			    (unsigned)((ph[3].flags & mask) == want) << 3;
		ci[c] = i;
		c += in & 1;
		ci[c] = i + 1;
		c += in >> 1 & 1;
		ci[c] = i + 2;
		c += in >> 2 & 1;
		ci[c] = i + 3;
		c += in >> 3 & 1;
	}
#endif
	for (; i < nb; i++) {
		const struct pm_photon *ph = &p[lo + i];
		float d2 = kd_dist2(ph->pos, q);

		dd[i] = d2;
		ci[c] = i;
		c += (d2 <= lim) & ((ph->flags & mask) == want);
	}
	return c;
}

/*
 * Offers the bucket [lo, hi) in two passes: distances and the filter
 * first, into a list of the photons that pass the current bound
 * (bucket_scan); then the offers, which re-check the bound as it
 * tightens.
 */
static inline void
knn_scan(struct knn_state *s, const struct pm_photon *p, uint32_t lo,
    uint32_t hi, const float q[3], uint8_t mask, uint8_t want)
{
	float dd[KD_BUCKET];
	uint32_t ci[KD_BUCKET];
	uint32_t i, c;

	c = bucket_scan(p, lo, hi - lo, q, s->lim, mask, want, dd, ci);
	for (i = 0; i < c; i++) {
		float d2 = dd[ci[i]];

		if (d2 <= s->lim)
			knn_offer(s, d2, lo + ci[i]);
	}
}

/*
 * The k-nearest walk: descend to the bucket of q, deferring far children
 * with their cell distances, then resume from the nearest deferred child
 * whose cell is still within the bound.  Returns how many were found.
 */
static inline size_t
knn_walk(const struct pm_photon *p, uint32_t n, const float q[3], size_t k,
    float max_d2, uint8_t mask, uint8_t want, struct pm_knn *out,
    bool heap_always)
{
	struct kd_iframe st[KD_STACK];
	struct knn_state s;
	size_t sp = 0;
	uint32_t lo = 0, hi = n;
	float off[3] = { 0.0f, 0.0f, 0.0f };

	s.out = out;
	s.k = k;
	s.cnt = 0;
	s.lim = max_d2;
	for (;;) {
		while (hi - lo > KD_BUCKET) {
			uint32_t m = lo + (hi - lo) / 2;
			const struct pm_photon *ph = &p[m];
			int ax = ph->flags & PM_KD_AXIS_MASK;
			float d2 = kd_dist2(ph->pos, q), diff, dd, o[3];

			/*
			 * Ask the memory for what comes next: the roots of
			 * both children, or every line of both when they are
			 * buckets.  On a tree larger than the caches a query
			 * waits on memory one node after the other; this
			 * fetches the next while the node itself is decided,
			 * and the far child is often visited later.
			 */
			KD_PREFETCH_CHILDREN(p, lo, m, hi);
			if (d2 <= s.lim && (ph->flags & mask) == want)
				knn_offer(&s, d2, m);
			/* A leaf mark here means a corrupt tree: stay in
			 * bounds, the answer is wrong anyway. */
			ax = ax > 2 ? 2 : ax;
			diff = q[ax] - ph->pos[ax];
			o[0] = off[0];
			o[1] = off[1];
			o[2] = off[2];
			o[ax] = fabsf(diff);
			dd = o[0] * o[0] + o[1] * o[1] + o[2] * o[2];
			if (dd <= s.lim) {
				st[sp].lo = diff < 0.0f ? m + 1 : lo;
				st[sp].hi = diff < 0.0f ? hi : m;
				st[sp].d2 = dd;
				st[sp].off[0] = o[0];
				st[sp].off[1] = o[1];
				st[sp].off[2] = o[2];
				sp++;
			}
			if (diff < 0.0f)
				hi = m;
			else
				lo = m + 1;
		}
		knn_scan(&s, p, lo, hi, q, mask, want);
		for (;;) {
			if (sp == 0) {
				if (heap_always && s.cnt < s.k)
					heap_make(s.out, s.cnt);
				return s.cnt;
			}
			sp--;
			if (st[sp].d2 <= s.lim)
				break;
		}
		lo = st[sp].lo;
		hi = st[sp].hi;
		off[0] = st[sp].off[0];
		off[1] = st[sp].off[1];
		off[2] = st[sp].off[2];
	}
}

/*
 * Batches are walked in Morton order of their points (a Z-order curve
 * through their bounding box), so that consecutive queries share the
 * upper tree and often buckets in the caches, and each query has a sure
 * bound from the one before it: the largest distance from its point to
 * the k neighbours just found (photons that pass the filter and are in
 * the caches), within which there are at least k photons, so the k
 * nearest lie within it too.  A walk that starts with its bound takes
 * only photons that may stay and prunes from the first cell, where one
 * without must take the first k it meets and then replace them, a heap
 * fix-up each; with the k-th distance known in advance the same queries
 * ran twice as fast.  (Walking several queries at once, a step of each in
 * turn with prefetches, so that their memory misses overlap, was measured
 * slower: the queries are bound by their branches and arithmetic more
 * than by memory, even on 10M photons.  So were a first bound from the
 * subtree around the point, and a buffer of candidates cut down to the
 * k nearest by bisection instead of a heap; in this round again, a
 * buffer of 2k to 4k candidates cut to k by quickselect, with and
 * without the guess below: 0.8x to 0.9x.)  The sure bound is still
 * loose; the guess below is tighter.
 */
/* Spreads the low 21 bits of x to every third bit. */
static inline uint64_t
morton_spread(uint64_t x)
{
	x &= 0x1fffff;
	x = (x | x << 32) & 0x1f00000000ffffULL;
	x = (x | x << 16) & 0x1f0000ff0000ffULL;
	x = (x | x << 8) & 0x100f00f00f00f00fULL;
	x = (x | x << 4) & 0x10c30c30c30c30c3ULL;
	x = (x | x << 2) & 0x1249249249249249ULL;
	return x;
}

/* A query's place on the curve and its index, sorted by radix. */
struct kd_order {
	uint64_t key;
	uint32_t i;
};

/*
 * Fills ord[0..nq) with the queries in Morton order of their points over
 * their bounding box (21 bits an axis), by an LSD radix sort of 11-bit
 * digits through tmp; stable, so equal keys keep their order.  NaN and
 * infinite coordinates sort anywhere: only the order changes, never a
 * result.
 */
static void
morton_order(const float *q, size_t nq, struct kd_order *ord,
    struct kd_order *tmp)
{
	float mn[3], mx[3], sc[3];
	size_t i, cnt[1 << 11];
	int a, pass;

	for (a = 0; a < 3; a++) {
		mn[a] = INFINITY;
		mx[a] = -INFINITY;
	}
	for (i = 0; i < nq; i++)
		for (a = 0; a < 3; a++) {
			float v = q[3 * i + a];

			mn[a] = v < mn[a] ? v : mn[a];
			mx[a] = v > mx[a] ? v : mx[a];
		}
	for (a = 0; a < 3; a++)
		sc[a] = mx[a] > mn[a] && isfinite(mx[a] - mn[a]) ?
		    2097151.0f / (mx[a] - mn[a]) : 0.0f;
	for (i = 0; i < nq; i++) {
		uint64_t key = 0;

		for (a = 0; a < 3; a++) {
			float t = (q[3 * i + a] - mn[a]) * sc[a];
			uint64_t u = t >= 0.0f && t <= 2097151.0f ?
			    (uint64_t)t : 0;

			key |= morton_spread(u) << a;
		}
		ord[i].key = key;
		ord[i].i = (uint32_t)i;
	}
	for (pass = 0; pass < 6; pass++) {
		struct kd_order *t;
		int sh = 11 * pass;
		size_t sum = 0;

		memset(cnt, 0, sizeof(cnt));
		for (i = 0; i < nq; i++)
			cnt[(ord[i].key >> sh) & 0x7ff]++;
		for (i = 0; i < (1 << 11); i++) {
			size_t c = cnt[i];

			cnt[i] = sum;
			sum += c;
		}
		for (i = 0; i < nq; i++)
			tmp[cnt[(ord[i].key >> sh) & 0x7ff]++] = ord[i];
		t = ord;
		ord = tmp;
		tmp = t;
	}
	/* Six passes: the result is back in the caller's ord. */
}

/*
 * Each query of a batch first tries a guess at its own k-th distance, the
 * k-th distance of its predecessor (a neighbour on the curve) widened by
 * KNN_GUESS / sqrt(k) (the relative spread of the k-th neighbour's squared
 * distance over nearby points goes as 1 / sqrt(k) where the photons lie
 * on surfaces).  A walk bounded by g that finds k photons has found the k
 * nearest: every photon it did not consider is farther than g, so farther
 * than all k.  If it finds fewer, the query is walked again with the
 * bound that is sure to hold k (above).  The guess is tighter than that
 * bound, and a tighter bound is fewer buckets and fewer heap replacements:
 * measured alone on 1M cornell-box photons, 1.26x (k = 50) and 1.5x
 * (k = 200) the queries per second, 1.3x and 1.6x on 10M; one query in
 * twenty (1M) to ten (10M) is walked twice at k = 50.  (KNN_GUESS from
 * 2.5 to 4 gave the same rates within 5%.)
 */
#ifndef KNN_GUESS
#define KNN_GUESS	3.5f
#endif
/* Many k-nearest queries at once; see kdtree.h. */
void
pm_kdtree_knn_batch(const struct pm_photon *p, size_t n, const float *q,
    size_t nq, size_t k, float max_d2, uint8_t mask, uint8_t want,
    struct pm_knn *out, size_t *found)
{
	struct kd_order *ord = NULL;
	size_t i, prev = 0;
	float gf;

	if (n == 0 || k == 0 || (uint64_t)n > UINT32_MAX ||
	    !(max_d2 >= 0.0f) || (uint64_t)nq > UINT32_MAX) {
		for (i = 0; i < nq; i++)
			found[i] = 0;
		return;
	}
	/* Sorting pays only when there are queries enough to share paths;
	 * without memory for it, the given order gives the same neighbours
	 * (ties perhaps chosen otherwise). */
	if (nq >= 64 && (ord = malloc(2 * nq * sizeof(*ord))) != NULL)
		morton_order(q, nq, ord, ord + nq);
	gf = 1.0f + KNN_GUESS / sqrtf((float)k);
	for (i = 0; i < nq; i++) {
		size_t j = ord != NULL ? ord[i].i : i, t;
		float lim = max_d2, guess, r = 0.0f;

		if (i > 0 && found[prev] == k) {
			guess = out[prev * k].d2 * gf;
			if (guess < max_d2) {
				found[j] = knn_walk(p, (uint32_t)n, &q[3 * j], k,
				    guess, mask, want, &out[j * k], true);
				if (found[j] == k) {
					prev = j;
					continue;
				}
			}
			/* The sure bound, needed only now. */
			for (t = 0; t < k; t++) {
				float d = kd_dist2(p[out[prev * k + t].idx].pos,
				    &q[3 * j]);

				r = d > r ? d : r;
			}
			lim = r < max_d2 ? r : max_d2;
		}
		found[j] = knn_walk(p, (uint32_t)n, &q[3 * j], k, lim, mask,
		    want, &out[j * k], true);
		prev = j;
	}
	free(ord);
}

/* One k-nearest query, degenerate arguments answering nothing; heap: the
 * result a max-heap even when fewer than k were found. */
static size_t
knn_one(const struct pm_photon *p, size_t n, const float q[3], size_t k,
    float max_d2, uint8_t mask, uint8_t want, struct pm_knn *out, bool heap)
{
	if (n == 0 || k == 0 || (uint64_t)n > UINT32_MAX || !(max_d2 >= 0.0f))
		return 0;
	return knn_walk(p, (uint32_t)n, q, k, max_d2, mask, want, out, heap);
}

size_t
pm_kdtree_knn(const struct pm_photon *p, size_t n, const float q[3],
    size_t k, float max_d2, uint8_t mask, uint8_t want, struct pm_knn *out)
{
	return knn_one(p, n, q, k, max_d2, mask, want, out, true);
}

size_t
pm_kdtree_knn_unordered(const struct pm_photon *p, size_t n, const float q[3],
    size_t k, float max_d2, uint8_t mask, uint8_t want, struct pm_knn *out)
{
	return knn_one(p, n, q, k, max_d2, mask, want, out, false);
}

static inline int
knn_less(const struct pm_knn *a, const struct pm_knn *b)
{
	return a->d2 < b->d2 || (a->d2 == b->d2 && a->idx < b->idx);
}

static void
knn_sift(struct pm_knn *r, size_t i, size_t n)
{
	struct pm_knn t = r[i];

	for (;;) {
		size_t c = 2 * i + 1;

		if (c >= n)
			break;
		if (c + 1 < n && knn_less(&r[c], &r[c + 1]))
			c++;
		if (!knn_less(&t, &r[c]))
			break;
		r[i] = r[c];
		i = c;
	}
	r[i] = t;
}

/* Sorts neighbours by increasing distance, then index (heapsort). */
void
pm_knn_sort(struct pm_knn *r, size_t count)
{
	size_t i;

	for (i = count / 2; i-- > 0;)
		knn_sift(r, i, count);
	for (i = count; i-- > 1;) {
		struct pm_knn t = r[0];

		r[0] = r[i];
		r[i] = t;
		knn_sift(r, 0, i);
	}
}

/* Every photon within max_d2 of q passing the filter; the total count.
 * The range walk's, so that one walk is kept fast, not two. */
size_t
pm_kdtree_radius(const struct pm_photon *p, size_t n, const float q[3],
    float max_d2, uint8_t mask, uint8_t want, struct pm_knn *out, size_t cap)
{
	struct pm_kd_range it;
	size_t cnt = 0;
	uint32_t idx;
	float d2;

	pm_kdtree_range_init(&it, p, n, q, max_d2, mask, want);
	while (pm_kdtree_range_next(&it, &idx, &d2)) {
		if (cnt < cap) {
			out[cnt].d2 = d2;
			out[cnt].idx = idx;
		}
		cnt++;
	}
	return cnt;
}

_Static_assert(sizeof(((struct pm_kd_range *)0)->st) /
    sizeof(((struct pm_kd_range *)0)->st[0]) == KD_STACK,
    "struct pm_kd_range's stack must hold KD_STACK subtrees");

/* A descent of the range walk finds at most one match per level (the
 * tree is at most 33 deep) and then a bucket; the vector scans may write
 * up to 8 entries past their last match. */
#define KD_RANGE_DESCENT	(33 + KD_RBUCKET + 8)
_Static_assert(KD_RANGE_DESCENT <= PM_KD_RANGE_BUF &&
    KD_RBUCKET <= KD_BUCKET,
    "struct pm_kd_range's buffer must hold one descent's matches");

/* The bucket scans of the range walk, by instruction set (kd_isa_force). */
enum {
	KD_ISA_BEST = 0,
	KD_ISA_C = 1,
	KD_ISA_SSE2 = 2,
	KD_ISA_AVX2 = 3,
};

#if (defined(__x86_64__) || defined(__i386__)) && defined(__SSE2__) && \
    (defined(__GNUC__) || defined(__clang__))
#define KD_X86	1
#include <immintrin.h>
#else
#define KD_X86	0
#endif

/* The instruction set tests force; 0: the best the CPU has. */
static atomic_int kd_isa_force;

/* The best instruction set this CPU runs, at most the forced one. */
static int
kd_isa_pick(void)
{
	int f = atomic_load_explicit(&kd_isa_force, memory_order_relaxed);
	int best = KD_ISA_C;

#if KD_X86
	best = __builtin_cpu_supports("avx2") &&
	    __builtin_cpu_supports("popcnt") ? KD_ISA_AVX2 : KD_ISA_SSE2;
#endif
	return f == KD_ISA_BEST || f > best ? best : f;
}

int
pm_kdtree_range_isa(int isa)
{
	atomic_store_explicit(&kd_isa_force, isa < 0 || isa > KD_ISA_AVX2 ?
	    KD_ISA_BEST : isa, memory_order_relaxed);
	return kd_isa_pick();
}

/* Starts a radius query that yields photons one at a time. */
void
pm_kdtree_range_init(struct pm_kd_range *r, const struct pm_photon *p,
    size_t n, const float q[3], float max_d2, uint8_t mask, uint8_t want)
{
	r->p = p;
	r->q[0] = q[0];
	r->q[1] = q[1];
	r->q[2] = q[2];
	r->max_d2 = max_d2;
	r->mask = mask;
	r->want = want;
	r->isa = (uint8_t)kd_isa_pick();
	r->nbuf = r->ibuf = 0;
	/* Nothing to walk in trees a query cannot index, as
	 * pm_kdtree_radius. */
	r->sp = n == 0 || (uint64_t)n > UINT32_MAX || !(max_d2 >= 0.0f) ?
	    0 : 1;
	r->st[0].lo = 0;
	r->st[0].hi = (uint32_t)n;
	r->st[0].off[0] = r->st[0].off[1] = r->st[0].off[2] = 0.0f;
}

/*
 * One descent of the range walk: takes the last deferred subtree, walks
 * down to the bucket of q, appending the nodes of the way that match to
 * r's buffer at *c, and deferring each far child whose cell comes within
 * the radius: the distance from q to the cell is kept per axis as in the
 * k-nearest walk (a tighter test than the distance to the splitting plane
 * alone, which visited a third more buckets).  No branch on the data: the
 * match is written and counted or not, the far child pushed and kept or
 * not (the push is always in bounds: the stack holds at most one subtree
 * per level), the next range picked by selects.  The bucket reached goes
 * to [*lo, *hi); false when there was nothing left to descend.
 */
KD_INLINE bool
range_descend(struct pm_kd_range *r, uint32_t *plo, uint32_t *phi,
    uint32_t *bidx, float *bd2, uint32_t *pc)
{
	const struct pm_photon *p = r->p;
	float q0 = r->q[0], q1 = r->q[1], q2 = r->q[2], max_d2 = r->max_d2;
	uint8_t mask = r->mask, want = r->want;
	uint32_t sp = r->sp, lo, hi, c = *pc;
	float o0, o1, o2;

	if (sp == 0)
		return false;
	sp--;
	lo = r->st[sp].lo;
	hi = r->st[sp].hi;
	o0 = r->st[sp].off[0];
	o1 = r->st[sp].off[1];
	o2 = r->st[sp].off[2];
	while (hi - lo > KD_RBUCKET) {
		uint32_t m = lo + (hi - lo) / 2;
		const struct pm_photon *ph = &p[m];
		int ax = ph->flags & PM_KD_AXIS_MASK;
		float dx = ph->pos[0] - q0, dy = ph->pos[1] - q1,
		    dz = ph->pos[2] - q2;
		float d = dx * dx + dy * dy + dz * dz, diff, f[3];
		bool left;

		/* The roots of both children, as in knn_walk; buckets
		 * are fetched whole when reached (range_fill). */
		if (m - lo > KD_RBUCKET) {
			kd_prefetch_line(&p[lo + (m - lo) / 2]);
			kd_prefetch_line(&p[m + 1 + (hi - m - 1) / 2]);
		}
		bidx[c] = m;
		bd2[c] = d;
		c += (d <= max_d2) & ((ph->flags & mask) == want);
		/* A leaf mark here means a corrupt tree: stay in bounds,
		 * the answer is wrong anyway.  The axis indexes, rather
		 * than selects: GCC made branches of selects on it, which
		 * the predictor missed. */
		ax = ax > 2 ? 2 : ax;
		diff = r->q[ax] - ph->pos[ax];
		f[0] = o0;
		f[1] = o1;
		f[2] = o2;
		f[ax] = fabsf(diff);
		left = diff < 0.0f;
		r->st[sp].lo = left ? m + 1 : lo;
		r->st[sp].hi = left ? hi : m;
		r->st[sp].off[0] = f[0];
		r->st[sp].off[1] = f[1];
		r->st[sp].off[2] = f[2];
		sp += f[0] * f[0] + f[1] * f[1] + f[2] * f[2] <= max_d2;
		lo = left ? lo : m + 1;
		hi = left ? m : hi;
	}
	r->sp = sp;
	*plo = lo;
	*phi = hi;
	*pc = c;
	return true;
}

/*
 * The bucket scans: the photons of p[lo, lo + nb) within lim that pass
 * the filter, in order, their indices to oi[0..) and squared distances
 * to od[0..); return how many.  Distances are computed as kd_dist2 does,
 * the same products and sums in the same order (and no fused
 * multiply-add), so the same floats.
 */

/* Plain C, without a branch per photon (most fail, unpredictably). */
KD_INLINE uint32_t
scan_c(const struct pm_photon *p, uint32_t lo, uint32_t nb, const float q[3],
    float lim, uint8_t mask, uint8_t want, uint32_t *oi, float *od)
{
	uint32_t i, c = 0;

	for (i = lo; i < lo + nb; i++) {
		float d2 = kd_dist2(p[i].pos, q);

		oi[c] = i;
		od[c] = d2;
		c += (d2 <= lim) & ((p[i].flags & mask) == want);
	}
	return c;
}

/* Bit j set if photon ph[j] (j < n) passes the filter. */
KD_INLINE unsigned
scan_flags(const struct pm_photon *ph, unsigned n, uint8_t mask, uint8_t want)
{
	unsigned j, in = 0;

	for (j = 0; j < n; j++)
		in |= (unsigned)((ph[j].flags & mask) == want) << j;
	return in;
}

#if KD_X86
/* SSE2: four photons at a time, their positions loaded as rows and
 * transposed; the matches of each four, usually none or few, taken from
 * the comparison's bits. */
KD_INLINE uint32_t
scan_sse2(const struct pm_photon *p, uint32_t lo, uint32_t nb,
    const float q[3], float lim, uint8_t mask, uint8_t want, uint32_t *oi,
    float *od)
{
	__m128 qx = _mm_set1_ps(q[0]), qy = _mm_set1_ps(q[1]),
	    qz = _mm_set1_ps(q[2]), vl = _mm_set1_ps(lim);
	/* Most lookups filter nothing (mask 0, want 0): then the flags'
	 * bytes need not be read. */
	bool filter = (mask | want) != 0;
	uint32_t i = 0, c = 0, j;
	float t[4];

	for (; i + 4 <= nb; i += 4) {
		const struct pm_photon *ph = &p[lo + i];
		__m128 d2 = d2_sse2(ph, qx, qy, qz);
		unsigned in;

		/* <= is false for NaN, as in the scalar test. */
		in = (unsigned)_mm_movemask_ps(_mm_cmple_ps(d2, vl));
		if (filter)
			in &= scan_flags(ph, 4, mask, want);
		_mm_storeu_ps(t, d2);
		/* Each photon written, the count moved past the matches:
		 * no branch a match would mispredict. */
		for (j = 0; j < 4; j++) {
			oi[c] = lo + i + j;
			od[c] = t[j];
			c += in >> j & 1;
		}
	}
	return c + scan_c(p, lo + i, nb - i, q, lim, mask, want, oi + c,
	    od + c);
}

/* For each 4-bit mask, the lanes of its set bits in order, a byte each
 * (the rest 0): the permutation that moves a half's matches to its
 * front. */
static const uint32_t kd_compact4[16] = {
	0x00000000, 0x00000000, 0x00000001, 0x00000100,
	0x00000002, 0x00000200, 0x00000201, 0x00020100,
	0x00000003, 0x00000300, 0x00000301, 0x00030100,
	0x00000302, 0x00030200, 0x00030201, 0x03020100,
};

/* The AVX2 scan, eight photons at a time: photons j and j + 4 share a
 * row, the two 128-bit halves transposed side by side.  A bucket not a
 * multiple of eight ends with the last eight photons again, the lanes
 * already scanned masked off, rather than a slower tail. */
__attribute__((target("avx2,popcnt")))
KD_INLINE uint32_t
scan_avx2(const struct pm_photon *p, uint32_t lo, uint32_t nb,
    const float q[3], float lim, uint8_t mask, uint8_t want, uint32_t *oi,
    float *od)
{
	__m256 qx = _mm256_set1_ps(q[0]), qy = _mm256_set1_ps(q[1]),
	    qz = _mm256_set1_ps(q[2]), vl = _mm256_set1_ps(lim);
	bool filter = (mask | want) != 0;
	uint32_t i = 0, c = 0;

	if (nb < 8)
		return scan_c(p, lo, nb, q, lim, mask, want, oi, od);
	for (;;) {
		const struct pm_photon *ph;
		__m256 r0, r1, r2, r3, t0, t1, t2, t3, dx, dy, dz, d2;
		__m128i pl, ph_;
		unsigned in, keep = 0xffu;

		if (i + 8 > nb) {
			if (i == nb)
				break;
			keep = 0xffu << (i + 8 - nb) & 0xffu;
			i = nb - 8;
		}
		ph = &p[lo + i];
		r0 = _mm256_insertf128_ps(_mm256_castps128_ps256(
		    _mm_loadu_ps(ph[0].pos)), _mm_loadu_ps(ph[4].pos), 1);
		r1 = _mm256_insertf128_ps(_mm256_castps128_ps256(
		    _mm_loadu_ps(ph[1].pos)), _mm_loadu_ps(ph[5].pos), 1);
		r2 = _mm256_insertf128_ps(_mm256_castps128_ps256(
		    _mm_loadu_ps(ph[2].pos)), _mm_loadu_ps(ph[6].pos), 1);
		r3 = _mm256_insertf128_ps(_mm256_castps128_ps256(
		    _mm_loadu_ps(ph[3].pos)), _mm_loadu_ps(ph[7].pos), 1);
		t0 = _mm256_unpacklo_ps(r0, r1);	/* x0 x1 y0 y1 */
		t1 = _mm256_unpacklo_ps(r2, r3);	/* x2 x3 y2 y3 */
		t2 = _mm256_unpackhi_ps(r0, r1);	/* z0 z1 .. */
		t3 = _mm256_unpackhi_ps(r2, r3);	/* z2 z3 .. */
		dx = _mm256_sub_ps(_mm256_shuffle_ps(t0, t1, 0x44), qx);
		dy = _mm256_sub_ps(_mm256_shuffle_ps(t0, t1, 0xee), qy);
		dz = _mm256_sub_ps(_mm256_shuffle_ps(t2, t3, 0x44), qz);
		d2 = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(dx, dx),
		    _mm256_mul_ps(dy, dy)), _mm256_mul_ps(dz, dz));
		/* Ordered, quiet: false for NaN, as the scalar <=. */
		in = (unsigned)_mm256_movemask_ps(_mm256_cmp_ps(d2, vl,
		    _CMP_LE_OQ)) & keep;
		if (filter)
			in &= scan_flags(ph, 8, mask, want);
		/* Each half's matches moved to its front by a permutation
		 * from the table and stored whole, the count moved past
		 * them: no branch a match would mispredict. */
		pl = _mm_cvtepu8_epi32(_mm_cvtsi32_si128(
		    (int)kd_compact4[in & 15]));
		ph_ = _mm_cvtepu8_epi32(_mm_cvtsi32_si128(
		    (int)kd_compact4[in >> 4]));
		_mm_storeu_ps(od + c, _mm_permutevar_ps(
		    _mm256_castps256_ps128(d2), pl));
		_mm_storeu_si128((__m128i *)(oi + c), _mm_add_epi32(pl,
		    _mm_set1_epi32((int)(lo + i))));
		c += (uint32_t)__builtin_popcount(in & 15);
		_mm_storeu_ps(od + c, _mm_permutevar_ps(
		    _mm256_extractf128_ps(d2, 1), ph_));
		_mm_storeu_si128((__m128i *)(oi + c), _mm_add_epi32(ph_,
		    _mm_set1_epi32((int)(lo + i + 4))));
		c += (uint32_t)__builtin_popcount(in >> 4);
		i += 8;
	}
	return c;
}
#endif

/*
 * Fills r's buffer with the matches of as many descents as it has room
 * for, each descent's nodes then its bucket, so the photons come in the
 * same order whatever the scan.  One function per instruction set, the
 * descent inlined in each.
 */
#ifndef KD_FILL_DESCENTS
#define KD_FILL_DESCENTS	16
#endif
#define KD_RANGE_FILL(r, scan) do {					\
	uint32_t lo_[KD_FILL_DESCENTS], hi_[KD_FILL_DESCENTS];		\
	uint32_t nm_[KD_FILL_DESCENTS], ti_[PM_KD_RANGE_BUF];		\
	float td_[PM_KD_RANGE_BUF];					\
	uint32_t nd_, nt_, used_, c_, i_, t_, j_;				\
									\
	do {								\
		nd_ = nt_ = used_ = c_ = 0;				\
		while (nd_ < KD_FILL_DESCENTS && used_ +		\
		    KD_RANGE_DESCENT <= PM_KD_RANGE_BUF) {		\
			const char *x_, *e_;				\
									\
			t_ = nt_;					\
			if (!range_descend((r), &lo_[nd_], &hi_[nd_],	\
			    ti_, td_, &nt_))				\
				break;					\
			nm_[nd_] = nt_ - t_;				\
			used_ += nm_[nd_] + hi_[nd_] - lo_[nd_];	\
			x_ = (const char *)&(r)->p[lo_[nd_]];		\
			e_ = (const char *)&(r)->p[hi_[nd_]];		\
			for (; x_ < e_; x_ += 64)			\
				kd_prefetch_line(x_);			\
			nd_++;						\
		}							\
		for (i_ = t_ = 0; i_ < nd_; i_++) {			\
			/* Mostly none or one: a loop, not memcpy. */	\
			for (j_ = 0; j_ < nm_[i_]; j_++) {		\
				(r)->bidx[c_ + j_] = ti_[t_ + j_];	\
				(r)->bd2[c_ + j_] = td_[t_ + j_];	\
			}						\
			c_ += nm_[i_];					\
			t_ += nm_[i_];					\
			c_ += scan((r)->p, lo_[i_], hi_[i_] - lo_[i_],	\
			    (r)->q, (r)->max_d2, (r)->mask, (r)->want,	\
			    (r)->bidx + c_, (r)->bd2 + c_);		\
		}							\
	} while (c_ == 0 && (r)->sp > 0);				\
	(r)->nbuf = c_;							\
	(r)->ibuf = 0;							\
} while (0)

static void
range_fill_c(struct pm_kd_range *r)
{
	KD_RANGE_FILL(r, scan_c);
}

#if KD_X86
static void
range_fill_sse2(struct pm_kd_range *r)
{
	KD_RANGE_FILL(r, scan_sse2);
}

__attribute__((target("avx2,popcnt")))
static void
range_fill_avx2(struct pm_kd_range *r)
{
	KD_RANGE_FILL(r, scan_avx2);
}
#endif

/*
 * The traversal of a radius query, in steps: each step fills r's buffer
 * with the matches of one or more descents (range_descend), which
 * pm_kdtree_range_next then hands out one at a time.
 */
bool
pm_kdtree_range_refill(struct pm_kd_range *r)
{
	switch (r->isa) {
#if KD_X86
	case KD_ISA_AVX2:
		range_fill_avx2(r);
		break;
	case KD_ISA_SSE2:
		range_fill_sse2(r);
		break;
#endif
	default:
		range_fill_c(r);
		break;
	}
	return r->nbuf > 0;
}

/*
 * The box every photon of a subtree must lie in, from its ancestors'
 * splits, with the ancestor that set each face (SIZE_MAX: none).
 */
struct kd_bounds {
	float lo[3], hi[3];
	size_t lo_src[3], hi_src[3];
};

static void
note_bad(size_t *worst, size_t idx)
{
	if (idx < *worst)
		*worst = idx;
}

/*
 * Checks [lo, hi) against b.  Each photon is compared once with the box
 * its ancestors impose, which is the same as comparing each node with
 * every photon of its subtrees, in O(n).  A photon outside the box blames
 * the ancestor whose face it crosses (the tightest on that axis), a wrong
 * leaf or inner-node mark blames the node itself; *bad keeps the lowest
 * index blamed.
 */
static void
verify_range(const struct pm_photon *p, size_t lo, size_t hi,
    struct kd_bounds b, size_t *bad)
{
	while (hi > lo) {
		size_t m = lo + (hi - lo) / 2;
		const struct pm_photon *ph = &p[m];
		int ax = ph->flags & PM_KD_AXIS_MASK, a;
		struct kd_bounds lb;

		for (a = 0; a < 3; a++) {
			if (!(ph->pos[a] >= b.lo[a]))
				note_bad(bad, b.lo_src[a] == SIZE_MAX ? m :
				    b.lo_src[a]);
			if (!(ph->pos[a] <= b.hi[a]))
				note_bad(bad, b.hi_src[a] == SIZE_MAX ? m :
				    b.hi_src[a]);
		}
		if (hi - lo == 1) {
			if (ax != PM_KD_LEAF)
				note_bad(bad, m);
			return;
		}
		if (ax == PM_KD_LEAF) {
			note_bad(bad, m);
			return;
		}
		lb = b;
		if (!(ph->pos[ax] >= lb.hi[ax])) {
			lb.hi[ax] = ph->pos[ax];
			lb.hi_src[ax] = m;
		}
		if (!(ph->pos[ax] <= b.lo[ax])) {
			b.lo[ax] = ph->pos[ax];
			b.lo_src[ax] = m;
		}
		verify_range(p, lo, m, lb, bad);
		lo = m + 1;
	}
}

/* True if every node's ordering invariant holds; else *bad names one. */
bool
pm_kdtree_verify(const struct pm_photon *p, size_t n, size_t *bad)
{
	struct kd_bounds b;
	size_t worst = SIZE_MAX;
	int a;

	if ((uint64_t)n > UINT32_MAX) {
		if (bad != NULL)
			*bad = 0;
		return false;
	}
	for (a = 0; a < 3; a++) {
		b.lo[a] = -INFINITY;
		b.hi[a] = INFINITY;
		b.lo_src[a] = b.hi_src[a] = SIZE_MAX;
	}
	verify_range(p, 0, n, b, &worst);
	if (worst == SIZE_MAX)
		return true;
	if (bad != NULL)
		*bad = worst;
	return false;
}
