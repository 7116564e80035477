/*
 * tmpdir.h: a private scratch directory for a unit test program.
 *
 * Tests that write files (maps, images, scenes) make one directory in
 * their group setup and remove it with everything in it in the teardown,
 * so that a failed assertion leaves nothing behind for the next run.
 */
#ifndef PM_TEST_TMPDIR_H
#define PM_TEST_TMPDIR_H

#include <stddef.h>

/*
 * Makes $TMPDIR/pm-test-NAME.XXXXXX (/tmp without TMPDIR) and writes its
 * path into dir[0..size).  Returns 0, or -1 if the path does not fit or
 * the directory cannot be made.
 */
int pm_tmpdir_make(char *dir, size_t size, const char *name);

/* Removes dir and everything below it, without a shell.  0 or -1. */
int pm_tmpdir_remove(const char *dir);

/*
 * The common case as cmocka group fixtures: pm_tmpdir_setup makes
 * pm_test_dir, named after the test program, and pm_tmpdir_teardown
 * removes it.
 */
extern char pm_test_dir[64];
int pm_tmpdir_setup(void **state);
int pm_tmpdir_teardown(void **state);

#endif
