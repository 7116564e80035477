/*
 * texture.h: Mitsuba 3's 2D textures (checkerboard, bitmap, rawconstant),
 * looked up by the surface's uv coordinates, and mesh_attribute, looked
 * up by the hit; and the BSDF of a surface point with its textured
 * parameters in place.
 *
 * A texture is a plain struct; a bitmap's texels are one flat array of
 * linear RGB floats that the texture owns.  Lookups allocate nothing and
 * read only, so any number of threads share a texture.  Files are read by
 * formats/texture.c; nothing here knows of them.
 */
#ifndef PM_TEXTURE_H
#define PM_TEXTURE_H

#include <stdbool.h>

#include "accel.h"
#include "bsdf.h"
#include "scene.h"
#include "vec.h"

enum pm_texture_type {
	PM_TEXTURE_CHECKERBOARD,
	PM_TEXTURE_BITMAP,
	PM_TEXTURE_CONSTANT,	/* rawconstant: color0 everywhere */
	PM_TEXTURE_MESH_ATTRIBUTE,	/* a mesh's vertex or face colour */
};

enum pm_mesh_attr {
	PM_ATTR_VERTEX_COLOR = 1,	/* bits, as pm_texture_needs says */
	PM_ATTR_FACE_COLOR = 2,
};

enum pm_wrap {
	PM_WRAP_REPEAT,		/* tile (Mitsuba's default) */
	PM_WRAP_MIRROR,		/* tile, every other copy mirrored */
	PM_WRAP_CLAMP,		/* the edge texels continue outwards */
};

struct pm_texture {
	enum pm_texture_type type;
	/* to_uv as an affine map of the plane: (u, v) becomes
	 * (a[0] u + a[1] v + a[2], a[3] u + a[4] v + a[5]). */
	float to_uv[6];
	/* checkerboard: color0 where the fractional parts of u and v are
	 * both at most 1/2 or both above, color1 elsewhere */
	struct pm_rgb color0, color1;
	/* checkerboard: color0 and color1 given as textures (the
	 * checkerboard owns these copies; NULL: the colours above), looked
	 * up at the same (u, v) before to_uv, as Mitsuba looks up a nested
	 * texture at the surface's uv */
	struct pm_texture *sub[2];
	/* bitmap: width x height linear RGB texels, top row first (v = 0
	 * is the top row, as in Mitsuba), owned by the texture */
	int width, height;
	float *rgb;
	bool nearest;		/* filter_type nearest, else bilinear */
	enum pm_wrap wrap;
	/* mesh_attribute: which, and Mitsuba's scale; color0 holds 0.5
	 * scale, what stands for its mean (Mitsuba has none) */
	enum pm_mesh_attr attr;
	float scale;
	char name[64];		/* id, or type and ordinal, for messages */
};

/* A texture of the given type with the identity to_uv and Mitsuba's
 * defaults (checkerboard 0.4 and 0.2; bitmap empty, bilinear, repeat). */
void pm_texture_init(struct pm_texture *t, enum pm_texture_type type);
/* Frees the texels and nested textures; t may be initialised again. */
void pm_texture_free(struct pm_texture *t);

/* A deep copy of src into *dst (texels and nested textures duplicated);
 * false when out of memory, *dst then empty. */
bool pm_texture_copy(struct pm_texture *dst, const struct pm_texture *src);

/* The texture's value at surface coordinates (u, v), before to_uv. */
struct pm_rgb pm_texture_eval(const struct pm_texture *t, float u, float v);
/* The texture as a scalar parameter (alpha, weight, opacity) reads it:
 * Mitsuba's eval_1 (texture.c says how). */
float pm_texture_eval1(const struct pm_texture *t, float u, float v);

/* The texture's value at hit h of scene s, whose uv is (u, v): as
 * pm_texture_eval, and a mesh_attribute (alone or within a checkerboard)
 * takes the hit's mesh's attribute, interpolated over the triangle for a
 * vertex colour; black where the shape has none. */
struct pm_rgb pm_texture_eval_at(const struct pm_scene *s,
    const struct pm_texture *t, const struct pm_hit *h, float u, float v);

/* The mesh attributes t looks up, nested textures included: a set of
 * enum pm_mesh_attr bits. */
unsigned pm_texture_needs(const struct pm_texture *t);

/* The texture's mean value over one period (Mitsuba's mean(): plastic
 * steers its samples by it). */
struct pm_rgb pm_texture_mean(const struct pm_texture *t);

/* The texture's value for a scalar parameter at (u, v), as Mitsuba's
 * eval_1: the luminance, except that a checkerboard answers with its
 * colours the other way round (Mitsuba 3.9.1's behaviour, followed). */
float pm_texture_eval1(const struct pm_texture *t, float u, float v);

/* The gradient over surface (u, v) of the texture's luminance into g
 * (Mitsuba's eval_1_grad): a bilinear bitmap's derivative within the
 * cell, zero for nearest lookups and checkerboards. */
void pm_texture_grad1(const struct pm_texture *t, float u, float v,
    float g[2]);

/* sRGB's transfer curve undone: an encoded value in [0, 1] to linear. */
float pm_srgb_to_linear(float c);

/*
 * The uv coordinates of a hit as Mitsuba defines them: a mesh's vertex
 * uv interpolated, or, for a mesh without, the barycentrics of vertices
 * 1 and 2; on a sphere (phi / 2 pi, theta / pi) in its object frame.
 */
void pm_hit_uv(const struct pm_scene *s, const struct pm_hit *h, float *u,
    float *v);

/* Whether b has a textured parameter, which pm_bsdf_at looks up (in line:
 * a path's every vertex asks, and nearly every answer is no). */
static inline bool
pm_bsdf_textured(const struct pm_bsdf *b)
{
	return b->tex_diffuse != 0 || b->tex_specular != 0 ||
	    b->tex_alpha != 0 || b->tex_transmittance != 0 ||
	    b->pr.textured || b->tex_weight != 0 || b->nested_textures ||
	    b->tex_alpha_v != 0;
}

/*
 * The BSDF at a hit: the scene's own when it has no textured parameter
 * (nothing is copied), else *tmp filled with the textured values looked
 * up there.  Derived fields (lobes, plastic's sampling weight) are kept
 * as pm_bsdf_prepare set them from the textures' means, as in Mitsuba.
 */
const struct pm_bsdf *pm_bsdf_at(const struct pm_scene *s,
    const struct pm_hit *h, struct pm_bsdf *tmp);

/*
 * The textured parameters of b (a copy) looked up at (u, v) in the
 * scene's textures, and (u, v) recorded for the BSDFs nested in b, which
 * bsdf.c looks up the same way when it reaches them.
 */
void pm_bsdf_lookup(const struct pm_texture *textures, struct pm_bsdf *b,
    float u, float v);

#endif
