/*
 * pm-render: renders a scene's camera, or a list of cameras, to linear
 * EXR images: by path tracing (the reference), or from a photon map made
 * by pm-shoot and pm-balance (the gather pass of photon mapping).
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
#include <strings.h>
#include <time.h>
#include <unistd.h>

#include "cli.h"
#include "../common/occupancy.h"
#include "../common/parse.h"
#include "../common/photonmap.h"
#include "../common/render.h"
#include "../common/shoot.h"
#include "../common/world.h"
#include "../formats/exr.h"
#include "../formats/png.h"
#include "../formats/pmap.h"
#include "../formats/scene_xml.h"

#define PROG "pm-render"
#define MAX_CAMERAS 100000

static const char usage_line[] =
    "usage: pm-render [-fqv] [--method path | photon | ptracer] [--spp N]\n"
    "                 [--size WxH] [--eye X,Y,Z] [--target X,Y,Z] [--up X,Y,Z]\n"
    "                 [--fov DEG] [--cameras FILE] [-D NAME=VALUE] [--seed N]\n"
    "                 [-t THREADS] [--half] [--global-radius R]\n"
    "                 [--caustic-radius R] [--lookup-size K] [--direct-samples N]\n"
    "                 [--final-gather]"
    " [--no-final-gather] [--final-gather-samples N]\n"
    "                 [--cache-step PIXELS] [--cache-rays N]\n"
    "                 [--cache-accuracy A] [--pass I] [--radius R] [--alpha A]\n"
    "                 [--preview FILE] [--preview-every SECONDS]\n"
    "                 [--volume-estimate point|beam]\n"
    "                 -o OUT.exr SCENE.xml [MAP.pmap]\n";

static const char help_text[] =
    "Render a scene's cameras to linear OpenEXR images, by path tracing or,\n"
    "given a balanced photon map, by photon mapping.\n\n"
    "  -o, --output OUT.exr        the image; with several cameras a %d\n"
    "                              pattern or a number before the extension\n"
    "  -f, --force                 overwrite existing outputs\n"
    "      --method path|photon|ptracer\n"
    "                              path tracing, photon mapping (needs MAP)\n"
    "                              or particle tracing (default: the\n"
    "                              scene's integrator)\n"
    "      --spp N                 samples per pixel (default: the scene's)\n"
    "      --size WxH              image size (default: the scene's film)\n"
    "      --eye X,Y,Z, --target X,Y,Z, --up X,Y,Z\n"
    "                              a camera instead of the scene's\n"
    "      --fov DEG               field of view\n"
    "      --cameras FILE          one camera per line: EYE TARGET UP [FOV]\n"
    "  -D, --define NAME=VALUE     set a scene's $NAME default\n"
    "      --seed N                random seed (default 0)\n"
    "  -t, --threads N             threads (default: all cores)\n"
    "      --half                  write half floats\n"
    "      --global-radius R, --caustic-radius R\n"
    "                              lookup radii, fractions of the scene radius\n"
    "      --lookup-size K         photons per estimate\n"
    "      --direct-samples N      light samples per camera sample (default 1)\n"
    "      --final-gather, --no-final-gather\n"
    "                              gather indirect light (default), or show\n"
    "                              the global map's photons directly\n"
    "      --volume-estimate point|beam\n"
    "                              media: the volume map at a point of each\n"
    "                              camera segment (default), or the beam\n"
    "                              radiance estimate along it\n"
    "      --final-gather-samples N  gather rays of a camera sample that the\n"
    "                              irradiance cache does not serve (default 1)\n"
    "      --cache-step PIXELS     pixels between irradiance cache points\n"
    "                              (default 2, 1 from 256 spp: the finest\n"
    "                              whose rays per pixel stay within the\n"
    "                              spp; 0: no cache)\n"
    "      --cache-rays N          gather rays per cache point (default\n"
    "                              4 per spp, from 16 to 256)\n"
    "      --cache-accuracy A      Ward's a: larger trusts points farther\n"
    "                              (default 0.6)\n"
    "      --pass I                progressive pass I (1, 2, ...): fixed radii\n"
    "      --radius R              first pass's global radius\n"
    "      --alpha A               progressive radius shrinkage (default 2/3)\n"
    "      --preview FILE          write the image so far to FILE (.png or\n"
    "                              .exr) while rendering, for a viewer\n"
    "      --preview-every SECONDS how often (default 1)\n"
    "  -q, --quiet                 no progress line, no warnings\n"
    "  -v, --verbose               scene, map and timing details\n"
    "  -h, --help                  print this help and exit\n"
    "      --version               print the version and exit\n\n"
    "A progress line goes to stderr when it is a terminal.\n";

struct cam_override {
	struct pm_vec3 eye, target, up;
	float fov;			/* 0: keep */
};

/* A usage error: one line on stderr, exit 2. */
#define usage_error pm_cli_usage_error

