/*
 * tmpfile.h: the temporary file every writer goes through (by way of
 * file.h's pm_out), so that an output is either complete (renamed into
 * place) or not there at all.
 */
#ifndef PM_TMPFILE_H
#define PM_TMPFILE_H

#include <stddef.h>

/*
 * Creates a new file beside path, named path.tmpPID.N, with the usual
 * permissions (0666 less the umask: O_EXCL rather than mkstemp, whose 0600
 * would survive the rename); its name goes to tmp.  Returns the descriptor,
 * or -1 with errno set.
 */
int pm_open_temp(const char *path, char *tmp, size_t tmpsize);

/* The next such name (path.tmpPID.N) into tmp; -1 with errno
 * ENAMETOOLONG if it does not fit. */
int pm_temp_name(const char *path, char *tmp, size_t tmpsize);

#endif
