/*
 * pmap.c: reader and writer of the photon-map file, whose every byte
 * man/pmap.5 specifies.
 *
 * One parser serves three sources: a caller's buffer (pm_pmap_parse), a
 * memory-mapped regular file, and a descriptor read front to back with
 * read(2) (a pipe, or any file when mapping is not allowed).  The header
 * is read first and checked whole -- its crc32, every field, every count,
 * size and offset against the file's size where that is known -- before
 * anything is allocated for photons; the payloads are then read in file
 * order, each checked against its crc32, so a pipe is read once without
 * seeking.  A pipe's size is unknown until it ends, so there a payload
 * past the end shows up as a short read, with the same message.
 *
 * The writer compresses each map into memory before writing anything,
 * because the header, which comes first, carries the stored sizes and
 * checksums, and the output may be a pipe that cannot be rewound.
 */
#include <errno.h>
#include <fcntl.h>
#include <inttypes.h>
#include <math.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

#include "crc32.h"
#include "endian.h"
#include "pmap.h"
#include "file.h"
#include "../common/parallel.h"

#define PMAP_FIXED	64		/* fixed part of the header */
#define PMAP_ENTRY	96		/* a map-table entry, version 2.0 */
#define PMAP_REC	24		/* one photon record */
#define PMAP_ALIGN	64		/* payload alignment */
#define PMAP_MAXMAPS	4		/* one of each kind */
/* Records per crc32 and reserved-byte check of a payload in place: 96 KiB,
 * so that the check reads what the crc32 has just brought into cache. */
#define PMAP_CHECK_RECS	4096
/* Bytes per read(2), write(2), crc32 or zlib call: fits ssize_t and uInt. */
#define PMAP_CHUNK	((size_t)1 << 30)
/* Buffer for compressed bytes read from a descriptor. */
#define PMAP_IOBUF	((size_t)1 << 20)
/* Deflate cannot expand data more than 1032 times (258 bytes from one
 * two-bit length and distance code): a bound on what a map can claim. */
#define PMAP_ZLIB_RATIO	1032
#define PMAP_ZLIB_LEVEL	1		/* 2.5% larger than 6, twice as
					 * fast */
#define PMAP_UNKNOWN	UINT64_MAX	/* a pipe's size before its end */

/* Map flags and compression methods (man/pmap.5). */
#define PMAP_MAP_BALANCED	1u
#define PMAP_STORE_NONE		0u
#define PMAP_STORE_ZLIB		1u

#define PMAP_EFFECTS_KNOWN \
	(PM_EFFECT_GLOBAL | PM_EFFECT_CAUSTICS | PM_EFFECT_REFRACTION | \
	PM_EFFECT_MEDIA)

#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
#define PMAP_HOST_LE	1
#else
#define PMAP_HOST_LE	0
#endif

/* The records are written as they lie in memory on a little-endian host. */
_Static_assert(offsetof(struct pm_photon, pos) == 0, "photon layout");
_Static_assert(offsetof(struct pm_photon, power) == 12, "photon layout");
_Static_assert(offsetof(struct pm_photon, dir) == 16, "photon layout");
_Static_assert(offsetof(struct pm_photon, normal) == 18, "photon layout");
_Static_assert(offsetof(struct pm_photon, flags) == 20, "photon layout");
_Static_assert(offsetof(struct pm_photon, depth) == 21, "photon layout");
_Static_assert(offsetof(struct pm_photon, reserved) == 22, "photon layout");
_Static_assert(sizeof(struct pm_photon) == PMAP_REC, "photon layout");

static const unsigned char pmap_magic[8] = {
	0x89, 'P', 'M', 'A', 'P', '\r', '\n', 0x1a
};

/* One map-table entry as the file has it. */
struct pmap_entry {
	uint32_t kind, flags, compression, crc;
	uint64_t count, emitted, first_index, offset, stored;
	float lo[3], hi[3];
	float radius;
	uint64_t at;			/* byte offset of the entry */
};

/* Where the bytes come from, and how far we are. */
struct pmap_in {
	const char *name;
	struct pm_error *err;
	int fd;				/* -1: the whole file in buf */
	const unsigned char *buf;
	uint64_t size;			/* or PMAP_UNKNOWN (a pipe) */
	uint64_t pos;			/* offset of the next byte */
	bool strict;			/* minor <= ours: reserved are 0 */
	unsigned major, minor;		/* the file's version */
	bool zero_copy;			/* buf is our private mapping */
	int threads;			/* for checking records in place */
};

static uint64_t
align_up(uint64_t x)
{
	return (x + (PMAP_ALIGN - 1)) & ~(uint64_t)(PMAP_ALIGN - 1);
}

static const char *
kind_name(uint32_t kind)
{
	switch (kind) {
	case PM_MAP_GLOBAL:	return "global";
	case PM_MAP_CAUSTIC:	return "caustic";
	case PM_MAP_IRRADIANCE:	return "irradiance";
	case PM_MAP_VOLUME:	return "volume";
	}
	return "unknown";
}

static bool
kind_known(uint32_t kind)
{
	return kind == PM_MAP_GLOBAL || kind == PM_MAP_CAUSTIC ||
	    kind == PM_MAP_IRRADIANCE || kind == PM_MAP_VOLUME;
}

/* Index of the first of n records whose reserved bytes are not zero, or
 * n.  The bytes are or-ed a block at a time, so the common case is one
 * load and one or per record, and no branch. */
static size_t
first_reserved(const unsigned char *rec, size_t n)
{
	size_t i, j, m;
	unsigned acc;

	for (i = 0; i < n; i += m) {
		m = n - i < 256 ? n - i : 256;
		acc = 0;
		for (j = 0; j < m; j++)
			acc |= (unsigned)rec[(i + j) * PMAP_REC + 22] |
			    (unsigned)rec[(i + j) * PMAP_REC + 23];
		if (acc != 0)
			for (j = 0; j < m; j++)
				if ((rec[(i + j) * PMAP_REC + 22] |
				    rec[(i + j) * PMAP_REC + 23]) != 0)
					return i + j;
	}
	return n;
}

/* Records from little-endian file order to the host's, in place. */
static void
records_to_host(struct pm_photon *p, size_t n)
{
	size_t i;
	int k;

	if (PMAP_HOST_LE)
		return;
	for (i = 0; i < n; i++)
		for (k = 0; k < 3; k++)
			p[i].pos[k] = pm_get_f32((const unsigned char *)&p[i].pos[k]);
}

/* Records in file order: the memory itself on a little-endian host, else
 * a copy in scratch (room for n records). */
static const unsigned char *
records_to_file(const struct pm_photon *p, size_t n, unsigned char *scratch)
{
	size_t i;
	int k;

	if (PMAP_HOST_LE)
		return (const unsigned char *)p;
	for (i = 0; i < n; i++) {
		memcpy(scratch + i * PMAP_REC, &p[i], PMAP_REC);
		for (k = 0; k < 3; k++)
			pm_put_f32(scratch + i * PMAP_REC + 4 * k, p[i].pos[k]);
	}
	return scratch;
}

/* Length of the UTF-8 sequence at s (at most n bytes), 0 if invalid. */
static size_t
utf8_len(const unsigned char *s, size_t n)
{
	unsigned char lo = 0x80, hi = 0xbf;
	size_t len, i;

	if (s[0] < 0x80)
		return 1;
	if (s[0] >= 0xc2 && s[0] <= 0xdf)
		len = 2;
	else if (s[0] >= 0xe0 && s[0] <= 0xef) {
		len = 3;
		if (s[0] == 0xe0)
			lo = 0xa0;	/* overlong */
		if (s[0] == 0xed)
			hi = 0x9f;	/* surrogates */
	} else if (s[0] >= 0xf0 && s[0] <= 0xf4) {
		len = 4;
		if (s[0] == 0xf0)
			lo = 0x90;	/* overlong */
		if (s[0] == 0xf4)
			hi = 0x8f;	/* beyond U+10FFFF */
	} else
		return 0;
	if (n < len)
		return 0;
	for (i = 1; i < len; i++) {
		if (s[i] < lo || s[i] > hi)
			return 0;
		lo = 0x80;
		hi = 0xbf;
	}
	return len;
}

/*
 * NULL if s[0..n) is a well-formed provenance text: UTF-8 lines
 * "key=value\n" with a non-empty key and no NUL; else what is wrong,
 * with *at the offset of the offending byte.
 */
static const char *
info_problem(const unsigned char *s, size_t n, size_t *at)
{
	size_t i = 0, start, k;
	bool eq;

	while (i < n) {
		start = i;
		eq = false;
		for (; i < n && s[i] != '\n'; i += k) {
			k = 1;
			*at = i;
			if (s[i] == '\0')
				return "a NUL byte";
			if (s[i] == '=' && !eq) {
				if (i == start)
					return "a line with an empty key";
				eq = true;
			}
			if (s[i] >= 0x80 && (k = utf8_len(s + i, n - i)) == 0)
				return "invalid UTF-8";
		}
		*at = i;
		if (i == n)
			return "a last line without a newline";
		if (!eq)
			return "a line without '='";
		i++;
	}
	return NULL;
}

/*
 * What is wrong with a map's counts, or NULL: they must give a byte size
 * that fits 64 bits, a non-zero flux normaliser when there are photons,
 * and an index range that does not wrap.  An irradiance map emitted no
 * paths: its records hold irradiance, which nothing divides.
 */
static const char *
counts_problem(uint32_t kind, uint64_t count, uint64_t emitted,
    uint64_t first_index)
{
	if (count > UINT64_MAX / PMAP_REC)
		return "its photon count overflows 64-bit byte sizes";
	if (kind == PM_MAP_IRRADIANCE)
		return emitted != 0 || first_index != 0 ? "an irradiance map's "
		    "emitted and first_index must be 0" : NULL;
	if (count > 0 && emitted == 0)
		return "it has photons but emitted none";
	if (first_index > UINT64_MAX - emitted)
		return "its index range wraps past 2^64";
	return NULL;
}

/* --- Reading --- */

/* Copies up to n bytes at the current position into dst, fewer only at
 * the end of the file; *got says how many. */
static enum pm_err
in_fill(struct pmap_in *in, void *dst, size_t n, size_t *got)
{
	unsigned char *d = dst;
	size_t have = 0, want;
	ssize_t k;

	if (in->fd < 0) {
		uint64_t left = in->pos < in->size ? in->size - in->pos : 0;

		have = (uint64_t)n < left ? n : (size_t)left;
		if (have > 0)
			memcpy(d, in->buf + in->pos, have);
	} else {
		while (have < n) {
			want = n - have < PMAP_CHUNK ? n - have : PMAP_CHUNK;
			k = read(in->fd, d + have, want);
			if (k < 0 && errno == EINTR)
				continue;
			if (k < 0)
				return pm_fail(in->err, PM_ERR_IO, "%s: read "
				    "failed at byte %" PRIu64 ": %s", in->name,
				    in->pos + have, strerror(errno));
			if (k == 0) {
				/* Now we know where the file ends. */
				in->size = in->pos + have;
				break;
			}
			have += (size_t)k;
		}
	}
	in->pos += have;
	*got = have;
	return PM_OK;
}

