/*
 * test_image.c: the image operations behind pm-downsample and the EXR and
 * PNG files around them, with the string attributes that carry provenance.
 *
 * Filters are checked against answers that follow from their definition:
 * a constant stays constant, a box is a block mean, a symmetric filter
 * reproduces a linear ramp away from the borders.  Files are checked by
 * round trips, by files OpenEXRCore writes directly in the variants pm
 * does not write itself (tiled, uint, half, missing channels), and by
 * truncated, bit-flipped and foreign files that must fail cleanly.
 */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <dirent.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <openexr.h>
#include <png.h>

#include "../../common/image.h"
#include "../../formats/exr.h"
#include "../../formats/png.h"
#include "tmpdir.h"

static const enum pm_filter all_filters[] = {
	PM_FILTER_BOX, PM_FILTER_TENT, PM_FILTER_GAUSSIAN,
	PM_FILTER_MITCHELL, PM_FILTER_LANCZOS,
};
#define NFILTERS (sizeof(all_filters) / sizeof(all_filters[0]))

/* A small fixed-seed generator, so every run sees the same pixels. */
static uint64_t rng_state;

static float
rnd(void)
{
	rng_state = rng_state * 6364136223846793005ULL + 1442695040888963407ULL;
	return (float)((rng_state >> 40) * (1.0 / 16777216.0));
}

static void
fill_random(struct pm_image *im, float lo, float hi)
{
	size_t i, n = (size_t)im->width * im->height * 3;

	for (i = 0; i < n; i++)
		im->rgb[i] = lo + (hi - lo) * rnd();
}

static void
path_in_tmp(char *buf, size_t size, const char *name)
{
	snprintf(buf, size, "%s/%s", pm_test_dir, name);
}

/* Copies the first len bytes of src to dst. */
static void
copy_prefix(const char *src, const char *dst, long len)
{
	FILE *in = fopen(src, "rb"), *out = fopen(dst, "wb");
	char buf[4096];
	long left = len;

	assert_non_null(in);
	assert_non_null(out);
	while (left > 0) {
		size_t want = left < (long)sizeof(buf) ? (size_t)left :
		    sizeof(buf);
		size_t got = fread(buf, 1, want, in);

		if (got == 0)
			break;
		assert_int_equal(fwrite(buf, 1, got, out), got);
		left -= (long)got;
	}
	fclose(in);
	assert_int_equal(fclose(out), 0);
}

static long
file_size(const char *path)
{
	FILE *fp = fopen(path, "rb");
	long n;

	assert_non_null(fp);
	assert_int_equal(fseek(fp, 0, SEEK_END), 0);
	n = ftell(fp);
	fclose(fp);
	return n;
}

/* True when the directory holds nothing but the names given (b may be
 * NULL): a temporary file left behind would show here. */
static int
only_files(const char *a, const char *b)
{
	DIR *d = opendir(pm_test_dir);
	struct dirent *e;
	int extra = 0;

	assert_non_null(d);
	while ((e = readdir(d)) != NULL) {
		if (strcmp(e->d_name, ".") == 0 || strcmp(e->d_name, "..") == 0)
			continue;
		if (strcmp(e->d_name, a) != 0 &&
		    (b == NULL || strcmp(e->d_name, b) != 0))
			extra++;
	}
	closedir(d);
	return extra == 0;
}

static void
test_filter_parse(void **state)
{
	(void)state;
	assert_int_equal(pm_filter_parse("box"), PM_FILTER_BOX);
	assert_int_equal(pm_filter_parse("tent"), PM_FILTER_TENT);
	assert_int_equal(pm_filter_parse("gaussian"), PM_FILTER_GAUSSIAN);
	assert_int_equal(pm_filter_parse("mitchell"), PM_FILTER_MITCHELL);
	assert_int_equal(pm_filter_parse("lanczos"), PM_FILTER_LANCZOS);
	assert_int_equal(pm_filter_parse("Box"), -1);
	assert_int_equal(pm_filter_parse(""), -1);
	assert_int_equal(pm_filter_parse("boxx"), -1);
	assert_int_equal(pm_filter_parse(NULL), -1);
}

/* A constant image stays that constant under every filter and factor, at
 * the borders too, because weights are renormalised per output pixel. */
static void
test_downsample_constant(void **state)
{
	static const int factors[] = { 1, 2, 3, 4, 7 };
	static const float consts[][3] = {
		{ 0.25f, 1.75f, 42.0f }, { 1e-4f, 3e4f, 1.0f },
	};
	struct pm_error err;
	size_t f, k, c, i;

	(void)state;
	for (f = 0; f < NFILTERS; f++)
	for (k = 0; k < sizeof(factors) / sizeof(factors[0]); k++)
	for (c = 0; c < 2; c++) {
		struct pm_image in, out;
		int fac = factors[k];

		assert_int_equal(pm_image_alloc(&in, 5 * fac, 3 * fac, &err),
		    PM_OK);
		for (i = 0; i < (size_t)in.width * in.height; i++)
			memcpy(in.rgb + 3 * i, consts[c], sizeof(consts[c]));
		assert_int_equal(pm_image_downsample(&in, fac, all_filters[f],
		    &out, &err), PM_OK);
		assert_int_equal(out.width, 5);
		assert_int_equal(out.height, 3);
		for (i = 0; i < (size_t)out.width * out.height * 3; i++) {
			float want = consts[c][i % 3];

			if (fabsf(out.rgb[i] - want) > 1e-6f * want)
				fail_msg("filter %zu factor %d: %.9g != %.9g",
				    f, fac, out.rgb[i], want);
		}
		pm_image_free(&in);
		pm_image_free(&out);
	}
}

