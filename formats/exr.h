/*
 * exr.h: OpenEXR images through OpenEXR's C API (OpenEXRCore).
 */
#ifndef PM_EXR_H
#define PM_EXR_H

#include <stdbool.h>
#include <stddef.h>

#include "../common/error.h"
#include "../common/image.h"

/* One string attribute of a header: the provenance the tools record. */
struct pm_exr_attr {
	char *name;
	char *value;
};

/* A header's string attributes in file order, each name once; owns its
 * strings.  Zero-initialised is empty. */
struct pm_exr_attrs {
	struct pm_exr_attr *v;
	size_t n;
};

/* Sets name to value, replacing an attribute of that name or appending
 * one; copies both strings. */
enum pm_err pm_exr_attrs_set(struct pm_exr_attrs *a, const char *name,
    const char *value, struct pm_error *err);
/* The value of name (owned by a), or NULL if a has none. */
const char *pm_exr_attrs_get(const struct pm_exr_attrs *a, const char *name);
/* Frees every attribute and leaves a empty. */
void pm_exr_attrs_free(struct pm_exr_attrs *a);

/*
 * Channels beside R, G and B, three to a layer: component k of im's
 * pixels is the channel named name[k] (owned), or unused where name[k] is
 * NULL.  Mitsuba's AOVs (moment's "nested.X", "m2_nested.X", ...) travel
 * this way.  Zero-initialised is empty.
 */
struct pm_exr_layer {
	char *name[3];
	struct pm_image im;
};

struct pm_exr_layers {
	struct pm_exr_layer *v;
	size_t n;
};

/* Appends a layer of channels n0, n1, n2 (NULL for an unused slot; the
 * names are copied) with a zeroed width x height image, and returns it in
 * *out (owned by l, valid until the next append). */
enum pm_err pm_exr_layers_add(struct pm_exr_layers *l, const char *n0,
    const char *n1, const char *n2, int width, int height,
    struct pm_exr_layer **out, struct pm_error *err);
/* Frees every layer and leaves l empty. */
void pm_exr_layers_free(struct pm_exr_layers *l);

/*
 * Writes im as a scanline RGB file, float32 uncompressed or (half = true)
 * half, PIZ compressed.  Writes to a temporary file beside path and renames it, so
 * that a failed write never leaves a partial file.
 */
enum pm_err pm_exr_write(const char *path, const struct pm_image *im, bool half,
    struct pm_error *err);
/* pm_exr_write with attrs (NULL for none) as string attributes of the
 * header; a name OpenEXR reserves for another type is an error. */
enum pm_err pm_exr_write_attrs(const char *path, const struct pm_image *im,
    bool half, const struct pm_exr_attrs *attrs, struct pm_error *err);

/* pm_exr_write_attrs with the channels of layers (NULL for none) beside
 * R, G and B, in the same pixel type; each layer's image has im's size. */
enum pm_err pm_exr_write_layers(const char *path, const struct pm_image *im,
    bool half, const struct pm_exr_attrs *attrs,
    const struct pm_exr_layers *layers, struct pm_error *err);

/* Reads the R, G and B channels (half, float or uint) of the first part;
 * a missing channel is an error. im is allocated here. */
enum pm_err pm_exr_read(const char *path, struct pm_image *im, struct pm_error *err);
/* pm_exr_read that also fills attrs (NULL: not wanted; emptied first,
 * owned by the caller) with the first part's string attributes, less
 * "name" and "type", which describe parts rather than the image; with im
 * NULL only the header is read. */
enum pm_err pm_exr_read_attrs(const char *path, struct pm_image *im,
    struct pm_exr_attrs *attrs, struct pm_error *err);
/* pm_exr_read_attrs that also reads every other channel into layers
 * (NULL: not wanted; emptied first, owned by the caller), three to a
 * layer in the file's (sorted) channel order, the last layer's unused
 * slots NULL. */
enum pm_err pm_exr_read_layers(const char *path, struct pm_image *im,
    struct pm_exr_attrs *attrs, struct pm_exr_layers *layers,
    struct pm_error *err);

#endif
