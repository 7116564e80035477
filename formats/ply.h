/*
 * ply.h: Stanford PLY reader (ascii, binary_little_endian, binary_big_endian).
 */
#ifndef PM_PLY_H
#define PM_PLY_H

#include <stddef.h>

#include "../common/error.h"
#include "../common/mesh.h"

/*
 * Reads the vertex element (x, y, z; nx, ny, nz and u, v or s, t when all
 * are present) and the face element (a list property named vertex_indices
 * or vertex_index; polygons fan-triangulated).  Other elements and
 * properties are skipped by their declared sizes.  Every count is checked
 * against the bytes that remain before anything is allocated.
 */
enum pm_err pm_ply_read(const char *path, struct pm_mesh *m, struct pm_error *err);
enum pm_err pm_ply_parse(const char *name, const unsigned char *buf, size_t len,
    struct pm_mesh *m, struct pm_error *err);

#endif
