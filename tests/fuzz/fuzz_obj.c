/*
 * fuzz_obj.c: libFuzzer target for the OBJ reader.  Whatever the bytes,
 * pm_obj_parse must return an error or a mesh whose indices are in range;
 * a mesh that parses is then validated and given normals, the steps the
 * scene loader takes next.
 */
#include <stddef.h>
#include <stdint.h>

#include "../../common/mesh.h"
#include "../../formats/obj.h"

/* libFuzzer's entry point: one input, always 0. */
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int
LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	struct pm_mesh m;
	struct pm_error err;
	uint32_t dropped, i;

	if (pm_obj_parse("fuzz.obj", (const char *)data, size, &m, &err) != PM_OK)
		return 0;
	/* An index out of range is the reader's bug, not the input's. */
	for (i = 0; i < 3 * m.ntris; i++)
		if (m.idx[i] >= m.nverts)
			__builtin_trap();
	if (pm_mesh_validate(&m, &dropped, &err) == PM_OK && m.ntris > 0)
		(void)pm_mesh_compute_normals(&m, &err);
	pm_mesh_free(&m);
	return 0;
}
