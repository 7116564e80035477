/*
 * cli.c: the option dialect, output checks, provenance and progress line
 * shared by the tools' mains (see cli.h).
 */
/* sched_getaffinity and CPU_COUNT are GNU extensions. */
#define _GNU_SOURCE
#include <errno.h>
#include <libgen.h>
#include <pthread.h>
#include <sched.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "../common/parse.h"
#include "cli.h"

/* The tool being run, for usage errors, and its command line. */
static const struct pm_cli *current;
static char *command;

void
pm_cli_usage_error(const char *fmt, ...)
{
	va_list ap;

	fprintf(stderr, "%s: ", current != NULL ? current->prog : "pm");
	va_start(ap, fmt);
	vfprintf(stderr, fmt, ap);
	va_end(ap);
	fputs(" (see --help)\n", stderr);
	exit(2);
}

/* Prints to stdout and exits 0, or 1 if stdout could not take it. */
static void __attribute__((noreturn))
finish_stdout(const char *prog)
{
	errno = 0;
	if (fflush(stdout) != 0 || ferror(stdout) || fclose(stdout) != 0) {
		fprintf(stderr, "%s: standard output: %s\n", prog,
		    errno != 0 ? strerror(errno) : "write error");
		exit(1);
	}
	exit(0);
}

/* Names what getopt_long refused: word is the argument it stopped at. */
static void __attribute__((noreturn))
bad_option(const struct pm_cli *cli, const char *word, int opt, int missing)
{
	const struct option *o;
	size_t len;

	if (word[0] != '-' || word[1] != '-') {
		if (missing)
			pm_cli_usage_error("option '-%c' needs an argument", opt);
		if (opt > 32 && opt < 127)
			pm_cli_usage_error("unknown option '-%c'", opt);
		pm_cli_usage_error("unknown option in '%s'", word);
	}
	len = strcspn(word + 2, "=");
	if (missing)
		pm_cli_usage_error("option '--%.*s' needs an argument",
		    (int)len, word + 2);
	for (o = cli->longopts; o->name != NULL; o++)
		if (strlen(o->name) == len &&
		    strncmp(o->name, word + 2, len) == 0) {
			if (word[2 + len] == '=' && o->has_arg == no_argument)
				pm_cli_usage_error("option '--%s' takes no "
				    "argument", o->name);
			break;
		}
	pm_cli_usage_error("unknown option '--%.*s'", (int)len, word + 2);
}

int
pm_cli_getopt(const struct pm_cli *cli, int argc, char **argv,
    const char *shortopts)
{
	char opts[128];
	int c, before = optind;

	if (current == NULL)
		command = pm_cli_join_args(argc, argv);
	current = cli;
	opterr = 0;
	/* A leading ':' makes a missing argument ':' rather than '?'. */
	snprintf(opts, sizeof(opts), ":%s", shortopts);
	c = getopt_long(argc, argv, opts, cli->longopts, NULL);
	switch (c) {
	case 'h':
		fputs(cli->usage, stdout);
		printf("\n%s", cli->help);
		finish_stdout(cli->prog);
	case PM_CLI_VERSION:
		printf("%s (pm) %s\n", cli->prog, PM_VERSION);
		finish_stdout(cli->prog);
	case ':':
	case '?':
		/* optind has moved past the offending word, or stays on it
		 * while it walks a cluster of short options. */
		bad_option(cli, argv[optind > before ? optind - 1 : before],
		    optopt, c == ':');
	default:
		return c;
	}
}

void
pm_cli_define(char *arg, struct pm_define *defs, size_t *n, size_t max)
{
	char *eq = strchr(arg, '=');

	if (eq == NULL || eq == arg)
		pm_cli_usage_error("-D wants NAME=VALUE, not '%s'", arg);
	if (*n == max)
		pm_cli_usage_error("too many -D definitions (at most %zu)", max);
	*eq = '\0';
	defs[*n].name = arg;
	defs[*n].value = eq + 1;
	(*n)++;
}

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
	struct stat st;
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
	if (stat(path, &st) == 0) {
		if (S_ISDIR(st.st_mode)) {
			fprintf(stderr, "%s: %s: is a directory\n", prog, path);
			return 0;
		}
		if (!force) {
			fprintf(stderr, "%s: %s: already exists (use -f to "
			    "overwrite)\n", prog, path);
			return 0;
		}
	}
	copy = strdup(path);
	if (copy == NULL) {
		fprintf(stderr, "%s: out of memory\n", prog);
		return 0;
	}
	dir = dirname(copy);
	ok = access(dir, W_OK | X_OK) == 0;
	if (!ok)
		fprintf(stderr, "%s: %s: cannot create files in %s: %s\n",
		    prog, path, dir, strerror(errno));
	free(copy);
	return ok;
}

