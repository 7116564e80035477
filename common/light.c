/*
 * light.c: light selection by power, area sampling of emitting shapes, and
 * the densities that multiple importance sampling compares against.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "light.h"
#include "texture.h"

/*
 * The fraction of an environment's power (taken through the disk of the
 * bounding sphere, area pi R^2) that can reach the geometry: at most the
 * mean projected area of the surfaces over that disk.  A convex closed
 * surface of area A shows A / 4 on average, a flat one A / 2; A / 2 for
 * everything errs towards the environment.
 */
static double
env_nee_share(const struct pm_scene *s)
{
	double area = 0.0, disk = 3.14159265358979323846 * (double)s->radius *
	    (double)s->radius;
	size_t i;

	if (s->env_light < 0 || !(disk > 0.0))
		return 1.0;
	for (i = 0; i < s->nshapes; i++) {
		const struct pm_shape *sh = &s->shapes[i];

		area += sh->type == PM_SHAPE_SPHERE ? 4.0 *
		    3.14159265358979323846 * (double)sh->radius *
		    (double)sh->radius : pm_mesh_area(&sh->mesh);
	}
	return fmin(1.0, 0.5 * area / disk);
}

/* A projector's bitmap when its photons can be drawn by texel (no
 * to_uv, so that texels are the image plane's cells), else NULL. */
static const struct pm_texture *
projector_image(const struct pm_scene *s, const struct pm_light *l)
{
	const struct pm_texture *t;
	static const float id[6] = {1, 0, 0, 0, 1, 0};

	if (l->type != PM_LIGHT_PROJECTOR || l->tex <= 0)
		return NULL;
	t = &s->textures[l->tex - 1];
	if (t->type != PM_TEXTURE_BITMAP || t->rgb == NULL ||
	    (size_t)t->width * (size_t)t->height < 2 ||
	    memcmp(t->to_uv, id, sizeof(id)) != 0)
		return NULL;
	return t;
}

/*
 * Over a projector image's texels, half by their mean and half uniform:
 * photons go where the image is bright, and the uniform half keeps the
 * density positive wherever bilinear filtering spreads light into a
 * black texel's cell.
 */
static enum pm_err
texel_distrib(struct pm_distrib *d, const struct pm_texture *t, double *w,
    struct pm_error *err)
{
	size_t j, n = (size_t)t->width * (size_t)t->height;
	double total = 0.0;

	for (j = 0; j < n; j++) {
		w[j] = fmax(0.0, ((double)t->rgb[3 * j] + t->rgb[3 * j + 1] +
		    t->rgb[3 * j + 2]) / 3.0);
		if (!isfinite(w[j]))
			w[j] = 0.0;
		total += w[j];
	}
	for (j = 0; j < n; j++)
		w[j] = (total > 0.0 ? 0.5 * w[j] / total : 0.0) +
		    (total > 0.0 ? 0.5 : 1.0) / (double)n;
	return pm_distrib_init(d, w, n, err);
}

enum pm_err
pm_alias_build(struct pm_alias *t, const double *w, size_t n,
    struct pm_error *err)
{
	double *p = malloc(n * sizeof(*p)), sum = 0.0;
	uint32_t *small = malloc(n * sizeof(*small));
	uint32_t *large = malloc(n * sizeof(*large));
	size_t i, ns = 0, nl = 0, pos = 0;

