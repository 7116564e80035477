/*
 * integrator.h: what the integrators (integrator_path.c, integrator_pm.c)
 * share with each other and with the camera pass that calls them: the
 * context they read, the photon maps, the path state, and the radiance
 * estimates along one camera ray.
 */
#ifndef PM_INTEGRATOR_H
#define PM_INTEGRATOR_H

#include <stdbool.h>
#include <stddef.h>

#include "accel.h"
#include "bsdf.h"
#include "icache.h"
#include "irradiance.h"
#include "light.h"
#include "rng.h"
#include "scene.h"

struct pm_occupancy;

/* Balanced photon maps and how to look them up (integrator_pm.c). */
struct pm_photon_maps {
	const struct pm_photon *global;	/* kd-tree order */
	size_t nglobal;
	float global_scale;		/* 1 / photon paths emitted */
	const struct pm_photon *caustic;
	size_t ncaustic;
	float caustic_scale;
	/* Where the caustic map has no photon within caustic_r2 (NULL:
	 * not known), so that an estimate there skips its walk. */
	const struct pm_occupancy *caustic_occ;
	float global_r2, caustic_r2;	/* squared maximum lookup radii */
	/* Precomputed irradiance records (kd-tree order; power is E in
	 * W/m^2, undivided), NULL if the map file has none, and the grid
	 * gather rays look them up in. */
	const struct pm_photon *irradiance;
	size_t nirradiance;
	const struct pm_irr_grid *irradiance_grid;
	/* Photons a gather ray may count without records: those of at most
	 * this many bounces (max_depth - 3), or -1 for all. */
	int gather_max_depth;
	int lookup_size;		/* k nearest photons per estimate */
	int direct_samples;		/* light samples per non-specular hit */
	bool final_gather;
	int final_gather_samples;	/* rays per sample without the cache */
	/* The image-space irradiance cache (icache.h): grid points every
	 * icache_step pixels (0: none, < 0: by the samples per pixel,
	 * pm_icache_default_step), icache_rays gather rays each (0: by
	 * the samples per pixel), Ward's accuracy icache_a. */
	int icache_step;
	int icache_rays;
	float icache_a;
	/* The volume map (participating media; integrator_pmvol.c), in
	 * kd-tree order, its flux normaliser and squared lookup radius. */
	const struct pm_photon *volume;
	size_t nvolume;
	float volume_scale;
	float volume_r2;
	int volume_samples;		/* points per camera segment in a
					 * medium (0: 1) */
	bool volume_beam;		/* the volume map by the beam radiance
					 * estimate (fixed radius), not at
					 * those points */
	/* Progressive photon mapping: every photon within the radii counts
	 * (no k-nearest), so that passes with shrinking radii average to the
	 * right answer; lookup_size is then unused. */
	bool fixed_radius;
};

/*
 * The radius of pass `pass` (1, 2, ...) of probabilistic progressive photon
 * mapping (Knaus and Zwicker 2011) as a multiple of the first pass's:
 * r_{i+1}^2 = r_i^2 (i + alpha) / (i + 1), alpha in (0, 1).  Returns 0 for
 * pass < 1.
 */
double pm_pppm_radius_scale(long pass, double alpha);

/* Largest lookupSize: estimates keep their neighbours on the stack. */
#define PM_MAX_LOOKUP 4096

/* What an integrator needs to look at; read-only while rendering. */
struct pm_render_ctx {
	const struct pm_scene *scene;
	const struct pm_accel *accel;
	const struct pm_lights *lights;
	int max_depth;			/* -1: unlimited */
	int rr_depth;
	bool hide_emitters;
	const struct pm_photon_maps *maps;	/* PM_METHOD_PHOTON only */
	float scene_radius;		/* bounding sphere; 0: unknown */
	const struct pm_icache *icache;	/* set by pm_render, or NULL */
};

