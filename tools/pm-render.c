/*
 * pm-render: renders a scene's camera to a linear EXR.
 *
 * This file only parses options, loads the inputs, calls the library and
 * reports; the rendering itself lives in common/.
 */
#include <errno.h>
#include <getopt.h>
#include <libgen.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "../common/accel.h"
#include "../common/parse.h"
#include "../common/render.h"
#include "../formats/exr.h"
#include "../formats/scene_xml.h"

#define PROG "pm-render"
#define VERSION "0.1.0"
#define MAX_DEFINES 64

static const char usage_line[] =
    "usage: pm-render [-qv] [--method path] [--spp N] [--size WxH] [--eye X,Y,Z]\n"
    "                 [--target X,Y,Z] [--up X,Y,Z] [--fov DEG] [-D NAME=VALUE]\n"
    "                 [--seed N] [-t THREADS] [--half] -o OUT.exr SCENE.xml\n";

static void
usage_error(const char *fmt, const char *arg)
{
	fprintf(stderr, PROG ": ");
	fprintf(stderr, fmt, arg);
	fprintf(stderr, "\n%s", usage_line);
	exit(2);
}

static double
now(void)
{
	struct timespec ts;

	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* Fails early, before any rendering, if the output cannot be created. */
static int
check_output_dir(const char *path)
{
	char *copy = strdup(path), *dir;
	int ok;

	if (copy == NULL)
		return 0;
	dir = dirname(copy);
	ok = access(dir, W_OK) == 0;
	if (!ok)
		fprintf(stderr, PROG ": %s: cannot write to directory %s: %s\n",
		    path, dir, strerror(errno));
	free(copy);
	return ok;
}

struct progress {
	_Atomic long done;
	long total;
	_Atomic int stop;
};

static void *
progress_thread(void *arg)
{
	struct progress *p = arg;
	struct timespec ts = {0, 250000000};

	while (!atomic_load(&p->stop)) {
		if (p->total > 0)
			fprintf(stderr, "\r" PROG ": %3ld%%",
			    100 * atomic_load(&p->done) / p->total);
		nanosleep(&ts, NULL);
	}
	fprintf(stderr, "\r" PROG ": 100%%\n");
	return NULL;
}

int
main(int argc, char **argv)
{
	enum {
		OPT_METHOD = 256, OPT_SPP, OPT_SIZE, OPT_EYE, OPT_TARGET, OPT_UP,
		OPT_FOV, OPT_SEED, OPT_HALF, OPT_HELP, OPT_VERSION,
	};
	static const struct option longopts[] = {
		{"method", required_argument, NULL, OPT_METHOD},
		{"spp", required_argument, NULL, OPT_SPP},
		{"size", required_argument, NULL, OPT_SIZE},
		{"eye", required_argument, NULL, OPT_EYE},
		{"target", required_argument, NULL, OPT_TARGET},
		{"up", required_argument, NULL, OPT_UP},
		{"fov", required_argument, NULL, OPT_FOV},
		{"define", required_argument, NULL, 'D'},
		{"seed", required_argument, NULL, OPT_SEED},
		{"threads", required_argument, NULL, 't'},
		{"half", no_argument, NULL, OPT_HALF},
		{"output", required_argument, NULL, 'o'},
		{"quiet", no_argument, NULL, 'q'},
		{"verbose", no_argument, NULL, 'v'},
		{"help", no_argument, NULL, OPT_HELP},
		{"version", no_argument, NULL, OPT_VERSION},
		{NULL, 0, NULL, 0},
	};
	struct pm_define defs[MAX_DEFINES];
	size_t ndefs = 0;
	const char *out_path = NULL, *scene_path;
	struct pm_vec3 eye, target, up = {0, 1, 0};
	int have_eye = 0, have_target = 0, width = 0, height = 0, half = 0;
	int verbose = 1, c;
	long spp = 0, threads = sysconf(_SC_NPROCESSORS_ONLN);
	float fov = 0.0f;
	unsigned long long seed = 0;
	struct pm_scene scene;
	struct pm_accel *accel = NULL;
	struct pm_lights lights;
	struct pm_render_ctx ctx;
	struct pm_render_opts opts;
	struct pm_render_stats stats;
	struct pm_image img = {0, 0, NULL};
	struct pm_error err = {PM_OK, ""};
	struct pm_camera cam;
	struct pm_vec3 lo, hi;
	struct progress prog;
	pthread_t prog_tid;
	int show_progress;
	double t0, t_load, t_render;

	if (threads < 1)
		threads = 1;
	while ((c = getopt_long(argc, argv, "D:o:qt:v", longopts, NULL)) != -1) {
		switch (c) {
		case 'D': {
			char *eq = strchr(optarg, '=');

			if (eq == NULL || eq == optarg)
				usage_error("-D wants NAME=VALUE, not '%s'", optarg);
			if (ndefs == MAX_DEFINES)
				usage_error("too many -D definitions (at most %s)", "64");
			*eq = '\0';
			defs[ndefs].name = optarg;
			defs[ndefs].value = eq + 1;
			ndefs++;
			break;
		}
		case 'o':
			out_path = optarg;
			break;
		case 'q':
			verbose = 0;
			break;
		case 't':
			if (!pm_parse_long(optarg, 1, 4096, &threads))
				usage_error("-t wants a thread count from 1 to 4096, not '%s'",
				    optarg);
			break;
		case 'v':
			verbose = 2;
			break;
		case OPT_METHOD:
			if (strcmp(optarg, "path") != 0)
				usage_error("unknown method '%s' (this build knows: path)",
				    optarg);
			break;
		case OPT_SPP:
			if (!pm_parse_long(optarg, 1, 1L << 24, &spp))
				usage_error("--spp wants a count from 1 to 16777216, not '%s'",
				    optarg);
			break;
		case OPT_SIZE:
			if (!pm_parse_size(optarg, 65536, &width, &height))
				usage_error("--size wants WxH, each 1 to 65536, not '%s'",
				    optarg);
			break;
		case OPT_EYE:
			if (!pm_parse_vec3(optarg, &eye))
				usage_error("--eye wants X,Y,Z, not '%s'", optarg);
			have_eye = 1;
			break;
		case OPT_TARGET:
			if (!pm_parse_vec3(optarg, &target))
				usage_error("--target wants X,Y,Z, not '%s'", optarg);
			have_target = 1;
			break;
		case OPT_UP:
			if (!pm_parse_vec3(optarg, &up))
				usage_error("--up wants X,Y,Z, not '%s'", optarg);
			break;
		case OPT_FOV:
			if (!pm_parse_float(optarg, 1e-3f, 179.0f, &fov))
				usage_error("--fov wants degrees in (0, 179], not '%s'",
				    optarg);
			break;
		case OPT_SEED:
			if (!pm_parse_u64(optarg, &seed))
				usage_error("--seed wants a non-negative integer, not '%s'",
				    optarg);
			break;
		case OPT_HALF:
			half = 1;
			break;
		case OPT_HELP:
			fputs(usage_line, stdout);
			return fclose(stdout) == 0 ? 0 : 1;
		case OPT_VERSION:
			puts(PROG " " VERSION);
			return fclose(stdout) == 0 ? 0 : 1;
		default:
			fputs(usage_line, stderr);
			return 2;
		}
	}
	if (optind + 1 != argc)
		usage_error("%s", optind == argc ? "no scene file given" :
		    "more than one scene file given");
	scene_path = argv[optind];
	if (out_path == NULL)
		usage_error("%s", "no output given (-o OUT.exr)");
	if (have_eye != have_target)
		usage_error("%s", "--eye and --target go together");
	if (!check_output_dir(out_path))
		return 1;

	t0 = now();
	if (pm_scene_load(scene_path, defs, ndefs, &scene, &err) != PM_OK) {
		fprintf(stderr, PROG ": %s\n", err.msg);
		return 1;
	}
	if (!scene.has_camera && !have_eye) {
		fprintf(stderr, PROG ": %s: the scene has no sensor; give --eye and --target\n",
		    scene_path);
		pm_scene_free(&scene);
		return 1;
	}
	cam = scene.camera;
	if (have_eye) {
		cam.to_world = pm_mat4_lookat(eye, target, up);
		if (!scene.has_camera)
			cam.fov = 45.0f;
	}
	if (fov > 0.0f)
		cam.fov = fov;
	if (width > 0) {
		cam.width = width;
		cam.height = height;
	}
	if (spp > 0)
		cam.spp = (int)spp;

	if (pm_accel_build(&scene, &accel, &err) != PM_OK) {
		fprintf(stderr, PROG ": %s: %s\n", scene_path, err.msg);
		pm_scene_free(&scene);
		return 1;
	}
	pm_accel_bounds(accel, &lo, &hi);
	if (!(pm_max_comp(pm_sub(hi, lo)) >= 0.0f)) {
		lo = pm_v3(0, 0, 0);
		hi = lo;
	}
	if (pm_lights_init(&lights, &scene, pm_scale(pm_add(lo, hi), 0.5f),
	    0.5f * pm_length(pm_sub(hi, lo)), &err) != PM_OK) {
		fprintf(stderr, PROG ": %s: %s\n", scene_path, err.msg);
		pm_accel_free(accel);
		pm_scene_free(&scene);
		return 1;
	}
	t_load = now() - t0;

	ctx.scene = &scene;
	ctx.accel = accel;
	ctx.lights = &lights;
	ctx.max_depth = scene.integrator.max_depth;
	ctx.rr_depth = scene.integrator.rr_depth;
	ctx.hide_emitters = scene.integrator.hide_emitters;
	opts.method = PM_METHOD_PATH;
	opts.spp = cam.spp;
	opts.seed = seed;
	opts.threads = (int)threads;
	atomic_init(&prog.done, 0);
	atomic_init(&prog.stop, 0);
	prog.total = 0;
	opts.tiles_done = &prog.done;
	opts.tiles_total = &prog.total;
	if (verbose >= 2)
		fprintf(stderr, PROG ": %s: %zu shapes, %zu lights, %dx%d, %d spp, "
		    "max_depth %d, %ld threads, loaded in %.3f s\n", scene_path,
		    scene.nshapes, scene.nlights, cam.width, cam.height, cam.spp,
		    ctx.max_depth, threads, t_load);
	if (scene.nlights == 0 && verbose)
		fprintf(stderr, PROG ": %s: warning: the scene has no lights\n",
		    scene_path);

	show_progress = verbose && isatty(STDERR_FILENO);
	if (show_progress &&
	    pthread_create(&prog_tid, NULL, progress_thread, &prog) != 0)
		show_progress = 0;
	t0 = now();
	if (pm_render(&ctx, &cam, &opts, &img, &stats, &err) != PM_OK) {
		fprintf(stderr, PROG ": %s\n", err.msg);
		return 1;
	}
	t_render = now() - t0;
	if (show_progress) {
		atomic_store(&prog.stop, 1);
		pthread_join(prog_tid, NULL);
	}
	if (pm_exr_write(out_path, &img, half, &err) != PM_OK) {
		fprintf(stderr, PROG ": %s\n", err.msg);
		return 1;
	}
	if (verbose >= 2)
		fprintf(stderr, PROG ": rendered %llu samples in %.3f s "
		    "(%.2f Msamples/s), %llu non-finite dropped\n",
		    (unsigned long long)stats.samples, t_render,
		    (double)stats.samples / t_render * 1e-6,
		    (unsigned long long)stats.dropped);
	else if (stats.dropped > 0 && verbose)
		fprintf(stderr, PROG ": warning: %llu non-finite samples dropped\n",
		    (unsigned long long)stats.dropped);
	pm_image_free(&img);
	pm_lights_free(&lights);
	pm_accel_free(accel);
	pm_scene_free(&scene);
	return 0;
}
