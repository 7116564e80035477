/*
 * bsdf_principled.c: Mitsuba 3's principled and principledthin BSDFs, in
 * RGB: Burley's "Physically Based Shading at Disney" (2012) and its BSDF
 * extension (2015) as Mitsuba 3 arranges them.
 *
 * principled: a diffuse base (Burley's diffuse with retro-reflection, or
 * Hanrahan-Krueger's flattened "fake subsurface" by `flatness`) weighted
 * (1 - metallic)(1 - spec_trans), a sheen lobe weighted (1 - metallic)
 * where the base is; one anisotropic GGX
 * lobe that reflects with a Fresnel term blending the dielectric one
 * (eta, or eta from `specular`), Schlick's with the base colour (metallic)
 * and Schlick's with the tinted colour (spec_tint), and transmits with
 * weight (1 - metallic) spec_trans; and a clearcoat (GTR1 distribution,
 * Schlick's Fresnel at 0.04, Smith GGX masking at alpha 0.25).  From
 * inside, only the dielectric interface's reflection and transmission.
 *
 * principledthin: a sheet, the same from both sides: a GGX reflection and
 * a transmission (the mirror image of a reflection lobe whose roughness is
 * scaled by 0.65 eta - 0.35) weighted by spec_trans, the diffuse base and
 * sheen weighted (1 - spec_trans)(1 - diff_trans / 2), and a Lambertian
 * transmission weighted (1 - spec_trans) diff_trans / 2.
 *
 * Every formula, mask and sampling probability is Mitsuba's (so that its
 * images are the specification), with two departures that leave the
 * integrals alone: visible normals are drawn with Heitz's 2018 map, and
 * when the `only` lobe mask switches off one of the GGX reflection and
 * transmission, the other keeps the whole of their sampling weight (so
 * that the choice of lobe does not depend on the drawn microfacet).
 *
 * Lobes: the diffuse base and sheen are PM_LOBE_DIFFUSE; the GGX
 * reflection and clearcoat PM_LOBE_GLOSSY; the GGX transmission
 * PM_LOBE_GLOSSY_TRANSMISSION; the thin sheet's Lambertian transmission
 * PM_LOBE_DIFFUSE_TRANSMISSION.  `only` selects among them.
 *
 * The anisotropic GGX here is written for these BSDFs (x is the shading
 * frame's first tangent, alpha_x along it), apart from bsdf.c's isotropic one.
 */
#include <math.h>

#include "bsdf.h"
#include "sampling.h"

/* Mitsuba's luminance of a linear sRGB colour. */
static float
luminance(struct pm_rgb c)
{
	return 0.212671f * c.r + 0.715160f * c.g + 0.072169f * c.b;
}

static float
lerp(float a, float b, float t)
{
	return a + t * (b - a);
}

static float
sign1(float x)
{
	return x < 0.0f ? -1.0f : 1.0f;
}

/* (1 - cos)^5, cos clamped to [0, 1]. */
static float
schlick_weight(float c)
{
	float m = pm_fminf(pm_fmaxf(1.0f - c, 0.0f), 1.0f), m2 = m * m;

	return m2 * m2 * m;
}

/* Schlick's Fresnel from r0 at cos_i (against a facet), taking the
 * transmitted angle's cosine when light goes to the optically thinner
 * side, as Mitsuba's principled does. */
static float
schlick(float r0, float cos_i, float eta)
{
	float eta_it = cos_i >= 0.0f ? eta : 1.0f / eta;
	float eta_ti = 1.0f / eta_it;
	float ct2 = 1.0f - (1.0f - cos_i * cos_i) * eta_ti * eta_ti;
	float w = eta_it > 1.0f ? schlick_weight(fabsf(cos_i)) :
	    schlick_weight(sqrtf(pm_fmaxf(ct2, 0.0f)));

	return lerp(w, 1.0f, r0);
}

static struct pm_rgb
schlick_rgb(struct pm_rgb r0, float cos_i, float eta)
{
	return pm_rgb(schlick(r0.r, cos_i, eta), schlick(r0.g, cos_i, eta),
	    schlick(r0.b, cos_i, eta));
}

static float
r0_of_eta(float eta)
{
	float r = (eta - 1.0f) / (eta + 1.0f);

	return r * r;
}

/* Base colour over its luminance (white where it has none). */
static struct pm_rgb
tint_of(struct pm_rgb base)
{
	float lum = luminance(base);

	return lum > 0.0f ? pm_rgb_scale(base, 1.0f / lum) : pm_rgb1(1.0f);
}

/* ---- anisotropic GGX ---- */

struct ggx {
	float ax, ay;
};

