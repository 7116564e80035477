/*
 * error.c: names of the error codes and the helper that fills a pm_error.
 */
#include <stdarg.h>
#include <stdio.h>

#include "error.h"

const char *
pm_strerror(enum pm_err code)
{
	switch (code) {
	case PM_OK:		return "success";
	case PM_ERR_NOMEM:	return "out of memory";
	case PM_ERR_IO:		return "input/output error";
	case PM_ERR_PARSE:	return "parse error";
	case PM_ERR_FORMAT:	return "bad file format";
	case PM_ERR_TRUNCATED:	return "truncated file";
	case PM_ERR_UNSUPPORTED: return "unsupported";
	case PM_ERR_INVALID:	return "invalid value";
	case PM_ERR_GEOMETRY:	return "geometry error";
	case PM_ERR_LIMIT:	return "limit exceeded";
	}
	return "unknown error";
}

enum pm_err
pm_fail(struct pm_error *err, enum pm_err code, const char *fmt, ...)
{
	va_list ap;

	if (err == NULL)
		return code;
	err->code = code;
	va_start(ap, fmt);
	vsnprintf(err->msg, sizeof(err->msg), fmt, ap);
	va_end(ap);
	return code;
}