/* Reads exactly n bytes, or says which part of the file is cut short. */
static enum pm_err
in_need(struct pmap_in *in, void *dst, size_t n, const char *what)
{
	uint64_t end = in->pos + n;
	enum pm_err e;
	size_t got;

	if ((e = in_fill(in, dst, n, &got)) != PM_OK)
		return e;
	if (got < n)
		return pm_fail(in->err, PM_ERR_TRUNCATED, "%s: truncated %s "
		    "(byte %" PRIu64 ", file is %" PRIu64 " bytes)", in->name,
		    what, end, in->pos);
	return PM_OK;
}

/* Skips to offset `to`, checking that the padding is zero. */
static enum pm_err
in_skip(struct pmap_in *in, uint64_t to, const char *what)
{
	unsigned char pad[512];
	enum pm_err e;
	uint64_t at;
	size_t n, i;

	while (in->pos < to) {
		at = in->pos;
		n = to - in->pos < sizeof(pad) ? (size_t)(to - in->pos) :
		    sizeof(pad);
		if ((e = in_need(in, pad, n, what)) != PM_OK)
			return e;
		for (i = 0; in->strict && i < n; i++)
			if (pad[i] != 0)
				return pm_fail(in->err, PM_ERR_FORMAT, "%s: "
				    "nonzero padding at byte %" PRIu64,
				    in->name, at + i);
	}
	return PM_OK;
}

/* What a magic number that is not ours tells about how it was damaged. */
static enum pm_err
bad_magic(struct pmap_in *in, const unsigned char *p, size_t got)
{
	static const unsigned char crlf_to_lf[7] = {
		0x89, 'P', 'M', 'A', 'P', '\n', 0x1a
	};
	static const unsigned char lf_to_crlf[8] = {
		0x89, 'P', 'M', 'A', 'P', '\r', '\r', '\n'
	};

	if (got >= sizeof(crlf_to_lf) &&
	    memcmp(p, crlf_to_lf, sizeof(crlf_to_lf)) == 0)
		return pm_fail(in->err, PM_ERR_FORMAT, "%s: not a photon map "
		    "(bad magic: CR LF became LF, so the file went through a "
		    "text-mode transfer)", in->name);
	if (got >= sizeof(lf_to_crlf) &&
	    memcmp(p, lf_to_crlf, sizeof(lf_to_crlf)) == 0)
		return pm_fail(in->err, PM_ERR_FORMAT, "%s: not a photon map "
		    "(bad magic: LF became CR LF, so the file went through a "
		    "text-mode transfer)", in->name);
	if (got >= 5 && p[0] == 0x09 && memcmp(p + 1, "PMAP", 4) == 0)
		return pm_fail(in->err, PM_ERR_FORMAT, "%s: not a photon map "
		    "(bad magic: the high bit of byte 0 was stripped by a "
		    "7-bit transfer)", in->name);
	return pm_fail(in->err, PM_ERR_FORMAT, "%s: not a photon map "
	    "(bad magic)", in->name);
}

/* A header cut short at size bytes, naming the part that is cut: the
 * fixed part's sizes are not yet checked, but serve to name it. */
static enum pm_err
header_cut(struct pmap_in *in, const unsigned char *fixed, uint32_t hs,
    uint64_t size)
{
	uint64_t table, text, end = hs;
	const char *what = "header";

	table = PMAP_FIXED + (uint64_t)pm_get_le32(fixed + 44) * pm_get_le32(fixed + 48);
	text = table + pm_get_le32(fixed + 52);
	if (table <= hs && size < table) {
		what = "map table";
		end = table;
	} else if (text + 4 <= hs && size < text) {
		what = "provenance text";
		end = text;
	}
	return pm_fail(in->err, PM_ERR_TRUNCATED, "%s: truncated %s (byte "
	    "%" PRIu64 ", file is %" PRIu64 " bytes)", in->name, what, end,
	    size);
}

/*
 * Reads the whole header into a new buffer (*hp, *hsp bytes) after
 * checking its magic, major version and size; verifies its crc32.
 */
static enum pm_err
read_header(struct pmap_in *in, unsigned char **hp, uint32_t *hsp)
{
	unsigned char fixed[PMAP_FIXED], *h, *nh;
	uint32_t hs, stored, computed;
	uint16_t major, minor;
	size_t got, cap, have, n;
	enum pm_err e;

	*hp = NULL;
	if ((e = in_fill(in, fixed, sizeof(fixed), &got)) != PM_OK)
		return e;
	if (memcmp(fixed, pmap_magic, got < 8 ? got : 8) != 0)
		return bad_magic(in, fixed, got);
	if (got == 0)
		return pm_fail(in->err, PM_ERR_TRUNCATED, "%s: empty file, "
		    "not a photon map", in->name);
	if (got < sizeof(fixed))
		return pm_fail(in->err, PM_ERR_TRUNCATED, "%s: truncated "
		    "header (byte %d, file is %" PRIu64 " bytes)", in->name,
		    PMAP_FIXED, (uint64_t)got);
	major = pm_get_le16(fixed + 8);
	minor = pm_get_le16(fixed + 10);
	if (major == 1)
		return pm_fail(in->err, PM_ERR_UNSUPPORTED, "%s: a version "
		    "1.%u photon map, whose 20-byte photons lack the surface "
		    "normal that version %d needs: shoot it again with "
		    "pm-shoot", in->name, (unsigned)minor,
		    PM_PMAP_VERSION_MAJOR);
	if (major != PM_PMAP_VERSION_MAJOR)
		return pm_fail(in->err, PM_ERR_UNSUPPORTED, "%s: unknown "
		    "version %u.%u (this reader knows %d.x)", in->name,
		    (unsigned)major, (unsigned)minor, PM_PMAP_VERSION_MAJOR);
	in->strict = minor <= PM_PMAP_VERSION_MINOR;
	in->major = major;
	in->minor = minor;
	hs = pm_get_le32(fixed + 12);
	if (hs < PMAP_FIXED + 4)
		return pm_fail(in->err, PM_ERR_FORMAT, "%s: header size %lu "
		    "is less than %d (byte 12)", in->name, (unsigned long)hs,
		    PMAP_FIXED + 4);
	if (in->size != PMAP_UNKNOWN && hs > in->size)
		return header_cut(in, fixed, hs, in->size);

	/* Grow the buffer as bytes arrive, so that a corrupt size read from
	 * a pipe costs no more memory than the bytes that are there. */
	cap = hs < 65536 ? hs : 65536;
	if ((h = malloc(cap)) == NULL)
		return pm_fail(in->err, PM_ERR_NOMEM, "%s: out of memory for "
		    "a header of %lu bytes", in->name, (unsigned long)hs);
	memcpy(h, fixed, sizeof(fixed));
	have = sizeof(fixed);
	while (have < hs) {
		if (have == cap) {
			cap = hs - cap < cap ? hs : cap * 2;
			if ((nh = realloc(h, cap)) == NULL) {
				free(h);
				return pm_fail(in->err, PM_ERR_NOMEM, "%s: out "
				    "of memory for a header of %lu bytes",
				    in->name, (unsigned long)hs);
			}
			h = nh;
		}
		n = cap - have;
		if ((e = in_fill(in, h + have, n, &got)) != PM_OK) {
			free(h);
			return e;
		}
		have += got;
		if (got < n) {
			free(h);
			return header_cut(in, fixed, hs, have);
		}
	}
	in->pos = hs;
	stored = pm_get_le32(h + hs - 4);
	computed = pm_crc32(0, h, hs - 4);
	if (stored != computed) {
		free(h);
		return pm_fail(in->err, PM_ERR_FORMAT, "%s: header checksum "
		    "mismatch (byte %lu: stored 0x%08lx, computed 0x%08lx)",
		    in->name, (unsigned long)(hs - 4), (unsigned long)stored,
		    (unsigned long)computed);
	}
	*hp = h;
	*hsp = hs;
	return PM_OK;
}

/* A payload that the file's end cuts short, in one message whether the
 * size was known beforehand or found at the end of a pipe. */
static enum pm_err
map_cut(struct pmap_in *in, const struct pmap_entry *me)
{
	return pm_fail(in->err, PM_ERR_TRUNCATED, "%s: truncated %s map "
	    "(bytes %" PRIu64 " to %" PRIu64 ", file is %" PRIu64 " bytes)",
	    in->name, kind_name(me->kind), me->offset, me->offset +
	    me->stored, in->size);
}

