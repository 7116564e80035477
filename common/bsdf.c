/*
 * bsdf.c: evaluation, sampling and densities of pm's closed set of
 * materials, each meaning what the Mitsuba 3 plugin of the same name means
 * (diffuse, conductor, roughconductor, dielectric, thindielectric,
 * roughdielectric, plastic, roughplastic, null, and the twosided adapter
 * for the non-transmissive ones), in RGB; principled and principledthin
 * live in bsdf_principled.c;
 * measured MERL BRDFs, whose lookup and sampling live in merl.c, and the
 * BSDFs made of others (blendbsdf, mask, twosided with two sides), which
 * reach theirs through pointers pm_scene_prepare sets.
 *
 * One switch per operation; no allocation; nothing here prints.  The
 * formulas are the textbook ones (Walter et al. 2007 for GGX and for rough
 * dielectrics, Heitz 2014 and 2018 for Smith masking and visible-normal
 * sampling, Moeller's "Optics" for the conductor Fresnel term; plastic is
 * a Lambertian base under a smooth dielectric coat, roughplastic under a
 * rough one with Mitsuba's tables of the coating's transmittance, their
 * internal bounces summed in closed form), arranged so that every edge
 * case behaves as Mitsuba 3 does.
 *
 * Departures from Mitsuba, none visible in images: the pdf of a sampled
 * delta component is 1 (bsdf.h's contract) where Mitsuba stores the
 * probability of having chosen that component; a component is chosen
 * when u1 < P rather than u1 <= P, so that one of probability zero is
 * never returned; visible normals are drawn with Heitz's 2018 map rather
 * than the 2014 one Mitsuba uses (the same density, other sample points);
 * Beckmann's normals are drawn from D(m) cos even with sample_visible,
 * and roughdielectric without it does not widen alpha for sampling
 * (other densities, the same integrals); roughplastic's tables are the
 * same integrals by another quadrature; alpha is clamped to 1e-4,
 * below which float breaks down; and a blendbsdf's or mask's sample of
 * a non-delta component carries the density of the whole mix (and its
 * f / pdf), where Mitsuba's carries its component's own density and
 * weight, which its path tracer then weighs against light samples that
 * use the mix's (pm's light samples and BSDF samples see one density).
 */
#include <math.h>
#include <string.h>
#include <strings.h>

#include "bsdf.h"
#include "merl.h"
#include "sampling.h"
#include "texture.h"

/* Below this the GGX lobe is narrower than float precision can follow. */
#define PM_MIN_ALPHA 1e-4f

/* Mirror about the normal in the local frame. */
static struct pm_vec3
reflect_z(struct pm_vec3 w)
{
	return pm_v3(-w.x, -w.y, w.z);
}

static bool
is_transmissive(enum pm_bsdf_type t)
{
	return t == PM_BSDF_DIELECTRIC || t == PM_BSDF_THINDIELECTRIC ||
	    t == PM_BSDF_ROUGHDIELECTRIC || t == PM_BSDF_NULL ||
	    t == PM_BSDF_MASK;
}

/* The lobes `only` selects a BSDF that is not made of others by: its own,
 * except that a measured BRDF, which cannot be split, counts as glossy
 * where it has a peak and as diffuse where it has none (the photon
 * render's rule for it). */
static unsigned
only_class(const struct pm_bsdf *b)
{
	unsigned c = 0;
	int i;

	if (b->type == PM_BSDF_MERL)
		return b->merl != NULL && b->merl->glossy ? PM_LOBE_GLOSSY :
		    PM_LOBE_DIFFUSE;
	if (b->type != PM_BSDF_BLEND && b->type != PM_BSDF_MASK &&
	    b->type != PM_BSDF_TWOSIDED)
		return b->lobes;
	/* made of others: what theirs are (a mask adds its pass) */
	for (i = 0; i < 2; i++)
		if (b->sub[i] != NULL && (i == 0 || b->type != PM_BSDF_MASK))
			c |= only_class(b->sub[i]);
	return b->type == PM_BSDF_MASK ? c | PM_LOBE_DELTA_TRANSMISSION : c;
}

/* Whether `only` leaves nothing of b. */
static bool
excluded(const struct pm_bsdf *b)
{
	return b->only != 0 && (only_class(b) & b->only) == 0;
}

/*
 * Mitsuba's twosided adapter: seen from below, the material behaves as if
 * the query had come from above, mirrored through the surface plane.  It
 * only makes sense for BSDFs that do not transmit (Mitsuba refuses those).
 */
static bool
twosided_flip(const struct pm_bsdf *b, struct pm_vec3 wi)
{
	return b->twosided && wi.z < 0.0f && !is_transmissive(b->type) &&
	    !(b->lobes & (PM_LOBE_TRANSMISSION | PM_LOBE_DIFFUSE_TRANSMISSION));
}

/* Fresnel reflectance of a dielectric; see bsdf.h for the conventions. */
float
pm_fresnel_dielectric(float cos_i, float eta, float *cos_t)
{
	/* eta_it: relative IOR in the direction of travel */
	float eta_it = cos_i >= 0.0f ? eta : 1.0f / eta;
	float eta_ti = 1.0f / eta_it;
	float ci = fabsf(cos_i);
	float ct2 = 1.0f - (1.0f - ci * ci) * eta_ti * eta_ti;
	float ct = sqrtf(pm_fmaxf(ct2, 0.0f));
	float as, ap, r;

	if (eta == 1.0f || ci == 0.0f) {
		/* index matched: nothing reflects; grazing: everything does */
		r = eta == 1.0f ? 0.0f : 1.0f;
	} else {
		/* ct = 0 at total internal reflection makes both ratios +-1 */
		as = (ci - eta_it * ct) / (ci + eta_it * ct);
		ap = (ct - eta_it * ci) / (ct + eta_it * ci);
		r = 0.5f * (as * as + ap * ap);
	}
	if (cos_t != NULL)
		/* the refracted ray leaves on the other side */
		*cos_t = cos_i >= 0.0f ? -ct : ct;
	return r;
}

/* One channel of the conductor Fresnel term (after Moeller, "Optics"). */
static float
fresnel_conductor1(float cos_i, float eta, float k)
{
	float c2 = cos_i * cos_i, s2 = 1.0f - c2, s4 = s2 * s2;
	float t1 = eta * eta - k * k - s2;
	float a2pb2 = sqrtf(pm_fmaxf(t1 * t1 + 4.0f * k * k * eta * eta, 0.0f));
	float a = sqrtf(pm_fmaxf(0.5f * (a2pb2 + t1), 0.0f));
	float term1 = a2pb2 + c2, term2 = 2.0f * cos_i * a;
	float rs = (term1 - term2) / (term1 + term2);
	float term3 = a2pb2 * c2 + s4, term4 = term2 * s2;
	float rp = rs * (term3 - term4) / (term3 + term4);

	return 0.5f * (rs + rp);
}

/* Conductor Fresnel reflectance per channel, for light arriving outside. */
struct pm_rgb
pm_fresnel_conductor(float cos_i, struct pm_rgb eta, struct pm_rgb k)
{
	return pm_rgb(fresnel_conductor1(cos_i, eta.r, k.r),
	    fresnel_conductor1(cos_i, eta.g, k.g),
	    fresnel_conductor1(cos_i, eta.b, k.b));
}

/*
 * Fresnel's diffuse reflectance Fdr(eta), the cosine-weighted hemispherical
 * average of R: the fits Mitsuba uses, Egan and Hilgeman (1973) below 1
 * and d'Eon and Irving (2011) above.
 */
static float
fresnel_diffuse_reflectance(float eta)
{
	float i1, i2, i3, i4, i5;

	if (eta < 1.0f)
		return -1.4399f * eta * eta + 0.7099f * eta + 0.6681f +
		    0.0636f / eta;
	i1 = 1.0f / eta;
	i2 = i1 * i1;
	i3 = i2 * i1;
	i4 = i3 * i1;
	i5 = i4 * i1;
	return 0.919317f - 3.4793f * i1 + 6.75335f * i2 - 7.80989f * i3 +
	    4.98554f * i4 - 1.36881f * i5;
}

/* ---- GGX (Trowbridge-Reitz), alpha ax along the frame's s, ay along t ---- */

static float
ggx_d(float ax, float ay, struct pm_vec3 m)
{
	float c2 = m.z * m.z, t, d;

	if (m.z <= 0.0f)
		return 0.0f;
	t = m.x * m.x / (ax * ax) + m.y * m.y / (ay * ay) + c2;
	d = 1.0f / (PM_PI * ax * ay * t * t);
	/* as Mitsuba: drop values too small to matter, avoiding denormals */
	return d * m.z > 1e-20f ? d : 0.0f;
}

/* Smith's masking for one direction v seen against microfacet m: GGX's
 * exact form, or Beckmann's by Walter et al.'s rational fit (both as
 * Mitsuba 3 evaluates them). */
