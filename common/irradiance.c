/*
 * irradiance.c: precomputed irradiance records (irradiance.h).
 *
 * Each record is computed from the global map alone, by the same code
 * whichever thread runs it, into its own slot: the records are the same
 * bytes for any thread count.
 */
#include <math.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

#include "irradiance.h"
#include "kdtree.h"
#include "parallel.h"

/*
 * Records are handed to threads in chunks of this many, and a chunk's
 * k-nearest queries go to pm_kdtree_knn_batch in batches of up to
 * IRR_BATCH_NB / k (whole chunks at pm-balance's k = 32), fixed by the
 * records' indices, so that the records do not depend on the thread
 * count.  The batch bounds each query by its predecessor's neighbours: on
 * cornell-box's 1.85M photons (231,582 records, k = 32, one thread) the
 * records took 0.75x to 0.85x the time of one pm_kdtree_knn a record, and
 * came out the same bytes.
 */
#define IRR_CHUNK	1024
#define IRR_BATCH_NB	32768	/* neighbours a batch holds: 256 KiB */
_Static_assert(IRR_BATCH_NB / PM_IRR_MAX_K >= 1, "a batch holds one query");

static inline bool
compatible(const struct pm_photon *x, struct pm_vec3 nrm, int max_depth)
{
	return (max_depth < 0 || x->depth <= max_depth) &&
	    pm_dot(pm_dir_unpack(x->normal), nrm) > PM_IRR_COS;
}

static inline size_t
knn_k(const struct pm_irradiance_opts *o)
{
	return o->k < 1 ? 1 : (o->k > PM_IRR_MAX_K ? PM_IRR_MAX_K :
	    (size_t)o->k);
}

/* The k-nearest estimate from the found neighbours nb[0..found), a
 * max-heap on distance (nb[0] the farthest). */
static struct pm_rgb
from_knn(const struct pm_photon *g, float scale, struct pm_vec3 nrm,
    const struct pm_irradiance_opts *o, const struct pm_knn *nb,
    size_t found, size_t k)
{
	double sum[3] = {0, 0, 0}, w;
	size_t i;
	float r2;

	if (found == 0)
		return pm_rgb1(0.0f);
	/* With k found, the k-th (nb[0], the farthest) lies on the disc's
	 * edge and sets its radius: counting it too would overestimate a
	 * uniform density by k / (k - 1).  The other k - 1 are the unbiased
	 * estimate. */
	for (i = found == k && k > 1 ? 1 : 0; i < found; i++) {
		struct pm_rgb c;

		if (!compatible(&g[nb[i].idx], nrm, o->max_depth))
			continue;
		c = pm_rgbe_unpack(g[nb[i].idx].power);
		sum[0] += c.r;
		sum[1] += c.g;
		sum[2] += c.b;
	}
	r2 = found == k ? nb[0].d2 : o->max_r2;
	if (!(r2 > 0.0f))
		return pm_rgb1(0.0f);
	w = (double)scale / (PM_PI * (double)r2);
	return pm_rgb((float)(sum[0] * w), (float)(sum[1] * w), (float)(sum[2] * w));
}

struct pm_rgb
pm_irradiance_estimate(const struct pm_photon *g, size_t n, float scale,
    struct pm_vec3 p, struct pm_vec3 nrm, const struct pm_irradiance_opts *o)
{
	float q[3] = {p.x, p.y, p.z}, r2;
	double sum[3] = {0, 0, 0}, w;

	if (n == 0 || !(o->max_r2 > 0.0f))
		return pm_rgb1(0.0f);
	if (o->fixed_radius) {
		struct pm_kd_range it;
		uint32_t idx;
		float d2;

		pm_kdtree_range_init(&it, g, n, q, o->max_r2, 0, 0);
		while (pm_kdtree_range_next(&it, &idx, &d2)) {
			struct pm_rgb c;

			if (!compatible(&g[idx], nrm, o->max_depth))
				continue;
			c = pm_rgbe_unpack(g[idx].power);
			sum[0] += c.r;
			sum[1] += c.g;
			sum[2] += c.b;
		}
		r2 = o->max_r2;
	} else {
		struct pm_knn nb[PM_IRR_MAX_K];
		size_t k = knn_k(o);

		return from_knn(g, scale, nrm, o, nb,
		    pm_kdtree_knn(g, n, q, k, o->max_r2, 0, 0, nb), k);
	}
	w = (double)scale / (PM_PI * (double)r2);
	return pm_rgb((float)(sum[0] * w), (float)(sum[1] * w), (float)(sum[2] * w));
}

