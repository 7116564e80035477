/*
 * test_merl.c: MERL measured BRDFs, from the bytes of the file to images.
 *
 *   - write then read: every bin of a gold table looked up at its centre
 *     gives the analytic model back to float rounding, and the reader's
 *     parameterisation inverts the writer's bin by bin;
 *   - the loader keeps one table per file however many BSDFs name it;
 *   - a Lambertian table has the albedo it was made with, and renders as
 *     `diffuse` does: a sphere in a furnace (analytic answer) and a small
 *     Cornell box (path tracing and photon mapping, means within 1%);
 *   - reciprocity up to index quantisation; the data-driven sampler's
 *     directions follow its pdf (chi-square), the pdf integrates to what
 *     the sampler produces; grazing and opposite directions stay finite;
 *   - broken files (empty, truncated at several lengths, wrong dimensions,
 *     wrong size, not MERL at all) fail with their own message and code.
 *
 * The 35 MB files live in a temporary directory removed at the end.
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

#include "../../common/kdtree.h"
#include "../../common/merl.h"
#include "../../common/render.h"
#include "../../common/rng.h"
#include "../../common/shoot.h"
#include "../../common/world.h"
#include "../../formats/merl.h"
#include "../../formats/scene_xml.h"
#include "stats.h"
#include "tmpdir.h"

#define NZ 40
#define NPHI 40
#define NCHI2 5
#define SIGNIFICANCE (1e-3 / NCHI2)
#define TWO_PI 6.283185307179586

static char dir[64];
static char gold_path[128], lambert_path[128];
static unsigned char *gold_buf;		/* the gold file's bytes */
static struct pm_merl *gold, *lambert, *plastic;
static const struct pm_rgb lambert_albedo = {0.6f, 0.45f, 0.3f};

static struct pm_merl_model
gold_model(void)
{
	struct pm_merl_model mo;

	memset(&mo, 0, sizeof(mo));
	mo.type = PM_MERL_METAL;
	assert_true(pm_conductor_lookup("Au", &mo.eta, &mo.k));
	mo.alpha = 0.15f;
	return mo;
}

static struct pm_merl_model
lambert_model(void)
{
	struct pm_merl_model mo;

	memset(&mo, 0, sizeof(mo));
	mo.type = PM_MERL_LAMBERT;
	mo.albedo = lambert_albedo;
	return mo;
}

static struct pm_merl_model
plastic_model(void)
{
	struct pm_merl_model mo;

	memset(&mo, 0, sizeof(mo));
	mo.type = PM_MERL_PLASTIC;
	mo.albedo = pm_rgb(0.1f, 0.3f, 0.6f);
	mo.alpha = 0.08f;
	mo.ior = 1.5f;
	return mo;
}

static int
setup(void **state)
{
	struct pm_merl_model mo;
	struct pm_error err;
	unsigned char *buf;

	(void)state;
	if (pm_tmpdir_make(dir, sizeof(dir), "merl") != 0)
		return -1;
	snprintf(gold_path, sizeof(gold_path), "%s/gold.binary", dir);
	snprintf(lambert_path, sizeof(lambert_path), "%s/lambert.binary", dir);
	mo = gold_model();
	if (pm_merl_write(gold_path, &mo, &err) != PM_OK)
		return -1;
	mo = lambert_model();
	if (pm_merl_write(lambert_path, &mo, &err) != PM_OK ||
	    pm_merl_read(lambert_path, &lambert, &err) != PM_OK)
		return -1;
	if ((gold_buf = malloc(PM_MERL_FILE_SIZE)) == NULL)
		return -1;
	mo = gold_model();
	pm_merl_encode(&mo, gold_buf);
	if (pm_merl_parse(gold_buf, PM_MERL_FILE_SIZE, "gold", &gold, &err)
	    != PM_OK)
		return -1;
	if ((buf = malloc(PM_MERL_FILE_SIZE)) == NULL)
		return -1;
	mo = plastic_model();
	pm_merl_encode(&mo, buf);
	if (pm_merl_parse(buf, PM_MERL_FILE_SIZE, "plastic", &plastic, &err)
	    != PM_OK)
		return -1;
	free(buf);
	return 0;
}

static int
teardown(void **state)
{
	(void)state;
	pm_merl_free(gold);
	pm_merl_free(lambert);
	pm_merl_free(plastic);
	free(gold_buf);
	return pm_tmpdir_remove(dir);
}

static struct pm_vec3
v3d(const double w[3])
{
	return pm_v3((float)w[0], (float)w[1], (float)w[2]);
}

static struct pm_vec3
dir_of(double theta, double phi)
{
	return pm_v3((float)(sin(theta) * cos(phi)),
	    (float)(sin(theta) * sin(phi)), (float)cos(theta));
}

static bool
rel_close(float got, float want, float rel)
{
	return fabsf(got - want) <= rel * fabsf(want) + 1e-30f;
}

/* ---- the file round trip ---- */

