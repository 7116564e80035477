/*
 * occupancy.c: the cell grid of occupancy.h.
 *
 * Why one cell of slack is enough: a photon p within distance r of q is
 * within r of it along each axis, so the exact values (x - lo) / cell of
 * p and q differ by at most r / cell = 1 / (1 + 1/256).  Computed in
 * float, each value carries a relative error of about two roundings
 * (2^-23) of itself, at most the cells along the axis (capped at 4096)
 * times 2^-23, 5e-4 cells: the computed values still differ by less than
 * one, so their floors by at most one, and p's cell is q's or a
 * neighbour.  A kd-tree walk that counts p measures its squared distance
 * in float too, within a few roundings of the exact one, which the same
 * 1/256 covers.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "occupancy.h"

/* Cells an axis at most (the rounding argument above), and words in all
 * (8 MB): a sparse or huge map gets wider cells, still exact. */
#define OCC_AXIS_MAX	4096.0f
#define OCC_WORDS_MAX	((size_t)1 << 20)

/* d = the row s of `words` words or'd with the rows `back` words
 * before it and `ahead` words after it in the grid (0: none there). */
static void
grow_row(uint64_t *d, const uint64_t *s, size_t words, size_t back,
    size_t ahead)
{
	size_t i;

	for (i = 0; i < words; i++)
		d[i] = s[i] | (back > 0 ? *(s + i - back) : 0) |
		    (ahead > 0 ? s[i + ahead] : 0);
}

void
pm_occupancy_build(struct pm_occupancy *o, const struct pm_photon *p,
    size_t n, float r2)
{
	float hi[3], cell, inv = 0.0f;
	size_t i, words = 0, rows = 0, total = 0, r;
	uint64_t *a, *b;
	int ax, tries, nn[3] = {0, 0, 0};

	memset(o, 0, sizeof(*o));
	if (n == 0 || !(r2 > 0.0f) || !isfinite(r2))
		return;
	for (ax = 0; ax < 3; ax++)
		o->lo[ax] = hi[ax] = p[0].pos[ax];
	for (i = 0; i < n; i++)
		for (ax = 0; ax < 3; ax++) {
			float x = p[i].pos[ax];

			if (!isfinite(x))
				return;
			o->lo[ax] = x < o->lo[ax] ? x : o->lo[ax];
			hi[ax] = x > hi[ax] ? x : hi[ax];
		}
	cell = sqrtf(r2) * (1.0f + 1.0f / 256.0f);
	for (tries = 0;; tries++) {
		bool fits = isfinite(cell) && cell > 0.0f;

		if (tries == 200)
			return;
		inv = 1.0f / cell;
		for (ax = 0; ax < 3 && fits; ax++) {
			float f = floorf((hi[ax] - o->lo[ax]) * inv) + 3.0f;

			fits = f <= OCC_AXIS_MAX;
			nn[ax] = fits ? (int)f : 0;
		}
		if (fits) {
			words = ((size_t)nn[0] + 63) / 64;
			rows = (size_t)nn[1] * (size_t)nn[2];
			total = words * rows;
			if (total <= OCC_WORDS_MAX)
				break;
		}
		cell *= 1.25f;
	}
	a = calloc(total, sizeof(*a));
	b = calloc(total, sizeof(*b));
	if (a == NULL || b == NULL) {
		free(a);
		free(b);
		return;
	}
	/* Each photon's own cell, as pm_occupancy_maybe finds a query's
	 * (v >= 0 here, since x >= lo): from 1 to nn - 2, since x <= hi. */
	for (i = 0; i < n; i++) {
		size_t c[3];

		for (ax = 0; ax < 3; ax++)
			c[ax] = (size_t)((p[i].pos[ax] - o->lo[ax]) * inv) + 1;
		a[(c[2] * (size_t)nn[1] + c[1]) * words + (c[0] >> 6)] |=
		    (uint64_t)1 << (c[0] & 63);
	}
	/* Grown by a cell along x (a row's bits and its words' edges) into
	 * b, then y (the rows beside) back into a, then z (the planes
	 * beside) into b: each set bit then covers its 27 cells. */
	for (r = 0; r < rows; r++) {
		const uint64_t *s = a + r * words;
		uint64_t *d = b + r * words;

		for (i = 0; i < words; i++)
			d[i] = s[i] | s[i] << 1 | s[i] >> 1 |
			    (i > 0 ? s[i - 1] >> 63 : 0) |
			    (i + 1 < words ? s[i + 1] << 63 : 0);
	}
	for (r = 0; r < rows; r++)
		grow_row(a + r * words, b + r * words, words,
		    r % (size_t)nn[1] > 0 ? words : 0,
		    r % (size_t)nn[1] + 1 < (size_t)nn[1] ? words : 0);
	for (r = 0; r < rows; r++)
		grow_row(b + r * words, a + r * words, words,
		    r / (size_t)nn[1] > 0 ? (size_t)nn[1] * words : 0,
		    r / (size_t)nn[1] + 1 < (size_t)nn[2] ?
		    (size_t)nn[1] * words : 0);
	free(a);
	o->inv_cell = inv;
	o->r2 = r2;
	for (ax = 0; ax < 3; ax++)
		o->n[ax] = nn[ax];
	o->words = words;
	o->bits = b;
}

void
pm_occupancy_free(struct pm_occupancy *o)
{
	free(o->bits);
	memset(o, 0, sizeof(*o));
}