/* Burley's alphas from roughness and anisotropic, floored at 0.001. */
static struct ggx
ggx_params(float roughness, float anisotropic)
{
	float r2 = roughness * roughness, aspect;
	struct ggx g;

	aspect = sqrtf(1.0f - 0.9f * anisotropic);
	g.ax = pm_fmaxf(0.001f, r2 / aspect);
	g.ay = pm_fmaxf(0.001f, r2 * aspect);
	return g;
}

static float
ggx_d(struct ggx g, struct pm_vec3 m)
{
	float x, y, t, d;

	if (m.z <= 0.0f)
		return 0.0f;
	x = m.x / g.ax;
	y = m.y / g.ay;
	t = x * x + y * y + m.z * m.z;
	d = 1.0f / (PM_PI * g.ax * g.ay * t * t);
	return d * m.z > 1e-20f ? d : 0.0f;
}

static float
ggx_g1(struct ggx g, struct pm_vec3 v, struct pm_vec3 m)
{
	float xy;

	if (pm_dot(v, m) * v.z <= 0.0f)
		return 0.0f;
	xy = g.ax * g.ax * v.x * v.x + g.ay * g.ay * v.y * v.y;
	if (xy == 0.0f)
		return 1.0f;
	return 2.0f / (1.0f + sqrtf(1.0f + xy / (v.z * v.z)));
}

/* Density of ggx_sample's normals seen from wi (wi.z > 0). */
static float
ggx_pdf(struct ggx g, struct pm_vec3 wi, struct pm_vec3 m)
{
	return ggx_d(g, m) * ggx_g1(g, wi, m) * fabsf(pm_dot(wi, m)) / wi.z;
}

/* A normal visible from wi (wi.z > 0), Heitz 2018, stretched by ax, ay. */
static struct pm_vec3
ggx_sample(struct ggx g, struct pm_vec3 wi, float u1, float u2)
{
	struct pm_vec3 vh, t1, t2, nh;
	float len2, r, phi, p1, p2, s;

	vh = pm_normalize(pm_v3(g.ax * wi.x, g.ay * wi.y, wi.z));
	len2 = vh.x * vh.x + vh.y * vh.y;
	t1 = len2 > 0.0f ? pm_scale(pm_v3(-vh.y, vh.x, 0.0f),
	    1.0f / sqrtf(len2)) : pm_v3(1.0f, 0.0f, 0.0f);
	t2 = pm_cross(vh, t1);
	r = sqrtf(u1);
	phi = 2.0f * PM_PI * u2;
	p1 = r * cosf(phi);
	p2 = r * sinf(phi);
	s = 0.5f * (1.0f + vh.z);
	p2 = (1.0f - s) * sqrtf(pm_fmaxf(0.0f, 1.0f - p1 * p1)) + s * p2;
	nh = pm_add(pm_add(pm_scale(t1, p1), pm_scale(t2, p2)),
	    pm_scale(vh, sqrtf(pm_fmaxf(0.0f, 1.0f - p1 * p1 - p2 * p2))));
	return pm_normalize(pm_v3(g.ax * nh.x, g.ay * nh.y, pm_fmaxf(0.0f, nh.z)));
}

/* ---- the clearcoat's GTR1 distribution and masking ---- */

static float
gtr1_d(float alpha, struct pm_vec3 m)
{
	float a2 = alpha * alpha, c2 = m.z * m.z;
	float d = (a2 - 1.0f) / (PM_PI * logf(a2) * (1.0f + (a2 - 1.0f) * c2));

	return d * m.z > 1e-20f ? d : 0.0f;
}

static float
gtr1_pdf(float alpha, struct pm_vec3 m)
{
	return m.z < 0.0f ? 0.0f : m.z * gtr1_d(alpha, m);
}

static struct pm_vec3
gtr1_sample(float alpha, float u1, float u2)
{
	float a2 = alpha * alpha, phi = 2.0f * PM_PI * u1;
	float c2 = (1.0f - powf(a2, 1.0f - u2)) / (1.0f - a2);
	float st = sqrtf(pm_fmaxf(0.0f, 1.0f - c2)), ct = sqrtf(pm_fmaxf(0.0f, c2));

	return pm_v3(cosf(phi) * st, sinf(phi) * st, ct);
}

/* Smith's GGX masking at a fixed alpha, as Mitsuba's clearcoat has it. */
static float
cc_g1(struct pm_vec3 v, struct pm_vec3 m, float alpha)
{
	float c = fabsf(v.z), c2 = c * c, t2 = (1.0f - c2) / c2;

	if (pm_dot(v, m) * v.z <= 0.0f)
		return 0.0f;
	if (v.z == 1.0f)
		return 1.0f;
	return 2.0f / (1.0f + sqrtf(1.0f + alpha * alpha * t2));
}

/* ---- shared pieces ---- */

/* Both directions on the sides a facet m (turned to wi's side of the
 * surface) allows: wo on wi's side for a reflection, across otherwise. */
