/*
 * medium.h: participating media with Mitsuba 3's meaning: the homogeneous
 * medium (extinction sigma_t and single-scattering albedo in RGB, times
 * scale), the heterogeneous one (both from volumes: grids of Mitsuba's
 * .vol files or constants), and their phase functions, isotropic and
 * Henyey-Greenstein.
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
 * scatter.  Heterogeneous media keep this with delta tracking against a
 * majorant shared by the channels (pm_medium_sample_ray says how).
 */
#ifndef PM_MEDIUM_H
#define PM_MEDIUM_H

#include <stdbool.h>

#include "rng.h"
#include "transform.h"
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
	PM_MEDIUM_HETEROGENEOUS,	/* sigma_t, albedo from volumes (het) */
};

/*
 * A grid of voxel values as Mitsuba's .vol files hold them
 * (formats/vol.h): nx x ny x nz voxels of nch channels (1 or 3), voxel
 * centres at ((x + 0.5) / nx, ...) of the unit cube.
 */
struct pm_grid {
	int nx, ny, nz, nch;
	float bbox[6];		/* the file's box: xmin, ymin, zmin, xmax, ... */
	float *data;		/* [((z ny + y) nx + x) nch + c], owned */
	float max;		/* over voxels and channels */
};

enum pm_vol_wrap {
	PM_VOL_CLAMP,		/* Mitsuba's default */
	PM_VOL_REPEAT,
	PM_VOL_MIRROR,
};

/* A volume of Mitsuba's: constant (constvolume, or a plain float or
 * colour) or a grid (gridvolume), placed by to_world over the unit cube. */
struct pm_volume {
	struct pm_rgb value;		/* constant: grid.data is NULL */
	struct pm_grid grid;
	struct pm_mat4 to_local;	/* world to the unit cube */
	bool nearest;			/* filter_type nearest, else trilinear */
	enum pm_vol_wrap wrap;
};

/*
 * What a heterogeneous medium adds: its two volumes, where it is (the
 * world box around sigma_t's unit cube, as Mitsuba's medium is clear
 * outside it), and the majorant that delta and ratio tracking sample
 * against: scale times the largest sigma_t of any voxel and channel.
 */
struct pm_hetero {
	struct pm_volume sigma_t, albedo;
	float scale;
	float majorant;
	struct pm_vec3 lo, hi;
	/* A coarse majorant grid (pm_hetero_prepare), NULL for none: per
	 * cell of nmaj[0] x nmaj[1] x nmaj[2], x fastest, the most sigma_t
	 * (scale applied) can be in it; no_maj_grid ignores it (tests). */
	float *maj;
	/* Per cell of the same grid: the least sigma_t per channel (RGB,
	 * scale applied: mino[3 cell + c]) and the most that sigma_t
	 * exceeds it by in any channel (res), the control and the majorant
	 * of residual ratio tracking (pm_medium_transmittance_ray). */
	float *mino, *res;
	int nmaj[3];
	bool no_maj_grid;
};

/* Builds h->maj, h->mino and h->res for a grid sigma_t whose to_world
 * does not rotate (the global majorant serves the others); false when
 * out of memory. */
bool pm_hetero_prepare(struct pm_hetero *h);

struct pm_medium {
	enum pm_medium_type type;
	struct pm_rgb sigma_t;		/* extinction, per unit length, scale
					 * already applied */
	struct pm_rgb albedo;		/* sigma_s / sigma_t */
	struct pm_phase phase;
	bool sample_emitters;		/* next-event estimation at scatters */
	char name[64];			/* id, or type and ordinal, for messages */
	struct pm_hetero *het;		/* heterogeneous: owned; NULL else */
};

/* Frees what a medium owns (a heterogeneous medium's grids); the struct
 * itself stays the caller's. */
void pm_medium_release(struct pm_medium *m);

/* Frees a grid's voxels. */
void pm_grid_free(struct pm_grid *g);

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

/*
 * The same as pm_medium_sample along the ray o + t d (d unit) from tmin to
 * tmax, for any medium: a homogeneous one goes to pm_medium_sample with
 * one number from rng (so its results are unchanged); a heterogeneous one
 * is delta-tracked against its majorant, each tentative collision real
 * with the probability sigma_t / majorant of the channel `channel`.  With
 * null collisions part of the sample (Miller et al. 2019), f and pdf hold
 * per channel, up to a factor common to all of them, sigma_n / majorant
 * at each null collision and sigma_s (f) or sigma_t (pdf) over the
 * majorant at the real one, so that f / pdf[channel] and f / (mean of
 * pdf) weigh as pm_medium_sample's do.  out->t is the distance past tmin.
 */
void pm_medium_sample_ray(const struct pm_medium *m, struct pm_vec3 o,
    struct pm_vec3 d, float tmin, float tmax, int channel, struct pm_rng *rng,
    struct pm_medium_sample *out);

/*
 * Transmittance along o + t d (d unit) from tmin to tmax (may be
 * INFINITY): exact for a homogeneous medium (rng unused), a ratio-tracking
 * estimate per channel for a heterogeneous one (unbiased, in [0, 1] but
 * for Russian roulette's 1/q).  With the majorant grid, residual ratio
 * tracking (Novak et al. 2014): in each cell the control, the cell's
 * least sigma_t per channel, is taken out exactly (Beer-Lambert) and
 * only the rest is tracked, against the cell's residual majorant: exact
 * in a constant grid, and fewer lookups and less variance than plain
 * ratio tracking wherever the density varies little within a cell.
 */
struct pm_rgb pm_medium_transmittance_ray(const struct pm_medium *m,
    struct pm_vec3 o, struct pm_vec3 d, float tmin, float tmax,
    struct pm_rng *rng);

/* sigma_t (scale applied) and the albedo of m at world point p. */
struct pm_rgb pm_medium_sigma_t_at(const struct pm_medium *m,
    struct pm_vec3 p);
struct pm_rgb pm_medium_albedo_at(const struct pm_medium *m,
    struct pm_vec3 p);

/* A volume's value at world point p: trilinear or nearest lookup of its
 * grid under its wrap mode, or its constant. */
struct pm_rgb pm_volume_eval(const struct pm_volume *v, struct pm_vec3 p);

#endif
