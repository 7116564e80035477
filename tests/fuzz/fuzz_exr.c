/*
 * fuzz_exr.c: libFuzzer target for the OpenEXR reader that pm-downsample
 * uses, with the channels beside R, G and B as it reads them for OpenEXR
 * output.  OpenEXR opens files by name, so each input goes into a memory
 * file (memfd) read back through /proc/self/fd: no disk traffic.
 */
#define _GNU_SOURCE
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <sys/mman.h>
#include <unistd.h>

#include "../../common/image.h"
#include "../../formats/exr.h"

/* libFuzzer's entry point: one input, always 0. */
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int
LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	static int fd = -1;
	static char path[64];
	struct pm_image im;
	struct pm_exr_layers ly = { NULL, 0 };
	struct pm_error err;

	if (fd < 0) {
		if ((fd = memfd_create("fuzz.exr", 0)) < 0)
			abort();
		snprintf(path, sizeof(path), "/proc/self/fd/%d", fd);
	}
	if (ftruncate(fd, 0) != 0 || pwrite(fd, data, size, 0) != (ssize_t)size)
		abort();
	if (pm_exr_read_layers(path, &im, NULL, &ly, &err) == PM_OK) {
		pm_image_free(&im);
		pm_exr_layers_free(&ly);
	}
	return 0;
}