struct irr_job {
	const struct pm_photon *g;
	size_t n;
	float scale;
	const struct pm_irradiance_opts *o;
	struct pm_photon *out;
	size_t nout;
	_Atomic size_t next;
	atomic_bool nomem;	/* a thread found no memory for its batch */
};

/* A deterministic dither for the RGBE rounding of record i: the golden
 * ratio's sequence, uniform enough that rounding errors cancel. */
static inline float
dither(size_t i)
{
	double x = (double)i * 0.6180339887498949;

	return (float)(x - floor(x));
}

static void *
irr_worker(void *arg)
{
	struct irr_job *j = arg;
	const struct pm_irradiance_opts *o = j->o;
	const size_t stride = (size_t)o->stride, k = knn_k(o);
	/* k <= PM_IRR_MAX_K: at least 32 a batch */
	const size_t nbatch = IRR_BATCH_NB / k < IRR_CHUNK ?
	    IRR_BATCH_NB / k : IRR_CHUNK;
	/* k nearest with a bound, the common case, go by batches; the
	 * fixed-radius ones (and the degenerate) one at a time */
	const bool batch = !o->fixed_radius && o->max_r2 > 0.0f;
	struct pm_knn *nb = NULL;
	size_t found[IRR_CHUNK], lo, hi, b, e, i;
	float q[3 * IRR_CHUNK];

	if (batch && (nb = malloc(nbatch * k * sizeof(*nb))) == NULL) {
		atomic_store(&j->nomem, true);
		return NULL;
	}
	while ((lo = atomic_fetch_add(&j->next, IRR_CHUNK)) < j->nout) {
		hi = lo + IRR_CHUNK < j->nout ? lo + IRR_CHUNK : j->nout;
		for (b = lo; b < hi; b = e) {
			e = b + nbatch < hi ? b + nbatch : hi;
			if (batch) {
				for (i = b; i < e; i++)
					memcpy(&q[3 * (i - b)],
					    j->g[i * stride + stride / 2].pos,
					    sizeof(j->g->pos));
				pm_kdtree_knn_batch(j->g, j->n, q, e - b, k,
				    o->max_r2, 0, 0, nb, found);
			}
			for (i = b; i < e; i++) {
				const struct pm_photon *x =
				    &j->g[i * stride + stride / 2];
				struct pm_photon *r = &j->out[i];
				struct pm_vec3 nrm = pm_dir_unpack(x->normal);
				struct pm_rgb E = batch ? from_knn(j->g,
				    j->scale, nrm, o, &nb[(i - b) * k],
				    found[i - b], k) :
				    pm_irradiance_estimate(j->g, j->n, j->scale,
				    pm_photon_pos(x), nrm, o);

				memset(r, 0, sizeof(*r));
				memcpy(r->pos, x->pos, sizeof(r->pos));
				memcpy(r->normal, x->normal, sizeof(r->normal));
				pm_rgbe_pack(E, dither(i), r->power);
				r->flags = PM_KD_LEAF;
			}
		}
	}
	free(nb);
	return NULL;
}

enum pm_err
pm_irradiance_records(const struct pm_photon *g, size_t n, float scale,
    const struct pm_irradiance_opts *o, struct pm_photon **out, size_t *nout,
    struct pm_error *err)
{
	struct irr_job j;

	*out = NULL;
	*nout = 0;
	if (o->stride < 1)
		return pm_fail(err, PM_ERR_INVALID,
		    "irradiance records: stride must be at least 1");
	j.nout = n / o->stride;
	if (j.nout == 0)
		return PM_OK;
	j.g = g;
	j.n = n;
	j.scale = scale;
	j.o = o;
	j.out = malloc(j.nout * sizeof(*j.out));
	if (j.out == NULL)
		return pm_fail(err, PM_ERR_NOMEM, "no memory for %zu irradiance "
		    "records", j.nout);
	atomic_init(&j.next, 0);
	atomic_init(&j.nomem, false);
	pm_parallel(o->threads, irr_worker, &j);
	if (atomic_load(&j.nomem)) {
		free(j.out);
		return pm_fail(err, PM_ERR_NOMEM, "no memory for the k-nearest "
		    "queries of irradiance records");
	}
	*out = j.out;
	*nout = j.nout;
	return PM_OK;
}

