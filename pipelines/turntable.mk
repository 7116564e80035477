# pipelines/turntable.mk: one photon map, many cameras.
#
#   make turntable          every frame of data/turntable.cams, as PNGs
#   make -j2 turntable      frames in parallel
#
# Each line of data/turntable.cams is one camera (EYE TARGET UP [FOV], see
# pm-render(1)).  Every frame depends on its own line, extracted into
# out/turntable/cam-NN.txt and rewritten only when that line changed, so
# editing one camera re-renders that frame only; all frames share
# out/bunny.pmap, shot once (pipelines/bunny.mk).

TT_CAMS   ?= data/turntable.cams
TT_SCENE  ?= data/bunny.xml
TT_MAP    ?= out/bunny.pmap
TT_SPP    ?= 16
TT_SIZE   ?= 512x512
TT_RENDER ?=
TT_N      := $(shell grep -cv '^[[:space:]]*\(#\|$$\)' $(TT_CAMS) 2>/dev/null || echo 0)
TT_IDS    := $(shell i=1; while [ $$i -le $(TT_N) ]; do printf '%02d ' $$i; i=$$((i+1)); done)
TT_PNGS   := $(TT_IDS:%=out/turntable/frame-%.png)

.PHONY: turntable FORCE
turntable: $(TT_PNGS)

# Keep the per-frame cameras and renders: they are what makes an edit to
# one camera re-render one frame.
.PRECIOUS: out/turntable/cam-%.txt out/turntable/frame-%.exr

# Camera NN's line, rewritten only when it differs from what is there.
out/turntable/cam-%.txt: FORCE
	@mkdir -p out/turntable
	@grep -v '^[[:space:]]*\(#\|$$\)' $(TT_CAMS) | sed -n "$$(expr $* + 0)p" > $@.new
	@if cmp -s $@.new $@; then rm -f $@.new; else mv $@.new $@; fi

out/turntable/frame-%.exr: out/turntable/cam-%.txt $(TT_MAP) $(TT_SCENE) bin/pm-render
	bin/pm-render -f -q --spp $(TT_SPP) --size $(TT_SIZE) $(TT_RENDER) \
		--cameras out/turntable/cam-$*.txt -o $@ $(TT_SCENE) $(TT_MAP)

out/turntable/frame-%.png: out/turntable/frame-%.exr bin/pm-downsample
	bin/pm-downsample -f --factor 1 -o $@ $<

FORCE:
