/*
 * mesh.c: indexed triangle meshes: clean-up after loading, smooth vertex
 * normals, transforms, and the shapes pm builds as meshes.
 *
 * The generators follow Mitsuba 3's conventions (rectangle [-1,1]^2 at
 * z = 0 facing +z, cube [-1,1]^3, unit disk facing +z) so that a Mitsuba
 * scene naming those shapes yields the same surfaces.  The disk's rim is
 * pushed outwards so that the polygon's area is exactly pi, which keeps
 * emitted power and photon flux the same as Mitsuba's analytic disk.
 */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "mesh.h"

/* Frees what m owns and zeroes it; a zeroed mesh is fine. */
void
pm_mesh_free(struct pm_mesh *m)
{
	if (m == NULL)
		return;
	free(m->pos);
	free(m->nrm);
	free(m->uv);
	free(m->idx);
	free(m->vcolor);
	free(m->fcolor);
	memset(m, 0, sizeof(*m));
}

/* Allocates the arrays of a mesh of nv vertices and nt triangles. */
static enum pm_err
mesh_alloc(struct pm_mesh *m, uint32_t nv, uint32_t nt, int with_nrm,
    int with_uv, struct pm_error *err)
{
	memset(m, 0, sizeof(*m));
	m->pos = malloc((size_t)nv * 3 * sizeof(float));
	m->idx = malloc((size_t)nt * 3 * sizeof(uint32_t));
	if (with_nrm)
		m->nrm = malloc((size_t)nv * 3 * sizeof(float));
	if (with_uv)
		m->uv = malloc((size_t)nv * 2 * sizeof(float));
	if (m->pos == NULL || m->idx == NULL || (with_nrm && m->nrm == NULL) ||
	    (with_uv && m->uv == NULL)) {
		pm_mesh_free(m);
		return pm_fail(err, PM_ERR_NOMEM,
		    "mesh: out of memory for %u vertices and %u triangles",
		    nv, nt);
	}
	m->nverts = nv;
	m->ntris = nt;
	return PM_OK;
}

static void
set_vertex(struct pm_mesh *m, uint32_t i, struct pm_vec3 p, struct pm_vec3 n,
    float u, float v)
{
	m->pos[3 * i] = p.x;
	m->pos[3 * i + 1] = p.y;
	m->pos[3 * i + 2] = p.z;
	if (m->nrm != NULL) {
		m->nrm[3 * i] = n.x;
		m->nrm[3 * i + 1] = n.y;
		m->nrm[3 * i + 2] = n.z;
	}
	if (m->uv != NULL) {
		m->uv[2 * i] = u;
		m->uv[2 * i + 1] = v;
	}
}

static void
set_tri(struct pm_mesh *m, uint32_t t, uint32_t a, uint32_t b, uint32_t c)
{
	m->idx[3 * t] = a;
	m->idx[3 * t + 1] = b;
	m->idx[3 * t + 2] = c;
}

/* Cross product of the edges in double: the face normal times twice the area. */
static void
face_cross(const struct pm_mesh *m, const uint32_t *t, double c[3])
{
	const float *p0 = m->pos + 3 * (size_t)t[0];
	const float *p1 = m->pos + 3 * (size_t)t[1];
	const float *p2 = m->pos + 3 * (size_t)t[2];
	double e1[3], e2[3];
	int k;

	for (k = 0; k < 3; k++) {
		e1[k] = (double)p1[k] - p0[k];
		e2[k] = (double)p2[k] - p0[k];
	}
	c[0] = e1[1] * e2[2] - e1[2] * e2[1];
	c[1] = e1[2] * e2[0] - e1[0] * e2[2];
	c[2] = e1[0] * e2[1] - e1[1] * e2[0];
}

/*
 * Checks every index, then compacts away triangles that are degenerate or
 * touch a non-finite vertex.  Indices are checked first so that a bad
 * file is rejected rather than silently shortened.
 */
