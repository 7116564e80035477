/*
 * shape.c: <shape> elements: meshes from OBJ, PLY and Mitsuba's serialized
 * files and the analytic shapes, baked into world space with their BSDF and
 * emitter.
 */
#include "private.h"

enum pm_err
sx_wrap(struct ld *ld, const struct xnode *n, const char *what, enum pm_err e)
{
	char msg[sizeof(ld->err->msg)];

	snprintf(msg, sizeof(msg), "%s", ld->err->msg);
	return sx_fail(ld, n, e, "%s: %s", what, msg);
}

/* Column lengths of M's linear part must agree and be orthogonal. */
bool
sx_similarity_scale(const struct pm_mat4 *M, float *scale)
{
	struct pm_vec3 c[3];
	float l[3];
	int i;

	for (i = 0; i < 3; i++) {
		c[i] = pm_v3(M->m[0][i], M->m[1][i], M->m[2][i]);
		l[i] = pm_length(c[i]);
	}
	if (!(l[0] > 0.0f))
		return false;
	for (i = 1; i < 3; i++)
		if (fabsf(l[i] - l[0]) > 1e-4f * l[0])
			return false;
	if (fabsf(pm_dot(c[0], c[1])) > 1e-4f * l[0] * l[0] ||
	    fabsf(pm_dot(c[0], c[2])) > 1e-4f * l[0] * l[0] ||
	    fabsf(pm_dot(c[1], c[2])) > 1e-4f * l[0] * l[0])
		return false;
	*scale = l[0];
	return true;
}

/* Validation, normals, world space and orientation, in Mitsuba's order. */
static enum pm_err
finish_mesh(struct ld *ld, const struct xnode *n, const char *what,
    struct pm_mesh *m, const struct pm_mat4 *M, bool face_normals, bool flip)
{
	struct pm_mat4 inv;
	uint32_t dropped = 0;
	enum pm_err e;

	if (!pm_mat4_inverse(*M, &inv))
		return sx_fail(ld, n, PM_ERR_INVALID, "%s: to_world is singular",
		    what);
	if ((e = pm_mesh_validate(m, &dropped, ld->err)) != PM_OK)
		return sx_wrap(ld, n, what, e);
	ld->s->dropped_triangles += dropped;
	if (m->ntris == 0)
		return sx_fail(ld, n, PM_ERR_INVALID, "%s: no triangles%s", what,
		    dropped ? " left after dropping degenerate ones" : "");
	if (face_normals) {
		free(m->nrm);
		m->nrm = NULL;
	}
	pm_mesh_transform(m, M);
	/* Mitsuba 3 computes smooth normals when a file has none. */
	if (!face_normals && m->nrm == NULL &&
	    (e = pm_mesh_compute_normals(m, ld->err)) != PM_OK)
		return sx_wrap(ld, n, what, e);
	if (flip)
		pm_mesh_flip(m);
	return PM_OK;
}

static float
comp(struct pm_vec3 v, int i)
{
	return i == 0 ? v.x : (i == 1 ? v.y : v.z);
}

/*
 * Mitsuba's cylinder: to_world * translate(p0) * frame(p1 - p0) *
 * scale(radius, radius, |p1 - p0|) on the unit cylinder.  Like Mitsuba,
 * the result must scale x and y alike without shear (Mitsuba warns and
 * renders something else; pm refuses), and a negative radius flips the
 * normals.
 */
static enum pm_err
cylinder_frame(struct ld *ld, struct plist *pl, struct pm_vec3 p0,
    struct pm_vec3 p1, double *radius, struct pm_mat4 *M, bool *flip)
{
	struct pm_vec3 d = pm_sub(p1, p0), c[3];
	struct pm_frame fr;
	struct pm_mat4 L = pm_mat4_identity();
	float len = pm_length(d), r, lx, ly;
	int i;

