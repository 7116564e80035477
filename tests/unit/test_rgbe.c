/*
 * test_rgbe.c: the Radiance HDR reader.  Files written here byte by byte
 * decode to the pixels they were made from, in every scanline layout
 * (flat, run-length, old-style runs) and both row orders; each kind of
 * damage (no signature, another format, a bad resolution line, scanlines
 * cut short or running past their width) fails with a message, never a
 * crash.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <cmocka.h>

#include "../../formats/rgbe.h"
#include "tmpdir.h"

static const char *
put(const char *name, const void *bytes, size_t n)
{
	static char path[256];
	FILE *f;

	snprintf(path, sizeof(path), "%s/%s", pm_test_dir, name);
	f = fopen(path, "wb");
	assert_non_null(f);
	assert_int_equal(fwrite(bytes, 1, n, f), n);
	assert_int_equal(fclose(f), 0);
	return path;
}

/* Header and resolution line, then body. */
static size_t
file(unsigned char *out, const char *res, const unsigned char *body,
    size_t n)
{
	int h = sprintf((char *)out, "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n"
	    "EXPOSURE=2\n\n%s\n", res);

	memcpy(out + h, body, n);
	return (size_t)h + n;
}

static void
pixel_is(const struct pm_image *im, int x, int y, double r, double g,
    double b)
{
	const float *p = &im->rgb[3 * ((size_t)y * (size_t)im->width +
	    (size_t)x)];

	assert_true(fabs(p[0] - r) < 1e-7 && fabs(p[1] - g) < 1e-7 &&
	    fabs(p[2] - b) < 1e-7);
}

static void
test_flat(void **state)
{
	unsigned char body[4 * 4 * 3], buf[512];
	struct pm_image im;
	struct pm_error err;
	int i;

	(void)state;
	for (i = 0; i < 12; i++) {
		body[4 * i] = (unsigned char)(10 * i);
		body[4 * i + 1] = 50;
		body[4 * i + 2] = 200;
		body[4 * i + 3] = (unsigned char)(i == 5 ? 0 : 128 + i % 3);
	}
	assert_int_equal(pm_rgbe_read(put("a.hdr", buf, file(buf, "-Y 3 +X 4",
	    body, sizeof(body))), &im, &err), PM_OK);
	assert_int_equal(im.width, 4);
	assert_int_equal(im.height, 3);
	/* mantissa / 256 * 2^(e - 128); exposure ignored; e = 0 is black */
	pixel_is(&im, 0, 0, 0.0, 50 / 256.0, 200 / 256.0);
	pixel_is(&im, 1, 0, 10 / 128.0, 50 / 128.0, 200 / 128.0);
	pixel_is(&im, 1, 1, 0.0, 0.0, 0.0);
	pixel_is(&im, 3, 2, 110 / 64.0, 50 / 64.0, 200 / 64.0);
	pm_image_free(&im);
	/* bottom row first */
	assert_int_equal(pm_rgbe_read(put("b.hdr", buf, file(buf, "+Y 3 +X 4",
	    body, sizeof(body))), &im, &err), PM_OK);
	pixel_is(&im, 0, 2, 0.0, 50 / 256.0, 200 / 256.0);
	pm_image_free(&im);
}

static void
test_rle(void **state)
{
	/* width 10, two rows: per component, runs and literals */
	static const unsigned char body[] = {
		2, 2, 0, 10,
		128 + 10, 7,				/* R: ten 7s */
		3, 1, 2, 3, 128 + 7, 9,			/* G: 1 2 3, seven 9s */
		10, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9,	/* B: literal 0..9 */
		128 + 10, 129,				/* E: all 129 */
		2, 2, 0, 10,
		128 + 10, 0, 128 + 10, 0, 128 + 10, 0, 128 + 10, 0,
	};
	unsigned char buf[512];
	struct pm_image im;
	struct pm_error err;

	(void)state;
	assert_int_equal(pm_rgbe_read(put("r.hdr", buf, file(buf, "-Y 2 +X 10",
	    body, sizeof(body))), &im, &err), PM_OK);
	pixel_is(&im, 0, 0, 7 / 128.0, 1 / 128.0, 0.0);
	pixel_is(&im, 2, 0, 7 / 128.0, 3 / 128.0, 2 / 128.0);
	pixel_is(&im, 9, 0, 7 / 128.0, 9 / 128.0, 9 / 128.0);
	pixel_is(&im, 4, 1, 0.0, 0.0, 0.0);
	pm_image_free(&im);
}