/* Cells at most: 4M cells is 16 MB of offsets. */
#define GRID_MAX_CELLS	(1u << 22)
/*
 * And at most this many a record.  Records lie on surfaces and the cells
 * fill a volume: cells of twice the records' spacing made 11 a record in
 * the cornell box, and the build was cache misses on them (a tenth of a
 * short render, serial).  Capped at 4, the cells are 1.56x wider, the
 * build twice as fast, and a whole render took 0.88x to 0.91x the time
 * on one thread (the lookups too got faster).  A lookup's record (the
 * nearest of its cell) may change, the images only well within their
 * noise: see docs/accuracy.md.
 */
#define GRID_CELLS_PER_REC	4.0f

static inline int
cell_coord(float x, float lo, float inv_cell, int n)
{
	float c = (x - lo) * inv_cell;
	int i = c > 0.0f ? (int)c : 0;

	return i < n ? i : n - 1;
}

/*
 * The grid's build in parts, for threads: records are split into index
 * ranges for the passes over records (bounds, cell keys), cells into
 * ranges for the counting sort, each part counting and placing only the
 * records of its own cells (reading every key, which is cheap next to
 * the scattered writes).  A cell's records land where the serial sort
 * put them, so the grid is the same whatever the thread count.
 */
#define GRID_PARTS_MAX	64
/* Below this many records, one part: threads would cost more than the
 * build. */
#define GRID_PART_RECS	32768

struct grid_job {
	struct pm_irr_grid *g;
	const struct pm_photon *r;
	uint32_t *key;
	size_t n, ncell;
	int parts, phase;
	_Atomic int next;
	float lo[GRID_PARTS_MAX][3], hi[GRID_PARTS_MAX][3];
	size_t total[GRID_PARTS_MAX];	/* records in a cell range */
};

enum { GRID_BOUNDS, GRID_KEYS, GRID_COUNT, GRID_PLACE };

static void
grid_part(struct grid_job *j, int p)
{
	struct pm_irr_grid *g = j->g;
	const struct pm_photon *r = j->r;
	size_t i, a, b, sum, c0, c1;
	int ax;

	a = j->n * (size_t)p / (size_t)j->parts;
	b = j->n * (size_t)(p + 1) / (size_t)j->parts;
	c0 = j->ncell * (size_t)p / (size_t)j->parts;
	c1 = j->ncell * (size_t)(p + 1) / (size_t)j->parts;
	switch (j->phase) {
	case GRID_BOUNDS: {
		/* pm_fminf / pm_fmaxf: libm's calls were a third of this
		 * serial set-up of every photon render.  The bounds in
		 * locals: kept in j, they could alias the positions (both
		 * float), and every record stored and reloaded them, a
		 * chain of store-to-load latencies (2.6 ms of 231k records,
		 * now a tenth of it). */
		float lo[3] = {INFINITY, INFINITY, INFINITY};
		float hi[3] = {-INFINITY, -INFINITY, -INFINITY};

		for (i = a; i < b; i++)
			for (ax = 0; ax < 3; ax++) {
				lo[ax] = pm_fminf(lo[ax], r[i].pos[ax]);
				hi[ax] = pm_fmaxf(hi[ax], r[i].pos[ax]);
			}
		memcpy(j->lo[p], lo, sizeof(lo));
		memcpy(j->hi[p], hi, sizeof(hi));
		break;
	}
	case GRID_KEYS: {
		/* the grid's shape in locals, for the same reason (the keys
		 * are uint32_t, which may alias g's ints) */
		const float lx = g->lo[0], ly = g->lo[1], lz = g->lo[2];
		const float inv = g->inv_cell;
		const int nx = g->nx, ny = g->ny, nz = g->nz;
		uint32_t *key = j->key;

		for (i = a; i < b; i++)
			key[i] = (uint32_t)(((size_t)cell_coord(r[i].pos[2], lz,
			    inv, nz) * (size_t)ny + (size_t)cell_coord(
			    r[i].pos[1], ly, inv, ny)) * (size_t)nx +
			    (size_t)cell_coord(r[i].pos[0], lx, inv, nx));
		break;
	}
	case GRID_COUNT:
		/* The counts' running sums end each cell (within the part's
		 * range; GRID_PLACE adds the parts before). */
		for (i = 0; i < j->n; i++)
			if (j->key[i] >= c0 && j->key[i] < c1)
				g->start[j->key[i]]++;
		for (i = c0, sum = 0; i < c1; i++) {
			sum += g->start[i];
			g->start[i] = (uint32_t)sum;
		}
		j->total[p] = sum;
		break;
	case GRID_PLACE:
		for (i = 0, sum = 0; i < (size_t)p; i++)
			sum += j->total[i];
		for (i = c0; i < c1; i++)
			g->start[i] += (uint32_t)sum;
		/* The records placed from the last down leave each start at
		 * its cell's first, in the records' order, without a pass
		 * to shift the starts back. */
		for (i = j->n; i-- > 0;) {
			struct pm_irr_rec *x;
			struct pm_vec3 nv;

			if (j->key[i] < c0 || j->key[i] >= c1)
				continue;
			x = &g->rec[--g->start[j->key[i]]];
			nv = pm_dir_unpack(r[i].normal);
			memcpy(x->p, r[i].pos, sizeof(x->p));
			x->n[0] = nv.x;
			x->n[1] = nv.y;
			x->n[2] = nv.z;
			memcpy(x->E, r[i].power, sizeof(x->E));
			x->pad = 0.0f;
		}
		break;
	}
}

