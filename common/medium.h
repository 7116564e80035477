/*
 * medium.h: participating media with Mitsuba 3's meaning: the homogeneous
 * medium (extinction sigma_t and single-scattering albedo in RGB, times
 * scale) and its phase functions, isotropic and Henyey-Greenstein.
 *
 * A ray travels in at most one medium at a time; shapes say which medium
 * lies on either side of them (scene.h: interior, exterior) and the camera
 * says which it sits in.  Everything here is a pure function of plain
 * structs: nothing allocates, so any thread may call it per ray.
 *
 * Free-flight sampling in RGB: the path tracer draws one channel per
 * path (the "hero", uniformly), samples every distance along the path
 * from that channel's exponential, and weights the path by the density
 * averaged over the three channels' choices of the whole path (one-sample
 * multiple importance sampling over channels, the "spectral MIS" of
 * pbrt-v4 and Mitsuba's volpathmis; integrator_volume.c keeps the
 * ratios).  The weight of a channel is then never more than 3 times its
 * own analogue weight, whatever the colour of sigma_t; Mitsuba's volpath
 * weights each distance by the chosen channel's density alone, which has
 * the same expectation and more variance.  In a grey medium both are
 * exact analogue sampling: weight 1 along the way, the albedo at a
 * scatter.
 */
#ifndef PM_MEDIUM_H
#define PM_MEDIUM_H

#include <stdbool.h>

#include "vec.h"

enum pm_phase_type {
	PM_PHASE_ISOTROPIC,
	PM_PHASE_HG,		/* Henyey-Greenstein, asymmetry g */
};

struct pm_phase {
	enum pm_phase_type type;
	float g;		/* hg: in (-1, 1); > 0 scatters forwards */
};

enum pm_medium_type {
	PM_MEDIUM_HOMOGENEOUS,
};

struct pm_medium {
	enum pm_medium_type type;
	struct pm_rgb sigma_t;		/* extinction, per unit length, scale
					 * already applied */
	struct pm_rgb albedo;		/* sigma_s / sigma_t */
	struct pm_phase phase;
	bool sample_emitters;		/* next-event estimation at scatters */
	char name[64];			/* id, or type and ordinal, for messages */
};

/*
 * The phase function's value for light travelling along d (unit, the
 * direction the path arrived in) and leaving along wo (unit): also the
 * solid-angle density with which pm_phase_sample picks wo, since both
 * phase functions are sampled exactly.  Integrates to 1 over the sphere.
 */
float pm_phase_eval(const struct pm_phase *ph, struct pm_vec3 d,
    struct pm_vec3 wo);

/* The solid-angle density of pm_phase_sample: the value itself. */
static inline float pm_phase_pdf(const struct pm_phase *ph, struct pm_vec3 d,
    struct pm_vec3 wo)
{
	return pm_phase_eval(ph, d, wo);
}

/* Samples wo from (u1, u2) in [0, 1)^2 about the arriving direction d;
 * *pdf gets pm_phase_eval(ph, d, wo); the sample's weight is 1. */
struct pm_vec3 pm_phase_sample(const struct pm_phase *ph, struct pm_vec3 d,
    float u1, float u2, float *pdf);

/* Transmittance exp(-sigma_t t) per channel; t may be INFINITY (0 where
 * sigma_t > 0, 1 where it is 0). */
struct pm_rgb pm_medium_transmittance(const struct pm_medium *m, float t);

/* What a free flight found (pm_medium_sample). */
struct pm_medium_sample {
	bool scattered;		/* a real scattering at distance t < tmax;
				 * otherwise the flight reached tmax */
	float t;
	struct pm_rgb f;	/* scattered: T(t) sigma_s; else T(tmax) */
	struct pm_rgb pdf;	/* the density of this outcome had each
				 * channel been the one sampled:
				 * scattered: sigma_t T(t); else T(tmax) */
};

/*
 * Samples the distance to the next scattering from channel `channel`'s
 * exponential (u in [0, 1)) along a ray in m that meets a surface (or
 * nothing: tmax INFINITY) at tmax.  f / pdf[channel] is the analogue
 * weight; f / (mean of pdf) that of one-sample MIS over a uniformly
 * chosen channel.
 */
void pm_medium_sample(const struct pm_medium *m, float tmax, int channel,
    float u, struct pm_medium_sample *out);

#endif
