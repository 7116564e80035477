# pipelines/bench.mk: `make bench`, pm's speed (tests/bench/bench.sh): the
# kd-tree against FLANN, photon tracing against plain Embree ray casts,
# the speed-up over threads, bytes per photon.  One table on stdout, JSON
# in out/bench/bench.json; about 2 minutes on 2 cores (106-126 s at stop 22); no pass or fail.
# Past commits' kd-tree walks against this one's, on the same photons and
# radii: sh tests/bench/range_vs.sh BEFORE AFTER SHOT.pmap (see the script).

.PHONY: bench

$(BUILD)/tests/bench: tests/bench/bench.c $(LIB)
	@mkdir -p $(dir $@)
	$(CC) $(PM_CFLAGS) $(CFLAGS) -o $@ tests/bench/bench.c $(LIB) $(PM_LIBS) \
	    -Wl,--wrap=pm_accel_intersect -Wl,--wrap=pm_accel_intersect_n

bench: deps
	$(MAKE) all $(BUILD)/tests/bench
	BIN=$(BIN) BENCH=$(BUILD)/tests/bench sh tests/bench/bench.sh
