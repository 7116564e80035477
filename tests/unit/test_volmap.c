/*
 * test_volmap.c: the volume photon map (participating media in photon
 * mode) against what a homogeneous medium must scatter analytically.
 *
 * The scenes are a point light of intensity I (power 4 pi I) at the
 * centre of a null-BSDF sphere of radius R filled with a medium: with
 * R sigma_t = 1000 the medium is infinite for every photon.  There:
 *   - every photon path scatters at least once (escape: e^-1000), so
 *     the depth-0 photons are exactly the paths shot, and a path's
 *     photons follow one another with depths 0, 1, 2, ... in the map,
 *     which lets the test sum each path's stored flux;
 *   - a scatter stores the flux leaving it, the arriving flux times
 *     the albedo a, and Russian roulette with survival a restores it:
 *     a path stores a Phi per scatter and scatters Geometric(1 - a)
 *     times, so its expected stored flux is Phi a / (1 - a), per
 *     channel, whatever sigma_t (also in a coloured medium, where the
 *     flights are sampled by one channel and weighted by the mixture);
 *   - the first scatters lie at distances from the light with density
 *     sigma_t e^(-sigma_t r): the stored flux per unit length.
 * The statistics use the per-path sums' own standard error.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <cmocka.h>

#include "../../common/integrator.h"
#include "../../common/kdtree.h"
#include "../../common/photonmap.h"
#include "../../common/shoot.h"
#include "../../common/world.h"
#include "../../formats/scene_xml.h"
#include "../../formats/vol.h"
#include "stats.h"
#include "tmpdir.h"

#define PI 3.14159265358979323846

static void
assert_within(double got, double want, double se, double k, const char *what)
{
	double tol = k * se + 1e-6 * fabs(want);

	print_message("%s: got %.6f want %.6f (se %.2g, %.2f sigma)\n", what,
	    got, want, se, se > 0 ? (got - want) / se : 0.0);
	assert_true(fabs(got - want) <= tol);
}

struct vworld {
	struct pm_scene scene;
	struct pm_world world;
	struct pm_shooter shooter;
};

/* A point light of intensity `inten` at the origin inside a null sphere
 * of radius `radius` holding the medium (sigma_t, albedo, phase); with
 * vol not NULL, the medium is heterogeneous and sigma_t is its XML (a
 * <volume> naming the file vol, which the caller removes). */
static void
vworld_init_any(struct vworld *w, const char *sigma_t, const char *albedo,
    const char *phase, float radius, const char *inten, const char *vol)
{
	char xml[4096];
	struct pm_error err;

	snprintf(xml, sizeof(xml), "<scene version=\"3.0.0\">"
	    "<medium type=\"%s\" id=\"m\">"
	    "%s%s%s"
	    "<rgb name=\"albedo\" value=\"%s\"/>%s</medium>"
	    "<shape type=\"sphere\"><float name=\"radius\" value=\"%g\"/>"
	    "<bsdf type=\"null\"/><ref name=\"interior\" id=\"m\"/></shape>"
	    "<emitter type=\"point\"><point name=\"position\" x=\"0\" y=\"0\" "
	    "z=\"0\"/><rgb name=\"intensity\" value=\"%s\"/></emitter>"
	    "</scene>", vol != NULL ? "heterogeneous" : "homogeneous",
	    vol != NULL ? "" : "<rgb name=\"sigma_t\" value=\"", sigma_t,
	    vol != NULL ? "" : "\"/>", albedo, phase, (double)radius, inten);
	memset(&err, 0, sizeof(err));
	if (pm_scene_load_string(xml, strlen(xml), "t.xml", ".", NULL, 0,
	    &w->scene, &err) != PM_OK)
		fail_msg("load: %s", err.msg);
	assert_int_equal(pm_world_init(&w->world, &w->scene, &err), PM_OK);
	assert_int_equal(pm_shooter_init(&w->shooter, &w->scene,
	    w->world.accel, &w->world.lights, &err), PM_OK);
}

static void
vworld_init(struct vworld *w, const char *sigma_t, const char *albedo,
    const char *phase, float radius, const char *inten)
{
	vworld_init_any(w, sigma_t, albedo, phase, radius, inten, NULL);
}

/*
 * A grid of nx x 1 x 1 voxels of nch channels (v: nx * nch values)
 * written to a temporary .vol file (path gets its name), and the
 * <volume> that places it over [x0, x1] x [-h, h] x [-h, h], filtered
 * as `filter` says, in xml.
 */
static void
grid_volume(char *path, size_t npath, char *xml, size_t nxml, int nx,
    int nch, const float *v, float x0, float x1, float h, const char *filter)
{
	struct pm_grid g;
	struct pm_error err;

	memset(&g, 0, sizeof(g));
	g.nx = nx;
	g.ny = g.nz = 1;
	g.nch = nch;
	g.bbox[3] = g.bbox[4] = g.bbox[5] = 1.0f;
	g.data = (float *)v;
	snprintf(path, npath, "%s/grid-%d.vol", pm_test_dir, nx);
	assert_int_equal(pm_vol_write(path, &g, &err), PM_OK);
	snprintf(xml, nxml, "<volume type=\"gridvolume\" name=\"sigma_t\">"
	    "<string name=\"filename\" value=\"%s\"/>"
	    "<string name=\"filter_type\" value=\"%s\"/>"
	    "<transform name=\"to_world\"><scale x=\"%g\" y=\"%g\" "
	    "z=\"%g\"/><translate x=\"%g\" y=\"%g\" z=\"%g\"/></transform>"
	    "</volume>", path, filter, (double)(x1 - x0), 2.0 * h, 2.0 * h,
	    (double)x0, -(double)h, -(double)h);
}

static void
vworld_free(struct vworld *w)
{
	pm_shooter_free(&w->shooter);
	pm_world_free(&w->world);
	pm_scene_free(&w->scene);
}

static void
shoot_volume(struct vworld *w, uint64_t n, int max_depth,
    struct pm_photon_buf *surf, struct pm_photon_buf *vol)
{
	struct pm_shoot_opts o;
	struct pm_shoot_stats st;
	struct pm_error err;

	memset(&o, 0, sizeof(o));
	o.pass = PM_PASS_GLOBAL;
	o.seed = 7;
	o.count = n;
	o.max_depth = max_depth;
	o.threads = 2;
	o.volume = vol;
	assert_int_equal(pm_shoot(&w->shooter, &o, surf, &st, &err), PM_OK);
	assert_int_equal(st.dropped, 0);
	assert_true(st.volume_stored == vol->n);
}

/* Per path (a run of depths starting at 0), the stored flux; mean and
 * standard error of each channel over the paths. */
static size_t
per_path_flux(const struct pm_photon_buf *vol, double mean[3], double se[3])
{
	double s[3] = {0, 0, 0}, s2[3] = {0, 0, 0}, cur[3] = {0, 0, 0};
	size_t i, paths = 0;
	int c;

	for (i = 0; i <= vol->n; i++) {
		if (i == vol->n || vol->p[i].depth == 0) {
			if (i > 0)
				for (c = 0; c < 3; c++) {
					s[c] += cur[c];
					s2[c] += cur[c] * cur[c];
				}
			if (i == vol->n)
				break;
			paths++;
			cur[0] = cur[1] = cur[2] = 0.0;
		}
		{
			struct pm_rgb p = pm_rgbe_unpack(vol->p[i].power);

			cur[0] += p.r;
			cur[1] += p.g;
			cur[2] += p.b;
		}
	}
	for (c = 0; c < 3; c++) {
		mean[c] = s[c] / (double)paths;
		se[c] = sqrt(fmax(s2[c] / (double)paths - mean[c] * mean[c],
		    0.0) / (double)paths);
	}
	return paths;
}

/* Grey, albedo 0.8, in an infinite medium: every path scatters first
 * (depth-0 photons = paths), photons of depth k number about N a^k, and
 * the stored flux per path is Phi a / (1 - a) = 4 Phi. */
