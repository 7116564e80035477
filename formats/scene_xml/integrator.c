/*
 * integrator.c: <integrator>: the path tracer's or the photon mapper's
 * parameters.
 */
#include "private.h"

enum pm_err
sx_load_integrator(struct ld *ld, struct xnode *n)
{
	struct pm_integrator *it = &ld->s->integrator;
	struct pm_photon_params *ph = &it->photon;
	struct plist pl;
	const char *type;
	long md, rr, v;
	double r;
	enum pm_err e;

	if (ld->integrator != NULL)
		return sx_fail(ld, n, PM_ERR_UNSUPPORTED, "more than one "
		    "<integrator> (the first is at %s:%d)",
		    ld->integrator->file, ld->integrator->line);
	ld->integrator = n;
	if ((e = sx_object_type(ld, n, &type)) != PM_OK ||
	    (e = sx_collect(ld, n, "integrator", type, &pl)) != PM_OK)
		return e;
	if (strcmp(type, "path") == 0) {
		it->type = PM_INTEGRATOR_PATH;
		if ((e = sx_get_int(ld, &pl, "max_depth", -1, -1, INT_MAX, &md))
		    != PM_OK ||
		    (e = sx_get_int(ld, &pl, "rr_depth", 5, 1, INT_MAX, &rr))
		    != PM_OK ||
		    (e = sx_get_bool(ld, &pl, "hide_emitters", false,
		    &it->hide_emitters)) != PM_OK)
			return e;
	} else if (strcmp(type, "photonmapper") == 0) {
		it->type = PM_INTEGRATOR_PHOTONMAPPER;
		if ((e = sx_get_int(ld, &pl, "maxDepth", -1, -1, INT_MAX, &md))
		    != PM_OK ||
		    (e = sx_get_int(ld, &pl, "rrDepth", 5, 1, INT_MAX, &rr))
		    != PM_OK ||
		    (e = sx_get_bool(ld, &pl, "hideEmitters", false,
		    &it->hide_emitters)) != PM_OK ||
		    (e = sx_get_int(ld, &pl, "globalPhotons", 250000, 0,
		    LONG_MAX, &ph->global_photons)) != PM_OK ||
		    (e = sx_get_int(ld, &pl, "causticPhotons", 250000, 0,
		    LONG_MAX, &ph->caustic_photons)) != PM_OK)
			return e;
		if ((e = sx_get_float(ld, &pl, "globalLookupRadius", 0.05, 1e-9,
		    1e9, &r)) != PM_OK)
			return e;
		ph->global_lookup_radius = (float)r;
		if ((e = sx_get_float(ld, &pl, "causticLookupRadius", 0.0125,
		    1e-9, 1e9, &r)) != PM_OK)
			return e;
		ph->caustic_lookup_radius = (float)r;
		if ((e = sx_get_int(ld, &pl, "lookupSize", 120, 1, 1 << 20, &v))
		    != PM_OK)
			return e;
		ph->lookup_size = (int)v;
		if ((e = sx_get_int(ld, &pl, "directSamples", 16, 0, 1 << 20, &v))
		    != PM_OK)
			return e;
		ph->direct_samples = (int)v;
		/* Mitsuba 0.6's glossySamples and granularity are checked and
		 * ignored (pm-scene(5)): glossy surfaces are path traced with
		 * one sample a vertex, and work is split by the tools, so
		 * neither changes the image a scene converges to. */
		if ((e = sx_get_int(ld, &pl, "glossySamples", 32, 0, 1 << 20, &v))
		    != PM_OK ||
		    (e = sx_get_int(ld, &pl, "granularity", 0, 0, INT_MAX, &v))
		    != PM_OK)
			return e;
		if ((e = sx_get_bool(ld, &pl, "finalGather", false,
		    &ph->final_gather)) != PM_OK)
			return e;
		if ((e = sx_get_int(ld, &pl, "finalGatherSamples", 64, 1, 1 << 20,
		    &v)) != PM_OK)
			return e;
		ph->final_gather_samples = (int)v;
	} else {
		return sx_unknown_plugin(ld, n, type, "path and photonmapper");
	}
	it->max_depth = (int)md;
	it->rr_depth = (int)rr;
	if ((e = sx_finish(ld, &pl)) != PM_OK)
		return e;
	return sx_no_objects(ld, &pl);
}
