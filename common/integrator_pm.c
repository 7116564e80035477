/*
 * integrator_pm.c: the gather pass of photon mapping (Jensen 2004, ch. 9).
 *
 * Along a camera path:
 *   - emitters count where they are seen directly or through specular
 *     surfaces (and, with MIS, after glossy ones);
 *   - specular (delta) components are followed recursively, choosing
 *     reflection or refraction by Fresnel weight; plastic's coating is
 *     followed every time, weighted by its Fresnel reflectance, beside the
 *     estimates of its diffuse base (choosing it with probability P would
 *     turn the light's reflection in it into noise);
 *   - glossy surfaces (rough conductors, rough dielectrics, shiny
 *     measured BRDFs) are path traced: light sampling and BSDF sampling
 *     with multiple importance sampling; roughplastic's rough coating is
 *     traced the same way, every time, beside the estimates of its
 *     diffuse base (as plastic's smooth coating is followed);
 *   - the principled BSDFs split as roughplastic does: the diffuse base
 *     (with sheen) from the maps, every other lobe (GGX reflection,
 *     clearcoat, GGX transmission, the thin sheet's diffuse
 *     transmission) traced; those without a base are traced whole,
 *     as rough conductors (metals) or rough dielectrics (transmitters);
 *   - rough dielectrics hold no photons: pm-shoot passes photons through
 *     them as through glass, into the caustic map, so light through
 *     frosted glass reaches diffuse surfaces as caustics; gather rays
 *     follow them by sampling (so do principled BSDFs that transmit and
 *     have no diffuse base);
 *   - at a diffuse surface the path ends with four estimates:
 *       direct light, exactly, from `direct_samples` light samples;
 *       caustics (light, specular+, here) from the caustic map with a cone
 *       filter (k = 1.1, normalised);
 *       the rest of the indirect light, either from the global map's
 *       photons that had a non-specular bounce before arriving (so neither
 *       direct light nor caustics count twice), or by final gathering:
 *       BSDF-sampled rays that end in the irradiance records (or the
 *       whole global map) at the first surface that holds photons, and
 *       path trace the glossy lobes they meet on the way.
 *
 * Radiance estimate: the k nearest photons within the maximum radius, each
 * weighted by the BSDF for its incident direction, over the disc area
 * pi r^2, r the distance to the k-th photon (or the maximum radius when
 * fewer were found).
 *
 * For progressive photon mapping the estimate is over a fixed radius
 * instead: every photon within it, however many, over pi r^2.  A k-nearest
 * radius depends on the photons themselves, and its bias does not average
 * away over independent passes; a fixed radius that shrinks from pass to
 * pass (Knaus and Zwicker's schedule) does, so the mean of the passes
 * converges to the right image.
 */
#include <math.h>

#include "integrator.h"
#include "irradiance.h"
#include "kdtree.h"
#include "merl.h"
#include "occupancy.h"
#include "frame.h"
#include "texture.h"

#define CONE_K 1.1f

/* Surfaces that hold photons (pm-shoot's rule): a rough dielectric holds
 * none, since light crosses it as it crosses glass (photons pass through
 * into the caustic map), so gather rays follow it as they follow glass. */
static bool
has_nonspecular(const struct pm_bsdf *b)
{
	return b->type != PM_BSDF_NULL && !pm_bsdf_passes_photons(b) &&
	    (b->lobes & (PM_LOBE_DIFFUSE | PM_LOBE_GLOSSY | PM_LOBE_GLOSSY_TRANSMISSION));
}

static bool
is_principled(const struct pm_bsdf *b)
{
	return b->type == PM_BSDF_PRINCIPLED || b->type == PM_BSDF_PRINCIPLEDTHIN;
}

/* Rough conductors and dielectrics, and measured materials with a peak
 * (merl.c decides), are traced rather than estimated: photon density
 * estimates blur glossy reflections beyond use.  Matte measured
 * materials use the maps.  (Roughplastic is split: its base uses the
 * maps, its coating is traced; see pm_photon_li_px.) */
static bool
is_glossy(const struct pm_bsdf *b)
{
	return b->type == PM_BSDF_ROUGHCONDUCTOR ||
	    b->type == PM_BSDF_ROUGHDIELECTRIC ||
	    (b->type == PM_BSDF_MERL && b->merl != NULL && b->merl->glossy) ||
	    (is_principled(b) && !(b->lobes & PM_LOBE_DIFFUSE));
}

/* Materials split into a diffuse base, estimated from the maps, and the
 * rest, traced: roughplastic (its rough coating), and the principled
 * BSDFs with a base and something else (their GGX and clearcoat lobes,
 * their transmission, the thin sheet's diffuse transmission too: the
 * photons on its other side are not on this one). */
static bool
is_split(const struct pm_bsdf *b)
{
	return b->type == PM_BSDF_ROUGHPLASTIC || (is_principled(b) &&
	    (b->lobes & PM_LOBE_DIFFUSE) && (b->lobes & ~(unsigned)PM_LOBE_DIFFUSE));
}

/* Everything but the diffuse: what a BSDF made of others (blendbsdf,
 * mask, twosided with two) has traced, followed or passed through rather
 * than estimated from the maps. */
