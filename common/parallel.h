/*
 * parallel.h: run one worker on several threads.
 *
 * The workers share their work through the caller's own state (an atomic
 * counter of chunks, say), so that which thread does which chunk never
 * changes a result.
 */
#ifndef PM_PARALLEL_H
#define PM_PARALLEL_H

/* Most threads a call starts; more are not waited for but not started. */
#define PM_PARALLEL_MAX	256

/*
 * Runs fn(arg) on `threads` threads (at least 1, at most PM_PARALLEL_MAX),
 * the calling thread among them, and returns when all have returned.  A
 * thread that cannot be started is left out: the others take its work.
 */
void pm_parallel(int threads, void *(*fn)(void *), void *arg);

#endif
