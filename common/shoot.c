/*
 * shoot.c: photon emission and tracing.
 *
 * Global pass: lights chosen by power, area lights emit from a point uniform
 * by area in a cosine-weighted direction, point lights over the sphere, spot
 * lights in their cone, the environment from a disk outside the scene; so
 * every photon leaves with about the same flux.  At each hit a photon is
 * stored if the surface has a non-specular component, then the BSDF is
 * sampled (importance transport) and Russian roulette with the sampled
 * weight as survival probability keeps surviving photons' flux similar
 * (Jensen 2004, sec. 5.3).
 *
 * Rough dielectrics (and principled BSDFs that transmit and have no
 * diffuse base) count as specular here: photons are not stored on them
 * and cross them on caustic paths (the camera pass traces them).
 *
 * Caustic pass: photons are aimed at the bounding spheres of the specular
 * shapes, the direction drawn from the mixture of the cones they subtend
 * (lights far away, the environment and directional lights: the origin
 * drawn from the mixture of the spheres' shadow disks), and the flux
 * divided by that mixture's true density, so that nothing is gained or
 * lost; only paths light, specular+, non-specular are stored.
 *
 * Participating media (Jensen and Christensen 1998): a photon travelling
 * in a medium samples a free flight from the exponential of one channel
 * chosen uniformly per flight (a heterogeneous medium: delta tracking of
 * that channel against the majorant grid, medium.h) and is weighted by
 * the flight's RGB value over the density averaged over the channels
 * (one-sample MIS; in a grey medium exactly 1 past the flight, the
 * albedo at the scatter point: null collisions cancel between the two).
 * The global pass stores a volume photon at every scatter, with the flux
 * that leaves it before Russian roulette (so already times the albedo
 * for that flight), then plays roulette on that weight and samples the
 * phase function; a scatter is a non-specular bounce.  Volumetric
 * caustics (light, specular+, scatter) go into the same volume map,
 * flagged PM_PHOTON_CAUSTIC: the camera pass estimates in-scattering
 * from all of them alike, and only needs the flag to tell them apart
 * for statistics.  The caustic pass ends a photon at a scatter (its
 * path is no longer specular; the global pass holds that light).
 * Null-BSDF boundaries only switch the medium, as in the path tracer:
 * no bounce, no specular event.
 */
#include <math.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "integrator.h"
#include "merl.h"
#include "rng.h"
#include "sampling.h"
#include "shoot.h"
#include "frame.h"
#include "texture.h"
#include "lanes.h"

/* A photon stuck between mirrors, or inside glass by total internal
 * reflection, stops here even when the depth is unlimited. */
#define HARD_MAX_BOUNCES 1000
#define CHUNK 2048
/* Bound on null-BSDF boundaries a photon (or a medium probe) crosses. */
#define MAX_CROSSINGS 1024

/* Surfaces that hold photons.  Not a rough dielectric: light crosses it as
 * it crosses glass, and it passes photons on as glass does (below). */
static inline bool
bsdf_has_nonspecular(const struct pm_bsdf *b)
{
	return b->type != PM_BSDF_NULL && !pm_bsdf_passes_photons(b) &&
	    (b->lobes & (PM_LOBE_DIFFUSE | PM_LOBE_GLOSSY | PM_LOBE_GLOSSY_TRANSMISSION));
}

/* Whether a surface reflects anything at all, for the effects summary. */
static bool
bsdf_reflects(const struct pm_bsdf *b)
{
	if (b->type == PM_BSDF_MERL)
		return b->merl != NULL &&
		    pm_rgb_max(pm_merl_albedo(b->merl, 0.0f)) > 0.0f;
	/* blendbsdf, mask, twosided with two: what they hold decides */
	if (pm_bsdf_is_composite(b))
		return (b->sub[0] != NULL && bsdf_reflects(b->sub[0])) ||
		    (b->sub[1] != NULL && bsdf_reflects(b->sub[1]));
	return pm_rgb_max(pm_rgb_add(b->diffuse, b->type == PM_BSDF_DIFFUSE ?
	    pm_rgb1(0) : b->specular)) > 0.0f;
}

/* Surfaces that make caustics: a delta component, or a rough dielectric,
 * whose every scattering keeps a photon on a caustic path (frosted glass
 * focuses light less sharply than clear glass, but the camera pass can
 * only see light through it in the caustic map: it traces the glass and
 * estimates the diffuse surface behind). */
static inline bool
bsdf_has_specular(const struct pm_bsdf *b)
{
	return b->type != PM_BSDF_NULL && ((b->lobes & PM_LOBE_DELTA) ||
	    pm_bsdf_passes_photons(b));
}

/* Whether a sampled event keeps a photon's path specular. */
static bool
event_specular(const struct pm_bsdf *b, const struct pm_bsdf_sample *bs)
{
	return (bs->lobe & PM_LOBE_DELTA) || pm_bsdf_passes_photons(b);
}

void
pm_shoot_effects(const struct pm_scene *s, struct pm_effects *e)
{
	e->media = s->nmedia > 0 && s->nlights > 0;
	size_t i;
	int nrefl = 0, nspec = 0, nrefr = 0;
	struct pm_effect_note *no = e->notes;

	for (i = 0; i < s->nshapes; i++) {
		const struct pm_bsdf *b = &s->bsdfs[s->shapes[i].bsdf];

		if (bsdf_has_nonspecular(b) && bsdf_reflects(b))
			nrefl++;
		if (bsdf_has_specular(b))
			nspec++;
		if (b->type == PM_BSDF_DIELECTRIC ||
		    b->type == PM_BSDF_THINDIELECTRIC ||
		    b->type == PM_BSDF_ROUGHDIELECTRIC ||
		    (b->lobes & PM_LOBE_GLOSSY_TRANSMISSION))
			nrefr++;
	}
	e->nspecular = nspec;
	e->global = nrefl > 0 && s->nlights > 0 &&
	    (s->integrator.max_depth < 0 || s->integrator.max_depth > 2);
	e->caustic = nspec > 0 && nrefl > 0 && s->nlights > 0;
	e->refraction = nrefr > 0;
	no[0].name = "global";
	snprintf(no[0].text, sizeof(no[0].text), "%s (%d shape%s reflect%s "
	    "diffusely or glossily%s)", e->global ? "yes" : "no", nrefl,
	    nrefl == 1 ? "" : "s", nrefl == 1 ? "s" : "",
	    s->integrator.max_depth >= 0 && s->integrator.max_depth <= 2 ?
	    ", but max_depth allows direct light only" : "");
	no[1].name = "caustics";
	snprintf(no[1].text, sizeof(no[1].text), "%s (%d shape%s with a "
	    "specular component%s)", e->caustic ? "yes" : "no", nspec,
	    nspec == 1 ? "" : "s",
	    nspec > 0 && nrefl == 0 ? ", but nothing diffuse to receive them" : "");
	no[2].name = "refraction";
	snprintf(no[2].text, sizeof(no[2].text), "%s (%d dielectric shape%s)",
	    e->refraction ? "yes" : "no", nrefr, nrefr == 1 ? "" : "s");
}

/*
 * The time a photon map saves is spent again rendering with it, so the
 * count that gives the least error in a given time grows with the render:
 * on data/cornell-box.xml and data/bunny.xml at 128x128 from 2 to 256
 * samples per pixel, the error per second was best with about one photon
 * path per ten camera samples (docs/accuracy.md); below 10000 paths the
 * irradiance records' noise shows even at one sample per pixel, and above
 * a million the map costs more to shoot and balance than it saves.
 */
long long
pm_shoot_default_paths(const struct pm_scene *s)
{
	double n;

	if (!s->has_camera)
		return PM_PATHS_NO_CAMERA;
	n = (double)s->camera.width * s->camera.height * s->camera.spp /
	    PM_SAMPLES_PER_PATH;
	if (n < PM_PATHS_MIN)
		return PM_PATHS_MIN;
	if (n > PM_PATHS_MAX)
		return PM_PATHS_MAX;
	return (long long)(n + 0.5);
}

int
pm_shoot_default_max_depth(const struct pm_scene *s)
{
	int md = s->integrator.max_depth;

	return md < 0 ? -1 : (md > 2 ? md - 2 : 0);
}

void
pm_photon_buf_free(struct pm_photon_buf *b)
{
	free(b->p);
	b->p = NULL;
	b->n = b->cap = 0;
}

/* Doubles b's room; false without memory. */
static __attribute__((noinline)) bool
buf_grow(struct pm_photon_buf *b)
{
	size_t cap = b->cap ? 2 * b->cap : 256;
	struct pm_photon *np = realloc(b->p, cap * sizeof(*np));

	if (np == NULL)
		return false;
	b->p = np;
	b->cap = cap;
	return true;
}

/* A new last photon of b, for the caller to fill in place; NULL without
 * memory.  Filled in place, not built and copied: a photon built field
 * by field (bytes among them) and then copied whole is read back before
 * its small stores can be forwarded, a stall a photon (the old push was
 * a thirtieth of the Cornell box's photon pass). */
static inline struct pm_photon *
buf_slot(struct pm_photon_buf *b)
{
	if (b->n == b->cap && !buf_grow(b))
		return NULL;
	return &b->p[b->n++];
}

static inline bool
buf_push(struct pm_photon_buf *b, const struct pm_photon *p)
{
	struct pm_photon *q = buf_slot(b);

	if (q == NULL)
		return false;
	*q = *p;
	return true;
}

static int light_medium(const struct pm_shooter *sh, size_t li);

/*
 * How a round (trace_paths) takes a global photon's bounces at a shape,
 * given bounces left and a finite flux: in diffuse_lanes at an untextured
 * isotropic plain diffuse BSDF, in coat_lanes at such a smooth plastic
 * with both its lobes (where there are lanes: PM_LANES), else one by one
 * (bounce).  Either way the result is bounce's.
 */
enum lane_kind { LANE_NONE, LANE_DIFFUSE, LANE_COAT };

static enum lane_kind
lane_kind(const struct pm_bsdf *b)
{
	if (pm_bsdf_textured(b) || pm_bsdf_needs_tangent(b) ||
	    !bsdf_has_nonspecular(b))
		return LANE_NONE;
	if (pm_bsdf_plain_diffuse(b) && !bsdf_has_specular(b))
		return LANE_DIFFUSE;
	if (PM_LANES && b->type == PM_BSDF_PLASTIC && !b->perturbed &&
	    b->only == 0)
		return LANE_COAT;
	return LANE_NONE;
}

enum pm_err
pm_shooter_init(struct pm_shooter *sh, const struct pm_scene *s,
    const struct pm_accel *a, const struct pm_lights *ls, struct pm_error *err)
{
	size_t i;

	memset(sh, 0, sizeof(*sh));
	sh->scene = s;
	sh->accel = a;
	sh->lights = ls;
	if (s->nmedia > 0) {
		sh->light_medium = calloc(s->nlights + 1,
		    sizeof(*sh->light_medium));
		if (sh->light_medium == NULL)
			return pm_fail(err, PM_ERR_NOMEM, "no memory for the "
			    "lights' media");
		for (i = 0; i < s->nlights; i++)
			sh->light_medium[i] = light_medium(sh, i);
	}
	sh->aim_center = calloc(s->nshapes + 1, sizeof(*sh->aim_center));
	sh->aim_radius = calloc(s->nshapes + 1, sizeof(*sh->aim_radius));
	sh->lane = calloc(s->nshapes + 1, sizeof(*sh->lane));
	if (sh->aim_center == NULL || sh->aim_radius == NULL ||
	    sh->lane == NULL) {
		pm_shooter_free(sh);
		return pm_fail(err, PM_ERR_NOMEM, "no memory for caustic targets");
	}
	for (i = 0; i < s->nshapes; i++)
		sh->lane[i] = (uint8_t)lane_kind(&s->bsdfs[s->shapes[i].bsdf]);
	for (i = 0; i < s->nshapes; i++) {
		const struct pm_shape *shp = &s->shapes[i];
		struct pm_vec3 lo, hi, c;
		float r = 0.0f;
		uint32_t v;

		if (!bsdf_has_specular(&s->bsdfs[shp->bsdf]))
			continue;
		if (shp->type == PM_SHAPE_SPHERE) {
			c = shp->center;
			r = shp->radius;
		} else {
			if (shp->mesh.nverts == 0)
				continue;
			lo = hi = pm_mesh_vertex(&shp->mesh, 0);
			for (v = 1; v < shp->mesh.nverts; v++) {
				struct pm_vec3 p = pm_mesh_vertex(&shp->mesh, v);

				lo = pm_v3(pm_fminf(lo.x, p.x), pm_fminf(lo.y, p.y), pm_fminf(lo.z, p.z));
				hi = pm_v3(pm_fmaxf(hi.x, p.x), pm_fmaxf(hi.y, p.y), pm_fmaxf(hi.z, p.z));
			}
			c = pm_scale(pm_add(lo, hi), 0.5f);
			for (v = 0; v < shp->mesh.nverts; v++)
				r = pm_fmaxf(r, pm_length(pm_sub(pm_mesh_vertex(&shp->mesh, v), c)));
		}
		/* A little margin so that rounding never leaves a sliver out. */
		sh->aim_center[sh->naim] = c;
		sh->aim_radius[sh->naim] = r * 1.001f + 1e-6f;
		sh->naim++;
	}
	return PM_OK;
}

