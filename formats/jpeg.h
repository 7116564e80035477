/*
 * jpeg.h: JPEG input through libjpeg, for bitmap textures.
 */
#ifndef PM_JPEG_H
#define PM_JPEG_H

#include <stdint.h>

#include "../common/error.h"

/* Reads a JPEG (baseline or progressive, grey or colour) as 8-bit RGB:
 * 3 * width * height bytes in *rgb, top row first, which the caller
 * frees; the bytes keep the file's (sRGB) encoding. */
enum pm_err pm_jpeg_read(const char *path, uint8_t **rgb, int *width,
    int *height, struct pm_error *err);

#endif
