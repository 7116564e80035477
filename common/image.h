/*
 * image.h: linear RGB float images, the film every tool writes and reads,
 * and the operations pm-downsample needs: filtered downsampling by an
 * integer factor, averaging, and tone mapping to 8-bit sRGB.
 */
#ifndef PM_IMAGE_H
#define PM_IMAGE_H

#include <stddef.h>
#include <stdint.h>

#include "error.h"

/* Keeps sizes small enough that 3 * width * height floats fit comfortably in
 * size_t and int arithmetic stays exact; 32768^2 is far beyond any film.
 * pm_image_alloc refuses more; the EXR reader holds all of a file's
 * channels within PM_IMAGE_MAX_PIXELS RGB pixels. */
#define PM_IMAGE_MAX_SIDE	32768
#define PM_IMAGE_MAX_PIXELS	((size_t)1 << 28)

struct pm_image {
	int width, height;
	float *rgb;		/* 3 * width * height, row-major, top row first */
};

enum pm_err pm_image_alloc(struct pm_image *im, int width, int height,
    struct pm_error *err);
void pm_image_free(struct pm_image *im);

enum pm_filter {
	PM_FILTER_BOX,
	PM_FILTER_TENT,
	PM_FILTER_GAUSSIAN,
	PM_FILTER_MITCHELL,
	PM_FILTER_LANCZOS,
};

/* Parses "box", "tent", ...; returns -1 if unknown. */
int pm_filter_parse(const char *name);

/*
 * Downsamples in by factor (which must divide both sizes) into out
 * (allocated here).  Each output pixel is a normalised weighted sum of the
 * input pixels whose centres fall within the filter's support, scaled to
 * output pixels; the filter is separable.  Filters with negative lobes
 * (Mitchell, Lanczos) can produce small negative values; they are kept,
 * since the film is linear and later averaging must stay unbiased.
 */
enum pm_err pm_image_downsample(const struct pm_image *in, int factor,
    enum pm_filter filter, struct pm_image *out, struct pm_error *err);

/* acc += im, pixel by pixel; sizes must match. */
enum pm_err pm_image_accumulate(struct pm_image *acc, const struct pm_image *im,
    struct pm_error *err);
void pm_image_scale(struct pm_image *im, float s);

/*
 * Converts to 8-bit sRGB: multiplies by 2^exposure, maps each channel with
 * the sRGB transfer curve, clamps to [0, 1] (NaN to 0) and rounds, so that
 * values never wrap.  out holds 3 * width * height bytes.
 */
void pm_image_to_srgb8(const struct pm_image *im, float exposure, uint8_t *out);

#endif
