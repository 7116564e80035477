/*
 * test_scene_xml.c: the Mitsuba scene loader.  Every supported element
 * parses into the values Mitsuba would give it, defaults included; every
 * kind of bad input fails with a message naming the right file and line;
 * transforms compose in Mitsuba's order; and Mitsuba's own Cornell box
 * loads unchanged when the shared scenes are present.
 */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "../../common/scene.h"
#include "../../common/spectrum.h"
#include "../../formats/exr.h"
#include "../../formats/scene_xml.h"
#include "tmpdir.h"

#define NEAR(a, b, tol) assert_true(fabs((double)(a) - (double)(b)) <= (tol))
#define PI 3.14159265358979323846

/* Writes text to pm_test_dir/name. */
static void
put_file(const char *name, const char *text)
{
	char path[256];
	FILE *f;

	snprintf(path, sizeof(path), "%s/%s", pm_test_dir, name);
	f = fopen(path, "w");
	assert_non_null(f);
	fputs(text, f);
	assert_int_equal(fclose(f), 0);
}

/* Loads xml as "t.xml" with pm_test_dir as its directory. */
static enum pm_err
load_defs(const char *xml, const struct pm_define *defs, size_t ndefs,
    struct pm_scene *s, struct pm_error *err)
{
	memset(err, 0, sizeof(*err));
	return pm_scene_load_string(xml, strlen(xml), "t.xml", pm_test_dir, defs,
	    ndefs, s, err);
}

static void
load_ok(const char *xml, struct pm_scene *s)
{
	struct pm_error err;
	enum pm_err e = load_defs(xml, NULL, 0, s, &err);

	if (e != PM_OK)
		print_error("unexpected failure: %s\n", err.msg);
	assert_int_equal(e, PM_OK);
}

/* Expects a failure whose message starts "t.xml:LINE:" and contains what. */
static void
load_fails(const char *xml, int line, const char *what)
{
	struct pm_scene s;
	struct pm_error err;
	char prefix[32];
	enum pm_err e = load_defs(xml, NULL, 0, &s, &err);

	if (e == PM_OK) {
		print_error("loaded, expected \"%s\" at line %d\n", what, line);
		pm_scene_free(&s);
		fail();
	}
	snprintf(prefix, sizeof(prefix), "t.xml:%d: ", line);
	if (strncmp(err.msg, prefix, strlen(prefix)) != 0 ||
	    strstr(err.msg, what) == NULL) {
		print_error("got \"%s\", expected \"%s...%s\"\n", err.msg,
		    prefix, what);
		fail();
	}
	/* A failed load leaves an empty scene. */
	assert_int_equal(s.nshapes, 0);
	assert_null(s.shapes);
	pm_scene_free(&s);
}

static const struct pm_bsdf *
shape_bsdf(const struct pm_scene *s, size_t i)
{
	assert_true(i < s->nshapes);
	assert_true(s->shapes[i].bsdf >= 0 &&
	    (size_t)s->shapes[i].bsdf < s->nbsdfs);
	return &s->bsdfs[s->shapes[i].bsdf];
}

static void
assert_rgb(struct pm_rgb c, double r, double g, double b)
{
	NEAR(c.r, r, 1e-6);
	NEAR(c.g, g, 1e-6);
	NEAR(c.b, b, 1e-6);
}

/* ------------------------------------------------------------ defaults */

static void
test_empty_scene_defaults(void **state)
{
	struct pm_scene s;

	(void)state;
	load_ok("<scene version=\"3.0.0\"/>", &s);
	assert_int_equal(s.nshapes, 0);
	assert_int_equal(s.nlights, 0);
	assert_false(s.has_camera);
	assert_int_equal(s.env_light, -1);
	assert_int_equal(s.integrator.type, PM_INTEGRATOR_PATH);
	assert_int_equal(s.integrator.max_depth, -1);
	assert_int_equal(s.integrator.rr_depth, 5);
	assert_false(s.integrator.hide_emitters);
	assert_string_equal(s.path, "t.xml");
	pm_scene_free(&s);

	/* Version 2.x is accepted as well. */
	load_ok("<scene version=\"2.1.0\"></scene>", &s);
	pm_scene_free(&s);
}

/* ------------------------------------------------------------ bsdfs */

static void
test_bsdfs(void **state)
{
	struct pm_scene s;
	const struct pm_bsdf *b;
	struct pm_rgb eta, k;
	float water;

	(void)state;
	load_ok("<scene version=\"3.0.0\">\n"
	    " <shape type=\"rectangle\"><bsdf type=\"diffuse\">"
	    "  <rgb name=\"reflectance\" value=\"0.1, 0.2, 0.3\"/></bsdf></shape>\n"
	    " <shape type=\"rectangle\"/>\n"
	    " <shape type=\"rectangle\"><bsdf type=\"conductor\">"
	    "  <string name=\"material\" value=\"Au\"/></bsdf></shape>\n"
	    " <shape type=\"rectangle\"><bsdf type=\"conductor\">"
	    "  <rgb name=\"eta\" value=\"0.2 0.3 0.4\"/>"
	    "  <rgb name=\"k\" value=\"3\"/>"
	    "  <spectrum name=\"specular_reflectance\" value=\"0.9\"/>"
	    " </bsdf></shape>\n"
	    " <shape type=\"rectangle\"><bsdf type=\"roughconductor\">"
	    "  <string name=\"distribution\" value=\"ggx\"/>"
	    "  <float name=\"alpha\" value=\"0.3\"/>"
	    "  <boolean name=\"sample_visible\" value=\"false\"/>"
	    " </bsdf></shape>\n"
	    " <shape type=\"rectangle\"><bsdf type=\"dielectric\"/></shape>\n"
	    " <shape type=\"rectangle\"><bsdf type=\"dielectric\">"
	    "  <string name=\"int_ior\" value=\"water\"/>"
	    "  <float name=\"ext_ior\" value=\"1\"/>"
	    "  <rgb name=\"specular_transmittance\" value=\"0.5, 0.6, 0.7\"/>"
	    " </bsdf></shape>\n"
	    " <shape type=\"rectangle\"><bsdf type=\"thindielectric\">"
	    "  <float name=\"int_ior\" value=\"1.5\"/>"
	    "  <float name=\"ext_ior\" value=\"1.25\"/>"
	    " </bsdf></shape>\n"
	    " <shape type=\"rectangle\"><bsdf type=\"plastic\"/></shape>\n"
	    " <shape type=\"rectangle\"><bsdf type=\"plastic\">"
	    "  <rgb name=\"diffuse_reflectance\" value=\"0.2, 0.4, 0.6\"/>"
	    "  <boolean name=\"nonlinear\" value=\"true\"/>"
	    "  <float name=\"int_ior\" value=\"1.6\"/>"
	    " </bsdf></shape>\n"
	    " <shape type=\"rectangle\"><bsdf type=\"twosided\">"
	    "  <bsdf type=\"diffuse\"><float name=\"reflectance\" value=\"0.7\"/>"
	    "  </bsdf></bsdf></shape>\n"
	    " <shape type=\"rectangle\"><bsdf type=\"null\"/></shape>\n"
	    "</scene>\n", &s);
	assert_int_equal(s.nshapes, 12);

	b = shape_bsdf(&s, 0);
	assert_int_equal(b->type, PM_BSDF_DIFFUSE);
	assert_rgb(b->diffuse, 0.1, 0.2, 0.3);
	assert_false(b->twosided);
	/* pm_bsdf_prepare has run. */
	assert_true(b->lobes & PM_LOBE_DIFFUSE);

	b = shape_bsdf(&s, 1);		/* Mitsuba's default BSDF */
	assert_int_equal(b->type, PM_BSDF_DIFFUSE);
	assert_rgb(b->diffuse, 0.5, 0.5, 0.5);

	b = shape_bsdf(&s, 2);
	assert_int_equal(b->type, PM_BSDF_CONDUCTOR);
	assert_true(pm_conductor_lookup("Au", &eta, &k));
	assert_rgb(b->eta, eta.r, eta.g, eta.b);
	assert_rgb(b->k, k.r, k.g, k.b);
	assert_rgb(b->specular, 1, 1, 1);

	b = shape_bsdf(&s, 3);
	assert_rgb(b->eta, 0.2, 0.3, 0.4);
	assert_rgb(b->k, 3, 3, 3);
	assert_rgb(b->specular, 0.9, 0.9, 0.9);

	b = shape_bsdf(&s, 4);
	assert_int_equal(b->type, PM_BSDF_ROUGHCONDUCTOR);
	NEAR(b->alpha, 0.3, 1e-7);
	assert_false(b->sample_visible);
	assert_true(pm_conductor_lookup("none", &eta, &k));
	assert_rgb(b->eta, eta.r, eta.g, eta.b);
	assert_rgb(b->k, k.r, k.g, k.b);

	b = shape_bsdf(&s, 5);		/* bk7 inside air */
	assert_int_equal(b->type, PM_BSDF_DIELECTRIC);
	NEAR(b->ior, 1.5046 / 1.000277, 1e-6);
	assert_rgb(b->specular, 1, 1, 1);
	assert_rgb(b->transmittance, 1, 1, 1);

	b = shape_bsdf(&s, 6);
	assert_true(pm_ior_lookup("water", &water));
	NEAR(b->ior, water, 1e-6);
	assert_rgb(b->transmittance, 0.5, 0.6, 0.7);

	b = shape_bsdf(&s, 7);
	assert_int_equal(b->type, PM_BSDF_THINDIELECTRIC);
	NEAR(b->ior, 1.2, 1e-6);

	b = shape_bsdf(&s, 8);		/* polypropylene inside air */
	assert_int_equal(b->type, PM_BSDF_PLASTIC);
	assert_rgb(b->diffuse, 0.5, 0.5, 0.5);
	assert_rgb(b->specular, 1, 1, 1);
	NEAR(b->ior, 1.49 / 1.000277, 1e-6);
	assert_false(b->nonlinear);

	b = shape_bsdf(&s, 9);
	assert_rgb(b->diffuse, 0.2, 0.4, 0.6);
	assert_true(b->nonlinear);
	NEAR(b->ior, 1.6 / 1.000277, 1e-6);

	b = shape_bsdf(&s, 10);
	assert_int_equal(b->type, PM_BSDF_DIFFUSE);
	assert_true(b->twosided);
	assert_rgb(b->diffuse, 0.7, 0.7, 0.7);

	b = shape_bsdf(&s, 11);
	assert_int_equal(b->type, PM_BSDF_NULL);
	pm_scene_free(&s);
}

/* BSDFs made of others: blendbsdf, mask, twosided with two sides; their
 * nested BSDFs are scene BSDFs below them, shared when referenced; and a
 * named conductor of Mitsuba's longer table. */
