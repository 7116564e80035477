/*
 * exr.c: reads and writes OpenEXR images through OpenEXRCore, the C API
 * of OpenEXR 3.
 *
 * OpenEXRCore reports errors through a callback that by default prints to
 * stderr; the library must not print, so every context gets a handler that
 * keeps the first message for the pm_error instead.  Writes go through our
 * own write callback on a temporary file opened beside the target, so that
 * we choose its name and permissions and rename it only once OpenEXR has
 * finished the offset table.  Provenance travels as string attributes
 * of the header (struct pm_exr_attrs), read and written here.
 */
#include <errno.h>
#include <fcntl.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include <openexr.h>

#include "exr.h"
#include "file.h"

/* What the callbacks of one context share with the code that made it. */
struct exr_io {
	int fd;			/* the file read, or the temporary file written */
	int read_errno;		/* set when the system failed a read */
	char msg[512];		/* OpenEXR's first error message */
};

/* Names in OpenEXR's order for the channel list: sorted, so B, G, R. */
static const char *const exr_names[3] = { "B", "G", "R" };
/* Where each of those lands within an interleaved RGB pixel. */
static const int exr_offset[3] = { 2, 1, 0 };

/*
 * Where channel `name` lives: the image holding it (im for R, G and B, or
 * a layer's) in *img and its component within a pixel in *k; false for a
 * channel neither has.
 */
static bool
exr_find(const char *name, struct pm_image *im,
    const struct pm_exr_layers *layers, struct pm_image **img, int *k)
{
	size_t i;
	int j;

	for (j = 0; j < 3; j++)
		if (strcmp(name, exr_names[j]) == 0) {
			*img = im;
			*k = exr_offset[j];
			return true;
		}
	for (i = 0; layers != NULL && i < layers->n; i++)
		for (j = 0; j < 3; j++)
			if (layers->v[i].name[j] != NULL &&
			    strcmp(name, layers->v[i].name[j]) == 0) {
				*img = &layers->v[i].im;
				*k = j;
				return true;
			}
	return false;
}

void
pm_exr_layers_free(struct pm_exr_layers *l)
{
	size_t i;
	int k;

	for (i = 0; i < l->n; i++) {
		for (k = 0; k < 3; k++)
			free(l->v[i].name[k]);
		pm_image_free(&l->v[i].im);
	}
	free(l->v);
	l->v = NULL;
	l->n = 0;
}

enum pm_err
pm_exr_layers_add(struct pm_exr_layers *l, const char *n0, const char *n1,
    const char *n2, int width, int height, struct pm_exr_layer **out,
    struct pm_error *err)
{
	const char *names[3] = { n0, n1, n2 };
	struct pm_exr_layer *v, *ly;
	enum pm_err e;
	int k;

	v = realloc(l->v, (l->n + 1) * sizeof(*v));
	if (v == NULL)
		return pm_fail(err, PM_ERR_NOMEM, "no memory for a layer");
	l->v = v;
	ly = &v[l->n];
	memset(ly, 0, sizeof(*ly));
	for (k = 0; k < 3; k++)
		if (names[k] != NULL && (ly->name[k] = strdup(names[k])) ==
		    NULL) {
			while (k-- > 0)
				free(ly->name[k]);
			return pm_fail(err, PM_ERR_NOMEM, "no memory for a "
			    "layer");
		}
	if ((e = pm_image_alloc(&ly->im, width, height, err)) != PM_OK) {
		for (k = 0; k < 3; k++)
			free(ly->name[k]);
		return e;
	}
	memset(ly->im.rgb, 0, 3 * sizeof(float) * (size_t)width *
	    (size_t)height);
	l->n++;
	if (out != NULL)
		*out = ly;
	return PM_OK;
}

static void
exr_on_error(exr_const_context_t ctxt, exr_result_t code, const char *msg)
{
	void *ud = NULL;
	struct exr_io *io;

	(void)code;
	if (exr_get_user_data(ctxt, &ud) != EXR_ERR_SUCCESS || ud == NULL)
		return;
	io = ud;
	if (io->msg[0] == '\0' && msg != NULL)
		snprintf(io->msg, sizeof(io->msg), "%s", msg);
}

