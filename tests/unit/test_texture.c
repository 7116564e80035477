/*
 * test_texture.c: textures against what they must return.
 *
 * Bitmaps written here (PNG, JPEG, OpenEXR) read back texel for texel at
 * the texel centres; bilinear interpolation, nearest lookups and the three
 * wrap modes against their definitions; sRGB decoding against the
 * formula; the checkerboard's pattern and to_uv; the uv of a hit on the
 * built-in shapes; the scene loader's textured BSDFs; a furnace: a
 * checkerboard sphere under uniform light reflects, at each point, its
 * reflectance there times the light; and photons: off a floor white on
 * one half and black on the other, every photon that bounced came from
 * the white half.
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
#include <jpeglib.h>
#include <png.h>

#include "../../common/image.h"
#include "../../common/integrator.h"
#include "../../common/rng.h"
#include "../../common/shoot.h"
#include "../../common/texture.h"
#include "../../common/world.h"
#include "../../formats/exr.h"
#include "../../formats/png.h"
#include "../../formats/scene_xml.h"
#include "../../formats/texture.h"
#include "tmpdir.h"

#define assert_near(a, b, tol) do {					\
	double a_ = (a), b_ = (b);					\
	if (!(fabs(a_ - b_) <= (tol)))					\
		fail_msg("%s = %.9g, expected %.9g within %g", #a,	\
		    a_, b_, (double)(tol));				\
} while (0)

static void
path_of(char *buf, size_t n, const char *name)
{
	snprintf(buf, n, "%s/%s", pm_test_dir, name);
}

/* The sRGB curve's inverse, from IEC 61966-2-1, in double. */
static double
srgb_decode(double c)
{
	return c <= 0.04045 ? c / 12.92 : pow((c + 0.055) / 1.055, 2.4);
}

static void
assert_rgb_near(struct pm_rgb got, double r, double g, double b, double tol)
{
	assert_near(got.r, r, tol);
	assert_near(got.g, g, tol);
	assert_near(got.b, b, tol);
}

/* A 5 x 3 image whose every byte differs: byte (x, y, c). */
static uint8_t
pattern_byte(int x, int y, int c)
{
	return (uint8_t)(17 * x + 61 * y + 89 * c + 3);
}

/* The 8-bit PNG reads back texel for texel at the texel centres, decoded
 * by the sRGB formula, and undecoded with raw. */
static void
test_png_round_trip(void **state)
{
	enum { W = 5, H = 3 };
	uint8_t px[3 * W * H];
	struct pm_texture t, r;
	struct pm_error err;
	char path[256];
	int x, y, c;

	(void)state;
	for (y = 0; y < H; y++)
		for (x = 0; x < W; x++)
			for (c = 0; c < 3; c++)
				px[3 * (y * W + x) + c] = pattern_byte(x, y, c);
	path_of(path, sizeof(path), "p.png");
	assert_int_equal(pm_png_write(path, px, W, H, &err), PM_OK);
	pm_texture_init(&t, PM_TEXTURE_BITMAP);
	pm_texture_init(&r, PM_TEXTURE_BITMAP);
	assert_int_equal(pm_bitmap_read(path, false, &t, &err), PM_OK);
	assert_int_equal(pm_bitmap_read(path, true, &r, &err), PM_OK);
	assert_int_equal(t.width, W);
	assert_int_equal(t.height, H);
	for (y = 0; y < H; y++)
		for (x = 0; x < W; x++) {
			float u = (x + 0.5f) / W, v = (y + 0.5f) / H;

			assert_rgb_near(pm_texture_eval(&t, u, v),
			    srgb_decode(pattern_byte(x, y, 0) / 255.0),
			    srgb_decode(pattern_byte(x, y, 1) / 255.0),
			    srgb_decode(pattern_byte(x, y, 2) / 255.0), 2e-6);
			assert_rgb_near(pm_texture_eval(&r, u, v),
			    pattern_byte(x, y, 0) / 255.0,
			    pattern_byte(x, y, 1) / 255.0,
			    pattern_byte(x, y, 2) / 255.0, 1e-6);
		}
	/* both branches of the curve, and its ends */
	assert_near(pm_srgb_to_linear(0.0f), 0.0, 0.0);
	assert_near(pm_srgb_to_linear(1.0f), 1.0, 1e-6);
	assert_near(pm_srgb_to_linear(0.04f), 0.04 / 12.92, 1e-8);
	assert_near(pm_srgb_to_linear(0.5f), srgb_decode(0.5), 1e-6);
	pm_texture_free(&t);
	pm_texture_free(&r);
}

/* A 16-bit PNG: its samples sRGB-decoded as the 8-bit ones are (as
 * Mitsuba reads PNG), at 16 bits' precision. */
