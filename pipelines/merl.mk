# pipelines/merl.mk: the bunny in a measured (MERL-layout) gold, through
# the photon pipeline.
#
#   bin/pm-merl --gold --------------------------> build/merl/gold.binary
#   data/bunny-merl.xml --pm-shoot--> out/bunny-merl-shot.pmap --pm-balance--> out/bunny-merl.pmap
#   data/bunny-merl.xml + out/bunny-merl.pmap --pm-render--> out/bunny-merl-2x.exr
#   out/bunny-merl-2x.exr --pm-downsample--> out/bunny-merl.exr, out/bunny-merl.png
#
# The gold is shiny, so pm-render path traces the bunny itself and gathers
# photons on the walls.  Included by the top-level Makefile; `make
# out/bunny-merl.png` builds everything it needs.

MERL_ALPHA       ?= 0.2
BUNNY_MERL_PHOTONS ?= 500000
BUNNY_MERL_SPP   ?= 16
BUNNY_MERL_SIZE  ?= 1024x1024
BUNNY_MERL_RENDER ?= --cache-step 8

build/merl/gold.binary: bin/pm-merl
	@mkdir -p build/merl
	bin/pm-merl -f -v --gold --alpha $(MERL_ALPHA) -o $@

out/bunny-merl-shot.pmap: data/bunny-merl.xml build/merl/gold.binary bin/pm-shoot
	@mkdir -p out
	bin/pm-shoot -f -v --photons $(BUNNY_MERL_PHOTONS) -o $@ data/bunny-merl.xml

out/bunny-merl.pmap: out/bunny-merl-shot.pmap bin/pm-balance
	bin/pm-balance -f -v -o $@ out/bunny-merl-shot.pmap

out/bunny-merl-2x.exr: data/bunny-merl.xml build/merl/gold.binary out/bunny-merl.pmap bin/pm-render
	bin/pm-render -f -v --spp $(BUNNY_MERL_SPP) --size $(BUNNY_MERL_SIZE) \
		$(BUNNY_MERL_RENDER) -o $@ data/bunny-merl.xml out/bunny-merl.pmap

out/bunny-merl.exr: out/bunny-merl-2x.exr bin/pm-downsample
	bin/pm-downsample -f --factor 2 --filter mitchell -o $@ out/bunny-merl-2x.exr

out/bunny-merl.png: out/bunny-merl.exr
	bin/pm-downsample -f --factor 1 -o $@ out/bunny-merl.exr