static void
test_composite_bsdfs(void **state)
{
	struct pm_scene s;
	const struct pm_bsdf *b, *c;
	struct pm_rgb eta, k;

	(void)state;
	load_ok("<scene version=\"3.0.0\">\n"
	    " <bsdf type=\"diffuse\" id=\"red\">"
	    "  <rgb name=\"reflectance\" value=\"0.6, 0.1, 0.1\"/></bsdf>\n"
	    " <shape type=\"rectangle\"><bsdf type=\"blendbsdf\">"
	    "  <float name=\"weight\" value=\"0.25\"/><ref id=\"red\"/>"
	    "  <bsdf type=\"conductor\"><string name=\"material\" "
	    "value=\"a-C\"/></bsdf></bsdf></shape>\n"
	    " <shape type=\"rectangle\"><bsdf type=\"mask\">"
	    "  <ref id=\"red\"/></bsdf></shape>\n"
	    " <shape type=\"rectangle\"><bsdf type=\"mask\">"
	    "  <texture name=\"opacity\" type=\"checkerboard\"/>"
	    "  <bsdf type=\"diffuse\"/></bsdf></shape>\n"
	    " <shape type=\"rectangle\"><bsdf type=\"twosided\">"
	    "  <ref id=\"red\"/><bsdf type=\"roughconductor\"/></bsdf>"
	    " </shape>\n"
	    "</scene>\n", &s);
	b = shape_bsdf(&s, 0);
	assert_int_equal(b->type, PM_BSDF_BLEND);
	NEAR(b->weight, 0.25, 1e-6);
	assert_true(b->nested[0] < s.shapes[0].bsdf &&
	    b->nested[1] < s.shapes[0].bsdf);
	c = &s.bsdfs[b->nested[0]];
	assert_int_equal(c->type, PM_BSDF_DIFFUSE);
	assert_rgb(c->diffuse, 0.6, 0.1, 0.1);
	c = &s.bsdfs[b->nested[1]];
	assert_int_equal(c->type, PM_BSDF_CONDUCTOR);
	assert_true(pm_conductor_lookup("a-C", &eta, &k));
	assert_rgb(c->eta, eta.r, eta.g, eta.b);
	assert_rgb(c->k, k.r, k.g, k.b);
	/* the referenced BSDF is one scene BSDF, however often nested */
	b = shape_bsdf(&s, 1);
	assert_int_equal(b->type, PM_BSDF_MASK);
	NEAR(b->weight, 0.5, 1e-6);
	assert_int_equal(b->nested[0], shape_bsdf(&s, 0)->nested[0]);
	b = shape_bsdf(&s, 2);
	assert_int_equal(b->type, PM_BSDF_MASK);
	assert_true(b->tex_weight > 0);
	b = shape_bsdf(&s, 3);
	assert_int_equal(b->type, PM_BSDF_TWOSIDED);
	assert_int_equal(s.bsdfs[b->nested[0]].type, PM_BSDF_DIFFUSE);
	assert_int_equal(s.bsdfs[b->nested[1]].type, PM_BSDF_ROUGHCONDUCTOR);
	pm_scene_free(&s);

	load_fails("<scene version=\"3.0.0\">\n"
	    "<shape type=\"rectangle\">\n<bsdf type=\"blendbsdf\">"
	    "<bsdf type=\"diffuse\"/><bsdf type=\"diffuse\"/></bsdf>"
	    "</shape></scene>", 3, "missing required parameter \"weight\"");
	load_fails("<scene version=\"3.0.0\">\n"
	    "<shape type=\"rectangle\"><bsdf type=\"blendbsdf\">"
	    "<float name=\"weight\" value=\"0.5\"/><bsdf type=\"diffuse\"/>"
	    "\n<bsdf type=\"diffuse\"/><bsdf type=\"diffuse\"/></bsdf>"
	    "</shape></scene>", 3, "needs two nested");
	load_fails("<scene version=\"3.0.0\">\n"
	    "<shape type=\"rectangle\">\n<bsdf type=\"mask\">"
	    "</bsdf></shape></scene>", 3, "needs one nested");
	load_fails("<scene version=\"3.0.0\">\n"
	    "<shape type=\"rectangle\"><bsdf type=\"twosided\">"
	    "<bsdf type=\"diffuse\"/>\n<bsdf type=\"dielectric\"/></bsdf>"
	    "</shape></scene>", 3, "let no light through");
	load_fails("<scene version=\"3.0.0\">\n"
	    "<shape type=\"rectangle\"><bsdf type=\"twosided\">"
	    "<bsdf type=\"diffuse\"/><bsdf type=\"diffuse\"/>\n"
	    "<bsdf type=\"diffuse\"/></bsdf></shape></scene>", 3,
	    "takes one or two");
	load_fails("<scene version=\"3.0.0\">\n"
	    "<bsdf type=\"blendbsdf\" id=\"loop\">\n"
	    "<float name=\"weight\" value=\"0.5\"/><ref id=\"loop\"/>"
	    "<bsdf type=\"diffuse\"/></bsdf><shape type=\"rectangle\">"
	    "<ref id=\"loop\"/></shape></scene>", 3, "refers to");
}

/* roughdielectric and roughplastic: Mitsuba's defaults (Beckmann, alpha
 * 0.1, visible normals, bk7 glass, polypropylene plastic) and each
 * parameter read. */
static void
test_rough_bsdfs(void **state)
{
	struct pm_scene s;
	const struct pm_bsdf *b;
	float water;

	(void)state;
	load_ok("<scene version=\"3.0.0\">\n"
	    " <shape type=\"rectangle\"><bsdf type=\"roughdielectric\"/>"
	    "</shape>\n"
	    " <shape type=\"rectangle\"><bsdf type=\"roughdielectric\">"
	    "  <string name=\"distribution\" value=\"ggx\"/>"
	    "  <float name=\"alpha_u\" value=\"0.3\"/>"
	    "  <float name=\"alpha_v\" value=\"0.3\"/>"
	    "  <boolean name=\"sample_visible\" value=\"false\"/>"
	    "  <string name=\"int_ior\" value=\"water\"/>"
	    "  <float name=\"ext_ior\" value=\"1\"/>"
	    "  <rgb name=\"specular_reflectance\" value=\"0.9\"/>"
	    "  <rgb name=\"specular_transmittance\" value=\"0.5, 0.6, 0.7\"/>"
	    " </bsdf></shape>\n"
	    " <shape type=\"rectangle\"><bsdf type=\"roughplastic\"/>"
	    "</shape>\n"
	    " <shape type=\"rectangle\"><bsdf type=\"roughplastic\">"
	    "  <string name=\"distribution\" value=\"ggx\"/>"
	    "  <float name=\"alpha\" value=\"0.25\"/>"
	    "  <rgb name=\"diffuse_reflectance\" value=\"0.2, 0.4, 0.6\"/>"
	    "  <float name=\"int_ior\" value=\"1.6\"/>"
	    "  <boolean name=\"nonlinear\" value=\"true\"/>"
	    " </bsdf></shape>\n"
	    "</scene>\n", &s);
	assert_int_equal(s.nshapes, 4);

	b = shape_bsdf(&s, 0);
	assert_int_equal(b->type, PM_BSDF_ROUGHDIELECTRIC);
	assert_true(b->beckmann && b->sample_visible);
	NEAR(b->alpha, 0.1, 1e-7);
	NEAR(b->ior, 1.5046 / 1.000277, 1e-6);
	assert_rgb(b->specular, 1, 1, 1);
	assert_rgb(b->transmittance, 1, 1, 1);
	assert_int_equal(b->lobes, PM_LOBE_GLOSSY | PM_LOBE_GLOSSY_TRANSMISSION);

	b = shape_bsdf(&s, 1);
	assert_false(b->beckmann || b->sample_visible);
	NEAR(b->alpha, 0.3, 1e-7);
	assert_true(pm_ior_lookup("water", &water));
	NEAR(b->ior, water, 1e-6);
	assert_rgb(b->specular, 0.9, 0.9, 0.9);
	assert_rgb(b->transmittance, 0.5, 0.6, 0.7);

	b = shape_bsdf(&s, 2);
	assert_int_equal(b->type, PM_BSDF_ROUGHPLASTIC);
	assert_true(b->beckmann && b->sample_visible);
	NEAR(b->alpha, 0.1, 1e-7);
	NEAR(b->ior, 1.49 / 1.000277, 1e-6);
	assert_rgb(b->diffuse, 0.5, 0.5, 0.5);
	assert_rgb(b->specular, 1, 1, 1);
	assert_false(b->nonlinear);
	/* pm_bsdf_prepare has filled the coating's tables */
	assert_true(b->rough_t[63] > 0.9f && b->rough_t[63] < 1.0f);
	assert_true(b->fdr_int > 0.3f && b->fdr_int < 0.7f);

	b = shape_bsdf(&s, 3);
	assert_false(b->beckmann);
	NEAR(b->alpha, 0.25, 1e-7);
	assert_rgb(b->diffuse, 0.2, 0.4, 0.6);
	NEAR(b->ior, 1.6 / 1.000277, 1e-6);
	assert_true(b->nonlinear);
	pm_scene_free(&s);

	load_fails("<scene version=\"3.0.0\"><shape type=\"rectangle\">\n"
	    "<bsdf type=\"roughplastic\"><float name=\"alpha_u\" "
	    "value=\"0.1\"/><float name=\"alpha_v\" value=\"0.3\"/></bsdf>"
	    "</shape></scene>", 2, "anisotropic");
	load_fails("<scene version=\"3.0.0\"><shape type=\"rectangle\">\n"
	    "<bsdf type=\"roughplastic\">\n<string name=\"distribution\" "
	    "value=\"phong\"/></bsdf></shape></scene>", 3,
	    "distribution \"phong\" is not supported");
	load_fails("<scene version=\"3.0.0\"><shape type=\"rectangle\">\n"
	    "<bsdf type=\"roughplastic\">\n<float name=\"alpha\" "
	    "value=\"0.1\"/><float name=\"alpha_u\" value=\"0.1\"/>"
	    "<float name=\"alpha_v\" value=\"0.1\"/></bsdf></shape></scene>",
	    3, "give either alpha or alpha_u and alpha_v");
}

/* ------------------------------------------------------------ shapes */

static void
test_shapes(void **state)
{
	struct pm_scene s;
	const struct pm_shape *sh;

	(void)state;
	load_ok("<scene version=\"3.0.0\">\n"
	    " <shape type=\"sphere\">\n"
	    "  <point name=\"center\" x=\"1\" y=\"2\" z=\"3\"/>\n"
	    "  <float name=\"radius\" value=\"2\"/>\n"
	    "  <transform name=\"to_world\"><scale value=\"3\"/>"
	    "   <rotate y=\"1\" angle=\"90\"/><translate x=\"1\"/></transform>\n"
	    "  <boolean name=\"flip_normals\" value=\"true\"/>\n"
	    " </shape>\n"
	    " <shape type=\"rectangle\">\n"
	    "  <transform name=\"to_world\"><scale value=\"2\"/></transform>\n"
	    "  <emitter type=\"area\"><rgb name=\"radiance\" value=\"1\"/></emitter>\n"
	    " </shape>\n"
	    " <shape type=\"cube\">\n"
	    "  <emitter type=\"area\"><rgb name=\"radiance\" value=\"1, 2, 3\"/></emitter>\n"
	    " </shape>\n"
	    " <shape type=\"disk\">\n"
	    "  <emitter type=\"area\"><rgb name=\"radiance\" value=\"1\"/></emitter>\n"
	    " </shape>\n"
	    " <shape type=\"rectangle\" id=\"down\">\n"
	    "  <boolean name=\"flip_normals\" value=\"true\"/>\n"
	    " </shape>\n"
	    " <shape type=\"sphere\">\n"
	    "  <emitter type=\"area\"><rgb name=\"radiance\" value=\"2\"/></emitter>\n"
	    " </shape>\n"
	    "</scene>\n", &s);
	assert_int_equal(s.nshapes, 6);
	assert_int_equal(s.nlights, 4);

	/* Sphere: the world centre is to_world applied to the centre; rotate
	 * (1,2,3) by 90 degrees about y: (3,2,-1); scaled first by 3. */
	sh = &s.shapes[0];
	assert_int_equal(sh->type, PM_SHAPE_SPHERE);
	NEAR(sh->center.x, 3 * 3 + 1, 1e-4);
	NEAR(sh->center.y, 3 * 2, 1e-4);
	NEAR(sh->center.z, 3 * -1, 1e-4);
	NEAR(sh->radius, 6, 1e-5);
	assert_true(sh->flip_normals);
	assert_int_equal(sh->light, -1);
	assert_string_equal(sh->name, "sphere#0");

	/* Rectangle [-2,2]^2: area 16, power pi A L. */
	sh = &s.shapes[1];
	assert_int_equal(sh->type, PM_SHAPE_MESH);
	assert_int_equal(sh->light, 0);
	assert_int_equal(s.lights[0].type, PM_LIGHT_AREA);
	assert_int_equal(s.lights[0].shape, 1);
	NEAR(s.lights[0].area, 16, 1e-4);
	NEAR(s.lights[0].power, PI * 16, 1e-3);
	assert_non_null(sh->mesh.nrm);
	NEAR(sh->mesh.nrm[2], 1, 1e-6);

	/* Cube [-1,1]^3: area 24; power uses the mean radiance, 2. */
	NEAR(s.lights[1].area, 24, 1e-4);
	NEAR(s.lights[1].power, PI * 24 * 2, 1e-3);
	assert_rgb(s.lights[1].radiance, 1, 2, 3);

	/* Disk: the tessellation keeps the area of the unit disk. */
	NEAR(s.lights[2].area, PI, 1e-4);

	/* flip_normals on a mesh: normals point down. */
	sh = &s.shapes[4];
	assert_string_equal(sh->name, "down");
	assert_non_null(sh->mesh.nrm);
	NEAR(sh->mesh.nrm[2], -1, 1e-6);

	/* Unit sphere light: area 4 pi. */
	NEAR(s.lights[3].area, 4 * PI, 1e-4);
	NEAR(s.lights[3].power, PI * 4 * PI * 2, 1e-3);
	pm_scene_free(&s);
}