static void
test_png16(void **state)
{
	static const uint16_t px[3 * 2] = {32768, 16384, 65535, 0, 1000, 50000};
	png_image im;
	struct pm_texture t;
	struct pm_error err;
	char path[256];
	int i;

	(void)state;
	path_of(path, sizeof(path), "p16.png");
	memset(&im, 0, sizeof(im));
	im.version = PNG_IMAGE_VERSION;
	im.width = 2;
	im.height = 1;
	im.format = PNG_FORMAT_LINEAR_RGB;
	assert_true(png_image_write_to_file(&im, path, 0, px, 0, NULL));
	pm_texture_init(&t, PM_TEXTURE_BITMAP);
	assert_int_equal(pm_bitmap_read(path, false, &t, &err), PM_OK);
	assert_int_equal(t.width, 2);
	for (i = 0; i < 6; i++)
		assert_near(t.rgb[i], srgb_decode(px[i] / 65535.0), 2e-6);
	assert_int_equal(pm_bitmap_read(path, true, &t, &err), PM_OK);
	for (i = 0; i < 6; i++)
		assert_near(t.rgb[i], px[i] / 65535.0, 1e-7);
	pm_texture_free(&t);
}

/* OpenEXR is linear: floats come back exactly, raw or not. */
static void
test_exr_round_trip(void **state)
{
	struct pm_image im;
	struct pm_texture t;
	struct pm_error err;
	char path[256];
	int i, x, y;

	(void)state;
	assert_int_equal(pm_image_alloc(&im, 4, 2, &err), PM_OK);
	for (i = 0; i < 3 * 4 * 2; i++)
		im.rgb[i] = 0.1f * (float)i + 0.03125f;
	path_of(path, sizeof(path), "e.exr");
	assert_int_equal(pm_exr_write(path, &im, false, &err), PM_OK);
	pm_texture_init(&t, PM_TEXTURE_BITMAP);
	t.nearest = true;
	assert_int_equal(pm_bitmap_read(path, false, &t, &err), PM_OK);
	for (y = 0; y < 2; y++)
		for (x = 0; x < 4; x++) {
			const float *p = &im.rgb[3 * (y * 4 + x)];

			assert_rgb_near(pm_texture_eval(&t, (x + 0.5f) / 4,
			    (y + 0.5f) / 2), p[0], p[1], p[2], 0.0);
		}
	pm_texture_free(&t);
	pm_image_free(&im);
}

enum { JW = 32, JH = 16 };
static const uint8_t jpeg_col[2][3] = {{200, 40, 90}, {30, 160, 250}};

/* Writes a JW x JH JPEG: the left half jpeg_col[0], the right jpeg_col[1]. */
static void
write_jpeg(const char *path)
{
	struct jpeg_compress_struct cj;
	struct jpeg_error_mgr jerr;
	uint8_t row[3 * JW];
	JSAMPROW rp = row;
	FILE *fp;
	int x, c;

	fp = fopen(path, "wb");
	assert_non_null(fp);
	cj.err = jpeg_std_error(&jerr);
	jpeg_create_compress(&cj);
	jpeg_stdio_dest(&cj, fp);
	cj.image_width = JW;
	cj.image_height = JH;
	cj.input_components = 3;
	cj.in_color_space = JCS_RGB;
	jpeg_set_defaults(&cj);
	jpeg_set_quality(&cj, 100, TRUE);
	jpeg_start_compress(&cj, TRUE);
	for (x = 0; x < JW; x++)
		for (c = 0; c < 3; c++)
			row[3 * x + c] = jpeg_col[x >= JW / 2][c];
	while (cj.next_scanline < cj.image_height)
		jpeg_write_scanlines(&cj, &rp, 1);
	jpeg_finish_compress(&cj);
	jpeg_destroy_compress(&cj);
	assert_int_equal(fclose(fp), 0);
}

/* A JPEG of flat colour blocks: lossy, but a block's middle comes back
 * within a few levels, decoded by the sRGB formula. */
static void
test_jpeg(void **state)
{
	enum { W = JW, H = JH };
	const uint8_t (*col)[3] = jpeg_col;
	struct pm_texture t;
	struct pm_error err;
	char path[256];
	int b, c;

	(void)state;
	path_of(path, sizeof(path), "j.jpg");
	write_jpeg(path);

	pm_texture_init(&t, PM_TEXTURE_BITMAP);
	assert_int_equal(pm_bitmap_read(path, false, &t, &err), PM_OK);
	assert_int_equal(t.width, W);
	assert_int_equal(t.height, H);
	for (b = 0; b < 2; b++) {
		/* the middle of each 16 x 16 block */
		struct pm_rgb v = pm_texture_eval(&t, (b * 16 + 8.0f) / W, 0.5f);
		const float *cv = &v.r;

		for (c = 0; c < 3; c++)
			assert_near(cv[c], srgb_decode(col[b][c] / 255.0),
			    srgb_decode(col[b][c] / 255.0) * 0.04 + 0.002);
	}
	pm_texture_free(&t);
}

