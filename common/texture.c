/*
 * texture.c: lookups of Mitsuba 3's checkerboard, bitmap and rawconstant
 * textures, the uv coordinates of a hit, and the BSDF of a hit with its
 * textures looked up (texture.h).
 *
 * A bitmap is looked up as Mitsuba (Dr.Jit's texture) does: texel centres
 * sit at ((i + 1/2) / width, (j + 1/2) / height), row j = 0 at v = 0;
 * bilinear interpolation weighs the four texels around the point, each
 * index wrapped on its own; nearest takes the texel the point falls in.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "texture.h"

void
pm_texture_init(struct pm_texture *t, enum pm_texture_type type)
{
	memset(t, 0, sizeof(*t));
	t->type = type;
	t->to_uv[0] = 1.0f;
	t->to_uv[4] = 1.0f;
	t->color0 = pm_rgb1(0.4f);
	t->color1 = pm_rgb1(0.2f);
	t->wrap = PM_WRAP_REPEAT;
}

void
pm_texture_free(struct pm_texture *t)
{
	int i;

	free(t->rgb);
	t->rgb = NULL;
	t->width = t->height = 0;
	for (i = 0; i < 2; i++)
		if (t->sub[i] != NULL) {
			pm_texture_free(t->sub[i]);
			free(t->sub[i]);
			t->sub[i] = NULL;
		}
}

bool
pm_texture_copy(struct pm_texture *dst, const struct pm_texture *src)
{
	size_t n = 3 * (size_t)src->width * (size_t)src->height;
	int i;

	*dst = *src;
	dst->rgb = NULL;
	dst->sub[0] = dst->sub[1] = NULL;
	if (src->rgb != NULL) {
		if ((dst->rgb = malloc(n * sizeof(float))) == NULL)
			goto fail;
		memcpy(dst->rgb, src->rgb, n * sizeof(float));
	}
	for (i = 0; i < 2; i++) {
		if (src->sub[i] == NULL)
			continue;
		if ((dst->sub[i] = calloc(1, sizeof(*dst->sub[i]))) == NULL)
			goto fail;
		if (!pm_texture_copy(dst->sub[i], src->sub[i])) {
			free(dst->sub[i]);
			dst->sub[i] = NULL;
			goto fail;
		}
	}
	return true;
fail:
	pm_texture_free(dst);
	return false;
}

float
pm_srgb_to_linear(float c)
{
	if (c <= 0.04045f)
		return c / 12.92f;
	return powf((c + 0.055f) / 1.055f, 2.4f);
}

/* An integer texel index from a coordinate in texels, safe for any float:
 * far-out and non-finite coordinates are brought within a range where
 * the conversion is defined (the wrap then decides). */
static inline long
texel_floor(float x)
{
	if (!(x > -1e9f))	/* NaN too */
		x = x != x ? 0.0f : -1e9f;
	if (x > 1e9f)
		x = 1e9f;
	return (long)floorf(x);
}

static inline int
wrap_index(long i, int n, enum pm_wrap w)
{
	long m;

	switch (w) {
	case PM_WRAP_CLAMP:
		return i < 0 ? 0 : i >= n ? n - 1 : (int)i;
	case PM_WRAP_MIRROR:
		/* period 2n: n texels forwards, then the same backwards */
		m = i % (2L * n);
		if (m < 0)
			m += 2L * n;
		return m < n ? (int)m : (int)(2L * n - 1 - m);
	case PM_WRAP_REPEAT:
	default:
		m = i % n;
		return (int)(m < 0 ? m + n : m);
	}
}

static inline struct pm_rgb
texel(const struct pm_texture *t, int x, int y)
{
	const float *p = t->rgb + 3 * ((size_t)y * (size_t)t->width + (size_t)x);

	return pm_rgb(p[0], p[1], p[2]);
}

static struct pm_rgb
bitmap_eval(const struct pm_texture *t, float u, float v)
{
	float x, y, fx, fy;
	long ix, iy;
	int x0, x1, y0, y1;
	struct pm_rgb a, b;

	if (t->rgb == NULL || t->width <= 0 || t->height <= 0)
		return pm_rgb1(0.0f);
	if (t->nearest) {
		x0 = wrap_index(texel_floor(u * (float)t->width), t->width, t->wrap);
		y0 = wrap_index(texel_floor(v * (float)t->height), t->height,
		    t->wrap);
		return texel(t, x0, y0);
	}
	x = u * (float)t->width - 0.5f;
	y = v * (float)t->height - 0.5f;
	ix = texel_floor(x);
	iy = texel_floor(y);
	fx = x - (float)ix;
	fy = y - (float)iy;
	if (!(fx >= 0.0f && fx <= 1.0f))	/* far out or NaN: clamp */
		fx = 0.0f;
	if (!(fy >= 0.0f && fy <= 1.0f))
		fy = 0.0f;
	x0 = wrap_index(ix, t->width, t->wrap);
	x1 = wrap_index(ix + 1, t->width, t->wrap);
	y0 = wrap_index(iy, t->height, t->wrap);
	y1 = wrap_index(iy + 1, t->height, t->wrap);
	a = pm_rgb_add(pm_rgb_scale(texel(t, x0, y0), 1.0f - fx),
	    pm_rgb_scale(texel(t, x1, y0), fx));
	b = pm_rgb_add(pm_rgb_scale(texel(t, x0, y1), 1.0f - fx),
	    pm_rgb_scale(texel(t, x1, y1), fx));
	return pm_rgb_add(pm_rgb_scale(a, 1.0f - fy), pm_rgb_scale(b, fy));
}

