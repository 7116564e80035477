/*
 * test_photonmap.c: the photon map's operations (common/photonmap.h).
 *
 * Photons are shot for real in a closed diffuse sphere lit from inside, so
 * that they come at many depths.  Two shards over disjoint index ranges,
 * given in either order and balanced or not, must merge into exactly the
 * bytes of the single run once both are in canonical order and balanced;
 * gaps are noted, overlaps, foreign seeds and kinds refused.  Statistics
 * must equal a recount done another way; the reader must report the
 * file's version and size and crc32s that match the records (from a
 * file, mapped or read, a buffer and a pipe, compressed or not); lookup
 * radii must follow the formulas of pm-render(1) and pm-balance(1).
 */
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

#include "../../common/photonmap.h"
#include "../../common/render.h"
#include "../../common/shoot.h"
#include "../../common/world.h"
#include "../../formats/pmap.h"
#include "tmpdir.h"

#define PATHS		20000	/* photon paths of the single run */
#define CUT		7919	/* where the shards meet */
#define SEED		42
#define CAUSTIC_SEED	99	/* the second map's: another stream */

struct world {
	struct pm_scene scene;
	struct pm_world traced;		/* ray caster and lights */
	struct pm_shooter shooter;
};

static struct world w;
static char tmpdir[64];

/* --- The scene and its shards ----------------------------------------- */

/* A diffuse sphere of the given albedo, seen from inside if flip. */
static int
diffuse_sphere(struct pm_scene *s, struct pm_vec3 c, float r, float albedo,
    bool flip)
{
	int b = pm_scene_add_bsdf(s), sh = pm_scene_add_shape(s);

	s->bsdfs[b].type = PM_BSDF_DIFFUSE;
	s->bsdfs[b].diffuse = pm_rgb1(albedo);
	s->shapes[sh] = (struct pm_shape){ .type = PM_SHAPE_SPHERE,
	    .center = c, .radius = r, .bsdf = b, .flip_normals = flip,
	    .light = -1 };
	return sh;
}

/* A closed sphere of albedo 0.6 around an emitting one. */
static int
setup(void **state)
{
	struct pm_scene *s = &w.scene;
	struct pm_error err;
	int sh, l;

	(void)state;
	if (pm_tmpdir_make(tmpdir, sizeof(tmpdir), "photonmap") != 0)
		return -1;
	pm_scene_init(s);
	diffuse_sphere(s, pm_v3(0, 0, 0), 10.0f, 0.6f, true);
	sh = diffuse_sphere(s, pm_v3(1, 2, 3), 1.0f, 0.0f, false);
	l = pm_scene_add_light(s);
	s->lights[l].type = PM_LIGHT_AREA;
	s->lights[l].radiance = pm_rgb(1.0f, 0.5f, 2.0f);
	s->lights[l].shape = sh;
	s->shapes[sh].light = l;
	if (pm_scene_prepare(s, &err) != PM_OK ||
	    pm_world_init(&w.traced, s, &err) != PM_OK ||
	    pm_shooter_init(&w.shooter, s, w.traced.accel, &w.traced.lights,
	    &err) != PM_OK)
		return -1;
	return 0;
}

static int
teardown(void **state)
{
	(void)state;
	pm_shooter_free(&w.shooter);
	pm_world_free(&w.traced);
	pm_scene_free(&w.scene);
	return pm_tmpdir_remove(tmpdir);
}

/* Shoots paths [first, first + count) into m, as pm-shoot would store
 * them (bounds of the positions, not balanced). */
