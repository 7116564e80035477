/*
 * rng.h: random numbers that are a pure function of where they are used.
 *
 * A generator is seeded from (seed, a, b), e.g. (seed, pixel, sample) or
 * (seed, photon index, 0), by hashing the three into PCG32's state and
 * stream.  Images and photon maps are therefore identical whatever the
 * number of threads, and shards of photon indices merge exactly.
 * PCG32: O'Neill 2014, "PCG: A family of simple fast space-efficient
 * statistically good algorithms for random number generation".
 */
#ifndef PM_RNG_H
#define PM_RNG_H

#include <stdint.h>

struct pm_rng {
	uint64_t state;
	uint64_t inc;
};

/* SplitMix64's finaliser: a bijective mix of 64 bits. */
static inline uint64_t pm_mix64(uint64_t z)
{
	z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
	z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
	return z ^ (z >> 31);
}

/* Steps the state past one number without computing it. */
static inline void pm_rng_skip(struct pm_rng *r)
{
	r->state = r->state * 6364136223846793005ULL + r->inc;
}

static inline uint32_t pm_rng_u32(struct pm_rng *r)
{
	uint64_t old = r->state;
	uint32_t xorshifted, rot;

	pm_rng_skip(r);
	xorshifted = (uint32_t)(((old >> 18) ^ old) >> 27);
	rot = (uint32_t)(old >> 59);
	return (xorshifted >> rot) | (xorshifted << ((-rot) & 31));
}

static inline struct pm_rng pm_rng_seed(uint64_t seed, uint64_t a, uint64_t b)
{
	struct pm_rng r;
	uint64_t h = pm_mix64(seed ^ 0x9e3779b97f4a7c15ULL);

	h = pm_mix64(h ^ a);
	h = pm_mix64((h + 0x632be59bd9b4e019ULL) ^ b);
	r.state = 0;
	r.inc = (pm_mix64(h ^ 0xda942042e4dd58b5ULL) << 1) | 1u;
	pm_rng_u32(&r);
	r.state += h;
	pm_rng_u32(&r);
	return r;
}

/* Uniform in [0, 1): 24 random bits, so 1.0f is never returned. */
static inline float pm_rng_float(struct pm_rng *r)
{
	return (float)(pm_rng_u32(r) >> 8) * 0x1p-24f;
}

/* Uniform in [0, 1) with 53 bits, for choices that need more resolution. */
static inline double pm_rng_double(struct pm_rng *r)
{
	uint64_t hi = pm_rng_u32(r), lo = pm_rng_u32(r);
	return (double)(((hi << 32) | lo) >> 11) * 0x1p-53;
}

#endif
