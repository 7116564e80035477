/*
 * pm-inspect: says what a photon-map file holds and where it came from,
 * checks it, and exports its photons as point clouds.
 *
 * The report is TSV, one "key<TAB>value..." line each, so that awk -F'\t'
 * and grep pick out any figure; --json gives the same as one object.  The
 * checks are the kd-tree invariant of balanced maps (the reader has already
 * verified every checksum) and a comparison of k-nearest-neighbour queries
 * against FLANN.  The dumps are for MeshLab and CloudCompare.  Nothing here
 * modifies the map: it is memory-mapped read-only when it can be.
 */
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>


#include "../common/error.h"
#include "../common/kdtree.h"
#include "../common/knn_check.h"
#include "../common/parse.h"
#include "../common/photon.h"
#include "../formats/pmap.h"
#include "cli.h"


#define PROG		"pm-inspect"
#define MAX_QUERIES	100000000L
#define MAX_K		1024L
#define DEFAULT_K	50
/* Colours of --dump ply: this quantile of the photons' largest channel
 * becomes full intensity. */
#define PLY_QUANTILE	0.99
#define PLY_GAMMA	(1.0 / 2.2)

static const char usage_line[] =
    "usage: pm-inspect [-qv] [--json] [--verify] [--dump xyz|ply|csv] "
    "[--map global|caustic|irradiance|volume] [--knn-check N [-k K]] [--seed S] "
    "MAP.pmap\n";

enum {
	OPT_JSON = 256, OPT_VERIFY, OPT_DUMP, OPT_MAP, OPT_KNN, OPT_SEED,
};

static const struct option longopts[] = {
	{ "dump",	required_argument,	NULL,	OPT_DUMP },
	{ "help",	no_argument,		NULL,	'h' },
	{ "json",	no_argument,		NULL,	OPT_JSON },
	{ "knn-check",	required_argument,	NULL,	OPT_KNN },
	{ "map",	required_argument,	NULL,	OPT_MAP },
	{ "quiet",	no_argument,		NULL,	'q' },
	{ "seed",	required_argument,	NULL,	OPT_SEED },
	{ "verbose",	no_argument,		NULL,	'v' },
	{ "verify",	no_argument,		NULL,	OPT_VERIFY },
	{ "version",	no_argument,		NULL,	PM_CLI_VERSION },
	{ NULL,		0,			NULL,	0 },
};

enum dump_kind { DUMP_NONE, DUMP_XYZ, DUMP_PLY, DUMP_CSV };

/* What is known of one map once it has been read and checked. */
struct map_report {
	const struct pm_map *m;
	struct pm_map_stats st;		/* counted over the records */
	/* --verify */
	bool verified, tree_ok;
	size_t bad;
	/* --knn-check */
	bool knn_done;
	struct pm_knn_check_result knn;
};

struct report {
	const char *name;
	const struct pm_pmap *pm;
	uint64_t photons;
	int n;
	struct map_report maps[4];
	bool verify;
	size_t knn_queries, knn_k;
	uint64_t seed;
};

static int verbosity = 1;	/* 0 with -q, 2 with -v */

static const char help_text[] =
    "Describe a photon-map file as TSV (or JSON), check it, or dump\n"
    "its photons as a point cloud.  MAP.pmap may be - for standard\n"
    "input.\n\n"
    "      --dump format     print the photons as xyz, ply or csv"
    " instead\n"
    "  -h, --help            print this help and exit\n"
    "      --json            one JSON object instead of TSV\n"
    "  -k K                  neighbours per --knn-check query"
    " (default 50)\n"
    "      --knn-check N     compare N k-nearest queries with FLANN\n"
    "      --map kind        only the global, caustic, irradiance or"
    " volume map\n"
    "  -q, --quiet           no warnings\n"
    "      --seed S          seed of the --knn-check queries"
    " (default 1)\n"
    "  -v, --verbose         say how long reading and checking took\n"
    "      --verify          check the kd-tree order of balanced maps\n"
    "      --version         print the version and exit\n";

