/*
 * texture.h (formats): bitmap textures from image files.
 */
#ifndef PM_FORMATS_TEXTURE_H
#define PM_FORMATS_TEXTURE_H

#include <stdbool.h>

#include "../common/error.h"
#include "../common/texture.h"

/*
 * Reads a PNG, JPEG or OpenEXR file (told apart by their first bytes, not
 * by the name) into t's texels as linear RGB, replacing any it had.  The
 * PNG (8 or 16 bits) and JPEG are sRGB-encoded, decoded here unless raw;
 * OpenEXR is
 * linear already.  Alpha is dropped, grey becomes equal RGB.
 */
enum pm_err pm_bitmap_read(const char *path, bool raw, struct pm_texture *t,
    struct pm_error *err);

#endif