#define REST_LOBES (PM_LOBE_GLOSSY | PM_LOBE_DELTA | PM_LOBE_TRANSMISSION | \
	PM_LOBE_DIFFUSE_TRANSMISSION)

/* A split material's diffuse base alone (lobe PM_LOBE_DIFFUSE), or the
 * rest alone (any other lobe), as a BSDF of its own (a copy with `only`
 * set), and so the diffuse parts of a BSDF made of others, or the rest;
 * other materials as they are. */
static const struct pm_bsdf *
split_lobe(const struct pm_bsdf *b, unsigned lobe, struct pm_bsdf *tmp)
{
	if (!is_split(b) && !pm_bsdf_is_composite(b))
		return b;
	*tmp = *b;
	/* a composite's rest as a fixed set: its lobes less the diffuse may
	 * be none, and `only` 0 would mean all */
	tmp->only = lobe == PM_LOBE_DIFFUSE ? lobe : pm_bsdf_is_composite(b) ?
	    REST_LOBES : b->lobes & ~(unsigned)PM_LOBE_DIFFUSE;
	return tmp;
}

/* The shading normal turned to the side a ray of direction d arrives
 * from, judged by the true surface: the rule pm-shoot stores photons'
 * normals by, so that the two compare. */
static inline struct pm_vec3
side_normal(const struct pm_hit *h, struct pm_vec3 d)
{
	return pm_dot(h->ng, d) < 0.0f ? h->ns : pm_neg(h->ns);
}

/* The photon's contribution before the density division: BSDF for its
 * incident direction over the cosine, times its power; false for none,
 * for photons of more than max_depth bounces (a negative max_depth: no
 * limit, as pm-render's gather_max_depth says for unlimited depth),
 * and for photons on a surface of another orientation (the other side of
 * a wall, a surface meeting this one at a corner): they never reach here. */
static inline bool
photon_term(const struct pm_photon *x, const struct pm_bsdf *b,
    struct pm_frame fr, struct pm_vec3 wi_local, struct pm_vec3 nrm,
    int max_depth, struct pm_rgb *out)
{
	struct pm_vec3 wo;
	struct pm_rgb f;

	if ((max_depth >= 0 && x->depth > max_depth) ||
	    pm_dot(pm_dir_unpack(x->normal), nrm) <= PM_IRR_COS)
		return false;
	wo = pm_to_local(fr, pm_dir_unpack(x->dir));
	if (fabsf(wo.z) < 1e-4f)
		return false;
	f = pm_bsdf_eval(b, wi_local, wo, PM_RADIANCE);
	if (pm_rgb_is_black(f))
		return false;
	*out = pm_rgb_mul(pm_rgb_scale(f, 1.0f / fabsf(wo.z)),
	    pm_rgbe_unpack(x->power));
	return true;
}

/* photon_term for a Lambertian b (pm_bsdf_lambertian, its side): the
 * photon's power alone, for the caller to multiply the sum by rho / pi
 * once; the same photons count as in photon_term (but for rounding at
 * the tests' very bounds). */
static inline bool
photon_power(const struct pm_photon *x, struct pm_vec3 n, float side,
    struct pm_vec3 nrm, int max_depth, struct pm_rgb *out)
{
	struct pm_vec3 a, b;
	float ca, cb;

	if (max_depth >= 0 && x->depth > max_depth)
		return false;
	/* the two cosines' tests on the unnormalised directions, squared
	 * (cos > c for c >= 0: dot > 0 and dot^2 > c^2 |v|^2): no square
	 * root or division per photon */
	a = pm_dir_unpack_raw(x->normal);
	ca = pm_dot(a, nrm);
	if (!(ca > 0.0f && ca * ca > PM_IRR_COS * PM_IRR_COS * pm_dot(a, a)))
		return false;
	b = pm_dir_unpack_raw(x->dir);
	cb = pm_dot(b, n) * side;
	if (!(cb > 0.0f && cb * cb >= 1e-8f * pm_dot(b, b)))
		return false;
	*out = pm_rgbe_unpack(x->power);
	return true;
}

bool
pm_photon_cacheable(const struct pm_bsdf *b)
{
	return has_nonspecular(b) && !is_glossy(b) &&
	    (!pm_bsdf_is_composite(b) || (b->lobes & PM_LOBE_DIFFUSE));
}

/* The fixed-radius estimate of progressive photon mapping: every photon
 * within sqrt(r2), walked without a buffer. */
static struct pm_rgb
estimate_fixed(const struct pm_photon *ph, size_t n, float scale, float r2,
    uint8_t mask, uint8_t want, bool cone, const struct pm_bsdf *b,
    struct pm_vec3 p, struct pm_vec3 nrm, int max_depth, struct pm_frame fr,
    struct pm_vec3 wi_local)
{
	struct pm_kd_range it;
	float q[3] = {p.x, p.y, p.z}, r, d2, w;
	struct pm_rgb t;
	/* A fixed radius may hold millions of photons: sum in double, since
	 * float loses whole percents past 2^22 terms. */
	double sum[3] = {0, 0, 0};
	uint32_t idx;
	struct pm_rgb rho;
	float side;
	bool lambert;

