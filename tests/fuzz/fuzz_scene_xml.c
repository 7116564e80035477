/*
 * fuzz_scene_xml.c: libFuzzer target for the Mitsuba XML loader.  Relative
 * file names resolve against a directory that does not exist, so the
 * loader's own checks (elements, parameters, numbers, references,
 * defaults, transforms) are what runs, then pm_scene_prepare.
 */
#include <stddef.h>
#include <stdint.h>

#include "../../common/scene.h"
#include "../../formats/scene_xml.h"

/* libFuzzer's entry point: one input, always 0. */
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int
LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	static const struct pm_define defs[] = {{"spp", "4"}, {"res", "8"}};
	struct pm_scene s;
	struct pm_error err;

	if (pm_scene_load_string((const char *)data, size, "fuzz.xml",
	    "/nonexistent-pm-fuzz", defs, 2, &s, &err) == PM_OK)
		pm_scene_free(&s);
	return 0;
}
