/*
 * photonmap.c: the photon map's operations (photonmap.h): merging shards,
 * the canonical order, balancing, irradiance records, statistics and the
 * lookup setup.
 *
 * pm-shoot can shoot one map in pieces (on several machines, or at
 * different times) over disjoint ranges of photon-path indices; because
 * each path depends only on (seed, kind, index), the pieces hold exactly
 * the photons one run over the whole range would store.  A merge checks
 * that the pieces belong together, concatenates them and adds their
 * emitted counts.  Before a kd-tree is built the photons are put in one
 * canonical order (sorted by their bytes, split-axis bits cleared), so
 * that the result depends only on the set of photons: shards given in any
 * order, balanced or not, merge into the very bytes that balancing one
 * unsharded run gives, and balancing a balanced map changes nothing.
 */
#include <math.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <unistd.h>

#include "irradiance.h"
#include "kdtree.h"
#include "parallel.h"
#include "photonmap.h"
#include "integrator.h"

#define NSLOTS	((int)(sizeof(((struct pm_pmap *)0)->maps) / \
		    sizeof(((struct pm_pmap *)0)->maps[0])))

const char *
pm_map_kind_name(enum pm_map_kind kind)
{
	switch (kind) {
	case PM_MAP_GLOBAL:
		return "global";
	case PM_MAP_CAUSTIC:
		return "caustic";
	case PM_MAP_IRRADIANCE:
		return "irradiance";
	case PM_MAP_VOLUME:
		return "volume";
	}
	return "unknown";
}

struct pm_map *
pm_pmap_find(struct pm_pmap *m, enum pm_map_kind kind)
{
	int i;

	for (i = 0; i < m->nmaps && i < NSLOTS; i++)
		if (m->maps[i].kind == kind)
			return &m->maps[i];
	return NULL;
}

/* --- Merging ----------------------------------------------------------- */

/* The set of photon-map kinds in m, as bits 1 << kind: irradiance maps
 * are not merged. */
static unsigned
kind_set(const struct pm_pmap *m)
{
	unsigned set = 0;
	int i;

	for (i = 0; i < m->nmaps; i++)
		if (m->maps[i].kind != PM_MAP_IRRADIANCE)
			set |= 1u << m->maps[i].kind;
	return set;
}

static void
kind_set_name(unsigned set, char *buf, size_t len)
{
	snprintf(buf, len, "%s%s%s",
	    set & (1u << PM_MAP_GLOBAL) ? "global" : "",
	    (set & (1u << PM_MAP_GLOBAL)) && (set & (1u << PM_MAP_CAUSTIC)) ?
	    "+" : "",
	    set & (1u << PM_MAP_CAUSTIC) ? "caustic" : "");
	if (set == 0)
		snprintf(buf, len, "no maps");
}

uint64_t
pm_pmap_drop_irradiance(struct pm_pmap *m)
{
	struct pm_map t;
	int i;

	for (i = 0; i < m->nmaps; i++) {
		if (m->maps[i].kind != PM_MAP_IRRADIANCE)
			continue;
		t = m->maps[i];
		memmove(&m->maps[i], &m->maps[i + 1], (size_t)(m->nmaps - 1 -
		    i) * sizeof(t));
		m->maps[m->nmaps - 1] = t;
		m->nmaps--;
		return t.count;		/* a kind appears at most once */
	}
	return 0;
}

enum pm_err
pm_pmap_compatible(const struct pm_shard *a, const struct pm_shard *b,
    struct pm_error *err)
{
	char sa[32], sb[32];

