/*
 * pm-downsample: averages rendered passes, filters them down by an integer
 * factor and writes the result as a linear OpenEXR file or as an 8-bit
 * sRGB PNG.
 *
 * pm-render renders supersampled and, for progressive rendering, in
 * independent passes; this is the last stage of the pipeline, the heir of
 * Radiance's pfilt.  Passes are summed pairwise (each sum adds two images
 * holding the same number of passes), so the rounding error grows with
 * the logarithm of the number of passes rather than with the number, while
 * only a logarithmic number of images is held at once.  Channels beside
 * R, G and B (Mitsuba's AOVs, such as the moment integrator's first and
 * second moments) are averaged and filtered the same way when the output
 * is OpenEXR: the mean of the passes' second moments is the second moment
 * of all their samples.
 */
#include <errno.h>
#include <getopt.h>
#include <limits.h>
#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <unistd.h>

#include "../common/error.h"
#include "../common/image.h"
#include "../formats/exr.h"
#include "../formats/png.h"
#include "cli.h"

#define PROG		"pm-downsample"
#define MAX_FACTOR	32768
#define MAX_EXPOSURE	64.0
/* Enough partial sums for 2^40 passes. */
#define MAX_LEVELS	40

static const char usage_line[] =
    "usage: pm-downsample [-fqv] [-e ev] [-F filter] [--factor n] [--half] "
    "-o output input ...\n";

static const char help_text[] =
    "Average OpenEXR passes of equal size, filter them down by an\n"
    "integer factor and write OpenEXR (linear) or PNG (sRGB).\n\n"
    "  -e, --exposure ev   scale by 2^ev before the sRGB curve (PNG;"
    " default 0)\n"
    "  -F, --filter name   box, tent, gaussian, mitchell or lanczos"
    " (default box)\n"
    "  -f, --force         overwrite an existing output\n"
    "      --factor n      output pixel = n x n input pixels"
    " (default 1)\n"
    "      --half          write half floats instead of float32"
    " (OpenEXR)\n"
    "  -h, --help          print this help and exit\n"
    "  -o, --output file   output, .exr or .png; - is PNG on"
    " standard output\n"
    "  -q, --quiet         no warnings\n"
    "  -v, --verbose       describe the inputs and the result\n"
    "      --version       print the version and exit\n";

static const char *const filter_names[] = {
	"box", "tent", "gaussian", "mitchell", "lanczos",
};

enum { OPT_HALF = 256, OPT_FACTOR };

static const struct option longopts[] = {
	{ "exposure",	required_argument,	NULL,	'e' },
	{ "filter",	required_argument,	NULL,	'F' },
	{ "factor",	required_argument,	NULL,	OPT_FACTOR },
	{ "force",	no_argument,		NULL,	'f' },
	{ "half",	no_argument,		NULL,	OPT_HALF },
	{ "help",	no_argument,		NULL,	'h' },
	{ "output",	required_argument,	NULL,	'o' },
	{ "quiet",	no_argument,		NULL,	'q' },
	{ "verbose",	no_argument,		NULL,	'v' },
	{ "version",	no_argument,		NULL,	PM_CLI_VERSION },
	{ NULL,		0,			NULL,	0 },
};

static const struct pm_cli cli = { PROG, usage_line, help_text, longopts };

static int verbosity = 1;	/* 0 with -q, 2 with -v */

/* Reports a usage error in one line and exits 2. */
#define usage_error pm_cli_usage_error

/*
 * Parses the whole of s as a number within [min, max]: a decimal integer
 * when integer is set, otherwise a real.  Anything else, trailing text or
 * overflow included, is a usage error that names the option.
 */
static double
parse_number(const char *opt, const char *s, double min, double max,
    bool integer)
{
	char *end;
	double v;

	errno = 0;
	if (*s == '\0' || *s == ' ' || *s == '\t' || *s == '\n')
		usage_error("%s: expected a number, got '%s'", opt, s);
	if (integer) {
		long l = strtol(s, &end, 10);

		v = (double)l;
	} else
		v = strtod(s, &end);
	if (*end != '\0')
		usage_error("%s: '%s' is not %s", opt, s,
		    integer ? "a whole number" : "a number");
	if (errno == ERANGE || !(v >= min && v <= max))
		usage_error("%s: '%s' is out of range (%g to %g)", opt, s, min,
		    max);
	return v;
}