char *
pm_cli_join_args(int argc, char **argv)
{
	static const char plain[] = "abcdefghijklmnopqrstuvwxyz"
	    "ABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_-+=/.,:@%";
	size_t len = 1, i;
	char *s, *q;
	int k;

	/* At worst every byte is a quote, written as '\'' (four bytes). */
	for (k = 0; k < argc; k++)
		len += 3 + 4 * strlen(argv[k]);
	if ((s = malloc(len)) == NULL)
		return NULL;
	q = s;
	for (k = 0; k < argc; k++) {
		const char *w = argv[k];

		if (k > 0)
			*q++ = ' ';
		if (*w != '\0' && strspn(w, plain) == strlen(w)) {
			q = stpcpy(q, w);
			continue;
		}
		*q++ = '\'';
		for (i = 0; w[i] != '\0'; i++) {
			if (w[i] == '\'')
				q = stpcpy(q, "'\\''");
			else
				*q++ = w[i];
		}
		*q++ = '\'';
	}
	*q = '\0';
	return s;
}

void
pm_cli_opts_init(struct pm_cli_opts *o)
{
	memset(o, 0, sizeof(*o));
	o->verbosity = 1;
	o->threads = pm_cli_cores();
	if (o->threads > 4096)
		o->threads = 4096;
}

int
pm_cli_common(struct pm_cli_opts *o, int c)
{
	switch (c) {
	case 'D':
		pm_cli_define(optarg, o->defs, &o->ndefs, PM_CLI_MAX_DEFINES);
		return 1;
	case 'f':
		o->force = 1;
		return 1;
	case 'o':
		o->output = optarg;
		return 1;
	case 'q':
		o->verbosity = 0;
		return 1;
	case 't':
		if (!pm_parse_long(optarg, 1, 4096, &o->threads))
			pm_cli_usage_error("-t wants a thread count from 1 to "
			    "4096, not '%s'", optarg);
		return 1;
	case 'v':
		o->verbosity = 2;
		return 1;
	}
	return 0;
}

long
pm_cli_cores(void)
{
	cpu_set_t set;
	long n;

	if (sched_getaffinity(0, sizeof(set), &set) == 0 &&
	    (n = CPU_COUNT(&set)) > 0)
		return n;
	n = sysconf(_SC_NPROCESSORS_ONLN);
	return n > 0 ? n : 1;
}

const char *
pm_cli_command(void)
{
	return command != NULL ? command : "?";
}

struct pm_cli_progress {
	const char *prog, *label;
	int show;
	_Atomic long *done, *total;
	void (*tick)(void *);
	void *arg;
	double tick_every, t0;
	pthread_t tid;
	pthread_mutex_t lock;
	pthread_cond_t wake;
	int stop;			/* under lock */
	int width;			/* of the line last drawn */
};

int
pm_cli_progress_wanted(int quiet)
{
	return !quiet && isatty(STDERR_FILENO);
}

/* Seconds as m:ss, or h:mm:ss from an hour on. */
static void
clock_time(double s, char *buf, size_t len)
{
	long t = s > 0.0 && s < 1e9 ? (long)(s + 0.5) : 0;

	if (t >= 3600)
		snprintf(buf, len, "%ld:%02ld:%02ld", t / 3600, t / 60 % 60,
		    t % 60);
	else
		snprintf(buf, len, "%ld:%02ld", t / 60, t % 60);
}

/* Redraws the line over the last one; final ends it. */
static void
draw(struct pm_cli_progress *p, int final)
{
	long done = atomic_load(p->done), total = atomic_load(p->total);
	double el = pm_cli_now() - p->t0;
	char line[256], e[32], r[32];
	int n;

	if (total <= 0)
		return;
	if (done > total)
		done = total;
	clock_time(el, e, sizeof(e));
	if (final || done == 0)
		n = snprintf(line, sizeof(line), "%s: %s%s%3ld%%  %s elapsed",
		    p->prog, p->label, *p->label ? "  " : "", 100 * done / total,
		    e);
	else {
		clock_time(el * (double)(total - done) / (double)done, r,
		    sizeof(r));
		n = snprintf(line, sizeof(line), "%s: %s%s%3ld%%  %s elapsed, "
		    "%s left", p->prog, p->label, *p->label ? "  " : "",
		    100 * done / total, e, r);
	}
	if (n < 0)
		return;
	if (n >= (int)sizeof(line))
		n = (int)sizeof(line) - 1;
	fprintf(stderr, "\r%s%*s", line, p->width > n ? p->width - n : 0, "");
	if (final)
		fputc('\n', stderr);
	fflush(stderr);
	p->width = final ? 0 : n;
}

