/*
 * fuzz_vol.c: libFuzzer target for the .vol grid reader (formats/vol.h):
 * every header and length must be refused or read without reading past
 * the buffer, and a grid read must hold only finite values.
 */
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>

#include "../../formats/vol.h"

/* libFuzzer's entry point: one input, always 0. */
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int
LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	struct pm_grid g;
	struct pm_error err;
	size_t i, n;

	if (pm_vol_parse(data, size, "fuzz.vol", &g, &err) != PM_OK)
		return 0;
	n = (size_t)g.nx * (size_t)g.ny * (size_t)g.nz * (size_t)g.nch;
	for (i = 0; i < n; i++)
		if (!isfinite(g.data[i]) || g.data[i] > g.max)
			abort();
	pm_grid_free(&g);
	return 0;
}
