/*
 * parse.c: strict number parsing (see parse.h).
 */
#include <errno.h>
#include <float.h>
#include <math.h>
#include <stdlib.h>

#include "parse.h"

bool
pm_parse_long(const char *s, long min, long max, long *out)
{
	char *end;
	long v;

	if (s == NULL || *s == '\0')
		return false;
	errno = 0;
	v = strtol(s, &end, 10);
	if (errno != 0 || *end != '\0' || v < min || v > max)
		return false;
	*out = v;
	return true;
}

bool
pm_parse_u64(const char *s, unsigned long long *out)
{
	char *end;
	unsigned long long v;

	if (s == NULL || *s < '0' || *s > '9')
		return false;
	errno = 0;
	v = strtoull(s, &end, 10);
	if (errno != 0 || *end != '\0')
		return false;
	*out = v;
	return true;
}

bool
pm_parse_float(const char *s, float min, float max, float *out)
{
	char *end;
	double v;

	if (s == NULL || *s == '\0')
		return false;
	errno = 0;
	v = strtod(s, &end);
	/* Compared as the float it becomes, so that "0.001" meets a bound
	 * of 1e-3f, which as a double is a little above 0.001. */
	if (errno != 0 || *end != '\0' || !isfinite(v) || v < -FLT_MAX ||
	    v > FLT_MAX || (float)v < min || (float)v > max)
		return false;
	*out = (float)v;
	return true;
}

bool
pm_parse_vec3(const char *s, struct pm_vec3 *out)
{
	double v[3];
	char *end;
	int i;

	if (s == NULL)
		return false;
	for (i = 0; i < 3; i++) {
		errno = 0;
		v[i] = strtod(s, &end);
		if (end == s || errno != 0 || !isfinite(v[i]))
			return false;
		s = end;
		if (i < 2) {
			if (*s != ',')
				return false;
			s++;
		}
	}
	if (*s != '\0')
		return false;
	*out = pm_v3((float)v[0], (float)v[1], (float)v[2]);
	return true;
}

bool
pm_parse_size(const char *s, int max, int *w, int *h)
{
	char *end;
	long a, b;

	if (s == NULL || *s < '0' || *s > '9')
		return false;
	errno = 0;
	a = strtol(s, &end, 10);
	if (errno != 0 || (*end != 'x' && *end != 'X') || a < 1 || a > max)
		return false;
	s = end + 1;
	if (*s < '0' || *s > '9')
		return false;
	b = strtol(s, &end, 10);
	if (errno != 0 || *end != '\0' || b < 1 || b > max)
		return false;
	*w = (int)a;
	*h = (int)b;
	return true;
}