	if (n == 0 || !(r2 > 0.0f))
		return pm_rgb1(0.0f);
	r = sqrtf(r2);
	lambert = pm_bsdf_lambertian(b, wi_local, &rho, &side);
	pm_kdtree_range_init(&it, ph, n, q, r2, mask, want);
	while (pm_kdtree_range_next(&it, &idx, &d2)) {
		if (lambert ? !photon_power(&ph[idx], fr.n, side, nrm,
		    max_depth, &t) : !photon_term(&ph[idx], b, fr, wi_local,
		    nrm, max_depth, &t))
			continue;
		w = cone ? 1.0f - sqrtf(d2) / (CONE_K * r) : 1.0f;
		sum[0] += (double)t.r * w;
		sum[1] += (double)t.g * w;
		sum[2] += (double)t.b * w;
	}
	w = scale / (PM_PI * r2);
	if (cone)
		w /= 1.0f - 2.0f / (3.0f * CONE_K);
	if (lambert) {
		sum[0] *= rho.r * PM_INV_PI;
		sum[1] *= rho.g * PM_INV_PI;
		sum[2] *= rho.b * PM_INV_PI;
	}
	return pm_rgb((float)(sum[0] * w), (float)(sum[1] * w), (float)(sum[2] * w));
}

/* Radiance towards wi_local from photons near p on a surface of normal
 * nrm (see the top of the file), of at most max_depth bounces. */
static struct pm_rgb
estimate(const struct pm_photon *ph, size_t n, const struct pm_occupancy *occ,
    float scale, float max_r2, int k, bool fixed, uint8_t mask, uint8_t want,
    bool cone, const struct pm_bsdf *b, struct pm_vec3 p, struct pm_vec3 nrm,
    int max_depth, struct pm_frame fr, struct pm_vec3 wi_local)
{
	struct pm_knn nb[PM_MAX_LOOKUP];
	float q[3] = {p.x, p.y, p.z}, r2, r, w;
	struct pm_rgb sum = pm_rgb1(0.0f), t, rho;
	size_t found, i;
	float side;
	bool lambert;

	/* nothing within the radius: what the walk would find (occ NULL:
	 * not known) */
	if (n == 0 || max_r2 <= 0.0f || !pm_occupancy_maybe(occ, q, max_r2))
		return sum;
	if (fixed)
		return estimate_fixed(ph, n, scale, max_r2, mask, want, cone, b, p,
		    nrm, max_depth, fr, wi_local);
	found = pm_kdtree_knn_unordered(ph, n, q, (size_t)k, max_r2, mask,
	    want, nb);
	if (found == 0)
		return sum;
	r2 = found == (size_t)k ? nb[0].d2 : max_r2;
	if (!(r2 > 0.0f))
		return sum;
	r = sqrtf(r2);
	lambert = pm_bsdf_lambertian(b, wi_local, &rho, &side);
	for (i = 0; i < found; i++) {
		if (lambert ? !photon_power(&ph[nb[i].idx], fr.n, side, nrm,
		    max_depth, &t) : !photon_term(&ph[nb[i].idx], b, fr,
		    wi_local, nrm, max_depth, &t))
			continue;
		w = cone ? 1.0f - sqrtf(nb[i].d2) / (CONE_K * r) : 1.0f;
		sum = pm_rgb_add(sum, pm_rgb_scale(t, w));
	}
	w = scale / (PM_PI * r2);
	if (cone)
		w /= 1.0f - 2.0f / (3.0f * CONE_K);
	if (lambert)
		sum = pm_rgb_mul(sum, pm_rgb_scale(rho, PM_INV_PI));
	return pm_rgb_scale(sum, w);
}

/* Knaus and Zwicker's radius schedule, as a multiple of the first radius. */
double
pm_pppm_radius_scale(long pass, double alpha)
{
	double s2 = 1.0;
	long i;

	if (pass < 1)
		return 0.0;
	for (i = 1; i < pass; i++)
		s2 *= ((double)i + alpha) / ((double)i + 1.0);
	return sqrt(s2);
}

/* Direct light at a non-specular hit: the mean of n light samples.  lu,
 * when not NULL, is a point of the camera pass's stratification that the
 * first light sample uses for its position on the light: over a pixel's
 * samples the light is then covered in proportion, which is what makes
 * soft shadows converge faster than independent samples do. */
