#!/usr/bin/env bash
# Illumination-network benchmark (docs/illumination-network.md has the table it fills):
# for the office scene at two network sizes, the scan-conversion and Embree preprocesses,
# the distribution, the render, a re-render from the saved network (no preprocess) and a
# relight (light strengths doubled: load + distribution + render). Release build:
#   cargo build --release && benches/network.sh [OUT_DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
BIN=${RAYLINK:-${CARGO_TARGET_DIR:-target}/release/raylink}
OUT=${1:-$(mktemp -d)}
mkdir -p "$OUT"
SCENE=scenes/network-office.toml
COMMON=(--integrator network --slopes 20 --width 480 --height 360 --spp 1 --network-stats)
now() { date +%s.%N; }
for STEP in 0.03125 0.0078125; do
  NET="$OUT/office-$STEP.net"
  rm -f "$NET"
  echo "== office, --slopes 20 --intercept-step $STEP"
  for BUILDER in scan embree; do
    echo "-- $BUILDER preprocess"
    EXTRA=()
    [ "$BUILDER" = scan ] && EXTRA=(--network-file "$NET")
    t0=$(now)
    "$BIN" render "$SCENE" "${COMMON[@]}" --intercept-step "$STEP" \
      --network-builder "$BUILDER" "${EXTRA[@]}" -o "$OUT/office-$STEP-$BUILDER.exr" 2>&1
    echo "wall $(echo "$(now) - $t0" | bc) s"
  done
  echo "-- new view from the saved network (no preprocess)"
  t0=$(now)
  "$BIN" render "$SCENE" "${COMMON[@]}" --intercept-step "$STEP" --network-file "$NET" \
    -o "$OUT/office-$STEP-reuse.exr" 2>&1
  echo "wall $(echo "$(now) - $t0" | bc) s"
  echo "-- relight: --light-scale 2 from the saved network"
  t0=$(now)
  "$BIN" render "$SCENE" "${COMMON[@]}" --intercept-step "$STEP" --network-file "$NET" \
    --light-scale 2 -o "$OUT/office-$STEP-relight.exr" 2>&1
  echo "wall $(echo "$(now) - $t0" | bc) s"
  ls -l "$NET"
done
