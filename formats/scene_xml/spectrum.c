/*
 * spectrum.c: <spectrum> properties.  A single value is a uniform
 * spectrum; value="400:0.1, 500:0.2, ..." lists wavelength:value pairs;
 * filename= names a text file of such pairs, one a line (Mitsuba's .spd
 * layout: '#' starts a comment line); type="blackbody", "uniform",
 * "regular", "irregular", "d65" and "srgb" are the spectrum plugins of
 * those names (regular and irregular lists read as value= lists are).  What the
 * spectrum means as RGB depends on where it is used (an emitter's or a
 * reflectance), so it is kept as given and reduced by sx_spectrum_rgb
 * when a getter asks for a colour.
 */
#include "private.h"
#include "../../common/spectrum.h"

#define MAX_SPECTRUM_FILE	((size_t)16 << 20)

/* Checks the pairs, Mitsuba's rules: two or more, wavelengths increasing. */
static enum pm_err
check_pairs(struct ld *ld, const struct xnode *k, const char *what,
    struct sx_spectrum *sp)
{
	size_t i;

	if (sp->n < 2)
		return sx_fail(ld, k, PM_ERR_INVALID, "<spectrum> %s: a spectrum "
		    "needs at least two wavelength:value pairs", what);
	for (i = 0; i < sp->n; i++)
		if (!isfinite(sp->wl[i]) || !isfinite(sp->v[i]) ||
		    (i > 0 && !(sp->wl[i] > sp->wl[i - 1])))
			return sx_fail(ld, k, PM_ERR_INVALID, "<spectrum> %s: "
			    "wavelengths must increase (pair %zu: %g)", what,
			    i + 1, sp->wl[i]);
	return PM_OK;
}

/* value="...": one number, or wavelength:value pairs. */
static enum pm_err
parse_value(struct ld *ld, const struct xnode *k, const char *v,
    struct sx_spectrum *sp)
{
	char *copy, *s, *tok, *colon;
	size_t cap = 1, n = 0;
	int cnt;
	enum pm_err e;

	if (strchr(v, ':') == NULL) {
		sp->kind = SX_SPEC_UNIFORM;
		return sx_numbers(ld, k, "value", v, &sp->value, 1, 1, &cnt);
	}
	sp->kind = SX_SPEC_LIST;
	for (s = (char *)v; *s != '\0'; s++)
		if (*s == ':')
			cap++;
	if ((copy = sx_arena_strdup(&ld->arena, v)) == NULL ||
	    (sp->wl = sx_arena_alloc(&ld->arena, cap * sizeof(double))) == NULL ||
	    (sp->v = sx_arena_alloc(&ld->arena, cap * sizeof(double))) == NULL)
		return sx_nomem(ld);
	for (s = copy;;) {
		while (*s == ',' || isspace((unsigned char)*s))
			s++;
		if (*s == '\0')
			break;
		tok = s;
		while (*s != '\0' && *s != ',' && !isspace((unsigned char)*s))
			s++;
		if (*s != '\0')
			*s++ = '\0';
		if ((colon = strchr(tok, ':')) == NULL || n == cap)
			return sx_fail(ld, k, PM_ERR_PARSE, "<spectrum> value: "
			    "\"%s\" is not a wavelength:value pair", tok);
		*colon = '\0';
		if (!sx_number(tok, &sp->wl[n]) || !sx_number(colon + 1,
		    &sp->v[n])) {
			*colon = ':';
			return sx_fail(ld, k, PM_ERR_PARSE, "<spectrum> value: "
			    "\"%s\" is not a wavelength:value pair of finite "
			    "numbers", tok);
		}
		n++;
	}
	sp->n = n;
	if ((e = check_pairs(ld, k, "value", sp)) != PM_OK)
		return e;
	return PM_OK;
}

/* filename="...": a wavelength and a value a line. */
static enum pm_err
parse_file(struct ld *ld, const struct xnode *k, const char *name,
    struct sx_spectrum *sp)
{
	const char *path;
	char *buf, *line, *next, *end;
	size_t len, cap = 1, n = 0, i;
	int lineno = 0;
	enum pm_err e;

