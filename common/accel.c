/*
 * accel.c: Embree 3 scene built from pm's shapes; closest-hit and shadow
 * queries that return pm's hit record.
 *
 * Triangles are copied into Embree's own buffers (Embree may read 16 bytes
 * past the last vertex, so sharing our exactly-sized arrays is not safe).
 * Spheres are Embree user geometry with pm's own ray test (sphere_hits);
 * Embree's sphere primitive cost a third more a ray one at a time, and
 * rounded differently in packets than alone.  Geometric normals and
 * hit positions are recomputed from our vertices rather than taken from
 * Embree, so that their orientation and precision are ours to define.
 */
#include <stdlib.h>
#include <string.h>

#include <embree3/rtcore.h>

#include "accel.h"

/* What a hit needs of a triangle that does not depend on where on it the
 * ray landed, computed once at build time with the very expressions a hit
 * would use (so the bits are the same): a closest hit then reads 16 bytes
 * instead of normalising a cross product and taking 9 magnitudes, about
 * 5% of a path-traced frame. */
struct pm_tri_geom {
	struct pm_vec3 ng;		/* unit geometric normal */
	float scale;			/* largest coordinate magnitude */
	/* The shading normal of a flat triangle (no vertex normals, or
	 * three equal ones: Mitsuba's rectangles, cubes and disks, every
	 * face of a faceted mesh), found once here rather than
	 * interpolated and normalised at every hit, where it was 4% of a
	 * path tracer's time in the Cornell box */
	struct pm_vec3 ns;
	uint32_t flat;
};

struct pm_accel {
	RTCDevice device;
	RTCScene scene;
	const struct pm_scene *s;
	struct pm_tri_geom **tri;	/* per shape, NULL for spheres */
};

/* Packets with fewer live rays than this go one at a time (a packet's
 * cost hardly depends on how many of its lanes are live). */
#define PACKET_MIN 3

static enum pm_err
embree_error(RTCDevice dev, struct pm_error *err, const char *what)
{
	enum RTCError e = rtcGetDeviceError(dev);

	return pm_fail(err, PM_ERR_GEOMETRY, "embree: %s failed (error %d)",
	    what, (int)e);
}

/*
 * Embree's low build quality (its Morton-code builder) rather than high
 * (binned SAH with spatial splits): measured one core each, side by side,
 * data/bunny.xml's BVH built in 9 to 13 ms of CPU rather than 29, and its
 * rays were no slower, if anything faster (path tracing at 8 spp, 128x128:
 * 0.174 s against 0.214 s, best of five).  Every tool builds the BVH
 * afresh, so its cost is paid in every pm-shoot and pm-render.
 */
#define PM_ACCEL_QUALITY RTC_BUILD_QUALITY_LOW

static inline float
pm_max_abs(struct pm_vec3 a)
{
	return pm_fmaxf(fabsf(a.x), pm_fmaxf(fabsf(a.y), fabsf(a.z)));
}

static enum pm_err
add_mesh(struct pm_accel *a, const struct pm_shape *sh, unsigned id,
    struct pm_error *err)
{
	const struct pm_mesh *m = &sh->mesh;
	struct pm_tri_geom *tg;
	RTCGeometry g;
	float *vb;
	unsigned *ib;
	uint32_t k;

	tg = malloc((size_t)m->ntris * sizeof(*tg));
	if (tg == NULL)
		return pm_fail(err, PM_ERR_NOMEM,
		    "%s: no memory for %u triangles", sh->name, m->ntris);
	for (k = 0; k < m->ntris; k++) {
		const uint32_t *t = &m->idx[3 * (size_t)k];
		struct pm_vec3 p0 = pm_mesh_vertex(m, t[0]);
		struct pm_vec3 p1 = pm_mesh_vertex(m, t[1]);
		struct pm_vec3 p2 = pm_mesh_vertex(m, t[2]);

		tg[k].ng = pm_normalize(pm_cross(pm_sub(p1, p0), pm_sub(p2, p0)));
		tg[k].scale = pm_fmaxf(pm_fmaxf(pm_max_abs(p0), pm_max_abs(p1)),
		    pm_max_abs(p2));
		tg[k].ns = tg[k].ng;
		tg[k].flat = 1;
		if (m->nrm != NULL) {
			const float *n0 = &m->nrm[3 * t[0]];
			struct pm_vec3 n = pm_v3(n0[0], n0[1], n0[2]);

			tg[k].flat = memcmp(n0, &m->nrm[3 * t[1]],
			    3 * sizeof(*n0)) == 0 && memcmp(n0,
			    &m->nrm[3 * t[2]], 3 * sizeof(*n0)) == 0;
			/* as fill_triangle_hit: normals that cancel fall
			 * back to the face's */
			if (tg[k].flat && pm_length(n) > 1e-6f)
				tg[k].ns = pm_normalize(n);
		}
	}
	a->tri[id] = tg;

