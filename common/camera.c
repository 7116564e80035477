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

/*
 * perspective_lanes: pm_camera_ray's perspective case, four film positions
 * at a time, its operations in its order (IEEE division and square root
 * are exact in SIMD as in scalar code; -ffp-contract=off fuses nothing),
 * so each ray is the scalar one's bits.  Its two divisions and two square
 * roots made the camera ray a twentieth of a path-traced Cornell box.
 */
#if (defined(__x86_64__) || defined(__i386__)) && defined(__SSE2__) && \
    (defined(__GNUC__) || defined(__clang__)) && !defined(PM_NO_SIMD)
#include <immintrin.h>

static size_t
perspective_lanes(const struct pm_camera_rays *c, const float *fx,
    const float *fy, size_t n, struct pm_vec3 *o, struct pm_vec3 *d,
    float *tmin, float *tmax)
{
	const __m128 one = _mm_set1_ps(1.0f), two = _mm_set1_ps(2.0f);
	const __m128 sign = _mm_set1_ps(-0.0f), zero = _mm_setzero_ps();
	const __m128 w = _mm_set1_ps((float)c->width);
	const __m128 h = _mm_set1_ps((float)c->height);
	const float *ax = &c->dx.x, *ay = &c->dy.x, *az = &c->dz.x;
	size_t i, k;
	int a;

	for (i = 0; i + 4 <= n; i += 4) {
		__m128 sx = _mm_sub_ps(_mm_div_ps(_mm_mul_ps(two,
		    _mm_loadu_ps(fx + i)), w), one);
		__m128 sy = _mm_sub_ps(one, _mm_div_ps(_mm_mul_ps(two,
		    _mm_loadu_ps(fy + i)), h));
		__m128 lx = _mm_mul_ps(_mm_xor_ps(sx, sign),
		    _mm_set1_ps(c->tan_x));
		__m128 ly = _mm_mul_ps(sy, _mm_set1_ps(c->tan_y));
		__m128 len, dd, l, inv, keep, dv[3];
		float out[3][4], tn[4], tf[4];

		for (a = 0; a < 3; a++)
			dv[a] = _mm_add_ps(_mm_add_ps(_mm_mul_ps(
			    _mm_set1_ps(az[a]), one), _mm_mul_ps(
			    _mm_set1_ps(ax[a]), lx)), _mm_mul_ps(
			    _mm_set1_ps(ay[a]), ly));
		len = _mm_sqrt_ps(_mm_add_ps(_mm_add_ps(_mm_mul_ps(lx, lx),
		    _mm_mul_ps(ly, ly)), _mm_mul_ps(one, one)));
		dd = _mm_add_ps(_mm_add_ps(_mm_mul_ps(dv[0], dv[0]),
		    _mm_mul_ps(dv[1], dv[1])), _mm_mul_ps(dv[2], dv[2]));
		l = _mm_sqrt_ps(dd);
		/* pm_normalize: a zero (or NaN) length leaves d as it is */
		keep = _mm_cmpngt_ps(l, zero);
		inv = _mm_div_ps(one, l);
		for (a = 0; a < 3; a++)
			_mm_storeu_ps(out[a], _mm_or_ps(_mm_and_ps(keep, dv[a]),
			    _mm_andnot_ps(keep, _mm_mul_ps(dv[a], inv))));
		_mm_storeu_ps(tn, _mm_mul_ps(_mm_set1_ps(c->near_clip), len));
		_mm_storeu_ps(tf, _mm_mul_ps(_mm_set1_ps(c->far_clip), len));
		for (k = 0; k < 4; k++) {
			o[i + k] = c->origin;
			d[i + k] = pm_v3(out[0][k], out[1][k], out[2][k]);
			tmin[i + k] = tn[k];
			tmax[i + k] = tf[k];
		}
	}
	return i;
}
#else
static size_t
perspective_lanes(const struct pm_camera_rays *c, const float *fx,
    const float *fy, size_t n, struct pm_vec3 *o, struct pm_vec3 *d,
    float *tmin, float *tmax)
{
	(void)c, (void)fx, (void)fy, (void)n, (void)o, (void)d, (void)tmin;
	(void)tmax;
	return 0;
}
#endif

void
pm_camera_rays_n(const struct pm_camera_rays *c, const float *fx,
    const float *fy, const float *lu, const float *lv, size_t n,
    struct pm_vec3 *o, struct pm_vec3 *d, float *tmin, float *tmax)
{
	size_t i = 0;

	if (c->type == PM_SENSOR_PERSPECTIVE)
		i = perspective_lanes(c, fx, fy, n, o, d, tmin, tmax);
	for (; i < n; i++)
		d[i] = pm_camera_ray(c, fx[i], fy[i], lu[i], lv[i], &o[i],
		    &tmin[i], &tmax[i]);
}