void
pm_shooter_free(struct pm_shooter *sh)
{
	free(sh->light_medium);
	free(sh->lane);
	sh->light_medium = NULL;
	free(sh->aim_center);
	free(sh->aim_radius);
	sh->aim_center = NULL;
	sh->aim_radius = NULL;
	sh->naim = 0;
}

/*
 * The medium at point x: found along a probe ray from x, whose first
 * crossing of a shape that names media says which lies on x's side
 * (shapes that name none keep the medium a ray has, so the probe looks
 * past them).  Nothing met: vacuum (-1).
 */
static int
medium_at(const struct pm_scene *s, const struct pm_accel *a, struct pm_vec3 x)
{
	struct pm_vec3 d = pm_normalize(pm_v3(0.2718f, 0.5772f, 0.7071f));
	struct pm_hit h;
	float tmin = 0.0f;
	int i;

	for (i = 0; i < MAX_CROSSINGS; i++) {
		const struct pm_shape *shp;

		if (!pm_accel_intersect(a, x, d, tmin, INFINITY, &h))
			return -1;
		shp = &s->shapes[h.shape];
		if (shp->interior != 0 || shp->exterior != 0)
			return (pm_dot(d, h.ng) < 0.0f ? shp->exterior :
			    shp->interior) - 1;
		x = pm_hit_origin(&h, d);
		tmin = 0.0f;
	}
	return -1;
}

static void sample_shape_point(const struct pm_shooter *sh, int li, float u1,
    float u2, struct pm_vec3 *p, struct pm_vec3 *ng, struct pm_vec3 *ns,
    struct pm_hit *lh);

/*
 * The medium light li's photons start in.  Point and spot lights: the
 * one at their position.  Area lights: the exterior of their shape if it
 * names one (they emit from its front), else the one at a point of it,
 * just in front.  Lights from outside the scene: vacuum.
 */
static int
light_medium(const struct pm_shooter *sh, size_t li)
{
	const struct pm_scene *s = sh->scene;
	const struct pm_light *l = &s->lights[li];
	struct pm_vec3 p, ng, ns;
	struct pm_hit lh;

	switch (l->type) {
	case PM_LIGHT_POINT:
	case PM_LIGHT_SPOT:
	case PM_LIGHT_PROJECTOR:
		return medium_at(s, sh->accel, l->position);
	case PM_LIGHT_AREA:
		if (s->shapes[l->shape].exterior != 0)
			return s->shapes[l->shape].exterior - 1;
		sample_shape_point(sh, (int)li, 0.5f, 0.5f, &p, &ng, &ns, &lh);
		return medium_at(s, sh->accel, pm_madd(p, ng,
		    1e-4f * pm_fmaxf(s->radius, 1e-3f)));
	default:
		return -1;
	}
}

/* Cosine of the cone that target j subtends from x; -1 if x is inside. */
static float
aim_cos(const struct pm_shooter *sh, int j, struct pm_vec3 x, struct pm_vec3 *axis)
{
	struct pm_vec3 d = pm_sub(sh->aim_center[j], x);
	float dist = pm_length(d), r = sh->aim_radius[j], s;

	*axis = dist > 0.0f ? pm_scale(d, 1.0f / dist) : pm_v3(0, 0, 1);
	if (dist <= r)
		return -1.0f;
	s = r / dist;
	return sqrtf(pm_fmaxf(0.0f, 1.0f - s * s));
}

/* Density of the aiming mixture for direction w leaving x. */
static float
aim_pdf(const struct pm_shooter *sh, struct pm_vec3 x, struct pm_vec3 w)
{
	float pdf = 0.0f;
	int j;

	for (j = 0; j < sh->naim; j++) {
		struct pm_vec3 axis;
		float c = aim_cos(sh, j, x, &axis);

		if (c <= -1.0f)
			pdf += pm_uniform_sphere_pdf();
		else if (pm_dot(w, axis) >= c)
			pdf += pm_uniform_cone_pdf(c);
	}
	return pdf / (float)sh->naim;
}

static struct pm_vec3
aim_sample(const struct pm_shooter *sh, struct pm_vec3 x, float u0, float u1,
    float u2)
{
	int j = (int)(u0 * (float)sh->naim);
	struct pm_vec3 axis;
	float c;

	if (j >= sh->naim)
		j = sh->naim - 1;
	c = aim_cos(sh, j, x, &axis);
	if (c <= -1.0f)
		return pm_square_to_uniform_sphere(u1, u2);
	return pm_to_world(pm_frame_from_normal(axis),
	    pm_square_to_uniform_cone(u1, u2, c));
}

/* Point on an area light's shape, its geometric and shading normals;
 * *lh says where it lies for a textured radiance's uv. */
static void
sample_shape_point(const struct pm_shooter *sh, int li, float u1, float u2,
    struct pm_vec3 *p, struct pm_vec3 *ng, struct pm_vec3 *ns,
    struct pm_hit *lh)
{
	const struct pm_scene *s = sh->scene;
	const struct pm_shape *shp = &s->shapes[s->lights[li].shape];

	lh->shape = s->lights[li].shape;
	lh->prim = 0;
	lh->u = lh->v = 0.0f;
	if (shp->type == PM_SHAPE_SPHERE) {
		struct pm_vec3 u = pm_square_to_uniform_sphere(u1, u2);

		*p = pm_madd(shp->center, u, shp->radius);
		*ng = *ns = shp->flip_normals ? pm_neg(u) : u;
	} else if (sh->lights->quad[li].on) {
		/* one flat, untextured parallelogram (light.h): directly
		 * on it, with its normals found once, as light samples do */
		const struct pm_light_quad *q = &sh->lights->quad[li];

		*p = pm_madd(pm_madd(q->p0, q->e1, u1), q->e2, u2);
		*ng = q->n;
		*ns = q->ns;
	} else {
		const struct pm_mesh *m = &shp->mesh;
		size_t t = pm_distrib_sample(&sh->lights->tris[li], u1, &u1);
		const uint32_t *ix = &m->idx[3 * t];
		struct pm_vec3 p0 = pm_mesh_vertex(m, ix[0]);
		struct pm_vec3 p1 = pm_mesh_vertex(m, ix[1]);
		struct pm_vec3 p2 = pm_mesh_vertex(m, ix[2]);
		float b1, b2;

		pm_square_to_triangle(u1, u2, &b1, &b2);
		lh->prim = (uint32_t)t;
		lh->u = b1;
		lh->v = b2;
		*p = pm_add(pm_add(pm_scale(p0, 1.0f - b1 - b2), pm_scale(p1, b1)),
		    pm_scale(p2, b2));
		*ng = pm_normalize(pm_cross(pm_sub(p1, p0), pm_sub(p2, p0)));
		*ns = *ng;
		if (m->nrm != NULL) {
			struct pm_vec3 sum = pm_v3(0, 0, 0);
			float bw[3] = {1.0f - b1 - b2, b1, b2};
			int k;

			for (k = 0; k < 3; k++)
				sum = pm_madd(sum, pm_v3(m->nrm[3 * ix[k]],
				    m->nrm[3 * ix[k] + 1], m->nrm[3 * ix[k] + 2]), bw[k]);
			if (pm_length(sum) > 1e-6f)
				*ns = pm_normalize(sum);
		}
	}
}

/*
 * A point in the plane through the scene's centre across direction n, for
 * a caustic photon from far away travelling along -n: inside the shadow
 * disk of one aiming sphere, chosen uniformly, and uniform within it.
 * Returns the point's density over that plane: the mixture of the disks,
 * each uniform, so that overlapping disks are counted right.
 */
static struct pm_vec3
aim_disk_sample(const struct pm_shooter *sh, struct pm_vec3 n,
    struct pm_frame f, float u0, float u1, float u2, float *pdf)
{
	const struct pm_vec3 o = sh->scene->center;
	int j = (int)(u0 * (float)sh->naim), k;
	struct pm_vec3 x;
	float dx, dy, p = 0.0f;

	if (j >= sh->naim)
		j = sh->naim - 1;
	pm_square_to_disk(u1, u2, &dx, &dy);
	x = pm_sub(sh->aim_center[j], pm_scale(n, pm_dot(pm_sub(
	    sh->aim_center[j], o), n)));
	x = pm_madd(pm_madd(x, f.s, dx * sh->aim_radius[j]), f.t,
	    dy * sh->aim_radius[j]);
	for (k = 0; k < sh->naim; k++) {
		struct pm_vec3 c = pm_sub(sh->aim_center[k], pm_scale(n,
		    pm_dot(pm_sub(sh->aim_center[k], o), n)));
		struct pm_vec3 d = pm_sub(x, c);
		float r = sh->aim_radius[k];

		if (pm_dot(d, d) <= r * r)
			p += 1.0f / (PM_PI * r * r);
	}
	*pdf = p / (float)sh->naim;
	return x;
}

/*
 * A direction through a projector's image and its solid-angle density.
 * A point (u, v) of the image plane at z = 1 (the perspective camera's
 * mapping, of area (2 tan_fov)^2 / aspect) is drawn with density p(u, v)
 * over [0, 1]^2: by texel where the light tables have the image's
 * (light.c: half by brightness, half uniform), else uniformly; the
 * direction's density is p / (area cos^3).
 */
static struct pm_vec3
projector_direction(const struct pm_shooter *sh, size_t li, float u,
    float v, float *pdf)
{
	const struct pm_light *l = &sh->scene->lights[li];
	const struct pm_distrib *tx = &sh->lights->tris[li];
	float puv = 1.0f, c, area;
	struct pm_vec3 d;

	if (tx->n > 0) {
		const struct pm_texture *t = &sh->scene->textures[l->tex - 1];
		size_t j = pm_distrib_sample(tx, u, &u);

		puv = (float)(pm_distrib_prob(tx, j) * (double)tx->n);
		u = ((float)(j % (size_t)t->width) + u) / (float)t->width;
		v = ((float)(j / (size_t)t->width) + v) / (float)t->height;
	}
	d = pm_v3((1.0f - 2.0f * u) * l->tan_fov,
	    (1.0f - 2.0f * v) * l->tan_fov / l->aspect, 1.0f);
	c = 1.0f / pm_length(d);
	area = 4.0f * l->tan_fov * l->tan_fov / l->aspect;
	*pdf = puv / (area * c * c * c);
	/* frame: to_world's axes, a rotation (scene_xml checks) */
	return pm_to_world(l->frame, pm_scale(d, c));
}

/* Whether light li emits as a parallelogram (light.h) shooting
 * cosine-distributed photons: emit_u's common case, emit_quad4's. */
static inline bool
emits_quad(const struct pm_shooter *sh, size_t li)
{
	const struct pm_scene *s = sh->scene;
	const struct pm_light *l = &s->lights[li];

	return l->type == PM_LIGHT_AREA && sh->lights->quad[li].on &&
	    s->shapes[l->shape].type != PM_SHAPE_SPHERE;
}

/*
 * Emits a photon path from its first six random numbers u: origin,
 * direction, flux and the medium it starts in.  cosine is (u[3], u[4])
 * warped to the cosine hemisphere (emit_batch warps many at once), the
 * local direction of an area light's unaimed photon.  False if the
 * sampled photon carries nothing (it still counts as emitted).
 */
