/*
 * bsdf.c: <bsdf> elements, named or nested, into the scene's BSDF table;
 * measured (MERL) tables are read once per file.
 */
#include "private.h"

/* An index of refraction: a number or one of Mitsuba's names. */
static enum pm_err
get_ior(struct ld *ld, struct plist *pl, const char *name, float def,
    float *out)
{
	struct prop *p = sx_prop_find(pl, name);

	*out = def;
	if (p == NULL)
		return PM_OK;
	p->used = true;
	if (p->type == P_STRING) {
		if (!pm_ior_lookup(p->s, out))
			return sx_fail(ld, p->n, PM_ERR_INVALID, "%s: unknown "
			    "material \"%s\" for \"%s\"", pl->what, p->s, name);
	} else if (p->type == P_FLOAT || p->type == P_INTEGER) {
		*out = (float)p->f;
	} else {
		return sx_wrong_type(ld, pl, p, "a <float> or a <string>");
	}
	if (!(*out > 0.0f))
		return sx_fail(ld, p->n, PM_ERR_INVALID, "%s: \"%s\" must be "
		    "positive", pl->what, name);
	return PM_OK;
}

static enum pm_err
conductor_params(struct ld *ld, struct plist *pl, struct pm_bsdf *b)
{
	const char *mat;
	enum pm_err e;

	if ((e = sx_get_string(ld, pl, "material", "none", &mat)) != PM_OK)
		return e;
	if (sx_has(pl, "eta") || sx_has(pl, "k")) {
		if (sx_has(pl, "material"))
			return sx_fail(ld, sx_prop_find(pl, "material")->n,
			    PM_ERR_INVALID, "%s: give either material or "
			    "eta and k, not both", pl->what);
		if (!sx_has(pl, "eta"))
			return sx_missing(ld, pl, "eta", "k is given");
		if (!sx_has(pl, "k"))
			return sx_missing(ld, pl, "k", "eta is given");
		if ((e = sx_get_color(ld, pl, "eta", 0.0f, &b->eta)) != PM_OK ||
		    (e = sx_get_color(ld, pl, "k", 0.0f, &b->k)) != PM_OK)
			return e;
	} else if (!pm_conductor_lookup(mat, &b->eta, &b->k)) {
		return sx_fail(ld, sx_prop_find(pl, "material")->n, PM_ERR_INVALID,
		    "%s: unknown conductor material \"%s\"", pl->what, mat);
	}
	return sx_get_color_tex(ld, pl, "specular_reflectance", 1.0f,
	    &b->specular, &b->tex_specular);
}

/*
 * A measured BRDF: the file resolves like any other, and its table is
 * read once per real path and shared by every BSDF that names it.
 */
static enum pm_err
build_merl(struct ld *ld, struct xnode *n, struct plist *pl,
    struct pm_bsdf *b)
{
	const char *fname, *path, *sampling, *key;
	struct pm_merl *m;
	char *real;
	bool interp;
	size_t i;
	enum pm_err e;

	if (!sx_has(pl, "filename"))
		return sx_missing(ld, pl, "filename", "a <string>");
	if ((e = sx_get_string(ld, pl, "filename", NULL, &fname)) != PM_OK ||
	    (e = sx_get_bool(ld, pl, "interpolate", false, &interp)) != PM_OK ||
	    (e = sx_get_string(ld, pl, "sampling", "data", &sampling)) != PM_OK)
		return e;
	if (strcmp(sampling, "data") != 0 && strcmp(sampling, "cosine") != 0)
		return sx_fail(ld, sx_prop_find(pl, "sampling")->n, PM_ERR_INVALID,
		    "%s: sampling \"%s\" is neither \"data\" nor \"cosine\"",
		    pl->what, sampling);
	b->merl_flags = (interp ? PM_MERL_INTERPOLATE : 0) |
	    (sampling[0] == 'c' ? PM_MERL_COSINE : 0);
	if ((e = sx_resolve(ld, n, n->dir, fname, &path)) != PM_OK)
		return e;
	real = realpath(path, NULL);
	key = real != NULL ? real : path;
	for (i = 0; i < ld->s->nmerls; i++)
		if (strcmp(ld->s->merls[i]->path, key) == 0) {
			b->merl = ld->s->merls[i];
			free(real);
			return PM_OK;
		}
	e = pm_merl_read(key, &m, ld->err);
	free(real);
	if (e != PM_OK)
		return sx_wrap(ld, n, pl->what, e);
	if (pm_scene_add_merl(ld->s, m) < 0) {
		pm_merl_free(m);
		return sx_nomem(ld);
	}
	b->merl = m;
	return PM_OK;
}

