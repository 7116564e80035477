/*
 * vol.c: Mitsuba's .vol grids (vol.h has the layout).  Bytes are
 * assembled explicitly, so the files are the same on any host.
 */
#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "endian.h"
#include "file.h"
#include "vol.h"

enum pm_err
pm_vol_parse(const void *buf, size_t len, const char *name,
    struct pm_grid *g, struct pm_error *err)
{
	const unsigned char *b = buf;
	int32_t dim[4];
	size_t n, i;
	int k;

	memset(g, 0, sizeof(*g));
	if (len < PM_VOL_HEADER)
		return pm_fail(err, len >= 3 && memcmp(b, "VOL", 3) == 0 ?
		    PM_ERR_TRUNCATED : PM_ERR_FORMAT, "%s: %s", name,
		    len >= 3 && memcmp(b, "VOL", 3) == 0 ? "truncated .vol "
		    "header" : "not a .vol grid (no \"VOL\" header)");
	if (memcmp(b, "VOL", 3) != 0)
		return pm_fail(err, PM_ERR_FORMAT, "%s: not a .vol grid (no "
		    "\"VOL\" header)", name);
	if (b[3] != 3)
		return pm_fail(err, PM_ERR_UNSUPPORTED, "%s: .vol version %d "
		    "(only 3 is read)", name, b[3]);
	if (pm_get_le32(b + 4) != 1)
		return pm_fail(err, PM_ERR_UNSUPPORTED, "%s: .vol encoding %u "
		    "(only 1, float32, is read)", name,
		    (unsigned)pm_get_le32(b + 4));
	for (k = 0; k < 4; k++)
		dim[k] = (int32_t)pm_get_le32(b + 8 + 4 * k);
	if (dim[0] <= 0 || dim[1] <= 0 || dim[2] <= 0)
		return pm_fail(err, PM_ERR_FORMAT, "%s: grid size %d x %d x %d",
		    name, (int)dim[0], (int)dim[1], (int)dim[2]);
	if (dim[3] != 1 && dim[3] != 3)
		return pm_fail(err, PM_ERR_UNSUPPORTED, "%s: %d channels (pm "
		    "reads 1 or 3)", name, (int)dim[3]);
	n = (size_t)dim[0];
	if (n > PM_VOL_MAX_VALUES / (size_t)dim[1] ||
	    (n *= (size_t)dim[1]) > PM_VOL_MAX_VALUES / (size_t)dim[2] ||
	    (n *= (size_t)dim[2]) > PM_VOL_MAX_VALUES / (size_t)dim[3])
		return pm_fail(err, PM_ERR_LIMIT, "%s: grid %d x %d x %d x %d "
		    "is larger than pm reads (%zu values)", name, (int)dim[0],
		    (int)dim[1], (int)dim[2], (int)dim[3], PM_VOL_MAX_VALUES);
	n *= (size_t)dim[3];
	if ((len - PM_VOL_HEADER) / 4 < n)
		return pm_fail(err, PM_ERR_TRUNCATED, "%s: truncated .vol grid "
		    "(%zu bytes of voxels, %zu wanted)", name,
		    len - PM_VOL_HEADER, 4 * n);
	if (len - PM_VOL_HEADER != 4 * n)
		return pm_fail(err, PM_ERR_FORMAT, "%s: %zu bytes after the "
		    ".vol grid's voxels", name, len - PM_VOL_HEADER - 4 * n);
	for (k = 0; k < 6; k++)
		g->bbox[k] = pm_get_f32(b + 24 + 4 * k);
	if ((g->data = malloc(n * sizeof(float))) == NULL)
		return pm_fail(err, PM_ERR_NOMEM, "%s: out of memory for %zu "
		    "voxel values", name, n);
	g->nx = dim[0];
	g->ny = dim[1];
	g->nz = dim[2];
	g->nch = dim[3];
	g->max = 0.0f;
	for (i = 0; i < n; i++) {
		float v = pm_get_f32(b + PM_VOL_HEADER + 4 * i);

		if (!isfinite(v)) {
			pm_grid_free(g);
			return pm_fail(err, PM_ERR_FORMAT, "%s: voxel value %zu "
			    "is not finite", name, i);
		}
		g->data[i] = v;
		if (i == 0 || v > g->max)
			g->max = v;
	}
	return PM_OK;
}

enum pm_err
pm_vol_read(const char *path, struct pm_grid *g, struct pm_error *err)
{
	char *buf;
	size_t len;
	enum pm_err e;

	memset(g, 0, sizeof(*g));
	if ((e = pm_read_file(path, PM_VOL_HEADER + 4 * PM_VOL_MAX_VALUES,
	    &buf, &len, err)) != PM_OK)
		return e;
	e = pm_vol_parse(buf, len, path, g, err);
	free(buf);
	return e;
}

void
pm_vol_encode(const struct pm_grid *g, unsigned char *buf)
{
	size_t n = (size_t)g->nx * (size_t)g->ny * (size_t)g->nz *
	    (size_t)g->nch, i;
	int k;

	memcpy(buf, "VOL", 3);
	buf[3] = 3;
	pm_put_le32(buf + 4, 1);
	pm_put_le32(buf + 8, (uint32_t)g->nx);
	pm_put_le32(buf + 12, (uint32_t)g->ny);
	pm_put_le32(buf + 16, (uint32_t)g->nz);
	pm_put_le32(buf + 20, (uint32_t)g->nch);
	for (k = 0; k < 6; k++)
		pm_put_f32(buf + 24 + 4 * k, g->bbox[k]);
	for (i = 0; i < n; i++)
		pm_put_f32(buf + PM_VOL_HEADER + 4 * i, g->data[i]);
}

enum pm_err
pm_vol_write(const char *path, const struct pm_grid *g, struct pm_error *err)
{
	size_t n = PM_VOL_HEADER + 4 * (size_t)g->nx * (size_t)g->ny *
	    (size_t)g->nz * (size_t)g->nch;
	unsigned char *buf, *p;
	struct pm_out out;
	enum pm_err e;
	ssize_t w;

	if ((buf = malloc(n)) == NULL)
		return pm_fail(err, PM_ERR_NOMEM, "%s: out of memory", path);
	pm_vol_encode(g, buf);
	if ((e = pm_out_open(&out, path, err)) != PM_OK) {
		free(buf);
		return e;
	}
	for (p = buf; n > 0; p += w, n -= (size_t)w) {
		w = write(out.fd, p, n);
		if (w < 0 && errno == EINTR) {
			w = 0;
			continue;
		}
		if (w < 0) {
			e = pm_fail(err, PM_ERR_IO, "%s: write failed: %s", path,
			    strerror(errno));
			pm_out_abort(&out);
			free(buf);
			return e;
		}
	}
	free(buf);
	if ((e = pm_out_commit(&out, err)) != PM_OK)
		return e;
	return PM_OK;
}
