#!/usr/bin/env bash
# The project's test command (README, and .ci/run):
#
#   bash scripts/test.sh
#
# 1. scripts/setup.sh            (apt packages, .venv with fmpy/pytest/libcosimpy; idempotent)
#    then the lint gates: cargo fmt --check, clippy -D warnings (workspace lints in Cargo.toml),
#    rustdoc with warnings denied
# 2. cargo build --release --workspace
# 3. target/release/magswarm fmu (packages target/fmu/MagSwarm.fmu, used by the tests below),
#    and the FMI 3.0 plant and both controller FMUs (target/fmu/fmi3/, target/fmu/MagSwarmPID.fmu)
# 4. cargo nextest run --workspace --release (cargo test when nextest is absent) + doc tests
# 5. .venv/bin/python -m pytest tests/python
#
# Stops at the first failing step and says which. Knobs:
#   MAGSWARM_SKIP_DOCTESTS=1   skip `cargo test --doc`
#   MAGSWARM_NO_NEXTEST=1      use `cargo test` even where nextest is installed
#   PYTEST_ARGS="-k state"     extra arguments for pytest
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"

export CARGO_TERM_COLOR="${CARGO_TERM_COLOR:-never}"
FMU="$ROOT/target/fmu/MagSwarm.fmu"
export MAGSWARM_FMU="${MAGSWARM_FMU:-$FMU}"

T0=$SECONDS
CURRENT=""
say() { printf '\n=== [test] %s\n' "$*"; }
fail() { printf '\n=== [test] FAILED: %s\n' "$*" >&2; exit 1; }
step() {
    CURRENT="$1"; shift
    say "$CURRENT"
    local t=$SECONDS
    "$@" || fail "$CURRENT (exit $?; command: $*)"
    printf '=== [test] %s: ok (%ds)\n' "$CURRENT" $((SECONDS - t))
}

# A clean run writes about 1.3 GB under target/ (release build, tests, examples) and 0.6 GB of
# venv; with room for the linker's temporaries, 3 GB. A full disk shows up much later as an
# obscure compiler error ("No space left on device"), so say it first.
need_gb=3
free_gb=$(df -Pk "$ROOT" | awk 'NR == 2 { printf "%d", $4 / 1048576 }')
if [ "${free_gb:-0}" -lt "$need_gb" ]; then
    printf '\n=== [test] WARNING: %s GB free on the filesystem of %s; the build and tests need about %s GB (cargo clean in other checkouts frees space)\n' \
        "$free_gb" "$ROOT" "$need_gb" >&2
fi

step "setup (scripts/setup.sh)" bash "$ROOT/scripts/setup.sh"

step "cargo fmt --all -- --check" cargo fmt --all -- --check

step "cargo build --release --workspace" \
    cargo build --release --workspace

step "cargo clippy --release --workspace --all-targets -- -D warnings" \
    cargo clippy --release --workspace --all-targets -- -D warnings

step "cargo doc --release --workspace --no-deps (rustdoc warnings denied)" \
    env RUSTDOCFLAGS="-D warnings" cargo doc --release --workspace --no-deps

[ -x target/release/magswarm ] || fail "target/release/magswarm was not built"

package_fmu() {
    rm -f "$FMU"
    target/release/magswarm fmu || return 1
    [ -s "$FMU" ] || { echo "magswarm fmu succeeded but $FMU is missing or empty" >&2; return 1; }
    ls -l "$FMU"
}
step "package the FMU (target/release/magswarm fmu -> target/fmu/MagSwarm.fmu)" package_fmu

package_more() {
    local args
    for args in "--fmi-version 3" "--pid" "--pid --fmi-version 3"; do
        # shellcheck disable=SC2086
        target/release/magswarm fmu --no-build $args || return 1
    done
}
step "package the FMI 3.0 FMU and the controller FMUs (target/fmu/fmi3/, target/fmu/MagSwarmPID.fmu)" package_more

if [ "${MAGSWARM_NO_NEXTEST:-0}" != 1 ] && cargo nextest --version >/dev/null 2>&1; then
    step "cargo nextest run --workspace --release" \
        cargo nextest run --workspace --release --no-fail-fast
    if [ "${MAGSWARM_SKIP_DOCTESTS:-0}" != 1 ]; then
        step "cargo test --doc --workspace --release" cargo test --doc --workspace --release
    fi
else
    step "cargo test --workspace --release" cargo test --workspace --release --no-fail-fast
fi

run_pytest() {
    local rc=0
    # shellcheck disable=SC2086
    "$ROOT/.venv/bin/python" -m pytest tests/python -q -rs ${PYTEST_ARGS:-} || rc=$?
    case "$rc" in
        0) return 0 ;;
        5) echo "pytest collected no tests in tests/python: that is a failure, not a pass" >&2; return 5 ;;
        *) return "$rc" ;;
    esac
}
step "pytest tests/python (fmpy, libcosimpy; FMU=$MAGSWARM_FMU)" run_pytest

printf '\n=== [test] all steps passed in %ds\n' $((SECONDS - T0))
