/*
 * kdtree_select.h: the kd-tree build's selection, written once for two
 * record types; kdtree.c includes it twice, for whole photons (ranges above
 * RADIX_MAX) and for its compact 16-byte records (below), with KT the
 * record type and KN(name) the name of each function for that type.  Both
 * instances read only pos[] and move whole records, so that they permute
 * any range alike whatever its record type: the tree built on compact
 * records is the one built on photons, bit for bit.  Not a header of its
 * own: no include guard, on purpose.
 */

static inline void
KN(swap)(KT *a, KT *b)
{
	KT t = *a;

	*a = *b;
	*b = t;
}

/* Index of a median of three keys (any of the three when some are NaN). */
static inline ptrdiff_t
KN(med3)(const KT *p, ptrdiff_t i, ptrdiff_t j, ptrdiff_t k, int ax)
{
	float a = p[i].pos[ax], b = p[j].pos[ax], c = p[k].pos[ax];

	if (a < b) {
		if (b < c)
			return j;
		return a < c ? k : i;
	}
	if (a < c)
		return i;
	return b < c ? k : j;
}

static void
KN(insertion_sort)(KT *p, ptrdiff_t lo, ptrdiff_t hi, int ax)
{
	ptrdiff_t i, j;

	for (i = lo + 1; i < hi; i++) {
		KT t = p[i];
		float v = t.pos[ax];

		for (j = i; j > lo && p[j - 1].pos[ax] > v; j--)
			p[j] = p[j - 1];
		p[j] = t;
	}
}

static void
KN(sift_down_key)(KT *p, ptrdiff_t root, ptrdiff_t n, int ax)
{
	for (;;) {
		ptrdiff_t c = 2 * root + 1;

		if (c >= n)
			return;
		if (c + 1 < n && p[c + 1].pos[ax] > p[c].pos[ax])
			c++;
		if (!(p[c].pos[ax] > p[root].pos[ax]))
			return;
		KN(swap)(&p[root], &p[c]);
		root = c;
	}
}

/* The introselect fallback: O(n log n) whatever the data. */
static void
KN(heap_sort_key)(KT *p, ptrdiff_t n, int ax)
{
	ptrdiff_t i;

	for (i = n / 2; i-- > 0;)
		KN(sift_down_key)(p, i, n, ax);
	for (i = n - 1; i > 0; i--) {
		KN(swap)(&p[0], &p[i]);
		KN(sift_down_key)(p, 0, i, ax);
	}
}

static void
KN(swap_blocks)(KT *p, ptrdiff_t a, ptrdiff_t b, ptrdiff_t len)
{
	while (len-- > 0)
		KN(swap)(&p[a++], &p[b++]);
}

/*
 * Bentley-McIlroy three-way partition of [lo, hi) around v: afterwards
 * [lo, *lt) < v, [*lt, *gt) == v, [*gt, hi) > v.  Equal keys are parked at
 * both ends during the scan and swapped to the middle at the end.
 */
static void
KN(partition3)(KT *p, ptrdiff_t lo, ptrdiff_t hi, float v, int ax,
    ptrdiff_t *lt, ptrdiff_t *gt)
{
	ptrdiff_t a = lo, b = lo, c = hi - 1, d = hi - 1, s, less, greater;
	float x;

	for (;;) {
		while (b <= c && (x = p[b].pos[ax]) <= v) {
			if (x == v)
				KN(swap)(&p[a++], &p[b]);
			b++;
		}
		while (c >= b && (x = p[c].pos[ax]) >= v) {
			if (x == v)
				KN(swap)(&p[c], &p[d--]);
			c--;
		}
		if (b > c)
			break;
		KN(swap)(&p[b++], &p[c--]);
	}
	/* Equal keys from both ends to the middle: [lo, a) swaps with the
	 * tail of the "less" block [a, b), (d, hi) with the head of the
	 * "greater" block [b, d]. */
	less = b - a;
	greater = d + 1 - b;
	s = a - lo < less ? a - lo : less;
	KN(swap_blocks)(p, lo, b - s, s);
	s = hi - 1 - d < greater ? hi - 1 - d : greater;
	KN(swap_blocks)(p, b, hi - s, s);
	*lt = lo + less;
	*gt = b + (hi - 1 - d);
}

/*
 * Two keys of an evenly spaced sample of ns keys of [lo, hi) that bracket
 * rank k's: the keys gap ranks either side of its rank in the sorted
 * sample, which smp holds.
 */
static void
KN(bracket)(const KT *p, ptrdiff_t lo, ptrdiff_t hi, ptrdiff_t k, int ax,
    float *smp, ptrdiff_t ns, ptrdiff_t gap, float *a, float *b)
{
	ptrdiff_t n = hi - lo, i, r;

	for (i = 0; i < ns; i++)
		smp[i] = p[lo + (ptrdiff_t)((int64_t)i * n / ns)].pos[ax];
	sort_floats(smp, (size_t)ns);
	r = (ptrdiff_t)((int64_t)(k - lo) * ns / n);
	*a = smp[r - gap < 0 ? 0 : r - gap];
	*b = smp[r + gap >= ns ? ns - 1 : r + gap];
}

