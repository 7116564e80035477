/*
 * medium.c: phase functions, transmittance and free-flight sampling of
 * the homogeneous medium (medium.h says which estimator and why).
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

#include "scene.h"

#define INV_4PI 0.0795774715459476679f

/* Below this |g| the Henyey-Greenstein inversion loses its digits to
 * cancellation; the function is then isotropic to within 3|g|. */
#define HG_ISOTROPIC_G 1e-3f

float
pm_phase_eval(const struct pm_phase *ph, struct pm_vec3 d, struct pm_vec3 wo)
{
	float g, den;

	if (ph->type == PM_PHASE_ISOTROPIC)
		return INV_4PI;
	g = ph->g;
	den = 1.0f + g * g - 2.0f * g * pm_dot(d, wo);
	den = pm_fmaxf(den, 1e-12f);
	return INV_4PI * (1.0f - g * g) / (den * sqrtf(den));
}

struct pm_vec3
pm_phase_sample(const struct pm_phase *ph, struct pm_vec3 d, float u1,
    float u2, float *pdf)
{
	struct pm_frame fr = pm_frame_from_normal(d);
	float c, s, phi, g = ph->g, q;
	struct pm_vec3 wo;

	if (ph->type == PM_PHASE_ISOTROPIC || fabsf(g) < HG_ISOTROPIC_G) {
		c = 1.0f - 2.0f * u1;
	} else {
		/* Inverting the cumulative distribution of cos theta. */
		q = (1.0f - g * g) / (1.0f - g + 2.0f * g * u1);
		c = (1.0f + g * g - q * q) / (2.0f * g);
	}
	c = pm_fminf(pm_fmaxf(c, -1.0f), 1.0f);
	s = sqrtf(pm_fmaxf(0.0f, 1.0f - c * c));
	phi = 2.0f * PM_PI * u2;
	wo = pm_normalize(pm_to_world(fr, pm_v3(s * cosf(phi), s * sinf(phi), c)));
	*pdf = pm_phase_eval(ph, d, wo);
	return wo;
}

static inline float
chan(struct pm_rgb c, int i)
{
	return i == 0 ? c.r : i == 1 ? c.g : c.b;
}

/* exp(-sigma t) with a clear medium clear at any distance. */
static inline float
tr1(float sigma, float t)
{
	return sigma > 0.0f ? expf(-sigma * t) : 1.0f;
}

struct pm_rgb
pm_medium_transmittance(const struct pm_medium *m, float t)
{
	return pm_rgb(tr1(m->sigma_t.r, t), tr1(m->sigma_t.g, t),
	    tr1(m->sigma_t.b, t));
}

void
pm_medium_sample(const struct pm_medium *m, float tmax, int channel, float u,
    struct pm_medium_sample *out)
{
	float sc = chan(m->sigma_t, channel < 0 ? 0 : channel > 2 ? 2 : channel);
	float t = sc > 0.0f ? -log1pf(-u) / sc : INFINITY;
	struct pm_rgb tr;

	if (t < tmax) {
		tr = pm_medium_transmittance(m, t);
		out->scattered = true;
		out->t = t;
		out->f = pm_rgb_mul(tr, pm_rgb_mul(m->sigma_t, m->albedo));
		out->pdf = pm_rgb_mul(tr, m->sigma_t);
		return;
	}
	tr = pm_medium_transmittance(m, tmax);
	out->scattered = false;
	out->t = tmax;
	out->f = tr;
	out->pdf = tr;		/* the chance of flying past tmax */
}

/* ------------------------------------------------ heterogeneous media */

void
pm_grid_free(struct pm_grid *g)
{
	free(g->data);
	g->data = NULL;
}

void
pm_medium_release(struct pm_medium *m)
{
	if (m->het == NULL)
		return;
	pm_grid_free(&m->het->sigma_t.grid);
	pm_grid_free(&m->het->albedo.grid);
	free(m->het->maj);
	free(m->het->mino);
	free(m->het->res);
	free(m->het);
	m->het = NULL;
}

