#!/usr/bin/env bash
# Idempotent installer for a fresh Debian machine (run as root, or with sudo available).
#
#   bash scripts/setup.sh
#
# - apt packages the build needs (libclang-dev for the `fmi` crate's bindgen), installed only when
#   missing; `apt-get update` runs at most once, and only if something must be installed;
# - a Python venv at .venv (created only if missing or broken) with requirements.txt installed;
#   pip runs only when requirements.txt changed since the last successful install (stamp file),
#   or when a required module is missing;
# - optional extras (requirements-optional.txt: matplotlib) tried once per change, never fatal;
# - fmi-sim 0.7 (rust-fmi's FMI 2.0/3.0 simulator, the second FMI 3.0 importer the tests use),
#   `cargo install`ed into $CARGO_HOME/bin only when that exact version is not there yet
#   (about 3-5 min of compilation once per machine, arrow included; then a version check).
#
# Works without a TTY and under CI=true. Environment knobs:
#   MAGSWARM_PYTHON   interpreter used to create the venv (default: python3.11, else python3)
#   MAGSWARM_VENV     venv directory (default: <repo>/.venv)
#   MAGSWARM_SKIP_APT=1  skip the apt step (e.g. on a non-Debian machine that already has libclang)
#   MAGSWARM_SKIP_FMI_SIM=1  do not install fmi-sim (its tests then skip, or fail under CI)
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"

VENV="${MAGSWARM_VENV:-$ROOT/.venv}"
REQ="$ROOT/requirements.txt"
REQ_OPT="$ROOT/requirements-optional.txt"
export DEBIAN_FRONTEND=noninteractive
export PIP_DISABLE_PIP_VERSION_CHECK=1 PIP_NO_INPUT=1 PIP_PROGRESS_BAR=off

say() { printf '[setup] %s\n' "$*"; }
die() { printf '[setup] ERROR: %s\n' "$*" >&2; exit 1; }

# ---------------------------------------------------------------- apt
APT_PACKAGES=(libclang-dev)

SUDO=""
if [ "$(id -u)" -ne 0 ]; then
    if command -v sudo >/dev/null 2>&1; then SUDO="sudo -n"; fi
fi

apt_updated=0
apt_install() {
    # apt_install PKG...: install the packages given (they are known to be missing)
    command -v apt-get >/dev/null 2>&1 || die "apt-get not found; install these by hand: $*"
    if [ "$(id -u)" -ne 0 ] && [ -z "$SUDO" ]; then
        die "not root and no sudo: install these by hand: $*"
    fi
    if [ "$apt_updated" -eq 0 ]; then
        say "apt-get update"
        $SUDO apt-get update -qq >/dev/null || die "apt-get update failed"
        apt_updated=1
    fi
    say "apt-get install $*"
    $SUDO apt-get install -y -qq --no-install-recommends "$@" >/dev/null \
        || die "apt-get install $* failed"
}

pkg_missing() { [ "$(dpkg-query -W -f='${Status}' "$1" 2>/dev/null)" != "install ok installed" ]; }

if [ "${MAGSWARM_SKIP_APT:-0}" != 1 ]; then
    if command -v dpkg >/dev/null 2>&1; then
        missing=()
        for p in "${APT_PACKAGES[@]}"; do pkg_missing "$p" && missing+=("$p"); done
        if [ "${#missing[@]}" -gt 0 ]; then apt_install "${missing[@]}"; else say "apt packages present: ${APT_PACKAGES[*]}"; fi
    else
        say "no dpkg here: skipping apt (need: ${APT_PACKAGES[*]})"
    fi
fi

# ---------------------------------------------------------------- toolchain check
command -v cargo >/dev/null 2>&1 || die "cargo not found: install a Rust toolchain (rustup) first"
# The lint gates of the test command need rustfmt and clippy (components of the toolchain).
for comp in rustfmt clippy; do
    if ! cargo "${comp/rustfmt/fmt}" --version >/dev/null 2>&1; then
        if command -v rustup >/dev/null 2>&1; then
            say "rustup component add $comp"
            rustup component add "$comp" || die "rustup component add $comp failed"
        else
            die "cargo ${comp/rustfmt/fmt} is missing and there is no rustup to add it: install the $comp component"
        fi
    fi
done

# ---------------------------------------------------------------- python
pick_python() {
    if [ -n "${MAGSWARM_PYTHON:-}" ]; then echo "$MAGSWARM_PYTHON"; return; fi
    for c in python3.11 python3; do
        if command -v "$c" >/dev/null 2>&1 && "$c" -c 'import sys; sys.exit(0 if sys.version_info >= (3, 11) else 1)' 2>/dev/null; then
            echo "$c"; return
        fi
    done
    echo ""
}

