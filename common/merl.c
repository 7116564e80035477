/*
 * merl.c: evaluation and importance sampling of MERL-layout measured BRDFs.
 *
 * Lookup follows the reference reader's parameterisation: the half vector
 * h of (wi, wo) gives theta_h; wi expressed in h's frame (rotated about z
 * by -phi_h, then about y by -theta_h) gives theta_d and phi_d, the latter
 * folded into [0, pi) by reciprocity.  Indices: theta_h on a square-root
 * axis, the other two linear.  Interpolation is trilinear in index space
 * between the bins' centres, so on the theta_h axis the weights are linear
 * in sqrt(theta_h), not in theta_h; phi_d wraps around (phi_d and
 * phi_d + pi are the same sample by reciprocity), the theta axes clamp.
 *
 * Sampling is data driven.  For each of PM_MERL_NTI bins of wi's polar
 * angle, a table over the half vector: theta_h in MERL's own square-root
 * bins, by PM_MERL_NPH bins of azimuth relative to wi, each cell uniform
 * in solid angle, its probability the integral of the luminance of
 * f_r cos(theta_o) over the directions wo its half vectors reflect wi to
 * (the Jacobian |dwo/dh| = 4 |wo.h| included).  Cosine sampling is mixed
 * in (20%) so that nothing the table missed has zero density.  The same
 * integration gives the directional albedo per channel.
 *
 * At the end, the analytic models formats/merl.c's writer tabulates: the
 * metal and the plastic's coat reuse bsdf.c's GGX rough conductor (with
 * k = 0 its Fresnel term is the dielectric one).
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "bsdf.h"
#include "merl.h"
#include "sampling.h"

#define HALF_PI 1.57079632679489661923
#define DATA_FRAC 0.8f
/* A material whose peak f_r exceeds this many times the Lambertian one of
 * the same albedo is glossy: its highlights are traced, not estimated. */
#define GLOSSY_RATIO 4.0f

static size_t
cell(int k, int i)
{
	return ((size_t)k * PM_MERL_NTH + (size_t)i) * (PM_MERL_NPH + 1);
}

/* A zeroed table; NULL when out of memory. */
struct pm_merl *
pm_merl_new(struct pm_error *err)
{
	struct pm_merl *m = calloc(1, sizeof(*m));

	if (m == NULL || (m->f = calloc(3 * (size_t)PM_MERL_N,
	    sizeof(float))) == NULL) {
		free(m);
		pm_fail(err, PM_ERR_NOMEM, "no memory for a MERL table (%zu "
		    "bytes)", 3 * (size_t)PM_MERL_N * sizeof(float));
		return NULL;
	}
	return m;
}

/* Frees m and what it owns. */
void
pm_merl_free(struct pm_merl *m)
{
	if (m == NULL)
		return;
	free(m->f);
	free(m->path);
	free(m->row_cdf);
	free(m->col_cdf);
	free(m);
}

/* The half/difference angles; false below the horizon. */
bool
pm_merl_angles(struct pm_vec3 wi, struct pm_vec3 wo, float *theta_h,
    float *theta_d, float *phi_d)
{
	struct pm_vec3 h;
	float len, r, cp, sp, dx, dy, dz;

	if (!(wi.z > 0.0f && wo.z > 0.0f))
		return false;
	h = pm_add(wi, wo);
	len = pm_length(h);
	if (!(len > 0.0f))
		return false;
	h = pm_scale(h, 1.0f / len);
	r = sqrtf(h.x * h.x + h.y * h.y);
	/* atan2 rather than acos: acos loses everything near the pole,
	 * where the square-root axis puts its finest bins */
	*theta_h = atan2f(r, h.z);
	if (r > 0.0f) {
		cp = h.x / r;
		sp = h.y / r;
	} else {
		cp = 1.0f;
		sp = 0.0f;
	}
	/* wi on the axes (cos phi cos th, sin phi cos th, -sin th),
	 * (-sin phi, cos phi, 0) and h, with cos th = h.z, sin th = r */
	dx = (wi.x * cp + wi.y * sp) * h.z - wi.z * r;
	dy = wi.y * cp - wi.x * sp;
	dz = pm_dot(wi, h);
	*theta_d = atan2f(sqrtf(dx * dx + dy * dy), dz);
	*phi_d = atan2f(dy, dx);
	if (*phi_d < 0.0f)
		*phi_d += PM_PI;
	return true;
}

static int
clampi(float x, int n)
{
	int i;

	if (!(x > 0.0f))
		return 0;
	i = x >= (float)n ? n - 1 : (int)x;
	return i;
}

