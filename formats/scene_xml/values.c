/*
 * values.c: the scalar values of the scene format: numbers, lists of
 * numbers, points and vectors, and <transform> with its operations.
 */
#include "private.h"

/* Splits s at runs of commas and white space, as Mitsuba does. */
static int
tokenize(char *s, char **tok, int max)
{
	int n = 0;

	for (;;) {
		while (*s == ',' || isspace((unsigned char)*s))
			s++;
		if (*s == '\0')
			return n;
		if (n == max)
			return max + 1;
		tok[n++] = s;
		while (*s != '\0' && *s != ',' && !isspace((unsigned char)*s))
			s++;
		if (*s != '\0')
			*s++ = '\0';
	}
}

bool
sx_number(const char *s, double *out)
{
	float f;
	char buf[128];
	size_t a = 0, b = strlen(s);

	while (a < b && isspace((unsigned char)s[a]))
		a++;
	while (b > a && isspace((unsigned char)s[b - 1]))
		b--;
	if (b - a >= sizeof(buf))
		return false;
	memcpy(buf, s + a, b - a);
	buf[b - a] = '\0';
	if (!pm_parse_float(buf, -3.4e38f, 3.4e38f, &f))
		return false;
	*out = f;
	return true;
}

/*
 * Parses between nmin and nmax sx_numbers (only the counts 1 and 3 when nmin
 * is 1 and nmax 3) from attribute what of n.
 */
enum pm_err
sx_numbers(struct ld *ld, const struct xnode *n, const char *what,
    const char *s, double *out, int nmin, int nmax, int *count)
{
	char *copy, *tok[17];
	int k, i;

	if ((copy = sx_arena_strdup(&ld->arena, s)) == NULL)
		return sx_nomem(ld);
	k = tokenize(copy, tok, 16);
	if (k < nmin || k > nmax || (nmin == 1 && nmax == 3 && k == 2)) {
		if (nmin == nmax)
			return sx_fail(ld, n, PM_ERR_PARSE, "<%s> %s=\"%s\": "
			    "expected %d numbers", n->tag, what, s, nmin);
		if (nmin == 9 && nmax == 16)
			return sx_fail(ld, n, PM_ERR_PARSE, "<%s> %s=\"%s\": "
			    "expected 16 (4x4) or 9 (3x3) numbers", n->tag,
			    what, s);
		if (nmin == 1 && nmax == 3)
			return sx_fail(ld, n, PM_ERR_PARSE, "<%s> %s=\"%s\": "
			    "expected 1 or 3 numbers", n->tag, what, s);
		return sx_fail(ld, n, PM_ERR_PARSE, "<%s> %s=\"%s\": "
		    "expected %d to %d numbers", n->tag, what, s, nmin, nmax);
	}
	for (i = 0; i < k; i++)
		if (!sx_number(tok[i], &out[i]))
			return sx_fail(ld, n, PM_ERR_PARSE, "<%s> %s=\"%s\": "
			    "\"%s\" is not a finite number", n->tag, what, s,
			    tok[i]);
	*count = k;
	return PM_OK;
}

/*
 * x/y/z attributes, or value with 1 or 3 sx_numbers (Mitsuba's
 * expand_value_to_xyz); missing components take def.
 */
enum pm_err
sx_xyz(struct ld *ld, const struct xnode *n, double def, struct pm_vec3 *out)
{
	static const char *const names[3] = {"x", "y", "z"};
	double v[3] = {def, def, def}, t[3];
	const char *val = sx_attr(n, "value"), *c;
	int i, k;
	enum pm_err e;

	if (val != NULL) {
		if (sx_attr(n, "x") || sx_attr(n, "y") || sx_attr(n, "z"))
			return sx_fail(ld, n, PM_ERR_INVALID, "<%s>: give either "
			    "value or x, y, z, not both", n->tag);
		if ((e = sx_numbers(ld, n, "value", val, t, 1, 3, &k)) != PM_OK)
			return e;
		for (i = 0; i < 3; i++)
			v[i] = k == 1 ? t[0] : t[i];
	} else {
		for (i = 0; i < 3; i++) {
			if ((c = sx_attr(n, names[i])) == NULL)
				continue;
			if ((e = sx_numbers(ld, n, names[i], c, &v[i], 1, 1, &k))
			    != PM_OK)
				return e;
		}
	}
	*out = pm_v3((float)v[0], (float)v[1], (float)v[2]);
	return PM_OK;
}

static enum pm_err
vec3_attr(struct ld *ld, const struct xnode *n, const char *name,
    struct pm_vec3 *out)
{
	double v[3];
	int k;
	enum pm_err e;

	if ((e = sx_numbers(ld, n, name, sx_attr(n, name), v, 3, 3, &k)) != PM_OK)
		return e;
	*out = pm_v3((float)v[0], (float)v[1], (float)v[2]);
	return PM_OK;
}

enum pm_err
sx_no_kids(struct ld *ld, const struct xnode *n)
{
	if (n->kids != NULL)
		return sx_fail(ld, n->kids, PM_ERR_INVALID,
		    "unexpected <%s> inside <%s>", n->kids->tag, n->tag);
	return PM_OK;
}

/* A <transform>: each operation is applied after the previous ones,
 * M = Op * M, as Mitsuba does. */
