/*
 * private.h: what the files of the scene XML loader share and nothing
 * else sees.  The public interface is formats/scene_xml.h; the loader is
 * split by element kind (doc.c: the document tree of the first pass and
 * its ids; values.c and props.c: numbers, transforms and typed
 * properties; bsdf.c, emitter.c, shape.c, sensor.c, integrator.c: one
 * kind of object each; load.c: the second pass and the entry points).
 * Functions shared between the files carry an sx_ prefix, since the
 * library's archive puts them in one namespace with everything else.
 */
#ifndef PM_SCENE_XML_PRIVATE_H
#define PM_SCENE_XML_PRIVATE_H

#include <ctype.h>
#include <errno.h>
#include <expat.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <unistd.h>

#include "../../common/merl.h"
#include "../../common/parse.h"
#include "../file.h"
#include "../merl.h"
#include "../obj.h"
#include "../ply.h"
#include "../serialized.h"
#include "../scene_xml.h"
#include "../texture.h"

#define MAX_DEPTH		64	/* element nesting */
#define MAX_INCLUDE_DEPTH	32
#define MAX_FILE_SIZE		((size_t)256 << 20)
#define DISK_SEGMENTS		256
#define CYLINDER_SEGMENTS	1024
#define PI_D			3.14159265358979323846

/* Default indices of refraction (Mitsuba's table). */
#define IOR_BK7			1.5046f
#define IOR_AIR			1.000277f
#define IOR_POLYPROPYLENE	1.49f

/* The first pass's memory: one arena, freed when loading ends. */
struct blk {
	struct blk *next;
	size_t used, cap;
	max_align_t data[];
};

struct arena {
	struct blk *head;
};

struct xnode {
	const char *tag;
	const char **attr;		/* name, value, ..., NULL */
	const char *file;
	const char *dir;		/* of file: where its names resolve */
	int line;
	int seq;			/* document order, for messages */
	struct xnode *parent, *kids, *last, *next;
	int inst;			/* bsdf or medium index, or carrying
					 * shape; -1 */
	bool busy;			/* being built: catches reference cycles */
};

struct param {				/* a -D define or a <default> */
	const char *name, *value;
	struct param *next;
};

struct dir {				/* a <path> search directory */
	const char *path;
	struct dir *next;
};

struct idmap {
	const char *id;
	struct xnode *node;
};

struct ld {
	struct pm_scene *s;
	struct pm_error *err;
	struct arena arena;
	bool failed;
	struct param *params, *params_last;
	struct dir *dirs, *dirs_last;
	const char *top_dir;
	struct xnode *root;
	struct idmap *ids;
	size_t nids;
	const char *incl[MAX_INCLUDE_DEPTH + 1];	/* real paths */
	int nincl;
	int default_bsdf;
	struct xnode *sensor, *integrator;
	int seq;
	/* While the shapes of a shapegroup are built for an instance: the
	 * instance's to_world, applied after each shape's own. */
	const struct pm_mat4 *instance_to_world;
};

struct doc {				/* one file being read by expat */
	struct ld *ld;
	XML_Parser p;
	const char *file;
	const char *dir;
	struct xnode *cur;
	struct xnode *graft;		/* include: where children go */
	int depth;
};


enum ptype {
	P_FLOAT, P_INTEGER, P_BOOLEAN, P_STRING, P_RGB, P_SPECTRUM,
	P_POINT, P_VECTOR, P_TRANSFORM,
};

/* A <spectrum> as given (spectrum.c); its RGB depends on where it is used. */
enum sx_spec_kind {
	SX_SPEC_UNIFORM,	/* value="0.5" */
	SX_SPEC_PLAIN,		/* type="uniform": a grey everywhere */
	SX_SPEC_LIST,		/* wavelength:value pairs, from value or a file */
	SX_SPEC_BLACKBODY,	/* type="blackbody" */
	SX_SPEC_RGB,		/* type="d65" or "srgb": a colour everywhere */
};

struct sx_spectrum {
	enum sx_spec_kind kind;
	double value;		/* uniform value; blackbody temperature */
	double wmin, wmax;	/* blackbody: wavelength range, nm */
	double *wl, *v;		/* list: n pairs */
	size_t n;
	struct pm_rgb rgb;	/* d65, srgb */
};

struct prop {
	const char *name;
	enum ptype type;
	const struct xnode *n;
	bool used;
	double f;		/* float, integer */
	long i;			/* integer */
	bool b;
	const char *s;
	struct pm_rgb c;	/* rgb */
	const struct sx_spectrum *spec;	/* spectrum */
	struct pm_vec3 v;	/* point, vector */
	struct pm_mat4 m;
};

struct plist {
	const struct xnode *owner;
	char what[96];		/* "bsdf \"diffuse\"", for messages */
	struct prop *p;
	size_t n;
	struct xnode *obj[16];	/* nested objects and refs */
	size_t nobj;
	/* Nested <texture>s not yet taken by a parameter (sx_get_texture
	 * removes what it takes); one left over is reported only once the
	 * plugin's type is known to be one pm reads (sx_finish,
	 * sx_missing), so that an unknown plugin is named first. */
	struct xnode *tex[16];
	size_t ntex;
};

/* doc.c */
void *sx_arena_alloc(struct arena *a, size_t n);
void sx_arena_free(struct arena *a);
char *sx_arena_strdup(struct arena *a, const char *s);
const char *sx_attr(const struct xnode *n, const char *name);
enum pm_err sx_build_idmap(struct ld *ld);
enum pm_err sx_check_attrs(struct ld *ld, const struct xnode *n,
    const char *const *allowed);
