#!/bin/bash
# Benchmarks of record 2026-12-03 (issue 43: CRSH's packets). Two binaries, both
#   cargo build --profile ci --bin rayspace --features embree
# BASE = 1b81643 (this session's start: CRSH's default path single rays), NEW = this stop's
# code, 7c0a620 (default path packets, chosen by single::locality). Embree and embree-stream run from NEW (the same library either
# way). 2 threads, this VM; medians and minima of the same runs are both given.
set -e
cd "$(dirname "$0")/../../.."
export RAYSPACE_SCENES=${RAYSPACE_SCENES:-../shared/scenes}
BASE=${BASE:-/tmp/base-target/ci/rayspace}
NEW=${NEW:-target/ci/rayspace}
RAYS=${RAYS:-/tmp/rays}
OUT=bench/results/2026-12-03d-2core
mkdir -p "$RAYS"
for s in sponza conference kitchen; do
  for k in shadow ao random; do
    [ -f "$RAYS/$s-$k.rays" ] || $NEW rays bench/scenes/$s.toml --kind $k -W 512 -H 512 -o "$RAYS/$s-$k.rays" >/dev/null
  done
done
# build + trace: `trace --repeat` (10 for shadow rays, 5 for AO and random); the summary line
# (medians) and the runs line (every run) of each, five interleaved rounds.
{
for round in 1 2 3 4 5; do
  for s in sponza conference kitchen; do
    for k in shadow ao random; do
      mode=--any-hit; rep=5; [ $k = random ] && mode=""; [ $k = shadow ] && rep=10
      for run in "base crsh" "new crsh" "new embree" "new embree-stream"; do
        set -- $run; bin=$NEW; [ $1 = base ] && bin=$BASE
        echo "== round $round $s $k $1 $2"
        $bin trace "$RAYS/$s-$k.rays" --scene bench/scenes/$s.toml -e $2 $mode --repeat $rep 2>&1 | grep -E '^[0-9]+ rays|^runs'
      done
    done
  done
done
} > $OUT/trace.txt
# counts of one trace each (deterministic).
{
for s in sponza conference kitchen; do
  for k in shadow ao random; do
    mode=--any-hit; [ $k = random ] && mode=""
    for b in base new; do
      bin=$NEW; [ $b = base ] && bin=$BASE
      echo "== $s $k $b crsh"
      $bin trace "$RAYS/$s-$k.rays" --scene bench/scenes/$s.toml -e crsh $mode 2>&1 | sed 1d | grep -E "^hits|ray-box|batches"
    done
  done
done
} > $OUT/counts.txt
# BART Kitchen 512², 3 bounces, 8 frames (frame CSVs), two rounds: kitchen-{base,new}-*.csv,
# then kitchen-2-*.csv (the second round runs NEW first).
K=$RAYSPACE_SCENES/bart-kitchen/aff/kitchen.aff
for round in "" "2-"; do
  runs=("base crsh" "new crsh" "new embree-stream")
  [ "$round" = "2-" ] && runs=("new embree-stream" "new crsh" "base crsh")
  for run in "${runs[@]}"; do
    set -- $run; bin=$NEW; [ $1 = base ] && bin=$BASE
    rm -rf /tmp/kframes
    $bin render "$K" -W 512 -H 512 -b 3 --frames 8 --engine $2 --out /tmp/kframes/%04d.png --frame-csv "$OUT/kitchen-$round$1-$2.csv" >/dev/null
  done
done
