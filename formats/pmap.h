/*
 * pmap.h: the photon-map file, pm's contract between tools.  man/pmap.5
 * specifies every byte; this is its reader and writer.  The types it
 * reads into, and what is done with them, are common/photonmap.h's.
 */
#ifndef PM_PMAP_H
#define PM_PMAP_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "../common/error.h"
#include "../common/photon.h"
#include "../common/photonmap.h"

#define PM_PMAP_VERSION_MAJOR 2
#define PM_PMAP_VERSION_MINOR 1

/*
 * Writes m to path ("-": standard output) through a temporary file renamed
 * on success.  compress: zlib-compress each map's records.  The crc32 of
 * each map's stored bytes is computed here.
 */
enum pm_err pm_pmap_write(const char *path, const struct pm_pmap *m,
    bool compress, struct pm_error *err);

/* The same, the uncompressed maps' bounds and checksums computed on up to
 * `threads` threads (the same bytes whatever their number). */
enum pm_err pm_pmap_write_threads(const char *path, const struct pm_pmap *m,
    bool compress, int threads, struct pm_error *err);

/*
 * A map file written as its photons come, so that they need not be held
 * in memory (pm-shoot's maps): to a named file only (the header, which
 * comes first, is written last), uncompressed, the maps in m's order.
 * pm_pmap_writer_open takes everything but the records and counts from m
 * (its maps' count must be 0 and photons NULL; m need not outlive the
 * call); pm_pmap_writer_add appends records to map i, the maps in turn
 * (adding to map i ends the maps before it); pm_pmap_writer_close writes
 * the header and puts the file in place.  The bytes are pm_pmap_write's
 * for the same maps.  After an error from add or close the writer is
 * freed and no file is left; pm_pmap_writer_abort frees a writer that is
 * given up.
 */
struct pm_pmap_writer;
enum pm_err pm_pmap_writer_open(struct pm_pmap_writer **w, const char *path,
    const struct pm_pmap *m, struct pm_error *err);
enum pm_err pm_pmap_writer_add(struct pm_pmap_writer *w, int i,
    const struct pm_photon *p, size_t n, struct pm_error *err);
enum pm_err pm_pmap_writer_close(struct pm_pmap_writer *w,
    struct pm_error *err);

/*
 * m's maps written on a thread of their own while the caller makes one map
 * more, to follow them (pm-balance's irradiance records, made on its other
 * threads), so that the write does not wait for them nor they for it.
 * pm_pmap_write_begin opens path for m's maps and `last`, whose entry it
 * takes but for its records and count (as pm_pmap_writer_open does), and
 * starts writing m's records; pm_pmap_write_end waits for that, appends
 * last's records, now made, and puts the file in place.  The bytes are
 * pm_pmap_write's for m's maps followed by last.  m's records must not
 * change until the end.  After an error from either nothing is left to
 * free and no file is left; pm_pmap_write_cancel gives up a write begun.
 */
struct pm_pmap_bgwrite;
enum pm_err pm_pmap_write_begin(struct pm_pmap_bgwrite **b, const char *path,
    const struct pm_pmap *m, const struct pm_map *last, struct pm_error *err);
enum pm_err pm_pmap_write_end(struct pm_pmap_bgwrite *b,
    const struct pm_map *last, struct pm_error *err);
void pm_pmap_write_cancel(struct pm_pmap_bgwrite *b);

/*
 * Records summarised apart from a writer: their crc32 in file order, their
 * bounds, and whether the writer would refuse one.  A producer on many
 * threads summarises each run on the thread that made it; what is left for
 * pm_pmap_writer_add_run, which must be called in file order, is to check
 * the summary, fold it into the map's and write the records.
 * pm_pmap_writer_add(w, i, p, n) is pm_pmap_run_summarize then
 * pm_pmap_writer_add_run.
 */
struct pm_pmap_run {
	const struct pm_photon *p;
	size_t n;
	uint32_t crc;			/* of the n records in file order */
	uint32_t bad;			/* nonzero: a record is refused */
	float lo[3], hi[3];		/* 0 for no records */
};
void pm_pmap_run_summarize(struct pm_pmap_run *r, const struct pm_photon *p,
    size_t n);
enum pm_err pm_pmap_writer_add_run(struct pm_pmap_writer *w, int i,
    const struct pm_pmap_run *r, struct pm_error *err);
void pm_pmap_writer_abort(struct pm_pmap_writer *w);

/*
 * Reads path ("-": standard input).  Every count, size and offset is
 * checked against the file's size before it is used, every crc32 is
 * verified, and reserved fields (the records' included) must be zero.
 * A version 1 file is refused (PM_ERR_UNSUPPORTED): it must be shot
 * again.  With allow_mmap, the
 * records of an uncompressed file are memory-mapped rather than copied
 * (little-endian hosts only).  m is initialised here; free it with
 * pm_pmap_free.  Besides the contents, m receives what the file says of
 * itself: its version, its size in bytes (a pipe is read to its end) and
 * each map's stored crc32 and the crc32 of its records uncompressed.
 */
enum pm_err pm_pmap_read(const char *path, struct pm_pmap *m, bool allow_mmap,
    struct pm_error *err);

/* The same, checking the records of a memory-mapped or uncompressed map
 * (their crc32 and reserved bytes) on up to `threads` threads, with the
 * same result whatever their number. */
enum pm_err pm_pmap_read_threads(const char *path, struct pm_pmap *m,
    bool allow_mmap, int threads, struct pm_error *err);

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

#endif
