# pipelines/bunny.mk: the demo.  data/bunny.xml rendered at twice the final
# size and filtered down to out/bunny.exr (linear) and out/bunny.png (sRGB).
# Included by the top-level Makefile; `make demo` builds out/bunny.png.

BUNNY_SPP  ?= 16
BUNNY_SIZE ?= 1024x1024
BUNNY_FILTER ?= mitchell

out/bunny-2x.exr: data/bunny.xml bin/pm-render
	@mkdir -p out
	bin/pm-render -v --spp $(BUNNY_SPP) --size $(BUNNY_SIZE) -o $@ data/bunny.xml

out/bunny.exr: out/bunny-2x.exr bin/pm-downsample
	bin/pm-downsample --factor 2 --filter $(BUNNY_FILTER) -o $@ out/bunny-2x.exr

out/bunny.png: out/bunny.exr
	bin/pm-downsample --factor 1 -o $@ out/bunny.exr
