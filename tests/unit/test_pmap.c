/*
 * test_pmap.c: the photon-map file, version 2.  Files written by
 * pm_pmap_write must read back identical, compressed or not, memory-mapped
 * or not, with 0 to 3 maps (global, caustic, irradiance) and empty maps,
 * from files, pipes and standard input; the writer's bytes must equal
 * those of a file built here from man/pmap.5 alone; a version 1 file must
 * be refused in one line; and damaged files -- every prefix of a small
 * file, every single flipped bit, and forged headers with valid checksums
 * (bad counts, offsets past the end, count x 24 overflow, reserved fields
 * and record bytes, irradiance maps that emitted paths, unknown versions
 * and kinds) -- must each fail with their own clear error.  Offsets
 * beyond 4 GiB are tested on sparse files, which take no disk.
 */
#define _GNU_SOURCE	/* O_TMPFILE */
#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>
#include <zlib.h>

#include <cmocka.h>

#include "../../formats/pmap.h"
#include "tmpdir.h"

#define BUFCAP	(1 << 20)
#define PATHCAP	128

/* --- Helpers --- */

static uint64_t
rnd(uint64_t *s)
{
	*s ^= *s << 13;
	*s ^= *s >> 7;
	*s ^= *s << 17;
	return *s;
}

static float
rndf(uint64_t *s)
{
	return (float)(rnd(s) >> 40) / (float)(1u << 24);
}

/* Photons such as a shooter would store: on the walls and floor of a
 * box, with powers around one colour and directions over a hemisphere. */
static struct pm_photon *
make_photons(size_t n, uint64_t seed)
{
	struct pm_photon *p = calloc(n ? n : 1, sizeof(*p));
	uint64_t s = seed * 2654435761u + 88172645463325252ull;
	struct pm_vec3 d;
	size_t i;
	int wall;

	assert_non_null(p);
	for (i = 0; i < n; i++) {
		wall = (int)(rnd(&s) % 3);
		p[i].pos[0] = wall == 0 ? -1.0f : rndf(&s) * 2.0f - 1.0f;
		p[i].pos[1] = wall == 1 ? 0.0f : rndf(&s) * 2.0f;
		p[i].pos[2] = wall == 2 ? 1.0f : rndf(&s) * 2.0f - 1.0f;
		pm_rgbe_pack(pm_rgb(0.5f + rndf(&s), 0.4f + 0.5f * rndf(&s),
		    0.3f * rndf(&s)), rndf(&s), p[i].power);
		d = pm_normalize(pm_v3(rndf(&s) - 0.5f, rndf(&s),
		    rndf(&s) - 0.5f));
		pm_dir_pack(d, p[i].dir);
		d = pm_normalize(pm_v3(rndf(&s) - 0.5f, rndf(&s) + 0.1f,
		    rndf(&s) - 0.5f));
		pm_dir_pack(d, p[i].normal);
		p[i].flags = (uint8_t)(rnd(&s) & (PM_PHOTON_VIA_DIFFUSE |
		    PM_PHOTON_CAUSTIC | PM_KD_AXIS_MASK));
		p[i].depth = (uint8_t)(rnd(&s) % 5);
	}
	return p;
}

static void
set_bounds(struct pm_map *a)
{
	uint64_t i;
	int k;

	for (k = 0; k < 3; k++)
		a->lo[k] = a->hi[k] = 0.0f;
	for (i = 0; i < a->count; i++)
		for (k = 0; k < 3; k++) {
			if (i == 0 || a->photons[i].pos[k] < a->lo[k])
				a->lo[k] = a->photons[i].pos[k];
			if (i == 0 || a->photons[i].pos[k] > a->hi[k])
				a->hi[k] = a->photons[i].pos[k];
		}
}

/* Irradiance records as pm-balance stores them: E in the power, the
 * surface normal, no direction, depth 0, only the kd-tree bits. */
static struct pm_photon *
make_irradiance(size_t n, uint64_t seed)
{
	struct pm_photon *p = make_photons(n, seed);
	size_t i;

	for (i = 0; i < n; i++) {
		p[i].dir[0] = p[i].dir[1] = 0;
		p[i].flags &= PM_KD_AXIS_MASK;
		p[i].depth = 0;
	}
	return p;
}

/* A map file in memory with nmaps maps of the given sizes: global,
 * caustic and irradiance, in that order. */
static void
make_pmap(struct pm_pmap *m, int nmaps, size_t n0, size_t n1, size_t n2)
{
	static const enum pm_map_kind kinds[3] = {
		PM_MAP_GLOBAL, PM_MAP_CAUSTIC, PM_MAP_IRRADIANCE
	};
	struct pm_error err;
	size_t n[3] = {n0, n1, n2};
	int i;

	memset(m, 0, sizeof(*m));
	m->scene_hash = 0x0123456789abcdefull;
	m->seed = 0xfedcba9876543210ull;
	m->effects = PM_EFFECT_GLOBAL | PM_EFFECT_CAUSTICS;
	m->max_depth = 7;
	assert_int_equal(pm_pmap_info_add(m, "tool", "pm-shoot", &err), PM_OK);
	assert_int_equal(pm_pmap_info_add(m, "seed", "42", &err), PM_OK);
	m->nmaps = nmaps;
	for (i = 0; i < nmaps; i++) {
		m->maps[i].kind = kinds[i];
		m->maps[i].count = n[i];
		m->maps[i].balanced = i >= 1;
		if (kinds[i] == PM_MAP_IRRADIANCE) {
			m->maps[i].radius = 0.125f;
			m->maps[i].photons = n[i] ? make_irradiance(n[i], 9u) :
			    NULL;
		} else {
			m->maps[i].emitted = n[i] / 2 + 1 + (uint64_t)i;
			m->maps[i].first_index = 1000u * (uint64_t)i;
			m->maps[i].photons = n[i] ? make_photons(n[i], 7u +
			    (uint64_t)i) : NULL;
		}
		set_bounds(&m->maps[i]);
	}
}

static void
assert_same(const struct pm_pmap *a, const struct pm_pmap *b)
{
	int i, k;

	assert_true(a->scene_hash == b->scene_hash);
	assert_true(a->seed == b->seed);
	assert_int_equal(a->effects, b->effects);
	assert_int_equal(a->max_depth, b->max_depth);
	assert_string_equal(a->info != NULL ? a->info : "",
	    b->info != NULL ? b->info : "");
	assert_int_equal(a->nmaps, b->nmaps);
	for (i = 0; i < a->nmaps; i++) {
		const struct pm_map *x = &a->maps[i], *y = &b->maps[i];

		assert_int_equal(x->kind, y->kind);
		assert_true(x->count == y->count);
		assert_true(x->emitted == y->emitted);
		assert_true(x->first_index == y->first_index);
		assert_int_equal(x->balanced, y->balanced);
		assert_true(x->radius == y->radius);
		for (k = 0; k < 3; k++) {
			assert_true(x->lo[k] == y->lo[k]);
			assert_true(x->hi[k] == y->hi[k]);
		}
		if (x->count > 0)
			assert_memory_equal(x->photons, y->photons,
			    x->count * sizeof(struct pm_photon));
		else
			assert_null(y->photons);
	}
}

/* A path in the test's directory, written into out. */
static char *
tpath(char out[PATHCAP], const char *name)
{
	snprintf(out, PATHCAP, "%s/%s", pm_test_dir, name);
	return out;
}

static size_t
slurp(const char *path, unsigned char *buf, size_t cap)
{
	FILE *f = fopen(path, "rb");
	size_t n;

	assert_non_null(f);
	n = fread(buf, 1, cap, f);
	assert_true(n < cap);
	fclose(f);
	return n;
}

/* Unlinks first: ext4 flushes a file truncated and rewritten on close,
 * which would make thousands of rewrites take seconds. */
static void
spit(const char *path, const unsigned char *buf, size_t n)
{
	FILE *f;

	unlink(path);
	f = fopen(path, "wb");
	assert_non_null(f);
	assert_true(fwrite(buf, 1, n, f) == n);
	assert_int_equal(fclose(f), 0);
}

static uint32_t
rd32(const unsigned char *p)
{
	return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 |
	    (uint32_t)p[3] << 24;
}

static void
wr16(unsigned char *p, uint16_t v)
{
	p[0] = (unsigned char)v;
	p[1] = (unsigned char)(v >> 8);
}

static void
wr32(unsigned char *p, uint32_t v)
{
	p[0] = (unsigned char)v;
	p[1] = (unsigned char)(v >> 8);
	p[2] = (unsigned char)(v >> 16);
	p[3] = (unsigned char)(v >> 24);
}

static void
wr64(unsigned char *p, uint64_t v)
{
	wr32(p, (uint32_t)v);
	wr32(p + 4, (uint32_t)(v >> 32));
}

static void
wrf(unsigned char *p, float f)
{
	uint32_t u;

	memcpy(&u, &f, 4);
	wr32(p, u);
}

/* Recomputes the header crc32 after a test has forged a field. */
static void
fix_crc(unsigned char *buf)
{
	uint32_t hs = rd32(buf + 12);

	wr32(buf + hs - 4, (uint32_t)crc32(0, buf, hs - 4));
}

/* Parses buf and checks the error code and that msg holds want. */
static void
expect_fail(const unsigned char *buf, size_t n, enum pm_err code,
    const char *want)
{
	struct pm_pmap m;
	struct pm_error err;

	memset(&err, 0, sizeof(err));
	if (pm_pmap_parse("t.pmap", buf, n, &m, &err) != code)
		fail_msg("expected code %d, got %d: %s", (int)code,
		    (int)err.code, err.msg);
	if (strncmp(err.msg, "t.pmap: ", 8) != 0 || strstr(err.msg, want) ==
	    NULL)
		fail_msg("message \"%s\" lacks \"%s\"", err.msg, want);
	assert_int_equal(m.nmaps, 0);
	assert_null(m.info);
}

/* Writes m and reads it back into the returned bytes. */
static size_t
write_bytes(const struct pm_pmap *m, bool compress, unsigned char *buf)
{
	struct pm_error err;
	char p[PATHCAP];
	size_t n;

	tpath(p, "w.pmap");
	if (pm_pmap_write(p, m, compress, &err) != PM_OK)
		fail_msg("%s", err.msg);
	n = slurp(p, buf, BUFCAP);
	unlink(p);
	return n;
}

/* --- A file built from man/pmap.5 alone --- */

struct spec_map {
	uint32_t kind, flags, compression;
	uint64_t count, emitted, first_index;
	float radius;
	const struct pm_photon *p;
};

struct spec {
	uint16_t major, minor;
	uint32_t effects, max_depth, entry_size, extra;
	uint64_t scene_hash, seed;
	const char *info;
	uint32_t nmaps;
	struct spec_map maps[3];
};

/* The file the specification describes for s, into out; its length. */
static size_t
spec_build(const struct spec *s, unsigned char *out)
{
	static unsigned char payload[3][65536];
	unsigned char *e;
	uint64_t off, stored[3];
	uint32_t isize = (uint32_t)strlen(s->info), hs, i;
	uLongf zlen;
	float lo[3], hi[3], x;
	uint64_t j;
	int k;

	hs = 64 + s->nmaps * s->entry_size + isize + s->extra + 4;
	memset(out, 0, BUFCAP);
	memcpy(out, "\x89" "PMAP\r\n\x1a", 8);
	wr16(out + 8, s->major);
	wr16(out + 10, s->minor);
	wr32(out + 12, hs);
	wr32(out + 20, s->effects);
	wr64(out + 24, s->scene_hash);
	wr64(out + 32, s->seed);
	wr32(out + 40, s->max_depth);
	wr32(out + 44, s->nmaps);
	wr32(out + 48, s->entry_size);
	wr32(out + 52, isize);
	memcpy(out + 64 + s->nmaps * s->entry_size, s->info, isize);
	off = hs;
	for (i = 0; i < s->nmaps; i++) {
		const struct spec_map *sm = &s->maps[i];

		for (j = 0; j < sm->count; j++) {
			unsigned char *r = payload[i] + 24 * j;

			assert_true(24 * (j + 1) <= sizeof(payload[0]));
			for (k = 0; k < 3; k++) {
				x = sm->p[j].pos[k];
				wrf(r + 4 * k, x);
				if (j == 0 || x < lo[k])
					lo[k] = x;
				if (j == 0 || x > hi[k])
					hi[k] = x;
			}
			memcpy(r + 12, sm->p[j].power, 4);
			memcpy(r + 16, sm->p[j].dir, 2);
			memcpy(r + 18, sm->p[j].normal, 2);
			r[20] = sm->p[j].flags;
			r[21] = sm->p[j].depth;
			memcpy(r + 22, sm->p[j].reserved, 2);
		}
		if (sm->count == 0)
			for (k = 0; k < 3; k++)
				lo[k] = hi[k] = 0.0f;
		off = (off + 63) / 64 * 64;
		e = out + 64 + i * s->entry_size;
		if (sm->compression == 1) {
			unsigned char raw[65536];

			memcpy(raw, payload[i], 24 * sm->count);
			zlen = sizeof(payload[i]);
			assert_int_equal(compress2(payload[i], &zlen, raw,
			    24 * sm->count, 1), Z_OK);
			stored[i] = zlen;
		} else
			stored[i] = 24 * sm->count;
		wr32(e, sm->kind);
		wr32(e + 4, sm->flags);
		wr32(e + 8, sm->compression);
		wr32(e + 12, (uint32_t)crc32(0, payload[i], (uInt)stored[i]));
		wr64(e + 16, sm->count);
		wr64(e + 24, sm->emitted);
		wr64(e + 32, sm->first_index);
		wr64(e + 40, off);
		wr64(e + 48, stored[i]);
		for (k = 0; k < 3; k++) {
			wrf(e + 56 + 4 * k, lo[k]);
			wrf(e + 68 + 4 * k, hi[k]);
		}
		wrf(e + 80, sm->radius);
		memcpy(out + off, payload[i], stored[i]);
		off += stored[i];
	}
	fix_crc(out);
	return off;
}

/* The spec for the maps of m. */
static void
spec_of(struct spec *s, const struct pm_pmap *m, uint32_t compression)
{
	int i;

	memset(s, 0, sizeof(*s));
	s->major = 2;
	s->entry_size = 96;
	s->effects = m->effects;
	s->max_depth = m->max_depth;
	s->scene_hash = m->scene_hash;
	s->seed = m->seed;
	s->info = m->info;
	s->nmaps = (uint32_t)m->nmaps;
	for (i = 0; i < m->nmaps; i++) {
		s->maps[i].kind = m->maps[i].kind;
		s->maps[i].flags = m->maps[i].balanced;
		s->maps[i].compression = compression;
		s->maps[i].count = m->maps[i].count;
		s->maps[i].emitted = m->maps[i].emitted;
		s->maps[i].first_index = m->maps[i].first_index;
		s->maps[i].radius = m->maps[i].radius;
		s->maps[i].p = m->maps[i].photons;
	}
}

/* --- Tests --- */

/* The example of man/pmap.5, byte for byte: version 2.0's golden file. */
static const unsigned char golden[216] = {
	0x89, 0x50, 0x4d, 0x41, 0x50, 0x0d, 0x0a, 0x1a,
	0x02, 0x00, 0x00, 0x00, 0xb9, 0x00, 0x00, 0x00,
	0x00, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00,
	0xef, 0xcd, 0xab, 0x89, 0x67, 0x45, 0x23, 0x01,
	0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
	0x00, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00,
	0x60, 0x00, 0x00, 0x00, 0x15, 0x00, 0x00, 0x00,
	0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
	0x01, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00,
	0x00, 0x00, 0x00, 0x00, 0xbc, 0xdf, 0xf7, 0xdc,
	0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
	0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
	0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
	0xc0, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
	0x18, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
	0x00, 0x00, 0x00, 0x3f, 0x00, 0x00, 0x80, 0x3f,
	0x00, 0x00, 0x80, 0xbe, 0x00, 0x00, 0x00, 0x3f,
	0x00, 0x00, 0x80, 0x3f, 0x00, 0x00, 0x80, 0xbe,
	0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
	0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
	0x74, 0x6f, 0x6f, 0x6c, 0x3d, 0x70, 0x6d, 0x2d,
	0x73, 0x68, 0x6f, 0x6f, 0x74, 0x0a, 0x73, 0x65,
	0x65, 0x64, 0x3d, 0x31, 0x0a, 0x53, 0x2b, 0x98,
	0xde, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
	0x00, 0x00, 0x00, 0x3f, 0x00, 0x00, 0x80, 0x3f,
	0x00, 0x00, 0x80, 0xbe, 0x80, 0x40, 0x20, 0x81,
	0x80, 0x80, 0x80, 0x80, 0x07, 0x01, 0x00, 0x00,
};

/* The same example as version 1.0 wrote it (20-byte records without a
 * normal), which version 2 refuses. */
static const unsigned char golden_v1[212] = {
	0x89, 0x50, 0x4d, 0x41, 0x50, 0x0d, 0x0a, 0x1a,
	0x01, 0x00, 0x00, 0x00, 0xb9, 0x00, 0x00, 0x00,
	0x00, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00,
	0xef, 0xcd, 0xab, 0x89, 0x67, 0x45, 0x23, 0x01,
	0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
	0x00, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00,
	0x60, 0x00, 0x00, 0x00, 0x15, 0x00, 0x00, 0x00,
	0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
	0x01, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00,
	0x00, 0x00, 0x00, 0x00, 0x74, 0xa1, 0x4c, 0x9d,
	0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
	0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
	0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
	0xc0, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
	0x14, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
	0x00, 0x00, 0x00, 0x3f, 0x00, 0x00, 0x80, 0x3f,
	0x00, 0x00, 0x80, 0xbe, 0x00, 0x00, 0x00, 0x3f,
	0x00, 0x00, 0x80, 0x3f, 0x00, 0x00, 0x80, 0xbe,
	0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
	0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
	0x74, 0x6f, 0x6f, 0x6c, 0x3d, 0x70, 0x6d, 0x2d,
	0x73, 0x68, 0x6f, 0x6f, 0x74, 0x0a, 0x73, 0x65,
	0x65, 0x64, 0x3d, 0x31, 0x0a, 0x79, 0x23, 0xb9,
	0xbe, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
	0x00, 0x00, 0x00, 0x3f, 0x00, 0x00, 0x80, 0x3f,
	0x00, 0x00, 0x80, 0xbe, 0x80, 0x40, 0x20, 0x81,
	0x80, 0x80, 0x07, 0x01,
};

/* The golden file reads as man/pmap.5 explains it, and the writer makes
 * it again from what was read. */
static void
test_golden(void **state)
{
	static unsigned char buf[BUFCAP];
	struct pm_pmap m;
	struct pm_error err;
	const struct pm_photon *p;
	struct pm_rgb c;
	struct pm_vec3 d;
	size_t n;

	(void)state;
	if (pm_pmap_parse("golden", golden, sizeof(golden), &m, &err) != PM_OK)
		fail_msg("%s", err.msg);
	assert_true(m.scene_hash == 0x0123456789abcdefull && m.seed == 1);
	assert_int_equal(m.effects, PM_EFFECT_GLOBAL);
	assert_int_equal(m.max_depth, 0);
	assert_string_equal(m.info, "tool=pm-shoot\nseed=1\n");
	assert_int_equal(m.nmaps, 1);
	assert_int_equal(m.maps[0].kind, PM_MAP_GLOBAL);
	assert_true(m.maps[0].count == 1 && m.maps[0].emitted == 1);
	assert_true(m.maps[0].first_index == 0 && m.maps[0].balanced);
	assert_true(m.maps[0].lo[0] == 0.5f && m.maps[0].hi[2] == -0.25f);
	p = &m.maps[0].photons[0];
	assert_true(p->pos[0] == 0.5f && p->pos[1] == 1.0f &&
	    p->pos[2] == -0.25f);
	c = pm_rgbe_unpack(p->power);
	assert_true(c.r == 1.0f && c.g == 0.5f && c.b == 0.25f);
	d = pm_dir_unpack(p->dir);
	assert_true(d.z > 0.9999f);
	d = pm_dir_unpack(p->normal);
	assert_true(d.z > 0.9999f);
	assert_int_equal(p->flags, PM_KD_LEAF | PM_PHOTON_VIA_DIFFUSE);
	assert_int_equal(p->depth, 1);
	assert_true(p->reserved[0] == 0 && p->reserved[1] == 0);
	n = write_bytes(&m, false, buf);
	assert_int_equal(n, sizeof(golden));
	assert_memory_equal(buf, golden, n);
	pm_pmap_free(&m);
}

/* pm_rgbe_unpack builds 2^(e - 136) from its bits rather than calling
 * ldexpf: the very same floats, for every exponent and mantissa. */
static void
test_rgbe_exponents(void **state)
{
	int e, m;

	(void)state;
	for (e = 0; e < 256; e++)
		for (m = 0; m < 256; m++) {
			uint8_t in[4] = {(uint8_t)m, (uint8_t)(255 - m),
			    (uint8_t)(m / 2), (uint8_t)e};
			struct pm_rgb c = pm_rgbe_unpack(in);
			float f = e == 0 ? 0.0f : ldexpf(1.0f, e - 136);
			float want[3] = {(float)m * f, (float)(255 - m) * f,
			    (float)(m / 2) * f};

			assert_memory_equal(&c.r, &want[0], sizeof(float));
			assert_memory_equal(&c.g, &want[1], sizeof(float));
			assert_memory_equal(&c.b, &want[2], sizeof(float));
		}
}

/* A real version 1 file is refused in one line that names the file, says
 * what it is and what to do; so is every file that says version 1. */
