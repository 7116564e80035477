/*
 * crc32.h: the CRC-32 of the photon-map format (zlib's crc32_z: the
 * polynomial of gzip and PNG), computed by carry-less multiplication
 * where the CPU has it.
 */
#ifndef PM_CRC32_H
#define PM_CRC32_H

#include <stddef.h>
#include <stdint.h>

/* crc extended over buf[0..len): the value zlib's crc32_z(crc, buf, len)
 * returns, for any crc, buf and len (pm_crc32(0, NULL, 0) is 0). */
uint32_t pm_crc32(uint32_t crc, const void *buf, size_t len);

/* The path pm_crc32 takes on this CPU, for tests and benchmarks (the
 * answer is the same on every path): 0 zlib, 1 folded with PCLMULQDQ,
 * 2 folded eight chunks at a time with VPCLMULQDQ. */
int pm_crc32_path(void);

/* Lets pm_crc32 take no path wider than `widest` (as numbered above), so
 * that tests can check the narrower paths on CPUs that have the wider;
 * returns the limit before.  Not for use while other threads checksum. */
int pm_crc32_limit(int widest);

#endif