/* Which writer the output's name asks for. */
enum out_kind { OUT_EXR, OUT_PNG };

static bool
output_kind(const char *path, enum out_kind *kind)
{
	const char *dot;

	if (strcmp(path, "-") == 0) {
		*kind = OUT_PNG;
		return true;
	}
	dot = strrchr(path, '.');
	if (dot == NULL || strchr(dot, '/') != NULL)
		return false;
	if (strcasecmp(dot, ".exr") == 0)
		*kind = OUT_EXR;
	else if (strcasecmp(dot, ".png") == 0)
		*kind = OUT_PNG;
	else
		return false;
	return true;
}

static size_t
count_nonfinite(const struct pm_image *im)
{
	size_t i, n = (size_t)im->width * im->height * 3, bad = 0;

	for (i = 0; i < n; i++)
		if (!isfinite(im->rgb[i]))
			bad++;
	return bad;
}

/* Fraction of channels that the sRGB conversion saturates. */
static double
clipped_fraction(const uint8_t *rgb, const struct pm_image *im, float ev)
{
	size_t i, n = (size_t)im->width * im->height * 3, hi = 0;
	float m = exp2f(ev);

	for (i = 0; i < n; i++)
		if (rgb[i] == 255 && im->rgb[i] * m > 1.0f)
			hi++;
	return n > 0 ? (double)hi / n : 0.0;
}

/* A pass or a sum of passes: the image and its other channels. */
struct frame {
	struct pm_image im;
	struct pm_exr_layers ly;
};

static void
frame_free(struct frame *f)
{
	pm_image_free(&f->im);
	pm_exr_layers_free(&f->ly);
}

/* acc += f, image and layers; the layers were checked to match. */
static enum pm_err
frame_accumulate(struct frame *acc, const struct frame *f,
    struct pm_error *err)
{
	enum pm_err e = pm_image_accumulate(&acc->im, &f->im, err);
	size_t i;

	for (i = 0; i < acc->ly.n && e == PM_OK; i++)
		e = pm_image_accumulate(&acc->ly.v[i].im, &f->ly.v[i].im, err);
	return e;
}

/* True if a and b have the same channels beside R, G and B. */
static bool
same_layers(const struct pm_exr_layers *a, const struct pm_exr_layers *b)
{
	size_t i;
	int k;

	if (a->n != b->n)
		return false;
	for (i = 0; i < a->n; i++)
		for (k = 0; k < 3; k++) {
			const char *x = a->v[i].name[k], *y = b->v[i].name[k];

			if ((x == NULL) != (y == NULL) ||
			    (x != NULL && strcmp(x, y) != 0))
				return false;
		}
	return true;
}

/* Releases every partial sum. */
static void
free_levels(struct frame *level)
{
	int k;

	for (k = 0; k < MAX_LEVELS; k++)
		frame_free(&level[k]);
}