	if (p == NULL || small == NULL || large == NULL) {
		free(p);
		free(small);
		free(large);
		return pm_fail(err, PM_ERR_NOMEM, "no memory for an alias table");
	}
	for (i = 0; i < n; i++)
		sum += w[i];
	for (i = 0; i < n; i++) {
		p[i] = w[i] * (double)n / sum;
		if (w[i] > 0.0)
			pos = i;
		if (p[i] < 1.0)
			small[ns++] = (uint32_t)i;
		else
			large[nl++] = (uint32_t)i;
	}
	/* Vose: each underfull bin takes its rest from an overfull one */
	while (ns > 0 && nl > 0) {
		uint32_t a = small[--ns], b = large[--nl];

		t[a].q = (float)p[a];
		t[a].alias = b;
		p[b] = (p[b] + p[a]) - 1.0;
		if (p[b] < 1.0)
			small[ns++] = b;
		else
			large[nl++] = b;
	}
	/* what rounding leaves is full, but a bin of weight zero never
	 * keeps itself */
	while (nl > 0) {
		i = large[--nl];
		t[i].q = 1.0f;
		t[i].alias = (uint32_t)i;
	}
	while (ns > 0) {
		i = small[--ns];
		t[i].q = w[i] > 0.0 ? 1.0f : 0.0f;
		t[i].alias = (uint32_t)(w[i] > 0.0 ? i : pos);
	}
	for (i = 0; i < n; i++) {
		t[i].inv_q = t[i].q > 0.0f ? (float)(1.0 / t[i].q) : 0.0f;
		t[i].inv_rest = t[i].q < 1.0f ?
		    (float)(1.0 / (1.0 - (double)t[i].q)) : 0.0f;
	}
	free(p);
	free(small);
	free(large);
	return PM_OK;
}

/*
 * Whether mesh m (its light triangles lt) is one flat parallelogram: two
 * triangles sharing two vertices, the other two opposite them (their sum
 * that of the shared two, to a millionth of the size), with equal
 * normals.  Then q is set on.
 */
static void
find_quad(const struct pm_mesh *m, const struct pm_light_tri *lt,
    struct pm_light_quad *q)
{
	const uint32_t *a = &m->idx[0], *b = &m->idx[3];
	int i, k, ua = -1, ub = -1, ns = 0;
	uint32_t s[2] = {0, 0};
	struct pm_vec3 va, vb, gap;
	float size;

	q->on = false;
	if (m->ntris != 2 || !lt[0].flat || !lt[1].flat ||
	    memcmp(&lt[0].ns, &lt[1].ns, sizeof(lt[0].ns)) != 0 ||
	    pm_dot(lt[0].n, lt[1].n) < 1.0f - 1e-6f)
		return;
	for (i = 0; i < 3; i++) {
		for (k = 0; k < 3 && b[k] != a[i]; k++)
			;
		if (k < 3 && ns < 2)
			s[ns++] = a[i];
		else
			ua = i;
	}
	for (i = 0; i < 3; i++)
		if (b[i] != s[0] && b[i] != s[1])
			ub = i;
	if (ns != 2 || ua < 0 || ub < 0)
		return;
	va = pm_mesh_vertex(m, a[ua]);
	vb = pm_mesh_vertex(m, b[ub]);
	gap = pm_sub(pm_add(va, vb), pm_add(pm_mesh_vertex(m, s[0]),
	    pm_mesh_vertex(m, s[1])));
	size = pm_length(pm_sub(vb, va));
	if (!(pm_length(gap) <= 1e-6f * size))
		return;
	q->p0 = va;
	q->e1 = pm_sub(pm_mesh_vertex(m, s[0]), va);
	q->e2 = pm_sub(pm_mesh_vertex(m, s[1]), va);
	q->n = lt[0].n;
	q->ns = lt[0].ns;
	q->f = pm_frame_from_normal(q->n);
	q->on = true;
}

enum pm_err
pm_lights_init(struct pm_lights *ls, const struct pm_scene *s,
    struct pm_error *err)
{
	double *w = NULL, env_share, total;
	size_t i, j, maxw = s->nlights;
	enum pm_err rc = PM_OK;

