/*
 * bsdf_principled.h: Mitsuba 3's principled and principledthin BSDFs
 * (Burley's Disney BSDF as Mitsuba defines it), their parameters and the
 * functions bsdf.c's switches call.  Conventions as in bsdf.h.
 */
#ifndef PM_BSDF_PRINCIPLED_H
#define PM_BSDF_PRINCIPLED_H

#include <stdbool.h>

#include "vec.h"

/* The scalar parameters, by Mitsuba's names; each may be a texture.
 * base_color is the BSDF's `diffuse` (and tex_diffuse). */
enum pm_pr_param {
	PM_PR_ROUGHNESS,
	PM_PR_ANISOTROPIC,
	PM_PR_METALLIC,		/* principled */
	PM_PR_SPEC_TRANS,
	PM_PR_SPEC_TINT,
	PM_PR_SHEEN,
	PM_PR_SHEEN_TINT,
	PM_PR_FLATNESS,
	PM_PR_CLEARCOAT,	/* principled */
	PM_PR_CLEARCOAT_GLOSS,	/* principled */
	PM_PR_DIFF_TRANS,	/* principledthin, in [0, 2] */
	PM_PR_ETA,		/* principled: a float; principledthin: may be a texture */
	PM_PR_N
};

/* Sampling rates, by role. */
enum pm_pr_rate {
	PM_PR_RATE_DIFFUSE,	/* diffuse_reflectance_sampling_rate */
	PM_PR_RATE_SPECULAR,	/* main_specular / specular_reflectance_... */
	PM_PR_RATE_OTHER,	/* clearcoat_ (principled), specular_transmittance_ (thin) */
	PM_PR_RATE_DIFF_TRANS,	/* diffuse_transmittance_ (thin) */
	PM_PR_NRATES
};

struct pm_principled {
	float v[PM_PR_N];
	/* 1 + index into scene.textures, 0 for none (pm_bsdf_at looks
	 * them up; until then v holds the textures' mean luminance) */
	int tex[PM_PR_N];
	bool textured;		/* some tex[] is set */
	/* Mitsuba's flags: the parameter was given and is not the float 0
	 * (they switch lobes on and steer sampling) */
	bool has_spec_trans, has_clearcoat, has_diff_trans;
	float rate[PM_PR_NRATES];
};

struct pm_bsdf;
struct pm_bsdf_sample;

/* Mitsuba's defaults for a principled (thin false) or principledthin BSDF. */
void pm_principled_defaults(struct pm_principled *p, bool thin);
/* The lobes a principled BSDF can produce (textured parameters count as
 * anything in their range). */
unsigned pm_principled_lobes(const struct pm_bsdf *b);
struct pm_rgb pm_principled_eval(const struct pm_bsdf *b, struct pm_vec3 wi,
    struct pm_vec3 wo, bool radiance);
float pm_principled_pdf(const struct pm_bsdf *b, struct pm_vec3 wi,
    struct pm_vec3 wo);
bool pm_principled_sample(const struct pm_bsdf *b, struct pm_vec3 wi,
    float u1, float u2, float u3, bool radiance, struct pm_bsdf_sample *s);

#endif
