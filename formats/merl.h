/*
 * merl.h: MERL BRDF files (.binary), read and written byte for byte as
 * the MERL database stores them: three little-endian int32 dimensions
 * (90, 90, 180), then the red, green and blue planes of 1,458,000
 * little-endian doubles each, 34,992,012 bytes in all.  Values times the
 * channel's scale are f_r; negative values mark samples below the horizon.
 *
 * The writer tabulates analytic BRDFs (common/merl.h's struct
 * pm_merl_model: Lambertian, a GGX conductor, a GGX-coated plastic) in
 * that layout, so that pm can test its reader and render measured-style
 * materials without the database.
 */
#ifndef PM_FORMATS_MERL_H
#define PM_FORMATS_MERL_H

#include <stddef.h>

#include "../common/error.h"
#include "../common/merl.h"
#include "../common/vec.h"

/* Encodes a model into buf, which holds PM_MERL_FILE_SIZE bytes: f_r at
 * the centre of every bin divided by the channel's scale, -1 where wi or
 * wo is below the horizon. */
void pm_merl_encode(const struct pm_merl_model *mo, unsigned char *buf);

/* Writes a model to path through a temporary file renamed into place;
 * "-" writes to standard output. */
enum pm_err pm_merl_write(const char *path, const struct pm_merl_model *mo,
    struct pm_error *err);

/* Parses a whole file held in memory (tests, fuzzing); name is used in
 * messages.  On success *out is a prepared table the caller frees with
 * pm_merl_free.  Never reads outside buf[0..len). */
enum pm_err pm_merl_parse(const void *buf, size_t len, const char *name,
    struct pm_merl **out, struct pm_error *err);

/* Reads and prepares the file at path; *out records path, size and crc. */
enum pm_err pm_merl_read(const char *path, struct pm_merl **out,
    struct pm_error *err);

#endif
