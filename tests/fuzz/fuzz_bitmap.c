/*
 * fuzz_bitmap.c: libFuzzer target for bitmap textures (PNG through
 * libpng, JPEG through libjpeg, OpenEXR; formats/texture.c).  The readers
 * open files by name, so each input goes into a memory file (memfd) read
 * back through /proc/self/fd.  A bitmap that reads is looked up at a few
 * points in every mode: a texel index out of range is the lookup's bug.
 */
#define _GNU_SOURCE
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <sys/mman.h>
#include <unistd.h>

#include "../../common/texture.h"
#include "../../formats/texture.h"

/* libFuzzer's entry point: one input, always 0. */
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int
LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	static const float uv[][2] = {{0.5f, 0.5f}, {-0.3f, 1.7f},
	    {1e9f, -1e9f}, {0.0f, 1.0f}};
	static int fd = -1;
	static char path[64];
	struct pm_texture t;
	struct pm_error err;
	size_t i;
	int m;

	if (fd < 0) {
		if ((fd = memfd_create("fuzz.bitmap", 0)) < 0)
			abort();
		snprintf(path, sizeof(path), "/proc/self/fd/%d", fd);
	}
	if (ftruncate(fd, 0) != 0 || pwrite(fd, data, size, 0) != (ssize_t)size)
		abort();
	pm_texture_init(&t, PM_TEXTURE_BITMAP);
	if (pm_bitmap_read(path, size > 0 && (data[size - 1] & 1), &t, &err)
	    != PM_OK)
		return 0;
	for (m = 0; m < 6; m++) {
		t.nearest = m & 1;
		t.wrap = (enum pm_wrap)(m / 2);
		for (i = 0; i < sizeof(uv) / sizeof(uv[0]); i++)
			(void)pm_texture_eval(&t, uv[i][0], uv[i][1]);
	}
	pm_texture_free(&t);
	return 0;
}
