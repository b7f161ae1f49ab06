#!/bin/bash
# Figures of record 2026-12-03c (issue 44: the grid's merge state and build peak). Binaries:
#   cargo build --profile ci --bin rayspace          (BASE = 268e066, this session's start)
#   cargo build --profile ci -p accel --example grid_build
# NEW = this stop's code. Interleaved in one sitting, 2 threads, this VM. Whole-process peaks
# from /usr/bin/time (max RSS, KB).
set -e
cd "$(dirname "$0")/../../.."
export RAYSPACE_SCENES=${RAYSPACE_SCENES:-../shared/scenes}
BASE=${BASE:-/tmp/rayspace-base}
NEW=${NEW:-target/ci/rayspace}
BASE_GB=${BASE_GB:-/tmp/base-target/ci/examples/grid_build}
NEW_GB=${NEW_GB:-target/ci/examples/grid_build}
RAYS=${RAYS:-/tmp/rays}
mkdir -p "$RAYS"
for s in sponza conference kitchen; do
  [ -f "$RAYS/$s-shadow.rays" ] || $NEW rays bench/scenes/$s.toml --kind shadow -W 512 -H 512 -o "$RAYS/$s-shadow.rays" >/dev/null
done
# The same grid, byte for byte (a hash of voxel map, boxes, expanded boxes, ranges, references).
for b in "$BASE_GB" "$NEW_GB"; do
  echo "== $b: $($b hairball:1M 1 | grep -E 'hash' )"
done
for round in 1 2; do
  for b in "$BASE" "$NEW"; do
    for n in 1M 2M; do
      echo "== $b hairball:$n round $round"
      /usr/bin/time -f "whole run %e s, peak %M KB" $b render hairball:$n --engine grid -W 64 -H 64 -b 0 --out /tmp/h.png 2>&1 | grep -E "irregular|peak"
    done
    for s in sponza conference kitchen; do
      echo "== $b $s round $round: $($b trace --scene bench/scenes/$s.toml "$RAYS/$s-shadow.rays" --engine grid --repeat 5 2>&1 | grep -oE "build [0-9.]+ ms" | head -1)"
    done
  done
done
# 10 M triangles, once each (minutes).
for b in "$BASE" "$NEW"; do
  echo "== $b hairball:10M"
  /usr/bin/time -f "whole run %e s, peak %M KB" $b render hairball:10M --engine grid -W 256 -H 256 -b 0 --out /tmp/h10.png 2>&1 | grep -E "irregular|peak"
done
