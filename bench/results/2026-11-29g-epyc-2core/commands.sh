#!/bin/bash
# Issue 15, seventh session: merging by runs. Binaries (all `cargo build --release`):
#   /tmp/gb_head  - grid_build example at 1149be6 (the session's start; merging by pairs)
#   /tmp/gb_new   - grid_build example at this commit (arguments: SCENE REPEATS paper runs|pairs)
#   /tmp/emb-old/release/rayspace, /tmp/emb-new/release/rayspace - the CLI at 1149be6 and at
#     this commit, both with --features embree,accel/embree
cd /work/main/bench/results/2026-11-29g-epyc-2core
export RAYSPACE_SCENES=/work/shared/scenes
S=/work/shared/scenes
# 1. The build pass by pass: best of 10 builds per process, 5 interleaved rounds.
for round in 1 2 3 4 5; do
  for s in dabrovic-sponza/sponza.obj conference/conference.obj bart-kitchen/kitchen.obj; do
    for v in "gb_head" "gb_new pairs" "gb_new runs"; do
      set -- $v
      echo "round $round $1 ${2:-pairs} $(basename $s .obj) $(/tmp/$1 $S/$s 10 paper $2 | grep -E 'rounds|hash|ms$' | awk '/rounds/ {printf "rounds %s cells %s ", $7, $10; next} {printf "%s %s ", $1, $NF=="ms" ? $(NF-1) : $NF}')"
    done
  done
done > grid-build-passes.txt
# 2. bench grid (Tables 1, 2, 3, 5) with the old and the new CLI, one after the other.
for b in old new; do
  /tmp/emb-$b/release/rayspace bench grid --md grid-$b.md --csv grid-table3-$b.csv --grids-csv grid-builds-$b.csv
done
# 3. The paper's Table 4 budget at 512² on Museum and Kitchen, old and new CLI.
for b in old new; do
  for s in museum:bart-museum/aff/museum5.aff kitchen:bart-kitchen/aff/kitchen.aff; do
    /tmp/emb-$b/release/rayspace bench budget $S/${s#*:} --width 512 --height 512 \
      --engines grid,obvhs-cwbvh,embree,embree-stream --csv budget-512-${s%%:*}-$b.csv
  done
done