/* Index i of n under a wrap mode (Dr.Jit's texture rules, which
 * Mitsuba's gridvolume uses): clamp to the edge, repeat with period n,
 * or mirror with period 2n. */
static inline int
wrap_index(int i, int n, enum pm_vol_wrap w)
{
	switch (w) {
	case PM_VOL_REPEAT:
		i %= n;
		return i < 0 ? i + n : i;
	case PM_VOL_MIRROR:
		if (i < 0)
			i = -i - 1;
		{
			int q = i / n, r = i - q * n;

			return (q & 1) ? n - 1 - r : r;
		}
	case PM_VOL_CLAMP:
	default:
		return i < 0 ? 0 : i >= n ? n - 1 : i;
	}
}

/* A coordinate of the unit cube, scaled to voxels, kept where floorf's
 * result fits an int (a point far outside wraps or clamps the same). */
static inline float
voxel_coord(float u, int n)
{
	float x = u * (float)n;

	return x > 1e7f ? 1e7f : x < -1e7f ? -1e7f : x == x ? x : 0.0f;
}

static inline struct pm_rgb
voxel(const struct pm_grid *g, int x, int y, int z)
{
	const float *v = g->data + (((size_t)z * (size_t)g->ny + (size_t)y) *
	    (size_t)g->nx + (size_t)x) * (size_t)g->nch;

	return g->nch == 1 ? pm_rgb1(v[0]) : pm_rgb(v[0], v[1], v[2]);
}

struct pm_rgb
pm_volume_eval(const struct pm_volume *v, struct pm_vec3 p)
{
	const struct pm_grid *g = &v->grid;
	struct pm_vec3 q;
	float fx, fy, fz, wx, wy, wz;
	int x0, y0, z0, x1, y1, z1;
	struct pm_rgb a, b, c, d;

	if (g->data == NULL)
		return v->value;
	q = pm_xform_point(&v->to_local, p);
	fx = voxel_coord(q.x, g->nx);
	fy = voxel_coord(q.y, g->ny);
	fz = voxel_coord(q.z, g->nz);
	if (v->nearest)
		return voxel(g, wrap_index((int)floorf(fx), g->nx, v->wrap),
		    wrap_index((int)floorf(fy), g->ny, v->wrap),
		    wrap_index((int)floorf(fz), g->nz, v->wrap));
	/* Voxel centres lie at half-integers: interpolate between the two
	 * centres about each coordinate. */
	fx -= 0.5f;
	fy -= 0.5f;
	fz -= 0.5f;
	x0 = (int)floorf(fx);
	y0 = (int)floorf(fy);
	z0 = (int)floorf(fz);
	wx = fx - (float)x0;
	wy = fy - (float)y0;
	wz = fz - (float)z0;
	x1 = wrap_index(x0 + 1, g->nx, v->wrap);
	y1 = wrap_index(y0 + 1, g->ny, v->wrap);
	z1 = wrap_index(z0 + 1, g->nz, v->wrap);
	x0 = wrap_index(x0, g->nx, v->wrap);
	y0 = wrap_index(y0, g->ny, v->wrap);
	z0 = wrap_index(z0, g->nz, v->wrap);
	a = pm_rgb_add(pm_rgb_scale(voxel(g, x0, y0, z0), 1.0f - wx),
	    pm_rgb_scale(voxel(g, x1, y0, z0), wx));
	b = pm_rgb_add(pm_rgb_scale(voxel(g, x0, y1, z0), 1.0f - wx),
	    pm_rgb_scale(voxel(g, x1, y1, z0), wx));
	c = pm_rgb_add(pm_rgb_scale(voxel(g, x0, y0, z1), 1.0f - wx),
	    pm_rgb_scale(voxel(g, x1, y0, z1), wx));
	d = pm_rgb_add(pm_rgb_scale(voxel(g, x0, y1, z1), 1.0f - wx),
	    pm_rgb_scale(voxel(g, x1, y1, z1), wx));
	a = pm_rgb_add(pm_rgb_scale(a, 1.0f - wy), pm_rgb_scale(b, wy));
	c = pm_rgb_add(pm_rgb_scale(c, 1.0f - wy), pm_rgb_scale(d, wy));
	return pm_rgb_add(pm_rgb_scale(a, 1.0f - wz), pm_rgb_scale(c, wz));
}

struct pm_rgb
pm_medium_sigma_t_at(const struct pm_medium *m, struct pm_vec3 p)
{
	const struct pm_hetero *h = m->het;

	if (h == NULL)
		return m->sigma_t;
	if (p.x < h->lo.x || p.y < h->lo.y || p.z < h->lo.z ||
	    p.x > h->hi.x || p.y > h->hi.y || p.z > h->hi.z)
		return pm_rgb1(0.0f);
	return pm_rgb_scale(pm_volume_eval(&h->sigma_t, p), h->scale);
}

struct pm_rgb
pm_medium_albedo_at(const struct pm_medium *m, struct pm_vec3 p)
{
	return m->het == NULL ? m->albedo : pm_volume_eval(&m->het->albedo, p);
}

/* Clips [*t0, *t1] of o + t d to the medium's box; false if nothing is
 * left (slab test; an axis d leaves parallel keeps the ray or drops it
 * whole). */
static bool
clip_box(const struct pm_hetero *h, struct pm_vec3 o, struct pm_vec3 d,
    double *t0, double *t1)
{
	const float oo[3] = {o.x, o.y, o.z}, dd[3] = {d.x, d.y, d.z};
	const float lo[3] = {h->lo.x, h->lo.y, h->lo.z};
	const float hi[3] = {h->hi.x, h->hi.y, h->hi.z};
	double a = *t0, b = *t1, n, f, inv;
	int k;

	for (k = 0; k < 3; k++) {
		if (dd[k] == 0.0f) {
			if (oo[k] < lo[k] || oo[k] > hi[k])
				return false;
			continue;
		}
		inv = 1.0 / (double)dd[k];
		n = ((double)lo[k] - oo[k]) * inv;
		f = ((double)hi[k] - oo[k]) * inv;
		if (n > f) {
			double tmp = n;

			n = f;
			f = tmp;
		}
		a = n > a ? n : a;
		b = f < b ? f : b;
	}
	*t0 = a;
	*t1 = b;
	return a < b;
}

/* Bound on the tentative collisions of one flight, against a majorant
 * absurdly large for the distance: past it the path ends (weight 0). */
#define MAX_COLLISIONS (1 << 24)

/*
 * The majorant grid: sigma_t's voxels in blocks of PM_MAJ_BLOCK per axis,
 * each cell holding scale times the largest value a lookup inside it can
 * return (trilinear lookups reach one voxel beyond the block, wrapped as
 * the volume wraps).  Only for grids whose to_world has no rotation, so
 * that the unit cube is the medium's box and cells are axis-aligned
 * there; otherwise the global majorant serves alone.
 */
#define PM_MAJ_BLOCK 8

