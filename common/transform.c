/*
 * transform.c: 4x4 matrices for placing shapes and cameras.
 *
 * The operations mirror Mitsuba 3's Transform4f so that a <transform>
 * element read from a Mitsuba scene puts things where Mitsuba puts them.
 * Matrices are row-major and act on column vectors (p' = M p); the scene
 * reader composes a <transform> block as M = Op * M, child by child.
 * Inversion works in double precision, since scene matrices can mix
 * millimetre translations with small rotations.
 */
#include <math.h>
#include <stdbool.h>

#include "transform.h"

/* The identity matrix. */
struct pm_mat4
pm_mat4_identity(void)
{
	struct pm_mat4 r = {{{0}}};
	int i;

	for (i = 0; i < 4; i++)
		r.m[i][i] = 1.0f;
	return r;
}

/* The product a * b (b acts first on a column vector). */
struct pm_mat4
pm_mat4_mul(struct pm_mat4 a, struct pm_mat4 b)
{
	struct pm_mat4 r;
	int i, j, k;

	for (i = 0; i < 4; i++)
		for (j = 0; j < 4; j++) {
			/* Sum in double: chains of transforms stay exact longer. */
			double s = 0.0;
			for (k = 0; k < 4; k++)
				s += (double)a.m[i][k] * b.m[k][j];
			r.m[i][j] = (float)s;
		}
	return r;
}

/* Translation by t. */
struct pm_mat4
pm_mat4_translate(struct pm_vec3 t)
{
	struct pm_mat4 r = pm_mat4_identity();

	r.m[0][3] = t.x;
	r.m[1][3] = t.y;
	r.m[2][3] = t.z;
	return r;
}

/* Scaling along the axes by s. */
struct pm_mat4
pm_mat4_scale(struct pm_vec3 s)
{
	struct pm_mat4 r = pm_mat4_identity();

	r.m[0][0] = s.x;
	r.m[1][1] = s.y;
	r.m[2][2] = s.z;
	return r;
}

/*
 * Right-handed rotation about a (normalised here) axis: Rodrigues' formula,
 * R = cos I + sin [a]x + (1 - cos) a a^T, the matrix Mitsuba builds.
 */
struct pm_mat4
pm_mat4_rotate(struct pm_vec3 axis, float angle_deg)
{
	struct pm_mat4 r = pm_mat4_identity();
	double len, x, y, z, s, c, t, rad;

	len = sqrt((double)axis.x * axis.x + (double)axis.y * axis.y +
	    (double)axis.z * axis.z);
	if (!(len > 0.0))
		return r;
	x = axis.x / len;
	y = axis.y / len;
	z = axis.z / len;
	rad = (double)angle_deg * (M_PI / 180.0);
	s = sin(rad);
	c = cos(rad);
	t = 1.0 - c;

	r.m[0][0] = (float)(x * x * t + c);
	r.m[0][1] = (float)(x * y * t - z * s);
	r.m[0][2] = (float)(x * z * t + y * s);
	r.m[1][0] = (float)(y * x * t + z * s);
	r.m[1][1] = (float)(y * y * t + c);
	r.m[1][2] = (float)(y * z * t - x * s);
	r.m[2][0] = (float)(z * x * t - y * s);
	r.m[2][1] = (float)(z * y * t + x * s);
	r.m[2][2] = (float)(z * z * t + c);
	return r;
}

/*
 * Camera-to-world (or object-to-world) matrix looking from origin at
 * target, as Mitsuba's look_at: columns left, new up, dir, origin.  When
 * up is parallel to the view direction Mitsuba would produce NaNs; we pick
 * any perpendicular instead so that a scene still loads.
 */
struct pm_mat4
pm_mat4_lookat(struct pm_vec3 origin, struct pm_vec3 target,
    struct pm_vec3 up)
{
	struct pm_mat4 r = pm_mat4_identity();
	struct pm_vec3 dir, left, nup;

	dir = pm_normalize(pm_sub(target, origin));
	left = pm_cross(up, dir);
	if (pm_length(left) > 0.0f)
		left = pm_normalize(left);
	else
		left = pm_frame_from_normal(dir).s;
	nup = pm_cross(dir, left);