static void
test_v1_refused(void **state)
{
	static unsigned char buf[BUFCAP];
	struct pm_pmap m;
	struct pm_error err;
	char p[PATHCAP];
	int mm;

	(void)state;
	expect_fail(golden_v1, sizeof(golden_v1), PM_ERR_UNSUPPORTED,
	    "t.pmap: a version 1.0 photon map, whose 20-byte photons lack "
	    "the surface normal that version 2 needs: shoot it again with "
	    "pm-shoot");
	tpath(p, "v1.pmap");
	spit(p, golden_v1, sizeof(golden_v1));
	for (mm = 0; mm < 2; mm++) {
		assert_int_equal(pm_pmap_read(p, &m, mm, &err),
		    PM_ERR_UNSUPPORTED);
		assert_non_null(strstr(err.msg, "v1.pmap: a version 1.0 photon "
		    "map"));
		assert_null(strchr(err.msg, '\n'));
	}
	unlink(p);
	/* Only its first 12 bytes are needed to know, even cut short. */
	expect_fail(golden_v1, 64, PM_ERR_UNSUPPORTED, "version 1.0");
	/* A later 1.x minor version alike. */
	memcpy(buf, golden_v1, sizeof(golden_v1));
	wr16(buf + 10, 4);
	fix_crc(buf);
	expect_fail(buf, sizeof(golden_v1), PM_ERR_UNSUPPORTED,
	    "a version 1.4 photon map");
}

static void
test_roundtrip(void **state)
{
	static const size_t sizes[][4] = {
		{0, 0, 0, 0}, {1, 0, 0, 0}, {1, 1, 0, 0}, {1, 2500, 0, 0},
		{2, 3000, 700, 0}, {2, 0, 9, 0}, {2, 1, 0, 0},
		{3, 3000, 700, 400}, {3, 0, 0, 0}, {3, 5, 0, 1}, {3, 0, 0, 7},
	};
	struct pm_pmap m, r;
	struct pm_error err;
	char p[PATHCAP];
	size_t t;
	int c, mm, i;
	bool any;

	(void)state;
	tpath(p, "rt.pmap");
	for (t = 0; t < sizeof(sizes) / sizeof(sizes[0]); t++) {
		make_pmap(&m, (int)sizes[t][0], sizes[t][1], sizes[t][2],
		    sizes[t][3]);
		for (c = 0; c < 2; c++) {
			assert_int_equal(pm_pmap_write(p, &m, c, &err), PM_OK);
			for (mm = 0; mm < 2; mm++) {
				if (pm_pmap_read(p, &r, mm, &err) != PM_OK)
					fail_msg("%s", err.msg);
				assert_same(&m, &r);
				/* Mapped exactly when asked for, uncompressed
				 * and with a photon to point at. */
				any = false;
				for (i = 0; i < m.nmaps; i++)
					any |= m.maps[i].count > 0;
				if (mm && !c && any)
					assert_non_null(r.mapped);
				else
					assert_null(r.mapped);
				pm_pmap_free(&r);
				assert_null(r.info);
			}
		}
		unlink(p);
		pm_pmap_free(&m);
	}
}

/* A volume map (version 2.1) beside the other three: the file says 2.1,
 * everything comes back, compressed or not, read or mapped; a 2.0
 * reader's view of it (the version field set back to 0) is refused. */
static void
test_volume_roundtrip(void **state)
{
	static unsigned char buf[BUFCAP];
	struct pm_pmap m, r;
	struct pm_error err;
	char p[PATHCAP];
	size_t n;
	int c, mm;

	(void)state;
	tpath(p, "vol.pmap");
	make_pmap(&m, 3, 300, 40, 20);
	m.maps[3].kind = PM_MAP_VOLUME;
	m.maps[3].count = 500;
	m.maps[3].emitted = m.maps[0].emitted;
	m.maps[3].first_index = m.maps[0].first_index;
	m.maps[3].photons = make_photons(500, 99u);
	set_bounds(&m.maps[3]);
	m.nmaps = 4;
	m.effects |= PM_EFFECT_MEDIA;
	for (c = 0; c < 2; c++) {
		assert_int_equal(pm_pmap_write(p, &m, c, &err), PM_OK);
		for (mm = 0; mm < 2; mm++) {
			if (pm_pmap_read(p, &r, mm, &err) != PM_OK)
				fail_msg("%s", err.msg);
			assert_int_equal(r.version_major, 2);
			assert_int_equal(r.version_minor, 1);
			assert_same(&m, &r);
			assert_int_equal(r.nmaps, 4);
			assert_int_equal(r.maps[3].kind, PM_MAP_VOLUME);
			assert_true(r.maps[3].count == 500);
			assert_memory_equal(r.maps[3].photons,
			    m.maps[3].photons, 500 * sizeof(struct pm_photon));
			assert_ptr_equal(pm_pmap_find(&r, PM_MAP_VOLUME),
			    &r.maps[3]);
			assert_string_equal(pm_map_kind_name(PM_MAP_VOLUME),
			    "volume");
			pm_pmap_free(&r);
		}
	}
	n = write_bytes(&m, false, buf);
	assert_int_equal(pm_pmap_parse("t.pmap", buf, n, &r, &err), PM_OK);
	assert_same(&m, &r);
	pm_pmap_free(&r);
	wr16(buf + 10, 0);
	fix_crc(buf);
	assert_int_not_equal(pm_pmap_parse("t.pmap", buf, n, &r, &err), PM_OK);
	unlink(p);
	pm_pmap_free(&m);
}

/* Photons mapped from a file may be reordered in place (pm-balance does)
 * without changing the file. */
static void
test_mmap_private(void **state)
{
	struct pm_pmap m, r, again;
	struct pm_error err;
	char p[PATHCAP];
	struct pm_photon tmp;

	(void)state;
	tpath(p, "mm.pmap");
	make_pmap(&m, 1, 100, 0, 0);
	assert_int_equal(pm_pmap_write(p, &m, false, &err), PM_OK);
	assert_int_equal(pm_pmap_read(p, &r, true, &err), PM_OK);
	assert_non_null(r.mapped);
	assert_true((uintptr_t)r.maps[0].photons % 64 == 0);
	tmp = r.maps[0].photons[0];
	r.maps[0].photons[0] = r.maps[0].photons[99];
	r.maps[0].photons[99] = tmp;
	assert_memory_equal(&r.maps[0].photons[99], &m.maps[0].photons[0],
	    sizeof(tmp));
	assert_int_equal(pm_pmap_read(p, &again, false, &err), PM_OK);
	assert_same(&m, &again);
	pm_pmap_free(&again);
	pm_pmap_free(&r);
	pm_pmap_free(&m);
	unlink(p);
}

/* The writer's bytes are those of man/pmap.5; and pm_pmap_parse gives
 * what pm_pmap_read gives. */
static void
test_spec_bytes(void **state)
{
	static unsigned char a[BUFCAP], b[BUFCAP];
	struct pm_pmap m, r;
	struct pm_error err;
	struct spec s;
	size_t na, nb;
	int c;

	(void)state;
	make_pmap(&m, 3, 5, 3, 4);
	for (c = 0; c < 2; c++) {
		na = write_bytes(&m, c, a);
		spec_of(&s, &m, (uint32_t)c);
		nb = spec_build(&s, b);
		assert_int_equal(na, nb);
		assert_memory_equal(a, b, na);
		assert_int_equal(pm_pmap_parse("t.pmap", b, nb, &r, &err),
		    PM_OK);
		assert_same(&m, &r);
		pm_pmap_free(&r);
	}
	/* Payloads start on 64-byte boundaries after a 64 + 3*96 + info +
	 * 4 byte header; the irradiance map's radius is at byte 80 of its
	 * entry. */
	assert_int_equal(rd32(a + 12), 64 + 3 * 96 + strlen(m.info) + 4);
	assert_int_equal(rd32(a + 64 + 2 * 96), PM_MAP_IRRADIANCE);
	assert_int_equal(rd32(a + 64 + 2 * 96 + 80), 0x3e000000);
	assert_int_equal(rd32(a + 64 + 96 + 80), 0);
	pm_pmap_free(&m);
}

static void
test_info(void **state)
{
	static unsigned char buf[BUFCAP];
	struct pm_pmap m, r;
	struct pm_error err;
	size_t n;

	(void)state;
	memset(&m, 0, sizeof(m));
	assert_int_equal(pm_pmap_info_add(&m, "command", "pm-shoot -n 1e6\n"
	    "scene.xml\r", &err), PM_OK);
	assert_int_equal(pm_pmap_info_add(&m, "why", "caustic map: glass "
	    "sphere (dielectric) \xc3\xa9 = e-acute", &err), PM_OK);
	assert_int_equal(pm_pmap_info_add(&m, "latin1", "caf\xe9!", &err),
	    PM_OK);
	assert_int_equal(pm_pmap_info_add(&m, "empty", "", &err), PM_OK);
	assert_string_equal(m.info, "command=pm-shoot -n 1e6 scene.xml \n"
	    "why=caustic map: glass sphere (dielectric) \xc3\xa9 = e-acute\n"
	    "latin1=caf?!\nempty=\n");
	assert_int_equal(pm_pmap_info_add(&m, "", "x", &err), PM_ERR_INVALID);
	assert_int_equal(pm_pmap_info_add(&m, "a=b", "x", &err),
	    PM_ERR_INVALID);
	assert_int_equal(pm_pmap_info_add(&m, "a\nb", "x", &err),
	    PM_ERR_INVALID);
	n = write_bytes(&m, false, buf);
	assert_int_equal(pm_pmap_parse("t.pmap", buf, n, &r, &err), PM_OK);
	assert_string_equal(r.info, m.info);
	/* pm-balance appends its own lines to what it read. */
	assert_int_equal(pm_pmap_info_add(&r, "tool", "pm-balance", &err),
	    PM_OK);
	n = write_bytes(&r, true, buf);
	pm_pmap_free(&r);
	assert_int_equal(pm_pmap_parse("t.pmap", buf, n, &r, &err), PM_OK);
	assert_non_null(strstr(r.info, "\nempty=\ntool=pm-balance\n"));
	assert_int_equal(strncmp(r.info, m.info, strlen(m.info)), 0);
	pm_pmap_free(&r);
	pm_pmap_free(&m);
}

static void
test_find(void **state)
{
	struct pm_pmap m;

	(void)state;
	make_pmap(&m, 3, 3, 4, 5);
	assert_ptr_equal(pm_pmap_find(&m, PM_MAP_GLOBAL), &m.maps[0]);
	assert_ptr_equal(pm_pmap_find(&m, PM_MAP_CAUSTIC), &m.maps[1]);
	assert_ptr_equal(pm_pmap_find(&m, PM_MAP_IRRADIANCE), &m.maps[2]);
	m.nmaps = 2;
	assert_null(pm_pmap_find(&m, PM_MAP_IRRADIANCE));
	m.nmaps = 1;
	assert_null(pm_pmap_find(&m, PM_MAP_CAUSTIC));
	m.nmaps = 3;
	pm_pmap_free(&m);
	make_pmap(&m, 0, 0, 0, 0);
	assert_null(pm_pmap_find(&m, PM_MAP_GLOBAL));
	pm_pmap_free(&m);
}