static const struct pm_cli cli = { PROG, usage_line, help_text, longopts };

/* Reports a usage error in one line and exits 2. */
#define usage_error pm_cli_usage_error

/* Effects as a comma-separated list of names ("none" for none). */
static void
effects_names(uint32_t e, char *buf, size_t len)
{
	static const char *const names[] = { "global", "caustics",
	    "refraction", "media" };
	size_t at = 0;
	int i;

	buf[0] = '\0';
	for (i = 0; i < 4; i++)
		if (e & (1u << i))
			at += (size_t)snprintf(buf + at, len - at, "%s%s",
			    at > 0 ? "," : "", names[i]);
	if (e & ~15u)
		snprintf(buf + at, len - at, "%s0x%x", at > 0 ? "," : "",
		    (unsigned)(e & ~7u));
	else if (at == 0)
		snprintf(buf, len, "none");
}

/* Photons per second of a rate as printed: never inf or NaN. */
static double
finite_or_zero(double x)
{
	return isfinite(x) ? x : 0.0;
}

/* --- Reading ---------------------------------------------------------- */

/*
 * Reads the map: memory-mapped when it is a regular file, read front to
 * back when it is a pipe.  The reader says the file's size and version.
 */
static bool
load(const char *path, struct pm_pmap *pm)
{
	struct pm_error err;

	if (strcmp(path, "-") == 0 && isatty(STDIN_FILENO)) {
		fprintf(stderr, "%s: -: refusing to read a photon map from a "
		    "terminal\n", PROG);
		return false;
	}
	if (pm_pmap_read(path, pm, true, &err) != PM_OK) {
		fprintf(stderr, "%s: %s\n", PROG, err.msg);
		return false;
	}
	return true;
}

/* --- TSV --------------------------------------------------------------- */

/* A value on a TSV line: tabs and line breaks would split it. */
static void
tsv_text(const char *s)
{
	for (; *s != '\0'; s++)
		putchar(*s == '\t' || *s == '\n' || *s == '\r' ? ' ' : *s);
}

static void
tsv_float(float x)
{
	printf("\t%.9g", (double)x);
}