/* Checks one map-table entry on its own and against the file's size. */
static enum pm_err
check_entry(struct pmap_in *in, const struct pmap_entry *me, uint32_t hs)
{
	const char *kn = kind_name(me->kind), *why;
	uint64_t raw, end;
	int k;

	if (me->kind == PM_MAP_VOLUME && in->minor < 1)
		return pm_fail(in->err, PM_ERR_FORMAT, "%s: a volume map "
		    "(kind 4, byte %" PRIu64 ") in a version 2.0 file; "
		    "volume maps are version 2.1's", in->name, me->at);
	if (!kind_known(me->kind))
		return pm_fail(in->err, in->strict ? PM_ERR_FORMAT :
		    PM_ERR_UNSUPPORTED, "%s: unknown map kind %lu (byte "
		    "%" PRIu64 "; this reader knows 1, global, 2, caustic, "
		    "3, irradiance, and 4, volume)", in->name, (unsigned long)me->kind,
		    me->at);
	if (in->strict && (me->flags & ~PMAP_MAP_BALANCED) != 0)
		return pm_fail(in->err, PM_ERR_FORMAT, "%s: unknown flags "
		    "0x%lx in the %s map (byte %" PRIu64 ")", in->name,
		    (unsigned long)me->flags, kn, me->at + 4);
	if (me->compression != PMAP_STORE_NONE &&
	    me->compression != PMAP_STORE_ZLIB)
		return pm_fail(in->err, PM_ERR_UNSUPPORTED, "%s: the %s map "
		    "uses compression method %lu (byte %" PRIu64 "; this "
		    "reader knows 0, none, and 1, zlib)", in->name, kn,
		    (unsigned long)me->compression, me->at + 8);
	if ((why = counts_problem(me->kind, me->count, me->emitted,
	    me->first_index)) != NULL)
		return pm_fail(in->err, PM_ERR_FORMAT, "%s: the %s map is "
		    "corrupt: %s (%" PRIu64 " photons, %" PRIu64 " emitted "
		    "from index %" PRIu64 "; byte %" PRIu64 ")", in->name, kn,
		    why, me->count, me->emitted, me->first_index, me->at + 16);
	if (me->offset % PMAP_ALIGN != 0)
		return pm_fail(in->err, PM_ERR_FORMAT, "%s: the %s map's "
		    "offset %" PRIu64 " is not a multiple of %d (byte "
		    "%" PRIu64 ")", in->name, kn, me->offset, PMAP_ALIGN,
		    me->at + 40);
	if (me->offset < hs)
		return pm_fail(in->err, PM_ERR_FORMAT, "%s: the %s map's "
		    "offset %" PRIu64 " lies inside the header of %lu bytes "
		    "(byte %" PRIu64 ")", in->name, kn, me->offset,
		    (unsigned long)hs, me->at + 40);
	if (me->stored > UINT64_MAX - me->offset)
		return pm_fail(in->err, PM_ERR_FORMAT, "%s: the %s map's "
		    "offset %" PRIu64 " plus size %" PRIu64 " overflows "
		    "(byte %" PRIu64 ")", in->name, kn, me->offset, me->stored,
		    me->at + 40);
	end = me->offset + me->stored;
	if (in->size != PMAP_UNKNOWN && end > in->size)
		return map_cut(in, me);
	raw = me->count * PMAP_REC;
	if (me->compression == PMAP_STORE_NONE && me->stored != raw)
		return pm_fail(in->err, PM_ERR_FORMAT, "%s: the %s map stores "
		    "%" PRIu64 " bytes, but %" PRIu64 " photons take %" PRIu64
		    " (byte %" PRIu64 ")", in->name, kn, me->stored, me->count,
		    raw, me->at + 48);
	if (me->compression == PMAP_STORE_ZLIB &&
	    raw / PMAP_ZLIB_RATIO > me->stored)
		return pm_fail(in->err, PM_ERR_FORMAT, "%s: the %s map claims "
		    "%" PRIu64 " photons, more than its %" PRIu64 " compressed "
		    "bytes can hold (byte %" PRIu64 ")", in->name, kn,
		    me->count, me->stored, me->at + 16);
	if (me->count > 0)
		for (k = 0; k < 3; k++)
			if (!isfinite(me->lo[k]) || !isfinite(me->hi[k]) ||
			    !(me->lo[k] <= me->hi[k]))
				return pm_fail(in->err, PM_ERR_FORMAT, "%s: "
				    "the %s map's bounds are not finite and "
				    "ordered (byte %" PRIu64 ")", in->name, kn,
				    me->at + 56);
	/* The radius belongs to irradiance maps; elsewhere it is reserved. */
	if (me->kind == PM_MAP_IRRADIANCE && !(isfinite(me->radius) &&
	    me->radius >= 0.0f))
		return pm_fail(in->err, PM_ERR_FORMAT, "%s: the irradiance "
		    "map's radius is not a finite number >= 0 (byte "
		    "%" PRIu64 ")", in->name, me->at + 80);
	return PM_OK;
}

/* Whether payload a comes after b: by offset, and at one offset the
 * shorter first, so that an empty payload ends where the next starts. */
static bool
after(const struct pmap_entry *a, const struct pmap_entry *b)
{
	return a->offset != b->offset ? a->offset > b->offset :
	    a->stored > b->stored;
}

/* The indices of e[0..n) in file order of their payloads (n is at most
 * PMAP_MAXMAPS: an insertion sort, stable). */
static void
offset_order(const struct pmap_entry *e, uint32_t n, uint32_t *order)
{
	uint32_t i, j;

	for (i = 0; i < n; i++) {
		for (j = i; j > 0 && after(&e[order[j - 1]], &e[i]); j--)
			order[j] = order[j - 1];
		order[j] = i;
	}
}

/*
 * Checks the header h (hs bytes, crc already verified) and fills m's
 * header fields and info, and e[0..m->nmaps).
 */
static enum pm_err
parse_header(struct pmap_in *in, const unsigned char *h, uint32_t hs,
    struct pm_pmap *m, struct pmap_entry *e)
{
	uint32_t flags, nmaps, esize, isize, effects, order[PMAP_MAXMAPS];
	uint64_t need, at;
	const unsigned char *p, *info;
	const char *why;
	size_t bad;
	enum pm_err r;
	uint32_t i, j;
	int k;

	flags = pm_get_le32(h + 16);
	effects = pm_get_le32(h + 20);
	nmaps = pm_get_le32(h + 44);
	esize = pm_get_le32(h + 48);
	isize = pm_get_le32(h + 52);
	if (in->strict && flags != 0)
		return pm_fail(in->err, PM_ERR_FORMAT, "%s: unknown file "
		    "flags 0x%lx (byte 16)", in->name, (unsigned long)flags);
	if (in->strict && ((effects & ~(uint32_t)PMAP_EFFECTS_KNOWN) != 0 ||
	    ((effects & PM_EFFECT_MEDIA) && in->minor < 1)))
		return pm_fail(in->err, PM_ERR_FORMAT, "%s: unknown effects "
		    "0x%lx (byte 20)", in->name, (unsigned long)effects);
	if (nmaps > PMAP_MAXMAPS)
		return pm_fail(in->err, in->strict ? PM_ERR_FORMAT :
		    PM_ERR_UNSUPPORTED, "%s: %lu maps (byte 44; at most %d, "
		    "global, caustic, irradiance and volume)", in->name,
		    (unsigned long)nmaps, PMAP_MAXMAPS);
	if (esize < PMAP_ENTRY || (in->strict && esize != PMAP_ENTRY))
		return pm_fail(in->err, PM_ERR_FORMAT, "%s: map entries of "
		    "%lu bytes (byte 48; version %d.%d has %d)", in->name,
		    (unsigned long)esize, PM_PMAP_VERSION_MAJOR,
		    PM_PMAP_VERSION_MINOR, PMAP_ENTRY);
	if (in->strict && pm_get_le64(h + 56) != 0)
		return pm_fail(in->err, PM_ERR_FORMAT, "%s: nonzero reserved "
		    "field (byte 56)", in->name);
	need = (uint64_t)PMAP_FIXED + (uint64_t)nmaps * esize + isize + 4;
	if (need > hs || (in->strict && need != hs))
		return pm_fail(in->err, PM_ERR_FORMAT, "%s: a header of %lu "
		    "bytes (byte 12) for %lu maps of %lu bytes and %lu bytes "
		    "of text, which take %" PRIu64, in->name, (unsigned long)hs,
		    (unsigned long)nmaps, (unsigned long)esize,
		    (unsigned long)isize, need);

	m->scene_hash = pm_get_le64(h + 24);
	m->seed = pm_get_le64(h + 32);
	m->effects = effects;
	m->max_depth = pm_get_le32(h + 40);

	for (i = 0; i < nmaps; i++) {
		at = PMAP_FIXED + (uint64_t)i * esize;
		p = h + at;
		e[i].at = at;
		e[i].kind = pm_get_le32(p);
		e[i].flags = pm_get_le32(p + 4);
		e[i].compression = pm_get_le32(p + 8);
		e[i].crc = pm_get_le32(p + 12);
		e[i].count = pm_get_le64(p + 16);
		e[i].emitted = pm_get_le64(p + 24);
		e[i].first_index = pm_get_le64(p + 32);
		e[i].offset = pm_get_le64(p + 40);
		e[i].stored = pm_get_le64(p + 48);
		for (k = 0; k < 3; k++) {
			e[i].lo[k] = pm_get_f32(p + 56 + 4 * k);
			e[i].hi[k] = pm_get_f32(p + 68 + 4 * k);
		}
		e[i].radius = pm_get_f32(p + 80);
		/* Bytes 80-83 are the radius of an irradiance map and
		 * reserved in the others; 84-95 are reserved. */
		for (k = e[i].kind == PM_MAP_IRRADIANCE ? 84 : 80;
		    in->strict && k < 96; k += 4)
			if (pm_get_le32(p + k) != 0)
				return pm_fail(in->err, PM_ERR_FORMAT, "%s: "
				    "nonzero reserved field in the %s map "
				    "(byte %" PRIu64 ")", in->name,
				    kind_name(e[i].kind), at + (uint64_t)k);
		if ((r = check_entry(in, &e[i], hs)) != PM_OK)
			return r;
		for (j = 0; j < i; j++)
			if (e[j].kind == e[i].kind)
				return pm_fail(in->err, PM_ERR_FORMAT, "%s: "
				    "two %s maps (bytes %" PRIu64 " and "
				    "%" PRIu64 ")", in->name,
				    kind_name(e[i].kind), e[j].at, at);
	}
	/* Payloads must not overlap one another: in order of offset, each
	 * ends at or before the next begins. */
	offset_order(e, nmaps, order);
	for (i = 0; i + 1 < nmaps; i++) {
		const struct pmap_entry *a = &e[order[i]], *b = &e[order[i + 1]];

		if (a->offset + a->stored > b->offset)
			return pm_fail(in->err, PM_ERR_FORMAT, "%s: the %s map "
			    "(bytes %" PRIu64 " to %" PRIu64 ") overlaps the "
			    "%s map (from byte %" PRIu64 ")", in->name,
			    kind_name(a->kind), a->offset,
			    a->offset + a->stored, kind_name(b->kind),
			    b->offset);
	}

	at = PMAP_FIXED + (uint64_t)nmaps * esize;
	info = h + at;
	if ((why = info_problem(info, isize, &bad)) != NULL)
		return pm_fail(in->err, PM_ERR_FORMAT, "%s: provenance text "
		    "has %s (byte %" PRIu64 ")", in->name, why,
		    at + (uint64_t)bad);
	if ((m->info = malloc((size_t)isize + 1)) == NULL)
		return pm_fail(in->err, PM_ERR_NOMEM, "%s: out of memory for "
		    "%lu bytes of provenance", in->name, (unsigned long)isize);
	if (isize > 0)
		memcpy(m->info, info, isize);
	m->info[isize] = '\0';
	m->nmaps = (int)nmaps;
	return PM_OK;
}

/* A checksum mismatch, named the way users read it. */
static enum pm_err
crc_mismatch(struct pmap_in *in, const struct pmap_entry *me, uint32_t got)
{
	return pm_fail(in->err, PM_ERR_FORMAT, "%s: checksum mismatch in the "
	    "%s map (bytes %" PRIu64 " to %" PRIu64 ": stored 0x%08lx, "
	    "computed 0x%08lx)", in->name, kind_name(me->kind), me->offset,
	    me->offset + me->stored, (unsigned long)me->crc,
	    (unsigned long)got);
}

/*
 * Inflates a zlib payload at the current position into dst (raw bytes),
 * computing the crc32 of every stored byte even when the stream is bad,
 * so that damage is reported as a checksum mismatch rather than as
 * whatever the damage did to the stream.
 */
