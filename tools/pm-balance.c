/*
 * pm-balance: merges photon-map shards into one file and balances the
 * kd-tree of every map in it, ready for pm-render.
 *
 * pm-shoot can shoot one map in pieces (on several machines, or at
 * different times) over disjoint ranges of photon-path indices; because
 * each path depends only on (seed, kind, index), the pieces hold exactly
 * the photons one run over the whole range would store.  This tool checks
 * that the pieces belong together (same scene, seed, effects, depth and
 * maps, ranges that do not overlap), concatenates them, adds their emitted
 * counts and builds the trees.
 *
 * Before the build the photons are put in one canonical order (sorted by
 * their bytes, split-axis bits cleared), so the output depends only on the
 * set of photons: shards given in any order, balanced or not, merge into
 * the very bytes that balancing one unsharded run gives, and balancing a
 * balanced map changes nothing but its provenance.
 */
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "../common/error.h"
#include "../common/irradiance.h"
#include "../common/kdtree.h"
#include "../common/parse.h"
#include "../common/photon.h"
#include "../common/render.h"
#include "../formats/pmap.h"
#include "cli.h"

#define PROG		"pm-balance"
#define MAX_THREADS	4096

static const char usage_line[] =
    "usage: pm-balance [-fqv] [-t THREADS] [--compress] [--irradiance-stride N]\n"
    "                  [--irradiance-k K] [--irradiance-radius R]\n"
    "                  [--pass I [--alpha A]] -o OUT.pmap IN.pmap ...\n";

static const char help_text[] =
    "Merge photon-map shards of one scene, balance their kd-trees and\n"
    "precompute irradiance records.  An input of - is standard input.\n\n"
    "      --alpha a         progressive radius schedule (default 2/3)\n"
    "      --compress        zlib-compress the photon records\n"
    "  -f, --force           overwrite an existing output\n"
    "  -h, --help            print this help and exit\n"
    "      --irradiance-k k  photons per irradiance record (default 32)\n"
    "      --irradiance-radius r  largest record radius, as a fraction\n"
    "                        of the global map's half-diagonal (default"
    " 0.05)\n"
    "      --irradiance-stride n  one irradiance record per n global\n"
    "                        photons (default 8; 0: none)\n"
    "  -o, --output file     the merged map; - is standard output\n"
    "      --pass i          progressive pass i: records over a fixed\n"
    "                        radius shrinking with i\n"
    "  -q, --quiet           no progress line, no warnings\n"
    "  -t, --threads n       threads for the kd-tree build (default:"
    " all cores)\n"
    "  -v, --verbose         per-map counts and build times\n"
    "      --version         print the version and exit\n\n"
    "A progress line goes to stderr when it is a terminal.\n";

enum {
	OPT_COMPRESS = 256, OPT_IRR_STRIDE, OPT_IRR_K, OPT_IRR_RADIUS,
	OPT_PASS, OPT_ALPHA,
};

static const struct option longopts[] = {
	{ "alpha",	required_argument,	NULL,	OPT_ALPHA },
	{ "compress",	no_argument,		NULL,	OPT_COMPRESS },
	{ "irradiance-k", required_argument,	NULL,	OPT_IRR_K },
	{ "irradiance-radius", required_argument, NULL,	OPT_IRR_RADIUS },
	{ "irradiance-stride", required_argument, NULL,	OPT_IRR_STRIDE },
	{ "pass",	required_argument,	NULL,	OPT_PASS },
	{ "force",	no_argument,		NULL,	'f' },
	{ "help",	no_argument,		NULL,	'h' },
	{ "output",	required_argument,	NULL,	'o' },
	{ "quiet",	no_argument,		NULL,	'q' },
	{ "threads",	required_argument,	NULL,	't' },
	{ "verbose",	no_argument,		NULL,	'v' },
	{ "version",	no_argument,		NULL,	PM_CLI_VERSION },
	{ NULL,		0,			NULL,	0 },
};

static const struct pm_cli cli = { PROG, usage_line, help_text, longopts };

/* One input file, read whole. */
struct input {
	const char *name;
	struct pm_pmap m;
	bool loaded;
};

/* One map of one input, for sorting by first index. */
struct piece {
	const struct input *in;
	const struct pm_map *map;
};

static int verbosity = 1;	/* 0 with -q, 2 with -v */

/* Reports a usage error in one line and exits 2. */
#define usage_error pm_cli_usage_error