/* The box filter of radius 1/2 output pixel covers exactly one block. */
static void
test_downsample_box_is_block_mean(void **state)
{
	static const int factors[] = { 1, 2, 3, 5 };
	struct pm_error err;
	size_t k;

	(void)state;
	rng_state = 1;
	for (k = 0; k < sizeof(factors) / sizeof(factors[0]); k++) {
		struct pm_image in, out;
		int fac = factors[k], x, y, c, dx, dy;

		assert_int_equal(pm_image_alloc(&in, 7 * fac, 4 * fac, &err),
		    PM_OK);
		fill_random(&in, -1.0f, 10.0f);
		assert_int_equal(pm_image_downsample(&in, fac, PM_FILTER_BOX,
		    &out, &err), PM_OK);
		for (y = 0; y < out.height; y++)
		for (x = 0; x < out.width; x++)
		for (c = 0; c < 3; c++) {
			double sum = 0, got;

			for (dy = 0; dy < fac; dy++)
			for (dx = 0; dx < fac; dx++)
				sum += in.rgb[((size_t)(y * fac + dy) *
				    in.width + x * fac + dx) * 3 + c];
			sum /= fac * fac;
			got = out.rgb[((size_t)y * out.width + x) * 3 + c];
			if (fabs(got - sum) > 1e-5 * (1 + fabs(sum)))
				fail_msg("factor %d (%d, %d): %.9g != %.9g",
				    fac, x, y, got, sum);
		}
		pm_image_free(&in);
		pm_image_free(&out);
	}
}

/*
 * Every filter is symmetric, so away from the borders it reproduces a
 * linear function of position exactly: a horizontal ramp whose value is
 * the input pixel's centre in output units must come out as the output
 * pixel's centre.  An error of half a pixel in the mapping shows here.
 */
static void
test_downsample_ramp(void **state)
{
	static const int factors[] = { 1, 2, 3, 4 };
	struct pm_error err;
	size_t f, k;

	(void)state;
	for (f = 0; f < NFILTERS; f++)
	for (k = 0; k < sizeof(factors) / sizeof(factors[0]); k++) {
		struct pm_image in, out;
		int fac = factors[k], wo = 16, x, y;

		assert_int_equal(pm_image_alloc(&in, wo * fac, 2 * fac, &err),
		    PM_OK);
		for (y = 0; y < in.height; y++)
		for (x = 0; x < in.width; x++) {
			float *p = in.rgb + ((size_t)y * in.width + x) * 3;

			p[0] = (x + 0.5f) / fac;
			p[1] = 100.0f - p[0];
			p[2] = 3.0f;
		}
		assert_int_equal(pm_image_downsample(&in, fac, all_filters[f],
		    &out, &err), PM_OK);
		/* Lanczos reaches 3 output pixels; stay 4 from each side. */
		for (y = 0; y < out.height; y++)
		for (x = 4; x < wo - 4; x++) {
			float *p = out.rgb + ((size_t)y * wo + x) * 3;

			if (fabsf(p[0] - (x + 0.5f)) > 1e-4f ||
			    fabsf(p[1] - (100.0f - (x + 0.5f))) > 1e-4f ||
			    fabsf(p[2] - 3.0f) > 1e-5f)
				fail_msg("filter %zu factor %d x %d: %g %g %g",
				    f, fac, x, p[0], p[1], p[2]);
		}
		pm_image_free(&in);
		pm_image_free(&out);
	}
}

/* Filters that vanish at every nonzero integer leave an image alone when
 * the factor is 1; the gaussian and Mitchell do not, and must blur. */
static void
test_downsample_factor1(void **state)
{
	struct pm_error err;
	struct pm_image in, out;
	size_t f, i, n;

	(void)state;
	rng_state = 7;
	assert_int_equal(pm_image_alloc(&in, 9, 6, &err), PM_OK);
	fill_random(&in, 0.0f, 1.0f);
	n = (size_t)in.width * in.height * 3;
	for (f = 0; f < NFILTERS; f++) {
		double maxdiff = 0;

		assert_int_equal(pm_image_downsample(&in, 1, all_filters[f],
		    &out, &err), PM_OK);
		for (i = 0; i < n; i++)
			maxdiff = fmax(maxdiff, fabs(out.rgb[i] - in.rgb[i]));
		if (all_filters[f] == PM_FILTER_GAUSSIAN ||
		    all_filters[f] == PM_FILTER_MITCHELL)
			assert_true(maxdiff > 1e-3);
		else
			assert_true(maxdiff < 1e-6);
		pm_image_free(&out);
	}
	pm_image_free(&in);
}

static void
test_downsample_errors(void **state)
{
	struct pm_error err;
	struct pm_image in, out;

	(void)state;
	assert_int_equal(pm_image_alloc(&in, 13, 12, &err), PM_OK);
	err.msg[0] = '\0';
	assert_int_equal(pm_image_downsample(&in, 2, PM_FILTER_BOX, &out,
	    &err), PM_ERR_INVALID);
	assert_null(out.rgb);
	assert_non_null(strstr(err.msg, "13x12"));
	assert_int_equal(pm_image_downsample(&in, 0, PM_FILTER_BOX, &out,
	    &err), PM_ERR_INVALID);
	assert_int_equal(pm_image_downsample(&in, 1, (enum pm_filter)99, &out,
	    &err), PM_ERR_INVALID);
	pm_image_free(&in);
	pm_image_free(&in);	/* twice is allowed */

	assert_int_equal(pm_image_alloc(&in, 0, 5, &err), PM_ERR_INVALID);
	assert_null(in.rgb);
	assert_int_equal(pm_image_alloc(&in, 1 << 20, 1 << 20, &err),
	    PM_ERR_LIMIT);
	assert_null(in.rgb);
}