static void
test_infinite_grey(void **state)
{
	struct vworld w;
	struct pm_photon_buf surf = {NULL, 0, 0}, vol = {NULL, 0, 0};
	const uint64_t n = 40000;
	const double a = 0.8, phi = 4.0 * PI * 1.0;
	double mean[3], se[3];
	size_t i, depth1 = 0;

	(void)state;
	vworld_init(&w, "1", "0.8", "", 1000.0f, "1");
	shoot_volume(&w, n, -1, &surf, &vol);
	assert_int_equal(surf.n, 0);	/* no surface holds photons */
	assert_int_equal(per_path_flux(&vol, mean, se), n);
	for (i = 0; i < vol.n; i++) {
		depth1 += vol.p[i].depth == 1;
		/* the sphere's centre, nothing farther than the medium */
		assert_true(vol.p[i].normal[0] == 0 && vol.p[i].normal[1] == 0);
		assert_true(vol.p[i].flags & PM_KD_LEAF);
		assert_int_equal(!!(vol.p[i].flags & PM_PHOTON_VIA_DIFFUSE),
		    vol.p[i].depth > 0);
		assert_false(vol.p[i].flags & PM_PHOTON_CAUSTIC);
	}
	/* binomial: n a survivors of the first scatter */
	assert_within((double)depth1, n * a, sqrt(n * a * (1 - a)), 4.0,
	    "photons of depth 1");
	assert_within(mean[0], phi * a / (1 - a), se[0], 4.0,
	    "stored flux per path (grey)");
	vworld_free(&w);
	pm_photon_buf_free(&surf);
	pm_photon_buf_free(&vol);
}

/* Coloured: sigma_t 0.5/1/2, albedo 0.9/0.6/0.3, Henyey-Greenstein:
 * per channel Phi_c a_c / (1 - a_c), with Phi = 4 pi (1, 2, 0.5). */
static void
test_infinite_coloured(void **state)
{
	struct vworld w;
	struct pm_photon_buf surf = {NULL, 0, 0}, vol = {NULL, 0, 0};
	const uint64_t n = 60000;
	const double a[3] = {0.9, 0.6, 0.3}, in[3] = {1.0, 2.0, 0.5};
	double mean[3], se[3];
	int c;

	(void)state;
	vworld_init(&w, "0.5, 1, 2", "0.9, 0.6, 0.3",
	    "<phase type=\"hg\"><float name=\"g\" value=\"0.6\"/></phase>",
	    2000.0f, "1, 2, 0.5");
	shoot_volume(&w, n, -1, &surf, &vol);
	assert_int_equal(per_path_flux(&vol, mean, se), n);
	for (c = 0; c < 3; c++)
		assert_within(mean[c], 4.0 * PI * in[c] * a[c] / (1 - a[c]),
		    se[c], 4.0, c == 0 ? "stored flux per path, red" :
		    c == 1 ? "green" : "blue");
	vworld_free(&w);
	pm_photon_buf_free(&surf);
	pm_photon_buf_free(&vol);
}

/* The coloured case with sigma_t a constant RGB grid (a heterogeneous
 * medium, delta-tracked against its majorant 2, with null collisions in
 * two channels of three) covering the sphere: the stored flux per path
 * is Phi_c a_c / (1 - a_c) again.  Albedos below 1/3 keep every flight's
 * weight (at most 3 times the analogue one, medium.h) below 1, so that
 * Russian roulette never lets a channel's flux grow and the per-path
 * sums have the finite variance their standard error assumes (with
 * test_infinite_coloured's 0.9 the sums are heavy-tailed: their sample
 * mean falls mostly below the true one). */
static void
test_infinite_coloured_grid(void **state)
{
	struct vworld w;
	struct pm_photon_buf surf = {NULL, 0, 0}, vol = {NULL, 0, 0};
	const uint64_t n = 100000;
	const double a[3] = {0.33, 0.3, 0.2}, in[3] = {1.0, 2.0, 0.5};
	const float v[6] = {0.5f, 1.0f, 2.0f, 0.5f, 1.0f, 2.0f};
	double mean[3], se[3];
	char path[128], xml[1024];
	int c;

	(void)state;
	grid_volume(path, sizeof(path), xml, sizeof(xml), 2, 3, v, -2100.0f,
	    2100.0f, 2100.0f, "trilinear");
	vworld_init_any(&w, xml, "0.33, 0.3, 0.2",
	    "<phase type=\"hg\"><float name=\"g\" value=\"0.6\"/></phase>",
	    2000.0f, "1, 2, 0.5", path);
	unlink(path);
	assert_int_equal(w.scene.media[0].type, PM_MEDIUM_HETEROGENEOUS);
	shoot_volume(&w, n, -1, &surf, &vol);
	assert_int_equal(per_path_flux(&vol, mean, se), n);
	for (c = 0; c < 3; c++)
		assert_within(mean[c], 4.0 * PI * in[c] * a[c] / (1 - a[c]),
		    se[c], 4.0, c == 0 ? "grid: stored flux per path, red" :
		    c == 1 ? "grid: green" : "grid: blue");
	vworld_free(&w);
	pm_photon_buf_free(&surf);
	pm_photon_buf_free(&vol);
}

