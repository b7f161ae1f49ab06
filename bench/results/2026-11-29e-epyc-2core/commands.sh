#!/bin/bash
cd /work/main
S=/work/shared/scenes
for round in 1 2 3 4 5; do
  for s in dabrovic-sponza/sponza.obj conference/conference.obj bart-kitchen/kitchen.obj; do
    for b in gb_head gb_new; do
      echo "round $round $b $(basename $s .obj) $(/tmp/$b $S/$s 10 | grep -E 'hash|ms$' | awk '{printf "%s %s ", $1, $NF=="ms" ? $(NF-1) : $NF}')"
    done
  done
done
#!/bin/bash
# Issue 16: CRSH 8/2 BVH vs Embree on Sponza 512² shadow rays, interleaved, 5 rounds.
cd /work/main
for round in 1 2 3 4 5; do
  for b in base cur; do
    for e in embree crsh; do
      echo "round $round $b $e $(/tmp/emb-$b/release/rayspace trace --scene bench/scenes/sponza.toml --engine $e --any-hit --repeat 10 /tmp/sh.rays 2>&1 | head -1)"
    done
  done
done
/tmp/emb-cur/release/rayspace trace --scene bench/scenes/sponza.toml --engine crsh --any-hit --repeat 10 /tmp/sh.rays 2>&1 | grep -E "phases|total tests"
/tmp/emb-base/release/rayspace trace --scene bench/scenes/sponza.toml --engine crsh --any-hit --repeat 10 /tmp/sh.rays 2>&1 | grep -E "phases|total tests"