/* A 3 x 2 linear texture, set by hand. */
static void
small_texture(struct pm_texture *t)
{
	int i;

	pm_texture_init(t, PM_TEXTURE_BITMAP);
	t->width = 3;
	t->height = 2;
	t->rgb = malloc(3 * 6 * sizeof(float));
	assert_non_null(t->rgb);
	for (i = 0; i < 6; i++) {
		t->rgb[3 * i] = (float)i;		/* texel index */
		t->rgb[3 * i + 1] = (float)(i % 3);	/* column */
		t->rgb[3 * i + 2] = (float)(i / 3);	/* row */
	}
}

/* Reads path's first n bytes, with byte flip (if < n) inverted, back
 * into a file of its own; returns its name in out. */
static void
damaged_copy(const char *path, size_t n, long flip, char *out, size_t len)
{
	static uint8_t buf[1 << 16];
	FILE *f = fopen(path, "rb");
	size_t got;

	assert_non_null(f);
	got = fread(buf, 1, sizeof(buf), f);
	fclose(f);
	assert_true(got < sizeof(buf));
	if (n > got)
		n = got;
	if (flip >= 0 && (size_t)flip < n)
		buf[flip] ^= 0xff;
	snprintf(out, len, "%s.bad", path);
	f = fopen(out, "wb");
	assert_non_null(f);
	assert_int_equal(fwrite(buf, 1, n, f), n);
	assert_int_equal(fclose(f), 0);
}

/* Damaged bitmaps: every truncation of a PNG, JPEG and OpenEXR file
 * before its end marker (PNG's 12-byte IEND chunk, JPEG's 2-byte EOI,
 * after which the image is whole) fails with a message naming the file
 * and leaves the texture as it was; flipped bytes never crash (a JPEG may
 * still decode to something). */
static void
test_damaged_files(void **state)
{
	static const uint8_t px[3 * 4] = {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11,
	    12};
	struct pm_image im;
	struct pm_texture t;
	struct pm_error err;
	char files[3][256], bad[300];
	static const long tail[3] = {12, 2, 0};
	long size, n, flip;
	int k;
	FILE *f;

	(void)state;
	path_of(files[0], sizeof(files[0]), "d.png");
	path_of(files[1], sizeof(files[1]), "d.jpg");
	path_of(files[2], sizeof(files[2]), "d.exr");
	assert_int_equal(pm_png_write(files[0], px, 2, 2, &err), PM_OK);
	write_jpeg(files[1]);
	assert_int_equal(pm_image_alloc(&im, 3, 2, &err), PM_OK);
	memset(im.rgb, 0, 3 * 6 * sizeof(float));
	assert_int_equal(pm_exr_write(files[2], &im, false, &err), PM_OK);
	pm_image_free(&im);
	pm_texture_init(&t, PM_TEXTURE_BITMAP);
	for (k = 0; k < 3; k++) {
		f = fopen(files[k], "rb");
		assert_non_null(f);
		assert_int_equal(fseek(f, 0, SEEK_END), 0);
		size = ftell(f);
		fclose(f);
		for (n = 0; n < size - tail[k]; n += n < 64 ? 1 : 7) {
			damaged_copy(files[k], (size_t)n, -1, bad, sizeof(bad));
			memset(&err, 0, sizeof(err));
			if (pm_bitmap_read(bad, false, &t, &err) == PM_OK)
				fail_msg("%s cut to %ld of %ld bytes: read", files[k],
				    n, size);
			assert_non_null(strstr(err.msg, bad));
			assert_null(t.rgb);
		}
		for (flip = 0; flip < size; flip += 3) {
			damaged_copy(files[k], (size_t)size, flip, bad, sizeof(bad));
			if (pm_bitmap_read(bad, false, &t, &err) == PM_OK)
				pm_texture_free(&t);
		}
	}
}

/* Bilinear weights: the lookup at any point is the weighted mean of the
 * four texels around it, weights by the distances to their centres. */