	if (a->m->scene_hash != b->m->scene_hash)
		return pm_fail(err, PM_ERR_INVALID, "%s: scene hash %016llx "
		    "differs from %s's (%016llx): shot from another scene",
		    b->name, (unsigned long long)b->m->scene_hash, a->name,
		    (unsigned long long)a->m->scene_hash);
	if (a->m->seed != b->m->seed)
		return pm_fail(err, PM_ERR_INVALID, "%s: seed %llu differs "
		    "from %s's (%llu)", b->name, (unsigned long long)b->m->seed,
		    a->name, (unsigned long long)a->m->seed);
	if (a->m->effects != b->m->effects)
		return pm_fail(err, PM_ERR_INVALID, "%s: effects 0x%x differ "
		    "from %s's (0x%x)", b->name, (unsigned)b->m->effects,
		    a->name, (unsigned)a->m->effects);
	if (a->m->max_depth != b->m->max_depth)
		return pm_fail(err, PM_ERR_INVALID, "%s: max_depth %u differs "
		    "from %s's (%u)", b->name, (unsigned)b->m->max_depth,
		    a->name, (unsigned)a->m->max_depth);
	if (kind_set(a->m) != kind_set(b->m)) {
		kind_set_name(kind_set(b->m), sb, sizeof(sb));
		kind_set_name(kind_set(a->m), sa, sizeof(sa));
		return pm_fail(err, PM_ERR_INVALID, "%s: holds %s maps, %s "
		    "holds %s", b->name, sb, a->name, sa);
	}
	return PM_OK;
}

/* One map of one shard, for sorting by first index. */
struct piece {
	const struct pm_shard *in;
	const struct pm_map *map;
};

static int
cmp_piece(const void *a, const void *b)
{
	const struct piece *pa = a, *pb = b;

	if (pa->map->first_index != pb->map->first_index)
		return pa->map->first_index < pb->map->first_index ? -1 : 1;
	/* Equal starts: the empty range first, so overlaps show up. */
	if (pa->map->emitted != pb->map->emitted)
		return pa->map->emitted < pb->map->emitted ? -1 : 1;
	return 0;
}

/*
 * Sorts the pieces of one kind by first index and checks that their
 * index ranges are disjoint; fills the merged header fields.
 */
static enum pm_err
plan_map(struct piece *pc, int n, struct pm_map *out, pm_merge_note_fn *note,
    void *note_arg, struct pm_error *err)
{
	uint64_t end_prev = 0, count = 0, emitted = 0;
	int i, prev = -1;

	qsort(pc, (size_t)n, sizeof(*pc), cmp_piece);
	out->first_index = pc[0].map->first_index;
	for (i = 0; i < n; i++) {
		const struct pm_map *m = pc[i].map;

		if (m->emitted > UINT64_MAX - m->first_index)
			return pm_fail(err, PM_ERR_LIMIT, "%s: %s photon paths "
			    "[%llu, +%llu) pass 2^64", pc[i].in->name,
			    pm_map_kind_name(m->kind),
			    (unsigned long long)m->first_index,
			    (unsigned long long)m->emitted);
		if (emitted > UINT64_MAX - m->emitted ||
		    count > UINT64_MAX - m->count)
			return pm_fail(err, PM_ERR_LIMIT, "%s: %s photon "
			    "counts pass 2^64", pc[i].in->name,
			    pm_map_kind_name(m->kind));
		emitted += m->emitted;
		count += m->count;
		/* An empty range overlaps nothing and starts nothing. */
		if (m->emitted == 0)
			continue;
		if (prev < 0)
			out->first_index = m->first_index;
		else if (m->first_index < end_prev) {
			const struct pm_map *p = pc[prev].map;

			return pm_fail(err, PM_ERR_INVALID, "%s: %s photon "
			    "paths [%llu, %llu) overlap those of %s [%llu, "
			    "%llu)", pc[i].in->name, pm_map_kind_name(m->kind),
			    (unsigned long long)m->first_index,
			    (unsigned long long)(m->first_index + m->emitted),
			    pc[prev].in->name,
			    (unsigned long long)p->first_index,
			    (unsigned long long)(p->first_index + p->emitted));
		} else if (m->first_index > end_prev && note != NULL)
			note(note_arg, m->kind, end_prev, m->first_index);
		/* Sorted by start, so the latest end is the one to beat. */
		if (prev < 0 || m->first_index + m->emitted > end_prev) {
			end_prev = m->first_index + m->emitted;
			prev = i;
		}
	}
	out->kind = pc[0].map->kind;
	out->count = count;
	out->emitted = emitted;
	out->balanced = false;
	out->photons = NULL;
	return PM_OK;
}

/* Photons copied between two drop_pages (1.5 MB). */
#define GATHER_STEP	65536

/*
 * Tells the system that the whole pages inside [p, p + len) are no longer
 * needed: a shard's records, once copied.  Mapped from the file, they
 * leave this process's memory (the page cache keeps them); read into
 * memory, their pages are given back.  Either way the shard and its copy
 * are not resident at once, so the peak memory stays near one map's.
 */