/*
 * First scatters in a medium whose density steps: sigma_t = s1 = 1 for
 * |x| < 1 and s2 = 3 beyond (a nearest-filtered grid of 8 voxels over
 * x in [-4, 4], 80 wide in y and z), grey, albedo 0.7, max_depth 0,
 * the point light at the origin.  A photon leaving at |cos| = mu to the
 * x axis (uniform in [0, 1]) reaches the step at r = 1 / mu, so it
 * passes r with the probability exp(-tau(r, mu)),
 *   tau = s1 r  (r mu <= 1),  s1 / mu + s2 (r - 1 / mu)  (beyond);
 * a shell [r0, r1)'s share of first scatters is the integral over mu of
 * exp(-tau(r0, mu)) - exp(-tau(r1, mu)) (midpoint rule, 20000 points).
 * Chi-square of the depth-0 photons' distances over 24 shells to r = 3
 * and the rest (farther, or gone: the box lies 4 past the step along x,
 * e^-10 at most).  Delta tracking's null collisions cancel in a grey
 * medium: every photon stores Phi a, up to RGBE's rounding.
 */
static double
step_tau(double r, double mu)
{
	const double s1 = 1.0, s2 = 3.0;

	return r * mu <= 1.0 ? s1 * r : s1 / mu + s2 * (r - 1.0 / mu);
}

static void
test_first_scatter_step(void **state)
{
	struct vworld w;
	struct pm_photon_buf surf = {NULL, 0, 0}, vol = {NULL, 0, 0};
	const uint64_t n = 100000;
	const double rmax = 3.0, a = 0.7, phi = 4.0 * PI;
	const float v[8] = {3, 3, 3, 1, 1, 3, 3, 3};
	enum { NB = 24, NMU = 20000 };
	double obs[NB + 1], expd[NB + 1], p, near = 0.0;
	char path[128], xml[1024];
	size_t i;
	int b, k;

	(void)state;
	grid_volume(path, sizeof(path), xml, sizeof(xml), 8, 1, v, -4.0f,
	    4.0f, 40.0f, "nearest");
	vworld_init_any(&w, xml, "0.7", "", 100.0f, "1", path);
	unlink(path);
	shoot_volume(&w, n, 0, &surf, &vol);
	memset(obs, 0, sizeof(obs));
	for (i = 0; i < vol.n; i++) {
		const struct pm_photon *x = &vol.p[i];
		double r = sqrt((double)x->pos[0] * x->pos[0] +
		    (double)x->pos[1] * x->pos[1] +
		    (double)x->pos[2] * x->pos[2]);
		struct pm_rgb c = pm_rgbe_unpack(x->power);

		assert_int_equal(x->depth, 0);
		assert_true(fabs(c.r - phi * a) < 0.01 * phi * a &&
		    c.g == c.r && c.b == c.r);
		b = (int)(r / rmax * NB);
		if (b < NB)
			obs[b]++;
	}
	for (b = 0; b < NB; b++)
		near += obs[b];
	obs[NB] = (double)n - near;
	for (b = 0; b <= NB; b++) {
		double r0 = rmax * b / NB, r1 = rmax * (b + 1) / NB, sum = 0.0;

		for (k = 0; k < NMU; k++) {
			double mu = (k + 0.5) / NMU;

			sum += exp(-step_tau(r0, mu)) -
			    (b < NB ? exp(-step_tau(r1, mu)) : 0.0);
		}
		expd[b] = (double)n * sum / NMU;
	}
	p = stats_chi2(obs, expd, NB + 1, STATS_POOL_JOIN, 1e-3,
	    "first scatters, stepped density");
	print_message("first scatters across a step: chi-square p = %.3g\n", p);
	assert_true(p > 1e-4);
	vworld_free(&w);
	pm_photon_buf_free(&surf);
	pm_photon_buf_free(&vol);
}

