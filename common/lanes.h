/*
 * lanes.h: the small SSE helpers that the SIMD lanes of path mode
 * (integrator_path.c) and of photon tracing (shoot.c) share.  Each is the
 * scalar code's operation lane by lane, so that lanes give the bits one
 * vertex at a time gives: pm_fmaxf's and pm_fminf's NaN rule, a dot
 * product's additions left to right.  Included only where the compiler
 * has SSE2 and PM_NO_SIMD is not set (PM_LANES is then 1).
 */
#ifndef PM_LANES_H
#define PM_LANES_H

#if (defined(__x86_64__) || defined(__i386__)) && defined(__SSE2__) && \
    (defined(__GNUC__) || defined(__clang__)) && !defined(PM_NO_SIMD)
#define PM_LANES 1
#include <stdint.h>
#include <immintrin.h>

/* pm_fmaxf and pm_fminf lane by lane: a NaN b loses */
static inline __m128
pm_max4(__m128 a, __m128 b)
{
	__m128 ka = _mm_or_ps(_mm_cmpgt_ps(a, b), _mm_cmpunord_ps(b, b));

	return _mm_or_ps(_mm_and_ps(ka, a), _mm_andnot_ps(ka, b));
}

static inline __m128
pm_min4(__m128 a, __m128 b)
{
	__m128 ka = _mm_or_ps(_mm_cmplt_ps(a, b), _mm_cmpunord_ps(b, b));

	return _mm_or_ps(_mm_and_ps(ka, a), _mm_andnot_ps(ka, b));
}

/* m ? a : b, lane by lane (m all ones or all zeros) */
static inline __m128
pm_sel4(__m128 m, __m128 a, __m128 b)
{
	return _mm_or_ps(_mm_and_ps(m, a), _mm_andnot_ps(m, b));
}

/* a.x * b.x + a.y * b.y + a.z * b.z, left to right */
static inline __m128
pm_dot4(__m128 ax, __m128 ay, __m128 az, __m128 bx, __m128 by, __m128 bz)
{
	return _mm_add_ps(_mm_add_ps(_mm_mul_ps(ax, bx), _mm_mul_ps(ay, by)),
	    _mm_mul_ps(az, bz));
}

/* four int32 masks (-1 or 0) as a float mask */
static inline __m128
pm_mask4(const int32_t *m)
{
	return _mm_castsi128_ps(_mm_loadu_si128((const __m128i *)m));
}

/* pm_frame_from_normal of (nx, ny, nz) lane by lane: its s and t */
static inline void
pm_frame4(__m128 nx, __m128 ny, __m128 nz, __m128 s[3], __m128 t[3])
{
	const __m128 one = _mm_set1_ps(1.0f), sign = _mm_set1_ps(-0.0f);
	__m128 sg = _mm_or_ps(_mm_and_ps(nz, sign), one);
	__m128 a = _mm_div_ps(_mm_set1_ps(-1.0f), _mm_add_ps(sg, nz));
	__m128 b = _mm_mul_ps(_mm_mul_ps(nx, ny), a);

	s[0] = _mm_add_ps(one, _mm_mul_ps(_mm_mul_ps(_mm_mul_ps(sg, nx), nx),
	    a));
	s[1] = _mm_mul_ps(sg, b);
	s[2] = _mm_mul_ps(_mm_xor_ps(sg, sign), nx);
	t[0] = b;
	t[1] = _mm_add_ps(sg, _mm_mul_ps(_mm_mul_ps(ny, ny), a));
	t[2] = _mm_xor_ps(ny, sign);
}

/* pm_fresnel_dielectric(cos_i, eta, NULL) lane by lane, its operations
 * in its order (bsdf.c) */
