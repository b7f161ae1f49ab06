#!/bin/bash
# Figures of record 2026-12-03f (issue 43): CRSH's single-ray walk testing a node's leaf
# triangles 8 at a time (blocks of 8, geom::tris8). Binaries, `ci` profile, Embree on:
#   cargo build --profile ci --bin rayspace --features embree   (BASE = 829217b, NEW = 6bfc8b5)
# Interleaved in one sitting, 2 threads, this VM. Only ratios within this sitting are compared.
set -e
cd "$(dirname "$0")/../../.."
export RAYSPACE_SCENES=${RAYSPACE_SCENES:-../shared/scenes}
BASE=${BASE:-/tmp/rs-base}
NEW=${NEW:-target/ci/rayspace}
RAYS=${RAYS:-/tmp/rays}
OUT=bench/results/2026-12-03f-2core
mkdir -p "$RAYS"
# Random rays (the single-ray path) on the bench scenes and on generated dense scenes; the
# packets' AO and shadow rays (any hit), whose triangles are now read from the blocks.
work=(
  "sponza-random bench/scenes/sponza.toml random"
  "conference-random bench/scenes/conference.toml random"
  "kitchen-random bench/scenes/kitchen.toml random"
  "hairball2k-random hairball:2k random"
  "hairball200k-random hairball:200k random"
  "city200k-random city:200k random"
  "sponza-ao bench/scenes/sponza.toml ao"
  "kitchen-ao bench/scenes/kitchen.toml ao"
  "sponza-shadow bench/scenes/sponza.toml shadow"
  "kitchen-shadow bench/scenes/kitchen.toml shadow"
)
for w in "${work[@]}"; do
  set -- $w
  [ -f "$RAYS/$1.rays" ] || $NEW rays $2 --kind $3 -W 512 -H 512 -o "$RAYS/$1.rays" >/dev/null
done
# Hits: NEW's records equal BASE's, bit for bit (closest hit; any hit for AO and shadows).
{
for w in "${work[@]}"; do
  set -- $w
  mode=--any-hit; [ $3 = random ] && mode=
  $BASE trace "$RAYS/$1.rays" --scene $2 $mode -o /tmp/hits-base >/dev/null 2>&1
  $NEW trace "$RAYS/$1.rays" --scene $2 $mode -o /tmp/hits-new >/dev/null 2>&1
  if cmp -s /tmp/hits-base /tmp/hits-new; then echo "$1 hits identical"; else echo "$1 hits DIFFER"; fi
done
} > $OUT/hits.txt
# Three rounds of `trace --repeat 5` per batch: BASE and NEW CRSH, Embree single-ray.
{
for round in 1 2 3; do
  for w in "${work[@]}"; do
    set -- $w
    mode=--any-hit; [ $3 = random ] && mode=
    for run in "base crsh" "new crsh" "new embree"; do
      set -- $w; r=$1; s=$2; set -- $run; bin=$NEW; [ $1 = base ] && bin=$BASE
      echo "== round $round $r $1 $2"
      $bin trace "$RAYS/$r.rays" --scene $s --engine $2 $mode --repeat 5 2>&1 | grep -E "^runs|^hits|^phases|structure"
    done
  done
done
} > $OUT/trace.txt
python3 $OUT/summarize.py $OUT/trace.txt > $OUT/summary.md