/* First scatters: the flux stored per unit length from the light is
 * Phi a sigma e^(-sigma r); in a sphere of radius R = 2 / sigma the
 * rest leaves.  Chi-square of the depth-0 photons' distances over 20
 * shells and the outside against the exponential; the depth-0 flux
 * against Phi a (1 - e^(-sigma R)); max_depth 0 stores nothing deeper. */
static void
test_first_scatter_per_length(void **state)
{
	struct vworld w;
	struct pm_photon_buf surf = {NULL, 0, 0}, vol = {NULL, 0, 0};
	const uint64_t n = 100000;
	const double sigma = 1.5, R = 2.0 / 1.5, a = 0.7, phi = 4.0 * PI;
	enum { NB = 20 };
	double obs[NB + 1], expd[NB + 1], flux = 0.0, p;
	size_t i;
	int b;

	(void)state;
	vworld_init(&w, "1.5", "0.7", "", (float)R, "1");
	shoot_volume(&w, n, 0, &surf, &vol);
	memset(obs, 0, sizeof(obs));
	for (i = 0; i < vol.n; i++) {
		const struct pm_photon *x = &vol.p[i];
		double r = sqrt((double)x->pos[0] * x->pos[0] +
		    (double)x->pos[1] * x->pos[1] +
		    (double)x->pos[2] * x->pos[2]);

		assert_int_equal(x->depth, 0);
		b = (int)(r / R * NB);
		obs[b < NB ? b : NB - 1]++;
		flux += pm_rgbe_unpack(x->power).r;
	}
	obs[NB] = (double)n - (double)vol.n;	/* escaped */
	for (b = 0; b < NB; b++)
		expd[b] = (double)n * (exp(-sigma * R * b / NB) -
		    exp(-sigma * R * (b + 1) / NB));
	expd[NB] = (double)n * exp(-sigma * R);
	p = stats_chi2(obs, expd, NB + 1, STATS_POOL_JOIN, 1e-3,
	    "first scatters");
	print_message("first scatters by distance: chi-square p = %.3g\n", p);
	assert_true(p > 1e-4);
	/* every stored photon carries Phi a exactly, up to RGBE rounding */
	p = 1.0 - exp(-sigma * R);
	assert_within(flux / (double)n, phi * a * p,
	    phi * a * sqrt(p * (1 - p) / (double)n), 4.0,
	    "depth-0 flux per path");
	vworld_free(&w);
	pm_photon_buf_free(&surf);
	pm_photon_buf_free(&vol);
}

/*
 * The volume estimates against single scattering around a point light in
 * an infinite grey medium, where it is analytic: at distance r the light
 * arriving straight from the light is I e^(-sigma r) / r^2, so the
 * in-scattered radiance (isotropic phase) is
 *   L_s(r) = sigma_s I e^(-sigma r) / (4 pi r^2).
 * The depth-0 photons (max_depth 0) hold exactly that light; relabelled
 * depth 1 (the estimates leave depth 0 to next-event estimation), their
 * fixed-radius density estimate at points of the sphere r = 1 must give
 * L_s(1), and the beam estimate along a segment must give the integral
 * of T L_s along it (Simpson's rule here).  Statistics: the photons
 * counted (Poisson); bias of the 0.05 kernel about 0.3%.
 */
#define NQ 400

struct ss {
	struct vworld w;
	struct pm_photon_buf surf, vol;
	struct pm_photon_maps maps;
	double sigma, albedo, inten;
};

static void
ss_setup(struct ss *t)
{
	struct pm_error err;
	size_t i;

	memset(t, 0, sizeof(*t));
	t->sigma = 1.0;
	t->albedo = 0.8;
	t->inten = 1.0;
	vworld_init(&t->w, "1", "0.8", "", 1000.0f, "1");
	shoot_volume(&t->w, 2000000, 0, &t->surf, &t->vol);
	for (i = 0; i < t->vol.n; i++)
		t->vol.p[i].depth = 1;
	assert_int_equal(pm_kdtree_build(t->vol.p, t->vol.n, 2, &err), PM_OK);
	t->maps.volume = t->vol.p;
	t->maps.nvolume = t->vol.n;
	t->maps.volume_scale = 1.0f / 2000000.0f;
	t->maps.volume_r2 = 0.05f * 0.05f;
	t->maps.fixed_radius = true;
	t->maps.lookup_size = 50;
}

