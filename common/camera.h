/*
 * camera.h: Mitsuba's perspective sensor turned into primary rays.
 */
#ifndef PM_CAMERA_H
#define PM_CAMERA_H

#include "scene.h"
#include "vec.h"

struct pm_camera_rays {
	struct pm_vec3 origin;
	struct pm_vec3 dx, dy, dz;	/* world images of the camera axes */
	float tan_x, tan_y;		/* half extents of the image plane at z = 1 */
	float near_clip, far_clip;
	int width, height;
};

/* Derives the ray generator from the scene's camera description. */
void pm_camera_setup(struct pm_camera_rays *c, const struct pm_camera *cam);

/*
 * The unit direction through film position (fx, fy), in pixels from the
 * top-left corner, and in *tmin and *tmax the ray's range for the clip
 * planes (Mitsuba measures them along the optical axis).
 */
struct pm_vec3 pm_camera_ray(const struct pm_camera_rays *c, float fx, float fy,
    float *tmin, float *tmax);

/* Half-extent tangents of the field of view for the given film size. */
void pm_camera_tangents(float fov_deg, enum pm_fov_axis axis, int width,
    int height, float *tan_x, float *tan_y);

#endif