static float
smith_g1(bool beckmann, float ax, float ay, struct pm_vec3 v,
    struct pm_vec3 m)
{
	float xy, tan2, a;

	/* a facet seen from behind masks everything */
	if (pm_dot(v, m) * v.z <= 0.0f)
		return 0.0f;
	/* the roughness projected on v's azimuth, squared, times sin^2 */
	xy = ax * ax * v.x * v.x + ay * ay * v.y * v.y;
	if (xy == 0.0f)
		return 1.0f;
	tan2 = xy / (v.z * v.z);
	if (!beckmann)
		return 2.0f / (1.0f + sqrtf(1.0f + tan2));
	a = 1.0f / sqrtf(tan2);
	if (a >= 1.6f)
		return 1.0f;
	return (3.535f * a + 2.181f * a * a) / (1.0f + 2.276f * a + 2.577f * a * a);
}

/*
 * A normal from the distribution of normals visible from wi (Heitz 2018,
 * "Sampling the GGX distribution of visible normals"): stretch wi to the
 * unit-roughness configuration, sample the projected hemisphere there,
 * and unstretch.  Density G1(wi,m) max(0, wi.m) D(m) / wi.z.
 */
static struct pm_vec3
ggx_sample_visible(float ax, float ay, struct pm_vec3 wi, float u1,
    float u2)
{
	struct pm_vec3 vh, t1, t2, nh;
	float len2, r, phi, p1, p2, s;

	vh = pm_normalize(pm_v3(ax * wi.x, ay * wi.y, wi.z));
	len2 = vh.x * vh.x + vh.y * vh.y;
	t1 = len2 > 0.0f ? pm_scale(pm_v3(-vh.y, vh.x, 0.0f),
	    1.0f / sqrtf(len2)) : pm_v3(1.0f, 0.0f, 0.0f);
	t2 = pm_cross(vh, t1);
	r = sqrtf(u1);
	phi = 2.0f * PM_PI * u2;
	p1 = r * cosf(phi);
	p2 = r * sinf(phi);
	/* squeeze the disk onto the part of it the view can see */
	s = 0.5f * (1.0f + vh.z);
	p2 = (1.0f - s) * sqrtf(pm_fmaxf(0.0f, 1.0f - p1 * p1)) + s * p2;
	nh = pm_add(pm_add(pm_scale(t1, p1), pm_scale(t2, p2)),
	    pm_scale(vh, sqrtf(pm_fmaxf(0.0f, 1.0f - p1 * p1 - p2 * p2))));
	return pm_normalize(pm_v3(ax * nh.x, ay * nh.y, pm_fmaxf(0.0f, nh.z)));
}

/* The microfacet normal of polar angle tan^2 theta = tan2 and azimuth
 * 2 pi u. */
static struct pm_vec3
normal_from_tan2(float tan2, float u)
{
	float cos_t = 1.0f / sqrtf(1.0f + tan2);
	float sin_t = sqrtf(pm_fmaxf(0.0f, 1.0f - cos_t * cos_t));
	float phi = 2.0f * PM_PI * u;

	return pm_v3(sin_t * cosf(phi), sin_t * sinf(phi), cos_t);
}

/* A normal from D(m) cos(theta_m): tan^2 theta = alpha^2 u / (1 - u). */
static struct pm_vec3
ggx_sample_all(float alpha, float u1, float u2)
{
	return normal_from_tan2(alpha * alpha * u1 / (1.0f - u1), u2);
}

/* ---- Beckmann, as Mitsuba 3 writes it ---- */

static float
beckmann_d(float ax, float ay, struct pm_vec3 m)
{
	float c2 = m.z * m.z, d;

	if (m.z <= 0.0f)
		return 0.0f;
	d = expf(-(m.x * m.x / (ax * ax) + m.y * m.y / (ay * ay)) / c2) /
	    (PM_PI * ax * ay * c2 * c2);
	return d * m.z > 1e-20f ? d : 0.0f;
}

/* A normal from D(m) cos(theta_m): tan^2 theta = -alpha^2 log(1 - u). */
static struct pm_vec3
beckmann_sample_all(float alpha, float u1, float u2)
{
	return normal_from_tan2(-alpha * alpha * logf(1.0f - u1), u2);
}

/*
 * A normal from D(m) cos(theta_m) of an anisotropic distribution: one of
 * the distribution at alpha 1, stretched by (ax, ay).  Both distributions
 * are those of slopes stretched from the unit one (Heitz 2014, sec. 5),
 * and the stretch of a normal's slopes is the stretch of its x and y.
 * Isotropic alphas keep the direct inversion (the same points as before
 * anisotropy existed).
 */
static struct pm_vec3
md_sample_all(bool beckmann, float ax, float ay, float u1, float u2)
{
	struct pm_vec3 m;

	if (ax == ay)
		return beckmann ? beckmann_sample_all(ax, u1, u2) :
		    ggx_sample_all(ax, u1, u2);
	m = beckmann ? beckmann_sample_all(1.0f, u1, u2) :
	    ggx_sample_all(1.0f, u1, u2);
	return pm_normalize(pm_v3(ax * m.x, ay * m.y, m.z));
}

/* The rough conductor's distribution; visible-normal sampling
 * is GGX's only (Beckmann draws from D(m) cos, its own density). */
static float
md_d(const struct pm_bsdf *b, float ax, float ay, struct pm_vec3 m)
{
	return b->beckmann ? beckmann_d(ax, ay, m) : ggx_d(ax, ay, m);
}

/* The BSDF's roughness along the frame's s and t, clamped as alpha is:
 * alpha_u and alpha_v where anisotropic, alpha twice else. */
static void
md_alphas(const struct pm_bsdf *b, float *ax, float *ay)
{
	*ax = pm_fmaxf(b->alpha, PM_MIN_ALPHA);
	*ay = b->aniso ? pm_fmaxf(b->alpha_v, PM_MIN_ALPHA) : *ax;
}

static bool
md_visible(const struct pm_bsdf *b)
{
	return b->sample_visible && !b->beckmann;
}

/* ---- per type ---- */

struct pm_rgb
pm_plastic_base(const struct pm_bsdf *b)
{
	struct pm_rgb d = b->diffuse;

	/* internal bounces between coating and base: a geometric series */
	if (b->nonlinear) {
		d.r /= 1.0f - d.r * b->fdr_int;
		d.g /= 1.0f - d.g * b->fdr_int;
		d.b /= 1.0f - d.b * b->fdr_int;
	} else
		d = pm_rgb_scale(d, 1.0f / (1.0f - b->fdr_int));
	return d;
}

static struct pm_rgb
plastic_diffuse(const struct pm_bsdf *b, float fi, float fo)
{
	float s = (1.0f - fi) * (1.0f - fo) / (b->ior * b->ior);

	return pm_rgb_scale(pm_plastic_base(b), s);
}

/* Probability that plastic's sampler picks the specular coating. */
static float
plastic_prob_specular(const struct pm_bsdf *b, float fi)
{
	/* `only` one of the two lobes: that one, always */
	if (b->only != 0 && !(b->only & PM_LOBE_DELTA_REFLECTION) !=
	    !(b->only & PM_LOBE_DIFFUSE))
		return (b->only & PM_LOBE_DELTA_REFLECTION) ? 1.0f : 0.0f;
	float ps = fi * b->specular_sampling_weight;
	float pd = (1.0f - fi) * (1.0f - b->specular_sampling_weight);

	return ps + pd > 0.0f ? ps / (ps + pd) : fi;
}

/* ---- the microfacet sampler every rough type shares ---- */

/* A microfacet normal for a query from wi_up (above the surface) and its
 * density: visible normals for GGX with sample_visible, D(m) cos else. */
static struct pm_vec3
md_sample(const struct pm_bsdf *b, float ax, float ay, struct pm_vec3 wi_up,
    float u2, float u3, float *pdf_m)
{
	struct pm_vec3 m;

	if (md_visible(b)) {
		m = ggx_sample_visible(ax, ay, wi_up, u2, u3);
		*pdf_m = smith_g1(false, ax, ay, wi_up, m) *
		    pm_fmaxf(pm_dot(wi_up, m), 0.0f) * ggx_d(ax, ay, m) / wi_up.z;
	} else {
		m = md_sample_all(b->beckmann, ax, ay, u2, u3);
		*pdf_m = md_d(b, ax, ay, m) * m.z;
	}
	return m;
}

/* The density md_sample draws m with. */
static float
md_pdf(const struct pm_bsdf *b, float ax, float ay, struct pm_vec3 wi_up,
    struct pm_vec3 m)
{
	if (md_visible(b))
		return smith_g1(false, ax, ay, wi_up, m) *
		    pm_fmaxf(pm_dot(wi_up, m), 0.0f) * ggx_d(ax, ay, m) / wi_up.z;
	return md_d(b, ax, ay, m) * m.z;
}

