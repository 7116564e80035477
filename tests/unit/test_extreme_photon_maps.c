/*
 * test_extreme_photon_maps.c: photon maps at their extremes.
 *
 *  - a million photons at one point, on a plane, on a line: the kd-tree
 *    builds, verifies and answers queries (test_kdtree.c covers the same
 *    shapes at small sizes against brute force);
 *  - k larger than the map, a radius of zero, maps of one and no photons,
 *    through queries and through the file (plain, compressed, mapped);
 *  - the fixed-radius estimate of progressive photon mapping sums every
 *    photon in its radius: with 2^22 photons in it the sum must still be
 *    right (a float sum of equal terms stops growing at 2^24 of them);
 *  - with PM_TEST_BIG=1 in the environment (2.3 GB of disk, about 3 GB of
 *    memory, some seconds): a map file of more than 2^31 bytes of photons
 *    (64-bit offsets) written and read back, and the fixed-radius sum over
 *    1.5 * 2^24 photons.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/statvfs.h>
#include <unistd.h>

#include <cmocka.h>

#include "../../common/kdtree.h"
#include "../../common/render.h"
#include "../../common/world.h"
#include "../../formats/pmap.h"
#include "../../formats/scene_xml.h"
#include "tmpdir.h"

static bool
big_tests(void)
{
	const char *e = getenv("PM_TEST_BIG");

	return e != NULL && strcmp(e, "1") == 0;
}

static struct pm_photon *
photons(size_t n, int shape, uint64_t seed)
{
	struct pm_photon *p = calloc(n ? n : 1, sizeof(*p));
	struct pm_rng rng = pm_rng_seed(seed, 0, 0);
	size_t i;

	assert_non_null(p);
	for (i = 0; i < n; i++) {
		float u = pm_rng_float(&rng), v = pm_rng_float(&rng);

		switch (shape) {
		case 0:		/* one point */
			p[i].pos[0] = 1.0f;
			p[i].pos[1] = 2.0f;
			p[i].pos[2] = 3.0f;
			break;
		case 1:		/* a plane */
			p[i].pos[0] = u;
			p[i].pos[1] = 0.5f;
			p[i].pos[2] = v;
			break;
		default:	/* a line */
			p[i].pos[0] = u;
			p[i].pos[1] = 2.0f * u;
			p[i].pos[2] = -u;
			break;
		}
		pm_rgbe_pack(pm_rgb1(1.0f), 0.5f, p[i].power);
	}
	return p;
}

/* The k-th smallest squared distance from q, by brute force. */
static float
kth_d2(const struct pm_photon *p, size_t n, const float q[3], size_t k)
{
	float *d = malloc(n * sizeof(*d)), r;
	size_t i, j;

	assert_non_null(d);
	for (i = 0; i < n; i++) {
		float dx = p[i].pos[0] - q[0], dy = p[i].pos[1] - q[1];
		float dz = p[i].pos[2] - q[2];

		d[i] = dx * dx + dy * dy + dz * dz;
	}
	/* k is small: k passes of selection. */
	for (j = 0; j < k; j++) {
		size_t m = j;

		for (i = j + 1; i < n; i++)
			if (d[i] < d[m])
				m = i;
		r = d[m];
		d[m] = d[j];
		d[j] = r;
	}
	r = d[k - 1];
	free(d);
	return r;
}