/* Two passes summed and halved give their mean exactly: the sum rounds
 * once, and halving is exact in binary. */
static void
test_accumulate_mean(void **state)
{
	struct pm_error err;
	struct pm_image a, b, c;
	size_t i, n;

	(void)state;
	rng_state = 3;
	assert_int_equal(pm_image_alloc(&a, 8, 5, &err), PM_OK);
	assert_int_equal(pm_image_alloc(&b, 8, 5, &err), PM_OK);
	assert_int_equal(pm_image_alloc(&c, 5, 8, &err), PM_OK);
	fill_random(&a, 0.0f, 4.0f);
	fill_random(&b, 0.0f, 4.0f);
	n = (size_t)a.width * a.height * 3;
	{
		float want[120];

		for (i = 0; i < n; i++)
			want[i] = (float)(((double)a.rgb[i] + b.rgb[i]) / 2);
		assert_int_equal(pm_image_accumulate(&a, &b, &err), PM_OK);
		pm_image_scale(&a, 0.5f);
		for (i = 0; i < n; i++)
			assert_true(a.rgb[i] == want[i]);
	}
	assert_int_equal(pm_image_accumulate(&a, &c, &err), PM_ERR_INVALID);
	assert_non_null(strstr(err.msg, "5x8"));
	pm_image_free(&a);
	pm_image_free(&b);
	pm_image_free(&c);
}

/* Every byte survives the trip back through the inverse sRGB curve, which
 * pins both the curve and the rounding. */
static void
test_srgb(void **state)
{
	struct pm_image im;
	struct pm_error err;
	uint8_t out[3 * 256];
	uint8_t one[3], ref[3];
	int b, i, prev;

	(void)state;
	assert_int_equal(pm_image_alloc(&im, 256, 1, &err), PM_OK);
	for (b = 0; b < 256; b++) {
		double s = b / 255.0, lin;

		lin = s <= 0.04045 ? s / 12.92 : pow((s + 0.055) / 1.055, 2.4);
		im.rgb[3 * b] = im.rgb[3 * b + 1] = im.rgb[3 * b + 2] =
		    (float)lin;
	}
	pm_image_to_srgb8(&im, 0.0f, out);
	for (b = 0; b < 256; b++)
		assert_int_equal(out[3 * b], b);
	pm_image_free(&im);

	/* Monotone over a fine sweep that runs well past 1. */
	assert_int_equal(pm_image_alloc(&im, 4000, 1, &err), PM_OK);
	for (i = 0; i < 4000; i++)
		im.rgb[3 * i] = im.rgb[3 * i + 1] = im.rgb[3 * i + 2] =
		    i / 2000.0f;
	{
		uint8_t *buf = malloc(3 * 4000);

		assert_non_null(buf);
		pm_image_to_srgb8(&im, 0.0f, buf);
		prev = 0;
		for (i = 0; i < 4000; i++) {
			assert_true(buf[3 * i] >= prev);
			prev = buf[3 * i];
		}
		assert_int_equal(buf[0], 0);
		assert_int_equal(buf[3 * 2000], 255);
		assert_int_equal(buf[3 * 3999], 255);
		free(buf);
	}
	pm_image_free(&im);

	/* Exposure scales by a power of two before the curve, so halving
	 * the pixels and adding one stop changes nothing. */
	assert_int_equal(pm_image_alloc(&im, 1, 1, &err), PM_OK);
	im.rgb[0] = 1.0f;
	im.rgb[1] = 0.5f;
	im.rgb[2] = 0.25f;
	pm_image_to_srgb8(&im, 0.0f, ref);
	assert_true(ref[0] > ref[1] && ref[1] > ref[2]);
	im.rgb[0] = 0.5f;
	im.rgb[1] = 0.25f;
	im.rgb[2] = 0.125f;
	pm_image_to_srgb8(&im, 1.0f, one);
	assert_memory_equal(one, ref, 3);
	im.rgb[0] = 4.0f;
	im.rgb[1] = 2.0f;
	im.rgb[2] = 1.0f;
	pm_image_to_srgb8(&im, -2.0f, one);
	assert_memory_equal(one, ref, 3);

	/* Nothing wraps: huge and infinite saturate, negative and NaN are
	 * black. */
	im.rgb[0] = 1e30f;
	im.rgb[1] = INFINITY;
	im.rgb[2] = 3.0e38f;
	pm_image_to_srgb8(&im, 8.0f, one);
	assert_int_equal(one[0], 255);
	assert_int_equal(one[1], 255);
	assert_int_equal(one[2], 255);
	im.rgb[0] = -1.0f;
	im.rgb[1] = NAN;
	im.rgb[2] = -INFINITY;
	pm_image_to_srgb8(&im, 0.0f, one);
	assert_int_equal(one[0], 0);
	assert_int_equal(one[1], 0);
	assert_int_equal(one[2], 0);
	im.rgb[0] = 0.0f;
	im.rgb[1] = 1.0f;
	im.rgb[2] = 1.0000001f;
	pm_image_to_srgb8(&im, 0.0f, one);
	assert_int_equal(one[0], 0);
	assert_int_equal(one[1], 255);
	assert_int_equal(one[2], 255);
	pm_image_free(&im);
}