/* ---- roughdielectric (Walter et al. 2007, as Mitsuba 3 writes it) ---- */

/*
 * The microfacet normal that takes wi to wo, turned up: the half vector
 * for a reflection, the generalised one, wi + eta wo, for a refraction
 * (eta the relative IOR of wo's side over wi's).  False where there is
 * none: grazing wi, or a pair no facet joins (the facet must face both
 * directions from their own sides).
 */
static bool
rd_normal(const struct pm_bsdf *b, struct pm_vec3 wi, struct pm_vec3 wo,
    struct pm_vec3 *m, float *eta, bool *reflect, float *den2)
{
	double hx, hy, hz, len2, s;

	if (wi.z == 0.0f || wo.z == 0.0f)
		return false;
	*reflect = wi.z * wo.z > 0.0f;
	*eta = *reflect ? 1.0f : wi.z > 0.0f ? b->ior : 1.0f / b->ior;
	/* in double: across the interface wi and eta wo nearly cancel in
	 * the tails, and (wi.m + eta wo.m)^2 is this length squared */
	hx = (double)wi.x + (double)*eta * wo.x;
	hy = (double)wi.y + (double)*eta * wo.y;
	hz = (double)wi.z + (double)*eta * wo.z;
	len2 = hx * hx + hy * hy + hz * hz;
	if (!(len2 > 0.0))
		return false;
	s = (hz < 0.0 ? -1.0 : 1.0) / sqrt(len2);
	*m = pm_v3((float)(hx * s), (float)(hy * s), (float)(hz * s));
	*den2 = (float)len2;
	return pm_dot(wi, *m) * wi.z > 0.0f && pm_dot(wo, *m) * wo.z > 0.0f;
}

/* |d omega_m / d omega_o|: 1 / (4 wo.m) for a reflection, eta^2 wo.m /
 * (wi.m + eta wo.m)^2 for a refraction, den2 that square. */
static float
rd_jacobian(struct pm_vec3 wo, struct pm_vec3 m, float eta, bool reflect,
    float den2)
{
	float om = fabsf(pm_dot(wo, m));

	if (reflect)
		return 1.0f / (4.0f * om);
	return eta * eta * om / den2;
}

static struct pm_rgb
eval_roughdielectric(const struct pm_bsdf *b, struct pm_vec3 wi,
    struct pm_vec3 wo, enum pm_transport mode)
{
	float ax, ay;
	struct pm_vec3 m;
	float eta, d, g, f, im, om, den2, v;
	bool reflect;

	md_alphas(b, &ax, &ay);
	if (!rd_normal(b, wi, wo, &m, &eta, &reflect, &den2))
		return pm_rgb1(0.0f);
	d = md_d(b, ax, ay, m);
	if (d == 0.0f)
		return pm_rgb1(0.0f);
	im = pm_dot(wi, m);
	om = pm_dot(wo, m);
	g = smith_g1(b->beckmann, ax, ay, wi, m) *
	    smith_g1(b->beckmann, ax, ay, wo, m);
	f = pm_fresnel_dielectric(im, b->ior, NULL);
	if (reflect)
		return pm_rgb_scale(b->specular, f * d * g / (4.0f * fabsf(wi.z)));
	/*
	 * Walter's BTDF for radiance (eq. 21, with wi on the camera's side)
	 * times cos_o; importance, its adjoint, carries eta^2 more (Veach
	 * 1997, sec. 5.2: radiance is compressed by 1/eta^2 on the way in).
	 */
	v = (1.0f - f) * d * g * fabsf(im * om / wi.z) / den2;
	if (mode == PM_IMPORTANCE)
		v *= eta * eta;
	return pm_rgb_scale(b->transmittance, v);
}

static float
pdf_roughdielectric(const struct pm_bsdf *b, struct pm_vec3 wi,
    struct pm_vec3 wo)
{
	float ax, ay;
	struct pm_vec3 m, wi_up = wi.z < 0.0f ? pm_neg(wi) : wi;
	float eta, f, den2;
	bool reflect;

	md_alphas(b, &ax, &ay);
	if (!rd_normal(b, wi, wo, &m, &eta, &reflect, &den2))
		return 0.0f;
	f = pm_fresnel_dielectric(pm_dot(wi, m), b->ior, NULL);
	return md_pdf(b, ax, ay, wi_up, m) * (reflect ? f : 1.0f - f) *
	    rd_jacobian(wo, m, eta, reflect, den2);
}

/* One facet from the distribution seen from wi's side, then reflection
 * or refraction through it chosen by its Fresnel reflectance. */
static bool
sample_roughdielectric(const struct pm_bsdf *b, struct pm_vec3 wi, float u1,
    float u2, float u3, enum pm_transport mode, struct pm_bsdf_sample *s)
{
	float ax, ay;
	struct pm_vec3 m, wi_up = wi.z < 0.0f ? pm_neg(wi) : wi;
	float pdf_m, im, f, cos_t, eta_it, eta_ti, w, pe, den2;
	bool reflect;

	md_alphas(b, &ax, &ay);
	if (wi.z == 0.0f)
		return false;
	m = md_sample(b, ax, ay, wi_up, u2, u3, &pdf_m);
	im = pm_dot(wi, m);
	/* a facet that faces away from wi is not seen from there */
	if (!(pdf_m > 0.0f) || im * wi.z <= 0.0f)
		return false;
	f = pm_fresnel_dielectric(im, b->ior, &cos_t);
	reflect = u1 < f;
	if (reflect) {
		s->wo = pm_sub(pm_scale(m, 2.0f * im), wi);
		s->weight = b->specular;
		s->eta = 1.0f;
		s->lobe = PM_LOBE_GLOSSY;
		pe = f;
		eta_it = 1.0f;
		if (s->wo.z * wi.z <= 0.0f)
			return false;
	} else {
		eta_it = im > 0.0f ? b->ior : 1.0f / b->ior;
		eta_ti = 1.0f / eta_it;
		s->wo = pm_add(pm_scale(wi, -eta_ti),
		    pm_scale(m, eta_ti * im + cos_t));
		s->weight = b->transmittance;
		/* radiance is compressed with the solid angle; importance
		 * is not (as for the smooth dielectric) */
		if (mode == PM_RADIANCE)
			s->weight = pm_rgb_scale(s->weight, eta_ti * eta_ti);
		s->eta = eta_it;
		s->lobe = PM_LOBE_GLOSSY_TRANSMISSION;
		pe = 1.0f - f;
		if (s->wo.z * wi.z >= 0.0f)
			return false;
	}
	s->wo = pm_normalize(s->wo);
	den2 = pm_dot(wi, m) + eta_it * pm_dot(s->wo, m);
	s->pdf = pdf_m * pe * rd_jacobian(s->wo, m, eta_it, reflect,
	    den2 * den2);
	if (!(s->pdf > 0.0f))
		return false;
	/* f |cos_o| / pdf: D and the Fresnel choice cancel */
	if (md_visible(b))
		w = smith_g1(false, ax, ay, s->wo, m);
	else
		w = smith_g1(b->beckmann, ax, ay, wi, m) *
		    smith_g1(b->beckmann, ax, ay, s->wo, m) *
		    fabsf(im / (wi.z * m.z));
	s->weight = pm_rgb_scale(s->weight, w);
	return true;
}

/* ---- roughplastic: a rough dielectric coating over a Lambertian base ---- */

/*
 * Energy that crosses a rough dielectric interface (relative IOR eta)
 * from direction wi = (sqrt(1 - mu^2), 0, mu) and is not masked on the
 * way out, single scattering only: transmit selects refraction (the
 * coating's transmittance) or reflection (its reflectance).  It is the
 * integral over visible normals of (1 - F) G1(wo) (or F G1(wo)); taken
 * here over the normals of D(m) cos, where m = m(u, phi) follows the
 * distribution's own inversion, by the midpoint rule in (v, phi), u a
 * function of v (below), with phi over half the circle (the integrand is
 * even in phi).
 */