/* MERL's indices, each clamped to its range. */
void
pm_merl_index(float theta_h, float theta_d, float phi_d, int *ith, int *itd,
    int *ipd)
{
	*ith = clampi(sqrtf(pm_fmaxf(theta_h, 0.0f) * (float)(1.0 / HALF_PI)) *
	    PM_MERL_NTH, PM_MERL_NTH);
	*itd = clampi(theta_d * (float)(PM_MERL_NTD / HALF_PI), PM_MERL_NTD);
	*ipd = clampi(phi_d * (float)(PM_MERL_NPD / (2.0 * HALF_PI)),
	    PM_MERL_NPD);
}

/* The directions at the centre of a bin, half vector in the xz plane. */
void
pm_merl_bin_dirs(int ith, int itd, int ipd, double wi[3], double wo[3])
{
	double s = (ith + 0.5) / PM_MERL_NTH;
	double th = s * s * HALF_PI;
	double td = (itd + 0.5) / PM_MERL_NTD * HALF_PI;
	double pd = (ipd + 0.5) / PM_MERL_NPD * 2.0 * HALF_PI;
	double d[3] = {sin(td) * cos(pd), sin(td) * sin(pd), cos(td)};
	double h[3] = {sin(th), 0.0, cos(th)};
	int a;

	/* the inverse of pm_merl_angles' rotation, with phi_h = 0 */
	wi[0] = d[0] * cos(th) + d[2] * sin(th);
	wi[1] = d[1];
	wi[2] = -d[0] * sin(th) + d[2] * cos(th);
	for (a = 0; a < 3; a++)
		wo[a] = 2.0 * d[2] * h[a] - wi[a];
}

static struct pm_rgb
at(const struct pm_merl *m, size_t idx)
{
	const float *p = m->f + 3 * idx;

	return pm_rgb(p[0], p[1], p[2]);
}

static size_t
idx3(int ith, int itd, int ipd)
{
	return (size_t)ipd + PM_MERL_NPD * ((size_t)itd +
	    PM_MERL_NTD * (size_t)ith);
}

/* A bin-centred coordinate on a clamped axis: lower index and weight. */
static void
axis(float x, int n, int *i0, float *t)
{
	x -= 0.5f;
	if (!(x > 0.0f))
		x = 0.0f;
	if (x > (float)(n - 1))
		x = (float)(n - 1);
	*i0 = (int)x;
	if (*i0 > n - 2)
		*i0 = n - 2;
	*t = x - (float)*i0;
}

/* f_r, nearest or trilinear; 0 below the horizon. */
struct pm_rgb
pm_merl_eval(const struct pm_merl *m, struct pm_vec3 wi, struct pm_vec3 wo,
    unsigned flags)
{
	float th, td, pd, th_x, td_x, pd_x, fl, t0, t1, t2;
	int ith, itd, ipd, i0, j0, p0, p1, a, b;
	struct pm_rgb sum = pm_rgb1(0.0f);

	if (!pm_merl_angles(wi, wo, &th, &td, &pd))
		return sum;
	if (!(flags & PM_MERL_INTERPOLATE)) {
		pm_merl_index(th, td, pd, &ith, &itd, &ipd);
		return at(m, idx3(ith, itd, ipd));
	}
	th_x = sqrtf(th * (float)(1.0 / HALF_PI)) * PM_MERL_NTH;
	td_x = td * (float)(PM_MERL_NTD / HALF_PI);
	pd_x = pd * (float)(PM_MERL_NPD / (2.0 * HALF_PI)) - 0.5f;
	axis(th_x, PM_MERL_NTH, &i0, &t0);
	axis(td_x, PM_MERL_NTD, &j0, &t1);
	/* phi_d is periodic with period pi: wrap rather than clamp */
	fl = floorf(pd_x);
	t2 = pd_x - fl;
	p0 = (int)fl;
	if (p0 < 0)
		p0 += PM_MERL_NPD;
	if (p0 >= PM_MERL_NPD)
		p0 -= PM_MERL_NPD;
	p1 = p0 + 1 == PM_MERL_NPD ? 0 : p0 + 1;
	for (a = 0; a < 2; a++)
		for (b = 0; b < 2; b++) {
			float w = (a ? t0 : 1.0f - t0) * (b ? t1 : 1.0f - t1);
			size_t base = idx3(i0 + a, j0 + b, 0);

			sum = pm_rgb_madd(sum, at(m, base + (size_t)p0),
			    pm_rgb1(w * (1.0f - t2)));
			sum = pm_rgb_madd(sum, at(m, base + (size_t)p1),
			    pm_rgb1(w * t2));
		}
	return sum;
}

