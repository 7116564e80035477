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

static bool replace_regular(const char *tmp, const char *path);

/*
 * An unnamed file in the directory of path (O_TMPFILE), named only once
 * complete: a run killed while writing (pm-shoot writes its map for the
 * whole of its run) leaves nothing behind.  -1 where the system, the file
 * system or a missing /proc (which naming it takes) has none.
 */
static int
open_unnamed(const char *path)
{
#ifdef O_TMPFILE
	const char *slash = strrchr(path, '/');
	char dir[4096];
	size_t n;

	if (access("/proc/self/fd", X_OK) != 0)
		return -1;
	if (slash == NULL)
		return open(".", O_TMPFILE | O_WRONLY | O_CLOEXEC, 0666);
	n = slash == path ? 1 : (size_t)(slash - path);
	if (n >= sizeof(dir))
		return -1;
	memcpy(dir, path, n);
	dir[n] = '\0';
	return open(dir, O_TMPFILE | O_WRONLY | O_CLOEXEC, 0666);
#else
	(void)path;
	return -1;
#endif
}

/* Links the unnamed file o->fd under a new temporary name, o->tmp; -1
 * with errno set on failure. */
static int
name_unnamed(struct pm_out *o)
{
	char proc[64];
	int tries;

	snprintf(proc, sizeof(proc), "/proc/self/fd/%d", o->fd);
	for (tries = 0; tries < 100; tries++) {
		if (pm_temp_name(o->path, o->tmp, sizeof(o->tmp)) != 0)
			return -1;
		if (linkat(AT_FDCWD, proc, AT_FDCWD, o->tmp,
		    AT_SYMLINK_FOLLOW) == 0)
			return 0;
		if (errno != EEXIST)
			break;
	}
	o->tmp[0] = '\0';
	return -1;
}

enum pm_err
pm_out_open(struct pm_out *o, const char *path, struct pm_error *err)
{
	o->path = path;
	o->tmp[0] = '\0';
	if ((o->fd = open_unnamed(path)) >= 0)
		return PM_OK;
	o->fd = pm_open_temp(path, o->tmp, sizeof(o->tmp));
	if (o->fd < 0)
		return pm_fail(err, PM_ERR_IO, "%s: cannot create a temporary "
		    "file beside it: %s", path, strerror(errno));
	return PM_OK;
}

enum pm_err
pm_out_commit(struct pm_out *o, struct pm_error *err)
{
	enum pm_err e;

	if (o->tmp[0] == '\0' && name_unnamed(o) != 0) {
		e = pm_fail(err, PM_ERR_IO, "%s: cannot name the finished "
		    "file: %s", o->path, strerror(errno));
		close(o->fd);
		o->fd = -1;
		return e;
	}
	/* close reports what a full disk or NFS held back until now. */
	if (close(o->fd) != 0) {
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
	if (o->tmp[0] != '\0')
		unlink(o->tmp);
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

