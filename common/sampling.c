/*
 * sampling.c: warps from the unit square to disks, hemispheres, spheres,
 * cones and triangles, and the discrete distribution that picks lights by
 * power and triangles by area.
 *
 * The warps allocate nothing and never fail; inputs are expected in [0,1).
 * The discrete distribution keeps a normalised cdf in double so that
 * millions of tiny weights still get their share, and it is written so
 * that an entry whose probability is zero can never be returned, whatever
 * u the caller passes: a zero-probability light would otherwise divide by
 * zero further down the pipeline.
 */
#include <math.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdlib.h>

#include "sampling.h"

/* The largest float below one; warps and u_reuse never return 1. */
#define ONE_MINUS_EPS 0x1.fffffep-1f

/* Shirley and Chiu's concentric map keeps strata compact and adjacent. */
/* Archimedes: z uniform in [0,1] gives uniform area on the hemisphere. */
struct pm_vec3
pm_square_to_uniform_hemisphere(float u1, float u2)
{
	float z = u1;
	float r = sqrtf(pm_fmaxf(0.0f, 1.0f - z * z));
	float phi = 2.0f * PM_PI * u2;

	return pm_v3(r * cosf(phi), r * sinf(phi), z);
}

/* 1/(2 pi) on the upper hemisphere (z >= 0), zero below. */
float
pm_uniform_hemisphere_pdf(struct pm_vec3 v)
{
	return v.z >= 0.0f ? 1.0f / (2.0f * PM_PI) : 0.0f;
}

/* Archimedes again, with z uniform in [-1,1]. */
struct pm_vec3
pm_square_to_uniform_sphere(float u1, float u2)
{
	float z = 1.0f - 2.0f * u1;
	float r = sqrtf(pm_fmaxf(0.0f, 1.0f - z * z));
	float phi = 2.0f * PM_PI * u2;

	return pm_v3(r * cosf(phi), r * sinf(phi), z);
}

/* 1/(4 pi) everywhere. */
float
pm_uniform_sphere_pdf(void)
{
	return 1.0f / (4.0f * PM_PI);
}

/*
 * z uniform in [cos_max, 1].  sin^2 is formed from 1 - z directly so that
 * the tiny cones of distant small lights keep their precision.
 */
struct pm_vec3
pm_square_to_uniform_cone(float u1, float u2, float cos_max)
{
	float one_minus_z = u1 * (1.0f - cos_max);
	float z = 1.0f - one_minus_z;
	float r = sqrtf(pm_fmaxf(0.0f, one_minus_z * (2.0f - one_minus_z)));
	float phi = 2.0f * PM_PI * u2;

	return pm_v3(r * cosf(phi), r * sinf(phi), z);
}

/* One over the cone's solid angle. */
float
pm_uniform_cone_pdf(float cos_max)
{
	return 1.0f / (2.0f * PM_PI * (1.0f - cos_max));
}

/* Builds the normalised cdf; rejects empty, negative or all-zero weights. */
enum pm_err
pm_distrib_init(struct pm_distrib *d, const double *w, size_t n,
    struct pm_error *err)
{
	size_t i, last = 0;
	double sum = 0.0;

