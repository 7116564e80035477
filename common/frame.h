/*
 * frame.h: shading frames that follow the surface's parameterisation, as
 * Mitsuba 3 builds them, for the BSDFs that need more than a normal:
 * anisotropic roughness, normal maps and bump maps.
 *
 * Mitsuba's frame at a hit is its shading normal n with s the tangent
 * dp/du made orthogonal to n (Gram-Schmidt) and t = n x s.  Isotropic
 * BSDFs do not care which way s points, so pm_bsdf_frame_at builds this
 * frame only for BSDFs that do and keeps the cheaper frame of the normal
 * alone for the others.
 */
#ifndef PM_FRAME_H
#define PM_FRAME_H

#include "accel.h"
#include "bsdf.h"
#include "scene.h"
#include "texture.h"
#include "vec.h"

/*
 * The partial derivatives of the hit point over the surface's uv, as
 * Mitsuba 3 defines them: a mesh's per triangle from its vertex uv (the
 * built-in rectangle, cube, disk and cylinder are meshes with Mitsuba's
 * uv), from its barycentrics (dp/du = p1 - p0, dp/dv = p2 - p0) without
 * uv, and an arbitrary pair around the geometric normal where the uv
 * triangle is degenerate; a sphere's analytic, u = phi / 2 pi and
 * v = theta / pi in its object frame.
 */
void pm_hit_dpdu(const struct pm_scene *s, const struct pm_hit *h,
    struct pm_vec3 *dpdu, struct pm_vec3 *dpdv);

/* The frame of unit normal n whose s is dpdu made orthogonal to n (an
 * arbitrary one around n where dpdu is zero or parallel to n). */
struct pm_frame pm_frame_gram_schmidt(struct pm_vec3 n, struct pm_vec3 dpdu);

/*
 * The BSDF at a hit (pm_bsdf_at, texture.h) and, in *fr, the shading
 * frame to evaluate it in, for a ray of direction d arriving there.  For
 * a normal- or bump-mapped BSDF the result is *tmp, with the perturbed
 * frame in its pframe (bsdf.h): *fr stays the unperturbed frame, whose
 * local directions eval, pdf and sample take as for any other BSDF.
 */
const struct pm_bsdf *pm_bsdf_frame_tangent(const struct pm_scene *s,
    const struct pm_hit *h, struct pm_vec3 d, const struct pm_bsdf *b,
    struct pm_bsdf *tmp, struct pm_frame *fr);

/* Whether b's lobes turn with the tangent (anisotropic roughness, a
 * principled BSDF's anisotropic) or its frame is perturbed by a map. */
static inline bool
pm_bsdf_needs_tangent(const struct pm_bsdf *b)
{
	return b->aniso || b->tex_normal != 0 || b->tex_bump != 0 ||
	    ((b->type == PM_BSDF_PRINCIPLED ||
	    b->type == PM_BSDF_PRINCIPLEDTHIN) &&
	    b->pr.v[PM_PR_ANISOTROPIC] != 0.0f) ||
	    /* a blend or mask of anisotropic BSDFs evaluates them in its
	     * own frame, which must then follow dp/du too */
	    (pm_bsdf_is_composite(b) && ((b->sub[0] != NULL &&
	    pm_bsdf_needs_tangent(b->sub[0])) || (b->sub[1] != NULL &&
	    pm_bsdf_needs_tangent(b->sub[1]))));
}

static inline const struct pm_bsdf *
pm_bsdf_frame_at(const struct pm_scene *s, const struct pm_hit *h,
    struct pm_vec3 d, struct pm_bsdf *tmp, struct pm_frame *fr)
{
	const struct pm_bsdf *b = &s->bsdfs[s->shapes[h->shape].bsdf];

	if (pm_bsdf_textured(b))
		b = pm_bsdf_at(s, h, tmp);

	/* isotropic (nearly every hit): any frame around the normal, in
	 * line, as before frames followed the surface */
	if (!pm_bsdf_needs_tangent(b)) {
		*fr = pm_frame_from_normal(h->ns);
		return b;
	}
	return pm_bsdf_frame_tangent(s, h, d, b, tmp, fr);
}

#endif
