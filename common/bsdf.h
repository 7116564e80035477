/*
 * bsdf.h: the closed set of materials, each with Mitsuba 3's meaning.
 *
 * All directions are unit vectors in the local shading frame (normal +z).
 * wi points from the surface towards where the query came from (the camera
 * side in path tracing, the light side when tracing photons); wo is the
 * other direction.  As in Mitsuba 3:
 *   - eval returns f(wi, wo) * |cos theta_o|, zero for delta components;
 *   - sample returns wo, its pdf (solid angle; 1 by convention for a delta
 *     component, in which case `delta` is set) and the weight
 *     f * |cos theta_o| / pdf (for delta components, the discrete weight);
 *   - pdf returns the solid-angle density sample would have produced wo
 *     with, for the non-delta components.
 * PM_RADIANCE and PM_IMPORTANCE select the adjoint for refraction: radiance
 * is scaled by 1/eta^2 when it crosses an interface, importance is not
 * (Veach 1997, ch. 5).  Photons carry importance-like flux.
 */
#ifndef PM_BSDF_H
#define PM_BSDF_H

#include <stdbool.h>

#include "bsdf_principled.h"
#include "sampling.h"
#include "vec.h"

enum pm_bsdf_type {
	PM_BSDF_DIFFUSE,
	PM_BSDF_CONDUCTOR,
	PM_BSDF_ROUGHCONDUCTOR,
	PM_BSDF_DIELECTRIC,
	PM_BSDF_THINDIELECTRIC,
	PM_BSDF_PLASTIC,
	PM_BSDF_NULL,		/* invisible to rays: Mitsuba's "null" */
	PM_BSDF_MERL,		/* a measured BRDF in MERL's layout (merl.h) */
	PM_BSDF_ROUGHDIELECTRIC,
	PM_BSDF_ROUGHPLASTIC,
	PM_BSDF_PRINCIPLED,	/* Disney's, as Mitsuba: bsdf_principled.c */
	PM_BSDF_PRINCIPLEDTHIN,
	/* Made of other BSDFs (nested, sub, below): */
	PM_BSDF_BLEND,		/* blendbsdf: (1 - weight) sub[0] + weight sub[1] */
	PM_BSDF_MASK,		/* mask: opacity x sub[0], the rest passes */
	PM_BSDF_TWOSIDED,	/* twosided with two BSDFs: sub[0] in front,
				 * sub[1] behind (one BSDF: the flag below) */
};

/* Resolution of roughplastic's table of the coating's transmittance over
 * cos theta (Mitsuba's: 64 nodes, linearly interpolated). */
#define PM_ROUGH_T_RES 64

struct pm_merl;
struct pm_texture;

enum pm_transport {
	PM_RADIANCE,
	PM_IMPORTANCE,
};

/* Lobe flags: which kinds of scattering a BSDF (or a sampled event) has. */
enum {
	PM_LOBE_DIFFUSE = 1 << 0,
	PM_LOBE_GLOSSY = 1 << 1,
	PM_LOBE_DELTA_REFLECTION = 1 << 2,
	PM_LOBE_DELTA_TRANSMISSION = 1 << 3,
	PM_LOBE_GLOSSY_TRANSMISSION = 1 << 4,
	PM_LOBE_DIFFUSE_TRANSMISSION = 1 << 5,	/* principledthin's */
	PM_LOBE_DELTA = PM_LOBE_DELTA_REFLECTION | PM_LOBE_DELTA_TRANSMISSION,
	PM_LOBE_TRANSMISSION = PM_LOBE_DELTA_TRANSMISSION | PM_LOBE_GLOSSY_TRANSMISSION,
};