static void
print_tsv(const struct report *r)
{
	const struct pm_pmap *pm = r->pm;
	char eff[128];
	const char *line;
	int i, d;

	effects_names(pm->effects, eff, sizeof(eff));
	fputs("file\t", stdout);
	tsv_text(r->name);
	putchar('\n');
	printf("file_bytes\t%llu\n", (unsigned long long)pm->file_bytes);
	printf("version\t%u.%u\n", pm->version_major, pm->version_minor);
	printf("scene_hash\t%016llx\n", (unsigned long long)pm->scene_hash);
	printf("seed\t%llu\n", (unsigned long long)pm->seed);
	printf("effects\t%s\n", eff);
	printf("max_depth\t%u\n", (unsigned)pm->max_depth);
	printf("maps\t%d\n", r->n);
	printf("photons\t%llu\n", (unsigned long long)r->photons);
	if (r->photons > 0)
		printf("bytes_per_photon\t%.3f\n", (double)pm->file_bytes /
		    (double)r->photons);
	printf("bytes_per_photon_in_memory\t%zu\n", sizeof(struct pm_photon));
	if (r->verify)
		printf("crc32\tok\n");
	for (i = 0; i < r->n; i++) {
		const struct map_report *mr = &r->maps[i];
		const struct pm_map *m = mr->m;
		const char *k = pm_map_kind_name(m->kind);

		if (m->kind == PM_MAP_IRRADIANCE)
			printf("%s.records\t%llu\n", k,
			    (unsigned long long)m->count);
		else {
			printf("%s.photons\t%llu\n", k,
			    (unsigned long long)m->count);
			printf("%s.emitted\t%llu\n", k,
			    (unsigned long long)m->emitted);
			printf("%s.first_index\t%llu\n", k,
			    (unsigned long long)m->first_index);
		}
		printf("%s.balanced\t%s\n", k, m->balanced ? "true" : "false");
		printf("%s.lo", k);
		tsv_float(m->lo[0]);
		tsv_float(m->lo[1]);
		tsv_float(m->lo[2]);
		printf("\n%s.hi", k);
		tsv_float(m->hi[0]);
		tsv_float(m->hi[1]);
		tsv_float(m->hi[2]);
		putchar('\n');
		if (m->kind == PM_MAP_IRRADIANCE) {
			printf("%s.radius", k);
			tsv_float(m->radius);
			printf("\n%s.mean_irradiance\t%.9g\t%.9g\t%.9g\n", k,
			    mr->st.mean_e[0], mr->st.mean_e[1],
			    mr->st.mean_e[2]);
			printf("%s.max_irradiance\t%.9g\n", k, mr->st.max_e);
		} else {
			printf("%s.flux\t%.9g\t%.9g\t%.9g\n", k,
			    mr->st.flux[0], mr->st.flux[1], mr->st.flux[2]);
			for (d = 0; d <= mr->st.max_depth; d++)
				printf("%s.depth.%d\t%llu\n", k, d,
				    (unsigned long long)mr->st.depth[d]);
			printf("%s.flag.via_diffuse\t%llu\n", k,
			    (unsigned long long)mr->st.via_diffuse);
			printf("%s.flag.caustic\t%llu\n", k,
			    (unsigned long long)mr->st.caustic);
		}
		printf("%s.records_crc32\t%08x\n", k, (unsigned)m->records_crc);
		if (mr->verified) {
			if (!m->balanced)
				printf("%s.kdtree\tnot balanced\n", k);
			else if (mr->tree_ok)
				printf("%s.kdtree\tok\n", k);
			else
				printf("%s.kdtree\tbroken at node %zu\n", k,
				    mr->bad);
		}
		if (mr->knn_done) {
			const struct pm_knn_check_result *q = &mr->knn;

			printf("%s.knn.queries\t%zu\n", k, q->queries);
			printf("%s.knn.k\t%zu\n", k, r->knn_k);
			printf("%s.knn.mismatches\t%zu\n", k, q->mismatches);
			printf("%s.knn.ties\t%zu\n", k, q->ties);
			printf("%s.knn.pm_qps\t%.6g\n", k,
			    finite_or_zero(q->pm_qps));
			printf("%s.knn.pm_qps_single\t%.6g\n", k,
			    finite_or_zero(q->pm_qps_single));
			printf("%s.knn.flann_qps\t%.6g\n", k,
			    finite_or_zero(q->flann_qps));
			printf("%s.knn.speedup\t%.4g\n", k,
			    finite_or_zero(q->pm_qps / q->flann_qps));
			printf("%s.knn.pm_build_s\t%.6g\n", k, q->pm_build_s);
			printf("%s.knn.flann_build_s\t%.6g\n", k,
			    q->flann_build_s);
		}
	}
	/* Provenance, split at the first '=' like Radiance's getinfo. */
	for (line = pm->info; line != NULL && *line != '\0';) {
		size_t len = strcspn(line, "\n"), eq = strcspn(line, "=");

		fputs("info\t", stdout);
		if (eq < len)
			printf("%.*s\t", (int)eq, line);
		else
			putchar('\t');
		for (d = eq < len ? (int)eq + 1 : 0; (size_t)d < len; d++)
			putchar(line[d] == '\t' || line[d] == '\r' ? ' ' :
			    line[d]);
		putchar('\n');
		line += len;
		if (*line == '\n')
			line++;
	}
}

/* --- JSON -------------------------------------------------------------- */