static void
test_million_degenerate(void **state)
{
	const size_t n = 1u << 20, k = 50;
	struct pm_knn out[50];
	struct pm_error err;
	int shape;

	(void)state;
	for (shape = 0; shape < 3; shape++) {
		struct pm_photon *p = photons(n, shape, 7 + (uint64_t)shape);
		struct pm_rng rng = pm_rng_seed(99, (uint64_t)shape, 0);
		struct pm_kd_range it;
		size_t bad, found, i, count;
		uint32_t idx;
		float d2;

		assert_int_equal(pm_kdtree_build(p, n, 2, &err), PM_OK);
		assert_true(pm_kdtree_verify(p, n, &bad));
		for (i = 0; i < 8; i++) {
			float q[3] = {pm_rng_float(&rng), pm_rng_float(&rng),
			    pm_rng_float(&rng)};
			float want;

			if (i == 0) {	/* on the data */
				q[0] = p[n / 3].pos[0];
				q[1] = p[n / 3].pos[1];
				q[2] = p[n / 3].pos[2];
			}
			found = pm_kdtree_knn(p, n, q, k, INFINITY, 0, 0, out);
			assert_int_equal(found, k);
			pm_knn_sort(out, found);
			want = kth_d2(p, n, q, k);
			assert_true(out[k - 1].d2 == want);
		}
		/* All of the one-point set lies within any radius of it. */
		if (shape == 0) {
			const float q[3] = {1.0f, 2.0f, 3.0f};

			assert_int_equal(pm_kdtree_radius(p, n, q, 0.0f, 0, 0, out, k), n);
			count = 0;
			pm_kdtree_range_init(&it, p, n, q, 1e-6f, 0, 0);
			while (pm_kdtree_range_next(&it, &idx, &d2)) {
				assert_true(idx < n && d2 == 0.0f);
				count++;
			}
			assert_int_equal(count, n);
		}
		free(p);
	}
}

/* k beyond the map, radius zero, one photon, none. */
static void
test_small_maps_and_zero_radius(void **state)
{
	static const size_t sizes[] = {0, 1, 2, 5};
	struct pm_knn out[100];
	struct pm_error err;
	size_t s;

	(void)state;
	for (s = 0; s < sizeof(sizes) / sizeof(sizes[0]); s++) {
		size_t n = sizes[s], found, i, bad;
		struct pm_photon *p = photons(n, 1, 3);
		const float far[3] = {10.0f, 10.0f, 10.0f};
		float q[3] = {0.5f, 0.5f, 0.5f};
		struct pm_kd_range it;
		uint32_t idx;
		float d2;

		assert_int_equal(pm_kdtree_build(p, n, 1, &err), PM_OK);
		assert_true(pm_kdtree_verify(p, n, &bad));
		found = pm_kdtree_knn(p, n, far, 100, INFINITY, 0, 0, out);
		assert_int_equal(found, n);
		pm_knn_sort(out, found);
		for (i = 0; i + 1 < found; i++)
			assert_true(out[i].d2 <= out[i + 1].d2);
		if (n > 0) {
			q[0] = p[0].pos[0];
			q[1] = p[0].pos[1];
			q[2] = p[0].pos[2];
		}
		/* Radius zero: at most the photons exactly at q. */
		found = pm_kdtree_knn(p, n, q, 100, 0.0f, 0, 0, out);
		assert_true(found <= n);
		for (i = 0; i < found; i++)
			assert_true(out[i].d2 == 0.0f);
		pm_kdtree_range_init(&it, p, n, q, 0.0f, 0, 0);
		i = 0;
		while (pm_kdtree_range_next(&it, &idx, &d2))
			assert_true(++i <= n && d2 == 0.0f);
		/* NaN and negative radii find nothing. */
		assert_int_equal(pm_kdtree_knn(p, n, q, 10, NAN, 0, 0, out), 0);
		assert_int_equal(pm_kdtree_knn(p, n, q, 10, -1.0f, 0, 0, out), 0);
		free(p);
	}
}