	if ((e = sx_resolve(ld, k, k->dir, name, &path)) != PM_OK)
		return e;
	if ((e = pm_read_file(path, MAX_SPECTRUM_FILE, &buf, &len, ld->err))
	    != PM_OK)
		return sx_wrap(ld, k, "<spectrum> filename", e);
	for (i = 0; i < len; i++)
		if (buf[i] == '\n')
			cap++;
	sp->kind = SX_SPEC_LIST;
	if ((sp->wl = sx_arena_alloc(&ld->arena, cap * sizeof(double))) == NULL ||
	    (sp->v = sx_arena_alloc(&ld->arena, cap * sizeof(double))) == NULL) {
		free(buf);
		return sx_nomem(ld);
	}
	for (line = buf; line != NULL && line < buf + len; line = next) {
		double w, v;

		lineno++;
		if ((next = strchr(line, '\n')) != NULL)
			*next++ = '\0';
		while (isspace((unsigned char)*line))
			line++;
		if (*line == '\0' || *line == '#')
			continue;
		errno = 0;
		w = strtod(line, &end);
		if (end != line) {
			line = end;
			v = strtod(line, &end);
		}
		if (end == line || errno != 0 || !isfinite(w) || !isfinite(v) ||
		    n == cap) {
			e = sx_fail(ld, k, PM_ERR_PARSE, "%s:%d: expected a "
			    "wavelength and a value", path, lineno);
			free(buf);
			return e;
		}
		for (line = end; isspace((unsigned char)*line); line++)
			;
		if (*line != '\0') {
			e = sx_fail(ld, k, PM_ERR_PARSE, "%s:%d: unexpected "
			    "\"%s\" after the wavelength and value", path,
			    lineno, line);
			free(buf);
			return e;
		}
		sp->wl[n] = w;
		sp->v[n] = v;
		n++;
	}
	free(buf);
	sp->n = n;
	return check_pairs(ld, k, path, sp);
}

/* A list of numbers of any length, for regular and irregular: *out
 * (in the loader's arena) and *n. */
static enum pm_err
number_list(struct ld *ld, const struct xnode *k, const char *what,
    const char *v, double **out, size_t *n)
{
	char *copy, *s, *tok;
	size_t cap = 1;

	for (s = (char *)v; *s != '\0'; s++)
		if (*s == ',' || isspace((unsigned char)*s))
			cap++;
	if ((copy = sx_arena_strdup(&ld->arena, v)) == NULL ||
	    (*out = sx_arena_alloc(&ld->arena, cap * sizeof(double))) == NULL)
		return sx_nomem(ld);
	*n = 0;
	for (s = copy;;) {
		while (*s == ',' || isspace((unsigned char)*s))
			s++;
		if (*s == '\0')
			return PM_OK;
		tok = s;
		while (*s != '\0' && *s != ',' && !isspace((unsigned char)*s))
			s++;
		if (*s != '\0')
			*s++ = '\0';
		if (*n == cap || !sx_number(tok, &(*out)[*n]))
			return sx_fail(ld, k, PM_ERR_PARSE, "<spectrum> %s: \"%s\" "
			    "is not a finite number", what, tok);
		(*n)++;
	}
}

/* regular: values evenly spaced from wavelength_min to wavelength_max. */
static enum pm_err
parse_regular(struct ld *ld, const struct xnode *k, struct plist *pl,
    struct sx_spectrum *sp)
{
	const char *v;
	double lo, hi;
	size_t i;
	enum pm_err e;

	if (!sx_has(pl, "values"))
		return sx_missing(ld, pl, "values", "a <string> of numbers");
	if ((e = sx_get_float(ld, pl, "wavelength_min", PM_CIE_MIN, 0.0, 1e6,
	    &lo)) != PM_OK ||
	    (e = sx_get_float(ld, pl, "wavelength_max", PM_CIE_MAX, 0.0, 1e6,
	    &hi)) != PM_OK ||
	    (e = sx_get_string(ld, pl, "values", NULL, &v)) != PM_OK ||
	    (e = number_list(ld, k, "values", v, &sp->v, &sp->n)) != PM_OK)
		return e;
	if (sp->n >= 2 && (sp->wl = sx_arena_alloc(&ld->arena, sp->n *
	    sizeof(double))) == NULL)
		return sx_nomem(ld);
	for (i = 0; sp->n >= 2 && i < sp->n; i++)
		sp->wl[i] = lo + (hi - lo) * (double)i / (double)(sp->n - 1);
	return check_pairs(ld, k, "values", sp);
}