static void *
grid_worker(void *arg)
{
	struct grid_job *j = arg;
	int p;

	while ((p = atomic_fetch_add(&j->next, 1)) < j->parts)
		grid_part(j, p);
	return NULL;
}

/* Runs one phase of the build on every part. */
static void
grid_phase(struct grid_job *j, int phase, int threads)
{
	j->phase = phase;
	atomic_store(&j->next, 0);
	if (threads > 1 && j->parts > 1)
		pm_parallel(threads < j->parts ? threads : j->parts,
		    grid_worker, j);
	else
		grid_worker(j);
}

enum pm_err
pm_irr_grid_build(struct pm_irr_grid *g, const struct pm_photon *r, size_t n,
    int threads, struct pm_error *err)
{
	float hi[3], ext, cell, vol, spacing;
	size_t i, samples = 0;
	struct grid_job *j;
	double dsum = 0.0;
	int a, p;

	memset(g, 0, sizeof(*g));
	if (n == 0)
		return PM_OK;
	if (n >= UINT32_MAX)
		return pm_fail(err, PM_ERR_INVALID, "too many irradiance records");
	if ((j = calloc(1, sizeof(*j))) == NULL)
		return pm_fail(err, PM_ERR_NOMEM, "no memory for the irradiance grid");
	j->g = g;
	j->r = r;
	j->n = n;
	if (threads < 1)
		threads = 1;
	j->parts = threads < GRID_PARTS_MAX ? threads : GRID_PARTS_MAX;
	if (n < GRID_PART_RECS)
		j->parts = 1;
	grid_phase(j, GRID_BOUNDS, threads);
	for (a = 0; a < 3; a++) {
		g->lo[a] = j->lo[0][a];
		hi[a] = j->hi[0][a];
		for (p = 1; p < j->parts; p++) {
			g->lo[a] = pm_fminf(g->lo[a], j->lo[p][a]);
			hi[a] = pm_fmaxf(hi[a], j->hi[p][a]);
		}
	}
	/* The records' spacing: the mean distance to the nearest other
	 * record, from up to 256 of them (records are in kd-tree order, so
	 * pm_kdtree_knn works on them). */
	for (i = 0; i < n && samples < 256; i += n / 256 + 1) {
		struct pm_knn nb[2];
		float q[3] = {r[i].pos[0], r[i].pos[1], r[i].pos[2]};

		if (pm_kdtree_knn(r, n, q, 2, INFINITY, 0, 0, nb) == 2) {
			dsum += sqrt((double)nb[0].d2);
			samples++;
		}
	}
	ext = pm_fmaxf(pm_fmaxf(hi[0] - g->lo[0], hi[1] - g->lo[1]), hi[2] - g->lo[2]);
	spacing = samples > 0 ? (float)(dsum / (double)samples) : ext;
	cell = pm_fmaxf(2.0f * spacing, 1e-6f * pm_fmaxf(ext, 1e-30f));
	for (;;) {
		vol = 1.0f;
		for (a = 0; a < 3; a++)
			vol *= floorf((hi[a] - g->lo[a]) / cell) + 1.0f;
		if (vol <= (float)GRID_MAX_CELLS &&
		    vol <= GRID_CELLS_PER_REC * (float)n)
			break;
		cell *= 1.25f;
	}
	g->inv_cell = 1.0f / cell;
	g->nx = (int)((hi[0] - g->lo[0]) / cell) + 1;
	g->ny = (int)((hi[1] - g->lo[1]) / cell) + 1;
	g->nz = (int)((hi[2] - g->lo[2]) / cell) + 1;
	j->ncell = (size_t)g->nx * (size_t)g->ny * (size_t)g->nz;
	g->start = calloc(j->ncell + 1, sizeof(*g->start));
	g->rec = malloc(n * sizeof(*g->rec));
	j->key = malloc(n * sizeof(*j->key));
	if (g->start == NULL || g->rec == NULL || j->key == NULL) {
		free(j->key);
		free(j);
		pm_irr_grid_free(g);
		return pm_fail(err, PM_ERR_NOMEM, "no memory for the irradiance grid");
	}
	/* Counting sort of the records by cell, each record's cell computed
	 * once. */
	grid_phase(j, GRID_KEYS, threads);
	grid_phase(j, GRID_COUNT, threads);
	g->start[j->ncell] = (uint32_t)n;
	grid_phase(j, GRID_PLACE, threads);
	free(j->key);
	free(j);
	return PM_OK;
}