static int64_t
exr_on_read(exr_const_context_t ctxt, void *ud, void *buf, uint64_t sz,
    uint64_t offset, exr_stream_error_func_ptr_t error_cb)
{
	struct exr_io *io = ud;
	char *p = buf;
	uint64_t done = 0;

	/* A short count at the end of the file is how OpenEXR learns that
	 * a file is truncated; only a failing read is an error here. */
	while (done < sz) {
		ssize_t n = pread(io->fd, p + done, (size_t)(sz - done),
		    (off_t)(offset + done));

		if (n < 0 && errno == EINTR)
			continue;
		if (n < 0) {
			io->read_errno = errno;
			if (io->msg[0] == '\0')
				snprintf(io->msg, sizeof(io->msg), "%s",
				    strerror(errno));
			if (error_cb != NULL)
				error_cb(ctxt, EXR_ERR_READ_IO, "read failed");
			return -1;
		}
		if (n == 0)
			break;
		done += (uint64_t)n;
	}
	return (int64_t)done;
}

static int64_t
exr_on_size(exr_const_context_t ctxt, void *ud)
{
	struct exr_io *io = ud;
	struct stat st;

	(void)ctxt;
	if (fstat(io->fd, &st) != 0 || !S_ISREG(st.st_mode))
		return -1;
	return (int64_t)st.st_size;
}

static int64_t
exr_on_write(exr_const_context_t ctxt, void *ud, const void *buf, uint64_t sz,
    uint64_t offset, exr_stream_error_func_ptr_t error_cb)
{
	struct exr_io *io = ud;
	const char *p = buf;
	uint64_t done = 0;

	while (done < sz) {
		ssize_t n = pwrite(io->fd, p + done, (size_t)(sz - done),
		    (off_t)(offset + done));

		if (n < 0 && errno == EINTR)
			continue;
		if (n <= 0) {
			if (io->msg[0] == '\0')
				snprintf(io->msg, sizeof(io->msg), "%s",
				    strerror(n < 0 ? errno : EIO));
			if (error_cb != NULL)
				error_cb(ctxt, EXR_ERR_WRITE_IO,
				    "write failed");
			return -1;
		}
		done += (uint64_t)n;
	}
	return (int64_t)done;
}

/* Fills err from an OpenEXR result, preferring the callback's message,
 * which names the attribute or chunk at fault. */
static enum pm_err
exr_fail(struct pm_error *err, enum pm_err code, const char *path,
    const char *what, exr_result_t rv, const struct exr_io *io)
{
	const char *detail = io->msg[0] != '\0' ? io->msg :
	    exr_get_default_error_message(rv);

	return pm_fail(err, code, "%s: %s: %s", path, what, detail);
}

/* Picks the pm error code closest to an OpenEXR one. */
static enum pm_err
exr_code(exr_result_t rv)
{
	switch (rv) {
	case EXR_ERR_OUT_OF_MEMORY:
		return PM_ERR_NOMEM;
	case EXR_ERR_FILE_ACCESS:
	case EXR_ERR_READ_IO:
	case EXR_ERR_WRITE_IO:
		return PM_ERR_IO;
	case EXR_ERR_FEATURE_NOT_IMPLEMENTED:
		return PM_ERR_UNSUPPORTED;
	default:
		return PM_ERR_FORMAT;
	}
}

/* Frees every attribute and leaves a empty. */
void
pm_exr_attrs_free(struct pm_exr_attrs *a)
{
	size_t i;

	for (i = 0; i < a->n; i++) {
		free(a->v[i].name);
		free(a->v[i].value);
	}
	free(a->v);
	a->v = NULL;
	a->n = 0;
}

/* The value of name, owned by a, or NULL if a has none. */
const char *
pm_exr_attrs_get(const struct pm_exr_attrs *a, const char *name)
{
	size_t i;

	for (i = 0; i < a->n; i++)
		if (strcmp(a->v[i].name, name) == 0)
			return a->v[i].value;
	return NULL;
}

/* Copies len bytes of s into a new NUL-terminated string, or NULL. */
static char *
exr_strndup(const char *s, size_t len)
{
	char *p = malloc(len + 1);

	if (p != NULL) {
		memcpy(p, s, len);
		p[len] = '\0';
	}
	return p;
}