bool
pm_hetero_prepare(struct pm_hetero *h)
{
	const struct pm_volume *v = &h->sigma_t;
	const struct pm_grid *g = &v->grid;
	const int nv[3] = {g->nx, g->ny, g->nz};
	int n[3], c[3], a, b, k, x, y, z;
	size_t cells;

	free(h->maj);
	free(h->mino);
	free(h->res);
	h->maj = h->mino = h->res = NULL;
	if (g->data == NULL)
		return true;
	for (a = 0; a < 3; a++)
		for (b = 0; b < 3; b++)
			if (a != b && v->to_local.m[a][b] != 0.0f)
				return true;
	for (k = 0; k < 3; k++)
		n[k] = (nv[k] + PM_MAJ_BLOCK - 1) / PM_MAJ_BLOCK;
	cells = (size_t)n[0] * (size_t)n[1] * (size_t)n[2];
	h->maj = malloc(cells * sizeof(float));
	h->mino = malloc(cells * 3 * sizeof(float));
	h->res = malloc(cells * sizeof(float));
	if (h->maj == NULL || h->mino == NULL || h->res == NULL) {
		free(h->maj);
		free(h->mino);
		free(h->res);
		h->maj = h->mino = h->res = NULL;
		return false;
	}
	for (c[2] = 0; c[2] < n[2]; c[2]++)
		for (c[1] = 0; c[1] < n[1]; c[1]++)
			for (c[0] = 0; c[0] < n[0]; c[0]++) {
				int lo[3], hi[3];
				float mx = 0.0f, cmin[3] = {INFINITY, INFINITY,
				    INFINITY}, cmax[3] = {0.0f, 0.0f, 0.0f}, r;
				size_t ci;

				for (k = 0; k < 3; k++) {
					lo[k] = c[k] * PM_MAJ_BLOCK - 1;
					hi[k] = (c[k] + 1) * PM_MAJ_BLOCK;
					if (hi[k] > nv[k])
						hi[k] = nv[k];
				}
				for (z = lo[2]; z <= hi[2]; z++)
					for (y = lo[1]; y <= hi[1]; y++)
						for (x = lo[0]; x <= hi[0]; x++) {
							struct pm_rgb q = voxel(g,
							    wrap_index(x, g->nx, v->wrap),
							    wrap_index(y, g->ny, v->wrap),
							    wrap_index(z, g->nz, v->wrap));

							mx = pm_fmaxf(mx, pm_rgb_max(q));
							cmin[0] = pm_fminf(cmin[0], q.r);
							cmin[1] = pm_fminf(cmin[1], q.g);
							cmin[2] = pm_fminf(cmin[2], q.b);
							cmax[0] = pm_fmaxf(cmax[0], q.r);
							cmax[1] = pm_fmaxf(cmax[1], q.g);
							cmax[2] = pm_fmaxf(cmax[2], q.b);
						}
				ci = ((size_t)c[2] * (size_t)n[1] + (size_t)c[1]) *
				    (size_t)n[0] + (size_t)c[0];
				h->maj[ci] = h->scale * mx;
				r = 0.0f;
				for (k = 0; k < 3; k++) {
					/* a voxel's value is never below the
					 * least, nor are lookups: they are convex
					 * combinations of voxels */
					h->mino[3 * ci + (size_t)k] = h->scale *
					    cmin[k];
					r = pm_fmaxf(r, h->scale * cmax[k] -
					    h->scale * cmin[k]);
				}
				/* rounding of the interpolation: a hair of
				 * headroom keeps the residual ratios >= 0 */
				h->res[ci] = r > 0.0f ? r * (1.0f + 1e-5f) +
				    1e-7f * h->maj[ci] : 0.0f;
			}
	for (k = 0; k < 3; k++)
		h->nmaj[k] = n[k];
	return true;
}

/*
 * A walk along the ray's part in the medium, cell by cell of the
 * majorant grid (Amanatides and Woo's traversal, in the unit cube's
 * coordinates, where the ray keeps its parameter t), or as one segment
 * under the global majorant.
 */
struct walk {
	const struct pm_hetero *h;
	double t, t1;
	int i[3], step[3];
	double tnext[3], dt[3];
	bool grid, done;
	size_t cell;		/* the last segment's cell; SIZE_MAX: none */
};

static bool
walk_init(struct walk *w, const struct pm_hetero *h, struct pm_vec3 o,
    struct pm_vec3 d, float tmin, float tmax)
{
	struct pm_vec3 ol, dl;
	double oo[3], dd[3], cs, p;
	int k;

