/*
 * parse.h: strict conversions of command-line and attribute text to
 * numbers: the whole string must be consumed, the value must be finite and
 * in range.  Shared by the tools so that every option is checked alike.
 */
#ifndef PM_PARSE_H
#define PM_PARSE_H

#include <stdbool.h>

#include "vec.h"

/* True and *out set if s is an integer in [min, max]. */
bool pm_parse_long(const char *s, long min, long max, long *out);
/* True and *out set if s is a finite number in [min, max]. */
bool pm_parse_float(const char *s, float min, float max, float *out);
/* "x,y,z" (spaces allowed after commas). */
bool pm_parse_vec3(const char *s, struct pm_vec3 *out);
/* "WxH" with both in [1, max]. */
bool pm_parse_size(const char *s, int max, int *w, int *h);
/* An unsigned 64-bit integer (seeds). */
bool pm_parse_u64(const char *s, unsigned long long *out);

#endif