/* wi's polar-angle bin and its azimuth as a cosine and sine. */
static int
wi_bin(struct pm_vec3 wi, float *c, float *s)
{
	float r = sqrtf(wi.x * wi.x + wi.y * wi.y);
	float ti = atan2f(r, wi.z);

	if (r > 0.0f) {
		*c = wi.x / r;
		*s = wi.y / r;
	} else {
		*c = 1.0f;
		*s = 0.0f;
	}
	return clampi(ti * (float)(PM_MERL_NTI / HALF_PI), PM_MERL_NTI);
}

/* Index of the last cdf entry at or below u in cdf[0..n]; the bin it
 * starts has positive width. */
static int
find(const float *cdf, int n, float u)
{
	int lo = 0, hi = n - 1;

	while (lo < hi) {
		int mid = (lo + hi + 1) / 2;

		if (cdf[mid] <= u)
			lo = mid;
		else
			hi = mid - 1;
	}
	return lo;
}

/* Density of the data sampler's half vector h, in solid angle. */
static float
pdf_half(const struct pm_merl *m, int k, float c, float s, struct pm_vec3 h)
{
	float r = sqrtf(h.x * h.x + h.y * h.y), th, phi;
	float hx = c * h.x + s * h.y, hy = c * h.y - s * h.x;
	const float *rc = m->row_cdf + (size_t)k * (PM_MERL_NTH + 1);
	const float *cc;
	int i, j;

	th = atan2f(r, h.z);
	i = clampi(sqrtf(th * (float)(1.0 / HALF_PI)) * PM_MERL_NTH,
	    PM_MERL_NTH);
	phi = atan2f(hy, hx);
	if (phi < 0.0f)
		phi += 2.0f * PM_PI;
	j = clampi(phi * (float)(PM_MERL_NPH / (4.0 * HALF_PI)), PM_MERL_NPH);
	cc = m->col_cdf + cell(k, i);
	return (rc[i + 1] - rc[i]) * (cc[j + 1] - cc[j]) * m->inv_domega[i];
}

/* Density of pm_merl_sample producing wo. */
float
pm_merl_pdf(const struct pm_merl *m, struct pm_vec3 wi, struct pm_vec3 wo,
    unsigned flags)
{
	struct pm_vec3 h;
	float c, s, df, len, p, dh;
	int k;

	if (!(wi.z > 0.0f && wo.z > 0.0f))
		return 0.0f;
	p = wo.z * PM_INV_PI;
	k = wi_bin(wi, &c, &s);
	df = (flags & PM_MERL_COSINE) ? 0.0f : m->data_frac[k];
	if (df == 0.0f)
		return p;
	h = pm_add(wi, wo);
	len = pm_length(h);
	if (!(len > 0.0f))
		return (1.0f - df) * p;
	h = pm_scale(h, 1.0f / len);
	dh = pm_dot(wo, h);
	if (!(dh > 0.0f))
		return (1.0f - df) * p;
	return (1.0f - df) * p + df * pdf_half(m, k, c, s, h) / (4.0f * dh);
}

/* Draws wo: cosine with probability 1 - data_frac, else from the table. */
bool
pm_merl_sample(const struct pm_merl *m, struct pm_vec3 wi, float u1,
    float u2, float u3, unsigned flags, struct pm_vec3 *wo, float *pdf)
{
	float c, s, df, x, sin_t, phi, hx, hy, dh, w;
	const float *rc, *cc;
	struct pm_vec3 h;
	int k, i, j;

	if (!(wi.z > 0.0f))
		return false;
	k = wi_bin(wi, &c, &s);
	df = (flags & PM_MERL_COSINE) ? 0.0f : m->data_frac[k];
	if (!(u1 < df)) {
		*wo = pm_square_to_cosine_hemisphere(u2, u3);
	} else {
		rc = m->row_cdf + (size_t)k * (PM_MERL_NTH + 1);
		i = find(rc, PM_MERL_NTH + 1, u2);
		w = rc[i + 1] - rc[i];
		u2 = w > 0.0f ? pm_fminf((u2 - rc[i]) / w, 0x1.fffffep-1f) : 0.5f;
		cc = m->col_cdf + cell(k, i);
		j = find(cc, PM_MERL_NPH + 1, u3);
		w = cc[j + 1] - cc[j];
		u3 = w > 0.0f ? pm_fminf((u3 - cc[j]) / w, 0x1.fffffep-1f) : 0.5f;
		/* uniform in solid angle within the cell: 1 - cos theta
		 * uniform, kept as such for precision near the pole */
		x = m->edge_omc[i] + u2 * (m->edge_omc[i + 1] - m->edge_omc[i]);
		sin_t = sqrtf(pm_fmaxf(x * (2.0f - x), 0.0f));
		phi = ((float)j + u3) * (2.0f * PM_PI / PM_MERL_NPH);
		hx = sin_t * cosf(phi);
		hy = sin_t * sinf(phi);
		h = pm_v3(c * hx - s * hy, s * hx + c * hy, 1.0f - x);
		dh = pm_dot(wi, h);
		if (!(dh > 0.0f))
			return false;
		*wo = pm_normalize(pm_sub(pm_scale(h, 2.0f * dh), wi));
	}
	if (!(wo->z > 0.0f))
		return false;
	*pdf = pm_merl_pdf(m, wi, *wo, flags);
	return *pdf > 0.0f && isfinite(*pdf);
}

