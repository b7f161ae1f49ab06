#!/bin/bash
# Figures of record 2026-12-02f (issue 44: the grid's build at scale). Two binaries, both
#   cargo build --profile ci --bin rayspace
# BASE = c08bddb (this session's start), NEW = this stop's code. Interleaved in one sitting,
# 2 threads, this VM. Whole-process peaks from /usr/bin/time (max RSS).
set -e
cd "$(dirname "$0")/../../.."
export RAYSPACE_SCENES=${RAYSPACE_SCENES:-../shared/scenes}
BASE=${BASE:-/tmp/rayspace-base}
NEW=${NEW:-target/ci/rayspace}
RAYS=${RAYS:-/tmp/rays}
mkdir -p "$RAYS"
for s in sponza conference; do
  [ -f "$RAYS/$s-shadow.rays" ] || $NEW rays bench/scenes/$s.toml --kind shadow -W 512 -H 512 -o "$RAYS/$s-shadow.rays" >/dev/null
done
for round in 1 2; do
  for b in "$BASE" "$NEW"; do
    for n in 1M 2M; do
      echo "== $b hairball:$n round $round"
      /usr/bin/time -f "whole run %e s, peak %M KB" $b render hairball:$n --engine grid -W 256 -H 256 -b 0 --out /tmp/h.png 2>&1 | grep -E "irregular|peak"
    done
    for s in sponza conference; do
      echo "== $b $s round $round: $($b trace --scene bench/scenes/$s.toml "$RAYS/$s-shadow.rays" --engine grid --repeat 5 2>&1 | grep -oE "build [0-9.]+ ms" | head -1)"
    done
  done
done