static void
test_exr_roundtrip_float(void **state)
{
	struct pm_error err;
	struct pm_image a, b;
	char path[512];

	(void)state;
	rng_state = 11;
	path_in_tmp(path, sizeof(path), "float.exr");
	/* 37 rows: not a multiple of ZIP's 16-line chunks. */
	assert_int_equal(pm_image_alloc(&a, 23, 37, &err), PM_OK);
	fill_random(&a, -2.0f, 1000.0f);
	a.rgb[0] = 1e-30f;
	a.rgb[1] = 3e38f;
	a.rgb[5] = -0.0f;
	err.msg[0] = '\0';
	if (pm_exr_write(path, &a, false, &err) != PM_OK)
		fail_msg("%s", err.msg);
	if (pm_exr_read(path, &b, &err) != PM_OK)
		fail_msg("%s", err.msg);
	assert_int_equal(b.width, 23);
	assert_int_equal(b.height, 37);
	assert_memory_equal(a.rgb, b.rgb, sizeof(float) * 3 * 23 * 37);
	/* No temporary file is left beside the output. */
	assert_true(only_files("float.exr", NULL));

	/* Writing again replaces the file whole. */
	pm_image_scale(&a, 2.0f);
	assert_int_equal(pm_exr_write(path, &a, false, &err), PM_OK);
	pm_image_free(&b);
	assert_int_equal(pm_exr_read(path, &b, &err), PM_OK);
	assert_memory_equal(a.rgb, b.rgb, sizeof(float) * 3 * 23 * 37);
	pm_image_free(&a);
	pm_image_free(&b);
	unlink(path);
}

/*
 * Channels beside R, G and B (layers): written and read back bit for bit
 * under their names, grouped three to a layer in the file's sorted order
 * (a last layer of one channel has two empty slots); readers that want
 * only RGB still read the file; duplicate names fail the write.
 */
static void
test_exr_layers(void **state)
{
	struct pm_error err;
	struct pm_exr_layers ly = { NULL, 0 }, back = { NULL, 0 };
	struct pm_exr_layer *l1, *l2;
	struct pm_image a, b;
	char path[512];
	size_t i, n = 9 * 7;
	int k;

	(void)state;
	rng_state = 5;
	path_in_tmp(path, sizeof(path), "layers.exr");
	assert_int_equal(pm_image_alloc(&a, 9, 7, &err), PM_OK);
	fill_random(&a, 0.0f, 10.0f);
	assert_int_equal(pm_exr_layers_add(&ly, "nested.X", "nested.Y",
	    "nested.Z", 9, 7, &l1, &err), PM_OK);
	fill_random(&l1->im, 0.0f, 1.0f);
	assert_int_equal(pm_exr_layers_add(&ly, "A", NULL, NULL, 9, 7, &l2,
	    &err), PM_OK);
	fill_random(&l2->im, 0.0f, 1.0f);
	if (pm_exr_write_layers(path, &a, false, NULL, &ly, &err) != PM_OK)
		fail_msg("%s", err.msg);
	if (pm_exr_read_layers(path, &b, NULL, &back, &err) != PM_OK)
		fail_msg("%s", err.msg);
	assert_memory_equal(a.rgb, b.rgb, sizeof(float) * 3 * n);
	/* Sorted: A, then nested.X, nested.Y; nested.Z alone. */
	assert_int_equal(back.n, 2);
	assert_string_equal(back.v[0].name[0], "A");
	assert_string_equal(back.v[0].name[1], "nested.X");
	assert_string_equal(back.v[0].name[2], "nested.Y");
	assert_string_equal(back.v[1].name[0], "nested.Z");
	assert_null(back.v[1].name[1]);
	assert_null(back.v[1].name[2]);
	for (i = 0; i < n; i++) {
		assert_true(back.v[0].im.rgb[3 * i] == l2->im.rgb[3 * i]);
		for (k = 0; k < 2; k++)
			assert_true(back.v[0].im.rgb[3 * i + 1 + k] ==
			    ly.v[0].im.rgb[3 * i + k]);
		assert_true(back.v[1].im.rgb[3 * i] ==
		    ly.v[0].im.rgb[3 * i + 2]);
	}
	pm_image_free(&b);
	assert_int_equal(pm_exr_read(path, &b, &err), PM_OK);
	assert_memory_equal(a.rgb, b.rgb, sizeof(float) * 3 * n);
	pm_image_free(&b);
	/* half: the same names, values within half's precision */
	assert_int_equal(pm_exr_write_layers(path, &a, true, NULL, &ly, &err),
	    PM_OK);
	assert_int_equal(pm_exr_read_layers(path, &b, NULL, &back, &err),
	    PM_OK);
	assert_int_equal(back.n, 2);
	for (i = 0; i < n; i++)
		assert_true(fabsf(back.v[1].im.rgb[3 * i] -
		    ly.v[0].im.rgb[3 * i + 2]) <= 1e-3f);
	pm_image_free(&b);
	pm_exr_layers_free(&back);
	/* A name given twice, or one that is R, fails and leaves nothing. */
	free(ly.v[1].name[0]);
	ly.v[1].name[0] = strdup("R");
	assert_non_null(ly.v[1].name[0]);
	unlink(path);
	assert_int_not_equal(pm_exr_write_layers(path, &a, false, NULL, &ly,
	    &err), PM_OK);
	assert_true(only_files("layers.exr", NULL));
	pm_exr_layers_free(&ly);
	assert_null(ly.v);
	pm_image_free(&a);
}

/*
 * String attributes, the provenance the tools record: set replaces or
 * appends; they come back in the order written, byte for byte (spaces,
 * quotes, UTF-8, an empty value); the pixels are those of a file written
 * without them; a header alone can be read; a name OpenEXR keeps for
 * another type fails the write and leaves nothing behind.
 */
static void
test_exr_attributes(void **state)
{
	static const char *const names[] = {
		"pm-render.version", "pm-render.command", "owner", "empty",
	};
	static const char *const values[] = {
		"0.3.0", "pm-render -o 'a b.exr' \"x\" data/caustics.xml",
		"\xc3\xa9t\xc3\xa9", "",
	};
	struct pm_exr_attrs at = { 0 }, back = { 0 };
	struct pm_error err;
	struct pm_image a, b, c;
	char path[512], plain[512];
	size_t i;

	(void)state;
	assert_int_equal(pm_exr_attrs_set(&at, "owner", "nobody", &err), PM_OK);
	for (i = 0; i < 4; i++)
		assert_int_equal(pm_exr_attrs_set(&at, names[i], values[i],
		    &err), PM_OK);
	/* "owner" was set twice: replaced in place, not appended. */
	assert_int_equal(at.n, 4);
	assert_string_equal(pm_exr_attrs_get(&at, "owner"), values[2]);
	assert_null(pm_exr_attrs_get(&at, "nothing"));
	assert_string_equal(at.v[0].name, "owner");

	rng_state = 5;
	path_in_tmp(path, sizeof(path), "attrs.exr");
	path_in_tmp(plain, sizeof(plain), "plain.exr");
	assert_int_equal(pm_image_alloc(&a, 9, 40, &err), PM_OK);
	fill_random(&a, 0.0f, 50.0f);
	if (pm_exr_write_attrs(path, &a, false, &at, &err) != PM_OK)
		fail_msg("%s", err.msg);
	assert_int_equal(pm_exr_write(plain, &a, false, &err), PM_OK);
	if (pm_exr_read_attrs(path, &b, &back, &err) != PM_OK)
		fail_msg("%s", err.msg);
	assert_int_equal(back.n, at.n);
	for (i = 0; i < at.n; i++) {
		assert_string_equal(back.v[i].name, at.v[i].name);
		assert_string_equal(back.v[i].value, at.v[i].value);
	}
	assert_int_equal(pm_exr_read_attrs(plain, &c, NULL, &err), PM_OK);
	assert_int_equal(b.width, c.width);
	assert_int_equal(b.height, c.height);
	assert_memory_equal(b.rgb, c.rgb, sizeof(float) * 3 * 9 * 40);
	assert_memory_equal(a.rgb, b.rgb, sizeof(float) * 3 * 9 * 40);
	pm_image_free(&b);
	pm_image_free(&c);

	/* A file without them reads as none, emptying what was there. */
	assert_int_equal(pm_exr_read_attrs(plain, NULL, &back, &err), PM_OK);
	assert_int_equal(back.n, 0);
	assert_null(back.v);
	/* The header alone. */
	assert_int_equal(pm_exr_read_attrs(path, NULL, &back, &err), PM_OK);
	assert_int_equal(back.n, 4);
	assert_string_equal(pm_exr_attrs_get(&back, "pm-render.command"),
	    values[1]);
	pm_exr_attrs_free(&back);
	assert_int_equal(back.n, 0);
	unlink(plain);

	/* Not an image: an error, and no attributes. */
	assert_int_equal(pm_exr_attrs_set(&back, "x", "y", &err), PM_OK);
	path_in_tmp(plain, sizeof(plain), "text.exr");
	copy_prefix(path, plain, 100);
	assert_int_not_equal(pm_exr_read_attrs(plain, NULL, &back, &err),
	    PM_OK);
	assert_int_equal(back.n, 0);
	unlink(plain);

	/* "compression" is a header attribute of another type. */
	unlink(path);
	assert_int_equal(pm_exr_attrs_set(&at, "compression", "none", &err),
	    PM_OK);
	err.msg[0] = '\0';
	assert_int_not_equal(pm_exr_write_attrs(path, &a, false, &at, &err),
	    PM_OK);
	assert_non_null(strstr(err.msg, "attrs.exr"));
	assert_true(only_files("nothing", NULL));
	pm_exr_attrs_free(&at);
	pm_image_free(&a);
}

/*
 * Noise that does not compress, in chunks of a realistic width.  The
 * writer never uses ZIP because OpenEXRCore 3.1.5 corrupted one ZIP chunk
 * of a real render (data/caustics.xml, 96x96, 1024 spp, seed 5); float
 * files are now uncompressed and half ones PIZ, and this round trip of
 * float noise guards the writer's handling of data no codec shrinks.
 */
static void
test_exr_roundtrip_incompressible(void **state)
{
	struct pm_error err;
	struct pm_image a, b;
	char path[512];
	size_t i, n;
	uint32_t x = 12345;

	(void)state;
	path_in_tmp(path, sizeof(path), "noise.exr");
	assert_int_equal(pm_image_alloc(&a, 96, 96, &err), PM_OK);
	n = (size_t)a.width * a.height * 3;
	/* Random bits with the exponent kept finite: no byte pattern for
	 * zlib to find, so a chunk compresses to more than its raw size. */
	for (i = 0; i < n; i++) {
		uint32_t bits;

		x = x * 1664525u + 1013904223u;
		bits = (x ^ (x >> 13)) & 0xbfffffffu;
		memcpy(&a.rgb[i], &bits, sizeof(bits));
	}
	if (pm_exr_write(path, &a, false, &err) != PM_OK)
		fail_msg("%s", err.msg);
	if (pm_exr_read(path, &b, &err) != PM_OK)
		fail_msg("%s", err.msg);
	assert_memory_equal(a.rgb, b.rgb, sizeof(float) * n);
	pm_image_free(&a);
	pm_image_free(&b);
	unlink(path);
}

