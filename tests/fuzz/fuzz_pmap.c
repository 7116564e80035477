/*
 * fuzz_pmap.c: libFuzzer target for the photon-map reader.  A map that
 * parses is then walked as pm-render and pm-inspect would walk it: the
 * kd-tree check and a query, which must not crash even when a map claims
 * to be balanced and is not (a compressed map may also claim far more
 * photons than its bytes; libFuzzer's memory limit catches a reader that
 * believes it).
 */
#include <stddef.h>
#include <stdint.h>

#include "../../common/kdtree.h"
#include "../../formats/pmap.h"

/* libFuzzer's entry point: one input, always 0. */
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int
LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	struct pm_pmap m;
	struct pm_error err;
	struct pm_knn out[8];
	const float q[3] = {0.0f, 0.0f, 0.0f};
	size_t bad;
	int i;

	if (pm_pmap_parse("fuzz.pmap", data, size, &m, &err) != PM_OK)
		return 0;
	for (i = 0; i < m.nmaps; i++) {
		struct pm_map *mp = &m.maps[i];

		if (mp->count == 0 || mp->count >= UINT32_MAX)
			continue;
		(void)pm_kdtree_verify(mp->photons, (size_t)mp->count, &bad);
		(void)pm_kdtree_knn(mp->photons, (size_t)mp->count, q, 8, 1e30f,
		    0, 0, out);
	}
	pm_pmap_free(&m);
	return 0;
}
