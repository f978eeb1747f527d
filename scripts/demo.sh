#!/usr/bin/env bash
# Build the FMU and run the demo closed-loop co-simulation (README's main command):
#
#   bash scripts/demo.sh
#
# 1. scripts/setup.sh (idempotent)
# 2. cargo build --release --workspace
# 3. target/release/magswarm fmu                      -> target/fmu/MagSwarm.fmu
# 4. target/release/magswarm fmu --pid                -> target/fmu/MagSwarmPID.fmu (the controller FMU)
# 5. the Rust harness: cargo run --release --example pid_tracking   -> target/demo/pid_tracking.csv (+ .png)
# 6. the fmpy script:  .venv/bin/python examples/pid_tracking.py     -> target/demo/pid_tracking_fmpy.csv
#    (MagSwarm.fmu + MagSwarmPID.fmu, Python as the master)
# 7. libcosim: the same script with --libcosim systems/magswarm_pid    -> target/demo/pid_tracking_libcosim.csv
#    (SystemStructure.ssd wiring MagSwarmPID.fmu to MagSwarm.fmu)
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
export CARGO_TERM_COLOR="${CARGO_TERM_COLOR:-never}"

FMU="target/fmu/MagSwarm.fmu"
OUT="target/demo"

say() { printf '\n=== [demo] %s\n' "$*"; }
fail() { printf '\n=== [demo] FAILED: %s\n' "$*" >&2; exit 1; }
step() {
    local what="$1"; shift
    say "$what"
    "$@" || fail "$what (exit $?; command: $*)"
}

step "setup (scripts/setup.sh)" bash scripts/setup.sh
step "cargo build --release --workspace" cargo build --release --workspace
[ -x target/release/magswarm ] || fail "target/release/magswarm was not built"
step "package the FMU: target/release/magswarm fmu" target/release/magswarm fmu
[ -s "$FMU" ] || fail "target/release/magswarm fmu ran but $FMU is missing"
ls -l "$FMU"

mkdir -p "$OUT"
missing=()
[ -f examples/pid_tracking.rs ] || missing+=("examples/pid_tracking.rs (the Rust PID harness)")
[ -f examples/pid_tracking.py ] || missing+=("examples/pid_tracking.py (the fmpy PID script)")
if [ "${#missing[@]}" -gt 0 ]; then
    printf '[demo] not written yet: %s\n' "${missing[@]}" >&2
    fail "the closed-loop demo needs the examples above; the FMU itself is ready at $FMU"
fi

PID_FMU="target/fmu/MagSwarmPID.fmu"
step "package the controller FMU: target/release/magswarm fmu --pid" target/release/magswarm fmu --pid
[ -s "$PID_FMU" ] || fail "target/release/magswarm fmu --pid ran but $PID_FMU is missing"

step "closed loop from the Rust harness (fmi crate importer)" \
    cargo run --release --example pid_tracking -- --fmu "$FMU" --out "$OUT/pid_tracking.csv" \
    --plot "$OUT/pid_tracking.png"
step "closed loop from fmpy (MagSwarm.fmu + MagSwarmPID.fmu)" \
    .venv/bin/python examples/pid_tracking.py --fmu "$FMU" --pid-fmu "$PID_FMU" \
    --out "$OUT/pid_tracking_fmpy.csv" --plot "$OUT/pid_tracking_fmpy.png"
step "closed loop in libcosim (systems/magswarm_pid/SystemStructure.ssd)" \
    .venv/bin/python examples/pid_tracking.py --fmu "$FMU" --pid-fmu "$PID_FMU" \
    --libcosim systems/magswarm_pid --system ssp --out "$OUT/pid_tracking_libcosim.csv"

say "done"
for f in "$OUT"/pid_tracking.csv "$OUT"/pid_tracking_fmpy.csv "$OUT"/pid_tracking_libcosim.csv "$OUT"/*.png; do
    [ -e "$f" ] && printf '  %s\n' "$f"
done
exit 0