static void
drop_pages(const void *p, size_t len)
{
	long pg = sysconf(_SC_PAGESIZE);
	uintptr_t a, e;

	if (pg <= 0)
		return;
	a = ((uintptr_t)p + (uintptr_t)pg - 1) & ~((uintptr_t)pg - 1);
	e = ((uintptr_t)p + len) & ~((uintptr_t)pg - 1);
	if (e > a)
		(void)madvise((void *)a, e - a, MADV_DONTNEED);
}

static void sort_buckets(struct pm_photon *p, const size_t start[257],
    int threads);

/*
 * The canonical sort's first pass as the merge's copy: each photon goes,
 * split-axis bits cleared, to the bucket of its first byte.  The shards'
 * records, taken as one array, are cut into parts; each part counts its
 * bytes, then copies its photons to places of its own in each bucket
 * (after those of the parts before it), dropping the shards' pages as it
 * goes, on threads.  Where in its bucket a photon lands depends on the
 * parts, but the buckets are then sorted completely, so the map does not.
 * Done in place, the first pass was pm-balance's longest serial step
 * (American flag sort's swaps across the whole map).
 */
#define SCATTER_PARTS_MAX	64

struct scatter_job {
	const struct piece *pc;
	int n;
	struct pm_photon *p;
	size_t total, parts;
	size_t (*place)[256];	/* per part: its counts, then its next places */
	int phase;		/* 0: count, 1: copy */
	atomic_size_t next;	/* the next part to take */
};

/* Where part i of `parts` starts among n records: n * i / parts, without
 * the product's overflow. */
static inline size_t
part_start(size_t n, size_t i, size_t parts)
{
	return n / parts * i + n % parts * i / parts;
}

static void
scatter_part(struct scatter_job *s, size_t part)
{
	size_t lo = part_start(s->total, part, s->parts);
	size_t hi = part_start(s->total, part + 1, s->parts);
	size_t *place = s->place[part], at, c, b, e, d, step, i;
	int j;

	/* the part's records, piece by piece: [b, e) of piece j */
	for (j = 0, at = 0; j < s->n && lo < hi; at += c, j++) {
		const struct pm_photon *src = s->pc[j].map->photons;

		c = (size_t)s->pc[j].map->count;
		if (lo >= at + c)
			continue;
		b = lo - at;
		e = (hi < at + c ? hi : at + c) - at;
		if (s->phase == 0)
			for (i = b; i < e; i++)
				place[((const unsigned char *)&src[i])[0]]++;
		else
			for (d = b; d < e; d += step) {
				step = e - d < GATHER_STEP ? e - d : GATHER_STEP;
				for (i = d; i < d + step; i++) {
					struct pm_photon *t = &s->p[place[
					    ((const unsigned char *)&src[i])[0]]++];

					*t = src[i];
					t->flags &= (uint8_t)~PM_KD_AXIS_MASK;
				}
				drop_pages(src + d, step * sizeof(*src));
			}
		lo = at + e;
	}
}

static void *
scatter_worker(void *arg)
{
	struct scatter_job *s = arg;
	size_t part;

	while ((part = atomic_fetch_add(&s->next, 1)) < s->parts)
		scatter_part(s, part);
	return NULL;
}

/* Copies the pieces' photons into p (total of them) as the first pass of
 * the canonical sort; start[] receives its buckets.  False without
 * memory. */
static bool
scatter(const struct piece *pc, int n, struct pm_photon *p, size_t total,
    int threads, size_t start[257])
{
	struct scatter_job s;
	size_t t, b, at;

	s.pc = pc;
	s.n = n;
	s.p = p;
	s.total = total;
	/* one part below 65536 photons: threads would cost more */
	s.parts = threads <= 1 || total < 65536 ? 1 :
	    (size_t)(threads < SCATTER_PARTS_MAX ? threads : SCATTER_PARTS_MAX);
	if ((s.place = calloc(s.parts, sizeof(*s.place))) == NULL)
		return false;
	s.phase = 0;
	atomic_init(&s.next, 0);
	pm_parallel(s.parts > 1 ? threads : 1, scatter_worker, &s);
	for (b = 0, at = 0; b < 256; b++) {
		start[b] = at;
		for (t = 0; t < s.parts; t++) {
			size_t c = s.place[t][b];

			s.place[t][b] = at;
			at += c;
		}
	}
	start[256] = at;
	s.phase = 1;
	atomic_store(&s.next, 0);
	pm_parallel(s.parts > 1 ? threads : 1, scatter_worker, &s);
	free(s.place);
	return true;
}