static void
test_old_runs(void **state)
{
	/* 9 wide: a pixel, then (1,1,1,3): three more of it; another pixel,
	 * (1,1,1,4) four more */
	static const unsigned char body[] = {
		10, 20, 30, 128, 1, 1, 1, 3,
		40, 50, 60, 129, 1, 1, 1, 4,
	};
	unsigned char buf[512];
	struct pm_image im;
	struct pm_error err;

	(void)state;
	assert_int_equal(pm_rgbe_read(put("o.hdr", buf, file(buf, "-Y 1 +X 9",
	    body, sizeof(body))), &im, &err), PM_OK);
	pixel_is(&im, 3, 0, 10 / 256.0, 20 / 256.0, 30 / 256.0);
	pixel_is(&im, 4, 0, 40 / 128.0, 50 / 128.0, 60 / 128.0);
	pixel_is(&im, 8, 0, 40 / 128.0, 50 / 128.0, 60 / 128.0);
	pm_image_free(&im);
}

static void
test_damage(void **state)
{
	static const unsigned char rle[] = {2, 2, 0, 10, 128 + 11, 7};
	static const unsigned char lit[] = {2, 2, 0, 10, 5, 1, 2};
	static const unsigned char wid[] = {2, 2, 0, 11, 128 + 10, 7};
	static const unsigned char flat[] = {1, 2, 3, 128, 4, 5};
	static const unsigned char run0[] = {1, 1, 1, 3, 4, 5, 6, 128};
	static const struct {
		const char *res;
		const unsigned char *body;
		size_t n;
		const char *what;
	} cases[] = {
		{"-Y 1 +X 10", rle, sizeof(rle), "run past the end"},
		{"-Y 1 +X 10", lit, sizeof(lit), "bad literal"},
		{"-Y 1 +X 10", wid, sizeof(wid), "width differs"},
		{"-Y 1 +X 2", flat, sizeof(flat), "truncated scanline"},
		{"-Y 1 +X 2", run0, sizeof(run0), "bad run"},
		{"-X 1 +Y 2", flat, sizeof(flat), "resolution line"},
		{"-Y 0 +X 2", flat, sizeof(flat), "at most"},
		{"-Y 1 +X 99999", flat, sizeof(flat), "at most"},
	};
	unsigned char buf[512];
	struct pm_image im;
	struct pm_error err;
	size_t i;

	(void)state;
	for (i = 0; i < sizeof(cases) / sizeof(cases[0]); i++) {
		print_message("damage %zu: %s\n", i, cases[i].what);
		assert_int_not_equal(pm_rgbe_read(put("d.hdr", buf, file(buf,
		    cases[i].res, cases[i].body, cases[i].n)), &im, &err), PM_OK);
		assert_non_null(strstr(err.msg, cases[i].what));
		assert_null(im.rgb);
	}
	assert_int_not_equal(pm_rgbe_read(put("n.hdr", "P6\n1 1\n255\n", 11),
	    &im, &err), PM_OK);
	assert_non_null(strstr(err.msg, "no #? signature"));
	assert_int_not_equal(pm_rgbe_read(put("x.hdr", "#?RADIANCE\n"
	    "FORMAT=32-bit_rle_xyze\n\n-Y 1 +X 1\n\1\2\3\4", 46), &im, &err),
	    PM_OK);
	assert_non_null(strstr(err.msg, "32-bit_rle_rgbe only"));
	assert_int_not_equal(pm_rgbe_read(put("t.hdr", "#?RADIANCE\nSOFTWARE=x",
	    21), &im, &err), PM_OK);
	assert_non_null(strstr(err.msg, "truncated header"));
}

int
main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_flat),
		cmocka_unit_test(test_rle),
		cmocka_unit_test(test_old_runs),
		cmocka_unit_test(test_damage),
	};

	return cmocka_run_group_tests(tests, pm_tmpdir_setup, pm_tmpdir_teardown);
}