static bool
compatible(struct pm_vec3 m, struct pm_vec3 wi, struct pm_vec3 wo,
    float cos_i, bool reflection)
{
	struct pm_vec3 ms = pm_scale(m, sign1(cos_i));

	if (!(pm_dot(wi, ms) > 0.0f))
		return false;
	return reflection ? pm_dot(wo, ms) > 0.0f : pm_dot(wo, ms) < 0.0f;
}

/* The diffuse base (diffuse, retro-reflection, fake subsurface) times
 * |cos_o|, before its weight; wh the reflection half vector. */
static struct pm_rgb
diffuse_base(const struct pm_bsdf *b, struct pm_vec3 wh, struct pm_vec3 wo,
    float cos_i, float cos_o)
{
	const float *v = b->pr.v;
	float fo = schlick_weight(fabsf(cos_o)), fi = schlick_weight(fabsf(cos_i));
	float f_diff = (1.0f - 0.5f * fi) * (1.0f - 0.5f * fo);
	float cos_d = pm_dot(wh, wo);
	float rr = 2.0f * v[PM_PR_ROUGHNESS] * cos_d * cos_d;
	float f = f_diff + rr * (fo + fi + fo * fi * (rr - 1.0f));

	if (v[PM_PR_FLATNESS] != 0.0f) {
		float fss90 = 0.5f * rr;
		float fss = lerp(1.0f, fss90, fo) * lerp(1.0f, fss90, fi);
		float f_ss = 1.25f * (fss * (1.0f / (fabsf(cos_o) +
		    fabsf(cos_i)) - 0.5f) + 0.5f);

		f = lerp(f, f_ss, v[PM_PR_FLATNESS]);
	}
	return pm_rgb_scale(b->diffuse, fabsf(cos_o) * PM_INV_PI * f);
}

/* The sheen times |cos_o|, before its weight (zero without sheen). */
static struct pm_rgb
sheen(const struct pm_bsdf *b, struct pm_vec3 wh, struct pm_vec3 wo,
    float cos_o)
{
	const float *v = b->pr.v;
	float tint = v[PM_PR_SHEEN_TINT], w;
	struct pm_rgb c = pm_rgb1(1.0f), t;

	if (!(v[PM_PR_SHEEN] > 0.0f))
		return pm_rgb1(0.0f);
	if (tint != 0.0f) {
		t = tint_of(b->diffuse);
		c = pm_rgb(lerp(1.0f, t.r, tint), lerp(1.0f, t.g, tint),
		    lerp(1.0f, t.b, tint));
	}
	w = v[PM_PR_SHEEN] * schlick_weight(fabsf(pm_dot(wh, wo))) *
	    fabsf(cos_o);
	return pm_rgb_scale(c, w);
}

/* Which lobes `only` leaves on. */
struct on {
	bool diff, gloss, trans, dtrans;
};

static struct on
lobes_on(const struct pm_bsdf *b)
{
	unsigned o = b->only;
	struct on r = { true, true, true, true };

	if (o != 0) {
		r.diff = (o & PM_LOBE_DIFFUSE) != 0;
		r.gloss = (o & PM_LOBE_GLOSSY) != 0;
		r.trans = (o & PM_LOBE_GLOSSY_TRANSMISSION) != 0;
		r.dtrans = (o & PM_LOBE_DIFFUSE_TRANSMISSION) != 0;
	}
	return r;
}

/* ---- principled ---- */

static float
pr_eta(const struct pm_bsdf *b)
{
	return b->pr.v[PM_PR_ETA];
}

static float
cc_alpha(const struct pm_bsdf *b)
{
	return lerp(0.1f, 0.001f, b->pr.v[PM_PR_CLEARCOAT_GLOSS]);
}

/* The half vector (generalised for refraction), turned up. */
static struct pm_vec3
pr_half(struct pm_vec3 wi, struct pm_vec3 wo, bool reflect, float eta_path)
{
	struct pm_vec3 h = pm_normalize(pm_add(wi, pm_scale(wo,
	    reflect ? 1.0f : eta_path)));

	return pm_scale(h, sign1(h.z));
}

/* Mitsuba's principled Fresnel term of the GGX reflection. */
static struct pm_rgb
pr_fresnel(const struct pm_bsdf *b, float f_diel, float cos_hi, bool front,
    float bsdf)
{
	const float *v = b->pr.v;
	float metallic = v[PM_PR_METALLIC], tint = v[PM_PR_SPEC_TINT];
	float eta = pr_eta(b), eta_it = cos_hi >= 0.0f ? eta : 1.0f / eta;
	struct pm_rgb f;

	if (!front)
		return pm_rgb1(bsdf * f_diel);
	f = pm_rgb_scale(schlick_rgb(b->diffuse, cos_hi, eta), metallic);
	if (tint != 0.0f)
		f = pm_rgb_add(f, pm_rgb_scale(schlick_rgb(pm_rgb_scale(
		    tint_of(b->diffuse), r0_of_eta(eta_it)), cos_hi, eta),
		    (1.0f - metallic) * tint));
	return pm_rgb_add(f, pm_rgb1((1.0f - metallic) * (1.0f - tint) *
	    f_diel));
}