	ls->n = s->nlights;
	ls->tris = NULL;
	ls->nee_alias = NULL;
	ls->nee_p = NULL;
	ls->tri = NULL;
	ls->tri_alias = NULL;
	ls->tri0 = NULL;
	ls->quad = NULL;
	ls->pick.cdf = NULL;
	ls->pick.n = 0;
	ls->nee.cdf = NULL;
	ls->nee.n = 0;
	if (s->nlights == 0)
		return PM_OK;
	for (i = 0; i < s->nshapes; i++)
		if (s->shapes[i].light >= 0 && s->shapes[i].mesh.ntris > maxw)
			maxw = s->shapes[i].mesh.ntris;
	for (i = 0; i < s->nlights; i++) {
		const struct pm_texture *img = projector_image(s, &s->lights[i]);

		if (img != NULL && (size_t)img->width * (size_t)img->height > maxw)
			maxw = (size_t)img->width * (size_t)img->height;
	}
	w = calloc(maxw, sizeof(*w));
	ls->tris = calloc(s->nlights, sizeof(*ls->tris));
	if (w == NULL || ls->tris == NULL) {
		rc = pm_fail(err, PM_ERR_NOMEM, "no memory for light tables");
		goto out;
	}
	for (i = 0; i < s->nlights; i++) {
		const struct pm_light *l = &s->lights[i];

		w[i] = l->power;
	}
	rc = pm_distrib_init(&ls->pick, w, s->nlights, err);
	if (rc != PM_OK)
		goto out;
	/* For light samples, an environment's power counts only what can
	 * fall on the geometry (see light.h): the bounding sphere's disk
	 * overstates it in an open scene, where most of that disk's flux
	 * misses everything. */
	env_share = env_nee_share(s);
	for (i = 0; i < s->nlights; i++)
		w[i] = s->lights[i].power * (i == (size_t)s->env_light ?
		    env_share : 1.0);
	total = 0.0;
	for (i = 0; i < s->nlights; i++)
		total += w[i];
	for (i = 0; i < s->nlights; i++)
		w[i] = (total > 0.0 ? 0.5 * w[i] / total : 0.0) +
		    0.5 / (double)s->nlights;
	rc = pm_distrib_init(&ls->nee, w, s->nlights, err);
	if (rc != PM_OK)
		goto out;
	ls->nee_alias = calloc(s->nlights, sizeof(*ls->nee_alias));
	ls->nee_p = calloc(s->nlights, sizeof(*ls->nee_p));
	ls->tri0 = calloc(s->nlights + 1, sizeof(*ls->tri0));
	ls->quad = calloc(s->nlights, sizeof(*ls->quad));
	if (ls->nee_alias == NULL || ls->nee_p == NULL || ls->tri0 == NULL ||
	    ls->quad == NULL) {
		rc = pm_fail(err, PM_ERR_NOMEM, "no memory for light tables");
		goto out;
	}
	rc = pm_alias_build(ls->nee_alias, w, s->nlights, err);
	if (rc != PM_OK)
		goto out;
	for (i = 0; i < s->nlights; i++) {
		const struct pm_light *l = &s->lights[i];

		ls->nee_p[i] = (float)pm_distrib_prob(&ls->nee, i);
		ls->tri0[i + 1] = ls->tri0[i] + (l->type == PM_LIGHT_AREA &&
		    s->shapes[l->shape].type == PM_SHAPE_MESH ?
		    s->shapes[l->shape].mesh.ntris : 0);
	}
	if (ls->tri0[s->nlights] > 0) {
		ls->tri = calloc(ls->tri0[s->nlights], sizeof(*ls->tri));
		ls->tri_alias = calloc(ls->tri0[s->nlights],
		    sizeof(*ls->tri_alias));
		if (ls->tri == NULL || ls->tri_alias == NULL) {
			rc = pm_fail(err, PM_ERR_NOMEM,
			    "no memory for light tables");
			goto out;
		}
	}
	for (i = 0; i < s->nlights; i++) {
		const struct pm_light *l = &s->lights[i];
		const struct pm_texture *img = projector_image(s, l);
		const struct pm_mesh *m;

		if (img != NULL) {
			rc = texel_distrib(&ls->tris[i], img, w, err);
			if (rc != PM_OK)
				goto out;
			continue;
		}
		if (l->type != PM_LIGHT_AREA ||
		    s->shapes[l->shape].type != PM_SHAPE_MESH)
			continue;
		m = &s->shapes[l->shape].mesh;
		for (j = 0; j < m->ntris; j++) {
			const uint32_t *t = &m->idx[3 * j];
			struct pm_vec3 p0 = pm_mesh_vertex(m, t[0]);
			struct pm_vec3 e1 = pm_sub(pm_mesh_vertex(m, t[1]), p0);
			struct pm_vec3 e2 = pm_sub(pm_mesh_vertex(m, t[2]), p0);
			struct pm_light_tri *lt = &ls->tri[ls->tri0[i] + j];

			w[j] = 0.5 * pm_length(pm_cross(e1, e2));
			lt->p0 = p0;
			lt->e1 = e1;
			lt->e2 = e2;
			lt->n = pm_normalize(pm_cross(e1, e2));
			lt->prim = (uint32_t)j;
			lt->flat = true;
			lt->ns = lt->n;
			if (m->nrm != NULL) {
				const float *a = &m->nrm[3 * t[0]];
				const float *b = &m->nrm[3 * t[1]];
				const float *c = &m->nrm[3 * t[2]];
				struct pm_vec3 v = pm_v3(a[0], a[1], a[2]);

				/* equal vertex normals interpolate to
				 * their own direction */
				lt->flat = memcmp(a, b, 3 * sizeof(*a)) == 0 &&
				    memcmp(a, c, 3 * sizeof(*a)) == 0 &&
				    pm_length(v) > 1e-6f;
				if (lt->flat)
					lt->ns = pm_normalize(v);
			}
		}
		rc = pm_distrib_init(&ls->tris[i], w, m->ntris, err);
		if (rc != PM_OK)
			goto out;
		rc = pm_alias_build(&ls->tri_alias[ls->tri0[i]], w, m->ntris,
		    err);
		if (rc != PM_OK)
			goto out;
		if (l->tex == 0)
			find_quad(m, &ls->tri[ls->tri0[i]], &ls->quad[i]);
	}
out:
	free(w);
	if (rc != PM_OK)
		pm_lights_free(ls);
	return rc;
}