	w->h = h;
	w->t = tmin;
	w->t1 = tmax;
	w->done = false;
	w->grid = h->maj != NULL && !h->no_maj_grid;
	if (!(h->majorant > 0.0f) || !clip_box(h, o, d, &w->t, &w->t1))
		return false;
	if (!w->grid)
		return true;
	ol = pm_xform_point(&h->sigma_t.to_local, o);
	dl = pm_xform_vector(&h->sigma_t.to_local, d);
	oo[0] = ol.x, oo[1] = ol.y, oo[2] = ol.z;
	dd[0] = dl.x, dd[1] = dl.y, dd[2] = dl.z;
	for (k = 0; k < 3; k++) {
		int nv = k == 0 ? h->sigma_t.grid.nx : k == 1 ?
		    h->sigma_t.grid.ny : h->sigma_t.grid.nz;

		cs = (double)PM_MAJ_BLOCK / nv;	/* a cell, in the cube */
		p = oo[k] + w->t * dd[k];
		w->i[k] = (int)floor(p / cs);
		if (w->i[k] < 0)
			w->i[k] = 0;
		if (w->i[k] >= h->nmaj[k])
			w->i[k] = h->nmaj[k] - 1;
		if (dd[k] > 0.0) {
			w->step[k] = 1;
			w->tnext[k] = ((w->i[k] + 1) * cs - oo[k]) / dd[k];
			w->dt[k] = cs / dd[k];
		} else if (dd[k] < 0.0) {
			w->step[k] = -1;
			w->tnext[k] = (w->i[k] * cs - oo[k]) / dd[k];
			w->dt[k] = -cs / dd[k];
		} else {
			w->step[k] = 0;
			w->tnext[k] = INFINITY;
			w->dt[k] = INFINITY;
		}
	}
	return true;
}

/* The next segment [*a, *b) and its majorant; false past the end. */
static bool
walk_next(struct walk *w, double *a, double *b, float *maj)
{
	int k;

	if (w->done)
		return false;
	*a = w->t;
	if (!w->grid) {
		*b = w->t1;
		*maj = w->h->majorant;
		w->cell = SIZE_MAX;
		w->done = true;
		return true;
	}
	k = w->tnext[0] < w->tnext[1] ? (w->tnext[0] < w->tnext[2] ? 0 : 2) :
	    (w->tnext[1] < w->tnext[2] ? 1 : 2);
	*b = w->tnext[k] < w->t1 ? w->tnext[k] : w->t1;
	w->cell = ((size_t)w->i[2] * (size_t)w->h->nmaj[1] +
	    (size_t)w->i[1]) * (size_t)w->h->nmaj[0] + (size_t)w->i[0];
	*maj = w->h->maj[w->cell];
	w->t = *b;
	if (!(w->tnext[k] < w->t1)) {
		w->done = true;
	} else {
		w->i[k] += w->step[k];
		w->tnext[k] += w->dt[k];
		if (w->i[k] < 0 || w->i[k] >= w->h->nmaj[k])
			w->done = true;
	}
	if (*b < *a)
		*b = *a;
	return true;
}

static inline float
chan_of(struct pm_rgb c, int i)
{
	return i == 0 ? c.r : i == 1 ? c.g : c.b;
}

/* sigma_n / majorant per channel, never negative. */
static inline struct pm_rgb
null_ratio(struct pm_rgb st, float maj)
{
	return pm_rgb(pm_fmaxf(0.0f, 1.0f - st.r / maj),
	    pm_fmaxf(0.0f, 1.0f - st.g / maj), pm_fmaxf(0.0f, 1.0f - st.b / maj));
}

void
pm_medium_sample_ray(const struct pm_medium *m, struct pm_vec3 o,
    struct pm_vec3 d, float tmin, float tmax, int channel, struct pm_rng *rng,
    struct pm_medium_sample *out)
{
	const struct pm_hetero *h = m->het;
	struct pm_rgb f = pm_rgb1(1.0f), pdf = pm_rgb1(1.0f), st;
	struct walk w;
	double t, a, b;
	float maj, mx;
	long n = 0;