static void
test_write_read_exact(void **state)
{
	struct pm_merl_model mo = gold_model();
	struct pm_error err;
	struct pm_merl *m;
	FILE *f;
	long size;
	int ith, itd, ipd, above = 0, below = 0, i, j, p;

	(void)state;
	f = fopen(gold_path, "rb");
	assert_non_null(f);
	assert_int_equal(fseek(f, 0, SEEK_END), 0);
	size = ftell(f);
	fclose(f);
	assert_int_equal(size, 34992012L);
	assert_int_equal(pm_merl_read(gold_path, &m, &err), PM_OK);
	assert_string_equal(m->path, gold_path);
	/* the same bytes, read or parsed, give the same identity */
	assert_int_equal(m->crc, gold->crc);
	assert_memory_equal(m->f, gold->f, 3 * sizeof(float) * PM_MERL_N);
	for (ith = 0; ith < PM_MERL_NTH; ith++)
		for (itd = 0; itd < PM_MERL_NTD; itd++)
			for (ipd = 0; ipd < PM_MERL_NPD; ipd++) {
				double wi[3], wo[3];
				struct pm_vec3 a, b;
				struct pm_rgb got, want;
				float th, td, pd;

				pm_merl_bin_dirs(ith, itd, ipd, wi, wo);
				a = v3d(wi);
				b = v3d(wo);
				got = pm_merl_eval(m, a, b, 0);
				if (wi[2] <= 0.0 || wo[2] <= 0.0) {
					assert_true(pm_rgb_is_black(got));
					below++;
					continue;
				}
				above++;
				assert_true(pm_merl_angles(a, b, &th, &td, &pd));
				pm_merl_index(th, td, pd, &i, &j, &p);
				if (i != ith || j != itd || p != ipd)
					fail_msg("bin %d %d %d looks up as %d %d "
					    "%d", ith, itd, ipd, i, j, p);
				want = pm_merl_model_eval(&mo, a, b);
				if (!rel_close(got.r, want.r, 1e-6f) ||
				    !rel_close(got.g, want.g, 1e-6f) ||
				    !rel_close(got.b, want.b, 1e-6f))
					fail_msg("bin %d %d %d: %g %g %g, model "
					    "%g %g %g", ith, itd, ipd, got.r,
					    got.g, got.b, want.r, want.g,
					    want.b);
			}
	/* MERL's tables have both kinds of samples */
	assert_true(above > PM_MERL_N / 2);
	assert_true(below > 0);
	pm_merl_free(m);
}

/* Below the horizon the writer stores MERL's -1, in stored units. */
static void
test_writer_marks_horizon(void **state)
{
	double wi[3], wo[3], v;
	uint64_t bits;
	size_t idx = 179 + 180 * (89 + 90 * 89);	/* grazing everything */
	int i;

	(void)state;
	pm_merl_bin_dirs(89, 89, 179, wi, wo);
	assert_true(wi[2] <= 0.0 || wo[2] <= 0.0);
	for (i = 0; i < 3; i++) {
		const unsigned char *p = gold_buf + 12 + 8 * ((size_t)i *
		    PM_MERL_N + idx);
		int b;

		bits = 0;
		for (b = 7; b >= 0; b--)
			bits = bits << 8 | p[b];
		memcpy(&v, &bits, sizeof(v));
		assert_true(v == -1.0);
	}
	/* header: 90, 90, 180 little-endian */
	assert_int_equal(gold_buf[0], 90);
	assert_int_equal(gold_buf[4], 90);
	assert_int_equal(gold_buf[8], 180);
	assert_int_equal(gold_buf[1] | gold_buf[5] | gold_buf[9], 0);
}

/* Interpolation reproduces a constant and stays between its samples. */
static void
test_interpolation(void **state)
{
	struct pm_rgb want = pm_rgb_scale(lambert_albedo, PM_INV_PI);
	struct pm_rng rng = pm_rng_seed(5, 0, 0);
	int i;

	(void)state;
	for (i = 0; i < 20000; i++) {
		struct pm_vec3 a = pm_square_to_cosine_hemisphere(
		    pm_rng_float(&rng), pm_rng_float(&rng));
		struct pm_vec3 b = pm_square_to_cosine_hemisphere(
		    pm_rng_float(&rng), pm_rng_float(&rng));
		struct pm_rgb f = pm_merl_eval(lambert, a, b,
		    PM_MERL_INTERPOLATE);
		struct pm_rgb g = pm_merl_eval(gold, a, b, PM_MERL_INTERPOLATE);

		/* away from the horizon every neighbour is a valid sample */
		if (a.z > 0.1f && b.z > 0.1f &&
		    (!rel_close(f.r, want.r, 1e-5f) ||
		    !rel_close(f.b, want.b, 1e-5f)))
			fail_msg("%g %g %g, %g %g %g: %g", a.x, a.y, a.z, b.x,
			    b.y, b.z, f.r);
		assert_true(pm_rgb_is_finite(g) && g.r >= 0.0f && g.g >= 0.0f);
	}
	/* at a bin's centre interpolation is (nearly) the sample itself */
	{
		double wi[3], wo[3];
		struct pm_rgb n, t;

		pm_merl_bin_dirs(20, 30, 40, wi, wo);
		n = pm_merl_eval(gold, v3d(wi), v3d(wo), 0);
		t = pm_merl_eval(gold, v3d(wi), v3d(wo), PM_MERL_INTERPOLATE);
		assert_true(rel_close(t.r, n.r, 1e-3f));
	}
}

/* ---- the loader ---- */