static bool
emit_u(const struct pm_shooter *sh, enum pm_map_pass pass, const float u[6],
    struct pm_vec3 cosine, struct pm_vec3 *o, struct pm_vec3 *d,
    struct pm_rgb *flux, int *medium)
{
	const struct pm_scene *s = sh->scene;
	const struct pm_lights *ls = sh->lights;
	float u0 = u[0], u1 = u[1], u2 = u[2], u3 = u[3], u4 = u[4], u5 = u[5];
	size_t li = pm_distrib_sample(&ls->pick, u0, NULL);
	const struct pm_light *l = &s->lights[li];
	float psel = (float)pm_distrib_prob(&ls->pick, li);
	bool aim = pass == PM_PASS_CAUSTIC && sh->naim > 0;
	struct pm_vec3 p, ng, ns, w;
	struct pm_hit lh;
	float pdf_dir;

	*medium = sh->light_medium != NULL ? sh->light_medium[li] : -1;
	if (!aim && emits_quad(sh, li)) {
		/* The common case, a parallelogram (light.h) shooting
		 * cosine-distributed photons: what the general case below
		 * computes, in its order, with the frame found once and
		 * nothing looked up (the radiance is untextured, and its
		 * side test is the shading normal's below): 77 -> 55 ns an
		 * emission, one core, before emit_batch's lanes. */
		const struct pm_light_quad *q = &ls->quad[li];
		float c;

		p = pm_madd(pm_madd(q->p0, q->e1, u1), q->e2, u2);
		w = pm_to_world(q->f, cosine);
		c = pm_dot(w, q->n);
		pdf_dir = pm_fmaxf(c, 0.0f) * PM_INV_PI;
		if (c <= 0.0f || pm_dot(w, q->ns) <= 0.0f || pdf_dir <= 0.0f)
			return false;
		*flux = pm_rgb_scale(l->radiance, c * (float)l->area /
		    (psel * pdf_dir));
		*o = pm_offset_origin(p, q->n, w);
		*d = w;
		return pm_rgb_max(*flux) > 0.0f;
	}
	switch (l->type) {
	case PM_LIGHT_AREA:
		sample_shape_point(sh, (int)li, u1, u2, &p, &ng, &ns, &lh);
		lh.p = p;
		lh.ns = ns;
		if (aim) {
			w = aim_sample(sh, p, u3, u4, u5);
			pdf_dir = aim_pdf(sh, p, w);
		} else {
			w = pm_to_world(pm_frame_from_normal(ng),
			    cosine);
			pdf_dir = pm_fmaxf(pm_dot(w, ng), 0.0f) * PM_INV_PI;
		}
		if (pm_dot(w, ng) <= 0.0f || pm_dot(w, ns) <= 0.0f || pdf_dir <= 0.0f)
			return false;
		/* Le cos / (p(light) p(point) p(direction)), p(point) = 1/area;
		 * a textured radiance by its value at the point: points
		 * are chosen by area, as in Mitsuba, and weighted */
		*flux = pm_rgb_scale(pm_area_emitted_at(s, l, &lh, w),
		    pm_dot(w, ng) * (float)l->area / (psel * pdf_dir));
		*o = pm_offset_origin(p, ng, w);
		break;
	case PM_LIGHT_POINT:
	case PM_LIGHT_SPOT:
	case PM_LIGHT_PROJECTOR:
		p = l->position;
		if (aim) {
			w = aim_sample(sh, p, u3, u4, u5);
			pdf_dir = aim_pdf(sh, p, w);
		} else if (l->type == PM_LIGHT_PROJECTOR) {
			w = projector_direction(sh, li, u3, u4, &pdf_dir);
		} else if (l->type == PM_LIGHT_SPOT) {
			float c = cosf(l->cutoff_angle * (PM_PI / 180.0f));

			w = pm_to_world(l->frame, pm_square_to_uniform_cone(u3, u4, c));
			pdf_dir = pm_uniform_cone_pdf(c);
		} else {
			w = pm_square_to_uniform_sphere(u3, u4);
			pdf_dir = pm_uniform_sphere_pdf();
		}
		if (pdf_dir <= 0.0f)
			return false;
		*flux = pm_rgb_scale(pm_light_intensity(s, l, w),
		    1.0f / (psel * pdf_dir));
		*o = p;
		break;
	case PM_LIGHT_CONSTANT:
	case PM_LIGHT_ENVMAP:
	case PM_LIGHT_DIRECTIONAL: {
		/* From a disk of the bounding sphere's radius, facing the
		 * scene, outside it: every line through the scene is covered.
		 * Flux: radiance (or, directional, irradiance) times the
		 * disk's area, over the densities of the light and of the
		 * direction. */
		struct pm_vec3 dir_to_sky;
		struct pm_frame f;
		float dx, dy, r = s->radius, area = PM_PI * r * r;

		if (l->type == PM_LIGHT_CONSTANT) {
			dir_to_sky = pm_square_to_uniform_sphere(u3, u4);
			*flux = pm_rgb_scale(l->radiance, 4.0f * PM_PI * PM_PI *
			    r * r / psel);	/* area / (psel / (4 pi)) */
		} else if (l->type == PM_LIGHT_ENVMAP) {
			dir_to_sky = pm_envmap_sample(l->env, u3, u4, &pdf_dir);
			if (!(pdf_dir > 0.0f))
				return false;
			*flux = pm_rgb_scale(pm_envmap_eval(l->env, dir_to_sky),
			    area / (psel * pdf_dir));
		} else {
			dir_to_sky = pm_neg(l->direction);
			*flux = pm_rgb_scale(l->intensity, area / psel);
		}
		f = pm_frame_from_normal(dir_to_sky);
		if (aim) {
			/* Caustic pass: only from the shadows of the specular
			 * shapes' spheres: the flux over the disk's uniform
			 * density, pi r^2, now over the aimed density. */
			float pdf_area;

			p = aim_disk_sample(sh, dir_to_sky, f, u5, u1, u2,
			    &pdf_area);
			if (!(pdf_area > 0.0f))
				return false;
			*flux = pm_rgb_scale(*flux, 1.0f / (area * pdf_area));
			p = pm_madd(p, dir_to_sky, r);
		} else {
			pm_square_to_disk(u1, u2, &dx, &dy);
			p = pm_madd(pm_madd(pm_madd(s->center, dir_to_sky, r),
			    f.s, dx * r), f.t, dy * r);
		}
		w = pm_neg(dir_to_sky);
		*o = p;
		break;
	}
	default:
		return false;
	}
	*d = w;
	return pm_rgb_max(*flux) > 0.0f;
}

/* emit_u with the six numbers an emission takes drawn from rng. */
static bool
emit(const struct pm_shooter *sh, enum pm_map_pass pass, struct pm_rng *rng,
    struct pm_vec3 *o, struct pm_vec3 *d, struct pm_rgb *flux, int *medium)
{
	float u[6];
	int j;

	for (j = 0; j < 6; j++)
		u[j] = pm_rng_float(rng);
	return emit_u(sh, pass, u, pm_square_to_cosine_hemisphere(u[3], u[4]),
	    o, d, flux, medium);
}

/* Bounces a path's diffuse directions are warped ahead for (emit_batch,
 * paths traced one at a time): in the Cornell box two cover 1.25 of the
 * 1.85 bounces a path (its photons of depth 0 and 1, of all depths). */
#define PRE_BOUNCES 2

/* A photon path's start: its random numbers' state after the emission,
 * and what the emission gave. */
struct path_start {
	struct pm_rng rng;
	struct pm_vec3 o, d;
	struct pm_rgb flux;
	int medium;
	bool ok;			/* false: it carries nothing */
	/* Cosine directions warped ahead (pre_v[i]) from the two numbers
	 * the path's generator gives from state pre_state[i] on, for
	 * i < npre: a bounce that draws its (u2, u3) from that state
	 * takes the direction as drawn. */
	int npre;
	uint64_t pre_state[PRE_BOUNCES];
	struct pm_vec3 pre_v[PRE_BOUNCES];
};

#if PM_LANES
/*
 * emit_u's parallelogram case for four paths that picked the same light
 * li, in SSE lanes: its operations in its order, its tests as masks, so
 * each lane is the bits emit_u gives (ok false where emit_u returns
 * false; the rest is then unused, as emit_u's is).  u holds the paths'
 * numbers, (cx, cy, cz) their cosine directions.  One light is the
 * common scene, and a light's data broadcast is all the lanes load.
 */
static void
emit_quad4(const struct pm_shooter *sh, size_t li, const float (*u)[6],
    const float *cx, const float *cy, const float *cz, struct path_start *ps)
{
	const struct pm_light_quad *q = &sh->lights->quad[li];
	const struct pm_light *l = &sh->scene->lights[li];
	const float psel = (float)pm_distrib_prob(&sh->lights->pick, li);
	const __m128 zero = _mm_setzero_ps();
	const float *p0 = &q->p0.x, *e1 = &q->e1.x, *e2 = &q->e2.x;
	const float *fs = &q->f.s.x, *ft = &q->f.t.x, *fn = &q->f.n.x;
	const float *rad = &l->radiance.r;
	__m128 u1 = _mm_setr_ps(u[0][1], u[1][1], u[2][1], u[3][1]);
	__m128 u2 = _mm_setr_ps(u[0][2], u[1][2], u[2][2], u[3][2]);
	__m128 vx = _mm_loadu_ps(cx), vy = _mm_loadu_ps(cy);
	__m128 vz = _mm_loadu_ps(cz), p[3], w[3], n[3], o[3], f[3];
	__m128 c, pdf, ok, sc, top;
	_Alignas(16) float out[10][4];
	_Alignas(16) int32_t okv[4];
	int a, k;

	for (a = 0; a < 3; a++) {
		p[a] = _mm_add_ps(_mm_add_ps(_mm_set1_ps(p0[a]),
		    _mm_mul_ps(_mm_set1_ps(e1[a]), u1)),
		    _mm_mul_ps(_mm_set1_ps(e2[a]), u2));
		w[a] = _mm_add_ps(_mm_add_ps(_mm_mul_ps(_mm_set1_ps(fs[a]), vx),
		    _mm_mul_ps(_mm_set1_ps(ft[a]), vy)),
		    _mm_mul_ps(_mm_set1_ps(fn[a]), vz));
		n[a] = _mm_set1_ps((&q->n.x)[a]);
	}
	c = pm_dot4(w[0], w[1], w[2], n[0], n[1], n[2]);
	pdf = _mm_mul_ps(pm_max4(c, zero), _mm_set1_ps(PM_INV_PI));
	/* !(c <= 0) && !(w . ns <= 0) && !(pdf <= 0), as emit_u tests */
	ok = _mm_and_ps(_mm_and_ps(_mm_cmpnle_ps(c, zero),
	    _mm_cmpnle_ps(pm_dot4(w[0], w[1], w[2], _mm_set1_ps(q->ns.x),
	    _mm_set1_ps(q->ns.y), _mm_set1_ps(q->ns.z)), zero)),
	    _mm_cmpnle_ps(pdf, zero));
	sc = _mm_div_ps(_mm_mul_ps(c, _mm_set1_ps((float)l->area)),
	    _mm_mul_ps(_mm_set1_ps(psel), pdf));
	for (a = 0; a < 3; a++)
		f[a] = _mm_mul_ps(_mm_set1_ps(rad[a]), sc);
	top = pm_max4(f[0], pm_max4(f[1], f[2]));
	ok = _mm_and_ps(ok, _mm_cmpgt_ps(top, zero));
	pm_offset4(p, n, pm_offset_eps4(p, zero), w, o);
	for (a = 0; a < 3; a++) {
		_mm_store_ps(out[a], o[a]);
		_mm_store_ps(out[3 + a], w[a]);
		_mm_store_ps(out[6 + a], f[a]);
	}
	_mm_store_si128((__m128i *)okv, _mm_castps_si128(ok));
	for (k = 0; k < 4; k++) {
		ps[k].o = pm_v3(out[0][k], out[1][k], out[2][k]);
		ps[k].d = pm_v3(out[3][k], out[4][k], out[5][k]);
		ps[k].flux = pm_rgb(out[6][k], out[7][k], out[8][k]);
		ps[k].medium = sh->light_medium != NULL ?
		    sh->light_medium[li] : -1;
		ps[k].ok = okv[k] != 0;
	}
}
#endif

