/*
 * test_textured_lights.c: the textures rawconstant, RGBE bitmaps and
 * checkerboards of textures, textured glass, and the textured emitters
 * (area radiance as a texture, the spot's texture, the projector),
 * against what they must give.
 *
 * Textures read back known texels at known uv.  The projector: the
 * irradiance it casts on a plane at z = 1 is pi scale E at each texel's
 * centre (Mitsuba's definition), the irradiance over a plane at z = 2
 * integrates (Monte Carlo, stated standard error) to the power
 * pm_scene_prepare gives it, pi scale mean(E) (2 tan(fov / 2))^2 /
 * aspect, and the photons it emits onto that plane carry that power, as
 * they do from an image black but for one texel (photons drawn by texel).  A
 * bitmap on a rectangle light: the irradiance its light samples estimate
 * at a point equals a quadrature over the light, each sample's value and
 * density equal what a ray along it finds (pm_lights_emitted,
 * pm_lights_pdf_area); a checkerboard on a sphere light inside a closed
 * sphere: the photons' flux sums to pi area mean(L).  The spot's texture
 * follows Mitsuba's uv, in to_world's frame.  mesh_attribute reads a
 * PLY file's vertex and face colours back at hits.
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

#include "../../common/image.h"
#include "../../common/rng.h"
#include "../../common/shoot.h"
#include "../../common/texture.h"
#include "../../common/world.h"
#include "../../formats/exr.h"
#include "../../formats/scene_xml.h"
#include "tmpdir.h"

#define assert_near(a, b, tol) do {					\
	double a_ = (a), b_ = (b);					\
	if (!(fabs(a_ - b_) <= (tol)))					\
		fail_msg("%s = %.9g, expected %.9g within %g", #a,	\
		    a_, b_, (double)(tol));				\
} while (0)

static char tmpdir[64];

/* A 4 x 2 image, every texel different, top row first. */
static const float img4x2[2][4][3] = {
	{{0.1f, 0.2f, 0.3f}, {0.9f, 0.1f, 0.1f}, {0.2f, 0.8f, 0.1f},
	    {0.3f, 0.3f, 0.9f}},
	{{0.5f, 0.5f, 0.5f}, {1.0f, 0.7f, 0.2f}, {0.05f, 0.4f, 0.6f},
	    {0.7f, 0.0f, 0.35f}},
};

static int
setup(void **state)
{
	struct pm_image im = {4, 2, (float *)img4x2};
	struct pm_error err;
	char path[128];
	/* RGBE texels (m * 2^(e - 136)): (1, 0.5, 0.25), (2, 3, 0.5),
	 * (0.125, 0.0625, 1), (4, 0, 1) */
	static const unsigned char rgbe[4][4] = {
		{128, 64, 32, 129}, {64, 96, 16, 131}, {16, 8, 128, 129},
		{128, 0, 32, 131},
	};
	static const char hdr[] = "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n"
	    "-Y 2 +X 2\n";
	FILE *f;

	(void)state;
	if (pm_tmpdir_make(tmpdir, sizeof(tmpdir), "texlight") != 0)
		return -1;
	snprintf(path, sizeof(path), "%s/img.exr", tmpdir);
	if (pm_exr_write(path, &im, false, &err) != PM_OK)
		return -1;
	{
		/* 8 x 4, black but for one texel */
		static float sparse[4][8][3];
		struct pm_image sp = {8, 4, (float *)sparse};

		sparse[1][5][0] = 4.0f;
		sparse[1][5][1] = 2.0f;
		sparse[1][5][2] = 1.0f;
		snprintf(path, sizeof(path), "%s/sparse.exr", tmpdir);
		if (pm_exr_write(path, &sp, false, &err) != PM_OK)
			return -1;
	}
	snprintf(path, sizeof(path), "%s/img.hdr", tmpdir);
	if ((f = fopen(path, "wb")) == NULL)
		return -1;
	fwrite(hdr, 1, sizeof(hdr) - 1, f);
	fwrite(rgbe, 1, sizeof(rgbe), f);
	return fclose(f) == 0 ? 0 : -1;
}

static int
teardown(void **state)
{
	(void)state;
	return pm_tmpdir_remove(tmpdir);
}

