/*
 * pm-shoot: traces photons from a scene's lights into a photon-map file:
 * a global map and, only where the scene has specular surfaces, a caustic
 * map.  The file is not yet balanced; pm-balance merges shards and builds
 * the kd-trees.
 */
#include <sys/statvfs.h>

#include <errno.h>
#include <getopt.h>
#include <libgen.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "cli.h"
#include "../common/parse.h"
#include "../common/shoot.h"
#include "../common/world.h"
#include "../formats/pmap.h"
#include "../formats/scene_xml.h"

#define PROG "pm-shoot"

static const char usage_line[] =
    "usage: pm-shoot [-fqv] [--photons N] [--caustic-photons N] [--seed S]\n"
    "                [--first-index I] [--max-depth D] [-t THREADS]\n"
    "                [-D NAME=VALUE] [--compress] -o OUT.pmap SCENE.xml\n";

static const char help_text[] =
    "Trace photon paths from a scene's lights into an unbalanced photon map:\n"
    "a global map and, where the scene has specular surfaces, a caustic map.\n"
    "Each path emitted stores a photon at every non-specular surface it\n"
    "reaches: --photons counts paths, the map holds a multiple of that.\n\n"
    "  -o, --output OUT.pmap     the map; - is standard output\n"
    "  -f, --force               overwrite an existing output\n"
    "      --photons N           photon paths to emit for the global map\n"
    "                            (default: the scene's globalPhotons, else\n"
    "                            film pixels x spp / 10, from 10^4 to 10^6)\n"
    "      --caustic-photons N   photon paths to emit for the caustic map\n"
    "                            (default: the scene's causticPhotons, else\n"
    "                            as --photons)\n"
    "      --seed S              random seed (default 0)\n"
    "      --first-index I       index of the first path, for shards\n"
    "      --max-depth D         bounces a photon may make; -1: unlimited\n"
    "  -t, --threads N           threads (default: all cores)\n"
    "  -D, --define NAME=VALUE   set a scene's $NAME default\n"
    "      --compress            zlib-compress the photon records\n"
    "  -q, --quiet               no progress line, no warnings\n"
    "  -v, --verbose             effects simulated, counts and timings\n"
    "  -h, --help                print this help and exit\n"
    "      --version             print the version and exit\n\n"
    "A progress line goes to stderr when it is a terminal.\n";

/* A usage error: one line on stderr, exit 2. */
#define usage_error pm_cli_usage_error

/*
 * Shoots a pass as pm_shoot does; with done set, in pieces of about a
 * hundredth, counting the paths shot in *done for the progress line.  Path
 * i depends only on (seed, pass, i) and pm_shoot appends in path order, so
 * the photons are the same either way.
 */
static enum pm_err
shoot_pass(const struct pm_shooter *sh, const struct pm_shoot_opts *so,
    struct pm_photon_buf *out, struct pm_shoot_stats *st, _Atomic long *done,
    struct pm_error *err)
{
	struct pm_shoot_opts piece = *so;
	struct pm_shoot_stats ps;
	uint64_t step = so->count / 100, at;
	enum pm_err e;

	if (done == NULL)
		return pm_shoot(sh, so, out, st, err);
	if (step < 65536)
		step = 65536;
	memset(st, 0, sizeof(*st));
	for (at = 0; at < so->count; at += piece.count) {
		piece.first = so->first + at;
		piece.count = so->count - at < step ? so->count - at : step;
		if ((e = pm_shoot(sh, &piece, out, &ps, err)) != PM_OK)
			return e;
		st->stored += ps.stored;
		st->dropped += ps.dropped;
		st->paths_specular += ps.paths_specular;
		st->volume_stored += ps.volume_stored;
		atomic_fetch_add(done, (long)piece.count);
	}
	return PM_OK;
}

/* Physical memory in bytes; 0 when the system will not say. */
static double
machine_memory(void)
{
	long pages = sysconf(_SC_PHYS_PAGES), size = sysconf(_SC_PAGESIZE);

	return pages > 0 && size > 0 ? (double)pages * (double)size : 0.0;
}

/* Bytes free to an unprivileged user on the file system that path (a
 * file, perhaps not there yet) goes to; 0 when the system will not say. */
static double
disk_free(const char *path)
{
	struct statvfs sv;
	char *dir = strdup(path);
	double free_bytes = 0.0;

	if (dir != NULL && statvfs(dirname(dir), &sv) == 0)
		free_bytes = (double)sv.f_bavail * (double)sv.f_frsize;
	free(dir);
	return free_bytes;
}

