/*
 * camera.c: primary rays of a pinhole camera with Mitsuba 3's conventions:
 * the camera looks down its local +z, +y is up and +x points left, so the
 * image's x axis runs along -x.
 */
#include <math.h>

#include "camera.h"
#include "transform.h"

void
pm_camera_tangents(float fov_deg, enum pm_fov_axis axis, int width, int height,
    float *tan_x, float *tan_y)
{
	float t = tanf(0.5f * fov_deg * (PM_PI / 180.0f));
	float w = (float)width, h = (float)height, diag;

	if (axis == PM_FOV_SMALLER)
		axis = width <= height ? PM_FOV_X : PM_FOV_Y;
	else if (axis == PM_FOV_LARGER)
		axis = width >= height ? PM_FOV_X : PM_FOV_Y;
	switch (axis) {
	case PM_FOV_Y:
		*tan_y = t;
		*tan_x = t * w / h;
		break;
	case PM_FOV_DIAGONAL:
		diag = sqrtf(w * w + h * h);
		*tan_x = t * w / diag;
		*tan_y = t * h / diag;
		break;
	default:
		*tan_x = t;
		*tan_y = t * h / w;
		break;
	}
}

void
pm_camera_setup(struct pm_camera_rays *c, const struct pm_camera *cam)
{
	c->origin = pm_xform_point(&cam->to_world, pm_v3(0, 0, 0));
	c->dx = pm_xform_vector(&cam->to_world, pm_v3(1, 0, 0));
	c->dy = pm_xform_vector(&cam->to_world, pm_v3(0, 1, 0));
	c->dz = pm_xform_vector(&cam->to_world, pm_v3(0, 0, 1));
	pm_camera_tangents(cam->fov, cam->fov_axis, cam->width, cam->height,
	    &c->tan_x, &c->tan_y);
	c->near_clip = cam->near_clip;
	c->far_clip = cam->far_clip;
	c->width = cam->width;
	c->height = cam->height;
}

struct pm_vec3
pm_camera_ray(const struct pm_camera_rays *c, float fx, float fy, float *tmin,
    float *tmax)
{
	/* Screen coordinates in [-1, 1], right and up positive. */
	float sx = 2.0f * fx / (float)c->width - 1.0f;
	float sy = 1.0f - 2.0f * fy / (float)c->height;
	struct pm_vec3 local = pm_v3(-sx * c->tan_x, sy * c->tan_y, 1.0f);
	struct pm_vec3 d = pm_madd(pm_madd(pm_scale(c->dz, local.z),
	    c->dx, local.x), c->dy, local.y);
	float len = pm_length(local);

	/* Clip planes are distances along the optical axis, where the local
	 * direction (local.z = 1) has length len per unit of depth.  A rigid
	 * to_world keeps distances, which is what lookat builds. */
	*tmin = c->near_clip * len;
	*tmax = c->far_clip * len;
	return pm_normalize(d);
}
