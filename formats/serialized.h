/*
 * serialized.h: reader of Mitsuba's .serialized meshes (format 0x041C,
 * versions 3 and 4): a short plain header, then each mesh as one zlib
 * stream, and a table of the meshes' offsets at the end of the file.
 */
#ifndef PM_SERIALIZED_H
#define PM_SERIALIZED_H

#include <stdbool.h>
#include <stddef.h>

#include "../common/error.h"
#include "../common/mesh.h"

/*
 * Reads mesh number shape_index (0 is the first) of the file at path into
 * *m (positions; normals and uv when the file has them; colours skipped),
 * and in *face_normals whether the file asks for flat shading.  On
 * failure *m is empty.
 */
enum pm_err pm_serialized_read(const char *path, long shape_index,
    struct pm_mesh *m, bool *face_normals, struct pm_error *err);

/* The same from a file already in memory; name is for messages. */
enum pm_err pm_serialized_parse(const char *name, const unsigned char *buf,
    size_t len, long shape_index, struct pm_mesh *m, bool *face_normals,
    struct pm_error *err);

#endif
