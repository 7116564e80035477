# pipelines/accuracy.mk: what accuracy costs in time (docs/accuracy.md).
#
#   make accuracy-refs   long Mitsuba 3 references of every scene in data/
#                        at 128x128 (about 10 minutes on 2 cores, cached
#                        in build/mitsuba-cache/ by the scenes' content)
#   make accuracy        the study: pm's knobs swept on cornell-box,
#                        caustics, bunny-glass, bunny and spot-haze (media,
#                        against Mitsuba's volpath), each stage timed, error
#                        against the references; Mitsuba 3's path tracer at
#                        the same budgets; the plots under docs/accuracy/
#                        and the tables in out/accuracy/summary.md (about
#                        25 minutes on 2 cores once the references exist)
#
# Python comes from build/venv (tests/mitsuba/setup-venv.sh: Mitsuba 3 and
# numpy from PyPI), with matplotlib for the plots and, when it installs,
# flip-evaluator for FLIP.  Neither target is part of `make test`.

ACC_VENV ?= build/venv
ACC_PY   := $(ACC_VENV)/bin/python

.PHONY: accuracy accuracy-refs accuracy-venv

accuracy-venv:
	@PM_VENV=$(ACC_VENV) sh tests/mitsuba/setup-venv.sh
	@$(ACC_PY) -c 'import matplotlib' 2>/dev/null || \
		$(ACC_PY) -m pip install -q --disable-pip-version-check matplotlib
	@$(ACC_PY) -c 'import flip_evaluator' 2>/dev/null || \
		$(ACC_PY) -m pip install -q --disable-pip-version-check flip-evaluator || \
		echo "accuracy: flip-evaluator did not install; FLIP is left out"

accuracy-refs: accuracy-venv
	PM_VENV=$(ACC_VENV) sh tests/accuracy/references.sh

accuracy: deps
	$(MAKE) all
	$(MAKE) accuracy-refs
	$(ACC_PY) tests/accuracy/study.py
	$(ACC_PY) tests/accuracy/plot.py --machine "$$(nproc) cores of \
		$$(sed -n 's/^model name[^:]*: //p' /proc/cpuinfo | head -n 1), \
		Mitsuba $$($(ACC_PY) -c 'import mitsuba; print(mitsuba.__version__)') \
		$$(cat $(ACC_VENV)/pm-variant)"