/*
 * Concatenates the pieces' photons into out (allocated here), in order of
 * first index, dropping each shard's pages as they are copied; with
 * `sorted`, into the canonical order instead (scatter, then the buckets
 * sorted on `threads` threads).
 */
static enum pm_err
gather(const struct piece *pc, int n, struct pm_map *out, bool sorted,
    int threads, struct pm_error *err)
{
	struct pm_photon *p;
	size_t at = 0, total, done, step, start[257];
	bool have_bounds = false;
	int j, a;

	if (out->count > SIZE_MAX / sizeof(*p))
		return pm_fail(err, PM_ERR_LIMIT, "%s map: %llu photons do not "
		    "fit in memory", pm_map_kind_name(out->kind),
		    (unsigned long long)out->count);
	total = (size_t)out->count;
	p = malloc(total > 0 ? total * sizeof(*p) : 1);
	if (p == NULL || (sorted && !scatter(pc, n, p, total, threads, start))) {
		free(p);
		return pm_fail(err, PM_ERR_NOMEM, "%s map: out of memory for "
		    "%zu photons", pm_map_kind_name(out->kind), total);
	}
	for (j = 0; j < n; j++) {
		const struct pm_map *m = pc[j].map;

		for (done = 0; !sorted && done < (size_t)m->count; done += step) {
			step = (size_t)m->count - done < GATHER_STEP ?
			    (size_t)m->count - done : GATHER_STEP;
			memcpy(p + at + done, m->photons + done,
			    step * sizeof(*p));
			drop_pages(m->photons + done, step * sizeof(*p));
		}
		at += (size_t)m->count;
		/* The shards' bounds, merged; an empty map's say nothing. */
		if (m->count == 0)
			continue;
		for (a = 0; a < 3; a++) {
			if (!have_bounds || m->lo[a] < out->lo[a])
				out->lo[a] = m->lo[a];
			if (!have_bounds || m->hi[a] > out->hi[a])
				out->hi[a] = m->hi[a];
		}
		have_bounds = true;
	}
	if (!have_bounds)
		for (a = 0; a < 3; a++) {
			out->lo[a] = pc[0].map->lo[a];
			out->hi[a] = pc[0].map->hi[a];
		}
	out->photons = p;
	if (sorted)
		sort_buckets(p, start, threads);
	return PM_OK;
}

static enum pm_err
merge(const struct pm_shard *in, int n, struct pm_pmap *out, int *order,
    pm_merge_note_fn *note, void *note_arg, bool sorted, int threads,
    struct pm_error *err)
{
	struct piece *pc;
	enum pm_err r = PM_OK;
	int i, k;

	if (n < 1)
		return pm_fail(err, PM_ERR_INVALID, "no shards to merge");
	if ((pc = calloc((size_t)n, sizeof(*pc))) == NULL)
		return pm_fail(err, PM_ERR_NOMEM, "out of memory");
	for (i = 0; i < n && order != NULL; i++)
		order[i] = i;
	out->scene_hash = in[0].m->scene_hash;
	out->seed = in[0].m->seed;
	out->effects = in[0].m->effects;
	out->max_depth = in[0].m->max_depth;
	out->nmaps = in[0].m->nmaps;
	for (k = 0; k < out->nmaps; k++)
		memset(&out->maps[k], 0, sizeof(out->maps[k]));
	/* The maps in the first shard's order. */
	for (k = 0; k < out->nmaps && r == PM_OK; k++) {
		enum pm_map_kind kind = in[0].m->maps[k].kind;

		for (i = 0; i < n; i++) {
			pc[i].in = &in[i];
			pc[i].map = pm_pmap_find(in[i].m, kind);
			if (pc[i].map == NULL) {
				r = pm_fail(err, PM_ERR_INVALID, "%s: holds no "
				    "%s map", in[i].name,
				    pm_map_kind_name(kind));
				goto done;
			}
		}
		if ((r = plan_map(pc, n, &out->maps[k], note, note_arg, err)) !=
		    PM_OK)
			break;
		for (i = 0; k == 0 && i < n && order != NULL; i++)
			order[i] = (int)(pc[i].in - in);
		r = gather(pc, n, &out->maps[k], sorted, threads, err);
	}
done:
	if (r != PM_OK)
		for (k = 0; k < out->nmaps; k++) {
			free(out->maps[k].photons);
			out->maps[k].photons = NULL;
		}
	free(pc);
	return r;
}

