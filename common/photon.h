/*
 * photon.h: the photon record, 24 bytes in memory and on disk (Jensen's
 * 20 plus the surface normal that precomputed irradiance needs), with the
 * packings of its power and directions.
 *
 * Power is stored unnormalised: a photon carries the flux it would carry
 * if it were the only one emitted, and the map's header says how many were
 * emitted, so renderers divide by that count.  Merging shards is then a
 * concatenation with the counts added; no record is ever requantised.
 */
#ifndef PM_PHOTON_H
#define PM_PHOTON_H

#include <math.h>
#include <stdint.h>
#include <string.h>

#include "vec.h"

struct pm_photon {
	float pos[3];		/* world position */
	uint8_t power[4];	/* RGBE: shared exponent (Ward, Radiance) */
	uint8_t dir[2];		/* incident direction (towards where the photon
				 * came from), octahedral, 8 bits per axis */
	uint8_t normal[2];	/* surface normal at the hit, octahedral, on
				 * the side the photon arrived from: lookups
				 * count only photons of compatible normal,
				 * so light does not leak through walls */
	uint8_t flags;		/* PM_KD_* split axis in bits 0-1, PM_PHOTON_* */
	uint8_t depth;		/* diffuse or glossy bounces before this hit,
				 * specular ones included: 0 is direct light */
	uint8_t reserved[2];	/* zero */
};

_Static_assert(sizeof(struct pm_photon) == 24, "a photon is 24 bytes");

/* Bits 0-1 of flags: the kd-tree node's split axis, or a leaf. */
enum {
	PM_KD_AXIS_MASK = 3,
	PM_KD_LEAF = 3,
};

/* Path flags. */
enum {
	/* The path had a diffuse or glossy bounce before this hit, so the
	 * photon is indirect light in the sense of the "direct visualisation"
	 * of the global map (neither direct light nor a caustic). */
	PM_PHOTON_VIA_DIFFUSE = 1 << 2,
	/* The path was light, specular+, this hit: a caustic photon. */
	PM_PHOTON_CAUSTIC = 1 << 3,
};

/*
 * RGB to RGBE: the largest channel's exponent is shared, values below 1e-32
 * become zero.  Channels are rounded with the dither u in [0, 1): floor(x +
 * u), which is unbiased when u is uniform.  Plain rounding is not: a channel
 * four times dimmer than the brightest keeps only 6 bits, and photons of
 * equal flux would all round the same way, biasing a map's total by percents.
 * u = 0.5 rounds to nearest.
 */
/* A dithered channel x = c * m + u to a byte: floor for x >= 0 (truncation
 * is floor there), 0 for x < 0 or NaN, 255 at most; pm_fminf(pm_fmaxf(floorf()))
 * bit for bit, without the three libm calls. */
static inline uint8_t pm_rgbe_chan(float x)
{
	return x > 0.0f ? (x < 255.0f ? (uint8_t)x : 255) : 0;
}

static inline void pm_rgbe_pack(struct pm_rgb c, float u, uint8_t out[4])
{
	float top = pm_rgb_max(c), m;
	uint32_t bits;
	int e;

	if (!(top > 1e-32f)) {
		out[0] = out[1] = out[2] = out[3] = 0;
		return;
	}
	/* frexpf's exponent e (top = f 2^e, f in [0.5, 1)) from the bits, as
	 * top is normal here, and the scale m = 2^(8 - e) that maps the
	 * maximum to [128, 256) built the same way. */
	memcpy(&bits, &top, sizeof(bits));
	e = (int)(bits >> 23) - 126;
	bits = (uint32_t)(135 - e) << 23;
	memcpy(&m, &bits, sizeof(m));
	/* A maximum that would dither up to 256 takes the next exponent. */
	if (top * m + u >= 256.0f) {
		m *= 0.5f;
		e++;
	}
	out[0] = pm_rgbe_chan(c.r * m + u);
	out[1] = pm_rgbe_chan(c.g * m + u);
	out[2] = pm_rgbe_chan(c.b * m + u);
	out[3] = (uint8_t)(e + 128);
}

static inline struct pm_rgb pm_rgbe_unpack(const uint8_t in[4])
{
	float f;

	if (in[3] == 0)
		return pm_rgb1(0.0f);
	if (in[3] >= 10) {
		/* 2^(e - 136) as a normal float's bits, what ldexpf gives,
		 * without its call: the gather unpacks every neighbour */
		uint32_t bits = (uint32_t)(in[3] - 9) << 23;

		memcpy(&f, &bits, sizeof(f));
	} else {
		f = ldexpf(1.0f, (int)in[3] - (128 + 8));	/* subnormal */
	}
	return pm_rgb((float)in[0] * f, (float)in[1] * f, (float)in[2] * f);
}

/* Unit vector to the octahedral square, quantised to 8 bits per axis
 * (about one degree). */
static inline void pm_dir_pack(struct pm_vec3 d, uint8_t out[2])
{
	float s = fabsf(d.x) + fabsf(d.y) + fabsf(d.z);
	float u, v;

	if (!(s > 0.0f)) {
		out[0] = out[1] = 128;
		return;
	}
	u = d.x / s;
	v = d.y / s;
	if (d.z < 0.0f) {
		float tu = (1.0f - fabsf(v)) * copysignf(1.0f, u);
		float tv = (1.0f - fabsf(u)) * copysignf(1.0f, v);

		u = tu;
		v = tv;
	}
	out[0] = (uint8_t)pm_fminf(pm_fmaxf((u * 0.5f + 0.5f) * 255.0f + 0.5f, 0.0f), 255.0f);
	out[1] = (uint8_t)pm_fminf(pm_fmaxf((v * 0.5f + 0.5f) * 255.0f + 0.5f, 0.0f), 255.0f);
}

/* pm_dir_unpack before its normalisation: the direction, of length
 * between 1/sqrt(3) and 1 (never 0), for tests that need no unit vector. */
static inline struct pm_vec3 pm_dir_unpack_raw(const uint8_t in[2])
{
	float u = (float)in[0] * (2.0f / 255.0f) - 1.0f;
	float v = (float)in[1] * (2.0f / 255.0f) - 1.0f;
	float z = 1.0f - fabsf(u) - fabsf(v);

	if (z < 0.0f) {
		float tu = (1.0f - fabsf(v)) * copysignf(1.0f, u);
		float tv = (1.0f - fabsf(u)) * copysignf(1.0f, v);

		u = tu;
		v = tv;
	}
	return pm_v3(u, v, z);
}

static inline struct pm_vec3 pm_dir_unpack(const uint8_t in[2])
{
	return pm_normalize(pm_dir_unpack_raw(in));
}

static inline struct pm_vec3 pm_photon_pos(const struct pm_photon *p)
{
	return pm_v3(p->pos[0], p->pos[1], p->pos[2]);
}

#endif
