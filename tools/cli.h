/*
 * cli.h: what the tools share and the library must not do: print, look at
 * terminals and check the file system before the work starts.
 */
#ifndef PM_CLI_H
#define PM_CLI_H

/* Seconds on a monotonic clock, for the timings -v prints. */
double pm_cli_now(void);

/*
 * True if the tool prog may write path: "-" is standard output, refused
 * when it is a terminal (binary data would garble it); an existing file
 * needs force; the directory must be writable.  Otherwise prints one line
 * "prog: path: why" and returns false, before any work is done.
 */
int pm_cli_check_output(const char *prog, const char *path, int force);

/* The command line as one string for a file's provenance (malloc'd; NULL
 * when out of memory). */
char *pm_cli_join_args(int argc, char **argv);

#endif