venv_ok() { [ -x "$VENV/bin/python" ] && "$VENV/bin/python" -c 'import sys, pip' >/dev/null 2>&1; }

if ! venv_ok; then
    PY="$(pick_python)"
    if [ -z "$PY" ]; then
        say "no python >= 3.11 found; installing Debian's python3"
        apt_install python3 python3-venv python3-pip
        PY="$(pick_python)"
        [ -n "$PY" ] || die "need Python >= 3.11 (libcosimpy wheels are built for 3.11-3.14)"
    fi
    # Debian's python3 has venv without ensurepip unless python3-venv is installed.
    if ! "$PY" -c 'import venv, ensurepip' >/dev/null 2>&1; then
        v="$("$PY" -c 'import sys; print(f"{sys.version_info[0]}.{sys.version_info[1]}")')"
        apt_install "python${v}-venv"
    fi
    rm -rf "$VENV"
    say "creating venv $VENV with $("$PY" --version 2>&1)"
    "$PY" -m venv "$VENV" || die "python -m venv failed"
    "$VENV/bin/python" -m pip install -q --upgrade pip >/dev/null 2>&1 || say "pip upgrade failed (continuing with the bundled pip)"
fi

VPY="$VENV/bin/python"
pyver="$("$VPY" -c 'import sys; print(sys.version.split()[0])')"

stamp_of() { { cat "$1"; echo "python=$pyver"; } | sha256sum | cut -d' ' -f1; }

modules_present() {
    "$VPY" - <<'EOF' >/dev/null 2>&1
import importlib.util, sys
sys.exit(0 if all(importlib.util.find_spec(m) for m in ("fmpy", "numpy", "pytest", "libcosimpy")) else 1)
EOF
}

STAMP="$VENV/.magswarm-requirements.sha256"
want="$(stamp_of "$REQ")"
if [ -f "$STAMP" ] && [ "$(cat "$STAMP")" = "$want" ] && modules_present; then
    say "python packages up to date ($pyver: fmpy, numpy, pytest, libcosimpy)"
else
    say "pip install -r requirements.txt"
    "$VPY" -m pip install -q -r "$REQ" || die "pip install -r requirements.txt failed"
    modules_present || die "packages installed but fmpy/numpy/pytest/libcosimpy cannot be imported"
    "$VPY" -c 'import libcosimpy._internal as i; i.libcosimc()' \
        || die "libcosimpy is installed but its bundled libcosimc.so does not load"
    echo "$want" > "$STAMP"
fi

if [ -f "$REQ_OPT" ]; then
    OSTAMP="$VENV/.magswarm-optional.sha256"
    owant="$(stamp_of "$REQ_OPT")"
    if [ -f "$OSTAMP" ] && [ "$(cat "$OSTAMP")" = "$owant" ]; then
        :
    else
        say "pip install -r requirements-optional.txt (optional: plots)"
        if "$VPY" -m pip install -q -r "$REQ_OPT" >/dev/null 2>&1; then
            say "optional extras installed"
        else
            say "optional extras unavailable (plots will be skipped)"
        fi
        # Stamp either way: do not retry a failing optional install on every run.
        echo "$owant" > "$OSTAMP"
    fi
fi

# ---------------------------------------------------------------- fmi-sim
FMI_SIM_VERSION=0.7.0
FMI_SIM="${CARGO_HOME:-$HOME/.cargo}/bin/fmi-sim"
if [ "${MAGSWARM_SKIP_FMI_SIM:-0}" = 1 ]; then
    say "fmi-sim: skipped (MAGSWARM_SKIP_FMI_SIM=1)"
elif [ -x "$FMI_SIM" ] && { "$FMI_SIM" --version 2>&1 || true; } | grep -q "fmi-sim $FMI_SIM_VERSION"; then
    say "fmi-sim $FMI_SIM_VERSION present ($FMI_SIM)"
else
    say "cargo install fmi-sim --version $FMI_SIM_VERSION --locked (once per machine, a few minutes)"
    t0=$SECONDS
    cargo install fmi-sim --version "$FMI_SIM_VERSION" --locked --quiet \
        || die "cargo install fmi-sim failed"
    say "fmi-sim installed in $((SECONDS - t0)) s"
fi

say "ok ($("$VPY" -c 'import fmpy, numpy, libcosimpy.__about__ as a; print(f"fmpy {fmpy.__version__}, numpy {numpy.__version__}, libcosimpy {a.__version__}")' 2>/dev/null || echo "venv ready"))"