static void
load(const char *body, struct pm_scene *s)
{
	char xml[8192];
	struct pm_error err;

	snprintf(xml, sizeof(xml), "<scene version=\"3.0.0\">\n%s</scene>\n",
	    body);
	memset(&err, 0, sizeof(err));
	if (pm_scene_load_string(xml, strlen(xml), "t.xml", tmpdir, NULL, 0, s,
	    &err) != PM_OK)
		fail_msg("%s", err.msg);
}

static void
assert_rgb_near(struct pm_rgb got, double r, double g, double b, double tol)
{
	assert_near(got.r, r, tol);
	assert_near(got.g, g, tol);
	assert_near(got.b, b, tol);
}

static const struct pm_texture *
find_texture(const struct pm_scene *s, const char *name)
{
	size_t i;

	for (i = 0; i < s->ntextures; i++)
		if (strcmp(s->textures[i].name, name) == 0)
			return &s->textures[i];
	fail_msg("no texture %s", name);
	return NULL;
}

/* rawconstant from a float, a <vector> and an <rgb>; an RGBE bitmap and
 * a rawconstant as a checkerboard's colours; textured glass. */
static void
test_textures(void **state)
{
	struct pm_scene s;
	const struct pm_texture *t;
	const struct pm_bsdf *b;
	struct pm_bsdf tmp;
	struct pm_hit h;
	int k;

	(void)state;
	load("<texture type=\"rawconstant\" id=\"f\">"
	    "<float name=\"value\" value=\"0.3\"/></texture>\n"
	    "<texture type=\"rawconstant\" id=\"v\">"
	    "<vector name=\"value\" x=\"0.7\" y=\"0.4\" z=\"2.5\"/></texture>\n"
	    "<texture type=\"rawconstant\" id=\"c\">"
	    "<rgb name=\"value\" value=\"0.1, 0.2, 0.3\"/></texture>\n"
	    "<shape type=\"rectangle\"><bsdf type=\"diffuse\">"
	    "<texture type=\"checkerboard\" name=\"reflectance\">"
	    "<texture type=\"bitmap\" name=\"color0\">"
	    "<string name=\"filename\" value=\"img.hdr\"/>"
	    "<string name=\"filter_type\" value=\"nearest\"/></texture>"
	    "<ref name=\"color1\" id=\"v\"/>"
	    "<transform name=\"to_uv\"><scale x=\"2\" y=\"2\"/></transform>"
	    "</texture></bsdf></shape>\n"
	    "<shape type=\"rectangle\"><bsdf type=\"dielectric\">"
	    "<texture type=\"checkerboard\" name=\"specular_transmittance\">"
	    "<ref name=\"color0\" id=\"c\"/>"
	    "<rgb name=\"color1\" value=\"0.9, 0.8, 0.7\"/></texture>"
	    "<ref name=\"specular_reflectance\" id=\"f\"/>"
	    "</bsdf></shape>\n", &s);
	/* f, v, c, the bitmap, the floor's checkerboard, glass's */
	assert_int_equal(s.ntextures, 6);
	for (k = 0; k < 3; k++) {
		static const float want[3][3] = {{0.3f, 0.3f, 0.3f},
		    {0.7f, 0.4f, 2.5f}, {0.1f, 0.2f, 0.3f}};

		t = find_texture(&s, k == 0 ? "f" : k == 1 ? "v" : "c");
		assert_int_equal(t->type, PM_TEXTURE_CONSTANT);
		assert_rgb_near(pm_texture_eval(t, 0.37f, -4.0f), want[k][0],
		    want[k][1], want[k][2], 1e-7);
		assert_rgb_near(pm_texture_mean(t), want[k][0], want[k][1],
		    want[k][2], 1e-7);
	}
	/* the floor's checkerboard; its color0, the RGBE texels, exactly */
	b = &s.bsdfs[s.shapes[0].bsdf];
	assert_true(b->tex_diffuse > 0);
	t = s.textures[b->tex_diffuse - 1].sub[0];
	assert_non_null(t);
	assert_int_equal(t->width, 2);
	assert_rgb_near(pm_texture_eval(t, 0.25f, 0.25f), 1.0, 0.5, 0.25, 1e-7);
	assert_rgb_near(pm_texture_eval(t, 0.75f, 0.25f), 2.0, 3.0, 0.5, 1e-7);
	assert_rgb_near(pm_texture_eval(t, 0.25f, 0.75f), 0.125, 0.0625, 1.0,
	    0.0);
	assert_rgb_near(pm_texture_eval(t, 0.75f, 0.75f), 4.0, 0.0, 1.0, 1e-7);
	/* the checkerboard (to_uv 2x): color0 is the bitmap at the
	 * surface's own uv, color1 the <vector> */
	t = &s.textures[b->tex_diffuse - 1];
	assert_non_null(t->sub[0]);
	assert_non_null(t->sub[1]);
	assert_rgb_near(pm_texture_eval(t, 0.1f, 0.1f), 1.0, 0.5, 0.25, 1e-7);
	assert_rgb_near(pm_texture_eval(t, 0.3f, 0.1f), 0.7, 0.4, 2.5, 1e-7);
	assert_rgb_near(pm_texture_eval(t, 0.3f, 0.35f), 1.0, 0.5, 0.25, 1e-7);
	assert_rgb_near(pm_texture_eval(t, 0.8f, 0.8f), 4.0, 0.0, 1.0, 1e-7);
	assert_rgb_near(pm_texture_eval(t, 0.8f, 0.6f), 0.7, 0.4, 2.5, 1e-7);
	assert_rgb_near(pm_texture_eval(t, 0.8f, 0.2f), 0.7, 0.4, 2.5, 1e-7);
	/* its mean: half the bitmap's, half the constant */
	assert_rgb_near(pm_texture_mean(t), 0.5 * (7.125 / 4 + 0.7),
	    0.5 * (3.5625 / 4 + 0.4), 0.5 * (2.75 / 4 + 2.5), 1e-6);
	/* glass: its transmittance and reflectance looked up at a hit */
	b = &s.bsdfs[s.shapes[1].bsdf];
	assert_true(b->tex_transmittance > 0 && b->tex_specular > 0);
	memset(&h, 0, sizeof(h));
	h.shape = 1;
	h.prim = 0;	/* (-1,-1) (1,-1) (1,1): uv = ((x+1)/2, (y+1)/2) */
	h.u = 0.1f;	/* weights 0.8, 0.1, 0.1: (-0.6, -0.8), uv (0.2, 0.1) */
	h.v = 0.1f;
	b = pm_bsdf_at(&s, &h, &tmp);
	assert_rgb_near(b->transmittance, 0.1, 0.2, 0.3, 1e-7);
	assert_rgb_near(b->specular, 0.3, 0.3, 0.3, 1e-6);
	h.u = 0.8f;	/* weights 0.1, 0.8, 0.1: (0.8, -0.8), uv (0.9, 0.1) */
	b = pm_bsdf_at(&s, &h, &tmp);
	assert_rgb_near(b->transmittance, 0.9, 0.8, 0.7, 1e-7);
	pm_scene_free(&s);
}