/* Sets name to the first len bytes of value, replacing or appending. */
static enum pm_err
exr_attrs_setn(struct pm_exr_attrs *a, const char *name, const char *value,
    size_t len, struct pm_error *err)
{
	struct pm_exr_attr *v;
	char *val;
	size_t i;

	if ((val = exr_strndup(value, len)) == NULL)
		return pm_fail(err, PM_ERR_NOMEM, "out of memory for the "
		    "attribute %s", name);
	for (i = 0; i < a->n; i++)
		if (strcmp(a->v[i].name, name) == 0) {
			free(a->v[i].value);
			a->v[i].value = val;
			return PM_OK;
		}
	v = realloc(a->v, (a->n + 1) * sizeof(*v));
	if (v == NULL || (v[a->n].name = strdup(name)) == NULL) {
		if (v != NULL)
			a->v = v;
		free(val);
		return pm_fail(err, PM_ERR_NOMEM, "out of memory for the "
		    "attribute %s", name);
	}
	v[a->n].value = val;
	a->v = v;
	a->n++;
	return PM_OK;
}

/* Sets name to value, replacing or appending; copies both strings. */
enum pm_err
pm_exr_attrs_set(struct pm_exr_attrs *a, const char *name, const char *value,
    struct pm_error *err)
{
	return exr_attrs_setn(a, name, value, strlen(value), err);
}

/* Encodes every scanline chunk of im into the open part 0 of ctxt. */
static exr_result_t
exr_write_pixels(exr_context_t ctxt, const struct pm_image *im,
    const struct pm_exr_layers *layers)
{
	exr_encode_pipeline_t enc = EXR_ENCODE_PIPELINE_INITIALIZER;
	exr_chunk_info_t cinfo;
	exr_result_t rv;
	int32_t lines;
	int y, c, started = 0;

	rv = exr_get_scanlines_per_chunk(ctxt, 0, &lines);
	if (rv != EXR_ERR_SUCCESS)
		return rv;
	if (lines < 1)
		return EXR_ERR_INVALID_ARGUMENT;
	for (y = 0; y < im->height; y += lines) {
		rv = exr_write_scanline_chunk_info(ctxt, 0, y, &cinfo);
		if (rv != EXR_ERR_SUCCESS)
			break;
		rv = started ? exr_encoding_update(ctxt, 0, &cinfo, &enc) :
		    exr_encoding_initialize(ctxt, 0, &cinfo, &enc);
		if (rv != EXR_ERR_SUCCESS)
			break;
		for (c = 0; c < enc.channel_count; c++) {
			exr_coding_channel_info_t *ch = &enc.channels[c];
			struct pm_image *img;
			int k;

			/* Only read through img: exr_find serves the
			 * reader too. */
			if (!exr_find(ch->channel_name, (struct pm_image *)im,
			    layers, &img, &k)) {
				rv = EXR_ERR_INVALID_ARGUMENT;
				goto out;
			}
			ch->user_pixel_stride = 3 * sizeof(float);
			ch->user_line_stride = 3 * sizeof(float) * im->width;
			ch->user_data_type = EXR_PIXEL_FLOAT;
			ch->user_bytes_per_element = sizeof(float);
			ch->encode_from_ptr = (const uint8_t *)(img->rgb +
			    (size_t)cinfo.start_y * im->width * 3 + k);
		}
		if (!started) {
			rv = exr_encoding_choose_default_routines(ctxt, 0, &enc);
			if (rv != EXR_ERR_SUCCESS)
				break;
			started = 1;
		}
		rv = exr_encoding_run(ctxt, 0, &enc);
		if (rv != EXR_ERR_SUCCESS)
			break;
	}
out:
	if (started || enc.channels != NULL)
		exr_encoding_destroy(ctxt, &enc);
	return rv;
}

/*
 * Writes im to path as a scanline file with channels B, G and R in float
 * (uncompressed) or half (PIZ), through a temporary file renamed on
 * success.  Not ZIP: OpenEXRCore 3.1.5 (Debian 12) writes corrupt ZIP and ZIPS
 * chunks when the data does not compress (noisy float renders at high
 * sample counts); test_image's incompressible round trip guards this.
 * Float32 files are written uncompressed: on renders PIZ saved 0% (a
 * 4096-spp reference) to 17% (a 1-spp render) of the size and took 80% of
 * pm-downsample's time at 128x128.
 */