/* Length of the valid UTF-8 sequence at s, or 0. */
static size_t
utf8_len(const unsigned char *s)
{
	size_t n, i;
	uint32_t c;

	if (s[0] < 0x80)
		return 1;
	if (s[0] >= 0xc2 && s[0] <= 0xdf)
		n = 2, c = s[0] & 0x1f;
	else if (s[0] >= 0xe0 && s[0] <= 0xef)
		n = 3, c = s[0] & 0x0f;
	else if (s[0] >= 0xf0 && s[0] <= 0xf4)
		n = 4, c = s[0] & 0x07;
	else
		return 0;
	for (i = 1; i < n; i++) {
		if ((s[i] & 0xc0) != 0x80)
			return 0;
		c = c << 6 | (s[i] & 0x3f);
	}
	/* Overlong forms, surrogates and values past U+10FFFF. */
	if ((n == 3 && c < 0x800) || (n == 4 && (c < 0x10000 ||
	    c > 0x10ffff)) || (c >= 0xd800 && c <= 0xdfff))
		return 0;
	return n;
}

/*
 * A JSON string of at most len bytes of s: quotes, backslashes and
 * control characters escaped, and any byte that is not valid UTF-8 taken
 * as Latin-1, so that the output always parses.
 */
static void
json_strn(const char *s, size_t len)
{
	const unsigned char *u = (const unsigned char *)s;
	size_t i = 0, n;

	putchar('"');
	while (i < len && u[i] != '\0') {
		if (u[i] == '"' || u[i] == '\\') {
			putchar('\\');
			putchar(u[i++]);
			continue;
		}
		if (u[i] < 0x20) {
			switch (u[i]) {
			case '\n': fputs("\\n", stdout); break;
			case '\r': fputs("\\r", stdout); break;
			case '\t': fputs("\\t", stdout); break;
			default: printf("\\u%04x", u[i]); break;
			}
			i++;
			continue;
		}
		n = utf8_len(u + i);
		if (n == 0 || i + n > len) {
			printf("\\u%04x", u[i++]);
			continue;
		}
		fwrite(u + i, 1, n, stdout);
		i += n;
	}
	putchar('"');
}

static void
json_str(const char *s)
{
	json_strn(s, strlen(s));
}

/* JSON has no infinities or NaN: they become null. */
static void
json_num(double x, int digits)
{
	if (isfinite(x))
		printf("%.*g", digits, x);
	else
		fputs("null", stdout);
}

static void
json_vec(const float v[3])
{
	printf("[");
	json_num(v[0], 9);
	printf(", ");
	json_num(v[1], 9);
	printf(", ");
	json_num(v[2], 9);
	printf("]");
}