static void
photons(struct pm_scene *s, uint64_t n, struct pm_photon_buf *buf,
    struct pm_world *w)
{
	struct pm_shooter sh;
	struct pm_shoot_opts o = {PM_PASS_GLOBAL, 7, 0, n, 1, 2, NULL, NULL,
	    NULL, NULL};
	struct pm_shoot_stats st;
	struct pm_error err;

	assert_int_equal(pm_world_init(w, s, &err), PM_OK);
	assert_int_equal(pm_shooter_init(&sh, s, w->accel, &w->lights, &err),
	    PM_OK);
	assert_int_equal(pm_shoot(&sh, &o, buf, &st, &err), PM_OK);
	assert_int_equal(st.dropped, 0);
	pm_shooter_free(&sh);
}

/*
 * The projector, at the origin looking along +z (fov 50 along x, scale
 * 2, the 4 x 2 image, nearest), over a diffuse plane at z = 2 facing it.
 */
static void
test_projector(void **state)
{
	struct pm_scene s;
	struct pm_world w;
	struct pm_photon_buf buf = {NULL, 0, 0};
	struct pm_light_sample ls;
	const struct pm_light *l;
	struct pm_rng rng;
	double tan_x = tan(25.0 * M_PI / 180.0), area, want[3] = {0, 0, 0};
	double sum[3] = {0, 0, 0}, sq = 0, half = 2.5 * tan_x, se;
	const uint64_t nph = 100000;
	const int n = 200000;
	int i, x, y, c;
	size_t k;

	(void)state;
	load("<emitter type=\"projector\">"
	    "<texture type=\"bitmap\" name=\"irradiance\">"
	    "<string name=\"filename\" value=\"img.exr\"/>"
	    "<string name=\"filter_type\" value=\"nearest\"/></texture>"
	    "<float name=\"scale\" value=\"2\"/>"
	    "<float name=\"fov\" value=\"50\"/></emitter>\n"
	    "<shape type=\"rectangle\"><transform name=\"to_world\">"
	    "<rotate y=\"1\" angle=\"180\"/><scale value=\"3\"/>"
	    "<translate z=\"2\"/></transform>"
	    "<bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"0.5\"/>"
	    "</bsdf></shape>\n", &s);
	l = &s.lights[0];
	assert_int_equal(l->type, PM_LIGHT_PROJECTOR);
	assert_near(l->tan_fov, tan_x, 1e-6);
	assert_near(l->aspect, 2.0, 0.0);
	area = 4.0 * tan_x * tan_x / 2.0;	/* the image plane at z = 1 */
	for (y = 0; y < 2; y++)
		for (x = 0; x < 4; x++)
			for (c = 0; c < 3; c++)
				want[c] += M_PI * 2.0 * img4x2[y][x][c] / 8.0 *
				    area;
	assert_near(l->power, (want[0] + want[1] + want[2]) / 3.0,
	    1e-6 * l->power);
	{
		struct pm_error err;

		assert_int_equal(pm_world_init(&w, &s, &err), PM_OK);
	}
	/* Each texel's centre on the plane at z = 1 receives pi scale E
	 * (u grows towards -x, v towards -y, as the camera's film). */
	for (y = 0; y < 2; y++)
		for (x = 0; x < 4; x++) {
			float u = (x + 0.5f) / 4.0f, v = (y + 0.5f) / 2.0f;
			struct pm_vec3 p = pm_v3((float)((1.0 - 2.0 * u) *
			    tan_x), (float)((1.0 - 2.0 * v) * tan_x / 2.0), 1.0f);
			float cos_p;

			assert_true(pm_lights_sample(&w.lights, &s, p, 0.5f,
			    0.5f, 0.5f, &ls));
			assert_true(ls.delta);
			cos_p = -ls.wi.z;	/* a plane facing the projector */
			for (c = 0; c < 3; c++)
				assert_near((&ls.value.r)[c] * cos_p,
				    M_PI * 2.0 * img4x2[y][x][c],
				    2e-5 * M_PI * 2.0);
		}
	/* Irradiance over the plane z = 2, points uniform over a square
	 * wider than the image's footprint: it integrates to the power. */
	rng = pm_rng_seed(11, 0, 0);
	for (i = 0; i < n; i++) {
		struct pm_vec3 p = pm_v3((float)((2.0 * pm_rng_double(&rng) -
		    1.0) * half), (float)((2.0 * pm_rng_double(&rng) - 1.0) *
		    half), 2.0f);
		double e[3] = {0, 0, 0};

		if (pm_lights_sample(&w.lights, &s, p, 0.5f, 0.5f, 0.5f, &ls))
			for (c = 0; c < 3; c++)
				e[c] = (&ls.value.r)[c] * -ls.wi.z *
				    (4.0 * half * half);
		for (c = 0; c < 3; c++)
			sum[c] += e[c];
		sq += e[1] * e[1];
	}
	se = sqrt((sq / n - (sum[1] / n) * (sum[1] / n)) / n);
	print_message("projector: irradiance integrates to %.5f %.5f %.5f "
	    "(want %.5f %.5f %.5f, standard error %.5f in G)\n", sum[0] / n,
	    sum[1] / n, sum[2] / n, want[0], want[1], want[2], se);
	for (c = 0; c < 3; c++)
		assert_near(sum[c] / n, want[c], 4.0 * se * want[c] / want[1]);
	pm_world_free(&w);

	/* Photons: every one lands on the plane; their flux sums to the
	 * power. */
	photons(&s, nph, &buf, &w);
	memset(sum, 0, sizeof(sum));
	sq = 0;
	for (k = 0; k < buf.n; k++) {
		struct pm_rgb f = pm_rgbe_unpack(buf.p[k].power);

		if (buf.p[k].depth != 0)
			continue;
		assert_near(buf.p[k].pos[2], 2.0, 1e-3);
		sum[0] += f.r;
		sum[1] += f.g;
		sum[2] += f.b;
		sq += (double)f.g * f.g;
	}
	se = sqrt((sq / nph - (sum[1] / nph) * (sum[1] / nph)) / nph);
	print_message("projector: photons carry %.5f %.5f %.5f (standard "
	    "error %.5f in G)\n", sum[0] / nph, sum[1] / nph, sum[2] / nph, se);
	for (c = 0; c < 3; c++)
		assert_near(sum[c] / nph, want[c], 4.0 * se * want[c] / want[1] +
		    0.01 * want[c]);
	pm_photon_buf_free(&buf);
	pm_world_free(&w);
	pm_scene_free(&s);
}

