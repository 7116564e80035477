/*
 * fuzz_serialized.c: libFuzzer target for the reader of Mitsuba's
 * .serialized meshes.  Whatever the bytes, pm_serialized_parse must return
 * an error or a mesh whose indices are in range, for the first mesh and
 * for one found through the table at the end; a mesh that parses is then
 * validated and given normals, the steps the scene loader takes next.
 */
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "../../common/mesh.h"
#include "../../formats/serialized.h"

/* libFuzzer's entry point: one input, always 0. */
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int
LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	struct pm_mesh m;
	struct pm_error err;
	uint32_t dropped, i;
	long index;
	bool fn;

	for (index = 0; index < 2; index++) {
		if (pm_serialized_parse("fuzz.serialized", data, size, index, &m,
		    &fn, &err) != PM_OK)
			continue;
		/* An index out of range is the reader's bug, not the input's. */
		for (i = 0; i < 3 * m.ntris; i++)
			if (m.idx[i] >= m.nverts)
				__builtin_trap();
		if (pm_mesh_validate(&m, &dropped, &err) == PM_OK && m.ntris > 0)
			(void)pm_mesh_compute_normals(&m, &err);
		pm_mesh_free(&m);
	}
	return 0;
}