static double
now(void)
{
	struct timespec ts;

	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static const char *
kind_name(enum pm_map_kind kind)
{
	switch (kind) {
	case PM_MAP_GLOBAL:
		return "global";
	case PM_MAP_CAUSTIC:
		return "caustic";
	case PM_MAP_IRRADIANCE:
		return "irradiance";
	}
	return "unknown";
}

/* The set of photon-map kinds in m, as bits 1 << kind: irradiance maps
 * are not merged (see drop_irradiance). */
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

/*
 * Takes an input's irradiance map out of it, with a note: its records
 * estimate irradiance from that input's global photons alone, so they
 * cannot be merged with another shard's, and they are no longer in kd-tree
 * order once the photons they describe are rebalanced.  The other maps
 * keep their order; the last slot keeps the records, so that
 * pm_pmap_free, which frees every slot, still frees them.
 */
static void
drop_irradiance(struct input *in)
{
	struct pm_pmap *m = &in->m;
	struct pm_map t;
	int i;

	for (i = 0; i < m->nmaps; i++) {
		if (m->maps[i].kind != PM_MAP_IRRADIANCE)
			continue;
		if (verbosity >= 1)
			fprintf(stderr, "%s: %s: note: its irradiance map "
			    "(%llu records) is dropped, not merged\n", PROG,
			    in->name, (unsigned long long)m->maps[i].count);
		t = m->maps[i];
		memmove(&m->maps[i], &m->maps[i + 1], (size_t)(m->nmaps - 1 -
		    i) * sizeof(t));
		m->maps[m->nmaps - 1] = t;
		m->nmaps--;
		return;		/* a kind appears at most once */
	}
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

/*
 * Checks that b can be merged with a: every field that decides which
 * photons a path stores must agree.  Prints the difference and returns
 * false if not.
 */
static bool
compatible(const struct input *a, const struct input *b)
{
	char sa[32], sb[32];

	if (a->m.scene_hash != b->m.scene_hash) {
		fprintf(stderr, "%s: %s: scene hash %016llx differs from %s's "
		    "(%016llx): shot from another scene\n", PROG, b->name,
		    (unsigned long long)b->m.scene_hash, a->name,
		    (unsigned long long)a->m.scene_hash);
		return false;
	}
	if (a->m.seed != b->m.seed) {
		fprintf(stderr, "%s: %s: seed %llu differs from %s's (%llu)\n",
		    PROG, b->name, (unsigned long long)b->m.seed, a->name,
		    (unsigned long long)a->m.seed);
		return false;
	}
	if (a->m.effects != b->m.effects) {
		fprintf(stderr, "%s: %s: effects 0x%x differ from %s's (0x%x)\n",
		    PROG, b->name, (unsigned)b->m.effects, a->name,
		    (unsigned)a->m.effects);
		return false;
	}
	if (a->m.max_depth != b->m.max_depth) {
		fprintf(stderr, "%s: %s: max_depth %u differs from %s's (%u)\n",
		    PROG, b->name, (unsigned)b->m.max_depth, a->name,
		    (unsigned)a->m.max_depth);
		return false;
	}
	if (kind_set(&a->m) != kind_set(&b->m)) {
		kind_set_name(kind_set(&b->m), sb, sizeof(sb));
		kind_set_name(kind_set(&a->m), sa, sizeof(sa));
		fprintf(stderr, "%s: %s: holds %s maps, %s holds %s\n", PROG,
		    b->name, sb, a->name, sa);
		return false;
	}
	return true;
}

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
	size_t count[256], next[256], end[256], i, j, at;
	const size_t len = sizeof(struct pm_photon);
	struct pm_photon t;
	unsigned v;

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
	memset(count, 0, sizeof(count));
	for (i = 0; i < n; i++)
		count[((const unsigned char *)&p[i])[byte]]++;
	for (at = 0, i = 0; i < 256; i++) {
		next[i] = at;
		at += count[i];
		end[i] = at;
	}
	/* Each swap puts one record into its bucket for good. */
	for (i = 0; i < 256; i++)
		while (next[i] < end[i]) {
			v = ((const unsigned char *)&p[next[i]])[byte];
			if (v == i) {
				next[i]++;
				continue;
			}
			t = p[next[v]];
			p[next[v]++] = p[next[i]];
			p[next[i]] = t;
		}
	for (at = 0, i = 0; i < 256; i++) {
		if (count[i] > 1)
			canonical_sort(p + at, count[i], byte + 1);
		at += count[i];
	}
}

/*
 * Sorts the pieces of one kind by first index and checks that their
 * index ranges are disjoint; fills the merged header fields.
 */
static bool
plan_map(struct piece *pc, int n, struct pm_map *out)
{
	uint64_t end_prev = 0, count = 0, emitted = 0;
	int i, prev = -1;

	qsort(pc, (size_t)n, sizeof(*pc), cmp_piece);
	out->first_index = pc[0].map->first_index;
	for (i = 0; i < n; i++) {
		const struct pm_map *m = pc[i].map;

		if (m->emitted > UINT64_MAX - m->first_index) {
			fprintf(stderr, "%s: %s: %s photon paths [%llu, +%llu) "
			    "pass 2^64\n", PROG, pc[i].in->name,
			    kind_name(m->kind),
			    (unsigned long long)m->first_index,
			    (unsigned long long)m->emitted);
			return false;
		}
		if (emitted > UINT64_MAX - m->emitted ||
		    count > UINT64_MAX - m->count) {
			fprintf(stderr, "%s: %s: %s photon counts pass 2^64\n",
			    PROG, pc[i].in->name, kind_name(m->kind));
			return false;
		}
		emitted += m->emitted;
		count += m->count;
		/* An empty range overlaps nothing and starts nothing. */
		if (m->emitted == 0)
			continue;
		if (prev < 0)
			out->first_index = m->first_index;
		else if (m->first_index < end_prev) {
			const struct pm_map *p = pc[prev].map;

			fprintf(stderr, "%s: %s: %s photon paths [%llu, %llu) "
			    "overlap those of %s [%llu, %llu)\n", PROG,
			    pc[i].in->name, kind_name(m->kind),
			    (unsigned long long)m->first_index,
			    (unsigned long long)(m->first_index + m->emitted),
			    pc[prev].in->name,
			    (unsigned long long)p->first_index,
			    (unsigned long long)(p->first_index + p->emitted));
			return false;
		} else if (m->first_index > end_prev && verbosity >= 2)
			fprintf(stderr, "%s: note: %s photon paths [%llu, %llu) "
			    "are in no input\n", PROG, kind_name(m->kind),
			    (unsigned long long)end_prev,
			    (unsigned long long)m->first_index);
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
	return true;
}

/* Photons copied between two drop_pages (1.5 MB). */
#define GATHER_STEP	65536

/*
 * Tells the system that the whole pages inside [p, p + len) are no longer
 * needed: an input's records, once copied.  Mapped from the file, they
 * leave this process's memory (the page cache keeps them); read into
 * memory, their pages are given back.  Either way the input and its copy
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

/* Concatenates the pieces' photons into out (allocated here), in order
 * of first index, dropping each input's pages as they are copied. */
static bool
gather(const struct piece *pc, int n, struct pm_map *out)
{
	struct pm_photon *p;
	size_t at = 0, total, done, step;
	bool have_bounds = false;
	int j, a;

	if (out->count > SIZE_MAX / sizeof(*p)) {
		fprintf(stderr, "%s: %s map: %llu photons do not fit in "
		    "memory\n", PROG, kind_name(out->kind),
		    (unsigned long long)out->count);
		return false;
	}
	total = (size_t)out->count;
	p = malloc(total > 0 ? total * sizeof(*p) : 1);
	if (p == NULL) {
		fprintf(stderr, "%s: %s map: out of memory for %zu photons\n",
		    PROG, kind_name(out->kind), total);
		return false;
	}
	for (j = 0; j < n; j++) {
		const struct pm_map *m = pc[j].map;

		for (done = 0; done < (size_t)m->count; done += step) {
			step = (size_t)m->count - done < GATHER_STEP ?
			    (size_t)m->count - done : GATHER_STEP;
			memcpy(p + at + done, m->photons + done,
			    step * sizeof(*p));
			drop_pages(m->photons + done, step * sizeof(*p));
		}
		at += (size_t)m->count;
		/* The inputs' bounds, merged; an empty map's say nothing. */
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
	return true;
}

static void
free_inputs(struct input *in, int n)
{
	int i;

	for (i = 0; in != NULL && i < n; i++)
		if (in[i].loaded) {
			pm_pmap_free(&in[i].m);
			in[i].loaded = false;
		}
}

/*
 * Adds precomputed irradiance records (irradiance.h) made from the
 * balanced global map of m, with their own kd-tree.  Their radius is a
 * fraction of the global map's half-diagonal: the k-nearest cap, or with
 * a progressive pass the fixed radius, shrinking along the schedule
 * pm-render's --pass follows, so that the records' blur averages away
 * over passes.  True when done (or when there is no global map).
 */
static bool
add_irradiance(struct pm_pmap *m, size_t stride, int k, float radius,
    long pass, float alpha, int threads, const char *output)
{
	struct pm_error err = {PM_OK, ""};
	struct pm_map *g = pm_pmap_find(m, PM_MAP_GLOBAL), *r;
	struct pm_irradiance_opts o;
	double diag = 0.0, t = now();
	size_t n;
	int a;

	if (g == NULL || g->count == 0 || g->emitted == 0 ||
	    pm_pmap_find(m, PM_MAP_IRRADIANCE) != NULL ||
	    m->nmaps >= (int)(sizeof(m->maps) / sizeof(m->maps[0])))
		return true;
	/* The merged bounds of the inputs (every reader checks them). */
	for (a = 0; a < 3; a++)
		diag += (double)(g->hi[a] - g->lo[a]) * (g->hi[a] - g->lo[a]);
	o.stride = stride;
	o.k = k;
	o.max_r2 = (float)(radius * radius * 0.25 * diag);
	o.fixed_radius = pass > 0;
	if (pass > 0) {
		double f = pm_pppm_radius_scale(pass, alpha);

		o.max_r2 = (float)(o.max_r2 * f * f);
	}
	/* pm-shoot caps photons at max_depth - 2 bounces for a scene's
	 * max_depth (0: none); a record feeds a gather ray, one segment
	 * more, so it counts one bounce fewer. */
	o.max_depth = m->max_depth > 0 ? (int)m->max_depth - 1 : -1;
	o.threads = threads;
	r = &m->maps[m->nmaps];
	memset(r, 0, sizeof(*r));
	r->kind = PM_MAP_IRRADIANCE;
	r->radius = sqrtf(o.max_r2);
	if (pm_irradiance_records(g->photons, (size_t)g->count,
	    1.0f / (float)g->emitted, &o, &r->photons, &n, &err) != PM_OK ||
	    pm_kdtree_build(r->photons, n, threads, &err) != PM_OK) {
		fprintf(stderr, "%s: %s: irradiance records: %s\n", PROG, output,
		    err.msg);
		free(r->photons);
		r->photons = NULL;
		return false;
	}
	r->count = n;
	r->balanced = true;
	m->nmaps++;
	if (verbosity >= 2)
		fprintf(stderr, "%s: irradiance map: %zu records, one per %zu "
		    "global photons, %s %.6g, in %.3f s\n", PROG, n, stride,
		    pass > 0 ? "fixed radius" : "k-nearest within", sqrt(o.max_r2),
		    now() - t);
	return true;
}

int
main(int argc, char *argv[])
{
	struct pm_error err;
	struct input *in = NULL;
	struct piece *pc = NULL;
	struct pm_pmap out;
	const struct input *first;
	const char *output = NULL;
	bool force = false, compress = false;
	long threads = sysconf(_SC_NPROCESSORS_ONLN);
	long irr_stride = 8, irr_k = 32, pass = 0;
	float irr_radius = 0.05f, alpha = 2.0f / 3.0f;
	int ch, i, j, k, n = 0, nstdin = 0, status = 1;
	double t, t_sort;
	struct pm_cli_progress *prog = NULL;
	_Atomic long pdone, ptotal;
	size_t sz;

	memset(&out, 0, sizeof(out));
	if (threads < 1)
		threads = 1;
	if (threads > MAX_THREADS)
		threads = MAX_THREADS;
	while ((ch = pm_cli_getopt(&cli, argc, argv, "fho:qt:v")) != -1) {
		switch (ch) {
		case 'f':
			force = true;
			break;
		case 'o':
			output = optarg;
			break;
		case 'q':
			verbosity = 0;
			break;
		case 't':
			if (!pm_parse_long(optarg, 1, MAX_THREADS, &threads))
				usage_error("--threads: expected a count from 1 "
				    "to %d, got '%s'", MAX_THREADS, optarg);
			break;
		case 'v':
			verbosity = 2;
			break;
		case OPT_COMPRESS:
			compress = true;
			break;
		case OPT_IRR_STRIDE:
			if (!pm_parse_long(optarg, 0, 1L << 30, &irr_stride))
				usage_error("--irradiance-stride: expected a count "
				    "from 0, got '%s'", optarg);
			break;
		case OPT_IRR_K:
			if (!pm_parse_long(optarg, 1, PM_IRR_MAX_K, &irr_k))
				usage_error("--irradiance-k: expected a count from 1 "
				    "to %d, got '%s'", PM_IRR_MAX_K, optarg);
			break;
		case OPT_IRR_RADIUS:
			if (!pm_parse_float(optarg, 1e-9f, 1e9f, &irr_radius))
				usage_error("--irradiance-radius: expected a positive "
				    "number, got '%s'", optarg);
			break;
		case OPT_PASS:
			if (!pm_parse_long(optarg, 1, 1L << 30, &pass))
				usage_error("--pass: expected a pass number from 1, "
				    "got '%s'", optarg);
			break;
		case OPT_ALPHA:
			if (!pm_parse_float(optarg, 1e-6f, 1.0f - 1e-6f, &alpha))
				usage_error("--alpha: expected a number in (0, 1), "
				    "got '%s'", optarg);
			break;
		default:
			usage_error("unhandled option '%s'", argv[optind - 1]);
		}
	}
	argc -= optind;
	argv += optind;

	if (output == NULL)
		usage_error("no output: give -o OUT.pmap, or -o - for standard "
		    "output");
	if (argc < 1)
		usage_error("no input files");
	if (argc > 1 << 20)
		usage_error("too many input files (at most %d)", 1 << 20);
	for (i = 0; i < argc; i++)
		if (strcmp(argv[i], "-") == 0)
			nstdin++;
	if (nstdin > 1)
		usage_error("standard input (-) can be read only once");
	if (nstdin > 0 && isatty(STDIN_FILENO)) {
		fprintf(stderr, "%s: -: refusing to read a photon map from a "
		    "terminal\n", PROG);
		return 1;
	}
	/* Checked before reading, so that nothing is read in vain. */
	if (!pm_cli_check_output(PROG, output, force))
		return 1;

	n = argc;
	in = calloc((size_t)n, sizeof(*in));
	pc = calloc((size_t)n, sizeof(*pc));
	if (in == NULL || pc == NULL) {
		fprintf(stderr, "%s: out of memory\n", PROG);
		goto done;
	}
	for (i = 0; i < n; i++) {
		in[i].name = strcmp(argv[i], "-") == 0 ? "standard input" :
		    argv[i];
		/* Mapped read-only: the records are copied out below. */
		if (pm_pmap_read(argv[i], &in[i].m, true, &err) != PM_OK) {
			fprintf(stderr, "%s: %s\n", PROG, err.msg);
			goto done;
		}
		in[i].loaded = true;
		drop_irradiance(&in[i]);
		if (i > 0 && !compatible(&in[0], &in[i]))
			goto done;
		if (verbosity >= 2) {
			fprintf(stderr, "%s: %s:", PROG, argv[i]);
			for (k = 0; k < in[i].m.nmaps; k++) {
				const struct pm_map *m = &in[i].m.maps[k];

				fprintf(stderr, "%s %s %llu photons from paths "
				    "[%llu, %llu)%s", k > 0 ? ";" : "",
				    kind_name(m->kind),
				    (unsigned long long)m->count,
				    (unsigned long long)m->first_index,
				    (unsigned long long)(m->first_index +
				    m->emitted), m->balanced ? ", balanced" :
				    "");
			}
			fprintf(stderr, "%s\n", in[i].m.nmaps == 0 ?
			    " no maps" : "");
		}
	}

	out.scene_hash = in[0].m.scene_hash;
	out.seed = in[0].m.seed;
	out.effects = in[0].m.effects;
	out.max_depth = in[0].m.max_depth;
	out.nmaps = in[0].m.nmaps;
	/* The maps in the first input's order; the provenance of the input
	 * whose first map starts lowest, so that the order given does not
	 * matter. */
	first = &in[0];
	for (k = 0; k < in[0].m.nmaps; k++) {
		enum pm_map_kind kind = in[0].m.maps[k].kind;

		for (i = 0; i < n; i++) {
			pc[i].in = &in[i];
			pc[i].map = pm_pmap_find(&in[i].m, kind);
		}
		if (!plan_map(pc, n, &out.maps[k]))
			goto done;
		if (k == 0)
			first = pc[0].in;
		if (!gather(pc, n, &out.maps[k]))
			goto done;
	}
	if (first->m.info != NULL && (out.info = strdup(first->m.info)) ==
	    NULL) {
		fprintf(stderr, "%s: out of memory\n", PROG);
		goto done;
	}
	/* "tool" names the version too, as pm-shoot's line does. */
	if (pm_pmap_info_add(&out, "tool", PROG " " PM_VERSION, &err) !=
	    PM_OK || pm_pmap_info_add(&out, "command", pm_cli_command(), &err) != PM_OK) {
		fprintf(stderr, "%s: %s\n", PROG, err.msg);
		goto done;
	}
	/* The inputs in merge order (of the first map's index ranges). */
	if (out.nmaps > 0) {
		for (i = 0; i < n; i++) {
			pc[i].in = &in[i];
			pc[i].map = pm_pmap_find(&in[i].m, out.maps[0].kind);
		}
		qsort(pc, (size_t)n, sizeof(*pc), cmp_piece);
	}
	for (i = 0; i < n; i++)
		if (pm_pmap_info_add(&out, "input", out.nmaps > 0 ?
		    pc[i].in->name : in[i].name, &err) != PM_OK) {
			fprintf(stderr, "%s: %s\n", PROG, err.msg);
			goto done;
		}
	/* The records are copied; the inputs are no longer needed. */
	free_inputs(in, n);

	/* Progress in photons: sorting counts once, the kd-tree build twice
	 * (it sorts along every level) and writing once. */
	atomic_init(&pdone, 0);
	atomic_init(&ptotal, 0);
	for (k = 0; k < out.nmaps; k++)
		atomic_fetch_add(&ptotal, 4 * (long)out.maps[k].count);
	prog = pm_cli_progress_start(PROG, "", pm_cli_progress_wanted(
	    verbosity == 0), &pdone, &ptotal, NULL, NULL, 0.0);
	for (k = 0; k < out.nmaps; k++) {
		struct pm_map *m = &out.maps[k];

		t = now();
		for (sz = 0; sz < (size_t)m->count; sz++)
			m->photons[sz].flags &= (uint8_t)~PM_KD_AXIS_MASK;
		canonical_sort(m->photons, (size_t)m->count, 0);
		t_sort = now() - t;
		atomic_fetch_add(&pdone, (long)m->count);
		t = now();
		if (pm_kdtree_build(m->photons, (size_t)m->count, (int)threads,
		    &err) != PM_OK) {
			pm_cli_progress_hold(prog);
			fprintf(stderr, "%s: %s: %s map: %s\n", PROG, output,
			    kind_name(m->kind), err.msg);
			goto done;
		}
		m->balanced = true;
		atomic_fetch_add(&pdone, 2 * (long)m->count);
		pm_cli_progress_hold(prog);
		if (verbosity >= 2)
			fprintf(stderr, "%s: %s map: %llu photons, %llu paths "
			    "[%llu, %llu), from %d input%s; sorted in %.3f s, "
			    "kd-tree built in %.3f s with %ld thread%s\n", PROG,
			    kind_name(m->kind), (unsigned long long)m->count,
			    (unsigned long long)m->emitted,
			    (unsigned long long)m->first_index,
			    (unsigned long long)(m->first_index + m->emitted),
			    n, n == 1 ? "" : "s", t_sort, now() - t, threads,
			    threads == 1 ? "" : "s");
		pm_cli_progress_release(prog);
	}

	if (irr_stride > 0 && !add_irradiance(&out, (size_t)irr_stride,
	    (int)irr_k, irr_radius, pass, alpha, (int)threads, output))
		goto done;

	t = now();
	if (pm_pmap_write(output, &out, compress, &err) != PM_OK) {
		pm_cli_progress_hold(prog);
		fprintf(stderr, "%s: %s\n", PROG, err.msg);
		goto done;
	}
	atomic_store(&pdone, atomic_load(&ptotal));
	pm_cli_progress_stop(prog);
	prog = NULL;
	if (verbosity >= 2)
		fprintf(stderr, "%s: %s: %d map%s written%s in %.3f s\n", PROG,
		    output, out.nmaps, out.nmaps == 1 ? "" : "s",
		    compress ? ", compressed," : "", now() - t);
	status = 0;

done:
	if (prog != NULL) {
		/* Held: the line was cleared for an error message. */
		pm_cli_progress_release(prog);
		pm_cli_progress_stop(prog);
	}
	free_inputs(in, n);
	for (j = 0; j < out.nmaps; j++)
		free(out.maps[j].photons);
	free(out.info);
	free(in);
	free(pc);
	if (status != 0)
		return status;

	/* A full disk or a closed pipe shows up only here. */
	errno = 0;
	if (fflush(stdout) != 0 || ferror(stdout) || fclose(stdout) != 0) {
		fprintf(stderr, "%s: stdout: %s\n", PROG,
		    errno != 0 ? strerror(errno) : "write error");
		return 1;
	}
	return 0;
}