enum pm_err
pm_exr_write(const char *path, const struct pm_image *im, bool half,
    struct pm_error *err)
{
	return pm_exr_write_attrs(path, im, half, NULL, err);
}

/* pm_exr_write with attrs (NULL for none) as string attributes. */
enum pm_err
pm_exr_write_attrs(const char *path, const struct pm_image *im, bool half,
    const struct pm_exr_attrs *attrs, struct pm_error *err)
{
	return pm_exr_write_layers(path, im, half, attrs, NULL, err);
}

/* pm_exr_write_attrs with the layers' channels too. */
enum pm_err
pm_exr_write_layers(const char *path, const struct pm_image *im, bool half,
    const struct pm_exr_attrs *attrs, const struct pm_exr_layers *layers,
    struct pm_error *err)
{
	exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
	exr_context_t ctxt = NULL;
	exr_pixel_type_t type = half ? EXR_PIXEL_HALF : EXR_PIXEL_FLOAT;
	struct exr_io io;
	exr_result_t rv;
	struct pm_out out;
	const char *what;
	int part, k;
	size_t i;
	enum pm_err e;

	if (im == NULL || im->rgb == NULL || im->width < 1 || im->height < 1)
		return pm_fail(err, PM_ERR_INVALID, "%s: empty image", path);
	for (i = 0; layers != NULL && i < layers->n; i++)
		if (layers->v[i].im.width != im->width ||
		    layers->v[i].im.height != im->height ||
		    layers->v[i].im.rgb == NULL)
			return pm_fail(err, PM_ERR_INVALID, "%s: a layer's size "
			    "differs from the image's", path);
	/* Checked here: OpenEXRCore 3.1 deadlocks reporting a duplicate
	 * channel (its error callback takes the lock it holds). */
	for (i = 0; layers != NULL && i < layers->n; i++)
		for (k = 0; k < 3; k++) {
			const char *nm = layers->v[i].name[k];
			struct pm_image *img;
			size_t i2;
			int k2;

			if (nm == NULL)
				continue;
			if (nm[0] == '\0' || exr_find(nm, (struct pm_image *)im,
			    NULL, &img, &k2))
				return pm_fail(err, PM_ERR_INVALID, "%s: bad "
				    "channel name '%s'", path, nm);
			for (i2 = 0; i2 <= i; i2++)
				for (k2 = 0; k2 < (i2 == i ? k : 3); k2++)
					if (layers->v[i2].name[k2] != NULL &&
					    strcmp(layers->v[i2].name[k2], nm)
					    == 0)
						return pm_fail(err,
						    PM_ERR_INVALID, "%s: channel "
						    "'%s' given twice", path, nm);
		}
	memset(&io, 0, sizeof(io));
	if ((e = pm_out_open(&out, path, err)) != PM_OK)
		return e;
	io.fd = out.fd;

	init.error_handler_fn = exr_on_error;
	init.user_data = &io;
	init.write_fn = exr_on_write;

