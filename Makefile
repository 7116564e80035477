# pm: photon mapping as a pipeline of Unix tools.
#
#   make            all tools into bin/
#   make demo       render the default bunny scene to out/bunny.png and out/bunny.exr
#   make test       build and run the whole test suite
#   make install    tools and man pages under $(PREFIX)
#   make clean
#
# `make demo` and `make test` first install missing Debian packages when run
# as root (apt-get), and say what to install otherwise.

PREFIX  ?= /usr/local
CC      ?= cc
OPT     ?= -O2
CFLAGS  ?= $(OPT) -g
PKGS     = OpenEXR expat libpng libjpeg zlib
# -fno-math-errno: pm never reads errno after libm, and without it GCC
# keeps a call to sqrtf behind every inlined sqrtss for the errno of a
# negative argument (1.5% of a path-traced frame); results are the same.
# -ffp-contract=off: no multiply-add fused into an FMA behind the code's
# back, so that SIMD lanes give their scalar code's bits (icache.c,
# sampling.c) with any compiler (GCC does so in C17 anyway; clang fuses
# by default where the target has FMA).
PM_CFLAGS = -std=c17 -Wall -Wextra -pthread -D_DEFAULT_SOURCE -fno-math-errno \
	-ffp-contract=off \
	$(shell pkg-config --cflags $(PKGS) 2>/dev/null)
# OpenEXR's pkg-config pulls in the C++ libraries; pm uses only the C core.
PM_LIBS  = -lembree3 -lOpenEXRCore -lflann $(shell pkg-config --libs expat libpng libjpeg zlib 2>/dev/null) \
	-lm -pthread
TEST_LIBS = $(shell pkg-config --libs cmocka 2>/dev/null || echo -lcmocka)

# Debian packages the build, the demo and the tests need.
DEBS = build-essential pkg-config libembree-dev libopenexr-dev libexpat1-dev \
	libpng-dev libjpeg-dev zlib1g-dev libflann-dev libcmocka-dev mandoc glmark2-data \
	python3 python3-venv libllvm19 clang libclang-rt-14-dev
# ...and those of the cluster tests (a one-node Slurm, tests/cluster/),
# which print SKIP without them.
CLUSTER_DEBS = slurm-wlm munge

BUILD = build
BIN   = bin
TOOLS = pm-shoot pm-balance pm-render pm-downsample pm-inspect pm-merl
BINS  = $(TOOLS:%=$(BIN)/%)
LIB   = $(BUILD)/libpm.a

