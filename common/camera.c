/*
 * camera.c: primary rays of Mitsuba 3's perspective (pinhole), thinlens and
 * orthographic sensors with its conventions: the camera looks down its
 * local +z, +y is up and +x points left, so the image's x axis runs along
 * -x.  Everything per ray is arithmetic on the precomputed struct: no
 * allocation, no state, so that threads share one generator.
 */
#include <math.h>

#include "camera.h"
#include "sampling.h"
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
	c->type = cam->type;
	c->origin = pm_xform_point(&cam->to_world, pm_v3(0, 0, 0));
	c->dx = pm_xform_vector(&cam->to_world, pm_v3(1, 0, 0));
	c->dy = pm_xform_vector(&cam->to_world, pm_v3(0, 1, 0));
	c->dz = pm_xform_vector(&cam->to_world, pm_v3(0, 0, 1));
	c->axis = pm_normalize(c->dz);
	if (cam->type == PM_SENSOR_ORTHOGRAPHIC) {
		/* Mitsuba's orthographic film spans x in [-1, 1] and y in
		 * [-h/w, h/w] of camera space (its orthographic_projection
		 * divides y by the aspect ratio), scaled by to_world. */
		c->tan_x = 1.0f;
		c->tan_y = (float)cam->height / (float)cam->width;
	} else {
		pm_camera_tangents(cam->fov, cam->fov_axis, cam->width,
		    cam->height, &c->tan_x, &c->tan_y);
	}
	c->near_clip = cam->near_clip;
	c->far_clip = cam->far_clip;
	c->aperture_radius = cam->aperture_radius;
	c->focus_distance = cam->focus_distance;
	c->width = cam->width;
	c->height = cam->height;
}

struct pm_vec3
pm_camera_ray(const struct pm_camera_rays *c, float fx, float fy, float lu,
    float lv, struct pm_vec3 *o, float *tmin, float *tmax)
{
	/* Screen coordinates in [-1, 1], right and up positive. */
	float sx = 2.0f * fx / (float)c->width - 1.0f;
	float sy = 1.0f - 2.0f * fy / (float)c->height;
	struct pm_vec3 local = pm_v3(-sx * c->tan_x, sy * c->tan_y, 1.0f);
	struct pm_vec3 d;
	float len, ax, ay;

	switch (c->type) {
	case PM_SENSOR_ORTHOGRAPHIC:
		/* Parallel rays from the near plane, which to_world may
		 * scale; the range is far - near in world units from there,
		 * as Mitsuba has it. */
		*o = pm_madd(pm_madd(pm_madd(c->origin, c->dx, local.x),
		    c->dy, local.y), c->dz, c->near_clip);
		*tmin = 0.0f;
		*tmax = c->far_clip - c->near_clip;
		return c->axis;
	case PM_SENSOR_THINLENS:
		/* The point of the focal plane (local z = focus_distance)
		 * that the pinhole ray through this film position reaches;
		 * every ray from the aperture aims at it. */
		pm_square_to_disk(lu, lv, &ax, &ay);
		ax *= c->aperture_radius;
		ay *= c->aperture_radius;
		local = pm_v3(local.x * c->focus_distance - ax,
		    local.y * c->focus_distance - ay, c->focus_distance);
		len = pm_length(local);
		*o = pm_madd(pm_madd(c->origin, c->dx, ax), c->dy, ay);
		d = pm_madd(pm_madd(pm_scale(c->dz, local.z), c->dx, local.x),
		    c->dy, local.y);
		/* Clip planes along the optical axis: depth z is reached at
		 * t = z len / local.z. */
		*tmin = c->near_clip * len / local.z;
		*tmax = c->far_clip * len / local.z;
		return pm_normalize(d);
	case PM_SENSOR_PERSPECTIVE:
		break;
	}
	d = pm_madd(pm_madd(pm_scale(c->dz, local.z), c->dx, local.x), c->dy,
	    local.y);
	len = pm_length(local);
	/* Clip planes are distances along the optical axis, where the local
	 * direction (local.z = 1) has length len per unit of depth.  A rigid
	 * to_world keeps distances, which is what lookat builds. */
	*o = c->origin;
	*tmin = c->near_clip * len;
	*tmax = c->far_clip * len;
	return pm_normalize(d);
}