static enum pm_err
inflate_map(struct pmap_in *in, const struct pmap_entry *me,
    unsigned char *dst, uint64_t raw, const char *what)
{
	unsigned char *iobuf = NULL, spill;
	const unsigned char *src;
	uint64_t left = me->stored, done = 0, room;
	uint32_t crc = 0;
	char problem[160] = "";
	z_stream z;
	enum pm_err e;
	uInt before_in, before_out;
	size_t n;
	int zr = Z_OK;

	memset(&z, 0, sizeof(z));
	if (inflateInit(&z) != Z_OK)
		return pm_fail(in->err, PM_ERR_NOMEM, "%s: cannot start zlib "
		    "for the %s map", in->name, kind_name(me->kind));
	if (in->fd >= 0 && (iobuf = malloc(PMAP_IOBUF)) == NULL) {
		inflateEnd(&z);
		return pm_fail(in->err, PM_ERR_NOMEM, "%s: out of memory",
		    in->name);
	}
	while (left > 0) {
		if (in->fd < 0) {
			n = left < PMAP_CHUNK ? (size_t)left : PMAP_CHUNK;
			src = in->buf + in->pos;
			in->pos += n;
		} else {
			n = left < PMAP_IOBUF ? (size_t)left : PMAP_IOBUF;
			if ((e = in_need(in, iobuf, n, what)) != PM_OK) {
				free(iobuf);
				inflateEnd(&z);
				return e;
			}
			src = iobuf;
		}
		left -= n;
		crc = pm_crc32(crc, src, n);
		z.next_in = (Bytef *)(uintptr_t)src;
		z.avail_in = (uInt)n;
		while (z.avail_in > 0 && problem[0] == '\0') {
			if (zr == Z_STREAM_END) {
				snprintf(problem, sizeof(problem), "%" PRIu64
				    " bytes follow the end of the zlib stream",
				    z.avail_in + left);
				break;
			}
			room = raw - done;
			if (room > 0) {
				z.next_out = dst + done;
				z.avail_out = room < PMAP_CHUNK ? (uInt)room :
				    (uInt)PMAP_CHUNK;
			} else {
				/* Full: one byte more would be one too many. */
				z.next_out = &spill;
				z.avail_out = 1;
			}
			before_in = z.avail_in;
			before_out = z.avail_out;
			zr = inflate(&z, Z_NO_FLUSH);
			if (room == 0 && z.avail_out == 0)
				snprintf(problem, sizeof(problem), "it "
				    "inflates to more than %" PRIu64 " photons",
				    me->count);
			else if (room > 0)
				done += before_out - z.avail_out;
			if (zr == Z_STREAM_END || problem[0] != '\0')
				continue;
			if (zr == Z_NEED_DICT)
				snprintf(problem, sizeof(problem), "the zlib "
				    "stream asks for a preset dictionary");
			else if (zr != Z_OK && !(zr == Z_BUF_ERROR &&
			    (z.avail_in != before_in ||
			    z.avail_out != before_out)))
				snprintf(problem, sizeof(problem), "bad zlib "
				    "data (%s)", z.msg != NULL ? z.msg :
				    "no progress");
		}
	}
	inflateEnd(&z);
	free(iobuf);
	if (crc != me->crc)
		return crc_mismatch(in, me, crc);
	if (problem[0] == '\0' && zr != Z_STREAM_END)
		snprintf(problem, sizeof(problem), "the zlib stream is cut "
		    "short");
	if (problem[0] == '\0' && done != raw)
		snprintf(problem, sizeof(problem), "it inflates to %" PRIu64
		    " bytes, not %" PRIu64 " photons of %d", done, me->count,
		    PMAP_REC);
	if (problem[0] != '\0')
		return pm_fail(in->err, PM_ERR_FORMAT, "%s: the %s map "
		    "(bytes %" PRIu64 " to %" PRIu64 ") is corrupt: %s",
		    in->name, kind_name(me->kind), me->offset,
		    me->offset + me->stored, problem);
	return PM_OK;
}

/* The crc32 of the raw bytes at rec and the index of their first record
 * with nonzero reserved bytes (UINT64_MAX: none, or not strict). */
static uint32_t
check_span(const unsigned char *rec, uint64_t raw, bool strict, uint64_t *badp)
{
	const size_t block = (size_t)PMAP_CHECK_RECS * PMAP_REC;
	uint64_t at, bad = UINT64_MAX;
	uint32_t crc = 0;
	size_t n, j;

	for (at = 0; at < raw; at += n) {
		n = raw - at < block ? (size_t)(raw - at) : block;
		crc = pm_crc32(crc, rec + at, n);
		if (strict && bad == UINT64_MAX &&
		    (j = first_reserved(rec + at, n / PMAP_REC)) <
		    n / PMAP_REC)
			bad = at / PMAP_REC + j;
	}
	*badp = bad;
	return crc;
}

/* Pieces of a parallel check: fixed by the size alone, so that threads
 * only change who checks which piece.  4 MiB of records a piece (a whole
 * number of records); at most PMAP_PIECES of them. */
#define PMAP_PIECE_RECS	((uint64_t)174763)
#define PMAP_PIECES	64

struct check_job {
	const unsigned char *rec;
	uint64_t raw, piece;		/* bytes in all, in a piece */
	int npieces;
	bool strict;
	atomic_int next;
	uint32_t crc[PMAP_PIECES];
	uint64_t bad[PMAP_PIECES];	/* record index within the piece */
};

static void *
check_worker(void *arg)
{
	struct check_job *j = arg;
	int p;

	while ((p = atomic_fetch_add(&j->next, 1)) < j->npieces) {
		uint64_t at = (uint64_t)p * j->piece;
		uint64_t n = j->raw - at < j->piece ? j->raw - at : j->piece;

		j->crc[p] = check_span(j->rec + at, n, j->strict, &j->bad[p]);
	}
	return NULL;
}

/*
 * Checks the count records at rec, raw bytes: their crc32 (into *crcp)
 * against the stored one when they are the payload as stored (with_crc),
 * then, unless the file is of a newer minor version, that their reserved
 * bytes are zero.  Both walk the records a cache-sized block at a time,
 * so that a memory-mapped map is read from memory once.  A damaged byte
 * is reported as a checksum mismatch first.
 */
static enum pm_err
check_records(struct pmap_in *in, const struct pmap_entry *me,
    const unsigned char *rec, uint64_t raw, bool with_crc, uint32_t *crcp)
{
	uint64_t bad = UINT64_MAX, piece;
	uint32_t crc;
	int p;

	/* Inflated records too: what pm-inspect reports.  A map of more
	 * than one piece, on more than one thread, is checked in pieces
	 * whose crc32s zlib combines into the very same crc32: the check
	 * and its page faults were a tenth of a short render's time, on
	 * one thread.  (A piece must fit crc32_combine's z_off_t, which
	 * may have 32 bits.) */
	piece = PMAP_PIECE_RECS * PMAP_REC;
	if (raw / PMAP_PIECES >= piece)
		piece = (raw / PMAP_PIECES / PMAP_REC + 1) * PMAP_REC;
	if (in->threads <= 1 || raw <= piece || piece > INT32_MAX) {
		crc = check_span(rec, raw, in->strict, &bad);
	} else {
		struct check_job *j = malloc(sizeof(*j));

		if (j == NULL)
			return pm_fail(in->err, PM_ERR_NOMEM, "%s: out of "
			    "memory", in->name);
		j->rec = rec;
		j->raw = raw;
		j->piece = piece;
		j->npieces = (int)((raw + piece - 1) / piece);
		j->strict = in->strict;
		atomic_init(&j->next, 0);
		pm_parallel(in->threads < j->npieces ? in->threads :
		    j->npieces, check_worker, j);
		crc = j->crc[0];
		bad = j->bad[0];
		for (p = 1; p < j->npieces; p++) {
			uint64_t at = (uint64_t)p * piece;
			uint64_t n = raw - at < piece ? raw - at : piece;

			crc = (uint32_t)crc32_combine(crc, j->crc[p],
			    (z_off_t)n);
			if (bad == UINT64_MAX && j->bad[p] != UINT64_MAX)
				bad = at / PMAP_REC + j->bad[p];
		}
		free(j);
	}
	*crcp = crc;
	if (with_crc && crc != me->crc)
		return crc_mismatch(in, me, crc);
	if (bad == UINT64_MAX)
		return PM_OK;
	if (me->compression == PMAP_STORE_NONE)
		return pm_fail(in->err, PM_ERR_FORMAT, "%s: nonzero reserved "
		    "bytes in record %" PRIu64 " of the %s map (byte %" PRIu64
		    ")", in->name, bad, kind_name(me->kind), me->offset +
		    bad * PMAP_REC + 22);
	return pm_fail(in->err, PM_ERR_FORMAT, "%s: nonzero reserved bytes in "
	    "record %" PRIu64 " of the %s map (bytes 22-23 of the record, "
	    "decompressed)", in->name, bad, kind_name(me->kind));
}

/* Reads one map's payload (the current position is at or before it). */
static enum pm_err
load_payload(struct pmap_in *in, const struct pmap_entry *me,
    struct pm_map *out)
{
	char what[32];
	unsigned char *dst;
	uint64_t raw = me->count * PMAP_REC;
	enum pm_err e;
	int k;

	snprintf(what, sizeof(what), "%s map", kind_name(me->kind));
	out->kind = (enum pm_map_kind)me->kind;
	out->count = me->count;
	out->emitted = me->emitted;
	out->first_index = me->first_index;
	out->balanced = (me->flags & PMAP_MAP_BALANCED) != 0;
	out->radius = me->kind == PM_MAP_IRRADIANCE ? me->radius : 0.0f;
	for (k = 0; k < 3; k++) {
		out->lo[k] = me->lo[k];
		out->hi[k] = me->hi[k];
	}
	out->photons = NULL;
	out->stored_crc = me->crc;
	out->records_crc = 0;		/* that of no bytes */
	if ((e = in_skip(in, me->offset, what)) != PM_OK)
		return e;
	if (raw > SIZE_MAX)
		return pm_fail(in->err, PM_ERR_LIMIT, "%s: the %s map's "
		    "%" PRIu64 " photons do not fit this machine's memory",
		    in->name, kind_name(me->kind), me->count);