	g = rtcNewGeometry(a->device, RTC_GEOMETRY_TYPE_TRIANGLE);
	if (g == NULL)
		return embree_error(a->device, err, "rtcNewGeometry");
	vb = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0,
	    RTC_FORMAT_FLOAT3, 3 * sizeof(float), m->nverts);
	ib = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0,
	    RTC_FORMAT_UINT3, 3 * sizeof(unsigned), m->ntris);
	if (vb == NULL || ib == NULL) {
		rtcReleaseGeometry(g);
		return pm_fail(err, PM_ERR_NOMEM,
		    "%s: no memory for %u triangles", sh->name, m->ntris);
	}
	memcpy(vb, m->pos, (size_t)m->nverts * 3 * sizeof(float));
	memcpy(ib, m->idx, (size_t)m->ntris * 3 * sizeof(unsigned));
	rtcSetGeometryBuildQuality(g, PM_ACCEL_QUALITY);
	rtcCommitGeometry(g);
	rtcAttachGeometryByID(a->scene, g, id);
	rtcReleaseGeometry(g);
	return PM_OK;
}

/*
 * The nearest t in (tnear, tfar) where o + t d meets sphere sh, in double
 * precision; false if none.  The discriminant is taken as a |d|^2 (r^2 -
 * |l|^2), l the sphere centre's offset from the ray's closest point, and
 * the roots as c / q and q / a (Haines et al., "Precision improvements
 * for ray/sphere intersection", Ray Tracing Gems 2019), so that neither
 * loses digits to cancellation, far from the sphere or near it.  The same
 * code serves single rays and packets, so both give the same bits.
 */
static bool
sphere_hits(const struct pm_shape *sh, const float o[3], const float d[3],
    float tnear, float tfar, float *t_out)
{
	double f[3] = {(double)o[0] - sh->center.x, (double)o[1] - sh->center.y,
	    (double)o[2] - sh->center.z};
	double a = (double)d[0] * d[0] + (double)d[1] * d[1] + (double)d[2] * d[2];
	double bh = -(f[0] * d[0] + f[1] * d[1] + f[2] * d[2]);
	double r2 = (double)sh->radius * sh->radius, k, l[3], disc, q, t[2];
	int i;

	if (!(a > 0.0))
		return false;
	k = bh / a;
	l[0] = f[0] + k * d[0];
	l[1] = f[1] + k * d[1];
	l[2] = f[2] + k * d[2];
	disc = a * (r2 - (l[0] * l[0] + l[1] * l[1] + l[2] * l[2]));
	if (!(disc >= 0.0))
		return false;
	q = bh + copysign(sqrt(disc), bh);
	if (q == 0.0)
		return false;
	t[0] = (f[0] * f[0] + f[1] * f[1] + f[2] * f[2] - r2) / q;
	t[1] = q / a;
	if (t[0] > t[1]) {
		double x = t[0];

		t[0] = t[1];
		t[1] = x;
	}
	for (i = 0; i < 2; i++) {
		float tf = (float)t[i];

		if (tf > tnear && tf < tfar) {
			*t_out = tf;
			return true;
		}
	}
	return false;
}

static void
sphere_bounds(const struct RTCBoundsFunctionArguments *args)
{
	const struct pm_shape *sh = args->geometryUserPtr;
	struct RTCBounds *b = args->bounds_o;
	/* a little room: the box is rounded to float, the test is not */
	float r = sh->radius * (1.0f + 1e-5f) + 1e-6f * (fabsf(sh->center.x) +
	    fabsf(sh->center.y) + fabsf(sh->center.z));

	b->lower_x = sh->center.x - r;
	b->lower_y = sh->center.y - r;
	b->lower_z = sh->center.z - r;
	b->upper_x = sh->center.x + r;
	b->upper_y = sh->center.y + r;
	b->upper_z = sh->center.z + r;
}