LIB_SRC  = $(sort $(wildcard common/*.c) $(wildcard formats/*.c) $(wildcard formats/*/*.c))
LIB_OBJ  = $(LIB_SRC:%.c=$(BUILD)/%.o)
TEST_SRC = $(sort $(wildcard tests/unit/test_*.c))
TEST_BIN = $(TEST_SRC:tests/unit/%.c=$(BUILD)/tests/%)
MANS     = $(sort $(wildcard man/*.[1-9]))

.PHONY: all demo test deps install clean check-unit check-cli check-man check-mitsuba \
	check-sanitize check-tsan check-nosimd turntable deps-cluster check-cluster
.PHONY: fuzz fuzz-build check-fuzz mitsuba-references

# Data files written by a program rather than stored: the .vol grids of
# data/smoke.xml (tests/volgen.c).
DATA_GEN = data/smoke.vol data/smoke-tint.vol

all: $(BINS) $(DATA_GEN)

$(BUILD)/tests/volgen: tests/volgen.c $(LIB)
	@mkdir -p $(dir $@)
	$(CC) $(PM_CFLAGS) $(CFLAGS) -o $@ tests/volgen.c $(LIB) $(PM_LIBS)
data/smoke.vol: $(BUILD)/tests/volgen
	$(BUILD)/tests/volgen smoke $@
data/smoke-tint.vol: $(BUILD)/tests/volgen
	$(BUILD)/tests/volgen tint $@

$(BUILD)/%.o: %.c
	@mkdir -p $(dir $@)
	$(CC) $(PM_CFLAGS) $(CFLAGS) -MMD -MP -c $< -o $@

# Made afresh each time: ar names members by their base name, so an
# update in place would keep members of objects since removed (the old
# formats/scene_xml.o) and replace one of two same-named ones
# (common/bsdf.o, formats/scene_xml/bsdf.o) by the other.
$(LIB): $(LIB_OBJ)
	@mkdir -p $(dir $@)
	rm -f $@
	$(AR) rcs $@ $(LIB_OBJ)

# What the tools share (printing, terminals, output checks) but the library
# must not do.
CLI_OBJ = $(BUILD)/tools/cli.o

$(BIN)/%: $(BUILD)/tools/%.o $(CLI_OBJ) $(LIB)
	@mkdir -p $(BIN)
	$(CC) $(CFLAGS) -pthread -o $@ $< $(CLI_OBJ) $(LIB) $(PM_LIBS)

# What the unit tests share (statistics; the BSDF tests' checks; scratch
# directories), linked
# into each of them.
TEST_HELP_OBJ = $(BUILD)/tests/unit/stats.o $(BUILD)/tests/unit/bsdf_check.o \
    $(BUILD)/tests/unit/tmpdir.o

$(BUILD)/tests/%: $(BUILD)/tests/unit/%.o $(TEST_HELP_OBJ) $(LIB)
	@mkdir -p $(dir $@)
	$(CC) $(CFLAGS) -pthread -o $@ $< $(TEST_HELP_OBJ) $(LIB) $(PM_LIBS) $(TEST_LIBS)

.SECONDARY: $(CLI_OBJ) $(TEST_HELP_OBJ)

-include $(LIB_OBJ:.o=.d) $(CLI_OBJ:.o=.d) $(TEST_SRC:tests/unit/%.c=$(BUILD)/tests/unit/%.d) \
	$(TOOLS:%=$(BUILD)/tools/%.d) $(TEST_HELP_OBJ:.o=.d)

# Installs what is missing when root, otherwise names it and stops.
deps:
	@missing=""; for p in $(DEBS); do \
		dpkg -s $$p >/dev/null 2>&1 || missing="$$missing $$p"; done; \
	if [ -n "$$missing" ]; then \
		if [ "$$(id -u)" = 0 ]; then \
			echo "installing:$$missing"; \
			DEBIAN_FRONTEND=noninteractive apt-get update -qq && \
			DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends $$missing; \
		else \
			echo "missing Debian packages:$$missing"; \
			echo "run: sudo apt-get install$$missing"; exit 1; \
		fi; \
	fi

# Installs Slurm and munge when root; otherwise the cluster tests SKIP.
deps-cluster:
	@missing=""; for p in $(CLUSTER_DEBS); do \
		dpkg -s $$p >/dev/null 2>&1 || missing="$$missing $$p"; done; \
	if [ -n "$$missing" ]; then \
		if [ "$$(id -u)" = 0 ]; then \
			echo "installing:$$missing"; \
			DEBIAN_FRONTEND=noninteractive apt-get update -qq && \
			DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends $$missing \
				|| echo "not installed:$$missing (the cluster tests will SKIP)"; \
		else \
			echo "missing Debian packages:$$missing (the cluster tests will SKIP)"; \
		fi; \
	fi

include pipelines/bunny.mk
include pipelines/turntable.mk
include pipelines/merl.mk
include pipelines/progressive.mk
include pipelines/accuracy.mk
include pipelines/bench.mk

# Builds use every core; the render stages use every core by themselves.
NPROC := $(shell nproc 2>/dev/null || echo 1)

demo: deps
	$(MAKE) -j$(NPROC) all
	$(MAKE) $(BUNNY).png

# Each part timed (tests/phase.sh); the last line lists them all.
PHASES = $(BUILD)/test-phases
PHASE  = @sh tests/phase.sh $(PHASES)
test: deps deps-cluster
	@mkdir -p $(BUILD) && rm -f $(PHASES)
	$(PHASE) build $(MAKE) -j$(NPROC) all $(TEST_BIN)
	$(PHASE) unit+cli+man $(MAKE) check-unit check-cli check-man
	$(PHASE) cluster $(MAKE) check-cluster
	$(PHASE) sanitize $(MAKE) check-sanitize
	$(PHASE) nosimd $(MAKE) check-nosimd
	$(PHASE) fuzz $(MAKE) check-fuzz
	$(PHASE) mitsuba $(MAKE) check-mitsuba
	@echo "make test: passed; seconds per part:" $$(cat $(PHASES))

check-unit: $(TEST_BIN)
	@sh tests/run-unit.sh $(TEST_BIN)

$(BUILD)/tests/exrutil: tests/cli/exrutil.c $(LIB)
	@mkdir -p $(dir $@)
	$(CC) $(PM_CFLAGS) $(CFLAGS) -o $@ tests/cli/exrutil.c $(LIB) $(PM_LIBS)

CLI_TESTS = $(sort $(wildcard tests/cli/*.sh))
check-cli: $(BINS) $(BUILD)/tests/exrutil
	@BIN=$(BIN) EXRUTIL=$(BUILD)/tests/exrutil sh tests/run-cli.sh $(CLI_TESTS)

# pipelines/slurm through a one-node Slurm started and stopped by the test
# (root, slurm-wlm and munge; SKIP otherwise, a failure when
# PM_CLUSTER_REQUIRED=1).
check-cluster: $(BINS) $(BUILD)/tests/exrutil
	@BIN=$(BIN) sh tests/cluster/run.sh

# The unit and CLI tests again, built with AddressSanitizer and UBSan.
SAN_FLAGS = -O1 -g -fsanitize=address,undefined -fno-omit-frame-pointer \
	-fno-sanitize-recover=undefined
# The builds run on every CPU (a sub-make does not inherit make test's -j);
# the checks after them run as check-unit and check-cli do anywhere, as many
# tests at once as there are CPUs (tests/run-each.sh).
check-sanitize:
	$(MAKE) -j$(NPROC) BUILD=build/san BIN=build/san/bin CFLAGS="$(SAN_FLAGS)" \
		$(TOOLS:%=build/san/bin/%) $(TEST_SRC:tests/unit/%.c=build/san/tests/%) \
		build/san/tests/exrutil
	$(MAKE) BUILD=build/san BIN=build/san/bin CFLAGS="$(SAN_FLAGS)" \
		check-unit check-cli
	$(MAKE) check-tsan

# The threaded code under ThreadSanitizer: the unit tests that start
# threads, and the CLI scripts that drive the threaded tools (pm-shoot,
# pm-balance, pm-render with its progress and preview thread).
TSAN_FLAGS = -O1 -g -fsanitize=thread -fno-omit-frame-pointer
TSAN_UNIT  = test_render test_kdtree test_kdbuild test_shoot test_irradiance test_photonmap \
	     test_ptracer test_pmap
TSAN_CLI   = tests/cli/render.sh tests/cli/photon.sh tests/cli/dialect.sh
check-tsan:
	$(MAKE) -j$(NPROC) BUILD=build/tsan BIN=build/tsan/bin CFLAGS="$(TSAN_FLAGS)" \
		$(TOOLS:%=build/tsan/bin/%) $(TSAN_UNIT:%=build/tsan/tests/%) \
		build/tsan/tests/exrutil
	TSAN_OPTIONS="halt_on_error=1 exitcode=66 suppressions=$(CURDIR)/tests/tsan.supp $(TSAN_OPTIONS)" \
		$(MAKE) BUILD=build/tsan BIN=build/tsan/bin CFLAGS="$(TSAN_FLAGS)" \
		TEST_BIN="$(TSAN_UNIT:%=build/tsan/tests/%)" CLI_TESTS="$(TSAN_CLI)" \
		check-unit check-cli

# The SIMD lanes' plain C (PM_NO_SIMD: what a compiler without SSE2
# builds), through the unit tests that hold lanes to one-at-a-time code:
# path mode's batches, light samples, camera rays, warps, the irradiance
# cache, photon emission.
NOSIMD_FLAGS = $(OPT) -g -DPM_NO_SIMD
NOSIMD_UNIT  = test_render test_light_rect test_camera test_sampling \
	       test_irradiance test_shoot
check-nosimd:
	$(MAKE) -j$(NPROC) BUILD=build/nosimd BIN=build/nosimd/bin \
		CFLAGS="$(NOSIMD_FLAGS)" $(NOSIMD_UNIT:%=build/nosimd/tests/%)
	$(MAKE) BUILD=build/nosimd BIN=build/nosimd/bin CFLAGS="$(NOSIMD_FLAGS)" \
		TEST_BIN="$(NOSIMD_UNIT:%=build/nosimd/tests/%)" check-unit

# libFuzzer targets (tests/fuzz/fuzz_*.c), built with clang, ASan and UBSan
# over their own copy of the library.  `make fuzz` fuzzes each for
# FUZZ_SECONDS; check-fuzz (run by `make test`) replays each committed
# corpus, then fuzzes each for CHECK_FUZZ_SECONDS; any crash fails.
FUZZ_TARGETS = $(sort $(patsubst tests/fuzz/fuzz_%.c,%,$(wildcard tests/fuzz/fuzz_*.c)))
FUZZ_BUILD   = build/fuzz
FUZZ_FLAGS   = -O1 -g -fsanitize=fuzzer-no-link,address,undefined \
	-fno-omit-frame-pointer -fno-sanitize-recover=undefined
FUZZ_SECONDS ?= 60
CHECK_FUZZ_SECONDS ?= 15

$(BUILD)/bin/fuzz_%: tests/fuzz/fuzz_%.c $(LIB)
	@mkdir -p $(dir $@)
	$(CC) $(PM_CFLAGS) $(CFLAGS) -fsanitize=fuzzer -o $@ $< $(LIB) $(PM_LIBS)

fuzz-build:
	$(MAKE) -j$(NPROC) BUILD=$(FUZZ_BUILD) CC=clang CFLAGS="$(FUZZ_FLAGS)" \
		$(FUZZ_TARGETS:%=$(FUZZ_BUILD)/bin/fuzz_%)

fuzz: fuzz-build
	@sh tests/fuzz/run.sh $(FUZZ_BUILD)/bin $(FUZZ_BUILD)/work $(FUZZ_SECONDS) $(FUZZ_TARGETS)

check-fuzz: fuzz-build
	@sh tests/fuzz/run.sh $(FUZZ_BUILD)/bin $(FUZZ_BUILD)/check $(CHECK_FUZZ_SECONDS) $(FUZZ_TARGETS)

check-man:
	@for m in $(MANS); do mandoc -T lint -W warning $$m || exit 1; done; \
	echo "man pages: $(words $(MANS)) linted clean"

# pm's bitmap lookups, for tests/mitsuba/texture_lookup.py.
$(BUILD)/tests/texlookup: tests/mitsuba/texlookup.c $(LIB)
	@mkdir -p $(dir $@)
	$(CC) $(PM_CFLAGS) $(CFLAGS) -o $@ tests/mitsuba/texlookup.c $(LIB) $(PM_LIBS)

# pm's principled BSDF values, for tests/mitsuba/bsdf_eval.py.
$(BUILD)/tests/bsdfeval: tests/mitsuba/bsdfeval.c $(LIB)
	@mkdir -p $(dir $@)
	$(CC) $(PM_CFLAGS) $(CFLAGS) -o $@ tests/mitsuba/bsdfeval.c $(LIB) $(PM_LIBS)

MITSUBA_PREREQ = $(BINS) $(BUILD)/tests/texlookup $(BUILD)/tests/bsdfeval $(BUILD)/tests/volgen $(DATA_GEN)
check-mitsuba: $(MITSUBA_PREREQ)
	@sh tests/mitsuba/compare.sh
	@sh tests/mitsuba/emitters.sh

# The Mitsuba renders that take minutes each (the media scenes: about 19 of
# check-mitsuba's 32 minutes of Mitsuba here), committed so that a fresh
# clone compares against them instead of rendering them
# (tests/mitsuba/references/README).  Remake them after editing one of
# these scenes or moving to another Mitsuba; the checks run as well.
MITSUBA_REFERENCE_CHECKS = fog-box glass-medium spot-haze haze-ball smoke hetero-box
mitsuba-references: $(MITSUBA_PREREQ)
	rm -f tests/mitsuba/references/*.exr tests/mitsuba/references/*.json
	MITSUBA_RECORD=tests/mitsuba/references \
		MITSUBA_ONLY="$(MITSUBA_REFERENCE_CHECKS)" sh tests/mitsuba/compare.sh

install: all
	install -d $(DESTDIR)$(PREFIX)/bin $(DESTDIR)$(PREFIX)/share/man/man1 \
		$(DESTDIR)$(PREFIX)/share/man/man5 $(DESTDIR)$(PREFIX)/share/man/man7
	install -m 755 $(BINS) $(DESTDIR)$(PREFIX)/bin
	for m in $(MANS); do s=$${m##*.}; \
		install -m 644 $$m $(DESTDIR)$(PREFIX)/share/man/man$$s; done

clean:
	rm -rf $(BUILD)/*.a $(BUILD)/common $(BUILD)/formats $(BUILD)/tools $(BUILD)/san $(BUILD)/tsan \
		$(BUILD)/tests $(BUILD)/fuzz bin out $(DATA_GEN)