static void
test_bilinear(void **state)
{
	struct pm_texture t;
	struct pm_rgb c;

	(void)state;
	small_texture(&t);
	/* at texel centres: the texel */
	c = pm_texture_eval(&t, 1.5f / 3, 0.5f / 2);
	assert_rgb_near(c, 1, 1, 0, 1e-6);
	/* a quarter of the way from texel (0,0) to (1,1) in both
	 * directions: x = 0.75 texels, y = 0.75 */
	c = pm_texture_eval(&t, 0.75f / 3, 0.75f / 2);
	assert_near(c.r, 0.75 * 0.75 * 0 + 0.25 * 0.75 * 1 +
	    0.75 * 0.25 * 3 + 0.25 * 0.25 * 4, 1e-5);
	assert_near(c.g, 0.25, 1e-5);	/* the column, linearly */
	assert_near(c.b, 0.25, 1e-5);	/* the row, linearly */
	/* nearest: the texel the point falls in */
	t.nearest = true;
	c = pm_texture_eval(&t, 0.99f / 3, 1.01f / 2);
	assert_rgb_near(c, 3, 0, 1, 0.0);
	c = pm_texture_eval(&t, 2.5f / 3, 0.2f / 2);
	assert_rgb_near(c, 2, 2, 0, 0.0);
	pm_texture_free(&t);
}

/* The wrap modes, on the column channel (g), with nearest and bilinear
 * lookups outside [0, 1]. */
static void
test_wrap_modes(void **state)
{
	struct pm_texture t;
	float u;

	(void)state;
	small_texture(&t);
	t.nearest = true;
	/* repeat: period 1 */
	t.wrap = PM_WRAP_REPEAT;
	for (u = -2.9f; u < 3.0f; u += 0.37f)
		assert_near(pm_texture_eval(&t, u, 0.25f).g,
		    pm_texture_eval(&t, u - floorf(u), 0.25f).g, 0.0);
	assert_near(pm_texture_eval(&t, -0.1f, 0.25f).g, 2, 0.0);
	assert_near(pm_texture_eval(&t, 1.1f, 0.25f).g, 0, 0.0);
	/* mirror: columns 0 1 2 | 2 1 0 | 0 1 2 ... and backwards */
	t.wrap = PM_WRAP_MIRROR;
	assert_near(pm_texture_eval(&t, 1.1f, 0.25f).g, 2, 0.0);
	assert_near(pm_texture_eval(&t, 1.5f, 0.25f).g, 1, 0.0);
	assert_near(pm_texture_eval(&t, 1.9f, 0.25f).g, 0, 0.0);
	assert_near(pm_texture_eval(&t, 2.1f, 0.25f).g, 0, 0.0);
	assert_near(pm_texture_eval(&t, -0.1f, 0.25f).g, 0, 0.0);
	assert_near(pm_texture_eval(&t, -0.9f, 0.25f).g, 2, 0.0);
	/* clamp: the edge texel outwards */
	t.wrap = PM_WRAP_CLAMP;
	assert_near(pm_texture_eval(&t, 7.0f, 0.25f).g, 2, 0.0);
	assert_near(pm_texture_eval(&t, -7.0f, 0.25f).g, 0, 0.0);
	assert_near(pm_texture_eval(&t, 0.5f, 9.0f).b, 1, 0.0);
	/* non-finite coordinates give some texel, never a crash */
	(void)pm_texture_eval(&t, NAN, INFINITY);

	/* bilinear at u = 0: half of column 0 and half of the column the
	 * wrap puts before it */
	t.nearest = false;
	t.wrap = PM_WRAP_REPEAT;
	assert_near(pm_texture_eval(&t, 0.0f, 0.25f).g, 0.5 * (0 + 2), 1e-6);
	t.wrap = PM_WRAP_MIRROR;
	assert_near(pm_texture_eval(&t, 0.0f, 0.25f).g, 0.0, 1e-6);
	t.wrap = PM_WRAP_CLAMP;
	assert_near(pm_texture_eval(&t, 1.0f, 0.25f).g, 2.0, 1e-6);
	t.wrap = PM_WRAP_REPEAT;
	assert_near(pm_texture_eval(&t, 1.0f, 0.25f).g, 0.5 * (2 + 0), 1e-6);
	pm_texture_free(&t);
}

/* Mitsuba's checkerboard: color0 where u and v are both in the lower or
 * both in the upper half of their unit cell; to_uv applies first. */