enum pm_err
pm_pmap_merge(const struct pm_shard *in, int n, struct pm_pmap *out,
    int *order, pm_merge_note_fn *note, void *note_arg, struct pm_error *err)
{
	return merge(in, n, out, order, note, note_arg, false, 1, err);
}

enum pm_err
pm_pmap_merge_canonical(const struct pm_shard *in, int n,
    struct pm_pmap *out, int *order, pm_merge_note_fn *note, void *note_arg,
    int threads, struct pm_error *err)
{
	return merge(in, n, out, order, note, note_arg, true, threads, err);
}

/* --- Balancing --------------------------------------------------------- */

/*
 * American flag sort's pass: reorders p[0..n) into 256 buckets by byte
 * `byte` of the records, in place; bucket b is [start[b], start[b + 1]).
 */
static void
byte_partition(struct pm_photon *p, size_t n, size_t byte, size_t start[257])
{
	size_t count[256], next[256], i;
	struct pm_photon t;
	unsigned v;

	memset(count, 0, sizeof(count));
	for (i = 0; i < n; i++)
		count[((const unsigned char *)&p[i])[byte]]++;
	start[0] = 0;
	for (i = 0; i < 256; i++) {
		next[i] = start[i];
		start[i + 1] = start[i] + count[i];
	}
	/* Each swap puts one record into its bucket for good. */
	for (i = 0; i < 256; i++)
		while (next[i] < start[i + 1]) {
			v = ((const unsigned char *)&p[next[i]])[byte];
			if (v == i) {
				next[i]++;
				continue;
			}
			t = p[next[v]];
			p[next[v]++] = p[next[i]];
			p[next[i]] = t;
		}
}

/*
 * Sorts p[0..n) into the canonical order: by the bytes of the records
 * (split-axis bits already cleared), as memcmp orders them, looking only at
 * bytes [byte, 24) since the earlier ones are equal throughout.  An
 * in-place most-significant-byte radix sort (McIlroy, Bostic and McIlroy's
 * American flag sort): a quarter of qsort's time and no extra memory.
 * Recursion is at most 24 deep.
 */
static void
canonical_sort(struct pm_photon *p, size_t n, size_t byte)
{
	size_t start[257], i, j;
	const size_t len = sizeof(struct pm_photon);
	struct pm_photon t;

	if (byte >= len)
		return;
	if (n <= 24) {
		for (i = 1; i < n; i++) {
			t = p[i];
			for (j = i; j > 0 && memcmp((const unsigned char *)
			    &p[j - 1] + byte, (const unsigned char *)&t + byte,
			    len - byte) > 0; j--)
				p[j] = p[j - 1];
			p[j] = t;
		}
		return;
	}
	byte_partition(p, n, byte, start);
	for (i = 0; i < 256; i++)
		if (start[i + 1] - start[i] > 1)
			canonical_sort(p + start[i], start[i + 1] - start[i],
			    byte + 1);
}

/*
 * The buckets of the first byte sorted on several threads: each bucket is a
 * range of its own after the first pass, and the sort is a total order on
 * the bytes, so the result is the same whoever sorts which bucket.
 */
struct bucket_sort {
	struct pm_photon *p;
	size_t start[257];		/* bucket b is [start[b], start[b + 1]) */
	atomic_int next;		/* the next bucket to take */
};

static void *
bucket_worker(void *arg)
{
	struct bucket_sort *bs = arg;
	int b;

	while ((b = atomic_fetch_add(&bs->next, 1)) < 256) {
		size_t n = bs->start[b + 1] - bs->start[b];

		if (n > 1)
			canonical_sort(bs->p + bs->start[b], n, 1);
	}
	return NULL;
}

/* The rest of canonical_sort after its first pass, whose buckets are
 * start[]'s: on threads when there are photons enough. */