static void
test_loader_shares_tables(void **state)
{
	char xml[2048];
	struct pm_scene s;
	struct pm_error err;
	size_t i, nmerl = 0;
	const struct pm_merl *first = NULL;

	(void)state;
	snprintf(xml, sizeof(xml),
	    "<scene version=\"3.0.0\">"
	    "<bsdf type=\"merl\" id=\"a\"><string name=\"filename\" "
	    "value=\"gold.binary\"/></bsdf>"
	    "<shape type=\"sphere\"><ref id=\"a\"/></shape>"
	    "<shape type=\"sphere\"><point name=\"center\" x=\"3\" y=\"0\" "
	    "z=\"0\"/><bsdf type=\"merl\"><string name=\"filename\" "
	    "value=\"./gold.binary\"/><boolean name=\"interpolate\" "
	    "value=\"true\"/><string name=\"sampling\" value=\"cosine\"/>"
	    "</bsdf></shape>"
	    "<shape type=\"sphere\"><point name=\"center\" x=\"6\" y=\"0\" "
	    "z=\"0\"/><bsdf type=\"twosided\"><bsdf type=\"merl\">"
	    "<string name=\"filename\" value=\"%s\"/></bsdf></bsdf></shape>"
	    "</scene>", gold_path);
	assert_int_equal(pm_scene_load_string(xml, strlen(xml), "t.xml", dir,
	    NULL, 0, &s, &err), PM_OK);
	assert_int_equal(s.nmerls, 1);
	for (i = 0; i < s.nbsdfs; i++) {
		if (s.bsdfs[i].type != PM_BSDF_MERL)
			continue;
		nmerl++;
		if (first == NULL)
			first = s.bsdfs[i].merl;
		assert_ptr_equal(s.bsdfs[i].merl, first);
		assert_true(s.bsdfs[i].lobes & PM_LOBE_GLOSSY);
		assert_false(pm_bsdf_is_delta(&s.bsdfs[i]));
	}
	assert_int_equal(nmerl, 3);
	assert_int_equal(s.bsdfs[1].merl_flags,
	    PM_MERL_INTERPOLATE | PM_MERL_COSINE);
	pm_scene_free(&s);

	snprintf(xml, sizeof(xml), "<scene version=\"3.0.0\"><bsdf "
	    "type=\"merl\"><string name=\"filename\" value=\"gold.binary\"/>"
	    "<string name=\"sampling\" value=\"fancy\"/></bsdf></scene>");
	assert_int_equal(pm_scene_load_string(xml, strlen(xml), "t.xml", dir,
	    NULL, 0, &s, &err), PM_ERR_INVALID);
	assert_non_null(strstr(err.msg, "fancy"));
	snprintf(xml, sizeof(xml), "<scene version=\"3.0.0\"><bsdf "
	    "type=\"merl\"/></scene>");
	assert_int_equal(pm_scene_load_string(xml, strlen(xml), "t.xml", dir,
	    NULL, 0, &s, &err), PM_ERR_INVALID);
	assert_non_null(strstr(err.msg, "filename"));
}

/* ---- albedo and sampling ---- */

static void
test_albedo(void **state)
{
	double t;

	(void)state;
	for (t = 0.0; t < 1.5; t += 0.1) {
		struct pm_rgb a = pm_merl_albedo(lambert, (float)t);

		print_message("theta %.1f: albedo %.4f %.4f %.4f\n", t, a.r,
		    a.g, a.b);
		assert_true(rel_close(a.r, lambert_albedo.r, 0.01f));
		assert_true(rel_close(a.g, lambert_albedo.g, 0.01f));
		assert_true(rel_close(a.b, lambert_albedo.b, 0.01f));
	}
	assert_false(lambert->glossy);
	assert_true(gold->glossy);
	/* gold reflects most of the red and some of the blue */
	assert_true(pm_merl_albedo(gold, 0.3f).r > 0.7f);
	assert_true(pm_merl_albedo(gold, 0.3f).r < 1.0f);
	assert_true(pm_merl_albedo(gold, 0.3f).b < pm_merl_albedo(gold,
	    0.3f).r);
}

static void
test_reciprocity(void **state)
{
	struct pm_rng rng = pm_rng_seed(7, 0, 0);
	int i, n = 0, same = 0, close = 0;

	(void)state;
	for (i = 0; i < 100000; i++) {
		struct pm_vec3 a = pm_square_to_uniform_hemisphere(
		    pm_rng_float(&rng), pm_rng_float(&rng));
		struct pm_vec3 b = pm_square_to_uniform_hemisphere(
		    pm_rng_float(&rng), pm_rng_float(&rng));
		struct pm_rgb f = pm_merl_eval(gold, a, b, 0);
		struct pm_rgb g = pm_merl_eval(gold, b, a, 0);
		struct pm_rgb fi = pm_merl_eval(gold, a, b, PM_MERL_INTERPOLATE);
		struct pm_rgb gi = pm_merl_eval(gold, b, a, PM_MERL_INTERPOLATE);

		n++;
		same += f.r == g.r && f.g == g.g && f.b == g.b;
		close += rel_close(fi.g, gi.g, 1e-3f);
	}
	print_message("reciprocal: %d of %d exactly, %d interpolated\n", same,
	    n, close);
	/* only pairs on a bin boundary may differ */
	assert_true(same >= n * 0.995);
	assert_true(close >= n * 0.995);
}

/*
 * Sampled directions over a (z, phi) grid of the upper hemisphere plus a
 * bin for failures; the expected counts integrate pdf() over each bin
 * with a 10 x 10 midpoint rule, the failure bin expects the rest.
 */
