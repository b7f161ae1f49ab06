#!/bin/bash
# Issue 15, closing run: the state the issue was filed against against today's, one sitting.
# Binaries (both `cargo build --release --features embree,accel/embree`):
#   /tmp/emb-base/release/rayspace - the CLI at 2035e2a (before any of issue 15's work)
#   /tmp/emb-new/release/rayspace  - the CLI at 58250fe (this session's start; the grid code
#                                    is unchanged since)
set -euo pipefail
cd "$(dirname "$0")"
export RAYSPACE_SCENES=/work/shared/scenes
S=$RAYSPACE_SCENES
SC=../../scenes
# 1. The build pass by pass: one cold build per process (`render` prints its passes), 5
#    interleaved rounds per scene.
for round in 1 2 3 4 5; do
  for s in sponza conference kitchen; do
    for b in base new; do
      echo "round $round $b $s $(/tmp/emb-$b/release/rayspace render $SC/$s.toml --engine grid --bounces 0 \
        --width 64 --height 64 --out /tmp/pass-$b.png 2>&1 | grep -o 'cells (initial.*' | head -1)"
    done
  done
done > build-passes.txt
# 2. bench grid (Tables 1, 2, 3, 5), base then new.
for b in base new; do
  /tmp/emb-$b/release/rayspace bench grid --md grid-$b.md --csv grid-table3-$b.csv --grids-csv grid-builds-$b.csv
done
# 3. The paper's Table 4 budget at 512² on Museum and Kitchen, base then new.
for b in base new; do
  for s in museum:bart-museum/aff/museum5.aff kitchen:bart-kitchen/aff/kitchen.aff; do
    /tmp/emb-$b/release/rayspace bench budget $S/${s#*:} --width 512 --height 512 \
      --engines grid,obvhs-cwbvh,embree,embree-stream --csv budget-512-${s%%:*}-$b.csv
  done
done
# 4. Run afterwards, not part of the sitting above (figures quoted in README.md):
#    the stadium's primary rays with both subdivision rules against the peers …
#   R=/tmp/emb-new/release/rayspace
#   $R rays stadium --kind primary --width 512 --height 512 --out /tmp/stadium-primary.rays
#   for e in "grid --grid-subdivision paper" "grid --grid-subdivision adaptive" obvhs-cwbvh embree; do
#     $R trace --scene stadium /tmp/stadium-primary.rays --engine $e --repeat 5
#   done
#    … and adaptive's cost on the real scenes (grid_build and grid_trace examples at 58250fe):
#   for s in dabrovic-sponza/sponza.obj conference/conference.obj bart-kitchen/kitchen.obj; do
#     for r in paper adaptive; do target/release/examples/grid_build $S/$s 5 $r; done
#   done
#   for r in paper adaptive; do target/release/examples/grid_trace ../../scenes/conference.toml 3 $r; done