/*
 * The microfacet parameters of the rough plugins: distribution
 * ("beckmann", Mitsuba's default, or "ggx"), sample_visible, and alpha or
 * alpha_u and alpha_v (isotropic only: pm's shading frames do not follow
 * a surface parameterisation, so anisotropy would have no direction).
 */
static enum pm_err
microfacet_params(struct ld *ld, struct xnode *n, struct plist *pl,
    struct pm_bsdf *b, bool alpha_tex)
{
	const char *s;
	double a, au, av;
	enum pm_err e;

	if ((e = sx_get_string(ld, pl, "distribution", "beckmann", &s))
	    != PM_OK ||
	    (e = sx_get_bool(ld, pl, "sample_visible", true,
	    &b->sample_visible)) != PM_OK)
		return e;
	if (strcmp(s, "beckmann") == 0)
		b->beckmann = true;
	else if (strcmp(s, "ggx") != 0)
		return sx_fail(ld, sx_prop_find(pl, "distribution")->n,
		    PM_ERR_UNSUPPORTED, "%s: distribution \"%s\" is not "
		    "supported (\"beckmann\" or \"ggx\")", pl->what, s);
	if (sx_has(pl, "alpha_u") || sx_has(pl, "alpha_v")) {
		if (sx_has(pl, "alpha"))
			return sx_fail(ld, sx_prop_find(pl, "alpha")->n,
			    PM_ERR_INVALID, "%s: give either alpha or "
			    "alpha_u and alpha_v", pl->what);
		if ((e = sx_get_float(ld, pl, "alpha_u", -1, 1e-4, 10, &au))
		    != PM_OK || (e = sx_get_float(ld, pl, "alpha_v", -1, 1e-4,
		    10, &av)) != PM_OK)
			return e;
		if (au != av)
			return sx_fail(ld, n, PM_ERR_UNSUPPORTED, "%s: "
			    "anisotropic roughness (alpha_u %g != alpha_v %g) "
			    "is not supported", pl->what, au, av);
		a = au;
	} else if (alpha_tex && (e = sx_get_texture(ld, pl, "alpha",
	    &b->tex_alpha)) != PM_OK) {
		return e;
	} else if (b->tex_alpha > 0) {
		/* the mean until a hit looks it up (texture.h) */
		struct pm_rgb m = pm_texture_mean(
		    &ld->s->textures[b->tex_alpha - 1]);

		a = 0.212671 * m.r + 0.715160 * m.g + 0.072169 * m.b;
	} else if ((e = sx_get_float(ld, pl, "alpha", 0.1, 1e-4, 10, &a))
	    != PM_OK) {
		return e;
	}
	b->alpha = (float)a;
	return PM_OK;
}

/*
 * One scalar parameter of the principled BSDFs: a float in [lo, hi] or a
 * texture (its mean luminance until a hit looks it up); *has, when not
 * NULL, is Mitsuba's flag: given, and not the float 0.
 */
static enum pm_err
pr_param(struct ld *ld, struct plist *pl, struct pm_principled *p, int i,
    const char *name, double def, double lo, double hi, bool *has)
{
	struct pm_rgb m;
	double d;
	enum pm_err e;

	if ((e = sx_get_texture(ld, pl, name, &p->tex[i])) != PM_OK)
		return e;
	if (p->tex[i] > 0) {
		m = pm_texture_mean(&ld->s->textures[p->tex[i] - 1]);
		p->v[i] = 0.212671f * m.r + 0.715160f * m.g + 0.072169f * m.b;
		p->textured = true;
		if (has != NULL)
			*has = true;
		return PM_OK;
	}
	if ((e = sx_get_float(ld, pl, name, def, lo, hi, &d)) != PM_OK)
		return e;
	p->v[i] = (float)d;
	if (has != NULL)
		*has = sx_has(pl, name) && d != 0.0;
	return PM_OK;
}

/* A sampling rate: a non-negative float. */
static enum pm_err
pr_rate(struct ld *ld, struct plist *pl, struct pm_principled *p, int i,
    const char *name)
{
	double d;
	enum pm_err e;

	if ((e = sx_get_float(ld, pl, name, 1.0, 0.0, 1e30, &d)) != PM_OK)
		return e;
	p->rate[i] = (float)d;
	return PM_OK;
}

/*
 * principled and principledthin, with Mitsuba's names and defaults.
 * principled takes eta or specular (eta = 2 / (1 - sqrt(0.08 specular))
 * - 1), not both; with transmission, eta 1 becomes 1.001 and specular 0
 * becomes 0.001, as in Mitsuba.
 */
static enum pm_err
build_principled(struct ld *ld, struct xnode *n, struct plist *pl,
    struct pm_bsdf *b, bool thin)
{
	struct pm_principled *p = &b->pr;
	double spec, eta;
	enum pm_err e;

	pm_principled_defaults(p, thin);
	if ((e = sx_get_color_tex(ld, pl, "base_color", 0.5f, &b->diffuse,
	    &b->tex_diffuse)) != PM_OK ||
	    (e = pr_param(ld, pl, p, PM_PR_ROUGHNESS, "roughness", 0.5, 0.0,
	    1e3, NULL)) != PM_OK ||
	    (e = pr_param(ld, pl, p, PM_PR_ANISOTROPIC, "anisotropic", 0.0,
	    0.0, 1.0, NULL)) != PM_OK ||
	    (e = pr_param(ld, pl, p, PM_PR_SPEC_TRANS, "spec_trans", 0.0, 0.0,
	    1.0, &p->has_spec_trans)) != PM_OK ||
	    (e = pr_param(ld, pl, p, PM_PR_SPEC_TINT, "spec_tint", 0.0, 0.0,
	    1.0, NULL)) != PM_OK ||
	    (e = pr_param(ld, pl, p, PM_PR_SHEEN, "sheen", 0.0, 0.0, 1e3,
	    NULL)) != PM_OK ||
	    (e = pr_param(ld, pl, p, PM_PR_SHEEN_TINT, "sheen_tint", 0.0, 0.0,
	    1.0, NULL)) != PM_OK ||
	    (e = pr_param(ld, pl, p, PM_PR_FLATNESS, "flatness", 0.0, 0.0,
	    1.0, NULL)) != PM_OK ||
	    (e = pr_rate(ld, pl, p, PM_PR_RATE_DIFFUSE,
	    "diffuse_reflectance_sampling_rate")) != PM_OK)
		return e;
	if (thin) {
		if ((e = pr_param(ld, pl, p, PM_PR_ETA, "eta", 1.5, 1e-3, 1e3,
		    NULL)) != PM_OK ||
		    (e = pr_param(ld, pl, p, PM_PR_DIFF_TRANS, "diff_trans",
		    0.0, 0.0, 2.0, &p->has_diff_trans)) != PM_OK ||
		    (e = pr_rate(ld, pl, p, PM_PR_RATE_SPECULAR,
		    "specular_reflectance_sampling_rate")) != PM_OK ||
		    (e = pr_rate(ld, pl, p, PM_PR_RATE_OTHER,
		    "specular_transmittance_sampling_rate")) != PM_OK ||
		    (e = pr_rate(ld, pl, p, PM_PR_RATE_DIFF_TRANS,
		    "diffuse_transmittance_sampling_rate")) != PM_OK)
			return e;
		return PM_OK;
	}
	if ((e = pr_param(ld, pl, p, PM_PR_METALLIC, "metallic", 0.0, 0.0, 1.0,
	    NULL)) != PM_OK ||
	    (e = pr_param(ld, pl, p, PM_PR_CLEARCOAT, "clearcoat", 0.0, 0.0,
	    1e3, &p->has_clearcoat)) != PM_OK ||
	    (e = pr_param(ld, pl, p, PM_PR_CLEARCOAT_GLOSS, "clearcoat_gloss",
	    0.0, 0.0, 1.0, NULL)) != PM_OK ||
	    (e = pr_rate(ld, pl, p, PM_PR_RATE_SPECULAR,
	    "main_specular_sampling_rate")) != PM_OK ||
	    (e = pr_rate(ld, pl, p, PM_PR_RATE_OTHER,
	    "clearcoat_sampling_rate")) != PM_OK)
		return e;
	if (sx_has(pl, "eta") && sx_has(pl, "specular"))
		return sx_fail(ld, n, PM_ERR_INVALID, "%s: give either eta or "
		    "specular, not both", pl->what);
	if (sx_has(pl, "eta")) {
		if ((e = sx_get_float(ld, pl, "eta", 1.5, 1e-3, 1e3, &eta))
		    != PM_OK)
			return e;
		if (p->has_spec_trans && eta == 1.0)
			eta = 1.001;
	} else {
		if ((e = sx_get_float(ld, pl, "specular", 0.5, 0.0, 12.4,
		    &spec)) != PM_OK)
			return e;
		if (p->has_spec_trans && spec == 0.0)
			spec = 1e-3;
		eta = 2.0 / (1.0 - sqrt(0.08 * spec)) - 1.0;
	}
	p->v[PM_PR_ETA] = (float)eta;
	return PM_OK;
}

static enum pm_err
build_twosided(struct ld *ld, struct plist *pl, struct pm_bsdf *b)
{
	struct xnode *inner;
	enum pm_err e;

	if (pl->nobj == 0)
		return sx_fail(ld, pl->owner, PM_ERR_INVALID, "%s needs one "
		    "nested <bsdf> or <ref>", pl->what);
	if (pl->nobj > 1)
		return sx_fail(ld, pl->obj[1], PM_ERR_UNSUPPORTED, "%s: different "
		    "BSDFs on the two sides are not supported", pl->what);
	inner = pl->obj[0];
	if (strcmp(inner->tag, "ref") == 0) {
		if ((e = sx_deref(ld, inner, &inner)) != PM_OK)
			return e;
		if (strcmp(inner->tag, "bsdf") != 0)
			return sx_fail(ld, pl->obj[0], PM_ERR_INVALID, "%s: <ref> "
			    "names a <%s>, expected a <bsdf>", pl->what,
			    inner->tag);
	} else if (strcmp(inner->tag, "bsdf") != 0) {
		return sx_fail(ld, inner, PM_ERR_INVALID, "unexpected <%s> inside "
		    "%s", inner->tag, pl->what);
	}
	if ((e = sx_build_bsdf(ld, inner, b)) != PM_OK)
		return e;
	b->twosided = true;
	return PM_OK;
}