/*
 * A projector image black but for one texel, filtered bilinearly (light
 * spreads into the black texels' cells, where photons drawn by texel
 * must still reach): the photons' flux still sums to the power, pi
 * scale mean(E) area (bilinear lookups with repeat keep the mean).
 */
static void
test_projector_sparse(void **state)
{
	struct pm_scene s;
	struct pm_world w;
	struct pm_photon_buf buf = {NULL, 0, 0};
	double tan_x = tan(30.0 * M_PI / 180.0), area = 4 * tan_x * tan_x / 2;
	double want[3], sum[3] = {0, 0, 0}, sq = 0, se;
	const uint64_t n = 50000;
	size_t k;
	int c;

	(void)state;
	load("<emitter type=\"projector\">"
	    "<texture type=\"bitmap\" name=\"irradiance\">"
	    "<string name=\"filename\" value=\"sparse.exr\"/></texture>"
	    "<float name=\"fov\" value=\"60\"/>"
	    "<transform name=\"to_world\"><lookat origin=\"0, 0, 0\" "
	    "target=\"0, 0, -1\" up=\"1, 0, 0\"/></transform></emitter>\n"
	    "<shape type=\"rectangle\"><transform name=\"to_world\">"
	    "<scale value=\"4\"/><translate z=\"-2\"/></transform>"
	    "<bsdf type=\"diffuse\"/></shape>\n", &s);
	want[0] = M_PI * 4.0 / 32.0 * area;
	want[1] = M_PI * 2.0 / 32.0 * area;
	want[2] = M_PI * 1.0 / 32.0 * area;
	photons(&s, n, &buf, &w);
	for (k = 0; k < buf.n; k++) {
		struct pm_rgb f = pm_rgbe_unpack(buf.p[k].power);

		if (buf.p[k].depth != 0)
			continue;
		sum[0] += f.r;
		sum[1] += f.g;
		sum[2] += f.b;
		sq += (double)f.r * f.r;
	}
	se = sqrt((sq / n - (sum[0] / n) * (sum[0] / n)) / n);
	print_message("sparse projector: photons carry %.5f %.5f %.5f (want "
	    "%.5f %.5f %.5f; standard error %.5f in R, %.1f%%)\n", sum[0] / n,
	    sum[1] / n, sum[2] / n, want[0], want[1], want[2], se,
	    100.0 * se / want[0]);
	for (c = 0; c < 3; c++)
		assert_near(sum[c] / n, want[c], 4.0 * se * want[c] / want[0] +
		    0.01 * want[c]);
	pm_photon_buf_free(&buf);
	pm_world_free(&w);
	pm_scene_free(&s);
}