/*
 * Reads a camera list: one camera per line, "EYE TARGET UP [FOV]" with
 * each vector as X,Y,Z; blank lines and lines starting with # are skipped.
 * Returns the count, or -1 after printing an error naming file and line.
 */
static long
read_cameras(const char *path, struct cam_override **out)
{
	FILE *f = fopen(path, "r");
	char line[1024];
	long n = 0, lineno = 0, cap = 0;
	struct cam_override *cams = NULL;

	if (f == NULL) {
		fprintf(stderr, PROG ": %s: %s\n", path, strerror(errno));
		return -1;
	}
	while (fgets(line, sizeof(line), f) != NULL) {
		char *tok[5], *save = NULL, *p = line;
		int nt = 0;
		struct cam_override c;

		lineno++;
		while (nt < 5 && (tok[nt] = strtok_r(p, " \t\r\n", &save)) != NULL) {
			p = NULL;
			nt++;
		}
		if (nt == 0 || tok[0][0] == '#')
			continue;
		c.fov = 0.0f;
		if (nt < 3 || nt > 4 || strtok_r(NULL, " \t\r\n", &save) != NULL ||
		    !pm_parse_vec3(tok[0], &c.eye) || !pm_parse_vec3(tok[1], &c.target) ||
		    !pm_parse_vec3(tok[2], &c.up) ||
		    (nt == 4 && !pm_parse_float(tok[3], 1e-3f, 179.0f, &c.fov))) {
			fprintf(stderr, PROG ": %s:%ld: expected EYE TARGET UP [FOV], "
			    "each vector as X,Y,Z\n", path, lineno);
			free(cams);
			fclose(f);
			return -1;
		}
		if (n == MAX_CAMERAS) {
			fprintf(stderr, PROG ": %s:%ld: more than %d cameras\n", path,
			    lineno, MAX_CAMERAS);
			free(cams);
			fclose(f);
			return -1;
		}
		if (n == cap) {
			struct cam_override *nc;

			cap = cap ? 2 * cap : 16;
			nc = realloc(cams, (size_t)cap * sizeof(*nc));
			if (nc == NULL) {
				fprintf(stderr, PROG ": %s: out of memory\n", path);
				free(cams);
				fclose(f);
				return -1;
			}
			cams = nc;
		}
		cams[n++] = c;
	}
	fclose(f);
	if (n == 0) {
		fprintf(stderr, PROG ": %s: no cameras in the file\n", path);
		free(cams);
		return -1;
	}
	*out = cams;
	return n;
}

/* Output name of camera i of n: the name itself for a single camera;
 * otherwise a printf pattern if it has one (frame-%04d.exr), else the
 * number inserted before the extension (out.exr -> out-0001.exr). */
static void
output_name(const char *pattern, long i, long n, char *buf, size_t len)
{
	const char *dot = strrchr(pattern, '.'), *pct = strchr(pattern, '%');

	if (n == 1)
		snprintf(buf, len, "%s", pattern);
	else if (pct != NULL && pct[1] != '\0')
		snprintf(buf, len, pattern, (int)(i + 1));
	else if (dot != NULL && strchr(dot, '/') == NULL)
		snprintf(buf, len, "%.*s-%04ld%s", (int)(dot - pattern), pattern,
		    i + 1, dot);
	else
		snprintf(buf, len, "%s-%04ld", pattern, i + 1);
}

/* Only %d-style patterns are accepted: the name is used as a format. */
static int
pattern_ok(const char *s)
{
	const char *p = strchr(s, '%');

	if (p == NULL)
		return 1;
	p++;
	while (*p >= '0' && *p <= '9')
		p++;
	return *p == 'd' && strchr(p, '%') == NULL;
}

/* True if path names a PNG file (else OpenEXR). */
static int
is_png(const char *path)
{
	size_t n = strlen(path);

	return n >= 4 && strcasecmp(path + n - 4, ".png") == 0;
}

/* The --preview file and what writing it needs. */
struct preview {
	const char *path;
	struct pm_render_watch *watch;
	struct pm_image snap;
	_Atomic long *done;		/* tiles finished */
	long written;			/* ...when the file was last written */
	int warned;
};

/* Writes im to the preview file (through a temporary, renamed); warns
 * once if it cannot. */
static void
preview_write(struct preview *pv, const struct pm_image *im)
{
	struct pm_error err = {PM_OK, ""};
	enum pm_err e;

	if (is_png(pv->path)) {
		uint8_t *rgb = malloc(3 * (size_t)im->width * (size_t)im->height);

		if (rgb == NULL)
			e = pm_fail(&err, PM_ERR_NOMEM, "%s: out of memory",
			    pv->path);
		else {
			pm_image_to_srgb8(im, 0.0f, rgb);
			e = pm_png_write_fast(pv->path, rgb, im->width,
			    im->height, &err);
			free(rgb);
		}
	} else
		e = pm_exr_write(pv->path, im, true, &err);
	if (e != PM_OK && !pv->warned) {
		fprintf(stderr, PROG ": warning: preview: %s\n", err.msg);
		pv->warned = 1;
	}
}