static struct pm_rgb
direct_light(const struct pm_render_ctx *ctx, const struct pm_bsdf *b,
    const struct pm_hit *h, struct pm_frame fr, struct pm_vec3 wi_local, int n,
    bool mis, const float *lu, int medium, struct pm_rng *rng)
{
	struct pm_rgb L = pm_rgb1(0.0f);
	int i;

	for (i = 0; i < n; i++) {
		struct pm_light_sample ls;
		struct pm_vec3 wo;
		struct pm_rgb f;
		float u0 = pm_rng_float(rng), u1 = pm_rng_float(rng);
		float u2 = pm_rng_float(rng), w;

		if (i == 0 && lu != NULL) {
			u1 = lu[0];
			u2 = lu[1];
		}

		if (!pm_lights_sample(ctx->lights, ctx->scene, h->p, u0, u1, u2, &ls))
			continue;
		wo = pm_to_local(fr, ls.wi);
		f = pm_bsdf_eval(b, wi_local, wo, PM_RADIANCE);
		if (pm_rgb_is_black(f))
			continue;
		if (ctx->scene->nmedia > 0) {
			/* media: the shadow ray's transmittance, through
			 * index-matched boundaries (integrator_pmvol.c) */
			f = pm_rgb_mul(f, pm_volume_shadow(ctx,
			    pm_hit_origin(h, ls.wi), pm_medium_after(ctx->scene,
			    h, ls.wi, medium), &ls));
			if (pm_rgb_is_black(f))
				continue;
		} else if (pm_light_occluded(ctx->accel, h, &ls))
			continue;
		w = ls.delta || !mis ? 1.0f :
		    pm_power_heuristic(ls.pdf, pm_bsdf_pdf(b, wi_local, wo));
		L = pm_rgb_madd(L, f, pm_rgb_scale(ls.value, w / ls.pdf));
	}
	return pm_rgb_scale(L, 1.0f / (float)n);
}

/* Irradiance at p (normal nrm) from the nearest compatible record, or
 * estimated there from the global map where no record is near (rare:
 * small or thin features between records). */
static struct pm_rgb
records_irradiance(const struct pm_photon_maps *m, struct pm_vec3 p,
    struct pm_vec3 nrm)
{
	struct pm_irradiance_opts io = {
		.stride = 1, .k = m->lookup_size, .max_r2 = m->global_r2,
		.fixed_radius = m->fixed_radius,
		.max_depth = m->gather_max_depth, .threads = 1,
	};
	struct pm_rgb E;

	if (pm_irradiance_lookup(m->irradiance_grid, p, nrm, &E))
		return E;
	return pm_irradiance_estimate(m->global, m->nglobal, m->global_scale, p,
	    nrm, &io);
}

/*
 * Radiance arriving along a gather ray: from the first surface that holds
 * photons, specular surfaces on the way followed.  With irradiance
 * records the surface's radiance is its reflectance times E / pi, E from
 * the nearest record of compatible normal (exact for a Lambertian surface
 * under any light; for plastic and matte measured BRDFs, one BSDF sample
 * weighs E / pi, which is exact when the light arriving there is uniform,
 * and a sample of a specular coating goes on as a gather ray).  Glossy
 * lobes (rough conductors, shiny measured BRDFs, roughplastic's coating)
 * reflect the light around them as unevenly as it arrives (a rough coat
 * mirrors the lamp), which E / pi cannot stand for: the gather ray path
 * traces them as camera paths do, a light sample with multiple importance
 * sampling and a BSDF sample that goes on, counting the emitters it meets
 * (roughplastic's base still takes E / pi).  Without records, the whole
 * global map is looked up at the first surface that holds photons.
 */
/*
 * pm_photon_gather for a ray leaving in `medium` (-1: none) from a camera
 * path vertex number depth.  Media: each segment adds its in-scattered
 * light (integrator_pmvol.c) and weights what lies beyond by its
 * transmittance; null boundaries switch the medium and are no bounce.
 */