static void
test_checkerboard(void **state)
{
	struct pm_texture t;
	struct pm_rgb m;

	(void)state;
	pm_texture_init(&t, PM_TEXTURE_CHECKERBOARD);
	assert_rgb_near(t.color0, 0.4, 0.4, 0.4, 1e-7);	/* Mitsuba's defaults */
	assert_rgb_near(t.color1, 0.2, 0.2, 0.2, 1e-7);
	t.color0 = pm_rgb(1, 0, 0);
	t.color1 = pm_rgb(0, 0, 1);
	assert_rgb_near(pm_texture_eval(&t, 0.25f, 0.25f), 1, 0, 0, 0);
	assert_rgb_near(pm_texture_eval(&t, 0.75f, 0.25f), 0, 0, 1, 0);
	assert_rgb_near(pm_texture_eval(&t, 0.25f, 0.75f), 0, 0, 1, 0);
	assert_rgb_near(pm_texture_eval(&t, 0.75f, 0.75f), 1, 0, 0, 0);
	assert_rgb_near(pm_texture_eval(&t, -0.25f, 0.25f), 0, 0, 1, 0);
	assert_rgb_near(pm_texture_eval(&t, 3.25f, -5.25f), 0, 0, 1, 0);
	/* the boundary 1/2 belongs to the lower half */
	assert_rgb_near(pm_texture_eval(&t, 0.5f, 0.25f), 1, 0, 0, 0);
	/* to_uv: scale 4 in u and shift v by 1/2 */
	t.to_uv[0] = 4.0f;
	t.to_uv[5] = 0.5f;
	assert_rgb_near(pm_texture_eval(&t, 0.2f, 0.25f), 1, 0, 0, 0);
	assert_rgb_near(pm_texture_eval(&t, 0.1f, 0.25f), 0, 0, 1, 0);
	assert_rgb_near(pm_texture_eval(&t, 0.1f, 0.75f), 1, 0, 0, 0);
	m = pm_texture_mean(&t);
	assert_rgb_near(m, 0.5, 0, 0.5, 0);
}

/* Mitsuba's uv on the built-in shapes. */
static void
test_hit_uv(void **state)
{
	struct pm_scene s;
	struct pm_error err;
	struct pm_hit h;
	float u, v;
	int sh;

	(void)state;
	pm_scene_init(&s);
	sh = pm_scene_add_shape(&s);
	s.shapes[sh].type = PM_SHAPE_MESH;
	assert_int_equal(pm_mesh_rectangle(&s.shapes[sh].mesh, &err), PM_OK);
	/* the rectangle: uv = ((x + 1) / 2, (y + 1) / 2) on both triangles */
	memset(&h, 0, sizeof(h));
	h.shape = sh;
	h.prim = 0;		/* vertices (-1,-1) (1,-1) (1,1) */
	h.u = 0.5f;		/* weights 0.25, 0.5, 0.25: (0.5, -0.5) */
	h.v = 0.25f;
	pm_hit_uv(&s, &h, &u, &v);
	assert_near(u, 0.75, 1e-6);
	assert_near(v, 0.25, 1e-6);
	h.prim = 1;		/* vertices (1,1) (-1,1) (-1,-1) */
	h.u = 0.25f;
	h.v = 0.5f;
	pm_hit_uv(&s, &h, &u, &v);
	assert_near(u, (0.25 * 1 + 0.25 * -1 + 0.5 * -1 + 1) / 2, 1e-6);
	assert_near(v, (0.25 * 1 + 0.25 * 1 + 0.5 * -1 + 1) / 2, 1e-6);
	/* a mesh without uv: the barycentrics */
	free(s.shapes[sh].mesh.uv);
	s.shapes[sh].mesh.uv = NULL;
	pm_hit_uv(&s, &h, &u, &v);
	assert_near(u, 0.25, 0.0);
	assert_near(v, 0.5, 0.0);

	/* the sphere: (phi / 2 pi, theta / pi) */
	sh = pm_scene_add_shape(&s);
	s.shapes[sh].type = PM_SHAPE_SPHERE;
	s.shapes[sh].center = pm_v3(1, 2, 3);
	s.shapes[sh].radius = 2.0f;
	h.shape = sh;
	h.p = pm_v3(1, 4, 3);			/* +y: phi = pi / 2 */
	pm_hit_uv(&s, &h, &u, &v);
	assert_near(u, 0.25, 1e-6);
	assert_near(v, 0.5, 1e-6);
	h.p = pm_v3(1 - sqrtf(2.0f), 2, 3 - sqrtf(2.0f));	/* phi = pi */
	pm_hit_uv(&s, &h, &u, &v);
	assert_near(u, 0.5, 1e-6);
	assert_near(v, 0.75, 1e-6);
	h.p = pm_v3(1, 2 - 2, 3);		/* -y: phi = 3 pi / 2 */
	pm_hit_uv(&s, &h, &u, &v);
	assert_near(u, 0.75, 1e-6);
	/* turned by 90 degrees about z (object x is world y): world +y is
	 * object +x, phi = 0 */
	s.shapes[sh].axes.s = pm_v3(0, 2, 0);
	s.shapes[sh].axes.t = pm_v3(-2, 0, 0);
	s.shapes[sh].axes.n = pm_v3(0, 0, 2);
	h.p = pm_v3(1, 4, 3);
	pm_hit_uv(&s, &h, &u, &v);
	assert_near(u, 0.0, 1e-6);
	h.p = pm_v3(-1, 2, 3);			/* world -x: object +y */
	pm_hit_uv(&s, &h, &u, &v);
	assert_near(u, 0.25, 1e-6);
	pm_scene_free(&s);
}