/* The progress thread's tick: the finished tiles so far, the rest black;
 * nothing if no tile has finished since the last write. */
static void
preview_tick(void *arg)
{
	struct preview *pv = arg;
	long done = atomic_load(pv->done);

	if (done != pv->written && pm_render_snapshot(pv->watch, &pv->snap)) {
		preview_write(pv, &pv->snap);
		pv->written = done;
	}
}

/* Progressive photon mapping's settings from the command line. */
struct pppm {
	long pass;		/* 0: not progressive */
	float radius;		/* first pass's global radius; 0: the scene's */
	double alpha;
};

/* Loads a balanced map for this scene into maps, with the lookup radii;
 * prints and returns 0 on failure. */
/* --volume-estimate beam (integrator_pmvol.c; docs/media.md measures
 * both). */
static bool volume_beam;

static int
load_maps(const char *path, const struct pm_scene *scene, float scene_radius,
    const struct pppm *pg, struct pm_pmap *pm, struct pm_photon_maps *maps,
    int verbose, int threads)
{
	struct pm_error err = {PM_OK, ""};
	const struct pm_photon_params *pp = &scene->integrator.photon;
	uint64_t want = pm_scene_hash(scene);
	struct pm_lookup_radii r;

	if (pm_pmap_read_threads(path, pm, true, threads, &err) != PM_OK) {
		fprintf(stderr, PROG ": %s\n", err.msg);
		return 0;
	}
	if (pm->scene_hash != want) {
		fprintf(stderr, PROG ": %s: the photons were shot in another scene "
		    "(scene hash %016llx, %s has %016llx); shoot them again\n", path,
		    (unsigned long long)pm->scene_hash, scene->path ? scene->path :
		    "this scene", (unsigned long long)want);
		return 0;
	}
	{
		/* pm-shoot caps photons at max_depth - 2 bounces (0: none)
		 * for a scene's max_depth; records made under another cap
		 * cannot be corrected here. */
		int md = scene->integrator.max_depth;
		uint32_t want_cap = pm_photon_depth_cap(md);

		if (pm->max_depth != want_cap && verbose) {
			char have[32] = "no limit", want[32] = "no limit";

			if (pm->max_depth)
				snprintf(have, sizeof(have), "%u", pm->max_depth);
			if (want_cap)
				snprintf(want, sizeof(want), "%u", want_cap);
			fprintf(stderr, PROG ": %s: warning: photon bounces: %s in the "
			    "map, %s for the scene's max_depth %d; light paths of "
			    "the wrong length will show: shoot them again\n", path,
			    have, want, md);
		}
	}
	if (pm_photon_maps_from_pmap(pm, maps, &err) != PM_OK) {
		fprintf(stderr, PROG ": %s: %s\n", path, err.msg);
		return 0;
	}
	r = pm_lookup_radii(pp->global_lookup_radius, pp->caustic_lookup_radius,
	    scene_radius, pg->pass, pg->alpha, pg->radius);
	maps->global_r2 = r.global_r2;
	maps->caustic_r2 = r.caustic_r2;
	/* The volume map is looked up with the global map's radius, and
	 * shrinks with it over progressive passes. */
	maps->volume_r2 = r.global_r2;
	maps->volume_samples = 1;
	maps->volume_beam = volume_beam;	/* 4 cost 2.6x for no visible gain (docs/media.md) */
	maps->fixed_radius = r.fixed;
	if (pg->pass > 0 && verbose >= 2)
		fprintf(stderr, PROG ": %s: progressive pass %ld, alpha %g: "
		    "radius scale %.9g, fixed radii %.9g (global) and %.9g "
		    "(caustic)\n", path, pg->pass, pg->alpha,
		    pm_pppm_radius_scale(pg->pass, pg->alpha),
		    sqrt(maps->global_r2), sqrt(maps->caustic_r2));
	maps->lookup_size = pp->lookup_size;
	maps->direct_samples = pp->direct_samples;
	maps->final_gather = pp->final_gather;
	maps->final_gather_samples = pp->final_gather_samples;
	/* by the samples per pixel; none in scenes with media, whose
	 * cache rays (render.c) would not follow the media: there every
	 * camera sample gathers, through media, itself */
	maps->icache_step = scene->nmedia > 0 ? 0 : -1;
	maps->icache_rays = 0;		/* by the samples per pixel */
	maps->icache_a = PM_ICACHE_ACCURACY;
	if (verbose >= 2)
		fprintf(stderr, PROG ": %s: %zu global photons, %zu caustic photons, "
		    "%zu volume photons, %zu irradiance records, radii %g and %g, %s%d, %d direct "
		    "samples, final gathering %s\n", path, maps->nglobal,
		    maps->ncaustic, maps->nvolume, maps->nirradiance,
		    sqrt(maps->global_r2),
		    sqrt(maps->caustic_r2), maps->fixed_radius ?
		    "every photon within them (k unused: " : "k = ",
		    maps->lookup_size, maps->direct_samples,
		    maps->final_gather ? "on" : "off");
	return 1;
}

