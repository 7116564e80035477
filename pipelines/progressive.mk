# pipelines/progressive.mk: probabilistic progressive photon mapping
# (Knaus and Zwicker 2011) as independent passes averaged by make.
#
#   make progressive                   PROG_PASSES passes of PROG_SCENE
#   make -j2 progressive               passes in parallel
#   make progressive PROG_PASSES=64    more passes; the first ones are kept
#
#   pass i:  pm-shoot --seed i | pm-balance --pass i --> pass-00i.pmap (deleted after)
#            pm-render --pass i --seed i     --> pass-00i.exr
#   mean i:  pm-downsample pass-001..00i.exr --> mean-00i.exr
#
# Every pass has its own photons and its own render seed, and estimates
# with fixed radii that shrink along Knaus and Zwicker's schedule (the
# irradiance records in pm-balance(1), the caustics in pm-render(1), both
# --pass), so the mean of the passes converges to the right image.  The
# running mean is written after each pass (mean-NNN.exr, and the latest as
# $(PROG_DIR).png): stop make at any point and keep the image of the passes
# done.  Raising PROG_PASSES re-renders nothing already rendered.

PROG_SCENE   ?= data/caustics.xml
PROG_PASSES  ?= 16
PROG_PHOTONS ?= 200000
PROG_CAUSTIC ?= 200000
PROG_SPP     ?= 4
PROG_SIZE    ?= 256x256
PROG_ALPHA   ?= 0.6666667
PROG_RENDER  ?=
PROG_NAME    := $(basename $(notdir $(PROG_SCENE)))
PROG_DIR     := out/progressive/$(PROG_NAME)
PROG_IDS     := $(shell i=1; while [ $$i -le $(PROG_PASSES) ]; do \
	printf '%03d ' $$i; i=$$((i+1)); done)
PROG_MEANS   := $(PROG_IDS:%=$(PROG_DIR)/mean-%.exr)
PROG_LAST    := $(lastword $(PROG_MEANS))

.PHONY: progressive
progressive: $(PROG_DIR).png

# A pass's map is needed only for its render: deleted once that is done.
.INTERMEDIATE: $(PROG_IDS:%=$(PROG_DIR)/pass-%.pmap)

$(PROG_DIR)/pass-%.pmap: $(PROG_SCENE) bin/pm-shoot bin/pm-balance
	@mkdir -p $(PROG_DIR)
	bin/pm-shoot -q -f --seed $$(expr $* + 0) --photons $(PROG_PHOTONS) \
		--caustic-photons $(PROG_CAUSTIC) -o $@.shot $(PROG_SCENE)
	bin/pm-balance -q -f --pass $$(expr $* + 0) --alpha $(PROG_ALPHA) -o $@ $@.shot
	@rm -f $@.shot

$(PROG_DIR)/pass-%.exr: $(PROG_DIR)/pass-%.pmap bin/pm-render
	bin/pm-render -f -q --pass $$(expr $* + 0) --seed $$(expr $* + 0) \
		--alpha $(PROG_ALPHA) --spp $(PROG_SPP) --size $(PROG_SIZE) \
		$(PROG_RENDER) -o $@ $(PROG_SCENE) $<

# mean-NNN.exr averages passes 1 to NNN.
define PROG_MEAN_RULE
$(PROG_DIR)/mean-$(1).exr: $(wordlist 1,$(2),$(PROG_IDS:%=$(PROG_DIR)/pass-%.exr)) bin/pm-downsample
	bin/pm-downsample -f -q -o $$@ $(wordlist 1,$(2),$(PROG_IDS:%=$(PROG_DIR)/pass-%.exr))
endef
$(foreach i,$(PROG_IDS),$(eval $(call PROG_MEAN_RULE,$(i),$(shell expr $(i) + 0))))

$(PROG_DIR).png: $(PROG_MEANS)
	bin/pm-downsample -f -q -o $@ $(PROG_LAST)
