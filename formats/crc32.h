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

/* Whether pm_crc32 folds with PCLMULQDQ on this CPU (for tests and
 * benchmarks: the answer is the same either way). */
int pm_crc32_is_folded(void);

#endif