static struct pm_rgb
gather_in(const struct pm_render_ctx *ctx, struct pm_vec3 o, struct pm_vec3 d,
    int medium, int depth, struct pm_rng *rng, float *t, const bool *first_hit,
    const struct pm_hit *first)
{
	const struct pm_photon_maps *m = ctx->maps;
	const struct pm_scene *s = ctx->scene;
	struct pm_rgb beta = pm_rgb1(1.0f), L = pm_rgb1(0.0f);
	struct pm_bsdf glossy_tmp, base_tmp;
	struct pm_vec3 prev_p = o;
	float prev_pdf = 0.0f;
	bool traced = false, prev_delta = false;
	int bounce, crossings = 0;

	if (t != NULL)
		*t = INFINITY;
	for (bounce = 0; bounce < 16; bounce++) {
		struct pm_hit h;
		const struct pm_bsdf *b;
		struct pm_bsdf bt;	/* b with its textures looked up */
		struct pm_frame fr;
		struct pm_vec3 wi, nrm;
		struct pm_bsdf_sample bs;
		bool hit;
		float u1, u2, u3;

		if (first != NULL && bounce == 0 && crossings == 0) {
			/* found already, as pm_accel_intersect would */
			hit = *first_hit;
			if (hit)
				h = *first;
		} else
			hit = pm_accel_intersect(ctx->accel, o, d, 0.0f, INFINITY,
			    &h);
		if (medium >= 0) {
			/* media: in-scattering along the segment */
			struct pm_rgb tr;

			L = pm_rgb_madd(L, beta, pm_volume_inscatter(ctx, medium,
			    o, d, 0.0f, hit ? h.t : INFINITY, depth + bounce,
			    &tr, rng));
			beta = pm_rgb_mul(beta, tr);
			if (pm_rgb_is_black(beta))
				break;
		}
		/* light met after a glossy bounce: the light sample there
		 * took the rest of it (MIS) */
		if (traced)
			L = pm_rgb_madd(L, beta, pm_lights_emitted(ctx->lights, s,
			    hit ? &h : NULL, d, prev_p, prev_pdf, prev_delta));
		if (!hit)
			break;
		if (t != NULL && bounce == 0 && crossings == 0)
			*t = h.t;
		if (s->nmedia > 0 &&
		    s->bsdfs[s->shapes[h.shape].bsdf].type == PM_BSDF_NULL) {
			/* media: an index-matched boundary, no bounce */
			if (++crossings > 1024)
				break;
			medium = pm_medium_after(s, &h, d, medium);
			o = pm_hit_origin(&h, d);
			bounce--;
			continue;
		}
		b = pm_bsdf_frame_at(s, &h, d, &bt, &fr);
		wi = pm_to_local(fr, pm_neg(d));
		nrm = side_normal(&h, d);
		if (pm_bsdf_is_composite(b) && has_nonspecular(b)) {
			/* its diffuse parts from the maps as a diffuse
			 * surface's, the rest traced as a glossy one is (a
			 * mask's pass, a mirror in a blend, followed) */
			const struct pm_bsdf *bb = split_lobe(b,
			    PM_LOBE_DIFFUSE, &base_tmp);

			if ((b->lobes & PM_LOBE_DIFFUSE) &&
			    m->irradiance_grid == NULL)
				L = pm_rgb_madd(L, beta, estimate(m->global,
				    m->nglobal, NULL, m->global_scale,
				    m->global_r2, m->lookup_size, m->fixed_radius,
				    0, 0, false, bb, h.p, nrm, m->gather_max_depth,
				    fr, wi));
			else if (b->lobes & PM_LOBE_DIFFUSE) {
				u1 = pm_rng_float(rng);
				u2 = pm_rng_float(rng);
				u3 = pm_rng_float(rng);
				if (pm_bsdf_sample(bb, wi, u1, u2, u3, PM_RADIANCE,
				    &bs))
					L = pm_rgb_madd(L, pm_rgb_mul(beta,
					    bs.weight), pm_rgb_scale(
					    records_irradiance(m, h.p, nrm),
					    1.0f / PM_PI));
			}
			if (!(b->lobes & REST_LOBES))
				break;
			b = split_lobe(b, REST_LOBES, &glossy_tmp);
			if (b->lobes & (PM_LOBE_GLOSSY |
			    PM_LOBE_GLOSSY_TRANSMISSION))
				L = pm_rgb_madd(L, beta, direct_light(ctx, b, &h,
				    fr, wi, 1, true, NULL, medium, rng));
		} else if (has_nonspecular(b) && m->irradiance_grid == NULL)
			return pm_rgb_madd(L, beta, estimate(m->global, m->nglobal,
			    NULL, m->global_scale, m->global_r2, m->lookup_size,
			    m->fixed_radius, 0, 0, false, b, h.p, nrm,
			    m->gather_max_depth, fr, wi));
		if (has_nonspecular(b) && (is_glossy(b) || is_split(b))) {
			const struct pm_bsdf *bg = split_lobe(b, PM_LOBE_GLOSSY,
			    &glossy_tmp);

			if (is_split(b)) {
				const struct pm_bsdf *bb = split_lobe(b,
				    PM_LOBE_DIFFUSE, &base_tmp);

				u1 = pm_rng_float(rng);
				u2 = pm_rng_float(rng);
				u3 = pm_rng_float(rng);
				if (pm_bsdf_sample(bb, wi, u1, u2, u3, PM_RADIANCE,
				    &bs))
					L = pm_rgb_madd(L, pm_rgb_mul(beta,
					    bs.weight), pm_rgb_scale(records_irradiance(m,
					    h.p, nrm), 1.0f / PM_PI));
			}
			L = pm_rgb_madd(L, beta, direct_light(ctx, bg, &h, fr, wi,
			    1, true, NULL, medium, rng));
			b = bg;
		}
		u1 = pm_rng_float(rng);
		u2 = pm_rng_float(rng);
		u3 = pm_rng_float(rng);
		if (pm_bsdf_plain_diffuse(b)) {
			/* A diffuse surface ends the gather with the records'
			 * irradiance, so its BSDF sample's direction would go
			 * unused (its cosine map was 7% of a photon render):
			 * only its weight counts, the reflectance, when light
			 * can come from wi's side (pm_diffuse_sample's test,
			 * after twosided's flip).  The numbers are drawn all
			 * the same: the random stream stays as it was. */
			float wz = b->twosided && wi.z < 0.0f ? -wi.z : wi.z;

			if (wz <= 0.0f)
				break;
			return pm_rgb_madd(L, pm_rgb_mul(beta, b->diffuse),
			    pm_rgb_scale(records_irradiance(m, h.p, nrm),
			    1.0f / PM_PI));
		}
		if (!pm_bsdf_sample(b, wi, u1, u2, u3, PM_RADIANCE, &bs))
			break;
		beta = pm_rgb_mul(beta, bs.weight);
		if (!(bs.lobe & PM_LOBE_DELTA) && has_nonspecular(b) &&
		    !is_glossy(b) && !is_split(b) && !pm_bsdf_is_composite(b))
			return pm_rgb_madd(L, beta, pm_rgb_scale(records_irradiance(m,
			    h.p, nrm), 1.0f / PM_PI));
		if (!(bs.lobe & PM_LOBE_DELTA) && has_nonspecular(b))
			traced = true;
		prev_p = h.p;
		prev_pdf = bs.pdf;
		/* no light sample was taken at glass, clear or rough: what
		 * it lets through counts in full */
		prev_delta = (bs.lobe & PM_LOBE_DELTA) || !has_nonspecular(b);
		d = pm_normalize(pm_to_world(fr, bs.wo));
		o = pm_hit_origin(&h, d);
		if (s->nmedia > 0)
			medium = pm_medium_after(s, &h, d, medium);
	}
	return L;
}