static void
ss_free(struct ss *t)
{
	vworld_free(&t->w);
	pm_photon_buf_free(&t->surf);
	pm_photon_buf_free(&t->vol);
}

static double
ls_at(const struct ss *t, double r)
{
	return t->sigma * t->albedo * t->inten * exp(-t->sigma * r) /
	    (4.0 * PI * r * r);
}

static void
test_point_estimate_single_scattering(void **state)
{
	struct ss t;
	const struct pm_phase iso = {PM_PHASE_ISOTROPIC, 0.0f};
	double sum = 0.0, want, count, h = 0.05;
	int i;

	(void)state;
	ss_setup(&t);
	for (i = 0; i < NQ; i++) {
		/* a Fibonacci lattice over the unit sphere */
		double z = 1.0 - (2.0 * i + 1.0) / NQ, ph = i * 2.39996323;
		double s = sqrt(1.0 - z * z);
		struct pm_vec3 p = pm_v3((float)(s * cos(ph)),
		    (float)(s * sin(ph)), (float)z);

		sum += pm_volume_map_estimate(&t.maps, &iso, p,
		    pm_v3(0, 0, 1), -1).r;
	}
	want = ls_at(&t, 1.0);
	/* photons expected within the NQ balls */
	count = 2e6 * t.sigma * exp(-t.sigma) / (4.0 * PI) *
	    (4.0 / 3.0 * PI * h * h * h) * NQ;
	assert_within(sum / NQ, want, want / sqrt(count), 4.0,
	    "point estimate at r = 1, fixed radius");
	/* k nearest: k photons over the volume out to the k-th, whose
	 * expectation in a locally uniform density is k / (k - 1) times
	 * the density (the k-th photon sits on the boundary): 2% high */
	t.maps.fixed_radius = false;
	t.maps.volume_r2 = 0.2f * 0.2f;
	sum = 0.0;
	for (i = 0; i < NQ; i++) {
		double z = 1.0 - (2.0 * i + 1.0) / NQ, ph = i * 2.39996323;
		double s = sqrt(1.0 - z * z);
		struct pm_vec3 p = pm_v3((float)(s * cos(ph)),
		    (float)(s * sin(ph)), (float)z);

		sum += pm_volume_map_estimate(&t.maps, &iso, p,
		    pm_v3(0, 0, 1), -1).r;
	}
	assert_within(sum / NQ, want * 50.0 / 49.0, want / sqrt(50.0 * NQ), 4.0,
	    "point estimate at r = 1, 50 nearest");
	/* photons of depth 0 are never counted */
	t.maps.fixed_radius = true;
	t.maps.volume_r2 = 0.05f * 0.05f;
	for (i = 0; i < (int)t.vol.n; i++)
		t.vol.p[i].depth = 0;
	assert_true(pm_volume_map_estimate(&t.maps, &iso, pm_v3(1, 0, 0),
	    pm_v3(0, 0, 1), -1).r == 0.0f);
	ss_free(&t);
}

static void
test_beam_estimate_single_scattering(void **state)
{
	struct ss t;
	struct pm_medium med;
	double sum = 0.0, want = 0.0, len = 3.0, h = 0.05, count;
	int i, k, n = 2000;

	(void)state;
	ss_setup(&t);
	memset(&med, 0, sizeof(med));
	med.type = PM_MEDIUM_HOMOGENEOUS;
	med.sigma_t = pm_rgb1(1.0f);
	med.albedo = pm_rgb1(0.8f);
	med.phase.type = PM_PHASE_ISOTROPIC;
	/* segments from (-1.5, 1, z) along +x, at distance sqrt(1 + z^2)
	 * from the light; z over a few values averages the noise */
	for (k = 0; k < 8; k++) {
		double z = -0.7 + 0.2 * k, w = 0.0, dt = len / n;

		sum += pm_volume_beam_estimate(&t.maps, &med,
		    pm_v3(-1.5f, 1.0f, (float)z), pm_v3(1, 0, 0), 0.0f,
		    (float)len, -1).r;
		for (i = 0; i <= n; i++) {
			double x = -1.5 + i * dt;
			double r = sqrt(x * x + 1.0 + z * z);
			double f = exp(-t.sigma * i * dt) * ls_at(&t, r);

			w += f * (i == 0 || i == n ? 1 : i % 2 ? 4 : 2);
		}
		want += w * dt / 3.0;
	}
	/* photons within the 8 cylinders (radius h, length 3, about
	 * distance 1.2 from the light) */
	count = 8 * 2e6 * t.sigma * exp(-1.2 * t.sigma) /
	    (4.0 * PI * 1.44) * PI * h * h * len;
	assert_within(sum / 8, want / 8, want / 8 / sqrt(count), 4.0,
	    "beam estimate along 8 segments");
	ss_free(&t);
}

