/*
 * parallel.c: pm_parallel (parallel.h).
 */
#include <pthread.h>

#include "parallel.h"

void
pm_parallel(int threads, void *(*fn)(void *), void *arg)
{
	pthread_t tid[PM_PARALLEL_MAX];
	int i, started = 0;

	if (threads > PM_PARALLEL_MAX)
		threads = PM_PARALLEL_MAX;
	for (i = 1; i < threads; i++)
		if (pthread_create(&tid[started], NULL, fn, arg) == 0)
			started++;
	fn(arg);
	for (i = 0; i < started; i++)
		pthread_join(tid[i], NULL);
}
