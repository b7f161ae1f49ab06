#!/bin/bash
# Benchmarks of record 2026-12-02c (issue 43: CRSH at Embree's speed). Two binaries, both
#   cargo build --profile ci --features embree,accel/embree --bin rayspace
# BASE = 8d04797 (the session's start: CRSH's default the dual traversal over the LBVH),
# NEW = this stop's code (CRSH's default single rays over the SAH tree). Embree and
# embree-stream run from NEW (the same library either way). 2 threads, this VM.
set -e
cd "$(dirname "$0")/../../.."
export RAYSPACE_SCENES=${RAYSPACE_SCENES:-../shared/scenes}
BASE=${BASE:-/tmp/base-target/ci/rayspace}
NEW=${NEW:-target/ci/rayspace}
RAYS=${RAYS:-/tmp/rays}
OUT=bench/results/2026-12-02c-2core
mkdir -p "$RAYS"
for s in sponza conference kitchen; do
  for k in shadow ao random; do
    [ -f "$RAYS/$s-$k.rays" ] || $NEW rays bench/scenes/$s.toml --kind $k -W 512 -H 512 -o "$RAYS/$s-$k.rays" >/dev/null
  done
done
# 1. trace: build + trace medians (--repeat 10 for shadow rays, 5 for AO and random), three
#    interleaved rounds: CRSH before and after, Embree single rays and streams.
{
for round in 1 2 3; do
  for s in sponza conference kitchen; do
    for k in shadow ao random; do
      mode=--any-hit; rep=5; [ $k = random ] && mode=""; [ $k = shadow ] && rep=10
      for run in "base crsh" "new crsh" "new embree" "new embree-stream"; do
        set -- $run; bin=$NEW; [ $1 = base ] && bin=$BASE
        echo "round $round $s $k $1 $2: $($bin trace "$RAYS/$s-$k.rays" --scene bench/scenes/$s.toml -e $2 $mode --repeat $rep 2>&1 | head -1)"
      done
    done
  done
done
} > $OUT/trace.txt
# 2. counts and phases of one trace each (deterministic counts).
{
for s in sponza conference kitchen; do
  for k in shadow ao random; do
    mode=--any-hit; [ $k = random ] && mode=""
    for run in "base crsh" "new crsh" "new crsh --ray-path bundles" "new crsh --object-builder lbvh" "new rah"; do
      set -- $run; bin=$NEW; [ $1 = base ] && bin=$BASE; shift
      echo "== $s $k ${run}"
      $bin trace "$RAYS/$s-$k.rays" --scene bench/scenes/$s.toml -e "$@" $mode 2>&1 | sed 1d
    done
  done
done
} > $OUT/counts.txt
# 3. BART Kitchen 512², 3 bounces, 8 frames (the frame CSV; medians of frames 1–7 in the
#    README), twice interleaved.
K=$RAYSPACE_SCENES/bart-kitchen/aff/kitchen.aff
for round in 1 2; do
  for run in "base crsh" "new crsh" "new embree-stream" "new embree"; do
    set -- $run; bin=$NEW; [ $1 = base ] && bin=$BASE
    rm -rf /tmp/kframes
    $bin render "$K" -W 512 -H 512 --frames 8 --engine $2 --out /tmp/kframes/%04d.png --frame-csv "$OUT/kitchen-$round-$1-$2.csv" >/dev/null
  done
done
# 4. The object builders: build time and the single-ray tree's surface-area metric.
cargo run -q --profile ci -p rsh --example object_trees -- bench/scenes/sponza.toml \
  bench/scenes/conference.toml bench/scenes/kitchen.toml > $OUT/builders.md