/* irregular: a list of wavelengths and one of values, as long. */
static enum pm_err
parse_irregular(struct ld *ld, const struct xnode *k, struct plist *pl,
    struct sx_spectrum *sp)
{
	const char *w, *v;
	size_t nw;
	enum pm_err e;

	if (!sx_has(pl, "wavelengths"))
		return sx_missing(ld, pl, "wavelengths", "a <string> of numbers");
	if (!sx_has(pl, "values"))
		return sx_missing(ld, pl, "values", "a <string> of numbers");
	if ((e = sx_get_string(ld, pl, "wavelengths", NULL, &w)) != PM_OK ||
	    (e = sx_get_string(ld, pl, "values", NULL, &v)) != PM_OK ||
	    (e = number_list(ld, k, "wavelengths", w, &sp->wl, &nw)) != PM_OK ||
	    (e = number_list(ld, k, "values", v, &sp->v, &sp->n)) != PM_OK)
		return e;
	if (nw != sp->n)
		return sx_fail(ld, k, PM_ERR_INVALID, "<spectrum>: %zu "
		    "wavelengths but %zu values", nw, sp->n);
	return check_pairs(ld, k, "wavelengths", sp);
}

/* d65 and srgb: an RGB colour (d65: times scale; in an RGB renderer the
 * illuminant is white). */
static enum pm_err
parse_colour(struct ld *ld, struct plist *pl, const char *type,
    struct sx_spectrum *sp)
{
	struct prop *c = sx_prop_find(pl, "color");
	double scale = 1.0;
	enum pm_err e;

	sp->kind = SX_SPEC_RGB;
	sp->rgb = pm_rgb1(1.0f);
	if (c == NULL && strcmp(type, "srgb") == 0)
		return sx_missing(ld, pl, "color", "an <rgb>");
	if (c != NULL) {
		c->used = true;
		if (c->type != P_RGB)
			return sx_wrong_type(ld, pl, c, "an <rgb>");
		sp->rgb = c->c;
	}
	if (strcmp(type, "d65") == 0 &&
	    (e = sx_get_float(ld, pl, "scale", 1.0, 0.0, 3.4e38, &scale))
	    != PM_OK)
		return e;
	sp->rgb = pm_rgb_scale(sp->rgb, (float)scale);
	if (!(sp->rgb.r >= 0.0f && sp->rgb.g >= 0.0f && sp->rgb.b >= 0.0f))
		return sx_fail(ld, c != NULL ? c->n : pl->owner, PM_ERR_INVALID,
		    "%s: the colour must not be negative", pl->what);
	return PM_OK;
}

/* type="blackbody", "uniform", "regular", "irregular", "d65" or "srgb",
 * with its parameters as children. */
static enum pm_err
parse_plugin(struct ld *ld, const struct xnode *k, const char *type,
    struct sx_spectrum *sp)
{
	static const char *const known[] = {"blackbody", "uniform", "regular",
	    "irregular", "d65", "srgb", NULL};
	const char *const *t;
	struct plist pl;
	enum pm_err e;