static void *
progress_main(void *arg)
{
	struct pm_cli_progress *p = arg;
	double next_draw = p->t0, next_tick = p->t0 + p->tick_every;

	pthread_mutex_lock(&p->lock);
	while (!p->stop) {
		double now = pm_cli_now(), until;
		struct timespec ts;

		if (p->show && now >= next_draw) {
			draw(p, 0);
			next_draw = now + 0.25;
		}
		if (p->tick != NULL && now >= next_tick) {
			pthread_mutex_unlock(&p->lock);
			p->tick(p->arg);
			pthread_mutex_lock(&p->lock);
			next_tick = pm_cli_now() + p->tick_every;
			continue;
		}
		until = p->show ? next_draw : next_tick;
		if (p->tick != NULL && next_tick < until)
			until = next_tick;
		/* The condition variable runs on CLOCK_MONOTONIC, as
		 * pm_cli_now does. */
		ts.tv_sec = (time_t)until;
		ts.tv_nsec = (long)((until - (double)ts.tv_sec) * 1e9);
		if (ts.tv_nsec >= 1000000000L)
			ts.tv_nsec = 999999999L;
		pthread_cond_timedwait(&p->wake, &p->lock, &ts);
	}
	pthread_mutex_unlock(&p->lock);
	return NULL;
}

struct pm_cli_progress *
pm_cli_progress_start(const char *prog, const char *label, int show,
    _Atomic long *done, _Atomic long *total, void (*tick)(void *),
    void *arg, double tick_every)
{
	struct pm_cli_progress *p;
	pthread_condattr_t ca;

	if (!show && tick == NULL)
		return NULL;
	if ((p = calloc(1, sizeof(*p))) == NULL)
		return NULL;
	p->prog = prog;
	p->label = label != NULL ? label : "";
	p->show = show;
	p->done = done;
	p->total = total;
	p->tick = tick;
	p->arg = arg;
	p->tick_every = tick_every > 0.0 ? tick_every : 1.0;
	p->t0 = pm_cli_now();
	pthread_condattr_init(&ca);
	pthread_condattr_setclock(&ca, CLOCK_MONOTONIC);
	pthread_cond_init(&p->wake, &ca);
	pthread_condattr_destroy(&ca);
	pthread_mutex_init(&p->lock, NULL);
	if (pthread_create(&p->tid, NULL, progress_main, p) != 0) {
		pthread_cond_destroy(&p->wake);
		pthread_mutex_destroy(&p->lock);
		free(p);
		return NULL;
	}
	return p;
}

void
pm_cli_progress_stop(struct pm_cli_progress *p)
{
	if (p == NULL)
		return;
	pthread_mutex_lock(&p->lock);
	p->stop = 1;
	pthread_cond_signal(&p->wake);
	pthread_mutex_unlock(&p->lock);
	pthread_join(p->tid, NULL);
	/* The whole line when the work is done; after a failure only its
	 * error message. */
	if (p->show && atomic_load(p->total) > 0 &&
	    atomic_load(p->done) >= atomic_load(p->total))
		draw(p, 1);
	else if (p->show && p->width > 0)
		fprintf(stderr, "\r%*s\r", p->width, "");
	pthread_cond_destroy(&p->wake);
	pthread_mutex_destroy(&p->lock);
	free(p);
}

void
pm_cli_progress_hold(struct pm_cli_progress *p)
{
	if (p == NULL)
		return;
	pthread_mutex_lock(&p->lock);
	if (p->show && p->width > 0) {
		fprintf(stderr, "\r%*s\r", p->width, "");
		p->width = 0;
	}
}

void
pm_cli_progress_release(struct pm_cli_progress *p)
{
	if (p == NULL)
		return;
	pthread_cond_signal(&p->wake);
	pthread_mutex_unlock(&p->lock);
}