	what = "cannot start writing";
	rv = exr_start_write(&ctxt, path, EXR_WRITE_FILE_DIRECTLY, &init);
	if (rv != EXR_ERR_SUCCESS)
		goto fail;
	what = "cannot define the image";
	rv = exr_add_part(ctxt, "rgb", EXR_STORAGE_SCANLINE, &part);
	if (rv == EXR_ERR_SUCCESS)
		rv = exr_initialize_required_attr_simple(ctxt, part,
		    im->width, im->height, half ? EXR_COMPRESSION_PIZ :
		    EXR_COMPRESSION_NONE);
	for (k = 0; k < 3 && rv == EXR_ERR_SUCCESS; k++)
		rv = exr_add_channel(ctxt, part, exr_names[k], type,
		    EXR_PERCEPTUALLY_LOGARITHMIC, 1, 1);
	/* OpenEXR keeps the channel list sorted whatever the order added;
	 * a name given twice is refused there. */
	for (i = 0; layers != NULL && i < layers->n && rv == EXR_ERR_SUCCESS;
	    i++)
		for (k = 0; k < 3 && rv == EXR_ERR_SUCCESS; k++)
			if (layers->v[i].name[k] != NULL)
				rv = exr_add_channel(ctxt, part,
				    layers->v[i].name[k], type,
				    EXR_PERCEPTUALLY_LINEAR, 1, 1);
	if (rv != EXR_ERR_SUCCESS)
		goto fail;
	what = "cannot set a string attribute";
	for (i = 0; attrs != NULL && i < attrs->n; i++)
		if ((rv = exr_attr_set_string(ctxt, part, attrs->v[i].name,
		    attrs->v[i].value)) != EXR_ERR_SUCCESS)
			goto fail;
	what = "cannot write the header";
	if ((rv = exr_write_header(ctxt)) != EXR_ERR_SUCCESS)
		goto fail;
	what = "cannot write the pixels";
	if ((rv = exr_write_pixels(ctxt, im, layers)) != EXR_ERR_SUCCESS)
		goto fail;
	/* exr_finish writes the chunk offset table: the file is only
	 * complete once it succeeds. */
	what = "cannot finish the file";
	rv = exr_finish(&ctxt);
	ctxt = NULL;
	if (rv != EXR_ERR_SUCCESS)
		goto fail;
	return pm_out_commit(&out, err);

fail:
	e = exr_fail(err, exr_code(rv), path, what, rv, &io);
	if (ctxt != NULL)
		exr_finish(&ctxt);
	pm_out_abort(&out);
	return e;
}

/*
 * Points the decoder's R, G and B outputs at the pixel (x0, y0) of im,
 * and those of the layers' channels at their images, as float,
 * interleaved; other channels are left NULL, which OpenEXR skips.
 * Returns how many channels were bound.
 */
static int
exr_bind(exr_decode_pipeline_t *dec, struct pm_image *im,
    const struct pm_exr_layers *layers, int x0, int y0)
{
	int c, k, found = 0;

	for (c = 0; c < dec->channel_count; c++) {
		exr_coding_channel_info_t *ch = &dec->channels[c];
		struct pm_image *img;

		ch->decode_to_ptr = NULL;
		if (!exr_find(ch->channel_name, im, layers, &img, &k))
			continue;
		ch->user_pixel_stride = 3 * sizeof(float);
		ch->user_line_stride = 3 * sizeof(float) * im->width;
		ch->user_data_type = EXR_PIXEL_FLOAT;
		ch->user_bytes_per_element = sizeof(float);
		ch->decode_to_ptr = (uint8_t *)(img->rgb +
		    ((size_t)y0 * im->width + x0) * 3 + k);
		found++;
	}
	return found;
}

/*
 * Decodes one chunk into im at (x0, y0) after checking that it lies
 * inside; the pipeline is initialised on first use.
 */
static exr_result_t
exr_decode_chunk(exr_context_t ctxt, exr_decode_pipeline_t *dec, int *started,
    const exr_chunk_info_t *cinfo, struct pm_image *im,
    const struct pm_exr_layers *layers, int nbind, int x0, int y0)
{
	exr_result_t rv;

	if (x0 < 0 || y0 < 0 || cinfo->width < 1 || cinfo->height < 1 ||
	    cinfo->width > im->width - x0 || cinfo->height > im->height - y0)
		return EXR_ERR_CORRUPT_CHUNK;
	rv = *started ? exr_decoding_update(ctxt, 0, cinfo, dec) :
	    exr_decoding_initialize(ctxt, 0, cinfo, dec);
	if (rv != EXR_ERR_SUCCESS)
		return rv;
	*started = 1;
	if (exr_bind(dec, im, layers, x0, y0) != nbind)
		return EXR_ERR_INVALID_ARGUMENT;
	/* Choosing again each chunk is cheap and follows any change of
	 * chunk shape, such as a short last block. */
	rv = exr_decoding_choose_default_routines(ctxt, 0, dec);
	if (rv != EXR_ERR_SUCCESS)
		return rv;
	return exr_decoding_run(ctxt, 0, dec);
}

/* Reads every scanline chunk of part 0; dw is its data window. */
static exr_result_t
exr_read_scanlines(exr_context_t ctxt, const exr_attr_box2i_t *dw,
    struct pm_image *im, const struct pm_exr_layers *layers, int nbind)
{
	exr_decode_pipeline_t dec = EXR_DECODE_PIPELINE_INITIALIZER;
	exr_chunk_info_t cinfo;
	exr_result_t rv = EXR_ERR_SUCCESS;
	int32_t lines;
	int y, started = 0;