static void
test_meshes(void **state)
{
	struct pm_scene s;
	const struct pm_mesh *m;
	uint32_t i;

	(void)state;
	put_file("quad.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n");
	put_file("quadn.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nvn 0 0 -1\n"
	    "f 1//1 2//1 3//1\n");
	put_file("degen.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 2 0 0\n"
	    "f 1 2 3\nf 1 2 4\n");
	put_file("tri.ply", "ply\nformat ascii 1.0\nelement vertex 3\n"
	    "property float x\nproperty float y\nproperty float z\n"
	    "element face 1\nproperty list uchar int vertex_indices\n"
	    "end_header\n0 0 0\n0 1 0\n0 0 1\n3 0 1 2\n");
	load_ok("<scene version=\"3.0.0\">\n"
	    " <shape type=\"obj\"><string name=\"filename\" value=\"quad.obj\"/>\n"
	    "  <transform name=\"to_world\"><translate x=\"5\"/></transform>\n"
	    " </shape>\n"
	    " <shape type=\"obj\"><string name=\"filename\" value=\"quad.obj\"/>\n"
	    "  <boolean name=\"face_normals\" value=\"true\"/>\n"
	    " </shape>\n"
	    " <shape type=\"obj\"><string name=\"filename\" value=\"quadn.obj\"/>\n"
	    " </shape>\n"
	    " <shape type=\"obj\"><string name=\"filename\" value=\"degen.obj\"/>\n"
	    " </shape>\n"
	    " <shape type=\"ply\"><string name=\"filename\" value=\"tri.ply\"/>\n"
	    "  <boolean name=\"flip_normals\" value=\"true\"/>\n"
	    " </shape>\n"
	    "</scene>\n", &s);
	assert_int_equal(s.nshapes, 5);

	/* No normals in the file: smooth ones are computed (+z), and the
	 * positions are in world space. */
	m = &s.shapes[0].mesh;
	assert_int_equal(m->ntris, 2);
	assert_non_null(m->nrm);
	for (i = 0; i < m->nverts; i++) {
		NEAR(m->nrm[3 * i + 2], 1, 1e-6);
		assert_true(m->pos[3 * i] >= 5 - 1e-6 &&
		    m->pos[3 * i] <= 6 + 1e-6);
	}
	/* face_normals drops them. */
	assert_null(s.shapes[1].mesh.nrm);
	/* Normals from the file are kept, even against the winding. */
	m = &s.shapes[2].mesh;
	assert_non_null(m->nrm);
	NEAR(m->nrm[2], -1, 1e-6);
	/* The degenerate triangle is dropped and counted. */
	assert_int_equal(s.shapes[3].mesh.ntris, 1);
	assert_int_equal(s.dropped_triangles, 1);
	/* PLY triangle in the x = 0 plane, winding gives +x; flipped: -x. */
	m = &s.shapes[4].mesh;
	assert_int_equal(m->ntris, 1);
	assert_non_null(m->nrm);
	NEAR(m->nrm[0], -1, 1e-6);
	pm_scene_free(&s);
}

/* ------------------------------------------------------------ emitters */

static void
test_emitters(void **state)
{
	struct pm_scene s;
	const struct pm_light *l;
	double theta;

	(void)state;
	load_ok("<scene version=\"3.0.0\">\n"
	    " <emitter type=\"point\">\n"
	    "  <rgb name=\"intensity\" value=\"1, 2, 3\"/>\n"
	    "  <point name=\"position\" value=\"1, 2, 3\"/>\n"
	    " </emitter>\n"
	    " <emitter type=\"point\">\n"
	    "  <transform name=\"to_world\"><translate value=\"4 5 6\"/></transform>\n"
	    " </emitter>\n"
	    " <emitter type=\"spot\">\n"
	    "  <spectrum name=\"intensity\" value=\"10\"/>\n"
	    "  <float name=\"cutoff_angle\" value=\"30\"/>\n"
	    "  <transform name=\"to_world\">\n"
	    "   <lookat origin=\"0, 2, 0\" target=\"0, 0, 0\" up=\"0, 0, 1\"/>\n"
	    "  </transform>\n"
	    " </emitter>\n"
	    " <emitter type=\"constant\"><rgb name=\"radiance\" value=\"2\"/></emitter>\n"
	    " <shape type=\"sphere\"/>\n"
	    "</scene>\n", &s);
	assert_int_equal(s.nlights, 4);

	l = &s.lights[0];
	assert_int_equal(l->type, PM_LIGHT_POINT);
	assert_rgb(l->intensity, 1, 2, 3);
	NEAR(l->position.x, 1, 1e-6);
	NEAR(l->position.z, 3, 1e-6);
	NEAR(l->power, 4 * PI * 2, 1e-4);

	l = &s.lights[1];		/* Mitsuba's default intensity is 1 */
	assert_rgb(l->intensity, 1, 1, 1);
	NEAR(l->position.x, 4, 1e-6);
	NEAR(l->position.y, 5, 1e-6);
	NEAR(l->position.z, 6, 1e-6);

	l = &s.lights[2];
	assert_int_equal(l->type, PM_LIGHT_SPOT);
	NEAR(l->cutoff_angle, 30, 1e-6);
	NEAR(l->beam_width, 22.5, 1e-6);	/* 3/4 of the cutoff */
	NEAR(l->position.y, 2, 1e-6);
	NEAR(l->frame.n.x, 0, 1e-6);
	NEAR(l->frame.n.y, -1, 1e-6);
	NEAR(l->frame.n.z, 0, 1e-6);
	theta = (30 + 22.5) / 2 * PI / 180;
	/* A uniform spectrum in an emitter is, as in Mitsuba's RGB
	 * variants, that value times the sRGB of XYZ = (1, 1, 1), whose
	 * mean is the sum of the sRGB matrix's entries over 3. */
	NEAR(l->power, 2 * PI * (1 - cos(theta)) * 10 * (3.240479 - 1.537150 -
	    0.498535 - 0.969256 + 1.875991 + 0.041556 + 0.055648 - 0.204043 +
	    1.057311) / 3, 1e-4);

	/* Constant: the scene's bounding sphere around the unit sphere's box
	 * has radius sqrt(3). */
	l = &s.lights[3];
	assert_int_equal(l->type, PM_LIGHT_CONSTANT);
	assert_int_equal(s.env_light, 3);
	NEAR(l->power, PI * 2 * 4 * PI * 3, 1e-3);
	pm_scene_free(&s);
}

/* ------------------------------------------------------------ spectra */

/*
 * Spectra as Mitsuba 3's RGB variants read them: a uniform value is a
 * grey, but in an emitter that value times the sRGB of a flat spectrum; a
 * list is integrated against the CIE curves (weighted by D65 unless in an
 * emitter); a file holds the same list; a blackbody is Planck's law.
 */
static void
test_spectra(void **state)
{
	static const double wl[4] = {400, 500, 600, 700};
	static const double v[4] = {0.1, 0.9, 0.2, 0.5};
	static const double one[3] = {1, 1, 1};
	struct pm_scene s;
	struct pm_rgb c, flat = pm_xyz_to_srgb(one);

	(void)state;
	put_file("s.spd", "# a comment\n400 0.1\n500 0.9\n\n600 0.2\n"
	    "700 0.5\n");
	load_ok("<scene version=\"3.0.0\">\n"
	    " <shape type=\"sphere\"><bsdf type=\"diffuse\">\n"
	    "  <spectrum name=\"reflectance\" value=\"0.25\"/>\n"
	    " </bsdf></shape>\n"
	    " <shape type=\"sphere\"><bsdf type=\"diffuse\">\n"
	    "  <spectrum name=\"reflectance\" value=\"400:0.1, 500:0.9,"
	    " 600:0.2, 700:0.5\"/>\n"
	    " </bsdf></shape>\n"
	    " <shape type=\"sphere\"><bsdf type=\"diffuse\">\n"
	    "  <spectrum name=\"reflectance\" filename=\"s.spd\"/>\n"
	    " </bsdf></shape>\n"
	    " <shape type=\"sphere\"><bsdf type=\"diffuse\">\n"
	    "  <spectrum name=\"reflectance\" value=\"300:0.5 900:0.5\"/>\n"
	    " </bsdf></shape>\n"
	    " <emitter type=\"point\">\n"
	    "  <spectrum name=\"intensity\" value=\"2\"/>\n"
	    " </emitter>\n"
	    " <emitter type=\"point\">\n"
	    "  <spectrum name=\"intensity\" filename=\"s.spd\"/>\n"
	    " </emitter>\n"
	    " <emitter type=\"point\">\n"
	    "  <spectrum name=\"intensity\" type=\"blackbody\">\n"
	    "   <float name=\"temperature\" value=\"3000\"/>\n"
	    "   <float name=\"wavelength_max\" value=\"700\"/>\n"
	    "  </spectrum>\n"
	    " </emitter>\n"
	    " <emitter type=\"point\">\n"
	    "  <spectrum name=\"intensity\" type=\"uniform\">\n"
	    "   <float name=\"value\" value=\"3\"/>\n"
	    "  </spectrum>\n"
	    " </emitter>\n"
	    " <emitter type=\"point\">\n"
	    "  <spectrum name=\"intensity\" type=\"regular\">\n"
	    "   <float name=\"wavelength_min\" value=\"400\"/>\n"
	    "   <float name=\"wavelength_max\" value=\"700\"/>\n"
	    "   <string name=\"values\" value=\"0.1, 0.9, 0.2, 0.5\"/>\n"
	    "  </spectrum>\n"
	    " </emitter>\n"
	    " <emitter type=\"point\">\n"
	    "  <spectrum name=\"intensity\" type=\"d65\">\n"
	    "   <float name=\"scale\" value=\"2\"/>\n"
	    "  </spectrum>\n"
	    " </emitter>\n"
	    "</scene>\n", &s);
	assert_rgb(shape_bsdf(&s, 0)->diffuse, 0.25, 0.25, 0.25);
	c = pm_spectrum_to_srgb(wl, v, 4, true, true, NULL);
	assert_rgb(shape_bsdf(&s, 1)->diffuse, c.r, c.g, c.b);
	assert_rgb(shape_bsdf(&s, 2)->diffuse, c.r, c.g, c.b);
	/* A flat reflectance stays grey (D65 is sRGB's white). */
	NEAR(shape_bsdf(&s, 3)->diffuse.r, 0.5, 2e-3);
	NEAR(shape_bsdf(&s, 3)->diffuse.g, 0.5, 2e-3);
	NEAR(shape_bsdf(&s, 3)->diffuse.b, 0.5, 2e-3);
	assert_rgb(s.lights[0].intensity, 2 * flat.r, 2 * flat.g, 2 * flat.b);
	c = pm_spectrum_to_srgb(wl, v, 4, false, false, NULL);
	assert_rgb(s.lights[1].intensity, c.r, c.g, c.b);
	c = pm_blackbody_to_srgb(3000, 360, 700);
	NEAR(s.lights[2].intensity.r, c.r, 1e-6 * c.r);
	NEAR(s.lights[2].intensity.b, c.b, 1e-6 * c.r);
	assert_true(c.r > c.g && c.g > c.b);
	assert_rgb(s.lights[3].intensity, 3, 3, 3);
	/* regular: the same list as value="400:0.1, ..., 700:0.5" */
	c = pm_spectrum_to_srgb(wl, v, 4, false, false, NULL);
	assert_rgb(s.lights[4].intensity, c.r, c.g, c.b);
	/* d65 in an RGB renderer: white (its colour), times scale */
	assert_rgb(s.lights[5].intensity, 2, 2, 2);
	pm_scene_free(&s);
}