int
main(int argc, char *argv[])
{
	struct frame level[MAX_LEVELS], sum;
	struct pm_image out;
	struct pm_exr_layers out_ly = { NULL, 0 }, first_ly = { NULL, 0 };
	struct pm_exr_attrs attrs = { 0 };
	struct pm_error err;
	enum out_kind kind = OUT_EXR;
	struct pm_cli_opts co;
	const char *output, *first = NULL;
	double exposure = 0.0;
	bool half = false, exposure_set = false, force;
	int filter = PM_FILTER_BOX, factor = 1;
	int ch, i, k, ninputs, width = 0, height = 0;
	size_t j;
	uint8_t *srgb = NULL;

	memset(level, 0, sizeof(level));
	memset(&sum, 0, sizeof(sum));
	memset(&out, 0, sizeof(out));
	pm_cli_opts_init(&co);
	while ((ch = pm_cli_getopt(&cli, argc, argv, "e:F:fho:qv")) != -1) {
		if (pm_cli_common(&co, ch))
			continue;
		switch (ch) {
		case 'e':
			exposure = parse_number("--exposure", optarg,
			    -MAX_EXPOSURE, MAX_EXPOSURE, false);
			exposure_set = true;
			break;
		case 'F':
			if ((filter = pm_filter_parse(optarg)) < 0)
				usage_error("--filter: unknown filter '%s'; "
				    "expected box, tent, gaussian, mitchell "
				    "or lanczos", optarg);
			break;
		case OPT_FACTOR:
			factor = (int)parse_number("--factor", optarg, 1,
			    MAX_FACTOR, true);
			break;
		case OPT_HALF:
			half = true;
			break;
		default:
			usage_error("unhandled option '%s'", argv[optind - 1]);
		}
	}
	output = co.output;
	force = co.force;
	verbosity = co.verbosity;
	argc -= optind;
	argv += optind;

	if (output == NULL)
		usage_error("no output: give -o file.exr, -o file.png or -o -");
	if (argc < 1)
		usage_error("no input files");
	if (!output_kind(output, &kind))
		usage_error("-o %s: cannot tell the format; the name must end "
		    "in .exr or .png, or be - for PNG on standard output",
		    output);
	if (half && kind != OUT_EXR)
		usage_error("--half applies to OpenEXR output only");
	if (exposure_set && kind != OUT_PNG)
		usage_error("--exposure applies to PNG output only; OpenEXR "
		    "output stays linear");
	for (i = 0; i < argc; i++)
		if (strcmp(argv[i], "-") == 0)
			usage_error("inputs must be files: OpenEXR cannot be "
			    "read from standard input");
	/* Checked before any work, so that nothing is read in vain. */
	if (!pm_cli_check_output(PROG, output, force))
		return 1;

	/* Sum the passes pairwise: level[k] holds 2^k of them. */
	ninputs = argc;
	for (i = 0; i < ninputs; i++) {
		struct frame carry;
		size_t bad;

		/* The first input's provenance is carried through; the
		 * other channels only into OpenEXR. */
		memset(&carry, 0, sizeof(carry));
		if (pm_exr_read_layers(argv[i], &carry.im, i == 0 ? &attrs :
		    NULL, kind == OUT_EXR ? &carry.ly : NULL, &err) != PM_OK) {
			fprintf(stderr, "%s: %s\n", PROG, err.msg);
			goto fail;
		}
		if (i == 0) {
			first = argv[i];
			width = carry.im.width;
			height = carry.im.height;
			if (width % factor != 0 || height % factor != 0) {
				fprintf(stderr, "%s: %s: size %dx%d is not "
				    "divisible by factor %d\n", PROG, argv[i],
				    width, height, factor);
				frame_free(&carry);
				goto fail;
			}
			/* Only the names: the pixels are summed below. */
			for (j = 0; j < carry.ly.n; j++)
				if (pm_exr_layers_add(&first_ly,
				    carry.ly.v[j].name[0], carry.ly.v[j].name[1],
				    carry.ly.v[j].name[2], 1, 1, NULL, &err) !=
				    PM_OK) {
					fprintf(stderr, "%s: %s\n", PROG,
					    err.msg);
					frame_free(&carry);
					goto fail;
				}
		} else if (carry.im.width != width ||
		    carry.im.height != height) {
			fprintf(stderr, "%s: %s: size %dx%d differs from %s "
			    "(%dx%d)\n", PROG, argv[i], carry.im.width,
			    carry.im.height, first, width, height);
			frame_free(&carry);
			goto fail;
		} else if (!same_layers(&carry.ly, &first_ly)) {
			fprintf(stderr, "%s: %s: its channels differ from "
			    "those of %s\n", PROG, argv[i], first);
			frame_free(&carry);
			goto fail;
		}
		if (verbosity >= 2)
			fprintf(stderr, "%s: %s: %dx%d, %zu channels beside "
			    "R, G and B\n", PROG, argv[i], carry.im.width,
			    carry.im.height, 3 * carry.ly.n);
		if (verbosity >= 1 && (bad = count_nonfinite(&carry.im)) > 0)
			fprintf(stderr, "%s: %s: warning: %zu channel values "
			    "are infinite or NaN\n", PROG, argv[i], bad);
		for (k = 0; k < MAX_LEVELS - 1 && level[k].im.rgb != NULL;
		    k++) {
			/* Sizes were checked above; this cannot fail. */
			if (frame_accumulate(&carry, &level[k], &err) !=
			    PM_OK) {
				fprintf(stderr, "%s: %s\n", PROG, err.msg);
				frame_free(&carry);
				goto fail;
			}
			frame_free(&level[k]);
		}
		level[k] = carry;
	}
	/* Add the partial sums, smallest first. */
	for (k = 0; k < MAX_LEVELS; k++) {
		if (level[k].im.rgb == NULL)
			continue;
		if (sum.im.rgb == NULL) {
			sum = level[k];
			memset(&level[k], 0, sizeof(level[k]));
			continue;
		}
		if (frame_accumulate(&sum, &level[k], &err) != PM_OK) {
			fprintf(stderr, "%s: %s\n", PROG, err.msg);
			goto fail;
		}
		frame_free(&level[k]);
	}
	if (ninputs > 1) {
		pm_image_scale(&sum.im, (float)(1.0 / ninputs));
		for (j = 0; j < sum.ly.n; j++)
			pm_image_scale(&sum.ly.v[j].im,
			    (float)(1.0 / ninputs));
	}

	if (pm_image_downsample(&sum.im, factor, (enum pm_filter)filter, &out,
	    &err) != PM_OK) {
		fprintf(stderr, "%s: %s: %s\n", PROG, first, err.msg);
		goto fail;
	}
	for (j = 0; j < sum.ly.n; j++) {
		struct pm_exr_layer *ly, *in = &sum.ly.v[j];

		if (pm_exr_layers_add(&out_ly, in->name[0], in->name[1],
		    in->name[2], 1, 1, &ly, &err) != PM_OK) {
			fprintf(stderr, "%s: %s\n", PROG, err.msg);
			goto fail;
		}
		pm_image_free(&ly->im);
		if (pm_image_downsample(&in->im, factor,
		    (enum pm_filter)filter, &ly->im, &err) != PM_OK) {
			fprintf(stderr, "%s: %s: %s\n", PROG, first, err.msg);
			goto fail;
		}
	}
	frame_free(&sum);
	if (verbosity >= 2)
		fprintf(stderr, "%s: averaged %d input%s; %s filter, factor "
		    "%d: %dx%d -> %dx%d\n", PROG, ninputs,
		    ninputs == 1 ? "" : "s", filter_names[filter], factor,
		    width, height, out.width, out.height);

	if (kind == OUT_EXR) {
		if (pm_exr_attrs_set(&attrs, PROG ".version", PM_VERSION,
		    &err) != PM_OK || pm_exr_attrs_set(&attrs, PROG
		    ".command", pm_cli_command(), &err) != PM_OK ||
		    pm_exr_write_layers(output, &out, half, &attrs, &out_ly,
		    &err) != PM_OK) {
			fprintf(stderr, "%s: %s\n", PROG, err.msg);
			goto fail;
		}
		if (verbosity >= 2)
			fprintf(stderr, "%s: %s: %dx%d OpenEXR, %s\n",
			    PROG, output, out.width, out.height,
			    half ? "half, PIZ" : "float, uncompressed");
	} else {
		srgb = malloc((size_t)out.width * out.height * 3);
		if (srgb == NULL) {
			fprintf(stderr, "%s: %s: out of memory\n", PROG,
			    output);
			goto fail;
		}
		pm_image_to_srgb8(&out, (float)exposure, srgb);
		if (pm_png_write(output, srgb, out.width, out.height,
		    &err) != PM_OK) {
			fprintf(stderr, "%s: %s\n", PROG, err.msg);
			goto fail;
		}
		if (verbosity >= 2)
			fprintf(stderr, "%s: %s: %dx%d sRGB PNG, exposure "
			    "%+g EV, %.2f%% of channels clipped\n", PROG,
			    output, out.width, out.height, exposure,
			    100.0 * clipped_fraction(srgb, &out,
			    (float)exposure));
		free(srgb);
	}
	pm_image_free(&out);
	pm_exr_layers_free(&out_ly);
	pm_exr_layers_free(&first_ly);
	pm_exr_attrs_free(&attrs);

	/* A full disk or a closed pipe shows up only here. */
	errno = 0;
	if (fflush(stdout) != 0 || ferror(stdout) || fclose(stdout) != 0) {
		fprintf(stderr, "%s: stdout: %s\n", PROG,
		    errno != 0 ? strerror(errno) : "write error");
		return 1;
	}
	return 0;

fail:
	free_levels(level);
	frame_free(&sum);
	pm_image_free(&out);
	pm_exr_layers_free(&out_ly);
	pm_exr_layers_free(&first_ly);
	pm_exr_attrs_free(&attrs);
	free(srgb);
	return 1;
}
