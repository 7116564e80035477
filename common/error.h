/*
 * error.h: the library's error codes and the message buffer that carries
 * the details (file, line, what was expected) up to the tool that prints it.
 *
 * The library never prints and never exits; it fills a struct pm_error and
 * returns its code.  Codes are fixed once published: append, never renumber.
 */
#ifndef PM_ERROR_H
#define PM_ERROR_H

enum pm_err {
	PM_OK = 0,
	PM_ERR_NOMEM = 1,	/* allocation failed */
	PM_ERR_IO = 2,		/* open, read or write failed (errno in message) */
	PM_ERR_PARSE = 3,	/* malformed text: XML, OBJ, ASCII PLY, numbers */
	PM_ERR_FORMAT = 4,	/* a binary file is not what it claims to be */
	PM_ERR_TRUNCATED = 5,	/* a file ends before its counts say it should */
	PM_ERR_UNSUPPORTED = 6,	/* valid input outside what pm implements */
	PM_ERR_INVALID = 7,	/* a value out of its range, or a missing value */
	PM_ERR_GEOMETRY = 8,	/* the ray-casting device refused the scene */
	PM_ERR_LIMIT = 9,	/* a request larger than pm allows */
};

struct pm_error {
	enum pm_err code;
	char msg[1024];
};

/* A static string naming the code; never NULL. */
const char *pm_strerror(enum pm_err code);

/*
 * Records code and a printf-style message in err (which may be NULL) and
 * returns code, so that callers can write `return pm_fail(err, ...)`.
 */
enum pm_err pm_fail(struct pm_error *err, enum pm_err code, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

#endif