static void
test_exr_roundtrip_half(void **state)
{
	struct pm_error err;
	struct pm_image a, b;
	char path[512];
	size_t i, n;

	(void)state;
	rng_state = 12;
	path_in_tmp(path, sizeof(path), "half.exr");
	assert_int_equal(pm_image_alloc(&a, 31, 17, &err), PM_OK);
	n = (size_t)a.width * a.height * 3;
	/* Spread over the normal half range, 1e-3 to 1e4, both signs. */
	for (i = 0; i < n; i++)
		a.rgb[i] = (i % 5 == 0 ? -1.0f : 1.0f) *
		    powf(10.0f, -3.0f + 7.0f * rnd());
	assert_int_equal(pm_exr_write(path, &a, true, &err), PM_OK);
	if (pm_exr_read(path, &b, &err) != PM_OK)
		fail_msg("%s", err.msg);
	assert_int_equal(b.width, 31);
	assert_int_equal(b.height, 17);
	for (i = 0; i < n; i++) {
		/* Half keeps 11 significant bits: rounding is within 2^-11. */
		if (fabsf(b.rgb[i] - a.rgb[i]) > fabsf(a.rgb[i]) * 0x1p-11f)
			fail_msg("%zu: %.9g read back as %.9g", i, a.rgb[i],
			    b.rgb[i]);
	}
	/* A half file is smaller than the float one would be. */
	assert_true(file_size(path) < (long)(n * 4));
	pm_image_free(&a);
	pm_image_free(&b);
	unlink(path);
}

/*
 * Writes an image straight through OpenEXRCore, with the channel names,
 * pixel type and storage the test asks for, so that the reader meets files
 * pm itself would not write.  Each channel holds value(x, y, channel).
 */
static float
probe_value(int x, int y, int ch)
{
	return (float)(x + 100 * y + 10000 * ch);
}

static void
write_custom(const char *path, const char **names, int nch,
    exr_pixel_type_t type, int tiled, int w, int h, int ox, int oy)
{
	exr_attr_box2i_t dw;
	exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
	exr_context_t ctxt;
	exr_encode_pipeline_t enc = EXR_ENCODE_PIPELINE_INITIALIZER;
	exr_chunk_info_t cinfo;
	uint32_t *u = malloc(sizeof(uint32_t) * (size_t)w * h * nch);
	float *f = malloc(sizeof(float) * (size_t)w * h * nch);
	int part, c, x, y, started = 0;
	int tx, ty, ntx, nty, tile = 8;

	assert_non_null(u);
	assert_non_null(f);
	for (y = 0; y < h; y++)
	for (x = 0; x < w; x++)
	for (c = 0; c < nch; c++) {
		size_t i = ((size_t)y * w + x) * nch + c;

		f[i] = probe_value(x, y, c);
		u[i] = (uint32_t)f[i];
	}
	assert_int_equal(exr_start_write(&ctxt, path, EXR_WRITE_FILE_DIRECTLY,
	    &init), EXR_ERR_SUCCESS);
	assert_int_equal(exr_add_part(ctxt, "p", tiled ? EXR_STORAGE_TILED :
	    EXR_STORAGE_SCANLINE, &part), EXR_ERR_SUCCESS);
	assert_int_equal(exr_initialize_required_attr_simple(ctxt, part, w, h,
	    EXR_COMPRESSION_ZIPS), EXR_ERR_SUCCESS);
	/* A data window away from the origin: the reader must place
	 * pixels relative to it. */
	dw.min.x = ox;
	dw.min.y = oy;
	dw.max.x = ox + w - 1;
	dw.max.y = oy + h - 1;
	assert_int_equal(exr_set_data_window(ctxt, part, &dw), EXR_ERR_SUCCESS);
	if (tiled)
		assert_int_equal(exr_set_tile_descriptor(ctxt, part, tile,
		    tile, EXR_TILE_ONE_LEVEL, EXR_TILE_ROUND_DOWN),
		    EXR_ERR_SUCCESS);
	for (c = 0; c < nch; c++)
		assert_int_equal(exr_add_channel(ctxt, part, names[c], type,
		    EXR_PERCEPTUALLY_LINEAR, 1, 1), EXR_ERR_SUCCESS);
	assert_int_equal(exr_write_header(ctxt), EXR_ERR_SUCCESS);

	ntx = tiled ? (w + tile - 1) / tile : 1;
	nty = tiled ? (h + tile - 1) / tile : h;
	for (ty = 0; ty < nty; ty++)
	for (tx = 0; tx < ntx; tx++) {
		int k;

		if (tiled)
			assert_int_equal(exr_write_tile_chunk_info(ctxt, part,
			    tx, ty, 0, 0, &cinfo), EXR_ERR_SUCCESS);
		else
			assert_int_equal(exr_write_scanline_chunk_info(ctxt,
			    part, oy + ty, &cinfo), EXR_ERR_SUCCESS);
		if (started)
			assert_int_equal(exr_encoding_update(ctxt, part,
			    &cinfo, &enc), EXR_ERR_SUCCESS);
		else
			assert_int_equal(exr_encoding_initialize(ctxt, part,
			    &cinfo, &enc), EXR_ERR_SUCCESS);
		for (k = 0; k < enc.channel_count; k++) {
			exr_coding_channel_info_t *ch = &enc.channels[k];
			int x0 = tiled ? tx * tile : 0;
			int y0 = tiled ? ty * tile : cinfo.start_y - oy;
			size_t at;

			for (c = 0; c < nch; c++)
				if (strcmp(ch->channel_name, names[c]) == 0)
					break;
			assert_true(c < nch);
			at = ((size_t)y0 * w + x0) * nch + c;
			ch->user_pixel_stride = 4 * nch;
			ch->user_line_stride = 4 * nch * w;
			if (type == EXR_PIXEL_UINT) {
				ch->user_data_type = EXR_PIXEL_UINT;
				ch->encode_from_ptr = (const uint8_t *)(u + at);
			} else {
				ch->user_data_type = EXR_PIXEL_FLOAT;
				ch->encode_from_ptr = (const uint8_t *)(f + at);
			}
			ch->user_bytes_per_element = 4;
		}
		if (!started)
			assert_int_equal(exr_encoding_choose_default_routines(
			    ctxt, part, &enc), EXR_ERR_SUCCESS);
		started = 1;
		assert_int_equal(exr_encoding_run(ctxt, part, &enc),
		    EXR_ERR_SUCCESS);
	}
	exr_encoding_destroy(ctxt, &enc);
	assert_int_equal(exr_finish(&ctxt), EXR_ERR_SUCCESS);
	free(u);
	free(f);
}

