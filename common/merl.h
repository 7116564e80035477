/*
 * merl.h: measured isotropic BRDFs in the MERL layout (Matusik et al.
 * 2003, "A data-driven reflectance model"): lookup in the half/difference
 * parameterisation, nearest or interpolated, a data-driven importance
 * sampler with its exact density, and the tabulated directional albedo.
 *
 * Directions are unit vectors in the local shading frame (normal +z), as
 * in bsdf.h.  The table holds f_r (1/sr, without the cosine) as floats with
 * the per-channel scales applied and samples below the horizon set to 0;
 * converting MERL's doubles to float costs a relative error below 6e-8
 * (2^-24), well under the 1e-6 the project allows.  formats/merl.c reads
 * and writes the files; a table is built once and then only read, so any
 * number of threads and BSDFs may share it.
 */
#ifndef PM_MERL_H
#define PM_MERL_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "error.h"
#include "vec.h"

#define PM_MERL_NTH 90		/* theta_half bins, on a square-root axis */
#define PM_MERL_NTD 90		/* theta_diff bins */
#define PM_MERL_NPD 180		/* phi_diff bins over [0, pi) */
#define PM_MERL_N (PM_MERL_NTH * PM_MERL_NTD * PM_MERL_NPD)
/* Bytes in a valid file: the three int32 dimensions, then 3 planes of
 * doubles. */
#define PM_MERL_FILE_SIZE (12 + 8 * 3 * (size_t)PM_MERL_N)

/* Per-channel factors from stored values to f_r (MERL's reader). */
#define PM_MERL_SCALE_R (1.0 / 1500.0)
#define PM_MERL_SCALE_G (1.15 / 1500.0)
#define PM_MERL_SCALE_B (1.66 / 1500.0)

/* Sampling tables: wi's polar angle in PM_MERL_NTI bins, the half vector
 * in PM_MERL_NTH (MERL's square-root axis) by PM_MERL_NPH azimuth cells. */
#define PM_MERL_NTI 32
#define PM_MERL_NPH 32

/* Flags a BSDF keeps next to its table (struct pm_bsdf.merl_flags). */
enum {
	PM_MERL_INTERPOLATE = 1 << 0,	/* trilinear lookup, not nearest */
	PM_MERL_COSINE = 1 << 1,	/* cosine sampling only (comparisons) */
};

struct pm_merl {
	float *f;		/* PM_MERL_N x (r, g, b), interleaved so that a
				 * lookup touches one cache line, not three */
	char *path;		/* the resolved file it came from, or NULL */
	uint32_t crc;		/* zlib crc32 of the file's bytes */
	uint64_t size;		/* of the file, bytes */
	/* Filled by pm_merl_prepare: */
	/* The sampler and the density both read these cumulative sums, so
	 * that they agree exactly, float rounding included. */
	float *row_cdf;		/* [NTI][NTH + 1] over theta_h rows */
	float *col_cdf;		/* [NTI][NTH][NPH + 1] within a row */
	float data_frac[PM_MERL_NTI];	/* P(data sampler), else cosine */
	struct pm_rgb albedo[PM_MERL_NTI];	/* at the bins' centres */
	float edge_omc[PM_MERL_NTH + 1];	/* 1 - cos of theta_h edges */
	float inv_domega[PM_MERL_NTH];	/* 1 / solid angle of a cell */
	bool glossy;		/* peaked enough to be path traced */
};

/* A zeroed table (all f_r 0); NULL and err filled when out of memory. */
struct pm_merl *pm_merl_new(struct pm_error *err);
/* Frees m and everything it owns; m may be NULL. */
void pm_merl_free(struct pm_merl *m);

/* Builds the sampling tables and the albedo from m->f; call once after
 * filling the table. */
enum pm_err pm_merl_prepare(struct pm_merl *m, struct pm_error *err);

/* The half/difference angles of (wi, wo): theta_h, theta_d in [0, pi/2]
 * and phi_d folded into [0, pi]; false if either is at or below the
 * horizon. */
bool pm_merl_angles(struct pm_vec3 wi, struct pm_vec3 wo, float *theta_h,
    float *theta_d, float *phi_d);
/* MERL's indices of the angles, each clamped to its range. */
void pm_merl_index(float theta_h, float theta_d, float phi_d, int *ith,
    int *itd, int *ipd);
/* The pair of directions at the centre of bin (ith, itd, ipd), with the
 * half vector in the xz plane; for writers and tests. */
void pm_merl_bin_dirs(int ith, int itd, int ipd, double wi[3], double wo[3]);

/* f_r(wi, wo) in 1/sr, 0 below the horizon; flags: PM_MERL_INTERPOLATE. */
struct pm_rgb pm_merl_eval(const struct pm_merl *m, struct pm_vec3 wi,
    struct pm_vec3 wo, unsigned flags);
/* Solid-angle density of pm_merl_sample producing wo; flags:
 * PM_MERL_COSINE. */
float pm_merl_pdf(const struct pm_merl *m, struct pm_vec3 wi,
    struct pm_vec3 wo, unsigned flags);
/* Draws wo for wi (u1 picks cosine or data sampling, (u2, u3) the
 * direction); false when nothing above the horizon was drawn. */
bool pm_merl_sample(const struct pm_merl *m, struct pm_vec3 wi, float u1,
    float u2, float u3, unsigned flags, struct pm_vec3 *wo, float *pdf);
/* Directional albedo (integral of f_r cos theta_o) for light or view at
 * polar angle theta_i, from the prepared table. */
struct pm_rgb pm_merl_albedo(const struct pm_merl *m, float theta_i);

/*
 * Analytic BRDFs in MERL's terms, for the writer (formats/merl.c) to
 * tabulate: what pm tests its reader and renders measured-style
 * materials with, without the database.
 */
enum pm_merl_model_type {
	PM_MERL_LAMBERT,	/* albedo / pi */
	PM_MERL_METAL,		/* GGX, Smith masking, conductor Fresnel */
	PM_MERL_PLASTIC,	/* Lambertian base under a GGX dielectric coat */
};

struct pm_merl_model {
	enum pm_merl_model_type type;
	struct pm_rgb albedo;	/* lambert: albedo; plastic: the base's */
	struct pm_rgb eta, k;	/* metal: complex index of refraction */
	float alpha;		/* metal, plastic: GGX roughness */
	float ior;		/* plastic: the coat's index of refraction */
};

/* f_r(wi, wo) of a model in 1/sr (no cosine); 0 below the horizon. */
struct pm_rgb pm_merl_model_eval(const struct pm_merl_model *mo,
    struct pm_vec3 wi, struct pm_vec3 wo);

/* The values MERL stores for bin (ith, itd, ipd) of a model: f_r at the
 * bin's centre divided by each channel's scale, or -1 (MERL's mark for
 * "below the horizon") where wi or wo is at or below it. */
void pm_merl_model_bin(const struct pm_merl_model *mo, int ith, int itd,
    int ipd, double v[3]);

#endif
