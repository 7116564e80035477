/*
 * cli.h: what the tools share and the library must not do: the one option
 * dialect (-h/--help, --version, one-line usage errors with exit 2, -D
 * NAME=VALUE), output checks, the recorded command line and the progress
 * line on a terminal.
 */
#ifndef PM_CLI_H
#define PM_CLI_H

#include <getopt.h>
#include <stdatomic.h>
#include <stddef.h>

#include "../formats/scene_xml.h"

/* The project's version: every tool prints it and records it in its
 * outputs. */
#define PM_VERSION "0.3.0"

/* The value a tool's longopts give --version ('h' is --help). */
#define PM_CLI_VERSION 0x7ff0

/* A tool as the shared option handling sees it. */
struct pm_cli {
	const char *prog;		/* "pm-render" */
	const char *usage;		/* "usage: ..." lines, each ending in \n */
	const char *help;		/* what it does and its options */
	const struct option *longopts;	/* with "help" ('h') and "version" */
};

/*
 * getopt_long in the shared dialect: returns the next option (-1 at the
 * end), after handling itself -h/--help (usage and option list on stdout,
 * exit 0), --version (exit 0), and an unknown option or a missing or
 * unwanted argument (one line on stderr, exit 2).  getopt's own messages
 * are off.
 */
int pm_cli_getopt(const struct pm_cli *cli, int argc, char **argv,
    const char *shortopts);

/* Prints "prog: <message> (see --help)" as one line and exits 2. */
void pm_cli_usage_error(const char *fmt, ...)
    __attribute__((noreturn, format(printf, 1, 2)));

/*
 * Adds a -D NAME=VALUE definition to defs[0..*n) (at most max); arg is
 * split in place.  A malformed one is a usage error.
 */
void pm_cli_define(char *arg, struct pm_define *defs, size_t *n, size_t max);

/*
 * The options the tools share, each meaning the same everywhere: -f
 * (overwrite an existing output), -o FILE, -q and -v (verbosity 0 and 2;
 * 1 by default), -t N (threads, 1 to 4096; pm_cli_cores() by default) and
 * -D NAME=VALUE.  A tool lists in its getopt string only those it takes
 * and passes every option to pm_cli_common first.
 */
#define PM_CLI_MAX_DEFINES 64
struct pm_cli_opts {
	int force;
	const char *output;		/* NULL unless -o */
	int verbosity;
	long threads;
	struct pm_define defs[PM_CLI_MAX_DEFINES];
	size_t ndefs;
};

void pm_cli_opts_init(struct pm_cli_opts *o);
/* Takes option c (with optarg) into o if it is a shared one and returns
 * 1; returns 0 for the tool's own options.  A bad -t or -D is a usage
 * error. */
int pm_cli_common(struct pm_cli_opts *o, int c);

/* Seconds on a monotonic clock, for the timings -v prints. */
double pm_cli_now(void);

/*
 * True if the tool prog may write path: "-" is standard output, refused
 * when it is a terminal (binary data would garble it); an existing file
 * needs force, a directory is refused; the directory must accept new
 * files.  Otherwise prints one line "prog: path: why" and returns false,
 * before any work is done.
 */
int pm_cli_check_output(const char *prog, const char *path, int force);

/* The command line as one string that a POSIX shell would read back as
 * the same words, for a file's provenance (malloc'd; NULL when out of
 * memory). */
char *pm_cli_join_args(int argc, char **argv);

/* The tool's command line as it was given (pm_cli_join_args of argv
 * before pm_cli_getopt's first call permuted it or -D split its words);
 * owned by cli.c; "?" if it could not be recorded. */
const char *pm_cli_command(void);

/* The default thread count: the processors this process may run on (its
 * affinity mask, as nproc(1) counts them, so that a Slurm allocation or
 * taskset is followed), or the online ones where the mask is unknown. */
long pm_cli_cores(void);

/*
 * A progress line on stderr, "prog: label  42%  0:03 elapsed, 0:04 left",
 * redrawn four times a second while work runs, when stderr is a terminal
 * and the tool was not told to be quiet; nothing otherwise.  done and
 * total count units of work and are written by the workers (total may be
 * 0 until known).  If tick is set it is called on the progress thread
 * every tick_every seconds (whether or not the line is shown), for
 * previews.
 */
struct pm_cli_progress;
struct pm_cli_progress *pm_cli_progress_start(const char *prog,
    const char *label, int show, _Atomic long *done, _Atomic long *total,
    void (*tick)(void *), void *arg, double tick_every);
/* Stops the thread (after its tick in progress, if any), ends the line (or
 * clears it if the work is not done) and frees p; NULL is allowed. */
void pm_cli_progress_stop(struct pm_cli_progress *p);
/* Clears the line and keeps it from being redrawn, so that the tool can
 * print lines of its own, until pm_cli_progress_release; NULL is allowed. */
void pm_cli_progress_hold(struct pm_cli_progress *p);
void pm_cli_progress_release(struct pm_cli_progress *p);
/* True if a progress line would be shown: stderr is a terminal and the
 * tool is not quiet. */
int pm_cli_progress_wanted(int quiet);

#endif