/* Maps of one and of no photons survive the file, in every form. */
static void
test_tiny_map_files(void **state)
{
	struct pm_error err;
	char path[128];
	int n, z, mm;

	(void)state;
	snprintf(path, sizeof(path), "%s/tiny.pmap", pm_test_dir);
	for (n = 0; n <= 1; n++)
		for (z = 0; z <= 1; z++)
			for (mm = 0; mm <= 1; mm++) {
				struct pm_pmap m, r;
				struct pm_photon *p = photons((size_t)n, 1, 5);

				memset(&m, 0, sizeof(m));
				m.nmaps = 1;
				m.maps[0].kind = PM_MAP_GLOBAL;
				m.maps[0].count = (uint64_t)n;
				m.maps[0].emitted = 10;
				m.maps[0].balanced = true;
				if (n > 0)
					memcpy(m.maps[0].lo, p[0].pos, sizeof(m.maps[0].lo)),
					memcpy(m.maps[0].hi, p[0].pos, sizeof(m.maps[0].hi));
				p[0].flags = PM_KD_LEAF;
				m.maps[0].photons = p;
				if (pm_pmap_write(path, &m, z != 0, &err) != PM_OK) {
					print_error("%s\n", err.msg);
					fail();
				}
				if (pm_pmap_read(path, &r, mm != 0, &err) != PM_OK) {
					print_error("%s\n", err.msg);
					fail();
				}
				assert_int_equal(r.nmaps, 1);
				assert_int_equal(r.maps[0].count, (uint64_t)n);
				assert_int_equal(r.maps[0].emitted, 10);
				if (n > 0)
					assert_memory_equal(r.maps[0].photons, p, sizeof(*p));
				pm_pmap_free(&r);
				free(p);
				unlink(path);
			}
}

/* A white diffuse floor (albedo 1) and a gather ray straight down onto
 * the origin, where n photons of power 1 arrive straight down too. */
static void
fixed_radius_sum(size_t n)
{
	struct pm_scene s;
	struct pm_world world;
	struct pm_photon_maps maps;
	struct pm_render_ctx ctx;
	struct pm_error err;
	struct pm_photon *p, one;
	struct pm_rng rng = pm_rng_seed(1, 2, 3);
	struct pm_rgb L;
	const char *xml = "<scene version=\"3.0.0\"><shape type=\"rectangle\">"
	    "<bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"1\"/></bsdf>"
	    "</shape></scene>";
	double r2 = 0.01, want;
	size_t i;

	assert_int_equal(pm_scene_load_string(xml, strlen(xml), "floor.xml",
	    pm_test_dir, NULL, 0, &s, &err), PM_OK);
	assert_int_equal(pm_world_init(&world, &s, &err), PM_OK);
	memset(&one, 0, sizeof(one));
	pm_rgbe_pack(pm_rgb1(1.0f), 0.5f, one.power);
	pm_dir_pack(pm_v3(0, 0, 1), one.dir);
	/* On the floor, lit from above: the normal estimates compare with. */
	pm_dir_pack(pm_v3(0, 0, 1), one.normal);
	one.flags = PM_KD_LEAF | PM_PHOTON_VIA_DIFFUSE;
	/* Coincident photons are a valid kd-tree in any order. */
	p = malloc(n * sizeof(*p));
	assert_non_null(p);
	for (i = 0; i < n; i++)
		p[i] = one;
	memset(&maps, 0, sizeof(maps));
	maps.global = p;
	maps.nglobal = n;
	maps.global_scale = 1.0f / (float)n;
	maps.global_r2 = (float)r2;
	maps.caustic_r2 = (float)r2;
	maps.lookup_size = 100;
	maps.direct_samples = 1;
	maps.fixed_radius = true;
	memset(&ctx, 0, sizeof(ctx));
	ctx.scene = &s;
	ctx.accel = world.accel;
	ctx.lights = &world.lights;
	ctx.max_depth = -1;
	ctx.rr_depth = 5;
	ctx.maps = &maps;
	L = pm_photon_li(&ctx, pm_v3(0, 0, 1), pm_v3(0, 0, -1), 0.0f, INFINITY,
	    &rng);
	/* f = 1 / pi; sum of n photons of power 1 / cos 1, times 1 / n over
	 * pi r^2. */
	want = 1.0 / (M_PI * M_PI * r2);
	print_message("%zu photons in the radius: L = %.6g (want %.6g)\n", n,
	    (double)L.r, want);
	assert_true(fabs(L.r - want) < 1e-3 * want);
	free(p);
	pm_world_free(&world);
	pm_scene_free(&s);
}

