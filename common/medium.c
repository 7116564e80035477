/*
 * medium.c: phase functions, transmittance and free-flight sampling of
 * the homogeneous medium (medium.h says which estimator and why).
 */
#include <math.h>

#include <stdio.h>

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
	den = fmaxf(den, 1e-12f);
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
	c = fminf(fmaxf(c, -1.0f), 1.0f);
	s = sqrtf(fmaxf(0.0f, 1.0f - c * c));
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

enum pm_err
pm_scene_refuse_media(const struct pm_scene *s, struct pm_error *err)
{
	size_t i;

	/* Photon mapping simulates homogeneous media (shoot.c, the volume
	 * map); any other kind is the path tracer's alone for now. */
	for (i = 0; i < s->nmedia; i++)
		if (s->media[i].type != PM_MEDIUM_HOMOGENEOUS)
			return pm_fail(err, PM_ERR_UNSUPPORTED, "medium "
			    "\"%s\": photon mapping simulates homogeneous "
			    "media only; pm-render --method path renders this "
			    "scene", s->media[i].name);
	return PM_OK;
}
