/*
 * fuzz_merl.c: libFuzzer target for the MERL BRDF reader.  A real table is
 * 34,992,012 bytes, so what this mostly checks is that every other size,
 * and every header, is refused without reading past the buffer.
 */
#include <stddef.h>
#include <stdint.h>

#include "../../common/merl.h"
#include "../../formats/merl.h"

/* libFuzzer's entry point: one input, always 0. */
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int
LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	struct pm_merl *m = NULL;
	struct pm_error err;

	if (pm_merl_parse(data, size, "fuzz.binary", &m, &err) == PM_OK)
		pm_merl_free(m);
	return 0;
}