enum pm_err
pm_mesh_validate(struct pm_mesh *m, uint32_t *dropped, struct pm_error *err)
{
	uint32_t t, k, kept = 0;

	if (dropped != NULL)
		*dropped = 0;
	if (m->ntris > 0 && (m->idx == NULL || m->pos == NULL))
		return pm_fail(err, PM_ERR_INVALID,
		    "mesh: %u triangles but no index or position array",
		    m->ntris);
	for (t = 0; t < m->ntris; t++)
		for (k = 0; k < 3; k++)
			if (m->idx[3 * t + k] >= m->nverts)
				return pm_fail(err, PM_ERR_INVALID,
				    "mesh: triangle %u: vertex index %u out of "
				    "range (expected less than %u)", t,
				    m->idx[3 * t + k], m->nverts);

	for (t = 0; t < m->ntris; t++) {
		const uint32_t *tri = m->idx + 3 * t;
		double c[3];
		int ok = 1;

		for (k = 0; k < 3 && ok; k++) {
			const float *p = m->pos + 3 * (size_t)tri[k];
			ok = isfinite(p[0]) && isfinite(p[1]) && isfinite(p[2]);
		}
		if (ok) {
			face_cross(m, tri, c);
			ok = c[0] != 0.0 || c[1] != 0.0 || c[2] != 0.0;
		}
		if (!ok)
			continue;
		if (kept != t) {
			memmove(m->idx + 3 * kept, tri, 3 * sizeof(uint32_t));
			if (m->fcolor != NULL)
				memmove(m->fcolor + 3 * kept, m->fcolor + 3 * t,
				    3 * sizeof(float));
		}
		kept++;
	}
	if (dropped != NULL)
		*dropped = m->ntris - kept;
	m->ntris = kept;
	return PM_OK;
}

/*
 * Angle-weighted vertex normals (Thuermer and Wuethrich 1998): each face
 * adds its unit normal times the angle it spans at the vertex, so that the
 * result does not depend on how a surface happens to be triangulated.
 */
enum pm_err
pm_mesh_compute_normals(struct pm_mesh *m, struct pm_error *err)
{
	double *acc;
	float *nrm;
	uint32_t t, v;
	int k;

	if (m->nverts == 0)
		return PM_OK;
	acc = calloc((size_t)m->nverts * 3, sizeof(double));
	nrm = m->nrm != NULL ? m->nrm :
	    malloc((size_t)m->nverts * 3 * sizeof(float));
	if (acc == NULL || nrm == NULL) {
		free(acc);
		if (nrm != m->nrm)
			free(nrm);
		return pm_fail(err, PM_ERR_NOMEM,
		    "mesh: out of memory computing normals for %u vertices",
		    m->nverts);
	}

	for (t = 0; t < m->ntris; t++) {
		const uint32_t *tri = m->idx + 3 * t;
		double c[3], len, angle[3];

		if (tri[0] >= m->nverts || tri[1] >= m->nverts ||
		    tri[2] >= m->nverts) {
			free(acc);
			if (nrm != m->nrm)
				free(nrm);
			return pm_fail(err, PM_ERR_INVALID,
			    "mesh: triangle %u: vertex index out of range", t);
		}
		face_cross(m, tri, c);
		len = sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
		if (!(len > 0.0) || !isfinite(len))
			continue;
		/*
		 * The cross product of a corner's two edges is the face's
		 * at every corner, so a corner's angle is atan2(len, the
		 * edges' dot product), stable for small and large angles
		 * alike; the three sum to pi, which saves the last atan2.
		 */
		for (k = 0; k < 3; k++) {
			const float *p = m->pos + 3 * (size_t)tri[k];
			const float *q = m->pos + 3 * (size_t)tri[(k + 1) % 3];
			const float *r = m->pos + 3 * (size_t)tri[(k + 2) % 3];
			double d = 0.0;
			int j;

			if (k < 2) {
				for (j = 0; j < 3; j++)
					d += ((double)q[j] - p[j]) *
					    ((double)r[j] - p[j]);
				angle[k] = atan2(len, d);
			} else {
				angle[2] = fmax(M_PI - angle[0] - angle[1], 0.0);
			}
			for (j = 0; j < 3; j++)
				acc[3 * (size_t)tri[k] + j] += c[j] *
				    (angle[k] / len);
		}
	}

	/* Zero marks a vertex still waiting for a normal. */
	for (v = 0; v < m->nverts; v++) {
		double *a = acc + 3 * (size_t)v;
		double len = sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);

		for (k = 0; k < 3; k++)
			nrm[3 * (size_t)v + k] = len > 1e-12 && isfinite(len) ?
			    (float)(a[k] / len) : 0.0f;
	}
	/* Faces that cancel out: take the first non-degenerate face's normal. */
	for (t = 0; t < m->ntris; t++) {
		const uint32_t *tri = m->idx + 3 * t;
		double c[3], len;

		face_cross(m, tri, c);
		len = sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
		if (!(len > 0.0) || !isfinite(len))
			continue;
		for (k = 0; k < 3; k++) {
			float *n = nrm + 3 * (size_t)tri[k];
			if (n[0] == 0.0f && n[1] == 0.0f && n[2] == 0.0f) {
				n[0] = (float)(c[0] / len);
				n[1] = (float)(c[1] / len);
				n[2] = (float)(c[2] / len);
			}
		}
	}
	/* Vertices no usable face touches still need a unit normal. */
	for (v = 0; v < m->nverts; v++) {
		float *n = nrm + 3 * (size_t)v;
		if (n[0] == 0.0f && n[1] == 0.0f && n[2] == 0.0f)
			n[2] = 1.0f;
	}
	free(acc);
	m->nrm = nrm;
	return PM_OK;
}

