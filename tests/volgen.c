/*
 * volgen.c: writes the .vol grids (Mitsuba's layout, formats/vol.h) that
 * the scenes and tests use, so that none is stored in the repository:
 *
 *   volgen smoke OUT.vol           a rising plume of smoke, 64 x 112 x 64,
 *                                  one channel, values in [0, 1)
 *                                  (data/smoke.xml's sigma_t)
 *   volgen tint OUT.vol            8 x 14 x 8 RGB albedo, warm below and
 *                                  grey above (data/smoke.xml's albedo)
 *   volgen const OUT.vol NX NY NZ V [V V]
 *                                  every voxel V (one channel) or the
 *                                  colour V V V (three)
 *   volgen lookup IN.vol trilinear|nearest clamp|repeat|mirror
 *                                  reads points x y z of the unit cube
 *                                  from stdin, writes pm's lookup there
 *                                  (R G B) to stdout (lookup_volume.py
 *                                  compares them with Mitsuba's)
 *
 * Everything is a pure function of the voxel index (hashed value noise),
 * so the files are the same on every machine.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "../common/rng.h"
#include "../formats/vol.h"

/* A lattice value in [0, 1) at integer point (i, j, k). */
static double
lattice(int i, int j, int k)
{
	uint64_t h = pm_mix64(((uint64_t)(uint32_t)i * 73856093u) ^
	    pm_mix64(((uint64_t)(uint32_t)j << 21) ^ (uint64_t)(uint32_t)k));

	return (double)(h >> 11) * 0x1p-53;
}

static double
smooth(double t)
{
	return t * t * (3.0 - 2.0 * t);
}

/* Value noise: the lattice interpolated with smoothstep weights. */
static double
vnoise(double x, double y, double z)
{
	int i = (int)floor(x), j = (int)floor(y), k = (int)floor(z), a, b, c;
	double fx = smooth(x - i), fy = smooth(y - j), fz = smooth(z - k), s = 0;

	for (c = 0; c < 2; c++)
		for (b = 0; b < 2; b++)
			for (a = 0; a < 2; a++)
				s += (a ? fx : 1 - fx) * (b ? fy : 1 - fy) *
				    (c ? fz : 1 - fz) * lattice(i + a, j + b, k + c);
	return s;
}

/* Four octaves, in [0, 1). */
static double
fbm(double x, double y, double z)
{
	double s = 0, w = 0.5, f = 1;
	int o;

	for (o = 0; o < 4; o++, w *= 0.5, f *= 2.03)
		s += w * vnoise(f * x, f * y, f * z);
	return s / 0.9375;
}

/* The plume's density at (x, y, z) of the unit cube, y up. */
static float
plume(double x, double y, double z)
{
	double cx = 0.5 + 0.12 * y * sin(5.0 * y + 0.5);
	double cz = 0.5 + 0.10 * y * cos(4.0 * y);
	double r = 0.07 + 0.30 * y;
	double d2 = ((x - cx) * (x - cx) + (z - cz) * (z - cz)) / (r * r);
	double v = exp(-2.0 * d2) * smooth(fmin(1.0, y / 0.06)) *
	    pow(1.0 - y, 1.5);
	double n = fbm(6.0 * x, 6.0 * y - 1.7, 6.0 * z);

	v *= fmax(0.0, 1.8 * n - 0.35);
	/* Saturated towards 1: a flat core keeps the largest value (the
	 * majorant that tracking samples against) near the typical one. */
	return (float)(1.0 - exp(-v / 0.12));
}

static int
make(struct pm_grid *g, int nx, int ny, int nz, int nch)
{
	memset(g, 0, sizeof(*g));
	g->nx = nx;
	g->ny = ny;
	g->nz = nz;
	g->nch = nch;
	g->bbox[3] = g->bbox[4] = g->bbox[5] = 1.0f;
	g->data = calloc((size_t)nx * ny * nz * nch, sizeof(float));
	return g->data != NULL;
}

int
main(int argc, char **argv)
{
	struct pm_grid g;
	struct pm_error err;
	int x, y, z, c, n[3];
	float v[3];
	size_t i = 0;

	if (argc == 3 && strcmp(argv[1], "smoke") == 0) {
		if (!make(&g, 64, 112, 64, 1))
			return 1;
		for (z = 0; z < g.nz; z++)
			for (y = 0; y < g.ny; y++)
				for (x = 0; x < g.nx; x++)
					g.data[i++] = plume((x + 0.5) / g.nx,
					    (y + 0.5) / g.ny, (z + 0.5) / g.nz);
	} else if (argc == 3 && strcmp(argv[1], "tint") == 0) {
		if (!make(&g, 8, 14, 8, 3))
			return 1;
		for (z = 0; z < g.nz; z++)
			for (y = 0; y < g.ny; y++)
				for (x = 0; x < g.nx; x++) {
					double h = (y + 0.5) / g.ny;

					g.data[i++] = (float)(0.95 - 0.05 * h);
					g.data[i++] = (float)(0.70 + 0.20 * h);
					g.data[i++] = (float)(0.45 + 0.45 * h);
				}
	} else if ((argc == 7 || argc == 9) && strcmp(argv[1], "const") == 0) {
		for (c = 0; c < 3; c++)
			n[c] = atoi(argv[3 + c]);
		for (c = 0; c < argc - 6; c++)
			v[c] = strtof(argv[6 + c], NULL);
		if (n[0] <= 0 || n[1] <= 0 || n[2] <= 0 ||
		    !make(&g, n[0], n[1], n[2], argc - 6))
			return 1;
		for (i = 0; i < (size_t)n[0] * n[1] * n[2] * g.nch; i++)
			g.data[i] = v[i % (size_t)g.nch];
	} else if (argc == 5 && strcmp(argv[1], "lookup") == 0) {
		struct pm_volume vol;
		double p[3];

		memset(&vol, 0, sizeof(vol));
		if (pm_vol_read(argv[2], &vol.grid, &err) != PM_OK) {
			fprintf(stderr, "volgen: %s\n", err.msg);
			return 1;
		}
		vol.to_local = pm_mat4_identity();
		vol.nearest = strcmp(argv[3], "nearest") == 0;
		vol.wrap = strcmp(argv[4], "repeat") == 0 ? PM_VOL_REPEAT :
		    strcmp(argv[4], "mirror") == 0 ? PM_VOL_MIRROR :
		    PM_VOL_CLAMP;
		while (scanf("%lf %lf %lf", &p[0], &p[1], &p[2]) == 3) {
			struct pm_rgb c = pm_volume_eval(&vol, pm_v3((float)p[0],
			    (float)p[1], (float)p[2]));

			printf("%.9g %.9g %.9g\n", c.r, c.g, c.b);
		}
		pm_grid_free(&vol.grid);
		return 0;
	} else {
		fprintf(stderr, "usage: volgen smoke|tint OUT.vol\n"
		    "       volgen const OUT.vol NX NY NZ V [V V]\n"
		    "       volgen lookup IN.vol FILTER WRAP <points\n");
		return 2;
	}
	if (pm_vol_write(argv[2], &g, &err) != PM_OK) {
		fprintf(stderr, "volgen: %s\n", err.msg);
		pm_grid_free(&g);
		return 1;
	}
	pm_grid_free(&g);
	return 0;
}