struct pm_bsdf {
	enum pm_bsdf_type type;
	bool twosided;		/* wrapped in Mitsuba's "twosided" */
	/* diffuse: reflectance; plastic: diffuse_reflectance */
	struct pm_rgb diffuse;
	/* conductors, dielectrics, plastics: specular_reflectance */
	struct pm_rgb specular;
	/* dielectric, thindielectric, roughdielectric: specular_transmittance */
	struct pm_rgb transmittance;
	/* conductors: complex index of refraction relative to ext_eta */
	struct pm_rgb eta, k;
	/* dielectrics and plastics: int_ior / ext_ior */
	float ior;
	/* rough*: the microfacet alpha (isotropic), GGX or Beckmann */
	float alpha;
	bool beckmann;		/* rough*: Beckmann's distribution */
	bool sample_visible;	/* rough*: sample visible normals
				 * (GGX; Beckmann samples D(m) cos) */
	bool nonlinear;		/* plastic, roughplastic */
	/* plastics: precomputed internal diffuse reflectance of the coating
	 * and the weight steering samples to the specular lobe; set by
	 * pm_bsdf_prepare */
	float fdr_int;
	float specular_sampling_weight;
	/* roughplastic: the coating's transmittance from outside at
	 * cos theta = i / (PM_ROUGH_T_RES - 1), PM_ROUGH_T_RES floats that
	 * pm_bsdf_prepare fills; the owner provides them (a scene's BSDFs
	 * share one array, scene.rough_t, which pm_scene_prepare hands
	 * out), so that the table is not in every BSDF and its copies */
	float *rough_t;
	unsigned lobes;		/* PM_LOBE_* this BSDF can produce */
	/* If not 0, the only PM_LOBE_* that eval, pdf and sample consider,
	 * as if the others were not there (Mitsuba's BSDFContext component
	 * selection); roughplastic, plastic and the principled BSDFs honour
	 * it lobe by lobe, BSDFs made of others pass it on to theirs, the
	 * rest keep or drop themselves whole (a measured BRDF counts as
	 * glossy if merl.c finds a peak, else as diffuse).  The photon
	 * render uses it
	 * to estimate the diffuse base and trace the glossy coating apart. */
	unsigned only;
	/* merl: the table, owned by the scene and shared by every BSDF that
	 * names the same file, and PM_MERL_INTERPOLATE, PM_MERL_COSINE */
	const struct pm_merl *merl;
	unsigned merl_flags;
	/* principled, principledthin: the parameters but base_color
	 * (diffuse, tex_diffuse) */
	struct pm_principled pr;
	/* Parameters given as textures: 1 + the index into scene.textures,
	 * 0 for none (so that a zeroed BSDF has none); pm_bsdf_at
	 * (texture.h) looks them up at a hit.  tex_diffuse replaces diffuse,
	 * tex_specular specular, tex_alpha alpha; until then those hold the
	 * textures' means. */
	int tex_diffuse, tex_specular, tex_alpha;
	int tex_transmittance;	/* dielectrics: replaces transmittance */
	/*
	 * blendbsdf, mask, twosided with two sides: the nested BSDFs as
	 * indices into scene.bsdfs (blendbsdf: its first and second; mask:
	 * [0]; twosided: front, back), each below this BSDF's own index, so
	 * that nesting has no cycles and pm_scene_prepare prepares children
	 * first; it also points sub[] at them (and textures at the scene's),
	 * so that eval, pdf and sample need no scene and copy nothing
	 * unless a nested BSDF is textured or `only` is set.
	 */
	int nested[2];
	const struct pm_bsdf *sub[2];
	const struct pm_texture *textures;
	/* blendbsdf: weight; mask: opacity (Mitsuba clamps both to [0, 1]);
	 * tex_weight as tex_diffuse (a scalar: the texture's luminance) */
	float weight;
	int tex_weight;
	/* Set by pm_scene_prepare: a BSDF nested in this one takes a
	 * texture, so pm_bsdf_at copies this one and records the hit's uv
	 * (u, v) for the nested ones to look theirs up at. */
	bool nested_textures;
	float u, v;
	/* rough conductors and dielectrics: anisotropic roughness, alpha
	 * (and tex_alpha) holding Mitsuba's alpha_u, along the shading
	 * frame's s (the surface's dp/du), alpha_v along t; tex_alpha_v as
	 * tex_alpha.  Not aniso: alpha both ways, alpha_v unused. */
	bool aniso;
	float alpha_v;
	int tex_alpha_v;
	/* Mitsuba's normalmap and bumpmap wrapped around this BSDF: 1 + the
	 * index into scene.textures of the normal map (RGB in tangent
	 * space) or of the height field, 0 for none; bump_scale is
	 * bumpmap's scale.  perturb_in_twosided: the wrapper sits inside
	 * twosided (twosided mirrors the query before it perturbs). */
	int tex_normal, tex_bump;
	float bump_scale;
	bool perturb_in_twosided;
	/* Set at a hit by pm_bsdf_frame_at (frame.h) on its copy: the
	 * perturbed shading frame, in the coordinates of the unperturbed
	 * one that eval, pdf and sample are given directions in.  They
	 * evaluate the BSDF in it as Mitsuba's wrappers do (the query
	 * turned into it, zero where wo lies on different sides of the
	 * two frames, Estevez et al.'s shadowing term). */
	bool perturbed;
	struct pm_frame pframe;
	/* normalmap, bumpmap: Mitsuba's flip_invalid_normals and
	 * use_shadowing_function turned off (both on by default) */
	bool keep_invalid_normals, no_shadowing;
};