static double
rough_interface(const struct pm_bsdf *b, float alpha, float mu, float eta,
    bool transmit, int nu, int nphi)
{
	struct pm_vec3 wi = pm_v3(sqrtf(pm_fmaxf(0.0f, 1.0f - mu * mu)), 0.0f, mu);
	double sum = 0.0;
	int i, j;

	for (i = 0; i < nu; i++) {
		/* u = 1 - (1 - v)^3: the steep facets of the tail are the
		 * ones a grazing wi sees most, and their weight grows like
		 * (1 - u)^-1/2 (GGX); the substitution makes it vanish */
		double v1 = 1.0 - ((double)i + 0.5) / (double)nu;
		double w = 3.0 * v1 * v1, row = 0.0;
		double u1 = v1 * v1 * v1;	/* 1 - u */
		float t2 = (float)(b->beckmann ? -alpha * alpha * log(u1) :
		    alpha * alpha * (1.0 - u1) / u1);

		for (j = 0; j < nphi; j++) {
			struct pm_vec3 m = normal_from_tan2(t2,
			    0.5f * ((float)j + 0.5f) / (float)nphi);
			struct pm_vec3 wo;
			float im = pm_dot(wi, m), cos_t, f, g;

			if (im <= 0.0f)
				continue;
			f = pm_fresnel_dielectric(im, eta, &cos_t);
			if (transmit) {
				wo = pm_add(pm_scale(wi, -1.0f / eta),
				    pm_scale(m, im / eta + cos_t));
				if (wo.z >= 0.0f)
					continue;
				f = 1.0f - f;
			} else {
				wo = pm_sub(pm_scale(m, 2.0f * im), wi);
				if (wo.z <= 0.0f)
					continue;
			}
			/* visible-normal density over D(m) cos:
			 * G1(wi) wi.m / (mu m.z) */
			g = smith_g1(b->beckmann, alpha, alpha, wi, m) *
			    smith_g1(b->beckmann, alpha, alpha, wo, m);
			row += (double)(f * g * im / (mu * m.z));
		}
		sum += w * row;
	}
	return sum / ((double)nu * nphi);
}

/*
 * Roughplastic's tables, as Mitsuba 3 defines them: the coating's
 * transmittance from outside at PM_ROUGH_T_RES values of cos theta
 * spaced evenly over [0, 1] (the first at 1e-6), and the internal
 * diffuse reflectance, twice the mean over the same nodes of the
 * reflectance from inside (relative IOR 1/eta) times cos theta.  (That
 * mean is Mitsuba's own rule; it is what its images are made with.)
 */
static void
roughplastic_tables(struct pm_bsdf *b)
{
	float alpha = pm_fmaxf(b->alpha, PM_MIN_ALPHA);
	double sum = 0.0;
	int i;

	/* no storage given: no base (rough_t reads 0), never a crash */
	if (b->rough_t == NULL) {
		b->fdr_int = 0.0f;
		return;
	}

	for (i = 0; i < PM_ROUGH_T_RES; i++) {
		float mu = pm_fmaxf(1e-6f, (float)i / (float)(PM_ROUGH_T_RES - 1));

		b->rough_t[i] = (float)rough_interface(b, alpha, mu, b->ior,
		    true, 64, 32);
		sum += rough_interface(b, alpha, mu, 1.0f / b->ior, false,
		    128, 64) * mu;
	}
	b->fdr_int = (float)(2.0 * sum / PM_ROUGH_T_RES);
}

/* The coating's transmittance at cos theta c, interpolated in the table. */
static float
rough_t(const struct pm_bsdf *b, float c)
{
	float x = pm_fminf(pm_fmaxf(c, 0.0f), 1.0f) * (float)(PM_ROUGH_T_RES - 1);
	int i = (int)x;

	if (b->rough_t == NULL)
		return 0.0f;

	if (i > PM_ROUGH_T_RES - 2)
		i = PM_ROUGH_T_RES - 2;
	x -= (float)i;
	return (1.0f - x) * b->rough_t[i] + x * b->rough_t[i + 1];
}

/* Which of roughplastic's lobes b->only leaves on. */
static void
rp_lobes(const struct pm_bsdf *b, bool *spec, bool *diff)
{
	*spec = b->only == 0 || (b->only & PM_LOBE_GLOSSY);
	*diff = b->only == 0 || (b->only & PM_LOBE_DIFFUSE);
}

/* Probability that roughplastic's sampler picks the coating (Mitsuba's
 * rule: the coating's reflectance against the base's share, steered by
 * the mean reflectances). */
static float
rp_prob_specular(const struct pm_bsdf *b, float t_i)
{
	bool spec, diff;
	float ps, pd;

	rp_lobes(b, &spec, &diff);
	if (spec != diff)
		return spec ? 1.0f : 0.0f;
	ps = (1.0f - t_i) * b->specular_sampling_weight;
	pd = t_i * (1.0f - b->specular_sampling_weight);
	return ps + pd > 0.0f ? ps / (ps + pd) : 0.5f;
}

static struct pm_rgb
eval_roughplastic(const struct pm_bsdf *b, struct pm_vec3 wi,
    struct pm_vec3 wo)
{
	float alpha = pm_fmaxf(b->alpha, PM_MIN_ALPHA), s;
	struct pm_rgb r = pm_rgb1(0.0f), d;
	struct pm_vec3 h;
	bool spec, diff;

	if (wi.z <= 0.0f || wo.z <= 0.0f)
		return r;
	rp_lobes(b, &spec, &diff);
	if (spec) {
		h = pm_normalize(pm_add(wi, wo));
		s = md_d(b, alpha, alpha, h) * smith_g1(b->beckmann, alpha, alpha, wi, h) *
		    smith_g1(b->beckmann, alpha, alpha, wo, h) *
		    pm_fresnel_dielectric(pm_dot(wi, h), b->ior, NULL) /
		    (4.0f * wi.z);
		r = pm_rgb_scale(b->specular, s);
	}
	if (diff) {
		d = b->diffuse;
		/* the light that bounces between base and coating */
		if (b->nonlinear) {
			d.r /= 1.0f - d.r * b->fdr_int;
			d.g /= 1.0f - d.g * b->fdr_int;
			d.b /= 1.0f - d.b * b->fdr_int;
		} else
			d = pm_rgb_scale(d, 1.0f / (1.0f - b->fdr_int));
		s = rough_t(b, wi.z) * rough_t(b, wo.z) * wo.z * PM_INV_PI /
		    (b->ior * b->ior);
		r = pm_rgb_add(r, pm_rgb_scale(d, s));
	}
	return r;
}

static float
pdf_roughplastic(const struct pm_bsdf *b, struct pm_vec3 wi,
    struct pm_vec3 wo)
{
	float alpha = pm_fmaxf(b->alpha, PM_MIN_ALPHA), ps, p = 0.0f;
	struct pm_vec3 h;

	if (wi.z <= 0.0f || wo.z <= 0.0f)
		return 0.0f;
	ps = rp_prob_specular(b, rough_t(b, wi.z));
	if (ps > 0.0f) {
		h = pm_normalize(pm_add(wi, wo));
		p = ps * md_pdf(b, alpha, alpha, wi, h) / (4.0f * pm_dot(wo, h));
	}
	return p + (1.0f - ps) * wo.z * PM_INV_PI;
}

static bool
sample_roughplastic(const struct pm_bsdf *b, struct pm_vec3 wi, float u1,
    float u2, float u3, struct pm_bsdf_sample *s)
{
	float alpha = pm_fmaxf(b->alpha, PM_MIN_ALPHA), ps, pdf_m;
	struct pm_vec3 m;

	if (wi.z <= 0.0f)
		return false;
	ps = rp_prob_specular(b, rough_t(b, wi.z));
	if (u1 < ps) {
		m = md_sample(b, alpha, alpha, wi, u2, u3, &pdf_m);
		if (!(pdf_m > 0.0f) || pm_dot(wi, m) <= 0.0f)
			return false;
		s->wo = pm_normalize(pm_sub(pm_scale(m, 2.0f * pm_dot(wi, m)),
		    wi));
		s->lobe = PM_LOBE_GLOSSY;
	} else {
		s->wo = pm_square_to_cosine_hemisphere(u2, u3);
		s->lobe = PM_LOBE_DIFFUSE;
	}
	if (s->wo.z <= 0.0f)
		return false;
	s->pdf = pdf_roughplastic(b, wi, s->wo);
	if (!(s->pdf > 0.0f))
		return false;
	s->weight = pm_rgb_scale(eval_roughplastic(b, wi, s->wo),
	    1.0f / s->pdf);
	s->eta = 1.0f;
	return true;
}

/* ---- BSDFs made of others: blendbsdf, mask, twosided with two sides ---- */

/*
 * Nested BSDF i of b as it stands at this hit: the scene's own when it
 * takes no texture and b selects no lobes, else a copy in *tmp with
 * its textures looked up at the hit's uv (which pm_bsdf_at recorded in
 * b) and b's `only` passed on.  A copy on the stack, never an
 * allocation; nesting is as deep as the scene file makes it.
 */
static const struct pm_bsdf *
nested_at(const struct pm_bsdf *b, int i, struct pm_bsdf *tmp)
{
	const struct pm_bsdf *c = b->sub[i];
	bool tex = c->tex_diffuse > 0 || c->tex_specular > 0 ||
	    c->tex_alpha > 0 || c->tex_weight > 0 || c->nested_textures;

	if (!tex && c->only == b->only)
		return c;
	*tmp = *c;
	tmp->only = b->only;
	if (tex && b->textures != NULL)
		pm_bsdf_lookup(b->textures, tmp, b->u, b->v);
	return tmp;
}

/* Whether `only` leaves anything of c (a nested BSDF as nested_at gives
 * it, so with the parent's `only`). */