/* Without media information: the irradiance cache's rays (render.c),
 * which scenes with media do not use (pm-render turns the cache off). */
struct pm_rgb
pm_photon_gather(const struct pm_render_ctx *ctx, struct pm_vec3 o,
    struct pm_vec3 d, struct pm_rng *rng, float *t)
{
	return gather_in(ctx, o, d, -1, 1, rng, t, NULL, NULL);
}

struct pm_rgb
pm_photon_gather_hit(const struct pm_render_ctx *ctx, struct pm_vec3 o,
    struct pm_vec3 d, struct pm_rng *rng, float *t, bool hit,
    const struct pm_hit *h)
{
	return gather_in(ctx, o, d, -1, 1, rng, t, &hit, h);
}

/* Indirect light at a diffuse hit by final gathering: BSDF-sampled rays;
 * samples of a specular lobe are left to the specular recursion. */
static struct pm_rgb
final_gather(const struct pm_render_ctx *ctx, const struct pm_bsdf *b,
    const struct pm_hit *h, struct pm_frame fr, struct pm_vec3 wi_local,
    int medium, int depth, struct pm_rng *rng)
{
	int i, n = ctx->maps->final_gather_samples;
	struct pm_rgb L = pm_rgb1(0.0f);

	for (i = 0; i < n; i++) {
		struct pm_bsdf_sample bs;
		struct pm_vec3 d;
		float u1 = pm_rng_float(rng), u2 = pm_rng_float(rng);
		float u3 = pm_rng_float(rng);

		if (!pm_bsdf_sample(b, wi_local, u1, u2, u3, PM_RADIANCE, &bs) ||
		    (bs.lobe & PM_LOBE_DELTA))
			continue;
		d = pm_normalize(pm_to_world(fr, bs.wo));
		L = pm_rgb_madd(L, bs.weight, gather_in(ctx,
		    pm_hit_origin(h, d), d, ctx->scene->nmedia > 0 ?
		    pm_medium_after(ctx->scene, h, d, medium) : -1, depth + 1,
		    rng, NULL, NULL, NULL));
	}
	return pm_rgb_scale(L, 1.0f / (float)n);
}

/*
 * Whether a plain diffuse BSDF's sample from (u2, u3) succeeds, for a
 * caller that needs only its weight (the reflectance), without the warp
 * whose direction would go unused (its cosine map was 4% of a photon
 * render): it does exactly when wi is above the surface (after twosided's
 * flip) and the warped direction above the horizon, which every point of
 * the disk well inside its rim is (radius below 0.999: x^2 + y^2 stays
 * below 0.999, the polynomials' sine and cosine within 1e-6 of a unit
 * pair).  1 or 0, or -1 where only the warp can tell.
 */
static inline int
diffuse_sample_ok(const struct pm_bsdf *b, struct pm_vec3 wi, float u2,
    float u3)
{
	float wz = b->twosided && wi.z < 0.0f ? -wi.z : wi.z;
	float a = 2.0f * u2 - 1.0f, c = 2.0f * u3 - 1.0f;

	if (wz <= 0.0f)
		return 0;
	return pm_fmaxf(fabsf(a), fabsf(c)) < 0.999f ? 1 : -1;
}

/* Indirect light at a camera path's non-specular vertex: from the
 * irradiance cache at the first surface seen (one BSDF sample weighs the
 * cached E / pi: exact for a Lambertian surface, and for the others'
 * non-specular lobes when the light around is uniform), else by final
 * gathering. */
static struct pm_rgb
indirect(const struct pm_render_ctx *ctx, const struct pm_bsdf *b,
    const struct pm_hit *h, struct pm_frame fr, struct pm_vec3 wi,
    struct pm_vec3 nrm, int depth, float fx, float fy, int medium,
    struct pm_rng *rng)
{
	struct pm_rgb E;

