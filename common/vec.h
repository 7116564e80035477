/*
 * vec.h: 3-vectors, RGB triples and orthonormal frames, all inline.
 *
 * Geometry is single precision (Embree works in float); accumulators that
 * sum many samples live elsewhere in double.  Plain structs passed by value
 * keep the hot paths free of aliasing worries and easy to port to CUDA C.
 */
#ifndef PM_VEC_H
#define PM_VEC_H

#include <math.h>

#define PM_PI 3.14159265358979323846f
#define PM_INV_PI 0.31830988618379067154f

struct pm_vec3 {
	float x, y, z;
};

/*
 * fmaxf, inline: without -ffinite-math-only GCC calls libm's on x86-64,
 * 3% of a path-traced frame.  The same result bit for bit as glibc's
 * (maxss: b when they compare equal, so -0/+0 as well), and NaN loses
 * to a number as the standard has it.
 */
static inline float pm_fmaxf(float a, float b)
{
	return a > b ? a : (b != b ? a : b);
}
/* fminf the same way (minss). */
static inline float pm_fminf(float a, float b)
{
	return a < b ? a : (b != b ? a : b);
}

struct pm_rgb {
	float r, g, b;
};

/* An orthonormal basis; n is the local +z axis. */
struct pm_frame {
	struct pm_vec3 s, t, n;
};

static inline struct pm_vec3 pm_v3(float x, float y, float z)
{
	struct pm_vec3 v = {x, y, z};
	return v;
}
static inline struct pm_vec3 pm_add(struct pm_vec3 a, struct pm_vec3 b)
{
	return pm_v3(a.x + b.x, a.y + b.y, a.z + b.z);
}
static inline struct pm_vec3 pm_sub(struct pm_vec3 a, struct pm_vec3 b)
{
	return pm_v3(a.x - b.x, a.y - b.y, a.z - b.z);
}
static inline struct pm_vec3 pm_scale(struct pm_vec3 a, float s)
{
	return pm_v3(a.x * s, a.y * s, a.z * s);
}
static inline struct pm_vec3 pm_neg(struct pm_vec3 a)
{
	return pm_v3(-a.x, -a.y, -a.z);
}
/* a + b * s */
static inline struct pm_vec3 pm_madd(struct pm_vec3 a, struct pm_vec3 b, float s)
{
	return pm_v3(a.x + b.x * s, a.y + b.y * s, a.z + b.z * s);
}
static inline float pm_dot(struct pm_vec3 a, struct pm_vec3 b)
{
	return a.x * b.x + a.y * b.y + a.z * b.z;
}
static inline struct pm_vec3 pm_cross(struct pm_vec3 a, struct pm_vec3 b)
{
	return pm_v3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z,
	    a.x * b.y - a.y * b.x);
}
static inline float pm_length(struct pm_vec3 a)
{
	return sqrtf(pm_dot(a, a));
}
/* Unit vector along a; a zero vector stays zero rather than becoming NaN. */
static inline struct pm_vec3 pm_normalize(struct pm_vec3 a)
{
	float l = pm_length(a);
	return l > 0.0f ? pm_scale(a, 1.0f / l) : a;
}
static inline float pm_max_comp(struct pm_vec3 a)
{
	return pm_fmaxf(a.x, pm_fmaxf(a.y, a.z));
}
static inline float pm_vget(struct pm_vec3 a, int axis)
{
	return axis == 0 ? a.x : axis == 1 ? a.y : a.z;
}

static inline struct pm_rgb pm_rgb(float r, float g, float b)
{
	struct pm_rgb c = {r, g, b};
	return c;
}
static inline struct pm_rgb pm_rgb1(float v)
{
	return pm_rgb(v, v, v);
}
static inline struct pm_rgb pm_rgb_add(struct pm_rgb a, struct pm_rgb b)
{
	return pm_rgb(a.r + b.r, a.g + b.g, a.b + b.b);
}
static inline struct pm_rgb pm_rgb_mul(struct pm_rgb a, struct pm_rgb b)
{
	return pm_rgb(a.r * b.r, a.g * b.g, a.b * b.b);
}
static inline struct pm_rgb pm_rgb_scale(struct pm_rgb a, float s)
{
	return pm_rgb(a.r * s, a.g * s, a.b * s);
}
/* a + b * c */
static inline struct pm_rgb pm_rgb_madd(struct pm_rgb a, struct pm_rgb b, struct pm_rgb c)
{
	return pm_rgb(a.r + b.r * c.r, a.g + b.g * c.g, a.b + b.b * c.b);
}
static inline float pm_rgb_max(struct pm_rgb a)
{
	return pm_fmaxf(a.r, pm_fmaxf(a.g, a.b));
}
static inline float pm_rgb_mean(struct pm_rgb a)
{
	return (a.r + a.g + a.b) * (1.0f / 3.0f);
}
static inline int pm_rgb_is_black(struct pm_rgb a)
{
	return a.r == 0.0f && a.g == 0.0f && a.b == 0.0f;
}
static inline int pm_rgb_is_finite(struct pm_rgb a)
{
	return isfinite(a.r) && isfinite(a.g) && isfinite(a.b);
}

/*
 * Frame around a unit normal, branchless and continuous except at one
 * point (Duff et al. 2017, "Building an orthonormal basis, revisited").
 */
static inline struct pm_frame pm_frame_from_normal(struct pm_vec3 n)
{
	struct pm_frame f;
	float sign = copysignf(1.0f, n.z);
	float a = -1.0f / (sign + n.z);
	float b = n.x * n.y * a;
	f.s = pm_v3(1.0f + sign * n.x * n.x * a, sign * b, -sign * n.x);
	f.t = pm_v3(b, sign + n.y * n.y * a, -n.y);
	f.n = n;
	return f;
}
static inline struct pm_vec3 pm_to_local(struct pm_frame f, struct pm_vec3 v)
{
	return pm_v3(pm_dot(v, f.s), pm_dot(v, f.t), pm_dot(v, f.n));
}
static inline struct pm_vec3 pm_to_world(struct pm_frame f, struct pm_vec3 v)
{
	return pm_add(pm_add(pm_scale(f.s, v.x), pm_scale(f.t, v.y)),
	    pm_scale(f.n, v.z));
}

#endif