static void
sort_buckets(struct pm_photon *p, const size_t start[257], int threads)
{
	struct bucket_sort bs;
	int b;

	if (threads <= 1 || start[256] < 65536) {
		for (b = 0; b < 256; b++)
			if (start[b + 1] - start[b] > 1)
				canonical_sort(p + start[b],
				    start[b + 1] - start[b], 1);
		return;
	}
	memcpy(bs.start, start, sizeof(bs.start));
	bs.p = p;
	atomic_init(&bs.next, 0);
	pm_parallel(threads, bucket_worker, &bs);
}

void
pm_map_canonical_order(struct pm_map *m, int threads)
{
	struct pm_photon *p = m->photons;
	size_t n = (size_t)m->count, i, start[257];

	for (i = 0; i < n; i++)
		p[i].flags &= (uint8_t)~PM_KD_AXIS_MASK;
	m->balanced = false;
	byte_partition(p, n, 0, start);
	sort_buckets(p, start, threads);
}

enum pm_err
pm_map_build_tree(struct pm_map *m, int threads, struct pm_error *err)
{
	enum pm_err r;

	if ((r = pm_kdtree_build(m->photons, (size_t)m->count, threads,
	    err)) != PM_OK)
		return r;
	m->balanced = true;
	return PM_OK;
}

enum pm_err
pm_map_balance(struct pm_map *m, int threads, struct pm_error *err)
{
	pm_map_canonical_order(m, threads);
	return pm_map_build_tree(m, threads, err);
}

float
pm_irradiance_setup_r2(const struct pm_map *g,
    const struct pm_irradiance_setup *s)
{
	double diag = 0.0, f;
	float r2;
	int a;

	/* The merged bounds of the shards (every reader checks them). */
	for (a = 0; a < 3; a++)
		diag += (double)(g->hi[a] - g->lo[a]) * (g->hi[a] - g->lo[a]);
	r2 = (float)(s->radius * s->radius * 0.25 * diag);
	if (s->pass > 0) {
		f = pm_pppm_radius_scale(s->pass, s->alpha);
		r2 = (float)(r2 * f * f);
	}
	return r2;
}

/*
 * The records' map entry.  Their radius is a fraction of the global map's
 * half-diagonal: the k-nearest cap, or with a progressive pass the fixed
 * radius, shrinking along the schedule pm-render's --pass follows, so that
 * the records' blur averages away over passes.  (A loop rather than
 * pm_pmap_find, which takes a map it may change.)
 */
bool
pm_pmap_irradiance_entry(const struct pm_pmap *m,
    const struct pm_irradiance_setup *s, struct pm_map *r)
{
	const struct pm_map *g = NULL;
	int i;

	for (i = 0; i < m->nmaps; i++)
		if (m->maps[i].kind == PM_MAP_IRRADIANCE)
			return false;
		else if (m->maps[i].kind == PM_MAP_GLOBAL)
			g = &m->maps[i];
	if (s->stride == 0 || g == NULL || g->count == 0 || g->emitted == 0 ||
	    m->nmaps >= NSLOTS)
		return false;
	memset(r, 0, sizeof(*r));
	r->kind = PM_MAP_IRRADIANCE;
	r->radius = sqrtf(pm_irradiance_setup_r2(g, s));
	r->balanced = true;
	return true;
}

enum pm_err
pm_pmap_add_irradiance(struct pm_pmap *m, const struct pm_irradiance_setup *s,
    struct pm_error *err)
{
	struct pm_error inner = {PM_OK, ""};
	struct pm_map *g = pm_pmap_find(m, PM_MAP_GLOBAL), *r, entry;
	struct pm_irradiance_opts o;
	enum pm_err e;
	size_t n = 0;

	if (!pm_pmap_irradiance_entry(m, s, &entry))
		return PM_OK;
	r = &m->maps[m->nmaps];
	*r = entry;
	o.stride = s->stride;
	o.k = s->k;
	o.max_r2 = pm_irradiance_setup_r2(g, s);
	o.fixed_radius = s->pass > 0;
	/* pm-shoot caps photons at max_depth - 2 bounces for a scene's
	 * max_depth (0: none); a record feeds a gather ray, one segment
	 * more, so it counts one bounce fewer. */
	o.max_depth = m->max_depth > 0 ? (int)m->max_depth - 1 : -1;
	o.threads = s->threads;
	if ((e = pm_irradiance_records(g->photons, (size_t)g->count,
	    1.0f / (float)g->emitted, &o, &r->photons, &n, &inner)) != PM_OK ||
	    (e = pm_kdtree_build(r->photons, n, s->threads, &inner)) !=
	    PM_OK) {
		free(r->photons);
		r->photons = NULL;
		return pm_fail(err, e, "irradiance records: %s", inner.msg);
	}
	r->count = n;
	m->nmaps++;
	return PM_OK;
}

