/*
 * pmap.h: the photon-map file, pm's contract between tools.  man/pmap.5
 * specifies every byte; this is its reader and writer.
 */
#ifndef PM_PMAP_H
#define PM_PMAP_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "../common/error.h"
#include "../common/photon.h"

#define PM_PMAP_VERSION_MAJOR 2
#define PM_PMAP_VERSION_MINOR 0

enum pm_map_kind {
	PM_MAP_GLOBAL = 1,
	PM_MAP_CAUSTIC = 2,
	/* Precomputed irradiance (Christensen 1999): records in the photon
	 * layout whose power is the irradiance E (W/m^2, not divided by
	 * emitted, which is 0 as first_index is), whose normal is the
	 * surface's, at a fraction of the global photons; made by
	 * pm-balance.  dir is undefined (0) and depth 0. */
	PM_MAP_IRRADIANCE = 3,
};

/* Effects a map file simulates (header field `effects`). */
enum {
	PM_EFFECT_GLOBAL = 1 << 0,	/* diffuse interreflection: a global map */
	PM_EFFECT_CAUSTICS = 1 << 1,	/* specular-to-diffuse: a caustic map */
	PM_EFFECT_REFRACTION = 1 << 2,	/* the scene has dielectrics */
};

struct pm_map {
	enum pm_map_kind kind;
	uint64_t count;			/* photons stored */
	uint64_t emitted;		/* photon paths shot for this map: the
					 * flux normaliser */
	uint64_t first_index;		/* index of the first path shot */
	bool balanced;			/* photons are in kd-tree order */
	float lo[3], hi[3];		/* bounds of the positions */
	float radius;			/* irradiance maps: the lookup radius
					 * the records were computed with,
					 * 0 if unknown; 0 for other kinds */
	struct pm_photon *photons;	/* count records (owned or mapped) */
};

struct pm_pmap {
	uint64_t scene_hash;		/* pm_scene_hash of the scene shot */
	uint64_t seed;
	uint32_t effects;		/* PM_EFFECT_* */
	uint32_t max_depth;		/* photon bounces allowed, 0 unlimited */
	char *info;			/* provenance: "key=value\n" lines, NUL-
					 * terminated, each tool appending its
					 * own; owned */
	int nmaps;			/* 0 to 3 */
	struct pm_map maps[3];
	/* Private: set by the reader when the photons are memory-mapped. */
	void *mapped;
	size_t mapped_len;
};

/*
 * Writes m to path ("-": standard output) through a temporary file renamed
 * on success.  compress: zlib-compress each map's records.  The crc32 of
 * each map's stored bytes is computed here.
 */
enum pm_err pm_pmap_write(const char *path, const struct pm_pmap *m,
    bool compress, struct pm_error *err);

/*
 * Reads path ("-": standard input).  Every count, size and offset is
 * checked against the file's size before it is used, every crc32 is
 * verified, and reserved fields (the records' included) must be zero.
 * A version 1 file is refused (PM_ERR_UNSUPPORTED): it must be shot
 * again.  With allow_mmap, the
 * records of an uncompressed file are memory-mapped rather than copied
 * (little-endian hosts only).  m is initialised here; free it with
 * pm_pmap_free.
 */
enum pm_err pm_pmap_read(const char *path, struct pm_pmap *m, bool allow_mmap,
    struct pm_error *err);

/* The same from a buffer (tests, fuzzing); name is used in messages. */
enum pm_err pm_pmap_parse(const char *name, const unsigned char *buf,
    size_t len, struct pm_pmap *m, struct pm_error *err);

/* Frees the records of every slot of m->maps (those past nmaps too) that
 * the reader or the caller put there, and the info; zeroes m. */
void pm_pmap_free(struct pm_pmap *m);

/* Appends "key=value\n" to m->info (value may contain anything but NUL
 * and newline, which is replaced by a space). */
enum pm_err pm_pmap_info_add(struct pm_pmap *m, const char *key,
    const char *value, struct pm_error *err);

/* The map of the given kind, or NULL. */
struct pm_map *pm_pmap_find(struct pm_pmap *m, enum pm_map_kind kind);

#endif