	if (me->compression == PMAP_STORE_NONE && in->zero_copy) {
		dst = (unsigned char *)(uintptr_t)(in->buf + in->pos);
		in->pos += raw;
		if ((e = check_records(in, me, dst, raw, true,
		    &out->records_crc)) != PM_OK)
			return e;
		out->photons = raw > 0 ? (struct pm_photon *)(void *)dst : NULL;
		return PM_OK;
	}
	if (raw == 0 && me->compression == PMAP_STORE_NONE)
		return me->crc == 0 ? PM_OK : crc_mismatch(in, me, 0);
	if ((dst = malloc(raw > 0 ? (size_t)raw : 1)) == NULL)
		return pm_fail(in->err, PM_ERR_NOMEM, "%s: out of memory for "
		    "the %s map's %" PRIu64 " photons", in->name,
		    kind_name(me->kind), me->count);
	if (me->compression == PMAP_STORE_NONE) {
		e = in_need(in, dst, (size_t)raw, what);
		if (e == PM_OK)
			e = check_records(in, me, dst, raw, true,
			    &out->records_crc);
	} else {
		e = inflate_map(in, me, dst, raw, what);
		if (e == PM_OK)
			e = check_records(in, me, dst, raw, false,
			    &out->records_crc);
	}
	if (e != PM_OK || raw == 0) {
		free(dst);
		return e;
	}
	out->photons = (struct pm_photon *)(void *)dst;
	records_to_host(out->photons, (size_t)me->count);
	return PM_OK;
}

/*
 * The same, where a pipe that ends inside the payload is reported as a
 * file of known size is: the end was unknown until it came.
 */
static enum pm_err
load_map(struct pmap_in *in, const struct pmap_entry *me, struct pm_map *out)
{
	enum pm_err e = load_payload(in, me, out);

	if (e == PM_ERR_TRUNCATED && in->size != PMAP_UNKNOWN &&
	    me->offset + me->stored > in->size)
		return map_cut(in, me);
	return e;
}

/* The whole file from in into m (zeroed by the caller). */
static enum pm_err
parse(struct pmap_in *in, struct pm_pmap *m)
{
	struct pmap_entry e[PMAP_MAXMAPS];
	unsigned char *h, extra;
	/* read_header sets hs whenever it succeeds; 0 for GCC's -O1
	 * sanitizer build, which cannot see that */
	uint32_t hs = 0, order[PMAP_MAXMAPS];
	enum pm_err r;
	size_t got;
	int i;

	if ((r = read_header(in, &h, &hs)) != PM_OK)
		return r;
	r = parse_header(in, h, hs, m, e);
	free(h);
	if (r != PM_OK)
		return r;
	m->version_major = in->major;
	m->version_minor = in->minor;
	/* In file order, so that a pipe is read front to back. */
	offset_order(e, (uint32_t)m->nmaps, order);
	for (i = 0; i < m->nmaps; i++)
		if ((r = load_map(in, &e[order[i]], &m->maps[order[i]])) !=
		    PM_OK)
			return r;
	/* A newer minor version may append; ours ends with the last map. */
	if (in->strict) {
		if ((r = in_fill(in, &extra, 1, &got)) != PM_OK)
			return r;
		if (got > 0)
			return pm_fail(in->err, PM_ERR_FORMAT, "%s: unexpected "
			    "data after the last map (byte %" PRIu64 ")",
			    in->name, in->pos - 1);
	}
	return PM_OK;
}

/*
 * Reads a pipe to its end, so that its size is known: only a file of a
 * newer minor version, which may append what this reader skips, has
 * bytes left after its last map.
 */
static enum pm_err
in_drain(struct pmap_in *in)
{
	unsigned char buf[4096];
	enum pm_err e;
	size_t got;

	do {
		if ((e = in_fill(in, buf, sizeof(buf), &got)) != PM_OK)
			return e;
	} while (got == sizeof(buf));
	return PM_OK;
}

/* Whether p points into m's mapping. */
static bool
in_mapping(const struct pm_pmap *m, const void *p)
{
	uintptr_t a = (uintptr_t)m->mapped, x = (uintptr_t)p;

	return m->mapped != NULL && x >= a && x - a < m->mapped_len;
}

/* Reads path ("-": standard input) into m; mmaps uncompressed records. */
enum pm_err
pm_pmap_read(const char *path, struct pm_pmap *m, bool allow_mmap,
    struct pm_error *err)
{
	return pm_pmap_read_threads(path, m, allow_mmap, 1, err);
}

enum pm_err
pm_pmap_read_threads(const char *path, struct pm_pmap *m, bool allow_mmap,
    int threads, struct pm_error *err)
{
	struct pmap_in in;
	struct stat st;
	bool is_stdin = strcmp(path, "-") == 0;
	enum pm_err r;
	off_t at = 0;
	void *p;
	int fd, i;

	memset(m, 0, sizeof(*m));
	memset(&in, 0, sizeof(in));
	in.name = is_stdin ? "standard input" : path;
	in.err = err;
	in.size = PMAP_UNKNOWN;
	in.threads = threads;
	fd = is_stdin ? STDIN_FILENO : open(path, O_RDONLY | O_CLOEXEC);
	if (fd < 0)
		return pm_fail(err, PM_ERR_IO, "%s: %s", path, strerror(errno));
	if (fstat(fd, &st) < 0) {
		r = pm_fail(err, PM_ERR_IO, "%s: %s", in.name, strerror(errno));
		goto done;
	}
	if (S_ISDIR(st.st_mode)) {
		r = pm_fail(err, PM_ERR_IO, "%s: is a directory", in.name);
		goto done;
	}
	if (S_ISREG(st.st_mode)) {
		/* Standard input may be a file someone has begun to read. */
		if (is_stdin && (at = lseek(fd, 0, SEEK_CUR)) < 0)
			at = 0;
		in.size = st.st_size > at ? (uint64_t)(st.st_size - at) : 0;
	}
	in.fd = fd;
	/* A private writable mapping: tools may reorder the photons in
	 * place (pm-balance) without touching the file. */
	if (allow_mmap && PMAP_HOST_LE && S_ISREG(st.st_mode) && at == 0 &&
	    in.size > 0 && in.size <= SIZE_MAX) {
		p = mmap(NULL, (size_t)in.size, PROT_READ | PROT_WRITE,
		    MAP_PRIVATE, fd, 0);
		if (p != MAP_FAILED) {
			m->mapped = p;
			m->mapped_len = (size_t)in.size;
			in.fd = -1;
			in.buf = p;
			in.zero_copy = true;
		}
	}
	r = parse(&in, m);
	if (r == PM_OK && in.size == PMAP_UNKNOWN)
		r = in_drain(&in);
	if (r == PM_OK)
		m->file_bytes = in.size;
	if (r == PM_OK && m->mapped != NULL) {
		/* Keep the mapping only if some map points into it. */
		for (i = 0; i < m->nmaps; i++)
			if (in_mapping(m, m->maps[i].photons))
				break;
		if (i == m->nmaps) {
			munmap(m->mapped, m->mapped_len);
			m->mapped = NULL;
			m->mapped_len = 0;
		}
	}
done:
	if (!is_stdin)
		close(fd);
	if (r != PM_OK)
		pm_pmap_free(m);
	return r;
}

/* Parses a whole file held in buf; the photons are copied. */
enum pm_err
pm_pmap_parse(const char *name, const unsigned char *buf, size_t len,
    struct pm_pmap *m, struct pm_error *err)
{
	struct pmap_in in;
	enum pm_err r;

	memset(m, 0, sizeof(*m));
	memset(&in, 0, sizeof(in));
	in.name = name;
	in.err = err;
	in.fd = -1;
	in.buf = buf;
	in.size = len;
	if ((r = parse(&in, m)) != PM_OK)
		pm_pmap_free(m);
	else
		m->file_bytes = len;
	return r;
}

/* Frees what the reader or the caller put in m, and zeroes it. */
void
pm_pmap_free(struct pm_pmap *m)
{
	int i;

	if (m == NULL)
		return;
	for (i = 0; i < PMAP_MAXMAPS; i++)
		if (!in_mapping(m, m->maps[i].photons))
			free(m->maps[i].photons);
	if (m->mapped != NULL)
		munmap(m->mapped, m->mapped_len);
	free(m->info);
	memset(m, 0, sizeof(*m));
}

/* --- Writing --- */

/* One map as it will be stored. */
struct pmap_out {
	unsigned char *z;		/* compressed bytes, NULL: records */
	uint64_t raw, stored, offset;
	uint32_t crc;
	float lo[3], hi[3];
};

/* Checks what the writer is given, so that it writes nothing the reader
 * would refuse. */
static enum pm_err
check_for_write(const char *name, const struct pm_pmap *m,
    struct pm_error *err)
{
	const struct pm_map *a;
	const char *why;
	size_t bad;
	int i, j;

	if (m->nmaps < 0 || m->nmaps > PMAP_MAXMAPS)
		return pm_fail(err, PM_ERR_INVALID, "%s: %d maps (at most %d)",
		    name, m->nmaps, PMAP_MAXMAPS);
	if ((m->effects & ~(uint32_t)PMAP_EFFECTS_KNOWN) != 0)
		return pm_fail(err, PM_ERR_INVALID, "%s: unknown effects 0x%lx",
		    name, (unsigned long)m->effects);
	for (i = 0; i < m->nmaps; i++) {
		a = &m->maps[i];
		if (!kind_known((uint32_t)a->kind))
			return pm_fail(err, PM_ERR_INVALID, "%s: map %d has "
			    "unknown kind %d", name, i, (int)a->kind);
		if (a->kind == PM_MAP_IRRADIANCE ? !(isfinite(a->radius) &&
		    a->radius >= 0.0f) : a->radius != 0.0f)
			return pm_fail(err, PM_ERR_INVALID, "%s: the %s map has "
			    "radius %g (an irradiance map's is finite and >= "
			    "0, the others' 0)", name, kind_name(a->kind),
			    (double)a->radius);
		for (j = 0; j < i; j++)
			if (m->maps[j].kind == a->kind)
				return pm_fail(err, PM_ERR_INVALID, "%s: two "
				    "%s maps", name, kind_name(a->kind));
		if ((why = counts_problem(a->kind, a->count, a->emitted,
		    a->first_index)) != NULL)
			return pm_fail(err, PM_ERR_INVALID, "%s: the %s map: "
			    "%s", name, kind_name(a->kind), why);
		if (a->count * PMAP_REC > SIZE_MAX ||
		    (a->count > 0 && a->photons == NULL))
			return pm_fail(err, PM_ERR_INVALID, "%s: the %s map "
			    "has %" PRIu64 " photons but no records", name,
			    kind_name(a->kind), a->count);
	}
	if (m->info != NULL && (why = info_problem((const unsigned char *)
	    m->info, strlen(m->info), &bad)) != NULL)
		return pm_fail(err, PM_ERR_INVALID, "%s: provenance text has "
		    "%s (character %zu)", name, why, bad);
	return PM_OK;
}

/* Bounds of positions, kept in registers by map_bounds. */
struct box {
	float lx, ly, lz, hx, hy, hz;
};

/*
 * x, with -0 made +0; sets *bad if x is an infinity or a NaN (its exponent
 * all ones), which a comparison would let through.  Adding +0 makes a
 * zero's sign not matter: the bounds of equal zeros would otherwise take
 * the sign of whichever came first, and depend on how the records are cut
 * into runs and pieces (pm-shoot's chunks, pm-balance's threads).
 */