struct pm_bsdf_sample {
	struct pm_vec3 wo;
	float pdf;
	struct pm_rgb weight;
	float eta;		/* relative IOR along the sampled path, 1 for reflection */
	unsigned lobe;		/* the PM_LOBE_* of the sampled event */
};

/* Fills derived fields (lobes, plastic's tables); call once after loading,
 * for a BSDF made of others after its sub[] are prepared and set, for
 * roughplastic after pointing rough_t at its table's storage. */
void pm_bsdf_prepare(struct pm_bsdf *b);

/* Whether b is made of other BSDFs (blendbsdf, mask, twosided with two). */
static inline bool pm_bsdf_is_composite(const struct pm_bsdf *b)
{
	return b->type == PM_BSDF_BLEND || b->type == PM_BSDF_MASK ||
	    b->type == PM_BSDF_TWOSIDED;
}

struct pm_rgb pm_bsdf_eval(const struct pm_bsdf *b, struct pm_vec3 wi,
    struct pm_vec3 wo, enum pm_transport mode);

/* Whether b, seen from wi, is Lambertian: pm_bsdf_eval(b, wi, wo, any
 * mode) is then *rho * |wo.z| / pi for wo.z * *side > 0 (side 1 or -1,
 * after twosided's flip) and black otherwise, so a photon estimate can
 * sum the photons' powers and multiply by *rho / pi once. */
bool pm_bsdf_lambertian(const struct pm_bsdf *b, struct pm_vec3 wi,
    struct pm_rgb *rho, float *side);
float pm_bsdf_pdf(const struct pm_bsdf *b, struct pm_vec3 wi, struct pm_vec3 wo);
/* u1 chooses the lobe, (u2, u3) the direction; false if nothing was sampled. */
bool pm_bsdf_sample(const struct pm_bsdf *b, struct pm_vec3 wi, float u1,
    float u2, float u3, enum pm_transport mode, struct pm_bsdf_sample *s);
/* pm_bsdf_sample with v, if not NULL, (u2, u3) warped to the cosine
 * hemisphere already (pm_square_to_cosine_hemisphere), which a diffuse or
 * plastic BSDF's diffuse lobe takes as its direction: the same result,
 * for callers that warp many pairs at once. */
bool pm_bsdf_sample_warped(const struct pm_bsdf *b, struct pm_vec3 wi,
    float u1, float u2, float u3, enum pm_transport mode,
    const struct pm_vec3 *v, struct pm_bsdf_sample *s);

/*
 * The diffuse lobe's eval, pdf and sample in the local frame, wi above
 * the surface (after twosided's flip): pm_bsdf_eval and friends use them
 * for the diffuse type, and the path tracer calls them directly at a
 * plain diffuse vertex (no map, no lobe selection, the commonest), so
 * both get the same bits without the call and the dispatch.
 */
static inline struct pm_rgb pm_diffuse_eval(struct pm_rgb r, struct pm_vec3 wi,
    struct pm_vec3 wo)
{
	if (wi.z <= 0.0f || wo.z <= 0.0f)
		return pm_rgb1(0.0f);
	return pm_rgb_scale(r, wo.z * PM_INV_PI);
}

static inline float pm_diffuse_pdf(struct pm_vec3 wi, struct pm_vec3 wo)
{
	if (wi.z <= 0.0f || wo.z <= 0.0f)
		return 0.0f;
	return wo.z * PM_INV_PI;
}

/* A plain diffuse BSDF (no map, no lobe selection), the commonest at a
 * path's vertices: its eval, pdf and sample are the inline diffuse lobe's
 * (below), the same bits as through bsdf.c, with twosided's flip. */
static inline bool pm_bsdf_plain_diffuse(const struct pm_bsdf *b)
{
	return b->type == PM_BSDF_DIFFUSE && !b->perturbed && b->only == 0;
}

/* pm_diffuse_sample with its direction v already warped from (u2, u3)
 * (pm_square_to_cosine_hemisphere): the same result, for callers that
 * warp many pairs at once. */