#define HEAD "<scene version=\"3.0.0\">\n"

/* ------------------------------------------------------------ envmap,
 * directional */

static void
test_envmap_directional(void **state)
{
	static float px[4 * 3 * 3];
	struct pm_image im = {4, 3, px};
	struct pm_error err;
	struct pm_scene s;
	char path[256];
	int i;

	(void)state;
	for (i = 0; i < 4 * 3 * 3; i++)
		px[i] = 0.5f;
	snprintf(path, sizeof(path), "%s/env.exr", pm_test_dir);
	assert_int_equal(pm_exr_write(path, &im, false, &err), PM_OK);
	load_ok("<scene version=\"3.0.0\">\n"
	    " <emitter type=\"directional\">\n"
	    "  <vector name=\"direction\" x=\"0\" y=\"0\" z=\"-2\"/>\n"
	    " </emitter>\n"
	    " <emitter type=\"directional\">\n"
	    "  <rgb name=\"irradiance\" value=\"1, 2, 3\"/>\n"
	    "  <transform name=\"to_world\"><rotate x=\"1\" angle=\"90\"/>"
	    "</transform>\n"
	    " </emitter>\n"
	    " <emitter type=\"envmap\">\n"
	    "  <string name=\"filename\" value=\"env.exr\"/>\n"
	    "  <float name=\"scale\" value=\"4\"/>\n"
	    "  <boolean name=\"mis_compensation\" value=\"true\"/>\n"
	    " </emitter>\n"
	    " <shape type=\"sphere\"/>\n"
	    "</scene>\n", &s);
	assert_int_equal(s.nlights, 3);
	assert_int_equal(s.lights[0].type, PM_LIGHT_DIRECTIONAL);
	assert_rgb(s.lights[0].intensity, 1, 1, 1);	/* Mitsuba's default */
	NEAR(s.lights[0].direction.z, -1, 1e-6);
	assert_rgb(s.lights[1].intensity, 1, 2, 3);
	NEAR(s.lights[1].direction.y, -1, 1e-6);	/* +z turned by 90 about x */
	/* E through the bounding sphere's disk: radius sqrt(3) */
	NEAR(s.lights[1].power, 2 * PI * 3, 1e-4);
	assert_int_equal(s.lights[2].type, PM_LIGHT_ENVMAP);
	assert_int_equal(s.env_light, 2);
	assert_non_null(s.lights[2].env);
	assert_int_equal(s.lights[2].env->width, 4);
	NEAR(pm_envmap_eval(s.lights[2].env, pm_v3(0, 1, 0)).g, 2, 1e-6);
	/* constant radiance 2 over the sphere, through the disk */
	NEAR(s.lights[2].power, PI * 2 * 4 * PI * 3, 1e-2);
	pm_scene_free(&s);

	load_fails(HEAD "<emitter type=\"envmap\">\n"
	    "</emitter></scene>", 2, "missing required parameter \"filename\"");
	put_file("sky.txt", "not an image\n");
	load_fails(HEAD "<emitter type=\"envmap\">\n"
	    "<string name=\"filename\" value=\"sky.txt\"/></emitter></scene>",
	    3, "not a PNG, JPEG");
	load_fails(HEAD "<emitter type=\"envmap\">\n"
	    "<string name=\"filename\" value=\"nope.exr\"/></emitter></scene>",
	    3, "nope.exr");
	load_fails(HEAD "<emitter type=\"envmap\">\n"
	    "<string name=\"filename\" value=\"env.exr\"/>\n"
	    "<transform name=\"to_world\"><scale x=\"2\"/></transform>"
	    "</emitter></scene>", 4, "must be a rotation");
	load_fails(HEAD "<emitter type=\"constant\"/>\n<emitter type=\"envmap\">"
	    "<string name=\"filename\" value=\"env.exr\"/></emitter></scene>",
	    3, "more than one environment emitter");
	load_fails(HEAD "<emitter type=\"directional\">\n"
	    "<vector name=\"direction\" x=\"0\" y=\"0\" z=\"0\"/>"
	    "</emitter></scene>", 3, "the direction is zero");
	load_fails(HEAD "<emitter type=\"directional\">\n"
	    "<vector name=\"direction\" x=\"1\"/><transform name=\"to_world\"/>"
	    "</emitter></scene>", 3, "either direction or to_world");
	load_fails(HEAD "<emitter type=\"directional\">\n"
	    "<point name=\"direction\" x=\"1\"/></emitter></scene>", 3,
	    "must be a <vector>");
}

/* ------------------------------------------------------------ camera */

static void
test_sensor(void **state)
{
	struct pm_scene s;
	const struct pm_camera *c;

	(void)state;
	load_ok("<scene version=\"3.0.0\">\n"
	    " <sensor type=\"perspective\">\n"
	    "  <float name=\"fov\" value=\"45\"/>\n"
	    "  <string name=\"fov_axis\" value=\"y\"/>\n"
	    "  <float name=\"near_clip\" value=\"0.5\"/>\n"
	    "  <float name=\"far_clip\" value=\"500\"/>\n"
	    "  <transform name=\"to_world\"><lookat origin=\"1, 2, 3\" "
	    "target=\"1, 2, 4\" up=\"0, 1, 0\"/></transform>\n"
	    "  <sampler type=\"independent\">"
	    "<integer name=\"sample_count\" value=\"64\"/></sampler>\n"
	    "  <film type=\"hdrfilm\">\n"
	    "   <integer name=\"width\" value=\"320\"/>\n"
	    "   <integer name=\"height\" value=\"240\"/>\n"
	    "   <string name=\"pixel_format\" value=\"rgba\"/>\n"
	    "   <string name=\"component_format\" value=\"float32\"/>\n"
	    "   <string name=\"file_format\" value=\"openexr\"/>\n"
	    "   <rfilter type=\"tent\"><float name=\"radius\" value=\"2\"/></rfilter>\n"
	    "  </film>\n"
	    " </sensor>\n"
	    "</scene>\n", &s);
	c = &s.camera;
	assert_true(s.has_camera);
	NEAR(c->fov, 45, 1e-6);
	assert_int_equal(c->fov_axis, PM_FOV_Y);
	NEAR(c->near_clip, 0.5, 1e-7);
	NEAR(c->far_clip, 500, 1e-4);
	NEAR(c->to_world.m[0][3], 1, 1e-6);
	NEAR(c->to_world.m[1][3], 2, 1e-6);
	NEAR(c->to_world.m[2][3], 3, 1e-6);
	NEAR(c->to_world.m[2][2], 1, 1e-6);	/* looks down +z */
	assert_int_equal(c->spp, 64);
	assert_int_equal(c->width, 320);
	assert_int_equal(c->height, 240);
	assert_int_equal(c->rfilter, PM_RFILTER_TENT);
	NEAR(c->filter_radius, 2, 1e-6);
	pm_scene_free(&s);

	/* Mitsuba's defaults: a 50 mm lens on 35 mm film (a diagonal field
	 * of view), 768 x 576, 4 samples, a Gaussian of stddev 0.5. */
	load_ok("<scene version=\"3.0.0\"><sensor type=\"perspective\"/>"
	    "</scene>", &s);
	c = &s.camera;
	assert_true(s.has_camera);
	NEAR(c->fov, 2 * atan(sqrt(36.0 * 36 + 24 * 24) / 100) * 180 / PI,
	    1e-4);
	assert_int_equal(c->fov_axis, PM_FOV_DIAGONAL);
	NEAR(c->near_clip, 0.01, 1e-8);
	NEAR(c->far_clip, 10000, 1e-3);
	assert_int_equal(c->width, 768);
	assert_int_equal(c->height, 576);
	assert_int_equal(c->spp, 4);
	assert_int_equal(c->rfilter, PM_RFILTER_GAUSSIAN);
	NEAR(c->filter_radius, 0.5, 1e-7);
	pm_scene_free(&s);

	load_ok("<scene version=\"3.0.0\"><sensor type=\"perspective\">"
	    "<string name=\"focal_length\" value=\"35mm\"/>"
	    "<film type=\"hdrfilm\"><rfilter type=\"box\"/></film>"
	    "</sensor></scene>", &s);
	NEAR(s.camera.fov, 2 * atan(sqrt(36.0 * 36 + 24 * 24) / 70) * 180 / PI,
	    1e-4);
	assert_int_equal(s.camera.rfilter, PM_RFILTER_BOX);
	pm_scene_free(&s);
}

/* The scene's own parameter embree_use_robust_intersections, as
 * Mitsuba's: off unless given; any other parameter of <scene> fails. */
static void
test_scene_params(void **state)
{
	struct pm_scene s;

	(void)state;
	load_ok("<scene version=\"3.0.0\"><shape type=\"sphere\"/></scene>",
	    &s);
	assert_false(s.robust);
	pm_scene_free(&s);
	load_ok("<scene version=\"3.0.0\"><shape type=\"sphere\"/>"
	    "<boolean name=\"embree_use_robust_intersections\" "
	    "value=\"true\"/></scene>", &s);
	assert_true(s.robust);
	assert_int_equal(s.nshapes, 1);
	pm_scene_free(&s);
	load_fails("<scene version=\"3.0.0\">\n"
	    "<float name=\"embree_use_robust_intersectionz\" value=\"1\"/>"
	    "</scene>", 2, "unknown parameter \"embree_use_robust_"
	    "intersectionz\" for <scene>");
	load_fails("<scene version=\"3.0.0\">\n"
	    "<float name=\"embree_use_robust_intersections\" value=\"1\"/>"
	    "</scene>", 2, "embree_use_robust_intersections");
	load_fails("<scene version=\"3.0.0\">\n<boolean name=\"embree_use_"
	    "robust_intersections\" value=\"true\"/>\n<boolean name=\"embree_"
	    "use_robust_intersections\" value=\"false\"/></scene>", 3,
	    "given twice");
}