	if (depth == 1 && pm_icache_lookup(ctx->icache, fx, fy, h->p, nrm, &E)) {
		struct pm_bsdf_sample bs;
		float u1 = pm_rng_float(rng), u2 = pm_rng_float(rng);
		float u3 = pm_rng_float(rng);
		int ok = pm_bsdf_plain_diffuse(b) ?
		    diffuse_sample_ok(b, wi, u2, u3) : -1;

		if (ok == 0)
			return pm_rgb1(0.0f);
		if (ok == 1)
			return pm_rgb_mul(b->diffuse, pm_rgb_scale(E,
			    1.0f / PM_PI));
		if (!pm_bsdf_sample(b, wi, u1, u2, u3, PM_RADIANCE, &bs) ||
		    (bs.lobe & PM_LOBE_DELTA))
			return pm_rgb1(0.0f);
		return pm_rgb_mul(bs.weight, pm_rgb_scale(E, 1.0f / PM_PI));
	}
	return final_gather(ctx, b, h, fr, wi, medium, depth, rng);
}

static struct pm_rgb photon_li(const struct pm_render_ctx *ctx,
    struct pm_vec3 o, struct pm_vec3 d, float tmin, float tmax,
    const struct pm_camera_sample *cs, struct pm_rng *rng,
    const bool *first_hit, const struct pm_hit *first);

struct pm_rgb
pm_photon_li(const struct pm_render_ctx *ctx, struct pm_vec3 o, struct pm_vec3 d,
    float tmin, float tmax, struct pm_rng *rng)
{
	struct pm_camera_sample cs = { NAN, NAN, { -1.0f, -1.0f } };

	return pm_photon_li_px(ctx, o, d, tmin, tmax, &cs, rng);
}

struct pm_rgb
pm_photon_li_px(const struct pm_render_ctx *ctx, struct pm_vec3 o,
    struct pm_vec3 d, float tmin, float tmax, const struct pm_camera_sample *cs,
    struct pm_rng *rng)
{
	return photon_li(ctx, o, d, tmin, tmax, cs, rng, NULL, NULL);
}

struct pm_rgb
pm_photon_li_px_hit(const struct pm_render_ctx *ctx, struct pm_vec3 o,
    struct pm_vec3 d, float tmin, float tmax, const struct pm_camera_sample *cs,
    struct pm_rng *rng, bool hit, const struct pm_hit *h)
{
	return photon_li(ctx, o, d, tmin, tmax, cs, rng, &hit, h);
}

/* The camera path; first_hit and first, when not NULL, are the camera
 * ray's hit found already. */
static struct pm_rgb
photon_li(const struct pm_render_ctx *ctx, struct pm_vec3 o,
    struct pm_vec3 d, float tmin, float tmax, const struct pm_camera_sample *cs,
    struct pm_rng *rng, const bool *first_hit, const struct pm_hit *first)
{
	const struct pm_scene *s = ctx->scene;
	const struct pm_photon_maps *m = ctx->maps;
	struct pm_rgb L = pm_rgb1(0.0f);
	struct pm_path pa;
	const float *lu = cs->lu[0] >= 0.0f ? cs->lu : NULL;
	float fx = cs->fx, fy = cs->fy;
	int depth;
	/* media: the ray's medium (-1: none) */
	int medium = s->camera_medium - 1, crossings = 0;