/* Paths emitted together (emit_batch). */
#define EMIT_LANES 8

/*
 * Paths first .. first + n - 1 (n <= EMIT_LANES) emitted as emit() would
 * emit them one by one, the same bits.  Emission was a seventh of the
 * Cornell box's photon pass, most of it one long chain of dependent
 * arithmetic a path, the cosine warp's the longest: the lanes' warps run
 * side by side in SIMD (pm_square_to_cosine_hemisphere_n), whatever the
 * lights (a light that does not use one wastes a quarter of a lane's
 * work).
 *
 * A diffuse bounce's warp is the same chain, a path's bounces one after
 * another, so in the global pass the lanes also take each path's first
 * PRE_BOUNCES bounces' directions, guessed ahead: a bounce at a
 * non-specular surface draws five numbers (the photon's dither, u1, u2,
 * u3, the roulette's), so in a path of such bounces bounce i's (u2, u3)
 * come from the state after 5 i + 2 draws.  The guess is checked where
 * it is used (bounce compares states), so a path that went otherwise (a
 * mirror, a medium, a lobe choice) warps its own.  Only for paths traced
 * one at a time (guess true): rounds warp their diffuse bounces' directions
 * together (trace_paths), and a guess there was work thrown away.
 */
static void
emit_batch(const struct pm_shooter *sh, const struct pm_shoot_opts *opts,
    uint64_t first, int n, bool guess, struct path_start *ps)
{
	enum { W = EMIT_LANES * (1 + PRE_BOUNCES) };
	float u[EMIT_LANES][6], ua[W], ub[W];
	struct pm_rng rs[EMIT_LANES];
	float x[W], y[W], z[W];
	int k, j, m;
	int npre = guess && opts->pass == PM_PASS_GLOBAL ? PRE_BOUNCES : 0;
#if PM_LANES
	const struct pm_lights *ls = sh->lights;
	bool aim = opts->pass == PM_PASS_CAUSTIC && sh->naim > 0;
#endif

	if (n <= 0)
		return;
	/* Each number in turn for every path (the inner loop over paths):
	 * a path's numbers are one chain of dependent multiplications, and
	 * a path at a time left the core waiting on each link (the loads
	 * of u, path by path, were this function's hottest lines). */
	for (k = 0; k < n; k++)
		ps[k].rng = pm_rng_seed(opts->seed, first + (uint64_t)k,
		    (uint64_t)opts->pass);
	for (j = 0; j < 6; j++)
		for (k = 0; k < n; k++)
			u[k][j] = pm_rng_float(&ps[k].rng);
	for (k = 0; k < n; k++) {
		ua[k] = u[k][3];
		ub[k] = u[k][4];
		ps[k].npre = npre;
		rs[k] = ps[k].rng;
	}
	for (j = 0; j < npre; j++)
		for (k = 0; k < n; k++) {
			struct pm_rng *r = &rs[k];

			m = n + k * npre + j;
			pm_rng_skip(r);	/* the dither */
			pm_rng_skip(r);	/* u1 */
			ps[k].pre_state[j] = r->state;
			ua[m] = pm_rng_float(r);
			ub[m] = pm_rng_float(r);
			pm_rng_skip(r);	/* the roulette */
		}
	pm_square_to_cosine_hemisphere_n(ua, ub, x, y, z,
	    (size_t)(n + n * npre));
	for (k = 0; k < n; k++) {
#if PM_LANES
		/* four paths from one parallelogram light: in lanes */
		if (k % 4 == 0 && k + 4 <= n && !aim) {
			size_t li = pm_distrib_sample(&ls->pick, u[k][0], NULL);

			for (j = 1; j < 4; j++)
				if (pm_distrib_sample(&ls->pick, u[k + j][0],
				    NULL) != li)
					break;
			if (j == 4 && emits_quad(sh, li)) {
				emit_quad4(sh, li, u + k, x + k, y + k, z + k,
				    ps + k);
				k += 3;
				continue;
			}
		}
#endif
		ps[k].ok = emit_u(sh, opts->pass, u[k], pm_v3(x[k], y[k], z[k]),
		    &ps[k].o, &ps[k].d, &ps[k].flux, &ps[k].medium);
	}
	for (k = 0, m = n; k < n; k++)
		for (j = 0; j < npre; j++, m++)
			ps[k].pre_v[j] = pm_v3(x[m], y[m], z[m]);
}

bool
pm_shooter_emit(const struct pm_shooter *sh, struct pm_rng *rng,
    struct pm_vec3 *o, struct pm_vec3 *d, struct pm_rgb *flux)
{
	int medium;	/* the particle tracer refuses media */

	return emit(sh, PM_PASS_GLOBAL, rng, o, d, flux, &medium);
}

void
pm_shooter_shape_point(const struct pm_shooter *sh, int light, float u1,
    float u2, struct pm_vec3 *p, struct pm_vec3 *ng, struct pm_vec3 *ns,
    struct pm_hit *lh)
{
	sample_shape_point(sh, light, u1, u2, p, ng, ns, lh);
}

struct chunk_out {
	struct pm_photon_buf buf;
	struct pm_photon_buf vbuf;	/* volume photons */
	uint64_t dropped, paths_specular;
	bool done;
	unsigned char note[PM_SHOOT_NOTE];	/* sink_prepare's */
};

/*
 * One free flight of a photon in medium `medium` along o + t d up to the
 * surface at t_end (INFINITY: none).  Returns 1 when it reached the
 * surface (flux weighted by the transmittance over the flight's
 * density), 2 when it scattered and goes on (the volume photon stored,
 * o, d and flux moved on past Russian roulette), 0 when the path ends,
 * -1 out of memory.
 */
static int
medium_flight(const struct pm_shooter *sh, const struct pm_shoot_opts *opts,
    struct pm_rng *rng, int medium, float t_end, int depth, int max_depth,
    bool specular_only, struct chunk_out *co, struct pm_vec3 *o,
    struct pm_vec3 *d, struct pm_rgb *flux)
{
	const struct pm_medium *m = &sh->scene->media[medium];
	struct pm_medium_sample ms;
	struct pm_rgb w;
	float u = pm_rng_float(rng), q, pdf;
	int c = (int)(pm_rng_float(rng) * 3.0f);

	if (m->het == NULL)
		pm_medium_sample(m, t_end, c > 2 ? 2 : c, u, &ms);
	else	/* delta tracking: same weights, nulls in f and pdf alike */
		pm_medium_sample_ray(m, *o, *d, 0.0f, t_end, c > 2 ? 2 : c,
		    rng, &ms);
	q = pm_rgb_mean(ms.pdf);
	if (!(q > 0.0f))
		return 0;
	w = pm_rgb_scale(ms.f, 1.0f / q);
	*flux = pm_rgb_mul(*flux, w);
	if (!ms.scattered)
		return pm_rgb_is_black(*flux) ? 0 : 1;
	*o = pm_madd(*o, *d, ms.t);
	if (opts->pass == PM_PASS_CAUSTIC)
		return 0;
	if (opts->volume != NULL) {
		struct pm_photon ph;

		if (!pm_rgb_is_finite(*flux)) {
			co->dropped++;
			return 0;
		}
		ph.pos[0] = o->x;
		ph.pos[1] = o->y;
		ph.pos[2] = o->z;
		pm_rgbe_pack(*flux, pm_rng_float(rng), ph.power);
		pm_dir_pack(pm_neg(*d), ph.dir);
		ph.normal[0] = ph.normal[1] = 0;	/* none in a medium */
		ph.reserved[0] = ph.reserved[1] = 0;
		ph.flags = PM_KD_LEAF;
		if (!specular_only)
			ph.flags |= PM_PHOTON_VIA_DIFFUSE;
		if (specular_only && depth > 0)
			ph.flags |= PM_PHOTON_CAUSTIC;
		ph.depth = (uint8_t)(depth < 255 ? depth : 255);
		if (!buf_push(&co->vbuf, &ph))
			return -1;
	}
	if (depth >= max_depth)
		return 0;
	/* Russian roulette on the scatter's weight (the albedo, in a grey
	 * medium), as at a surface. */
	q = pm_fminf(pm_rgb_max(w), 1.0f);
	if (!(q > 0.0f) || pm_rng_float(rng) >= q)
		return 0;
	*flux = pm_rgb_scale(*flux, 1.0f / q);
	{
		float u1 = pm_rng_float(rng), u2 = pm_rng_float(rng);

		*d = pm_phase_sample(&m->phase, *d, u1, u2, &pdf);
	}
	if (!(pdf > 0.0f))
		return 0;
	return 2;
}

/* A photon path between bounces. */
struct photon_state {
	struct pm_rng rng;
	struct pm_vec3 o, d;
	struct pm_rgb flux;
	bool specular_only, via_diffuse;
	int depth, medium;		/* medium: the photon's, -1: none */
};

/*
 * A photon's bounce at the surface hit h: its photon stored in out (or
 * counted as dropped), the BSDF sampled, Russian roulette, and st moved
 * on past the surface.  1: the path goes on; 0: it ends; -1: out of
 * memory.
 */
static int
bounce(const struct pm_shooter *sh, const struct pm_shoot_opts *opts,
    const struct path_start *ps, int max_depth, const struct pm_hit *h,
    struct photon_state *st, struct chunk_out *co, struct pm_photon_buf *out)
{
	const struct pm_scene *s = sh->scene;
	const struct pm_bsdf *b;
	struct pm_bsdf bt;	/* b with its textures looked up */
	struct pm_frame fr;
	struct pm_vec3 wi_local;
	struct pm_bsdf_sample bs;
	const struct pm_vec3 *v;
	float q, u1, u2, u3;
	int i, depth = st->depth;

	b = pm_bsdf_frame_at(s, h, st->d, &bt, &fr);
	if (depth == 0 && bsdf_has_specular(b))
		co->paths_specular++;
	if (bsdf_has_nonspecular(b) && (opts->pass == PM_PASS_GLOBAL ||
	    (st->specular_only && depth > 0))) {
		struct pm_photon ph;

		if (!pm_rgb_is_finite(st->flux)) {
			co->dropped++;
			return 0;
		}
		ph.pos[0] = h->p.x;
		ph.pos[1] = h->p.y;
		ph.pos[2] = h->p.z;
		pm_rgbe_pack(st->flux, pm_rng_float(&st->rng), ph.power);
		pm_dir_pack(pm_neg(st->d), ph.dir);
		/* The shading normal, turned to the side the photon came
		 * from (judged by the true surface). */
		pm_dir_pack(pm_dot(h->ng, st->d) < 0.0f ? h->ns : pm_neg(h->ns),
		    ph.normal);
		ph.reserved[0] = ph.reserved[1] = 0;
		ph.flags = PM_KD_LEAF;
		if (st->via_diffuse)
			ph.flags |= PM_PHOTON_VIA_DIFFUSE;
		if (st->specular_only && depth > 0)
			ph.flags |= PM_PHOTON_CAUSTIC;
		ph.depth = (uint8_t)(depth < 255 ? depth : 255);
		if (!buf_push(out, &ph))
			return -1;
	}
	if (opts->pass == PM_PASS_CAUSTIC && !bsdf_has_specular(b))
		return 0;
	if (depth >= max_depth)
		return 0;
	wi_local = pm_to_local(fr, pm_neg(st->d));
	u1 = pm_rng_float(&st->rng);
	for (i = 0, v = NULL; i < ps->npre; i++)
		if (st->rng.state == ps->pre_state[i])
			v = &ps->pre_v[i];	/* (u2, u3) warped */
	u2 = pm_rng_float(&st->rng);
	u3 = pm_rng_float(&st->rng);
	if (!pm_bsdf_sample_v(b, wi_local, u1, u2, u3, PM_IMPORTANCE, v, &bs))
		return 0;
	if (opts->pass == PM_PASS_CAUSTIC && !event_specular(b, &bs))
		return 0;
	/* Russian roulette: survive with the probability the surface
	 * scatters this photon, so survivors keep their flux. */
	q = pm_fminf(pm_rgb_max(bs.weight), 1.0f);
	if (!(q > 0.0f) || pm_rng_float(&st->rng) >= q)
		return 0;
	st->flux = pm_rgb_scale(pm_rgb_mul(st->flux, bs.weight), 1.0f / q);
	if (!event_specular(b, &bs)) {
		st->specular_only = false;
		st->via_diffuse = true;
	}
	st->d = pm_normalize(pm_to_world(fr, bs.wo));
	st->o = pm_hit_origin(h, st->d);
	if (s->nmedia > 0)
		st->medium = pm_medium_after(s, h, st->d, st->medium);
	st->depth++;
	return 1;
}