static bool
selected(const struct pm_bsdf *c)
{
	return c->only == 0 || (only_class(c) & c->only) != 0;
}

/*
 * The components a composite chooses between when sampling, in order:
 * blendbsdf its two BSDFs, mask its BSDF and the pass through it.  m[]
 * are their shares of the BSDF (the mixture weights), q[] the
 * probabilities of sampling each: the shares, renormalised over the
 * components `only` leaves.  Returns how many there are.
 */
static int
components(const struct pm_bsdf *b, const struct pm_bsdf *c0,
    const struct pm_bsdf *c1, float m[2], float q[2])
{
	float w = pm_fminf(pm_fmaxf(b->weight, 0.0f), 1.0f), t;
	bool a0, a1;

	if (b->type == PM_BSDF_BLEND) {
		m[0] = 1.0f - w;
		m[1] = w;
		a0 = selected(c0);
		a1 = selected(c1);
	} else {
		/* mask: its BSDF at the opacity, the rest a pass */
		m[0] = w;
		m[1] = 1.0f - w;
		a0 = selected(c0);
		a1 = b->only == 0 || (b->only & PM_LOBE_DELTA_TRANSMISSION);
	}
	q[0] = a0 ? m[0] : 0.0f;
	q[1] = a1 ? m[1] : 0.0f;
	t = q[0] + q[1];
	if (t > 0.0f) {
		q[0] /= t;
		q[1] /= t;
	}
	return 2;
}

static struct pm_rgb
eval_composite(const struct pm_bsdf *b, struct pm_vec3 wi, struct pm_vec3 wo,
    enum pm_transport mode)
{
	struct pm_bsdf t0, t1;
	const struct pm_bsdf *c0, *c1;
	struct pm_rgb r = pm_rgb1(0.0f);
	float m[2], q[2];

	if (b->type == PM_BSDF_TWOSIDED) {
		/* the back seen as if from the front (Mitsuba's twosided) */
		if (wi.z > 0.0f)
			return pm_bsdf_eval(nested_at(b, 0, &t0), wi, wo, mode);
		wi.z = -wi.z;
		wo.z = -wo.z;
		return pm_bsdf_eval(nested_at(b, 1, &t1), wi, wo, mode);
	}
	c0 = nested_at(b, 0, &t0);
	c1 = b->type == PM_BSDF_BLEND ? nested_at(b, 1, &t1) : NULL;
	components(b, c0, c1 != NULL ? c1 : c0, m, q);
	if (m[0] > 0.0f)
		r = pm_rgb_scale(pm_bsdf_eval(c0, wi, wo, mode), m[0]);
	if (c1 != NULL && m[1] > 0.0f)
		r = pm_rgb_madd(r, pm_rgb1(m[1]), pm_bsdf_eval(c1, wi, wo, mode));
	return r;
}

static float
pdf_composite(const struct pm_bsdf *b, struct pm_vec3 wi, struct pm_vec3 wo)
{
	struct pm_bsdf t0, t1;
	const struct pm_bsdf *c0, *c1;
	float m[2], q[2], p = 0.0f;

	if (b->type == PM_BSDF_TWOSIDED) {
		if (wi.z > 0.0f)
			return pm_bsdf_pdf(nested_at(b, 0, &t0), wi, wo);
		wi.z = -wi.z;
		wo.z = -wo.z;
		return pm_bsdf_pdf(nested_at(b, 1, &t1), wi, wo);
	}
	c0 = nested_at(b, 0, &t0);
	c1 = b->type == PM_BSDF_BLEND ? nested_at(b, 1, &t1) : NULL;
	components(b, c0, c1 != NULL ? c1 : c0, m, q);
	/* the density of the mixture: each component's, by the chance of
	 * sampling it (a mask's pass is a delta, no density) */
	if (q[0] > 0.0f)
		p = q[0] * pm_bsdf_pdf(c0, wi, wo);
	if (c1 != NULL && q[1] > 0.0f)
		p += q[1] * pm_bsdf_pdf(c1, wi, wo);
	return p;
}

/* Largest float below 1: a remapped u1 must stay in [0, 1). */
#define BELOW_ONE 0x1.fffffep-1f

/*
 * One component chosen by u1 with probability q[] (u1 rescaled and used
 * again inside it), then sampled.  A delta sample keeps its own weight
 * times share / probability; any other is weighed against the whole
 * mixture, f / pdf with both summed over the components, so that its pdf
 * is the one pm_bsdf_pdf gives and MIS sees one density.
 */
static bool
sample_composite(const struct pm_bsdf *b, struct pm_vec3 wi, float u1,
    float u2, float u3, enum pm_transport mode, struct pm_bsdf_sample *s)
{
	struct pm_bsdf t0, t1;
	const struct pm_bsdf *c0, *c1, *c;
	float m[2], q[2];
	int k;

	if (b->type == PM_BSDF_TWOSIDED) {
		bool back = wi.z <= 0.0f;

		if (back)
			wi.z = -wi.z;
		if (!pm_bsdf_sample(nested_at(b, back ? 1 : 0, &t0), wi, u1, u2,
		    u3, mode, s))
			return false;
		if (back)
			s->wo.z = -s->wo.z;
		return true;
	}
	c0 = nested_at(b, 0, &t0);
	c1 = b->type == PM_BSDF_BLEND ? nested_at(b, 1, &t1) : NULL;
	components(b, c0, c1 != NULL ? c1 : c0, m, q);
	if (!(q[0] + q[1] > 0.0f))
		return false;
	if (u1 < q[0]) {
		k = 0;
		u1 = pm_fminf(u1 / q[0], BELOW_ONE);
	} else {
		k = 1;
		u1 = q[1] > 0.0f ? pm_fminf((u1 - q[0]) / q[1], BELOW_ONE) : 0.0f;
	}
	if (!(q[k] > 0.0f))
		return false;
	if (c1 == NULL && k == 1) {
		/* through the mask, as if nothing were there */
		s->wo = pm_neg(wi);
		s->pdf = 1.0f;
		s->weight = pm_rgb1(m[1] / q[1]);
		s->eta = 1.0f;
		s->lobe = PM_LOBE_DELTA_TRANSMISSION;
		return true;
	}
	c = k == 0 ? c0 : c1;
	if (!pm_bsdf_sample(c, wi, u1, u2, u3, mode, s))
		return false;
	if (s->lobe & PM_LOBE_DELTA) {
		s->weight = pm_rgb_scale(s->weight, m[k] / q[k]);
		return true;
	}
	s->pdf = pdf_composite(b, wi, s->wo);
	if (!(s->pdf > 0.0f))
		return false;
	s->weight = pm_rgb_scale(eval_composite(b, wi, s->wo, mode),
	    1.0f / s->pdf);
	return true;
}

/* Fills derived fields (lobes, plastic's tables); call once after loading. */
void
pm_bsdf_prepare(struct pm_bsdf *b)
{
	float dm, sm;

	switch (b->type) {
	case PM_BSDF_DIFFUSE:
		b->lobes = PM_LOBE_DIFFUSE;
		break;
	case PM_BSDF_CONDUCTOR:
		b->lobes = PM_LOBE_DELTA_REFLECTION;
		break;
	case PM_BSDF_ROUGHCONDUCTOR:
		b->lobes = PM_LOBE_GLOSSY;
		break;
	case PM_BSDF_DIELECTRIC:
	case PM_BSDF_THINDIELECTRIC:
		b->lobes = PM_LOBE_DELTA_REFLECTION |
		    PM_LOBE_DELTA_TRANSMISSION;
		break;
	case PM_BSDF_PLASTIC:
		b->lobes = PM_LOBE_DELTA_REFLECTION | PM_LOBE_DIFFUSE;
		/* light inside the coating meets the interface with 1/eta */
		b->fdr_int = fresnel_diffuse_reflectance(1.0f / b->ior);
		/* steer samples by the mean reflectances, as Mitsuba does */
		dm = pm_rgb_mean(b->diffuse);
		sm = pm_rgb_mean(b->specular);
		b->specular_sampling_weight = dm + sm > 0.0f ?
		    sm / (dm + sm) : 0.5f;
		break;
	case PM_BSDF_NULL:
		b->lobes = PM_LOBE_DELTA_TRANSMISSION;
		break;
	case PM_BSDF_MERL:
		/* measured: anything from matte to shiny, never a delta */
		b->lobes = PM_LOBE_GLOSSY | PM_LOBE_DIFFUSE;
		break;
	case PM_BSDF_ROUGHDIELECTRIC:
		b->lobes = PM_LOBE_GLOSSY | PM_LOBE_GLOSSY_TRANSMISSION;
		break;
	case PM_BSDF_PRINCIPLED:
	case PM_BSDF_PRINCIPLEDTHIN:
		b->lobes = pm_principled_lobes(b);
		break;
	case PM_BSDF_BLEND:
	case PM_BSDF_TWOSIDED:
		/* what either nested BSDF can do (as Mitsuba's flags) */
		b->lobes = (b->sub[0] != NULL ? b->sub[0]->lobes : 0) |
		    (b->sub[1] != NULL ? b->sub[1]->lobes : 0);
		break;
	case PM_BSDF_MASK:
		b->lobes = (b->sub[0] != NULL ? b->sub[0]->lobes : 0) |
		    PM_LOBE_DELTA_TRANSMISSION;
		break;
	case PM_BSDF_ROUGHPLASTIC:
		b->lobes = PM_LOBE_GLOSSY | PM_LOBE_DIFFUSE;
		roughplastic_tables(b);
		dm = pm_rgb_mean(b->diffuse);
		sm = pm_rgb_mean(b->specular);
		b->specular_sampling_weight = dm + sm > 0.0f ?
		    sm / (dm + sm) : 0.5f;
		break;
	}
}