static inline __m128
pm_fresnel4(__m128 cos_i, __m128 eta)
{
	const __m128 one = _mm_set1_ps(1.0f), zero = _mm_setzero_ps();
	__m128 eta_it = pm_sel4(_mm_cmpge_ps(cos_i, zero), eta,
	    _mm_div_ps(one, eta));
	__m128 eta_ti = _mm_div_ps(one, eta_it);
	__m128 ci = _mm_andnot_ps(_mm_set1_ps(-0.0f), cos_i);
	__m128 ct2 = _mm_sub_ps(one, _mm_mul_ps(_mm_mul_ps(_mm_sub_ps(one,
	    _mm_mul_ps(ci, ci)), eta_ti), eta_ti));
	__m128 ct = _mm_sqrt_ps(pm_max4(ct2, zero));
	__m128 ec = _mm_mul_ps(eta_it, ct), ei = _mm_mul_ps(eta_it, ci);
	__m128 as = _mm_div_ps(_mm_sub_ps(ci, ec), _mm_add_ps(ci, ec));
	__m128 ap = _mm_div_ps(_mm_sub_ps(ct, ei), _mm_add_ps(ct, ei));
	__m128 r = _mm_mul_ps(_mm_set1_ps(0.5f), _mm_add_ps(_mm_mul_ps(as, as),
	    _mm_mul_ps(ap, ap)));
	__m128 matched = _mm_cmpeq_ps(eta, one);

	/* index matched: nothing reflects; grazing: everything does */
	return pm_sel4(_mm_or_ps(matched, _mm_cmpeq_ps(ci, zero)),
	    _mm_andnot_ps(matched, one), r);
}

/* pm_offset_origin_scaled's distance for hit points p with scale */
static inline __m128
pm_offset_eps4(const __m128 p[3], __m128 scale)
{
	const __m128 sign = _mm_set1_ps(-0.0f);
	__m128 m = pm_max4(_mm_andnot_ps(sign, p[0]), pm_max4(
	    _mm_andnot_ps(sign, p[1]), _mm_andnot_ps(sign, p[2])));

	return pm_max4(_mm_mul_ps(pm_max4(m, scale), _mm_set1_ps(2e-5f)),
	    _mm_set1_ps(1e-30f));
}

/* pm_offset_origin_scaled: p moved by eps along ng, to the side that dir
 * leaves on, into o */
static inline void
pm_offset4(const __m128 p[3], const __m128 ng[3], __m128 eps,
    const __m128 dir[3], __m128 o[3])
{
	__m128 e = pm_sel4(_mm_cmpge_ps(pm_dot4(ng[0], ng[1], ng[2], dir[0],
	    dir[1], dir[2]), _mm_setzero_ps()), eps, _mm_xor_ps(eps,
	    _mm_set1_ps(-0.0f)));
	int c;

	for (c = 0; c < 3; c++)
		o[c] = _mm_add_ps(p[c], _mm_mul_ps(ng[c], e));
}

/* pm_dir_pack of (x, y, z), four at a time, its operations in its order:
 * the two bytes of each lane in o0 and o1 */
static inline void
pm_dir_pack4(__m128 x, __m128 y, __m128 z, int32_t *o0, int32_t *o1)
{
	const __m128 sign = _mm_set1_ps(-0.0f), one = _mm_set1_ps(1.0f);
	const __m128 zero = _mm_setzero_ps(), half = _mm_set1_ps(0.5f);
	const __m128 c255 = _mm_set1_ps(255.0f);
	__m128 s = _mm_add_ps(_mm_add_ps(_mm_andnot_ps(sign, x),
	    _mm_andnot_ps(sign, y)), _mm_andnot_ps(sign, z));
	__m128 bad = _mm_cmpngt_ps(s, zero), neg = _mm_cmplt_ps(z, zero);
	__m128 u = _mm_div_ps(x, s), v = _mm_div_ps(y, s), tu, tv, w[2];
	int c;

	tu = _mm_mul_ps(_mm_sub_ps(one, _mm_andnot_ps(sign, v)),
	    _mm_or_ps(_mm_and_ps(u, sign), one));
	tv = _mm_mul_ps(_mm_sub_ps(one, _mm_andnot_ps(sign, u)),
	    _mm_or_ps(_mm_and_ps(v, sign), one));
	w[0] = pm_sel4(neg, tu, u);
	w[1] = pm_sel4(neg, tv, v);
	for (c = 0; c < 2; c++) {
		/* pm_fminf(pm_fmaxf(t, 0), 255), then the byte; 128 where
		 * the vector has no length */
		__m128 t = _mm_add_ps(_mm_mul_ps(_mm_add_ps(_mm_mul_ps(w[c],
		    half), half), c255), half);
		__m128i b;

		t = _mm_and_ps(_mm_cmpgt_ps(t, zero), t);
		t = pm_sel4(_mm_cmplt_ps(t, c255), t, c255);
		b = _mm_cvttps_epi32(t);
		b = _mm_or_si128(_mm_and_si128(_mm_castps_si128(bad),
		    _mm_set1_epi32(128)), _mm_andnot_si128(_mm_castps_si128(bad),
		    b));
		_mm_storeu_si128((__m128i *)(c == 0 ? o0 : o1), b);
	}
}