/* The 4 x 2 image (nearest, times 3) on a rectangle light 1 above a
 * point, tilted; light samples against a quadrature and against rays. */
static void
test_area_bitmap(void **state)
{
	struct pm_scene s;
	struct pm_world w;
	struct pm_light_sample ls;
	struct pm_rng rng;
	struct pm_vec3 ref = pm_v3(0.3f, -0.2f, 0.0f);
	const struct pm_shape *sh;
	double q[3] = {0, 0, 0}, sum[3] = {0, 0, 0}, sq = 0, se;
	const int n = 200000, grid = 400;
	struct pm_error err;
	int i, j, c, checked = 0;

	(void)state;
	load("<shape type=\"rectangle\"><transform name=\"to_world\">"
	    "<rotate x=\"1\" angle=\"160\"/><translate z=\"1\"/></transform>"
	    "<emitter type=\"area\">"
	    "<texture type=\"bitmap\" name=\"radiance\">"
	    "<string name=\"filename\" value=\"img.exr\"/>"
	    "<string name=\"filter_type\" value=\"nearest\"/>"
	    "</texture></emitter></shape>\n", &s);
	assert_int_equal(pm_world_init(&w, &s, &err), PM_OK);
	sh = &s.shapes[0];
	/* Quadrature: the rectangle in uv, texel-aligned midpoints; the
	 * irradiance on a surface at ref facing +z. */
	for (j = 0; j < grid; j++)
		for (i = 0; i < grid; i++) {
			float u = (i + 0.5f) / grid, v = (j + 0.5f) / grid;
			/* the rectangle's point of uv (u, v): x = 2u - 1,
			 * y = 2v - 1, turned 160 degrees about x */
			float lx = 2 * u - 1, ly = 2 * v - 1;
			float ca = cosf(160.0f * PM_PI / 180.0f);
			float sa = sinf(160.0f * PM_PI / 180.0f);
			struct pm_vec3 p = pm_v3(lx, ly * ca, ly * sa + 1.0f);
			struct pm_vec3 nl = pm_v3(0, -sa, ca);
			struct pm_vec3 d = pm_sub(p, ref);
			double d2 = pm_dot(d, d), dl = sqrt(d2);
			double cos_r = d.z / dl, cos_l = -pm_dot(nl, d) / dl;
			struct pm_rgb L = pm_texture_eval(&s.textures[0], u, v);

			if (cos_l <= 0 || cos_r <= 0)
				continue;
			for (c = 0; c < 3; c++)
				q[c] += (&L.r)[c] * cos_l * cos_r / d2 *
				    (4.0 / grid / grid);
		}
	rng = pm_rng_seed(5, 0, 0);
	for (i = 0; i < n; i++) {
		double e[3] = {0, 0, 0};

		if (pm_lights_sample(&w.lights, &s, ref, pm_rng_float(&rng),
		    pm_rng_float(&rng), pm_rng_float(&rng), &ls) &&
		    ls.wi.z > 0) {
			for (c = 0; c < 3; c++)
				e[c] = (&ls.value.r)[c] * ls.wi.z / ls.pdf;
			/* the ray along the sample finds the same radiance
			 * and the same density */
			if (i % 97 == 0) {
				struct pm_hit h;
				struct pm_rgb le;

				assert_true(pm_accel_intersect(w.accel, ref,
				    ls.wi, 0.0f, INFINITY, &h));
				le = pm_lights_emitted(&w.lights, &s, &h, ls.wi,
				    ref, ls.pdf, true);
				for (c = 0; c < 3; c++)
					assert_near((&le.r)[c], (&ls.value.r)[c],
					    1e-3 * (&ls.value.r)[c] + 1e-6);
				assert_near(pm_lights_pdf_area(&w.lights, &s, 0,
				    ref, h.p, h.ng), ls.pdf, 1e-3 * ls.pdf);
				checked++;
			}
		}
		for (c = 0; c < 3; c++)
			sum[c] += e[c];
		sq += e[1] * e[1];
	}
	assert_true(checked > 1000);
	se = sqrt((sq / n - (sum[1] / n) * (sum[1] / n)) / n);
	print_message("bitmap area light: light samples %.5f %.5f %.5f, "
	    "quadrature %.5f %.5f %.5f (standard error %.5f in G)\n",
	    sum[0] / n, sum[1] / n, sum[2] / n, q[0], q[1], q[2], se);
	for (c = 0; c < 3; c++)
		assert_near(sum[c] / n, q[c], 4.0 * se * q[c] / q[1] +
		    2e-3 * q[c]);
	(void)sh;
	pm_world_free(&w);
	pm_scene_free(&s);
}