static void
test_magic(void **state)
{
	static unsigned char buf[BUFCAP], bad[BUFCAP];
	struct pm_pmap m;
	size_t n;

	(void)state;
	make_pmap(&m, 1, 4, 0, 0);
	n = write_bytes(&m, false, buf);
	pm_pmap_free(&m);
	expect_fail(buf, 0, PM_ERR_TRUNCATED, "empty file");
	memcpy(bad, buf, n);
	bad[1] = 'Q';
	expect_fail(bad, n, PM_ERR_FORMAT, "not a photon map (bad magic)");
	expect_fail((const unsigned char *)"hello", 5, PM_ERR_FORMAT,
	    "not a photon map (bad magic)");
	/* CR LF to LF, as a text-mode transfer would do. */
	memcpy(bad, buf, 5);
	memcpy(bad + 5, buf + 6, n - 6);
	expect_fail(bad, n - 1, PM_ERR_FORMAT, "text-mode");
	/* LF to CR LF. */
	memcpy(bad, buf, 6);
	bad[6] = '\r';
	memcpy(bad + 7, buf + 6, n - 6);
	expect_fail(bad, n + 1, PM_ERR_FORMAT, "text-mode");
	/* A 7-bit channel. */
	memcpy(bad, buf, n);
	bad[0] &= 0x7f;
	expect_fail(bad, n, PM_ERR_FORMAT, "7-bit");
}

static void
test_versions(void **state)
{
	static unsigned char buf[BUFCAP], b2[BUFCAP];
	struct pm_pmap m, r;
	struct pm_error err;
	struct spec s;
	size_t n, n2;
	int c;

	(void)state;
	make_pmap(&m, 3, 6, 2, 3);
	n = write_bytes(&m, true, buf);

	wr16(buf + 8, 3);
	expect_fail(buf, n, PM_ERR_UNSUPPORTED,
	    "unknown version 3.0 (this reader knows 2.x)");
	wr16(buf + 8, 0);
	expect_fail(buf, n, PM_ERR_UNSUPPORTED, "unknown version 0.0");
	wr16(buf + 8, 1);
	expect_fail(buf, n, PM_ERR_UNSUPPORTED, "a version 1.0 photon map");
	wr16(buf + 8, 2);

	/* A newer minor version is read; what it may add is ignored:
	 * reserved fields, flags, data after the last map. */
	wr16(buf + 10, 3);
	fix_crc(buf);
	assert_int_equal(pm_pmap_parse("t.pmap", buf, n, &r, &err), PM_OK);
	assert_same(&m, &r);
	pm_pmap_free(&r);
	buf[56] = 1;			/* reserved */
	buf[64 + 88] = 1;		/* reserved in a map entry */
	buf[64 + 80] = 1;		/* the radius of a global map */
	buf[64 + 2 * 96 + 84] = 1;	/* reserved in the irradiance entry */
	buf[64 + 4] |= 0x80;		/* a map flag */
	buf[16] = 4;			/* a file flag */
	fix_crc(buf);
	memcpy(buf + n, "more", 4);
	assert_int_equal(pm_pmap_parse("t.pmap", buf, n + 4, &r, &err), PM_OK);
	assert_same(&m, &r);
	pm_pmap_free(&r);
	/* ... which version 2.0 forbids. */
	wr16(buf + 10, 0);
	fix_crc(buf);
	expect_fail(buf, n, PM_ERR_FORMAT, "unknown file flags");

	/* A newer minor version with longer map entries and more header. */
	spec_of(&s, &m, 1);
	s.minor = PM_PMAP_VERSION_MINOR + 1;
	s.entry_size = 120;
	s.extra = 12;
	n2 = spec_build(&s, b2);
	assert_int_equal(pm_pmap_parse("t.pmap", b2, n2, &r, &err), PM_OK);
	assert_same(&m, &r);
	pm_pmap_free(&r);
	s.minor = 0;
	n2 = spec_build(&s, b2);
	expect_fail(b2, n2, PM_ERR_FORMAT, "map entries of 120 bytes");
	s.entry_size = 96;
	n2 = spec_build(&s, b2);
	expect_fail(b2, n2, PM_ERR_FORMAT, "a header of");
	/* Records whose reserved bytes are set: an error in 2.0, a meaning
	 * to ignore in a newer minor version, compressed or not. */
	m.maps[1].photons[1].reserved[1] = 0x20;
	for (c = 0; c < 2; c++) {
		spec_of(&s, &m, (uint32_t)c);
		n2 = spec_build(&s, b2);
		expect_fail(b2, n2, PM_ERR_FORMAT, c ? "nonzero reserved bytes "
		    "in record 1 of the caustic map (bytes 22-23 of the "
		    "record, decompressed)" : "nonzero reserved bytes in "
		    "record 1 of the caustic map (byte");
		s.minor = PM_PMAP_VERSION_MINOR + 1;
		n2 = spec_build(&s, b2);
		assert_int_equal(pm_pmap_parse("t.pmap", b2, n2, &r, &err),
		    PM_OK);
		assert_int_equal(r.maps[1].photons[1].reserved[1], 0x20);
		pm_pmap_free(&r);
	}
	pm_pmap_free(&m);
}

/* Every prefix of a file is an error, never a crash, from a buffer, a
 * mapped file and a read file alike. */
static void
test_truncated(void **state)
{
	static unsigned char buf[BUFCAP];
	struct pm_pmap m, r;
	struct pm_error err;
	char p[PATHCAP];
	size_t n, len;
	char want[64];
	int c, i, mm;

	(void)state;
	tpath(p, "cut.pmap");
	for (i = 0; i < 4; i++) {
		make_pmap(&m, i, 5, 3, 4);
		for (c = 0; c < 2; c++) {
			n = write_bytes(&m, c, buf);
			for (len = 0; len < n; len++) {
				expect_fail(buf, len, PM_ERR_TRUNCATED, "");
				if (len == 0)
					continue;
				snprintf(want, sizeof(want), "file is %zu "
				    "bytes)", len);
				expect_fail(buf, len, PM_ERR_TRUNCATED, want);
				spit(p, buf, len);
				for (mm = 0; mm < 2; mm++) {
					assert_int_equal(pm_pmap_read(p, &r,
					    mm, &err), PM_ERR_TRUNCATED);
					assert_non_null(strstr(err.msg, want));
				}
			}
			assert_int_equal(pm_pmap_parse("t.pmap", buf, n, &r,
			    &err), PM_OK);
			pm_pmap_free(&r);
		}
		pm_pmap_free(&m);
	}
	unlink(p);
	/* The part that is cut is named: 64 fixed bytes, 96 per map, the
	 * 22 bytes of "tool=pm-shoot\nseed=42\n", a crc32. */
	make_pmap(&m, 1, 5, 0, 0);
	n = write_bytes(&m, false, buf);
	expect_fail(buf, 40, PM_ERR_TRUNCATED,
	    "truncated header (byte 64, file is 40 bytes)");
	expect_fail(buf, 80, PM_ERR_TRUNCATED,
	    "truncated map table (byte 160, file is 80 bytes)");
	expect_fail(buf, 170, PM_ERR_TRUNCATED,
	    "truncated provenance text (byte 182, file is 170 bytes)");
	expect_fail(buf, 183, PM_ERR_TRUNCATED,
	    "truncated header (byte 186, file is 183 bytes)");
	expect_fail(buf, 200, PM_ERR_TRUNCATED,
	    "truncated global map (bytes 192 to 312, file is 200 bytes)");
	pm_pmap_free(&m);
}

/* Every single flipped bit is caught: the header by its checksum (or its
 * magic and version), payloads by theirs, padding by being zero. */
static void
test_bitflips(void **state)
{
	static unsigned char buf[BUFCAP];
	struct pm_pmap m, r;
	struct pm_error err;
	size_t n, i, hs, g0, g1, g2, s0;
	char p[PATHCAP];
	int c, b, mm;

	(void)state;
	tpath(p, "flip.pmap");
	make_pmap(&m, 3, 5, 3, 4);
	for (c = 0; c < 2; c++) {
		n = write_bytes(&m, c, buf);
		for (i = 0; i < n; i++)
			for (b = 0; b < 8; b++) {
				buf[i] ^= (unsigned char)(1u << b);
				assert_int_not_equal(pm_pmap_parse("t.pmap",
				    buf, n, &r, &err), PM_OK);
				buf[i] ^= (unsigned char)(1u << b);
			}
		hs = rd32(buf + 12);
		g0 = (size_t)(buf[64 + 40] | buf[64 + 41] << 8);
		g1 = (size_t)(buf[160 + 40] | buf[160 + 41] << 8);
		g2 = (size_t)(buf[256 + 40] | buf[256 + 41] << 8);
		/* Named: a header field, the global and the caustic map. */
		buf[33] ^= 4;
		expect_fail(buf, n, PM_ERR_FORMAT, "header checksum mismatch");
		buf[33] ^= 4;
		buf[hs - 20] ^= 1;
		expect_fail(buf, n, PM_ERR_FORMAT, "header checksum mismatch");
		buf[hs - 20] ^= 1;
		buf[g0 + 7] ^= 0x10;
		expect_fail(buf, n, PM_ERR_FORMAT,
		    "checksum mismatch in the global map");
		/* The same through a mapped and a read file. */
		spit(p, buf, n);
		for (mm = 0; mm < 2; mm++) {
			assert_int_equal(pm_pmap_read(p, &r, mm, &err),
			    PM_ERR_FORMAT);
			assert_non_null(strstr(err.msg,
			    "checksum mismatch in the global map"));
		}
		unlink(p);
		buf[g0 + 7] ^= 0x10;
		buf[g1 + 2] ^= 0x10;
		expect_fail(buf, n, PM_ERR_FORMAT,
		    "checksum mismatch in the caustic map");
		buf[g1 + 2] ^= 0x10;
		/* A flipped reserved record byte is damage, not a forgery. */
		buf[n - 1] ^= 0x01;
		expect_fail(buf, n, PM_ERR_FORMAT,
		    "checksum mismatch in the irradiance map");
		buf[n - 1] ^= 0x01;
		assert_true(g2 > g1);
		s0 = (size_t)(buf[64 + 48] | buf[64 + 49] << 8);
		if (g0 + s0 < g1) {	/* padding before the caustic map */
			buf[g1 - 1] = 1;
			expect_fail(buf, n, PM_ERR_FORMAT, "nonzero padding");
			buf[g1 - 1] = 0;
		}
		expect_fail(buf, n + 1, PM_ERR_FORMAT, "after the last map");
	}
	pm_pmap_free(&m);
}