/* ---- normalmap and bumpmap: the BSDF in a perturbed frame ---- */

/*
 * Estevez et al.'s shadowing of light arriving along w at a surface whose
 * normal a map tilted to n (Ray Tracing Gems, 2019, ch. 12), both in the
 * unperturbed frame, as Mitsuba's wrappers apply it by default: 1 for an
 * untilted normal, falling off towards grazing w as the tilt grows.
 */
static float
shadow_terminator(const struct pm_bsdf *b, struct pm_vec3 n,
    struct pm_vec3 w)
{
	float n2 = n.z * n.z, w2 = w.z * w.z, a2;

	if (b->no_shadowing)
		return 1.0f;
	a2 = n2 > 0.0f ? pm_fminf(0.125f * pm_fmaxf(0.0f, 1.0f - n2) / n2, 1.0f) :
	    1.0f;
	if (a2 == 0.0f)
		return 1.0f;
	if (!(w2 > 0.0f))
		return 0.0f;
	return 2.0f / (1.0f + sqrtf(1.0f + a2 * pm_fmaxf(0.0f, 1.0f - w2) / w2));
}

/*
 * The wrapped BSDF (b without its wrapper) and the query as it sees it:
 * mirrored first where the wrapper sits inside twosided (Mitsuba's
 * twosided mirrors the query before handing it on), and returns whether
 * it was mirrored.
 */
static bool
perturbed_inner(const struct pm_bsdf *b, struct pm_bsdf *inner,
    struct pm_vec3 *wi, struct pm_vec3 *wo)
{
	*inner = *b;
	inner->perturbed = false;
	if (!b->perturb_in_twosided)
		return false;
	inner->twosided = false;
	if (wi->z >= 0.0f)
		return false;
	wi->z = -wi->z;
	if (wo != NULL)
		wo->z = -wo->z;
	return true;
}

/* Which direction the shadowing term takes: the light's, wo for
 * radiance, wi for importance (the term is not symmetric, and photons
 * must meet it where the camera's paths do). */
static struct pm_vec3
shadow_dir(struct pm_vec3 wi, struct pm_vec3 wo, enum pm_transport mode)
{
	return mode == PM_RADIANCE ? wo : wi;
}

/*
 * Importance's correction for the tilted normal (Veach 1997, sec. 5.3):
 * the BSDF's cosine belongs to the light's side, wi for importance, and
 * the flux leaving towards wo spreads over the unperturbed surface, so
 * f |cos_p wo| becomes f |cos_p wi| |cos wo| / |cos wi|.  1 for
 * radiance, whose wo is the light's side already.  wi, wo unperturbed;
 * wip, wop perturbed.
 */
static float
importance_factor(enum pm_transport mode, struct pm_vec3 wi,
    struct pm_vec3 wo, struct pm_vec3 wip, struct pm_vec3 wop)
{
	float d = wi.z * wop.z;

	if (mode == PM_RADIANCE)
		return 1.0f;
	return d != 0.0f ? fabsf(wip.z * wo.z / d) : 0.0f;
}

static struct pm_rgb
eval_perturbed(const struct pm_bsdf *b, struct pm_vec3 wi, struct pm_vec3 wo,
    enum pm_transport mode)
{
	struct pm_bsdf in;
	struct pm_vec3 wip, wop;

	perturbed_inner(b, &in, &wi, &wo);
	wip = pm_to_local(b->pframe, wi);
	wop = pm_to_local(b->pframe, wo);
	/* light must leave on the same side of both frames */
	if (wo.z * wop.z <= 0.0f)
		return pm_rgb1(0.0f);
	return pm_rgb_scale(pm_bsdf_eval(&in, wip, wop, mode),
	    shadow_terminator(b, b->pframe.n, shadow_dir(wi, wo, mode)) *
	    importance_factor(mode, wi, wo, wip, wop));
}

static float
pdf_perturbed(const struct pm_bsdf *b, struct pm_vec3 wi, struct pm_vec3 wo)
{
	struct pm_bsdf in;
	struct pm_vec3 wop;

	perturbed_inner(b, &in, &wi, &wo);
	wop = pm_to_local(b->pframe, wo);
	if (wo.z * wop.z <= 0.0f)
		return 0.0f;
	return pm_bsdf_pdf(&in, pm_to_local(b->pframe, wi), wop);
}

/* pm_bsdf_sample, or pm_bsdf_coating where coating, through the wrapper. */
static bool
sample_perturbed(const struct pm_bsdf *b, struct pm_vec3 wi, float u1,
    float u2, float u3, enum pm_transport mode, bool coating,
    struct pm_bsdf_sample *s)
{
	struct pm_bsdf in;
	struct pm_vec3 wo, wip;
	bool mirror = perturbed_inner(b, &in, &wi, NULL), ok;

	wip = pm_to_local(b->pframe, wi);
	ok = coating ? pm_bsdf_coating(&in, wip, s) :
	    pm_bsdf_sample(&in, wip, u1, u2, u3, mode, s);
	if (!ok)
		return false;
	wo = pm_to_world(b->pframe, s->wo);
	if (s->wo.z * wo.z <= 0.0f)
		return false;
	s->weight = pm_rgb_scale(s->weight,
	    shadow_terminator(b, b->pframe.n, shadow_dir(wi, wo, mode)) *
	    importance_factor(mode, wi, wo, wip, s->wo));
	s->wo = wo;
	if (mirror)
		s->wo.z = -s->wo.z;
	return true;
}

bool
pm_bsdf_lambertian(const struct pm_bsdf *b, struct pm_vec3 wi,
    struct pm_rgb *rho, float *side)
{
	if (b->perturbed || b->type != PM_BSDF_DIFFUSE || excluded(b))
		return false;
	*side = 1.0f;
	if (twosided_flip(b, wi)) {
		wi.z = -wi.z;
		*side = -1.0f;
	}
	*rho = wi.z > 0.0f ? b->diffuse : pm_rgb1(0.0f);
	return true;
}

/* f(wi, wo) |cos theta_o|; zero for delta components. */
struct pm_rgb
pm_bsdf_eval(const struct pm_bsdf *b, struct pm_vec3 wi, struct pm_vec3 wo,
    enum pm_transport mode)
{
	struct pm_vec3 h;
	struct pm_rgb f;
	float ax, ay, d, g, fi, fo;

	if (b->perturbed)
		return eval_perturbed(b, wi, wo, mode);
	if (twosided_flip(b, wi)) {
		wi.z = -wi.z;
		wo.z = -wo.z;
	}
	if (excluded(b))
		return pm_rgb1(0.0f);
	switch (b->type) {
	case PM_BSDF_DIFFUSE:
		return pm_diffuse_eval(b->diffuse, wi, wo);
	case PM_BSDF_ROUGHCONDUCTOR:
		if (wi.z <= 0.0f || wo.z <= 0.0f)
			break;
		md_alphas(b, &ax, &ay);
		h = pm_normalize(pm_add(wi, wo));
		d = md_d(b, ax, ay, h);
		if (d == 0.0f)
			break;
		g = smith_g1(b->beckmann, ax, ay, wi, h) *
		    smith_g1(b->beckmann, ax, ay, wo, h);
		f = pm_fresnel_conductor(pm_dot(wi, h), b->eta, b->k);
		/* D G F / (4 cos_i cos_o), times cos_o */
		return pm_rgb_scale(pm_rgb_mul(f, b->specular),
		    d * g / (4.0f * wi.z));
	case PM_BSDF_PLASTIC:
		if (wi.z <= 0.0f || wo.z <= 0.0f ||
		    (b->only != 0 && !(b->only & PM_LOBE_DIFFUSE)))
			break;
		fi = pm_fresnel_dielectric(wi.z, b->ior, NULL);
		fo = pm_fresnel_dielectric(wo.z, b->ior, NULL);
		return pm_rgb_scale(plastic_diffuse(b, fi, fo),
		    wo.z * PM_INV_PI);
	case PM_BSDF_MERL:
		if (wi.z <= 0.0f || wo.z <= 0.0f || b->merl == NULL)
			break;
		return pm_rgb_scale(pm_merl_eval(b->merl, wi, wo,
		    b->merl_flags), wo.z);
	case PM_BSDF_ROUGHDIELECTRIC:
		return eval_roughdielectric(b, wi, wo, mode);
	case PM_BSDF_ROUGHPLASTIC:
		return eval_roughplastic(b, wi, wo);
	case PM_BSDF_PRINCIPLED:
	case PM_BSDF_PRINCIPLEDTHIN:
		return pm_principled_eval(b, wi, wo, mode == PM_RADIANCE);
	case PM_BSDF_BLEND:
	case PM_BSDF_MASK:
	case PM_BSDF_TWOSIDED:
		return eval_composite(b, wi, wo, mode);
	case PM_BSDF_CONDUCTOR:
	case PM_BSDF_DIELECTRIC:
	case PM_BSDF_THINDIELECTRIC:
	case PM_BSDF_NULL:
		break;
	}
	return pm_rgb1(0.0f);
}