static void
shoot_map(struct pm_map *m, enum pm_map_kind kind, uint64_t seed,
    uint64_t first, uint64_t count)
{
	struct pm_shoot_opts o = {PM_PASS_GLOBAL, seed, first, count, -1, 2,
	    NULL, NULL, NULL, NULL};
	struct pm_photon_buf b = {NULL, 0, 0};
	struct pm_shoot_stats st;
	struct pm_error err;
	size_t i;
	int a;

	assert_int_equal(pm_shoot(&w.shooter, &o, &b, &st, &err), PM_OK);
	memset(m, 0, sizeof(*m));
	m->kind = kind;
	m->count = b.n;
	m->emitted = count;
	m->first_index = first;
	m->photons = b.p;
	for (i = 0; i < b.n; i++)
		for (a = 0; a < 3; a++) {
			if (i == 0 || b.p[i].pos[a] < m->lo[a])
				m->lo[a] = b.p[i].pos[a];
			if (i == 0 || b.p[i].pos[a] > m->hi[a])
				m->hi[a] = b.p[i].pos[a];
		}
}

/* A shard of paths [first, first + count): a global map and a second
 * map (named caustic; the merge does not care what made it). */
static void
shoot_shard(struct pm_pmap *m, uint64_t first, uint64_t count)
{
	memset(m, 0, sizeof(*m));
	m->scene_hash = pm_scene_hash(&w.scene);
	m->seed = SEED;
	m->effects = PM_EFFECT_GLOBAL | PM_EFFECT_CAUSTICS;
	m->nmaps = 2;
	shoot_map(&m->maps[0], PM_MAP_GLOBAL, SEED, first, count);
	shoot_map(&m->maps[1], PM_MAP_CAUSTIC, CAUSTIC_SEED, first, count);
}

static void
balance_all(struct pm_pmap *m, int threads)
{
	struct pm_error err;
	int k;

	for (k = 0; k < m->nmaps; k++)
		assert_int_equal(pm_map_balance(&m->maps[k], threads, &err),
		    PM_OK);
}

static void
free_merged(struct pm_pmap *m)
{
	int k;

	for (k = 0; k < m->nmaps; k++)
		free(m->maps[k].photons);
	memset(m, 0, sizeof(*m));
}

struct gaps {
	int n;
	enum pm_map_kind kind[4];
	uint64_t from[4], to[4];
};

static void
note_gap(void *arg, enum pm_map_kind kind, uint64_t from, uint64_t to)
{
	struct gaps *g = arg;

	if (g->n < 4) {
		g->kind[g->n] = kind;
		g->from[g->n] = from;
		g->to[g->n] = to;
	}
	g->n++;
}

/* --- Merging ------------------------------------------------------------ */

/* Two shards, the later given first and balanced already, merge into the
 * single run's bytes. */
static void
test_merge_equals_one_run(void **state)
{
	struct pm_pmap one, a, b, out;
	struct pm_shard in[2];
	struct pm_error err;
	struct gaps g = {0};
	int order[2] = {-1, -1}, k, x;

	(void)state;
	shoot_shard(&one, 0, PATHS);
	shoot_shard(&a, 0, CUT);
	shoot_shard(&b, CUT, PATHS - CUT);
	balance_all(&b, 1);
	in[0].name = "b.pmap";
	in[0].m = &b;
	in[1].name = "a.pmap";
	in[1].m = &a;
	assert_int_equal(pm_pmap_compatible(&in[0], &in[1], &err), PM_OK);
	memset(&out, 0, sizeof(out));
	assert_int_equal(pm_pmap_merge(in, 2, &out, order, note_gap, &g,
	    &err), PM_OK);
	/* a's paths come first: its provenance is the one kept. */
	assert_int_equal(order[0], 1);
	assert_int_equal(order[1], 0);
	assert_int_equal(g.n, 0);
	assert_true(out.scene_hash == one.scene_hash);
	assert_true(out.seed == SEED);
	assert_int_equal(out.effects, one.effects);
	assert_int_equal(out.nmaps, 2);
	for (k = 0; k < 2; k++) {
		struct pm_map *m = &out.maps[k], *o = &one.maps[k];

		assert_int_equal(m->kind, o->kind);
		assert_int_equal(m->count, o->count);
		assert_int_equal(m->emitted, PATHS);
		assert_int_equal(m->first_index, 0);
		assert_false(m->balanced);
		for (x = 0; x < 3; x++) {
			assert_true(m->lo[x] == o->lo[x]);
			assert_true(m->hi[x] == o->hi[x]);
		}
		/* The same set of photons: the same canonical order. */
		pm_map_canonical_order(m, 1);
		pm_map_canonical_order(o, 1);
		assert_memory_equal(m->photons, o->photons,
		    (size_t)o->count * sizeof(*o->photons));
		/* One thread here, two for the single run: the tree is the
		 * same whatever the count. */
		assert_int_equal(pm_map_build_tree(m, 1, &err), PM_OK);
		assert_int_equal(pm_map_build_tree(o, 2, &err), PM_OK);
		assert_true(m->balanced);
		assert_memory_equal(m->photons, o->photons,
		    (size_t)o->count * sizeof(*o->photons));
	}
	free_merged(&out);
	pm_pmap_free(&a);
	pm_pmap_free(&b);
	pm_pmap_free(&one);
}