struct pm_rgb
pm_texture_eval(const struct pm_texture *t, float u, float v)
{
	const float *m = t->to_uv;
	float tu = m[0] * u + m[1] * v + m[2];
	float tv = m[3] * u + m[4] * v + m[5];

	switch (t->type) {
	case PM_TEXTURE_CHECKERBOARD: {
		bool hu = tu - floorf(tu) > 0.5f, hv = tv - floorf(tv) > 0.5f;
		int k = hu == hv ? 0 : 1;

		/* a nested texture sees the surface's uv, not to_uv's */
		if (t->sub[k] != NULL)
			return pm_texture_eval(t->sub[k], u, v);
		return k == 0 ? t->color0 : t->color1;
	}
	case PM_TEXTURE_BITMAP:
		return bitmap_eval(t, tu, tv);
	case PM_TEXTURE_CONSTANT:
	case PM_TEXTURE_MESH_ATTRIBUTE:	/* without a hit: its stand-in */
		return t->color0;
	}
	return pm_rgb1(0.0f);
}

/*
 * Mitsuba's eval_1, for scalar parameters: a bitmap's luminance there; a
 * checkerboard's colour reduced by its mean, as Mitsuba reduces a colour
 * constant, and with the two colours swapped, as Mitsuba 3 has them
 * (its checkerboard's eval_1 gives color1 where eval gives color0).
 */
float
pm_texture_eval1(const struct pm_texture *t, float u, float v)
{
	const float *m = t->to_uv;
	float tu = m[0] * u + m[1] * v + m[2];
	float tv = m[3] * u + m[4] * v + m[5];
	struct pm_rgb c;

	if (t->type == PM_TEXTURE_CHECKERBOARD) {
		bool hu = tu - floorf(tu) > 0.5f, hv = tv - floorf(tv) > 0.5f;

		c = hu == hv ? t->color1 : t->color0;
		return (c.r + c.g + c.b) / 3.0f;
	}
	c = pm_texture_eval(t, u, v);
	return 0.212671f * c.r + 0.715160f * c.g + 0.072169f * c.b;
}

struct pm_rgb
pm_texture_eval_at(const struct pm_scene *s, const struct pm_texture *t,
    const struct pm_hit *h, float u, float v)
{
	const struct pm_mesh *m;
	const uint32_t *ix;
	const float *c;
	float w;
	int k;

	switch (t->type) {
	case PM_TEXTURE_CHECKERBOARD: {
		const float *a = t->to_uv;
		float tu = a[0] * u + a[1] * v + a[2];
		float tv = a[3] * u + a[4] * v + a[5];

		if (t->sub[0] == NULL && t->sub[1] == NULL)
			break;
		/* as pm_texture_eval, the nested textures seeing the hit */
		k = (tu - floorf(tu) > 0.5f) == (tv - floorf(tv) > 0.5f) ? 0 : 1;
		if (t->sub[k] != NULL)
			return pm_texture_eval_at(s, t->sub[k], h, u, v);
		return k == 0 ? t->color0 : t->color1;
	}
	case PM_TEXTURE_MESH_ATTRIBUTE:
		m = &s->shapes[h->shape].mesh;
		if (s->shapes[h->shape].type != PM_SHAPE_MESH)
			return pm_rgb1(0.0f);
		if (t->attr == PM_ATTR_FACE_COLOR) {
			if (m->fcolor == NULL)
				return pm_rgb1(0.0f);
			c = m->fcolor + 3 * (size_t)h->prim;
			return pm_rgb(t->scale * c[0], t->scale * c[1],
			    t->scale * c[2]);
		}
		if (m->vcolor == NULL)
			return pm_rgb1(0.0f);
		ix = &m->idx[3 * (size_t)h->prim];
		w = 1.0f - h->u - h->v;
		{
			const float *c0 = m->vcolor + 3 * (size_t)ix[0];
			const float *c1 = m->vcolor + 3 * (size_t)ix[1];
			const float *c2 = m->vcolor + 3 * (size_t)ix[2];

			return pm_rgb_scale(pm_rgb(
			    w * c0[0] + h->u * c1[0] + h->v * c2[0],
			    w * c0[1] + h->u * c1[1] + h->v * c2[1],
			    w * c0[2] + h->u * c1[2] + h->v * c2[2]), t->scale);
		}
	default:
		break;
	}
	return pm_texture_eval(t, u, v);
}

