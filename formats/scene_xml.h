/*
 * scene_xml.h: the subset of Mitsuba 3's scene format that pm supports,
 * read with expat into a struct pm_scene.  man/pm-scene.5 lists every
 * element and parameter.
 */
#ifndef PM_SCENE_XML_H
#define PM_SCENE_XML_H

#include <stddef.h>

#include "../common/error.h"
#include "../common/scene.h"

/* A -D name=value override of a <default>. */
struct pm_define {
	const char *name;
	const char *value;
};

/*
 * Loads path into s (initialised here; free with pm_scene_free).  Relative
 * file names resolve against the directory of the file that names them and
 * any <path> elements.  Anything outside the subset is an error naming the
 * file, line and element.  Meshes are read, transformed to world space and
 * given normals here; pm_scene_prepare is called before returning.
 */
enum pm_err pm_scene_load(const char *path, const struct pm_define *defs,
    size_t ndefs, struct pm_scene *s, struct pm_error *err);

/* The same from a string (tests, fuzzing); base_dir resolves file names. */
enum pm_err pm_scene_load_string(const char *xml, size_t len, const char *name,
    const char *base_dir, const struct pm_define *defs, size_t ndefs,
    struct pm_scene *s, struct pm_error *err);

#endif