static void
print_json(const struct report *r)
{
	const struct pm_pmap *pm = r->pm;
	const char *line;
	int i, d, e, ne = 0;
	static const char *const effect_names[] = { "global", "caustics",
	    "refraction", "media" };

	printf("{\n  \"file\": ");
	json_str(r->name);
	printf(",\n  \"file_bytes\": %llu,\n",
	    (unsigned long long)pm->file_bytes);
	printf("  \"version\": \"%u.%u\",\n", pm->version_major,
	    pm->version_minor);
	printf("  \"scene_hash\": \"%016llx\",\n",
	    (unsigned long long)pm->scene_hash);
	printf("  \"seed\": %llu,\n", (unsigned long long)pm->seed);
	printf("  \"effects\": [");
	for (e = 0; e < 4; e++)
		if (pm->effects & (1u << e))
			printf("%s\"%s\"", ne++ > 0 ? ", " : "",
			    effect_names[e]);
	printf("],\n  \"effects_bits\": %u,\n", (unsigned)pm->effects);
	printf("  \"max_depth\": %u,\n", (unsigned)pm->max_depth);
	printf("  \"photons\": %llu,\n", (unsigned long long)r->photons);
	printf("  \"bytes_per_photon\": ");
	json_num(r->photons > 0 ? (double)pm->file_bytes / (double)r->photons :
	    NAN, 6);
	printf(",\n  \"bytes_per_photon_in_memory\": %zu,\n",
	    sizeof(struct pm_photon));
	if (r->verify)
		printf("  \"crc32\": \"ok\",\n");
	printf("  \"maps\": [");
	for (i = 0; i < r->n; i++) {
		const struct map_report *mr = &r->maps[i];
		const struct pm_map *m = mr->m;

		printf("%s\n    {\n      \"kind\": \"%s\",\n", i > 0 ? "," : "",
		    pm_map_kind_name(m->kind));
		if (m->kind == PM_MAP_IRRADIANCE)
			printf("      \"records\": %llu,\n",
			    (unsigned long long)m->count);
		else {
			printf("      \"photons\": %llu,\n",
			    (unsigned long long)m->count);
			printf("      \"emitted\": %llu,\n",
			    (unsigned long long)m->emitted);
			printf("      \"first_index\": %llu,\n",
			    (unsigned long long)m->first_index);
		}
		printf("      \"balanced\": %s,\n",
		    m->balanced ? "true" : "false");
		printf("      \"lo\": ");
		json_vec(m->lo);
		printf(",\n      \"hi\": ");
		json_vec(m->hi);
		if (m->kind == PM_MAP_IRRADIANCE) {
			printf(",\n      \"radius\": ");
			json_num(m->radius, 9);
			printf(",\n      \"mean_irradiance\": [");
			json_num(mr->st.mean_e[0], 9);
			printf(", ");
			json_num(mr->st.mean_e[1], 9);
			printf(", ");
			json_num(mr->st.mean_e[2], 9);
			printf("],\n      \"max_irradiance\": ");
			json_num(mr->st.max_e, 9);
			printf(",\n");
		} else {
			printf(",\n      \"flux\": [");
			json_num(mr->st.flux[0], 9);
			printf(", ");
			json_num(mr->st.flux[1], 9);
			printf(", ");
			json_num(mr->st.flux[2], 9);
			printf("],\n      \"depth\": [");
			for (d = 0; d <= mr->st.max_depth; d++)
				printf("%s%llu", d > 0 ? ", " : "",
				    (unsigned long long)mr->st.depth[d]);
			printf("],\n      \"flags\": {\"via_diffuse\": %llu, "
			    "\"caustic\": %llu},\n",
			    (unsigned long long)mr->st.via_diffuse,
			    (unsigned long long)mr->st.caustic);
		}
		printf("      \"records_crc32\": \"%08x\"",
		    (unsigned)m->records_crc);
		if (mr->verified) {
			printf(",\n      \"kdtree\": ");
			if (!m->balanced)
				printf("\"not balanced\"");
			else if (mr->tree_ok)
				printf("\"ok\"");
			else
				printf("{\"broken_at_node\": %zu}", mr->bad);
		}
		if (mr->knn_done) {
			const struct pm_knn_check_result *q = &mr->knn;

			printf(",\n      \"knn_check\": {\"queries\": %zu, "
			    "\"k\": %zu, \"mismatches\": %zu, \"ties\": %zu, "
			    "\"pm_qps\": ", q->queries, r->knn_k,
			    q->mismatches, q->ties);
			json_num(q->pm_qps, 6);
			printf(", \"pm_qps_single\": ");
			json_num(q->pm_qps_single, 6);
			printf(", \"flann_qps\": ");
			json_num(q->flann_qps, 6);
			printf(", \"speedup\": ");
			json_num(q->pm_qps / q->flann_qps, 4);
			printf(", \"pm_build_s\": ");
			json_num(q->pm_build_s, 6);
			printf(", \"flann_build_s\": ");
			json_num(q->flann_build_s, 6);
			printf("}");
		}
		printf("\n    }");
	}
	printf("%s],\n  \"info\": [", r->n > 0 ? "\n  " : "");
	for (line = pm->info, i = 0; line != NULL && *line != '\0'; i++) {
		size_t len = strcspn(line, "\n");

		printf("%s\n    ", i > 0 ? "," : "");
		json_strn(line, len);
		line += len;
		if (*line == '\n')
			line++;
	}
	printf("%s]\n}\n", i > 0 ? "\n  " : "");
}

/* --- Dumps ------------------------------------------------------------- */

static int
cmp_float(const void *a, const void *b)
{
	float x = *(const float *)a, y = *(const float *)b;

	return (x > y) - (x < y);
}