/* Embree's ray and hit layouts for N lanes (rtcore_ray.h): each field an
 * array of N, in this order. */
enum { RAY_ORG = 0, RAY_TNEAR = 3, RAY_DIR = 4, RAY_TFAR = 8, RAY_FIELDS = 12,
	HIT_U = 3, HIT_V = 4, HIT_PRIM = 5, HIT_GEOM = 6, HIT_INST = 7 };

static void
sphere_intersect(const struct RTCIntersectFunctionNArguments *args)
{
	const struct pm_shape *sh = args->geometryUserPtr;
	unsigned n = args->N, i;
	float *ray = (float *)args->rayhit;
	float *hit = ray + RAY_FIELDS * n;

	for (i = 0; i < n; i++) {
		float o[3], d[3], t;

		if (args->valid[i] != -1)
			continue;
		o[0] = ray[(RAY_ORG + 0) * n + i];
		o[1] = ray[(RAY_ORG + 1) * n + i];
		o[2] = ray[(RAY_ORG + 2) * n + i];
		d[0] = ray[(RAY_DIR + 0) * n + i];
		d[1] = ray[(RAY_DIR + 1) * n + i];
		d[2] = ray[(RAY_DIR + 2) * n + i];
		if (!sphere_hits(sh, o, d, ray[RAY_TNEAR * n + i],
		    ray[RAY_TFAR * n + i], &t))
			continue;
		ray[RAY_TFAR * n + i] = t;
		hit[HIT_U * n + i] = 0.0f;
		hit[HIT_V * n + i] = 0.0f;
		((unsigned *)hit)[HIT_PRIM * n + i] = args->primID;
		((unsigned *)hit)[HIT_GEOM * n + i] = args->geomID;
		((unsigned *)hit)[HIT_INST * n + i] = RTC_INVALID_GEOMETRY_ID;
	}
}

static void
sphere_occluded(const struct RTCOccludedFunctionNArguments *args)
{
	const struct pm_shape *sh = args->geometryUserPtr;
	unsigned n = args->N, i;
	float *ray = (float *)args->ray;

	for (i = 0; i < n; i++) {
		float o[3], d[3], t;

		if (args->valid[i] != -1)
			continue;
		o[0] = ray[(RAY_ORG + 0) * n + i];
		o[1] = ray[(RAY_ORG + 1) * n + i];
		o[2] = ray[(RAY_ORG + 2) * n + i];
		d[0] = ray[(RAY_DIR + 0) * n + i];
		d[1] = ray[(RAY_DIR + 1) * n + i];
		d[2] = ray[(RAY_DIR + 2) * n + i];
		if (sphere_hits(sh, o, d, ray[RAY_TNEAR * n + i],
		    ray[RAY_TFAR * n + i], &t))
			ray[RAY_TFAR * n + i] = -INFINITY;
	}
}

static enum pm_err
add_sphere(struct pm_accel *a, const struct pm_shape *sh, unsigned id,
    struct pm_error *err)
{
	RTCGeometry g;

	g = rtcNewGeometry(a->device, RTC_GEOMETRY_TYPE_USER);
	if (g == NULL)
		return embree_error(a->device, err, "rtcNewGeometry");
	rtcSetGeometryUserPrimitiveCount(g, 1);
	rtcSetGeometryUserData(g, (void *)sh);
	rtcSetGeometryBoundsFunction(g, sphere_bounds, NULL);
	rtcSetGeometryIntersectFunction(g, sphere_intersect);
	rtcSetGeometryOccludedFunction(g, sphere_occluded);
	rtcCommitGeometry(g);
	rtcAttachGeometryByID(a->scene, g, id);
	rtcReleaseGeometry(g);
	return PM_OK;
}

enum pm_err
pm_accel_build(const struct pm_scene *s, struct pm_accel **out,
    struct pm_error *err)
{
	struct pm_accel *a;
	enum pm_err rc;
	size_t i;

