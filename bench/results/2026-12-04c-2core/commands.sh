#!/bin/bash
# Figures of record 2026-12-04c (issue 43): CRSH's single-ray walk finding a node's tested
# leaf positions from a byte-wise prefix sum (no per-triangle run building). Binaries,
# `ci` profile, Embree on:
#   cargo build --profile ci --bin rayspace --features embree   (BASE = 0b01897, NEW = 9050593)
# Interleaved in one sitting, 2 threads, this VM. Only ratios within this sitting are compared.
set -e
cd "$(dirname "$0")/../../.."
export RAYSPACE_SCENES=${RAYSPACE_SCENES:-../shared/scenes}
BASE=${BASE:-/tmp/rs-base}
NEW=${NEW:-target/ci/rayspace}
RAYS=${RAYS:-/tmp/rays}
OUT=bench/results/2026-12-04c-2core
mkdir -p "$RAYS"
# Random rays: the batches CRSH traces as single rays (its incoherent path).
work=(
  "sponza-random bench/scenes/sponza.toml"
  "conference-random bench/scenes/conference.toml"
  "kitchen-random bench/scenes/kitchen.toml"
  "hairball2k-random hairball:2k"
  "hairball200k-random hairball:200k"
  "city200k-random city:200k"
)
for w in "${work[@]}"; do
  set -- $w
  [ -f "$RAYS/$1.rays" ] || $NEW rays $2 --kind random -W 512 -H 512 -o "$RAYS/$1.rays" >/dev/null
done
# Hits and counts: NEW's equal BASE's, closest and any hit.
{
for w in "${work[@]}"; do
  set -- $w
  for mode in "" "--any-hit"; do
    $BASE trace "$RAYS/$1.rays" --scene $2 $mode -o /tmp/hits-base 2>&1 | grep -E "tests|passes|^hits" > /tmp/counts-base
    $NEW trace "$RAYS/$1.rays" --scene $2 $mode -o /tmp/hits-new 2>&1 | grep -E "tests|passes|^hits" > /tmp/counts-new
    h=DIFFER; cmp -s /tmp/hits-base /tmp/hits-new && h=identical
    c=DIFFER; cmp -s /tmp/counts-base /tmp/counts-new && c=identical
    echo "$1 ${mode:-closest}: hits $h, counts $c"
  done
done
} > $OUT/hits.txt
# Three rounds of `trace --repeat 7` per batch: BASE and NEW CRSH, Embree single-ray.
{
for round in 1 2 3; do
  for w in "${work[@]}"; do
    for run in "base crsh" "new crsh" "new embree"; do
      set -- $w; r=$1; s=$2; set -- $run; bin=$NEW; [ $1 = base ] && bin=$BASE
      echo "== round $round $r $1 $2"
      $bin trace "$RAYS/$r.rays" --scene $s --engine $2 --repeat 7 2>&1 | grep -E "^runs|^hits|^phases|structure"
    done
  done
done
} > $OUT/trace.txt
python3 $OUT/summarize.py $OUT/trace.txt > $OUT/summary.md
