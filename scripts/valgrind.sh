#!/usr/bin/env bash
# valgrind memcheck of N (default 10000) instantiate / init / step / FMU-state / free cycles of
# an FMU's library, driven by a minimal C importer (scripts/valgrind_cycles.c), then dlclose.
# Usage: scripts/valgrind.sh [FMU] [N] [INPUT_VR OUTPUT_VR]   (FMU default target/fmu/MagSwarm.fmu;
#        for MagSwarmPID.fmu pass the vr of an input and an output, e.g. 3 10)
# Needs: valgrind, cc. Expect "ERROR SUMMARY: 0 errors" and "definitely lost: 0 bytes".
set -euo pipefail
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
FMU="$(realpath "${1:-$ROOT/target/fmu/MagSwarm.fmu}")"
N="${2:-10000}"
WORK="$(mktemp -d)"
trap 'rm -rf "$WORK"' EXIT
cc -O1 -g -o "$WORK/cycles" "$ROOT/scripts/valgrind_cycles.c" -ldl
(cd "$WORK" && unzip -q "$FMU" -d fmu)
ID="$(grep -o 'modelIdentifier="[^"]*"' "$WORK/fmu/modelDescription.xml" | head -1 | cut -d'"' -f2)"
GUID="$(grep -o 'guid="[^"]*"' "$WORK/fmu/modelDescription.xml" | head -1 | cut -d'"' -f2)"
valgrind --tool=memcheck --leak-check=full --show-leak-kinds=definite,indirect,possible \
    --errors-for-leak-kinds=definite,indirect,possible --error-exitcode=9 \
    "$WORK/cycles" "$WORK/fmu/binaries/linux64/$ID.so" "$GUID" "file://$WORK/fmu/resources" "$N" "${@:3}"
