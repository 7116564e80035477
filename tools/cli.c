/*
 * cli.c: helpers shared by the tools' mains (see cli.h).
 */
#include <errno.h>
#include <libgen.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "cli.h"

double
pm_cli_now(void)
{
	struct timespec ts;

	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

int
pm_cli_check_output(const char *prog, const char *path, int force)
{
	char *copy, *dir;
	int ok;

	if (strcmp(path, "-") == 0) {
		if (isatty(STDOUT_FILENO)) {
			fprintf(stderr, "%s: refusing to write binary output to "
			    "a terminal\n", prog);
			return 0;
		}
		return 1;
	}
	if (!force && access(path, F_OK) == 0) {
		fprintf(stderr, "%s: %s: already exists (use -f to overwrite)\n",
		    prog, path);
		return 0;
	}
	copy = strdup(path);
	if (copy == NULL) {
		fprintf(stderr, "%s: out of memory\n", prog);
		return 0;
	}
	dir = dirname(copy);
	ok = access(dir, W_OK) == 0;
	if (!ok)
		fprintf(stderr, "%s: %s: cannot write to directory %s: %s\n",
		    prog, path, dir, strerror(errno));
	free(copy);
	return ok;
}

char *
pm_cli_join_args(int argc, char **argv)
{
	size_t len = 1, off = 0, n;
	char *s;
	int i;

	for (i = 0; i < argc; i++)
		len += strlen(argv[i]) + 1;
	s = malloc(len);
	if (s == NULL)
		return NULL;
	for (i = 0; i < argc; i++) {
		if (i > 0)
			s[off++] = ' ';
		n = strlen(argv[i]);
		memcpy(s + off, argv[i], n);
		off += n;
	}
	s[off] = '\0';
	return s;
}