/* What a camera path carries from one vertex to the next. */
struct pm_path {
	struct pm_vec3 o, d;		/* the next ray */
	float tmin, tmax;
	struct pm_rgb beta;		/* throughput */
	float eta_scale;		/* product of eta^2 over refractions */
	struct pm_vec3 prev_p;		/* the last vertex, and the density the */
	float prev_pdf;			/* ray left it with, for MIS; prev_delta: */
	bool prev_delta;		/* a camera ray or a specular bounce */
	/* Media (integrator_volume.c): the channel free flights are
	 * sampled in (-1 until the first), and per channel the density of
	 * the flights so far had that channel been sampled, over the
	 * hero's, scaled to mean 1; beta is already divided by it. */
	int hero;
	struct pm_rgb chan_ratio;
};

/* A path about to trace the camera ray o + t d, t in (tmin, tmax). */
void pm_path_start(struct pm_path *pa, struct pm_vec3 o, struct pm_vec3 d,
    float tmin, float tmax);

/*
 * Moves the path on through the BSDF sample bs taken at h (shading frame
 * fr): multiplies the throughput, aims the next ray, records what MIS needs
 * about this bounce, and from depth rr_depth on plays Russian roulette on
 * the throughput with refraction's radiance scaling undone, so that glass
 * does not end paths early.  False when the path ends here.
 */
bool pm_path_continue(struct pm_path *pa, const struct pm_hit *h,
    struct pm_frame fr, const struct pm_bsdf_sample *bs, int depth,
    int rr_depth, struct pm_rng *rng);

/* Radiance along a camera ray by path tracing with next-event estimation
 * and multiple importance sampling (integrator_path.c). */
struct pm_rgb pm_path_li(const struct pm_render_ctx *ctx, struct pm_vec3 o,
    struct pm_vec3 d, float tmin, float tmax, struct pm_rng *rng);

/* One camera ray of pm_path_li_batch, its own random numbers, and what
 * comes back along it. */
struct pm_path_sample {
	struct pm_vec3 o, d;
	float tmin, tmax;
	struct pm_rng rng;
	struct pm_rgb L;		/* out */
};

/* smp[i].L = pm_path_li(ctx, smp[i].o, ..., &smp[i].rng) for i < n, bit for
 * bit, but faster: the paths go together and their rays in batches. */
void pm_path_li_batch(const struct pm_render_ctx *ctx,
    struct pm_path_sample *smp, size_t n);

/* Radiance along a camera ray from photon maps: exact direct light,
 * specular recursion, caustic and global maps or final gathering
 * (integrator_pm.c). */
struct pm_rgb pm_photon_li(const struct pm_render_ctx *ctx, struct pm_vec3 o,
    struct pm_vec3 d, float tmin, float tmax, struct pm_rng *rng);

/* What the camera pass knows of one sample beyond its ray: its film
 * position (fx, fy), which lets the first surface seen take its indirect
 * light from ctx->icache, and a stratified point (lu[0], lu[1]) in
 * [0, 1)^2 for the first light sample along the path (lu[0] < 0: none). */
struct pm_camera_sample {
	float fx, fy;
	float lu[2];
};

/* The same as pm_photon_li for the camera sample cs. */
struct pm_rgb pm_photon_li_px(const struct pm_render_ctx *ctx, struct pm_vec3 o,
    struct pm_vec3 d, float tmin, float tmax, const struct pm_camera_sample *cs,
    struct pm_rng *rng);
/* The same with the camera ray's first hit already found (hit, h: what
 * pm_accel_intersect gives for it), for camera rays cast in packets. */
struct pm_rgb pm_photon_li_px_hit(const struct pm_render_ctx *ctx,
    struct pm_vec3 o, struct pm_vec3 d, float tmin, float tmax,
    const struct pm_camera_sample *cs, struct pm_rng *rng, bool hit,
    const struct pm_hit *h);

/* True where the photon render estimates light at a surface rather than
 * following or path tracing it: where indirect light may be cached. */