/* A map of n random records (split-axis bits among them, duplicates, a
 * crowded first byte) for paths [first, first + 1000). */
static void
random_map(struct pm_map *m, size_t n, uint64_t first, uint64_t seed)
{
	struct pm_rng rng = pm_rng_seed(seed, 0, 0);
	size_t i, k;
	int a;

	memset(m, 0, sizeof(*m));
	m->kind = PM_MAP_GLOBAL;
	m->first_index = first;
	m->emitted = 1000;
	m->count = n;
	m->photons = malloc(n * sizeof(*m->photons));
	assert_non_null(m->photons);
	for (i = 0; i < n; i++) {
		unsigned char *r = (unsigned char *)&m->photons[i];

		for (k = 0; k < sizeof(struct pm_photon); k++)
			r[k] = (unsigned char)(pm_rng_u32(&rng) >> 24);
		if (i % 5 == 2)
			m->photons[i] = m->photons[i - 1];
		if (i % 7 == 3)
			r[0] = 200;
	}
	for (a = 0; a < 3; a++) {
		m->lo[a] = -1.0f;
		m->hi[a] = 1.0f;
	}
}

/* pm_pmap_merge_canonical: the bytes of pm_pmap_merge then
 * pm_map_canonical_order, split-axis bits cleared, for 1, 2 and 5
 * threads (the shards' records are given back as they are copied, so each
 * merge gets fresh copies). */
static void
test_merge_canonical(void **state)
{
	const size_t na = 70000, nb = 50000;
	struct pm_map ma, mb;
	struct pm_pmap a, b, ref, out;
	struct pm_shard in[2];
	struct pm_error err;
	int threads[3] = {1, 2, 5}, t, order[2];
	size_t i;

	(void)state;
	random_map(&ma, na, 1000, 3);
	random_map(&mb, nb, 0, 4);
	memset(&a, 0, sizeof(a));
	a.seed = SEED;
	a.nmaps = 1;
	b = a;
	in[0].name = "a.pmap";
	in[0].m = &a;
	in[1].name = "b.pmap";
	in[1].m = &b;
	for (t = -1; t < 3; t++) {
		a.maps[0] = ma;
		a.maps[0].photons = malloc(na * sizeof(*ma.photons));
		b.maps[0] = mb;
		b.maps[0].photons = malloc(nb * sizeof(*mb.photons));
		assert_non_null(a.maps[0].photons);
		assert_non_null(b.maps[0].photons);
		memcpy(a.maps[0].photons, ma.photons, na * sizeof(*ma.photons));
		memcpy(b.maps[0].photons, mb.photons, nb * sizeof(*mb.photons));
		memset(&out, 0, sizeof(out));
		if (t < 0) {
			assert_int_equal(pm_pmap_merge(in, 2, &ref, order, NULL,
			    NULL, &err), PM_OK);
			pm_map_canonical_order(&ref.maps[0], 1);
		} else {
			assert_int_equal(pm_pmap_merge_canonical(in, 2, &out,
			    order, NULL, NULL, threads[t], &err), PM_OK);
			assert_int_equal(order[0], 1);
			assert_int_equal(out.maps[0].count, na + nb);
			assert_int_equal(out.maps[0].emitted, 2000);
			assert_false(out.maps[0].balanced);
			assert_memory_equal(out.maps[0].photons,
			    ref.maps[0].photons, (na + nb) *
			    sizeof(*ref.maps[0].photons));
			free_merged(&out);
		}
		free(a.maps[0].photons);
		free(b.maps[0].photons);
	}
	for (i = 0; i < na + nb; i++)
		assert_int_equal(ref.maps[0].photons[i].flags &
		    PM_KD_AXIS_MASK, 0);
	free_merged(&ref);
	free(ma.photons);
	free(mb.photons);
}