/*
 * Moves the mesh by M.  If M is singular the normals cannot follow it,
 * so they are dropped and the mesh falls back to flat shading.
 */
void
pm_mesh_transform(struct pm_mesh *m, const struct pm_mat4 *M)
{
	struct pm_mat4 inv;
	double det;
	uint32_t i;
	const float (*a)[4] = M->m;

	for (i = 0; i < m->nverts; i++) {
		struct pm_vec3 p = pm_xform_point(M, pm_mesh_vertex(m, i));
		m->pos[3 * i] = p.x;
		m->pos[3 * i + 1] = p.y;
		m->pos[3 * i + 2] = p.z;
	}
	if (m->nrm != NULL) {
		if (pm_mat4_inverse(*M, &inv)) {
			for (i = 0; i < m->nverts; i++) {
				float *np = m->nrm + 3 * (size_t)i;
				struct pm_vec3 n = pm_xform_normal(&inv,
				    pm_v3(np[0], np[1], np[2]));
				n = pm_normalize(n);
				np[0] = n.x;
				np[1] = n.y;
				np[2] = n.z;
			}
		} else {
			free(m->nrm);
			m->nrm = NULL;
		}
	}

	/* A mirror turns the edge cross product against the normals. */
	det = (double)a[0][0] * ((double)a[1][1] * a[2][2] - (double)a[1][2] * a[2][1]) -
	    (double)a[0][1] * ((double)a[1][0] * a[2][2] - (double)a[1][2] * a[2][0]) +
	    (double)a[0][2] * ((double)a[1][0] * a[2][1] - (double)a[1][1] * a[2][0]);
	if (det < 0.0)
		for (i = 0; i < m->ntris; i++) {
			uint32_t t = m->idx[3 * i + 1];
			m->idx[3 * i + 1] = m->idx[3 * i + 2];
			m->idx[3 * i + 2] = t;
		}
}

/* Turns the mesh inside out: the other side becomes the front. */
void
pm_mesh_flip(struct pm_mesh *m)
{
	uint32_t i;

	for (i = 0; i < m->ntris; i++) {
		uint32_t t = m->idx[3 * i + 1];
		m->idx[3 * i + 1] = m->idx[3 * i + 2];
		m->idx[3 * i + 2] = t;
	}
	if (m->nrm != NULL)
		for (i = 0; i < 3 * m->nverts; i++)
			m->nrm[i] = -m->nrm[i];
}

/* Rectangle [-1,1]^2 at z = 0 facing +z, uv = ((x+1)/2, (y+1)/2). */
enum pm_err
pm_mesh_rectangle(struct pm_mesh *m, struct pm_error *err)
{
	struct pm_vec3 n = pm_v3(0.0f, 0.0f, 1.0f);
	enum pm_err e;

	if ((e = mesh_alloc(m, 4, 2, 1, 1, err)) != PM_OK)
		return e;
	set_vertex(m, 0, pm_v3(-1.0f, -1.0f, 0.0f), n, 0.0f, 0.0f);
	set_vertex(m, 1, pm_v3(1.0f, -1.0f, 0.0f), n, 1.0f, 0.0f);
	set_vertex(m, 2, pm_v3(1.0f, 1.0f, 0.0f), n, 1.0f, 1.0f);
	set_vertex(m, 3, pm_v3(-1.0f, 1.0f, 0.0f), n, 0.0f, 1.0f);
	set_tri(m, 0, 0, 1, 2);
	set_tri(m, 1, 2, 3, 0);
	return PM_OK;
}

/*
 * Cube [-1,1]^3: four vertices per face so that each face keeps its own
 * flat normal and maps onto [0,1]^2 in uv, oriented on each face as
 * Mitsuba 3's cube is (its vertex table, read back through Mitsuba's
 * Python API): u = (su p[iu] + 1) / 2, v = (sv p[iv] + 1) / 2 with, per
 * face -x, +x, -y, +y, -z, +z, the axes and signs below.
 */