	rv = exr_get_scanlines_per_chunk(ctxt, 0, &lines);
	if (rv != EXR_ERR_SUCCESS)
		return rv;
	if (lines < 1)
		return EXR_ERR_INVALID_ATTR;
	for (y = dw->min.y; y <= dw->max.y; y += lines) {
		rv = exr_read_scanline_chunk_info(ctxt, 0, y, &cinfo);
		if (rv != EXR_ERR_SUCCESS)
			break;
		rv = exr_decode_chunk(ctxt, &dec, &started, &cinfo, im,
		    layers, nbind, cinfo.start_x - dw->min.x,
		    cinfo.start_y - dw->min.y);
		if (rv != EXR_ERR_SUCCESS)
			break;
		/* Guards against a loop that cannot advance. */
		if (dw->max.y - y < lines)
			break;
	}
	if (started)
		exr_decoding_destroy(ctxt, &dec);
	return rv;
}

/* Reads the tiles of level 0 of part 0. */
static exr_result_t
exr_read_tiles(exr_context_t ctxt, struct pm_image *im,
    const struct pm_exr_layers *layers, int nbind)
{
	exr_decode_pipeline_t dec = EXR_DECODE_PIPELINE_INITIALIZER;
	exr_chunk_info_t cinfo;
	exr_result_t rv;
	int32_t tw, th, lw, lh;
	int tx, ty, ntx, nty, started = 0;

	rv = exr_get_tile_sizes(ctxt, 0, 0, 0, &tw, &th);
	if (rv == EXR_ERR_SUCCESS)
		rv = exr_get_level_sizes(ctxt, 0, 0, 0, &lw, &lh);
	if (rv != EXR_ERR_SUCCESS)
		return rv;
	if (tw < 1 || th < 1 || lw != im->width || lh != im->height)
		return EXR_ERR_INVALID_ATTR;
	ntx = (int)(((int64_t)lw + tw - 1) / tw);
	nty = (int)(((int64_t)lh + th - 1) / th);
	for (ty = 0; ty < nty && rv == EXR_ERR_SUCCESS; ty++) {
		for (tx = 0; tx < ntx; tx++) {
			rv = exr_read_tile_chunk_info(ctxt, 0, tx, ty, 0, 0,
			    &cinfo);
			if (rv != EXR_ERR_SUCCESS)
				break;
			rv = exr_decode_chunk(ctxt, &dec, &started, &cinfo, im,
			    layers, nbind, tx * tw, ty * th);
			if (rv != EXR_ERR_SUCCESS)
				break;
		}
	}
	if (started)
		exr_decoding_destroy(ctxt, &dec);
	return rv;
}

/* Copies the string attributes of part 0 but "name" and "type" into a. */
static enum pm_err
exr_read_strings(exr_const_context_t ctxt, const char *path,
    struct pm_exr_attrs *a, const struct exr_io *io, struct pm_error *err)
{
	const exr_attribute_t *at;
	exr_result_t rv;
	int32_t count, i;
	enum pm_err e;

	if ((rv = exr_get_attribute_count(ctxt, 0, &count)) != EXR_ERR_SUCCESS)
		return exr_fail(err, exr_code(rv), path, "bad header", rv, io);
	for (i = 0; i < count; i++) {
		rv = exr_get_attribute_by_index(ctxt, 0,
		    EXR_ATTR_LIST_FILE_ORDER, i, &at);
		if (rv != EXR_ERR_SUCCESS)
			return exr_fail(err, exr_code(rv), path, "bad header",
			    rv, io);
		if (at->type != EXR_ATTR_STRING || at->string == NULL ||
		    strcmp(at->name, "name") == 0 ||
		    strcmp(at->name, "type") == 0)
			continue;
		e = exr_attrs_setn(a, at->name, at->string->str != NULL ?
		    at->string->str : "", at->string->length > 0 ?
		    (size_t)at->string->length : 0, err);
		if (e != PM_OK)
			return e;
	}
	return PM_OK;
}

/* Reads R, G and B of the first part of path into im, which is allocated
 * here and owned by the caller; the data window gives the size. */