/* The canonical order on threads (the first byte's buckets sorted in
 * parallel) is the one-thread order, byte for byte: random records with
 * many duplicates and a crowded first byte, for 2, 3 and 8 threads. */
static void
test_canonical_order_threads(void **state)
{
	const size_t n = 200000, size = n * sizeof(struct pm_photon);
	struct pm_map in, ref, c;
	struct pm_rng rng = pm_rng_seed(7, 0, 0);
	size_t i, k;
	int threads[3] = {2, 3, 8}, t;

	(void)state;
	memset(&in, 0, sizeof(in));
	in.count = n;
	in.photons = malloc(size);
	assert_non_null(in.photons);
	for (i = 0; i < n; i++) {
		unsigned char *r = (unsigned char *)&in.photons[i];

		for (k = 0; k < sizeof(struct pm_photon); k++)
			r[k] = (unsigned char)(pm_rng_u32(&rng) >> 24);
		if (i % 4 == 1)		/* duplicates */
			in.photons[i] = in.photons[i - 1];
		if (i % 8 == 3)		/* a bucket far larger than the rest */
			r[0] = 17;
	}
	ref = in;
	ref.photons = malloc(size);
	c = in;
	c.photons = malloc(size);
	assert_non_null(ref.photons);
	assert_non_null(c.photons);
	memcpy(ref.photons, in.photons, size);
	pm_map_canonical_order(&ref, 1);
	for (i = 1; i < n; i++)
		assert_true(memcmp(&ref.photons[i - 1], &ref.photons[i],
		    sizeof(struct pm_photon)) <= 0);
	for (t = 0; t < 3; t++) {
		memcpy(c.photons, in.photons, size);
		pm_map_canonical_order(&c, threads[t]);
		assert_memory_equal(ref.photons, c.photons, size);
	}
	free(in.photons);
	free(ref.photons);
	free(c.photons);
}

/* The canonical order is the records' bytes, split-axis bits cleared;
 * balancing a balanced map changes nothing. */
static void
test_canonical_order(void **state)
{
	struct pm_pmap one;
	struct pm_map *m = &one.maps[0];
	struct pm_photon *copy;
	struct pm_error err;
	size_t i, n;

	(void)state;
	shoot_shard(&one, 0, 3000);
	n = (size_t)m->count;
	assert_true(n > 1000);
	/* Shuffle, so that the sort has work whatever the shooter's order. */
	for (i = n - 1; i > 0; i--) {
		size_t j = (i * 2654435761u) % (i + 1);
		struct pm_photon t = m->photons[i];

		m->photons[i] = m->photons[j];
		m->photons[j] = t;
	}
	pm_map_canonical_order(m, 1);
	for (i = 0; i < n; i++)
		assert_int_equal(m->photons[i].flags & PM_KD_AXIS_MASK, 0);
	for (i = 1; i < n; i++)
		assert_true(memcmp(&m->photons[i - 1], &m->photons[i],
		    sizeof(*m->photons)) <= 0);
	assert_int_equal(pm_map_build_tree(m, 2, &err), PM_OK);
	assert_true(m->balanced);
	copy = malloc(n * sizeof(*copy));
	assert_non_null(copy);
	memcpy(copy, m->photons, n * sizeof(*copy));
	assert_int_equal(pm_map_balance(m, 3, &err), PM_OK);
	assert_memory_equal(copy, m->photons, n * sizeof(*copy));
	free(copy);
	pm_pmap_free(&one);
}

/* Paths no shard covers are noted; overlapping ones, other seeds and
 * other kinds of map are refused with the names. */