/*
 * Writes img to path as OpenEXR with its provenance as string attributes,
 * as man/pm-render.1 lists them: the version, the command line, the scene
 * and its hash, and the map (when one was used).
 */
static enum pm_err
write_exr(const char *path, const struct pm_image *img, bool half,
    const char *scene_path, const struct pm_scene *scene,
    const char *map_path, const struct pm_exr_layers *layers,
    struct pm_error *err)
{
	struct pm_exr_attrs at = { 0 };
	char hash[17];
	/* The map comes last: without one the list ends before it. */
	const char *const kv[][2] = {
		{ PROG ".version", PM_VERSION },
		{ PROG ".command", pm_cli_command() },
		{ PROG ".scene", scene_path },
		{ PROG ".scene_hash", hash },
		{ PROG ".map", map_path },
	};
	enum pm_err e = PM_OK;
	size_t i;

	snprintf(hash, sizeof(hash), "%016llx",
	    (unsigned long long)pm_scene_hash(scene));
	for (i = 0; i < sizeof(kv) / sizeof(kv[0]) && kv[i][1] != NULL &&
	    e == PM_OK; i++)
		e = pm_exr_attrs_set(&at, kv[i][0], kv[i][1], err);
	if (e == PM_OK)
		e = pm_exr_write_layers(path, img, half, &at, layers, err);
	pm_exr_attrs_free(&at);
	return e;
}

/*
 * The moments as Mitsuba's moment integrator names its channels: the
 * nested integrator's name with .X, .Y, .Z (first moment) and the same
 * with m2_ in front (second), taken over from m1 and m2 into layers.
 */
static enum pm_err
moment_layers(const char *name, struct pm_image *m1, struct pm_image *m2,
    struct pm_exr_layers *layers, struct pm_error *err)
{
	char n[2][3][80];
	struct pm_image *src[2] = { m1, m2 };
	struct pm_exr_layer *ly;
	enum pm_err e;
	int i, k;

	for (i = 0; i < 2; i++) {
		for (k = 0; k < 3; k++)
			snprintf(n[i][k], sizeof(n[i][k]), "%s%s.%c",
			    i ? "m2_" : "", name, "XYZ"[k]);
		/* Allocated 1x1, then given the render's pixels. */
		if ((e = pm_exr_layers_add(layers, n[i][0], n[i][1], n[i][2],
		    1, 1, &ly, err)) != PM_OK)
			return e;
		pm_image_free(&ly->im);
		ly->im = *src[i];
		memset(src[i], 0, sizeof(*src[i]));
	}
	return PM_OK;
}

