/*
 * photonmap.h: the photon map as a library type and its operations.
 *
 * A file (formats/pmap.h) holds up to three maps of one scene: global,
 * caustic and precomputed irradiance.  Here is what the tools do with
 * them, so that a test can call it: merging shards shot over disjoint
 * index ranges into the map one run would give (in a canonical order that
 * depends only on the set of photons), balancing kd-trees, adding
 * irradiance records, counting statistics, and setting up lookups (radii
 * and the progressive schedule).  Nothing here prints, exits or touches a
 * file; failures come back as a code with a message in struct pm_error.
 */
#ifndef PM_PHOTONMAP_H
#define PM_PHOTONMAP_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "error.h"
#include "photon.h"

enum pm_map_kind {
	PM_MAP_GLOBAL = 1,
	PM_MAP_CAUSTIC = 2,
	/* Precomputed irradiance (Christensen 1999): records in the photon
	 * layout whose power is the irradiance E (W/m^2, not divided by
	 * emitted, which is 0 as first_index is), whose normal is the
	 * surface's, at a fraction of the global photons; made by
	 * pm-balance.  dir is undefined (0) and depth 0. */
	PM_MAP_IRRADIANCE = 3,
	/* The volume photon map (Jensen and Christensen 1998): photons
	 * stored where they scattered in a participating medium, shot
	 * with the global map (same paths, same emitted count).  normal
	 * is undefined (0); power is the flux leaving the scatter before
	 * Russian roulette, i.e. already times the medium's
	 * sigma_s / sigma_t for that flight (see shoot.c), so that
	 * sum(phase * power) / (emitted * volume) estimates the
	 * in-scattered radiance sigma_s * integral(phase * L). */
	PM_MAP_VOLUME = 4,
};

/* Effects a map file simulates (header field `effects`). */
enum {
	PM_EFFECT_GLOBAL = 1 << 0,	/* diffuse interreflection: a global map */
	PM_EFFECT_CAUSTICS = 1 << 1,	/* specular-to-diffuse: a caustic map */
	PM_EFFECT_REFRACTION = 1 << 2,	/* the scene has dielectrics */
	PM_EFFECT_MEDIA = 1 << 3,	/* participating media: a volume map */
};

struct pm_map {
	enum pm_map_kind kind;
	uint64_t count;			/* photons stored */
	uint64_t emitted;		/* photon paths shot for this map: the
					 * flux normaliser */
	uint64_t first_index;		/* index of the first path shot */
	bool balanced;			/* photons are in kd-tree order */
	float lo[3], hi[3];		/* bounds of the positions (set by
					 * the reader; the writer computes
					 * its own) */
	float radius;			/* irradiance maps: the lookup radius
					 * the records were computed with,
					 * 0 if unknown; 0 for other kinds */
	struct pm_photon *photons;	/* count records (owned or mapped) */
	/* Set by the reader, ignored by the writer (which computes its
	 * own): the crc32 the file stores for this map (of the stored,
	 * perhaps compressed, bytes) and the crc32 of the records as they
	 * are stored uncompressed (equal when the map is not compressed). */
	uint32_t stored_crc;
	uint32_t records_crc;
};

struct pm_pmap {
	uint64_t scene_hash;		/* pm_scene_hash of the scene shot */
	uint64_t seed;
	uint32_t effects;		/* PM_EFFECT_* */
	uint32_t max_depth;		/* photon bounces allowed, 0 unlimited */
	char *info;			/* provenance: "key=value\n" lines, NUL-
					 * terminated, each tool appending its
					 * own; owned */
	int nmaps;			/* 0 to 4 */
	struct pm_map maps[4];
	/* Set by the reader, ignored by the writer: the file's version and
	 * its size in bytes (what a pipe gave, to its end). */
	unsigned version_major, version_minor;
	uint64_t file_bytes;
	/* Private: set by the reader when the photons are memory-mapped. */
	void *mapped;
	size_t mapped_len;
};

/* "global", "caustic", "irradiance", "volume" or "unknown"; static. */
const char *pm_map_kind_name(enum pm_map_kind kind);

/* The map of the given kind in m, or NULL. */
struct pm_map *pm_pmap_find(struct pm_pmap *m, enum pm_map_kind kind);

/* --- Merging shards ---------------------------------------------------- */

/* One input of a merge: a shard as read, and the name messages give it. */
struct pm_shard {
	const char *name;
	struct pm_pmap *m;
};

/*
 * Takes m's irradiance map out of it: its records estimate irradiance from
 * that shard's global photons alone, so they cannot be merged with
 * another's, and they lose their kd-tree order once the photons they
 * describe are rebalanced.  The other maps keep their order; the last
 * slot keeps the records, so that pm_pmap_free, which frees every slot,
 * still frees them.  Returns the records dropped, 0 if there was none.
 */
uint64_t pm_pmap_drop_irradiance(struct pm_pmap *m);

/*
 * PM_OK if b can be merged with a: every field that decides which photons
 * a path stores must agree (scene, seed, effects, depth cap, kinds of
 * map).  Otherwise PM_ERR_INVALID with the difference, naming b first.
 */
enum pm_err pm_pmap_compatible(const struct pm_shard *a,
    const struct pm_shard *b, struct pm_error *err);

/* Called with each gap in the paths the shards cover, for a note. */
typedef void pm_merge_note_fn(void *arg, enum pm_map_kind kind,
    uint64_t from, uint64_t to);

