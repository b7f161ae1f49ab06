#!/bin/bash
# Benchmarks of record 2026-12-03 (issue 43: CRSH's build and single-ray walk). Two binaries, both
#   cargo build --profile ci --bin rayspace --features embree
# BASE = b775004 (this session's start), NEW = this stop's code. Embree and embree-stream run
# from NEW (the same library either way). 2 threads, this VM (25 % steal time seen this
# session: medians and minima of the same runs are both given).
set -e
cd "$(dirname "$0")/../../.."
export RAYSPACE_SCENES=${RAYSPACE_SCENES:-../shared/scenes}
BASE=${BASE:-/tmp/base-target/ci/rayspace}
NEW=${NEW:-target/ci/rayspace}
RAYS=${RAYS:-/tmp/rays}
OUT=bench/results/2026-12-03-2core
mkdir -p "$RAYS"
for s in sponza conference kitchen; do
  for k in shadow ao random; do
    [ -f "$RAYS/$s-$k.rays" ] || $NEW rays bench/scenes/$s.toml --kind $k -W 512 -H 512 -o "$RAYS/$s-$k.rays" >/dev/null
  done
done
# build + trace: `trace --repeat` (10 for shadow rays, 5 for AO and random); the summary line
# (medians) and the runs line (every run) of each, three interleaved rounds.
{
for round in 1 2 3; do
  for s in sponza conference kitchen; do
    for k in shadow ao random; do
      [ $s != sponza ] && [ $k != shadow ] && continue
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
    [ $s != sponza ] && [ $k != shadow ] && continue
    mode=--any-hit; [ $k = random ] && mode=""
    for b in base new; do
      bin=$NEW; [ $b = base ] && bin=$BASE
      echo "== $s $k $b crsh"
      $bin trace "$RAYS/$s-$k.rays" --scene bench/scenes/$s.toml -e crsh $mode 2>&1 | sed 1d | grep -E "^hits|ray-box"
    done
  done
done
} > $OUT/counts.txt
# BART Kitchen 512², 3 bounces, 8 frames (frame CSVs; medians of frames 1-7 of build_ms,
# trace_ms and their sum in the README), two rounds: kitchen-{base,new}-*.csv, then
# kitchen-2-*.csv (the second round ran NEW first).
K=$RAYSPACE_SCENES/bart-kitchen/aff/kitchen.aff
for round in "" "2-"; do
  for run in "base crsh" "new crsh" "new embree-stream"; do
    set -- $run; bin=$NEW; [ $1 = base ] && bin=$BASE
    rm -rf /tmp/kframes
    $bin render "$K" -W 512 -H 512 -b 3 --frames 8 --engine $2 --out /tmp/kframes/%04d.png --frame-csv "$OUT/kitchen-$round$1-$2.csv" >/dev/null
  done
done