static void
test_fixed_radius_many_photons(void **state)
{
	(void)state;
	fixed_radius_sum(1000);
	fixed_radius_sum((size_t)1 << 22);
	if (big_tests())
		fixed_radius_sum(((size_t)3 << 23));
	else
		print_message("1.5 * 2^24 photons: skipped (PM_TEST_BIG=1 runs it)\n");
}

/* 2^31 bytes and more of photons: offsets and sizes past 32 bits. */
static void
test_map_past_2gb(void **state)
{
	const size_t n = ((size_t)1 << 31) / sizeof(struct pm_photon) + 1000;
	struct pm_pmap m, r;
	struct pm_error err;
	struct statvfs fs;
	char path[128];
	struct pm_photon *p;
	int mm;

	(void)state;
	if (!big_tests()) {
		print_message("skipped (PM_TEST_BIG=1 runs it)\n");
		return;
	}
	if (statvfs(pm_test_dir, &fs) != 0 ||
	    (double)fs.f_bavail * (double)fs.f_frsize < 3.0 * (double)n *
	    (double)sizeof(struct pm_photon)) {
		print_message("skipped: not enough disk in %s\n", pm_test_dir);
		return;
	}
	snprintf(path, sizeof(path), "%s/big.pmap", pm_test_dir);
	/* calloc: untouched zero pages cost no memory until read. */
	p = calloc(n, sizeof(*p));
	assert_non_null(p);
	p[n - 1].pos[0] = 1.0f;
	pm_rgbe_pack(pm_rgb1(2.0f), 0.5f, p[n - 1].power);
	memset(&m, 0, sizeof(m));
	m.nmaps = 2;
	m.maps[0].kind = PM_MAP_GLOBAL;
	m.maps[0].count = n;
	m.maps[0].emitted = n;
	m.maps[0].hi[0] = 1.0f;
	m.maps[0].photons = p;
	/* a second map after the first: its offset is past 2^31 */
	m.maps[1].kind = PM_MAP_CAUSTIC;
	m.maps[1].count = 1;
	m.maps[1].emitted = 3;
	m.maps[1].lo[0] = m.maps[1].hi[0] = 1.0f;
	m.maps[1].photons = p + n - 1;
	if (pm_pmap_write(path, &m, false, &err) != PM_OK) {
		print_error("%s\n", err.msg);
		free(p);
		unlink(path);
		fail();
	}
	free(p);
	for (mm = 1; mm >= 0; mm--) {
		if (pm_pmap_read(path, &r, mm != 0, &err) != PM_OK) {
			print_error("%s\n", err.msg);
			unlink(path);
			fail();
		}
		assert_int_equal(r.nmaps, 2);
		assert_int_equal(r.maps[0].count, n);
		assert_true(r.maps[0].photons[n - 1].pos[0] == 1.0f);
		assert_int_equal(r.maps[1].count, 1);
		assert_int_equal(r.maps[1].emitted, 3);
		assert_true(r.maps[1].photons[0].pos[0] == 1.0f);
		assert_true(pm_rgbe_unpack(r.maps[1].photons[0].power).g == 2.0f);
		pm_pmap_free(&r);
		print_message("%zu photons (%zu bytes) read back (%s)\n", n,
		    n * sizeof(*p), mm ? "mapped" : "copied");
	}
	unlink(path);
}

int
main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_million_degenerate),
		cmocka_unit_test(test_small_maps_and_zero_radius),
		cmocka_unit_test(test_tiny_map_files),
		cmocka_unit_test(test_fixed_radius_many_photons),
		cmocka_unit_test(test_map_past_2gb),
	};

	return cmocka_run_group_tests(tests, pm_tmpdir_setup, pm_tmpdir_teardown);
}
