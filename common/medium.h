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
 * Free-flight sampling in RGB (pm_medium_sample): a channel is chosen
 * uniformly and a distance drawn from its exponential; the sample is then
 * weighted by the density averaged over the three channels (one-sample
 * multiple importance sampling over the channels, the "spectral MIS" of
 * Mitsuba's volpathmis and pbrt-v4).  Its expectation is that of
 * Mitsuba's volpath, which weights by the chosen channel's density alone;
 * the average never divides by a tiny density, so a chromatic medium
 * gives no fireflies.  In a grey medium both reduce to exact analogue
 * sampling: the weight is 1 along the way and the albedo at a scatter.
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
	struct pm_rgb weight;	/* scattered: T(t) sigma_s / p(t); else
				 * T(tmax) / P(t >= tmax) */
};

/*
 * Samples the distance to the next scattering along a ray in m that meets
 * a surface (or nothing: tmax INFINITY) at tmax, with u_channel choosing
 * the channel and u_dist the distance.  The weights make the estimate
 * unbiased whatever the colour of sigma_t; a flight past tmax with
 * weight zero means the medium can carry no light that far.
 */
void pm_medium_sample(const struct pm_medium *m, float tmax, float u_channel,
    float u_dist, struct pm_medium_sample *out);

#endif
