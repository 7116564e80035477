/*
 * texture.c (formats): image files into bitmap textures' texels.  The
 * decoders are png.c, jpeg.c, exr.c and rgbe.c; this file tells the
 * formats apart and turns 8-bit samples into linear floats once, at load,
 * so that a lookup never converts.
 */
#include <errno.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "../common/image.h"
#include "exr.h"
#include "jpeg.h"
#include "png.h"
#include "rgbe.h"
#include "texture.h"

/* 8-bit samples (stride bytes a pixel, RGB first) into linear floats. */
static float *
from_8bit(const uint8_t *px, size_t n, int stride, bool raw)
{
	float lut[256];
	float *out;
	size_t i;
	int c;

	if ((out = malloc(n * 3 * sizeof(float))) == NULL)
		return NULL;
	for (c = 0; c < 256; c++)
		lut[c] = raw ? (float)c / 255.0f :
		    pm_srgb_to_linear((float)c / 255.0f);
	for (i = 0; i < n; i++)
		for (c = 0; c < 3; c++)
			out[3 * i + c] = lut[px[(size_t)stride * i + (size_t)c]];
	return out;
}

/* 16-bit RGBA samples into linear floats: sRGB-encoded like 8-bit ones,
 * as Mitsuba reads PNG. */
static float *
from_16bit(const uint16_t *px, size_t n, bool raw)
{
	float *out;
	size_t i;
	int c;

	if ((out = malloc(n * 3 * sizeof(float))) == NULL)
		return NULL;
	for (i = 0; i < n; i++)
		for (c = 0; c < 3; c++) {
			float v = (float)px[4 * i + (size_t)c] / 65535.0f;

			out[3 * i + c] = raw ? v : pm_srgb_to_linear(v);
		}
	return out;
}

enum pm_err
pm_bitmap_read(const char *path, bool raw, struct pm_texture *t,
    struct pm_error *err)
{
	static const uint8_t png_magic[4] = {0x89, 'P', 'N', 'G'};
	static const uint8_t jpeg_magic[3] = {0xff, 0xd8, 0xff};
	static const uint8_t exr_magic[4] = {0x76, 0x2f, 0x31, 0x01};
	uint8_t head[4] = {0, 0, 0, 0}, *px = NULL;
	struct pm_image im;
	int w = 0, h = 0, stride;
	float *rgb;
	FILE *fp;
	size_t got;
	enum pm_err e;

	if ((fp = fopen(path, "rb")) == NULL)
		return pm_fail(err, PM_ERR_IO, "%s: %s", path, strerror(errno));
	got = fread(head, 1, sizeof(head), fp);
	fclose(fp);
	if ((got == sizeof(head) && memcmp(head, exr_magic, 4) == 0) ||
	    (got >= 2 && head[0] == '#' && head[1] == '?')) {
		/* OpenEXR, or Radiance's RGBE ("#?RADIANCE"): linear
		 * already, whatever raw says, as in Mitsuba */
		memset(&im, 0, sizeof(im));
		e = head[0] == '#' ? pm_rgbe_read(path, &im, err) :
		    pm_exr_read(path, &im, err);
		if (e != PM_OK)
			return e;
		pm_texture_free(t);
		t->rgb = im.rgb;	/* linear RGB, top row first: as is */
		t->width = im.width;
		t->height = im.height;
		return PM_OK;
	}
	if (got == sizeof(head) && memcmp(head, png_magic, 4) == 0) {
		void *raw_px;
		int bits;

		if ((e = pm_png_read(path, &raw_px, &bits, &w, &h, err)) != PM_OK)
			return e;
		if (bits == 16) {
			rgb = from_16bit(raw_px, (size_t)w * (size_t)h, raw);
			free(raw_px);
			goto done;
		}
		px = raw_px;
		stride = 4;
	} else if (got >= 3 && memcmp(head, jpeg_magic, 3) == 0) {
		e = pm_jpeg_read(path, &px, &w, &h, err);
		stride = 3;
	} else {
		return pm_fail(err, PM_ERR_UNSUPPORTED, "%s: not a PNG, JPEG, "
		    "OpenEXR or Radiance HDR file (the bitmap formats pm reads)", path);
	}
	if (e != PM_OK)
		return e;
	rgb = from_8bit(px, (size_t)w * (size_t)h, stride, raw);
	free(px);
done:
	if (rgb == NULL)
		return pm_fail(err, PM_ERR_NOMEM, "%s: no memory for %dx%d "
		    "texels", path, w, h);
	pm_texture_free(t);
	t->rgb = rgb;
	t->width = w;
	t->height = h;
	return PM_OK;
}
