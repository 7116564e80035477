/*
 * image.c: linear RGB float images and what pm-downsample does to them:
 * separable filtered downsampling by an integer factor, pixel-by-pixel
 * accumulation for averaging passes, and tone mapping to 8-bit sRGB.
 *
 * Downsampling works in output-pixel units: the centre of input pixel i,
 * i + 0.5, lies at (i + 0.5) / factor, and every filter's support is
 * measured there, so a filter looks the same whatever the factor.  The
 * weights of each output pixel are summed over the input pixels that exist
 * and divided by that sum, which keeps a constant image constant and
 * handles the borders without inventing pixels beyond them.
 */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "image.h"


/* One filter tap row: the weights of output pixel j start at input index
 * first[j] and run for count[j] entries of w, at offset j * stride. */
struct pm_taps {
	int *first;
	int *count;
	double *w;
	int stride;
};

/* Allocates a zeroed width x height image into im; im->rgb is owned by the
 * caller and released with pm_image_free. */
enum pm_err
pm_image_alloc(struct pm_image *im, int width, int height, struct pm_error *err)
{
	size_t npix;

	im->width = 0;
	im->height = 0;
	im->rgb = NULL;
	if (width < 1 || height < 1)
		return pm_fail(err, PM_ERR_INVALID,
		    "image size %dx%d: both sides must be at least 1",
		    width, height);
	if (width > PM_IMAGE_MAX_SIDE || height > PM_IMAGE_MAX_SIDE)
		return pm_fail(err, PM_ERR_LIMIT,
		    "image size %dx%d: sides are limited to %d pixels "
		    "(it would need %.1f GiB of film)", width, height,
		    PM_IMAGE_MAX_SIDE, (double)width * height * 3 * sizeof(float) /
		    (1024.0 * 1024.0 * 1024.0));
	npix = (size_t)width * (size_t)height;
	if (npix > PM_IMAGE_MAX_PIXELS)
		return pm_fail(err, PM_ERR_LIMIT,
		    "image size %dx%d: more than %zu pixels (it would need "
		    "%.1f GiB of film)", width, height, PM_IMAGE_MAX_PIXELS,
		    (double)npix * 3 * sizeof(float) / (1024.0 * 1024.0 * 1024.0));
	im->rgb = calloc(3 * npix, sizeof(float));
	if (im->rgb == NULL)
		return pm_fail(err, PM_ERR_NOMEM,
		    "image size %dx%d: cannot allocate %zu bytes",
		    width, height, 3 * npix * sizeof(float));
	im->width = width;
	im->height = height;
	return PM_OK;
}

/* Releases the pixels of im and leaves it empty; safe to call twice. */
void
pm_image_free(struct pm_image *im)
{
	if (im == NULL)
		return;
	free(im->rgb);
	im->rgb = NULL;
	im->width = 0;
	im->height = 0;
}

/* Maps a filter name to its enum value, or -1 if there is none. */
int
pm_filter_parse(const char *name)
{
	static const struct {
		const char *name;
		enum pm_filter filter;
	} names[] = {
		{ "box", PM_FILTER_BOX },
		{ "tent", PM_FILTER_TENT },
		{ "gaussian", PM_FILTER_GAUSSIAN },
		{ "mitchell", PM_FILTER_MITCHELL },
		{ "lanczos", PM_FILTER_LANCZOS },
	};
	size_t i;

	if (name == NULL)
		return -1;
	for (i = 0; i < sizeof(names) / sizeof(names[0]); i++)
		if (strcmp(name, names[i].name) == 0)
			return (int)names[i].filter;
	return -1;
}

/* The half-width of the filter's support, in output pixels. */
static double
filter_radius(enum pm_filter filter)
{
	switch (filter) {
	case PM_FILTER_BOX:
		return 0.5;
	case PM_FILTER_TENT:
		return 1.0;
	case PM_FILTER_GAUSSIAN:
	case PM_FILTER_MITCHELL:
		return 2.0;
	case PM_FILTER_LANCZOS:
		return 3.0;
	}
	return 0.0;
}

static double
sinc(double x)
{
	if (fabs(x) < 1e-9)
		return 1.0;
	return sin(M_PI * x) / (M_PI * x);
}

/*
 * The unnormalised 1-D filter at distance x (output pixels) from the
 * centre; callers only ask within the support.
 */
