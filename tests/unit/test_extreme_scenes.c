/*
 * test_extreme_scenes.c: hard but valid scenes, each rendered or shot end to
 * end from Mitsuba XML, must give finite and correct results with no
 * sample or photon dropped:
 *
 *  - the same scene at millimetre, metre and kilometre scale renders the
 *    same image (ray offsets scale with the scene: no acne, no leaks);
 *  - dielectrics are lossless, so nested, touching and index-1 glass in a
 *    uniform environment (a furnace) leaves every pixel at the
 *    environment's radiance; rough glass nearly so, and never above;
 *  - a tiny sphere light converges to the point light of equal intensity;
 *    a huge one (radius 1e5) is a furnace;
 *  - a point light inside a closed glass sphere loses no photon flux;
 *  - grazing, total internal reflection and an index of 1 in every BSDF;
 *  - degenerate meshes (zero-area and needle triangles, duplicate
 *    vertices, zero-length normals in the file, normals that cancel).
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <cmocka.h>

#include "../../common/render.h"
#include "../../common/shoot.h"
#include "../../common/world.h"
#include "../../formats/scene_xml.h"
#include "tmpdir.h"

struct world {
	struct pm_scene scene;
	struct pm_world world;
	struct pm_render_ctx ctx;
};

static void
world_load(struct world *w, const char *xml)
{
	struct pm_error err;

	memset(w, 0, sizeof(*w));
	if (pm_scene_load_string(xml, strlen(xml), "hard.xml", pm_test_dir, NULL, 0,
	    &w->scene, &err) != PM_OK) {
		print_error("%s\n", err.msg);
		fail();
	}
	assert_int_equal(pm_world_init(&w->world, &w->scene, &err), PM_OK);
	w->ctx.scene = &w->scene;
	w->ctx.accel = w->world.accel;
	w->ctx.lights = &w->world.lights;
	w->ctx.max_depth = w->scene.integrator.max_depth;
	w->ctx.rr_depth = w->scene.integrator.rr_depth;
	w->ctx.hide_emitters = w->scene.integrator.hide_emitters;
}

static void
world_free(struct world *w)
{
	pm_world_free(&w->world);
	pm_scene_free(&w->scene);
}

/* Path-traces the scene's camera; asserts that nothing was dropped and
 * every pixel is finite; returns the image and its mean. */
static void
render(struct world *w, struct pm_image *im, double mean[3])
{
	struct pm_render_opts o;
	struct pm_render_stats st;
	struct pm_error err;
	size_t i, n;

	memset(&o, 0, sizeof(o));
	o.method = PM_METHOD_PATH;
	o.spp = w->scene.camera.spp;
	o.seed = 11;
	o.threads = 2;
	assert_int_equal(pm_render(&w->ctx, &w->scene.camera, &o, im, &st, &err),
	    PM_OK);
	assert_int_equal(st.dropped, 0);
	n = (size_t)im->width * (size_t)im->height;
	mean[0] = mean[1] = mean[2] = 0.0;
	for (i = 0; i < n; i++) {
		int c;

		for (c = 0; c < 3; c++) {
			assert_true(isfinite(im->rgb[3 * i + c]));
			assert_true(im->rgb[3 * i + c] >= 0.0f);
			mean[c] += im->rgb[3 * i + c];
		}
	}
	for (i = 0; i < 3; i++)
		mean[i] /= (double)n;
}

/* The Cornell-like box of data/cornell-box.xml, closed, with a sphere light
 * and a glass and a diffuse sphere, every shape scaled by s about the
 * origin and the camera moved to match. */