static void
check_sampling(const struct pm_bsdf *b, struct pm_vec3 wi, uint64_t seed,
    const char *what)
{
	static double obs[NZ * NPHI + 1], expd[NZ * NPHI + 1];
	const int n = 1000000, sub = 32;
	struct pm_rng rng = pm_rng_seed(seed, 0, 0);
	struct pm_bsdf_sample s;
	double dz = 1.0 / NZ, dp = TWO_PI / NPHI, total = 0.0;
	int i, iz, ip, a, c;

	memset(obs, 0, sizeof(obs));
	for (i = 0; i < n; i++) {
		float u1 = pm_rng_float(&rng), u2 = pm_rng_float(&rng);
		float u3 = pm_rng_float(&rng);

		if (!pm_bsdf_sample(b, wi, u1, u2, u3, PM_RADIANCE, &s)) {
			obs[NZ * NPHI] += 1.0;
			continue;
		}
		/* each sample says what pdf() and eval() say */
		assert_true(s.wo.z > 0.0f);
		assert_true(rel_close(s.pdf, pm_bsdf_pdf(b, wi, s.wo), 1e-5f));
		{
			struct pm_rgb f = pm_bsdf_eval(b, wi, s.wo,
			    PM_RADIANCE);

			assert_true(rel_close(s.weight.g * s.pdf, f.g, 1e-4f));
		}
		{
			double phi = atan2(s.wo.y, s.wo.x);

			if (phi < 0.0)
				phi += TWO_PI;
			iz = (int)(s.wo.z * NZ);
			ip = (int)(phi / TWO_PI * NPHI);
			iz = iz >= NZ ? NZ - 1 : iz;
			ip = ip >= NPHI ? NPHI - 1 : ip;
			obs[iz * NPHI + ip] += 1.0;
		}
	}
	for (iz = 0; iz < NZ; iz++)
		for (ip = 0; ip < NPHI; ip++) {
			double sum = 0.0;

			for (a = 0; a < sub; a++)
				for (c = 0; c < sub; c++) {
					double z = dz * (iz + (a + 0.5) / sub);
					double phi = dp * (ip + (c + 0.5) / sub);
					double r = sqrt(fmax(0.0, 1.0 - z * z));

					sum += pm_bsdf_pdf(b, wi, pm_v3(
					    (float)(r * cos(phi)),
					    (float)(r * sin(phi)), (float)z));
				}
			expd[iz * NPHI + ip] = n * sum * dz * dp / (sub * sub);
			total += expd[iz * NPHI + ip];
		}
	print_message("%s: pdf integrates to %.4f, %.4f of samples drawn\n",
	    what, total / n, 1.0 - obs[NZ * NPHI] / n);
	/* the pdf integrates to the fraction of samples that succeed */
	assert_true(fabs(total / n - (1.0 - obs[NZ * NPHI] / n)) < 0.01);
	expd[NZ * NPHI] = fmax(0.0, n - total);
	assert_true(stats_chi2(obs, expd, NZ * NPHI + 1, STATS_POOL_OWN,
	    2.0, what) > SIGNIFICANCE);
}

static struct pm_bsdf
mk_merl(const struct pm_merl *m, unsigned flags)
{
	struct pm_bsdf b;

	memset(&b, 0, sizeof(b));
	b.type = PM_BSDF_MERL;
	b.merl = m;
	b.merl_flags = flags;
	pm_bsdf_prepare(&b);
	return b;
}

static void
test_sampling_follows_pdf(void **state)
{
	struct pm_bsdf b;

	(void)state;
	b = mk_merl(gold, 0);
	check_sampling(&b, dir_of(0.0, 0.0), 11, "gold, normal");
	check_sampling(&b, dir_of(0.9, 0.4), 12, "gold, 52 degrees");
	check_sampling(&b, dir_of(1.25, 2.0), 13, "gold, 72 degrees");
	b = mk_merl(plastic, PM_MERL_INTERPOLATE);
	check_sampling(&b, dir_of(0.5, -1.0), 14, "plastic");
	b = mk_merl(lambert, PM_MERL_COSINE);
	check_sampling(&b, dir_of(0.7, 0.0), 15, "lambert, cosine");
}

/*
 * At grazing incidence the density in wo has structure finer than any
 * quadrature over wo bins resolves (the half-vector cells near the pole
 * are tiny), so the data sampler is checked in its own cells: half
 * vectors of the samples drawn against the tables' probabilities, over
 * the cells whose directions all stay above the horizon.
 */
