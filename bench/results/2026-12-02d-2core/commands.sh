#!/bin/bash
# Figures of record 2026-12-02d (issue 42: the frame around the trace). Two binaries, both
#   cargo build --profile ci --features embree,accel/embree --bin rayspace
# BASE = 35aedc4 (this stop's start), NEW = this stop's code. 2 threads, this VM.
set -e
cd "$(dirname "$0")/../../.."
export RAYSPACE_SCENES=${RAYSPACE_SCENES:-../shared/scenes}
BASE=${BASE:-/tmp/base-target/ci/rayspace}
NEW=${NEW:-target/ci/rayspace}
OUT=bench/results/2026-12-02d-2core
TMP=$(mktemp -d)
# 1. Kitchen 512², 3 bounces, 8 frames: three interleaved rounds, BASE then NEW, Embree's
#    stream engine and CRSH; the frame CSV's phase columns (medians of frames 1-7 in README.md).
for r in 1 2 3; do
  for b in base new; do
    bin=$NEW; [ $b = base ] && bin=$BASE
    for e in embree-stream crsh; do
      $bin render kitchen --engine $e --frames 8 --out "$TMP/%04d.png" --frame-csv "$OUT/frames-2/$b-$e-$r.csv" >/dev/null
    done
  done
done
# 2. The same images: every PNG of BASE and NEW byte-identical (and scripts/fingerprint.sh).
for s in office spheres sponza conference; do
  for b in base new; do
    bin=$NEW; [ $b = base ] && bin=$BASE
    $bin render $s --engine embree-stream --out "$TMP/$b-$s.png" >/dev/null
  done
  cmp "$TMP/base-$s.png" "$TMP/new-$s.png" && echo "$s: identical"
done
# 3. Each phase alone, buffers kept (criterion; Kitchen, office, spheres at 512²).
cargo bench -p render --bench frame
