/*
 * test_kdbuild.c: pm_kdtree_build lays out exactly the tree kdtree.h
 * describes, and the same one it always has.
 *
 * A small tree of photons with distinct coordinates has one layout only
 * (each subtree's set of photons, hence its bounds, axis and median, is
 * fixed by its parent's), which a plain recursive builder here (sort the
 * range on the widest axis of its exact bounds, take the middle) makes
 * too: the two must agree byte for byte.  Larger trees choose the axis
 * from a sample of the range as it lies, and ties leave the order of equal
 * keys to the selection, so there the layout is pinned by a hash of the
 * output of the build as of main 4f226f1 (the layout pm-balance has always
 * written), on random, tied, duplicate, flat and single-point sets that
 * cross the build's thresholds, with 1, 2 and 4 threads.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "../../common/kdtree.h"

static uint64_t
next(uint64_t *s)
{
	*s ^= *s << 13;
	*s ^= *s >> 7;
	*s ^= *s << 17;
	return *s;
}

static float
unit(uint64_t *s)
{
	return (float)(next(s) >> 40) * (1.0f / 16777216.0f);
}

enum kind { UNIFORM, TIES, POINT, PLANE, DUPLICATES, WIDE };

static struct pm_photon *
make_set(size_t n, enum kind kind, uint64_t seed)
{
	struct pm_photon *p = calloc(n ? n : 1, sizeof(*p));
	uint64_t s = seed * 0x9e3779b97f4a7c15u + 1;
	size_t i;
	int a;

	assert_non_null(p);
	for (i = 0; i < n; i++) {
		uint32_t id = (uint32_t)i;

		for (a = 0; a < 3; a++)
			switch (kind) {
			case UNIFORM:
				p[i].pos[a] = unit(&s);
				break;
			case TIES:
				p[i].pos[a] = (float)(next(&s) % 8);
				break;
			case POINT:
				p[i].pos[a] = 0.5f;
				break;
			case PLANE:
				p[i].pos[a] = a == 1 ? -2.0f : unit(&s);
				break;
			case DUPLICATES:
				/* A few hundred distinct points, each many
				 * times, and signed zeros. */
				p[i].pos[a] = (float)(next(&s) % 7) - 3.0f;
				if (p[i].pos[a] == 0.0f && (next(&s) & 1))
					p[i].pos[a] = -0.0f;
				break;
			case WIDE:
				p[i].pos[a] = (i & 1 ? 1e6f : 1e-6f) *
				    (unit(&s) - 0.25f);
				break;
			}
		memcpy(p[i].power, &id, sizeof(id));
		p[i].flags = (uint8_t)(next(&s) & 15);
		p[i].depth = (uint8_t)i;
	}
	return p;
}

static uint64_t
fnv(const void *b, size_t len)
{
	const unsigned char *c = b;
	uint64_t h = 1469598103934665603u;
	size_t i;

	for (i = 0; i < len; i++) {
		h ^= c[i];
		h *= 1099511628211u;
	}
	return h;
}

static int ref_axis;

static int
cmp_key(const void *a, const void *b)
{
	float x = ((const struct pm_photon *)a)->pos[ref_axis];
	float y = ((const struct pm_photon *)b)->pos[ref_axis];

	return x < y ? -1 : x > y;
}

/* The layout of kdtree.h, plainly: exact bounds, a sort, the middle. */
static void
ref_build(struct pm_photon *p, size_t n)
{
	float lo[3], hi[3], e[3];
	size_t i, m = n / 2;
	int a, ax;

	if (n == 0)
		return;
	if (n == 1) {
		p[0].flags = (uint8_t)((p[0].flags & ~PM_KD_AXIS_MASK) |
		    PM_KD_LEAF);
		return;
	}
	for (a = 0; a < 3; a++)
		lo[a] = hi[a] = p[0].pos[a];
	for (i = 1; i < n; i++)
		for (a = 0; a < 3; a++) {
			lo[a] = p[i].pos[a] < lo[a] ? p[i].pos[a] : lo[a];
			hi[a] = p[i].pos[a] > hi[a] ? p[i].pos[a] : hi[a];
		}
	for (a = 0; a < 3; a++)
		e[a] = hi[a] - lo[a];
	ax = e[0] >= e[1] && e[0] >= e[2] ? 0 : e[1] >= e[2] ? 1 : 2;
	ref_axis = ax;
	qsort(p, n, sizeof(*p), cmp_key);
	p[m].flags = (uint8_t)((p[m].flags & ~PM_KD_AXIS_MASK) | ax);
	ref_build(p, m);
	ref_build(p + m + 1, n - m - 1);
}

