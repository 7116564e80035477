/*
 * exrutil.c: makes and measures the small images that the CLI tests of
 * pm-downsample feed it and read back; a test helper, never installed.
 *
 *   exrutil make OUT.exr W H R G B [ramp] [NAME=VALUE...]
 *	writes a W x H float image of colour (R, G, B); with "ramp", x / W
 *	is added to every channel of column x, so that filters have
 *	something to move; each NAME=VALUE becomes a string attribute.
 *   exrutil stat IN.exr
 *	prints "W H meanR meanG meanB min max" with %.9g.
 *   exrutil pngstat IN.png
 *	prints "W H min max" over every byte of the decoded RGB.
 *   exrutil relmse TEST.exr REF.exr
 *	prints the relative mean squared error of TEST against REF, the
 *	mean over pixels and channels of (t - r)^2 / (r^2 + 0.01), and the
 *	relative difference of the means per channel, (mean t - mean r) /
 *	mean r: "relmse dR dG dB".
 *   exrutil attrs IN.exr
 *	prints the string attributes, "NAME<TAB>VALUE" in file order.
 *   exrutil channels IN.exr
 *	prints "NAME<TAB>MEAN" (%.9g) for every channel beside R, G and B,
 *	in the file's order, and for a NAME with an m2_NAME beside it the
 *	smallest m2_NAME - NAME^2 over the pixels as "var(NAME)<TAB>MIN".
 *   exrutil same A.exr B.exr
 *	succeeds if both decode to the same size and the same float pixels,
 *	bit for bit; otherwise names the first difference.
 *
 * Exit status 0 on success, 1 on any failure (with a message on stderr).
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <png.h>

#include "../../common/image.h"
#include "../../formats/exr.h"

int
main(int argc, char **argv)
{
	struct pm_error err;

	if (argc >= 8 && strcmp(argv[1], "make") == 0) {
		struct pm_exr_attrs at = { 0 };
		struct pm_image im;
		int w = atoi(argv[3]), h = atoi(argv[4]), x, y, k, a;
		int ramp = argc > 8 && strcmp(argv[8], "ramp") == 0;
		float c[3];

		for (a = 8 + ramp; a < argc; a++) {
			char *eq = strchr(argv[a], '=');

			if (eq == NULL) {
				fprintf(stderr, "exrutil: %s: expected "
				    "NAME=VALUE\n", argv[a]);
				return 1;
			}
			*eq = '\0';
			if (pm_exr_attrs_set(&at, argv[a], eq + 1, &err) !=
			    PM_OK) {
				fprintf(stderr, "exrutil: %s\n", err.msg);
				return 1;
			}
		}
		for (k = 0; k < 3; k++)
			c[k] = strtof(argv[5 + k], NULL);
		if (pm_image_alloc(&im, w, h, &err) != PM_OK) {
			fprintf(stderr, "exrutil: %s\n", err.msg);
			return 1;
		}
		for (y = 0; y < h; y++)
		for (x = 0; x < w; x++)
		for (k = 0; k < 3; k++)
			im.rgb[((size_t)y * w + x) * 3 + k] = c[k] +
			    (ramp ? (float)x / w : 0.0f);
		if (pm_exr_write_attrs(argv[2], &im, false, &at, &err) !=
		    PM_OK) {
			fprintf(stderr, "exrutil: %s\n", err.msg);
			return 1;
		}
		pm_exr_attrs_free(&at);
		pm_image_free(&im);
		return 0;
	}
	if (argc == 3 && strcmp(argv[1], "attrs") == 0) {
		struct pm_exr_attrs at = { 0 };
		size_t i;

		if (pm_exr_read_attrs(argv[2], NULL, &at, &err) != PM_OK) {
			fprintf(stderr, "exrutil: %s\n", err.msg);
			return 1;
		}
		for (i = 0; i < at.n; i++)
			printf("%s\t%s\n", at.v[i].name, at.v[i].value);
		pm_exr_attrs_free(&at);
		return 0;
	}
	if (argc == 3 && strcmp(argv[1], "channels") == 0) {
		struct pm_exr_layers ly = { NULL, 0 };
		struct pm_image im;
		size_t i, j, p, n;
		int k, l;

		if (pm_exr_read_layers(argv[2], &im, NULL, &ly, &err) !=
		    PM_OK) {
			fprintf(stderr, "exrutil: %s\n", err.msg);
			return 1;
		}
		n = (size_t)im.width * (size_t)im.height;
		for (i = 0; i < ly.n; i++)
			for (k = 0; k < 3; k++) {
				double s = 0.0;

				if (ly.v[i].name[k] == NULL)
					continue;
				for (p = 0; p < n; p++)
					s += ly.v[i].im.rgb[3 * p + k];
				printf("%s\t%.9g\n", ly.v[i].name[k], s / n);
			}
		for (i = 0; i < ly.n; i++)
			for (k = 0; k < 3; k++)
				for (j = 0; j < ly.n; j++)
					for (l = 0; l < 3; l++) {
						const char *a = ly.v[i].name[k];
						const char *b = ly.v[j].name[l];
						double lo = INFINITY;

						if (a == NULL || b == NULL ||
						    strncmp(b, "m2_", 3) != 0 ||
						    strcmp(b + 3, a) != 0)
							continue;
						for (p = 0; p < n; p++) {
							double m1 = ly.v[i].im.rgb[3 * p + k];
							double m2 = ly.v[j].im.rgb[3 * p + l];

							if (m2 - m1 * m1 < lo)
								lo = m2 - m1 * m1;
						}
						printf("var(%s)\t%.9g\n", a, lo);
					}
		pm_exr_layers_free(&ly);
		pm_image_free(&im);
		return 0;
	}
	if (argc == 4 && strcmp(argv[1], "same") == 0) {
		struct pm_image a, b;
		size_t i, n;

		if (pm_exr_read(argv[2], &a, &err) != PM_OK ||
		    pm_exr_read(argv[3], &b, &err) != PM_OK) {
			fprintf(stderr, "exrutil: %s\n", err.msg);
			return 1;
		}
		if (a.width != b.width || a.height != b.height) {
			fprintf(stderr, "exrutil: sizes differ: %dx%d and "
			    "%dx%d\n", a.width, a.height, b.width, b.height);
			return 1;
		}
		n = (size_t)a.width * (size_t)a.height * 3;
		for (i = 0; i < n; i++)
			if (memcmp(&a.rgb[i], &b.rgb[i], sizeof(float)) != 0) {
				fprintf(stderr, "exrutil: pixel (%zu, %zu) "
				    "channel %zu differs: %.9g and %.9g\n",
				    i / 3 % (size_t)a.width,
				    i / 3 / (size_t)a.width, i % 3,
				    a.rgb[i], b.rgb[i]);
				return 1;
			}
		printf("%dx%d, %zu values identical\n", a.width, a.height, n);
		pm_image_free(&a);
		pm_image_free(&b);
		return 0;
	}
	if (argc == 3 && strcmp(argv[1], "stat") == 0) {
		struct pm_image im;
		double mean[3] = { 0, 0, 0 }, lo = INFINITY, hi = -INFINITY;
		size_t i, n;

		if (pm_exr_read(argv[2], &im, &err) != PM_OK) {
			fprintf(stderr, "exrutil: %s\n", err.msg);
			return 1;
		}
		n = (size_t)im.width * im.height;
		for (i = 0; i < 3 * n; i++) {
			mean[i % 3] += im.rgb[i];
			if (im.rgb[i] < lo)
				lo = im.rgb[i];
			if (im.rgb[i] > hi)
				hi = im.rgb[i];
		}
		printf("%d %d %.9g %.9g %.9g %.9g %.9g\n", im.width, im.height,
		    mean[0] / n, mean[1] / n, mean[2] / n, lo, hi);
		pm_image_free(&im);
		return 0;
	}
	if (argc == 4 && strcmp(argv[1], "relmse") == 0) {
		struct pm_image t, r;
		double e = 0, mt[3] = {0, 0, 0}, mr[3] = {0, 0, 0};
		size_t i, n;

		if (pm_exr_read(argv[2], &t, &err) != PM_OK ||
		    pm_exr_read(argv[3], &r, &err) != PM_OK) {
			fprintf(stderr, "exrutil: %s\n", err.msg);
			return 1;
		}
		if (t.width != r.width || t.height != r.height) {
			fprintf(stderr, "exrutil: sizes differ\n");
			return 1;
		}
		n = (size_t)t.width * (size_t)t.height * 3;
		for (i = 0; i < n; i++) {
			double d = (double)t.rgb[i] - r.rgb[i];

			e += d * d / ((double)r.rgb[i] * r.rgb[i] + 0.01);
			mt[i % 3] += t.rgb[i];
			mr[i % 3] += r.rgb[i];
		}
		printf("%.9g %.9g %.9g %.9g\n", e / (double)n,
		    (mt[0] - mr[0]) / mr[0], (mt[1] - mr[1]) / mr[1],
		    (mt[2] - mr[2]) / mr[2]);
		pm_image_free(&t);
		pm_image_free(&r);
		return 0;
	}
	if (argc == 3 && strcmp(argv[1], "pngstat") == 0) {
		png_image img;
		unsigned char *buf;
		size_t i, n;
		int lo = 255, hi = 0;

		memset(&img, 0, sizeof(img));
		img.version = PNG_IMAGE_VERSION;
		if (!png_image_begin_read_from_file(&img, argv[2])) {
			fprintf(stderr, "exrutil: %s: %s\n", argv[2],
			    img.message);
			return 1;
		}
		img.format = PNG_FORMAT_RGB;
		n = PNG_IMAGE_SIZE(img);
		if ((buf = malloc(n)) == NULL ||
		    !png_image_finish_read(&img, NULL, buf, 0, NULL)) {
			fprintf(stderr, "exrutil: %s: %s\n", argv[2],
			    img.message);
			return 1;
		}
		for (i = 0; i < n; i++) {
			if (buf[i] < lo)
				lo = buf[i];
			if (buf[i] > hi)
				hi = buf[i];
		}
		printf("%u %u %d %d\n", img.width, img.height, lo, hi);
		free(buf);
		return 0;
	}
	fprintf(stderr, "usage: exrutil make OUT.exr W H R G B [ramp] "
	    "[NAME=VALUE...]\n"
	    "       exrutil stat IN.exr\n       exrutil pngstat IN.png\n"
	    "       exrutil relmse TEST.exr REF.exr\n"
	    "       exrutil attrs IN.exr\n       exrutil same A.exr B.exr\n");
	return 1;
}
