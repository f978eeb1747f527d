#!/usr/bin/env bash
# The hardware bridge end to end on emulated devices, one command:
#
#   bash scripts/bridge_demo.sh
#
# 1. builds magswarm-bridge (release);
# 2. `magswarm-bridge emulate` serves the UR controller (RTDE 30004, dashboard 29999,
#    secondary interface 30002) on a loopback address and the TMCL stepper on a pty;
# 3. `magswarm-bridge run --targets` closes the loop with the PID of magswarm-control:
#    RTDE and TMCL to the emulated devices, frames from the emulated camera (a virtual swarm
#    driven by the robot's reported pose and the stepper's frequency), radii measured by
#    magswarm-vision, a shadow model beside it;
# 4. plots the tracking (target/bridge_demo/tracking.png; needs matplotlib, skipped without);
# 5. builds the rig FMU for the same config (magswarm-bridge fmu -> MagSwarmRig.fmu) and drives
#    it with fmpy: a step of z_m and omega_m, 8 s in real time (needs the .venv of
#    scripts/setup.sh, skipped without).
#
# Output: target/bridge_demo/{log.csv,tracking.png,emulate.log,MagSwarmRig.fmu,rig_fmu.csv,
# rig_fmu.png}. The run takes 40 s, the FMU 8 s (wall time: the devices and the camera run in
# real time).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
OUT="$ROOT/target/bridge_demo"
mkdir -p "$OUT"
cargo build --release -p magswarm-bridge -p magswarm-rig-fmu
BRIDGE="$ROOT/target/release/magswarm-bridge"

# A loopback address of our own, so the standard UR ports do not clash with anything.
HOST="127.$((RANDOM % 250 + 2)).$((RANDOM % 250 + 2)).$((RANDOM % 250 + 2))"
sed -e "s/^host = .*/host = \"$HOST\"/" \
    -e "s|^device = .*|device = \"$OUT/tmcl\"|" \
    examples/bridge/rig_emulated.toml > "$OUT/rig.toml"

"$BRIDGE" emulate --config "$OUT/rig.toml" > "$OUT/emulate.out" 2> "$OUT/emulate.log" &
EMU=$!
trap 'kill -TERM $EMU 2>/dev/null || true; wait $EMU 2>/dev/null || true' EXIT
for _ in $(seq 100); do grep -q '^ready$' "$OUT/emulate.out" 2>/dev/null && break; sleep 0.1; done
grep -q '^ready$' "$OUT/emulate.out" || { cat "$OUT/emulate.log" >&2; exit 1; }
cat "$OUT/emulate.out"

"$BRIDGE" check --config "$OUT/rig.toml"
"$BRIDGE" run --config "$OUT/rig.toml" --targets examples/bridge/targets.csv \
    --log "$OUT/log.csv"

if [ -x .venv/bin/python ]; then
    .venv/bin/python examples/bridge/plot_tracking.py "$OUT/log.csv" "$OUT/tracking.png" || true
fi
echo "log: $OUT/log.csv"

# The same rig as an FMU: built from the same config, driven by fmpy.
"$BRIDGE" fmu --config "$OUT/rig.toml" --out "$OUT/MagSwarmRig.fmu"
if [ -x .venv/bin/python ]; then
    .venv/bin/python examples/bridge/rig_fmu_step.py "$OUT/MagSwarmRig.fmu" "$OUT/rig_fmu.csv" \
        "$OUT/rig_fmu.png"
else
    echo "no .venv (bash scripts/setup.sh): the rig FMU was built, not run"
fi
