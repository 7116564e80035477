/*
 * integrator.c: <integrator>: the path tracer's or the photon mapper's
 * parameters, and the Mitsuba 3 integrators that mean one of them here:
 * volpath and volpathmis (path tracing, through media where the scene has
 * them: integrator_volume.c), direct
 * (path tracing to depth 2: light seen directly or after one bounce, with
 * light and BSDF sampling, as Mitsuba's direct integrator computes it)
 * the particle tracer ptracer, and the moment wrapper (its nested
 * integrator, whose name the scene records for the moments' channels).
 */
#include "private.h"

static enum pm_err load_type(struct ld *ld, struct xnode *n, int depth);

/* <integrator type="moment">: exactly one nested integrator, loaded in
 * its place. */
static enum pm_err
load_moment(struct ld *ld, struct xnode *n, struct plist *pl, int depth)
{
	const char *name;
	enum pm_err e;

	if ((e = sx_finish(ld, pl)) != PM_OK)
		return e;
	if (pl->nobj != 1 || strcmp(pl->obj[0]->tag, "integrator") != 0)
		return sx_fail(ld, n, PM_ERR_UNSUPPORTED, "%s: pm renders one "
		    "nested <integrator>, found %zu nested elements", pl->what,
		    pl->nobj);
	if (depth > 0)
		return sx_fail(ld, pl->obj[0], PM_ERR_UNSUPPORTED,
		    "%s: a moment integrator inside another", pl->what);
	name = sx_attr(pl->obj[0], "name");
	if (name == NULL)
		name = "_arg_0";
	if (name[0] == '\0' || strlen(name) >= sizeof(ld->s->integrator.
	    moment_name) - 3)
		return sx_fail(ld, pl->obj[0], PM_ERR_UNSUPPORTED, "%s: the "
		    "nested integrator's name must have 1 to %zu characters",
		    pl->what, sizeof(ld->s->integrator.moment_name) - 4);
	ld->s->integrator.moment = true;
	snprintf(ld->s->integrator.moment_name,
	    sizeof(ld->s->integrator.moment_name), "%s", name);
	if ((e = load_type(ld, pl->obj[0], depth + 1)) != PM_OK)
		return e;
	/* Mitsuba's moment wraps sampling integrators, which a particle
	 * tracer is not. */
	if (ld->s->integrator.type == PM_INTEGRATOR_PTRACER)
		return sx_fail(ld, pl->obj[0], PM_ERR_UNSUPPORTED, "%s: "
		    "moment cannot wrap ptracer, which splats from the "
		    "lights", pl->what);
	return PM_OK;
}

/* The path tracer's parameters, shared by path, volpath and volpathmis. */
static enum pm_err
path_params(struct ld *ld, struct plist *pl, long *md, long *rr)
{
	enum pm_err e;

	if ((e = sx_get_int(ld, pl, "max_depth", -1, -1, INT_MAX, md))
	    != PM_OK ||
	    (e = sx_get_int(ld, pl, "rr_depth", 5, 1, INT_MAX, rr))
	    != PM_OK)
		return e;
	return sx_get_bool(ld, pl, "hide_emitters", false,
	    &ld->s->integrator.hide_emitters);
}

enum pm_err
sx_load_integrator(struct ld *ld, struct xnode *n)
{
	if (ld->integrator != NULL)
		return sx_fail(ld, n, PM_ERR_UNSUPPORTED, "more than one "
		    "<integrator> (the first is at %s:%d)",
		    ld->integrator->file, ld->integrator->line);
	ld->integrator = n;
	return load_type(ld, n, 0);
}

static enum pm_err
load_type(struct ld *ld, struct xnode *n, int depth)
{
	struct pm_integrator *it = &ld->s->integrator;
	struct pm_photon_params *ph = &it->photon;
	struct plist pl;
	const char *type;
	long md, rr, v, shading;
	double r;
	enum pm_err e;

	if ((e = sx_object_type(ld, n, &type)) != PM_OK ||
	    (e = sx_collect(ld, n, "integrator", type, &pl)) != PM_OK)
		return e;
	if (strcmp(type, "moment") == 0)
		return load_moment(ld, n, &pl, depth);
	if (strcmp(type, "path") == 0 || strcmp(type, "volpath") == 0 ||
	    strcmp(type, "volpathmis") == 0) {
		it->type = PM_INTEGRATOR_PATH;
		if ((e = path_params(ld, &pl, &md, &rr)) != PM_OK)
			return e;
	} else if (strcmp(type, "ptracer") == 0) {
		it->type = PM_INTEGRATOR_PTRACER;
		if ((e = path_params(ld, &pl, &md, &rr)) != PM_OK ||
		    (e = sx_get_int(ld, &pl, "samples_per_pass", -1, -1,
		    INT_MAX, &it->samples_per_pass)) != PM_OK)
			return e;
		if (it->samples_per_pass == 0)
			return sx_fail(ld, n, PM_ERR_INVALID, "%s: "
			    "samples_per_pass must be -1 or positive",
			    pl.what);
	} else if (strcmp(type, "direct") == 0) {
		/* The sample counts change the noise, not the image. */
		it->type = PM_INTEGRATOR_PATH;
		md = 2;
		rr = 5;
		if ((e = sx_get_int(ld, &pl, "shading_samples", 1, 1, 1 << 20,
		    &shading)) != PM_OK ||
		    (e = sx_get_int(ld, &pl, "emitter_samples", shading, 0,
		    1 << 20, &v)) != PM_OK ||
		    (e = sx_get_int(ld, &pl, "bsdf_samples", shading, 0, 1 << 20,
		    &v)) != PM_OK ||
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
		return sx_unknown_plugin(ld, n, type, "path, volpath, volpathmis, "
		    "direct, ptracer, photonmapper and moment");
	}
	it->max_depth = (int)md;
	it->rr_depth = (int)rr;
	if ((e = sx_finish(ld, &pl)) != PM_OK)
		return e;
	return sx_no_objects(ld, &pl);
}