/*
 * How many photons n paths of a pass will store, from a pilot run of the
 * first PILOT_PATHS of them: paths store a scene-dependent number of
 * photons, so only shooting some tells.  The pilot's photons are the
 * same ones the real run will shoot, so nothing about the map changes.
 */
#define PILOT_PATHS 4096
static enum pm_err
estimate_stored(const struct pm_shooter *sh, const struct pm_shoot_opts *so,
    double *stored, struct pm_error *err)
{
	struct pm_shoot_opts pilot = *so;
	struct pm_shoot_stats st;
	struct pm_photon_buf b = {NULL, 0, 0};
	enum pm_err e;

	pilot.count = PILOT_PATHS;
	e = pm_shoot(sh, &pilot, &b, &st, err);
	pm_photon_buf_free(&b);
	*stored = (double)(st.stored + st.volume_stored) / PILOT_PATHS *
	    (double)so->count;
	return e;
}

/* Where pm_shoot puts the photons of a streamed map: map `map` of w. */
struct file_sink {
	struct pm_pmap_writer *w;
	int map;
};

_Static_assert(sizeof(struct pm_pmap_run) <= PM_SHOOT_NOTE,
    "a chunk's note holds its run's summary");

/* On the tracing thread: the chunk's checksum and bounds. */
static void
to_file_prepare(void *arg, const struct pm_photon *p, size_t n,
    unsigned char note[PM_SHOOT_NOTE])
{
	struct pm_pmap_run r;

	(void)arg;
	pm_pmap_run_summarize(&r, p, n);
	memcpy(note, &r, sizeof(r));
}

/* In path order: folded into the map's and written. */
static enum pm_err
to_file(void *arg, const struct pm_photon *p, size_t n,
    const unsigned char note[PM_SHOOT_NOTE], struct pm_error *err)
{
	struct file_sink *s = arg;
	struct pm_pmap_run r;
	enum pm_err e;

	(void)p;
	(void)n;
	memcpy(&r, note, sizeof(r));
	e = pm_pmap_writer_add_run(s->w, s->map, &r, err);
	if (e != PM_OK)
		s->w = NULL;	/* freed by the failed add */
	return e;
}

