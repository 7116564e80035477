#!/bin/sh
# setup-venv.sh: a Python virtual environment with Mitsuba 3 and numpy under
# build/venv, so that tests/mitsuba/compare.sh can check pm-render against
# Mitsuba's own path tracer on the same scene file.
#
# Run from the repository root. It is idempotent: when the environment is
# already there and works it only prints the variant and returns. It picks the
# fastest Mitsuba variant that really renders here (llvm_ad_rgb needs a libLLVM
# that Dr.Jit can drive; Debian's LLVM 15 is too old and aborts in the JIT) and
# records it in build/venv/pm-variant; scalar_rgb is the fallback.
#
# Failures are loud: no network or no pip means a non-zero exit, never a
# silent pass of the comparison.

set -eu

VENV=${PM_VENV:-build/venv}
VARIANT_FILE=$VENV/pm-variant

say() { printf 'setup-venv: %s\n' "$*"; }
die() { printf 'setup-venv: error: %s\n' "$*" >&2; exit 1; }

# Debian's python3 first: a pyenv shim may point at an interpreter that CI's
# fresh machine does not have.
if [ -x /usr/bin/python3 ]; then
	PY=/usr/bin/python3
elif command -v python3 >/dev/null 2>&1; then
	PY=$(command -v python3)
else
	die "no python3 found (Debian: apt-get install python3 python3-venv)"
fi

is_root() { [ "$(id -u)" = 0 ]; }

apt_install() {
	# Try with the lists we have, then once more after refreshing them.
	DEBIAN_FRONTEND=noninteractive apt-get install -y -qq \
	    --no-install-recommends "$@" >/dev/null 2>&1 && return 0
	DEBIAN_FRONTEND=noninteractive apt-get update -qq >/dev/null 2>&1 || true
	DEBIAN_FRONTEND=noninteractive apt-get install -y -qq \
	    --no-install-recommends "$@" >/dev/null 2>&1
}

# Renders a tiny scene in a child process: set_variant alone succeeds even
# when the JIT later aborts on an old libLLVM, so only a render proves it.
probe() {
	timeout 300 "$VENV/bin/python" - "$1" <<'EOF' >/dev/null 2>&1
import sys
import mitsuba as mi
mi.set_variant(sys.argv[1])
scene = mi.load_dict(mi.cornell_box())
img = mi.render(scene, spp=2)
import numpy as np
a = np.array(img)
sys.exit(0 if a.shape[-1] == 3 and np.isfinite(a).all() and a.mean() > 0 else 1)
EOF
}

ready() {
	[ -x "$VENV/bin/python" ] && [ -s "$VARIANT_FILE" ] &&
	    "$VENV/bin/python" -c 'import mitsuba, numpy' >/dev/null 2>&1
}

if ready; then
	say "ready: $("$VENV/bin/python" -c 'import mitsuba; print("mitsuba", mitsuba.__version__)'), variant $(cat "$VARIANT_FILE")"
	exit 0
fi

if [ ! -x "$VENV/bin/python" ]; then
	if ! "$PY" -c 'import venv, ensurepip' >/dev/null 2>&1; then
		if is_root && command -v apt-get >/dev/null 2>&1; then
			say "installing python3-venv"
			apt_install python3-venv || die "apt-get install python3-venv failed"
		else
			die "$PY lacks venv/ensurepip (Debian: apt-get install python3-venv)"
		fi
	fi
	say "creating $VENV with $PY"
	rm -rf "$VENV"
	mkdir -p "$(dirname "$VENV")"
	"$PY" -m venv "$VENV" || die "python3 -m venv $VENV failed"
fi

# The Mitsuba that the committed references were rendered with
# (tests/mitsuba/references/): their keys hold its version, so another one
# misses them all and check-mitsuba renders every reference afresh (about
# 20 minutes more).  MITSUBA_PIP overrides, e.g. MITSUBA_PIP=mitsuba for
# the newest.
MITSUBA_PIP=${MITSUBA_PIP:-mitsuba==3.9.1}
say "pip install $MITSUBA_PIP numpy"
"$VENV/bin/python" -m pip install -q --disable-pip-version-check "$MITSUBA_PIP" numpy ||
    die "pip install $MITSUBA_PIP numpy failed (is PyPI reachable?)"
"$VENV/bin/python" -c 'import mitsuba, numpy' ||
    die "mitsuba or numpy does not import after pip install"

variant=${MITSUBA_VARIANT:-}
if [ -z "$variant" ]; then
	if probe llvm_ad_rgb; then
		variant=llvm_ad_rgb
	elif is_root && command -v apt-get >/dev/null 2>&1 &&
	    say "llvm_ad_rgb does not render here; trying Debian's libllvm19" &&
	    apt_install libllvm19 && probe llvm_ad_rgb; then
		variant=llvm_ad_rgb
	else
		say "llvm_ad_rgb unusable here, falling back to scalar_rgb"
		probe scalar_rgb || die "even scalar_rgb does not render"
		variant=scalar_rgb
	fi
fi
printf '%s\n' "$variant" >"$VARIANT_FILE"
say "ready: $("$VENV/bin/python" -c 'import mitsuba; print("mitsuba", mitsuba.__version__)'), variant $variant"