	if (!(len > 0.0f))
		return sx_fail(ld, pl->owner, PM_ERR_INVALID, "%s: p0 and p1 "
		    "must differ", pl->what);
	if (!(*radius != 0.0))
		return sx_fail(ld, sx_prop_find(pl, "radius")->n,
		    PM_ERR_INVALID, "%s: radius must not be 0", pl->what);
	if (*radius < 0.0) {
		*radius = -*radius;
		*flip = !*flip;
	}
	r = (float)*radius;
	fr = pm_frame_from_normal(pm_scale(d, 1.0f / len));
	for (i = 0; i < 3; i++) {
		L.m[i][0] = comp(fr.s, i) * r;
		L.m[i][1] = comp(fr.t, i) * r;
		L.m[i][2] = comp(fr.n, i) * len;
		L.m[i][3] = comp(p0, i);
	}
	*M = pm_mat4_mul(*M, L);
	for (i = 0; i < 3; i++)
		c[i] = pm_v3(M->m[0][i], M->m[1][i], M->m[2][i]);
	lx = pm_length(c[0]);
	ly = pm_length(c[1]);
	if (!(lx > 0.0f) || fabsf(lx - ly) > 1e-4f * lx ||
	    fabsf(pm_dot(c[0], c[1])) > 1e-4f * lx * ly ||
	    fabsf(pm_dot(c[0], c[2])) > 1e-4f * lx * pm_length(c[2]) ||
	    fabsf(pm_dot(c[1], c[2])) > 1e-4f * ly * pm_length(c[2]))
		return sx_fail(ld, pl->owner, PM_ERR_UNSUPPORTED, "%s: to_world "
		    "must keep the cross-section round (no shear, the same "
		    "scale across the axis), as Mitsuba's cylinder needs",
		    pl->what);
	return PM_OK;
}

/* The BSDF, area light and media of a shape, from nested elements or
 * refs. */
static enum pm_err
shape_objects(struct ld *ld, struct plist *pl, int *bsdf, struct xnode **em,
    int *interior, int *exterior)
{
	struct xnode *o, *t, *bnode = NULL;
	size_t i;
	enum pm_err e;

	*em = NULL;
	for (i = 0; i < pl->nobj; i++) {
		o = pl->obj[i];
		t = o;
		if (strcmp(o->tag, "ref") == 0 &&
		    (e = sx_deref(ld, o, &t)) != PM_OK)
			return e;
		if (strcmp(t->tag, "bsdf") == 0) {
			if (bnode != NULL)
				return sx_fail(ld, o, PM_ERR_INVALID, "%s has more "
				    "than one BSDF (first at line %d)",
				    pl->what, bnode->line);
			bnode = o;
			if ((e = sx_bsdf_index(ld, t, bsdf)) != PM_OK)
				return e;
		} else if (strcmp(t->tag, "emitter") == 0) {
			if (*em != NULL)
				return sx_fail(ld, o, PM_ERR_INVALID, "%s has more "
				    "than one emitter", pl->what);
			*em = t;
		} else if (strcmp(t->tag, "medium") == 0) {
			if ((e = sx_shape_medium(ld, pl, o, t, interior,
			    exterior)) != PM_OK)
				return e;
		} else if (o != t) {
			return sx_fail(ld, o, PM_ERR_INVALID, "%s: <ref id=\"%s\"> "
			    "names a <%s>, expected a <bsdf>, an <emitter> or a "
			    "<medium>",
			    pl->what, sx_attr(o, "id"), t->tag);
		} else {
			return sx_fail(ld, o, PM_ERR_INVALID, "unexpected <%s> "
			    "inside %s", o->tag, pl->what);
		}
	}
	/* Mitsuba's default BSDF is diffuse with reflectance 0.5, but 0 on
	 * a shape that emits (Shape's constructor): an emitter given no
	 * BSDF reflects nothing. */
	if (bnode == NULL && *em != NULL) {
		if ((*bsdf = pm_scene_add_bsdf(ld->s)) < 0)
			return sx_nomem(ld);
		ld->s->bsdfs[*bsdf].type = PM_BSDF_DIFFUSE;
		ld->s->bsdfs[*bsdf].diffuse = pm_rgb1(0.0f);
	} else if (bnode == NULL && (*bsdf = sx_default_bsdf(ld)) < 0) {
		return sx_nomem(ld);
	}
	return PM_OK;
}

