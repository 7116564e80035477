/*
 * merl.c: the MERL BRDF file format (.binary), read and written.
 *
 * The reader accepts exactly what the MERL database ships: the header's
 * dimensions must be 90, 90, 180 and the file exactly 34,992,012 bytes;
 * anything else is an error naming the file and what was wrong.  Bytes are
 * decoded as little-endian whatever the host, and no read goes beyond the
 * length the caller gave.  Stored doubles become floats of f_r (scale
 * applied); negative samples (below the horizon) and non-finite ones
 * become 0, the value the renderer would use for them anyway.
 *
 * The writer lays out what common/merl.c tabulates of an analytic BRDF at
 * the centre of every bin, so a table looked up at those directions gives
 * the model back to float rounding.
 */
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include <zlib.h>

#include "endian.h"
#include "file.h"
#include "merl.h"

static const double scale[3] = {PM_MERL_SCALE_R, PM_MERL_SCALE_G,
    PM_MERL_SCALE_B};

/* Tabulates a model in the file layout into buf (PM_MERL_FILE_SIZE). */
void
pm_merl_encode(const struct pm_merl_model *mo, unsigned char *buf)
{
	int ith, itd, ipd, c;

	pm_put_le32(buf, PM_MERL_NTH);
	pm_put_le32(buf + 4, PM_MERL_NTD);
	pm_put_le32(buf + 8, PM_MERL_NPD);
	for (ith = 0; ith < PM_MERL_NTH; ith++)
		for (itd = 0; itd < PM_MERL_NTD; itd++)
			for (ipd = 0; ipd < PM_MERL_NPD; ipd++) {
				size_t idx = (size_t)ipd + PM_MERL_NPD *
				    ((size_t)itd + PM_MERL_NTD * (size_t)ith);
				double v[3];

				pm_merl_model_bin(mo, ith, itd, ipd, v);
				for (c = 0; c < 3; c++)
					pm_put_f64(buf + 12 + 8 * ((size_t)c *
					    PM_MERL_N + idx), v[c]);
			}
}

static enum pm_err
write_all(int fd, const char *name, const unsigned char *p, size_t n,
    struct pm_error *err)
{
	ssize_t w;

	while (n > 0) {
		w = write(fd, p, n);
		if (w < 0) {
			if (errno == EINTR)
				continue;
			return pm_fail(err, PM_ERR_IO, "%s: write failed: %s",
			    name, strerror(errno));
		}
		p += w;
		n -= (size_t)w;
	}
	return PM_OK;
}

/* Writes a model to path via a renamed temporary file ("-": stdout). */
enum pm_err
pm_merl_write(const char *path, const struct pm_merl_model *mo,
    struct pm_error *err)
{
	bool to_stdout = strcmp(path, "-") == 0;
	const char *name = to_stdout ? "standard output" : path;
	unsigned char *buf;
	struct pm_out out;
	enum pm_err r;

	if ((buf = malloc(PM_MERL_FILE_SIZE)) == NULL)
		return pm_fail(err, PM_ERR_NOMEM, "%s: no memory for %zu bytes",
		    name, PM_MERL_FILE_SIZE);
	pm_merl_encode(mo, buf);
	if (to_stdout) {
		r = write_all(STDOUT_FILENO, name, buf, PM_MERL_FILE_SIZE, err);
		goto done;
	}
	if ((r = pm_out_open(&out, path, err)) != PM_OK)
		goto done;
	r = write_all(out.fd, name, buf, PM_MERL_FILE_SIZE, err);
	if (r == PM_OK)
		r = pm_out_commit(&out, err);
	else
		pm_out_abort(&out);
done:
	free(buf);
	return r;
}

/*
 * Checks what the first len bytes of a file of total size bytes say:
 * a header with MERL's dimensions, and exactly the size they imply.
 */
static enum pm_err
check(const unsigned char *p, size_t len, uint64_t size, const char *name,
    struct pm_error *err)
{
	int32_t d[3];
	int i;