	r.m[0][0] = left.x; r.m[0][1] = nup.x; r.m[0][2] = dir.x; r.m[0][3] = origin.x;
	r.m[1][0] = left.y; r.m[1][1] = nup.y; r.m[1][2] = dir.y; r.m[1][3] = origin.y;
	r.m[2][0] = left.z; r.m[2][1] = nup.z; r.m[2][2] = dir.z; r.m[2][3] = origin.z;
	return r;
}

/*
 * Inverts a general 4x4 matrix by Gauss-Jordan elimination with partial
 * pivoting in double.  Returns false (leaving *inv untouched) if a pivot
 * vanishes or the input is not finite.
 */
bool
pm_mat4_inverse(struct pm_mat4 a, struct pm_mat4 *inv)
{
	double w[4][8];
	int i, j, k, p;

	for (i = 0; i < 4; i++)
		for (j = 0; j < 4; j++) {
			if (!isfinite(a.m[i][j]))
				return false;
			w[i][j] = a.m[i][j];
			w[i][j + 4] = i == j ? 1.0 : 0.0;
		}

	for (k = 0; k < 4; k++) {
		double best = 0.0, piv;

		p = -1;
		for (i = k; i < 4; i++)
			if (fabs(w[i][k]) > best) {
				best = fabs(w[i][k]);
				p = i;
			}
		if (p < 0)
			return false;
		if (p != k)
			for (j = 0; j < 8; j++) {
				double t = w[k][j];
				w[k][j] = w[p][j];
				w[p][j] = t;
			}
		piv = 1.0 / w[k][k];
		for (j = 0; j < 8; j++)
			w[k][j] *= piv;
		for (i = 0; i < 4; i++) {
			double f;

			if (i == k || w[i][k] == 0.0)
				continue;
			f = w[i][k];
			for (j = 0; j < 8; j++)
				w[i][j] -= f * w[k][j];
		}
	}

	for (i = 0; i < 4; i++)
		for (j = 0; j < 4; j++)
			if (!isfinite((float)w[i][j + 4]))
				return false;
	for (i = 0; i < 4; i++)
		for (j = 0; j < 4; j++)
			inv->m[i][j] = (float)w[i][j + 4];
	return true;
}

/*
 * M p for a point (w = 1).  The homogeneous divide only happens for
 * projective matrices, so affine ones pay nothing for it.
 */
struct pm_vec3
pm_xform_point(const struct pm_mat4 *m, struct pm_vec3 p)
{
	const float (*a)[4] = m->m;
	float x, y, z, w;

	x = a[0][0] * p.x + a[0][1] * p.y + a[0][2] * p.z + a[0][3];
	y = a[1][0] * p.x + a[1][1] * p.y + a[1][2] * p.z + a[1][3];
	z = a[2][0] * p.x + a[2][1] * p.y + a[2][2] * p.z + a[2][3];
	w = a[3][0] * p.x + a[3][1] * p.y + a[3][2] * p.z + a[3][3];
	if (w != 1.0f && w != 0.0f) {
		float iw = 1.0f / w;
		x *= iw;
		y *= iw;
		z *= iw;
	}
	return pm_v3(x, y, z);
}

/* M v for a direction (w = 0): translation does not apply. */
struct pm_vec3
pm_xform_vector(const struct pm_mat4 *m, struct pm_vec3 v)
{
	const float (*a)[4] = m->m;

	return pm_v3(a[0][0] * v.x + a[0][1] * v.y + a[0][2] * v.z,
	    a[1][0] * v.x + a[1][1] * v.y + a[1][2] * v.z,
	    a[2][0] * v.x + a[2][1] * v.y + a[2][2] * v.z);
}

/*
 * inv^T n: normals must stay perpendicular to transformed tangents under
 * non-uniform scaling.  The result is not renormalised; callers that need
 * a unit normal normalise it themselves.
 */
struct pm_vec3
pm_xform_normal(const struct pm_mat4 *inv, struct pm_vec3 n)
{
	const float (*a)[4] = inv->m;

	return pm_v3(a[0][0] * n.x + a[1][0] * n.y + a[2][0] * n.z,
	    a[0][1] * n.x + a[1][1] * n.y + a[2][1] * n.z,
	    a[0][2] * n.x + a[1][2] * n.y + a[2][2] * n.z);
}