static const struct {
	int iu, su, iv, sv;
} cube_uv[6] = {
	{1, 1, 2, 1}, {1, 1, 2, -1},	/* x faces: listed -, + */
	{2, 1, 0, 1}, {0, -1, 2, -1},	/* y */
	{1, -1, 0, 1}, {1, 1, 0, 1},	/* z */
};

enum pm_err
pm_mesh_cube(struct pm_mesh *m, struct pm_error *err)
{
	static const float corner[4][2] = {
		{-1.0f, -1.0f}, {1.0f, -1.0f}, {1.0f, 1.0f}, {-1.0f, 1.0f}
	};
	enum pm_err e;
	int face, c;

	if ((e = mesh_alloc(m, 24, 12, 1, 1, err)) != PM_OK)
		return e;
	for (face = 0; face < 6; face++) {
		int axis = face / 2;
		float sign = face % 2 == 0 ? 1.0f : -1.0f;
		float n[3] = {0.0f, 0.0f, 0.0f};
		uint32_t base = (uint32_t)face * 4;

		n[axis] = sign;
		for (c = 0; c < 4; c++) {
			/*
			 * (s, t) run along the two other axes in cyclic
			 * order, so s x t = +axis; mirroring s on the
			 * negative faces keeps the corners counter-clockwise
			 * seen from outside.
			 */
			float p[3];
			float s = corner[c][0] * sign, t = corner[c][1];

			p[axis] = sign;
			p[(axis + 1) % 3] = s;
			p[(axis + 2) % 3] = t;
			int f = 2 * axis + (sign > 0.0f);

			set_vertex(m, base + (uint32_t)c, pm_v3(p[0], p[1], p[2]),
			    pm_v3(n[0], n[1], n[2]),
			    ((float)cube_uv[f].su * p[cube_uv[f].iu] + 1.0f) * 0.5f,
			    ((float)cube_uv[f].sv * p[cube_uv[f].iv] + 1.0f) * 0.5f);
		}
		set_tri(m, 2 * (uint32_t)face, base, base + 1, base + 2);
		set_tri(m, 2 * (uint32_t)face + 1, base + 2, base + 3, base);
	}
	return PM_OK;
}

/*
 * Unit disk as a fan.  A regular n-gon of circumradius r has area
 * n r^2 sin(2 pi / n) / 2; choosing r^2 = 2 pi / (n sin(2 pi / n)) makes
 * that pi.  uv is Mitsuba's (radius, angle / 2 pi); each wedge has its own
 * centre vertex carrying the wedge's middle angle, and the seam vertex is
 * doubled, so that v does not wrap across a triangle.
 */
enum pm_err
pm_mesh_disk(struct pm_mesh *m, uint32_t segments, struct pm_error *err)
{
	struct pm_vec3 n = pm_v3(0.0f, 0.0f, 1.0f);
	double r, step;
	enum pm_err e;
	uint32_t i;

	if (segments < 3 || segments > (1u << 24))
		return pm_fail(err, PM_ERR_INVALID,
		    "disk: %u segments (expected 3 to %u)", segments, 1u << 24);
	step = 2.0 * M_PI / segments;
	r = sqrt(2.0 * M_PI / (segments * sin(step)));
	if ((e = mesh_alloc(m, 2 * segments + 1, segments, 1, 1, err)) != PM_OK)
		return e;
	for (i = 0; i <= segments; i++) {
		double phi = i == segments ? 0.0 : i * step;
		set_vertex(m, segments + i,
		    pm_v3((float)(r * cos(phi)), (float)(r * sin(phi)), 0.0f),
		    n, 1.0f, (float)((double)i / segments));
	}
	for (i = 0; i < segments; i++) {
		set_vertex(m, i, pm_v3(0.0f, 0.0f, 0.0f), n, 0.0f,
		    (float)((i + 0.5) / segments));
		set_tri(m, i, i, segments + i, segments + i + 1);
	}
	return PM_OK;
}

/*
 * Unit sphere with one vertex per pole and rings - 1 rings of `segments`
 * vertices, all shared (no seam), so that computed vertex normals see
 * every face around each vertex.  Normals are the exact sphere normals;
 * there is no uv, since a shared seam vertex cannot carry two values.
 */
enum pm_err
pm_mesh_uv_sphere(struct pm_mesh *m, uint32_t rings, uint32_t segments,
    struct pm_error *err)
{
	uint32_t nv, nt, i, j, t = 0, south;
	enum pm_err e;