/*
 * One pass over [lo, hi): afterwards [lo, *lt) < a, [*lt, *gt) in [a, b]
 * (or NaN), [*gt, hi) > b.  (A version without branches, swapping every
 * record with its destination, measured slower: 3.38 s against 3.14 s on
 * 10M photons.)
 */
static void
KN(partition_ab)(KT *p, ptrdiff_t lo, ptrdiff_t hi, float a, float b, int ax,
    ptrdiff_t *lt, ptrdiff_t *gt)
{
	ptrdiff_t l = lo, i = lo, g = hi;

	while (i < g) {
		float x = p[i].pos[ax];

		if (x < a)
			KN(swap)(&p[l++], &p[i++]);
		else if (x > b)
			KN(swap)(&p[i], &p[--g]);
		else
			i++;
	}
	*lt = l;
	*gt = g;
}

/* Narrows [*lo, *hi), which holds rank k, to the part of [lt, gt) that
 * holds it. */
static inline void
KN(narrow_to)(ptrdiff_t *lo, ptrdiff_t *hi, ptrdiff_t k, ptrdiff_t lt,
    ptrdiff_t gt)
{
	if (k < lt)
		*hi = lt;
	else if (k >= gt)
		*lo = gt;
	else {
		*lo = lt;
		*hi = gt;
	}
}

/* Narrows [*lo, *hi), which holds rank k, by a pass around two sampled
 * keys. */
static void
KN(narrow_by_sample)(KT *p, ptrdiff_t *lo, ptrdiff_t *hi, ptrdiff_t k, int ax)
{
	float smp[FR_SAMPLE], a, b;
	ptrdiff_t lt, gt;

	KN(bracket)(p, *lo, *hi, k, ax, smp, FR_SAMPLE, FR_GAP, &a, &b);
	KN(partition_ab)(p, *lo, *hi, a, b, ax, &lt, &gt);
	KN(narrow_to)(lo, hi, k, lt, gt);
}

/*
 * Rearranges [lo, hi) so that p[k] holds the key it would hold if sorted,
 * everything before it <= and everything after it >= (by pos[ax]).
 */
static void
KN(select_kth)(KT *p, ptrdiff_t lo, ptrdiff_t hi, ptrdiff_t k, int ax)
{
	int budget;

	while (hi - lo >= FR_MIN) {
		ptrdiff_t n = hi - lo;

		KN(narrow_by_sample)(p, &lo, &hi, k, ax);
		/* A bad sample (rare), or many equal keys: introselect takes
		 * it from here. */
		if (hi - lo > n / 2)
			break;
	}
	budget = 2 * floor_log2((size_t)(hi - lo)) + 8;

	while (hi - lo > SELECT_SMALL) {
		ptrdiff_t n = hi - lo, mid = lo + n / 2, lt, gt, pv;

		if (budget-- == 0) {
			KN(heap_sort_key)(p + lo, n, ax);
			return;
		}
		if (n >= 512) {
			ptrdiff_t s = n / 8;

			pv = KN(med3)(p, KN(med3)(p, lo, lo + s, lo + 2 * s, ax),
			    KN(med3)(p, mid - s, mid, mid + s, ax),
			    KN(med3)(p, hi - 1 - 2 * s, hi - 1 - s, hi - 1, ax),
			    ax);
		} else
			pv = KN(med3)(p, lo, mid, hi - 1, ax);
		KN(partition3)(p, lo, hi, p[pv].pos[ax], ax, &lt, &gt);
		if (k < lt)
			hi = lt;
		else if (k >= gt)
			lo = gt;
		else
			return;
	}
	KN(sort_small)(p, lo, hi, ax);
}

#ifndef KT_OWN_AXIS
/*
 * The axis of largest extent of the bounding box of [lo, hi), or for a
 * range of more than 8 * AXIS_SAMPLE photons, of an evenly spaced sample
 * of AXIS_SAMPLE to 2 * AXIS_SAMPLE of them (see kdtree.c).
 */
static int
KN(widest_axis)(const KT *p, size_t lo, size_t hi)
{
	float x0, x1, y0, y1, z0, z1, e0, e1, e2;
	size_t i, step = 1;

	if (hi - lo >= 8 * AXIS_SAMPLE)
		step = (hi - lo) / AXIS_SAMPLE;
	/* Locals, not arrays: the bounds stay in registers. */
	x0 = x1 = p[lo].pos[0];
	y0 = y1 = p[lo].pos[1];
	z0 = z1 = p[lo].pos[2];
	for (i = lo + step; i < hi; i += step) {
		float x = p[i].pos[0], y = p[i].pos[1], z = p[i].pos[2];

		x0 = x < x0 ? x : x0;
		x1 = x > x1 ? x : x1;
		y0 = y < y0 ? y : y0;
		y1 = y > y1 ? y : y1;
		z0 = z < z0 ? z : z0;
		z1 = z > z1 ? z : z1;
	}
	e0 = x1 - x0;
	e1 = y1 - y0;
	e2 = z1 - z0;
	if (e0 >= e1 && e0 >= e2)
		return 0;
	return e1 >= e2 ? 1 : 2;
}
#endif
