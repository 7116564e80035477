/*
 * png.h: 8-bit RGB PNG output, and 8- or 16-bit RGBA input, through libpng.
 */
#ifndef PM_PNG_H
#define PM_PNG_H

#include <stdint.h>

#include "../common/error.h"

/* Writes rgb (3 * width * height bytes, top row first) to path through a
 * temporary file that is renamed on success; "-" writes to stdout. */
enum pm_err pm_png_write(const char *path, const uint8_t *rgb, int width,
    int height, struct pm_error *err);

/* The same, encoded for speed (zlib level 1, no row filters) rather than
 * size: for an image rewritten every second, such as a preview. */
enum pm_err pm_png_write_fast(const char *path, const uint8_t *rgb,
    int width, int height, struct pm_error *err);

/* Reads any PNG as RGBA, 4 * width * height samples in *rgba, top row
 * first, which the caller frees: 8-bit files (grey and palettes
 * expanded) as uint8_t, in the file's encoding; 16-bit ones as uint16_t
 * (*bits says which), the samples as the file has them (without a gamma
 * chunk).  A missing alpha is opaque. */
enum pm_err pm_png_read(const char *path, void **rgba, int *bits,
    int *width, int *height, struct pm_error *err);

#endif