/* Headers with valid checksums that lie. */
static void
test_forged(void **state)
{
	static unsigned char orig[BUFCAP], buf[BUFCAP];
	struct pm_pmap m;
	size_t n, e0 = 64, e1 = 160, e2 = 256;
	uint64_t g0, g1, g2;
	uint32_t hs;

	(void)state;
	make_pmap(&m, 3, 5, 3, 4);
	n = write_bytes(&m, false, orig);
	hs = rd32(orig + 12);
	g0 = orig[e0 + 40] | (uint64_t)orig[e0 + 41] << 8;
	g1 = orig[e1 + 40] | (uint64_t)orig[e1 + 41] << 8;
	g2 = orig[e2 + 40] | (uint64_t)orig[e2 + 41] << 8;
#define FORGE(stmt, code, want) do {					\
	memcpy(buf, orig, n);						\
	stmt;								\
	fix_crc(buf);							\
	expect_fail(buf, n, code, want);				\
} while (0)
	/* Counts and offsets past the end. */
	FORGE(wr64(buf + e0 + 40, (n + 63) / 64 * 64), PM_ERR_TRUNCATED,
	    "truncated global map (bytes");
	FORGE((wr64(buf + e1 + 16, 300), wr64(buf + e1 + 48, 6000)),
	    PM_ERR_TRUNCATED, "truncated caustic map");
	FORGE(wr64(buf + e0 + 40, UINT64_MAX - 63), PM_ERR_FORMAT,
	    "overflows");
	FORGE(wr64(buf + e0 + 40, 0), PM_ERR_FORMAT, "inside the header");
	FORGE(wr64(buf + e0 + 40, g0 + 4), PM_ERR_FORMAT,
	    "not a multiple of 64");
	FORGE(wr64(buf + e1 + 40, g0), PM_ERR_FORMAT, "overlaps");
	/* Three payloads: each against the next in order of offset. */
	assert_true(g1 + 5 * 24 < g2);
	FORGE(wr64(buf + e2 + 40, g1), PM_ERR_FORMAT,
	    "the caustic map (bytes");
	FORGE(wr64(buf + e2 + 40, g1), PM_ERR_FORMAT,
	    "overlaps the irradiance map");
	FORGE(wr64(buf + e0 + 40, g1), PM_ERR_FORMAT,
	    "the caustic map (bytes");
	FORGE(wr64(buf + e0 + 40, g1), PM_ERR_FORMAT,
	    "overlaps the global map");
	FORGE(wr64(buf + e0 + 48, 99), PM_ERR_FORMAT,
	    "stores 99 bytes, but 5 photons take 120");
	/* count * 24 that overflows, here to exactly 0 bytes. */
	FORGE((wr64(buf + e0 + 16, 1ull << 62), wr64(buf + e0 + 48, 0)),
	    PM_ERR_FORMAT, "overflows 64-bit");
	FORGE(wr64(buf + e0 + 16, UINT64_MAX / 24 + 1), PM_ERR_FORMAT,
	    "overflows 64-bit");
	FORGE(wr64(buf + e0 + 24, 0), PM_ERR_FORMAT, "emitted none");
	FORGE(wr64(buf + e0 + 32, UINT64_MAX), PM_ERR_FORMAT, "wraps");
	/* Reserved fields, flags, kinds. */
	FORGE(buf[60] = 1, PM_ERR_FORMAT, "nonzero reserved field (byte 56)");
	FORGE(buf[e1 + 81] = 1, PM_ERR_FORMAT,
	    "nonzero reserved field in the caustic map (byte 240)");
	FORGE(wrf(buf + e0 + 80, 0.5f), PM_ERR_FORMAT,
	    "nonzero reserved field in the global map (byte 144)");
	FORGE(buf[e2 + 87] = 1, PM_ERR_FORMAT,
	    "nonzero reserved field in the irradiance map (byte 340)");
	FORGE(buf[e2 + 95] = 1, PM_ERR_FORMAT,
	    "nonzero reserved field in the irradiance map (byte 348)");
	/* Irradiance maps: no paths emitted, a radius that is a length. */
	FORGE(wr64(buf + e2 + 24, 4), PM_ERR_FORMAT,
	    "the irradiance map is corrupt: an irradiance map's emitted and "
	    "first_index must be 0");
	FORGE(wr64(buf + e2 + 32, 1), PM_ERR_FORMAT, "must be 0");
	FORGE(wrf(buf + e2 + 80, -0.5f), PM_ERR_FORMAT,
	    "the irradiance map's radius is not a finite number >= 0 "
	    "(byte 336)");
	FORGE(wrf(buf + e2 + 80, NAN), PM_ERR_FORMAT, "radius");
	FORGE(wrf(buf + e2 + 80, INFINITY), PM_ERR_FORMAT, "radius");
	/* Reserved record bytes, behind a valid payload checksum. */
	FORGE((buf[g2 + 3 * 24 + 23] = 1, wr32(buf + e2 + 12,
	    (uint32_t)crc32(0, buf + g2, 4 * 24))), PM_ERR_FORMAT,
	    "nonzero reserved bytes in record 3 of the irradiance map");
	FORGE((buf[g0 + 22] = 0x80, wr32(buf + e0 + 12,
	    (uint32_t)crc32(0, buf + g0, 5 * 24))), PM_ERR_FORMAT,
	    "nonzero reserved bytes in record 0 of the global map");
	FORGE(buf[e0 + 4] = 2, PM_ERR_FORMAT, "unknown flags");
	FORGE(buf[20] = 8, PM_ERR_FORMAT, "unknown effects");
	FORGE(buf[e1] = 7, PM_ERR_FORMAT, "unknown map kind 7 (byte 160");
	FORGE(buf[e1] = 5, PM_ERR_FORMAT, "unknown map kind 5 (byte 160");
	/* kind 4, the volume map, is version 2.1's */
	FORGE(buf[e1] = 4, PM_ERR_FORMAT, "a volume map (kind 4, byte 160) "
	    "in a version 2.0 file");
	FORGE(buf[e1] = 1, PM_ERR_FORMAT, "two global maps");
	FORGE((buf[e1] = 3, memset(buf + e1 + 24, 0, 16)), PM_ERR_FORMAT,
	    "two irradiance maps (bytes 160 and 256)");
	FORGE(buf[e0 + 8] = 2, PM_ERR_UNSUPPORTED, "compression method 2");
	FORGE(wrf(buf + e0 + 56, NAN), PM_ERR_FORMAT, "bounds");
	FORGE(wrf(buf + e0 + 68, -1e30f), PM_ERR_FORMAT, "bounds");
	/* The header's own sizes. */
	FORGE(buf[44] = 5, PM_ERR_FORMAT, "5 maps (byte 44; at most 4");
	FORGE(buf[44] = 2, PM_ERR_FORMAT, "a header of");
	FORGE(buf[52]++, PM_ERR_FORMAT, "a header of");
	FORGE(wr32(buf + 48, 95), PM_ERR_FORMAT, "map entries of 95 bytes");
	/* The provenance text. */
	FORGE(buf[hs - 6] = 0, PM_ERR_FORMAT, "a NUL byte");
	FORGE(buf[hs - 5] = 'x', PM_ERR_FORMAT, "without a newline");
	FORGE(buf[hs - 5 - 3] = 0xff, PM_ERR_FORMAT, "invalid UTF-8");
	FORGE(memcpy(buf + e2 + 96, "=x", 2), PM_ERR_FORMAT, "empty key");
	FORGE(memcpy(buf + e2 + 96 + 4, "~", 1), PM_ERR_FORMAT, "without '='");
#undef FORGE
	/* A header size below the fixed part, or past the end. */
	memcpy(buf, orig, n);
	wr32(buf + 12, 20);
	expect_fail(buf, n, PM_ERR_FORMAT, "header size 20");
	wr32(buf + 12, (uint32_t)n + 1);
	expect_fail(buf, n, PM_ERR_TRUNCATED, "truncated header");
	pm_pmap_free(&m);
}

/* The records' reserved bytes are checked in every way of reading, and
 * past the first block of records checked at a time; the writer refuses
 * them before writing anything. */
static void
test_reserved_records(void **state)
{
	static unsigned char buf[BUFCAP];
	struct pm_pmap m, r;
	struct pm_error err;
	char p[PATHCAP], want[128];
	size_t n, k = 9000;
	uint64_t g0;
	int mm;

	(void)state;
	tpath(p, "res.pmap");
	make_pmap(&m, 1, 10000, 0, 0);
	n = write_bytes(&m, false, buf);
	g0 = rd32(buf + 64 + 40);
	buf[g0 + k * 24 + 22] = 0x01;
	wr32(buf + 64 + 12, (uint32_t)crc32(0, buf + g0, 10000 * 24));
	fix_crc(buf);
	snprintf(want, sizeof(want), "nonzero reserved bytes in record %zu of "
	    "the global map (byte %llu)", k,
	    (unsigned long long)(g0 + k * 24 + 22));
	expect_fail(buf, n, PM_ERR_FORMAT, want);
	spit(p, buf, n);
	for (mm = 0; mm < 2; mm++) {
		assert_int_equal(pm_pmap_read(p, &r, mm, &err), PM_ERR_FORMAT);
		if (strstr(err.msg, want) == NULL)
			fail_msg("\"%s\" lacks \"%s\"", err.msg, want);
	}
	unlink(p);
	m.maps[0].photons[k].reserved[0] = 1;
	assert_int_equal(pm_pmap_write(p, &m, true, &err), PM_ERR_INVALID);
	assert_non_null(strstr(err.msg, "photon 9000 of the global map has "
	    "nonzero reserved bytes"));
	assert_int_equal(access(p, F_OK), -1);
	pm_pmap_free(&m);
}

/* A map of several 4 MiB pieces is checked in parallel with the result of
 * one thread: the same crc32 of its records, and the same first record
 * with nonzero reserved bytes when two pieces have one. */
static void
test_threads_check(void **state)
{
	const size_t cnt = 500000, bad1 = 200000, bad2 = 450000;
	const size_t cap = cnt * 24 + 4096;
	unsigned char *buf = malloc(cap);
	struct pm_pmap m, r;
	struct pm_error err;
	char p[PATHCAP], want[96], first[sizeof(err.msg)];
	uint32_t crc1 = 0;
	uint64_t g0;
	size_t n;
	int t;

	(void)state;
	assert_non_null(buf);
	tpath(p, "threads.pmap");
	make_pmap(&m, 1, cnt, 0, 0);
	unlink(p);
	assert_int_equal(pm_pmap_write(p, &m, false, &err), PM_OK);
	for (t = 1; t <= 5; t += 2) {
		assert_int_equal(pm_pmap_read_threads(p, &r, true, t, &err),
		    PM_OK);
		assert_int_equal(r.maps[0].count, cnt);
		if (t == 1)
			crc1 = r.maps[0].records_crc;
		assert_int_equal(r.maps[0].records_crc, crc1);
		assert_int_equal(r.maps[0].records_crc, r.maps[0].stored_crc);
		pm_pmap_free(&r);
	}
	/* Damage without a new crc32: the same mismatch, the same
	 * computed crc32, on any number of threads. */
	n = slurp(p, buf, cap);
	g0 = rd32(buf + 64 + 40);
	buf[g0 + bad2 * 24 + 3] ^= 0x40;
	spit(p, buf, n);
	for (t = 1; t <= 5; t += 2) {
		assert_int_equal(pm_pmap_read_threads(p, &r, true, t, &err),
		    PM_ERR_FORMAT);
		assert_non_null(strstr(err.msg, "checksum mismatch"));
		if (t == 1)
			memcpy(first, err.msg, sizeof(first));
		assert_string_equal(err.msg, first);
	}
	/* Two records with reserved bytes set, in different pieces. */
	buf[g0 + bad2 * 24 + 3] ^= 0x40;
	buf[g0 + bad1 * 24 + 22] = 1;
	buf[g0 + bad2 * 24 + 23] = 1;
	wr32(buf + 64 + 12, (uint32_t)crc32(0, buf + g0, (uInt)(cnt * 24)));
	fix_crc(buf);
	spit(p, buf, n);
	snprintf(want, sizeof(want), "nonzero reserved bytes in record %zu "
	    "of the global map", bad1);
	for (t = 1; t <= 5; t += 2) {
		assert_int_equal(pm_pmap_read_threads(p, &r, t != 3, t, &err),
		    PM_ERR_FORMAT);
		if (strstr(err.msg, want) == NULL)
			fail_msg("%d threads: \"%s\" lacks \"%s\"", t,
			    err.msg, want);
	}
	unlink(p);
	pm_pmap_free(&m);
	free(buf);
}