static inline float
checked(float x, uint32_t *bad)
{
	uint32_t u;

	memcpy(&u, &x, sizeof(u));
	*bad |= (uint32_t)((u & 0x7f800000u) == 0x7f800000u);
	return x + 0.0f;
}

/* b widened to q; *bad set if q has a reserved byte set or a coordinate
 * that is not finite. */
static inline struct box
box_add(struct box b, const struct pm_photon *q, uint32_t *bad)
{
	float x = checked(q->pos[0], bad), y = checked(q->pos[1], bad),
	    z = checked(q->pos[2], bad);

	*bad |= (uint32_t)(q->reserved[0] | q->reserved[1]);
	b.lx = x < b.lx ? x : b.lx;
	b.ly = y < b.ly ? y : b.ly;
	b.lz = z < b.lz ? z : b.lz;
	b.hx = x > b.hx ? x : b.hx;
	b.hy = y > b.hy ? y : b.hy;
	b.hz = z > b.hz ? z : b.hz;
	return b;
}

/* lo and hi widened to rlo and rhi; set to them when first. */
static void
bounds_fold(float lo[3], float hi[3], bool first, const float rlo[3],
    const float rhi[3])
{
	int k;

	for (k = 0; k < 3; k++) {
		lo[k] = first || rlo[k] < lo[k] ? rlo[k] : lo[k];
		hi[k] = first || rhi[k] > hi[k] ? rhi[k] : hi[k];
	}
}

/*
 * The bounds of p[0..n) into lo and hi (0 for no records); nonzero if a
 * record has a reserved byte set or a coordinate that is not finite.  pm-shoot and pm-balance wait for this pass with every other
 * thread idle: branch-free, the bounds in registers, two sets of them
 * (even and odd records) so that no min or max waits on the one before.
 */
static uint32_t
box_records(const struct pm_photon *p, uint64_t n, float lo[3], float hi[3])
{
	struct box b0, b1;
	uint32_t bad = 0;
	uint64_t i;

	if (n == 0) {
		lo[0] = lo[1] = lo[2] = hi[0] = hi[1] = hi[2] = 0.0f;
		return 0;
	}
	b0.lx = b0.hx = p[0].pos[0] + 0.0f;
	b0.ly = b0.hy = p[0].pos[1] + 0.0f;
	b0.lz = b0.hz = p[0].pos[2] + 0.0f;
	b1 = b0;
	for (i = 0; i + 1 < n; i += 2) {
		b0 = box_add(b0, &p[i], &bad);
		b1 = box_add(b1, &p[i + 1], &bad);
	}
	if (i < n)
		b0 = box_add(b0, &p[i], &bad);
	lo[0] = b0.lx;
	lo[1] = b0.ly;
	lo[2] = b0.lz;
	hi[0] = b0.hx;
	hi[1] = b0.hy;
	hi[2] = b0.hz;
	bounds_fold(lo, hi, false, (const float[3]){b1.lx, b1.ly, b1.lz},
	    (const float[3]){b1.hx, b1.hy, b1.hz});
	return bad;
}

/* The error for the first record of p[0..n) that box_records refused;
 * records are numbered from base in messages. */
static enum pm_err
bad_record(const char *name, enum pm_map_kind kind, const struct pm_photon *p,
    uint64_t n, uint64_t base, struct pm_error *err)
{
	uint64_t i;
	int k;

	for (i = 0; i < n; i++) {
		if ((p[i].reserved[0] | p[i].reserved[1]) != 0)
			return pm_fail(err, PM_ERR_INVALID, "%s: photon "
			    "%" PRIu64 " of the %s map has nonzero reserved "
			    "bytes", name, base + i, kind_name(kind));
		for (k = 0; k < 3; k++)
			if (!isfinite(p[i].pos[k]))
				return pm_fail(err, PM_ERR_INVALID, "%s: "
				    "photon %" PRIu64 " of the %s map is not "
				    "at a finite position", name, base + i,
				    kind_name(kind));
	}
	return pm_fail(err, PM_ERR_INVALID, "%s: the %s map's photons "
	    "changed while it was written", name, kind_name(kind));
}

/* Bounds of a map's positions, which must be finite; and its records'
 * reserved bytes, which must be zero. */
static enum pm_err
map_bounds(const char *name, const struct pm_map *a, struct pmap_out *o,
    struct pm_error *err)
{
	if (box_records(a->photons, a->count, o->lo, o->hi) != 0)
		return bad_record(name, a->kind, a->photons, a->count, 0, err);
	return PM_OK;
}

/* The crc32 of a map's records in file order. */
static uint32_t
records_crc(const struct pm_photon *p, uint64_t count, unsigned char *scratch,
    size_t per)
{
	uint64_t i, n;
	uint32_t crc = 0;

	for (i = 0; i < count; i += n) {
		n = count - i < per ? count - i : per;
		crc = pm_crc32(crc, records_to_file(p + i, (size_t)n, scratch),
		    (size_t)n * PMAP_REC);
	}
	return (uint32_t)crc;
}

/* Deflates a map's records into o->z (o->stored bytes) and its crc32. */
static enum pm_err
deflate_map(const char *name, const struct pm_map *a, struct pmap_out *o,
    unsigned char *scratch, size_t per, struct pm_error *err)
{
	unsigned char *out, *grown;
	uint64_t cap, done = 0, in_next = 0, room;
	z_stream z;
	size_t n;
	int zr, flush;

	memset(&z, 0, sizeof(z));
	if (deflateInit(&z, PMAP_ZLIB_LEVEL) != Z_OK)
		return pm_fail(err, PM_ERR_NOMEM, "%s: cannot start zlib",
		    name);
	cap = deflateBound(&z, (uLong)o->raw);
	if (cap < o->raw || cap > SIZE_MAX)
		cap = o->raw + o->raw / 8 + 64;	/* uLong too narrow */
	if ((out = malloc((size_t)cap)) == NULL) {
		deflateEnd(&z);
		return pm_fail(err, PM_ERR_NOMEM, "%s: out of memory to "
		    "compress the %s map", name, kind_name(a->kind));
	}
	do {
		if (z.avail_in == 0 && in_next < a->count) {
			n = a->count - in_next < per ? (size_t)(a->count -
			    in_next) : per;
			z.next_in = (Bytef *)(uintptr_t)records_to_file(
			    a->photons + in_next, n, scratch);
			z.avail_in = (uInt)(n * PMAP_REC);
			in_next += n;
		}
		flush = in_next == a->count ? Z_FINISH : Z_NO_FLUSH;
		if (done == cap) {
			/* Beyond deflateBound: cannot happen, but cheap. */
			cap += cap / 8 + 65536;
			if ((grown = realloc(out, (size_t)cap)) == NULL) {
				free(out);
				deflateEnd(&z);
				return pm_fail(err, PM_ERR_NOMEM, "%s: out of "
				    "memory to compress the %s map", name,
				    kind_name(a->kind));
			}
			out = grown;
		}
		room = cap - done;
		z.next_out = out + done;
		z.avail_out = room < PMAP_CHUNK ? (uInt)room : (uInt)PMAP_CHUNK;
		room = z.avail_out;
		zr = deflate(&z, flush);
		done += room - z.avail_out;
	} while (zr == Z_OK || zr == Z_BUF_ERROR);
	deflateEnd(&z);
	if (zr != Z_STREAM_END) {
		free(out);
		return pm_fail(err, PM_ERR_NOMEM, "%s: zlib failed on the %s "
		    "map (%d)", name, kind_name(a->kind), zr);
	}
	if ((grown = realloc(out, done > 0 ? (size_t)done : 1)) != NULL)
		out = grown;
	o->z = out;
	o->stored = done;
	o->crc = pm_crc32(0, out, (size_t)done);
	return PM_OK;
}

/* Writes n bytes, whatever the size of n: at offset off, or where the
 * descriptor is when off is negative (a pipe). */
static enum pm_err
write_all(int fd, const void *buf, uint64_t n, int64_t off, const char *name,
    struct pm_error *err)
{
	const unsigned char *p = buf;
	size_t want;
	ssize_t k;

	while (n > 0) {
		want = n < PMAP_CHUNK ? (size_t)n : PMAP_CHUNK;
		k = off < 0 ? write(fd, p, want) : pwrite(fd, p, want,
		    (off_t)off);
		if (k < 0 && errno == EINTR)
			continue;
		if (k <= 0)
			return pm_fail(err, PM_ERR_IO, "%s: write failed: %s",
			    name, k < 0 ? strerror(errno) : "no progress");
		p += k;
		n -= (uint64_t)k;
		if (off >= 0)
			off += k;
	}
	return PM_OK;
}

/* The header, laid out as man/pmap.5 says; hs bytes. */
static bool
needs_2_1(const struct pm_pmap *m)
{
	int i;

	if (m->effects & PM_EFFECT_MEDIA)
		return true;
	for (i = 0; i < m->nmaps; i++)
		if (m->maps[i].kind == PM_MAP_VOLUME)
			return true;
	return false;
}

static void
build_header(unsigned char *h, uint32_t hs, const struct pm_pmap *m,
    const struct pmap_out *o, size_t isize)
{
	const struct pm_map *a;
	unsigned char *p;
	int i, k;

	memset(h, 0, hs);
	memcpy(h, pmap_magic, sizeof(pmap_magic));
	pm_put_le16(h + 8, PM_PMAP_VERSION_MAJOR);
	/* The oldest version that describes the file: 2.1 only for what
	 * 2.1 added (a volume map, the media effect), so that files
	 * without media stay 2.0, byte for byte, and 2.0 readers read
	 * them as strictly as before. */
	pm_put_le16(h + 10, needs_2_1(m) ? 1 : 0);
	pm_put_le32(h + 12, hs);
	pm_put_le32(h + 16, 0);
	pm_put_le32(h + 20, m->effects);
	pm_put_le64(h + 24, m->scene_hash);
	pm_put_le64(h + 32, m->seed);
	pm_put_le32(h + 40, m->max_depth);
	pm_put_le32(h + 44, (uint32_t)m->nmaps);
	pm_put_le32(h + 48, PMAP_ENTRY);
	pm_put_le32(h + 52, (uint32_t)isize);
	for (i = 0; i < m->nmaps; i++) {
		a = &m->maps[i];
		p = h + PMAP_FIXED + i * PMAP_ENTRY;
		pm_put_le32(p, (uint32_t)a->kind);
		pm_put_le32(p + 4, a->balanced ? PMAP_MAP_BALANCED : 0);
		pm_put_le32(p + 8, o[i].z != NULL ? PMAP_STORE_ZLIB :
		    PMAP_STORE_NONE);
		pm_put_le32(p + 12, o[i].crc);
		pm_put_le64(p + 16, a->count);
		pm_put_le64(p + 24, a->emitted);
		pm_put_le64(p + 32, a->first_index);
		pm_put_le64(p + 40, o[i].offset);
		pm_put_le64(p + 48, o[i].stored);
		for (k = 0; k < 3; k++) {
			pm_put_f32(p + 56 + 4 * k, o[i].lo[k]);
			pm_put_f32(p + 68 + 4 * k, o[i].hi[k]);
		}
		pm_put_f32(p + 80, a->radius);
	}
	if (isize > 0)
		memcpy(h + PMAP_FIXED + m->nmaps * PMAP_ENTRY, m->info, isize);
	pm_put_le32(h + hs - 4, pm_crc32(0, h, hs - 4));
}

