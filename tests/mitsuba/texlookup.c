/*
 * texlookup.c: pm's bitmap texture lookups for texture_lookup.py, which
 * asks Mitsuba 3 the same questions.
 *
 *   texlookup FILE bilinear|nearest repeat|mirror|clamp raw|srgb < UV
 *
 * reads "u v" lines and prints "r g b" for each: FILE read as a bitmap
 * texture (formats/texture.c) and looked up there (common/texture.c).
 */
#include <stdio.h>
#include <string.h>

#include "../../formats/texture.h"

int
main(int argc, char **argv)
{
	struct pm_texture t;
	struct pm_error err;
	float u, v;

	if (argc != 5) {
		fprintf(stderr, "usage: texlookup FILE bilinear|nearest "
		    "repeat|mirror|clamp raw|srgb < UV\n");
		return 2;
	}
	pm_texture_init(&t, PM_TEXTURE_BITMAP);
	if (pm_bitmap_read(argv[1], strcmp(argv[4], "raw") == 0, &t, &err)
	    != PM_OK) {
		fprintf(stderr, "texlookup: %s\n", err.msg);
		return 1;
	}
	t.nearest = strcmp(argv[2], "nearest") == 0;
	t.wrap = strcmp(argv[3], "mirror") == 0 ? PM_WRAP_MIRROR :
	    strcmp(argv[3], "clamp") == 0 ? PM_WRAP_CLAMP : PM_WRAP_REPEAT;
	while (scanf("%f %f", &u, &v) == 2) {
		struct pm_rgb c = pm_texture_eval(&t, u, v);

		printf("%.9g %.9g %.9g\n", c.r, c.g, c.b);
	}
	pm_texture_free(&t);
	return ferror(stdout) || fclose(stdout) != 0;
}