static void
test_merge_checks(void **state)
{
	struct pm_pmap a, b, out;
	struct pm_shard in[2];
	struct pm_error err;
	struct gaps g = {0};
	uint64_t dropped;

	(void)state;
	shoot_shard(&a, 0, 500);
	shoot_shard(&b, 600, 400);
	in[0].name = "a.pmap";
	in[0].m = &a;
	in[1].name = "b.pmap";
	in[1].m = &b;
	memset(&out, 0, sizeof(out));
	assert_int_equal(pm_pmap_merge(in, 2, &out, NULL, note_gap, &g, &err),
	    PM_OK);
	assert_int_equal(g.n, 2);
	assert_int_equal(g.kind[0], PM_MAP_GLOBAL);
	assert_int_equal(g.kind[1], PM_MAP_CAUSTIC);
	assert_int_equal(g.from[0], 500);
	assert_int_equal(g.to[0], 600);
	assert_int_equal(out.maps[0].emitted, 900);
	assert_int_equal(out.maps[0].count, a.maps[0].count +
	    b.maps[0].count);
	free_merged(&out);
	pm_pmap_free(&a);
	pm_pmap_free(&b);

	shoot_shard(&a, 0, 500);
	shoot_shard(&b, 499, 100);
	memset(&out, 0, sizeof(out));
	assert_int_equal(pm_pmap_merge(in, 2, &out, NULL, NULL, NULL, &err),
	    PM_ERR_INVALID);
	assert_string_equal(err.msg, "b.pmap: global photon paths [499, 599) "
	    "overlap those of a.pmap [0, 500)");
	assert_null(out.maps[0].photons);
	assert_null(out.maps[1].photons);

	b.seed = SEED + 1;
	assert_int_equal(pm_pmap_compatible(&in[0], &in[1], &err),
	    PM_ERR_INVALID);
	assert_string_equal(err.msg, "b.pmap: seed 43 differs from a.pmap's "
	    "(42)");
	b.seed = SEED;
	b.nmaps = 1;
	assert_int_equal(pm_pmap_compatible(&in[0], &in[1], &err),
	    PM_ERR_INVALID);
	assert_string_equal(err.msg, "b.pmap: holds global maps, a.pmap holds "
	    "global+caustic");
	b.nmaps = 2;

	/* An irradiance map is dropped, its records kept for freeing. */
	balance_all(&b, 2);
	{
		struct pm_irradiance_setup s = {4, 8, 0.05f, 0, 2.0f / 3.0f, 2};

		assert_int_equal(pm_pmap_add_irradiance(&b, &s, &err), PM_OK);
	}
	assert_int_equal(b.nmaps, 3);
	assert_int_equal(b.maps[2].kind, PM_MAP_IRRADIANCE);
	dropped = b.maps[2].count;
	assert_true(dropped > 0);
	{
		/* Irradiance first: the others move up. */
		struct pm_map t = b.maps[0];

		b.maps[0] = b.maps[2];
		b.maps[2] = t;
	}
	assert_int_equal(pm_pmap_drop_irradiance(&b), dropped);
	assert_int_equal(b.nmaps, 2);
	assert_int_equal(b.maps[0].kind, PM_MAP_CAUSTIC);
	assert_int_equal(b.maps[1].kind, PM_MAP_GLOBAL);
	assert_int_equal(b.maps[2].kind, PM_MAP_IRRADIANCE);
	assert_int_equal(pm_pmap_drop_irradiance(&b), 0);
	pm_pmap_free(&a);
	pm_pmap_free(&b);
}

/* --- Statistics --------------------------------------------------------- */

/* The statistics equal a recount: depth by depth, flag by flag, flux in
 * long double. */