/* A checkerboard sphere light (8 sectors in phi by 2 hemispheres, equal
 * areas) inside a closed sphere: photons carry pi area mean(L). */
static void
test_area_photons(void **state)
{
	struct pm_scene s;
	struct pm_world w;
	struct pm_photon_buf buf = {NULL, 0, 0};
	const uint64_t n = 100000;
	double want[3], sum[3] = {0, 0, 0}, sq = 0, se;
	size_t k;
	int c;

	(void)state;
	load("<shape type=\"sphere\"><float name=\"radius\" value=\"0.5\"/>"
	    "<emitter type=\"area\">"
	    "<texture type=\"checkerboard\" name=\"radiance\">"
	    "<rgb name=\"color0\" value=\"4, 1, 0\"/>"
	    "<rgb name=\"color1\" value=\"0, 1, 2\"/>"
	    "<transform name=\"to_uv\"><scale x=\"4\"/></transform>"
	    "</texture></emitter></shape>\n"
	    "<shape type=\"sphere\"><float name=\"radius\" value=\"5\"/>"
	    "<boolean name=\"flip_normals\" value=\"true\"/>"
	    "<bsdf type=\"diffuse\"/></shape>\n", &s);
	want[0] = M_PI * M_PI * 2.0;	/* pi 4 pi r^2 = pi^2 */
	want[1] = M_PI * M_PI * 1.0;
	want[2] = M_PI * M_PI * 1.0;
	assert_near(s.lights[0].power, (want[0] + want[1] + want[2]) / 3.0,
	    1e-3 * s.lights[0].power);
	photons(&s, n, &buf, &w);
	for (k = 0; k < buf.n; k++) {
		struct pm_rgb f = pm_rgbe_unpack(buf.p[k].power);

		if (buf.p[k].depth != 0)
			continue;
		sum[0] += f.r;
		sum[1] += f.g;
		sum[2] += f.b;
		sq += (double)f.r * f.r;
	}
	se = sqrt((sq / n - (sum[0] / n) * (sum[0] / n)) / n);
	print_message("checkerboard sphere light: photons carry %.5f %.5f "
	    "%.5f (want %.5f %.5f %.5f; standard error %.5f in R)\n",
	    sum[0] / n, sum[1] / n, sum[2] / n, want[0], want[1], want[2], se);
	for (c = 0; c < 3; c++)
		assert_near(sum[c] / n, want[c], 4.0 * se * want[c] / want[0] +
		    0.002 * want[c]);
	pm_photon_buf_free(&buf);
	pm_world_free(&w);
	pm_scene_free(&s);
}

