/*
 * vol.h: Mitsuba's binary volume grids (.vol, the gridvolume plugin's
 * files, the format of Mitsuba 0.6), read and written byte for byte:
 *
 *   offset size  content (little-endian)
 *        0    3  "VOL"
 *        3    1  version, 3
 *        4    4  int32 encoding, 1 (float32; the only one Mitsuba reads)
 *        8   12  int32 nx, ny, nz, voxels along x, y, z
 *       20    4  int32 channels: 1 or 3 (Mitsuba's 6 is refused here)
 *       24   24  float32 box: xmin, ymin, zmin, xmax, ymax, zmax
 *       48    *  float32 voxels, [((z ny + y) nx + x) channels + c]
 *
 * nothing after them.  The reader refuses any other version, encoding or
 * channel count, sizes that disagree with the file's length, more than
 * PM_VOL_MAX_VALUES values, and values that are not finite.
 */
#ifndef PM_FORMATS_VOL_H
#define PM_FORMATS_VOL_H

#include <stddef.h>

#include "../common/error.h"
#include "../common/medium.h"

#define PM_VOL_HEADER 48
/* 2^28 floats (1 GiB): a 645^3 grid of one channel, 448^3 of three. */
#define PM_VOL_MAX_VALUES ((size_t)1 << 28)

/* Parses a whole file held in memory (tests, fuzzing); name is used in
 * messages.  On success *g owns new voxels (pm_grid_free).  Never reads
 * outside buf[0..len). */
enum pm_err pm_vol_parse(const void *buf, size_t len, const char *name,
    struct pm_grid *g, struct pm_error *err);

/* Reads the file at path. */
enum pm_err pm_vol_read(const char *path, struct pm_grid *g,
    struct pm_error *err);

/* Encodes g into buf of PM_VOL_HEADER + 4 nx ny nz nch bytes. */
void pm_vol_encode(const struct pm_grid *g, unsigned char *buf);

/* Writes g to path through a temporary file renamed into place. */
enum pm_err pm_vol_write(const char *path, const struct pm_grid *g,
    struct pm_error *err);

#endif