unsigned
pm_texture_needs(const struct pm_texture *t)
{
	unsigned n = t->type == PM_TEXTURE_MESH_ATTRIBUTE ? (unsigned)t->attr :
	    0u;
	int i;

	for (i = 0; i < 2; i++)
		if (t->sub[i] != NULL)
			n |= pm_texture_needs(t->sub[i]);
	return n;
}

struct pm_rgb
pm_texture_mean(const struct pm_texture *t)
{
	double s[3] = {0, 0, 0};
	size_t i, n;

	switch (t->type) {
	case PM_TEXTURE_CHECKERBOARD:
		/* each colour covers half the period; a nested texture
		 * counts with its own mean */
		return pm_rgb_scale(pm_rgb_add(t->sub[0] != NULL ?
		    pm_texture_mean(t->sub[0]) : t->color0, t->sub[1] != NULL ?
		    pm_texture_mean(t->sub[1]) : t->color1), 0.5f);
	case PM_TEXTURE_CONSTANT:
	case PM_TEXTURE_MESH_ATTRIBUTE:
		return t->color0;
	case PM_TEXTURE_BITMAP:
		if (t->rgb == NULL || t->width <= 0 || t->height <= 0)
			break;
		n = (size_t)t->width * (size_t)t->height;
		for (i = 0; i < n; i++) {
			s[0] += t->rgb[3 * i];
			s[1] += t->rgb[3 * i + 1];
			s[2] += t->rgb[3 * i + 2];
		}
		return pm_rgb((float)(s[0] / (double)n), (float)(s[1] / (double)n),
		    (float)(s[2] / (double)n));
	}
	return pm_rgb1(0.0f);
}

void
pm_hit_uv(const struct pm_scene *s, const struct pm_hit *h, float *u, float *v)
{
	const struct pm_shape *sh = &s->shapes[h->shape];

	if (sh->type == PM_SHAPE_SPHERE) {
		struct pm_vec3 d = pm_sub(h->p, sh->center), l;
		const struct pm_frame *a = &sh->axes;
		float r, phi, ct;

		/* the object frame's axes; none given: the world's */
		if (pm_dot(a->n, a->n) > 0.0f)
			l = pm_v3(pm_dot(d, a->s) / pm_dot(a->s, a->s),
			    pm_dot(d, a->t) / pm_dot(a->t, a->t),
			    pm_dot(d, a->n) / pm_dot(a->n, a->n));
		else
			l = d;
		r = pm_length(l);
		ct = r > 0.0f ? l.z / r : 1.0f;
		ct = pm_fminf(pm_fmaxf(ct, -1.0f), 1.0f);
		phi = atan2f(l.y, l.x);
		if (phi < 0.0f)
			phi += 2.0f * PM_PI;
		*u = phi * (0.5f / PM_PI);
		*v = acosf(ct) * (1.0f / PM_PI);
		return;
	}
	if (sh->mesh.uv != NULL) {
		const uint32_t *t = &sh->mesh.idx[3 * (size_t)h->prim];
		const float *uv = sh->mesh.uv;
		float w = 1.0f - h->u - h->v;

		*u = w * uv[2 * t[0]] + h->u * uv[2 * t[1]] + h->v * uv[2 * t[2]];
		*v = w * uv[2 * t[0] + 1] + h->u * uv[2 * t[1] + 1] +
		    h->v * uv[2 * t[2] + 1];
		return;
	}
	/* Mitsuba's uv on a mesh without texture coordinates */
	*u = h->u;
	*v = h->v;
}

/* Colour parameter i (1 + a texture index) at (u, v), at hit h of scene s
 * where they are known (mesh attributes need the hit), else by uv alone
 * (BSDFs nested in others are looked up without the hit). */
static struct pm_rgb
colour_at(const struct pm_texture *textures, int i, const struct pm_scene *s,
    const struct pm_hit *h, float u, float v)
{
	const struct pm_texture *t = &textures[i - 1];

	return s != NULL && h != NULL ? pm_texture_eval_at(s, t, h, u, v) :
	    pm_texture_eval(t, u, v);
}

