/*
 * envmap.c: the latitude-longitude environment (see envmap.h for the
 * mapping, which is Mitsuba 3's, and for how directions are sampled).
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "envmap.h"

#define TWO_PI_D	6.28318530717958647692

/* Mitsuba's luminance weights (Rec. 709). */
static double
luminance(const float *c)
{
	return 0.212671 * c[0] + 0.715160 * c[1] + 0.072169 * c[2];
}

enum pm_err
pm_envmap_init(struct pm_envmap *e, const float *rgb, int width, int height,
    float scale, const struct pm_mat4 *to_world, struct pm_error *err)
{
	size_t W, H, x, y, k;
	double *w;
	enum pm_err rc;

	memset(e, 0, sizeof(*e));
	if (width < 2 || height < 3 || width > (1 << 16) || height > (1 << 16))
		return pm_fail(err, PM_ERR_INVALID, "environment map: %dx%d "
		    "pixels, expected at least 2x3 and at most 65536 a side",
		    width, height);
	if (!pm_mat4_inverse(*to_world, &e->to_local))
		return pm_fail(err, PM_ERR_INVALID, "environment map: to_world "
		    "is not invertible");
	e->to_world = *to_world;
	W = (size_t)width;
	H = (size_t)height;
	e->width = width;
	e->height = height;
	e->rgb = malloc((W + 1) * H * 3 * sizeof(float));
	w = malloc(W * (H - 1) * sizeof(double));
	if (e->rgb == NULL || w == NULL) {
		free(w);
		pm_envmap_free(e);
		return pm_fail(err, PM_ERR_NOMEM, "no memory for a %dx%d "
		    "environment map", width, height);
	}
	for (y = 0; y < H; y++) {
		for (x = 0; x <= W; x++)
			for (k = 0; k < 3; k++) {
				float v = rgb[3 * (y * W + x % W) + k] * scale;

				/* NaN and negatives are no light */
				e->rgb[3 * (y * (W + 1) + x) + k] =
				    v > 0.0f && isfinite(v) ? v : 0.0f;
			}
	}
	/* Cell (x, y) spans texel columns x..x+1 and rows y..y+1: phi over
	 * 2 pi / W, cos theta from cos(y pi / (H-1)) to cos((y+1) pi / (H-1)). */
	e->integral = 0.0;
	for (y = 0; y + 1 < H; y++) {
		double c0 = cos(PM_PI * (double)y / (double)(H - 1));
		double c1 = cos(PM_PI * (double)(y + 1) / (double)(H - 1));
		double sa = TWO_PI_D / (double)W * (c0 - c1);

		for (x = 0; x < W; x++) {
			const float *t00 = &e->rgb[3 * (y * (W + 1) + x)];
			const float *t10 = t00 + 3;
			const float *t01 = t00 + 3 * (W + 1), *t11 = t01 + 3;
			double lum = 0.25 * (luminance(t00) + luminance(t10) +
			    luminance(t01) + luminance(t11));
			double mean = 0.0;

			for (k = 0; k < 3; k++)
				mean += (t00[k] + t10[k] + t01[k] + t11[k]) / 12.0;
			/* The weights are positive exactly where the
			 * radiance is, since luminance is a positive
			 * combination of non-negative channels. */
			w[y * W + x] = lum * sa;
			e->integral += mean * sa;
		}
	}
	/* A black map (or a scale of 0) is valid and sends no light: it has
	 * no distribution, and nothing is ever sampled from it. */
	rc = e->integral > 0.0 ? pm_distrib_init(&e->cells, w, W * (H - 1),
	    err) : PM_OK;
	free(w);
	if (rc != PM_OK)
		pm_envmap_free(e);
	return rc;
}

void
pm_envmap_free(struct pm_envmap *e)
{
	free(e->rgb);
	e->rgb = NULL;
	pm_distrib_free(&e->cells);
}

/* Unit direction in the emitter's frame. */
static struct pm_vec3
local_dir(const struct pm_envmap *e, struct pm_vec3 w)
{
	return pm_normalize(pm_xform_vector(&e->to_local, w));
}

/* Texel coordinates of local direction d: column in [0, W), row in
 * [0, H - 1]; *cx, *cy the cell, *fx, *fy the position within it. */