	if (h == NULL) {
		pm_medium_sample(m, tmax - tmin, channel, pm_rng_float(rng), out);
		return;
	}
	channel = channel < 0 ? 0 : channel > 2 ? 2 : channel;
	out->scattered = false;
	out->t = tmax - tmin;
	if (walk_init(&w, h, o, d, tmin, tmax))
		while (walk_next(&w, &a, &b, &maj)) {
			if (!(maj > 0.0f))
				continue;	/* a clear cell */
			/* Exponential steps are memoryless: a fresh one
			 * starts at each cell's entry. */
			for (t = a;; n++) {
				struct pm_vec3 p;

				if (n >= MAX_COLLISIONS) {
					f = pm_rgb1(0.0f);
					goto done;
				}
				t -= log1p(-(double)pm_rng_float(rng)) / maj;
				if (!(t < b))
					break;
				p = pm_madd(o, d, (float)t);
				st = pm_medium_sigma_t_at(m, p);
				if (pm_rng_float(rng) * maj < chan_of(st, channel)) {
					f = pm_rgb_mul(f, pm_rgb_scale(pm_rgb_mul(st,
					    pm_medium_albedo_at(m, p)), 1.0f / maj));
					pdf = pm_rgb_mul(pdf, pm_rgb_scale(st,
					    1.0f / maj));
					out->scattered = true;
					out->t = (float)(t - tmin);
					goto done;
				}
				st = null_ratio(st, maj);
				f = pm_rgb_mul(f, st);
				pdf = pm_rgb_mul(pdf, st);
				/* Only ratios of f and pdf matter: keep them
				 * in range along long chains of nulls. */
				mx = pm_rgb_max(pdf);
				if (mx < 1e-20f && mx > 0.0f) {
					f = pm_rgb_scale(f, 1.0f / mx);
					pdf = pm_rgb_scale(pdf, 1.0f / mx);
				}
			}
		}
done:
	out->f = f;
	out->pdf = pdf;
}

struct pm_rgb
pm_medium_transmittance_ray(const struct pm_medium *m, struct pm_vec3 o,
    struct pm_vec3 d, float tmin, float tmax, struct pm_rng *rng)
{
	const struct pm_hetero *h = m->het;
	struct pm_rgb tr = pm_rgb1(1.0f);
	struct walk w;
	double t, a, b;
	float maj, mx;
	long n = 0;

	if (h == NULL)
		return pm_medium_transmittance(m, tmax - tmin);
	if (!walk_init(&w, h, o, d, tmin, tmax))
		return tr;
	while (walk_next(&w, &a, &b, &maj)) {
		struct pm_rgb ctl = pm_rgb1(0.0f), st;

		if (!(maj > 0.0f))
			continue;
		if (w.cell != SIZE_MAX && h->mino != NULL) {
			/* residual ratio tracking: the control exactly */
			const float *mn = h->mino + 3 * w.cell;

			ctl = pm_rgb(mn[0], mn[1], mn[2]);
			tr = pm_rgb_mul(tr, pm_rgb((float)exp(-(double)ctl.r *
			    (b - a)), (float)exp(-(double)ctl.g * (b - a)),
			    (float)exp(-(double)ctl.b * (b - a))));
			maj = h->res[w.cell];
			if (!(maj > 0.0f))
				continue;	/* constant in the cell */
		}
		for (t = a;; n++) {
			if (n >= MAX_COLLISIONS)
				return pm_rgb1(0.0f);
			t -= log1p(-(double)pm_rng_float(rng)) / maj;
			if (!(t < b))
				break;
			st = pm_medium_sigma_t_at(m, pm_madd(o, d, (float)t));
			/* sigma_t is never below the control but for
			 * rounding (and a point rounded out of the box,
			 * where it reads 0): such a ratio stays 1 */
			tr = pm_rgb_mul(tr, null_ratio(pm_rgb(pm_fmaxf(0.0f,
			    st.r - ctl.r), pm_fmaxf(0.0f, st.g - ctl.g),
			    pm_fmaxf(0.0f, st.b - ctl.b)), maj));
			/* Russian roulette once little is left (weights 1/q
			 * keep the estimate unbiased). */
			mx = pm_rgb_max(tr);
			if (mx < 0.1f) {
				if (!(mx > 0.0f) || pm_rng_float(rng) >= 0.5f)
					return pm_rgb1(0.0f);
				tr = pm_rgb_scale(tr, 2.0f);
			}
		}
	}
	return tr;
}
