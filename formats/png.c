/*
 * png.c: writes 8-bit RGB PNG files through libpng.
 *
 * libpng reports errors by calling a handler that must not return; ours
 * keeps the message and longjmps back to pm_png_write, so that nothing is
 * printed and the temporary file is removed.  Warnings are dropped: the
 * only ones a writer can raise concern options we do not use.
 */
#include <errno.h>
#include <fcntl.h>
#include <setjmp.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <png.h>

#include "file.h"
#include "png.h"

/* What libpng's callbacks share with pm_png_write. */
struct png_io {
	jmp_buf jmp;
	char msg[512];
};

static void
png_on_error(png_structp png, png_const_charp msg)
{
	struct png_io *io = png_get_error_ptr(png);

	snprintf(io->msg, sizeof(io->msg), "%s", msg != NULL ? msg : "error");
	longjmp(io->jmp, 1);
}

static void
png_on_warning(png_structp png, png_const_charp msg)
{
	(void)png;
	(void)msg;
}

/*
 * Encodes the image into fp.  Kept apart from the file handling so that
 * the setjmp here guards no local that changes after it.
 */
static int
png_encode(FILE *fp, const uint8_t *rgb, int width, int height, bool fast,
    struct png_io *io)
{
	png_structp png;
	png_infop info;
	int y;

