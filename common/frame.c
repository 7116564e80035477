/*
 * frame.c: tangents from the surface's parameterisation and the shading
 * frames Mitsuba 3's normalmap and bumpmap perturb (frame.h).
 */
#include <math.h>

#include "frame.h"
#include "texture.h"

/* A sphere's dp/du and dp/dv: in its object frame (axes a, columns of
 * to_world, world's if all zero) the point l on a sphere of radius |l|
 * has dp/du = 2 pi (-l.y, l.x, 0) and dp/dv = pi (l.z cos phi,
 * l.z sin phi, -rho), rho = sqrt(l.x^2 + l.y^2), mapped by to_world. */
static void
sphere_dpdu(const struct pm_shape *sh, struct pm_vec3 p, struct pm_vec3 *dpdu,
    struct pm_vec3 *dpdv)
{
	struct pm_vec3 d = pm_sub(p, sh->center), l;
	struct pm_frame a = sh->axes;
	float rho, c, sn;

	if (!(pm_dot(a.n, a.n) > 0.0f)) {
		a.s = pm_v3(1.0f, 0.0f, 0.0f);
		a.t = pm_v3(0.0f, 1.0f, 0.0f);
		a.n = pm_v3(0.0f, 0.0f, 1.0f);
	}
	l = pm_v3(pm_dot(d, a.s) / pm_dot(a.s, a.s),
	    pm_dot(d, a.t) / pm_dot(a.t, a.t), pm_dot(d, a.n) / pm_dot(a.n, a.n));
	rho = sqrtf(l.x * l.x + l.y * l.y);
	c = rho > 0.0f ? l.x / rho : 1.0f;
	sn = rho > 0.0f ? l.y / rho : 0.0f;
	*dpdu = pm_scale(pm_add(pm_scale(a.s, -l.y), pm_scale(a.t, l.x)),
	    2.0f * PM_PI);
	*dpdv = pm_scale(pm_add(pm_add(pm_scale(a.s, l.z * c),
	    pm_scale(a.t, l.z * sn)), pm_scale(a.n, -rho)), PM_PI);
}

void
pm_hit_dpdu(const struct pm_scene *s, const struct pm_hit *h,
    struct pm_vec3 *dpdu, struct pm_vec3 *dpdv)
{
	const struct pm_shape *sh = &s->shapes[h->shape];
	const struct pm_mesh *m = &sh->mesh;
	const uint32_t *t;
	struct pm_vec3 p0, dp0, dp1;
	float du0, dv0, du1, dv1, det;

	if (sh->type == PM_SHAPE_SPHERE) {
		sphere_dpdu(sh, h->p, dpdu, dpdv);
		return;
	}
	t = &m->idx[3 * (size_t)h->prim];
	p0 = pm_mesh_vertex(m, t[0]);
	dp0 = pm_sub(pm_mesh_vertex(m, t[1]), p0);
	dp1 = pm_sub(pm_mesh_vertex(m, t[2]), p0);
	if (m->uv == NULL) {
		/* uv are the barycentrics of vertices 1 and 2 */
		*dpdu = dp0;
		*dpdv = dp1;
		return;
	}
	du0 = m->uv[2 * t[1]] - m->uv[2 * t[0]];
	dv0 = m->uv[2 * t[1] + 1] - m->uv[2 * t[0] + 1];
	du1 = m->uv[2 * t[2]] - m->uv[2 * t[0]];
	dv1 = m->uv[2 * t[2] + 1] - m->uv[2 * t[0] + 1];
	det = du0 * dv1 - dv0 * du1;
	if (det == 0.0f || !isfinite(det)) {
		struct pm_frame f = pm_frame_from_normal(h->ng);

		*dpdu = f.s;
		*dpdv = f.t;
		return;
	}
	/* invert the triangle's linear map from uv to positions */
	*dpdu = pm_scale(pm_sub(pm_scale(dp0, dv1), pm_scale(dp1, dv0)),
	    1.0f / det);
	*dpdv = pm_scale(pm_sub(pm_scale(dp1, du0), pm_scale(dp0, du1)),
	    1.0f / det);
}