void
pm_lights_free(struct pm_lights *ls)
{
	size_t i;

	if (ls->tris != NULL)
		for (i = 0; i < ls->n; i++)
			pm_distrib_free(&ls->tris[i]);
	free(ls->tris);
	ls->tris = NULL;
	free(ls->nee_alias);
	free(ls->nee_p);
	free(ls->tri);
	free(ls->tri_alias);
	free(ls->tri0);
	free(ls->quad);
	ls->quad = NULL;
	ls->nee_alias = NULL;
	ls->nee_p = NULL;
	ls->tri = NULL;
	ls->tri_alias = NULL;
	ls->tri0 = NULL;
	pm_distrib_free(&ls->pick);
	pm_distrib_free(&ls->nee);
}

float
pm_spot_falloff(const struct pm_light *l, struct pm_vec3 w)
{
	float cos_t = pm_dot(w, l->frame.n);
	float cutoff = l->cutoff_angle * (PM_PI / 180.0f);
	float beam = l->beam_width * (PM_PI / 180.0f);
	float theta;

	if (cos_t <= cosf(cutoff))
		return 0.0f;
	if (cos_t >= cosf(beam))
		return 1.0f;
	theta = acosf(pm_fminf(cos_t, 1.0f));
	return (cutoff - theta) / (cutoff - beam);
}

struct pm_rgb
pm_light_intensity(const struct pm_scene *s, const struct pm_light *l,
    struct pm_vec3 w)
{
	struct pm_vec3 d;
	struct pm_rgb I;
	float x, y, c;

	switch (l->type) {
	case PM_LIGHT_POINT:
		return l->intensity;
	case PM_LIGHT_SPOT:
		I = pm_rgb_scale(l->intensity, pm_spot_falloff(l, w));
		if (l->tex == 0 || pm_rgb_is_black(I))
			return I;
		/* Mitsuba's projection: the cone's cutoff circle is
		 * inscribed in the unit square of uv */
		d = pm_xform_vector(&l->to_local, w);
		if (!(d.z > 0.0f))
			return pm_rgb1(0.0f);
		x = d.x / (d.z * l->tan_fov);
		y = d.y / (d.z * l->tan_fov);
		return pm_rgb_mul(I, pm_texture_eval(&s->textures[l->tex - 1],
		    0.5f + 0.5f * x, 0.5f + 0.5f * y));
	case PM_LIGHT_PROJECTOR:
		/* The perspective camera's mapping of its image plane at
		 * z = 1 (u along -x, v along -y, fov along x); Mitsuba
		 * scales the texture's value so that it is the irradiance
		 * (times pi) there: an intensity of pi E / cos^3. */
		d = pm_xform_vector(&l->to_local, w);
		if (!(d.z > 0.0f))
			return pm_rgb1(0.0f);
		x = 0.5f - 0.5f * d.x / (d.z * l->tan_fov);
		y = 0.5f - 0.5f * l->aspect * d.y / (d.z * l->tan_fov);
		if (!(x >= 0.0f && x <= 1.0f && y >= 0.0f && y <= 1.0f))
			return pm_rgb1(0.0f);
		c = d.z / pm_length(d);
		return pm_rgb_scale(pm_rgb_mul(l->intensity,
		    pm_texture_eval(&s->textures[l->tex - 1], x, y)),
		    PM_PI / (c * c * c));
	default:
		return pm_rgb1(0.0f);
	}
}

