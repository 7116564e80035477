/*
 * bsdfeval.c: pm's BSDF values and densities for bsdf_eval.py, which asks
 * Mitsuba 3 the same questions.
 *
 *   bsdfeval SCENE.xml < DIRECTIONS
 *
 * loads SCENE.xml (formats/scene_xml) and, for each line
 * "wi.x wi.y wi.z wo.x wo.y wo.z" (local shading frame), prints
 * "r g b pdf": eval (f |cos theta_o|, radiance) and pdf of the first
 * shape's BSDF.
 */
#include <stdio.h>

#include "../../formats/scene_xml.h"

int
main(int argc, char **argv)
{
	struct pm_scene s;
	struct pm_error err;
	const struct pm_bsdf *b;
	struct pm_vec3 wi, wo;

	if (argc != 2) {
		fprintf(stderr, "usage: bsdfeval SCENE.xml < DIRECTIONS\n");
		return 2;
	}
	if (pm_scene_load(argv[1], NULL, 0, &s, &err) != PM_OK) {
		fprintf(stderr, "bsdfeval: %s\n", err.msg);
		return 1;
	}
	if (s.nshapes == 0) {
		fprintf(stderr, "bsdfeval: %s: no shape\n", argv[1]);
		return 1;
	}
	b = &s.bsdfs[s.shapes[0].bsdf];
	while (scanf("%f %f %f %f %f %f", &wi.x, &wi.y, &wi.z, &wo.x, &wo.y,
	    &wo.z) == 6) {
		struct pm_rgb f = pm_bsdf_eval(b, wi, wo, PM_RADIANCE);

		printf("%.9g %.9g %.9g %.9g\n", f.r, f.g, f.b,
		    pm_bsdf_pdf(b, wi, wo));
	}
	pm_scene_free(&s);
	return 0;
}