static void
test_integrators(void **state)
{
	struct pm_scene s;
	const struct pm_photon_params *ph;

	(void)state;
	load_ok("<scene version=\"3.0.0\"><integrator type=\"path\">"
	    "<integer name=\"max_depth\" value=\"8\"/>"
	    "<integer name=\"rr_depth\" value=\"3\"/>"
	    "<boolean name=\"hide_emitters\" value=\"TRUE\"/>"
	    "</integrator></scene>", &s);
	assert_int_equal(s.integrator.type, PM_INTEGRATOR_PATH);
	assert_int_equal(s.integrator.max_depth, 8);
	assert_int_equal(s.integrator.rr_depth, 3);
	assert_true(s.integrator.hide_emitters);
	pm_scene_free(&s);

	load_ok("<scene version=\"3.0.0\"><integrator type=\"photonmapper\">"
	    "<integer name=\"globalPhotons\" value=\"1000000\"/>"
	    "<integer name=\"causticPhotons\" value=\"3000000000\"/>"
	    "<float name=\"globalLookupRadius\" value=\"0.1\"/>"
	    "<float name=\"causticLookupRadius\" value=\"0.01\"/>"
	    "<integer name=\"lookupSize\" value=\"50\"/>"
	    "<integer name=\"directSamples\" value=\"4\"/>"
	    "<integer name=\"glossySamples\" value=\"8\"/>"
	    "<integer name=\"maxDepth\" value=\"12\"/>"
	    "<integer name=\"rrDepth\" value=\"7\"/>"
	    "<integer name=\"granularity\" value=\"1000\"/>"
	    "<boolean name=\"finalGather\" value=\"true\"/>"
	    "<integer name=\"finalGatherSamples\" value=\"256\"/>"
	    "</integrator></scene>", &s);
	ph = &s.integrator.photon;
	assert_int_equal(s.integrator.type, PM_INTEGRATOR_PHOTONMAPPER);
	assert_int_equal(s.integrator.max_depth, 12);
	assert_int_equal(s.integrator.rr_depth, 7);
	assert_int_equal(ph->global_photons, 1000000);
	assert_true(ph->caustic_photons == 3000000000L);
	NEAR(ph->global_lookup_radius, 0.1, 1e-7);
	NEAR(ph->caustic_lookup_radius, 0.01, 1e-8);
	assert_int_equal(ph->lookup_size, 50);
	assert_int_equal(ph->direct_samples, 4);
	assert_true(ph->final_gather);
	assert_int_equal(ph->final_gather_samples, 256);
	pm_scene_free(&s);

	/* Mitsuba 0.6's defaults. */
	load_ok("<scene version=\"3.0.0\"><integrator type=\"photonmapper\"/>"
	    "</scene>", &s);
	ph = &s.integrator.photon;
	assert_int_equal(ph->global_photons, 250000);
	assert_int_equal(ph->caustic_photons, 250000);
	NEAR(ph->global_lookup_radius, 0.05, 1e-8);
	NEAR(ph->caustic_lookup_radius, 0.0125, 1e-8);
	assert_int_equal(ph->lookup_size, 120);
	assert_int_equal(ph->direct_samples, 16);
	assert_int_equal(s.integrator.max_depth, -1);
	assert_int_equal(s.integrator.rr_depth, 5);
	pm_scene_free(&s);

	/* glossySamples and granularity are ignored, but still checked. */
	load_fails("<scene version=\"3.0.0\">\n<integrator type=\"photonmapper\">"
	    "<integer name=\"glossySamples\" value=\"-1\"/>"
	    "</integrator></scene>", 2, "glossySamples");
	load_fails("<scene version=\"3.0.0\">\n<integrator type=\"photonmapper\">"
	    "<integer name=\"granularity\" value=\"x\"/>"
	    "</integrator></scene>", 2, "granularity");

	/* Mitsuba 3's integrators that mean one of pm's: volpath and
	 * volpathmis are path tracing (no media here), direct is path
	 * tracing to depth 2, moment renders its nested integrator. */
	load_ok("<scene version=\"3.0.0\"><integrator type=\"volpath\">"
	    "<integer name=\"max_depth\" value=\"6\"/>"
	    "<boolean name=\"hide_emitters\" value=\"true\"/>"
	    "</integrator></scene>", &s);
	assert_int_equal(s.integrator.type, PM_INTEGRATOR_PATH);
	assert_int_equal(s.integrator.max_depth, 6);
	assert_true(s.integrator.hide_emitters);
	assert_false(s.integrator.moment);
	pm_scene_free(&s);
	load_ok("<scene version=\"3.0.0\"><integrator type=\"volpathmis\"/>"
	    "</scene>", &s);
	assert_int_equal(s.integrator.type, PM_INTEGRATOR_PATH);
	assert_int_equal(s.integrator.max_depth, -1);
	pm_scene_free(&s);
	load_ok("<scene version=\"3.0.0\"><integrator type=\"direct\">"
	    "<integer name=\"shading_samples\" value=\"4\"/>"
	    "<integer name=\"bsdf_samples\" value=\"0\"/>"
	    "</integrator></scene>", &s);
	assert_int_equal(s.integrator.type, PM_INTEGRATOR_PATH);
	assert_int_equal(s.integrator.max_depth, 2);
	pm_scene_free(&s);
	load_ok("<scene version=\"3.0.0\"><integrator type=\"moment\">"
	    "<integrator type=\"photonmapper\">"
	    "<integer name=\"maxDepth\" value=\"5\"/></integrator>"
	    "</integrator></scene>", &s);
	assert_int_equal(s.integrator.type, PM_INTEGRATOR_PHOTONMAPPER);
	assert_int_equal(s.integrator.max_depth, 5);
	assert_true(s.integrator.moment);
	/* Mitsuba 3.9's name for an unnamed nested object */
	assert_string_equal(s.integrator.moment_name, "_arg_0");
	pm_scene_free(&s);
	load_ok("<scene version=\"3.0.0\"><integrator type=\"moment\">"
	    "<integrator type=\"path\" name=\"nested\" id=\"x\"/>"
	    "</integrator></scene>", &s);
	assert_string_equal(s.integrator.moment_name, "nested");
	pm_scene_free(&s);
	/* The particle tracer: path's parameters and samples_per_pass. */
	load_ok("<scene version=\"3.0.0\"><integrator type=\"ptracer\">"
	    "<integer name=\"max_depth\" value=\"4\"/>"
	    "<integer name=\"rr_depth\" value=\"3\"/>"
	    "<boolean name=\"hide_emitters\" value=\"true\"/>"
	    "<integer name=\"samples_per_pass\" value=\"8\"/>"
	    "</integrator></scene>", &s);
	assert_int_equal(s.integrator.type, PM_INTEGRATOR_PTRACER);
	assert_int_equal(s.integrator.max_depth, 4);
	assert_int_equal(s.integrator.rr_depth, 3);
	assert_true(s.integrator.hide_emitters);
	assert_int_equal(s.integrator.samples_per_pass, 8);
	pm_scene_free(&s);
	load_ok("<scene version=\"3.0.0\"><integrator type=\"ptracer\"/>"
	    "</scene>", &s);
	assert_int_equal(s.integrator.max_depth, -1);
	assert_int_equal(s.integrator.samples_per_pass, -1);
	pm_scene_free(&s);
	load_fails("<scene version=\"3.0.0\">\n<integrator type=\"ptracer\">"
	    "<integer name=\"samples_per_pass\" value=\"0\"/>"
	    "</integrator></scene>", 2, "samples_per_pass");
	load_fails("<scene version=\"3.0.0\"><integrator type=\"moment\">\n"
	    "<integrator type=\"ptracer\"/></integrator></scene>", 2,
	    "cannot wrap ptracer");
	load_fails("<scene version=\"3.0.0\">\n<integrator type=\"moment\"/>"
	    "</scene>", 2, "one nested <integrator>, found 0");
	load_fails("<scene version=\"3.0.0\">\n<integrator type=\"moment\">"
	    "<integrator type=\"path\"/><integrator type=\"direct\"/>"
	    "</integrator></scene>", 2, "found 2");
	load_fails("<scene version=\"3.0.0\">\n<integrator type=\"moment\">"
	    "<bsdf type=\"diffuse\"/></integrator></scene>", 2, "found 1");
	load_fails("<scene version=\"3.0.0\">\n<integrator type=\"moment\">"
	    "\n<integrator type=\"moment\"><integrator type=\"path\"/>"
	    "</integrator></integrator></scene>", 3, "inside another");
	load_fails("<scene version=\"3.0.0\">\n<integrator type=\"direct\">"
	    "<integer name=\"shading_samples\" value=\"0\"/>"
	    "</integrator></scene>", 2, "shading_samples");
}

/* ------------------------------------------------------------ parameters */

static void
test_defaults_and_defines(void **state)
{
	static const char xml[] =
	    "<scene version=\"3.0.0\">\n"
	    " <default name=\"depth\" value=\"3\"/>\n"
	    " <default name=\"w\" value=\"64\"/>\n"
	    " <integrator type=\"path\">\n"
	    "  <integer name=\"max_depth\" value=\"$depth\"/>\n"
	    " </integrator>\n"
	    " <sensor type=\"perspective\"><film type=\"hdrfilm\">\n"
	    "  <integer name=\"width\" value=\"1$w\"/>\n"
	    " </film></sensor>\n"
	    "</scene>\n";
	struct pm_define defs[] = {{"depth", "7"}, {"unused", "1"}};
	struct pm_scene s;
	struct pm_error err;

	(void)state;
	load_ok(xml, &s);
	assert_int_equal(s.integrator.max_depth, 3);
	assert_int_equal(s.camera.width, 164);
	pm_scene_free(&s);

	assert_int_equal(load_defs(xml, defs, 2, &s, &err), PM_OK);
	assert_int_equal(s.integrator.max_depth, 7);
	assert_int_equal(s.camera.width, 164);
	pm_scene_free(&s);

	/* A define also serves a name no <default> declares. */
	defs[0].name = "d2";
	assert_int_equal(load_defs("<scene version=\"3.0.0\">"
	    "<integrator type=\"path\"><integer name=\"max_depth\" "
	    "value=\"$d2\"/></integrator></scene>", defs, 1, &s, &err), PM_OK);
	assert_int_equal(s.integrator.max_depth, 7);
	pm_scene_free(&s);
}