struct pm_rgb
pm_area_emitted_at(const struct pm_scene *s, const struct pm_light *l,
    const struct pm_hit *h, struct pm_vec3 w)
{
	float u, v;

	if (!(pm_dot(h->ns, w) > 0.0f))
		return pm_rgb1(0.0f);
	if (l->tex == 0)
		return l->radiance;
	pm_hit_uv(s, h, &u, &v);
	return pm_texture_eval_at(s, &s->textures[l->tex - 1], h, u, v);
}

bool
pm_lights_sample(const struct pm_lights *ls, const struct pm_scene *s,
    struct pm_vec3 ref, float u0, float u1, float u2, struct pm_light_sample *o)
{
	const struct pm_light *l;
	struct pm_vec3 d;
	float psel, d2, cos_l;
	size_t li;

	if (ls->n == 0)
		return false;
	li = pm_alias_sample(ls->nee_alias, ls->n, u0, NULL);
	l = &s->lights[li];
	psel = ls->nee_p[li];
	o->light = (int)li;
	o->delta = false;
	switch (l->type) {
	case PM_LIGHT_POINT:
	case PM_LIGHT_SPOT:
	case PM_LIGHT_PROJECTOR:
		d = pm_sub(l->position, ref);
		d2 = pm_dot(d, d);
		if (d2 <= 0.0f)
			return false;
		o->dist = sqrtf(d2);
		o->wi = pm_scale(d, 1.0f / o->dist);
		o->p = l->position;
		o->n = pm_neg(o->wi);
		o->value = pm_rgb_scale(pm_light_intensity(s, l, o->n),
		    1.0f / d2);
		o->pdf = psel;
		o->delta = true;
		return !pm_rgb_is_black(o->value);
	case PM_LIGHT_CONSTANT:
		o->wi = pm_square_to_uniform_sphere(u1, u2);
		o->dist = INFINITY;
		o->p = pm_madd(ref, o->wi, 2.0f * s->radius);
		o->n = pm_neg(o->wi);
		o->value = l->radiance;
		o->pdf = psel * pm_uniform_sphere_pdf();
		return true;
	case PM_LIGHT_ENVMAP: {
		float pdf;

		o->wi = pm_envmap_sample(l->env, u1, u2, &pdf);
		if (!(pdf > 0.0f))
			return false;
		o->dist = INFINITY;
		o->p = pm_madd(ref, o->wi, 2.0f * s->radius);
		o->n = pm_neg(o->wi);
		o->value = pm_envmap_eval(l->env, o->wi);
		o->pdf = psel * pdf;
		return !pm_rgb_is_black(o->value);
	}
	case PM_LIGHT_DIRECTIONAL:
		/* A delta in direction: the light arrives along -direction
		 * with irradiance E, whatever the point. */
		o->wi = pm_neg(l->direction);
		o->dist = INFINITY;
		o->p = pm_madd(ref, o->wi, 2.0f * s->radius);
		o->n = l->direction;
		o->value = l->intensity;
		o->pdf = psel;
		o->delta = true;
		return !pm_rgb_is_black(o->value);
	case PM_LIGHT_AREA:
		break;
	}
	{
		const struct pm_shape *sh = &s->shapes[l->shape];
		struct pm_vec3 ns;
		uint32_t prim = 0;	/* the light point's triangle and */
		float bu = 0.0f, bv = 0.0f;	/* barycentrics, for a texture */

		if (sh->type == PM_SHAPE_SPHERE) {
			struct pm_vec3 u = pm_square_to_uniform_sphere(u1, u2);

			o->p = pm_madd(sh->center, u, sh->radius);
			o->n = sh->flip_normals ? pm_neg(u) : u;
			ns = o->n;
		} else if (ls->quad[li].on) {
			const struct pm_light_quad *q = &ls->quad[li];

			o->p = pm_madd(pm_madd(q->p0, q->e1, u1), q->e2, u2);
			o->n = q->n;
			ns = q->ns;
		} else {
			const struct pm_mesh *m = &sh->mesh;
			size_t t0 = ls->tri0[li];
			const struct pm_light_tri *lt = &ls->tri[t0 +
			    pm_alias_sample(&ls->tri_alias[t0],
			    ls->tri0[li + 1] - t0, u1, &u1)];
			float b1, b2;

			pm_square_to_triangle(u1, u2, &b1, &b2);
			prim = lt->prim;
			bu = b1;
			bv = b2;
			o->p = pm_madd(pm_madd(lt->p0, lt->e1, b1), lt->e2, b2);
			o->n = lt->n;
			ns = lt->ns;
			if (!lt->flat) {
				const uint32_t *ix = &m->idx[3 * lt->prim];
				const float *nv = m->nrm;
				struct pm_vec3 sum = pm_v3(0, 0, 0);
				float bw[3] = {1.0f - b1 - b2, b1, b2};
				int k;

				for (k = 0; k < 3; k++)
					sum = pm_madd(sum, pm_v3(nv[3 * ix[k]],
					    nv[3 * ix[k] + 1], nv[3 * ix[k] + 2]), bw[k]);
				if (pm_length(sum) > 1e-6f)
					ns = pm_normalize(sum);
			}
		}
		d = pm_sub(o->p, ref);
		d2 = pm_dot(d, d);
		if (d2 <= 0.0f)
			return false;
		o->dist = sqrtf(d2);
		o->wi = pm_scale(d, 1.0f / o->dist);
		/* The density converts by the geometric normal; whether the
		 * light shines this way is decided by the shading normal, as
		 * when a ray hits the light. */
		cos_l = fabsf(pm_dot(o->n, o->wi));
		if (l->tex == 0) {
			o->value = pm_dot(ns, o->wi) < 0.0f ? l->radiance :
			    pm_rgb1(0.0f);
		} else {
			/* the light point as a hit, for its uv: only a
			 * textured light needs it */
			struct pm_hit lh;

			lh.shape = l->shape;
			lh.prim = prim;
			lh.u = bu;
			lh.v = bv;
			lh.p = o->p;
			lh.ns = ns;
			o->value = pm_area_emitted_at(s, l, &lh, pm_neg(o->wi));
		}
		if (cos_l <= 0.0f || pm_rgb_is_black(o->value))
			return false;
		o->pdf = psel * d2 / (cos_l * (float)l->area);
		return true;
	}
}