/* Mitsuba's shapegroup holds shapes only, and no groups or instances. */
static enum pm_err
check_group(struct ld *ld, struct xnode *g)
{
	struct xnode *k;
	const char *type;
	enum pm_err e;

	for (k = g->kids; k != NULL; k = k->next) {
		if (strcmp(k->tag, "shape") != 0)
			return sx_fail(ld, k, PM_ERR_INVALID, "shape "
			    "\"shapegroup\" holds only <shape> elements, found "
			    "<%s>", k->tag);
		if ((e = sx_object_type(ld, k, &type)) != PM_OK)
			return e;
		if (strcmp(type, "shapegroup") == 0 ||
		    strcmp(type, "instance") == 0)
			return sx_fail(ld, k, PM_ERR_INVALID, "a shapegroup "
			    "cannot hold a shape \"%s\" (nor can Mitsuba's)",
			    type);
	}
	return PM_OK;
}

/*
 * An instance of a shapegroup: the group's shapes are built once more
 * each, with the instance's to_world after their own.  pm flattens
 * instances into world-space copies rather than using Embree's instancing:
 * every later stage (light sampling, photon shooting, normals, the scene's
 * hash) then sees plain meshes and spheres, at the cost of memory per copy.
 */
static enum pm_err
load_instance(struct ld *ld, struct xnode *n, struct plist *pl)
{
	struct pm_mat4 M;
	struct xnode *g, *k;
	const char *gtype;
	enum pm_err e;

	if ((e = sx_get_transform(ld, pl, "to_world", &M)) != PM_OK ||
	    (e = sx_finish(ld, pl)) != PM_OK)
		return e;
	if (pl->nobj != 1 || strcmp(pl->obj[0]->tag, "ref") != 0)
		return sx_fail(ld, pl->nobj > 0 ? pl->obj[pl->nobj - 1] : n,
		    PM_ERR_INVALID, "%s takes exactly one <ref> to a "
		    "shapegroup", pl->what);
	if ((e = sx_deref(ld, pl->obj[0], &g)) != PM_OK)
		return e;
	if (strcmp(g->tag, "shape") != 0 ||
	    sx_object_type(ld, g, &gtype) != PM_OK ||
	    strcmp(gtype, "shapegroup") != 0)
		return sx_fail(ld, pl->obj[0], PM_ERR_INVALID, "%s: <ref "
		    "id=\"%s\"> names a <%s>, expected a shape \"shapegroup\"",
		    pl->what, sx_attr(pl->obj[0], "id"), g->tag);
	if (g->busy || ld->instance_to_world != NULL)
		return sx_fail(ld, n, PM_ERR_INVALID, "%s: instances cannot "
		    "nest", pl->what);
	if ((e = check_group(ld, g)) != PM_OK)
		return e;
	g->busy = true;
	ld->instance_to_world = &M;
	for (k = g->kids; k != NULL; k = k->next)
		if ((e = sx_load_shape(ld, k, k->dir)) != PM_OK)
			break;
	ld->instance_to_world = NULL;
	g->busy = false;
	return e;
}

