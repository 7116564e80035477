/*
 * file.h: the two ways the formats meet the file system: reading a whole
 * file into memory, and writing an output through a temporary file that
 * is renamed into place, so that an output is either complete or not
 * there at all.
 */
#ifndef PM_FILE_H
#define PM_FILE_H

#include <stddef.h>

#include "../common/error.h"

/*
 * Reads the file at path into a new buffer, *buf (the caller frees it),
 * of *len bytes followed by a NUL that text parsers may rely on.  A file
 * larger than max bytes is PM_ERR_LIMIT.
 */
enum pm_err pm_read_file(const char *path, size_t max, char **buf,
    size_t *len, struct pm_error *err);

/* An output being written: fd is its temporary file, -1 once closed; tmp
 * its name, empty while it has none (an O_TMPFILE file, named by
 * pm_out_commit, so that a killed run leaves nothing). */
struct pm_out {
	const char *path;
	char tmp[4096];
	int fd;
};

/* Creates the temporary file beside path for o->fd (see tmpfile.h). */
enum pm_err pm_out_open(struct pm_out *o, const char *path,
    struct pm_error *err);

/*
 * Closes o->fd, which must be open (the temporary file may be unnamed until
 * now: write through a dup to use stdio), and renames the temporary file
 * to the output's path; on failure removes it.
 */
enum pm_err pm_out_commit(struct pm_out *o, struct pm_error *err);

/* Closes o->fd unless already closed and removes the temporary file:
 * what a writer does when it fails. */
void pm_out_abort(struct pm_out *o);

#endif
