/*
 * rgbe.h: Radiance HDR images (RGBE, ".hdr"), read only.
 */
#ifndef PM_RGBE_H
#define PM_RGBE_H

#include "../common/error.h"
#include "../common/image.h"

/*
 * Reads an RGBE image ("#?RADIANCE" or "#?RGBE" header, FORMAT
 * 32-bit_rle_rgbe, rows top first "-Y H +X W" or bottom first "+Y H +X W",
 * flat, run-length or old-style run-length scanlines) into im, allocated
 * here, as linear RGB: mantissa times 2^(exponent - 136), as Mitsuba and
 * Greg Ward's reference reader convert it.  EXPOSURE lines are ignored,
 * as Mitsuba ignores them.
 */
enum pm_err pm_rgbe_read(const char *path, struct pm_image *im,
    struct pm_error *err);

#endif
