/*
 * sampling.h: warps from the unit square to the domains a renderer samples,
 * each with the density it produces, and a discrete distribution for
 * choosing lights by power and triangles by area.
 *
 * Every warp takes uniform numbers in [0,1) and returns a point; the pdf
 * functions give the density of that point with respect to the domain's own
 * measure (area for the disk and triangle, solid angle for directions).
 */
#ifndef PM_SAMPLING_H
#define PM_SAMPLING_H

#include <math.h>
#include <stdbool.h>
#include <stddef.h>

#include "error.h"
#include "vec.h"

/*
 * sin and cos of (pi/4) t for |t| <= 1, by their Taylor polynomials to the
 * x^9 and x^10 terms: the first term left out is below 2e-9 for |x| <=
 * pi/4, under a tenth of a float's spacing at 1, so the result is libm's
 * but for the rounding of the sums (a few float spacings at most, which
 * test_sampling checks).
 */
static inline void pm_sincos_quarter_pi(float t, float *s, float *c)
{
	float x = t * (PM_PI / 4.0f), x2 = x * x;

	*s = x * (1.0f + x2 * (-1.0f / 6.0f + x2 * (1.0f / 120.0f +
	    x2 * (-1.0f / 5040.0f + x2 * (1.0f / 362880.0f)))));
	*c = 1.0f + x2 * (-0.5f + x2 * (1.0f / 24.0f + x2 * (-1.0f / 720.0f +
	    x2 * (1.0f / 40320.0f + x2 * (-1.0f / 3628800.0f)))));
}

/*
 * Concentric map (Shirley and Chiu 1997) onto the unit disk; pdf 1/pi.
 * Inline, as is the cosine hemisphere below: out of line, returning the
 * vector cost a store-to-load forwarding stall per call (GCC returns it
 * through the stack), a fifth of the warp's time.
 */
static inline void pm_square_to_disk(float u1, float u2, float *x, float *y)
{
	float a = 2.0f * u1 - 1.0f, b = 2.0f * u2 - 1.0f;
	float big, small, t, s, c;
	bool wedge_a;

	if (a == 0.0f && b == 0.0f) {
		*x = 0.0f;
		*y = 0.0f;
		return;
	}
	/* phi = (pi/4) t in the wedges around the x axis (|a| > |b|, r =
	 * a), pi/2 - (pi/4) t around the y axis (r = b), with t the smaller
	 * over the larger, |t| <= 1: the sine and cosine of (pi/4) t from
	 * their polynomials, swapped in the second wedges (libm's sincosf
	 * was 7% of a path tracer's time).  Written as selects, not
	 * branches: which wedge a random point falls in is a coin toss the
	 * branch predictor loses half the time. */
	wedge_a = fabsf(a) > fabsf(b);
	big = wedge_a ? a : b;
	small = wedge_a ? b : a;
	t = small / big;
	pm_sincos_quarter_pi(t, &s, &c);
	*x = big * (wedge_a ? c : s);
	*y = big * (wedge_a ? s : c);
}

/* Cosine-weighted hemisphere around +z; pdf cos(theta)/pi.  Malley's
 * method: the uniform disk projected up onto the hemisphere. */
static inline struct pm_vec3 pm_square_to_cosine_hemisphere(float u1, float u2)
{
	float x, y;

	pm_square_to_disk(u1, u2, &x, &y);
	return pm_v3(x, y, sqrtf(pm_fmaxf(0.0f, 1.0f - x * x - y * y)));
}
/* The same warp of n pairs (u1[i], u2[i]) at once, in SIMD where the
 * compiler has it: (x[i], y[i], z[i]) is pm_square_to_cosine_hemisphere's
 * result bit for bit (test_sampling), for code that draws many
 * directions before it needs one (pm_shoot's emission). */
void pm_square_to_cosine_hemisphere_n(const float *u1, const float *u2,
    float *x, float *y, float *z, size_t n);
/* Its density, cos(theta)/pi above the horizon, zero below it (inline
 * for the same reason: the vector passed by value went through the
 * stack). */
static inline float pm_cosine_hemisphere_pdf(struct pm_vec3 v)
{
	return v.z > 0.0f ? v.z * PM_INV_PI : 0.0f;
}

/* Uniform hemisphere around +z; pdf 1/(2 pi). */
struct pm_vec3 pm_square_to_uniform_hemisphere(float u1, float u2);
float pm_uniform_hemisphere_pdf(struct pm_vec3 v);

/* Uniform sphere; pdf 1/(4 pi). */
struct pm_vec3 pm_square_to_uniform_sphere(float u1, float u2);
float pm_uniform_sphere_pdf(void);

/* Uniform cone around +z with cos(theta) >= cos_max; pdf 1/(2 pi (1 - cos_max)). */
struct pm_vec3 pm_square_to_uniform_cone(float u1, float u2, float cos_max);
float pm_uniform_cone_pdf(float cos_max);

/* Barycentric (b1, b2) uniform over a triangle (b0 = 1 - b1 - b2): the
 * square-root map, b0 = 1 - sqrt(u1), makes the area uniform.  Inline:
 * every area-light sample of the path tracer takes it. */
static inline void pm_square_to_triangle(float u1, float u2, float *b1,
    float *b2)
{
	float t = sqrtf(u1);

	*b1 = 1.0f - t;
	*b2 = u2 * t;
}

/*
 * A discrete distribution over n weights (n >= 1, weights >= 0, sum > 0):
 * sample returns an index with probability w[i] / sum and, when u_reuse is
 * not NULL, a fresh uniform number reused from what u had left.
 */
struct pm_distrib {
	size_t n;
	double sum;		/* sum of the weights */
	double *cdf;		/* n + 1 entries, cdf[0] = 0, cdf[n] = 1 */
};

enum pm_err pm_distrib_init(struct pm_distrib *d, const double *w, size_t n,
    struct pm_error *err);
void pm_distrib_free(struct pm_distrib *d);
size_t pm_distrib_sample(const struct pm_distrib *d, float u, float *u_reuse);
/* Probability of index i. */
double pm_distrib_prob(const struct pm_distrib *d, size_t i);

#endif