/* Lobe selection probabilities: GGX reflection, GGX transmission,
 * clearcoat, diffuse; f the dielectric Fresnel term at the facet. */
struct pr_probs {
	float sr, st, cc, diff;
};

static bool
pr_probs(const struct pm_bsdf *b, bool front, float f, struct pr_probs *p)
{
	const struct pm_principled *pr = &b->pr;
	const float *v = pr->v;
	struct on on = lobes_on(b);
	float metallic = v[PM_PR_METALLIC], bsdf, brdf, sum;
	float rs = pr->rate[PM_PR_RATE_SPECULAR];

	brdf = (1.0f - metallic) * (1.0f - v[PM_PR_SPEC_TRANS]);
	bsdf = pr->has_spec_trans ? (1.0f - metallic) * v[PM_PR_SPEC_TRANS] :
	    0.0f;
	on.trans = on.trans && pr->has_spec_trans;
	if (front) {
		if (on.gloss && on.trans) {
			p->sr = rs * (1.0f - bsdf * (1.0f - f));
			p->st = rs * bsdf * (1.0f - f);
		} else {
			/* one of the two alone keeps their whole weight */
			p->sr = on.gloss ? rs : 0.0f;
			p->st = on.trans && bsdf > 0.0f ? rs : 0.0f;
		}
		p->cc = on.gloss && pr->has_clearcoat ? 0.25f *
		    v[PM_PR_CLEARCOAT] * pr->rate[PM_PR_RATE_OTHER] : 0.0f;
		p->diff = on.diff ? brdf * pr->rate[PM_PR_RATE_DIFFUSE] : 0.0f;
	} else {
		p->cc = p->diff = 0.0f;
		if (on.gloss && on.trans) {
			p->sr = f;
			p->st = 1.0f - f;
		} else {
			p->sr = on.gloss ? 1.0f : 0.0f;
			p->st = on.trans ? 1.0f : 0.0f;
		}
	}
	sum = p->sr + p->st + p->cc + p->diff;
	if (!(sum > 0.0f))
		return false;
	p->sr /= sum;
	p->st /= sum;
	p->cc /= sum;
	p->diff /= sum;
	return true;
}

static struct pm_rgb
pr_eval(const struct pm_bsdf *b, struct pm_vec3 wi, struct pm_vec3 wo,
    bool radiance)
{
	const struct pm_principled *pr = &b->pr;
	const float *v = pr->v;
	struct on on = lobes_on(b);
	float cos_i = wi.z, cos_o = wo.z, eta = pr_eta(b);
	float metallic = v[PM_PR_METALLIC], brdf, bsdf, eta_path, f, d, g;
	float ih, oh, t;
	bool reflect, refract, front;
	struct pm_rgb r = pm_rgb1(0.0f);
	struct pm_vec3 wh;
	struct ggx gg;

	if (cos_i == 0.0f)
		return r;
	brdf = (1.0f - metallic) * (1.0f - v[PM_PR_SPEC_TRANS]);
	bsdf = (1.0f - metallic) * v[PM_PR_SPEC_TRANS];
	reflect = cos_i * cos_o > 0.0f;
	refract = cos_i * cos_o < 0.0f;
	if (!reflect && !refract)
		return r;
	front = cos_i > 0.0f;
	eta_path = front ? eta : 1.0f / eta;
	gg = ggx_params(v[PM_PR_ROUGHNESS], v[PM_PR_ANISOTROPIC]);
	wh = pr_half(wi, wo, reflect, eta_path);
	ih = pm_dot(wi, wh);
	oh = pm_dot(wo, wh);
	f = pm_fresnel_dielectric(ih, eta, NULL);
	d = ggx_d(gg, wh);
	g = ggx_g1(gg, wi, wh) * ggx_g1(gg, wo, wh);

	if (reflect && compatible(wh, wi, wo, cos_i, true)) {
		if (on.gloss && f > 0.0f)
			r = pm_rgb_add(r, pm_rgb_scale(pr_fresnel(b, f, ih, front,
			    bsdf), d * g / (4.0f * fabsf(cos_i))));
		if (on.gloss && pr->has_clearcoat && v[PM_PR_CLEARCOAT] > 0.0f &&
		    front)
			r = pm_rgb_add(r, pm_rgb1(v[PM_PR_CLEARCOAT] * 0.25f *
			    schlick(0.04f, ih, eta) * gtr1_d(cc_alpha(b), wh) *
			    cc_g1(wi, wh, 0.25f) * cc_g1(wo, wh, 0.25f) *
			    fabsf(cos_o)));
	}
	if (refract && on.trans && pr->has_spec_trans && bsdf > 0.0f &&
	    f < 1.0f && compatible(wh, wi, wo, cos_i, false)) {
		/* radiance is compressed by 1/eta^2 on the way in */
		float scale = radiance ? 1.0f / (eta_path * eta_path) : 1.0f;

		t = bsdf * fabsf(scale * (1.0f - f) * d * g * eta_path *
		    eta_path * ih * oh / (cos_i * (ih + eta_path * oh) *
		    (ih + eta_path * oh)));
		r = pm_rgb_add(r, pm_rgb(sqrtf(b->diffuse.r) * t,
		    sqrtf(b->diffuse.g) * t, sqrtf(b->diffuse.b) * t));
	}
	/* the sheen is weighted (1 - metallic), but only where the base is */
	if (reflect && front && on.diff && brdf > 0.0f)
		r = pm_rgb_add(r, pm_rgb_add(pm_rgb_scale(diffuse_base(b, wh,
		    wo, cos_i, cos_o), brdf), pm_rgb_scale(sheen(b, wh, wo,
		    cos_o), 1.0f - metallic)));
	return r;
}