static char *
box_xml(double s)
{
	static char buf[8192];

	snprintf(buf, sizeof(buf),
	    "<scene version=\"3.0.0\">\n"
	    "<integrator type=\"path\"/>\n"
	    "<sensor type=\"perspective\">\n"
	    " <float name=\"fov\" value=\"75\"/>\n"
	    " <float name=\"near_clip\" value=\"%.9g\"/>\n"
	    " <float name=\"far_clip\" value=\"%.9g\"/>\n"
	    " <transform name=\"to_world\"><lookat origin=\"0, %.9g, %.9g\" "
	    "target=\"0, %.9g, 0\" up=\"0, 1, 0\"/></transform>\n"
	    " <sampler type=\"independent\"><integer name=\"sample_count\" "
	    "value=\"16\"/></sampler>\n"
	    " <film type=\"hdrfilm\"><integer name=\"width\" value=\"32\"/>"
	    "<integer name=\"height\" value=\"32\"/></film>\n"
	    "</sensor>\n"
	    "<bsdf type=\"diffuse\" id=\"white\"><rgb name=\"reflectance\" "
	    "value=\"0.7\"/></bsdf>\n"
	    "<bsdf type=\"diffuse\" id=\"red\"><rgb name=\"reflectance\" "
	    "value=\"0.6, 0.1, 0.1\"/></bsdf>\n"
	    "<bsdf type=\"dielectric\" id=\"glass\"/>\n"
	    "<shape type=\"cube\"><boolean name=\"flip_normals\" value=\"true\"/>\n"
	    " <transform name=\"to_world\"><translate y=\"1\"/><scale value=\"%.9g\"/>"
	    "</transform><ref id=\"white\"/></shape>\n"
	    "<shape type=\"rectangle\"><transform name=\"to_world\">"
	    "<rotate y=\"1\" angle=\"90\"/><translate x=\"-0.999\" y=\"1\"/>"
	    "<scale value=\"%.9g\"/></transform><ref id=\"red\"/></shape>\n"
	    "<shape type=\"sphere\"><point name=\"center\" x=\"%.9g\" y=\"%.9g\" "
	    "z=\"0\"/><float name=\"radius\" value=\"%.9g\"/><ref id=\"glass\"/>"
	    "</shape>\n"
	    "<shape type=\"sphere\"><point name=\"center\" x=\"%.9g\" y=\"%.9g\" "
	    "z=\"%.9g\"/><float name=\"radius\" value=\"%.9g\"/><ref id=\"white\"/>"
	    "</shape>\n"
	    "<shape type=\"sphere\"><point name=\"center\" x=\"0\" y=\"%.9g\" "
	    "z=\"0\"/><float name=\"radius\" value=\"%.9g\"/>\n"
	    " <emitter type=\"area\"><rgb name=\"radiance\" value=\"20\"/></emitter>"
	    "</shape>\n"
	    "</scene>\n",
	    0.01 * s, 100.0 * s, 1.0 * s, 0.95 * s, 1.0 * s,
	    s, s,
	    0.4 * s, 0.35 * s, 0.35 * s,
	    -0.4 * s, 0.3 * s, -0.3 * s, 0.3 * s,
	    1.7 * s, 0.15 * s);
	return buf;
}

/* Millimetres to kilometres: the same random numbers give the same
 * image, up to the float rounding of positions. */
static void
test_scale_invariance(void **state)
{
	static const double scales[] = {1e-3, 1e3, 1.0};
	struct pm_image im[3];
	double mean[3][3], diff = 0.0;
	size_t i, k, n;

	(void)state;
	for (i = 0; i < 3; i++) {
		struct world w;

		world_load(&w, box_xml(scales[i]));
		render(&w, &im[i], mean[i]);
		world_free(&w);
	}
	for (i = 0; i < 2; i++) {
		/* Pixel by pixel too: acne darkens or speckles, a leak
		 * brightens edges; either moves many pixels a lot. */
		n = (size_t)im[2].width * (size_t)im[2].height * 3;
		diff = 0.0;
		for (k = 0; k < n; k++)
			diff += fabs(im[i].rgb[k] - im[2].rgb[k]);
		print_message("scale %g: mean %.5f %.5f %.5f (scale 1: %.5f %.5f "
		    "%.5f), mean absolute pixel difference %.5f\n", scales[i],
		    mean[i][0], mean[i][1], mean[i][2], mean[2][0], mean[2][1],
		    mean[2][2], diff / (double)n);
		for (k = 0; k < 3; k++)
			assert_true(fabs(mean[i][k] - mean[2][k]) <= 0.02 * mean[2][k]);
		assert_true(diff / (double)n <= 0.05 * (mean[2][0] + mean[2][1] +
		    mean[2][2]) / 3.0);
	}
	for (i = 0; i < 3; i++)
		pm_image_free(&im[i]);
}

/* A camera inside a uniform environment of radiance 1 looking at lossless
 * dielectrics sees 1 everywhere, whatever the nesting. */