/* Directional albedo at theta_i, linear between the bins' centres. */
struct pm_rgb
pm_merl_albedo(const struct pm_merl *m, float theta_i)
{
	float x = theta_i * (float)(PM_MERL_NTI / HALF_PI) - 0.5f, t;
	int k;

	if (!(x > 0.0f))
		return m->albedo[0];
	if (x >= (float)(PM_MERL_NTI - 1))
		return m->albedo[PM_MERL_NTI - 1];
	k = (int)x;
	t = x - (float)k;
	return pm_rgb_add(pm_rgb_scale(m->albedo[k], 1.0f - t),
	    pm_rgb_scale(m->albedo[k + 1], t));
}

/* Normalises n + 1 running sums in place into a cdf; false if all zero. */
static bool
normalise(const double *sum, float *cdf, int n)
{
	int i;

	cdf[0] = 0.0f;
	if (!(sum[n] > 0.0)) {
		for (i = 1; i <= n; i++)
			cdf[i] = (float)i / (float)n;
		return false;
	}
	for (i = 1; i < n; i++)
		cdf[i] = (float)(sum[i] / sum[n]);
	cdf[n] = 1.0f;
	return true;
}

/* Builds the sampling tables and the albedo (see the top of the file). */
enum pm_err
pm_merl_prepare(struct pm_merl *m, struct pm_error *err)
{
	enum { SUB = 2 };
	double rows[PM_MERL_NTH + 1], cols[PM_MERL_NPH + 1], omc[PM_MERL_NTH + 1];
	double domega, lum_peak = 0.0;
	int k, i, j, a, b;

	free(m->row_cdf);
	free(m->col_cdf);
	m->row_cdf = malloc((size_t)PM_MERL_NTI * (PM_MERL_NTH + 1) *
	    sizeof(float));
	m->col_cdf = malloc((size_t)PM_MERL_NTI * PM_MERL_NTH *
	    (PM_MERL_NPH + 1) * sizeof(float));
	if (m->row_cdf == NULL || m->col_cdf == NULL)
		return pm_fail(err, PM_ERR_NOMEM, "no memory for the MERL "
		    "sampling tables");
	for (i = 0; i <= PM_MERL_NTH; i++) {
		double s = (double)i / PM_MERL_NTH, th = s * s * HALF_PI;

		/* 1 - cos, written so that it keeps its digits near 0 */
		omc[i] = 2.0 * sin(0.5 * th) * sin(0.5 * th);
		m->edge_omc[i] = (float)omc[i];
	}
	for (i = 0; i < PM_MERL_NTH; i++)
		m->inv_domega[i] = (float)(PM_MERL_NPH / ((omc[i + 1] - omc[i]) *
		    4.0 * HALF_PI));

	for (k = 0; k < PM_MERL_NTI; k++) {
		double ti = (k + 0.5) / PM_MERL_NTI * HALF_PI;
		struct pm_vec3 wi = pm_v3((float)sin(ti), 0.0f, (float)cos(ti));
		double alb[3] = {0.0, 0.0, 0.0};

		rows[0] = 0.0;
		for (i = 0; i < PM_MERL_NTH; i++) {
			domega = (omc[i + 1] - omc[i]) * 4.0 * HALF_PI /
			    PM_MERL_NPH;
			cols[0] = 0.0;
			for (j = 0; j < PM_MERL_NPH; j++) {
				double w = 0.0;

				for (a = 0; a < SUB; a++)
					for (b = 0; b < SUB; b++) {
						double x = omc[i] + (a + 0.5) /
						    SUB * (omc[i + 1] - omc[i]);
						double st = sqrt(x * (2.0 - x));
						double ph = (j + (b + 0.5) / SUB) *
						    4.0 * HALF_PI / PM_MERL_NPH;
						struct pm_vec3 h = pm_v3(
						    (float)(st * cos(ph)),
						    (float)(st * sin(ph)),
						    (float)(1.0 - x));
						float dh = pm_dot(wi, h), jac, l;
						struct pm_vec3 wo;
						struct pm_rgb f;

						if (!(dh > 0.0f))
							continue;
						wo = pm_sub(pm_scale(h,
						    2.0f * dh), wi);
						if (!(wo.z > 0.0f))
							continue;
						f = pm_merl_eval(m, wi, wo, 0);
						/* f cos_o |dwo/dh| */
						jac = 4.0f * dh * wo.z;
						l = pm_rgb_mean(f);
						if (k == 0 && l > lum_peak)
							lum_peak = l;
						w += (double)l * jac;
						alb[0] += (double)f.r * jac *
						    domega / (SUB * SUB);
						alb[1] += (double)f.g * jac *
						    domega / (SUB * SUB);
						alb[2] += (double)f.b * jac *
						    domega / (SUB * SUB);
					}
				cols[j + 1] = cols[j] + w * domega /
				    (SUB * SUB);
			}
			rows[i + 1] = rows[i] + cols[PM_MERL_NPH];
			normalise(cols, m->col_cdf + cell(k, i), PM_MERL_NPH);
		}
		m->data_frac[k] = normalise(rows, m->row_cdf +
		    (size_t)k * (PM_MERL_NTH + 1), PM_MERL_NTH) ? DATA_FRAC :
		    0.0f;
		m->albedo[k] = pm_rgb((float)alb[0], (float)alb[1],
		    (float)alb[2]);
	}
	m->glossy = lum_peak > GLOSSY_RATIO * PM_INV_PI *
	    pm_rgb_mean(m->albedo[0]);
	return PM_OK;
}