bool pm_photon_cacheable(const struct pm_bsdf *b);

/* Radiance arriving along a final-gathering ray from o in direction d,
 * from the irradiance records (or the global map) at the first
 * non-specular surface; *t (if not NULL) gets the distance to the first
 * surface hit, INFINITY for none. */
struct pm_rgb pm_photon_gather(const struct pm_render_ctx *ctx, struct pm_vec3 o,
    struct pm_vec3 d, struct pm_rng *rng, float *t);
/* The same with the ray's first hit already found (hit, h: what
 * pm_accel_intersect gives for it), for rays cast in packets. */
struct pm_rgb pm_photon_gather_hit(const struct pm_render_ctx *ctx,
    struct pm_vec3 o, struct pm_vec3 d, struct pm_rng *rng, float *t,
    bool hit, const struct pm_hit *h);

/* Participating media in the path tracer (integrator_volume.c). */

/* The medium a ray leaving hit h along d travels in, having travelled in
 * `medium` (-1: none): the one on the far side if the shape names any. */
int pm_medium_after(const struct pm_scene *s, const struct pm_hit *h,
    struct pm_vec3 d, int medium);

/* Transmittance from o, in `medium`, to the light sample ls through media
 * and null-BSDF boundaries; zero where another surface blocks it.
 * Heterogeneous media estimate it (ratio tracking) from rng. */
struct pm_rgb pm_volume_tr(const struct pm_render_ctx *ctx,
    struct pm_vec3 o, int medium, const struct pm_light_sample *ls,
    struct pm_rng *rng);

/* pm_volume_tr with a generator seeded from the ray (o, ls->wi): the same
 * for homogeneous media, which draw nothing. */
struct pm_rgb pm_volume_shadow(const struct pm_render_ctx *ctx,
    struct pm_vec3 o, int medium, const struct pm_light_sample *ls);

/* Photon mode in media (integrator_pmvol.c). */

/* In-scattered radiance sigma_s * integral(phase L) at p toward -d (d:
 * the camera ray's direction) from the volume map's photons of 1 to
 * max_depth bounces (-1: any), phase ph. */
struct pm_rgb pm_volume_map_estimate(const struct pm_photon_maps *m,
    const struct pm_phase *ph, struct pm_vec3 p, struct pm_vec3 d,
    int max_depth);

/* The same integrated along the camera segment o + t d, t in (tmin,
 * t_end), in medium med, times the transmittance from tmin: the beam
 * radiance estimate with the fixed radius sqrt(m->volume_r2). */
struct pm_rgb pm_volume_beam_estimate(const struct pm_photon_maps *m,
    const struct pm_medium *med, struct pm_vec3 o, struct pm_vec3 d,
    float tmin, float t_end, int max_depth);

/* Light scattered towards o along the segment o + t d, t in (tmin,
 * t_end), in `medium`, for a camera path vertex number depth; *tr gets
 * the segment's transmittance, for what lies beyond. */
struct pm_rgb pm_volume_inscatter(const struct pm_render_ctx *ctx, int medium,
    struct pm_vec3 o, struct pm_vec3 d, float tmin, float t_end, int depth,
    struct pm_rgb *tr, struct pm_rng *rng);

enum pm_vol_event {
	PM_VOL_PASS,		/* reached the surface; beta weighted */
	PM_VOL_SCATTER,		/* scattered: light sampled into L, the
				 * path moved on along the phase sample */
	PM_VOL_END,		/* the path ends here */
};

/* Samples a free flight in `medium` along the path's ray, from pa->tmin
 * to the surface at t_end (pa->tmax without one); at a scatter, vertex
 * number depth of the path, does what a surface bounce does. */
enum pm_vol_event pm_volume_step(const struct pm_render_ctx *ctx,
    struct pm_path *pa, int medium, float t_end, int depth, struct pm_rgb *L,
    struct pm_rng *rng);

#endif