static void
test_sampling_grazing_cells(void **state)
{
	static double obs[PM_MERL_NTH][PM_MERL_NPH];
	const float ti = 1.45f;
	const int n = 2000000;
	struct pm_vec3 wi = pm_v3(sinf(ti), 0.0f, cosf(ti));
	struct pm_rng rng = pm_rng_seed(17, 0, 0);
	int k = (int)(ti * PM_MERL_NTI / (0.5f * PM_PI)), i, j, a, c, cells = 0;
	const float *rc = gold->row_cdf + (size_t)k * (PM_MERL_NTH + 1);
	double chi2 = 0.0, p;

	(void)state;
	memset(obs, 0, sizeof(obs));
	for (i = 0; i < n; i++) {
		struct pm_vec3 wo, h;
		float pdf, th, ph;
		int ci, cj;

		/* u1 = 0: the data branch */
		if (!pm_merl_sample(gold, wi, 0.0f, pm_rng_float(&rng),
		    pm_rng_float(&rng), 0, &wo, &pdf))
			continue;
		h = pm_normalize(pm_add(wi, wo));
		th = atan2f(sqrtf(h.x * h.x + h.y * h.y), h.z);
		ph = atan2f(h.y, h.x);
		if (ph < 0.0f)
			ph += 2.0f * PM_PI;
		ci = (int)(sqrtf(th / (0.5f * PM_PI)) * PM_MERL_NTH);
		cj = (int)(ph / (2.0f * PM_PI) * PM_MERL_NPH);
		obs[ci < PM_MERL_NTH ? ci : PM_MERL_NTH - 1]
		    [cj < PM_MERL_NPH ? cj : PM_MERL_NPH - 1] += 1.0;
	}
	for (i = 0; i < PM_MERL_NTH; i++)
		for (j = 0; j < PM_MERL_NPH; j++) {
			const float *cc = gold->col_cdf + ((size_t)k *
			    PM_MERL_NTH + (size_t)i) * (PM_MERL_NPH + 1);
			double e = n * (double)(rc[i + 1] - rc[i]) *
			    (double)(cc[j + 1] - cc[j]);
			bool whole = e >= 20.0;

			for (a = 0; a < 2 && whole; a++)
				for (c = 0; c < 2; c++) {
					double x = gold->edge_omc[i + a];
					double st = sqrt(x * (2.0 - x));
					double phi = (j + c) * TWO_PI /
					    PM_MERL_NPH;
					struct pm_vec3 h = pm_v3((float)(st *
					    cos(phi)), (float)(st * sin(phi)),
					    (float)(1.0 - x));
					float dh = pm_dot(wi, h);

					if (dh <= 0.0f || 2.0f * dh * h.z -
					    wi.z <= 1e-3f)
						whole = false;
				}
			if (!whole)
				continue;
			chi2 += (obs[i][j] - e) * (obs[i][j] - e) / e;
			cells++;
		}
	p = stats_gamma_q(0.5 * (cells - 1), 0.5 * chi2);
	print_message("gold, 83 degrees, in half-vector cells: chi2 %.1f over "
	    "%d cells, p = %.3g\n", chi2, cells, p);
	assert_true(cells > 500);
	assert_true(p > SIGNIFICANCE);
}

/* The mean sample weight is the albedo: the sampler is unbiased. */
static void
test_sample_weights(void **state)
{
	struct pm_bsdf b = mk_merl(gold, 0), c = mk_merl(gold, PM_MERL_COSINE);
	struct pm_rng rng = pm_rng_seed(9, 0, 0);
	struct pm_vec3 wi = dir_of(0.6, 0.0);
	double sd = 0.0, sc = 0.0, qd = 0.0, qc = 0.0;
	int i, n = 400000;
	struct pm_rgb a = pm_merl_albedo(gold, 0.6f);

	(void)state;
	for (i = 0; i < n; i++) {
		struct pm_bsdf_sample s;
		float u1 = pm_rng_float(&rng), u2 = pm_rng_float(&rng);
		float u3 = pm_rng_float(&rng);

		if (pm_bsdf_sample(&b, wi, u1, u2, u3, PM_RADIANCE, &s)) {
			sd += s.weight.r;
			qd += s.weight.r * s.weight.r;
		}
		if (pm_bsdf_sample(&c, wi, u1, u2, u3, PM_RADIANCE, &s)) {
			sc += s.weight.r;
			qc += s.weight.r * s.weight.r;
		}
	}
	sd /= n;
	sc /= n;
	qd = qd / n - sd * sd;
	qc = qc / n - sc * sc;
	print_message("albedo %.4f; data %.4f (var %.4f), cosine %.4f (var "
	    "%.4f)\n", a.r, sd, qd, sc, qc);
	assert_true(fabs(sd - a.r) < 0.01);
	assert_true(fabs(sc - a.r) < 6.0 * sqrt(qc / n) + 0.005);
	/* what the data-driven sampler is for */
	assert_true(qd < 0.1 * qc);
}

static void
test_degenerate_directions(void **state)
{
	struct pm_bsdf b = mk_merl(gold, PM_MERL_INTERPOLATE);
	struct pm_vec3 g = pm_v3(1.0f, 0.0f, 0.0f), n = pm_v3(0, 0, 1);
	struct pm_vec3 t = pm_normalize(pm_v3(1.0f, 0.0f, 1e-7f));
	struct pm_bsdf_sample s;
	struct pm_rgb f;
	float th, td, pd;
	int k;

	(void)state;
	assert_true(pm_rgb_is_black(pm_bsdf_eval(&b, g, n, PM_RADIANCE)));
	assert_true(pm_bsdf_pdf(&b, g, n) == 0.0f);
	assert_false(pm_bsdf_sample(&b, g, 0.5f, 0.5f, 0.5f, PM_RADIANCE, &s));
	/* wi = -wo: one of them is below the surface */
	assert_true(pm_rgb_is_black(pm_bsdf_eval(&b, t, pm_neg(t),
	    PM_RADIANCE)));
	assert_true(pm_bsdf_pdf(&b, t, pm_neg(t)) == 0.0f);
	/* opposite grazing directions: h has zero length */
	assert_false(pm_merl_angles(g, pm_neg(g), &th, &td, &pd));
	f = pm_bsdf_eval(&b, t, pm_v3(-t.x, -t.y, t.z), PM_RADIANCE);
	assert_true(pm_rgb_is_finite(f));
	assert_true(isfinite(pm_bsdf_pdf(&b, t, pm_v3(-t.x, -t.y, t.z))));
	/* the same direction twice, and the normal */
	f = pm_bsdf_eval(&b, n, n, PM_RADIANCE);
	assert_true(pm_rgb_is_finite(f) && f.r > 0.0f);
	assert_true(isfinite(pm_bsdf_pdf(&b, n, n)));
	/* the extreme random numbers */
	for (k = 0; k < 4; k++) {
		float u = k == 0 ? 0.0f : k == 1 ? 0x1.fffffep-1f : 0.5f;
		struct pm_vec3 wi = k == 3 ? t : n;

		if (pm_bsdf_sample(&b, wi, 0.5f * u, u, u, PM_RADIANCE, &s)) {
			assert_true(isfinite(s.pdf) && s.pdf > 0.0f);
			assert_true(pm_rgb_is_finite(s.weight));
		}
	}
}

