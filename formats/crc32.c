/*
 * crc32.c: the CRC-32 of crc32.h.
 *
 * zlib's crc32_z went through the records at about 1.5 GB/s here, the
 * largest part of the fixed cost of every pm-render start (loading and
 * checking a 50 MB map) and a serial part of pm-balance's and pm-shoot's
 * writes.  A CRC is a remainder of polynomial division over GF(2), so a
 * 128-bit chunk of the message can be moved ("folded") any fixed distance
 * ahead by a carry-less multiplication with x^d mod P and added (xor) to
 * the data there, without changing the remainder; four independent
 * chunks of a 64-byte block keep the multiplier busy.  What is left, one
 * 128-bit chunk, is reduced to 32 bits in two more folds and a Barrett
 * reduction.  (Gopal et al., "Fast CRC Computation for Generic
 * Polynomials Using PCLMULQDQ Instruction", Intel, 2009.)  The constants
 * below are those powers of x modulo the bit-reflected polynomial
 * 0x104C11DB7, in the reflected form the algorithm needs; the unit test
 * checks every path against zlib.  Lengths under 64 bytes and the last
 * len % 16 bytes go to zlib, and so does everything on CPUs without
 * PCLMULQDQ.
 *
 * The 128-bit multiplier was the limit, not memory: 12.8 GB/s on data in
 * cache, 12.0 from memory, on this project's machines (AMD EPYC).  Where
 * the CPU also has VPCLMULQDQ (two 128-bit products an instruction, AVX2
 * registers), eight chunks of a 128-byte block fold at once, each 1024
 * bits ahead: 25.6 and 17.5 GB/s (docs/accuracy.md).
 */
#include <stdatomic.h>
#include <zlib.h>

#include "crc32.h"

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <immintrin.h>
#define PM_CRC32_FOLD 1
#endif

/* zlib takes at most UINT_MAX bytes a call (uInt lengths on old
 * versions): longer inputs go in slices. */
static uint32_t
crc_zlib(uint32_t crc, const unsigned char *p, size_t len)
{
	while (len > 0) {
		size_t n = len > (1u << 30) ? (size_t)1 << 30 : len;

		crc = (uint32_t)crc32(crc, p, (uInt)n);
		p += n;
		len -= n;
	}
	return crc;
}

#ifdef PM_CRC32_FOLD
/* x^(4*128+32) and x^(4*128-32) mod P: a chunk 64 bytes ahead. */
#define K1	0x154442bd4ull
#define K2	0x1c6e41596ull
/* x^(128+32) and x^(128-32) mod P: a chunk 16 bytes ahead. */
#define K3	0x1751997d0ull
#define K4	0x0ccaa009eull
/* x^(8*128+32) and x^(8*128-32) mod P: a chunk 128 bytes ahead. */
#define K7	0x1e88ef372ull
#define K8	0x14a7fe880ull
/* x^64 mod P: 64 bits to 32. */
#define K5	0x163cd6124ull
/* P itself and floor(x^64 / P), for the Barrett reduction. */
#define POLY	0x1db710641ull
#define MU	0x1f7011641ull

/* x's two 64-bit halves, each times its half of k (low by low, high by
 * high), summed: x moved ahead by the distance k encodes. */
__attribute__((target("pclmul,sse4.1"))) static inline __m128i
fold(__m128i x, __m128i k)
{
	return _mm_xor_si128(_mm_clmulepi64_si128(x, k, 0x00),
	    _mm_clmulepi64_si128(x, k, 0x11));
}

/* The CRC from x0, the register so far, and the len bytes at p (a
 * multiple of 16) still to fold in; as zlib returns it. */
__attribute__((target("pclmul,sse4.1"))) static inline uint32_t
crc_finish(__m128i x0, const unsigned char *p, size_t len)
{
	const __m128i k34 = _mm_set_epi64x((long long)K4, (long long)K3);
	const __m128i mask32 = _mm_set_epi32(0, 0, 0, -1);
	const __m128i pmu = _mm_set_epi64x((long long)MU, (long long)POLY);
	__m128i t;

	for (; len >= 16; p += 16, len -= 16)
		x0 = _mm_xor_si128(fold(x0, k34),
		    _mm_loadu_si128((const __m128i *)p));
	/* 128 bits to 64: the low half moved onto the high one (which
	 * also appends the 32 zero bits a CRC's remainder implies)... */
	t = _mm_clmulepi64_si128(x0, k34, 0x10);
	x0 = _mm_xor_si128(_mm_srli_si128(x0, 8), t);
	/* ...64 to 32 more... */
	t = _mm_clmulepi64_si128(_mm_and_si128(x0, mask32),
	    _mm_set_epi64x(0, (long long)K5), 0x00);
	x0 = _mm_xor_si128(_mm_srli_si128(x0, 4), t);
	/* ...and the remainder of the last 64 bits by Barrett: the quotient
	 * from mu, times P, subtracted. */
	t = _mm_clmulepi64_si128(_mm_and_si128(x0, mask32), pmu, 0x10);
	t = _mm_clmulepi64_si128(_mm_and_si128(t, mask32), pmu, 0x00);
	x0 = _mm_xor_si128(x0, t);
	return ~(uint32_t)_mm_extract_epi32(x0, 1);
}

/* The CRC of len bytes at p, len a multiple of 16 and at least 64; crc
 * as zlib takes and returns it. */