/* Small trees of distinct coordinates: the build is the reference's. */
static void
test_reference_layout(void **state)
{
	static const size_t sizes[] = { 1, 2, 3, 4, 7, 12, 13, 20, 31, 32, 33,
	    47, 64, 100, 255, 256, 300, 511 };
	size_t s, t, i;
	struct pm_error err;

	(void)state;
	for (s = 0; s < sizeof(sizes) / sizeof(sizes[0]); s++)
		for (t = 0; t < 4; t++) {
			size_t n = sizes[s];
			struct pm_photon *p = make_set(n, UNIFORM, 100 * s + t);
			struct pm_photon *r = malloc(n * sizeof(*r));
			struct pm_photon *q = malloc(n * sizeof(*q));
			uint64_t g = 12345 + s * 7 + t;
			int th, a;

			assert_non_null(r);
			assert_non_null(q);
			/* Distinct coordinates on every axis: 0..n-1 shuffled
			 * per axis, scaled unevenly so that the widest axis
			 * varies with t. */
			for (i = 0; i < n; i++) {
				p[i].pos[0] = (float)i * (1.0f + (float)t);
				p[i].pos[1] = (float)i * 2.0f;
				p[i].pos[2] = (float)i * (t == 3 ? 5.0f : 0.5f);
			}
			for (a = 1; a < 3; a++)
				for (i = n; i > 1; i--) {
					size_t j = (size_t)(next(&g) % i);
					float x = p[i - 1].pos[a];

					p[i - 1].pos[a] = p[j].pos[a];
					p[j].pos[a] = x;
				}
			memcpy(r, p, n * sizeof(*r));
			ref_build(r, n);
			for (th = 1; th <= 3; th += 2) {
				memcpy(q, p, n * sizeof(*q));
				assert_int_equal(pm_kdtree_build(q, n, th,
				    &err), PM_OK);
				assert_memory_equal(q, r, n * sizeof(*q));
			}
			free(p);
			free(r);
			free(q);
		}
}

/* Hashes of the trees main 4f226f1 built from make_set(n, kind, 7). */
struct golden {
	enum kind kind;
	size_t n;
	uint64_t hash;
};

static const struct golden goldens[] = {
	{ UNIFORM, 1000, UINT64_C(0x90734dba4437ee2d) },
	{ UNIFORM, 4097, UINT64_C(0x0ac6a075ee5aa24f) },
	{ UNIFORM, 65536, UINT64_C(0x473cf67a2e12df33) },
	{ UNIFORM, 65537, UINT64_C(0x95780835ad412e42) },
	{ UNIFORM, 100003, UINT64_C(0x1576bea7247d967e) },
	{ UNIFORM, 300000, UINT64_C(0x140785f00636c9ef) },
	{ TIES, 1000, UINT64_C(0xd3cd22704b6f1e48) },
	{ TIES, 4097, UINT64_C(0x9785faee92468653) },
	{ TIES, 65536, UINT64_C(0x30c9f9da0e7a1e5a) },
	{ TIES, 65537, UINT64_C(0xa9dd725d871897e6) },
	{ TIES, 100003, UINT64_C(0xe407c30ccd8d45ef) },
	{ TIES, 300000, UINT64_C(0xb23e083998595828) },
	{ POINT, 1000, UINT64_C(0x5bb2651922fbf5c8) },
	{ POINT, 4097, UINT64_C(0x9f32b6582ca2618a) },
	{ POINT, 65536, UINT64_C(0x00dabd1d15800433) },
	{ POINT, 65537, UINT64_C(0x93d43ce8dc76c1f3) },
	{ PLANE, 1000, UINT64_C(0xf20b0d652031fe64) },
	{ PLANE, 4097, UINT64_C(0x7ff143863e555474) },
	{ PLANE, 65536, UINT64_C(0x198415291f730c54) },
	{ PLANE, 65537, UINT64_C(0x4077a1da522e9e58) },
	{ PLANE, 100003, UINT64_C(0x3f107905d9b2d51c) },
	{ PLANE, 300000, UINT64_C(0x92b3c4ff47e6bb12) },
	{ DUPLICATES, 1000, UINT64_C(0x78a65763c836629c) },
	{ DUPLICATES, 4097, UINT64_C(0x2e66851fc82d6251) },
	{ DUPLICATES, 65536, UINT64_C(0x1dd4577dd3d7380f) },
	{ DUPLICATES, 65537, UINT64_C(0x76c1634b73468b2b) },
	{ DUPLICATES, 100003, UINT64_C(0xd2d4228323329115) },
	{ DUPLICATES, 300000, UINT64_C(0xad5f93cb02cb7cdd) },
	{ WIDE, 1000, UINT64_C(0x720c037ef5d799f3) },
	{ WIDE, 4097, UINT64_C(0xee83e629b9582fe7) },
	{ WIDE, 65536, UINT64_C(0xa0261b96c191ed64) },
	{ WIDE, 65537, UINT64_C(0xfc06592d592be8db) },
	{ WIDE, 100003, UINT64_C(0xdb633ab5973afec8) },
	{ WIDE, 300000, UINT64_C(0x24770399c8fb2843) },
};

static void
test_golden_layout(void **state)
{
	size_t g;
	struct pm_error err;

	(void)state;
	for (g = 0; g < sizeof(goldens) / sizeof(goldens[0]); g++) {
		size_t n = goldens[g].n;
		struct pm_photon *p = make_set(n, goldens[g].kind, 7);
		struct pm_photon *q = malloc(n * sizeof(*q));
		int th;

		assert_non_null(q);
		for (th = 1; th <= 4; th *= 2) {
			uint64_t h;

			memcpy(q, p, n * sizeof(*q));
			assert_int_equal(pm_kdtree_build(q, n, th, &err),
			    PM_OK);
			h = fnv(q, n * sizeof(*q));
			if (h != goldens[g].hash)
				print_error("kind %d, n %zu, %d threads: "
				    "hash %016llx, expected %016llx\n",
				    (int)goldens[g].kind, n, th,
				    (unsigned long long)h,
				    (unsigned long long)goldens[g].hash);
			assert_true(h == goldens[g].hash);
		}
		free(p);
		free(q);
	}
}

int
main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_reference_layout),
		cmocka_unit_test(test_golden_layout),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