/* The spot's texture: uv = 1/2 + (x, y) / (2 z tan(cutoff)) in
 * to_world's frame, here turned 90 degrees about z (local x is world
 * y, local y world -x). */
static void
test_spot_texture(void **state)
{
	struct pm_scene s;
	const struct pm_light *l;
	double t = tan(40.0 * M_PI / 180.0);
	int x, y, c;

	(void)state;
	load("<emitter type=\"spot\"><rgb name=\"intensity\" value=\"2\"/>"
	    "<float name=\"cutoff_angle\" value=\"40\"/>"
	    "<float name=\"beam_width\" value=\"40\"/>"
	    "<texture type=\"bitmap\" name=\"texture\">"
	    "<string name=\"filename\" value=\"img.exr\"/>"
	    "<string name=\"filter_type\" value=\"nearest\"/></texture>"
	    "<transform name=\"to_world\"><rotate z=\"1\" angle=\"90\"/>"
	    "<translate x=\"1\"/></transform></emitter>\n", &s);
	l = &s.lights[0];
	/* the four texels around the centre lie inside the cone */
	for (y = 0; y < 2; y++)
		for (x = 1; x < 3; x++) {
			double u = (x + 0.5) / 4.0, v = (y + 0.5) / 2.0;
			double lx = (2 * u - 1) * t, ly = (2 * v - 1) * t;
			struct pm_vec3 w = pm_normalize(pm_v3((float)-ly,
			    (float)lx, 1.0f));
			struct pm_rgb I;

			if (lx * lx + ly * ly >= t * t)
				continue;
			I = pm_light_intensity(&s, l, w);
			for (c = 0; c < 3; c++)
				assert_near((&I.r)[c], 2.0 * img4x2[y][x][c],
				    1e-5);
		}
	/* outside the cone: nothing */
	assert_true(pm_rgb_is_black(pm_light_intensity(&s, l,
	    pm_normalize(pm_v3(0, 1, 1)))));
	pm_scene_free(&s);
}

/*
 * mesh_attribute: a PLY file's vertex colours (red green blue) and face
 * colours (r g b, on a quad's two triangles and after a degenerate
 * triangle that is dropped) read back, looked up at hits; a shape
 * without the attribute is refused.
 */