static double
filter_eval(enum pm_filter filter, double x)
{
	/* Mitsuba's gaussian: stddev 0.5, cut at 4 stddev, shifted down so
	 * that it reaches zero at the cut instead of jumping there. */
	const double sigma = 0.5, gr = 2.0;
	/* Mitchell and Netravali's recommended B = C = 1/3. */
	const double b = 1.0 / 3.0, c = 1.0 / 3.0;
	double ax = fabs(x);

	switch (filter) {
	case PM_FILTER_BOX:
		return 1.0;
	case PM_FILTER_TENT:
		return ax < 1.0 ? 1.0 - ax : 0.0;
	case PM_FILTER_GAUSSIAN:
		return fmax(0.0, exp(-x * x / (2 * sigma * sigma)) -
		    exp(-gr * gr / (2 * sigma * sigma)));
	case PM_FILTER_MITCHELL:
		if (ax < 1.0)
			return ((12 - 9 * b - 6 * c) * ax * ax * ax +
			    (-18 + 12 * b + 6 * c) * ax * ax +
			    (6 - 2 * b)) / 6.0;
		if (ax < 2.0)
			return ((-b - 6 * c) * ax * ax * ax +
			    (6 * b + 30 * c) * ax * ax +
			    (-12 * b - 48 * c) * ax +
			    (8 * b + 24 * c)) / 6.0;
		return 0.0;
	case PM_FILTER_LANCZOS:
		return ax < 3.0 ? sinc(x) * sinc(x / 3.0) : 0.0;
	}
	return 0.0;
}

static void
taps_free(struct pm_taps *t)
{
	free(t->first);
	free(t->count);
	free(t->w);
	memset(t, 0, sizeof(*t));
}

/*
 * Builds the normalised weights of the nout output pixels along one axis
 * of length nin = nout * factor.  Only input pixels inside the image take
 * part, so at a border the weights are renormalised over what is there.
 */
static enum pm_err
taps_build(struct pm_taps *t, int nin, int factor, enum pm_filter filter,
    struct pm_error *err)
{
	double radius = filter_radius(filter);
	int nout = nin / factor;
	int j;

	memset(t, 0, sizeof(*t));
	/* |(i + 0.5) / factor - (j + 0.5)| < radius holds for fewer than
	 * 2 * radius * factor + 1 consecutive i. */
	t->stride = (int)ceil(2.0 * radius * factor) + 1;
	t->first = calloc((size_t)nout, sizeof(int));
	t->count = calloc((size_t)nout, sizeof(int));
	t->w = calloc((size_t)nout * (size_t)t->stride, sizeof(double));
	if (t->first == NULL || t->count == NULL || t->w == NULL) {
		taps_free(t);
		return pm_fail(err, PM_ERR_NOMEM,
		    "downsample: cannot allocate filter weights");
	}
	for (j = 0; j < nout; j++) {
		double centre = (j + 0.5) * factor;	/* in input units */
		double *w = t->w + (size_t)j * (size_t)t->stride;
		double sum = 0.0;
		int lo, hi, i, n;

		lo = (int)floor(centre - radius * factor - 0.5);
		hi = (int)ceil(centre + radius * factor - 0.5);
		if (lo < 0)
			lo = 0;
		if (hi > nin - 1)
			hi = nin - 1;
		/* Skip the ends outside the open support, so that each row
		 * starts at its first contributing pixel. */
		while (lo <= hi &&
		    !(fabs((lo + 0.5) / factor - (j + 0.5)) < radius))
			lo++;
		while (hi >= lo &&
		    !(fabs((hi + 0.5) / factor - (j + 0.5)) < radius))
			hi--;
		n = hi - lo + 1;
		if (n < 1 || n > t->stride) {
			taps_free(t);
			return pm_fail(err, PM_ERR_INVALID,
			    "downsample: no input pixels under output pixel %d",
			    j);
		}
		for (i = 0; i < n; i++) {
			double d = (lo + i + 0.5) / factor - (j + 0.5);

			w[i] = filter_eval(filter, d);
			sum += w[i];
		}
		/* Negative lobes can in principle cancel the centre at a
		 * border; fall back to the nearest pixel rather than divide
		 * by nothing. */
		if (!(sum > 1e-12)) {
			int near = (int)floor(centre);

			if (near > nin - 1)
				near = nin - 1;
			if (near < lo || near > hi)
				near = lo;
			for (i = 0; i < n; i++)
				w[i] = (lo + i == near) ? 1.0 : 0.0;
			sum = 1.0;
		}
		for (i = 0; i < n; i++)
			w[i] /= sum;
		t->first[j] = lo;
		t->count[j] = n;
	}
	return PM_OK;
}

/* Filters and decimates in by factor into out, horizontally then
 * vertically; out is allocated here and owned by the caller. */
enum pm_err
pm_image_downsample(const struct pm_image *in, int factor,
    enum pm_filter filter, struct pm_image *out, struct pm_error *err)
{
	struct pm_taps tx, ty;
	struct pm_image mid;
	enum pm_err e;
	int wo, ho, x, y, k;