enum pm_err
pm_exr_read(const char *path, struct pm_image *im, struct pm_error *err)
{
	return pm_exr_read_attrs(path, im, NULL, err);
}

/* pm_exr_read that also reads the string attributes into attrs (NULL:
 * not wanted); with im NULL only the header is read. */
enum pm_err
pm_exr_read_attrs(const char *path, struct pm_image *im,
    struct pm_exr_attrs *attrs, struct pm_error *err)
{
	return pm_exr_read_layers(path, im, attrs, NULL, err);
}

/* True for R, G and B, which the image itself holds. */
static bool
exr_is_rgb(const char *name)
{
	return strcmp(name, "R") == 0 || strcmp(name, "G") == 0 ||
	    strcmp(name, "B") == 0;
}

/* pm_exr_read_attrs that also reads the other channels into layers. */
enum pm_err
pm_exr_read_layers(const char *path, struct pm_image *im,
    struct pm_exr_attrs *attrs, struct pm_exr_layers *layers,
    struct pm_error *err)
{
	exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
	exr_context_t ctxt = NULL;
	const exr_attr_chlist_t *chl;
	exr_attr_box2i_t dw;
	exr_storage_t storage;
	struct exr_io io;
	exr_result_t rv;
	int64_t w, h;
	int k, c, nbind = 3;
	enum pm_err e;

	if (im != NULL) {
		im->width = im->height = 0;
		im->rgb = NULL;
	}
	if (attrs != NULL)
		pm_exr_attrs_free(attrs);
	if (layers != NULL)
		pm_exr_layers_free(layers);
	memset(&io, 0, sizeof(io));
	io.fd = open(path, O_RDONLY | O_CLOEXEC);
	if (io.fd < 0)
		return pm_fail(err, PM_ERR_IO, "%s: %s", path, strerror(errno));
	init.error_handler_fn = exr_on_error;
	init.user_data = &io;
	init.read_fn = exr_on_read;
	init.size_fn = exr_on_size;
	/* A damaged chunk table should fail, not be guessed around. */
	init.flags = EXR_CONTEXT_FLAG_DISABLE_CHUNK_RECONSTRUCTION;