struct pm_frame
pm_frame_gram_schmidt(struct pm_vec3 n, struct pm_vec3 dpdu)
{
	struct pm_vec3 s = pm_madd(dpdu, n, -pm_dot(n, dpdu));
	float l2 = pm_dot(s, s);
	struct pm_frame f;

	if (!(l2 > 0.0f) || !isfinite(l2))
		return pm_frame_from_normal(n);
	f.n = n;
	f.s = pm_scale(s, 1.0f / sqrtf(l2));
	f.t = pm_cross(n, f.s);
	return f;
}

/*
 * The perturbed normal in the unperturbed frame fr, unnormalised:
 * normalmap's texel mapped from [0, 1] to [-1, 1]; bumpmap's normal of
 * the surface displaced by scale times the height field along ns (dp/du
 * and dp/dv tilted by the height's gradient), turned to the side of the
 * geometric normal.
 */
static struct pm_vec3
perturbation(const struct pm_scene *s, const struct pm_hit *h,
    const struct pm_bsdf *b, struct pm_frame fr, struct pm_vec3 dpdu,
    struct pm_vec3 dpdv)
{
	float u, v, g[2];
	struct pm_vec3 du, dv, cr;

	pm_hit_uv(s, h, &u, &v);
	if (b->tex_normal > 0) {
		struct pm_rgb c = pm_texture_eval(&s->textures[b->tex_normal - 1],
		    u, v);

		return pm_v3(2.0f * c.r - 1.0f, 2.0f * c.g - 1.0f,
		    2.0f * c.b - 1.0f);
	}
	pm_texture_grad1(&s->textures[b->tex_bump - 1], u, v, g);
	du = pm_madd(dpdu, h->ns, b->bump_scale * g[0] - pm_dot(h->ns, dpdu));
	dv = pm_madd(dpdv, h->ns, b->bump_scale * g[1] - pm_dot(h->ns, dpdv));
	cr = pm_cross(du, dv);
	if (pm_dot(h->ng, cr) < 0.0f)
		cr = pm_neg(cr);
	return pm_to_local(fr, cr);
}

/* pm_bsdf_frame_at's work for a BSDF b (pm_bsdf_at's answer) that
 * needs the tangent. */
const struct pm_bsdf *
pm_bsdf_frame_tangent(const struct pm_scene *s, const struct pm_hit *h,
    struct pm_vec3 d, const struct pm_bsdf *b, struct pm_bsdf *tmp,
    struct pm_frame *fr)
{
	struct pm_vec3 dpdu, dpdv, n, wi, st;
	float l2;

	pm_hit_dpdu(s, h, &dpdu, &dpdv);
	*fr = pm_frame_gram_schmidt(h->ns, dpdu);
	if (b->tex_normal == 0 && b->tex_bump == 0)
		return b;
	if (b != tmp)
		*tmp = *b;
	n = perturbation(s, h, tmp, *fr, dpdu, dpdv);
	wi = pm_to_local(*fr, pm_neg(d));
	if (tmp->perturb_in_twosided && wi.z < 0.0f)
		wi.z = -wi.z;	/* twosided mirrors the query first */
	/* keep the normal on the side wi arrives from (Mitsuba's
	 * flip_invalid_normals, after Schuessler et al. 2017) */
	if (!tmp->keep_invalid_normals && wi.z * pm_dot(wi, n) <= 0.0f)
		n = pm_v3(-n.x, -n.y, n.z);
	l2 = pm_dot(n, n);
	n = l2 > 0.0f && isfinite(l2) ? pm_scale(n, 1.0f / sqrtf(l2)) :
	    pm_v3(0.0f, 0.0f, 1.0f);
	/* s: the unperturbed tangent made orthogonal to n */
	st = pm_v3(1.0f - n.x * n.x, -n.x * n.y, -n.x * n.z);
	l2 = pm_dot(st, st);
	tmp->pframe.s = l2 > 0.0f && isfinite(l2) ?
	    pm_scale(st, 1.0f / sqrtf(l2)) : pm_v3(0.0f, 1.0f, 0.0f);
	tmp->pframe.n = n;
	tmp->pframe.t = pm_cross(n, tmp->pframe.s);
	tmp->perturbed = true;
	return tmp;
}
