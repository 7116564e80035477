/*
 * pm-merl: writes a MERL-layout measured BRDF file (.binary) tabulated
 * from an analytic model: a Lambertian of a given albedo, a GGX metal
 * (gold, or any of pm's named conductors), or a plastic (a Lambertian base
 * under a GGX-rough dielectric coat).  Scenes use the result through
 * <bsdf type="merl">, exactly as they would use a file of the MERL
 * database.
 */
#include <errno.h>
#include <getopt.h>
#include <libgen.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "../common/bsdf.h"
#include "../common/parse.h"
#include "../formats/merl.h"
#include "cli.h"

#define PROG "pm-merl"

static const char usage_line[] =
    "usage: pm-merl [-fv] [--lambert R,G,B | --gold | --conductor NAME |\n"
    "               --plastic R,G,B] [--alpha A] [--ior N] -o OUT.binary\n";

static const char help_text[] =
    "Tabulate an analytic BRDF as a MERL measured-BRDF file.\n\n"
    "  -o, --output OUT.binary   the table; - is standard output\n"
    "  -f, --force               overwrite an existing output\n"
    "      --lambert R,G,B       a Lambertian of that albedo\n"
    "      --gold                GGX gold\n"
    "      --conductor NAME      a GGX conductor named as in pm-scene(5)\n"
    "      --plastic R,G,B       a diffuse base under a GGX dielectric coat\n"
    "      --alpha A             GGX roughness (default 0.2 metal, 0.1 "
    "plastic)\n"
    "      --ior N               the plastic coat's index (default 1.5)\n"
    "  -v, --verbose             say what was written\n"
    "  -h, --help                print this help and exit\n"
    "      --version             print the version and exit\n";

/* A usage error: one line on stderr, exit 2. */
#define usage_error pm_cli_usage_error

/* "R,G,B" or a single grey value, each in [0, 1]. */
static int
parse_rgb(const char *s, struct pm_rgb *c)
{
	char buf[128], *p, *q;
	float v[3];
	int n = 0;

	if (strlen(s) >= sizeof(buf))
		return 0;
	strcpy(buf, s);
	for (p = buf; n < 3; p = q + 1) {
		q = strchr(p, ',');
		if (q != NULL)
			*q = '\0';
		if (!pm_parse_float(p, 0.0f, 1.0f, &v[n++]))
			return 0;
		if (q == NULL)
			break;
	}
	if (q != NULL || (n != 1 && n != 3))
		return 0;
	if (n == 1)
		v[1] = v[2] = v[0];
	*c = pm_rgb(v[0], v[1], v[2]);
	return 1;
}

int
main(int argc, char **argv)
{
	enum {
		OPT_LAMBERT = 256, OPT_GOLD, OPT_CONDUCTOR, OPT_PLASTIC,
		OPT_ALPHA, OPT_IOR,
	};
	static const struct option longopts[] = {
		{"lambert", required_argument, NULL, OPT_LAMBERT},
		{"gold", no_argument, NULL, OPT_GOLD},
		{"conductor", required_argument, NULL, OPT_CONDUCTOR},
		{"plastic", required_argument, NULL, OPT_PLASTIC},
		{"alpha", required_argument, NULL, OPT_ALPHA},
		{"ior", required_argument, NULL, OPT_IOR},
		{"output", required_argument, NULL, 'o'},
		{"force", no_argument, NULL, 'f'},
		{"verbose", no_argument, NULL, 'v'},
		{"help", no_argument, NULL, 'h'},
		{"version", no_argument, NULL, PM_CLI_VERSION},
		{NULL, 0, NULL, 0},
	};
	static const struct pm_cli cli = {PROG, usage_line, help_text, longopts};
	struct pm_merl_model mo;
	struct pm_error err = {PM_OK, ""};
	struct pm_cli_opts co;
	const char *out_path, *what = NULL;
	float alpha = -1.0f, ior = -1.0f;
	int force, verbose, nmodels = 0, c;

	memset(&mo, 0, sizeof(mo));
	pm_cli_opts_init(&co);
	while ((c = pm_cli_getopt(&cli, argc, argv, "fho:v")) != -1) {
		if (pm_cli_common(&co, c))
			continue;
		switch (c) {
		case OPT_LAMBERT:
			mo.type = PM_MERL_LAMBERT;
			if (!parse_rgb(optarg, &mo.albedo))
				usage_error("--lambert wants R,G,B in [0, 1], "
				    "not '%s'", optarg);
			what = "Lambertian";
			nmodels++;
			break;
		case OPT_GOLD:
		case OPT_CONDUCTOR:
			mo.type = PM_MERL_METAL;
			if (!pm_conductor_lookup(c == OPT_GOLD ? "Au" : optarg,
			    &mo.eta, &mo.k))
				usage_error("--conductor: unknown material "
				    "'%s' (Au, Ag, Al, Cu, ... as pm-scene(5) "
				    "lists)", optarg);
			what = c == OPT_GOLD ? "gold" : "conductor";
			nmodels++;
			break;
		case OPT_PLASTIC:
			mo.type = PM_MERL_PLASTIC;
			if (!parse_rgb(optarg, &mo.albedo))
				usage_error("--plastic wants R,G,B in [0, 1], "
				    "not '%s'", optarg);
			what = "plastic";
			nmodels++;
			break;
		case OPT_ALPHA:
			if (!pm_parse_float(optarg, 1e-3f, 1.0f, &alpha))
				usage_error("--alpha wants a roughness from "
				    "0.001 to 1, not '%s'", optarg);
			break;
		case OPT_IOR:
			if (!pm_parse_float(optarg, 1.0f, 4.0f, &ior))
				usage_error("--ior wants an index from 1 to 4, "
				    "not '%s'", optarg);
			break;
		default:
			usage_error("unhandled option '%s'", argv[optind - 1]);
		}
	}
	out_path = co.output;
	force = co.force;
	verbose = co.verbosity >= 2;
	if (optind != argc)
		usage_error("unexpected argument '%s'", argv[optind]);
	if (nmodels != 1)
		usage_error("%s", nmodels == 0 ? "no model given (--lambert, "
		    "--gold, --conductor or --plastic)" : "more than one model "
		    "given");
	if (out_path == NULL)
		usage_error("%s", "no output given (-o OUT.binary, or -o - for "
		    "stdout)");
	if (mo.type == PM_MERL_LAMBERT && (alpha >= 0.0 || ior >= 0.0))
		usage_error("%s", "--alpha and --ior do not apply to "
		    "--lambert");
	if (mo.type == PM_MERL_METAL && ior >= 0.0)
		usage_error("%s", "--ior applies to --plastic only");
	mo.alpha = alpha >= 0.0f ? alpha : mo.type == PM_MERL_METAL ? 0.2f :
	    0.1f;
	mo.ior = ior >= 0.0f ? ior : 1.5f;
	if (!pm_cli_check_output(PROG, out_path, force))
		return 1;
	if (pm_merl_write(out_path, &mo, &err) != PM_OK) {
		fprintf(stderr, PROG ": %s\n", err.msg);
		return 1;
	}
	if (verbose && strcmp(out_path, "-") != 0)
		fprintf(stderr, PROG ": %s: %s, %zu bytes\n", out_path, what,
		    PM_MERL_FILE_SIZE);
	if (strcmp(out_path, "-") == 0 && fclose(stdout) != 0) {
		fprintf(stderr, PROG ": standard output: %s\n",
		    strerror(errno));
		return 1;
	}
	return 0;
}
