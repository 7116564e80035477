/*
 * png.h: 8-bit RGB PNG output, and 8-bit RGBA input, through libpng.
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

/* Reads any PNG as 8-bit RGBA (grey is repeated, a missing alpha is
 * opaque, 16-bit samples are rounded to 8 bits, the bytes keep the file's
 * encoding): 4 * width * height bytes in *rgba, top row first, which the
 * caller frees. */
enum pm_err pm_png_read(const char *path, uint8_t **rgba, int *width,
    int *height, struct pm_error *err);

#endif
