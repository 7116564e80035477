# pipelines/bunny.mk: the demo, through the photon pipeline.
#
#   data/bunny.xml --pm-shoot--> out/bunny-shot.pmap --pm-balance--> out/bunny.pmap
#   data/bunny.xml + out/bunny.pmap --pm-render--> out/bunny-2x.exr (1024x1024)
#   out/bunny-2x.exr --pm-downsample--> out/bunny.exr (512x512), out/bunny.png
#
# The map depends on the scene only, so changing the camera or the sample
# count re-renders without re-shooting.  Included by the top-level Makefile;
# `make demo` builds out/bunny.png.

BUNNY_PHOTONS  ?= 1000000
BUNNY_CAUSTIC  ?= 1000000
BUNNY_SPP      ?= 4
BUNNY_SIZE     ?= 1024x1024
BUNNY_FILTER   ?= mitchell
BUNNY_RENDER   ?= --lookup-size 120 --direct-samples 4

out/bunny-shot.pmap: data/bunny.xml bin/pm-shoot
	@mkdir -p out
	bin/pm-shoot -f -v --photons $(BUNNY_PHOTONS) \
		--caustic-photons $(BUNNY_CAUSTIC) -o $@ data/bunny.xml

out/bunny.pmap: out/bunny-shot.pmap bin/pm-balance
	bin/pm-balance -f -v -o $@ out/bunny-shot.pmap

out/bunny-2x.exr: data/bunny.xml out/bunny.pmap bin/pm-render
	bin/pm-render -f -v --spp $(BUNNY_SPP) --size $(BUNNY_SIZE) $(BUNNY_RENDER) \
		-o $@ data/bunny.xml out/bunny.pmap

out/bunny.exr: out/bunny-2x.exr bin/pm-downsample
	bin/pm-downsample -f --factor 2 --filter $(BUNNY_FILTER) -o $@ out/bunny-2x.exr

out/bunny.png: out/bunny.exr
	bin/pm-downsample -f --factor 1 -o $@ out/bunny.exr

# The path-traced reference of the same view, for comparison.
out/bunny-path-2x.exr: data/bunny.xml bin/pm-render
	@mkdir -p out
	bin/pm-render -f -v --spp 64 --size $(BUNNY_SIZE) -o $@ data/bunny.xml

out/bunny-path.png: out/bunny-path-2x.exr bin/pm-downsample
	bin/pm-downsample -f --factor 2 --filter $(BUNNY_FILTER) -o $@ out/bunny-path-2x.exr