static void
test_dielectric_furnace(void **state)
{
	static const char *shapes[] = {
		/* nested: a sphere of 1.33 inside one of 1.5 */
		"<shape type=\"sphere\"><float name=\"radius\" value=\"1\"/>"
		"<bsdf type=\"dielectric\"><float name=\"int_ior\" value=\"1.5\"/>"
		"</bsdf></shape>"
		"<shape type=\"sphere\"><float name=\"radius\" value=\"0.5\"/>"
		"<bsdf type=\"dielectric\"><float name=\"int_ior\" value=\"1.33\"/>"
		"<float name=\"ext_ior\" value=\"1.5\"/></bsdf></shape>",
		/* touching at one point */
		"<shape type=\"sphere\"><point name=\"center\" x=\"-0.5\" y=\"0\" "
		"z=\"0\"/><float name=\"radius\" value=\"0.5\"/>"
		"<bsdf type=\"dielectric\"/></shape>"
		"<shape type=\"sphere\"><point name=\"center\" x=\"0.5\" y=\"0\" "
		"z=\"0\"/><float name=\"radius\" value=\"0.5\"/>"
		"<bsdf type=\"dielectric\"/></shape>",
		/* an index of refraction of 1, a thin sheet, a glass cube */
		"<shape type=\"sphere\"><float name=\"radius\" value=\"1\"/>"
		"<bsdf type=\"dielectric\"><float name=\"int_ior\" value=\"1\"/>"
		"<float name=\"ext_ior\" value=\"1\"/></bsdf></shape>"
		"<shape type=\"rectangle\"><bsdf type=\"thindielectric\"/></shape>"
		"<shape type=\"cube\"><transform name=\"to_world\"><scale value=\"0.3\"/>"
		"</transform><bsdf type=\"dielectric\"/></shape>",
	};
	size_t i;

	(void)state;
	for (i = 0; i < sizeof(shapes) / sizeof(shapes[0]); i++) {
		char xml[4096];
		struct world w;
		struct pm_image im;
		double m[3];

		snprintf(xml, sizeof(xml),
		    "<scene version=\"3.0.0\"><integrator type=\"path\"/>"
		    "<sensor type=\"perspective\"><float name=\"fov\" value=\"40\"/>"
		    "<transform name=\"to_world\"><lookat origin=\"0.3, 0.2, 4\" "
		    "target=\"0, 0, 0\" up=\"0, 1, 0\"/></transform>"
		    "<sampler type=\"independent\"><integer name=\"sample_count\" "
		    "value=\"16\"/></sampler><film type=\"hdrfilm\">"
		    "<integer name=\"width\" value=\"24\"/><integer name=\"height\" "
		    "value=\"24\"/></film></sensor>"
		    "<emitter type=\"constant\"><rgb name=\"radiance\" value=\"1\"/>"
		    "</emitter>%s</scene>", shapes[i]);
		world_load(&w, xml);
		render(&w, &im, m);
		print_message("dielectric furnace %zu: %.5f %.5f %.5f\n", i, m[0],
		    m[1], m[2]);
		/* Roulette (q <= 0.95) and paths trapped by total internal
		 * reflection add noise but no bias. */
		assert_true(fabs(m[0] - 1.0) < 0.03 && fabs(m[1] - 1.0) < 0.03 &&
		    fabs(m[2] - 1.0) < 0.03);
		pm_image_free(&im);
		world_free(&w);
	}
}

/* Rough glass in the same furnace: Walter's model scatters once between
 * microfacets, so masking loses light, little at low roughness (the
 * sphere then looks like clear glass: 1 within the noise allowed above)
 * and more at high roughness, but it never makes light: never above 1. */
static void
test_rough_dielectric_furnace(void **state)
{
	static const struct {
		const char *bsdf;
		double lo, hi;
	} cases[] = {
		{ "<bsdf type=\"roughdielectric\"><float name=\"alpha\" "
		  "value=\"0.02\"/></bsdf>", 0.97, 1.03 },
		{ "<bsdf type=\"roughdielectric\"><string name=\"distribution\" "
		  "value=\"ggx\"/><float name=\"alpha\" value=\"0.02\"/>"
		  "</bsdf>", 0.97, 1.03 },
		{ "<bsdf type=\"roughdielectric\"><string name=\"distribution\" "
		  "value=\"ggx\"/><float name=\"alpha\" value=\"0.6\"/>"
		  "<float name=\"int_ior\" value=\"1.33\"/></bsdf>", 0.5, 1.0 },
	};
	size_t i;

	(void)state;
	for (i = 0; i < sizeof(cases) / sizeof(cases[0]); i++) {
		char xml[4096];
		struct world w;
		struct pm_image im;
		double m[3];

		snprintf(xml, sizeof(xml),
		    "<scene version=\"3.0.0\"><integrator type=\"path\"/>"
		    "<sensor type=\"perspective\"><float name=\"fov\" value=\"30\"/>"
		    "<transform name=\"to_world\"><lookat origin=\"0.3, 0.2, 4\" "
		    "target=\"0, 0, 0\" up=\"0, 1, 0\"/></transform>"
		    "<sampler type=\"independent\"><integer name=\"sample_count\" "
		    "value=\"16\"/></sampler><film type=\"hdrfilm\">"
		    "<integer name=\"width\" value=\"24\"/><integer name=\"height\" "
		    "value=\"24\"/></film></sensor>"
		    "<emitter type=\"constant\"><rgb name=\"radiance\" value=\"1\"/>"
		    "</emitter><shape type=\"sphere\"><float name=\"radius\" "
		    "value=\"1\"/>%s</shape></scene>", cases[i].bsdf);
		world_load(&w, xml);
		render(&w, &im, m);
		print_message("rough dielectric furnace %zu: %.5f %.5f %.5f\n", i,
		    m[0], m[1], m[2]);
		assert_true(m[1] >= cases[i].lo && m[1] <= cases[i].hi);
		assert_true(fabs(m[0] - m[1]) < 1e-6 && fabs(m[2] - m[1]) < 1e-6);
		pm_image_free(&im);
		world_free(&w);
	}
}