static float
pr_pdf(const struct pm_bsdf *b, struct pm_vec3 wi, struct pm_vec3 wo)
{
	const struct pm_principled *pr = &b->pr;
	const float *v = pr->v;
	float cos_i = wi.z, cos_o = wo.z, eta = pr_eta(b), eta_path, f;
	float oh, ih, dwh, pdf = 0.0f, pm;
	bool reflect, refract, front;
	struct pm_vec3 wh, wi_up;
	struct pr_probs p;
	struct ggx gg;

	if (cos_i == 0.0f)
		return 0.0f;
	front = cos_i > 0.0f;
	reflect = cos_i * cos_o > 0.0f;
	refract = cos_i * cos_o < 0.0f;
	if (!reflect && !refract)
		return 0.0f;
	eta_path = front ? eta : 1.0f / eta;
	wh = pr_half(wi, wo, reflect, eta_path);
	ih = pm_dot(wi, wh);
	oh = pm_dot(wo, wh);
	f = pm_fresnel_dielectric(ih, eta, NULL);
	if (!pr_probs(b, front, f, &p))
		return 0.0f;
	if (reflect)
		dwh = fabsf(1.0f / (4.0f * oh));
	else
		dwh = fabsf(eta_path * eta_path * oh /
		    ((ih + eta_path * oh) * (ih + eta_path * oh)));
	gg = ggx_params(v[PM_PR_ROUGHNESS], v[PM_PR_ANISOTROPIC]);
	wi_up = pm_scale(wi, sign1(cos_i));
	if (reflect && compatible(wh, wi, wo, cos_i, true)) {
		pm = ggx_pdf(gg, wi_up, wh);
		pdf += p.sr * pm * dwh;
		if (p.cc > 0.0f)
			pdf += p.cc * gtr1_pdf(cc_alpha(b), wh) * dwh;
	}
	if (reflect && p.diff > 0.0f)
		pdf += p.diff * cos_o * PM_INV_PI;
	if (refract && p.st > 0.0f && compatible(wh, wi, wo, cos_i, false))
		pdf += p.st * ggx_pdf(gg, wi_up, wh) * dwh;
	return pdf;
}