/*
 * Single scattering along camera segments as pm-render computes it
 * (pm_volume_inscatter with an empty volume map: transmittance sampling
 * and equiangular sampling toward the light, weighted by the balance
 * heuristic) against the integral of T L_s along them (Simpson's rule),
 * around the point light in the infinite grey medium: a segment far from
 * the light and two that pass within 0.1 and 0.02 of it, where L_s peaks
 * as 1 / r^2.  Means within 4 standard errors of the samples' own.
 */
static void
test_inscatter_single_scattering(void **state)
{
	struct vworld w;
	struct pm_photon_maps maps;
	struct pm_render_ctx ctx;
	const double sig = 1.0, alb = 0.8, len = 3.0;
	const double off[3][2] = {{1.0, 0.3}, {0.1, 0.0}, {0.02, 0.0}};
	int k;

	(void)state;
	vworld_init(&w, "1", "0.8", "", 1000.0f, "1");
	memset(&maps, 0, sizeof(maps));
	maps.volume_samples = 1;
	memset(&ctx, 0, sizeof(ctx));
	ctx.scene = &w.scene;
	ctx.accel = w.world.accel;
	ctx.lights = &w.world.lights;
	ctx.max_depth = -1;
	ctx.maps = &maps;
	for (k = 0; k < 3; k++) {
		struct pm_rng rng = pm_rng_seed(11, (uint64_t)k, 3);
		struct pm_vec3 o = pm_v3(-1.5f, (float)off[k][0],
		    (float)off[k][1]);
		double s = 0.0, s2 = 0.0, want = 0.0, mean, se;
		int i, n = 200000, nq = 200000;
		char what[96];

		for (i = 0; i < n; i++) {
			struct pm_rgb tr;
			double v = pm_volume_inscatter(&ctx, 0, o,
			    pm_v3(1, 0, 0), 0.0f, (float)len, 0, &tr, &rng).r;

			s += v;
			s2 += v * v;
		}
		mean = s / n;
		se = sqrt(fmax(s2 / n - mean * mean, 0.0) / n);
		for (i = 0; i <= nq; i++) {
			double dt = len / nq, x = -1.5 + i * dt;
			double r2 = x * x + off[k][0] * off[k][0] +
			    off[k][1] * off[k][1], r = sqrt(r2);
			double f = exp(-sig * i * dt) * sig * alb *
			    exp(-sig * r) / (4.0 * PI * r2);

			want += f * dt / 3.0 *
			    (i == 0 || i == nq ? 1 : i % 2 ? 4 : 2);
		}
		snprintf(what, sizeof(what), "single scattering, segment "
		    "%.2f from the light", off[k][0]);
		assert_within(mean, want, se, 4.0, what);
	}
	vworld_free(&w);
}

int
main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_infinite_grey),
		cmocka_unit_test(test_infinite_coloured),
		cmocka_unit_test(test_first_scatter_per_length),
		cmocka_unit_test(test_infinite_coloured_grid),
		cmocka_unit_test(test_first_scatter_step),
		cmocka_unit_test(test_point_estimate_single_scattering),
		cmocka_unit_test(test_beam_estimate_single_scattering),
		cmocka_unit_test(test_inscatter_single_scattering),
	};

	return cmocka_run_group_tests(tests, pm_tmpdir_setup, pm_tmpdir_teardown);
}