/* ---- renders ---- */

struct world {
	struct pm_scene scene;
	struct pm_world world;
	struct pm_render_ctx ctx;
	struct pm_photon_buf photons;
	struct pm_photon_maps maps;
};

static void
world_ready(struct world *w)
{
	struct pm_scene *s = &w->scene;
	struct pm_error err;

	assert_int_equal(pm_world_init(&w->world, s, &err), PM_OK);
	memset(&w->ctx, 0, sizeof(w->ctx));
	w->ctx.scene = s;
	w->ctx.accel = w->world.accel;
	w->ctx.lights = &w->world.lights;
	w->ctx.max_depth = s->integrator.max_depth;
	w->ctx.rr_depth = s->integrator.rr_depth;
	memset(&w->photons, 0, sizeof(w->photons));
}

static void
world_free(struct world *w)
{
	pm_photon_buf_free(&w->photons);
	pm_world_free(&w->world);
	pm_scene_free(&w->scene);
}

/* Shoots a global map and points the context at it. */
static void
world_photons(struct world *w, long n)
{
	struct pm_shooter sh;
	struct pm_shoot_opts o;
	struct pm_shoot_stats st;
	struct pm_error err;

	assert_int_equal(pm_shooter_init(&sh, &w->scene, w->world.accel,
	    &w->world.lights, &err), PM_OK);
	memset(&o, 0, sizeof(o));
	o.pass = PM_PASS_GLOBAL;
	o.seed = 1;
	o.count = (uint64_t)n;
	o.max_depth = -1;
	o.threads = 2;
	assert_int_equal(pm_shoot(&sh, &o, &w->photons, &st, &err), PM_OK);
	pm_shooter_free(&sh);
	assert_int_equal(pm_kdtree_build(w->photons.p, w->photons.n, 2, &err),
	    PM_OK);
	memset(&w->maps, 0, sizeof(w->maps));
	w->maps.global = w->photons.p;
	w->maps.nglobal = w->photons.n;
	w->maps.global_scale = 1.0f / (float)n;
	w->maps.global_r2 = 0.05f * w->scene.radius;
	w->maps.global_r2 *= w->maps.global_r2;
	w->maps.lookup_size = 100;
	w->maps.direct_samples = 4;
	w->ctx.maps = &w->maps;
}

static void
render_mean(struct world *w, enum pm_method method, int spp, double m[3])
{
	const struct pm_camera *c = &w->scene.camera;
	struct pm_render_opts o;
	struct pm_render_stats st;
	struct pm_image im;
	struct pm_error err;
	size_t i, n = (size_t)c->width * (size_t)c->height;

	memset(&o, 0, sizeof(o));
	o.method = method;
	o.spp = spp;
	o.seed = 3;
	o.threads = 2;
	assert_int_equal(pm_render(&w->ctx, c, &o, &im, &st, &err), PM_OK);
	assert_int_equal(st.dropped, 0);
	m[0] = m[1] = m[2] = 0.0;
	for (i = 0; i < n; i++) {
		m[0] += im.rgb[3 * i];
		m[1] += im.rgb[3 * i + 1];
		m[2] += im.rgb[3 * i + 2];
	}
	m[0] /= (double)n;
	m[1] /= (double)n;
	m[2] /= (double)n;
	pm_image_free(&im);
}

static void
assert_means(const double a[3], const double b[3], double rel,
    const char *what)
{
	int c;

	print_message("%s: %.5f %.5f %.5f against %.5f %.5f %.5f\n", what,
	    a[0], a[1], a[2], b[0], b[1], b[2]);
	for (c = 0; c < 3; c++)
		assert_true(fabs(a[c] - b[c]) <= rel * b[c]);
}

/* A MERL Lambertian sphere under uniform light reflects albedo * Le. */
static void
test_furnace(void **state)
{
	struct world w;
	struct pm_scene *s = &w.scene;
	struct pm_error err;
	const struct pm_rgb le = {1.0f, 2.0f, 0.5f};
	double m[3] = {0, 0, 0}, want[3];
	int b, sh, l, x, y, cnt = 0;
	struct pm_render_opts o;
	struct pm_render_stats st;
	struct pm_image im;

	(void)state;
	pm_scene_init(s);
	b = pm_scene_add_bsdf(s);
	s->bsdfs[b].type = PM_BSDF_DIFFUSE;
	s->bsdfs[b].diffuse = pm_rgb1(0.0f);
	sh = pm_scene_add_shape(s);
	s->shapes[sh].type = PM_SHAPE_SPHERE;
	s->shapes[sh].radius = 10.0f;
	s->shapes[sh].flip_normals = true;
	s->shapes[sh].bsdf = b;
	l = pm_scene_add_light(s);
	s->lights[l].type = PM_LIGHT_AREA;
	s->lights[l].radiance = le;
	s->lights[l].shape = sh;
	s->shapes[sh].light = l;
	b = pm_scene_add_bsdf(s);
	s->bsdfs[b].type = PM_BSDF_MERL;
	s->bsdfs[b].merl = lambert;	/* not the scene's to free */
	sh = pm_scene_add_shape(s);
	s->shapes[sh].type = PM_SHAPE_SPHERE;
	s->shapes[sh].radius = 1.0f;
	s->shapes[sh].bsdf = b;
	s->has_camera = true;
	s->camera.to_world = pm_mat4_lookat(pm_v3(0, 0, 5), pm_v3(0, 0, 0),
	    pm_v3(0, 1, 0));
	s->camera.fov = 20.0f;
	s->camera.fov_axis = PM_FOV_X;
	s->camera.width = s->camera.height = 32;
	s->camera.rfilter = PM_RFILTER_BOX;
	assert_int_equal(pm_scene_prepare(s, &err), PM_OK);
	world_ready(&w);
	memset(&o, 0, sizeof(o));
	o.method = PM_METHOD_PATH;
	o.spp = 256;
	o.seed = 3;
	o.threads = 2;
	assert_int_equal(pm_render(&w.ctx, &s->camera, &o, &im, &st, &err),
	    PM_OK);
	for (y = 8; y < 24; y++)
		for (x = 8; x < 24; x++, cnt++) {
			m[0] += im.rgb[3 * (y * 32 + x)];
			m[1] += im.rgb[3 * (y * 32 + x) + 1];
			m[2] += im.rgb[3 * (y * 32 + x) + 2];
		}
	pm_image_free(&im);
	m[0] /= cnt;
	m[1] /= cnt;
	m[2] /= cnt;
	want[0] = lambert_albedo.r * le.r;
	want[1] = lambert_albedo.g * le.g;
	want[2] = lambert_albedo.b * le.b;
	assert_means(m, want, 0.01, "furnace");
	world_free(&w);
}