static void
test_stats_recount(void **state)
{
	struct pm_pmap one;
	struct pm_map_stats s;
	uint64_t total = 0, n, vd, ca;
	long double sum[3];
	double max_e;
	int d, c, deepest = -1;
	size_t i;

	(void)state;
	shoot_shard(&one, 0, 5000);
	for (c = 0; c < one.nmaps; c++) {
		const struct pm_map *m = &one.maps[c];

		pm_map_stats(m, &s);
		for (d = 0; d < 256; d++) {
			for (n = 0, i = 0; i < (size_t)m->count; i++)
				n += m->photons[i].depth == d;
			assert_int_equal(s.depth[d], n);
			total += n;
			if (n > 0)
				deepest = d;
		}
		assert_int_equal(total, m->count);
		assert_int_equal(s.max_depth, deepest);
		assert_true(s.max_depth >= 3);	/* albedo 0.6: bounces */
		vd = ca = 0;
		sum[0] = sum[1] = sum[2] = 0.0L;
		max_e = 0.0;
		for (i = (size_t)m->count; i-- > 0;) {
			const struct pm_photon *p = &m->photons[i];
			struct pm_rgb e = pm_rgbe_unpack(p->power);

			vd += (p->flags & PM_PHOTON_VIA_DIFFUSE) != 0;
			ca += (p->flags & PM_PHOTON_CAUSTIC) != 0;
			sum[0] += e.r;
			sum[1] += e.g;
			sum[2] += e.b;
			max_e = fmax(max_e, fmax(e.r, fmax(e.g, e.b)));
		}
		assert_int_equal(s.via_diffuse, vd);
		assert_int_equal(s.caustic, ca);
		assert_true(s.max_e == max_e);
		for (i = 0; i < 3; i++) {
			double f = (double)(sum[i] / m->emitted);
			double e = (double)(sum[i] / m->count);

			assert_true(fabs(s.flux[i] - f) <= 1e-9 * f);
			assert_true(fabs(s.mean_e[i] - e) <= 1e-9 * e);
		}
		total = 0;
		deepest = -1;
	}
	/* An empty map: nothing, and no division by zero. */
	one.maps[0].count = 0;
	one.maps[0].emitted = 0;
	pm_map_stats(&one.maps[0], &s);
	assert_int_equal(s.max_depth, -1);
	assert_true(s.flux[0] == 0.0 && s.mean_e[0] == 0.0 && s.max_e == 0.0);
	pm_pmap_free(&one);
}

/* --- What the reader reports ------------------------------------------- */

static unsigned char *
slurp(const char *path, size_t *len)
{
	unsigned char *buf;
	struct stat st;
	FILE *f;

	assert_int_equal(stat(path, &st), 0);
	*len = (size_t)st.st_size;
	buf = malloc(*len);
	assert_non_null(buf);
	f = fopen(path, "rb");
	assert_non_null(f);
	assert_int_equal(fread(buf, 1, *len, f), *len);
	fclose(f);
	return buf;
}

/* Reads buf through a pipe on standard input, as `cat f | tool -` does. */
static void
read_piped(const unsigned char *buf, size_t len, struct pm_pmap *r)
{
	struct pm_error err;
	int fds[2], saved;
	pid_t pid;

	assert_int_equal(pipe(fds), 0);
	pid = fork();
	assert_true(pid >= 0);
	if (pid == 0) {
		size_t at = 0;
		ssize_t k;

		close(fds[0]);
		while (at < len && (k = write(fds[1], buf + at, len - at)) > 0)
			at += (size_t)k;
		_exit(at == len ? 0 : 1);
	}
	close(fds[1]);
	saved = dup(STDIN_FILENO);
	assert_true(saved >= 0);
	assert_int_equal(dup2(fds[0], STDIN_FILENO), STDIN_FILENO);
	close(fds[0]);
	assert_int_equal(pm_pmap_read("-", r, true, &err), PM_OK);
	assert_int_equal(dup2(saved, STDIN_FILENO), STDIN_FILENO);
	close(saved);
	assert_int_equal(waitpid(pid, NULL, 0), pid);
}