/*
 * The PLY colour scale of a map: the PLY_QUANTILE quantile of the
 * photons' largest power channel (zero powers left out), so that a few
 * very bright photons do not turn the rest black.  0 when all are black.
 */
static bool
colour_scale(const struct pm_map *m, float *scale)
{
	size_t i, n = 0;
	float *v;

	*scale = 0.0f;
	if (m->count == 0)
		return true;
	if ((v = malloc((size_t)m->count * sizeof(*v))) == NULL)
		return false;
	for (i = 0; i < (size_t)m->count; i++) {
		float c = pm_rgb_max(pm_rgbe_unpack(m->photons[i].power));

		if (c > 0.0f)
			v[n++] = c;
	}
	if (n > 0) {
		qsort(v, n, sizeof(*v), cmp_float);
		*scale = v[(size_t)((double)(n - 1) * PLY_QUANTILE)];
	}
	free(v);
	return true;
}

static unsigned
colour_byte(float c, float scale)
{
	double x;

	if (!(scale > 0.0f) || !(c > 0.0f))
		return 0;
	x = fmin((double)c / scale, 1.0);
	return (unsigned)(pow(x, PLY_GAMMA) * 255.0 + 0.5);
}

static bool
dump(const struct report *r, enum dump_kind kind)
{
	uint64_t total = 0;
	float scale = 0.0f;
	size_t j;
	int i;

	for (i = 0; i < r->n; i++)
		total += r->maps[i].m->count;
	if (kind == DUMP_PLY) {
		printf("ply\nformat ascii 1.0\n");
		printf("comment made by pm-inspect %s from ", PM_VERSION);
		tsv_text(r->name);
		printf("\ncomment scene_hash %016llx\n",
		    (unsigned long long)r->pm->scene_hash);
		printf("element vertex %llu\n", (unsigned long long)total);
		printf("property float x\nproperty float y\nproperty float z\n"
		    "property uchar red\nproperty uchar green\n"
		    "property uchar blue\nend_header\n");
	} else if (kind == DUMP_CSV)
		printf("kind,x,y,z,flux_r,flux_g,flux_b,dir_x,dir_y,dir_z,"
		    "depth,flags,normal_x,normal_y,normal_z\n");
	for (i = 0; i < r->n; i++) {
		const struct pm_map *m = r->maps[i].m;
		const char *k = pm_map_kind_name(m->kind);
		/* Irradiance records hold E, which nothing divides. */
		double norm = m->emitted > 0 ? 1.0 / (double)m->emitted : 1.0;

		if (kind == DUMP_PLY && !colour_scale(m, &scale)) {
			fprintf(stderr, "%s: %s: out of memory\n", PROG,
			    r->name);
			return false;
		}
		for (j = 0; j < (size_t)m->count; j++) {
			const struct pm_photon *p = &m->photons[j];
			struct pm_rgb c;
			struct pm_vec3 d;

			switch (kind) {
			case DUMP_XYZ:
				printf("%.9g %.9g %.9g\n", (double)p->pos[0],
				    (double)p->pos[1], (double)p->pos[2]);
				break;
			case DUMP_PLY:
				c = pm_rgbe_unpack(p->power);
				printf("%.9g %.9g %.9g %u %u %u\n",
				    (double)p->pos[0], (double)p->pos[1],
				    (double)p->pos[2], colour_byte(c.r, scale),
				    colour_byte(c.g, scale),
				    colour_byte(c.b, scale));
				break;
			case DUMP_CSV:
				c = pm_rgbe_unpack(p->power);
				printf("%s,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,", k,
				    (double)p->pos[0], (double)p->pos[1],
				    (double)p->pos[2], c.r * norm, c.g * norm,
				    c.b * norm);
				/* An irradiance record has no direction. */
				d = pm_dir_unpack(p->dir);
				if (m->kind == PM_MAP_IRRADIANCE)
					printf(",,,");
				else
					printf("%.6g,%.6g,%.6g,", (double)d.x,
					    (double)d.y, (double)d.z);
				/* A volume photon has no normal. */
				d = pm_dir_unpack(p->normal);
				if (m->kind == PM_MAP_VOLUME)
					printf("%u,%u,,,\n", (unsigned)p->depth,
					    (unsigned)p->flags);
				else
					printf("%u,%u,%.6g,%.6g,%.6g\n",
					    (unsigned)p->depth,
					    (unsigned)p->flags, (double)d.x,
					    (double)d.y, (double)d.z);
				break;
			case DUMP_NONE:
				break;
			}
			if (ferror(stdout))
				return true;	/* reported at close */
		}
	}
	return true;
}