void
pm_irr_grid_free(struct pm_irr_grid *g)
{
	free(g->start);
	free(g->rec);
	g->start = NULL;
	g->rec = NULL;
}

/* The nearest compatible record of one cell, improving *best. */
static inline void
scan_cell(const struct pm_irr_grid *g, size_t c, struct pm_vec3 p,
    struct pm_vec3 nrm, float *best, uint32_t *bi)
{
	uint32_t k;

	for (k = g->start[c]; k < g->start[c + 1]; k++) {
		const struct pm_irr_rec *x = &g->rec[k];
		float dx = x->p[0] - p.x, dy = x->p[1] - p.y, dz = x->p[2] - p.z;
		float d2 = dx * dx + dy * dy + dz * dz;

		if (d2 < *best && x->n[0] * nrm.x + x->n[1] * nrm.y +
		    x->n[2] * nrm.z > PM_IRR_COS) {
			*best = d2;
			*bi = k;
		}
	}
}

static inline size_t
grid_cell(const struct pm_irr_grid *g, struct pm_vec3 p)
{
	return ((size_t)cell_coord(p.z, g->lo[2], g->inv_cell, g->nz) *
	    (size_t)g->ny + (size_t)cell_coord(p.y, g->lo[1], g->inv_cell,
	    g->ny)) * (size_t)g->nx + (size_t)cell_coord(p.x, g->lo[0],
	    g->inv_cell, g->nx);
}

void
pm_irradiance_prefetch(const struct pm_irr_grid *g, const struct pm_vec3 *p,
    size_t n)
{
	size_t i;

	if (g == NULL || g->start == NULL)
		return;
	/* the cells' starts, all of them in flight at once; then, as they
	 * arrive, the first records each names (a cell holds a few, which
	 * the next line's prefetch covers) */
	for (i = 0; i < n; i++)
		__builtin_prefetch(&g->start[grid_cell(g, p[i])]);
	for (i = 0; i < n; i++) {
		size_t c = grid_cell(g, p[i]);
		uint32_t k = g->start[c], e = g->start[c + 1];

		if (k < e)
			__builtin_prefetch(&g->rec[k]);
		if (e - k > 2)
			__builtin_prefetch(&g->rec[k + 2]);
	}
}

bool
pm_irradiance_lookup(const struct pm_irr_grid *g, struct pm_vec3 p,
    struct pm_vec3 nrm, struct pm_rgb *E)
{
	float best = INFINITY;
	uint32_t bi = 0;
	int cx, cy, cz, x, y, z;

	if (g == NULL || g->start == NULL)
		return false;
	cx = cell_coord(p.x, g->lo[0], g->inv_cell, g->nx);
	cy = cell_coord(p.y, g->lo[1], g->inv_cell, g->ny);
	cz = cell_coord(p.z, g->lo[2], g->inv_cell, g->nz);
	scan_cell(g, ((size_t)cz * (size_t)g->ny + (size_t)cy) * (size_t)g->nx +
	    (size_t)cx, p, nrm, &best, &bi);
	if (best == INFINITY)
		for (z = cz - 1; z <= cz + 1; z++)
			for (y = cy - 1; y <= cy + 1; y++)
				for (x = cx - 1; x <= cx + 1; x++) {
					if (x < 0 || y < 0 || z < 0 || x >= g->nx ||
					    y >= g->ny || z >= g->nz ||
					    (x == cx && y == cy && z == cz))
						continue;
					scan_cell(g, ((size_t)z * (size_t)g->ny +
					    (size_t)y) * (size_t)g->nx + (size_t)x,
					    p, nrm, &best, &bi);
				}
	if (best == INFINITY)
		return false;
	*E = pm_rgbe_unpack(g->rec[bi].E);
	return true;
}
