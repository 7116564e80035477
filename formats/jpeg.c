/*
 * jpeg.c: reads JPEG files through libjpeg.
 *
 * libjpeg's default error handler prints and exits; ours keeps the message
 * and longjmps back, so that the library neither prints nor exits.
 */
#include <errno.h>
#include <setjmp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <jpeglib.h>
#include <jerror.h>

#include "jpeg.h"

/* as PNG_MAX_PIXELS (png.c): 2^26 texels */
#define JPEG_MAX_PIXELS ((size_t)1 << 26)

struct jpeg_err {
	struct jpeg_error_mgr mgr;	/* first: libjpeg passes this pointer */
	jmp_buf jmp;
	char msg[JMSG_LENGTH_MAX];
};

static void
jpeg_on_error(j_common_ptr c)
{
	struct jpeg_err *je = (struct jpeg_err *)c->err;

	je->mgr.format_message(c, je->msg);
	longjmp(je->jmp, 1);
}

/* Warnings: a file that ends early is an error (libjpeg would fill the
 * rest with grey); other damage libjpeg recovers from is let pass, as
 * Mitsuba's reader does. */
static void
jpeg_on_emit(j_common_ptr c, int level)
{
	struct jpeg_err *je = (struct jpeg_err *)c->err;

	if (level < 0 && je->mgr.msg_code == JWRN_JPEG_EOF) {
		je->mgr.format_message(c, je->msg);
		longjmp(je->jmp, 1);
	}
}

/* Decodes fp into *out; kept apart so that its setjmp guards only the
 * decompressor and the buffer, which live in *st. */
struct jpeg_state {
	struct jpeg_decompress_struct d;
	struct jpeg_err je;
	uint8_t *buf;
};

static int
jpeg_decode(FILE *fp, struct jpeg_state *st, int *w, int *h)
{
	JSAMPROW row;
	size_t n;

	st->d.err = jpeg_std_error(&st->je.mgr);
	st->je.mgr.error_exit = jpeg_on_error;
	st->je.mgr.emit_message = jpeg_on_emit;
	if (setjmp(st->je.jmp)) {
		jpeg_destroy_decompress(&st->d);
		return -1;
	}
	jpeg_create_decompress(&st->d);
	jpeg_stdio_src(&st->d, fp);
	jpeg_read_header(&st->d, TRUE);
	st->d.out_color_space = JCS_RGB;
	jpeg_start_decompress(&st->d);
	n = (size_t)st->d.output_width * (size_t)st->d.output_height;
	if (st->d.output_components != 3 || n == 0 || n > JPEG_MAX_PIXELS) {
		snprintf(st->je.msg, sizeof(st->je.msg), "%ux%u pixels of %d "
		    "components is not what pm reads", st->d.output_width,
		    st->d.output_height, st->d.output_components);
		jpeg_destroy_decompress(&st->d);
		return -1;
	}
	if ((st->buf = malloc(n * 3)) == NULL) {
		snprintf(st->je.msg, sizeof(st->je.msg), "out of memory");
		jpeg_destroy_decompress(&st->d);
		return -1;
	}
	while (st->d.output_scanline < st->d.output_height) {
		row = st->buf + (size_t)st->d.output_scanline *
		    st->d.output_width * 3;
		jpeg_read_scanlines(&st->d, &row, 1);
	}
	jpeg_finish_decompress(&st->d);
	*w = (int)st->d.output_width;
	*h = (int)st->d.output_height;
	jpeg_destroy_decompress(&st->d);
	return 0;
}

enum pm_err
pm_jpeg_read(const char *path, uint8_t **rgb, int *width, int *height,
    struct pm_error *err)
{
	struct jpeg_state *st;
	FILE *fp;
	enum pm_err e = PM_OK;

	*rgb = NULL;
	if ((fp = fopen(path, "rb")) == NULL)
		return pm_fail(err, PM_ERR_IO, "%s: %s", path, strerror(errno));
	/* on the heap: the state is large and outlives a longjmp */
	if ((st = calloc(1, sizeof(*st))) == NULL) {
		fclose(fp);
		return pm_fail(err, PM_ERR_NOMEM, "%s: no memory", path);
	}
	if (jpeg_decode(fp, st, width, height) != 0) {
		e = pm_fail(err, PM_ERR_FORMAT, "%s: %s", path, st->je.msg);
		free(st->buf);
	} else {
		*rgb = st->buf;
	}
	free(st);
	fclose(fp);
	return e;
}