	*out = NULL;
	a = calloc(1, sizeof(*a));
	if (a == NULL)
		return pm_fail(err, PM_ERR_NOMEM, "no memory for the accelerator");
	a->s = s;
	a->tri = calloc(s->nshapes > 0 ? s->nshapes : 1, sizeof(*a->tri));
	if (a->tri == NULL) {
		free(a);
		return pm_fail(err, PM_ERR_NOMEM, "no memory for the accelerator");
	}
	a->device = rtcNewDevice(NULL);
	if (a->device == NULL) {
		free(a->tri);
		free(a);
		return pm_fail(err, PM_ERR_GEOMETRY, "embree: cannot create a device");
	}
	a->scene = rtcNewScene(a->device);
	/* Mitsuba 3's default, Embree's plain scene: its robust mode
	 * (watertight triangles, conservative boxes) cast path tracing's
	 * rays 1.08x slower in the Cornell box, photons 1.05x (one core
	 * each, side by side, docs/accuracy.md); a scene that needs rays
	 * never to slip between two triangles' shared edge asks for it as
	 * it would Mitsuba. */
	rtcSetSceneFlags(a->scene, s->robust ? RTC_SCENE_FLAG_ROBUST :
	    RTC_SCENE_FLAG_NONE);
	rtcSetSceneBuildQuality(a->scene, PM_ACCEL_QUALITY);
	for (i = 0; i < s->nshapes; i++) {
		const struct pm_shape *sh = &s->shapes[i];

		if (sh->type == PM_SHAPE_SPHERE)
			rc = add_sphere(a, sh, (unsigned)i, err);
		else if (sh->mesh.ntris > 0)
			rc = add_mesh(a, sh, (unsigned)i, err);
		else
			rc = PM_OK;
		if (rc != PM_OK) {
			pm_accel_free(a);
			return rc;
		}
	}
	rtcCommitScene(a->scene);
	if (rtcGetDeviceError(a->device) != RTC_ERROR_NONE) {
		rc = embree_error(a->device, err, "rtcCommitScene");
		pm_accel_free(a);
		return rc;
	}
	*out = a;
	return PM_OK;
}

void
pm_accel_free(struct pm_accel *a)
{
	if (a == NULL)
		return;
	if (a->scene != NULL)
		rtcReleaseScene(a->scene);
	if (a->device != NULL)
		rtcReleaseDevice(a->device);
	if (a->tri != NULL) {
		size_t i;

		for (i = 0; i < a->s->nshapes; i++)
			free(a->tri[i]);
		free(a->tri);
	}
	free(a);
}

static void
fill_triangle_hit(const struct pm_shape *sh, const struct pm_tri_geom *tg,
    uint32_t prim, float u, float v, struct pm_hit *h)
{
	const struct pm_mesh *m = &sh->mesh;
	const uint32_t *t = &m->idx[3 * (size_t)prim];
	struct pm_vec3 p0 = pm_mesh_vertex(m, t[0]);
	struct pm_vec3 p1 = pm_mesh_vertex(m, t[1]);
	struct pm_vec3 p2 = pm_mesh_vertex(m, t[2]);
	float w = 1.0f - u - v;

	h->p = pm_add(pm_add(pm_scale(p0, w), pm_scale(p1, u)), pm_scale(p2, v));
	h->scale = tg[prim].scale;
	h->ng = tg[prim].ng;
	if (tg[prim].flat) {
		h->ns = tg[prim].ns;
	} else {
		const float *n = m->nrm;
		struct pm_vec3 n0 = pm_v3(n[3 * t[0]], n[3 * t[0] + 1], n[3 * t[0] + 2]);
		struct pm_vec3 n1 = pm_v3(n[3 * t[1]], n[3 * t[1] + 1], n[3 * t[1] + 2]);
		struct pm_vec3 n2 = pm_v3(n[3 * t[2]], n[3 * t[2] + 1], n[3 * t[2] + 2]);
		struct pm_vec3 ns = pm_add(pm_add(pm_scale(n0, w), pm_scale(n1, u)),
		    pm_scale(n2, v));
		float l = pm_length(ns);

		/* Normals that cancel within a face fall back to the face's. */
		h->ns = l > 1e-6f ? pm_scale(ns, 1.0f / l) : h->ng;
	}
}

static void
fill_sphere_hit(const struct pm_shape *sh, struct pm_vec3 p, struct pm_hit *h)
{
	struct pm_vec3 n = pm_normalize(pm_sub(p, sh->center));

	if (sh->flip_normals)
		n = pm_neg(n);
	/* Project back onto the sphere: o + t d carries the error of t. */
	h->p = pm_madd(sh->center, pm_normalize(pm_sub(p, sh->center)), sh->radius);
	h->ng = n;
	h->ns = n;
	h->scale = pm_max_abs(sh->center) + sh->radius;
}