/* An empty payload may share its offset with the next payload, whatever
 * the order of their entries. */
static void
test_empty_payload_order(void **state)
{
	static unsigned char buf[BUFCAP];
	struct pm_pmap m, r;
	struct pm_error err;
	uint64_t g1;
	size_t n;

	(void)state;
	make_pmap(&m, 3, 5, 3, 0);
	n = write_bytes(&m, false, buf);
	g1 = rd32(buf + 160 + 40);
	/* The empty irradiance map, last in the table, where the caustic
	 * map starts; the file then ends with the caustic map. */
	wr64(buf + 256 + 40, g1);
	fix_crc(buf);
	assert_true(g1 + 3 * 24 < n);
	if (pm_pmap_parse("t.pmap", buf, (size_t)g1 + 3 * 24, &r, &err) !=
	    PM_OK)
		fail_msg("%s", err.msg);
	assert_same(&m, &r);
	pm_pmap_free(&r);
	/* Inside it, it is an overlap. */
	wr64(buf + 256 + 40, g1 + 64);
	fix_crc(buf);
	expect_fail(buf, (size_t)g1 + 3 * 24, PM_ERR_FORMAT,
	    "the caustic map (bytes");
	pm_pmap_free(&m);
}

/* Compressed payloads whose counts disagree with what they inflate to,
 * and zlib data that is not zlib, all behind valid checksums. */
static void
test_forged_zlib(void **state)
{
	static unsigned char orig[BUFCAP], buf[BUFCAP];
	struct pm_pmap m;
	size_t n, e0 = 64;
	uint64_t g0, s0;
	int i;

	(void)state;
	make_pmap(&m, 1, 5, 0, 0);
	n = write_bytes(&m, true, orig);
	g0 = orig[e0 + 40] | (uint64_t)orig[e0 + 41] << 8;
	s0 = orig[e0 + 48] | (uint64_t)orig[e0 + 49] << 8;
	assert_true(g0 + s0 == n);

	memcpy(buf, orig, n);
	wr64(buf + e0 + 16, 6);
	fix_crc(buf);
	expect_fail(buf, n, PM_ERR_FORMAT, "inflates to 120 bytes, not 6");
	wr64(buf + e0 + 16, 4);
	fix_crc(buf);
	expect_fail(buf, n, PM_ERR_FORMAT, "more than 4 photons");
	/* A zlib bomb's claim. */
	wr64(buf + e0 + 16, 1000000000);
	fix_crc(buf);
	expect_fail(buf, n, PM_ERR_FORMAT, "more than its");
	/* Garbage with a matching crc32. */
	memcpy(buf, orig, n);
	for (i = 2; i < (int)s0; i++)
		buf[g0 + (uint64_t)i] = (unsigned char)(i * 37 + 11);
	wr32(buf + e0 + 12, (uint32_t)crc32(0, buf + g0, (uInt)s0));
	fix_crc(buf);
	expect_fail(buf, n, PM_ERR_FORMAT, "bad zlib data");
	/* A stream cut short (stored size shrunk, crc recomputed). */
	memcpy(buf, orig, n);
	wr64(buf + e0 + 48, s0 - 4);
	wr32(buf + e0 + 12, (uint32_t)crc32(0, buf + g0, (uInt)(s0 - 4)));
	fix_crc(buf);
	expect_fail(buf, n - 4, PM_ERR_FORMAT, "cut short");
	/* Bytes after the end of the stream, inside the stored size. */
	memcpy(buf, orig, n);
	buf[n] = 0;
	wr64(buf + e0 + 48, s0 + 1);
	wr32(buf + e0 + 12, (uint32_t)crc32(0, buf + g0, (uInt)(s0 + 1)));
	fix_crc(buf);
	expect_fail(buf, n + 1, PM_ERR_FORMAT, "follow the end");
	pm_pmap_free(&m);
}

/* Runs in a child: writes n bytes of buf to fd and exits. */
static pid_t
feed(int fd, const char *path, const unsigned char *buf, size_t n)
{
	pid_t pid;
	ssize_t k;
	size_t done = 0;

	fflush(stdout);
	fflush(stderr);
	pid = fork();
	assert_true(pid >= 0);
	if (pid > 0)
		return pid;
	if (path != NULL && (fd = open(path, O_WRONLY)) < 0)
		_exit(1);
	while (done < n && (k = write(fd, buf + done, n - done)) > 0)
		done += (size_t)k;
	_exit(done == n ? 0 : 1);
}

static void
reap(pid_t pid)
{
	int st;

	assert_int_equal(waitpid(pid, &st, 0), pid);
	assert_true(WIFEXITED(st));
}

static void
test_pipes(void **state)
{
	static unsigned char buf[BUFCAP];
	struct pm_pmap m, r;
	struct pm_error err;
	char fifo[PATHCAP];
	int c, fds[2], saved;
	size_t n;
	pid_t pid;

	(void)state;
	tpath(fifo, "fifo");
	/* 400 kB: more than a pipe holds, so reads come in pieces. */
	make_pmap(&m, 3, 20000, 1500, 700);
	assert_int_equal(mkfifo(fifo, 0600), 0);
	for (c = 0; c < 2; c++) {
		n = write_bytes(&m, c, buf);
		pid = feed(-1, fifo, buf, n);
		if (pm_pmap_read(fifo, &r, true, &err) != PM_OK)
			fail_msg("%s", err.msg);
		reap(pid);
		assert_null(r.mapped);
		assert_same(&m, &r);
		pm_pmap_free(&r);
		/* Cut short: the size is learnt at the end. */
		pid = feed(-1, fifo, buf, n - 30);
		assert_int_equal(pm_pmap_read(fifo, &r, false, &err),
		    PM_ERR_TRUNCATED);
		reap(pid);
		assert_non_null(strstr(err.msg, "truncated irradiance map"));
		assert_non_null(strstr(err.msg, "bytes)"));

		/* Standard input. */
		assert_int_equal(pipe(fds), 0);
		pid = feed(fds[1], NULL, buf, n);
		close(fds[1]);
		saved = dup(STDIN_FILENO);
		assert_true(dup2(fds[0], STDIN_FILENO) >= 0);
		close(fds[0]);
		if (pm_pmap_read("-", &r, true, &err) != PM_OK)
			fail_msg("%s", err.msg);
		assert_true(dup2(saved, STDIN_FILENO) >= 0);
		close(saved);
		reap(pid);
		assert_same(&m, &r);
		pm_pmap_free(&r);
	}
	unlink(fifo);
	pm_pmap_free(&m);
}

static void
test_stdout(void **state)
{
	struct pm_pmap m, r;
	struct pm_error err;
	char p[PATHCAP];
	int fd, saved;

	(void)state;
	tpath(p, "out.pmap");
	make_pmap(&m, 3, 300, 20, 30);
	fflush(stdout);
	saved = dup(STDOUT_FILENO);
	fd = open(p, O_WRONLY | O_CREAT | O_TRUNC, 0644);
	assert_true(fd >= 0 && saved >= 0);
	assert_true(dup2(fd, STDOUT_FILENO) >= 0);
	close(fd);
	assert_int_equal(pm_pmap_write("-", &m, true, &err), PM_OK);
	/* A full disk is an error, not a short file. */
	fd = open("/dev/full", O_WRONLY);
	if (fd >= 0) {
		assert_true(dup2(fd, STDOUT_FILENO) >= 0);
		close(fd);
		assert_int_equal(pm_pmap_write("-", &m, false, &err),
		    PM_ERR_IO);
		assert_non_null(strstr(err.msg, "standard output: write "
		    "failed"));
	}
	assert_true(dup2(saved, STDOUT_FILENO) >= 0);
	close(saved);
	assert_int_equal(pm_pmap_read(p, &r, true, &err), PM_OK);
	assert_same(&m, &r);
	pm_pmap_free(&r);
	unlink(p);
	pm_pmap_free(&m);
}

static int
count_files(void)
{
	DIR *d = opendir(pm_test_dir);
	struct dirent *e;
	int n = 0;

	assert_non_null(d);
	while ((e = readdir(d)) != NULL)
		if (e->d_name[0] != '.')
			n++;
	closedir(d);
	return n;
}