static int
path_max_depth(const struct pm_shoot_opts *opts)
{
	return opts->max_depth < 0 ? HARD_MAX_BOUNCES :
	    (opts->max_depth < HARD_MAX_BOUNCES ? opts->max_depth :
	    HARD_MAX_BOUNCES);
}

static void
state_start(struct photon_state *st, const struct path_start *ps)
{
	st->rng = ps->rng;
	st->o = ps->o;
	st->d = ps->d;
	st->flux = ps->flux;
	st->specular_only = true;
	st->via_diffuse = false;
	st->depth = 0;
	st->medium = ps->medium;
}

static bool
trace_path(const struct pm_shooter *sh, const struct pm_shoot_opts *opts,
    const struct path_start *ps, struct chunk_out *co)
{
	const struct pm_scene *s = sh->scene;
	struct photon_state st;
	int max_depth = path_max_depth(opts), crossings = 0;

	if (!ps->ok)
		return true;
	state_start(&st, ps);
	for (;;) {
		struct pm_hit h;
		int r;
		bool hit = pm_accel_intersect(sh->accel, st.o, st.d, 0.0f,
		    INFINITY, &h);

		if (st.medium >= 0) {
			/* media: a scatter before the surface */
			int ev = medium_flight(sh, opts, &st.rng, st.medium,
			    hit ? h.t : INFINITY, st.depth, max_depth,
			    st.specular_only, co, &st.o, &st.d, &st.flux);

			if (ev < 0)
				return false;
			if (ev == 0)
				break;
			if (ev == 2) {
				st.specular_only = false;
				st.via_diffuse = true;
				st.depth++;
				continue;
			}
		}
		if (!hit)
			break;
		if (s->nmedia > 0 &&
		    s->bsdfs[s->shapes[h.shape].bsdf].type == PM_BSDF_NULL) {
			/* media: an index-matched boundary, no bounce */
			if (++crossings > MAX_CROSSINGS)
				break;
			st.medium = pm_medium_after(s, &h, st.d, st.medium);
			st.o = pm_hit_origin(&h, st.d);
			continue;
		}
		r = bounce(sh, opts, ps, max_depth, &h, &st, co, &co->buf);
		if (r < 0)
			return false;
		if (r == 0)
			break;
	}
	return true;
}

/*
 * A round's bounces at plain diffuse surfaces, field by field, for
 * diffuse_lanes: the hit (p, ng, ns, scale), the photon's direction d and
 * flux, the numbers drawn for it in its path's order (the photon's
 * dither; (u2, u3) already warped to v), the reflectance and twosided
 * mask; and what the lanes give back: the photon's packed power,
 * direction and normal, whether the BSDF's sample succeeds, and the
 * path's next flux, direction and origin.
 */
/*
 * A round's bounces in lanes: at plain diffuse surfaces from lane 0 up,
 * at smooth plastic ones (a diffuse base under a dielectric coating) from
 * the last lane down, each side in whole groups of four: room for a
 * round's paths and the padding of both sides.
 */
#define DIFFUSE_LANES 264
/* the lane of the round's plastic bounce c */
#define COAT_LANE(c) (DIFFUSE_LANES - 1 - (c))

struct diffuse_round {
	float p[3][DIFFUSE_LANES], ng[3][DIFFUSE_LANES], ns[3][DIFFUSE_LANES];
	float d[3][DIFFUSE_LANES], flux[3][DIFFUSE_LANES];
	/* the diffuse albedo, or plastic's base (pm_plastic_base) */
	float alb[3][DIFFUSE_LANES], v[3][DIFFUSE_LANES];
	float u2[DIFFUSE_LANES], u3[DIFFUSE_LANES];	/* v, unwarped */
	float dither[DIFFUSE_LANES], scale[DIFFUSE_LANES];
	/* plastic's: the lobe's number, the coating's specular reflectance,
	 * its index and its sampling weight */
	float u1[DIFFUSE_LANES], spec[3][DIFFUSE_LANES];
	float ior[DIFFUSE_LANES], ssw[DIFFUSE_LANES];
	int32_t tw[DIFFUSE_LANES];
	uint8_t path[DIFFUSE_LANES];
	/* results; coat_spec: plastic's coating sampled, not its base */
	int32_t power[4][DIFFUSE_LANES], dir[2][DIFFUSE_LANES];
	int32_t normal[2][DIFFUSE_LANES], ok[DIFFUSE_LANES];
	int32_t coat_spec[DIFFUSE_LANES];
	float nflux[3][DIFFUSE_LANES], nd[3][DIFFUSE_LANES];
	float no[3][DIFFUSE_LANES], q[DIFFUSE_LANES];
};

#if PM_LANES
/*
 * surface_lanes: bounce's arithmetic at a plain diffuse surface, or with
 * coat at a smooth plastic one (sample_plastic's), four bounces at a time
 * in SSE lanes, its operations in its order (IEEE division and square
 * root are exact in SIMD as in scalar code, -ffp-contract=off fuses
 * nothing): the frame, the photon's packing (pm_rgbe_pack, pm_dir_pack),
 * the BSDF's sample, the roulette's probability, the next flux, direction
 * and origin.  Lanes j0 .. j1 - 1, in whole groups of four, those past
 * the round's bounces set but unused.  coat is a constant where this is
 * inlined (diffuse_lanes, coat_lanes): diffuse bounces pay nothing for
 * plastic's.
 */
static inline __attribute__((always_inline)) void
surface_lanes(struct diffuse_round *r, size_t j0, size_t j1, bool coat)
{
	const __m128 zero = _mm_setzero_ps(), one = _mm_set1_ps(1.0f);
	const __m128 sign = _mm_set1_ps(-0.0f), inv_pi = _mm_set1_ps(PM_INV_PI);
	size_t j;
	int c;

	for (j = j0; j < j1; j += 4) {
		__m128 p[3], g[3], n[3], d[3], f[3], a[3], v[3], s[3], t[3];
		__m128 wi[3], wt[3], wiz, flip, pdf, ok, q, iq, w[3], dd, l;
		__m128 keep, gd, o[3];

		for (c = 0; c < 3; c++) {
			p[c] = _mm_loadu_ps(r->p[c] + j);
			g[c] = _mm_loadu_ps(r->ng[c] + j);
			n[c] = _mm_loadu_ps(r->ns[c] + j);
			d[c] = _mm_loadu_ps(r->d[c] + j);
			f[c] = _mm_loadu_ps(r->flux[c] + j);
			a[c] = _mm_loadu_ps(r->alb[c] + j);
			v[c] = _mm_loadu_ps(r->v[c] + j);
			wi[c] = _mm_xor_ps(d[c], sign);
		}
		/* the photon: pm_rgbe_pack(flux, dither), pm_dir_pack */
		pm_rgbe_pack4(f[0], f[1], f[2], _mm_loadu_ps(r->dither + j),
		    r->power[0] + j, r->power[1] + j, r->power[2] + j,
		    r->power[3] + j);
		pm_dir_pack4(wi[0], wi[1], wi[2], r->dir[0] + j, r->dir[1] + j);
		gd = _mm_cmplt_ps(pm_dot4(g[0], g[1], g[2], d[0], d[1], d[2]),
		    zero);
		pm_dir_pack4(pm_sel4(gd, n[0], _mm_xor_ps(n[0], sign)),
		    pm_sel4(gd, n[1], _mm_xor_ps(n[1], sign)),
		    pm_sel4(gd, n[2], _mm_xor_ps(n[2], sign)),
		    r->normal[0] + j, r->normal[1] + j);
		/* pm_frame_from_normal(ns) and wi's z in it */
		pm_frame4(n[0], n[1], n[2], s, t);
		wiz = pm_dot4(wi[0], wi[1], wi[2], n[0], n[1], n[2]);
		/* the BSDF's sample (pm_bsdf_sample_v), twosided's flip */
		flip = _mm_and_ps(pm_mask4(r->tw + j), _mm_cmplt_ps(wiz, zero));
		wiz = _mm_xor_ps(wiz, _mm_and_ps(flip, sign));
		pdf = _mm_and_ps(_mm_cmpgt_ps(v[2], zero), _mm_mul_ps(v[2],
		    inv_pi));
		if (!coat) {
			/* plain diffuse: v, weighted by the albedo */
			ok = _mm_cmpgt_ps(pdf, zero);
			for (c = 0; c < 3; c++)
				wt[c] = a[c];
		} else {
			/* sample_plastic: the coating with probability ps
			 * (plastic_prob_specular), its mirror direction
			 * weighted by specular Fi / ps; else the base's v,
			 * by plastic_diffuse / (1 - ps) */
			__m128 eta = _mm_loadu_ps(r->ior + j);
			__m128 ssw = _mm_loadu_ps(r->ssw + j);
			__m128 fi = pm_fresnel4(wiz, eta), fo, ps, pd, den, spec;
			__m128 sf, ipd, fis, wix, wiy;

			ps = _mm_mul_ps(fi, ssw);
			den = _mm_add_ps(ps, _mm_mul_ps(_mm_sub_ps(one, fi),
			    _mm_sub_ps(one, ssw)));
			ps = pm_sel4(_mm_cmpgt_ps(den, zero), _mm_div_ps(ps, den),
			    fi);
			pd = _mm_sub_ps(one, ps);
			spec = _mm_cmplt_ps(_mm_loadu_ps(r->u1 + j), ps);
			pdf = _mm_mul_ps(pd, pdf);
			fo = pm_fresnel4(v[2], eta);
			sf = _mm_div_ps(_mm_mul_ps(_mm_sub_ps(one, fi),
			    _mm_sub_ps(one, fo)), _mm_mul_ps(eta, eta));
			ipd = _mm_div_ps(one, pd);
			fis = _mm_div_ps(fi, ps);
			for (c = 0; c < 3; c++)
				wt[c] = pm_sel4(spec, _mm_mul_ps(_mm_loadu_ps(
				    r->spec[c] + j), fis), _mm_mul_ps(_mm_mul_ps(
				    a[c], sf), ipd));
			ok = _mm_or_ps(spec, _mm_cmpgt_ps(pdf, zero));
			/* reflect_z(wi) where the coating was sampled */
			wix = pm_dot4(wi[0], wi[1], wi[2], s[0], s[1], s[2]);
			wiy = pm_dot4(wi[0], wi[1], wi[2], t[0], t[1], t[2]);
			v[0] = pm_sel4(spec, _mm_xor_ps(wix, sign), v[0]);
			v[1] = pm_sel4(spec, _mm_xor_ps(wiy, sign), v[1]);
			v[2] = pm_sel4(spec, wiz, v[2]);
			_mm_storeu_si128((__m128i *)(r->coat_spec + j),
			    _mm_castps_si128(spec));
		}
		ok = _mm_andnot_ps(_mm_cmple_ps(wiz, zero), ok);
		_mm_storeu_si128((__m128i *)(r->ok + j), _mm_castps_si128(ok));
		v[2] = _mm_xor_ps(v[2], _mm_and_ps(flip, sign));
		/* the roulette's probability and the next flux */
		q = pm_min4(pm_max4(wt[0], pm_max4(wt[1], wt[2])), one);
		_mm_storeu_ps(r->q + j, q);
		iq = _mm_div_ps(one, q);
		for (c = 0; c < 3; c++)
			_mm_storeu_ps(r->nflux[c] + j, _mm_mul_ps(_mm_mul_ps(f[c],
			    wt[c]), iq));
		/* pm_normalize(pm_to_world(frame, wo)) */
		for (c = 0; c < 3; c++)
			w[c] = _mm_add_ps(_mm_add_ps(_mm_mul_ps(s[c], v[0]),
			    _mm_mul_ps(t[c], v[1])), _mm_mul_ps(n[c], v[2]));
		dd = pm_dot4(w[0], w[1], w[2], w[0], w[1], w[2]);
		l = _mm_sqrt_ps(dd);
		keep = _mm_cmpngt_ps(l, zero);
		l = _mm_div_ps(one, l);
		for (c = 0; c < 3; c++) {
			w[c] = pm_sel4(keep, w[c], _mm_mul_ps(w[c], l));
			_mm_storeu_ps(r->nd[c] + j, w[c]);
		}
		/* pm_hit_origin(h, d) */
		pm_offset4(p, g, pm_offset_eps4(p, _mm_loadu_ps(r->scale + j)),
		    w, o);
		for (c = 0; c < 3; c++)
			_mm_storeu_ps(r->no[c] + j, o[c]);
	}
}