static void
test_mesh_attribute(void **state)
{
	static const char ply[] = "ply\nformat ascii 1.0\n"
	    "element vertex 5\nproperty float x\nproperty float y\n"
	    "property float z\nproperty float red\nproperty float green\n"
	    "property float blue\nelement face 2\n"
	    "property uchar r\nproperty list uchar int vertex_indices\n"
	    "property uchar g\nproperty uchar b\nend_header\n"
	    "0 0 0 1 0 0\n1 0 0 0 1 0\n1 1 0 0 0 1\n0 1 0 0.5 0.5 0.5\n"
	    "2 0 0 9 9 9\n"
	    "7 3 0 1 4 8 9\n"		/* degenerate: 0 1 4 in a line */
	    "10 4 0 1 2 3 20 30\n";	/* a quad: two triangles */
	struct pm_scene s;
	struct pm_error err;
	struct pm_bsdf tmp;
	const struct pm_bsdf *b;
	const struct pm_mesh *m;
	struct pm_hit h;
	char path[128], xml[1024];
	FILE *f;

	(void)state;
	snprintf(path, sizeof(path), "%s/attr.ply", tmpdir);
	assert_non_null(f = fopen(path, "w"));
	fputs(ply, f);
	assert_int_equal(fclose(f), 0);
	load("<shape type=\"ply\"><string name=\"filename\" "
	    "value=\"attr.ply\"/><bsdf type=\"diffuse\">"
	    "<texture type=\"mesh_attribute\" name=\"reflectance\">"
	    "<string name=\"name\" value=\"vertex_color\"/>"
	    "<float name=\"scale\" value=\"0.5\"/></texture></bsdf>"
	    "</shape>\n"
	    "<shape type=\"ply\"><string name=\"filename\" "
	    "value=\"attr.ply\"/><bsdf type=\"diffuse\">"
	    "<texture type=\"checkerboard\" name=\"reflectance\">"
	    "<texture type=\"mesh_attribute\" name=\"color0\">"
	    "<string name=\"name\" value=\"face_color\"/></texture>"
	    "<texture type=\"mesh_attribute\" name=\"color1\">"
	    "<string name=\"name\" value=\"face_color\"/></texture>"
	    "</texture></bsdf></shape>\n", &s);
	m = &s.shapes[0].mesh;
	assert_int_equal(m->ntris, 2);
	assert_non_null(m->vcolor);
	assert_non_null(m->fcolor);
	/* 8-bit colours as the file gives them, as Mitsuba 3 keeps them */
	assert_near(m->fcolor[0], 10, 0);
	assert_near(m->fcolor[1], 20, 0);
	assert_near(m->fcolor[5], 30, 0);
	memset(&h, 0, sizeof(h));
	h.shape = 0;
	h.prim = 0;		/* vertices 0 1 2 */
	h.u = 0.25f;
	h.v = 0.5f;
	b = pm_bsdf_at(&s, &h, &tmp);
	assert_rgb_near(b->diffuse, 0.5 * 0.25, 0.5 * 0.25, 0.5 * 0.5, 1e-6);
	h.prim = 1;		/* vertices 0 2 3 */
	h.u = 0.0f;
	h.v = 1.0f;
	b = pm_bsdf_at(&s, &h, &tmp);
	assert_rgb_near(b->diffuse, 0.25, 0.25, 0.25, 1e-6);
	/* face colours, through a checkerboard */
	h.shape = 1;
	b = pm_bsdf_at(&s, &h, &tmp);
	assert_rgb_near(b->diffuse, 10, 20, 30, 0);
	pm_scene_free(&s);

	/* a rectangle has no vertex colours */
	snprintf(xml, sizeof(xml), "<scene version=\"3.0.0\"><shape "
	    "type=\"rectangle\"><bsdf type=\"diffuse\"><texture "
	    "type=\"mesh_attribute\" name=\"reflectance\"><string "
	    "name=\"name\" value=\"vertex_color\"/></texture></bsdf>"
	    "</shape></scene>");
	memset(&err, 0, sizeof(err));
	assert_int_not_equal(pm_scene_load_string(xml, strlen(xml), "t.xml",
	    tmpdir, NULL, 0, &s, &err), PM_OK);
	assert_non_null(strstr(err.msg, "vertex_color"));
}

int
main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_textures),
		cmocka_unit_test(test_projector),
		cmocka_unit_test(test_projector_sparse),
		cmocka_unit_test(test_area_bitmap),
		cmocka_unit_test(test_area_photons),
		cmocka_unit_test(test_spot_texture),
		cmocka_unit_test(test_mesh_attribute),
	};

	return cmocka_run_group_tests(tests, setup, teardown);
}