/* A diffuse floor under a light 1 above it: a point light of intensity I,
 * or a sphere light of radius r and radiance I / (pi r^2). */
static char *
lit_floor_xml(const char *light)
{
	static char buf[4096];

	snprintf(buf, sizeof(buf),
	    "<scene version=\"3.0.0\"><integrator type=\"path\">"
	    "<boolean name=\"hide_emitters\" value=\"true\"/></integrator>"
	    "<sensor type=\"perspective\"><float name=\"fov\" value=\"60\"/>"
	    "<transform name=\"to_world\"><lookat origin=\"0, 2, 2\" "
	    "target=\"0, 0, 0\" up=\"0, 1, 0\"/></transform>"
	    "<sampler type=\"independent\"><integer name=\"sample_count\" "
	    "value=\"32\"/></sampler><film type=\"hdrfilm\">"
	    "<integer name=\"width\" value=\"32\"/><integer name=\"height\" "
	    "value=\"32\"/></film></sensor>"
	    "<shape type=\"rectangle\"><transform name=\"to_world\">"
	    "<rotate x=\"1\" angle=\"-90\"/><scale value=\"3\"/></transform>"
	    "<bsdf type=\"diffuse\"/></shape>%s</scene>", light);
	return buf;
}

static void
test_tiny_light_is_point_light(void **state)
{
	static const double radii[] = {1e-2, 1e-4};
	struct world w;
	struct pm_image im;
	double ref[3], m[3];
	size_t i;

	(void)state;
	world_load(&w, lit_floor_xml("<emitter type=\"point\"><point "
	    "name=\"position\" x=\"0\" y=\"1\" z=\"0\"/><rgb name=\"intensity\" "
	    "value=\"2\"/></emitter>"));
	render(&w, &im, ref);
	pm_image_free(&im);
	world_free(&w);
	for (i = 0; i < 2; i++) {
		char light[512];
		double r = radii[i];

		snprintf(light, sizeof(light), "<shape type=\"sphere\"><point "
		    "name=\"center\" x=\"0\" y=\"1\" z=\"0\"/><float name=\"radius\" "
		    "value=\"%.9g\"/><emitter type=\"area\"><rgb name=\"radiance\" "
		    "value=\"%.9g\"/></emitter></shape>", r, 2.0 / (M_PI * r * r));
		world_load(&w, lit_floor_xml(light));
		render(&w, &im, m);
		print_message("sphere light r=%g: %.5f (point light %.5f)\n", r, m[0],
		    ref[0]);
		assert_true(fabs(m[0] - ref[0]) <= 0.02 * ref[0]);
		pm_image_free(&im);
		world_free(&w);
	}
}

/* A dim point light under a bright environment, whose power is taken over
 * the scene's bounding sphere: light samples still pick the point light at
 * a quarter of the time (half by power, half uniformly over the two; by
 * power alone, well under 1%), and every sample's density is the one
 * the MIS weights use. */