int
main(int argc, char *argv[])
{
	struct pm_error err;
	struct pm_pmap pm;
	struct report r;
	enum dump_kind dump_kind = DUMP_NONE;
	const char *path;
	bool json = false, verify = false, loaded = false, k_set = false;
	bool seed_set = false, failed = false;
	int ch, i, only = 0;
	long queries = 0, k = DEFAULT_K;
	unsigned long long seed = 1;
	double t;
	struct pm_cli_opts co;

	memset(&pm, 0, sizeof(pm));
	memset(&r, 0, sizeof(r));
	pm_cli_opts_init(&co);
	while ((ch = pm_cli_getopt(&cli, argc, argv, "hk:qv")) != -1) {
		if (pm_cli_common(&co, ch))
			continue;
		switch (ch) {
		case 'k':
			if (!pm_parse_long(optarg, 1, MAX_K, &k))
				usage_error("-k: expected a neighbour count "
				    "from 1 to %ld, got '%s'", MAX_K, optarg);
			k_set = true;
			break;
		case OPT_DUMP:
			if (strcmp(optarg, "xyz") == 0)
				dump_kind = DUMP_XYZ;
			else if (strcmp(optarg, "ply") == 0)
				dump_kind = DUMP_PLY;
			else if (strcmp(optarg, "csv") == 0)
				dump_kind = DUMP_CSV;
			else
				usage_error("--dump: unknown format '%s'; "
				    "expected xyz, ply or csv", optarg);
			break;
		case OPT_JSON:
			json = true;
			break;
		case OPT_KNN:
			if (!pm_parse_long(optarg, 1, MAX_QUERIES, &queries))
				usage_error("--knn-check: expected a query "
				    "count from 1 to %ld, got '%s'",
				    MAX_QUERIES, optarg);
			break;
		case OPT_MAP:
			if (strcmp(optarg, "global") == 0)
				only = PM_MAP_GLOBAL;
			else if (strcmp(optarg, "caustic") == 0)
				only = PM_MAP_CAUSTIC;
			else if (strcmp(optarg, "irradiance") == 0)
				only = PM_MAP_IRRADIANCE;
			else if (strcmp(optarg, "volume") == 0)
				only = PM_MAP_VOLUME;
			else
				usage_error("--map: unknown map '%s'; expected "
				    "global, caustic, irradiance or volume",
				    optarg);
			break;
		case OPT_SEED:
			if (!pm_parse_u64(optarg, &seed))
				usage_error("--seed: expected a non-negative "
				    "integer, got '%s'", optarg);
			seed_set = true;
			break;
		case OPT_VERIFY:
			verify = true;
			break;
		default:
			usage_error("unhandled option '%s'", argv[optind - 1]);
		}
	}
	verbosity = co.verbosity;
	argc -= optind;
	argv += optind;

	if (argc < 1)
		usage_error("no photon map given");
	if (argc > 1)
		usage_error("one photon map at a time (got %d)", argc);
	if ((k_set || seed_set) && queries == 0)
		usage_error("%s applies to --knn-check only",
		    k_set ? "-k" : "--seed");
	if (dump_kind != DUMP_NONE && (json || verify || queries > 0))
		usage_error("--dump prints photons only; it does not combine "
		    "with %s", json ? "--json" : verify ? "--verify" :
		    "--knn-check");
	path = argv[0];

	t = pm_cli_now();
	if (!load(path, &pm))
		return 1;
	loaded = true;
	if (verbosity >= 2)
		fprintf(stderr, "%s: %s: read and checked in %.3f s\n", PROG,
		    path, pm_cli_now() - t);
	r.name = path;
	r.pm = &pm;
	r.verify = verify;
	r.knn_queries = (size_t)queries;
	r.knn_k = (size_t)k;
	r.seed = seed;
	for (i = 0; i < pm.nmaps; i++) {
		if (only != 0 && pm.maps[i].kind != (enum pm_map_kind)only)
			continue;
		r.maps[r.n].m = &pm.maps[i];
		r.n++;
	}
	if (only != 0 && r.n == 0) {
		fprintf(stderr, "%s: %s: holds no %s map\n", PROG, path,
		    pm_map_kind_name((enum pm_map_kind)only));
		goto fail;
	}

	if (dump_kind != DUMP_NONE) {
		if (!dump(&r, dump_kind))
			goto fail;
		goto done;
	}

	for (i = 0; i < r.n; i++) {
		const struct pm_map *m = r.maps[i].m;

		pm_map_stats(m, &r.maps[i].st);
		if (m->kind != PM_MAP_IRRADIANCE)
			r.photons += m->count;
	}
	for (i = 0; i < r.n; i++) {
		struct map_report *mr = &r.maps[i];
		const struct pm_map *m = mr->m;

		if (verify) {
			mr->verified = true;
			mr->tree_ok = !m->balanced || pm_kdtree_verify(
			    m->photons, (size_t)m->count, &mr->bad);
			if (!mr->tree_ok) {
				fprintf(stderr, "%s: %s: %s map: kd-tree order "
				    "broken at node %zu\n", PROG, path,
				    pm_map_kind_name(m->kind), mr->bad);
				failed = true;
			}
		}
		if (queries > 0 && !m->balanced) {
			if (verbosity >= 1)
				fprintf(stderr, "%s: %s: %s map is not "
				    "balanced; --knn-check skips it\n", PROG,
				    path, pm_map_kind_name(m->kind));
		} else if (queries > 0 && (!verify || mr->tree_ok)) {
			t = pm_cli_now();
			if (pm_knn_check(m->photons, (size_t)m->count,
			    (size_t)queries, (size_t)k, seed, &mr->knn,
			    &err) != PM_OK) {
				fprintf(stderr, "%s: %s: %s map: %s\n", PROG,
				    path, pm_map_kind_name(m->kind), err.msg);
				goto fail;
			}
			mr->knn_done = true;
			if (verbosity >= 2)
				fprintf(stderr, "%s: %s map: knn check took "
				    "%.3f s\n", PROG, pm_map_kind_name(m->kind),
				    pm_cli_now() - t);
			if (mr->knn.mismatches > 0) {
				fprintf(stderr, "%s: %s: %s map: %zu of %zu "
				    "k-nearest queries differ from FLANN's\n",
				    PROG, path, pm_map_kind_name(m->kind),
				    mr->knn.mismatches, mr->knn.queries);
				failed = true;
			}
		}
	}
	if (queries > 0 && !failed) {
		bool any = false;

		for (i = 0; i < r.n; i++)
			any = any || r.maps[i].knn_done;
		if (!any) {
			fprintf(stderr, "%s: %s: no balanced map for "
			    "--knn-check; run pm-balance first\n", PROG, path);
			failed = true;
		}
	}
	if (json)
		print_json(&r);
	else
		print_tsv(&r);

done:
	pm_pmap_free(&pm);
	loaded = false;

	/* A full disk or a closed pipe shows up only here. */
	errno = 0;
	if (fflush(stdout) != 0 || ferror(stdout) || fclose(stdout) != 0) {
		fprintf(stderr, "%s: stdout: %s\n", PROG,
		    errno != 0 ? strerror(errno) : "write error");
		return 1;
	}
	return failed ? 1 : 0;

fail:
	if (loaded)
		pm_pmap_free(&pm);
	return 1;
}
