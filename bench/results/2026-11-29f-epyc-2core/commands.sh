#!/bin/bash
# Benchmarks of record 2026-11-29f (seventh session). Two binaries, both built with
#   cargo build --release --features embree,accel/embree
# base = 932fe89 (the traversal of the session's start, e0e9974: the two commits between are
# behaviour-unchanged reviews), new = this stop's code. Rays:
#   rayspace rays bench/scenes/sponza.toml --kind shadow --out sh.rays       (and conference, kitchen)
set -e
cd "$(dirname "$0")/../../.."
export RAYSPACE_SCENES=${RAYSPACE_SCENES:-../shared/scenes}
BASE=${BASE:-/tmp/emb-cur/release/rayspace}
NEW=${NEW:-/tmp/emb-new/release/rayspace}
RAYS=${RAYS:-/tmp}
# 1. Issue 16: a CRSH 8/2 frame on Sponza's shadow rays against Embree, 5 interleaved rounds
#    (crsh-bvh-vs-embree.txt)
OUT=bench/results/2026-11-29f-epyc-2core
{
for round in 1 2 3 4 5; do
  for b in base new; do
    bin=$BASE; [ $b = new ] && bin=$NEW
    for e in embree crsh; do
      echo "round $round $b $e $($bin trace --scene bench/scenes/sponza.toml --engine $e --any-hit --repeat 10 $RAYS/sh.rays 2>&1 | head -1)"
    done
  done
done
for b in base new; do
  bin=$BASE; [ $b = new ] && bin=$NEW
  for e in crsh rah; do
    echo "$b $e: $($bin trace --scene bench/scenes/sponza.toml --engine $e --any-hit --repeat 10 $RAYS/sh.rays 2>&1 | grep -E 'phases|total tests' | tr '\n' ' ')"
  done
  for s in conference kitchen; do
    echo "$b crsh $s: $($bin trace --scene bench/scenes/$s.toml --engine crsh --any-hit --repeat 3 $RAYS/$s.rays 2>&1 | grep -E 'total tests')"
  done
done
} > $OUT/crsh-bvh-vs-embree.txt
# 2. BART Kitchen, 512², 3 bounces, 30 frames (kitchen-30-crsh-bvh.csv)
$NEW render $RAYSPACE_SCENES/bart-kitchen/aff/kitchen.aff --width 512 --height 512 --bounces 3 \
  --engine crsh --frames 30 --frame-csv $OUT/kitchen-30-crsh-bvh.csv \
  --out /tmp/k%d.png
# 3. The thesis's tables with the object hierarchy (rsh.md, rsh.csv)
$NEW bench rsh --configs 8/2,16/3 --md $OUT/rsh.md --csv $OUT/rsh.csv