/* Solid-angle density of sampling wo, non-delta components only. */
float
pm_bsdf_pdf(const struct pm_bsdf *b, struct pm_vec3 wi, struct pm_vec3 wo)
{
	struct pm_vec3 m;
	float ax, ay, fi;

	if (b->perturbed)
		return pdf_perturbed(b, wi, wo);
	if (twosided_flip(b, wi)) {
		wi.z = -wi.z;
		wo.z = -wo.z;
	}
	if (excluded(b))
		return 0.0f;
	switch (b->type) {
	case PM_BSDF_DIFFUSE:
		return pm_diffuse_pdf(wi, wo);
	case PM_BSDF_ROUGHCONDUCTOR:
		if (wi.z <= 0.0f || wo.z <= 0.0f)
			break;
		m = pm_normalize(pm_add(wi, wo));
		/* the same side tests smith_g1 applies while sampling */
		if (pm_dot(wi, m) <= 0.0f || pm_dot(wo, m) <= 0.0f)
			break;
		md_alphas(b, &ax, &ay);
		if (md_visible(b))
			return ggx_d(ax, ay, m) * smith_g1(false, ax, ay, wi, m) /
			    (4.0f * wi.z);
		return md_d(b, ax, ay, m) * m.z / (4.0f * pm_dot(wo, m));
	case PM_BSDF_PLASTIC:
		if (wi.z <= 0.0f || wo.z <= 0.0f)
			break;
		fi = pm_fresnel_dielectric(wi.z, b->ior, NULL);
		return wo.z * PM_INV_PI * (1.0f - plastic_prob_specular(b, fi));
	case PM_BSDF_MERL:
		if (b->merl == NULL)
			break;
		return pm_merl_pdf(b->merl, wi, wo, b->merl_flags);
	case PM_BSDF_ROUGHDIELECTRIC:
		return pdf_roughdielectric(b, wi, wo);
	case PM_BSDF_ROUGHPLASTIC:
		return pdf_roughplastic(b, wi, wo);
	case PM_BSDF_PRINCIPLED:
	case PM_BSDF_PRINCIPLEDTHIN:
		return pm_principled_pdf(b, wi, wo);
	case PM_BSDF_BLEND:
	case PM_BSDF_MASK:
	case PM_BSDF_TWOSIDED:
		return pdf_composite(b, wi, wo);
	case PM_BSDF_CONDUCTOR:
	case PM_BSDF_DIELECTRIC:
	case PM_BSDF_THINDIELECTRIC:
	case PM_BSDF_NULL:
		break;
	}
	return 0.0f;
}

static bool
sample_roughconductor(const struct pm_bsdf *b, struct pm_vec3 wi, float u2,
    float u3, struct pm_bsdf_sample *s)
{
	float ax, ay;
	struct pm_vec3 m;
	float dim, pdf_m, w;

	md_alphas(b, &ax, &ay);
	if (wi.z <= 0.0f)
		return false;
	if (md_visible(b)) {
		m = ggx_sample_visible(ax, ay, wi, u2, u3);
		dim = pm_dot(wi, m);
		pdf_m = smith_g1(false, ax, ay, wi, m) * pm_fmaxf(dim, 0.0f) *
		    ggx_d(ax, ay, m) / wi.z;
	} else {
		m = md_sample_all(b->beckmann, ax, ay, u2, u3);
		dim = pm_dot(wi, m);
		pdf_m = md_d(b, ax, ay, m) * m.z;
	}
	/* a facet facing away from wi cannot reflect it */
	if (dim <= 0.0f || pdf_m <= 0.0f)
		return false;
	s->wo = pm_normalize(pm_sub(pm_scale(m, 2.0f * dim), wi));
	if (s->wo.z <= 0.0f)
		return false;
	/* Jacobian of the half-vector map; wo.m = wi.m for a reflection */
	s->pdf = pdf_m / (4.0f * dim);
	if (md_visible(b))
		w = smith_g1(false, ax, ay, s->wo, m);
	else
		w = smith_g1(b->beckmann, ax, ay, wi, m) *
		    smith_g1(b->beckmann, ax, ay, s->wo, m) * dim /
		    (wi.z * m.z);
	s->weight = pm_rgb_scale(pm_rgb_mul(pm_fresnel_conductor(dim, b->eta,
	    b->k), b->specular), w);
	s->eta = 1.0f;
	s->lobe = PM_LOBE_GLOSSY;
	return true;
}

static bool
sample_dielectric(const struct pm_bsdf *b, struct pm_vec3 wi, float u1,
    enum pm_transport mode, struct pm_bsdf_sample *s)
{
	float cos_t, eta_it, eta_ti;
	float r = pm_fresnel_dielectric(wi.z, b->ior, &cos_t);

	s->pdf = 1.0f;
	if (u1 < r) {
		s->wo = reflect_z(wi);
		s->weight = b->specular;
		s->eta = 1.0f;
		s->lobe = PM_LOBE_DELTA_REFLECTION;
		return true;
	}
	eta_it = wi.z >= 0.0f ? b->ior : 1.0f / b->ior;
	eta_ti = 1.0f / eta_it;
	s->wo = pm_v3(-eta_ti * wi.x, -eta_ti * wi.y, cos_t);
	s->weight = b->transmittance;
	/* radiance is compressed with the solid angle; importance is not */
	if (mode == PM_RADIANCE)
		s->weight = pm_rgb_scale(s->weight, eta_ti * eta_ti);
	s->eta = eta_it;
	s->lobe = PM_LOBE_DELTA_TRANSMISSION;
	return true;
}

static bool
sample_thindielectric(const struct pm_bsdf *b, struct pm_vec3 wi, float u1,
    struct pm_bsdf_sample *s)
{
	float r = pm_fresnel_dielectric(fabsf(wi.z), b->ior, NULL);

	/* all the bounces inside the sheet: R + T^2 R / (1 - R^2) */
	r *= 2.0f / (1.0f + r);
	s->pdf = 1.0f;
	s->eta = 1.0f;
	if (u1 < r) {
		s->wo = reflect_z(wi);
		s->weight = b->specular;
		s->lobe = PM_LOBE_DELTA_REFLECTION;
	} else {
		s->wo = pm_neg(wi);
		s->weight = b->transmittance;
		s->lobe = PM_LOBE_DELTA_TRANSMISSION;
	}
	return true;
}

static bool
sample_plastic(const struct pm_bsdf *b, struct pm_vec3 wi, float u1,
    float u2, float u3, const struct pm_vec3 *v, struct pm_bsdf_sample *s)
{
	float fi, fo, ps, pd;

	if (wi.z <= 0.0f)
		return false;
	fi = pm_fresnel_dielectric(wi.z, b->ior, NULL);
	ps = plastic_prob_specular(b, fi);
	pd = 1.0f - ps;
	s->eta = 1.0f;
	if (u1 < ps) {
		s->wo = reflect_z(wi);
		s->pdf = 1.0f;
		s->weight = pm_rgb_scale(b->specular, fi / ps);
		s->lobe = PM_LOBE_DELTA_REFLECTION;
		return true;
	}
	s->wo = v != NULL ? *v : pm_square_to_cosine_hemisphere(u2, u3);
	s->pdf = pd * pm_cosine_hemisphere_pdf(s->wo);
	if (!(s->pdf > 0.0f))
		return false;
	fo = pm_fresnel_dielectric(s->wo.z, b->ior, NULL);
	/* f cos / pdf: the cos/pi of the lobe cancels against the warp */
	s->weight = pm_rgb_scale(plastic_diffuse(b, fi, fo), 1.0f / pd);
	s->lobe = PM_LOBE_DIFFUSE;
	return true;
}