	out->width = out->height = 0;
	out->rgb = NULL;
	if (in == NULL || in->rgb == NULL || in->width < 1 || in->height < 1)
		return pm_fail(err, PM_ERR_INVALID, "downsample: empty image");
	if (filter_radius(filter) <= 0.0)
		return pm_fail(err, PM_ERR_INVALID,
		    "downsample: unknown filter %d", (int)filter);
	if (factor < 1)
		return pm_fail(err, PM_ERR_INVALID,
		    "downsample: factor %d is not positive", factor);
	if (in->width % factor != 0 || in->height % factor != 0)
		return pm_fail(err, PM_ERR_INVALID,
		    "image size %dx%d is not divisible by factor %d",
		    in->width, in->height, factor);
	wo = in->width / factor;
	ho = in->height / factor;

	if ((e = taps_build(&tx, in->width, factor, filter, err)) != PM_OK)
		return e;
	if ((e = taps_build(&ty, in->height, factor, filter, err)) != PM_OK) {
		taps_free(&tx);
		return e;
	}
	if ((e = pm_image_alloc(&mid, wo, in->height, err)) != PM_OK)
		goto done;
	if ((e = pm_image_alloc(out, wo, ho, err)) != PM_OK)
		goto done;

	/* Rows: in (W x H) -> mid (wo x H). */
	for (y = 0; y < in->height; y++) {
		const float *row = in->rgb + (size_t)y * in->width * 3;
		float *dst = mid.rgb + (size_t)y * wo * 3;

		for (x = 0; x < wo; x++) {
			const double *w = tx.w + (size_t)x * tx.stride;
			const float *src = row + (size_t)tx.first[x] * 3;
			double r = 0, g = 0, b = 0;

			for (k = 0; k < tx.count[x]; k++) {
				r += w[k] * src[3 * k];
				g += w[k] * src[3 * k + 1];
				b += w[k] * src[3 * k + 2];
			}
			dst[3 * x] = (float)r;
			dst[3 * x + 1] = (float)g;
			dst[3 * x + 2] = (float)b;
		}
	}
	/* Columns: mid (wo x H) -> out (wo x ho). */
	for (y = 0; y < ho; y++) {
		const double *w = ty.w + (size_t)y * ty.stride;
		float *dst = out->rgb + (size_t)y * wo * 3;

		for (x = 0; x < wo; x++) {
			double r = 0, g = 0, b = 0;

			for (k = 0; k < ty.count[y]; k++) {
				const float *src = mid.rgb +
				    ((size_t)(ty.first[y] + k) * wo + x) * 3;

				r += w[k] * src[0];
				g += w[k] * src[1];
				b += w[k] * src[2];
			}
			dst[3 * x] = (float)r;
			dst[3 * x + 1] = (float)g;
			dst[3 * x + 2] = (float)b;
		}
	}
	e = PM_OK;
done:
	if (e != PM_OK)
		pm_image_free(out);
	pm_image_free(&mid);
	taps_free(&tx);
	taps_free(&ty);
	return e;
}

/* Adds im to acc pixel by pixel; fails, leaving acc alone, if the sizes
 * differ. */
enum pm_err
pm_image_accumulate(struct pm_image *acc, const struct pm_image *im,
    struct pm_error *err)
{
	size_t i, n;

	if (acc->width != im->width || acc->height != im->height)
		return pm_fail(err, PM_ERR_INVALID,
		    "image size %dx%d differs from %dx%d",
		    im->width, im->height, acc->width, acc->height);
	n = (size_t)acc->width * (size_t)acc->height * 3;
	for (i = 0; i < n; i++)
		acc->rgb[i] += im->rgb[i];
	return PM_OK;
}

/* Multiplies every channel of im by s. */
void
pm_image_scale(struct pm_image *im, float s)
{
	size_t i, n;

	n = (size_t)im->width * (size_t)im->height * 3;
	for (i = 0; i < n; i++)
		im->rgb[i] *= s;
}

/* The sRGB transfer curve of one linear channel, as a byte.  Written so
 * that NaN and negatives land on 0 and anything at or above 1 (infinity
 * included) on 255, before any conversion to an integer can wrap. */
static uint8_t
srgb8(float v)
{
	double s;

	if (!(v > 0.0f))
		return 0;
	if (v >= 1.0f)
		return 255;
	if (v <= 0.0031308f)
		s = 12.92 * v;
	else
		s = 1.055 * pow(v, 1.0 / 2.4) - 0.055;
	s = s * 255.0 + 0.5;
	if (s >= 255.0)
		return 255;
	if (s < 0.0)
		return 0;
	return (uint8_t)s;
}

/* Writes 3 * width * height bytes of sRGB into out, after scaling by
 * 2^exposure; see image.h for the clamping rules. */
void
pm_image_to_srgb8(const struct pm_image *im, float exposure, uint8_t *out)
{
	size_t i, n;
	float m = exp2f(exposure);

	n = (size_t)im->width * (size_t)im->height * 3;
	for (i = 0; i < n; i++)
		out[i] = srgb8(im->rgb[i] * m);
}