enum pm_err
sx_load_shape(struct ld *ld, struct xnode *n, const char *naming_dir)
{
	struct plist pl;
	struct pm_mesh mesh;
	struct pm_shape *sh;
	struct pm_mat4 M;
	struct pm_vec3 center;
	struct pm_rgb radiance;
	int tex;
	struct xnode *em;
	const char *type, *fname = NULL, *path, *id;
	double radius = 1.0;
	struct pm_vec3 p0, p1;
	bool face_normals = false, flip = false, flip_tc = true;
	bool is_file, is_obj, is_ser, file_face_normals = false;
	long shape_index = 0;
	float scale;
	int idx, bsdf = -1, li, interior = -1, exterior = -1;
	uint32_t v;
	enum pm_err e;

	memset(&mesh, 0, sizeof(mesh));
	if ((e = sx_object_type(ld, n, &type)) != PM_OK)
		return e;
	/* A group is drawn only through its instances. */
	if (strcmp(type, "shapegroup") == 0)
		return check_group(ld, n);
	if ((e = sx_collect(ld, n, "shape", type, &pl)) != PM_OK)
		return e;
	if (strcmp(type, "instance") == 0)
		return load_instance(ld, n, &pl);
	is_obj = strcmp(type, "obj") == 0;
	is_ser = strcmp(type, "serialized") == 0;
	is_file = is_obj || is_ser || strcmp(type, "ply") == 0;
	if (!is_file && strcmp(type, "sphere") != 0 &&
	    strcmp(type, "rectangle") != 0 && strcmp(type, "cube") != 0 &&
	    strcmp(type, "disk") != 0 && strcmp(type, "cylinder") != 0)
		return sx_unknown_plugin(ld, n, type, "obj, ply, serialized, "
		    "sphere, rectangle, cube, disk, cylinder, shapegroup and "
		    "instance");

	if ((e = sx_get_transform(ld, &pl, "to_world", &M)) != PM_OK ||
	    (e = sx_get_bool(ld, &pl, "flip_normals", false, &flip)) != PM_OK)
		return e;
	if (ld->instance_to_world != NULL)
		M = pm_mat4_mul(*ld->instance_to_world, M);
	if (is_file) {
		if (!sx_has(&pl, "filename"))
			return sx_missing(ld, &pl, "filename", "a <string>");
		if ((e = sx_get_string(ld, &pl, "filename", NULL, &fname))
		    != PM_OK ||
		    (e = sx_get_bool(ld, &pl, "face_normals", false,
		    &face_normals)) != PM_OK)
			return e;
		if (is_obj && (e = sx_get_bool(ld, &pl, "flip_tex_coords", true,
		    &flip_tc)) != PM_OK)
			return e;
		if (is_ser && (e = sx_get_int(ld, &pl, "shape_index", 0, 0,
		    LONG_MAX, &shape_index)) != PM_OK)
			return e;
	} else if (strcmp(type, "cylinder") == 0) {
		if ((e = sx_get_point(ld, &pl, "p0", pm_v3(0, 0, 0), &p0))
		    != PM_OK ||
		    (e = sx_get_point(ld, &pl, "p1", pm_v3(0, 0, 1), &p1))
		    != PM_OK ||
		    (e = sx_get_float(ld, &pl, "radius", 1.0, -3.4e38, 3.4e38,
		    &radius)) != PM_OK ||
		    (e = cylinder_frame(ld, &pl, p0, p1, &radius, &M, &flip))
		    != PM_OK)
			return e;
	} else if (strcmp(type, "sphere") == 0) {
		if ((e = sx_get_point(ld, &pl, "center", pm_v3(0, 0, 0), &center))
		    != PM_OK ||
		    (e = sx_get_float(ld, &pl, "radius", 1.0, 0.0, 3.4e38,
		    &radius)) != PM_OK)
			return e;
		if (!(radius > 0.0))
			return sx_fail(ld, sx_prop_find(&pl, "radius")->n,
			    PM_ERR_INVALID, "%s: radius must be positive",
			    pl.what);
	}
	if ((e = sx_finish(ld, &pl)) != PM_OK ||
	    (e = shape_objects(ld, &pl, &bsdf, &em, &interior, &exterior))
	    != PM_OK)
		return e;

	if (is_file) {
		if ((e = sx_resolve(ld, n, naming_dir, fname, &path)) != PM_OK)
			return e;
		if (is_ser) {
			e = pm_serialized_read(path, shape_index, &mesh,
			    &file_face_normals, ld->err);
			/* the file's flag means face_normals="true" */
			face_normals = face_normals || file_face_normals;
		} else {
			e = is_obj ? pm_obj_read(path, &mesh, ld->err) :
			    pm_ply_read(path, &mesh, ld->err);
		}
		if (e == PM_OK && is_obj && flip_tc && mesh.uv != NULL)
			for (v = 0; v < mesh.nverts; v++)
				mesh.uv[2 * v + 1] = 1.0f - mesh.uv[2 * v + 1];
	} else if (strcmp(type, "rectangle") == 0) {
		e = pm_mesh_rectangle(&mesh, ld->err);
	} else if (strcmp(type, "cube") == 0) {
		e = pm_mesh_cube(&mesh, ld->err);
	} else if (strcmp(type, "disk") == 0) {
		e = pm_mesh_disk(&mesh, DISK_SEGMENTS, ld->err);
	} else if (strcmp(type, "cylinder") == 0) {
		e = pm_mesh_cylinder(&mesh, CYLINDER_SEGMENTS, ld->err);
	}
	if (e != PM_OK) {
		pm_mesh_free(&mesh);
		return sx_wrap(ld, n, pl.what, e);
	}

	if ((idx = pm_scene_add_shape(ld->s)) < 0) {
		pm_mesh_free(&mesh);
		return sx_nomem(ld);
	}
	sh = &ld->s->shapes[idx];
	sh->mesh = mesh;	/* owned by the scene from here on */
	sh->bsdf = bsdf;
	sh->flip_normals = flip;
	sh->interior = interior + 1;	/* 0: none */
	sh->exterior = exterior + 1;
	id = sx_attr(n, "id");
	if (id != NULL)
		snprintf(sh->name, sizeof(sh->name), "%s", id);
	else
		snprintf(sh->name, sizeof(sh->name), "%s#%d", type, idx);
	if (strcmp(type, "sphere") == 0) {
		if (!sx_similarity_scale(&M, &scale))
			return sx_fail(ld, n, PM_ERR_UNSUPPORTED, "%s: to_world "
			    "must be a rotation, uniform scale and "
			    "translation", pl.what);
		sh->type = PM_SHAPE_SPHERE;
		sh->center = pm_xform_point(&M, center);
		sh->radius = (float)radius * scale;
		/* the object frame that uv is measured in */
		sh->axes.s = pm_v3(M.m[0][0], M.m[1][0], M.m[2][0]);
		sh->axes.t = pm_v3(M.m[0][1], M.m[1][1], M.m[2][1]);
		sh->axes.n = pm_v3(M.m[0][2], M.m[1][2], M.m[2][2]);
	} else {
		sh->type = PM_SHAPE_MESH;
		if ((e = finish_mesh(ld, n, pl.what, &sh->mesh, &M,
		    face_normals, flip)) != PM_OK)
			return e;
	}

	if (em != NULL) {
		if (ld->instance_to_world != NULL)
			return sx_fail(ld, n, PM_ERR_UNSUPPORTED, "%s: a shape "
			    "in a shapegroup cannot emit (Mitsuba does not "
			    "instance emitters either)", pl.what);
		if (em->inst >= 0)
			return sx_fail(ld, n, PM_ERR_INVALID, "%s: emitter at "
			    "line %d is already attached to shape %s", pl.what,
			    em->line, ld->s->shapes[em->inst].name);
		if ((e = sx_build_area(ld, em, &radiance, &tex)) != PM_OK)
			return e;
		if ((li = pm_scene_add_light(ld->s)) < 0)
			return sx_nomem(ld);
		ld->s->lights[li].type = PM_LIGHT_AREA;
		ld->s->lights[li].radiance = radiance;
		ld->s->lights[li].tex = tex;
		ld->s->lights[li].shape = idx;
		ld->s->shapes[idx].light = li;
		em->inst = idx;
	}
	return PM_OK;
}