	pm_path_start(&pa, o, d, tmin, tmax);
	for (depth = 1;; depth++) {
		struct pm_hit h;
		bool hit;
		const struct pm_bsdf *b;
		struct pm_bsdf bt;	/* b with its textures looked up */
		struct pm_bsdf_sample bs;
		struct pm_frame fr;
		struct pm_vec3 wi;
		float u1, u2, u3;

		if (first_hit != NULL) {
			/* the camera ray's, once */
			hit = *first_hit;
			if (hit)
				h = *first;
			first_hit = NULL;
		} else {
			hit = pm_accel_intersect(ctx->accel, pa.o, pa.d,
			    pa.tmin, pa.tmax, &h);
		}
		if (medium >= 0) {
			/* media: in-scattering along the segment, then what
			 * lies beyond through its transmittance */
			struct pm_rgb tr;

			L = pm_rgb_madd(L, pa.beta, pm_volume_inscatter(ctx,
			    medium, pa.o, pa.d, pa.tmin, hit ? h.t : pa.tmax,
			    depth, &tr, rng));
			pa.beta = pm_rgb_mul(pa.beta, tr);
			if (pm_rgb_is_black(pa.beta))
				break;
		}
		if (!(depth == 1 && ctx->hide_emitters))
			L = pm_rgb_madd(L, pa.beta, pm_lights_emitted(ctx->lights, s,
			    hit ? &h : NULL, pa.d, pa.prev_p, pa.prev_pdf, pa.prev_delta));
		if (!hit)
			break;
		if (s->nmedia > 0 &&
		    s->bsdfs[s->shapes[h.shape].bsdf].type == PM_BSDF_NULL) {
			/* media: an index-matched boundary, no vertex */
			if (++crossings > 1024)
				break;
			medium = pm_medium_after(s, &h, pa.d, medium);
			pa.o = pm_hit_origin(&h, pa.d);
			pa.tmin = 0.0f;
			pa.tmax = INFINITY;
			depth--;
			continue;
		}
		if (ctx->max_depth >= 0 && depth >= ctx->max_depth)
			break;
		b = pm_bsdf_frame_at(s, &h, pa.d, &bt, &fr);
		wi = pm_to_local(fr, pm_neg(pa.d));

		if (is_glossy(b)) {
			/* Path traced: light sampling here, BSDF sampling on. */
			L = pm_rgb_madd(L, pa.beta, direct_light(ctx, b, &h, fr, wi,
			    1, true, lu, medium, rng));
			lu = NULL;
		} else if (has_nonspecular(b) && (!pm_bsdf_is_composite(b) ||
		    (b->lobes & PM_LOBE_DIFFUSE))) {
			/* roughplastic: its diffuse base here, its coating
			 * below; a BSDF made of others: its diffuse parts
			 * here, the rest below */
			struct pm_bsdf base_tmp;
			const struct pm_bsdf *bb = split_lobe(b,
			    PM_LOBE_DIFFUSE, &base_tmp);
			struct pm_rgb E = direct_light(ctx, bb, &h, fr, wi,
			    m->direct_samples, false, lu, medium, rng);

			lu = NULL;

			struct pm_vec3 nrm = side_normal(&h, pa.d);
			/* Photons of d bounces close paths of depth + d + 1
			 * segments here; max_depth counts segments. */
			int dcap = ctx->max_depth < 0 ? 255 :
			    ctx->max_depth - depth - 1;

			E = pm_rgb_add(E, estimate(m->caustic, m->ncaustic,
			    m->caustic_occ, m->caustic_scale, m->caustic_r2,
			    m->lookup_size, m->fixed_radius, 0, 0, true,
			    bb, h.p, nrm, dcap, fr, wi));
			/* A gather ray adds a segment and its surface's
			 * photons at least one more. */
			bool gather_fits = ctx->max_depth < 0 ||
			    depth + 2 <= ctx->max_depth;

			if (m->final_gather) {
				if (gather_fits)
					E = pm_rgb_add(E, indirect(ctx, bb, &h, fr,
					    wi, nrm, depth, fx, fy, medium,
					    rng));
			} else
				E = pm_rgb_add(E, estimate(m->global, m->nglobal,
				    NULL, m->global_scale, m->global_r2,
				    m->lookup_size, m->fixed_radius,
				    PM_PHOTON_VIA_DIFFUSE, PM_PHOTON_VIA_DIFFUSE,
				    false, bb, h.p, nrm, dcap, fr, wi));
			L = pm_rgb_madd(L, pa.beta, E);
			if (!(b->lobes & (PM_LOBE_DELTA | PM_LOBE_GLOSSY |
			    PM_LOBE_TRANSMISSION |
			    PM_LOBE_DIFFUSE_TRANSMISSION)))
				break;
		}

		if (pm_bsdf_is_composite(b)) {
			/* The rest of a BSDF made of others, traced as a
			 * glossy surface is (light sampling with MIS for
			 * its glossy parts) and sampled on, its mirrors and
			 * a mask's pass followed as any specular surface. */
			struct pm_bsdf rest_tmp;
			const struct pm_bsdf *br = split_lobe(b, REST_LOBES,
			    &rest_tmp);

			if (b->lobes & (PM_LOBE_GLOSSY |
			    PM_LOBE_GLOSSY_TRANSMISSION)) {
				L = pm_rgb_madd(L, pa.beta, direct_light(ctx, br,
				    &h, fr, wi, 1, true, lu, medium, rng));
				lu = NULL;
			}
			u1 = pm_rng_float(rng);
			u2 = pm_rng_float(rng);
			u3 = pm_rng_float(rng);
			if (!pm_bsdf_sample(br, wi, u1, u2, u3, PM_RADIANCE, &bs))
				break;
		} else if (is_split(b)) {
			/* A diffuse base with a rough coating (or a
			 * principled BSDF's other lobes): the base is
			 * estimated above, the rest path traced as a rough
			 * conductor is (light sampling with MIS here, then
			 * a sample of the rest alone), every time. */
			struct pm_bsdf coat_tmp;
			const struct pm_bsdf *bc = split_lobe(b,
			    PM_LOBE_GLOSSY, &coat_tmp);

			L = pm_rgb_madd(L, pa.beta, direct_light(ctx, bc, &h, fr,
			    wi, 1, true, NULL, medium, rng));
			u1 = pm_rng_float(rng);
			u2 = pm_rng_float(rng);
			u3 = pm_rng_float(rng);
			if (!pm_bsdf_sample(bc, wi, u1, u2, u3, PM_RADIANCE, &bs))
				break;
		} else if (!is_glossy(b) && has_nonspecular(b)) {
			/* A diffuse base with a smooth coating: the base is
			 * estimated above, the coating followed every time
			 * (one path, so no splitting blow-up). */
			if (!pm_bsdf_coating(b, wi, &bs))
				break;
		} else {
			u1 = pm_rng_float(rng);
			u2 = pm_rng_float(rng);
			u3 = pm_rng_float(rng);
			if (!pm_bsdf_sample(b, wi, u1, u2, u3, PM_RADIANCE, &bs))
				break;
		}
		if (!pm_path_continue(&pa, &h, fr, &bs, depth, ctx->rr_depth, rng))
			break;
		if (s->nmedia > 0)
			medium = pm_medium_after(s, &h, pa.d, medium);
	}
	return L;
}