/* Writes the header and payloads to fd. */
static enum pm_err
write_body(int fd, const char *name, const unsigned char *h, uint32_t hs,
    const struct pm_pmap *m, const struct pmap_out *o, unsigned char *scratch,
    size_t per, struct pm_error *err)
{
	static const unsigned char zeros[PMAP_ALIGN];
	const struct pm_map *a;
	uint64_t pos = hs, j, n;
	enum pm_err r;
	int i;

	if ((r = write_all(fd, h, hs, -1, name, err)) != PM_OK)
		return r;
	for (i = 0; i < m->nmaps; i++) {
		a = &m->maps[i];
		if ((r = write_all(fd, zeros, o[i].offset - pos, -1, name,
		    err)) !=
		    PM_OK)
			return r;
		if (o[i].z != NULL)
			r = write_all(fd, o[i].z, o[i].stored, -1, name, err);
		else if (PMAP_HOST_LE)
			r = write_all(fd, a->photons, o[i].stored, -1, name,
			    err);
		else
			for (j = 0; j < a->count && r == PM_OK; j += n) {
				n = a->count - j < per ? a->count - j : per;
				r = write_all(fd, records_to_file(a->photons +
				    j, (size_t)n, scratch), n * PMAP_REC, -1,
				    name, err);
			}
		if (r != PM_OK)
			return r;
		pos = o[i].offset + o[i].stored;
	}
	return PM_OK;
}

/* Writes m to path ("-": standard output) via a renamed temporary file. */
enum pm_err
pm_pmap_write(const char *path, const struct pm_pmap *m, bool compress,
    struct pm_error *err)
{
	return pm_pmap_write_threads(path, m, compress, 1, err);
}

/* o's bounds and crc32 (set when first) followed by run r's: zlib combines
 * the two crc32s from r's alone (O(log n), no pass over the records). */
static void
run_fold(struct pmap_out *o, bool first, const struct pm_pmap_run *r)
{
	bounds_fold(o->lo, o->hi, first, r->lo, r->hi);
	o->crc = first ? r->crc : (uint32_t)crc32_combine(o->crc, r->crc,
	    (z_off_t)(r->n * PMAP_REC));
}

/* A map's records summarised in pieces, on threads. */
struct sum_job {
	const struct pm_photon *p;
	uint64_t count, piece;
	int npieces;
	struct pm_pmap_run run[PMAP_PIECES];
	_Atomic int next;
};

static void *
sum_worker(void *arg)
{
	struct sum_job *j = arg;
	int k;

	while ((k = atomic_fetch_add(&j->next, 1)) < j->npieces) {
		uint64_t at = (uint64_t)k * j->piece;
		uint64_t n = j->count - at < j->piece ? j->count - at :
		    j->piece;

		pm_pmap_run_summarize(&j->run[k], j->p + at, (size_t)n);
	}
	return NULL;
}

/*
 * An uncompressed map's bounds and crc32, its records checked, in pieces
 * of the reader's size on up to `threads` threads, combined in order: the
 * same result as one pass (map_bounds and records_crc), which pm-balance
 * waited for with its other threads idle.
 */
static enum pm_err
map_summary(const char *name, const struct pm_map *a, struct pmap_out *o,
    int threads, unsigned char *scratch, size_t per, struct pm_error *err)
{
	struct sum_job *j;
	uint64_t piece = PMAP_PIECE_RECS;
	int k;

	if (a->count / PMAP_PIECES >= piece)
		piece = a->count / PMAP_PIECES + 1;
	if (threads <= 1 || a->count <= piece) {
		enum pm_err r = map_bounds(name, a, o, err);

		if (r == PM_OK)
			o->crc = records_crc(a->photons, a->count, scratch,
			    per);
		return r;
	}
	if ((j = malloc(sizeof(*j))) == NULL)
		return pm_fail(err, PM_ERR_NOMEM, "%s: out of memory", name);
	j->p = a->photons;
	j->count = a->count;
	j->piece = piece;
	j->npieces = (int)((a->count + piece - 1) / piece);
	atomic_init(&j->next, 0);
	pm_parallel(threads < j->npieces ? threads : j->npieces, sum_worker,
	    j);
	for (k = 0; k < j->npieces; k++) {
		const struct pm_pmap_run *r = &j->run[k];

		if (r->bad != 0) {
			enum pm_err e = bad_record(name, a->kind, r->p, r->n,
			    (uint64_t)k * piece, err);

			free(j);
			return e;
		}
		run_fold(o, k == 0, r);
	}
	free(j);
	return PM_OK;
}

enum pm_err
pm_pmap_write_threads(const char *path, const struct pm_pmap *m,
    bool compress, int threads, struct pm_error *err)
{
	struct pmap_out o[PMAP_MAXMAPS];
	bool to_stdout = strcmp(path, "-") == 0;
	const char *name = to_stdout ? "standard output" : path;
	unsigned char *h = NULL, *scratch = NULL;
	struct pm_out out;
	size_t isize = m->info != NULL ? strlen(m->info) : 0, per = 65536;
	uint64_t hs, end;
	enum pm_err r;
	int i;

	memset(o, 0, sizeof(o));
	if ((r = check_for_write(name, m, err)) != PM_OK)
		return r;
	hs = (uint64_t)PMAP_FIXED + (uint64_t)m->nmaps * PMAP_ENTRY + isize + 4;
	if (hs > UINT32_MAX)
		return pm_fail(err, PM_ERR_LIMIT, "%s: %zu bytes of provenance "
		    "text do not fit a header", name, isize);
	if (!PMAP_HOST_LE && (scratch = malloc(per * PMAP_REC)) == NULL)
		return pm_fail(err, PM_ERR_NOMEM, "%s: out of memory", name);

	end = hs;
	for (i = 0; i < m->nmaps; i++) {
		o[i].raw = m->maps[i].count * PMAP_REC;
		if (compress) {
			if ((r = map_bounds(name, &m->maps[i], &o[i], err)) !=
			    PM_OK || (r = deflate_map(name, &m->maps[i], &o[i],
			    scratch, per, err)) != PM_OK)
				goto done;
		} else {
			o[i].stored = o[i].raw;
			if ((r = map_summary(name, &m->maps[i], &o[i], threads,
			    scratch, per, err)) != PM_OK)
				goto done;
		}
		o[i].offset = align_up(end);
		end = o[i].offset + o[i].stored;
	}
	if ((h = malloc((size_t)hs)) == NULL) {
		r = pm_fail(err, PM_ERR_NOMEM, "%s: out of memory", name);
		goto done;
	}
	build_header(h, (uint32_t)hs, m, o, isize);

	if (to_stdout) {
		r = write_body(STDOUT_FILENO, name, h, (uint32_t)hs, m, o,
		    scratch, per, err);
		goto done;
	}
	if ((r = pm_out_open(&out, path, err)) != PM_OK)
		goto done;
	r = write_body(out.fd, name, h, (uint32_t)hs, m, o, scratch, per,
	    err);
	if (r == PM_OK)
		r = pm_out_commit(&out, err);
	else
		pm_out_abort(&out);
done:
	for (i = 0; i < PMAP_MAXMAPS; i++)
		free(o[i].z);
	free(h);
	free(scratch);
	return r;
}

/* --- Writing as the photons come --- */

struct pm_pmap_writer {
	struct pm_out out;
	struct pm_pmap m;		/* the header's fields; info a copy */
	struct pmap_out o[PMAP_MAXMAPS];	/* bounds and crc32 as added */
	uint32_t hs;			/* header bytes */
	int cur;			/* the map being added to */
	uint64_t pos;			/* end of what is written */
	unsigned char *scratch;		/* big-endian hosts: records in
					 * file order */
};

#define WRITER_PER	65536		/* records converted at a time */
#define WRITER_RUN	((size_t)1 << 24)	/* records summarised at a time */

/* Zeros from w->pos up to off, as pm_pmap_write pads between maps (so
 * that the file has no holes and ends where its last map does). */
static enum pm_err
writer_pad(struct pm_pmap_writer *w, uint64_t off, struct pm_error *err)
{
	static const unsigned char zeros[PMAP_ALIGN];
	enum pm_err r;

	if (off > w->pos && (r = write_all(w->out.fd, zeros, off - w->pos,
	    (int64_t)w->pos, w->out.path, err)) != PM_OK)
		return r;
	w->pos = off;
	return PM_OK;
}

/* Ends map w->cur and starts the next one at the next aligned offset. */
static enum pm_err
writer_next(struct pm_pmap_writer *w, struct pm_error *err)
{
	struct pmap_out *o = &w->o[w->cur];

	o->stored = o->raw = w->m.maps[w->cur].count * PMAP_REC;
	w->cur++;
	if (w->cur < w->m.nmaps) {
		w->o[w->cur].offset = align_up(w->pos);
		return writer_pad(w, w->o[w->cur].offset, err);
	}
	return PM_OK;
}

static void
writer_free(struct pm_pmap_writer *w)
{
	free(w->m.info);
	free(w->scratch);
	free(w);
}

void
pm_pmap_writer_abort(struct pm_pmap_writer *w)
{
	if (w == NULL)
		return;
	pm_out_abort(&w->out);
	writer_free(w);
}