static void
test_forward_refs(void **state)
{
	struct pm_scene s;

	(void)state;
	load_ok("<scene version=\"3.0.0\">\n"
	    " <shape type=\"rectangle\">\n"
	    "  <ref id=\"red\"/>\n"
	    "  <ref name=\"emitter\" id=\"lamp\"/>\n"
	    " </shape>\n"
	    " <shape type=\"cube\"><ref name=\"bsdf\" id=\"red\"/></shape>\n"
	    " <shape type=\"disk\"><bsdf type=\"twosided\"><ref id=\"red\"/>"
	    "</bsdf></shape>\n"
	    " <bsdf type=\"diffuse\" id=\"red\">\n"
	    "  <rgb name=\"reflectance\" value=\"0.8, 0.1, 0.1\"/>\n"
	    " </bsdf>\n"
	    " <emitter type=\"area\" id=\"lamp\">\n"
	    "  <rgb name=\"radiance\" value=\"5\"/>\n"
	    " </emitter>\n"
	    "</scene>\n", &s);
	assert_int_equal(s.nshapes, 3);
	assert_int_equal(s.nlights, 1);
	/* Both references share one BSDF; twosided gets its own copy. */
	assert_int_equal(s.shapes[0].bsdf, s.shapes[1].bsdf);
	assert_rgb(shape_bsdf(&s, 0)->diffuse, 0.8, 0.1, 0.1);
	assert_false(shape_bsdf(&s, 0)->twosided);
	assert_true(s.shapes[2].bsdf != s.shapes[0].bsdf);
	assert_true(shape_bsdf(&s, 2)->twosided);
	assert_rgb(shape_bsdf(&s, 2)->diffuse, 0.8, 0.1, 0.1);
	assert_int_equal(s.shapes[0].light, 0);
	assert_int_equal(s.lights[0].shape, 0);
	assert_rgb(s.lights[0].radiance, 5, 5, 5);
	pm_scene_free(&s);
}