static void
diffuse_lanes(struct diffuse_round *r, size_t j0, size_t j1)
{
	surface_lanes(r, j0, j1, false);
}

static void
coat_lanes(struct diffuse_round *r, size_t j0, size_t j1)
{
	surface_lanes(r, j0, j1, true);
}
#endif

/* Room in *tag for index i; false without memory. */
static __attribute__((noinline)) bool
tag_grow(uint8_t **tag, size_t *tag_cap, size_t i)
{
	size_t cap = 2 * (i + 1);
	uint8_t *t = realloc(*tag, cap);

	if (t == NULL)
		return false;
	*tag = t;
	*tag_cap = cap;
	return true;
}

/* The path of photon i in *tag; false without memory. */
static inline bool
tag_photon(uint8_t **tag, size_t *tag_cap, size_t i, uint8_t path)
{
	if (i >= *tag_cap && !tag_grow(tag, tag_cap, i))
		return false;
	(*tag)[i] = path;
	return true;
}

/* Bounce k of the round's diffuse ones (coat: plastic ones): what
 * surface_lanes reads, and its random numbers drawn in bounce's order
 * (the photon's dither, u1, which only plastic uses, then u2 and u3,
 * which trace_paths warps into the direction with the round's others). */
static inline __attribute__((always_inline)) void
lane_take(struct diffuse_round *r, int k, const struct pm_scene *s,
    const struct pm_hit *h, struct photon_state *st, uint8_t path, bool coat)
{
	const struct pm_bsdf *b = &s->bsdfs[s->shapes[h->shape].bsdf];
	struct pm_rgb alb = coat ? pm_plastic_base(b) : b->diffuse;
	int c;

	r->dither[k] = pm_rng_float(&st->rng);
	if (coat)
		r->u1[k] = pm_rng_float(&st->rng);
	else
		(void)pm_rng_float(&st->rng);
	r->u2[k] = pm_rng_float(&st->rng);
	r->u3[k] = pm_rng_float(&st->rng);
	for (c = 0; c < 3; c++) {
		r->p[c][k] = (&h->p.x)[c];
		r->ng[c][k] = (&h->ng.x)[c];
		r->ns[c][k] = (&h->ns.x)[c];
		r->d[c][k] = (&st->d.x)[c];
	}
	r->flux[0][k] = st->flux.r;
	r->flux[1][k] = st->flux.g;
	r->flux[2][k] = st->flux.b;
	r->alb[0][k] = alb.r;
	r->alb[1][k] = alb.g;
	r->alb[2][k] = alb.b;
	if (coat) {
		r->spec[0][k] = b->specular.r;
		r->spec[1][k] = b->specular.g;
		r->spec[2][k] = b->specular.b;
		r->ior[k] = b->ior;
		r->ssw[k] = b->specular_sampling_weight;
	}
	r->scale[k] = h->scale;
	r->tw[k] = b->twosided ? -1 : 0;
	r->path[k] = path;
}

/* Lanes k0 .. k1 - 1, past a side's bounces up to its group of four, set
 * so that they compute on numbers */
static void
lane_pad(struct diffuse_round *r, int k0, int k1)
{
	int k, c;

	for (k = k0; k < k1; k++) {
		for (c = 0; c < 3; c++) {
			r->p[c][k] = r->ng[c][k] = r->d[c][k] = 0.0f;
			r->flux[c][k] = r->alb[c][k] = r->spec[c][k] = 0.0f;
			r->ns[c][k] = c == 2 ? 1.0f : 0.0f;
		}
		r->dither[k] = r->scale[k] = r->u2[k] = r->u3[k] = 0.0f;
		r->u1[k] = r->ssw[k] = 0.0f;
		r->ior[k] = 1.5f;
		r->tw[k] = 0;
	}
}

#if !PM_LANES
/* diffuse_lanes where the compiler has no SSE2: bounce's own calls
 * (coat_bounce takes no bounce there) */
static void
diffuse_lanes(struct diffuse_round *r, size_t j0, size_t j1)
{
	size_t k;

	for (k = j0; k < j1; k++) {
		struct pm_vec3 p = pm_v3(r->p[0][k], r->p[1][k], r->p[2][k]);
		struct pm_vec3 ng = pm_v3(r->ng[0][k], r->ng[1][k], r->ng[2][k]);
		struct pm_vec3 ns = pm_v3(r->ns[0][k], r->ns[1][k], r->ns[2][k]);
		struct pm_vec3 d = pm_v3(r->d[0][k], r->d[1][k], r->d[2][k]);
		struct pm_vec3 v = pm_v3(r->v[0][k], r->v[1][k], r->v[2][k]);
		struct pm_rgb f = pm_rgb(r->flux[0][k], r->flux[1][k],
		    r->flux[2][k]);
		struct pm_rgb a = pm_rgb(r->alb[0][k], r->alb[1][k],
		    r->alb[2][k]);
		struct pm_frame fr = pm_frame_from_normal(ns);
		struct pm_vec3 wi = pm_to_local(fr, pm_neg(d)), w, o;
		struct pm_hit h;
		uint8_t pw[4], dir[2], nrm[2];
		bool flip = r->tw[k] && wi.z < 0.0f;
		float pdf, q;
		int c;

		pm_rgbe_pack(f, r->dither[k], pw);
		pm_dir_pack(pm_neg(d), dir);
		pm_dir_pack(pm_dot(ng, d) < 0.0f ? ns : pm_neg(ns), nrm);
		for (c = 0; c < 4; c++)
			r->power[c][k] = pw[c];
		for (c = 0; c < 2; c++) {
			r->dir[c][k] = dir[c];
			r->normal[c][k] = nrm[c];
		}
		if (flip)
			wi.z = -wi.z;
		pdf = pm_cosine_hemisphere_pdf(v);
		r->ok[k] = !(wi.z <= 0.0f) && pdf > 0.0f ? -1 : 0;
		if (flip)
			v.z = -v.z;
		q = pm_fminf(pm_rgb_max(a), 1.0f);
		r->q[k] = q;
		f = pm_rgb_scale(pm_rgb_mul(f, a), 1.0f / q);
		w = pm_normalize(pm_to_world(fr, v));
		h.p = p;
		h.ng = ng;
		h.scale = r->scale[k];
		o = pm_hit_origin(&h, w);
		for (c = 0; c < 3; c++) {
			r->nflux[c][k] = (&f.r)[c];
			r->nd[c][k] = (&w.x)[c];
			r->no[c][k] = (&o.x)[c];
		}
	}
}
#endif

/* Bounce k's photon into out, tagged with its path in *tag, and the path
 * (its state in sts) moved on if the sample and the roulette let it:
 * bounce's result for it (1 on, 0 ended, -1 out of memory).  coat: a
 * plastic bounce. */
static inline __attribute__((always_inline)) int
lane_give(const struct diffuse_round *r, int k, struct photon_state *sts,
    struct pm_photon_buf *out, uint8_t **tag, size_t *tag_cap, bool coat)
{
	struct photon_state *st = &sts[r->path[k]];
	struct pm_photon *ph = buf_slot(out);
	float q;
	int c;

	if (ph == NULL || !tag_photon(tag, tag_cap, out->n - 1, r->path[k]))
		return -1;
	for (c = 0; c < 3; c++)
		ph->pos[c] = r->p[c][k];
	for (c = 0; c < 4; c++)
		ph->power[c] = (uint8_t)r->power[c][k];
	for (c = 0; c < 2; c++) {
		ph->dir[c] = (uint8_t)r->dir[c][k];
		ph->normal[c] = (uint8_t)r->normal[c][k];
	}
	ph->reserved[0] = ph->reserved[1] = 0;
	ph->flags = (uint8_t)(PM_KD_LEAF |
	    (st->via_diffuse ? PM_PHOTON_VIA_DIFFUSE : 0) |
	    (st->specular_only && st->depth > 0 ? PM_PHOTON_CAUSTIC : 0));
	ph->depth = (uint8_t)(st->depth < 255 ? st->depth : 255);
	if (!r->ok[k])
		return 0;
	q = r->q[k];
	if (!(q > 0.0f) || pm_rng_float(&st->rng) >= q)
		return 0;
	st->flux = pm_rgb(r->nflux[0][k], r->nflux[1][k], r->nflux[2][k]);
	if (!coat || !r->coat_spec[k]) {
		/* a diffuse lobe, not plastic's coating */
		st->specular_only = false;
		st->via_diffuse = true;
	}
	st->d = pm_v3(r->nd[0][k], r->nd[1][k], r->nd[2][k]);
	st->o = pm_v3(r->no[0][k], r->no[1][k], r->no[2][k]);
	st->depth++;
	return 1;
}

/* lane_give for a side's n bounces (coat: the plastic ones, from the
 * last lane down), the paths that go on appended to idx[*m..]; false
 * without memory. */
static inline __attribute__((always_inline)) bool
lanes_give(const struct diffuse_round *r, int n, bool coat,
    struct photon_state *sts, struct pm_photon_buf *out, uint8_t **tag,
    size_t *tag_cap, uint8_t *idx, int *m)
{
	int c;

	for (c = 0; c < n; c++) {
		int l = coat ? COAT_LANE(c) : c;
		int g = lane_give(r, l, sts, out, tag, tag_cap, coat);

		if (g < 0)
			return false;
		if (g > 0)
			idx[(*m)++] = r->path[l];
	}
	return true;
}

/*
 * Paths first .. first + n - 1 (n <= PHOTON_LANES) traced together,
 * without media: a bounce of every live path a round, the round's rays
 * cast as Embree packets (pm_accel_intersect_n), the bounces at plain
 * diffuse surfaces four at a time (diffuse_lanes, 1.05-1.14x more; their
 * directions warped together, not guessed ahead at the emission, another
 * 1.03-1.07x, stop 35), those at smooth plastic ones too (coat_lanes:
 * data/bunny.xml 1.01-1.03x, stop 36), the others as trace_path's.  Their photons go to
 * rd->tmp tagged with their path (rd->tag) and are put back in path order
 * at the end, so the chunk's photons are trace_path's, in its order, to
 * the bit.  The packets cast a round's rays 1.23x faster than one at a
 * time (bench casts, cornell-box), more than the bookkeeping costs: the
 * global pass 1.04-1.07x faster on this workplace's AVX-512 Xeon
 * (docs/accuracy.md, stop 34), where stop 25 measured rounds like these
 * at 1.00-1.02x on the machine of its day.  256 paths a round rather
 * than 64: the later bounces, when few paths are left, still fill whole
 * packets, and a round's fixed costs are paid a quarter as often
 * (cornell-box 1.04-1.06x, bunny 1.02-1.03x, stop 35).
 */
#define PHOTON_LANES 256
_Static_assert(PHOTON_LANES % 4 == 0 && DIFFUSE_LANES % 4 == 0 &&
    PHOTON_LANES + 6 <= DIFFUSE_LANES && PHOTON_LANES <= 256, "a round's "
    "diffuse and plastic bounces fill whole groups of four lanes from "
    "either end, and a byte tags a photon with its path");

/* A thread's working memory for trace_paths, on the heap: a round's
 * paths, rays, hits and diffuse lanes are about 120 KB, more than a
 * stack a caller made small can hold; and the round's photons, tagged
 * with their paths. */