static void
fill_hit(const struct pm_accel *a, struct pm_vec3 o, struct pm_vec3 d, float t,
    unsigned geom, unsigned prim, float u, float v, struct pm_hit *h)
{
	const struct pm_shape *sh = &a->s->shapes[geom];

	h->t = t;
	h->shape = (int)geom;
	h->prim = prim;
	h->u = u;
	h->v = v;
	if (sh->type == PM_SHAPE_SPHERE)
		fill_sphere_hit(sh, pm_madd(o, d, t), h);
	else
		fill_triangle_hit(sh, a->tri[geom], prim, u, v, h);
}

bool
pm_accel_intersect(const struct pm_accel *a, struct pm_vec3 o, struct pm_vec3 d,
    float tmin, float tmax, struct pm_hit *h)
{
	struct RTCIntersectContext ctx;
	struct RTCRayHit rh;

	/* Every field Embree reads is set; the hit's outputs are not
	 * cleared first (a memset of the 80 bytes showed in profiles). */
	rtcInitIntersectContext(&ctx);
	rh.ray.org_x = o.x;
	rh.ray.org_y = o.y;
	rh.ray.org_z = o.z;
	rh.ray.dir_x = d.x;
	rh.ray.dir_y = d.y;
	rh.ray.dir_z = d.z;
	rh.ray.tnear = tmin;
	rh.ray.tfar = tmax;
	rh.ray.time = 0.0f;
	rh.ray.mask = 0xffffffffu;
	rh.ray.id = 0;
	rh.ray.flags = 0;
	rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
	rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
	rtcIntersect1(a->scene, &ctx, &rh);
	if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID)
		return false;
	fill_hit(a, o, d, rh.ray.tfar, rh.hit.geomID, rh.hit.primID, rh.hit.u,
	    rh.hit.v, h);
	return true;
}

bool
pm_accel_occluded(const struct pm_accel *a, struct pm_vec3 o, struct pm_vec3 d,
    float tmin, float tmax)
{
	struct RTCIntersectContext ctx;
	struct RTCRay r;

	rtcInitIntersectContext(&ctx);
	r.org_x = o.x;
	r.org_y = o.y;
	r.org_z = o.z;
	r.dir_x = d.x;
	r.dir_y = d.y;
	r.dir_z = d.z;
	r.tnear = tmin;
	r.tfar = tmax;
	r.time = 0.0f;
	r.mask = 0xffffffffu;
	r.id = 0;
	r.flags = 0;
	rtcOccluded1(a->scene, &ctx, &r);
	/* Embree marks a blocked ray by setting tfar to -inf. */
	return r.tfar < 0.0f;
}

/*
 * The packet loops (accel_packets.h), for packets of 8 rays on every
 * CPU.  Packets of 16, which Embree casts natively with AVX-512, were
 * 1-3% faster on one machine (stop 25) but slower on this workplace's
 * AVX-512 Xeon: path mode 128x128, 64 spp, one core, 0.587-0.627 s with
 * 8 against 0.614-0.634 s with 16 (cornell-box; caustics 0.594-0.605
 * against 0.626-0.635), the photon render 0.104-0.105 s against 0.112 s.
 */
#define PW 8
#include "accel_packets.h"
#undef PW

void
pm_accel_intersect_n(const struct pm_accel *a, const struct pm_ray *r,
    size_t n, struct pm_hit *h, bool *hit)
{
	size_t i;

	if (n < PACKET_MIN) {
		for (i = 0; i < n; i++)
			hit[i] = pm_accel_intersect(a, r[i].o, r[i].d, r[i].tmin,
			    r[i].tmax, &h[i]);
		return;
	}
	intersect_packets8(a, r, n, h, hit);
}

void
pm_accel_occluded_n(const struct pm_accel *a, const struct pm_ray *r,
    size_t n, bool *occ)
{
	size_t i;

	if (n < PACKET_MIN) {
		for (i = 0; i < n; i++)
			occ[i] = pm_accel_occluded(a, r[i].o, r[i].d, r[i].tmin,
			    r[i].tmax);
		return;
	}
	occluded_packets8(a, r, n, occ);
}

void
pm_accel_bounds(const struct pm_accel *a, struct pm_vec3 *lo, struct pm_vec3 *hi)
{
	struct RTCBounds b;

	rtcGetSceneBounds(a->scene, &b);
	*lo = pm_v3(b.lower_x, b.lower_y, b.lower_z);
	*hi = pm_v3(b.upper_x, b.upper_y, b.upper_z);
}
