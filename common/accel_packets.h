/*
 * accel_packets.h: pm_accel_intersect_n's and pm_accel_occluded_n's loops
 * over packets of PW rays, written once for any width Embree takes (4, 8
 * or 16): accel.c includes this with PW defined (8; see there why).
 * Not a header of its own; the names below carry the width.
 */
#define PW_PASTE(a, b) a##b
#define PW_NAME(a, b) PW_PASTE(a, b)
#define PW_RAYHIT PW_NAME(struct RTCRayHit, PW)
#define PW_RAY PW_NAME(struct RTCRay, PW)

/* Groups of n >= PACKET_MIN rays, PW at a time; a last group of fewer
 * than PACKET_MIN goes one ray at a time. */
static void
PW_NAME(intersect_packets, PW)(const struct pm_accel *a,
    const struct pm_ray *r, size_t n, struct pm_hit *h, bool *hit)
{
	struct RTCIntersectContext ctx;
	_Alignas(64) PW_RAYHIT rh;
	_Alignas(64) int valid[PW];
	size_t i, k, m;

	rtcInitIntersectContext(&ctx);
	for (i = 0; i < n; i += PW) {
		m = n - i < PW ? n - i : PW;
		if (m < PACKET_MIN) {
			for (k = i; k < n; k++)
				hit[k] = pm_accel_intersect(a, r[k].o, r[k].d,
				    r[k].tmin, r[k].tmax, &h[k]);
			break;
		}
		for (k = 0; k < PW; k++) {
			/* dead lanes get a copy of a live ray: the
			 * packet then holds no garbage for Embree to read */
			const struct pm_ray *q = &r[i + (k < m ? k : 0)];

			valid[k] = k < m ? -1 : 0;
			rh.ray.org_x[k] = q->o.x;
			rh.ray.org_y[k] = q->o.y;
			rh.ray.org_z[k] = q->o.z;
			rh.ray.dir_x[k] = q->d.x;
			rh.ray.dir_y[k] = q->d.y;
			rh.ray.dir_z[k] = q->d.z;
			rh.ray.tnear[k] = q->tmin;
			rh.ray.tfar[k] = q->tmax;
			rh.ray.time[k] = 0.0f;
			rh.ray.mask[k] = 0xffffffffu;
			rh.ray.id[k] = 0;
			rh.ray.flags[k] = 0;
			rh.hit.geomID[k] = RTC_INVALID_GEOMETRY_ID;
			rh.hit.instID[0][k] = RTC_INVALID_GEOMETRY_ID;
		}
		PW_NAME(rtcIntersect, PW)(valid, a->scene, &ctx, &rh);
		for (k = 0; k < m; k++) {
			hit[i + k] = rh.hit.geomID[k] != RTC_INVALID_GEOMETRY_ID;
			if (hit[i + k])
				fill_hit(a, r[i + k].o, r[i + k].d, rh.ray.tfar[k],
				    rh.hit.geomID[k], rh.hit.primID[k],
				    rh.hit.u[k], rh.hit.v[k], &h[i + k]);
		}
	}
}

static void
PW_NAME(occluded_packets, PW)(const struct pm_accel *a,
    const struct pm_ray *r, size_t n, bool *occ)
{
	struct RTCIntersectContext ctx;
	_Alignas(64) PW_RAY ry;
	_Alignas(64) int valid[PW];
	size_t i, k, m;

	rtcInitIntersectContext(&ctx);
	for (i = 0; i < n; i += PW) {
		m = n - i < PW ? n - i : PW;
		if (m < PACKET_MIN) {
			for (k = i; k < n; k++)
				occ[k] = pm_accel_occluded(a, r[k].o, r[k].d,
				    r[k].tmin, r[k].tmax);
			break;
		}
		for (k = 0; k < PW; k++) {
			const struct pm_ray *q = &r[i + (k < m ? k : 0)];

			valid[k] = k < m ? -1 : 0;
			ry.org_x[k] = q->o.x;
			ry.org_y[k] = q->o.y;
			ry.org_z[k] = q->o.z;
			ry.dir_x[k] = q->d.x;
			ry.dir_y[k] = q->d.y;
			ry.dir_z[k] = q->d.z;
			ry.tnear[k] = q->tmin;
			ry.tfar[k] = q->tmax;
			ry.time[k] = 0.0f;
			ry.mask[k] = 0xffffffffu;
			ry.id[k] = 0;
			ry.flags[k] = 0;
		}
		PW_NAME(rtcOccluded, PW)(valid, a->scene, &ctx, &ry);
		for (k = 0; k < m; k++)
			occ[i + k] = ry.tfar[k] < 0.0f;
	}
}

#undef PW_RAY
#undef PW_RAYHIT
#undef PW_NAME
#undef PW_PASTE