/*
 * pm_lights_sample_n: the parallelogram case of pm_lights_sample, its
 * operations in its order (a dot product's adds left to right, the
 * direction scaled by the distance's reciprocal), four points a lane,
 * so that each point gets the bits the scalar code gives; IEEE square
 * root and division are exact in SIMD as in scalar code, and nothing is
 * fused into an FMA (-ffp-contract=off).  In a path-traced Cornell box
 * the scalar light sample, one chain of dependent arithmetic with a
 * square root and two divisions in it, was an eighth of the time.
 */
#if (defined(__x86_64__) || defined(__i386__)) && defined(__SSE2__) && \
    (defined(__GNUC__) || defined(__clang__)) && !defined(PM_NO_SIMD)
#include <immintrin.h>

static size_t
quad_lanes(const struct pm_lights *ls, const struct pm_scene *s,
    struct pm_light_lanes *ll, size_t n)
{
	const struct pm_light *l = &s->lights[0];
	const struct pm_light_quad *q = &ls->quad[0];
	const float psel = ls->nee_p[0], area = (float)l->area;
	const __m128 zero = _mm_setzero_ps(), one = _mm_set1_ps(1.0f);
	const __m128 sign = _mm_set1_ps(-0.0f);
	const float *p0 = &q->p0.x, *e1 = &q->e1.x, *e2 = &q->e2.x;
	const float *rad = &l->radiance.r;
	size_t i;
	int a;