enum pm_err
sx_parse_transform(struct ld *ld, const struct xnode *t, struct pm_mat4 *out)
{
	static const char *const ok_xyz[] = {"x", "y", "z", "value", NULL};
	static const char *const ok_rot[] = {"x", "y", "z", "value", "angle",
	    NULL};
	static const char *const ok_mat[] = {"value", NULL};
	static const char *const ok_look[] = {"origin", "target", "up", NULL};
	struct pm_mat4 M = pm_mat4_identity(), op;
	const struct xnode *k;
	struct pm_vec3 v, o, tg, up, dir;
	const char *s;
	double a, m[16];
	int cnt, i, j;
	enum pm_err e;

	for (k = t->kids; k != NULL; k = k->next) {
		if ((e = sx_no_kids(ld, k)) != PM_OK)
			return e;
		if (strcmp(k->tag, "translate") == 0) {
			if ((e = sx_check_attrs(ld, k, ok_xyz)) != PM_OK ||
			    (e = sx_xyz(ld, k, 0.0, &v)) != PM_OK)
				return e;
			op = pm_mat4_translate(v);
		} else if (strcmp(k->tag, "scale") == 0) {
			if ((e = sx_check_attrs(ld, k, ok_xyz)) != PM_OK ||
			    (e = sx_xyz(ld, k, 1.0, &v)) != PM_OK)
				return e;
			op = pm_mat4_scale(v);
		} else if (strcmp(k->tag, "rotate") == 0) {
			if ((e = sx_check_attrs(ld, k, ok_rot)) != PM_OK ||
			    (e = sx_need_attr(ld, k, "angle", &s)) != PM_OK ||
			    (e = sx_numbers(ld, k, "angle", s, &a, 1, 1, &cnt))
			    != PM_OK)
				return e;
			/* The angle is not part of value="x, y, z". */
			{
				struct xnode tmp = *k;
				const char *attrs[9];
				const char **src;
				int na = 0;

				for (src = k->attr; src[0] != NULL; src += 2) {
					if (strcmp(src[0], "angle") == 0)
						continue;
					attrs[na++] = src[0];
					attrs[na++] = src[1];
				}
				attrs[na] = NULL;
				tmp.attr = attrs;
				if ((e = sx_xyz(ld, &tmp, 0.0, &v)) != PM_OK)
					return e;
			}
			if (pm_dot(v, v) == 0.0f)
				return sx_fail(ld, k, PM_ERR_INVALID,
				    "<rotate> needs a non-zero axis");
			op = pm_mat4_rotate(v, (float)a);
		} else if (strcmp(k->tag, "matrix") == 0) {
			if ((e = sx_check_attrs(ld, k, ok_mat)) != PM_OK ||
			    (e = sx_need_attr(ld, k, "value", &s)) != PM_OK ||
			    (e = sx_numbers(ld, k, "value", s, m, 9, 16, &cnt))
			    != PM_OK)
				return e;
			if (cnt != 9 && cnt != 16)
				return sx_fail(ld, k, PM_ERR_PARSE, "<matrix> "
				    "value=\"%s\": expected 16 (4x4) or 9 "
				    "(3x3) numbers", s);
			op = pm_mat4_identity();
			for (i = 0; i < (cnt == 16 ? 4 : 3); i++)
				for (j = 0; j < (cnt == 16 ? 4 : 3); j++)
					op.m[i][j] = (float)m[i *
					    (cnt == 16 ? 4 : 3) + j];
		} else if (strcmp(k->tag, "lookat") == 0 ||
		    strcmp(k->tag, "look_at") == 0) {
			if ((e = sx_check_attrs(ld, k, ok_look)) != PM_OK ||
			    (e = sx_need_attr(ld, k, "origin", &s)) != PM_OK ||
			    (e = sx_need_attr(ld, k, "target", &s)) != PM_OK ||
			    (e = vec3_attr(ld, k, "origin", &o)) != PM_OK ||
			    (e = vec3_attr(ld, k, "target", &tg)) != PM_OK)
				return e;
			dir = pm_sub(tg, o);
			if (pm_dot(dir, dir) == 0.0f)
				return sx_fail(ld, k, PM_ERR_INVALID,
				    "<%s>: origin and target coincide", k->tag);
			if (sx_attr(k, "up") != NULL) {
				if ((e = vec3_attr(ld, k, "up", &up)) != PM_OK)
					return e;
			} else {
				up = pm_v3(0, 0, 0);
			}
			if (pm_dot(up, up) == 0.0f) {
				/* Mitsuba: any vector perpendicular to dir. */
				up = pm_frame_from_normal(pm_normalize(dir)).s;
			}
			v = pm_cross(pm_normalize(up), pm_normalize(dir));
			if (pm_dot(v, v) < 1e-12f)
				return sx_fail(ld, k, PM_ERR_INVALID,
				    "<%s>: up is parallel to the view "
				    "direction", k->tag);
			op = pm_mat4_lookat(o, tg, up);
		} else {
			return sx_fail(ld, k, PM_ERR_UNSUPPORTED,
			    "unknown element <%s> in <transform> (expected "
			    "translate, rotate, scale, matrix or lookat)",
			    k->tag);
		}
		M = pm_mat4_mul(op, M);
	}
	for (i = 0; i < 4; i++)
		for (j = 0; j < 4; j++)
			if (!isfinite(M.m[i][j]))
				return sx_fail(ld, t, PM_ERR_INVALID,
				    "<transform> is not finite");
	*out = M;
	return PM_OK;
}
