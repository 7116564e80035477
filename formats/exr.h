/*
 * exr.h: OpenEXR images through OpenEXR's C API (OpenEXRCore).
 */
#ifndef PM_EXR_H
#define PM_EXR_H

#include <stdbool.h>

#include "../common/error.h"
#include "../common/image.h"

/*
 * Writes im as a scanline RGB file, float32 or (half = true) half, ZIP
 * compressed.  Writes to a temporary file beside path and renames it, so
 * that a failed write never leaves a partial file.
 */
enum pm_err pm_exr_write(const char *path, const struct pm_image *im, bool half,
    struct pm_error *err);

/* Reads the R, G and B channels (half, float or uint) of the first part;
 * a missing channel is an error. im is allocated here. */
enum pm_err pm_exr_read(const char *path, struct pm_image *im, struct pm_error *err);

#endif