static void
test_include(void **state)
{
	struct pm_scene s;
	struct pm_error err;
	char path[256];

	(void)state;
	put_file("frag.xml", "<scene version=\"3.0.0\">\n"
	    " <default name=\"refl\" value=\"0.25\"/>\n"
	    " <bsdf type=\"diffuse\" id=\"grey\">\n"
	    "  <float name=\"reflectance\" value=\"$refl\"/>\n"
	    " </bsdf>\n"
	    "</scene>\n");
	snprintf(path, sizeof(path), "mkdir -p '%s/extra'", pm_test_dir);
	assert_int_equal(system(path), 0);
	put_file("extra/hidden.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
	put_file("main.xml", "<scene version=\"3.0.0\">\n"
	    " <path value=\"extra\"/>\n"
	    " <include filename=\"frag.xml\"/>\n"
	    " <shape type=\"obj\">\n"
	    "  <string name=\"filename\" value=\"hidden.obj\"/>\n"
	    "  <ref id=\"grey\"/>\n"
	    " </shape>\n"
	    "</scene>\n");
	snprintf(path, sizeof(path), "%s/main.xml", pm_test_dir);
	assert_int_equal(pm_scene_load(path, NULL, 0, &s, &err), PM_OK);
	assert_int_equal(s.nshapes, 1);
	assert_int_equal(s.shapes[0].mesh.ntris, 1);
	assert_rgb(shape_bsdf(&s, 0)->diffuse, 0.25, 0.25, 0.25);
	assert_string_equal(s.path, path);
	pm_scene_free(&s);

	/* a includes b includes a: the error names b and its line. */
	put_file("a.xml", "<scene version=\"3.0.0\">\n"
	    " <include filename=\"b.xml\"/>\n</scene>\n");
	put_file("b.xml", "<scene version=\"3.0.0\">\n\n"
	    " <include filename=\"a.xml\"/>\n</scene>\n");
	snprintf(path, sizeof(path), "%s/a.xml", pm_test_dir);
	assert_int_not_equal(pm_scene_load(path, NULL, 0, &s, &err), PM_OK);
	assert_non_null(strstr(err.msg, "b.xml:3: "));
	assert_non_null(strstr(err.msg, "include cycle"));
	pm_scene_free(&s);

	/* A string that includes a file including itself. */
	put_file("self.xml", "<scene version=\"3.0.0\">"
	    "<include filename=\"self.xml\"/></scene>\n");
	assert_int_not_equal(load_defs("<scene version=\"3.0.0\">\n"
	    "<include filename=\"self.xml\"/>\n</scene>", NULL, 0, &s, &err),
	    PM_OK);
	assert_non_null(strstr(err.msg, "self.xml:1: "));
	assert_non_null(strstr(err.msg, "include cycle"));

	/* A missing include. */
	load_fails("<scene version=\"3.0.0\">\n\n"
	    "<include filename=\"nothere.xml\"/>\n</scene>", 3,
	    "cannot find \"nothere.xml\"");
}

/* ------------------------------------------------------------ transforms */

/* Position of a point light placed by the given transform body. */
static struct pm_vec3
place(const char *ops)
{
	char xml[1024];
	struct pm_scene s;
	struct pm_vec3 p;

	snprintf(xml, sizeof(xml), "<scene version=\"3.0.0\"><emitter "
	    "type=\"point\"><transform name=\"to_world\">%s</transform>"
	    "</emitter></scene>", ops);
	load_ok(xml, &s);
	assert_int_equal(s.nlights, 1);
	p = s.lights[0].position;
	pm_scene_free(&s);
	return p;
}

static void
assert_at(struct pm_vec3 p, double x, double y, double z)
{
	NEAR(p.x, x, 1e-5);
	NEAR(p.y, y, 1e-5);
	NEAR(p.z, z, 1e-5);
}

static void
test_transform_order(void **state)
{
	(void)state;
	/* Each operation applies after the ones before it: M = Op * M. */
	assert_at(place("<translate x=\"1\"/><scale value=\"2\"/>"), 2, 0, 0);
	assert_at(place("<scale value=\"2\"/><translate x=\"1\"/>"), 1, 0, 0);
	assert_at(place("<translate x=\"1\"/><rotate z=\"1\" angle=\"90\"/>"),
	    0, 1, 0);
	assert_at(place("<rotate z=\"1\" angle=\"90\"/><translate x=\"1\"/>"),
	    1, 0, 0);
	assert_at(place("<translate value=\"1 1 1\"/><scale x=\"2\" z=\"3\"/>"),
	    2, 1, 3);
	assert_at(place("<translate value=\"1\"/><rotate value=\"0, 0, 1\" "
	    "angle=\"180\"/>"), -1, -1, 1);
	assert_at(place("<matrix value=\"1 0 0 5  0 1 0 6  0 0 1 7  0 0 0 1\"/>"),
	    5, 6, 7);
	assert_at(place("<translate x=\"1\"/>"
	    "<matrix value=\"0 -1 0  1 0 0  0 0 1\"/>"), 0, 1, 0);
	assert_at(place("<lookat origin=\"3, 4, 5\" target=\"0, 0, 0\"/>"
	    "<translate y=\"1\"/>"), 3, 5, 5);
	assert_at(place(""), 0, 0, 0);
}

/* ------------------------------------------------------------ errors */


static void
test_errors(void **state)
{
	static const struct {
		const char *xml;
		int line;
		const char *what;
	} cases[] = {
		/* malformed XML */
		{HEAD "<shape type=\"sphere\">\n</scene>\n", 3, "malformed XML"},
		{HEAD "<shape type=\"sphere\"/>\n", 3, "malformed XML"},
		{"", 1, "empty file"},
		{"  \n\n", 1, "empty file"},
		{"<scene>\n</scene>", 1, "needs the attribute \"version\""},
		{"<scene version=\"0.6.0\"/>", 1, "version \"0.6.0\""},
		{"\n<shape type=\"sphere\"/>", 2, "expected <scene>"},
		{HEAD "\n  hello\n</scene>", 3, "unexpected text \"hello"},
		/* unknown elements, plugins, parameters */
		{HEAD "\n<foo/>\n</scene>", 3, "unknown element <foo> in <scene>"},
		{HEAD "<shape type=\"sphere\">\n<bar/></shape></scene>", 3,
		    "unknown element <bar> in shape \"sphere\""},
		{HEAD "<shape type=\"teapot\"/></scene>", 2,
		    "unknown shape type \"teapot\""},
		{HEAD "<shape type=\"sphere\"><bsdf type=\"hair\"/>"
		    "</shape></scene>", 2, "unknown bsdf type \"hair\""},
		{HEAD "<emitter type=\"sunsky\"/></scene>", 2,
		    "unknown emitter type \"sunsky\""},
		{HEAD "<integrator type=\"aov\"/></scene>", 2,
		    "unknown integrator type \"aov\""},
		{HEAD "<sensor type=\"radiancemeter\"/></scene>", 2,
		    "unknown sensor type \"radiancemeter\""},
		{HEAD "<shape type=\"sphere\">\n"
		    "<float name=\"radiuss\" value=\"1\"/></shape></scene>", 3,
		    "unknown parameter \"radiuss\" for shape \"sphere\""},
		{HEAD "<integrator type=\"path\">\n\n"
		    "<integer name=\"volumePhotons\" value=\"1\"/>"
		    "</integrator></scene>", 4, "unknown parameter"},
		{HEAD "<shape type=\"sphere\" colour=\"red\"/></scene>", 2,
		    "unexpected attribute \"colour\""},
		/* wrong property types */
		{HEAD "<shape type=\"sphere\">\n"
		    "<rgb name=\"radius\" value=\"1\"/></shape></scene>", 3,
		    "\"radius\" must be a <float>, found <rgb>"},
		{HEAD "<integrator type=\"path\">\n"
		    "<float name=\"max_depth\" value=\"3\"/></integrator>"
		    "</scene>", 3, "must be an <integer>"},
		{HEAD "<shape type=\"sphere\">\n"
		    "<string name=\"to_world\" value=\"1\"/></shape></scene>", 3,
		    "must be a <transform>"},
		/* bad numbers and values */
		{HEAD "<shape type=\"sphere\">\n"
		    "<float name=\"radius\" value=\"1.5x\"/></shape></scene>", 3,
		    "\"1.5x\" is not a finite number"},
		{HEAD "<shape type=\"sphere\">\n"
		    "<float name=\"radius\" value=\"nan\"/></shape></scene>", 3,
		    "is not a finite number"},
		{HEAD "<shape type=\"sphere\">\n"
		    "<float name=\"radius\" value=\"1e999\"/></shape></scene>", 3,
		    "is not a finite number"},
		{HEAD "<integrator type=\"path\">\n"
		    "<integer name=\"max_depth\" value=\"1.5\"/></integrator>"
		    "</scene>", 3, "is not an integer"},
		{HEAD "<integrator type=\"path\">\n"
		    "<boolean name=\"hide_emitters\" value=\"yes\"/></integrator>"
		    "</scene>", 3, "neither true nor false"},
		{HEAD "<shape type=\"rectangle\"><bsdf type=\"diffuse\">\n"
		    "<rgb name=\"reflectance\" value=\"0.1, 0.2\"/></bsdf>"
		    "</shape></scene>", 3, "expected 1 or 3 numbers"},
		{HEAD "<shape type=\"rectangle\"><bsdf type=\"diffuse\">\n"
		    "<spectrum name=\"reflectance\" value=\"700:0.1, 400:0.5\"/>"
		    "</bsdf></shape></scene>", 3, "wavelengths must increase"},
		{HEAD "<shape type=\"rectangle\"><bsdf type=\"diffuse\">\n"
		    "<spectrum name=\"reflectance\" value=\"400:0.1\"/>"
		    "</bsdf></shape></scene>", 3, "at least two"},
		{HEAD "<shape type=\"rectangle\"><bsdf type=\"diffuse\">\n"
		    "<spectrum name=\"reflectance\" value=\"400:0.1, 500\"/>"
		    "</bsdf></shape></scene>", 3, "not a wavelength:value pair"},
		{HEAD "<emitter type=\"constant\">\n"
		    "<spectrum name=\"radiance\" type=\"cie\"/>"
		    "</emitter></scene>", 3, "unknown spectrum type \"cie\""},
		{HEAD "<emitter type=\"constant\">\n"
		    "<spectrum name=\"radiance\" type=\"irregular\">"
		    "<string name=\"wavelengths\" value=\"400 500 600\"/>"
		    "<string name=\"values\" value=\"1 2\"/></spectrum>"
		    "</emitter></scene>", 3, "3 wavelengths but 2 values"},
		{HEAD "<emitter type=\"constant\">\n"
		    "<spectrum name=\"radiance\" type=\"regular\">"
		    "<string name=\"values\" value=\"1 x\"/></spectrum>"
		    "</emitter></scene>", 3, "\"x\" is not a finite number"},
		{HEAD "<emitter type=\"constant\">\n"
		    "<spectrum name=\"radiance\" type=\"srgb\"/>"
		    "</emitter></scene>", 3, "missing required parameter "
		    "\"color\""},
		{HEAD "<emitter type=\"constant\">\n"
		    "<spectrum name=\"radiance\" type=\"blackbody\"/>"
		    "</emitter></scene>", 3, "missing required parameter "
		    "\"temperature\""},
		{HEAD "<emitter type=\"constant\">\n"
		    "<spectrum name=\"radiance\" filename=\"nope.spd\"/>"
		    "</emitter></scene>", 3, "nope.spd"},
		{HEAD "<shape type=\"rectangle\"><bsdf type=\"diffuse\">\n"
		    "<rgb name=\"reflectance\" value=\"-0.5\"/></bsdf>"
		    "</shape></scene>", 3, "must not be negative"},
		{HEAD "<integrator type=\"path\">\n"
		    "<integer name=\"max_depth\" value=\"-2\"/></integrator>"
		    "</scene>", 3, "outside [-1,"},
		{HEAD "<emitter type=\"point\"><transform name=\"to_world\">\n"
		    "<matrix value=\"1 2 3\"/></transform></emitter></scene>", 3,
		    "expected 16 (4x4) or 9 (3x3) numbers"},
		{HEAD "<emitter type=\"point\"><transform name=\"to_world\">\n"
		    "<rotate x=\"1\"/></transform></emitter></scene>", 3,
		    "needs the attribute \"angle\""},
		{HEAD "<emitter type=\"point\"><transform name=\"to_world\">\n"
		    "<shear x=\"1\"/></transform></emitter></scene>", 3,
		    "unknown element <shear> in <transform>"},
		{HEAD "<emitter type=\"point\"><transform name=\"to_world\">\n"
		    "<lookat origin=\"1 1 1\" target=\"1 1 1\"/></transform>"
		    "</emitter></scene>", 3, "coincide"},
		/* parameters */
		{HEAD "<integrator type=\"path\">\n\n"
		    "<integer name=\"max_depth\" value=\"$depth\"/></integrator>"
		    "</scene>", 4, "undefined parameter $depth"},
		{HEAD "<default name=\"a\" value=\"1\"/>\n"
		    "<shape type=\"sphere\"><default name=\"b\" value=\"1\"/>"
		    "</shape></scene>", 3, "must be a child of <scene>"},
		/* references */
		{HEAD "<shape type=\"sphere\">\n<ref id=\"nope\"/></shape>"
		    "</scene>", 3, "<ref id=\"nope\">: no object has this id"},
		{HEAD "<bsdf type=\"diffuse\" id=\"x\"/>\n"
		    "<bsdf type=\"diffuse\" id=\"x\"/></scene>", 3,
		    "duplicate id \"x\" (first at t.xml:2)"},
		{HEAD "<sensor type=\"perspective\" id=\"cam\"/>\n"
		    "<shape type=\"sphere\"><ref id=\"cam\"/></shape></scene>", 3,
		    "names a <sensor>"},
		{HEAD "<bsdf type=\"twosided\" id=\"t\">\n<ref id=\"t\"/></bsdf>"
		    "</scene>", 2, "refers to itself"},
		/* missing required parameters */
		{HEAD "\n<shape type=\"obj\"/></scene>", 3,
		    "missing required parameter \"filename\""},
		{HEAD "<shape type=\"sphere\">\n<emitter type=\"area\"/>"
		    "</shape></scene>", 3,
		    "missing required parameter \"radiance\""},
		{HEAD "<shape type=\"sphere\">\n"
		    "<emitter type=\"area\"><rgb name=\"radiance\" value=\"1\"/>"
		    "</emitter><ref id=\"l\"/></shape>\n"
		    "<emitter type=\"area\" id=\"l\"><rgb name=\"radiance\" "
		    "value=\"1\"/></emitter></scene>", 3, "more than one emitter"},
		{HEAD "<shape type=\"obj\">\n<string name=\"filename\" "
		    "value=\"absent.obj\"/></shape></scene>", 2,
		    "cannot find \"absent.obj\""},
		{HEAD "<shape/></scene>", 2, "needs the attribute \"type\""},
		{HEAD "<shape type=\"obj\">\n<string name=\"filename\" "
		    "value=\"bad.obj\"/></shape></scene>", 2,
		    "shape \"obj\": "},
		{HEAD "<shape type=\"obj\">\n<string name=\"filename\" "
		    "value=\"flat.obj\"/></shape></scene>", 2,
		    "no triangles left"},
		{HEAD "<shape type=\"sphere\">\n<float value=\"1\"/></shape>"
		    "</scene>", 3, "needs the attribute \"name\""},
		/* unsupported features and inconsistent scenes */
		{HEAD "<shape type=\"rectangle\"><bsdf type=\"diffuse\">\n"
		    "<texture name=\"reflectance\" type=\"bitmap\"/></bsdf>"
		    "</shape></scene>", 3, "texture \"bitmap\": missing required "
		    "parameter \"filename\""},
		/* where pm takes no texture, one is named as not supported */
		{HEAD "<shape type=\"rectangle\"><bsdf type=\"conductor\">\n"
		    "<texture name=\"eta\" type=\"checkerboard\"/>"
		    "</bsdf></shape></scene>", 3, "bsdf \"conductor\": textures "
		    "are not supported here (<texture name=\"eta\">)"},
		{HEAD "<texture type=\"checkerboard\" id=\"t\">\n"
		    "<texture name=\"color2\" type=\"checkerboard\"/></texture>"
		    "</scene>", 3, "textures are not supported here"},
		{HEAD "<shape type=\"rectangle\"><bsdf type=\"diffuse\">\n"
		    "<texture type=\"checkerboard\"/></bsdf></shape></scene>", 3,
		    "a nested <texture> needs a name"},
		{HEAD "<shape type=\"rectangle\"><bsdf type=\"diffuse\">\n"
		    "<texture name=\"reflectance\" type=\"noise\"/></bsdf>"
		    "</shape></scene>", 3, "unknown texture type \"noise\""},
		{HEAD "<texture type=\"bitmap\" id=\"t\">\n"
		    "<string name=\"filename\" value=\"absent.png\"/>"
		    "<string name=\"wrap_mode\" value=\"wrap\"/></texture>"
		    "</scene>", 3, "wrap_mode \"wrap\" is not one of"},
		{HEAD "<texture type=\"bitmap\" id=\"t\">\n"
		    "<string name=\"filename\" value=\"absent.png\"/>"
		    "</texture></scene>", 2, "cannot find \"absent.png\""},
		{HEAD "<texture type=\"bitmap\" id=\"t\">\n"
		    "<string name=\"filename\" value=\"flat.obj\"/>"
		    "</texture></scene>", 2, "not a PNG, JPEG, OpenEXR or Radiance "
		    "HDR file"},
		{HEAD "<shape type=\"rectangle\"><bsdf type=\"diffuse\">\n"
		    "<rgb name=\"reflectance\" value=\"0.5\"/>"
		    "<texture name=\"reflectance\" type=\"checkerboard\"/>"
		    "</bsdf></shape></scene>", 3,
		    "parameter \"reflectance\" given twice"},
		{HEAD "<shape type=\"rectangle\"><bsdf type=\"diffuse\">\n"
		    "<ref name=\"reflectance\" id=\"b\"/></bsdf></shape>"
		    "<bsdf type=\"diffuse\" id=\"b\"/></scene>", 3,
		    "names a <bsdf>, expected a <texture>"},
		/* an unknown plugin is named before the texture inside it */
		{HEAD "<shape type=\"rectangle\">\n<bsdf type=\"hair\">"
		    "<texture name=\"base_color\" type=\"bitmap\"/>"
		    "</bsdf></shape></scene>", 3,
		    "unknown bsdf type \"hair\""},
		/* a texture by reference is a texture */
		{HEAD "<shape type=\"rectangle\"><bsdf type=\"conductor\">\n"
		    "<ref name=\"eta\" id=\"t\"/></bsdf>"
		    "</shape>\n<texture type=\"checkerboard\" id=\"t\"/>"
		    "</scene>", 3, "textures are not supported here (<ref "
		    "id=\"t\"> names the <texture> at line 4)"},
		/* a required parameter given as a texture: the texture's
		 * own errors */
		{HEAD "<shape type=\"rectangle\"><emitter type=\"area\">\n"
		    "<texture name=\"radiance\" type=\"bitmap\"/></emitter>"
		    "</shape></scene>", 3, "filename"},
		{HEAD "<shape type=\"rectangle\"><bsdf type=\"roughconductor\">\n"
		    "<string name=\"distribution\" value=\"phong\"/></bsdf>"
		    "</shape></scene>", 3,
		    "distribution \"phong\" is not supported"},
		{HEAD "<shape type=\"rectangle\"><bsdf type=\"roughplastic\">\n"
		    "<string name=\"distribution\" value=\"ggx\"/>"
		    "<float name=\"alpha_u\" value=\"0.1\"/>"
		    "<float name=\"alpha_v\" value=\"0.2\"/></bsdf></shape>"
		    "</scene>", 2, "anisotropic"},
		{HEAD "<shape type=\"rectangle\"><bsdf type=\"roughconductor\">\n"
		    "<float name=\"alpha_u\" value=\"0.1\"/></bsdf></shape>"
		    "</scene>", 2, "alpha_v"},
		{HEAD "<shape type=\"rectangle\"><bsdf type=\"bumpmap\">\n"
		    "<texture type=\"checkerboard\"/><bsdf type=\"diffuse\"/>"
		    "</bsdf></shape></scene>", 3, "must be a bitmap"},
		{HEAD "<shape type=\"rectangle\"><bsdf type=\"normalmap\">\n"
		    "<bsdf type=\"diffuse\"/></bsdf></shape></scene>", 2,
		    "normalmap"},
		{HEAD "<shape type=\"rectangle\"><bsdf type=\"conductor\">\n"
		    "<string name=\"material\" value=\"Unobtainium\"/></bsdf>"
		    "</shape></scene>", 3, "unknown conductor material"},
		{HEAD "<shape type=\"rectangle\"><bsdf type=\"dielectric\">\n"
		    "<string name=\"int_ior\" value=\"kryptonite\"/></bsdf>"
		    "</shape></scene>", 3, "unknown material \"kryptonite\""},
		{HEAD "\n<emitter type=\"area\" id=\"lonely\">"
		    "<rgb name=\"radiance\" value=\"1\"/></emitter></scene>", 3,
		    "area emitter \"lonely\" is not referenced"},
		{HEAD "<emitter type=\"area\">"
		    "<rgb name=\"radiance\" value=\"1\"/></emitter></scene>", 2,
		    "must be nested in a <shape>"},
		{HEAD "<shape type=\"rectangle\"><ref id=\"l\"/></shape>\n"
		    "<shape type=\"rectangle\"><ref id=\"l\"/></shape>\n"
		    "<emitter type=\"area\" id=\"l\"><rgb name=\"radiance\" "
		    "value=\"1\"/></emitter></scene>", 3, "already attached"},
		{HEAD "<shape type=\"rectangle\">\n<emitter type=\"point\"/>"
		    "</shape></scene>", 3, "only an \"area\" emitter"},
		{HEAD "<emitter type=\"constant\"/>\n<emitter type=\"constant\"/>"
		    "</scene>", 3, "more than one environment emitter"},
		{HEAD "<emitter type=\"point\">\n"
		    "<point name=\"position\" value=\"1 2 3\"/>"
		    "<transform name=\"to_world\"/></emitter></scene>", 3,
		    "either position or to_world"},
		{HEAD "<shape type=\"sphere\">\n<transform name=\"to_world\">"
		    "<scale x=\"2\"/></transform></shape></scene>", 2,
		    "uniform scale"},
		{HEAD "<sensor type=\"perspective\">\n<transform name=\"to_world\">"
		    "<scale value=\"2\"/></transform></sensor></scene>", 2,
		    "must not scale"},
		{HEAD "<sensor type=\"perspective\">\n"
		    "<float name=\"near_clip\" value=\"10\"/>"
		    "<float name=\"far_clip\" value=\"1\"/></sensor></scene>", 2,
		    "near_clip"},
		{HEAD "<sensor type=\"perspective\">\n"
		    "<string name=\"fov_axis\" value=\"y\"/></sensor></scene>", 3,
		    "fov_axis applies only with fov"},
		{HEAD "<sensor type=\"perspective\"><film type=\"hdrfilm\">\n"
		    "<rfilter type=\"mitchell\"/></film></sensor></scene>", 3,
		    "unknown rfilter type \"mitchell\""},
		{HEAD "<sensor type=\"perspective\"><film type=\"hdrfilm\">\n"
		    "<string name=\"pixel_format\" value=\"cmyk\"/></film>"
		    "</sensor></scene>", 3, "not one of"},
		{HEAD "<sensor type=\"perspective\"/>\n"
		    "<sensor type=\"perspective\"/></scene>", 3,
		    "more than one <sensor>"},
		{HEAD "<sensor type=\"perspective\"><sampler type=\"ldsampler\">"
		    "</sampler></sensor></scene>", 2,
		    "unknown sampler type \"ldsampler\""},
	};
	size_t i;

	(void)state;
	put_file("bad.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n");
	put_file("flat.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n");
	for (i = 0; i < sizeof(cases) / sizeof(cases[0]); i++) {
		print_message("error case %zu: %s\n", i, cases[i].what);
		load_fails(cases[i].xml, cases[i].line, cases[i].what);
	}
}

/* ------------------------------------------------------------ cbox */

static void
test_cbox(void **state)
{
	const char *shared = getenv("PM_SHARED");
	struct pm_scene s;
	struct pm_error err;
	char path[1024];
	size_t i;

	(void)state;
	snprintf(path, sizeof(path), "%s/scenes/mitsuba-cbox/cbox-rgb.xml",
	    shared != NULL ? shared : "../shared");
	if (access(path, R_OK) != 0) {
		print_message("skipping: %s is absent (set PM_SHARED)\n", path);
		skip();
	}
	if (pm_scene_load(path, NULL, 0, &s, &err) != PM_OK) {
		print_error("%s\n", err.msg);
		fail();
	}
	assert_int_equal(s.nshapes, 8);
	assert_int_equal(s.nlights, 1);
	assert_int_equal(s.lights[0].type, PM_LIGHT_AREA);
	assert_int_equal(s.lights[0].shape, 0);	/* the luminaire */
	NEAR(s.lights[0].area, 130.0 * 105.0, 1.0);
	assert_rgb(s.lights[0].radiance, 18.387, 10.9873, 2.75357);
	assert_true(s.has_camera);
	assert_int_equal(s.camera.width, 256);
	assert_int_equal(s.camera.height, 256);
	NEAR(s.camera.fov, 39.3077, 1e-5);
	assert_int_equal(s.camera.fov_axis, PM_FOV_SMALLER);
	assert_int_equal(s.camera.spp, 256);
	assert_int_equal(s.camera.rfilter, PM_RFILTER_BOX);
	NEAR(s.camera.near_clip, 10, 1e-6);
	NEAR(s.camera.far_clip, 2800, 1e-3);
	assert_int_equal(s.integrator.type, PM_INTEGRATOR_PATH);
	assert_int_equal(s.integrator.max_depth, 6);
	for (i = 0; i < s.nshapes; i++)
		assert_int_equal(s.shapes[i].type, PM_SHAPE_MESH);
	/* The luminaire is translated by -0.5 in y: ceiling at 548.8. */
	NEAR(s.shapes[0].mesh.pos[1], 548.8 - 0.5, 1e-3);
	pm_scene_free(&s);

	/* -D overrides the file's defaults. */
	{
		struct pm_define d[] = {{"spp", "16"}, {"res", "64"},
		    {"max_depth", "3"}};

		assert_int_equal(pm_scene_load(path, d, 3, &s, &err), PM_OK);
		assert_int_equal(s.camera.spp, 16);
		assert_int_equal(s.camera.width, 64);
		assert_int_equal(s.integrator.max_depth, 3);
		pm_scene_free(&s);
	}
}

/* principled and principledthin: Mitsuba's defaults, eta from
 * specular, the transmission adjustments, textured scalars. */
static void
test_principled_bsdfs(void **state)
{
	struct pm_scene s;
	const struct pm_bsdf *b;

	(void)state;
	load_ok("<scene version=\"3.0.0\">\n"
	    " <shape type=\"rectangle\"><bsdf type=\"principled\"/></shape>\n"
	    " <shape type=\"rectangle\"><bsdf type=\"principled\">"
	    "  <rgb name=\"base_color\" value=\"0.1, 0.2, 0.3\"/>"
	    "  <float name=\"specular\" value=\"0.7\"/>"
	    "  <float name=\"metallic\" value=\"1\"/>"
	    "  <float name=\"anisotropic\" value=\"0.5\"/>"
	    "  <float name=\"clearcoat\" value=\"0\"/>"
	    "  <float name=\"clearcoat_sampling_rate\" value=\"2\"/>"
	    " </bsdf></shape>\n"
	    " <shape type=\"rectangle\"><bsdf type=\"principled\">"
	    "  <float name=\"spec_trans\" value=\"1\"/>"
	    "  <float name=\"eta\" value=\"1\"/>"
	    "  <texture name=\"roughness\" type=\"checkerboard\">"
	    "   <rgb name=\"color0\" value=\"0.2\"/>"
	    "   <rgb name=\"color1\" value=\"0.6\"/></texture>"
	    " </bsdf></shape>\n"
	    " <shape type=\"rectangle\"><bsdf type=\"principledthin\"/>"
	    "</shape>\n"
	    " <shape type=\"rectangle\"><bsdf type=\"principledthin\">"
	    "  <float name=\"diff_trans\" value=\"2\"/>"
	    "  <float name=\"eta\" value=\"1.33\"/>"
	    " </bsdf></shape>\n"
	    "</scene>\n", &s);
	assert_int_equal(s.nshapes, 5);

	b = shape_bsdf(&s, 0);
	assert_int_equal(b->type, PM_BSDF_PRINCIPLED);
	assert_rgb(b->diffuse, 0.5, 0.5, 0.5);
	NEAR(b->pr.v[PM_PR_ROUGHNESS], 0.5, 1e-7);
	NEAR(b->pr.v[PM_PR_ETA], 1.5, 1e-6);	/* specular 0.5 */
	NEAR(b->pr.v[PM_PR_METALLIC], 0.0, 0.0);
	assert_false(b->pr.has_spec_trans || b->pr.has_clearcoat ||
	    b->pr.textured);
	NEAR(b->pr.rate[PM_PR_RATE_OTHER], 1.0, 0.0);
	assert_int_equal(b->lobes, PM_LOBE_DIFFUSE | PM_LOBE_GLOSSY);

	b = shape_bsdf(&s, 1);
	assert_rgb(b->diffuse, 0.1, 0.2, 0.3);
	NEAR(b->pr.v[PM_PR_ETA], 2.0 / (1.0 - sqrt(0.08 * 0.7)) - 1.0, 1e-6);
	NEAR(b->pr.v[PM_PR_ANISOTROPIC], 0.5, 1e-7);
	/* clearcoat given as 0 is off, as Mitsuba's flag says */
	assert_false(b->pr.has_clearcoat);
	NEAR(b->pr.rate[PM_PR_RATE_OTHER], 2.0, 0.0);
	assert_int_equal(b->lobes, PM_LOBE_GLOSSY);

	b = shape_bsdf(&s, 2);
	assert_true(b->pr.has_spec_trans);
	NEAR(b->pr.v[PM_PR_ETA], 1.001, 1e-6);
	assert_true(b->pr.textured && b->pr.tex[PM_PR_ROUGHNESS] > 0);
	NEAR(b->pr.v[PM_PR_ROUGHNESS], 0.4, 1e-6);	/* the mean */
	assert_int_equal(b->lobes, PM_LOBE_GLOSSY | PM_LOBE_GLOSSY_TRANSMISSION);
	assert_true(pm_bsdf_passes_photons(b));

	b = shape_bsdf(&s, 3);
	assert_int_equal(b->type, PM_BSDF_PRINCIPLEDTHIN);
	NEAR(b->pr.v[PM_PR_ETA], 1.5, 1e-7);
	assert_int_equal(b->lobes, PM_LOBE_DIFFUSE);

	b = shape_bsdf(&s, 4);
	NEAR(b->pr.v[PM_PR_ETA], 1.33, 1e-6);
	assert_true(b->pr.has_diff_trans);
	assert_int_equal(b->lobes, PM_LOBE_DIFFUSE_TRANSMISSION);
	pm_scene_free(&s);

	load_fails("<scene version=\"3.0.0\"><shape type=\"rectangle\">\n"
	    "<bsdf type=\"principled\"><float name=\"eta\" value=\"1.5\"/>"
	    "<float name=\"specular\" value=\"0.5\"/></bsdf></shape></scene>",
	    2, "give either eta or specular");
	load_fails("<scene version=\"3.0.0\"><shape type=\"rectangle\">\n"
	    "<bsdf type=\"principledthin\">\n<float name=\"diff_trans\" "
	    "value=\"3\"/></bsdf></shape></scene>", 3, "outside [0, 2]");
	load_fails("<scene version=\"3.0.0\"><shape type=\"rectangle\">\n"
	    "<bsdf type=\"principledthin\">\n<float name=\"clearcoat\" "
	    "value=\"1\"/></bsdf></shape></scene>", 3, "clearcoat");
}

int
main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_empty_scene_defaults),
		cmocka_unit_test(test_bsdfs),
		cmocka_unit_test(test_composite_bsdfs),
		cmocka_unit_test(test_rough_bsdfs),
		cmocka_unit_test(test_principled_bsdfs),
		cmocka_unit_test(test_shapes),
		cmocka_unit_test(test_meshes),
		cmocka_unit_test(test_emitters),
		cmocka_unit_test(test_spectra),
		cmocka_unit_test(test_envmap_directional),
		cmocka_unit_test(test_sensor),
		cmocka_unit_test(test_integrators),
		cmocka_unit_test(test_defaults_and_defines),
		cmocka_unit_test(test_forward_refs),
		cmocka_unit_test(test_include),
		cmocka_unit_test(test_transform_order),
		cmocka_unit_test(test_errors),
		cmocka_unit_test(test_scene_params),
		cmocka_unit_test(test_cbox),
	};

	return cmocka_run_group_tests(tests, pm_tmpdir_setup, pm_tmpdir_teardown);
}