	if (rings < 2 || segments < 3 || rings > 65536 || segments > 65536)
		return pm_fail(err, PM_ERR_INVALID,
		    "uv sphere: %u rings and %u segments (expected at least 2 "
		    "and 3, at most 65536)", rings, segments);
	nv = (rings - 1) * segments + 2;
	nt = 2 * segments * (rings - 1);
	if ((e = mesh_alloc(m, nv, nt, 1, 0, err)) != PM_OK)
		return e;

	set_vertex(m, 0, pm_v3(0.0f, 0.0f, 1.0f), pm_v3(0.0f, 0.0f, 1.0f), 0, 0);
	south = nv - 1;
	set_vertex(m, south, pm_v3(0.0f, 0.0f, -1.0f), pm_v3(0.0f, 0.0f, -1.0f),
	    0, 0);
	for (i = 1; i < rings; i++) {
		double theta = M_PI * i / rings;
		for (j = 0; j < segments; j++) {
			double phi = 2.0 * M_PI * j / segments;
			struct pm_vec3 p = pm_v3((float)(sin(theta) * cos(phi)),
			    (float)(sin(theta) * sin(phi)), (float)cos(theta));
			set_vertex(m, 1 + (i - 1) * segments + j, p, p, 0, 0);
		}
	}
	/* Ring i (1-based) vertex j lives at 1 + (i - 1) * segments + j. */
	for (j = 0; j < segments; j++) {
		uint32_t j1 = (j + 1) % segments;
		set_tri(m, t++, 0, 1 + j, 1 + j1);
		set_tri(m, t++, south, 1 + (rings - 2) * segments + j1,
		    1 + (rings - 2) * segments + j);
	}
	for (i = 1; i + 1 < rings; i++) {
		uint32_t a = 1 + (i - 1) * segments, b = a + segments;
		for (j = 0; j < segments; j++) {
			uint32_t j1 = (j + 1) % segments;
			set_tri(m, t++, a + j, b + j, b + j1);
			set_tri(m, t++, a + j, b + j1, a + j1);
		}
	}
	return PM_OK;
}

/* Sum of the triangle areas, in double. */
double
pm_mesh_area(const struct pm_mesh *m)
{
	double sum = 0.0, c[3];
	uint32_t t;

	for (t = 0; t < m->ntris; t++) {
		face_cross(m, m->idx + 3 * t, c);
		sum += 0.5 * sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
	}
	return sum;
}

/*
 * Mitsuba's cylinder, open at both ends: x^2 + y^2 = 1 for z in [0, 1], as
 * `segments` quads.  The rim's radius is pushed out so that the prism's
 * area equals the cylinder's 2 pi (segments sin(pi / segments) r = pi r),
 * as for the disk; normals are the exact radial ones, and interpolating
 * two of them across a facet points exactly away from the axis at the hit.
 * uv as Mitsuba's: u = phi / (2 pi), v = z, with a seam of doubled vertices.
 */
enum pm_err
pm_mesh_cylinder(struct pm_mesh *m, uint32_t segments, struct pm_error *err)
{
	double r, phi;
	enum pm_err e;
	uint32_t i;

	if (segments < 3 || segments > (1u << 24))
		return pm_fail(err, PM_ERR_INVALID,
		    "cylinder: %u segments (expected 3 to %u)", segments,
		    1u << 24);
	r = M_PI / (segments * sin(M_PI / segments));
	if ((e = mesh_alloc(m, 2 * (segments + 1), 2 * segments, 1, 1, err))
	    != PM_OK)
		return e;
	for (i = 0; i <= segments; i++) {
		struct pm_vec3 n;
		float u = (float)((double)i / segments);

		phi = i == segments ? 0.0 : 2.0 * M_PI * i / segments;
		n = pm_v3((float)cos(phi), (float)sin(phi), 0.0f);
		set_vertex(m, 2 * i, pm_v3((float)(r * cos(phi)),
		    (float)(r * sin(phi)), 0.0f), n, u, 0.0f);
		set_vertex(m, 2 * i + 1, pm_v3((float)(r * cos(phi)),
		    (float)(r * sin(phi)), 1.0f), n, u, 1.0f);
	}
	/* Counter-clockwise seen from outside. */
	for (i = 0; i < segments; i++) {
		set_tri(m, 2 * i, 2 * i, 2 * i + 2, 2 * i + 3);
		set_tri(m, 2 * i + 1, 2 * i, 2 * i + 3, 2 * i + 1);
	}
	return PM_OK;
}