int
main(int argc, char **argv)
{
	enum {
		OPT_METHOD = 256, OPT_SPP, OPT_SIZE, OPT_EYE, OPT_TARGET, OPT_UP,
		OPT_FOV, OPT_SEED, OPT_HALF, OPT_CAMERAS,
		OPT_GRADIUS, OPT_CRADIUS, OPT_LOOKUP, OPT_DIRECT, OPT_FG, OPT_NOFG,
		OPT_FGSAMPLES, OPT_PASS, OPT_RADIUS, OPT_ALPHA, OPT_CSTEP,
		OPT_CRAYS, OPT_CACC, OPT_PREVIEW, OPT_PREVIEW_EVERY, OPT_VOLEST,
	};
	static const struct option longopts[] = {
		{"method", required_argument, NULL, OPT_METHOD},
		{"spp", required_argument, NULL, OPT_SPP},
		{"size", required_argument, NULL, OPT_SIZE},
		{"eye", required_argument, NULL, OPT_EYE},
		{"target", required_argument, NULL, OPT_TARGET},
		{"up", required_argument, NULL, OPT_UP},
		{"fov", required_argument, NULL, OPT_FOV},
		{"cameras", required_argument, NULL, OPT_CAMERAS},
		{"define", required_argument, NULL, 'D'},
		{"seed", required_argument, NULL, OPT_SEED},
		{"threads", required_argument, NULL, 't'},
		{"half", no_argument, NULL, OPT_HALF},
		{"output", required_argument, NULL, 'o'},
		{"global-radius", required_argument, NULL, OPT_GRADIUS},
		{"caustic-radius", required_argument, NULL, OPT_CRADIUS},
		{"lookup-size", required_argument, NULL, OPT_LOOKUP},
		{"direct-samples", required_argument, NULL, OPT_DIRECT},
		{"final-gather", no_argument, NULL, OPT_FG},
		{"no-final-gather", no_argument, NULL, OPT_NOFG},
		{"final-gather-samples", required_argument, NULL, OPT_FGSAMPLES},
		{"cache-step", required_argument, NULL, OPT_CSTEP},
		{"cache-rays", required_argument, NULL, OPT_CRAYS},
		{"cache-accuracy", required_argument, NULL, OPT_CACC},
		{"pass", required_argument, NULL, OPT_PASS},
		{"radius", required_argument, NULL, OPT_RADIUS},
		{"alpha", required_argument, NULL, OPT_ALPHA},
		{"preview", required_argument, NULL, OPT_PREVIEW},
		{"preview-every", required_argument, NULL, OPT_PREVIEW_EVERY},
		{"volume-estimate", required_argument, NULL, OPT_VOLEST},
		{"force", no_argument, NULL, 'f'},
		{"quiet", no_argument, NULL, 'q'},
		{"verbose", no_argument, NULL, 'v'},
		{"help", no_argument, NULL, 'h'},
		{"version", no_argument, NULL, PM_CLI_VERSION},
		{NULL, 0, NULL, 0},
	};
	static const struct pm_cli cli = {PROG, usage_line, help_text, longopts};
	struct pm_cli_opts co;
	const char *out_path, *scene_path, *map_path = NULL;
	const char *cameras_path = NULL, *method = NULL;
	struct cam_override one = {{0, 0, 0}, {0, 0, 0}, {0, 1, 0}, 0.0f};
	struct cam_override *cams = NULL;
	long ncams = 0, ci;
	int have_eye = 0, have_target = 0, width = 0, height = 0, half = 0;
	int verbose, c, fg = -1, force;
	struct preview pv = {NULL, NULL, {0, 0, NULL}, NULL, 0, 0};
	float preview_every = 1.0f;
	long spp = 0, threads;
	long lookup = 0, direct = 0, fg_samples = 0;
	long cache_step = -1, cache_rays = 0;
	float cache_acc = 0.0f;
	float fov = 0.0f, gradius = 0.0f, cradius = 0.0f, alpha = 2.0f / 3.0f;
	struct pppm pg = {0, 0.0f, 2.0 / 3.0};
	unsigned long long seed = 0;
	struct pm_scene scene;
	struct pm_world world;
	struct pm_render_ctx ctx;
	struct pm_irr_grid irr_grid = {0};
	struct pm_occupancy caustic_occ = {0};
	struct pm_render_opts opts;
	struct pm_render_stats stats;
	struct pm_error err = {PM_OK, ""};
	struct pm_pmap pmap;
	struct pm_photon_maps maps;
	double t0, t_load;
	int status = 0, have_pmap = 0;

	pm_cli_opts_init(&co);
	while ((c = pm_cli_getopt(&cli, argc, argv, "D:fho:qt:v")) != -1) {
		if (pm_cli_common(&co, c))
			continue;
		switch (c) {
		case OPT_METHOD:
			if (strcmp(optarg, "path") != 0 &&
			    strcmp(optarg, "photon") != 0 &&
			    strcmp(optarg, "ptracer") != 0)
				usage_error("unknown method '%s' (path, photon or "
				    "ptracer)", optarg);
			method = optarg;
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
			if (!pm_parse_vec3(optarg, &one.eye))
				usage_error("--eye wants X,Y,Z, not '%s'", optarg);
			have_eye = 1;
			break;
		case OPT_TARGET:
			if (!pm_parse_vec3(optarg, &one.target))
				usage_error("--target wants X,Y,Z, not '%s'", optarg);
			have_target = 1;
			break;
		case OPT_UP:
			if (!pm_parse_vec3(optarg, &one.up))
				usage_error("--up wants X,Y,Z, not '%s'", optarg);
			break;
		case OPT_FOV:
			if (!pm_parse_float(optarg, 1e-3f, 179.0f, &fov))
				usage_error("--fov wants degrees in (0, 179], not '%s'",
				    optarg);
			break;
		case OPT_CAMERAS:
			cameras_path = optarg;
			break;
		case OPT_SEED:
			if (!pm_parse_u64(optarg, &seed))
				usage_error("--seed wants a non-negative integer, not '%s'",
				    optarg);
			break;
		case OPT_HALF:
			half = 1;
			break;
		case OPT_GRADIUS:
			if (!pm_parse_float(optarg, 0.0f, 1e6f, &gradius) || gradius <= 0)
				usage_error("--global-radius wants a positive fraction, not '%s'",
				    optarg);
			break;
		case OPT_CRADIUS:
			if (!pm_parse_float(optarg, 0.0f, 1e6f, &cradius) || cradius <= 0)
				usage_error("--caustic-radius wants a positive fraction, not '%s'",
				    optarg);
			break;
		case OPT_LOOKUP:
			if (!pm_parse_long(optarg, 1, PM_MAX_LOOKUP, &lookup))
				usage_error("--lookup-size wants 1 to 4096 photons, not '%s'",
				    optarg);
			break;
		case OPT_DIRECT:
			if (!pm_parse_long(optarg, 1, 1 << 16, &direct))
				usage_error("--direct-samples wants 1 to 65536, not '%s'",
				    optarg);
			break;
		case OPT_FG:
			fg = 1;
			break;
		case OPT_NOFG:
			fg = 0;
			break;
		case OPT_VOLEST:
			if (strcmp(optarg, "point") == 0)
				volume_beam = false;
			else if (strcmp(optarg, "beam") == 0)
				volume_beam = true;
			else
				usage_error("--volume-estimate wants point or "
				    "beam, not '%s'", optarg);
			break;
		case OPT_CSTEP:
			if (!pm_parse_long(optarg, 0, 1 << 16, &cache_step))
				usage_error("--cache-step wants 0 to 65536 pixels, not '%s'",
				    optarg);
			break;
		case OPT_CRAYS:
			if (!pm_parse_long(optarg, 1, 1 << 20, &cache_rays))
				usage_error("--cache-rays wants 1 to 1048576, not '%s'",
				    optarg);
			break;
		case OPT_CACC:
			if (!pm_parse_float(optarg, 1e-3f, 100.0f, &cache_acc))
				usage_error("--cache-accuracy wants a number in [0.001, "
				    "100], not '%s'", optarg);
			break;
		case OPT_FGSAMPLES:
			if (!pm_parse_long(optarg, 1, 1 << 16, &fg_samples))
				usage_error("--final-gather-samples wants 1 to 65536, not '%s'",
				    optarg);
			break;
		case OPT_PASS:
			if (!pm_parse_long(optarg, 1, 1L << 30, &pg.pass))
				usage_error("--pass wants a pass number from 1 to 2^30, "
				    "not '%s'", optarg);
			break;
		case OPT_RADIUS:
			if (!pm_parse_float(optarg, 0.0f, 1e6f, &pg.radius) ||
			    pg.radius <= 0)
				usage_error("--radius wants a positive fraction, not '%s'",
				    optarg);
			break;
		case OPT_ALPHA:
			if (!pm_parse_float(optarg, 0.0f, 1.0f, &alpha) ||
			    alpha <= 0.0f || alpha >= 1.0f)
				usage_error("--alpha wants a number strictly between 0 "
				    "and 1, not '%s'", optarg);
			pg.alpha = alpha;
			break;
		case OPT_PREVIEW:
			pv.path = optarg;
			break;
		case OPT_PREVIEW_EVERY:
			if (!pm_parse_float(optarg, 0.01f, 86400.0f, &preview_every))
				usage_error("--preview-every wants seconds from 0.01 "
				    "to 86400, not '%s'", optarg);
			break;
		default:
			usage_error("unhandled option '%s'", argv[optind - 1]);
		}
	}
	out_path = co.output;
	force = co.force;
	verbose = co.verbosity;
	threads = co.threads;
	if (optind == argc)
		usage_error("%s", "no scene file given");
	if (argc - optind > 2)
		usage_error("%s", "too many arguments (SCENE.xml [MAP.pmap])");
	scene_path = argv[optind];
	if (argc - optind == 2)
		map_path = argv[optind + 1];
	if (method != NULL && strcmp(method, "photon") == 0 && map_path == NULL)
		usage_error("%s", "--method photon needs a photon map (SCENE.xml MAP.pmap)");
	if (method != NULL && strcmp(method, "path") == 0 && map_path != NULL)
		usage_error("%s", "--method path takes no photon map");
	if (method != NULL && strcmp(method, "ptracer") == 0 && map_path != NULL)
		usage_error("%s", "--method ptracer takes no photon map");
	if (out_path == NULL)
		usage_error("%s", "no output given (-o OUT.exr)");
	if ((pg.pass > 0 || pg.radius > 0.0f) && map_path == NULL)
		usage_error("%s", "--pass and --radius need a photon map");
	if (pg.radius > 0.0f && pg.pass == 0)
		pg.pass = 1;
	if (!pattern_ok(out_path))
		usage_error("-o: only a %%d-style pattern is allowed in '%s'", out_path);
	if (have_eye != have_target)
		usage_error("%s", "--eye and --target go together");
	if (have_eye && cameras_path != NULL)
		usage_error("%s", "--eye and --cameras exclude each other");
	if (pv.path != NULL && strcmp(pv.path, "-") == 0)
		usage_error("%s", "--preview wants a file, not standard output");
	if (cameras_path != NULL) {
		ncams = read_cameras(cameras_path, &cams);
		if (ncams < 0)
			return 1;
	}
	/* Every output is checked before anything is rendered. */
	for (ci = 0; ci < (cams != NULL ? ncams : 1); ci++) {
		char name[4096];

		output_name(out_path, ci, cams != NULL ? ncams : 1, name,
		    sizeof(name));
		if (!pm_cli_check_output(PROG, name, force)) {
			free(cams);
			return 1;
		}
	}
	if (pv.path != NULL && !pm_cli_check_output(PROG, pv.path, 1)) {
		free(cams);
		return 1;
	}

	t0 = pm_cli_now();
	if (pm_scene_load(scene_path, co.defs, co.ndefs, &scene, &err) != PM_OK) {
		fprintf(stderr, PROG ": %s\n", err.msg);
		free(cams);
		return 1;
	}
	if (!scene.has_camera && !have_eye && cams == NULL) {
		fprintf(stderr, PROG ": %s: the scene has no sensor; give --eye and "
		    "--target, or --cameras\n", scene_path);
		pm_scene_free(&scene);
		return 1;
	}
	if (cams == NULL) {
		cams = &one;
		ncams = 1;
	}
	if (pm_world_init(&world, &scene, &err) != PM_OK) {
		fprintf(stderr, PROG ": %s: %s\n", scene_path, err.msg);
		pm_scene_free(&scene);
		return 1;
	}
	if (map_path != NULL) {
		struct pm_photon_params *pp = &scene.integrator.photon;

		if (gradius > 0)
			pp->global_lookup_radius = gradius;
		if (cradius > 0)
			pp->caustic_lookup_radius = cradius;
		if (lookup > 0)
			pp->lookup_size = (int)lookup;
		if (direct > 0)
			pp->direct_samples = (int)direct;
		if (fg >= 0)
			pp->final_gather = fg;
		if (fg_samples > 0)
			pp->final_gather_samples = (int)fg_samples;
		if (pp->lookup_size < 1 || pp->lookup_size > PM_MAX_LOOKUP) {
			fprintf(stderr, PROG ": %s: lookupSize %d is outside 1..%d\n",
			    scene_path, pp->lookup_size, PM_MAX_LOOKUP);
			status = 1;
			goto out;
		}
		have_pmap = 1;
		if (!load_maps(map_path, &scene, scene.radius, &pg, &pmap, &maps,
		    verbose, (int)threads)) {
			status = 1;
			goto out;
		}
		if (maps.nirradiance > 0) {
			if (pm_irr_grid_build(&irr_grid, maps.irradiance,
			    maps.nirradiance, (int)threads, &err) != PM_OK) {
				fprintf(stderr, PROG ": %s: %s\n", map_path, err.msg);
				status = 1;
				goto out;
			}
			maps.irradiance_grid = &irr_grid;
		}
		/* 81% of the demo's caustic estimates find nothing
		 * (occupancy.h); 10 ms for a million caustic photons. */
		pm_occupancy_build(&caustic_occ, maps.caustic, maps.ncaustic,
		    maps.caustic_r2);
		maps.caustic_occ = &caustic_occ;
	}
	t_load = pm_cli_now() - t0;

	if (pv.path != NULL && (pv.watch = pm_render_watch_new()) == NULL) {
		fprintf(stderr, PROG ": out of memory\n");
		status = 1;
		goto out;
	}
	ctx.scene = &scene;
	ctx.accel = world.accel;
	ctx.lights = &world.lights;
	ctx.max_depth = scene.integrator.max_depth;
	ctx.rr_depth = scene.integrator.rr_depth;
	ctx.hide_emitters = scene.integrator.hide_emitters;
	ctx.scene_radius = scene.radius;
	ctx.icache = NULL;
	maps.gather_max_depth = ctx.max_depth < 0 ? -1 : ctx.max_depth - 3;
	if (map_path != NULL) {
		if (cache_step >= 0 && scene.nmedia == 0)	/* media: none */
			maps.icache_step = (int)cache_step;
		if (cache_rays > 0)
			maps.icache_rays = (int)cache_rays;
		if (cache_acc > 0.0f)
			maps.icache_a = cache_acc;
	}
	ctx.maps = map_path != NULL ? &maps : NULL;
	memset(&opts, 0, sizeof(opts));
	opts.method = map_path != NULL ? PM_METHOD_PHOTON : PM_METHOD_PATH;
	/* The scene's ptracer, unless the command line chose otherwise. */
	if (map_path == NULL && (method != NULL ? strcmp(method, "ptracer") == 0 :
	    scene.integrator.type == PM_INTEGRATOR_PTRACER))
		opts.method = PM_METHOD_PTRACER;
	if (opts.method == PM_METHOD_PTRACER && scene.integrator.moment &&
	    verbose)
		fprintf(stderr, PROG ": %s: note: --method ptracer writes no "
		    "moments (Mitsuba's moment wraps sampling integrators "
		    "only)\n", scene_path);
	opts.seed = seed;
	opts.threads = (int)threads;
	if (scene.nlights == 0 && verbose)
		fprintf(stderr, PROG ": %s: warning: the scene has no lights\n",
		    scene_path);
	if (scene.nmedia > 0 && verbose)
		fprintf(stderr, PROG ": %s: note: %zu participating medi%s, %s; "
		    "the camera is in %s%s%s\n",
		    scene_path, scene.nmedia, scene.nmedia == 1 ? "um" : "a",
		    map_path != NULL ? "in-scattering from light samples and "
		    "the volume map" : "path traced as Mitsuba's volpath",
		    scene.camera_medium > 0 ? "\"" : "vacuum",
		    scene.camera_medium > 0 ?
		    scene.media[scene.camera_medium - 1].name : "",
		    scene.camera_medium > 0 ? "\"" : "");
	if (scene.dropped_triangles > 0 && verbose)
		fprintf(stderr, PROG ": %s: warning: %zu degenerate triangles "
		    "(zero area or non-finite vertices) dropped\n", scene_path,
		    scene.dropped_triangles);

	for (ci = 0; ci < ncams && status == 0; ci++) {
		struct pm_camera cam = scene.camera;
		struct pm_image img = {0, 0, NULL};
		struct pm_image m1 = {0, 0, NULL}, m2 = {0, 0, NULL};
		struct pm_exr_layers layers = {NULL, 0};
		bool moments;
		_Atomic long done, total;
		struct pm_cli_progress *prog;
		char name[4096];
		double t_render;

		if (have_eye || cams != &one) {
			cam.to_world = pm_mat4_lookat(cams[ci].eye, cams[ci].target,
			    cams[ci].up);
			if (!scene.has_camera) {
				cam.fov = 45.0f;
				cam.fov_axis = PM_FOV_X;
			}
		}
		if (cams[ci].fov > 0.0f)
			cam.fov = cams[ci].fov;
		if (fov > 0.0f)
			cam.fov = fov;
		if (width > 0) {
			cam.width = width;
			cam.height = height;
		}
		if (spp > 0)
			cam.spp = (int)spp;
		opts.spp = cam.spp;
		output_name(out_path, ci, ncams, name, sizeof(name));
		if (verbose >= 2)
			fprintf(stderr, PROG ": %s: %zu shapes, %zu lights, %dx%d, %d spp, "
			    "%s, max_depth %d, %ld threads, loaded in %.3f s\n", name,
			    scene.nshapes, scene.nlights, cam.width, cam.height, cam.spp,
			    map_path ? "photon map" : opts.method ==
			    PM_METHOD_PTRACER ? "particle tracing" : "path tracing",
			    ctx.max_depth,
			    threads, t_load);

		atomic_init(&done, 0);
		atomic_init(&total, 0);
		opts.tiles_done = &done;
		opts.tiles_total = &total;
		opts.watch = pv.watch;
		moments = scene.integrator.moment &&
		    opts.method != PM_METHOD_PTRACER;
		opts.moment1 = moments ? &m1 : NULL;
		opts.moment2 = moments ? &m2 : NULL;
		pv.done = &done;
		pv.written = 0;
		prog = pm_cli_progress_start(PROG, ncams > 1 ? name : "",
		    pm_cli_progress_wanted(!verbose), &done, &total,
		    pv.path != NULL ? preview_tick : NULL, &pv, preview_every);
		t0 = pm_cli_now();
		if (pm_render(&ctx, &cam, &opts, &img, &stats, &err) != PM_OK) {
			fprintf(stderr, PROG ": %s\n", err.msg);
			status = 1;
		}
		t_render = pm_cli_now() - t0;
		pm_cli_progress_stop(prog);
		/* The last preview is the finished image. */
		if (status == 0 && pv.path != NULL)
			preview_write(&pv, &img);
		if (status == 0 && moments &&
		    moment_layers(scene.integrator.moment_name, &m1, &m2,
		    &layers, &err) != PM_OK) {
			fprintf(stderr, PROG ": %s\n", err.msg);
			status = 1;
		}
		if (status == 0 && write_exr(name, &img, half, scene_path,
		    &scene, map_path, &layers, &err) != PM_OK) {
			fprintf(stderr, PROG ": %s\n", err.msg);
			status = 1;
		}
		if (status == 0 && verbose >= 2)
			fprintf(stderr, PROG ": %s: rendered %llu samples in %.3f s "
			    "(%.2f Msamples/s), %llu non-finite dropped\n", name,
			    (unsigned long long)stats.samples, t_render,
			    (double)stats.samples / t_render * 1e-6,
			    (unsigned long long)stats.dropped);
		else if (status == 0 && stats.dropped > 0 && verbose)
			fprintf(stderr, PROG ": %s: warning: %llu non-finite samples "
			    "dropped\n", name, (unsigned long long)stats.dropped);
		pm_image_free(&img);
		pm_image_free(&m1);
		pm_image_free(&m2);
		pm_exr_layers_free(&layers);
	}
out:
	pm_irr_grid_free(&irr_grid);
	pm_occupancy_free(&caustic_occ);
	if (have_pmap)
		pm_pmap_free(&pmap);
	if (cams != &one)
		free(cams);
	pm_image_free(&pv.snap);
	pm_render_watch_free(pv.watch);
	pm_world_free(&world);
	pm_scene_free(&scene);
	return status;
}
