/*
 * camera.h: Mitsuba's perspective, orthographic and thinlens sensors
 * turned into primary rays.
 */
#ifndef PM_CAMERA_H
#define PM_CAMERA_H

#include <stddef.h>

#include "scene.h"
#include "vec.h"

struct pm_camera_rays {
	enum pm_sensor_type type;
	struct pm_vec3 origin;		/* to_world's image of the local origin */
	struct pm_vec3 dx, dy, dz;	/* world images of the camera axes; only
					 * orthographic ones may be scaled */
	struct pm_vec3 axis;		/* dz normalised: orthographic rays */
	float tan_x, tan_y;		/* perspective, thinlens: half extents
					 * of the image plane at z = 1;
					 * orthographic: of the film at z = 0 */
	float near_clip, far_clip;
	float aperture_radius, focus_distance;	/* thinlens */
	int width, height;
};

/* Derives the ray generator from the scene's camera description. */
void pm_camera_setup(struct pm_camera_rays *c, const struct pm_camera *cam);

/* True when the camera's rays need a lens sample (thinlens): then the
 * caller draws the two numbers that pm_camera_ray's lu and lv take. */
static inline bool
pm_camera_needs_lens(const struct pm_camera_rays *c)
{
	return c->type == PM_SENSOR_THINLENS;
}

/*
 * The unit direction of the ray through film position (fx, fy), in pixels
 * from the top-left corner; its origin in *o and in *tmin and *tmax its
 * range for the clip planes, as Mitsuba's sensors measure them (along the
 * optical axis; orthographic: from the near plane, where *o lies).  (lu,
 * lv) in [0,1)^2 picks the point on a thin lens's aperture and is ignored
 * by the other sensors.
 */
struct pm_vec3 pm_camera_ray(const struct pm_camera_rays *c, float fx, float fy,
    float lu, float lv, struct pm_vec3 *o, float *tmin, float *tmax);

/* pm_camera_ray at n film positions (fx[i], fy[i]) with lens numbers
 * (lu[i], lv[i]), the same bits; a perspective camera's four at a time
 * in SIMD lanes. */
void pm_camera_rays_n(const struct pm_camera_rays *c, const float *fx,
    const float *fy, const float *lu, const float *lv, size_t n,
    struct pm_vec3 *o, struct pm_vec3 *d, float *tmin, float *tmax);

/* Half-extent tangents of the field of view for the given film size. */
void pm_camera_tangents(float fov_deg, enum pm_fov_axis axis, int width,
    int height, float *tan_x, float *tan_y);

#endif