	for (t = known; *t != NULL && strcmp(*t, type) != 0; t++)
		;
	if (*t == NULL)
		return sx_fail(ld, k, PM_ERR_UNSUPPORTED, "unknown spectrum type "
		    "\"%s\" (pm supports blackbody, uniform, regular, "
		    "irregular, d65 and srgb)", type);
	if ((e = sx_collect(ld, k, "spectrum", type, &pl)) != PM_OK)
		return e;
	if (strcmp(type, "regular") == 0 || strcmp(type, "irregular") == 0) {
		sp->kind = SX_SPEC_LIST;
		if ((e = (type[0] == 'r' ? parse_regular : parse_irregular)(ld,
		    k, &pl, sp)) != PM_OK)
			return e;
	} else if (strcmp(type, "d65") == 0 || strcmp(type, "srgb") == 0) {
		if ((e = parse_colour(ld, &pl, type, sp)) != PM_OK)
			return e;
	} else if (strcmp(type, "uniform") == 0) {
		sp->kind = SX_SPEC_PLAIN;
		if ((e = sx_get_float(ld, &pl, "value", 1.0, 0.0, 3.4e38,
		    &sp->value)) != PM_OK)
			return e;
	} else {
		sp->kind = SX_SPEC_BLACKBODY;
		if (!sx_has(&pl, "temperature"))
			return sx_missing(ld, &pl, "temperature", "a <float>, "
			    "in kelvin");
		if ((e = sx_get_float(ld, &pl, "temperature", 0.0, 1e-3, 1e9,
		    &sp->value)) != PM_OK ||
		    (e = sx_get_float(ld, &pl, "wavelength_min", PM_CIE_MIN,
		    1.0, 1e6, &sp->wmin)) != PM_OK ||
		    (e = sx_get_float(ld, &pl, "wavelength_max", PM_CIE_MAX,
		    sp->wmin, 1e6, &sp->wmax)) != PM_OK)
			return e;
	}
	if ((e = sx_finish(ld, &pl)) != PM_OK)
		return e;
	return sx_no_objects(ld, &pl);
}

enum pm_err
sx_parse_spectrum(struct ld *ld, const struct xnode *k, struct prop *p)
{
	static const char *const ok_plain[] = {"name", "value", "filename",
	    NULL};
	static const char *const ok_typed[] = {"name", "type", NULL};
	struct sx_spectrum *sp;
	const char *v = sx_attr(k, "value"), *f = sx_attr(k, "filename");
	const char *type = sx_attr(k, "type");
	enum pm_err e;

	if ((e = sx_check_attrs(ld, k, type != NULL ? ok_typed : ok_plain))
	    != PM_OK ||
	    (e = sx_need_attr(ld, k, "name", &p->name)) != PM_OK)
		return e;
	if ((sp = sx_arena_alloc(&ld->arena, sizeof(*sp))) == NULL)
		return sx_nomem(ld);
	memset(sp, 0, sizeof(*sp));
	p->spec = sp;
	if (type != NULL)
		return parse_plugin(ld, k, type, sp);
	if ((e = sx_no_kids(ld, k)) != PM_OK)
		return e;
	if (v != NULL && f != NULL)
		return sx_fail(ld, k, PM_ERR_INVALID, "<spectrum name=\"%s\">: "
		    "give either value or filename, not both", p->name);
	if (f != NULL)
		return parse_file(ld, k, f, sp);
	if (v == NULL)
		return sx_fail(ld, k, PM_ERR_INVALID, "<spectrum name=\"%s\"> "
		    "needs value, filename or type", p->name);
	return parse_value(ld, k, v, sp);
}

/*
 * The RGB Mitsuba 3's RGB variants make of a spectrum: a uniform value is
 * a grey, except in an emitter, where it is that value times the sRGB of
 * a flat spectrum (XYZ = 1, 1, 1), as a spectral variant would show it;
 * a list is integrated against the CIE curves, weighted by D65 and
 * clamped to [0, 1] unless in an emitter or unbounded (see spectrum.h).
 * Mitsuba's RGB variants refuse to render a blackbody, a regular and an
 * irregular spectrum; pm reduces them as a spectral variant's film shows
 * them: as lists (integrated without D65 in an emitter, with it
 * elsewhere), a blackbody always as an emitter's.
 */
struct pm_rgb
sx_spectrum_rgb(const struct sx_spectrum *sp, bool emitter, bool unbounded)
{
	static const double flat[3] = {1.0, 1.0, 1.0};

	switch (sp->kind) {
	case SX_SPEC_UNIFORM:
		if (emitter)
			return pm_rgb_scale(pm_xyz_to_srgb(flat), (float)sp->value);
		return pm_rgb1((float)sp->value);
	case SX_SPEC_PLAIN:
		return pm_rgb1((float)sp->value);
	case SX_SPEC_RGB:
		return sp->rgb;
	case SX_SPEC_LIST:
		return pm_spectrum_to_srgb(sp->wl, sp->v, sp->n, !emitter,
		    !(emitter || unbounded), NULL);
	case SX_SPEC_BLACKBODY:
		return pm_blackbody_to_srgb(sp->value, sp->wmin, sp->wmax);
	}
	return pm_rgb1(0.0f);
}