enum pm_err sx_deref(struct ld *ld, struct xnode *ref, struct xnode **out);
char *sx_dir_of(struct arena *a, const char *path);
enum pm_err sx_fail(struct ld *ld, const struct xnode *n, enum pm_err code,
    const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 4, 5)))
#endif
    ;
enum pm_err sx_need_attr(struct ld *ld, const struct xnode *n, const char *name,
    const char **out);
enum pm_err sx_nomem(struct ld *ld);
enum pm_err sx_param_add(struct ld *ld, const char *name, const char *value);
enum pm_err sx_parse_doc(struct ld *ld, const char *file, const char *buf,
    size_t len, struct xnode *graft);
enum pm_err sx_resolve(struct ld *ld, const struct xnode *n,
    const char *naming_dir, const char *name, const char **out);

/* values.c */
enum pm_err sx_no_kids(struct ld *ld, const struct xnode *n);
bool sx_number(const char *s, double *out);
enum pm_err sx_numbers(struct ld *ld, const struct xnode *n, const char *what,
    const char *s, double *out, int nmin, int nmax, int *count);
enum pm_err sx_parse_transform(struct ld *ld, const struct xnode *t,
    struct pm_mat4 *out);
enum pm_err sx_xyz(struct ld *ld, const struct xnode *n, double def,
    struct pm_vec3 *out);

/* props.c */
enum pm_err sx_collect(struct ld *ld, const struct xnode *owner,
    const char *kind, const char *type, struct plist *pl);
enum pm_err sx_collect_scene(struct ld *ld, const struct xnode *root,
    struct plist *pl);
enum pm_err sx_finish(struct ld *ld, struct plist *pl);
enum pm_err sx_get_bool(struct ld *ld, struct plist *pl, const char *name,
    bool def, bool *out);
enum pm_err sx_get_color(struct ld *ld, struct plist *pl, const char *name,
    float def, struct pm_rgb *out);
enum pm_err sx_get_float(struct ld *ld, struct plist *pl, const char *name,
    double def, double lo, double hi, double *out);
enum pm_err sx_get_int(struct ld *ld, struct plist *pl, const char *name,
    long def, long lo, long hi, long *out);
enum pm_err sx_get_point(struct ld *ld, struct plist *pl, const char *name,
    struct pm_vec3 def, struct pm_vec3 *out);
enum pm_err sx_get_string(struct ld *ld, struct plist *pl, const char *name,
    const char *def, const char **out);
enum pm_err sx_get_transform(struct ld *ld, struct plist *pl, const char *name,
    struct pm_mat4 *out);
bool sx_has(struct plist *pl, const char *name);
bool sx_is_object_tag(const char *t);
enum pm_err sx_missing(struct ld *ld, struct plist *pl, const char *name,
    const char *want);
enum pm_err sx_no_objects(struct ld *ld, struct plist *pl);
enum pm_err sx_object_type(struct ld *ld, const struct xnode *n,
    const char **type);
struct prop *sx_prop_find(struct plist *pl, const char *name);
int sx_ptype_of(const char *t);
enum pm_err sx_unknown_plugin(struct ld *ld, const struct xnode *n,
    const char *type, const char *known);
enum pm_err sx_wrong_type(struct ld *ld, struct plist *pl, struct prop *p,
    const char *want);

/* spectrum.c */
enum pm_err sx_parse_spectrum(struct ld *ld, const struct xnode *k,
    struct prop *p);
struct pm_rgb sx_spectrum_rgb(const struct sx_spectrum *sp, bool emitter,
    bool unbounded);

/* texture.c */
enum pm_err sx_get_color_tex(struct ld *ld, struct plist *pl,
    const char *name, float def, struct pm_rgb *out, int *tex);
enum pm_err sx_get_texture(struct ld *ld, struct plist *pl, const char *name,
    int *tex);
enum pm_err sx_texture_index(struct ld *ld, struct xnode *n, int *out);

/* bsdf.c */
enum pm_err sx_bsdf_index(struct ld *ld, struct xnode *n, int *out);
enum pm_err sx_build_bsdf(struct ld *ld, struct xnode *n, struct pm_bsdf *b);
int sx_default_bsdf(struct ld *ld);

/* emitter.c */
enum pm_err sx_build_area(struct ld *ld, struct xnode *n,
    struct pm_rgb *radiance, int *tex);
enum pm_err sx_load_emitter(struct ld *ld, struct xnode *n);

/* shape.c */
enum pm_err sx_load_shape(struct ld *ld, struct xnode *n,
    const char *naming_dir);
bool sx_similarity_scale(const struct pm_mat4 *M, float *scale);
enum pm_err sx_load_fov(struct ld *ld, struct plist *pl, const struct xnode *n,
    struct pm_camera *c);
enum pm_err sx_wrap(struct ld *ld, const struct xnode *n, const char *what,
    enum pm_err e);

/* medium.c */
enum pm_err sx_build_medium(struct ld *ld, struct xnode *n,
    struct pm_medium *m);
enum pm_err sx_check_phase(struct ld *ld, struct xnode *n);
enum pm_err sx_medium_index(struct ld *ld, struct xnode *n, int *out);
enum pm_err sx_shape_medium(struct ld *ld, struct plist *pl, struct xnode *o,
    struct xnode *t, int *interior, int *exterior);

/* sensor.c */
enum pm_err sx_load_sensor(struct ld *ld, struct xnode *n);

/* integrator.c */
enum pm_err sx_load_integrator(struct ld *ld, struct xnode *n);

#endif
