/*
 * transform.h: 4x4 affine transforms, composed as Mitsuba composes them.
 *
 * In a <transform> element each child operation is applied after the ones
 * before it, so the running matrix M becomes Op * M.  Matrices are row-major
 * and act on column vectors: p' = M p.
 */
#ifndef PM_TRANSFORM_H
#define PM_TRANSFORM_H

#include <stdbool.h>

#include "vec.h"

struct pm_mat4 {
	float m[4][4];
};

struct pm_mat4 pm_mat4_identity(void);
struct pm_mat4 pm_mat4_mul(struct pm_mat4 a, struct pm_mat4 b);	/* a * b */
struct pm_mat4 pm_mat4_translate(struct pm_vec3 t);
struct pm_mat4 pm_mat4_scale(struct pm_vec3 s);
/* Rotation by angle_deg degrees about axis (right-handed, as Mitsuba). */
struct pm_mat4 pm_mat4_rotate(struct pm_vec3 axis, float angle_deg);
/* Mitsuba's lookat: columns are left = up x dir, up' = dir x left, dir, origin. */
struct pm_mat4 pm_mat4_lookat(struct pm_vec3 origin, struct pm_vec3 target,
    struct pm_vec3 up);
/* False if the matrix is singular. */
bool pm_mat4_inverse(struct pm_mat4 a, struct pm_mat4 *inv);

struct pm_vec3 pm_xform_point(const struct pm_mat4 *m, struct pm_vec3 p);
struct pm_vec3 pm_xform_vector(const struct pm_mat4 *m, struct pm_vec3 v);
/* Transforms a normal by the inverse transpose; inv is the inverse of M. */
struct pm_vec3 pm_xform_normal(const struct pm_mat4 *inv, struct pm_vec3 n);

#endif