/* The loader's textured BSDFs: nested and by reference, shared, with the
 * BSDF holding the mean until a hit looks it up. */
static void
test_scene_textures(void **state)
{
	static const uint8_t px[3 * 4] = {255, 0, 0, 0, 255, 0, 0, 0, 255,
	    255, 255, 255};
	char path[256], xml[4096];
	struct pm_scene s;
	struct pm_error err;
	struct pm_bsdf tmp;
	const struct pm_bsdf *b;
	struct pm_hit h;

	(void)state;
	path_of(path, sizeof(path), "t.png");
	assert_int_equal(pm_png_write(path, px, 2, 2, &err), PM_OK);
	snprintf(xml, sizeof(xml),
	    "<scene version=\"3.0.0\">\n"
	    "<texture type=\"bitmap\" id=\"img\">"
	    "<string name=\"filename\" value=\"t.png\"/>"
	    "<string name=\"filter_type\" value=\"nearest\"/>"
	    "<string name=\"wrap_mode\" value=\"clamp\"/>"
	    "<boolean name=\"raw\" value=\"true\"/></texture>\n"
	    "<shape type=\"rectangle\"><bsdf type=\"diffuse\">"
	    "<texture name=\"reflectance\" type=\"checkerboard\">"
	    "<rgb name=\"color0\" value=\"0.8, 0.6, 0.4\"/>"
	    "<transform name=\"to_uv\"><scale x=\"2\" y=\"2\"/></transform>"
	    "</texture></bsdf></shape>\n"
	    "<shape type=\"rectangle\"><bsdf type=\"plastic\">"
	    "<ref name=\"diffuse_reflectance\" id=\"img\"/></bsdf></shape>\n"
	    "<shape type=\"rectangle\"><bsdf type=\"roughconductor\">"
	    "<ref name=\"specular_reflectance\" id=\"img\"/>"
	    "<texture name=\"alpha\" type=\"checkerboard\"/></bsdf></shape>\n"
	    "</scene>\n");
	memset(&err, 0, sizeof(err));
	if (pm_scene_load_string(xml, strlen(xml), "t.xml", pm_test_dir, NULL, 0,
	    &s, &err) != PM_OK)
		fail_msg("%s", err.msg);
	assert_int_equal(pm_scene_prepare(&s, &err), PM_OK);
	assert_int_equal(s.ntextures, 3);	/* img shared, built once */
	assert_int_equal(s.bsdfs[s.shapes[1].bsdf].tex_diffuse,
	    s.bsdfs[s.shapes[2].bsdf].tex_specular);
	/* diffuse: the checkerboard's mean until looked up */
	b = &s.bsdfs[s.shapes[0].bsdf];
	assert_true(b->tex_diffuse > 0);
	assert_rgb_near(b->diffuse, 0.5, 0.4, 0.3, 1e-6);
	memset(&h, 0, sizeof(h));
	h.shape = 0;
	h.prim = 0;
	h.u = 0.1f;		/* uv = (0.15, 0.05) */
	h.v = 0.05f;
	b = pm_bsdf_at(&s, &h, &tmp);
	assert_ptr_equal(b, &tmp);
	/* uv (0.15, 0.05) scaled by 2: (0.3, 0.1), both lower: color0 */
	assert_rgb_near(b->diffuse, 0.8, 0.6, 0.4, 1e-6);
	/* plastic: raw, nearest, clamped texels; v = 0 is the top row */
	h.shape = 1;
	h.u = 0.9f;		/* uv = (0.95, 0.05): texel (1, 0), green */
	h.v = 0.05f;
	b = pm_bsdf_at(&s, &h, &tmp);
	assert_rgb_near(b->diffuse, 0, 1, 0, 0.0);
	assert_int_equal(b->type, PM_BSDF_PLASTIC);
	/* the conductor: the same image, alpha the checkerboard (0.4 or
	 * 0.2, grey) read as Mitsuba 3's eval_1 reads it, with its two
	 * colours swapped: at uv (0.95, 0.05), where eval gives color1,
	 * alpha is color0 */
	h.shape = 2;
	b = pm_bsdf_at(&s, &h, &tmp);
	assert_rgb_near(b->specular, 0, 1, 0, 0.0);
	assert_near(b->alpha, 0.4, 1e-5);
	pm_scene_free(&s);
}