	png = png_create_write_struct(PNG_LIBPNG_VER_STRING, io, png_on_error,
	    png_on_warning);
	if (png == NULL) {
		snprintf(io->msg, sizeof(io->msg), "cannot start libpng");
		return -1;
	}
	/* Both handles exist before setjmp, so that the longjmp finds them
	 * unchanged. */
	info = png_create_info_struct(png);
	if (info == NULL) {
		png_destroy_write_struct(&png, NULL);
		snprintf(io->msg, sizeof(io->msg), "out of memory");
		return -1;
	}
	if (setjmp(io->jmp)) {
		png_destroy_write_struct(&png, &info);
		return -1;
	}
	png_init_io(png, fp);
	if (fast) {
		/* A quarter of the time, for a file about a quarter larger. */
		png_set_compression_level(png, 1);
		png_set_filter(png, PNG_FILTER_TYPE_BASE, PNG_FILTER_NONE);
	}
	png_set_IHDR(png, info, (png_uint_32)width, (png_uint_32)height, 8,
	    PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE,
	    PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
	/* The bytes are already sRGB-encoded; say so, so that viewers do
	 * not apply a gamma of their own. */
	png_set_sRGB_gAMA_and_cHRM(png, info, PNG_sRGB_INTENT_PERCEPTUAL);
	png_write_info(png, info);
	for (y = 0; y < height; y++)
		png_write_row(png, rgb + (size_t)y * (size_t)width * 3);
	png_write_end(png, info);
	png_destroy_write_struct(&png, &info);
	return 0;
}

/* Writes rgb as an 8-bit RGB PNG to path (through a temporary file that
 * is renamed on success), or to stdout when path is "-". */
static enum pm_err
write_png(const char *path, const uint8_t *rgb, int width, int height,
    bool fast, struct pm_error *err)
{
	struct png_io io;
	struct pm_out out;
	FILE *fp;
	enum pm_err e;
	int fd = -1;

	if (rgb == NULL || width < 1 || height < 1)
		return pm_fail(err, PM_ERR_INVALID, "%s: empty image", path);
	memset(&io, 0, sizeof(io));

	if (strcmp(path, "-") == 0) {
		/* The caller owns stdout and closes it; flushing here is how
		 * a write error on a pipe or a full disk shows up. */
		if (png_encode(stdout, rgb, width, height, fast, &io) != 0)
			return pm_fail(err, PM_ERR_IO, "stdout: %s", io.msg);
		if (fflush(stdout) != 0 || ferror(stdout))
			return pm_fail(err, PM_ERR_IO, "stdout: %s",
			    strerror(errno));
		return PM_OK;
	}

	if ((e = pm_out_open(&out, path, err)) != PM_OK)
		return e;
	/* fp gets a copy of the descriptor: the temporary file may be
	 * unnamed, and must stay open until pm_out_commit names it. */
	if ((fd = dup(out.fd)) < 0 || (fp = fdopen(fd, "wb")) == NULL) {
		e = pm_fail(err, PM_ERR_IO, "%s: %s", path, strerror(errno));
		if (fd >= 0)
			close(fd);
		pm_out_abort(&out);
		return e;
	}
	if (png_encode(fp, rgb, width, height, fast, &io) != 0) {
		e = pm_fail(err, PM_ERR_IO, "%s: %s", path, io.msg);
		fclose(fp);
		pm_out_abort(&out);
		return e;
	}
	if (fflush(fp) != 0 || ferror(fp)) {
		e = pm_fail(err, PM_ERR_IO, "%s: %s", path, strerror(errno));
		fclose(fp);
		pm_out_abort(&out);
		return e;
	}
	if (fclose(fp) != 0) {
		e = pm_fail(err, PM_ERR_IO, "%s: %s", path, strerror(errno));
		pm_out_abort(&out);
		return e;
	}
	return pm_out_commit(&out, err);
}

enum pm_err
pm_png_write(const char *path, const uint8_t *rgb, int width, int height,
    struct pm_error *err)
{
	return write_png(path, rgb, width, height, false, err);
}

enum pm_err
pm_png_write_fast(const char *path, const uint8_t *rgb, int width,
    int height, struct pm_error *err)
{
	return write_png(path, rgb, width, height, true, err);
}

/* The largest image a texture may be: 2^26 texels (8192 x 8192 or 16384 x
 * 4096), 768 MiB of float RGB, 1 GiB with the 8-bit image it is decoded
 * from.  (2^27 let a 232-byte JPEG that claims 62208 x 2048 pixels take
 * 1.9 GiB, past the 2 GiB the fuzzers allow with their own memory.) */
#define PNG_MAX_PIXELS ((size_t)1 << 26)

/*
 * Reads through libpng's simplified interface, which does the colour
 * conversions (palette, grey) itself and reports errors in the image's
 * message rather than through a handler.  16-bit files come as its
 * "linear" 16-bit samples, which for a file without a gamma chunk are the
 * file's own, with the colour premultiplied by alpha, undone here.
 */
enum pm_err
pm_png_read(const char *path, void **rgba, int *bits, int *width,
    int *height, struct pm_error *err)
{
	png_image im;
	size_t n, i;
	void *buf;

	*rgba = NULL;
	memset(&im, 0, sizeof(im));
	im.version = PNG_IMAGE_VERSION;
	if (!png_image_begin_read_from_file(&im, path)) {
		enum pm_err e = pm_fail(err, errno == ENOENT ? PM_ERR_IO :
		    PM_ERR_FORMAT, "%s: %s", path, im.message);

		png_image_free(&im);
		return e;
	}
	n = (size_t)im.width * (size_t)im.height;
	if (im.width < 1 || im.height < 1 || im.width > INT32_MAX ||
	    im.height > INT32_MAX || n > PNG_MAX_PIXELS) {
		png_image_free(&im);
		return pm_fail(err, PM_ERR_LIMIT, "%s: %ux%u pixels is more "
		    "than pm reads", path, im.width, im.height);
	}
	*bits = (im.format & PNG_FORMAT_FLAG_LINEAR) ? 16 : 8;
	im.format = *bits == 16 ? PNG_FORMAT_LINEAR_RGB_ALPHA : PNG_FORMAT_RGBA;
	if ((buf = malloc(n * 4 * (size_t)(*bits / 8))) == NULL) {
		png_image_free(&im);
		return pm_fail(err, PM_ERR_NOMEM, "%s: no memory for %ux%u "
		    "pixels", path, im.width, im.height);
	}
	if (!png_image_finish_read(&im, NULL, buf, 0, NULL)) {
		enum pm_err e = pm_fail(err, PM_ERR_FORMAT, "%s: %s", path,
		    im.message);

		free(buf);
		png_image_free(&im);
		return e;
	}
	if (*bits == 16) {
		uint16_t *p = buf;

		for (i = 0; i < n; i++, p += 4)
			if (p[3] > 0 && p[3] < 65535) {
				int c;

				for (c = 0; c < 3; c++) {
					unsigned v = ((unsigned)p[c] * 65535u +
					    p[3] / 2u) / p[3];

					p[c] = (uint16_t)(v > 65535u ? 65535u : v);
				}
			}
	}
	*width = (int)im.width;
	*height = (int)im.height;
	*rgba = buf;
	return PM_OK;
}
