/*
 * tmpfile.c: unique temporary files beside an output (see tmpfile.h).
 */
#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <unistd.h>

#include "tmpfile.h"

int
pm_temp_name(const char *path, char *tmp, size_t tmpsize)
{
	static _Atomic unsigned serial;
	int n = snprintf(tmp, tmpsize, "%s.tmp%ld.%u", path, (long)getpid(),
	    serial++);

	if (n < 0 || (size_t)n >= tmpsize) {
		errno = ENAMETOOLONG;
		return -1;
	}
	return 0;
}

int
pm_open_temp(const char *path, char *tmp, size_t tmpsize)
{
	int fd, tries;

	for (tries = 0; tries < 100; tries++) {
		if (pm_temp_name(path, tmp, tmpsize) != 0)
			return -1;
		fd = open(tmp, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
		if (fd >= 0 || errno != EEXIST)
			return fd;
	}
	return -1;
}
