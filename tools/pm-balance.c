/*
 * pm-balance: merges photon-map shards into one file and balances the
 * kd-tree of every map in it, ready for pm-render.
 *
 * Shards shot over disjoint ranges of photon-path indices merge into
 * exactly the map one run would give, in a canonical order that depends
 * only on the set of photons (common/photonmap.h says how); this tool
 * reads them, reports, and writes the result.
 */
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "../common/error.h"
#include "../common/irradiance.h"
#include "../common/parse.h"
#include "../common/photonmap.h"
#include "../formats/pmap.h"
#include "cli.h"

#define PROG		"pm-balance"

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
    "  -t, --threads n       threads for the map check and the kd-tree\n"
    "                        build (default: all cores)\n"
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

static int verbosity = 1;	/* 0 with -q, 2 with -v */

/* Reports a usage error in one line and exits 2. */
#define usage_error pm_cli_usage_error

/* Frees the inputs read so far. */
static void
free_inputs(struct pm_pmap *in, int n)
{
	int i;

	for (i = 0; in != NULL && i < n; i++)
		pm_pmap_free(&in[i]);
}

/* The merge's note of paths that no input covers (with -v). */
static void
gap_note(void *arg, enum pm_map_kind kind, uint64_t from, uint64_t to)
{
	(void)arg;
	if (verbosity >= 2)
		fprintf(stderr, "%s: note: %s photon paths [%llu, %llu) are in "
		    "no input\n", PROG, pm_map_kind_name(kind),
		    (unsigned long long)from, (unsigned long long)to);
}

/* With -v: what one input holds. */
static void
describe_input(const char *name, const struct pm_pmap *m)
{
	int k;

	fprintf(stderr, "%s: %s:", PROG, name);
	for (k = 0; k < m->nmaps; k++)
		fprintf(stderr, "%s %s %llu photons from paths [%llu, %llu)%s",
		    k > 0 ? ";" : "", pm_map_kind_name(m->maps[k].kind),
		    (unsigned long long)m->maps[k].count,
		    (unsigned long long)m->maps[k].first_index,
		    (unsigned long long)(m->maps[k].first_index +
		    m->maps[k].emitted), m->maps[k].balanced ? ", balanced" :
		    "");
	fprintf(stderr, "%s\n", m->nmaps == 0 ? " no maps" : "");
}

