/*
 * obj.h: Wavefront OBJ reader (v, vt, vn, f; polygons fan-triangulated).
 */
#ifndef PM_OBJ_H
#define PM_OBJ_H

#include "../common/error.h"
#include "../common/mesh.h"

/*
 * Reads path into m (owned by the caller, freed with pm_mesh_free).  As in
 * Mitsuba 3, vertices with the same (v, vt, vn) triple are shared; normals
 * are kept only if every face vertex has one.  Other statements (o, g, s,
 * usemtl, mtllib, l, p) are ignored.  Errors name the file and line.
 */
enum pm_err pm_obj_read(const char *path, struct pm_mesh *m, struct pm_error *err);

/* The same, from a buffer in memory (for tests and fuzzing); name is used
 * in messages. */
enum pm_err pm_obj_parse(const char *name, const char *buf, size_t len,
    struct pm_mesh *m, struct pm_error *err);

#endif