static void
test_write_errors(void **state)
{
	struct pm_pmap m, r;
	struct pm_error err;
	char p[PATHCAP], dir[PATHCAP], q[PATHCAP];
	int before;

	(void)state;
	tpath(p, "keep.pmap");
	tpath(dir, "adir");
	make_pmap(&m, 3, 10, 5, 4);
	assert_int_equal(pm_pmap_write(tpath(q, "no/such/dir.pmap"), &m, false,
	    &err), PM_ERR_IO);
	/* A failed rename leaves no temporary file behind. */
	assert_int_equal(mkdir(dir, 0700), 0);
	before = count_files();
	assert_int_equal(pm_pmap_write(dir, &m, false, &err), PM_ERR_IO);
	assert_int_equal(count_files(), before);
	rmdir(dir);
	/* An existing file is replaced whole (swapped with the temporary
	 * file, which then goes: no file is left behind). */
	assert_int_equal(pm_pmap_write(p, &m, true, &err), PM_OK);
	before = count_files();
	m.maps[0].count = 3;
	set_bounds(&m.maps[0]);
	assert_int_equal(pm_pmap_write(p, &m, false, &err), PM_OK);
	assert_int_equal(count_files(), before);
	assert_int_equal(pm_pmap_read(p, &r, false, &err), PM_OK);
	assert_same(&m, &r);
	pm_pmap_free(&r);
	/* A symbolic link is replaced by the file, as rename would, and
	 * what it pointed to stays. */
	assert_int_equal(symlink("keep.pmap", tpath(q, "link.pmap")), 0);
	m.maps[0].count = 4;
	set_bounds(&m.maps[0]);
	assert_int_equal(pm_pmap_write(q, &m, false, &err), PM_OK);
	{
		struct stat st;

		assert_int_equal(lstat(q, &st), 0);
		assert_true(S_ISREG(st.st_mode));
	}
	assert_int_equal(count_files(), before + 1);
	assert_int_equal(pm_pmap_read(q, &r, false, &err), PM_OK);
	assert_true(r.maps[0].count == 4);
	pm_pmap_free(&r);
	assert_int_equal(pm_pmap_read(p, &r, false, &err), PM_OK);
	assert_true(r.maps[0].count == 3);
	pm_pmap_free(&r);
	unlink(q);
	m.maps[0].count = 3;
	set_bounds(&m.maps[0]);
	m.maps[0].count = 10;
	/* What the reader would refuse is never written. */
	m.maps[1].kind = PM_MAP_GLOBAL;
	assert_int_equal(pm_pmap_write(p, &m, false, &err), PM_ERR_INVALID);
	m.maps[1].kind = PM_MAP_CAUSTIC;
	m.maps[0].photons[3].pos[1] = NAN;
	assert_int_equal(pm_pmap_write(p, &m, true, &err), PM_ERR_INVALID);
	assert_non_null(strstr(err.msg, "photon 3 of the global map"));
	m.maps[0].photons[3].pos[1] = 0.5f;
	m.maps[0].photons[7].pos[2] = -INFINITY;
	assert_int_equal(pm_pmap_write(p, &m, false, &err), PM_ERR_INVALID);
	assert_non_null(strstr(err.msg, "photon 7 of the global map is not "
	    "at a finite position"));
	m.maps[0].photons[7].pos[2] = 0.25f;
	m.maps[1].photons[4].reserved[1] = 1;
	assert_int_equal(pm_pmap_write(p, &m, false, &err), PM_ERR_INVALID);
	assert_non_null(strstr(err.msg, "photon 4 of the caustic map has "
	    "nonzero reserved bytes"));
	m.maps[1].photons[4].reserved[1] = 0;
	m.maps[0].emitted = 0;
	assert_int_equal(pm_pmap_write(p, &m, false, &err), PM_ERR_INVALID);
	m.maps[0].emitted = 1;
	m.nmaps = 4;
	assert_int_equal(pm_pmap_write(p, &m, false, &err), PM_ERR_INVALID);
	m.nmaps = 3;
	/* Irradiance maps emit nothing and have a radius; others have none. */
	m.maps[2].emitted = 100;
	assert_int_equal(pm_pmap_write(p, &m, false, &err), PM_ERR_INVALID);
	assert_non_null(strstr(err.msg, "the irradiance map: an irradiance "
	    "map's emitted and first_index must be 0"));
	m.maps[2].emitted = 0;
	m.maps[2].radius = -1.0f;
	assert_int_equal(pm_pmap_write(p, &m, false, &err), PM_ERR_INVALID);
	m.maps[2].radius = NAN;
	assert_int_equal(pm_pmap_write(p, &m, false, &err), PM_ERR_INVALID);
	m.maps[2].radius = 0.0f;
	m.maps[1].radius = 0.5f;
	assert_int_equal(pm_pmap_write(p, &m, false, &err), PM_ERR_INVALID);
	assert_non_null(strstr(err.msg, "the caustic map has radius 0.5"));
	m.maps[1].radius = 0.0f;
	m.maps[2].kind = PM_MAP_CAUSTIC;
	assert_int_equal(pm_pmap_write(p, &m, false, &err), PM_ERR_INVALID);
	m.maps[2].kind = (enum pm_map_kind)4;
	assert_int_equal(pm_pmap_write(p, &m, false, &err), PM_ERR_INVALID);
	m.maps[2].kind = PM_MAP_IRRADIANCE;
	m.info[0] = '=';
	assert_int_equal(pm_pmap_write(p, &m, false, &err), PM_ERR_INVALID);
	m.info[0] = 't';
	/* The failed writes left the last good file as it was. */
	assert_int_equal(pm_pmap_read(p, &r, false, &err), PM_OK);
	assert_true(r.maps[0].count == 3);
	pm_pmap_free(&r);
	assert_int_equal(pm_pmap_read(tpath(q, "missing.pmap"), &r, false,
	    &err), PM_ERR_IO);
	assert_int_equal(pm_pmap_read(pm_test_dir, &r, false, &err), PM_ERR_IO);
	unlink(p);
	pm_pmap_free(&m);
}

/* Writes m to path with pm_pmap_writer, its maps' records added in pieces
 * of `piece` records (0: a map at a time); the file's size. */
static size_t
stream_file(const struct pm_pmap *m, size_t piece, const char *p)
{
	struct pm_pmap_writer *w;
	struct pm_pmap h = *m;
	struct pm_error err;
	struct stat st;
	size_t j, k;
	int i;

	for (i = 0; i < h.nmaps; i++) {
		h.maps[i].count = 0;
		h.maps[i].photons = NULL;
	}
	if (pm_pmap_writer_open(&w, p, &h, &err) != PM_OK)
		fail_msg("%s", err.msg);
	for (i = 0; i < m->nmaps; i++)
		for (j = 0; j < m->maps[i].count; j += k) {
			k = m->maps[i].count - j;
			if (piece > 0 && k > piece)
				k = piece;
			if (pm_pmap_writer_add(w, i, m->maps[i].photons + j, k,
			    &err) != PM_OK)
				fail_msg("%s", err.msg);
		}
	if (pm_pmap_writer_close(w, &err) != PM_OK)
		fail_msg("%s", err.msg);
	assert_int_equal(stat(p, &st), 0);
	return (size_t)st.st_size;
}

/* What pm_pmap_writer writes for m (stream_file), into buf; its length. */
static size_t
stream_bytes(const struct pm_pmap *m, size_t piece, unsigned char *buf)
{
	char p[PATHCAP];
	size_t n;

	tpath(p, "s.pmap");
	(void)stream_file(m, piece, p);
	n = slurp(p, buf, BUFCAP);
	unlink(p);
	return n;
}

/* m's maps but the last written on a thread while the caller makes the
 * last and adds it to the same struct, as pm-balance does
 * (pm_pmap_write_begin, then _end); the file's length in buf. */
static size_t
bg_bytes(const struct pm_pmap *m, unsigned char *buf)
{
	struct pm_pmap_bgwrite *b;
	struct pm_pmap g = *m;
	struct pm_map last = m->maps[m->nmaps - 1];
	struct pm_error err;
	char p[PATHCAP];
	size_t n;

	g.nmaps--;
	memset(&g.maps[g.nmaps], 0, sizeof(g.maps[g.nmaps]));
	/* the entry begin takes: none of the records */
	last.photons = NULL;
	last.count = 0;
	tpath(p, "bg.pmap");
	if (pm_pmap_write_begin(&b, p, &g, &last, &err) != PM_OK)
		fail_msg("%s", err.msg);
	g.maps[g.nmaps++] = m->maps[m->nmaps - 1];
	if (pm_pmap_write_end(b, &g.maps[g.nmaps - 1], &err) != PM_OK)
		fail_msg("%s", err.msg);
	n = slurp(p, buf, BUFCAP);
	unlink(p);
	return n;
}

/* m streamed in runs of 1, 7, 64, 1000 records and a map at a time, and
 * its maps but the last on a thread (bg_bytes), give pm_pmap_write's
 * bytes. */
static void
check_streamed(const struct pm_pmap *m)
{
	static unsigned char a[BUFCAP], b[BUFCAP];
	static const size_t pieces[] = {0, 1, 7, 64, 1000};
	size_t na = write_bytes(m, false, a), nb, q;

	for (q = 0; q < sizeof(pieces) / sizeof(pieces[0]); q++) {
		nb = stream_bytes(m, pieces[q], b);
		assert_int_equal(na, nb);
		assert_memory_equal(a, b, na);
	}
	if (m->nmaps > 0) {
		nb = bg_bytes(m, b);
		assert_int_equal(na, nb);
		assert_memory_equal(a, b, na);
	}
}

/* The streaming writer writes pm_pmap_write's bytes, whatever the
 * pieces, with empty maps first, between and last, and with no maps;
 * what it cannot write leaves no file. */
static void
test_writer(void **state)
{
	static const size_t sizes[][3] = {
		{300, 40, 20}, {0, 40, 20}, {300, 0, 20}, {300, 40, 0},
		{0, 0, 0}, {1, 1, 1},
	};
	struct pm_pmap_writer *w;
	struct pm_pmap m, h;
	struct pm_error err;
	char p[PATHCAP];
	size_t s, q;
	int nmaps, before;

	(void)state;
	for (nmaps = 0; nmaps <= 3; nmaps++)
		for (s = 0; s < sizeof(sizes) / sizeof(sizes[0]); s++) {
			make_pmap(&m, nmaps, sizes[s][0], sizes[s][1],
			    sizes[s][2]);
			check_streamed(&m);
			pm_pmap_free(&m);
		}
	/* Equal zeros of both signs where the bounds are: the first of them
	 * in one order of runs is not the first in another, and the bounds
	 * must not depend on it. */
	make_pmap(&m, 1, 300, 0, 0);
	for (s = 0; s < 300; s++)
		for (q = 0; q < 3; q++)
			m.maps[0].photons[s].pos[q] = 1.0f +
			    fabsf(m.maps[0].photons[s].pos[q]);
	m.maps[0].photons[1].pos[0] = 0.0f;
	m.maps[0].photons[2].pos[0] = -0.0f;
	m.maps[0].photons[9].pos[1] = -0.0f;
	m.maps[0].photons[12].pos[1] = 0.0f;
	check_streamed(&m);
	pm_pmap_free(&m);
	/* Refusals: no file is left, nor a temporary one. */
	tpath(p, "refused.pmap");
	before = count_files();
	make_pmap(&m, 3, 30, 20, 10);
	h = m;
	h.maps[0].count = h.maps[1].count = h.maps[2].count = 0;
	h.maps[0].photons = h.maps[1].photons = h.maps[2].photons = NULL;
	assert_int_equal(pm_pmap_writer_open(&w, p, &m, &err), PM_ERR_INVALID);
	assert_non_null(strstr(err.msg, "photons before any were added"));
	/* maps out of order */
	assert_int_equal(pm_pmap_writer_open(&w, p, &h, &err), PM_OK);
	assert_int_equal(pm_pmap_writer_add(w, 1, m.maps[1].photons, 5, &err),
	    PM_OK);
	assert_int_equal(pm_pmap_writer_add(w, 0, m.maps[0].photons, 5, &err),
	    PM_ERR_INVALID);
	assert_int_equal(count_files(), before);
	/* a bad record, numbered from the map's start */
	m.maps[0].photons[13].pos[0] = INFINITY;
	assert_int_equal(pm_pmap_writer_open(&w, p, &h, &err), PM_OK);
	assert_int_equal(pm_pmap_writer_add(w, 0, m.maps[0].photons, 10, &err),
	    PM_OK);
	assert_int_equal(pm_pmap_writer_add(w, 0, m.maps[0].photons + 10, 10,
	    &err), PM_ERR_INVALID);
	assert_non_null(strstr(err.msg, "photon 13 of the global map is not "
	    "at a finite position"));
	assert_int_equal(count_files(), before);
	m.maps[0].photons[13].pos[0] = 0.5f;
	/* photons with none emitted, found at the end */
	h.maps[1].emitted = 0;
	assert_int_equal(pm_pmap_writer_open(&w, p, &h, &err), PM_OK);
	assert_int_equal(pm_pmap_writer_add(w, 1, m.maps[1].photons, 3, &err),
	    PM_OK);
	assert_int_equal(pm_pmap_writer_close(w, &err), PM_ERR_INVALID);
	assert_non_null(strstr(err.msg, "has photons but emitted none"));
	assert_int_equal(count_files(), before);
	/* given up; while it is written, the file has no name where the
	 * file system has unnamed files */
	assert_int_equal(pm_pmap_writer_open(&w, p, &h, &err), PM_OK);
	assert_int_equal(pm_pmap_writer_add(w, 0, m.maps[0].photons, 30,
	    &err), PM_OK);
	{
		int fd = open(pm_test_dir, O_TMPFILE | O_WRONLY, 0600);

		if (fd >= 0) {
			close(fd);
			assert_int_equal(count_files(), before);
		}
	}
	pm_pmap_writer_abort(w);
	assert_int_equal(count_files(), before);
	pm_pmap_free(&m);
}