static void
test_small_light_beside_environment(void **state)
{
	struct world w;
	struct pm_light_sample ls;
	int n = 4000, i, picked = 0, env = -1;

	(void)state;
	world_load(&w, lit_floor_xml("<emitter type=\"point\"><point "
	    "name=\"position\" x=\"0\" y=\"1\" z=\"0\"/><rgb name=\"intensity\" "
	    "value=\"0.05\"/></emitter><emitter type=\"constant\">"
	    "<rgb name=\"radiance\" value=\"2\"/></emitter>"));
	for (i = 0; i < (int)w.scene.nlights; i++)
		if (w.scene.lights[i].type == PM_LIGHT_CONSTANT)
			env = i;
	assert_true(env >= 0);
	for (i = 0; i < n; i++) {
		float u0 = ((float)i + 0.5f) / (float)n;

		assert_true(pm_lights_sample(&w.world.lights, &w.scene,
		    pm_v3(0.1f, 0.0f, 0.2f), u0, 0.3f, 0.7f, &ls));
		if (ls.light != env)
			picked++;
		else
			assert_true(fabsf(ls.pdf - pm_lights_pdf_env(
			    &w.world.lights, &w.scene, ls.wi)) <= 1e-6f * ls.pdf);
	}
	print_message("point light picked %d of %d times\n", picked, n);
	assert_true(picked >= (int)(0.24 * n));
	world_free(&w);
}

/* An emitting sphere of radius 1e5 around a diffuse sphere of albedo 0.5:
 * the sphere reflects exactly half the emitted radiance. */
static void
test_huge_light(void **state)
{
	struct world w;
	struct pm_image im;
	double m[3];

	(void)state;
	world_load(&w,
	    "<scene version=\"3.0.0\"><integrator type=\"path\"/>"
	    "<sensor type=\"perspective\"><float name=\"fov\" value=\"8\"/>"
	    "<float name=\"far_clip\" value=\"1e7\"/>"
	    "<transform name=\"to_world\"><lookat origin=\"0, 0, 5\" "
	    "target=\"0, 0, 0\" up=\"0, 1, 0\"/></transform>"
	    "<sampler type=\"independent\"><integer name=\"sample_count\" "
	    "value=\"32\"/></sampler><film type=\"hdrfilm\">"
	    "<integer name=\"width\" value=\"8\"/><integer name=\"height\" "
	    "value=\"8\"/></film></sensor>"
	    "<shape type=\"sphere\"><float name=\"radius\" value=\"1\"/>"
	    "<bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"0.5\"/>"
	    "</bsdf></shape>"
	    "<shape type=\"sphere\"><float name=\"radius\" value=\"1e5\"/>"
	    "<boolean name=\"flip_normals\" value=\"true\"/>"
	    "<bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"0\"/></bsdf>"
	    "<emitter type=\"area\"><rgb name=\"radiance\" value=\"3\"/></emitter>"
	    "</shape></scene>");
	render(&w, &im, m);
	print_message("huge light: %.5f (want 1.5)\n", m[0]);
	assert_true(fabs(m[0] - 1.5) < 0.03 && fabs(m[2] - 1.5) < 0.03);
	pm_image_free(&im);
	world_free(&w);
}

/*
 * A point light of intensity I inside a glass sphere inside a black
 * diffuse sphere: every photon path leaves the glass (no internal
 * reflection can trap it: the light is too near the centre) and is stored
 * once on the black sphere, so the stored flux sums to 4 pi I exactly per
 * path shot.  The sum is taken in double over every photon.
 */
static void
test_light_inside_glass(void **state)
{
	struct world w;
	struct pm_shooter sh;
	struct pm_shoot_opts so;
	struct pm_shoot_stats st;
	struct pm_photon_buf buf = {NULL, 0, 0};
	struct pm_error err;
	double sum[3] = {0, 0, 0}, want = 4.0 * M_PI * 2.0;
	size_t i;

	(void)state;
	world_load(&w,
	    "<scene version=\"3.0.0\"><integrator type=\"path\"/>"
	    "<shape type=\"sphere\"><float name=\"radius\" value=\"1\"/>"
	    "<bsdf type=\"dielectric\"><float name=\"int_ior\" value=\"1.5\"/>"
	    "</bsdf></shape>"
	    "<shape type=\"sphere\"><float name=\"radius\" value=\"5\"/>"
	    "<boolean name=\"flip_normals\" value=\"true\"/>"
	    "<bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"0\"/></bsdf>"
	    "</shape>"
	    "<emitter type=\"point\"><point name=\"position\" x=\"0.3\" y=\"0.2\" "
	    "z=\"0\"/><rgb name=\"intensity\" value=\"2\"/></emitter></scene>");
	assert_int_equal(pm_shooter_init(&sh, &w.scene, w.world.accel,
	    &w.world.lights, &err), PM_OK);
	memset(&so, 0, sizeof(so));
	so.pass = PM_PASS_GLOBAL;
	so.seed = 5;
	so.count = 200000;
	so.max_depth = -1;
	so.threads = 2;
	assert_int_equal(pm_shoot(&sh, &so, &buf, &st, &err), PM_OK);
	assert_int_equal(st.dropped, 0);
	for (i = 0; i < buf.n; i++) {
		struct pm_rgb c = pm_rgbe_unpack(buf.p[i].power);

		assert_true(isfinite(c.r) && isfinite(c.g) && isfinite(c.b));
		sum[0] += c.r;
		sum[1] += c.g;
		sum[2] += c.b;
	}
	print_message("light in glass: %zu photons from %llu paths, flux %.6f "
	    "(want %.6f)\n", buf.n, (unsigned long long)so.count,
	    sum[0] / (double)so.count, want);
	/* One photon per path; RGBE dithering is unbiased. */
	assert_int_equal(buf.n, so.count);
	for (i = 0; i < 3; i++)
		assert_true(fabs(sum[i] / (double)so.count - want) < 2e-3 * want);
	pm_photon_buf_free(&buf);
	pm_shooter_free(&sh);
	world_free(&w);
}

static bool
finite_sample(const struct pm_bsdf_sample *s)
{
	return isfinite(s->wo.x) && isfinite(s->wo.y) && isfinite(s->wo.z) &&
	    fabsf(pm_length(s->wo) - 1.0f) < 1e-3f && isfinite(s->pdf) &&
	    s->pdf >= 0.0f && isfinite(s->weight.r) && isfinite(s->weight.g) &&
	    isfinite(s->weight.b) && s->weight.r >= 0.0f && isfinite(s->eta);
}

/* Every BSDF at grazing and below-horizon directions: finite or refused. */
static void
test_bsdfs_grazing(void **state)
{
	static const float zs[] = {1.0f, 0.5f, 1e-3f, 1e-7f, 0.0f, -0.0f, -1e-7f,
	    -1e-3f, -0.7f, -1.0f};
	struct pm_bsdf b[8];
	struct pm_rng rng = pm_rng_seed(1, 2, 3);
	size_t nb = 0, i, j, k;

	(void)state;
	memset(b, 0, sizeof(b));
	b[nb].type = PM_BSDF_DIFFUSE;
	b[nb++].diffuse = pm_rgb1(0.8f);
	b[nb].type = PM_BSDF_CONDUCTOR;
	b[nb].specular = pm_rgb1(1.0f);
	b[nb].eta = pm_rgb(0.2f, 0.9f, 1.1f);
	b[nb++].k = pm_rgb(3.9f, 2.4f, 2.2f);
	b[nb] = b[1];
	b[nb].type = PM_BSDF_ROUGHCONDUCTOR;
	b[nb].alpha = 0.01f;
	b[nb++].sample_visible = true;
	for (k = 0; k < 3; k++) {	/* glass, index 1, the inverse index */
		b[nb].type = PM_BSDF_DIELECTRIC;
		b[nb].specular = b[nb].transmittance = pm_rgb1(1.0f);
		b[nb++].ior = k == 0 ? 1.5f : k == 1 ? 1.0f : 1.0f / 1.5f;
	}
	b[nb].type = PM_BSDF_THINDIELECTRIC;
	b[nb].specular = b[nb].transmittance = pm_rgb1(1.0f);
	b[nb++].ior = 1.5f;
	b[nb].type = PM_BSDF_PLASTIC;
	b[nb].diffuse = pm_rgb1(0.5f);
	b[nb].specular = pm_rgb1(1.0f);
	b[nb++].ior = 1.5f;
	for (i = 0; i < nb; i++) {
		pm_bsdf_prepare(&b[i]);
		for (j = 0; j < sizeof(zs) / sizeof(zs[0]); j++) {
			float z = zs[j], r = sqrtf(fmaxf(0.0f, 1.0f - z * z));
			struct pm_vec3 wi = pm_v3(r, 0.0f, z);

			for (k = 0; k < 200; k++) {
				struct pm_bsdf_sample s;
				struct pm_vec3 wo = pm_square_to_uniform_sphere(
				    pm_rng_float(&rng), pm_rng_float(&rng));
				struct pm_rgb f;
				float pdf;
				int mode;

				for (mode = 0; mode < 2; mode++) {
					f = pm_bsdf_eval(&b[i], wi, wo, mode ? PM_IMPORTANCE :
					    PM_RADIANCE);
					assert_true(isfinite(f.r) && isfinite(f.g) &&
					    isfinite(f.b) && f.r >= 0.0f);
					if (pm_bsdf_sample(&b[i], wi, pm_rng_float(&rng),
					    pm_rng_float(&rng), pm_rng_float(&rng),
					    mode ? PM_IMPORTANCE : PM_RADIANCE, &s) &&
					    !finite_sample(&s)) {
						print_error("bsdf %zu wi.z %g: wo %g %g %g pdf "
						    "%g weight %g\n", i, (double)z,
						    (double)s.wo.x, (double)s.wo.y,
						    (double)s.wo.z, (double)s.pdf,
						    (double)s.weight.r);
						fail();
					}
				}
				pdf = pm_bsdf_pdf(&b[i], wi, wo);
				assert_true(isfinite(pdf) && pdf >= 0.0f);
			}
		}
	}
}

/* Total internal reflection: from inside glass beyond the critical angle
 * every sample reflects, mirror-like, with weight 1; at an index of 1
 * every sample goes straight through with weight 1. */
static void
test_tir_and_index_one(void **state)
{
	struct pm_bsdf glass, air;
	struct pm_rng rng = pm_rng_seed(4, 5, 6);
	/* sin 50 degrees = 0.766 > 1 / 1.5: beyond the critical angle */
	struct pm_vec3 wi = pm_v3(sinf(0.8727f), 0.0f, -cosf(0.8727f));
	int k;

	(void)state;
	memset(&glass, 0, sizeof(glass));
	glass.type = PM_BSDF_DIELECTRIC;
	glass.specular = glass.transmittance = pm_rgb1(1.0f);
	glass.ior = 1.5f;
	air = glass;
	air.ior = 1.0f;
	pm_bsdf_prepare(&glass);
	pm_bsdf_prepare(&air);
	for (k = 0; k < 1000; k++) {
		struct pm_bsdf_sample s;
		float u1 = pm_rng_float(&rng), u2 = pm_rng_float(&rng);
		float u3 = pm_rng_float(&rng);

		assert_true(pm_bsdf_sample(&glass, wi, u1, u2, u3, PM_RADIANCE, &s));
		assert_true(s.lobe == PM_LOBE_DELTA_REFLECTION);
		assert_true(fabsf(s.wo.x + wi.x) < 1e-5f && fabsf(s.wo.z - wi.z) < 1e-5f);
		assert_true(fabsf(s.weight.r - 1.0f) < 1e-5f);
		assert_true(pm_bsdf_sample(&air, wi, u1, u2, u3, PM_RADIANCE, &s));
		assert_true(s.lobe == PM_LOBE_DELTA_TRANSMISSION);
		assert_true(fabsf(s.wo.x + wi.x) < 1e-5f && fabsf(s.wo.z + wi.z) < 1e-5f);
		assert_true(fabsf(s.weight.r - 1.0f) < 1e-5f);
	}
}

static void
write_file(const char *name, const char *text)
{
	char path[128];
	FILE *f;

	snprintf(path, sizeof(path), "%s/%s", pm_test_dir, name);
	f = fopen(path, "w");
	assert_non_null(f);
	fputs(text, f);
	assert_int_equal(fclose(f), 0);
}

/*
 * Degenerate geometry in files: zero-area triangles (a repeated vertex,
 * three collinear vertices) are dropped and counted; needle triangles and
 * duplicate vertices stay; normals of zero length in the file, and
 * computed normals that cancel (a two-sided sheet of coincident faces),
 * still shade and light finitely.
 */
static void
test_degenerate_meshes(void **state)
{
	struct world w;
	struct pm_image im;
	double m[3];
	size_t i, j;

	(void)state;
	write_file("degenerate.obj",
	    "v -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 0 1\n"
	    "v -1 0 -1\n"			/* 5: a duplicate of 1 */
	    "v 0 0 0\nv 0.5 0 0\nv 1 0 0\n"	/* 6-8: collinear */
	    "v -1 0.5 0\nv 1 0.5 0\nv 1 0.5000001 0\n"	/* 9-11: a needle */
	    "f 1 3 2\nf 5 4 3\n"		/* the floor, one corner duplicated */
	    "f 1 1 2\n"				/* repeated vertex */
	    "f 6 7 8\n"				/* collinear */
	    "f 9 10 11\n");
	write_file("zero-normals.obj",
	    "v -0.3 0.3 -0.3\nv 0.3 0.3 -0.3\nv 0.3 0.3 0.3\n"
	    "vn 0 0 0\nvn 0 0 0\nvn 0 1 0\n"
	    "f 1//1 3//3 2//2\n");
	/* Both windings of one triangle: the angle-weighted normals cancel. */
	write_file("cancel.ply",
	    "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
	    "property float y\nproperty float z\nelement face 2\n"
	    "property list uchar int vertex_indices\nend_header\n"
	    "-0.5 0.8 -0.5\n0.5 0.8 -0.5\n0 0.8 0.5\n3 0 2 1\n3 0 1 2\n");
	world_load(&w,
	    "<scene version=\"3.0.0\"><integrator type=\"path\"/>"
	    "<sensor type=\"perspective\"><float name=\"fov\" value=\"60\"/>"
	    "<transform name=\"to_world\"><lookat origin=\"0, 2, 2\" "
	    "target=\"0, 0, 0\" up=\"0, 1, 0\"/></transform>"
	    "<sampler type=\"independent\"><integer name=\"sample_count\" "
	    "value=\"8\"/></sampler><film type=\"hdrfilm\">"
	    "<integer name=\"width\" value=\"24\"/><integer name=\"height\" "
	    "value=\"24\"/></film></sensor>"
	    "<shape type=\"obj\"><string name=\"filename\" "
	    "value=\"degenerate.obj\"/><bsdf type=\"diffuse\"/></shape>"
	    "<shape type=\"obj\"><string name=\"filename\" "
	    "value=\"zero-normals.obj\"/><bsdf type=\"plastic\"/></shape>"
	    "<shape type=\"ply\"><string name=\"filename\" value=\"cancel.ply\"/>"
	    "<boolean name=\"face_normals\" value=\"false\"/>"
	    "<bsdf type=\"diffuse\"/></shape>"
	    "<emitter type=\"point\"><point name=\"position\" x=\"0\" y=\"1.5\" "
	    "z=\"0.2\"/><rgb name=\"intensity\" value=\"3\"/></emitter>"
	    "<emitter type=\"constant\"><rgb name=\"radiance\" value=\"0.2\"/>"
	    "</emitter></scene>");
	print_message("dropped triangles: %zu\n", w.scene.dropped_triangles);
	assert_int_equal(w.scene.dropped_triangles, 2);
	for (i = 0; i < w.scene.nshapes; i++) {
		const struct pm_mesh *me = &w.scene.shapes[i].mesh;

		if (me->nrm == NULL)
			continue;
		for (j = 0; j < me->nverts; j++) {
			struct pm_vec3 n = pm_v3(me->nrm[3 * j], me->nrm[3 * j + 1],
			    me->nrm[3 * j + 2]);

			/* a normal is unit, or zero for "use the face's" */
			assert_true(isfinite(n.x) && isfinite(n.y) && isfinite(n.z));
			assert_true(fabsf(pm_length(n) - 1.0f) < 1e-3f ||
			    pm_length(n) == 0.0f);
		}
	}
	render(&w, &im, m);
	print_message("degenerate meshes: mean %.5f\n", m[0]);
	assert_true(m[0] > 0.0);
	pm_image_free(&im);
	{
		struct pm_shooter sh;
		struct pm_shoot_opts so;
		struct pm_shoot_stats st;
		struct pm_photon_buf buf = {NULL, 0, 0};
		struct pm_error err;

		assert_int_equal(pm_shooter_init(&sh, &w.scene, w.world.accel,
		    &w.world.lights, &err), PM_OK);
		memset(&so, 0, sizeof(so));
		so.pass = PM_PASS_GLOBAL;
		so.count = 20000;
		so.max_depth = -1;
		so.threads = 2;
		assert_int_equal(pm_shoot(&sh, &so, &buf, &st, &err), PM_OK);
		assert_int_equal(st.dropped, 0);
		assert_true(buf.n > 0);
		pm_photon_buf_free(&buf);
		pm_shooter_free(&sh);
	}
	world_free(&w);
}

int
main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_scale_invariance),
		cmocka_unit_test(test_dielectric_furnace),
		cmocka_unit_test(test_rough_dielectric_furnace),
		cmocka_unit_test(test_tiny_light_is_point_light),
		cmocka_unit_test(test_huge_light),
		cmocka_unit_test(test_small_light_beside_environment),
		cmocka_unit_test(test_light_inside_glass),
		cmocka_unit_test(test_bsdfs_grazing),
		cmocka_unit_test(test_tir_and_index_one),
		cmocka_unit_test(test_degenerate_meshes),
	};

	return cmocka_run_group_tests(tests, pm_tmpdir_setup, pm_tmpdir_teardown);
}