/* The reader's version, size and crc32s, by every way of reading. */
static void
test_reader_reports(void **state)
{
	struct pm_irradiance_setup s = {8, 16, 0.05f, 0, 2.0f / 3.0f, 2};
	struct pm_pmap one, r;
	struct pm_error err;
	uint32_t want[3];
	unsigned char *buf;
	char path[128];
	size_t len;
	int c, how, k;

	(void)state;
	shoot_shard(&one, 0, 4000);
	balance_all(&one, 2);
	assert_int_equal(pm_pmap_add_irradiance(&one, &s, &err), PM_OK);
	assert_int_equal(one.nmaps, 3);
	/* The records as the file stores them: little-endian, as memory is
	 * on the hosts this test runs on. */
	for (k = 0; k < 3; k++)
		want[k] = (uint32_t)crc32(0, (const Bytef *)one.maps[k].photons,
		    (uInt)(one.maps[k].count * sizeof(struct pm_photon)));
	snprintf(path, sizeof(path), "%s/m.pmap", tmpdir);
	for (c = 0; c < 2; c++) {
		assert_int_equal(pm_pmap_write(path, &one, c == 1, &err),
		    PM_OK);
		buf = slurp(path, &len);
		for (how = 0; how < 4; how++) {
			if (how < 2)
				assert_int_equal(pm_pmap_read(path, &r,
				    how == 1, &err), PM_OK);
			else if (how == 2)
				assert_int_equal(pm_pmap_parse("m.pmap", buf,
				    len, &r, &err), PM_OK);
			else
				read_piped(buf, len, &r);
			assert_int_equal(r.version_major,
			    PM_PMAP_VERSION_MAJOR);
			/* no volume map: written as 2.0 (pmap.5) */
			assert_int_equal(r.version_minor, 0);
			assert_int_equal(r.file_bytes, len);
			assert_int_equal(r.nmaps, 3);
			for (k = 0; k < 3; k++) {
				/* Entry k of the map table: crc at 12, offset
				 * at 40, stored size at 48 (pmap(5)). */
				const unsigned char *e = buf + 64 + 96 * k;
				uint64_t off, st;
				uint32_t crc;

				/* Little-endian, as this host is (above). */
				memcpy(&crc, e + 12, 4);
				memcpy(&off, e + 40, 8);
				memcpy(&st, e + 48, 8);

				assert_true(off + st <= len);
				assert_int_equal(r.maps[k].records_crc,
				    want[k]);
				assert_int_equal(r.maps[k].stored_crc, crc);
				assert_int_equal(r.maps[k].stored_crc,
				    (uint32_t)crc32(0, buf + off, (uInt)st));
				if (c == 0)
					assert_int_equal(r.maps[k].stored_crc,
					    want[k]);
				else
					assert_int_not_equal(
					    r.maps[k].stored_crc, want[k]);
			}
			pm_pmap_free(&r);
		}
		free(buf);
	}
	unlink(path);
	pm_pmap_free(&one);
}

/* --- Lookups ------------------------------------------------------------ */

/* r(1) times the schedule r(I+1)^2 = r(I)^2 (I + alpha) / (I + 1),
 * multiplied out here (pm-render(1)). */
static double
schedule_r2(double r1, long pass, double alpha)
{
	double r2 = r1 * r1;
	long i;

	for (i = 1; i < pass; i++)
		r2 *= (i + alpha) / (i + 1);
	return r2;
}

static void
assert_close(double got, double want)
{
	assert_true(fabs(got - want) <= 1e-6 * want);
}