static void
locate(const struct pm_envmap *e, struct pm_vec3 d, int *cx, int *cy,
    float *fx, float *fy)
{
	float u = atan2f(d.x, -d.z) * (float)(1.0 / TWO_PI_D);
	float v = acosf(pm_fminf(pm_fmaxf(d.y, -1.0f), 1.0f)) * (float)(1.0 / PM_PI);
	float x, y;

	/* half a texel: texel x's centre is at u = (x + 1/2) / W */
	u -= 0.5f / (float)e->width;
	u -= floorf(u);
	x = u * (float)e->width;
	y = v * (float)(e->height - 1);
	/* a degenerate direction (NaN) reads texel 0, never converts a
	 * NaN to int */
	if (!(x >= 0.0f))
		x = 0.0f;
	if (!(y >= 0.0f))
		y = 0.0f;
	*cx = (int)x;
	if (*cx > e->width - 1)
		*cx = e->width - 1;
	*cy = (int)y;
	if (*cy > e->height - 2)
		*cy = e->height - 2;
	if (*cy < 0)
		*cy = 0;
	*fx = x - (float)*cx;
	*fy = y - (float)*cy;
}

struct pm_rgb
pm_envmap_eval(const struct pm_envmap *e, struct pm_vec3 w)
{
	int cx, cy;
	float fx, fy, c[3];
	size_t W1 = (size_t)e->width + 1, k;
	const float *t00, *t10, *t01, *t11;

	locate(e, local_dir(e, w), &cx, &cy, &fx, &fy);
	t00 = &e->rgb[3 * ((size_t)cy * W1 + (size_t)cx)];
	t10 = t00 + 3;
	t01 = t00 + 3 * W1;
	t11 = t01 + 3;
	for (k = 0; k < 3; k++)
		c[k] = (1.0f - fy) * ((1.0f - fx) * t00[k] + fx * t10[k]) +
		    fy * ((1.0f - fx) * t01[k] + fx * t11[k]);
	return pm_rgb(c[0], c[1], c[2]);
}

/* Solid angle of a cell in row cy. */
static double
cell_solid_angle(const struct pm_envmap *e, int cy)
{
	double c0 = cos(PM_PI * (double)cy / (double)(e->height - 1));
	double c1 = cos(PM_PI * (double)(cy + 1) / (double)(e->height - 1));

	return TWO_PI_D / (double)e->width * (c0 - c1);
}

struct pm_vec3
pm_envmap_sample(const struct pm_envmap *e, float u1, float u2, float *pdf)
{
	size_t i;
	int cx, cy;
	double c0, c1, phi, ct, st;
	struct pm_vec3 d;

	if (e->cells.n == 0) {
		*pdf = 0.0f;
		return pm_v3(0, 1, 0);
	}
	i = pm_distrib_sample(&e->cells, u1, &u1);
	cx = (int)(i % (size_t)e->width);
	cy = (int)(i / (size_t)e->width);
	c0 = cos(PM_PI * (double)cy / (double)(e->height - 1));
	c1 = cos(PM_PI * (double)(cy + 1) / (double)(e->height - 1));
	phi = TWO_PI_D * ((double)cx + 0.5 + (double)u1) / (double)e->width;
	ct = c0 + (c1 - c0) * (double)u2;

	ct = fmin(fmax(ct, -1.0), 1.0);
	st = sqrt(fmax(0.0, 1.0 - ct * ct));
	d = pm_v3((float)(sin(phi) * st), (float)ct, (float)(-cos(phi) * st));
	*pdf = (float)(pm_distrib_prob(&e->cells, i) / cell_solid_angle(e, cy));
	return pm_normalize(pm_xform_vector(&e->to_world, d));
}

float
pm_envmap_pdf(const struct pm_envmap *e, struct pm_vec3 w)
{
	int cx, cy;
	float fx, fy;

	locate(e, local_dir(e, w), &cx, &cy, &fx, &fy);
	return (float)(pm_distrib_prob(&e->cells, (size_t)cy *
	    (size_t)e->width + (size_t)cx) / cell_solid_angle(e, cy));
}