	d->n = 0;
	d->sum = 0.0;
	d->cdf = NULL;
	if (n == 0)
		return pm_fail(err, PM_ERR_INVALID,
		    "distribution: expected at least one weight");
	if (n >= SIZE_MAX / sizeof(double) - 1)
		return pm_fail(err, PM_ERR_LIMIT,
		    "distribution: %zu weights is too many", n);
	for (i = 0; i < n; i++) {
		if (!(w[i] >= 0.0) || !isfinite(w[i]))
			return pm_fail(err, PM_ERR_INVALID,
			    "distribution: weight %zu is %g, expected a finite "
			    "value >= 0", i, w[i]);
		if (w[i] > 0.0)
			last = i;
		sum += w[i];
	}
	if (!(sum > 0.0) || !isfinite(sum))
		return pm_fail(err, PM_ERR_INVALID,
		    "distribution: weights sum to %g, expected a finite "
		    "positive sum", sum);
	d->cdf = malloc((n + 1) * sizeof(double));
	if (d->cdf == NULL)
		return pm_fail(err, PM_ERR_NOMEM,
		    "distribution: cannot allocate %zu entries", n + 1);
	d->cdf[0] = 0.0;
	for (i = 0; i < n; i++)
		d->cdf[i + 1] = d->cdf[i] + w[i];
	for (i = 1; i <= n; i++)
		d->cdf[i] /= sum;
	/*
	 * Rounding may leave the running sum a hair below one; pin every
	 * entry from the last positive weight on, so that the final bins of
	 * zero weight have zero width and the last positive one reaches 1.
	 */
	for (i = last + 1; i <= n; i++)
		d->cdf[i] = 1.0;
	d->n = n;
	d->sum = sum;
	return PM_OK;
}

/* Frees the cdf; the struct may be initialised again afterwards. */
void
pm_distrib_free(struct pm_distrib *d)
{
	free(d->cdf);
	d->cdf = NULL;
	d->n = 0;
	d->sum = 0.0;
}

/*
 * The index i with cdf[i] <= u < cdf[i+1]: such a bin has positive width,
 * so zero weights are never chosen.  u outside [0,1) is clamped first.
 */
size_t
pm_distrib_sample(const struct pm_distrib *d, float u, float *u_reuse)
{
	double x = u;
	size_t lo = 0, hi = d->n - 1, mid;

	if (!(x >= 0.0))
		x = 0.0;
	if (x >= 1.0)
		x = 0x1.fffffffffffffp-1;
	/* smallest i with cdf[i + 1] > x; cdf[n] = 1 > x guarantees one */
	while (lo < hi) {
		mid = lo + (hi - lo) / 2;
		if (d->cdf[mid + 1] > x)
			hi = mid;
		else
			lo = mid + 1;
	}
	if (u_reuse != NULL) {
		float r = (float)((x - d->cdf[lo]) /
		    (d->cdf[lo + 1] - d->cdf[lo]));
		*u_reuse = pm_fminf(pm_fmaxf(r, 0.0f), ONE_MINUS_EPS);
	}
	return lo;
}

/* The width of bin i, which is exactly what sampling uses. */
double
pm_distrib_prob(const struct pm_distrib *d, size_t i)
{
	if (i >= d->n)
		return 0.0;
	return d->cdf[i + 1] - d->cdf[i];
}

/*
 * pm_square_to_cosine_hemisphere_n: the warp's operations in its order,
 * its branches as selects, four lanes at a time, so that each lane is the
 * bits the scalar warp gives (IEEE division and square root are exact in
 * SIMD as in scalar code, and the Makefile's -ffp-contract=off fuses no
 * multiply-add into an FMA).  SSE2 where the compiler has it (PM_NO_SIMD:
 * the scalar warp throughout); GCC does not vectorise the plain loop by
 * itself.  In pm-shoot, a path's emission was one long chain of
 * dependent arithmetic, the disk's division, polynomials and square root
 * the most of it: side by side, the lanes' chains overlap.
 */
#if (defined(__x86_64__) || defined(__i386__)) && defined(__SSE2__) && \
    (defined(__GNUC__) || defined(__clang__)) && !defined(PM_NO_SIMD)
#include <immintrin.h>

