/*
 * file.c: whole-file reads and outputs renamed into place (see file.h).
 */
#define _GNU_SOURCE	/* renameat2 */
#include <sys/stat.h>

#include <errno.h>
#include <fcntl.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "file.h"
#include "tmpfile.h"

enum pm_err
pm_read_file(const char *path, size_t max, char **buf, size_t *len,
    struct pm_error *err)
{
	FILE *f;
	char *p = NULL, *q;
	size_t cap = 0, n = 0, got;
	int saved;

	if ((f = fopen(path, "rb")) == NULL)
		return pm_fail(err, PM_ERR_IO, "%s: %s", path, strerror(errno));
	for (;;) {
		/* Room for at least one byte and the NUL. */
		if (cap - n < 2) {
			size_t ncap = cap == 0 ? 65536 : 2 * cap;

			if (ncap < cap || (q = realloc(p, ncap)) == NULL) {
				free(p);
				fclose(f);
				return pm_fail(err, PM_ERR_NOMEM, "%s: out of "
				    "memory reading the file", path);
			}
			p = q;
			cap = ncap;
		}
		got = fread(p + n, 1, cap - n - 1, f);
		n += got;
		if (n > max) {
			free(p);
			fclose(f);
			return pm_fail(err, PM_ERR_LIMIT,
			    "%s: larger than %zu bytes", path, max);
		}
		if (got == 0)
			break;
	}
	if (ferror(f)) {
		saved = errno;
		free(p);
		fclose(f);
		return pm_fail(err, PM_ERR_IO, "%s: read error: %s", path,
		    strerror(saved));
	}
	fclose(f);
	p[n] = '\0';
	*buf = p;
	*len = n;
	return PM_OK;
}

enum pm_err
pm_out_open(struct pm_out *o, const char *path, struct pm_error *err)
{
	o->path = path;
	o->fd = pm_open_temp(path, o->tmp, sizeof(o->tmp));
	if (o->fd < 0)
		return pm_fail(err, PM_ERR_IO, "%s: cannot create a temporary "
		    "file beside it: %s", path, strerror(errno));
	return PM_OK;
}

/*
 * Puts tmp in the place of the regular file at path by swapping the two
 * names in one step (readers see the old file or the new one, as with
 * rename), then removes the old file under tmp's name; false, with
 * nothing changed, where path is not a regular file or the system
 * cannot swap.  Why not rename: ext4 (auto_da_alloc, on by default)
 * starts writing back a file that a rename puts over an existing one
 * before rename returns, for programs that replace files without fsync;
 * for a 44 MB photon map that was 34-64 ms of a 0.35 s pm-shoot, every
 * rerun of a pipeline step.  Outputs here are caches remade by make,
 * and a map or image damaged by a crash fails its checksum or decoder,
 * so they are replaced atomically but not durably, as before.
 */
static bool
replace_regular(const char *tmp, const char *path)
{
#ifdef RENAME_EXCHANGE
	struct stat st;

	if (lstat(path, &st) != 0 || !S_ISREG(st.st_mode))
		return false;
	if (renameat2(AT_FDCWD, tmp, AT_FDCWD, path, RENAME_EXCHANGE) != 0)
		return false;
	/* tmp is the old file now; left behind only if the directory
	 * refuses an unlink it has just allowed a create in. */
	(void)unlink(tmp);
	return true;
#else
	(void)tmp;
	(void)path;
	return false;
#endif
}

enum pm_err
pm_out_commit(struct pm_out *o, struct pm_error *err)
{
	enum pm_err e;

	/* close reports what a full disk or NFS held back until now. */
	if (o->fd >= 0 && close(o->fd) != 0) {
		o->fd = -1;
		e = pm_fail(err, PM_ERR_IO, "%s: write failed: %s", o->path,
		    strerror(errno));
		unlink(o->tmp);
		return e;
	}
	o->fd = -1;
	if (replace_regular(o->tmp, o->path))
		return PM_OK;
	if (rename(o->tmp, o->path) != 0) {
		e = pm_fail(err, PM_ERR_IO, "%s: cannot rename %s to it: %s",
		    o->path, o->tmp, strerror(errno));
		unlink(o->tmp);
		return e;
	}
	return PM_OK;
}

void
pm_out_abort(struct pm_out *o)
{
	if (o->fd >= 0)
		close(o->fd);
	o->fd = -1;
	unlink(o->tmp);
}