/* bsdf.c's GGX rough conductor with the given complex IOR. */
static struct pm_bsdf
ggx(struct pm_rgb eta, struct pm_rgb k, float alpha)
{
	struct pm_bsdf b;

	memset(&b, 0, sizeof(b));
	b.type = PM_BSDF_ROUGHCONDUCTOR;
	b.eta = eta;
	b.k = k;
	b.specular = pm_rgb1(1.0f);
	b.alpha = alpha;
	b.sample_visible = true;
	pm_bsdf_prepare(&b);
	return b;
}

/* f_r of a model, 1/sr; 0 below the horizon. */
struct pm_rgb
pm_merl_model_eval(const struct pm_merl_model *mo, struct pm_vec3 wi,
    struct pm_vec3 wo)
{
	struct pm_bsdf b;
	struct pm_rgb f;
	float fi, fo;

	if (!(wi.z > 0.0f && wo.z > 0.0f))
		return pm_rgb1(0.0f);
	switch (mo->type) {
	case PM_MERL_LAMBERT:
		return pm_rgb_scale(mo->albedo, PM_INV_PI);
	case PM_MERL_METAL:
		b = ggx(mo->eta, mo->k, mo->alpha);
		return pm_rgb_scale(pm_bsdf_eval(&b, wi, wo, PM_RADIANCE),
		    1.0f / wo.z);
	case PM_MERL_PLASTIC:
		b = ggx(pm_rgb1(mo->ior), pm_rgb1(0.0f), mo->alpha);
		f = pm_rgb_scale(pm_bsdf_eval(&b, wi, wo, PM_RADIANCE),
		    1.0f / wo.z);
		/* what the coat lets in, and out again */
		fi = pm_fresnel_dielectric(wi.z, mo->ior, NULL);
		fo = pm_fresnel_dielectric(wo.z, mo->ior, NULL);
		return pm_rgb_add(f, pm_rgb_scale(mo->albedo,
		    (1.0f - fi) * (1.0f - fo) * PM_INV_PI));
	}
	return pm_rgb1(0.0f);
}

void
pm_merl_model_bin(const struct pm_merl_model *mo, int ith, int itd, int ipd,
    double v[3])
{
	static const double scale[3] = {PM_MERL_SCALE_R, PM_MERL_SCALE_G,
	    PM_MERL_SCALE_B};
	double wi[3], wo[3];
	struct pm_rgb f;

	pm_merl_bin_dirs(ith, itd, ipd, wi, wo);
	if (wi[2] <= 0.0 || wo[2] <= 0.0) {
		v[0] = v[1] = v[2] = -1.0;
		return;
	}
	f = pm_merl_model_eval(mo, pm_v3((float)wi[0], (float)wi[1],
	    (float)wi[2]), pm_v3((float)wo[0], (float)wo[1], (float)wo[2]));
	v[0] = f.r / scale[0];
	v[1] = f.g / scale[1];
	v[2] = f.b / scale[2];
}