/* A small Cornell box whose sphere is `diffuse` or a MERL Lambertian. */
static void
cornell(struct world *w, const char *sphere_bsdf)
{
	char xml[4096];
	struct pm_error err;
	static const char *const walls[] = {
	    "<rotate x=\"1\" angle=\"-90\"/>",
	    "<rotate x=\"1\" angle=\"90\"/><translate y=\"2\"/>",
	    "<translate y=\"1\" z=\"-1\"/>",
	    "<rotate y=\"1\" angle=\"90\"/><translate x=\"-1\" y=\"1\"/>",
	    "<rotate y=\"1\" angle=\"-90\"/><translate x=\"1\" y=\"1\"/>",
	};
	static const char *const col[] = {"0.7", "0.7", "0.7",
	    "0.6, 0.1, 0.1", "0.1, 0.5, 0.1"};
	size_t n = 0;
	int i;

	n += (size_t)snprintf(xml + n, sizeof(xml) - n,
	    "<scene version=\"3.0.0\"><sensor type=\"perspective\">"
	    "<float name=\"fov\" value=\"40\"/><transform name=\"to_world\">"
	    "<lookat origin=\"0, 1, 3.8\" target=\"0, 1, 0\" up=\"0, 1, 0\"/>"
	    "</transform><film type=\"hdrfilm\"><integer name=\"width\" "
	    "value=\"40\"/><integer name=\"height\" value=\"40\"/>"
	    "<rfilter type=\"box\"/></film></sensor>");
	for (i = 0; i < 5; i++)
		n += (size_t)snprintf(xml + n, sizeof(xml) - n,
		    "<shape type=\"rectangle\"><transform name=\"to_world\">%s"
		    "</transform><bsdf type=\"diffuse\"><rgb name=\"reflectance"
		    "\" value=\"%s\"/></bsdf></shape>", walls[i], col[i]);
	n += (size_t)snprintf(xml + n, sizeof(xml) - n,
	    "<shape type=\"sphere\"><point name=\"center\" x=\"0\" y=\"0.6\" "
	    "z=\"0\"/><float name=\"radius\" value=\"0.6\"/>%s</shape>"
	    "<shape type=\"rectangle\"><transform name=\"to_world\">"
	    "<scale x=\"0.3\" y=\"0.3\"/><rotate x=\"1\" angle=\"90\"/>"
	    "<translate y=\"1.99\"/></transform><emitter type=\"area\">"
	    "<rgb name=\"radiance\" value=\"12, 10, 8\"/></emitter></shape>"
	    "</scene>", sphere_bsdf);
	assert_true(n < sizeof(xml));
	assert_int_equal(pm_scene_load_string(xml, n, "cornell.xml", dir, NULL,
	    0, &w->scene, &err), PM_OK);
	world_ready(w);
}

static void
test_cornell(void **state)
{
	static const char diffuse[] = "<bsdf type=\"diffuse\"><rgb name="
	    "\"reflectance\" value=\"0.6, 0.45, 0.3\"/></bsdf>";
	static const char merl_data[] = "<bsdf type=\"merl\"><string name="
	    "\"filename\" value=\"lambert.binary\"/></bsdf>";
	static const char merl_interp[] = "<bsdf type=\"merl\"><string name="
	    "\"filename\" value=\"lambert.binary\"/><boolean name="
	    "\"interpolate\" value=\"true\"/></bsdf>";
	struct world w;
	double ref[3], m[3], pref[3];

	(void)state;
	cornell(&w, diffuse);
	render_mean(&w, PM_METHOD_PATH, 96, ref);
	world_photons(&w, 100000);
	render_mean(&w, PM_METHOD_PHOTON, 8, pref);
	world_free(&w);

	cornell(&w, merl_data);
	render_mean(&w, PM_METHOD_PATH, 96, m);
	assert_means(m, ref, 0.01, "cornell, path, merl");
	world_photons(&w, 100000);
	render_mean(&w, PM_METHOD_PHOTON, 8, m);
	assert_means(m, pref, 0.01, "cornell, photons, merl");
	world_free(&w);

	cornell(&w, merl_interp);
	render_mean(&w, PM_METHOD_PATH, 96, m);
	assert_means(m, ref, 0.01, "cornell, path, merl interpolated");
	world_free(&w);
}