/* A checkerboard sphere (0.9 and 0.2 per channel pattern) inside a black
 * sphere emitting Le: at each point it reflects rho(uv) Le, in the path
 * tracer's mean over many samples of one ray. */
static void
test_furnace(void **state)
{
	struct pm_scene s;
	struct pm_world w;
	struct pm_render_ctx ctx;
	struct pm_error err;
	struct pm_texture t;
	int b, sh, l, k, i;
	const struct pm_rgb le = pm_rgb(1.0f, 2.0f, 0.5f);
	/* directions whose (u, v) under to_uv scale 4 lie mid-cell:
	 * phi = 22.5 or 67.5 degrees, theta = 78.75 degrees */
	const double phis[2] = {22.5, 67.5};
	const struct pm_rgb want[2] = {{0.2f, 0.5f, 0.7f}, {0.9f, 0.1f, 0.3f}};

	(void)state;
	pm_scene_init(&s);
	pm_texture_init(&t, PM_TEXTURE_CHECKERBOARD);
	t.color0 = want[1];
	t.color1 = want[0];
	t.to_uv[0] = 4.0f;
	t.to_uv[4] = 4.0f;
	assert_int_equal(pm_scene_add_texture(&s, &t), 0);
	b = pm_scene_add_bsdf(&s);
	s.bsdfs[b].type = PM_BSDF_DIFFUSE;
	s.bsdfs[b].diffuse = pm_rgb1(0.0f);	/* the emitter: black */
	sh = pm_scene_add_shape(&s);
	s.shapes[sh].type = PM_SHAPE_SPHERE;
	s.shapes[sh].radius = 10.0f;
	s.shapes[sh].flip_normals = true;
	s.shapes[sh].bsdf = b;
	l = pm_scene_add_light(&s);
	s.lights[l].type = PM_LIGHT_AREA;
	s.lights[l].radiance = le;
	s.lights[l].shape = sh;
	s.shapes[sh].light = l;
	b = pm_scene_add_bsdf(&s);
	s.bsdfs[b].type = PM_BSDF_DIFFUSE;
	s.bsdfs[b].tex_diffuse = 1;
	s.bsdfs[b].diffuse = pm_texture_mean(&t);
	sh = pm_scene_add_shape(&s);
	s.shapes[sh].type = PM_SHAPE_SPHERE;
	s.shapes[sh].radius = 1.0f;
	s.shapes[sh].bsdf = b;
	assert_int_equal(pm_scene_prepare(&s, &err), PM_OK);
	assert_int_equal(pm_world_init(&w, &s, &err), PM_OK);
	memset(&ctx, 0, sizeof(ctx));
	ctx.scene = &s;
	ctx.accel = w.accel;
	ctx.lights = &w.lights;
	ctx.max_depth = -1;
	ctx.rr_depth = 5;

	for (k = 0; k < 2; k++) {
		double ph = phis[k] * M_PI / 180, th = 78.75 * M_PI / 180;
		struct pm_vec3 d = pm_v3((float)(cos(ph) * sin(th)),
		    (float)(sin(ph) * sin(th)), (float)cos(th));
		double sum[3] = {0, 0, 0}, sq[3] = {0, 0, 0};
		const int n = 20000;
		const float *wv = &want[k].r, *lv = &le.r;

		for (i = 0; i < n; i++) {
			struct pm_rng rng = pm_rng_seed(7, (uint64_t)k,
			    (uint64_t)i);
			struct pm_rgb L = pm_path_li(&ctx, pm_scale(d, 3.0f),
			    pm_neg(d), 0.0f, INFINITY, &rng);
			const float *lp = &L.r;
			int c;

			for (c = 0; c < 3; c++) {
				sum[c] += lp[c];
				sq[c] += (double)lp[c] * lp[c];
			}
		}
		for (i = 0; i < 3; i++) {
			double m = sum[i] / n, var = sq[i] / n - m * m;
			double se = sqrt(fmax(var, 0.0) / n);

			print_message("ray %d channel %d: %.5f +- %.5f, want "
			    "%.5f\n", k, i, m, se, (double)(wv[i] * lv[i]));
			/* five standard errors, and float's rounding */
			assert_near(m, wv[i] * lv[i], 5 * se + 1e-5);
		}
	}
	pm_world_free(&w);
	pm_scene_free(&s);
}