/* --- Statistics -------------------------------------------------------- */

void
pm_map_stats(const struct pm_map *m, struct pm_map_stats *s)
{
	double sum[3] = { 0.0, 0.0, 0.0 };
	size_t i, n = (size_t)m->count;

	memset(s, 0, sizeof(*s));
	s->max_depth = -1;
	for (i = 0; i < n; i++) {
		const struct pm_photon *p = &m->photons[i];
		struct pm_rgb c = pm_rgbe_unpack(p->power);

		sum[0] += c.r;
		sum[1] += c.g;
		sum[2] += c.b;
		if (pm_rgb_max(c) > s->max_e)
			s->max_e = pm_rgb_max(c);
		s->depth[p->depth]++;
		if (p->depth > s->max_depth)
			s->max_depth = p->depth;
		if (p->flags & PM_PHOTON_VIA_DIFFUSE)
			s->via_diffuse++;
		if (p->flags & PM_PHOTON_CAUSTIC)
			s->caustic++;
	}
	for (i = 0; i < 3; i++) {
		s->flux[i] = m->emitted > 0 ? sum[i] / (double)m->emitted :
		    0.0;
		s->mean_e[i] = n > 0 ? sum[i] / (double)n : 0.0;
	}
}

/* --- Lookups ----------------------------------------------------------- */

struct pm_lookup_radii
pm_lookup_radii(float global, float caustic, float scene_radius, long pass,
    double alpha, float first)
{
	struct pm_lookup_radii r;
	double f;

	memset(&r, 0, sizeof(r));
	r.global_r2 = global * scene_radius;
	r.global_r2 *= r.global_r2;
	r.caustic_r2 = caustic * scene_radius;
	r.caustic_r2 *= r.caustic_r2;
	if (pass > 0) {
		f = pm_pppm_radius_scale(pass, alpha);
		if (first > 0.0f) {
			double g = first / global;

			f *= g;
		}
		r.global_r2 = (float)(r.global_r2 * f * f);
		r.caustic_r2 = (float)(r.caustic_r2 * f * f);
		r.fixed = true;
	}
	return r;
}

enum pm_err
pm_photon_maps_from_pmap(const struct pm_pmap *pm,
    struct pm_photon_maps *maps, struct pm_error *err)
{
	int i;

	memset(maps, 0, sizeof(*maps));
	for (i = 0; i < pm->nmaps; i++) {
		const struct pm_map *m = &pm->maps[i];

		switch (m->kind) {
		case PM_MAP_GLOBAL:
			maps->global = m->photons;
			maps->nglobal = (size_t)m->count;
			maps->global_scale = m->emitted ?
			    1.0f / (float)m->emitted : 0.0f;
			break;
		case PM_MAP_CAUSTIC:
			maps->caustic = m->photons;
			maps->ncaustic = (size_t)m->count;
			maps->caustic_scale = m->emitted ?
			    1.0f / (float)m->emitted : 0.0f;
			break;
		case PM_MAP_VOLUME:
			maps->volume = m->photons;
			maps->nvolume = (size_t)m->count;
			maps->volume_scale = m->emitted ?
			    1.0f / (float)m->emitted : 0.0f;
			break;
		case PM_MAP_IRRADIANCE:
			/* Irradiance, not flux: nothing to divide by. */
			maps->irradiance = m->photons;
			maps->nirradiance = (size_t)m->count;
			break;
		}
		if (!m->balanced && m->count > 1)
			return pm_fail(err, PM_ERR_INVALID, "the %s map is not "
			    "balanced; run pm-balance on it first",
			    pm_map_kind_name(m->kind));
	}
	return PM_OK;
}

uint32_t
pm_photon_depth_cap(int scene_max_depth)
{
	int md = scene_max_depth;

	return md < 0 ? 0 : (uint32_t)(md > 2 ? md - 2 : 0);
}