int
main(int argc, char **argv)
{
	enum {
		OPT_PHOTONS = 256, OPT_CAUSTIC, OPT_SEED, OPT_FIRST, OPT_MAXDEPTH,
		OPT_COMPRESS,
	};
	static const struct option longopts[] = {
		{"photons", required_argument, NULL, OPT_PHOTONS},
		{"caustic-photons", required_argument, NULL, OPT_CAUSTIC},
		{"seed", required_argument, NULL, OPT_SEED},
		{"first-index", required_argument, NULL, OPT_FIRST},
		{"max-depth", required_argument, NULL, OPT_MAXDEPTH},
		{"threads", required_argument, NULL, 't'},
		{"define", required_argument, NULL, 'D'},
		{"compress", no_argument, NULL, OPT_COMPRESS},
		{"output", required_argument, NULL, 'o'},
		{"force", no_argument, NULL, 'f'},
		{"quiet", no_argument, NULL, 'q'},
		{"verbose", no_argument, NULL, 'v'},
		{"help", no_argument, NULL, 'h'},
		{"version", no_argument, NULL, PM_CLI_VERSION},
		{NULL, 0, NULL, 0},
	};
	static const struct pm_cli cli = {PROG, usage_line, help_text, longopts};
	struct pm_cli_progress *prog;
	enum pm_err e;
	_Atomic long done, total;
	struct pm_cli_opts co;
	const char *out_path, *scene_path;
	long threads, max_depth = -2;
	long long nglobal = -1, ncaustic = -1;
	unsigned long long seed = 0, first = 0, v;
	int verbose, force, compress = 0, c, status = 0;
	struct pm_scene scene;
	struct pm_world world;
	struct pm_shooter shooter;
	struct pm_effects fx;
	struct pm_error err = {PM_OK, ""};
	struct pm_pmap out;
	struct pm_photon_buf bufs[2] = {{NULL, 0, 0}, {NULL, 0, 0}};
	struct pm_photon_buf vbuf = {NULL, 0, 0};	/* the volume map */
	char tmp[128];
	double t0;
	int pass, i, vmap = -1, smap[2] = {-1, -1};
	bool stream;
	struct file_sink sink = {NULL, -1};

	pm_cli_opts_init(&co);
	while ((c = pm_cli_getopt(&cli, argc, argv, "D:fho:qt:v")) != -1) {
		if (pm_cli_common(&co, c))
			continue;
		switch (c) {
		case OPT_PHOTONS:
			if (!pm_parse_u64(optarg, &v) || v > (1ULL << 40))
				usage_error("--photons wants a count from 0 to 2^40, not '%s'",
				    optarg);
			nglobal = (long long)v;
			break;
		case OPT_CAUSTIC:
			if (!pm_parse_u64(optarg, &v) || v > (1ULL << 40))
				usage_error("--caustic-photons wants a count from 0 to 2^40, "
				    "not '%s'", optarg);
			ncaustic = (long long)v;
			break;
		case OPT_SEED:
			if (!pm_parse_u64(optarg, &seed))
				usage_error("--seed wants a non-negative integer, not '%s'",
				    optarg);
			break;
		case OPT_FIRST:
			if (!pm_parse_u64(optarg, &first) || first > (1ULL << 62))
				usage_error("--first-index wants a non-negative integer, "
				    "not '%s'", optarg);
			break;
		case OPT_MAXDEPTH:
			if (!pm_parse_long(optarg, -1, 1000, &max_depth))
				usage_error("--max-depth wants -1 (unlimited) to 1000, not '%s'",
				    optarg);
			break;
		case OPT_COMPRESS:
			compress = 1;
			break;
		default:
			usage_error("unhandled option '%s'", argv[optind - 1]);
		}
	}
	out_path = co.output;
	force = co.force;
	verbose = co.verbosity;
	threads = co.threads;
	if (optind + 1 != argc)
		usage_error("%s", optind == argc ? "no scene file given" :
		    "more than one scene file given");
	scene_path = argv[optind];
	if (out_path == NULL)
		usage_error("%s", "no output given (-o OUT.pmap, or -o - for stdout)");
	if (!pm_cli_check_output(PROG, out_path, force))
		return 1;

	t0 = pm_cli_now();
	if (pm_scene_load(scene_path, co.defs, co.ndefs, &scene, &err) != PM_OK) {
		fprintf(stderr, PROG ": %s\n", err.msg);
		return 1;
	}
	if (scene.nlights == 0) {
		fprintf(stderr, PROG ": %s: the scene has no lights to shoot photons "
		    "from\n", scene_path);
		pm_scene_free(&scene);
		return 1;
	}
	if (nglobal < 0)
		nglobal = scene.integrator.photon.global_photons;
	if (nglobal < 0)
		nglobal = pm_shoot_default_paths(&scene);
	if (ncaustic < 0)
		ncaustic = scene.integrator.photon.caustic_photons;
	if (ncaustic < 0)
		ncaustic = pm_shoot_default_paths(&scene);
	if (max_depth == -2)
		max_depth = pm_shoot_default_max_depth(&scene);
	pm_shoot_effects(&scene, &fx);
	if (pm_world_init(&world, &scene, &err) != PM_OK) {
		fprintf(stderr, PROG ": %s: %s\n", scene_path, err.msg);
		pm_scene_free(&scene);
		return 1;
	}
	if (pm_shooter_init(&shooter, &scene, world.accel, &world.lights,
	    &err) != PM_OK) {
		fprintf(stderr, PROG ": %s: %s\n", scene_path, err.msg);
		pm_world_free(&world);
		pm_scene_free(&scene);
		return 1;
	}
	if (verbose >= 2) {
		fprintf(stderr, PROG ": %s: loaded in %.3f s; simulating:\n",
		    scene_path, pm_cli_now() - t0);
		for (i = 0; i < PM_EFFECT_NOTES; i++)
			fprintf(stderr, "%s: %s\n", fx.notes[i].name,
			    fx.notes[i].text);
	}
	if (verbose && scene.dropped_triangles > 0)
		fprintf(stderr, PROG ": %s: warning: %zu degenerate triangles "
		    "(zero area or non-finite vertices) dropped\n", scene_path,
		    scene.dropped_triangles);

	/*
	 * To a named file, uncompressed, the maps are written as their
	 * photons come (pm_pmap_writer), not held: the memory stays a few
	 * chunks whatever the map's size, and the writing overlaps the
	 * tracing instead of following it.  The global pass of a scene
	 * with media makes two maps at once (volume and global), which a
	 * file written in order cannot take; it, --compress (whose sizes
	 * come only at the end) and standard output keep the maps whole.
	 */
	stream = strcmp(out_path, "-") != 0 && !compress && !fx.media;

	/*
	 * Refuse, before allocating, a request whose photons would not fit
	 * in memory: each pass's photons are held twice at its end (the
	 * threads' chunks and the map they are gathered into).  Streamed
	 * maps are not held, but their file must fit on its disk.  Small
	 * requests cannot exceed any machine and skip the pilot.
	 */
	{
		double need = 0.0, stored[2] = {0, 0};
		double have = stream ? disk_free(out_path) : machine_memory();

		for (pass = 0; pass < 2; pass++) {
			struct pm_shoot_opts so;
			long long n = pass == 0 ? nglobal : ncaustic;

			if (!(pass == 0 ? fx.global || fx.media : fx.caustic) ||
			    n <= (1LL << 20))
				continue;
			memset(&so, 0, sizeof(so));
			so.volume = pass == 0 && fx.media ? &vbuf : NULL;
			so.pass = pass == 0 ? PM_PASS_GLOBAL : PM_PASS_CAUSTIC;
			so.seed = seed;
			so.first = first;
			so.count = (uint64_t)n;
			so.max_depth = (int)max_depth;
			so.threads = (int)threads;
			if (estimate_stored(&shooter, &so, &stored[pass], &err) != PM_OK) {
				fprintf(stderr, PROG ": %s: %s\n", scene_path, err.msg);
				status = 1;
				break;
			}
			need += (stream ? 1.0 : 2.0) * stored[pass] *
			    (double)sizeof(struct pm_photon);
		}
		if (status == 0 && have > 0.0 && need > 0.9 * have) {
			fprintf(stderr, PROG ": %s: %.3g photons would need about %.1f "
			    "GiB of %s, and %s has %.1f GiB%s: shoot fewer paths, "
			    "or shards with --first-index\n", scene_path,
			    stored[0] + stored[1], need / (1024.0 * 1024.0 * 1024.0),
			    stream ? "disk" : "memory", stream ? "its file system" :
			    "this machine", have / (1024.0 * 1024.0 * 1024.0),
			    stream ? " free" : "");
			status = 1;
		}
		if (status != 0) {
			pm_shooter_free(&shooter);
			pm_world_free(&world);
			pm_scene_free(&scene);
			return 1;
		}
	}

	memset(&out, 0, sizeof(out));
	out.scene_hash = pm_scene_hash(&scene);
	out.seed = seed;
	out.max_depth = max_depth < 0 ? 0 : (uint32_t)max_depth;
	out.effects = (fx.global ? PM_EFFECT_GLOBAL : 0) |
	    (fx.caustic ? PM_EFFECT_CAUSTICS : 0) |
	    (fx.refraction ? PM_EFFECT_REFRACTION : 0) |
	    (fx.media ? PM_EFFECT_MEDIA : 0);
	pm_pmap_info_add(&out, "tool", PROG " " PM_VERSION, NULL);
	pm_pmap_info_add(&out, "command", pm_cli_command(), NULL);
	pm_pmap_info_add(&out, "scene", scene_path, NULL);
	snprintf(tmp, sizeof(tmp), "%016llx", (unsigned long long)out.scene_hash);
	pm_pmap_info_add(&out, "scene_hash", tmp, NULL);
	snprintf(tmp, sizeof(tmp), "%llu", seed);
	pm_pmap_info_add(&out, "seed", tmp, NULL);
	for (i = 0; i < PM_EFFECT_NOTES; i++) {
		snprintf(tmp, sizeof(tmp), "effect.%s", fx.notes[i].name);
		pm_pmap_info_add(&out, tmp, fx.notes[i].text, NULL);
	}
	/* The maps in file order: the global pass's volume map, then its
	 * global map (a scene with media alone shoots that pass for the
	 * volume map), then the caustic map. */
	for (pass = 0; pass < 2; pass++) {
		long long n = pass == 0 ? nglobal : ncaustic;
		static const enum pm_map_kind kinds[3] = {
			PM_MAP_VOLUME, PM_MAP_GLOBAL, PM_MAP_CAUSTIC
		};
		bool has[3] = {pass == 0 && fx.media, pass == 0 && fx.global,
		    pass == 1 && fx.caustic};
		int k;

		smap[pass] = -1;
		for (k = 0; k < 3; k++) {
			struct pm_map *m;

			if (!has[k] || n == 0)
				continue;
			if (k == 0)
				vmap = out.nmaps;
			else
				smap[pass] = out.nmaps;
			m = &out.maps[out.nmaps++];
			m->kind = kinds[k];
			m->emitted = (uint64_t)n;
			m->first_index = first;
		}
	}
	if (stream && pm_pmap_writer_open(&sink.w, out_path, &out, &err) !=
	    PM_OK) {
		fprintf(stderr, PROG ": %s\n", err.msg);
		status = 1;
	}

	for (pass = 0; pass < 2 && status == 0; pass++) {
		struct pm_shoot_opts so;
		struct pm_shoot_stats st;
		long long n = pass == 0 ? nglobal : ncaustic;

		if (smap[pass] < 0 && (pass == 1 || vmap < 0))
			continue;
		memset(&so, 0, sizeof(so));
		if (stream) {
			sink.map = smap[pass];
			so.sink_prepare = to_file_prepare;
			so.sink = to_file;
			so.sink_arg = &sink;
		}
		so.volume = pass == 0 && fx.media ? &vbuf : NULL;
		so.pass = pass == 0 ? PM_PASS_GLOBAL : PM_PASS_CAUSTIC;
		so.seed = seed;
		so.first = first;
		so.count = (uint64_t)n;
		so.max_depth = (int)max_depth;
		so.threads = (int)threads;
		t0 = pm_cli_now();
		/* One progress line a map, ended before -v reports it. */
		atomic_init(&done, 0);
		atomic_init(&total, (long)n);
		prog = pm_cli_progress_start(PROG, pass == 0 ? "global map" :
		    "caustic map", pm_cli_progress_wanted(!verbose), &done, &total,
		    NULL, NULL, 0.0);
		e = shoot_pass(&shooter, &so, &bufs[pass], &st, prog != NULL ?
		    &done : NULL, &err);
		pm_cli_progress_stop(prog);
		if (e != PM_OK) {
			fprintf(stderr, PROG ": %s: %s\n", scene_path, err.msg);
			status = 1;
			break;
		}
		if (verbose >= 2)
			fprintf(stderr, PROG ": %s map: %lld paths [%llu, %llu) shot in "
			    "%.3f s (%.0f paths/s), %llu photons stored, %llu dropped\n",
			    pass == 0 ? "global" : "caustic", n, first,
			    first + (unsigned long long)n, pm_cli_now() - t0,
			    (double)n / (pm_cli_now() - t0), (unsigned long long)st.stored,
			    (unsigned long long)st.dropped);
		else if (st.dropped > 0 && verbose)
			fprintf(stderr, PROG ": warning: %llu non-finite photons dropped\n",
			    (unsigned long long)st.dropped);
		if (verbose >= 2 && so.volume != NULL)
			fprintf(stderr, PROG ": volume map: %llu photons stored "
			    "at scatters in media\n",
			    (unsigned long long)st.volume_stored);
		if (vmap >= 0 && pass == 0) {
			out.maps[vmap].count = vbuf.n;
			out.maps[vmap].photons = vbuf.p;
		}
		if (smap[pass] < 0)	/* shot for the volume map alone */
			pm_photon_buf_free(&bufs[pass]);
		else if (!stream) {
			out.maps[smap[pass]].count = bufs[pass].n;
			out.maps[smap[pass]].photons = bufs[pass].p;
		}
		/* lo and hi stay 0: the writer computes the bounds it
		 * stores in its own pass over the photons. */
	}
	if (stream && sink.w != NULL) {
		if (status == 0 && pm_pmap_writer_close(sink.w, &err) != PM_OK) {
			fprintf(stderr, PROG ": %s\n", err.msg);
			status = 1;
		} else if (status != 0)
			pm_pmap_writer_abort(sink.w);
		sink.w = NULL;
	}
	if (status == 0 && !stream && pm_pmap_write(out_path, &out, compress,
	    &err) != PM_OK) {
		fprintf(stderr, PROG ": %s\n", err.msg);
		status = 1;
	}
	/* The records belong to the buffers, not to the file structure. */
	for (i = 0; i < out.nmaps; i++)
		out.maps[i].photons = NULL;
	out.nmaps = 0;
	pm_pmap_free(&out);
	pm_photon_buf_free(&bufs[0]);
	pm_photon_buf_free(&bufs[1]);
	pm_photon_buf_free(&vbuf);
	pm_shooter_free(&shooter);
	pm_world_free(&world);
	pm_scene_free(&scene);
	if (status == 0 && strcmp(out_path, "-") == 0 && fclose(stdout) != 0) {
		fprintf(stderr, PROG ": standard output: %s\n", strerror(errno));
		status = 1;
	}
	return status;
}