/* Writing the first maps on a thread while the last is made gives
 * pm_pmap_write's bytes (check_streamed, in test_writer, for the rest);
 * a bad record in the maps the thread writes, an entry the header
 * refuses and a write given up leave no file. */
static void
test_write_begin_end(void **state)
{
	struct pm_pmap_bgwrite *bg;
	struct pm_pmap m, first;
	struct pm_map last;
	struct pm_error err;
	char p[PATHCAP];
	int before;

	(void)state;
	make_pmap(&m, 3, 25000, 1, 5000);
	check_streamed(&m);
	pm_pmap_free(&m);
	tpath(p, "refused.pmap");
	before = count_files();
	make_pmap(&m, 3, 300, 40, 20);
	first = m;
	first.nmaps = 2;
	last = m.maps[2];
	last.photons = NULL;
	last.count = 0;
	/* a bad record in the thread's maps: found at the end */
	m.maps[1].photons[17].pos[2] = NAN;
	assert_int_equal(pm_pmap_write_begin(&bg, p, &first, &last, &err),
	    PM_OK);
	assert_int_equal(pm_pmap_write_end(bg, &m.maps[2], &err),
	    PM_ERR_INVALID);
	assert_non_null(strstr(err.msg, "photon 17 of the caustic map"));
	assert_int_equal(count_files(), before);
	m.maps[1].photons[17].pos[2] = 0.5f;
	/* given up while the thread writes */
	assert_int_equal(pm_pmap_write_begin(&bg, p, &first, &last, &err),
	    PM_OK);
	pm_pmap_write_cancel(bg);
	assert_int_equal(count_files(), before);
	/* a last map the header cannot hold */
	last.radius = -1.0f;
	assert_int_equal(pm_pmap_write_begin(&bg, p, &first, &last, &err),
	    PM_ERR_INVALID);
	assert_null(bg);
	assert_int_equal(count_files(), before);
	pm_pmap_free(&m);
}

/* The whole file at path, in a new buffer of *n bytes. */
static unsigned char *
slurp_all(const char *path, size_t *n)
{
	FILE *f = fopen(path, "rb");
	unsigned char *b;
	long len;

	assert_non_null(f);
	assert_int_equal(fseek(f, 0, SEEK_END), 0);
	len = ftell(f);
	assert_true(len > 0);
	rewind(f);
	b = malloc((size_t)len);
	assert_non_null(b);
	assert_int_equal(fread(b, 1, (size_t)len, f), (size_t)len);
	fclose(f);
	*n = (size_t)len;
	return b;
}

/* m written on 1 thread, on 2, 3 and 7 (bounds and checksums in pieces
 * combined in order), and streamed in runs of 7 records: the same bytes. */
static void
check_write_threads(const struct pm_pmap *m)
{
	static const int threads[] = {2, 3, 7};
	struct pm_error err;
	unsigned char *a, *b;
	char p[PATHCAP], q[PATHCAP];
	size_t na, nb;
	unsigned t;

	tpath(p, "t1.pmap");
	tpath(q, "tn.pmap");
	assert_int_equal(pm_pmap_write_threads(p, m, false, 1, &err), PM_OK);
	a = slurp_all(p, &na);
	for (t = 0; t <= sizeof(threads) / sizeof(threads[0]); t++) {
		if (t < sizeof(threads) / sizeof(threads[0]))
			assert_int_equal(pm_pmap_write_threads(q, m, false,
			    threads[t], &err), PM_OK);
		else
			(void)stream_file(m, 7, q);
		b = slurp_all(q, &nb);
		assert_int_equal(na, nb);
		assert_memory_equal(a, b, na);
		free(b);
	}
	free(a);
	unlink(p);
	unlink(q);
}

/* Bounds and checksums computed on threads, in pieces combined in order,
 * give the bytes of one pass, also with zeros of both signs at the
 * bounds; a bad record in a later piece is named by its number in the
 * map. */
static void
test_write_threads(void **state)
{
	struct pm_pmap m;
	struct pm_error err;
	struct pm_photon *ph;
	char q[PATHCAP];
	size_t i;

	(void)state;
	/* 400001 records: three pieces of the reader's size and a bit */
	make_pmap(&m, 3, 400001, 1000, 200000);
	check_write_threads(&m);
	ph = m.maps[0].photons;
	for (i = 0; i < (size_t)m.maps[0].count; i++) {
		ph[i].pos[0] = (i * 7919u) % 5 == 0 ? -0.0f :
		    fabsf(ph[i].pos[0]);
		ph[i].pos[1] = (i * 104729u) % 3 == 0 ? 0.0f :
		    fabsf(ph[i].pos[1]);
		ph[i].pos[2] = -fabsf(ph[i].pos[2]);
		if ((i * 31u) % 7 == 0)
			ph[i].pos[2] = i % 2 ? -0.0f : 0.0f;
	}
	check_write_threads(&m);
	ph[350000].pos[1] = NAN;
	assert_int_equal(pm_pmap_write_threads(tpath(q, "tn.pmap"), &m, false,
	    3, &err), PM_ERR_INVALID);
	assert_non_null(strstr(err.msg, "photon 350000 of the global map is "
	    "not at a finite position"));
	unlink(q);
	pm_pmap_free(&m);
}

/*
 * 64-bit sizes and offsets, on sparse files: a map of 300 million
 * photons (7.2 GB) and one placed beyond 4 GiB, in files one byte short,
 * which must be reported with exact 64-bit byte numbers before anything
 * is read or allocated.
 */
static void
test_large_offsets(void **state)
{
	static unsigned char buf[BUFCAP];
	struct pm_pmap m, r;
	struct pm_error err;
	struct stat st;
	char p[PATHCAP];
	uint64_t count = 300000000, off0 = 384, off1, end;
	char want[128];
	size_t n;
	int fd, mm;

	(void)state;
	tpath(p, "big.pmap");
	make_pmap(&m, 2, 1, 1, 0);
	n = write_bytes(&m, false, buf);
	assert_int_equal(rd32(buf + 12) <= off0, 1);
	off1 = (off0 + count * 24 + 63) / 64 * 64;
	end = off1 + 24;
	assert_true(off1 > (1ull << 32));
	wr64(buf + 64 + 16, count);
	wr64(buf + 64 + 24, count);
	wr64(buf + 64 + 40, off0);
	wr64(buf + 64 + 48, count * 24);
	wr64(buf + 160 + 40, off1);
	fix_crc(buf);
	for (mm = 0; mm < 2; mm++) {
		fd = open(p, O_WRONLY | O_CREAT | O_TRUNC, 0600);
		assert_true(fd >= 0);
		assert_true(write(fd, buf, 384) == 384);
		assert_int_equal(ftruncate(fd, (off_t)(end - 1)), 0);
		assert_int_equal(fstat(fd, &st), 0);
		assert_true((uint64_t)st.st_blocks * 512 < (1u << 20));
		close(fd);
		assert_int_equal(pm_pmap_read(p, &r, mm, &err),
		    PM_ERR_TRUNCATED);
		snprintf(want, sizeof(want), "truncated caustic map (bytes "
		    "%llu to %llu, file is %llu bytes)",
		    (unsigned long long)off1, (unsigned long long)end,
		    (unsigned long long)(end - 1));
		if (strstr(err.msg, want) == NULL)
			fail_msg("\"%s\" lacks \"%s\"", err.msg, want);
	}
	/* The global map cut one byte short of its 7.2 GB. */
	wr32(buf + 44, 1);
	memmove(buf + 160, buf + 256, n - 256);
	wr32(buf + 12, rd32(buf + 12) - 96);
	fix_crc(buf);
	fd = open(p, O_WRONLY | O_CREAT | O_TRUNC, 0600);
	assert_true(fd >= 0);
	assert_true(write(fd, buf, 384) == 384);
	assert_int_equal(ftruncate(fd, (off_t)(off0 + count * 24 - 1)), 0);
	close(fd);
	assert_int_equal(pm_pmap_read(p, &r, true, &err), PM_ERR_TRUNCATED);
	assert_non_null(strstr(err.msg, "(bytes 384 to 7200000384, file is "
	    "7200000383 bytes)"));
	unlink(p);
	pm_pmap_free(&m);
}

int
main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_roundtrip),
		cmocka_unit_test(test_rgbe_exponents),
		cmocka_unit_test(test_volume_roundtrip),
		cmocka_unit_test(test_mmap_private),
		cmocka_unit_test(test_spec_bytes),
		cmocka_unit_test(test_golden),
		cmocka_unit_test(test_v1_refused),
		cmocka_unit_test(test_info),
		cmocka_unit_test(test_find),
		cmocka_unit_test(test_magic),
		cmocka_unit_test(test_versions),
		cmocka_unit_test(test_truncated),
		cmocka_unit_test(test_bitflips),
		cmocka_unit_test(test_forged),
		cmocka_unit_test(test_empty_payload_order),
		cmocka_unit_test(test_forged_zlib),
		cmocka_unit_test(test_reserved_records),
		cmocka_unit_test(test_threads_check),
		cmocka_unit_test(test_pipes),
		cmocka_unit_test(test_stdout),
		cmocka_unit_test(test_write_errors),
		cmocka_unit_test(test_writer),
		cmocka_unit_test(test_write_begin_end),
		cmocka_unit_test(test_write_threads),
		cmocka_unit_test(test_large_offsets),
	};

	return cmocka_run_group_tests(tests, pm_tmpdir_setup, pm_tmpdir_teardown);
}