static void
test_lookup_radii(void **state)
{
	static const float scene_r[] = {1.0f, 7.5f, 1234.0f};
	static const double alphas[] = {0.5, 2.0 / 3.0, 0.9};
	struct pm_lookup_radii r;
	long pass;
	int i, j;

	(void)state;
	for (i = 0; i < 3; i++) {
		float R = scene_r[i];

		/* Not progressive: fractions of the bounding sphere. */
		r = pm_lookup_radii(0.05f, 0.0125f, R, 0, 2.0 / 3.0, 0.0f);
		assert_false(r.fixed);
		assert_close(r.global_r2, (0.05 * R) * (0.05 * R));
		assert_close(r.caustic_r2, (0.0125 * R) * (0.0125 * R));
		for (j = 0; j < 3; j++)
			for (pass = 1; pass <= 64; pass *= 2) {
				double a = alphas[j];

				r = pm_lookup_radii(0.05f, 0.0125f, R, pass, a,
				    0.0f);
				assert_true(r.fixed);
				assert_close(r.global_r2,
				    schedule_r2(0.05 * R, pass, a));
				assert_close(r.caustic_r2,
				    schedule_r2(0.0125 * R, pass, a));
				/* --radius: the first global radius, the
				 * caustic one keeping its ratio. */
				r = pm_lookup_radii(0.05f, 0.0125f, R, pass, a,
				    0.02f);
				assert_close(r.global_r2,
				    schedule_r2(0.02 * R, pass, a));
				assert_close(r.caustic_r2,
				    schedule_r2(0.005 * R, pass, a));
			}
	}
	assert_int_equal(pm_photon_depth_cap(-1), 0);
	assert_int_equal(pm_photon_depth_cap(2), 0);
	assert_int_equal(pm_photon_depth_cap(8), 6);
}

/* Irradiance records: a fraction of the half-diagonal of the global
 * map's bounds (pm-balance(1)), shrinking along the same schedule. */
static void
test_irradiance_radius(void **state)
{
	struct pm_irradiance_setup s = {8, 32, 0.05f, 0, 2.0f / 3.0f, 1};
	struct pm_map g;
	double half;

	(void)state;
	memset(&g, 0, sizeof(g));
	g.lo[0] = -1.0f, g.lo[1] = 0.0f, g.lo[2] = 2.0f;
	g.hi[0] = 3.0f, g.hi[1] = 3.0f, g.hi[2] = 14.0f;
	half = 0.5 * sqrt(4.0 * 4.0 + 3.0 * 3.0 + 12.0 * 12.0);	/* 6.5 */
	assert_close(pm_irradiance_setup_r2(&g, &s), (0.05 * half) *
	    (0.05 * half));
	s.pass = 5;
	s.alpha = 0.7f;
	assert_close(pm_irradiance_setup_r2(&g, &s), schedule_r2(0.05 * half,
	    5, 0.7f));
}

/* A render borrows the records, with 1/emitted, and only balanced. */
static void
test_photon_maps(void **state)
{
	struct pm_pmap one;
	struct pm_photon_maps maps;
	struct pm_error err;

	(void)state;
	shoot_shard(&one, 0, 1000);
	assert_int_equal(pm_photon_maps_from_pmap(&one, &maps, &err),
	    PM_ERR_INVALID);
	assert_string_equal(err.msg, "the global map is not balanced; run "
	    "pm-balance on it first");
	balance_all(&one, 2);
	assert_int_equal(pm_photon_maps_from_pmap(&one, &maps, &err), PM_OK);
	assert_ptr_equal(maps.global, one.maps[0].photons);
	assert_int_equal(maps.nglobal, one.maps[0].count);
	assert_true(maps.global_scale == 1.0f / 1000.0f);
	assert_ptr_equal(maps.caustic, one.maps[1].photons);
	assert_null(maps.irradiance);
	assert_false(maps.fixed_radius);
	assert_string_equal(pm_map_kind_name(PM_MAP_IRRADIANCE), "irradiance");
	assert_ptr_equal(pm_pmap_find(&one, PM_MAP_CAUSTIC), &one.maps[1]);
	assert_null(pm_pmap_find(&one, PM_MAP_IRRADIANCE));
	pm_pmap_free(&one);
}

int
main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_merge_equals_one_run),
		cmocka_unit_test(test_canonical_order),
		cmocka_unit_test(test_canonical_order_threads),
		cmocka_unit_test(test_merge_canonical),
		cmocka_unit_test(test_merge_checks),
		cmocka_unit_test(test_stats_recount),
		cmocka_unit_test(test_reader_reports),
		cmocka_unit_test(test_lookup_radii),
		cmocka_unit_test(test_irradiance_radius),
		cmocka_unit_test(test_photon_maps),
	};

	return cmocka_run_group_tests(tests, setup, teardown);
}