/* R, G and B are found by name among other channels, in any pixel type,
 * in scanline and tiled files alike. */
static void
test_exr_read_variants(void **state)
{
	static const char *names[] = { "A", "B", "G", "R", "Z" };
	static const exr_pixel_type_t types[] = {
		EXR_PIXEL_FLOAT, EXR_PIXEL_HALF, EXR_PIXEL_UINT,
	};
	struct pm_error err;
	struct pm_image im;
	char path[512];
	size_t t;
	int tiled, x, y;
	const int w = 19, h = 13;

	(void)state;
	path_in_tmp(path, sizeof(path), "variant.exr");
	for (t = 0; t < 3; t++)
	for (tiled = 0; tiled < 2; tiled++) {
		write_custom(path, names, 5, types[t], tiled, w, h, 3, -5);
		if (pm_exr_read(path, &im, &err) != PM_OK)
			fail_msg("type %zu tiled %d: %s", t, tiled, err.msg);
		assert_int_equal(im.width, w);
		assert_int_equal(im.height, h);
		for (y = 0; y < h; y++)
		for (x = 0; x < w; x++) {
			const float *p = im.rgb + ((size_t)y * w + x) * 3;
			/* Values up to 3e4 are exact in float and uint;
			 * half keeps them to within 2^-11. */
			float tol = types[t] == EXR_PIXEL_HALF ?
			    4e4f * 0x1p-11f : 0.0f;

			if (fabsf(p[0] - probe_value(x, y, 3)) > tol ||
			    fabsf(p[1] - probe_value(x, y, 2)) > tol ||
			    fabsf(p[2] - probe_value(x, y, 1)) > tol)
				fail_msg("type %zu tiled %d (%d, %d): %g %g %g",
				    t, tiled, x, y, p[0], p[1], p[2]);
		}
		pm_image_free(&im);
	}
	unlink(path);
}

static void
test_exr_missing_channel(void **state)
{
	static const char *names[] = { "G", "R" };
	static const char *gray[] = { "Y" };
	struct pm_error err;
	struct pm_image im;
	char path[512];

	(void)state;
	path_in_tmp(path, sizeof(path), "rg.exr");
	write_custom(path, names, 2, EXR_PIXEL_FLOAT, 0, 4, 4, 0, 0);
	err.msg[0] = '\0';
	assert_int_equal(pm_exr_read(path, &im, &err), PM_ERR_FORMAT);
	assert_null(im.rgb);
	assert_non_null(strstr(err.msg, "rg.exr"));
	assert_non_null(strstr(err.msg, "channel B"));

	write_custom(path, gray, 1, EXR_PIXEL_HALF, 1, 4, 4, 0, 0);
	assert_int_equal(pm_exr_read(path, &im, &err), PM_ERR_FORMAT);
	assert_null(im.rgb);
	assert_non_null(strstr(err.msg, "channel R"));
	unlink(path);
}

/* Every prefix of a valid file shorter than the whole must be refused,
 * with the file named and nothing allocated. */
static void
test_exr_truncated(void **state)
{
	struct pm_error err;
	struct pm_image a, b;
	char path[512], cut[512];
	long size, len;

	(void)state;
	rng_state = 5;
	path_in_tmp(path, sizeof(path), "whole.exr");
	path_in_tmp(cut, sizeof(cut), "cut.exr");
	assert_int_equal(pm_image_alloc(&a, 16, 40, &err), PM_OK);
	fill_random(&a, 0.0f, 1.0f);
	assert_int_equal(pm_exr_write(path, &a, false, &err), PM_OK);
	size = file_size(path);
	assert_true(size > 1000);
	for (len = 0; len < size; len += (len < 400 ? 7 : 97)) {
		copy_prefix(path, cut, len);
		err.msg[0] = '\0';
		if (pm_exr_read(cut, &b, &err) == PM_OK)
			fail_msg("a file cut to %ld of %ld bytes was accepted",
			    len, size);
		assert_null(b.rgb);
		assert_non_null(strstr(err.msg, "cut.exr"));
	}
	/* One byte short still fails. */
	copy_prefix(path, cut, size - 1);
	assert_int_not_equal(pm_exr_read(cut, &b, &err), PM_OK);
	pm_image_free(&a);
	unlink(path);
	unlink(cut);
}

/* Flipped bits anywhere may be accepted or refused, but must never crash
 * or leak (ASan and UBSan watch this). */
