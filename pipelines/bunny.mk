# pipelines/bunny.mk: the demo, through the photon pipeline.
#
#   data/bunny.xml --pm-shoot--> out/bunny-shot.pmap --pm-balance--> out/bunny.pmap
#   data/bunny.xml + out/bunny.pmap --pm-render--> out/bunny-2x.exr (1024x1024)
#   out/bunny-2x.exr --pm-downsample--> out/bunny.exr (512x512), out/bunny.png
#
# The map depends on the scene only, so changing the camera or the sample
# count re-renders without re-shooting.  Included by the top-level Makefile;
# `make demo` builds out/bunny.png.
#
# Indirect light comes from final gathering into the map's precomputed
# irradiance records, cached on a grid of every 8th pixel of the 1024x1024
# render (every 4th of the final image) with 512 rays per grid point; 16
# samples per pixel (4 x 4 strata).  BUNNY_SEED seeds both the photons and
# the camera samples: two renders with different seeds differ only by the
# estimate's noise (`make demo BUNNY_SEED=11`, then 22, and
# tests/accuracy/seeds.py out/bunny-seed11.exr out/bunny-seed22.exr;
# docs/accuracy.md measures it).

BUNNY_SEED     ?= 0
BUNNY_PHOTONS  ?= 500000
BUNNY_CAUSTIC  ?= 250000
BUNNY_SPP      ?= 16
BUNNY_SIZE     ?= 1024x1024
BUNNY_FILTER   ?= mitchell
BUNNY_RENDER   ?= --cache-step 8 --cache-rays 512

# BUNNY_SEED 0 writes out/bunny.*; another seed writes out/bunny-seedN.*,
# so that renders of two seeds stand side by side and make knows which
# files a seed made.
BUNNY := out/bunny$(if $(filter-out 0,$(BUNNY_SEED)),-seed$(BUNNY_SEED))

$(BUNNY)-shot.pmap: data/bunny.xml bin/pm-shoot
	@mkdir -p out
	bin/pm-shoot -f -v --seed $(BUNNY_SEED) --photons $(BUNNY_PHOTONS) \
		--caustic-photons $(BUNNY_CAUSTIC) -o $@ data/bunny.xml

$(BUNNY).pmap: $(BUNNY)-shot.pmap bin/pm-balance
	bin/pm-balance -f -v -o $@ $(BUNNY)-shot.pmap

$(BUNNY)-2x.exr: data/bunny.xml $(BUNNY).pmap bin/pm-render
	bin/pm-render -f -v --seed $(BUNNY_SEED) --spp $(BUNNY_SPP) --size $(BUNNY_SIZE) $(BUNNY_RENDER) \
		-o $@ data/bunny.xml $(BUNNY).pmap

$(BUNNY).exr: $(BUNNY)-2x.exr bin/pm-downsample
	bin/pm-downsample -f --factor 2 --filter $(BUNNY_FILTER) -o $@ $(BUNNY)-2x.exr

$(BUNNY).png: $(BUNNY).exr
	bin/pm-downsample -f --factor 1 -o $@ $(BUNNY).exr

# The path-traced reference of the same view, for comparison.
out/bunny-path-2x.exr: data/bunny.xml bin/pm-render
	@mkdir -p out
	bin/pm-render -f -v --spp 64 --size $(BUNNY_SIZE) -o $@ data/bunny.xml

out/bunny-path.png: out/bunny-path-2x.exr bin/pm-downsample
	bin/pm-downsample -f --factor 2 --filter $(BUNNY_FILTER) -o $@ out/bunny-path-2x.exr