static bool
sample_merl(const struct pm_bsdf *b, struct pm_vec3 wi, float u1, float u2,
    float u3, struct pm_bsdf_sample *s)
{
	if (b->merl == NULL || !pm_merl_sample(b->merl, wi, u1, u2, u3,
	    b->merl_flags, &s->wo, &s->pdf))
		return false;
	s->weight = pm_rgb_scale(pm_merl_eval(b->merl, wi, s->wo,
	    b->merl_flags), s->wo.z / s->pdf);
	s->eta = 1.0f;
	/* the data sampler follows both the peak and the base */
	s->lobe = PM_LOBE_GLOSSY;
	return true;
}

/* The smooth coating of a coated diffuse BSDF (plastic) as one sample that
 * chooses nothing: the mirror direction with weight Fresnel x specular.
 * A camera path that follows it at every coated hit, beside the base's own
 * estimate, sees the coating's reflections without the noise of picking
 * the coating with probability P (weight 1/P where picked, 0 elsewhere). */
bool
pm_bsdf_coating(const struct pm_bsdf *b, struct pm_vec3 wi,
    struct pm_bsdf_sample *s)
{
	bool flip = twosided_flip(b, wi);

	if (b->type != PM_BSDF_PLASTIC)
		return false;
	if (b->perturbed)
		return sample_perturbed(b, wi, 0.0f, 0.0f, 0.0f, PM_RADIANCE,
		    true, s);
	if (flip)
		wi.z = -wi.z;
	if (wi.z <= 0.0f)
		return false;
	s->wo = reflect_z(wi);
	s->pdf = 1.0f;
	s->weight = pm_rgb_scale(b->specular,
	    pm_fresnel_dielectric(wi.z, b->ior, NULL));
	s->eta = 1.0f;
	s->lobe = PM_LOBE_DELTA_REFLECTION;
	if (flip)
		s->wo.z = -s->wo.z;
	return true;
}

/* u1 chooses the lobe, (u2, u3) the direction; false if nothing was sampled. */
bool
pm_bsdf_sample(const struct pm_bsdf *b, struct pm_vec3 wi, float u1,
    float u2, float u3, enum pm_transport mode, struct pm_bsdf_sample *s)
{
	return pm_bsdf_sample_warped(b, wi, u1, u2, u3, mode, NULL, s);
}

bool
pm_bsdf_sample_warped(const struct pm_bsdf *b, struct pm_vec3 wi, float u1,
    float u2, float u3, enum pm_transport mode, const struct pm_vec3 *v,
    struct pm_bsdf_sample *s)
{
	bool flip = twosided_flip(b, wi), ok = false;

	if (excluded(b))
		return false;
	if (b->perturbed)
		return sample_perturbed(b, wi, u1, u2, u3, mode, false, s);
	if (flip)
		wi.z = -wi.z;
	switch (b->type) {
	case PM_BSDF_DIFFUSE:
		ok = v != NULL ? pm_diffuse_sample_warped(b->diffuse, wi, *v, s) :
		    pm_diffuse_sample(b->diffuse, wi, u2, u3, s);
		break;
	case PM_BSDF_CONDUCTOR:
		if (wi.z <= 0.0f)
			break;
		s->wo = reflect_z(wi);
		s->pdf = 1.0f;
		s->weight = pm_rgb_mul(b->specular,
		    pm_fresnel_conductor(wi.z, b->eta, b->k));
		s->eta = 1.0f;
		s->lobe = PM_LOBE_DELTA_REFLECTION;
		ok = true;
		break;
	case PM_BSDF_ROUGHCONDUCTOR:
		ok = sample_roughconductor(b, wi, u2, u3, s);
		break;
	case PM_BSDF_DIELECTRIC:
		ok = sample_dielectric(b, wi, u1, mode, s);
		break;
	case PM_BSDF_THINDIELECTRIC:
		ok = sample_thindielectric(b, wi, u1, s);
		break;
	case PM_BSDF_PLASTIC:
		ok = sample_plastic(b, wi, u1, u2, u3, v, s);
		break;
	case PM_BSDF_NULL:
		s->wo = pm_neg(wi);
		s->pdf = 1.0f;
		s->weight = pm_rgb1(1.0f);
		s->eta = 1.0f;
		s->lobe = PM_LOBE_DELTA_TRANSMISSION;
		ok = true;
		break;
	case PM_BSDF_MERL:
		ok = sample_merl(b, wi, u1, u2, u3, s);
		break;
	case PM_BSDF_ROUGHDIELECTRIC:
		ok = sample_roughdielectric(b, wi, u1, u2, u3, mode, s);
		break;
	case PM_BSDF_ROUGHPLASTIC:
		ok = sample_roughplastic(b, wi, u1, u2, u3, s);
		break;
	case PM_BSDF_PRINCIPLED:
	case PM_BSDF_PRINCIPLEDTHIN:
		ok = pm_principled_sample(b, wi, u1, u2, u3,
		    mode == PM_RADIANCE, s);
		break;
	case PM_BSDF_BLEND:
	case PM_BSDF_MASK:
	case PM_BSDF_TWOSIDED:
		ok = sample_composite(b, wi, u1, u2, u3, mode, s);
		break;
	}
	if (ok && flip)
		s->wo.z = -s->wo.z;
	return ok;
}

/*
 * Mitsuba's table of named indices of refraction (Hecht, "Optics", 4th ed.;
 * 0 to 20 degrees Celsius, about 589 nm), with the values its code uses.
 */
static const struct {
	const char *name;
	float ior;
} ior_table[] = {
	{ "vacuum",		1.0f },
	{ "helium",		1.000036f },
	{ "hydrogen",		1.000132f },
	{ "air",		1.000277f },
	{ "carbon dioxide",	1.00045f },
	{ "water",		1.3330f },
	{ "acetone",		1.36f },
	{ "ethanol",		1.361f },
	{ "carbon tetrachloride", 1.461f },
	{ "glycerol",		1.4729f },
	{ "benzene",		1.501f },
	{ "silicone oil",	1.52045f },
	{ "bromine",		1.661f },
	{ "water ice",		1.31f },
	{ "fused quartz",	1.458f },
	{ "pyrex",		1.470f },
	{ "acrylic glass",	1.49f },
	{ "polypropylene",	1.49f },
	{ "bk7",		1.5046f },
	{ "sodium chloride",	1.544f },
	{ "amber",		1.55f },
	{ "pet",		1.5750f },
	{ "diamond",		2.419f },
};

/* Named IOR, case-insensitively as Mitsuba matches; false if unknown. */
bool
pm_ior_lookup(const char *name, float *ior)
{
	size_t i;

	for (i = 0; i < sizeof(ior_table) / sizeof(ior_table[0]); i++)
		if (strcasecmp(name, ior_table[i].name) == 0) {
			*ior = ior_table[i].ior;
			return true;
		}
	return false;
}

/*
 * Mitsuba 3's named conductors in RGB: the spectral eta and k it ships
 * (data/ior/<name>.{eta,k}.spd) as its RGB variants reduce them, asked of
 * Mitsuba itself by tests/mitsuba/conductors.py, which wrote
 * conductors.h and checks it against Mitsuba (compare.sh).  Names are
 * case-sensitive, as Mitsuba's file names are; "none" is a perfect
 * mirror.
 *
 * Notes for the scene loader (Mitsuba 3 defaults, from its plugin docs):
 *   diffuse:        reflectance 0.5.
 *   conductor:      material "none" (eta 0, k 1: a perfect mirror),
 *                   specular_reflectance 1; giving eta/k and a material
 *                   together is an error.
 *   roughconductor: as conductor, plus alpha 0.1, sample_visible true,
 *                   distribution "beckmann" (or "ggx").
 *   roughdielectric: as dielectric, plus alpha, distribution, sample_visible
 *                   as roughconductor.
 *   roughplastic:   as plastic, plus alpha, distribution, sample_visible.
 *   dielectric, thindielectric: int_ior "bk7" (1.5046), ext_ior "air"
 *                   (1.000277), specular_reflectance and
 *                   specular_transmittance 1; b->ior = int_ior / ext_ior.
 *   plastic:        int_ior "polypropylene" (1.49), ext_ior "air",
 *                   diffuse_reflectance 0.5, specular_reflectance 1,
 *                   nonlinear false.
 * A float int_ior/ext_ior is taken as is; a string goes through
 * pm_ior_lookup.  Call pm_bsdf_prepare after filling a struct pm_bsdf.
 */
static const struct {
	const char *name;
	struct pm_rgb eta, k;
} conductor_table[] = {
#include "conductors.h"
};

/* Named conductor, eta and k in RGB; false if the name is unknown. */
bool
pm_conductor_lookup(const char *name, struct pm_rgb *eta, struct pm_rgb *k)
{
	size_t i;

	for (i = 0; i < sizeof(conductor_table) / sizeof(conductor_table[0]);
	    i++)
		if (strcmp(name, conductor_table[i].name) == 0) {
			*eta = conductor_table[i].eta;
			*k = conductor_table[i].k;
			return true;
		}
	return false;
}