/*
 * Merges the maps of n compatible shards (irradiance maps dropped) into
 * out's maps and header fields (out->info is left alone): for each kind,
 * in the first shard's order of kinds, the shards' index ranges must be
 * disjoint; the photons are concatenated in order of first index, the
 * emitted counts added and the bounds merged.  The maps come out not
 * balanced and not yet in canonical order.  Each shard's records are
 * given back to the system page by page as they are copied, so the peak
 * memory stays near one map's; the shards must not be used afterwards
 * except to free them.  order (n entries, may be NULL) receives the
 * shards' indices in merge order of the first map (the given order when
 * there are no maps): order[0]'s provenance is the one to keep.  note
 * (may be NULL) hears of paths no shard covers.  out's photons are owned
 * by the caller (free each out->maps[i].photons), also on failure.
 */
enum pm_err pm_pmap_merge(const struct pm_shard *in, int n,
    struct pm_pmap *out, int *order, pm_merge_note_fn *note, void *note_arg,
    struct pm_error *err);

/*
 * pm_pmap_merge with the maps coming out in canonical order (see
 * pm_map_canonical_order), the same bytes, the sort's first pass done by
 * the copy and the rest on up to `threads` threads: what pm-balance does.
 */
enum pm_err pm_pmap_merge_canonical(const struct pm_shard *in, int n,
    struct pm_pmap *out, int *order, pm_merge_note_fn *note, void *note_arg,
    int threads, struct pm_error *err);

/* --- Balancing --------------------------------------------------------- */

/*
 * Puts m's records in the canonical order: split-axis bits cleared, then
 * sorted by their bytes as memcmp orders them.  The order depends only on
 * the set of photons, so shards given in any order, balanced or not, give
 * the very bytes one unsharded run does, whatever the thread count (the
 * buckets of the first byte are sorted on up to `threads` threads).
 */
void pm_map_canonical_order(struct pm_map *m, int threads);

/* Builds m's kd-tree in place (threads >= 1) and marks it balanced. */
enum pm_err pm_map_build_tree(struct pm_map *m, int threads,
    struct pm_error *err);

/* Both of the above: m in canonical order, then balanced. */
enum pm_err pm_map_balance(struct pm_map *m, int threads,
    struct pm_error *err);

/* How pm-balance makes irradiance records (see pm-balance(1)). */
struct pm_irradiance_setup {
	size_t stride;		/* one record per stride global photons */
	int k;			/* photons per record (k-nearest) */
	float radius;		/* largest radius, as a fraction of the
				 * global map's half-diagonal */
	long pass;		/* progressive pass (1, 2, ...): a fixed
				 * radius; 0: k-nearest within radius */
	float alpha;		/* the progressive schedule */
	int threads;
};

/*
 * The squared record radius for global map g: radius times g's half-
 * diagonal (from its bounds), times the progressive schedule's scale for
 * pass > 0.
 */
float pm_irradiance_setup_r2(const struct pm_map *g,
    const struct pm_irradiance_setup *s);

/*
 * Adds precomputed irradiance records (irradiance.h), with their own
 * kd-tree, made from m's balanced global map.  Does nothing (PM_OK) when
 * m has no global photons, already has irradiance records or has no free
 * slot.  The new map's photons belong to m's caller as the others do.
 */
enum pm_err pm_pmap_add_irradiance(struct pm_pmap *m,
    const struct pm_irradiance_setup *s, struct pm_error *err);

/* Whether pm_pmap_add_irradiance would add a map to m; if so, its entry
 * in *r as it will be but for its records and count (pm_pmap_write_begin's
 * last map). */
bool pm_pmap_irradiance_entry(const struct pm_pmap *m,
    const struct pm_irradiance_setup *s, struct pm_map *r);

/* --- Statistics -------------------------------------------------------- */

struct pm_map_stats {
	double flux[3];			/* watts: sum of power / emitted */
	/* Irradiance maps, whose records hold E, not flux: */
	double mean_e[3];		/* W/m^2, over the records */
	double max_e;			/* W/m^2, the largest channel */
	uint64_t depth[256];		/* photons per depth */
	int max_depth;			/* largest depth present, -1: none */
	uint64_t via_diffuse, caustic;	/* photons with each flag */
};

/* Counts s over m's records (s is overwritten). */
void pm_map_stats(const struct pm_map *m, struct pm_map_stats *s);

/* --- Lookups ----------------------------------------------------------- */

/* Squared lookup radii of a render, and whether they are fixed. */
struct pm_lookup_radii {
	float global_r2, caustic_r2;
	bool fixed;		/* progressive: every photon within counts */
};

/*
 * The lookup radii of a render: global and caustic are fractions of the
 * scene's bounding-sphere radius, as in Mitsuba 0.6's photon mapper.  For
 * a progressive pass (pass > 0) both start there -- or, with first > 0,
 * where that global radius puts them, keeping their ratio -- and shrink
 * together by pm_pppm_radius_scale(pass, alpha), fixed.
 */
struct pm_lookup_radii pm_lookup_radii(float global, float caustic,
    float scene_radius, long pass, double alpha, float first);

struct pm_photon_maps;

/*
 * Points maps at pm's global, caustic and irradiance records with their
 * flux normalisers (1 / emitted; irradiance records hold E, undivided);
 * the other fields of maps are zeroed.  PM_ERR_INVALID if a map of more
 * than one photon is not balanced.  maps borrows pm's records.
 */
enum pm_err pm_photon_maps_from_pmap(const struct pm_pmap *pm,
    struct pm_photon_maps *maps, struct pm_error *err);

/*
 * The photons' bounce cap pm-shoot stores for a scene's max_depth (-1:
 * unlimited): max_depth - 2, 0 for no limit.
 */
uint32_t pm_photon_depth_cap(int scene_max_depth);

#endif