static void
lookup(const struct pm_texture *textures, const struct pm_scene *s,
    const struct pm_hit *h, struct pm_bsdf *b, float u, float v)
{
	int i;

	if (b->tex_diffuse > 0)
		b->diffuse = colour_at(textures, b->tex_diffuse, s, h, u, v);
	if (b->tex_specular > 0)
		b->specular = colour_at(textures, b->tex_specular, s, h, u, v);
	if (b->tex_transmittance > 0)
		b->transmittance = colour_at(textures, b->tex_transmittance, s,
		    h, u, v);
	/* scalar parameters, as Mitsuba's eval_1 reduces them */
	if (b->tex_alpha > 0)
		b->alpha = pm_texture_eval1(&textures[b->tex_alpha - 1], u, v);
	if (b->tex_alpha_v > 0)
		b->alpha_v = pm_texture_eval1(&textures[b->tex_alpha_v - 1], u,
		    v);
	if (b->tex_weight > 0)
		b->weight = pm_texture_eval1(&textures[b->tex_weight - 1], u,
		    v);
	/* the principled BSDFs' scalar parameters */
	for (i = 0; b->pr.textured && i < PM_PR_N; i++)
		if (b->pr.tex[i] > 0)
			b->pr.v[i] = pm_texture_eval1(&textures[b->pr.tex[i] - 1],
			    u, v);
	/* where BSDFs nested in this one look theirs up */
	b->u = u;
	b->v = v;
}

void
pm_bsdf_lookup(const struct pm_texture *textures, struct pm_bsdf *b, float u,
    float v)
{
	lookup(textures, NULL, NULL, b, u, v);
}

const struct pm_bsdf *
pm_bsdf_at(const struct pm_scene *s, const struct pm_hit *h,
    struct pm_bsdf *tmp)
{
	const struct pm_bsdf *b = &s->bsdfs[s->shapes[h->shape].bsdf];
	float u, v;

	if (!pm_bsdf_textured(b))
		return b;
	*tmp = *b;
	pm_hit_uv(s, h, &u, &v);
	lookup(s->textures, s, h, tmp, u, v);
	return tmp;
}

static inline struct pm_rgb
rgb_diff(struct pm_rgb a, struct pm_rgb b)
{
	return pm_rgb(a.r - b.r, a.g - b.g, a.b - b.b);
}

/*
 * The gradient over (u, v) of the texture's luminance, as Mitsuba's
 * eval_1_grad: a bilinear bitmap's exact derivative within the cell the
 * point falls in (the chain rule through to_uv included); nearest
 * lookups and checkerboards are flat almost everywhere, so zero.
 */
void
pm_texture_grad1(const struct pm_texture *t, float u, float v, float g[2])
{
	const float *m = t->to_uv;
	float tu = m[0] * u + m[1] * v + m[2];
	float tv = m[3] * u + m[4] * v + m[5];
	float x, y, fx, fy, dx, dy;
	struct pm_rgb ex, ey;
	long ix, iy;
	int x0, x1, y0, y1;

	g[0] = g[1] = 0.0f;
	if (t->type != PM_TEXTURE_BITMAP || t->nearest || t->rgb == NULL ||
	    t->width <= 0 || t->height <= 0)
		return;
	x = tu * (float)t->width - 0.5f;
	y = tv * (float)t->height - 0.5f;
	ix = texel_floor(x);
	iy = texel_floor(y);
	fx = x - (float)ix;
	fy = y - (float)iy;
	if (!(fx >= 0.0f && fx <= 1.0f))
		fx = 0.0f;
	if (!(fy >= 0.0f && fy <= 1.0f))
		fy = 0.0f;
	x0 = wrap_index(ix, t->width, t->wrap);
	x1 = wrap_index(ix + 1, t->width, t->wrap);
	y0 = wrap_index(iy, t->height, t->wrap);
	y1 = wrap_index(iy + 1, t->height, t->wrap);
	/* d/dx and d/dy of the bilinear blend, in texels */
	ex = pm_rgb_add(pm_rgb_scale(rgb_diff(texel(t, x1, y0),
	    texel(t, x0, y0)), 1.0f - fy), pm_rgb_scale(rgb_diff(texel(t,
	    x1, y1), texel(t, x0, y1)), fy));
	ey = pm_rgb_add(pm_rgb_scale(rgb_diff(texel(t, x0, y1),
	    texel(t, x0, y0)), 1.0f - fx), pm_rgb_scale(rgb_diff(texel(t,
	    x1, y1), texel(t, x1, y0)), fx));
	dx = (0.212671f * ex.r + 0.715160f * ex.g + 0.072169f * ex.b) *
	    (float)t->width;
	dy = (0.212671f * ey.r + 0.715160f * ey.g + 0.072169f * ey.b) *
	    (float)t->height;
	g[0] = m[0] * dx + m[3] * dy;
	g[1] = m[1] * dx + m[4] * dy;
}