__attribute__((target("pclmul,sse4.1"))) static uint32_t
crc_fold(uint32_t crc, const unsigned char *p, size_t len)
{
	const __m128i k12 = _mm_set_epi64x((long long)K2, (long long)K1);
	const __m128i k34 = _mm_set_epi64x((long long)K4, (long long)K3);
	__m128i x0, x1, x2, x3;

	/* zlib's pre-conditioning: the register starts inverted. */
	x0 = _mm_xor_si128(_mm_loadu_si128((const __m128i *)p),
	    _mm_cvtsi32_si128((int)~crc));
	x1 = _mm_loadu_si128((const __m128i *)(p + 16));
	x2 = _mm_loadu_si128((const __m128i *)(p + 32));
	x3 = _mm_loadu_si128((const __m128i *)(p + 48));
	p += 64;
	len -= 64;
	for (; len >= 64; p += 64, len -= 64) {
		x0 = _mm_xor_si128(fold(x0, k12),
		    _mm_loadu_si128((const __m128i *)p));
		x1 = _mm_xor_si128(fold(x1, k12),
		    _mm_loadu_si128((const __m128i *)(p + 16)));
		x2 = _mm_xor_si128(fold(x2, k12),
		    _mm_loadu_si128((const __m128i *)(p + 32)));
		x3 = _mm_xor_si128(fold(x3, k12),
		    _mm_loadu_si128((const __m128i *)(p + 48)));
	}
	/* Four chunks into one, then the remaining 16-byte chunks. */
	x0 = _mm_xor_si128(fold(x0, k34), x1);
	x0 = _mm_xor_si128(fold(x0, k34), x2);
	x0 = _mm_xor_si128(fold(x0, k34), x3);
	return crc_finish(x0, p, len);
}

/* fold() on both 128-bit halves of x at once. */
__attribute__((target("vpclmulqdq,avx2,pclmul,sse4.1"))) static inline __m256i
fold2(__m256i x, __m256i k)
{
	return _mm256_xor_si256(_mm256_clmulepi64_epi128(x, k, 0x00),
	    _mm256_clmulepi64_epi128(x, k, 0x11));
}

/* crc_fold, eight chunks at a time in four AVX2 registers; len a
 * multiple of 16 and at least 128. */
__attribute__((target("vpclmulqdq,avx2,pclmul,sse4.1"))) static uint32_t
crc_fold_wide(uint32_t crc, const unsigned char *p, size_t len)
{
	const __m256i k78 = _mm256_set_epi64x((long long)K8, (long long)K7,
	    (long long)K8, (long long)K7);
	const __m128i k34 = _mm_set_epi64x((long long)K4, (long long)K3);
	__m256i y[4];
	__m128i x0;
	int i;

	for (i = 0; i < 4; i++)
		y[i] = _mm256_loadu_si256((const __m256i *)(p + 32 * i));
	y[0] = _mm256_xor_si256(y[0],
	    _mm256_zextsi128_si256(_mm_cvtsi32_si128((int)~crc)));
	p += 128;
	len -= 128;
	for (; len >= 128; p += 128, len -= 128)
		for (i = 0; i < 4; i++)
			y[i] = _mm256_xor_si256(fold2(y[i], k78),
			    _mm256_loadu_si256((const __m256i *)(p + 32 * i)));
	/* The eight chunks into one, in the order of the bytes. */
	x0 = _mm256_castsi256_si128(y[0]);
	x0 = _mm_xor_si128(fold(x0, k34), _mm256_extracti128_si256(y[0], 1));
	for (i = 1; i < 4; i++) {
		x0 = _mm_xor_si128(fold(x0, k34), _mm256_castsi256_si128(y[i]));
		x0 = _mm_xor_si128(fold(x0, k34),
		    _mm256_extracti128_si256(y[i], 1));
	}
	return crc_finish(x0, p, len);
}

/* The widest path this CPU has: 0 zlib, 1 PCLMULQDQ, 2 VPCLMULQDQ. */
static int
cpu_path(void)
{
	static _Atomic int known;	/* the path + 1; 0: not asked yet */
	int k = known;

	if (k == 0) {
		__builtin_cpu_init();
		k = 1;
		if (__builtin_cpu_supports("pclmul") &&
		    __builtin_cpu_supports("sse4.1")) {
			k = 2;
			if (__builtin_cpu_supports("vpclmulqdq") &&
			    __builtin_cpu_supports("avx2"))
				k = 3;
		}
		known = k;
	}
	return k - 1;
}
#endif

/* The widest path allowed (pm_crc32_limit). */
static _Atomic int limit = 2;

uint32_t
pm_crc32(uint32_t crc, const void *buf, size_t len)
{
	const unsigned char *p = buf;

#ifdef PM_CRC32_FOLD
	if (len >= 64) {
		int path = pm_crc32_path();
		size_t body = len & ~(size_t)15;

		/* under 256 bytes the eight chunks' merge is a good part
		 * of the work */
		if (path == 2 && len >= 256)
			crc = crc_fold_wide(crc, p, body);
		else if (path >= 1)
			crc = crc_fold(crc, p, body);
		else
			body = 0;
		p += body;
		len -= body;
	}
#endif
	return crc_zlib(crc, p, len);
}

int
pm_crc32_path(void)
{
#ifdef PM_CRC32_FOLD
	int cpu = cpu_path(), lim = limit;

	return cpu < lim ? cpu : lim;
#else
	return 0;
#endif
}

int
pm_crc32_limit(int widest)
{
	return atomic_exchange(&limit, widest < 0 ? 0 : widest);
}