	if (size == 0)
		return pm_fail(err, PM_ERR_FORMAT, "%s: empty file, not a MERL "
		    "BRDF (expected %zu bytes)", name, PM_MERL_FILE_SIZE);
	if (len < 12)
		return pm_fail(err, PM_ERR_TRUNCATED, "%s: %llu bytes, too short "
		    "for a MERL BRDF header (12 bytes)", name,
		    (unsigned long long)size);
	for (i = 0; i < 3; i++)
		d[i] = (int32_t)pm_get_le32(p + 4 * i);
	if (d[0] != PM_MERL_NTH || d[1] != PM_MERL_NTD || d[2] != PM_MERL_NPD)
		return pm_fail(err, PM_ERR_FORMAT, "%s: not a MERL BRDF: "
		    "dimensions %ld x %ld x %ld, expected 90 x 90 x 180", name,
		    (long)d[0], (long)d[1], (long)d[2]);
	if (size < PM_MERL_FILE_SIZE)
		return pm_fail(err, PM_ERR_TRUNCATED, "%s: truncated MERL BRDF: "
		    "%llu bytes, expected %zu", name, (unsigned long long)size,
		    PM_MERL_FILE_SIZE);
	if (size > PM_MERL_FILE_SIZE)
		return pm_fail(err, PM_ERR_FORMAT, "%s: %llu bytes, but a MERL "
		    "BRDF has exactly %zu (trailing data)", name,
		    (unsigned long long)size, PM_MERL_FILE_SIZE);
	return PM_OK;
}

/* Parses a whole file in memory into a prepared table. */
enum pm_err
pm_merl_parse(const void *buf, size_t len, const char *name,
    struct pm_merl **out, struct pm_error *err)
{
	const unsigned char *p = buf;
	struct pm_merl *m;
	enum pm_err r;
	size_t i;
	int c;

	*out = NULL;
	if (name == NULL)
		name = "<buffer>";
	if ((r = check(p, len, len, name, err)) != PM_OK)
		return r;
	if ((m = pm_merl_new(err)) == NULL)
		return PM_ERR_NOMEM;
	for (c = 0; c < 3; c++) {
		const unsigned char *q = p + 12 + 8 * (size_t)c * PM_MERL_N;
		for (i = 0; i < PM_MERL_N; i++) {
			double v = pm_get_f64(q + 8 * i) * scale[c];

			/* below the horizon (negative) or not a number */
			m->f[3 * i + (size_t)c] = v > 0.0 && v < 3.4e38 ?
			    (float)v : 0.0f;
		}
	}
	m->crc = (uint32_t)crc32(crc32(0L, Z_NULL, 0), p, (uInt)len);
	m->size = len;
	if ((r = pm_merl_prepare(m, err)) != PM_OK) {
		pm_merl_free(m);
		return r;
	}
	*out = m;
	return PM_OK;
}

/* Reads, checks and prepares the file at path. */
enum pm_err
pm_merl_read(const char *path, struct pm_merl **out, struct pm_error *err)
{
	unsigned char *buf = NULL;
	size_t got = 0, want = PM_MERL_FILE_SIZE + 1;
	struct stat st;
	enum pm_err r;
	ssize_t n;
	int fd;

	*out = NULL;
	if ((fd = open(path, O_RDONLY | O_CLOEXEC)) < 0)
		return pm_fail(err, PM_ERR_IO, "%s: %s", path, strerror(errno));
	if (fstat(fd, &st) == 0 && S_ISREG(st.st_mode) &&
	    (uint64_t)st.st_size != PM_MERL_FILE_SIZE) {
		/* the size alone decides; read no more than the header */
		unsigned char h[12];

		while (got < sizeof(h) && (n = read(fd, h + got,
		    sizeof(h) - got)) != 0) {
			if (n < 0 && errno == EINTR)
				continue;
			if (n < 0)
				break;
			got += (size_t)n;
		}
		close(fd);
		r = check(h, got, (uint64_t)st.st_size, path, err);
		if (r == PM_OK)	/* the file changed under us */
			r = pm_fail(err, PM_ERR_IO, "%s: size changed while "
			    "reading", path);
		return r;
	}
	/* one byte more than a MERL file, to tell one that is too long */
	if ((buf = malloc(want)) == NULL) {
		close(fd);
		return pm_fail(err, PM_ERR_NOMEM, "%s: no memory for %zu bytes",
		    path, want);
	}
	while (got < want && (n = read(fd, buf + got, want - got)) != 0) {
		if (n < 0) {
			if (errno == EINTR)
				continue;
			r = pm_fail(err, PM_ERR_IO, "%s: %s", path,
			    strerror(errno));
			close(fd);
			free(buf);
			return r;
		}
		got += (size_t)n;
	}
	close(fd);
	r = pm_merl_parse(buf, got, path, out, err);
	free(buf);
	if (r == PM_OK && ((*out)->path = strdup(path)) == NULL) {
		pm_merl_free(*out);
		*out = NULL;
		r = pm_fail(err, PM_ERR_NOMEM, "%s: out of memory", path);
	}
	return r;
}