struct round {
	struct path_start ps[PHOTON_LANES];
	struct photon_state st[PHOTON_LANES];
	struct pm_ray rays[PHOTON_LANES];
	struct pm_hit hits[PHOTON_LANES];
	struct diffuse_round dr;
	bool hitf[PHOTON_LANES];
	uint8_t idx[PHOTON_LANES];
	struct pm_photon_buf tmp;
	uint8_t *tag;
	size_t tag_cap;
};

static bool
trace_paths(const struct pm_shooter *sh, const struct pm_shoot_opts *opts,
    uint64_t first, int n, struct chunk_out *co, struct round *rd)
{
	const struct pm_scene *s = sh->scene;
	struct path_start *ps = rd->ps;
	struct photon_state *st = rd->st;
	struct pm_ray *rays = rd->rays;
	struct pm_hit *hits = rd->hits;
	struct diffuse_round *dr = &rd->dr;
	struct pm_photon_buf *tmp = &rd->tmp;
	uint8_t **tag = &rd->tag;
	size_t *tag_cap = &rd->tag_cap;
	bool *hitf = rd->hitf;
	uint8_t *idx = rd->idx;
	size_t cnt[PHOTON_LANES + 1], i;
	int max_depth = path_max_depth(opts), k, na, m, b, nd, nc, j, j2;
	/* the global pass's bounces in lanes (lane_kind) */
	const uint8_t *lane = opts->pass == PM_PASS_GLOBAL ? sh->lane : NULL;

	for (b = 0; b < n; b += EMIT_LANES)
		emit_batch(sh, opts, first + (uint64_t)b,
		    n - b < EMIT_LANES ? n - b : EMIT_LANES, false, ps + b);
	for (k = na = 0; k < n; k++)
		if (ps[k].ok) {
			state_start(&st[k], &ps[k]);
			idx[na++] = (uint8_t)k;
		}
	tmp->n = 0;
	while (na > 0) {
		for (k = 0; k < na; k++) {
			const struct photon_state *p = &st[idx[k]];

			rays[k].o = p->o;
			rays[k].d = p->d;
			rays[k].tmin = 0.0f;
			rays[k].tmax = INFINITY;
		}
		pm_accel_intersect_n(sh->accel, rays, (size_t)na, hits, hitf);
		for (k = m = nd = nc = 0; k < na; k++) {
			struct photon_state *p = &st[idx[k]];
			size_t before = tmp->n;
			int r;

			if (hitf[k] && lane != NULL && lane[hits[k].shape] !=
			    LANE_NONE && p->depth < max_depth &&
			    pm_rgb_is_finite(p->flux)) {
				if (lane[hits[k].shape] == LANE_DIFFUSE) {
					lane_take(dr, nd++, s, &hits[k], p,
					    idx[k], false);
					continue;
				}
				if (p->depth == 0)
					co->paths_specular++;	/* as bounce */
				lane_take(dr, COAT_LANE(nc++), s, &hits[k], p,
				    idx[k], true);
				continue;
			}
			r = hitf[k] ? bounce(sh, opts, &ps[idx[k]], max_depth,
			    &hits[k], p, co, tmp) : 0;
			if (r < 0)
				return false;
			if (tmp->n > before &&
			    !tag_photon(tag, tag_cap, before, idx[k]))
				return false;
			if (r > 0)
				idx[m++] = idx[k];
		}
		/*
		 * The round's directions warped together: a bounce's warp
		 * alone is one long chain of dependent arithmetic
		 * (emit_batch), side by side in SIMD a short one.  The
		 * diffuse bounces in lanes [0, j), plastic ones in [j2,
		 * DIFFUSE_LANES).
		 */
		j = (nd + 3) / 4 * 4;
		j2 = DIFFUSE_LANES - (nc + 3) / 4 * 4;
		if (nd > 0) {
			lane_pad(dr, nd, j);
			pm_square_to_cosine_hemisphere_n(dr->u2, dr->u3, dr->v[0],
			    dr->v[1], dr->v[2], (size_t)j);
			diffuse_lanes(dr, 0, (size_t)j);
		}
#if PM_LANES
		if (nc > 0) {
			lane_pad(dr, j2, COAT_LANE(nc) + 1);
			pm_square_to_cosine_hemisphere_n(dr->u2 + j2, dr->u3 + j2,
			    dr->v[0] + j2, dr->v[1] + j2, dr->v[2] + j2,
			    (size_t)(DIFFUSE_LANES - j2));
			coat_lanes(dr, (size_t)j2, DIFFUSE_LANES);
		}
#endif
		if (!lanes_give(dr, nd, false, st, tmp, tag, tag_cap, idx, &m) ||
		    !lanes_give(dr, nc, true, st, tmp, tag, tag_cap, idx, &m))
			return false;
		na = m;
	}
	/* back in path order: a counting sort by path, stable */
	memset(cnt, 0, sizeof(cnt));
	for (i = 0; i < tmp->n; i++)
		cnt[(*tag)[i] + 1]++;
	for (k = 0; k < PHOTON_LANES; k++)
		cnt[k + 1] += cnt[k];
	if (co->buf.cap - co->buf.n < tmp->n) {
		size_t cap = co->buf.n + tmp->n;
		struct pm_photon *np;

		cap = cap < 2 * co->buf.cap ? 2 * co->buf.cap : cap;
		np = realloc(co->buf.p, cap * sizeof(*np));
		if (np == NULL)
			return false;
		co->buf.p = np;
		co->buf.cap = cap;
	}
	for (i = 0; i < tmp->n; i++)
		co->buf.p[co->buf.n + cnt[(*tag)[i]]++] = tmp->p[i];
	co->buf.n += tmp->n;
	return true;
}

/*
 * Chunks are handed out in order from a counter, and each one's photons
 * are appended to the output as soon as it and every chunk before it are
 * done: the output is in chunk order whatever the number of threads, no
 * chunk waits long, and the photons are never held twice (the peak
 * memory is the map plus a few chunks), nor copied in one serial pass at
 * the end.
 */
struct job {
	const struct pm_shooter *sh;
	const struct pm_shoot_opts *opts;
	struct chunk_out *chunks;
	size_t nchunks;
	_Atomic size_t next;
	_Atomic int failed;
	pthread_mutex_t lock;	/* guards what follows and chunks' done */
	size_t committed;	/* chunks appended to out */
	struct pm_photon_buf *out;
	bool out_of_memory;
	bool sink_failed;	/* sink_err says why */
	struct pm_error sink_err;
	uint64_t stored, vstored;
};

/* Appends src to dst, growing it by half at least; false without memory. */
static bool
append_buf(struct pm_photon_buf *dst, const struct pm_photon_buf *src)
{
	if (src->n > dst->cap - dst->n) {
		/* Grow by half: realloc moves large blocks by remapping, and
		 * untouched pages cost nothing. */
		size_t cap = dst->n + src->n;
		struct pm_photon *np;

		cap = cap < dst->cap + dst->cap / 2 ? dst->cap + dst->cap / 2 :
		    cap;
		np = realloc(dst->p, cap * sizeof(*np));
		if (np == NULL)
			return false;
		dst->p = np;
		dst->cap = cap;
	}
	if (src->n > 0) {
		memcpy(dst->p + dst->n, src->p, src->n * sizeof(*src->p));
		dst->n += src->n;
	}
	return true;
}

/* Appends every done chunk that follows the committed ones; under
 * j->lock. */
static void
commit_chunks(struct job *j)
{
	while (j->committed < j->nchunks && j->chunks[j->committed].done) {
		struct chunk_out *co = &j->chunks[j->committed++];

		if (j->opts->sink != NULL) {
			if (!j->sink_failed && j->opts->sink(j->opts->sink_arg,
			    co->buf.p, co->buf.n, co->note, &j->sink_err) !=
			    PM_OK) {
				j->sink_failed = true;
				atomic_store(&j->failed, 1);
			}
		} else if (!j->out_of_memory && !append_buf(j->out, &co->buf))
			j->out_of_memory = true;
		if (!j->out_of_memory && j->opts->volume != NULL &&
		    !append_buf(j->opts->volume, &co->vbuf))
			j->out_of_memory = true;
		j->stored += co->buf.n;
		j->vstored += co->vbuf.n;
		pm_photon_buf_free(&co->buf);
		pm_photon_buf_free(&co->vbuf);
	}
}

static void *
worker(void *arg)
{
	struct job *j = arg;
	struct round *rd = NULL;
	size_t c;

	while ((c = atomic_fetch_add(&j->next, 1)) < j->nchunks) {
		uint64_t first = j->opts->first + (uint64_t)c * CHUNK;
		uint64_t end = j->opts->first + j->opts->count, i;
		/* Filled here, not in j->chunks: neighbouring chunks
		 * share cache lines, and two threads bumping their
		 * photon counts there for every photon cost pm-shoot a
		 * tenth of its speed-up. */
		struct chunk_out co = {0};
		bool ok = true;

		if (first + CHUNK < end)
			end = first + CHUNK;
		if (j->sh->scene->nmedia == 0) {
			if (rd == NULL && (rd = calloc(1, sizeof(*rd))) == NULL)
				ok = false;
			for (i = first; i < end && ok; i += PHOTON_LANES)
				ok = trace_paths(j->sh, j->opts, i,
				    end - i < PHOTON_LANES ? (int)(end - i) :
				    PHOTON_LANES, &co, rd);
		} else {
			/* media: one path at a time */
			for (i = first; i < end && ok; i += EMIT_LANES) {
				struct path_start ps[EMIT_LANES];
				int k, n = end - i < EMIT_LANES ?
				    (int)(end - i) : EMIT_LANES;

				emit_batch(j->sh, j->opts, i, n, true, ps);
				for (k = 0; k < n && ok; k++)
					ok = trace_path(j->sh, j->opts, &ps[k],
					    &co);
			}
		}
		if (ok && j->opts->sink_prepare != NULL)
			j->opts->sink_prepare(j->opts->sink_arg, co.buf.p,
			    co.buf.n, co.note);
		pthread_mutex_lock(&j->lock);
		j->chunks[c] = co;	/* freed by pm_shoot if not done */
		if (!ok) {
			pthread_mutex_unlock(&j->lock);
			atomic_store(&j->failed, 1);
			break;
		}
		j->chunks[c].done = true;
		commit_chunks(j);
		pthread_mutex_unlock(&j->lock);
		if (atomic_load(&j->failed))
			break;
	}
	if (rd != NULL) {
		pm_photon_buf_free(&rd->tmp);
		free(rd->tag);
		free(rd);
	}
	return NULL;
}

enum pm_err
pm_shoot(const struct pm_shooter *sh, const struct pm_shoot_opts *opts,
    struct pm_photon_buf *out, struct pm_shoot_stats *stats, struct pm_error *err)
{
	struct job j;
	pthread_t *tid;
	int i, started = 0, nthreads = opts->threads < 1 ? 1 : opts->threads;
	size_t c;
	enum pm_err rc = PM_OK;

	memset(stats, 0, sizeof(*stats));
	if (opts->count == 0)
		return PM_OK;
	if (sh->scene->nlights == 0)
		return pm_fail(err, PM_ERR_INVALID, "the scene has no lights to shoot from");
	j.sh = sh;
	j.opts = opts;
	j.nchunks = (size_t)((opts->count + CHUNK - 1) / CHUNK);
	j.chunks = calloc(j.nchunks, sizeof(*j.chunks));
	tid = calloc((size_t)nthreads, sizeof(*tid));
	if (j.chunks == NULL || tid == NULL) {
		free(j.chunks);
		free(tid);
		return pm_fail(err, PM_ERR_NOMEM, "no memory for %zu photon chunks",
		    j.nchunks);
	}
	atomic_init(&j.next, 0);
	atomic_init(&j.failed, 0);
	if (pthread_mutex_init(&j.lock, NULL) != 0) {
		free(j.chunks);
		free(tid);
		return pm_fail(err, PM_ERR_NOMEM, "no mutex for the photon chunks");
	}
	j.committed = 0;
	j.out = out;
	j.out_of_memory = false;
	j.sink_failed = false;
	j.stored = j.vstored = 0;
	for (i = 1; i < nthreads; i++)
		if (pthread_create(&tid[started], NULL, worker, &j) == 0)
			started++;
	worker(&j);
	for (i = 0; i < started; i++)
		pthread_join(tid[i], NULL);
	free(tid);