/* ---- broken files ---- */

static void
expect_parse(const unsigned char *src, size_t len, enum pm_err code,
    const char *words)
{
	/* an exact-size copy, so that a read past the end trips ASan */
	unsigned char *p = malloc(len ? len : 1);
	struct pm_merl *m = (struct pm_merl *)1;
	struct pm_error err;

	assert_non_null(p);
	if (len)
		memcpy(p, src, len);
	err.msg[0] = '\0';
	assert_int_equal(pm_merl_parse(p, len, "broken.binary", &m, &err),
	    code);
	assert_null(m);
	print_message("%zu bytes: %s\n", len, err.msg);
	assert_non_null(strstr(err.msg, "broken.binary"));
	assert_non_null(strstr(err.msg, words));
	free(p);
}

static void
test_broken_buffers(void **state)
{
	static const size_t cuts[] = {1, 4, 11, 12, 13, 20, 1000,
	    12 + 8 * (size_t)PM_MERL_N, PM_MERL_FILE_SIZE / 2,
	    PM_MERL_FILE_SIZE - 8, PM_MERL_FILE_SIZE - 1};
	unsigned char *big;
	const char *text = "<?xml version=\"1.0\"?><scene/>\n";
	size_t i;

	(void)state;
	expect_parse(gold_buf, 0, PM_ERR_FORMAT, "empty");
	for (i = 0; i < sizeof(cuts) / sizeof(cuts[0]); i++)
		expect_parse(gold_buf, cuts[i], cuts[i] < 12 ?
		    PM_ERR_TRUNCATED : PM_ERR_TRUNCATED, cuts[i] < 12 ?
		    "too short" : "truncated");
	expect_parse((const unsigned char *)text, strlen(text), PM_ERR_FORMAT,
	    "not a MERL BRDF");
	big = malloc(PM_MERL_FILE_SIZE + 8);
	assert_non_null(big);
	memcpy(big, gold_buf, PM_MERL_FILE_SIZE);
	memset(big + PM_MERL_FILE_SIZE, 0, 8);
	expect_parse(big, PM_MERL_FILE_SIZE + 8, PM_ERR_FORMAT, "trailing");
	/* dimensions swapped: the same product, still not MERL's */
	big[0] = 180;
	big[8] = 90;
	expect_parse(big, PM_MERL_FILE_SIZE, PM_ERR_FORMAT, "180 x 90 x 90");
	/* a big-endian header */
	memset(big, 0, 12);
	big[3] = 90;
	big[7] = 90;
	big[11] = 180;
	expect_parse(big, PM_MERL_FILE_SIZE, PM_ERR_FORMAT, "dimensions");
	free(big);
}

static void
write_prefix(const char *path, const unsigned char *p, size_t n)
{
	FILE *f = fopen(path, "wb");

	assert_non_null(f);
	assert_int_equal(fwrite(p, 1, n, f), n);
	assert_int_equal(fclose(f), 0);
}

static void
test_broken_files(void **state)
{
	static const size_t sizes[] = {0, 7, 12, 5000000,
	    PM_MERL_FILE_SIZE - 1};
	char path[160], xml[512];
	struct pm_merl *m;
	struct pm_scene s;
	struct pm_error err;
	size_t i;

	(void)state;
	snprintf(path, sizeof(path), "%s/broken.binary", dir);
	for (i = 0; i < sizeof(sizes) / sizeof(sizes[0]); i++) {
		write_prefix(path, gold_buf, sizes[i]);
		assert_int_not_equal(pm_merl_read(path, &m, &err), PM_OK);
		assert_null(m);
		print_message("%zu bytes: %s\n", sizes[i], err.msg);
		assert_non_null(strstr(err.msg, path));
	}
	/* a scene naming it says where, and what */
	snprintf(xml, sizeof(xml), "<scene version=\"3.0.0\">\n<bsdf "
	    "type=\"merl\"><string name=\"filename\" value=\"broken.binary\"/>"
	    "</bsdf></scene>");
	assert_int_equal(pm_scene_load_string(xml, strlen(xml), "b.xml", dir,
	    NULL, 0, &s, &err), PM_ERR_TRUNCATED);
	print_message("%s\n", err.msg);
	assert_non_null(strstr(err.msg, "b.xml:2"));
	assert_non_null(strstr(err.msg, "broken.binary"));
	unlink(path);
	assert_int_equal(pm_merl_read(path, &m, &err), PM_ERR_IO);
	assert_int_equal(pm_scene_load_string(xml, strlen(xml), "b.xml", dir,
	    NULL, 0, &s, &err), PM_ERR_IO);
}

int
main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_write_read_exact),
		cmocka_unit_test(test_writer_marks_horizon),
		cmocka_unit_test(test_interpolation),
		cmocka_unit_test(test_loader_shares_tables),
		cmocka_unit_test(test_albedo),
		cmocka_unit_test(test_reciprocity),
		cmocka_unit_test(test_sampling_follows_pdf),
		cmocka_unit_test(test_sampling_grazing_cells),
		cmocka_unit_test(test_sample_weights),
		cmocka_unit_test(test_degenerate_directions),
		cmocka_unit_test(test_furnace),
		cmocka_unit_test(test_cornell),
		cmocka_unit_test(test_broken_buffers),
		cmocka_unit_test(test_broken_files),
	};

	return cmocka_run_group_tests(tests, setup, teardown);
}
