/*
 * mesh.h: indexed triangle meshes, the shapes pm builds as meshes
 * (rectangle, cube, disk), and vertex normals for smooth shading.
 */
#ifndef PM_MESH_H
#define PM_MESH_H

#include <stdint.h>

#include "error.h"
#include "transform.h"
#include "vec.h"

struct pm_mesh {
	uint32_t nverts;
	uint32_t ntris;
	float *pos;		/* 3 * nverts */
	float *nrm;		/* 3 * nverts unit normals, or NULL: flat shading */
	float *uv;		/* 2 * nverts, or NULL */
	uint32_t *idx;		/* 3 * ntris, counter-clockwise seen from the front */
	/* Mitsuba's mesh attributes vertex_color (3 * nverts) and
	 * face_color (3 * ntris, one per triangle), or NULL: what a PLY
	 * file gives, for the mesh_attribute texture */
	float *vcolor, *fcolor;
};

void pm_mesh_free(struct pm_mesh *m);

/*
 * Drops triangles with zero area or non-finite vertices and reports how
 * many were dropped in *dropped; fails if an index is out of range.
 */
enum pm_err pm_mesh_validate(struct pm_mesh *m, uint32_t *dropped,
    struct pm_error *err);

/*
 * Computes smooth vertex normals, weighting each face normal by the angle
 * the face makes at the vertex (Thuermer and Wuethrich 1998), replacing
 * any normals present.  A vertex whose faces' normals cancel gets the
 * normal of its first face.
 */
enum pm_err pm_mesh_compute_normals(struct pm_mesh *m, struct pm_error *err);

/* Applies M to positions and its inverse transpose to normals (renormalised);
 * a transform that mirrors (negative determinant) also flips the winding so
 * that the geometric normal keeps facing the same side as the shading one. */
void pm_mesh_transform(struct pm_mesh *m, const struct pm_mat4 *M);

/* Reverses winding and negates normals (Mitsuba's flip_normals). */
void pm_mesh_flip(struct pm_mesh *m);

/* Mitsuba's rectangle: [-1,1]^2 at z = 0, normal +z, uv in [0,1]^2. */
enum pm_err pm_mesh_rectangle(struct pm_mesh *m, struct pm_error *err);
/* Mitsuba's cube: [-1,1]^3, outward flat normals (24 vertices, 12 triangles). */
enum pm_err pm_mesh_cube(struct pm_mesh *m, struct pm_error *err);
/* Mitsuba's disk: unit disk at z = 0, normal +z, as a fan of `segments`
 * triangles whose total area equals pi (the rim is pushed out to match). */
enum pm_err pm_mesh_disk(struct pm_mesh *m, uint32_t segments,
    struct pm_error *err);
/* A UV sphere mesh of the unit sphere (used by tests for normal checks). */
enum pm_err pm_mesh_uv_sphere(struct pm_mesh *m, uint32_t rings,
    uint32_t segments, struct pm_error *err);

/* Mitsuba's open cylinder of radius 1 about the z axis, z in [0, 1], outward
 * exact normals, as `segments` facets whose total area equals 2 pi. */
enum pm_err pm_mesh_cylinder(struct pm_mesh *m, uint32_t segments,
    struct pm_error *err);

/* Total surface area. */
double pm_mesh_area(const struct pm_mesh *m);

static inline struct pm_vec3 pm_mesh_vertex(const struct pm_mesh *m, uint32_t i)
{
	return pm_v3(m->pos[3 * i], m->pos[3 * i + 1], m->pos[3 * i + 2]);
}

#endif