	for (i = 0; i + 4 <= n; i += 4) {
		__m128 u1 = _mm_loadu_ps(ll->u[1] + i);
		__m128 u2 = _mm_loadu_ps(ll->u[2] + i);
		__m128 p[3], d[3], d2, r, inv, c, cs, good, front;

		for (a = 0; a < 3; a++) {
			p[a] = _mm_add_ps(_mm_add_ps(_mm_set1_ps(p0[a]),
			    _mm_mul_ps(_mm_set1_ps(e1[a]), u1)),
			    _mm_mul_ps(_mm_set1_ps(e2[a]), u2));
			d[a] = _mm_sub_ps(p[a], _mm_loadu_ps(ll->ref[a] + i));
		}
		d2 = _mm_add_ps(_mm_add_ps(_mm_mul_ps(d[0], d[0]),
		    _mm_mul_ps(d[1], d[1])), _mm_mul_ps(d[2], d[2]));
		r = _mm_sqrt_ps(d2);
		inv = _mm_div_ps(one, r);
		for (a = 0; a < 3; a++)
			d[a] = _mm_mul_ps(d[a], inv);	/* now wi */
		c = _mm_add_ps(_mm_add_ps(
		    _mm_mul_ps(_mm_set1_ps(q->n.x), d[0]),
		    _mm_mul_ps(_mm_set1_ps(q->n.y), d[1])),
		    _mm_mul_ps(_mm_set1_ps(q->n.z), d[2]));
		c = _mm_andnot_ps(sign, c);	/* cos_l */
		cs = _mm_add_ps(_mm_add_ps(
		    _mm_mul_ps(_mm_set1_ps(q->ns.x), d[0]),
		    _mm_mul_ps(_mm_set1_ps(q->ns.y), d[1])),
		    _mm_mul_ps(_mm_set1_ps(q->ns.z), d[2]));
		/* the scalar tests: d2 > 0, the light's front (ns . wi < 0),
		 * cos_l > 0; a NaN fails each as it does there */
		front = _mm_cmpgt_ps(d2, zero);
		good = _mm_and_ps(_mm_and_ps(front, _mm_cmplt_ps(cs, zero)),
		    _mm_cmpgt_ps(c, zero));
		_mm_storeu_ps(ll->pdf + i, _mm_div_ps(_mm_mul_ps(
		    _mm_set1_ps(psel), d2), _mm_mul_ps(c, _mm_set1_ps(area))));
		_mm_storeu_ps(ll->dist + i, r);
		for (a = 0; a < 3; a++) {
			_mm_storeu_ps(ll->wi[a] + i, d[a]);
			_mm_storeu_ps(ll->p[a] + i, p[a]);
			/* the radiance where the light shines this way, zero
			 * behind it (the scalar value, where d2 > 0) */
			_mm_storeu_ps(ll->value[a] + i,
			    _mm_and_ps(good, _mm_set1_ps(rad[a])));
		}
		_mm_storeu_si128((__m128i *)(ll->ok + i), _mm_castps_si128(good));
		_mm_storeu_si128((__m128i *)(ll->delta + i), _mm_setzero_si128());
		for (a = 0; a < 4; a++)
			ll->ok[i + (size_t)a] &= ll->want[i + (size_t)a] ? -1 : 0;
	}
	return i;
}
#else
static size_t
quad_lanes(const struct pm_lights *ls, const struct pm_scene *s,
    struct pm_light_lanes *ll, size_t n)
{
	(void)ls, (void)s, (void)ll, (void)n;
	return 0;
}
#endif

void
pm_lights_sample_n(const struct pm_lights *ls, const struct pm_scene *s,
    struct pm_light_lanes *ll, size_t n)
{
	size_t i = 0;