/* pm_rgbe_chan of four dithered channels: the byte, 0 below 0 or for a
 * NaN, 255 from 255 on */
static inline __m128i
pm_rgbe_chan4(__m128 x)
{
	const __m128 c255 = _mm_set1_ps(255.0f);
	__m128 in = _mm_cmplt_ps(x, c255);
	__m128i b = _mm_cvttps_epi32(_mm_and_ps(in, x));

	b = _mm_or_si128(_mm_and_si128(_mm_castps_si128(in), b),
	    _mm_andnot_si128(_mm_castps_si128(in), _mm_set1_epi32(255)));
	return _mm_and_si128(_mm_castps_si128(_mm_cmpgt_ps(x,
	    _mm_setzero_ps())), b);
}

/* pm_rgbe_pack of (r, g, b) with dither u, four at a time, its
 * operations in its order: the four bytes of each lane in o0..o3 */
static inline void
pm_rgbe_pack4(__m128 r, __m128 g, __m128 b, __m128 u, int32_t *o0,
    int32_t *o1, int32_t *o2, int32_t *o3)
{
	__m128 top = pm_max4(r, pm_max4(g, b)), m, adj;
	__m128i e, live;

	/* frexpf's exponent from the bits, the scale 2^(8 - e) built the
	 * same way; a maximum that would dither up to 256 takes the next
	 * exponent; all zeros where !(top > 1e-32) */
	e = _mm_sub_epi32(_mm_srli_epi32(_mm_castps_si128(top), 23),
	    _mm_set1_epi32(126));
	m = _mm_castsi128_ps(_mm_slli_epi32(_mm_sub_epi32(
	    _mm_set1_epi32(135), e), 23));
	adj = _mm_cmpge_ps(_mm_add_ps(_mm_mul_ps(top, m), u),
	    _mm_set1_ps(256.0f));
	m = pm_sel4(adj, _mm_mul_ps(m, _mm_set1_ps(0.5f)), m);
	e = _mm_sub_epi32(e, _mm_castps_si128(adj));	/* adj is -1 */
	live = _mm_castps_si128(_mm_cmpgt_ps(top, _mm_set1_ps(1e-32f)));
	_mm_storeu_si128((__m128i *)o0, _mm_and_si128(live,
	    pm_rgbe_chan4(_mm_add_ps(_mm_mul_ps(r, m), u))));
	_mm_storeu_si128((__m128i *)o1, _mm_and_si128(live,
	    pm_rgbe_chan4(_mm_add_ps(_mm_mul_ps(g, m), u))));
	_mm_storeu_si128((__m128i *)o2, _mm_and_si128(live,
	    pm_rgbe_chan4(_mm_add_ps(_mm_mul_ps(b, m), u))));
	_mm_storeu_si128((__m128i *)o3, _mm_and_si128(live,
	    _mm_add_epi32(e, _mm_set1_epi32(128))));
}
#else
#define PM_LANES 0
#endif

#endif