static void
test_exr_bitflips(void **state)
{
	struct pm_error err;
	struct pm_image a, b;
	char path[512], bad[512];
	unsigned char *buf;
	long size, i;
	FILE *fp;

	(void)state;
	rng_state = 6;
	path_in_tmp(path, sizeof(path), "flip-src.exr");
	path_in_tmp(bad, sizeof(bad), "flip.exr");
	assert_int_equal(pm_image_alloc(&a, 12, 20, &err), PM_OK);
	fill_random(&a, 0.0f, 1.0f);
	assert_int_equal(pm_exr_write(path, &a, true, &err), PM_OK);
	size = file_size(path);
	buf = malloc((size_t)size);
	assert_non_null(buf);
	fp = fopen(path, "rb");
	assert_non_null(fp);
	assert_int_equal(fread(buf, 1, (size_t)size, fp), (size_t)size);
	fclose(fp);
	for (i = 0; i < 300; i++) {
		long at = (long)(rnd() * size);
		unsigned char bit = (unsigned char)(1u << (int)(rnd() * 8));

		buf[at] ^= bit;
		fp = fopen(bad, "wb");
		assert_non_null(fp);
		assert_int_equal(fwrite(buf, 1, (size_t)size, fp),
		    (size_t)size);
		assert_int_equal(fclose(fp), 0);
		if (pm_exr_read(bad, &b, &err) == PM_OK)
			pm_image_free(&b);
		else
			assert_null(b.rgb);
		buf[at] ^= bit;
	}
	free(buf);
	pm_image_free(&a);
	unlink(path);
	unlink(bad);
}

static void
test_exr_not_exr(void **state)
{
	struct pm_error err;
	struct pm_image im;
	char path[512];
	FILE *fp;

	(void)state;
	path_in_tmp(path, sizeof(path), "text.exr");
	fp = fopen(path, "w");
	assert_non_null(fp);
	fputs("P3\n2 2\n255\nthis is not an OpenEXR file at all\n", fp);
	assert_int_equal(fclose(fp), 0);
	err.msg[0] = '\0';
	assert_int_not_equal(pm_exr_read(path, &im, &err), PM_OK);
	assert_null(im.rgb);
	assert_non_null(strstr(err.msg, "text.exr"));
	unlink(path);

	path_in_tmp(path, sizeof(path), "no-such-file.exr");
	assert_int_equal(pm_exr_read(path, &im, &err), PM_ERR_IO);
	assert_null(im.rgb);
	assert_non_null(strstr(err.msg, "no-such-file.exr"));

	/* A directory is not a file either. */
	assert_int_not_equal(pm_exr_read(pm_test_dir, &im, &err), PM_OK);
	assert_null(im.rgb);
}

static void
test_write_failures(void **state)
{
	struct pm_error err;
	struct pm_image a;
	char path[512];
	uint8_t rgb[3 * 4] = { 0 };

	(void)state;
	assert_int_equal(pm_image_alloc(&a, 2, 2, &err), PM_OK);
	path_in_tmp(path, sizeof(path), "missing-dir/out.exr");
	assert_int_equal(pm_exr_write(path, &a, false, &err), PM_ERR_IO);
	assert_non_null(strstr(err.msg, "out.exr"));
	path_in_tmp(path, sizeof(path), "missing-dir/out.png");
	assert_int_equal(pm_png_write(path, rgb, 2, 2, &err), PM_ERR_IO);
	assert_non_null(strstr(err.msg, "out.png"));
	pm_image_free(&a);
}

/* The PNG decodes, through libpng's own reader, to the bytes written. */
static void
test_png_roundtrip(void **state)
{
	struct pm_error err;
	png_image img;
	char path[512];
	uint8_t rgb[3 * 21 * 10], back[3 * 21 * 10];
	size_t i;

	(void)state;
	rng_state = 9;
	for (i = 0; i < sizeof(rgb); i++)
		rgb[i] = (uint8_t)(rnd() * 256);
	path_in_tmp(path, sizeof(path), "out.png");
	if (pm_png_write(path, rgb, 21, 10, &err) != PM_OK)
		fail_msg("%s", err.msg);
	assert_true(only_files("out.png", NULL));
	memset(&img, 0, sizeof(img));
	img.version = PNG_IMAGE_VERSION;
	assert_true(png_image_begin_read_from_file(&img, path));
	assert_int_equal(img.width, 21);
	assert_int_equal(img.height, 10);
	img.format = PNG_FORMAT_RGB;
	assert_true(png_image_finish_read(&img, NULL, back, 0, NULL));
	assert_memory_equal(rgb, back, sizeof(rgb));
	unlink(path);
}

int
main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_filter_parse),
		cmocka_unit_test(test_downsample_constant),
		cmocka_unit_test(test_downsample_box_is_block_mean),
		cmocka_unit_test(test_downsample_ramp),
		cmocka_unit_test(test_downsample_factor1),
		cmocka_unit_test(test_downsample_errors),
		cmocka_unit_test(test_accumulate_mean),
		cmocka_unit_test(test_srgb),
		cmocka_unit_test(test_exr_roundtrip_float),
		cmocka_unit_test(test_exr_roundtrip_incompressible),
		cmocka_unit_test(test_exr_roundtrip_half),
		cmocka_unit_test(test_exr_attributes),
		cmocka_unit_test(test_exr_layers),
		cmocka_unit_test(test_exr_read_variants),
		cmocka_unit_test(test_exr_missing_channel),
		cmocka_unit_test(test_exr_truncated),
		cmocka_unit_test(test_exr_bitflips),
		cmocka_unit_test(test_exr_not_exr),
		cmocka_unit_test(test_write_failures),
		cmocka_unit_test(test_png_roundtrip),
	};

	return cmocka_run_group_tests(tests, pm_tmpdir_setup, pm_tmpdir_teardown);
}