int
main(int argc, char *argv[])
{
	struct pm_error err;
	struct pm_pmap *in = NULL, out;
	struct pm_shard *shards = NULL;
	struct pm_irradiance_setup irr;
	struct pm_pmap_bgwrite *bg = NULL;
	struct pm_map last;
	enum pm_err r;
	struct pm_cli_opts co;
	const char *output;
	bool force, compress = false;
	long threads;
	long irr_stride = 8, irr_k = 32, pass = 0;
	float irr_radius = 0.05f, alpha = 2.0f / 3.0f;
	int ch, i, j, k, n = 0, nread = 0, nstdin = 0, status = 1;
	int *order = NULL;
	uint64_t dropped;
	double t, t_sort;
	struct pm_cli_progress *prog = NULL;
	_Atomic long pdone, ptotal;

	memset(&out, 0, sizeof(out));
	pm_cli_opts_init(&co);
	while ((ch = pm_cli_getopt(&cli, argc, argv, "fho:qt:v")) != -1) {
		if (pm_cli_common(&co, ch))
			continue;
		switch (ch) {
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
	output = co.output;
	force = co.force;
	verbosity = co.verbosity;
	threads = co.threads;
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

	irr.stride = (size_t)irr_stride;
	irr.k = (int)irr_k;
	irr.radius = irr_radius;
	irr.pass = pass;
	irr.alpha = alpha;
	irr.threads = (int)threads;
	n = argc;
	in = calloc((size_t)n, sizeof(*in));
	shards = calloc((size_t)n, sizeof(*shards));
	order = calloc((size_t)n, sizeof(*order));
	if (in == NULL || shards == NULL || order == NULL) {
		fprintf(stderr, "%s: out of memory\n", PROG);
		goto done;
	}
	for (i = 0; i < n; i++) {
		shards[i].name = strcmp(argv[i], "-") == 0 ? "standard input" :
		    argv[i];
		shards[i].m = &in[i];
		/* Mapped read-only: the records are copied out below. */
		if (pm_pmap_read_threads(argv[i], &in[i], true,
		    (int)threads, &err) != PM_OK) {
			fprintf(stderr, "%s: %s\n", PROG, err.msg);
			goto done;
		}
		nread = i + 1;
		if ((dropped = pm_pmap_drop_irradiance(&in[i])) > 0 &&
		    verbosity >= 1)
			fprintf(stderr, "%s: %s: note: its irradiance map "
			    "(%llu records) is dropped, not merged\n", PROG,
			    shards[i].name, (unsigned long long)dropped);
		if (i > 0 && pm_pmap_compatible(&shards[0], &shards[i], &err) !=
		    PM_OK) {
			fprintf(stderr, "%s: %s\n", PROG, err.msg);
			goto done;
		}
		if (verbosity >= 2)
			describe_input(argv[i], &in[i]);
	}
	/* The copy out of the inputs is the canonical sort's first pass. */
	t = pm_cli_now();
	if (pm_pmap_merge_canonical(shards, n, &out, order, gap_note, NULL,
	    (int)threads, &err) != PM_OK) {
		fprintf(stderr, "%s: %s\n", PROG, err.msg);
		goto done;
	}
	t_sort = pm_cli_now() - t;
	/* The provenance of the input whose first map starts lowest, so that
	 * the order given does not matter; "tool" names the version too, as
	 * pm-shoot's line does; then the inputs in merge order. */
	if (in[order[0]].info != NULL && (out.info = strdup(
	    in[order[0]].info)) == NULL) {
		fprintf(stderr, "%s: out of memory\n", PROG);
		goto done;
	}
	if (pm_pmap_info_add(&out, "tool", PROG " " PM_VERSION, &err) !=
	    PM_OK || pm_pmap_info_add(&out, "command", pm_cli_command(), &err) != PM_OK) {
		fprintf(stderr, "%s: %s\n", PROG, err.msg);
		goto done;
	}
	for (i = 0; i < n; i++)
		if (pm_pmap_info_add(&out, "input", shards[order[i]].name,
		    &err) != PM_OK) {
			fprintf(stderr, "%s: %s\n", PROG, err.msg);
			goto done;
		}
	/* The records are copied; the inputs are no longer needed. */
	free_inputs(in, nread);
	nread = 0;

	if (verbosity >= 2)
		fprintf(stderr, "%s: merged and sorted into the canonical order "
		    "in %.3f s\n", PROG, t_sort);

	/* Progress in photons: the kd-tree build counts twice (it sorts
	 * along every level) and writing once. */
	atomic_init(&pdone, 0);
	atomic_init(&ptotal, 0);
	for (k = 0; k < out.nmaps; k++)
		atomic_fetch_add(&ptotal, 3 * (long)out.maps[k].count);
	prog = pm_cli_progress_start(PROG, "", pm_cli_progress_wanted(
	    verbosity == 0), &pdone, &ptotal, NULL, NULL, 0.0);
	for (k = 0; k < out.nmaps; k++) {
		struct pm_map *m = &out.maps[k];

		t = pm_cli_now();
		if (pm_map_build_tree(m, (int)threads, &err) != PM_OK) {
			pm_cli_progress_hold(prog);
			fprintf(stderr, "%s: %s: %s map: %s\n", PROG, output,
			    pm_map_kind_name(m->kind), err.msg);
			goto done;
		}
		atomic_fetch_add(&pdone, 2 * (long)m->count);
		pm_cli_progress_hold(prog);
		if (verbosity >= 2)
			fprintf(stderr, "%s: %s map: %llu photons, %llu paths "
			    "[%llu, %llu), from %d input%s; "
			    "kd-tree built in %.3f s with %ld thread%s\n", PROG,
			    pm_map_kind_name(m->kind),
			    (unsigned long long)m->count,
			    (unsigned long long)m->emitted,
			    (unsigned long long)m->first_index,
			    (unsigned long long)(m->first_index + m->emitted),
			    n, n == 1 ? "" : "s", pm_cli_now() - t,
			    threads, threads == 1 ? "" : "s");
		pm_cli_progress_release(prog);
	}

	t = pm_cli_now();
	k = out.nmaps;
	/* With threads to spare, the photon maps are written while the
	 * irradiance records are made (the same bytes): written after
	 * them, on one thread, they took 25 of 384 ms on two threads
	 * (1M cornell-box paths), the others idle. */
	if (!compress && threads > 1 && strcmp(output, "-") != 0 &&
	    pm_pmap_irradiance_entry(&out, &irr, &last) &&
	    pm_pmap_write_begin(&bg, output, &out, &last, &err) != PM_OK) {
		fprintf(stderr, "%s: %s\n", PROG, err.msg);
		goto done;
	}
	if (pm_pmap_add_irradiance(&out, &irr, &err) != PM_OK) {
		pm_pmap_write_cancel(bg);
		bg = NULL;
		fprintf(stderr, "%s: %s: %s\n", PROG, output, err.msg);
		goto done;
	}
	if (out.nmaps > k && verbosity >= 2)
		fprintf(stderr, "%s: irradiance map: %llu records, one per %zu "
		    "global photons, %s %.6g, in %.3f s\n", PROG,
		    (unsigned long long)out.maps[k].count, irr.stride,
		    pass > 0 ? "fixed radius" : "k-nearest within",
		    sqrt(pm_irradiance_setup_r2(pm_pmap_find(&out,
		    PM_MAP_GLOBAL), &irr)), pm_cli_now() - t);

	t = pm_cli_now();
	r = bg != NULL ? pm_pmap_write_end(bg, &out.maps[k], &err) :
	    pm_pmap_write_threads(output, &out, compress, (int)threads, &err);
	bg = NULL;
	if (r != PM_OK) {
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
		    compress ? ", compressed," : "", pm_cli_now() - t);
	status = 0;

done:
	pm_pmap_write_cancel(bg);
	if (prog != NULL) {
		/* Held: the line was cleared for an error message. */
		pm_cli_progress_release(prog);
		pm_cli_progress_stop(prog);
	}
	free_inputs(in, nread);
	for (j = 0; j < out.nmaps; j++)
		free(out.maps[j].photons);
	free(out.info);
	free(in);
	free(shards);
	free(order);
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