enum pm_err
pm_pmap_writer_open(struct pm_pmap_writer **wp, const char *path,
    const struct pm_pmap *m, struct pm_error *err)
{
	struct pm_pmap_writer *w;
	size_t isize = m->info != NULL ? strlen(m->info) : 0;
	enum pm_err r;
	uint64_t hs;
	int i;

	*wp = NULL;
	if ((r = check_for_write(path, m, err)) != PM_OK)
		return r;
	for (i = 0; i < m->nmaps; i++)
		if (m->maps[i].count != 0 || m->maps[i].photons != NULL)
			return pm_fail(err, PM_ERR_INVALID, "%s: the %s map "
			    "has photons before any were added", path,
			    kind_name(m->maps[i].kind));
	hs = (uint64_t)PMAP_FIXED + (uint64_t)m->nmaps * PMAP_ENTRY + isize + 4;
	if (hs > UINT32_MAX)
		return pm_fail(err, PM_ERR_LIMIT, "%s: %zu bytes of provenance "
		    "text do not fit a header", path, isize);
	if ((w = calloc(1, sizeof(*w))) == NULL)
		return pm_fail(err, PM_ERR_NOMEM, "%s: out of memory", path);
	w->m = *m;
	w->m.info = NULL;
	if ((isize > 0 && (w->m.info = strdup(m->info)) == NULL) ||
	    (!PMAP_HOST_LE && (w->scratch = malloc(WRITER_PER * PMAP_REC)) ==
	    NULL)) {
		writer_free(w);
		return pm_fail(err, PM_ERR_NOMEM, "%s: out of memory", path);
	}
	w->hs = (uint32_t)hs;
	w->cur = 0;
	/* The header and its padding are written at the end, over this
	 * space; the first map starts where pm_pmap_write puts it. */
	w->pos = align_up(hs);
	w->o[0].offset = w->pos;
	if ((r = pm_out_open(&w->out, path, err)) != PM_OK) {
		writer_free(w);
		return r;
	}
	*wp = w;
	return PM_OK;
}

void
pm_pmap_run_summarize(struct pm_pmap_run *r, const struct pm_photon *p,
    size_t n)
{
	unsigned char tmp[64 * PMAP_REC];
	size_t j, k;

	r->p = p;
	r->n = n;
	r->bad = box_records(p, n, r->lo, r->hi);
	if (PMAP_HOST_LE)
		r->crc = pm_crc32(0, p, n * PMAP_REC);
	else
		for (r->crc = 0, j = 0; j < n; j += k) {
			k = n - j < 64 ? n - j : 64;
			r->crc = pm_crc32(r->crc, records_to_file(p + j, k,
			    tmp), k * PMAP_REC);
		}
}

enum pm_err
pm_pmap_writer_add_run(struct pm_pmap_writer *w, int i,
    const struct pm_pmap_run *r, struct pm_error *err)
{
	struct pm_map *a;
	enum pm_err e = PM_OK;
	size_t j, k;

	if (i < w->cur || i >= w->m.nmaps) {
		e = pm_fail(err, PM_ERR_INVALID, "%s: photons added to map %d "
		    "while writing map %d of %d", w->out.path, i, w->cur,
		    w->m.nmaps);
		goto fail;
	}
	while (w->cur < i)
		if ((e = writer_next(w, err)) != PM_OK)
			goto fail;
	a = &w->m.maps[i];
	if (r->n > (UINT64_MAX / PMAP_REC - a->count) ||
	    r->n > (sizeof(z_off_t) < 8 ? INT32_MAX : INT64_MAX) / PMAP_REC) {
		e = pm_fail(err, PM_ERR_LIMIT, "%s: %zu records added to the "
		    "%s map at once, more than its size or a checksum "
		    "combination can take", w->out.path, r->n,
		    kind_name(a->kind));
		goto fail;
	}
	if (r->bad != 0) {
		e = bad_record(w->out.path, a->kind, r->p, r->n, a->count, err);
		goto fail;
	}
	if (r->n == 0)
		return PM_OK;
	run_fold(&w->o[i], a->count == 0, r);
	for (j = 0; j < r->n; j += k) {
		k = r->n - j < WRITER_PER ? r->n - j : WRITER_PER;
		if ((e = write_all(w->out.fd, records_to_file(r->p + j, k,
		    w->scratch), (uint64_t)k * PMAP_REC, (int64_t)w->pos,
		    w->out.path, err)) != PM_OK)
			goto fail;
		w->pos += (uint64_t)k * PMAP_REC;
	}
	a->count += r->n;
	return PM_OK;
fail:
	pm_pmap_writer_abort(w);
	return e;
}

enum pm_err
pm_pmap_writer_add(struct pm_pmap_writer *w, int i, const struct pm_photon *p,
    size_t n, struct pm_error *err)
{
	struct pm_pmap_run r;
	enum pm_err e = PM_OK;
	size_t j = 0, k;

	/* In runs whose byte counts fit a 32-bit z_off_t (crc32_combine). */
	do {
		k = n - j < WRITER_RUN ? n - j : WRITER_RUN;
		pm_pmap_run_summarize(&r, p + j, k);
		e = pm_pmap_writer_add_run(w, i, &r, err);
		j += k;
	} while (e == PM_OK && j < n);
	return e;
}

enum pm_err
pm_pmap_writer_close(struct pm_pmap_writer *w, struct pm_error *err)
{
	static const unsigned char zeros[PMAP_ALIGN];
	size_t isize = w->m.info != NULL ? strlen(w->m.info) : 0;
	unsigned char *h = NULL;
	enum pm_err r;
	const char *why;
	int i;

	while (w->cur < w->m.nmaps)
		if ((r = writer_next(w, err)) != PM_OK)
			goto fail;
	for (i = 0; i < w->m.nmaps; i++) {
		const struct pm_map *a = &w->m.maps[i];

		if ((why = counts_problem((uint32_t)a->kind, a->count,
		    a->emitted, a->first_index)) != NULL) {
			r = pm_fail(err, PM_ERR_INVALID, "%s: the %s map: %s",
			    w->out.path, kind_name(a->kind), why);
			goto fail;
		}
	}
	if ((h = malloc(w->hs)) == NULL) {
		r = pm_fail(err, PM_ERR_NOMEM, "%s: out of memory",
		    w->out.path);
		goto fail;
	}
	build_header(h, w->hs, &w->m, w->o, isize);
	/* The padding before the first map belongs to it: a file of no
	 * maps ends with its header. */
	if ((r = write_all(w->out.fd, h, w->hs, 0, w->out.path, err)) !=
	    PM_OK || (r = write_all(w->out.fd, zeros, w->m.nmaps > 0 ?
	    align_up(w->hs) - w->hs : 0, w->hs, w->out.path, err)) != PM_OK)
		goto fail;
	free(h);
	r = pm_out_commit(&w->out, err);
	writer_free(w);
	return r;
fail:
	free(h);
	pm_pmap_writer_abort(w);
	return r;
}

/* --- Writing on a thread while the last map is made --- */

struct pm_pmap_bgwrite {
	struct pm_pmap_writer *w;	/* NULL once an error freed it */
	struct pm_pmap m;		/* the maps the thread writes, as
					 * begun: the caller's may grow */
	pthread_t t;
	bool started;			/* t runs; else its work is left to
					 * pm_pmap_write_end */
	enum pm_err r;			/* the thread's result */
	struct pm_error err;
};

static void *
bg_worker(void *arg)
{
	struct pm_pmap_bgwrite *b = arg;
	int i;

	b->r = PM_OK;
	for (i = 0; i < b->m.nmaps && b->r == PM_OK; i++)
		if ((b->r = pm_pmap_writer_add(b->w, i, b->m.maps[i].photons,
		    (size_t)b->m.maps[i].count, &b->err)) != PM_OK)
			b->w = NULL;	/* freed by the writer */
	return NULL;
}

enum pm_err
pm_pmap_write_begin(struct pm_pmap_bgwrite **bp, const char *path,
    const struct pm_pmap *m, const struct pm_map *last, struct pm_error *err)
{
	struct pm_pmap_bgwrite *b;
	struct pm_pmap h;
	enum pm_err r;
	int i;

	*bp = NULL;
	if (m->nmaps < 0 || m->nmaps >= PMAP_MAXMAPS)
		return pm_fail(err, PM_ERR_INVALID, "%s: %d maps and one more "
		    "(at most %d)", path, m->nmaps, PMAP_MAXMAPS);
	/* The header's maps: m's and last, none with records yet. */
	h = *m;
	h.maps[h.nmaps++] = *last;
	for (i = 0; i < h.nmaps; i++) {
		h.maps[i].count = 0;
		h.maps[i].photons = NULL;
	}
	if ((b = calloc(1, sizeof(*b))) == NULL)
		return pm_fail(err, PM_ERR_NOMEM, "%s: out of memory", path);
	if ((r = pm_pmap_writer_open(&b->w, path, &h, err)) != PM_OK) {
		free(b);
		return r;
	}
	b->m = *m;
	b->started = pthread_create(&b->t, NULL, bg_worker, b) == 0;
	*bp = b;
	return PM_OK;
}

/* Waits for the thread, or does its work when none could start. */
static void
bg_wait(struct pm_pmap_bgwrite *b)
{
	if (b->started)
		pthread_join(b->t, NULL);
	else
		bg_worker(b);
}

enum pm_err
pm_pmap_write_end(struct pm_pmap_bgwrite *b, const struct pm_map *last,
    struct pm_error *err)
{
	enum pm_err r;
	int i = b->m.nmaps;

	bg_wait(b);
	if ((r = b->r) != PM_OK) {
		*err = b->err;
		free(b);
		return r;
	}
	if ((r = pm_pmap_writer_add(b->w, i, last->photons,
	    (size_t)last->count, err)) == PM_OK)
		r = pm_pmap_writer_close(b->w, err);
	free(b);
	return r;
}

void
pm_pmap_write_cancel(struct pm_pmap_bgwrite *b)
{
	if (b == NULL)
		return;
	bg_wait(b);
	pm_pmap_writer_abort(b->w);
	free(b);
}

/* Appends "key=value\n" to m->info; the value is made one valid line. */
enum pm_err
pm_pmap_info_add(struct pm_pmap *m, const char *key, const char *value,
    struct pm_error *err)
{
	size_t klen = strlen(key), vlen = strlen(value), old, i, k;
	const unsigned char *v = (const unsigned char *)value;
	char *s, *d;

	if (klen == 0 || strpbrk(key, "=\n\r") != NULL)
		return pm_fail(err, PM_ERR_INVALID, "provenance key \"%s\" is "
		    "empty or has '=' or a newline", key);
	for (i = 0; i < klen; i += k)
		if ((k = utf8_len((const unsigned char *)key + i, klen - i)) ==
		    0)
			return pm_fail(err, PM_ERR_INVALID, "provenance key "
			    "is not UTF-8");
	old = m->info != NULL ? strlen(m->info) : 0;
	if ((s = realloc(m->info, old + klen + vlen + 3)) == NULL)
		return pm_fail(err, PM_ERR_NOMEM, "out of memory for "
		    "provenance");
	m->info = s;
	d = s + old;
	memcpy(d, key, klen);
	d += klen;
	*d++ = '=';
	/* Newlines would start a line of their own; bytes that are not
	 * UTF-8 (a command line in Latin-1) would make the file invalid. */
	for (i = 0; i < vlen; i += k) {
		k = utf8_len(v + i, vlen - i);
		if (v[i] == '\n' || v[i] == '\r')
			*d++ = ' ';
		else if (k == 0)
			*d++ = '?';
		else {
			memcpy(d, v + i, k);
			d += k;
		}
		if (k == 0)
			k = 1;
	}
	*d++ = '\n';
	*d = '\0';
	return PM_OK;
}
