/*
 * endian.h: little-endian integers and IEEE floats in byte buffers.
 *
 * Every binary format pm reads or writes (pmap, Mitsuba's .vol and
 * .serialized, MERL's .binary) is little-endian whatever the host.  These
 * build values byte by byte, so they need no alignment and are the same on
 * any host; compilers turn them into single loads and stores where the
 * host is little-endian.  One copy, shared by the readers and writers.
 */
#ifndef PM_ENDIAN_H
#define PM_ENDIAN_H

#include <stdint.h>
#include <string.h>

static inline uint16_t
pm_get_le16(const unsigned char *p)
{
	return (uint16_t)(p[0] | p[1] << 8);
}

static inline uint32_t
pm_get_le32(const unsigned char *p)
{
	return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 |
	    (uint32_t)p[3] << 24;
}

static inline uint64_t
pm_get_le64(const unsigned char *p)
{
	return (uint64_t)pm_get_le32(p) | (uint64_t)pm_get_le32(p + 4) << 32;
}

static inline float
pm_get_f32(const unsigned char *p)
{
	uint32_t u = pm_get_le32(p);
	float f;

	memcpy(&f, &u, sizeof(f));
	return f;
}

static inline double
pm_get_f64(const unsigned char *p)
{
	uint64_t u = pm_get_le64(p);
	double d;

	memcpy(&d, &u, sizeof(d));
	return d;
}

static inline void
pm_put_le16(unsigned char *p, uint16_t v)
{
	p[0] = (unsigned char)v;
	p[1] = (unsigned char)(v >> 8);
}

static inline void
pm_put_le32(unsigned char *p, uint32_t v)
{
	p[0] = (unsigned char)v;
	p[1] = (unsigned char)(v >> 8);
	p[2] = (unsigned char)(v >> 16);
	p[3] = (unsigned char)(v >> 24);
}

static inline void
pm_put_le64(unsigned char *p, uint64_t v)
{
	pm_put_le32(p, (uint32_t)v);
	pm_put_le32(p + 4, (uint32_t)(v >> 32));
}

static inline void
pm_put_f32(unsigned char *p, float f)
{
	uint32_t u;

	memcpy(&u, &f, sizeof(u));
	pm_put_le32(p, u);
}

static inline void
pm_put_f64(unsigned char *p, double d)
{
	uint64_t u;

	memcpy(&u, &d, sizeof(u));
	pm_put_le64(p, u);
}

#endif