static bool
pr_sample(const struct pm_bsdf *b, struct pm_vec3 wi, float u1, float u2,
    float u3, bool radiance, struct pm_bsdf_sample *s)
{
	const float *v = b->pr.v;
	float cos_i = wi.z, eta = pr_eta(b), f, cos_t, eta_it, eta_ti, im;
	bool front = cos_i > 0.0f;
	struct pm_vec3 m;
	struct pr_probs p;
	struct ggx gg;

	/* from inside, only a transmitting solid scatters (Mitsuba's rule;
	 * the interface's reflection there is weighted by the transmission) */
	if (cos_i == 0.0f || (!front && !(b->pr.has_spec_trans &&
	    (1.0f - v[PM_PR_METALLIC]) * v[PM_PR_SPEC_TRANS] > 0.0f)))
		return false;
	gg = ggx_params(v[PM_PR_ROUGHNESS], v[PM_PR_ANISOTROPIC]);
	m = ggx_sample(gg, pm_scale(wi, sign1(cos_i)), u2, u3);
	im = pm_dot(wi, m);
	f = pm_fresnel_dielectric(im, eta, &cos_t);
	if (!pr_probs(b, front, f, &p))
		return false;
	s->eta = 1.0f;
	if (u1 < p.diff) {
		s->wo = pm_square_to_cosine_hemisphere(u2, u3);
		s->lobe = PM_LOBE_DIFFUSE;
	} else if (u1 < p.diff + p.cc) {
		struct pm_vec3 mc = gtr1_sample(cc_alpha(b), u2, u3);

		s->wo = pm_sub(pm_scale(mc, 2.0f * pm_dot(wi, mc)), wi);
		s->lobe = PM_LOBE_GLOSSY;
		if (!compatible(mc, wi, s->wo, cos_i, true))
			return false;
	} else if (p.st > 0.0f && (u1 < p.diff + p.cc + p.st || p.sr == 0.0f)) {
		eta_it = im >= 0.0f ? eta : 1.0f / eta;
		eta_ti = 1.0f / eta_it;
		s->wo = pm_sub(pm_scale(m, im * eta_ti + cos_t),
		    pm_scale(wi, eta_ti));
		s->eta = eta_it;
		s->lobe = PM_LOBE_GLOSSY_TRANSMISSION;
		if (!(cos_i * s->wo.z < 0.0f) ||
		    !compatible(m, wi, s->wo, cos_i, false))
			return false;
	} else {
		s->wo = pm_sub(pm_scale(m, 2.0f * im), wi);
		s->lobe = PM_LOBE_GLOSSY;
		if (!compatible(m, wi, s->wo, cos_i, true))
			return false;
	}
	if (s->lobe != PM_LOBE_GLOSSY_TRANSMISSION && !(cos_i * s->wo.z > 0.0f))
		return false;
	s->wo = pm_normalize(s->wo);
	s->pdf = pr_pdf(b, wi, s->wo);
	if (!(s->pdf > 0.0f))
		return false;
	s->weight = pm_rgb_scale(pr_eval(b, wi, s->wo, radiance), 1.0f / s->pdf);
	return true;
}

/* ---- principledthin ---- */

/* The transmission lobe's distribution: roughness scaled by the IOR
 * (Burley 2015, figure 15). */
static struct ggx
thin_trans_ggx(const struct pm_bsdf *b)
{
	const float *v = b->pr.v;

	return ggx_params((0.65f * v[PM_PR_ETA] - 0.35f) * v[PM_PR_ROUGHNESS],
	    v[PM_PR_ANISOTROPIC]);
}

struct thin_probs {
	float sr, st, dr, dt;
};

static bool
thin_probs(const struct pm_bsdf *b, struct thin_probs *p)
{
	const struct pm_principled *pr = &b->pr;
	float st = pr->v[PM_PR_SPEC_TRANS], dt = 0.5f * pr->v[PM_PR_DIFF_TRANS];
	struct on on = lobes_on(b);
	float sum;

	p->sr = on.gloss && pr->has_spec_trans ?
	    0.5f * st * pr->rate[PM_PR_RATE_SPECULAR] : 0.0f;
	p->st = on.trans && pr->has_spec_trans ?
	    0.5f * st * pr->rate[PM_PR_RATE_OTHER] : 0.0f;
	p->dr = on.diff ? pr->rate[PM_PR_RATE_DIFFUSE] * (1.0f - st) *
	    (1.0f - dt) : 0.0f;
	p->dt = on.dtrans && pr->has_diff_trans ?
	    pr->rate[PM_PR_RATE_DIFF_TRANS] * (1.0f - st) * dt : 0.0f;
	sum = p->sr + p->st + p->dr + p->dt;
	if (!(sum > 0.0f))
		return false;
	p->sr /= sum;
	p->st /= sum;
	p->dr /= sum;
	p->dt /= sum;
	return true;
}

