/*
 * test_crc32.c: pm_crc32 is zlib's crc32_z.  Every length from 0 to 1100
 * bytes (under, at and past the 64-byte block and the 16-byte chunk of the
 * folded path, and the 128-byte block of the wide one) at every
 * alignment, each from a random starting crc, then long buffers whole and
 * in uneven pieces, and inputs whose folds are all ones or all zeros,
 * must give zlib's value bit for bit, on every path this CPU has.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

#include <cmocka.h>

#include "../../formats/crc32.h"

/* A fixed stream of bytes (xorshift), so failures repeat. */
static uint64_t
next(uint64_t *s)
{
	*s ^= *s << 13;
	*s ^= *s >> 7;
	*s ^= *s << 17;
	return *s;
}

static uint32_t
zref(uint32_t crc, const unsigned char *p, size_t n)
{
	return (uint32_t)crc32_z(crc, p, n);
}

static void
every_length(void)
{
	enum { MAXLEN = 1100 };
	unsigned char *b = malloc(MAXLEN + 16);
	uint64_t s = 0x9e3779b97f4a7c15ull;
	size_t len, off, i, bad = 0;

	assert_non_null(b);
	for (i = 0; i < MAXLEN + 16; i++)
		b[i] = (unsigned char)next(&s);
	for (len = 0; len <= MAXLEN; len++)
		for (off = 0; off < 16; off++) {
			uint32_t c0 = (uint32_t)next(&s);

			if (pm_crc32(c0, b + off, len) != zref(c0, b + off, len))
				bad++;
		}
	assert_int_equal(bad, 0);
	assert_int_equal(pm_crc32(0, NULL, 0), 0);
	free(b);
}

static void
long_and_pieces(void)
{
	const size_t n = (size_t)9 << 20;	/* 9 MiB */
	unsigned char *b = malloc(n);
	uint64_t s = 12345;
	uint32_t whole, pieced = 0;
	size_t i, at, step;

	assert_non_null(b);
	for (i = 0; i < n; i++)
		b[i] = (unsigned char)next(&s);
	whole = pm_crc32(0, b, n);
	assert_int_equal(whole, zref(0, b, n));
	/* In pieces of odd sizes: the crc carried between calls. */
	for (at = 0; at < n; at += step) {
		step = (size_t)(next(&s) % 70000);
		if (step > n - at)
			step = n - at;
		pieced = pm_crc32(pieced, b + at, step);
	}
	assert_int_equal(pieced, whole);
	/* Bytes that drive every register to all ones or all zeros. */
	memset(b, 0xff, n);
	assert_int_equal(pm_crc32(0, b, 4096 + 48), zref(0, b, 4096 + 48));
	assert_int_equal(pm_crc32(0xffffffffu, b, n), zref(0xffffffffu, b, n));
	memset(b, 0, n);
	assert_int_equal(pm_crc32(0, b, n), zref(0, b, n));
	assert_int_equal(pm_crc32(0xdeadbeefu, b, 777), zref(0xdeadbeefu, b, 777));
	free(b);
}

/* Runs check on every path this CPU has, from the widest down. */
static void
on_every_path(void (*check)(void))
{
	int widest, path;

	/* the CPU's widest, whatever a failed test before left */
	pm_crc32_limit(2);
	widest = pm_crc32_path();
	for (path = widest; path >= 0; path--) {
		pm_crc32_limit(path);
		assert_int_equal(pm_crc32_path(), path);
		check();
	}
	pm_crc32_limit(widest);
}

static void
test_every_length(void **state)
{
	(void)state;
	on_every_path(every_length);
}

static void
test_long_and_pieces(void **state)
{
	(void)state;
	on_every_path(long_and_pieces);
}

/* Which paths ran is printed, so that a log shows the folded ones were
 * tested (the CI machines have PCLMULQDQ). */
static void
test_path(void **state)
{
	static const char *name[] = { "zlib only", "folded with PCLMULQDQ",
	    "folded with PCLMULQDQ and, eight chunks at a time, VPCLMULQDQ" };
	int path = pm_crc32_path();

	(void)state;
	assert_true(path >= 0 && path <= 2);
	print_message("pm_crc32: %s\n", name[path]);
}

int
main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_path),
		cmocka_unit_test(test_every_length),
		cmocka_unit_test(test_long_and_pieces),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
