/*
 * rgbe.c: the Radiance HDR reader.  Every length read from the file is
 * checked against what is left of it before it is used.
 */
#include <math.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "file.h"
#include "rgbe.h"

#define MAX_RGBE_FILE	((size_t)1 << 30)
#define MAX_SIDE	65536

struct rd {
	const unsigned char *base, *p, *end;
	const char *path;
	struct pm_error *err;
};

static enum pm_err
bad(struct rd *r, const char *what)
{
	return pm_fail(r->err, PM_ERR_PARSE, "%s: %s (byte %zu)", r->path, what,
	    (size_t)(r->p - r->base));
}

/* One header line, without its newline, into buf; false at the end. */
static bool
line(struct rd *r, char *buf, size_t cap)
{
	size_t n = 0;

	if (r->p >= r->end)
		return false;
	while (r->p < r->end && *r->p != '\n') {
		if (n + 1 < cap)
			buf[n++] = (char)*r->p;
		r->p++;
	}
	if (r->p < r->end)
		r->p++;
	buf[n] = '\0';
	return true;
}

static void
store(float *dst, const unsigned char *px)
{
	/* a mantissa of 256 would be 1: 2^(e - 128) / 256 */
	float f = ldexpf(1.0f, (int)px[3] - 136);

	if (px[3] == 0) {
		dst[0] = dst[1] = dst[2] = 0.0f;
		return;
	}
	dst[0] = (float)px[0] * f;
	dst[1] = (float)px[1] * f;
	dst[2] = (float)px[2] * f;
}

/* A scanline in the run-length layout: each of the four components of
 * every pixel in turn, as runs (count > 128: count - 128 copies of one
 * byte) and literals (count bytes). */
static enum pm_err
scan_rle(struct rd *r, unsigned char *row, int w)
{
	int c, x;

	r->p += 4;	/* 2, 2, width */
	for (c = 0; c < 4; c++) {
		for (x = 0; x < w;) {
			int n;

			if (r->p >= r->end)
				return bad(r, "truncated run-length scanline");
			n = *r->p++;
			if (n > 128) {
				n -= 128;
				if (x + n > w || r->p >= r->end)
					return bad(r, "run past the end of a "
					    "scanline");
				while (n-- > 0)
					row[4 * x++ + c] = *r->p;
				r->p++;
			} else {
				if (n == 0 || x + n > w || r->end - r->p < n)
					return bad(r, "bad literal in a "
					    "run-length scanline");
				while (n-- > 0)
					row[4 * x++ + c] = *r->p++;
			}
		}
	}
	return PM_OK;
}

/* A flat scanline, where (1, 1, 1, n) repeats the pixel before n times
 * (shifted by 8 bits more for each such pixel in a row: the old
 * run-length layout). */
static enum pm_err
scan_flat(struct rd *r, unsigned char *row, int w)
{
	int x = 0, shift = 0;

	while (x < w) {
		const unsigned char *q = r->p;

		if (r->end - r->p < 4)
			return bad(r, "truncated scanline");
		r->p += 4;
		if (q[0] == 1 && q[1] == 1 && q[2] == 1) {
			long n = (long)q[3] << shift;

			if (x == 0 || shift > 16 || n > w - x)
				return bad(r, "bad run in an old-style scanline");
			for (; n > 0; n--, x++)
				memcpy(&row[4 * x], &row[4 * (x - 1)], 4);
			shift += 8;
		} else {
			memcpy(&row[4 * x++], q, 4);
			shift = 0;
		}
	}
	return PM_OK;
}

enum pm_err
pm_rgbe_read(const char *path, struct pm_image *im, struct pm_error *err)
{
	char *buf, ln[256], ys[3], xs[3];
	size_t len;
	struct rd r;
	unsigned char *row = NULL;
	int w, h, y, x, nl = 0;
	bool bottom_up;
	enum pm_err rc;

	im->width = im->height = 0;
	im->rgb = NULL;
	if ((rc = pm_read_file(path, MAX_RGBE_FILE, &buf, &len, err)) != PM_OK)
		return rc;
	r.base = r.p = (const unsigned char *)buf;
	r.end = r.p + len;
	r.path = path;
	r.err = err;
	if (len < 2 || memcmp(buf, "#?", 2) != 0) {
		rc = pm_fail(err, PM_ERR_PARSE, "%s: not a Radiance HDR file "
		    "(no #? signature)", path);
		goto out;
	}
	for (;;) {
		if (!line(&r, ln, sizeof(ln))) {
			rc = pm_fail(err, PM_ERR_PARSE, "%s: truncated header",
			    path);
			goto out;
		}
		if (nl++ > 0 && ln[0] == '\0')
			break;
		if (strncmp(ln, "FORMAT=", 7) == 0 &&
		    strcmp(ln + 7, "32-bit_rle_rgbe") != 0) {
			rc = pm_fail(err, PM_ERR_UNSUPPORTED, "%s: format %s, pm "
			    "reads 32-bit_rle_rgbe only", path, ln + 7);
			goto out;
		}
	}
	if (!line(&r, ln, sizeof(ln)) ||
	    sscanf(ln, "%2s %d %2s %d", ys, &h, xs, &w) != 4 ||
	    (strcmp(ys, "-Y") != 0 && strcmp(ys, "+Y") != 0) ||
	    strcmp(xs, "+X") != 0) {
		rc = pm_fail(err, PM_ERR_UNSUPPORTED, "%s: resolution line "
		    "\"%s\", expected \"-Y H +X W\" or \"+Y H +X W\"", path, ln);
		goto out;
	}
	if (w < 1 || h < 1 || w > MAX_SIDE || h > MAX_SIDE) {
		rc = pm_fail(err, PM_ERR_LIMIT, "%s: %dx%d pixels, at most "
		    "%d a side", path, w, h, MAX_SIDE);
		goto out;
	}
	bottom_up = ys[0] == '+';
	if ((rc = pm_image_alloc(im, w, h, err)) != PM_OK)
		goto out;
	if ((row = malloc(4 * (size_t)w)) == NULL) {
		rc = pm_fail(err, PM_ERR_NOMEM, "%s: no memory for a scanline",
		    path);
		goto out;
	}
	for (y = 0; y < h; y++) {
		int dy = bottom_up ? h - 1 - y : y;

		if (w >= 8 && w < 32768 && r.end - r.p >= 4 && r.p[0] == 2 &&
		    r.p[1] == 2 && !(r.p[2] & 0x80)) {
			if (((int)r.p[2] << 8 | r.p[3]) != w) {
				rc = bad(&r, "scanline width differs from the "
				    "image's");
				goto out;
			}
			rc = scan_rle(&r, row, w);
		} else {
			rc = scan_flat(&r, row, w);
		}
		if (rc != PM_OK)
			goto out;
		for (x = 0; x < w; x++)
			store(&im->rgb[3 * ((size_t)dy * (size_t)w + (size_t)x)],
			    &row[4 * x]);
	}
out:
	free(row);
	free(buf);
	if (rc != PM_OK)
		pm_image_free(im);
	return rc;
}