	pthread_mutex_destroy(&j.lock);
	if (j.sink_failed) {
		if (err != NULL)
			*err = j.sink_err;
		rc = j.sink_err.code;
	} else if (atomic_load(&j.failed))
		rc = pm_fail(err, PM_ERR_NOMEM, "no memory for the photons");
	else if (j.out_of_memory)
		rc = pm_fail(err, PM_ERR_NOMEM, "no memory for %llu photons "
		    "(%llu bytes)", (unsigned long long)j.stored,
		    (unsigned long long)(j.stored * sizeof(*out->p)));
	stats->stored = j.stored;
	stats->volume_stored = j.vstored;
	for (c = 0; c < j.nchunks; c++) {
		struct chunk_out *co = &j.chunks[c];

		stats->dropped += co->dropped;
		stats->paths_specular += co->paths_specular;
		/* Chunks left behind by a failure. */
		pm_photon_buf_free(&co->buf);
		pm_photon_buf_free(&co->vbuf);
	}
	free(j.chunks);
	return rc;
}

/* FNV-1a, 64 bits, over whatever bytes describe the photons' world. */
static uint64_t
fnv(uint64_t h, const void *data, size_t len)
{
	const unsigned char *p = data;
	size_t i;

	for (i = 0; i < len; i++) {
		h ^= p[i];
		h *= 0x100000001b3ULL;
	}
	return h;
}

static uint64_t
fnv_f(uint64_t h, float f)
{
	return fnv(h, &f, sizeof(f));
}

static uint64_t
fnv_rgb(uint64_t h, struct pm_rgb c)
{
	return fnv_f(fnv_f(fnv_f(h, c.r), c.g), c.b);
}

static uint64_t
fnv_i(uint64_t h, int64_t v)
{
	return fnv(h, &v, sizeof(v));
}

/* A volume of a heterogeneous medium: its constant or its grid's
 * voxels, placement, filter and wrap. */
static uint64_t
volume_hash(uint64_t h, const struct pm_volume *v)
{
	const struct pm_grid *g = &v->grid;
	int r, c;

	h = fnv_rgb(h, v->value);
	if (g->data != NULL) {
		h = fnv_i(fnv_i(fnv_i(fnv_i(h, g->nx), g->ny), g->nz), g->nch);
		h = fnv(h, g->data, sizeof(float) * (size_t)g->nx *
		    (size_t)g->ny * (size_t)g->nz * (size_t)g->nch);
	}
	for (r = 0; r < 3; r++)
		for (c = 0; c < 4; c++)
			h = fnv_f(h, v->to_local.m[r][c]);
	return fnv_i(fnv_i(h, v->nearest), v->wrap);
}

/* A heterogeneous medium's volumes, scale and box (only media of that
 * kind hash them, so homogeneous scenes keep their hashes). */
static uint64_t
hetero_hash(uint64_t h, const struct pm_hetero *het)
{
	h = volume_hash(volume_hash(h, &het->sigma_t), &het->albedo);
	h = fnv_f(h, het->scale);
	h = fnv_f(fnv_f(fnv_f(h, het->lo.x), het->lo.y), het->lo.z);
	return fnv_f(fnv_f(fnv_f(h, het->hi.x), het->hi.y), het->hi.z);
}

/* A texture's identity: its parameters and texels. */
static uint64_t
texture_hash(uint64_t h, const struct pm_texture *t)
{
	int i;

	h = fnv_i(h, t->type);
	for (i = 0; i < 6; i++)
		h = fnv_f(h, t->to_uv[i]);
	h = fnv_rgb(fnv_rgb(h, t->color0), t->color1);
	if (t->type == PM_TEXTURE_MESH_ATTRIBUTE)
		h = fnv_f(fnv_i(h, t->attr), t->scale);
	for (i = 0; i < 2; i++)
		if (t->sub[i] != NULL)
			h = texture_hash(fnv_i(h, 10 + i), t->sub[i]);
	h = fnv_i(fnv_i(h, t->width), t->height);
	if (t->rgb != NULL)
		h = fnv(h, t->rgb, sizeof(float) * 3 * (size_t)t->width *
		    (size_t)t->height);
	return fnv_i(fnv_i(h, t->nearest), t->wrap);
}

uint64_t
pm_scene_hash(const struct pm_scene *s)
{
	uint64_t h = 0xcbf29ce484222325ULL;
	size_t i;

	/* Field by field: struct padding must not leak into the identity. */
	h = fnv_i(h, (int64_t)s->nshapes);
	for (i = 0; i < s->nshapes; i++) {
		const struct pm_shape *sh = &s->shapes[i];

		h = fnv_i(h, sh->type);
		h = fnv_i(h, sh->bsdf);
		h = fnv_i(h, sh->light);
		h = fnv_i(h, sh->flip_normals);
		if (sh->type == PM_SHAPE_SPHERE) {
			h = fnv_f(fnv_f(fnv_f(fnv_f(h, sh->center.x), sh->center.y),
			    sh->center.z), sh->radius);
			continue;
		}
		h = fnv_i(h, sh->mesh.nverts);
		h = fnv_i(h, sh->mesh.ntris);
		h = fnv(h, sh->mesh.pos, sizeof(float) * 3 * sh->mesh.nverts);
		h = fnv(h, sh->mesh.idx, sizeof(uint32_t) * 3 * sh->mesh.ntris);
		h = fnv_i(h, sh->mesh.nrm != NULL);
		if (sh->mesh.nrm != NULL)
			h = fnv(h, sh->mesh.nrm, sizeof(float) * 3 * sh->mesh.nverts);
	}
	h = fnv_i(h, (int64_t)s->nbsdfs);
	for (i = 0; i < s->nbsdfs; i++) {
		const struct pm_bsdf *b = &s->bsdfs[i];

		h = fnv_i(h, b->type);
		h = fnv_i(h, b->twosided);
		h = fnv_rgb(h, b->diffuse);
		h = fnv_rgb(h, b->specular);
		h = fnv_rgb(h, b->transmittance);
		h = fnv_rgb(h, b->eta);
		h = fnv_rgb(h, b->k);
		h = fnv_f(h, b->ior);
		h = fnv_f(h, b->alpha);
		h = fnv_i(h, b->sample_visible);
		/* only when set, so that the scenes hashed before it keep
		 * their hashes */
		if (b->beckmann)
			h = fnv_i(h, 1);
		h = fnv_i(h, b->nonlinear);
		/* a measured table by its file's size and crc32: the same
		 * bytes under another name are the same material */
		if (b->type == PM_BSDF_MERL && b->merl != NULL) {
			h = fnv_i(h, (int64_t)b->merl->size);
			h = fnv_i(h, b->merl->crc);
			h = fnv_i(h, b->merl_flags);
		}
		/* textures, again only when there are any */
		if (b->tex_diffuse > 0)
			h = texture_hash(fnv_i(h, 1), &s->textures[b->tex_diffuse - 1]);
		if (b->tex_specular > 0)
			h = texture_hash(fnv_i(h, 2), &s->textures[b->tex_specular - 1]);
		if (b->tex_alpha > 0)
			h = texture_hash(fnv_i(h, 3), &s->textures[b->tex_alpha - 1]);
		if (b->tex_transmittance > 0)
			h = texture_hash(fnv_i(h, 5),
			    &s->textures[b->tex_transmittance - 1]);
		/* the principled BSDFs' parameters, only for them */
		if (b->type == PM_BSDF_PRINCIPLED ||
		    b->type == PM_BSDF_PRINCIPLEDTHIN) {
			int j;

			h = fnv(h, b->pr.v, sizeof(b->pr.v));
			h = fnv(h, b->pr.rate, sizeof(b->pr.rate));
			h = fnv_i(h, b->pr.has_spec_trans +
			    2 * b->pr.has_clearcoat + 4 * b->pr.has_diff_trans);
			for (j = 0; j < PM_PR_N; j++)
				if (b->pr.tex[j] > 0)
					h = texture_hash(fnv_i(h, 10 + j),
					    &s->textures[b->pr.tex[j] - 1]);
		}
		/* BSDFs made of others, again only when there are any */
		if (pm_bsdf_is_composite(b)) {
			h = fnv_i(fnv_i(h, b->nested[0]), b->nested[1]);
			h = fnv_f(h, b->weight);
		}
		if (b->tex_weight > 0)
			h = texture_hash(fnv_i(h, 4), &s->textures[b->tex_weight - 1]);
	}
	/* where textures are, the uv they are looked up by */
	for (i = 0; s->ntextures > 0 && i < s->nshapes; i++) {
		const struct pm_shape *sh = &s->shapes[i];

		if (sh->type == PM_SHAPE_SPHERE)
			h = fnv(h, &sh->axes, sizeof(sh->axes));
		else if (sh->mesh.uv != NULL)
			h = fnv(h, sh->mesh.uv, sizeof(float) * 2 * sh->mesh.nverts);
		/* and the mesh attributes of mesh_attribute textures */
		if (sh->type == PM_SHAPE_MESH && sh->mesh.vcolor != NULL)
			h = fnv(fnv_i(h, 6), sh->mesh.vcolor, sizeof(float) * 3 *
			    sh->mesh.nverts);
		if (sh->type == PM_SHAPE_MESH && sh->mesh.fcolor != NULL)
			h = fnv(fnv_i(h, 7), sh->mesh.fcolor, sizeof(float) * 3 *
			    sh->mesh.ntris);
	}
	/* media, only when there are any (scenes without keep their
	 * hashes): the media and which shapes bound them */
	if (s->nmedia > 0) {
		h = fnv_i(h, (int64_t)s->nmedia);
		for (i = 0; i < s->nmedia; i++) {
			const struct pm_medium *m = &s->media[i];

			h = fnv_i(h, m->type);
			h = fnv_rgb(fnv_rgb(h, m->sigma_t), m->albedo);
			h = fnv_i(fnv_f(h, m->phase.g), m->phase.type);
			if (m->het != NULL)
				h = hetero_hash(h, m->het);
		}
		for (i = 0; i < s->nshapes; i++)
			h = fnv_i(fnv_i(h, s->shapes[i].interior),
			    s->shapes[i].exterior);
	}
	h = fnv_i(h, (int64_t)s->nlights);
	for (i = 0; i < s->nlights; i++) {
		const struct pm_light *l = &s->lights[i];

		h = fnv_i(h, l->type);
		h = fnv_rgb(h, l->radiance);
		h = fnv_rgb(h, l->intensity);
		h = fnv_i(h, l->shape);
		h = fnv_f(fnv_f(fnv_f(h, l->position.x), l->position.y), l->position.z);
		h = fnv_f(fnv_f(fnv_f(h, l->frame.n.x), l->frame.n.y), l->frame.n.z);
		h = fnv_f(h, l->cutoff_angle);
		h = fnv_f(h, l->beam_width);
		/* textured lights and projectors only, as below */
		if (l->tex > 0)
			h = texture_hash(fnv_i(h, 4), &s->textures[l->tex - 1]);
		if (l->tex > 0 || l->type == PM_LIGHT_PROJECTOR) {
			int r, c;

			for (r = 0; r < 3; r++)
				for (c = 0; c < 4; c++)
					h = fnv_f(h, l->to_local.m[r][c]);
			h = fnv_f(fnv_f(h, l->tan_fov), l->aspect);
		}
		/* only for the light types that have them, so that the
		 * scenes hashed before they existed keep their hashes */
		if (l->type == PM_LIGHT_DIRECTIONAL)
			h = fnv_f(fnv_f(fnv_f(h, l->direction.x),
			    l->direction.y), l->direction.z);
		if (l->type == PM_LIGHT_ENVMAP && l->env != NULL) {
			const struct pm_envmap *e = l->env;
			int r, c;

			h = fnv_i(fnv_i(h, e->width), e->height);
			h = fnv(h, e->rgb, sizeof(float) * 3 *
			    ((size_t)e->width + 1) * (size_t)e->height);
			for (r = 0; r < 3; r++)
				for (c = 0; c < 3; c++)
					h = fnv_f(h, e->to_world.m[r][c]);
		}
	}
	return h;
}
