/*
 * tmpdir.c: the unit tests' scratch directories (tmpdir.h).
 */
#define _GNU_SOURCE	/* nftw, program_invocation_short_name */

#include <errno.h>
#include <ftw.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "tmpdir.h"

int
pm_tmpdir_make(char *dir, size_t size, const char *name)
{
	const char *base = getenv("TMPDIR");
	int n;

	if (base == NULL || *base == '\0')
		base = "/tmp";
	n = snprintf(dir, size, "%s/pm-test-%s.XXXXXX", base, name);
	if (n < 0 || (size_t)n >= size)
		return -1;
	return mkdtemp(dir) == NULL ? -1 : 0;
}

/* nftw's callback: with FTW_DEPTH a directory comes after its contents. */
static int
remove_one(const char *path, const struct stat *st, int flag, struct FTW *f)
{
	(void)st;
	(void)flag;
	(void)f;
	return remove(path);
}

int
pm_tmpdir_remove(const char *dir)
{
	return nftw(dir, remove_one, 16, FTW_DEPTH | FTW_PHYS) == 0 ? 0 : -1;
}

char pm_test_dir[64];

int
pm_tmpdir_setup(void **state)
{
	(void)state;
	/* "test_pmap" makes pm-test-pmap.XXXXXX */
	return pm_tmpdir_make(pm_test_dir, sizeof(pm_test_dir),
	    program_invocation_short_name + (strncmp(
	    program_invocation_short_name, "test_", 5) == 0 ? 5 : 0));
}

int
pm_tmpdir_teardown(void **state)
{
	(void)state;
	return pm_tmpdir_remove(pm_test_dir);
}