	/* one light, a flat untextured parallelogram that shines */
	if (ls->n == 1 && s->lights[0].type == PM_LIGHT_AREA &&
	    s->shapes[s->lights[0].shape].type != PM_SHAPE_SPHERE &&
	    ls->quad[0].on && !pm_rgb_is_black(s->lights[0].radiance))
		i = quad_lanes(ls, s, ll, n);
	for (; i < n; i++) {
		struct pm_light_sample o;
		bool ok = ll->want[i] && pm_lights_sample(ls, s,
		    pm_v3(ll->ref[0][i], ll->ref[1][i], ll->ref[2][i]),
		    ll->u[0][i], ll->u[1][i], ll->u[2][i], &o);
		int a;

		if (!ok)
			memset(&o, 0, sizeof(o));
		for (a = 0; a < 3; a++) {
			ll->wi[a][i] = (&o.wi.x)[a];
			ll->p[a][i] = (&o.p.x)[a];
		}
		ll->value[0][i] = o.value.r;
		ll->value[1][i] = o.value.g;
		ll->value[2][i] = o.value.b;
		ll->dist[i] = o.dist;
		ll->pdf[i] = o.pdf;
		ll->delta[i] = o.delta ? -1 : 0;
		ll->ok[i] = ok ? -1 : 0;
	}
}

float
pm_lights_pdf_area(const struct pm_lights *ls, const struct pm_scene *s,
    int light, struct pm_vec3 ref, struct pm_vec3 p, struct pm_vec3 n)
{
	const struct pm_light *l = &s->lights[light];
	struct pm_vec3 d = pm_sub(p, ref);
	float d2 = pm_dot(d, d);
	float cos_l = fabsf(pm_dot(n, d)) / sqrtf(d2);

	if (cos_l <= 0.0f || d2 <= 0.0f)
		return 0.0f;
	return (float)pm_distrib_prob(&ls->nee, (size_t)light) * d2 /
	    (cos_l * (float)l->area);
}

float
pm_lights_pdf_env(const struct pm_lights *ls, const struct pm_scene *s,
    struct pm_vec3 w)
{
	const struct pm_light *l;

	if (s->env_light < 0)
		return 0.0f;
	l = &s->lights[s->env_light];
	return (float)pm_distrib_prob(&ls->nee, (size_t)s->env_light) *
	    (l->type == PM_LIGHT_ENVMAP ? pm_envmap_pdf(l->env, w) :
	    pm_uniform_sphere_pdf());
}

struct pm_rgb
pm_lights_env_radiance(const struct pm_scene *s, struct pm_vec3 w)
{
	const struct pm_light *l;

	if (s->env_light < 0)
		return pm_rgb1(0.0f);
	l = &s->lights[s->env_light];
	return l->type == PM_LIGHT_ENVMAP ? pm_envmap_eval(l->env, w) :
	    l->radiance;
}

bool
pm_light_occluded(const struct pm_accel *a, const struct pm_hit *h,
    const struct pm_light_sample *ls)
{
	struct pm_ray r;

	if (!pm_light_shadow_ray(h, ls, &r))
		return false;
	return pm_accel_occluded(a, r.o, r.d, r.tmin, r.tmax);
}

struct pm_rgb
pm_lights_emitted(const struct pm_lights *ls, const struct pm_scene *s,
    const struct pm_hit *h, struct pm_vec3 d, struct pm_vec3 prev_p,
    float prev_pdf, bool prev_delta)
{
	struct pm_rgb Le;
	int light;
	float w;

	if (h == NULL) {
		if (s->env_light < 0)
			return pm_rgb1(0.0f);
		Le = pm_lights_env_radiance(s, d);
		if (pm_rgb_is_black(Le))
			return Le;
		w = prev_delta ? 1.0f :
		    pm_power_heuristic(prev_pdf, pm_lights_pdf_env(ls, s, d));
		return pm_rgb_scale(Le, w);
	}
	light = s->shapes[h->shape].light;
	if (light < 0)
		return pm_rgb1(0.0f);
	Le = pm_area_emitted_at(s, &s->lights[light], h, pm_neg(d));
	if (pm_rgb_is_black(Le))
		return Le;
	w = prev_delta ? 1.0f : pm_power_heuristic(prev_pdf,
	    pm_lights_pdf_area(ls, s, light, prev_p, h->p, h->ng));
	return pm_rgb_scale(Le, w);
}