static struct pm_rgb
thin_eval(const struct pm_bsdf *b, struct pm_vec3 wi, struct pm_vec3 wo)
{
	const struct pm_principled *pr = &b->pr;
	const float *v = pr->v;
	struct on on = lobes_on(b);
	float st = v[PM_PR_SPEC_TRANS], dt = 0.5f * v[PM_PR_DIFF_TRANS];
	float eta = v[PM_PR_ETA], sg, cos_i, cos_o, f, tint;
	struct pm_vec3 wo_r, wh;
	struct pm_rgb r = pm_rgb1(0.0f), fs;
	struct ggx gg;

	if (wi.z == 0.0f)
		return r;
	/* the sheet is the same from both sides: look from above */
	sg = sign1(wi.z);
	wi = pm_scale(wi, sg);
	wo = pm_scale(wo, sg);
	cos_i = wi.z;
	cos_o = wo.z;
	wo_r = pm_v3(wo.x, wo.y, fabsf(wo.z));
	wh = pm_normalize(pm_add(wi, wo_r));
	if (pr->has_spec_trans && st > 0.0f) {
		f = pm_fresnel_dielectric(pm_dot(wi, wh), eta, NULL);
		if (on.gloss && cos_o > 0.0f &&
		    compatible(wh, wi, wo, cos_i, true)) {
			gg = ggx_params(v[PM_PR_ROUGHNESS], v[PM_PR_ANISOTROPIC]);
			tint = v[PM_PR_SPEC_TINT];
			fs = pm_rgb1(0.0f);
			if (tint != 0.0f)
				fs = schlick_rgb(pm_rgb_scale(tint_of(b->diffuse),
				    r0_of_eta(eta)), pm_dot(wi, wh), eta);
			fs = pm_rgb(lerp(f, fs.r, tint), lerp(f, fs.g, tint),
			    lerp(f, fs.b, tint));
			r = pm_rgb_add(r, pm_rgb_scale(fs, st * ggx_d(gg, wh) *
			    ggx_g1(gg, wi, wh) * ggx_g1(gg, wo, wh) /
			    (4.0f * cos_i)));
		}
		if (on.trans && cos_o < 0.0f &&
		    compatible(wh, wi, wo, cos_i, false)) {
			gg = thin_trans_ggx(b);
			r = pm_rgb_add(r, pm_rgb_scale(b->diffuse, st *
			    (1.0f - f) * ggx_d(gg, wh) * ggx_g1(gg, wi, wh) *
			    ggx_g1(gg, wo, wh) / (4.0f * cos_i)));
		}
	}
	if (on.diff && cos_o > 0.0f && st < 1.0f && dt < 1.0f)
		r = pm_rgb_add(r, pm_rgb_scale(pm_rgb_add(diffuse_base(b, wh,
		    wo, cos_i, cos_o), sheen(b, wh, wo, cos_o)),
		    (1.0f - st) * (1.0f - dt)));
	if (on.dtrans && pr->has_diff_trans && cos_o < 0.0f && st < 1.0f &&
	    dt > 0.0f)
		r = pm_rgb_add(r, pm_rgb_scale(b->diffuse, (1.0f - st) * dt *
		    PM_INV_PI * fabsf(cos_o)));
	return r;
}

static float
thin_pdf(const struct pm_bsdf *b, struct pm_vec3 wi, struct pm_vec3 wo)
{
	const float *v = b->pr.v;
	struct thin_probs p;
	struct pm_vec3 wo_r, wh;
	float sg, pdf = 0.0f, dwh;

	if (wi.z == 0.0f || !thin_probs(b, &p))
		return 0.0f;
	sg = sign1(wi.z);
	wi = pm_scale(wi, sg);
	wo = pm_scale(wo, sg);
	if (p.sr > 0.0f || p.st > 0.0f) {
		wo_r = pm_v3(wo.x, wo.y, fabsf(wo.z));
		wh = pm_normalize(pm_add(wi, wo_r));
		dwh = fabsf(1.0f / (4.0f * pm_dot(wo_r, wh)));
		if (wo.z > 0.0f && p.sr > 0.0f &&
		    compatible(wh, wi, wo, wi.z, true))
			pdf += p.sr * ggx_pdf(ggx_params(v[PM_PR_ROUGHNESS],
			    v[PM_PR_ANISOTROPIC]), wi, wh) * dwh;
		if (wo.z < 0.0f && p.st > 0.0f &&
		    compatible(wh, wi, wo, wi.z, false))
			pdf += p.st * ggx_pdf(thin_trans_ggx(b), wi, wh) * dwh;
	}
	if (wo.z > 0.0f)
		pdf += p.dr * wo.z * PM_INV_PI;
	if (wo.z < 0.0f)
		pdf += p.dt * -wo.z * PM_INV_PI;
	return pdf;
}