	rv = exr_start_read(&ctxt, path, &init);
	if (rv != EXR_ERR_SUCCESS) {
		/* A short read here is a file too small to be an image, not
		 * a failing disk. */
		e = exr_fail(err, rv == EXR_ERR_READ_IO && io.read_errno == 0 ?
		    PM_ERR_FORMAT : exr_code(rv), path, "not a readable "
		    "OpenEXR file", rv, &io);
		if (ctxt != NULL)
			exr_finish(&ctxt);
		close(io.fd);
		return e;
	}
	if ((rv = exr_get_storage(ctxt, 0, &storage)) != EXR_ERR_SUCCESS ||
	    (rv = exr_get_data_window(ctxt, 0, &dw)) != EXR_ERR_SUCCESS ||
	    (rv = exr_get_channels(ctxt, 0, &chl)) != EXR_ERR_SUCCESS) {
		e = exr_fail(err, exr_code(rv), path, "bad header", rv, &io);
		goto out;
	}
	if (storage != EXR_STORAGE_SCANLINE && storage != EXR_STORAGE_TILED) {
		e = pm_fail(err, PM_ERR_UNSUPPORTED, "%s: deep images are not "
		    "supported; expected a scanline or tiled image", path);
		goto out;
	}
	/* Checked in the order R, G, B that people name them. */
	for (k = 2; k >= 0; k--) {
		const exr_attr_chlist_entry_t *ent = NULL;

		for (c = 0; c < chl->num_channels; c++)
			if (chl->entries[c].name.str != NULL &&
			    strcmp(chl->entries[c].name.str, exr_names[k]) == 0)
				ent = &chl->entries[c];
		if (ent == NULL) {
			e = pm_fail(err, PM_ERR_FORMAT, "%s: no channel %s; "
			    "expected channels R, G and B", path, exr_names[k]);
			goto out;
		}
		if (ent->x_sampling != 1 || ent->y_sampling != 1) {
			e = pm_fail(err, PM_ERR_UNSUPPORTED, "%s: channel %s is "
			    "subsampled (%d, %d); expected full resolution",
			    path, exr_names[k], ent->x_sampling,
			    ent->y_sampling);
			goto out;
		}
	}
	w = (int64_t)dw.max.x - dw.min.x + 1;
	h = (int64_t)dw.max.y - dw.min.y + 1;
	if (w < 1 || h < 1 || w > INT32_MAX || h > INT32_MAX) {
		e = pm_fail(err, PM_ERR_FORMAT, "%s: bad data window "
		    "(%d, %d)-(%d, %d)", path, dw.min.x, dw.min.y, dw.max.x,
		    dw.max.y);
		goto out;
	}
	if (attrs != NULL &&
	    (e = exr_read_strings(ctxt, path, attrs, &io, err)) != PM_OK)
		goto out;
	if (im == NULL) {
		e = PM_OK;
		goto out;
	}
	if ((e = pm_image_alloc(im, (int)w, (int)h, err)) == PM_OK &&
	    layers != NULL) {
		/* The other channels, three to a layer in list order, all of
		 * them within the pixels one image may have. */
		const char *nm[3];
		int m = 0;
		size_t extra = 0;

		for (c = 0; c < chl->num_channels; c++)
			if (chl->entries[c].name.str != NULL &&
			    !exr_is_rgb(chl->entries[c].name.str))
				extra++;
		if ((extra + 2) / 3 + 1 > PM_IMAGE_MAX_PIXELS / ((size_t)w *
		    (size_t)h)) {
			e = pm_fail(err, PM_ERR_LIMIT, "%s: %zu channels of "
			    "%lldx%lld pixels: more than %zu pixels of film "
			    "in all", path, extra + 3, (long long)w,
			    (long long)h, (size_t)PM_IMAGE_MAX_PIXELS);
			pm_image_free(im);
			goto out;
		}
		for (c = 0; c <= chl->num_channels && e == PM_OK; c++) {
			const exr_attr_chlist_entry_t *ent = c <
			    chl->num_channels ? &chl->entries[c] : NULL;

			if (ent != NULL && (ent->name.str == NULL ||
			    exr_is_rgb(ent->name.str)))
				continue;
			if (ent != NULL && (ent->x_sampling != 1 ||
			    ent->y_sampling != 1)) {
				e = pm_fail(err, PM_ERR_UNSUPPORTED, "%s: "
				    "channel %s is subsampled (%d, %d); "
				    "expected full resolution", path,
				    ent->name.str, ent->x_sampling,
				    ent->y_sampling);
				break;
			}
			if (ent != NULL)
				nm[m++] = ent->name.str;
			if (m == 3 || (ent == NULL && m > 0)) {
				while (m < 3)
					nm[m++] = NULL;
				e = pm_exr_layers_add(layers, nm[0], nm[1],
				    nm[2], (int)w, (int)h, NULL, err);
				nbind += (nm[0] != NULL) + (nm[1] != NULL) +
				    (nm[2] != NULL);
				m = 0;
			}
		}
		if (e != PM_OK) {
			pm_image_free(im);
			pm_exr_layers_free(layers);
			goto out;
		}
	}
	if (e != PM_OK) {
		/* Put the file name in front of the allocator's message. */
		char msg[sizeof(err->msg)];

		if (err != NULL) {
			snprintf(msg, sizeof(msg), "%s", err->msg);
			pm_fail(err, e, "%s: %s", path, msg);
		}
		goto out;
	}
	if (storage == EXR_STORAGE_SCANLINE)
		rv = exr_read_scanlines(ctxt, &dw, im, layers, nbind);
	else
		rv = exr_read_tiles(ctxt, im, layers, nbind);
	if (rv == EXR_ERR_READ_IO && io.read_errno == 0) {
		e = pm_fail(err, PM_ERR_TRUNCATED, "%s: truncated: the file "
		    "ends inside its pixel data", path);
		pm_image_free(im);
		goto out;
	}
	if (rv != EXR_ERR_SUCCESS) {
		e = exr_fail(err, exr_code(rv), path, "cannot read the pixels",
		    rv, &io);
		pm_image_free(im);
		goto out;
	}
	e = PM_OK;
out:
	if (e != PM_OK && attrs != NULL)
		pm_exr_attrs_free(attrs);
	if (e != PM_OK && layers != NULL)
		pm_exr_layers_free(layers);
	exr_finish(&ctxt);
	close(io.fd);
	return e;
}