/* A rectangle mesh [-10, 10]^2 at height z, facing +z or, flipped, -z. */
static int
add_plane(struct pm_scene *s, float z, bool down, int bsdf)
{
	struct pm_error err;
	struct pm_mat4 M = pm_mat4_mul(pm_mat4_translate(pm_v3(0, 0, z)),
	    pm_mat4_scale(pm_v3(10, 10, 10)));
	int sh = pm_scene_add_shape(s);

	s->shapes[sh].type = PM_SHAPE_MESH;
	s->shapes[sh].bsdf = bsdf;
	assert_int_equal(pm_mesh_rectangle(&s->shapes[sh].mesh, &err), PM_OK);
	pm_mesh_transform(&s->shapes[sh].mesh, &M);
	if (down)
		pm_mesh_flip(&s->shapes[sh].mesh);
	return sh;
}

/* pm-shoot's photons see the texture: under a point light midway between
 * a floor (a 2 x 1 bitmap: white where x < 0, black where x > 0) and a
 * ceiling, every photon stored on the ceiling after one bounce came from
 * the white half; with the floor's mean albedo instead, half would come
 * from the black one. */
static void
test_photons_see_texture(void **state)
{
	struct pm_scene s;
	struct pm_world w;
	struct pm_shooter sh;
	struct pm_error err;
	struct pm_texture t;
	struct pm_photon_buf buf = {NULL, 0, 0};
	struct pm_shoot_opts o = {PM_PASS_GLOBAL, 5, 0, 100000, -1, 1, NULL,
	    NULL, NULL, NULL};
	struct pm_shoot_stats st;
	size_t i, bounced = 0, from_black = 0;
	int b, l;

	(void)state;
	pm_scene_init(&s);
	pm_texture_init(&t, PM_TEXTURE_BITMAP);
	t.width = 2;
	t.height = 1;
	t.nearest = true;
	t.wrap = PM_WRAP_CLAMP;
	t.rgb = calloc(6, sizeof(float));
	assert_non_null(t.rgb);
	t.rgb[0] = t.rgb[1] = t.rgb[2] = 1.0f;
	assert_int_equal(pm_scene_add_texture(&s, &t), 0);
	b = pm_scene_add_bsdf(&s);
	s.bsdfs[b].type = PM_BSDF_DIFFUSE;
	s.bsdfs[b].tex_diffuse = 1;
	s.bsdfs[b].diffuse = pm_texture_mean(&t);
	add_plane(&s, 0.0f, false, b);
	b = pm_scene_add_bsdf(&s);
	s.bsdfs[b].type = PM_BSDF_DIFFUSE;
	s.bsdfs[b].diffuse = pm_rgb1(0.5f);
	add_plane(&s, 1.0f, true, b);
	l = pm_scene_add_light(&s);
	s.lights[l].type = PM_LIGHT_POINT;
	s.lights[l].position = pm_v3(0, 0, 0.5f);
	s.lights[l].intensity = pm_rgb1(1.0f);
	assert_int_equal(pm_scene_prepare(&s, &err), PM_OK);
	assert_int_equal(pm_world_init(&w, &s, &err), PM_OK);
	assert_int_equal(pm_shooter_init(&sh, &s, w.accel, &w.lights, &err),
	    PM_OK);
	assert_int_equal(pm_shoot(&sh, &o, &buf, &st, &err), PM_OK);
	for (i = 0; i < buf.n; i++) {
		const struct pm_photon *p = &buf.p[i];
		struct pm_vec3 d = pm_dir_unpack(p->dir);
		float x0;

		/* on the ceiling, after the one bounce on the floor, and
		 * steep enough that 8-bit directions trace back closely */
		if (p->depth != 1 || p->pos[2] < 0.5f || d.z > -0.5f)
			continue;
		bounced++;
		x0 = p->pos[0] + d.x * (p->pos[2] / -d.z);
		if (x0 > 0.05f)
			from_black++;
	}
	print_message("%zu photons on the ceiling after one bounce, %zu "
	    "from the black half\n", bounced, from_black);
	assert_true(bounced > 1000);
	assert_int_equal(from_black, 0);
	pm_photon_buf_free(&buf);
	pm_shooter_free(&sh);
	pm_world_free(&w);
	pm_scene_free(&s);
}

int
main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_png_round_trip),
		cmocka_unit_test(test_png16),
		cmocka_unit_test(test_exr_round_trip),
		cmocka_unit_test(test_jpeg),
		cmocka_unit_test(test_damaged_files),
		cmocka_unit_test(test_bilinear),
		cmocka_unit_test(test_wrap_modes),
		cmocka_unit_test(test_checkerboard),
		cmocka_unit_test(test_hit_uv),
		cmocka_unit_test(test_scene_textures),
		cmocka_unit_test(test_furnace),
		cmocka_unit_test(test_photons_see_texture),
	};

	return cmocka_run_group_tests(tests, pm_tmpdir_setup, pm_tmpdir_teardown);
}