static bool
thin_sample(const struct pm_bsdf *b, struct pm_vec3 wi, float u1, float u2,
    float u3, struct pm_bsdf_sample *s)
{
	const float *v = b->pr.v;
	struct thin_probs p;
	struct pm_vec3 w, m;
	float sg;

	if (wi.z == 0.0f || !thin_probs(b, &p))
		return false;
	sg = sign1(wi.z);
	w = pm_scale(wi, sg);
	if (u1 < p.sr || (p.st == 0.0f && p.dr == 0.0f && p.dt == 0.0f)) {
		m = ggx_sample(ggx_params(v[PM_PR_ROUGHNESS],
		    v[PM_PR_ANISOTROPIC]), w, u2, u3);
		s->wo = pm_sub(pm_scale(m, 2.0f * pm_dot(w, m)), w);
		s->lobe = PM_LOBE_GLOSSY;
		if (!(s->wo.z > 0.0f) || !compatible(m, w, s->wo, w.z, true))
			return false;
	} else if (u1 < p.sr + p.st || (p.dr == 0.0f && p.dt == 0.0f)) {
		/* a reflection turned through the sheet */
		m = ggx_sample(thin_trans_ggx(b), w, u2, u3);
		s->wo = pm_sub(pm_scale(m, 2.0f * pm_dot(w, m)), w);
		s->wo.z = -s->wo.z;
		s->lobe = PM_LOBE_GLOSSY_TRANSMISSION;
		if (!(s->wo.z < 0.0f) || !compatible(m, w, s->wo, w.z, false))
			return false;
	} else if (u1 < p.sr + p.st + p.dr || p.dt == 0.0f) {
		s->wo = pm_square_to_cosine_hemisphere(u2, u3);
		s->lobe = PM_LOBE_DIFFUSE;
	} else {
		s->wo = pm_neg(pm_square_to_cosine_hemisphere(u2, u3));
		s->lobe = PM_LOBE_DIFFUSE_TRANSMISSION;
	}
	s->wo = pm_scale(pm_normalize(s->wo), sg);
	s->eta = 1.0f;
	s->pdf = thin_pdf(b, wi, s->wo);
	if (!(s->pdf > 0.0f))
		return false;
	s->weight = pm_rgb_scale(thin_eval(b, wi, s->wo), 1.0f / s->pdf);
	return true;
}

/* ---- what bsdf.c calls ---- */

void
pm_principled_defaults(struct pm_principled *p, bool thin)
{
	int i;

	for (i = 0; i < PM_PR_N; i++) {
		p->v[i] = 0.0f;
		p->tex[i] = 0;
	}
	p->v[PM_PR_ROUGHNESS] = 0.5f;
	p->v[PM_PR_ETA] = 1.5f;	/* thin: eta; principled: from specular 0.5 */
	p->textured = false;
	p->has_spec_trans = p->has_clearcoat = p->has_diff_trans = false;
	for (i = 0; i < PM_PR_NRATES; i++)
		p->rate[i] = 1.0f;
	(void)thin;
}

/* Whether parameter i can be above lo (or below hi) somewhere. */
static bool
can_exceed(const struct pm_principled *p, int i, float lo)
{
	return p->tex[i] != 0 || p->v[i] > lo;
}

static bool
can_be_below(const struct pm_principled *p, int i, float hi)
{
	return p->tex[i] != 0 || p->v[i] < hi;
}

unsigned
pm_principled_lobes(const struct pm_bsdf *b)
{
	const struct pm_principled *p = &b->pr;
	unsigned l = 0;

	if (b->type == PM_BSDF_PRINCIPLED) {
		l = PM_LOBE_GLOSSY;
		if (can_be_below(p, PM_PR_METALLIC, 1.0f) &&
		    can_be_below(p, PM_PR_SPEC_TRANS, 1.0f))
			l |= PM_LOBE_DIFFUSE;
		if (p->has_spec_trans && can_be_below(p, PM_PR_METALLIC, 1.0f) &&
		    can_exceed(p, PM_PR_SPEC_TRANS, 0.0f))
			l |= PM_LOBE_GLOSSY_TRANSMISSION;
		return l;
	}
	if (p->has_spec_trans && can_exceed(p, PM_PR_SPEC_TRANS, 0.0f))
		l |= PM_LOBE_GLOSSY | PM_LOBE_GLOSSY_TRANSMISSION;
	if (can_be_below(p, PM_PR_SPEC_TRANS, 1.0f)) {
		if (can_be_below(p, PM_PR_DIFF_TRANS, 2.0f))
			l |= PM_LOBE_DIFFUSE;
		if (p->has_diff_trans && can_exceed(p, PM_PR_DIFF_TRANS, 0.0f))
			l |= PM_LOBE_DIFFUSE_TRANSMISSION;
	}
	return l;
}

struct pm_rgb
pm_principled_eval(const struct pm_bsdf *b, struct pm_vec3 wi,
    struct pm_vec3 wo, bool radiance)
{
	return b->type == PM_BSDF_PRINCIPLED ? pr_eval(b, wi, wo, radiance) :
	    thin_eval(b, wi, wo);
}

float
pm_principled_pdf(const struct pm_bsdf *b, struct pm_vec3 wi,
    struct pm_vec3 wo)
{
	return b->type == PM_BSDF_PRINCIPLED ? pr_pdf(b, wi, wo) :
	    thin_pdf(b, wi, wo);
}

bool
pm_principled_sample(const struct pm_bsdf *b, struct pm_vec3 wi, float u1,
    float u2, float u3, bool radiance, struct pm_bsdf_sample *s)
{
	return b->type == PM_BSDF_PRINCIPLED ?
	    pr_sample(b, wi, u1, u2, u3, radiance, s) :
	    thin_sample(b, wi, u1, u2, u3, s);
}