/* Builds the BSDF an element describes into *b (not into the scene). */
enum pm_err
sx_build_bsdf(struct ld *ld, struct xnode *n, struct pm_bsdf *b)
{
	struct plist pl;
	const char *type;
	float iint, iext;
	enum pm_err e;

	if (n->busy)
		return sx_fail(ld, n, PM_ERR_INVALID, "<bsdf> refers to itself");
	if ((e = sx_object_type(ld, n, &type)) != PM_OK ||
	    (e = sx_collect(ld, n, "bsdf", type, &pl)) != PM_OK)
		return e;
	memset(b, 0, sizeof(*b));
	n->busy = true;
	if (strcmp(type, "diffuse") == 0) {
		b->type = PM_BSDF_DIFFUSE;
		e = sx_get_color_tex(ld, &pl, "reflectance", 0.5f, &b->diffuse,
		    &b->tex_diffuse);
	} else if (strcmp(type, "conductor") == 0) {
		b->type = PM_BSDF_CONDUCTOR;
		e = conductor_params(ld, &pl, b);
	} else if (strcmp(type, "roughconductor") == 0) {
		b->type = PM_BSDF_ROUGHCONDUCTOR;
		if ((e = conductor_params(ld, &pl, b)) == PM_OK)
			e = microfacet_params(ld, n, &pl, b, true);
	} else if (strcmp(type, "roughdielectric") == 0) {
		b->type = PM_BSDF_ROUGHDIELECTRIC;
		if ((e = get_ior(ld, &pl, "int_ior", IOR_BK7, &iint)) != PM_OK ||
		    (e = get_ior(ld, &pl, "ext_ior", IOR_AIR, &iext)) != PM_OK ||
		    (e = sx_get_color_tex(ld, &pl, "specular_reflectance", 1.0f,
		    &b->specular, &b->tex_specular)) != PM_OK ||
		    (e = sx_get_color_tex(ld, &pl, "specular_transmittance",
		    1.0f, &b->transmittance, &b->tex_transmittance)) != PM_OK ||
		    (e = microfacet_params(ld, n, &pl, b, false)) != PM_OK)
			goto out;
		b->ior = iint / iext;
	} else if (strcmp(type, "dielectric") == 0 ||
	    strcmp(type, "thindielectric") == 0) {
		b->type = type[0] == 'd' ? PM_BSDF_DIELECTRIC :
		    PM_BSDF_THINDIELECTRIC;
		if ((e = get_ior(ld, &pl, "int_ior", IOR_BK7, &iint)) != PM_OK ||
		    (e = get_ior(ld, &pl, "ext_ior", IOR_AIR, &iext)) != PM_OK ||
		    (e = sx_get_color_tex(ld, &pl, "specular_reflectance", 1.0f,
		    &b->specular, &b->tex_specular)) != PM_OK ||
		    (e = sx_get_color_tex(ld, &pl, "specular_transmittance",
		    1.0f, &b->transmittance, &b->tex_transmittance)) != PM_OK)
			goto out;
		b->ior = iint / iext;
	} else if (strcmp(type, "plastic") == 0 ||
	    strcmp(type, "roughplastic") == 0) {
		b->type = type[0] == 'p' ? PM_BSDF_PLASTIC :
		    PM_BSDF_ROUGHPLASTIC;
		if (b->type == PM_BSDF_ROUGHPLASTIC &&
		    (e = microfacet_params(ld, n, &pl, b, false)) != PM_OK)
			goto out;
		if ((e = sx_get_color_tex(ld, &pl, "diffuse_reflectance", 0.5f,
		    &b->diffuse, &b->tex_diffuse)) != PM_OK ||
		    (e = sx_get_color_tex(ld, &pl, "specular_reflectance", 1.0f,
		    &b->specular, &b->tex_specular)) != PM_OK ||
		    (e = get_ior(ld, &pl, "int_ior", IOR_POLYPROPYLENE, &iint))
		    != PM_OK ||
		    (e = get_ior(ld, &pl, "ext_ior", IOR_AIR, &iext)) != PM_OK ||
		    (e = sx_get_bool(ld, &pl, "nonlinear", false, &b->nonlinear))
		    != PM_OK)
			goto out;
		b->ior = iint / iext;
	} else if (strcmp(type, "principled") == 0 ||
	    strcmp(type, "principledthin") == 0) {
		b->type = type[10] == '\0' ? PM_BSDF_PRINCIPLED :
		    PM_BSDF_PRINCIPLEDTHIN;
		e = build_principled(ld, n, &pl, b,
		    b->type == PM_BSDF_PRINCIPLEDTHIN);
	} else if (strcmp(type, "twosided") == 0) {
		if ((e = sx_finish(ld, &pl)) != PM_OK ||
		    (e = build_twosided(ld, &pl, b)) != PM_OK)
			goto out;
		n->busy = false;
		return PM_OK;
	} else if (strcmp(type, "null") == 0) {
		b->type = PM_BSDF_NULL;
	} else if (strcmp(type, "merl") == 0) {
		b->type = PM_BSDF_MERL;
		e = build_merl(ld, n, &pl, b);
	} else {
		e = sx_unknown_plugin(ld, n, type, "diffuse, conductor, "
		    "roughconductor, dielectric, thindielectric, "
		    "roughdielectric, plastic, roughplastic, principled, "
		    "principledthin, merl, twosided and null");
		goto out;
	}
	if (e == PM_OK && (e = sx_finish(ld, &pl)) == PM_OK)
		e = sx_no_objects(ld, &pl);
out:
	n->busy = false;
	return e;
}

/* The scene index of the BSDF element n, built once however often used. */
enum pm_err
sx_bsdf_index(struct ld *ld, struct xnode *n, int *out)
{
	struct pm_bsdf b;
	enum pm_err e;
	int i;

	if (n->inst >= 0) {
		*out = n->inst;
		return PM_OK;
	}
	if ((e = sx_build_bsdf(ld, n, &b)) != PM_OK)
		return e;
	if ((i = pm_scene_add_bsdf(ld->s)) < 0)
		return sx_nomem(ld);
	ld->s->bsdfs[i] = b;
	n->inst = i;
	*out = i;
	return PM_OK;
}

int
sx_default_bsdf(struct ld *ld)
{
	int i;

	if (ld->default_bsdf >= 0)
		return ld->default_bsdf;
	if ((i = pm_scene_add_bsdf(ld->s)) < 0)
		return -1;
	ld->s->bsdfs[i].type = PM_BSDF_DIFFUSE;
	ld->s->bsdfs[i].diffuse = pm_rgb1(0.5f);
	ld->default_bsdf = i;
	return i;
}