static inline bool pm_diffuse_sample_warped(struct pm_rgb r, struct pm_vec3 wi,
    struct pm_vec3 v, struct pm_bsdf_sample *s)
{
	if (wi.z <= 0.0f)
		return false;
	s->wo = v;
	s->pdf = pm_cosine_hemisphere_pdf(s->wo);
	if (!(s->pdf > 0.0f))
		return false;
	s->weight = r;
	s->eta = 1.0f;
	s->lobe = PM_LOBE_DIFFUSE;
	return true;
}

static inline bool pm_diffuse_sample(struct pm_rgb r, struct pm_vec3 wi,
    float u2, float u3, struct pm_bsdf_sample *s)
{
	if (wi.z <= 0.0f)
		return false;
	return pm_diffuse_sample_warped(r, wi,
	    pm_square_to_cosine_hemisphere(u2, u3), s);
}

/* pm_bsdf_sample_warped, a plain diffuse BSDF's in line (the commonest
 * at a path's vertices). */
static inline bool pm_bsdf_sample_v(const struct pm_bsdf *b, struct pm_vec3 wi,
    float u1, float u2, float u3, enum pm_transport mode,
    const struct pm_vec3 *v, struct pm_bsdf_sample *s)
{
	bool flip;

	if (!pm_bsdf_plain_diffuse(b))
		return pm_bsdf_sample_warped(b, wi, u1, u2, u3, mode, v, s);
	flip = b->twosided && wi.z < 0.0f;
	if (flip)
		wi.z = -wi.z;
	if (!(v != NULL ? pm_diffuse_sample_warped(b->diffuse, wi, *v, s) :
	    pm_diffuse_sample(b->diffuse, wi, u2, u3, s)))
		return false;
	if (flip)
		s->wo.z = -s->wo.z;
	return true;
}

/* Plastic's coating as a deterministic mirror sample (weight Fresnel x
 * specular); false for every other type or from below. */
bool pm_bsdf_coating(const struct pm_bsdf *b, struct pm_vec3 wi,
    struct pm_bsdf_sample *s);

/* True if every lobe is a delta (mirror, glass): no light sampling there. */
static inline bool pm_bsdf_is_delta(const struct pm_bsdf *b)
{
	return (b->lobes & ~(unsigned)PM_LOBE_DELTA) == 0;
}

/* Whether photons cross b as they cross glass, holding none there (the
 * rule of pm-shoot and of the gather pass): a rough dielectric, or a
 * principled BSDF that transmits and has no diffuse base. */
static inline bool pm_bsdf_passes_photons(const struct pm_bsdf *b)
{
	return b->type == PM_BSDF_ROUGHDIELECTRIC ||
	    ((b->type == PM_BSDF_PRINCIPLED ||
	    b->type == PM_BSDF_PRINCIPLEDTHIN) &&
	    !(b->lobes & PM_LOBE_DIFFUSE) && (b->lobes &
	    (PM_LOBE_GLOSSY_TRANSMISSION | PM_LOBE_DIFFUSE_TRANSMISSION)));
}

/* Fresnel reflectance of a dielectric interface; cos_i may be negative
 * (inside); returns R and, in *cos_t, the signed cosine of the refracted
 * direction (0 at total internal reflection). */
float pm_fresnel_dielectric(float cos_i, float eta, float *cos_t);
/* Plastic's diffuse base after the light's bounces between coating and
 * base (a geometric series): its diffuse lobe is this times (1 - Fi)
 * (1 - Fo) / eta^2 (pm-shoot's lanes take it from here, to the bit). */
struct pm_rgb pm_plastic_base(const struct pm_bsdf *b);
/* Fresnel reflectance of a conductor with complex IOR eta + i k, per channel. */
struct pm_rgb pm_fresnel_conductor(float cos_i, struct pm_rgb eta, struct pm_rgb k);

/* Named indices of refraction (Mitsuba's list: "bk7", "water", ...);
 * returns false if the name is unknown. */
bool pm_ior_lookup(const char *name, float *ior);
/* Mitsuba 3's named conductors ("Au", "a-C", "Cu_palik", ..., "none"),
 * eta and k in RGB as its RGB variants have them; returns false if the
 * name is unknown. */
bool pm_conductor_lookup(const char *name, struct pm_rgb *eta, struct pm_rgb *k);

#endif