static size_t
cosine_sse(const float *u1, const float *u2, float *x, float *y, float *z,
    size_t n)
{
	const __m128 one = _mm_set1_ps(1.0f), two = _mm_set1_ps(2.0f);
	const __m128 zero = _mm_setzero_ps(), sign = _mm_set1_ps(-0.0f);
	size_t k;

	for (k = 0; k + 4 <= n; k += 4) {
		__m128 a = _mm_sub_ps(_mm_mul_ps(two, _mm_loadu_ps(u1 + k)), one);
		__m128 b = _mm_sub_ps(_mm_mul_ps(two, _mm_loadu_ps(u2 + k)), one);
		/* pm_square_to_disk: the wedge, its larger and smaller
		 * coordinate, and the centre, where the scalar warp returns
		 * early (here its 0 / 0 is NaN until masked below) */
		__m128 wa = _mm_cmpgt_ps(_mm_andnot_ps(sign, a),
		    _mm_andnot_ps(sign, b));
		__m128 centre = _mm_and_ps(_mm_cmpeq_ps(a, zero),
		    _mm_cmpeq_ps(b, zero));
		__m128 big = _mm_or_ps(_mm_and_ps(wa, a), _mm_andnot_ps(wa, b));
		__m128 small = _mm_or_ps(_mm_and_ps(wa, b), _mm_andnot_ps(wa, a));
		__m128 t = _mm_div_ps(small, big);
		/* pm_sincos_quarter_pi, its Horner steps one by one */
		__m128 xx = _mm_mul_ps(t, _mm_set1_ps(PM_PI / 4.0f));
		__m128 x2 = _mm_mul_ps(xx, xx);
		__m128 sn, cs, dx, dy, r;

		sn = _mm_add_ps(_mm_set1_ps(-1.0f / 5040.0f),
		    _mm_mul_ps(x2, _mm_set1_ps(1.0f / 362880.0f)));
		sn = _mm_add_ps(_mm_set1_ps(1.0f / 120.0f), _mm_mul_ps(x2, sn));
		sn = _mm_add_ps(_mm_set1_ps(-1.0f / 6.0f), _mm_mul_ps(x2, sn));
		sn = _mm_mul_ps(xx, _mm_add_ps(one, _mm_mul_ps(x2, sn)));
		cs = _mm_add_ps(_mm_set1_ps(1.0f / 40320.0f),
		    _mm_mul_ps(x2, _mm_set1_ps(-1.0f / 3628800.0f)));
		cs = _mm_add_ps(_mm_set1_ps(-1.0f / 720.0f), _mm_mul_ps(x2, cs));
		cs = _mm_add_ps(_mm_set1_ps(1.0f / 24.0f), _mm_mul_ps(x2, cs));
		cs = _mm_add_ps(_mm_set1_ps(-0.5f), _mm_mul_ps(x2, cs));
		cs = _mm_add_ps(one, _mm_mul_ps(x2, cs));
		dx = _mm_mul_ps(big, _mm_or_ps(_mm_and_ps(wa, cs),
		    _mm_andnot_ps(wa, sn)));
		dy = _mm_mul_ps(big, _mm_or_ps(_mm_and_ps(wa, sn),
		    _mm_andnot_ps(wa, cs)));
		dx = _mm_andnot_ps(centre, dx);
		dy = _mm_andnot_ps(centre, dy);
		/* sqrt(pm_fmaxf(0, r)): r where r > 0, else 0 (NaN too) */
		r = _mm_sub_ps(_mm_sub_ps(one, _mm_mul_ps(dx, dx)),
		    _mm_mul_ps(dy, dy));
		r = _mm_and_ps(_mm_cmpgt_ps(r, zero), r);
		_mm_storeu_ps(x + k, dx);
		_mm_storeu_ps(y + k, dy);
		_mm_storeu_ps(z + k, _mm_sqrt_ps(r));
	}
	return k;
}
#else
static size_t
cosine_sse(const float *u1, const float *u2, float *x, float *y, float *z,
    size_t n)
{
	(void)u1, (void)u2, (void)x, (void)y, (void)z, (void)n;
	return 0;
}
#endif

void
pm_square_to_cosine_hemisphere_n(const float *u1, const float *u2, float *x,
    float *y, float *z, size_t n)
{
	size_t k = cosine_sse(u1, u2, x, y, z, n);

	for (; k < n; k++) {
		struct pm_vec3 v = pm_square_to_cosine_hemisphere(u1[k], u2[k]);

		x[k] = v.x;
		y[k] = v.y;
		z[k] = v.z;
	}
}
