#!/usr/bin/env bash
# The GPU CRSH frames of this stop's README, on Mesa's lavapipe (no GPU was lent):
# BIN=target/ci/rayspace (cargo build --profile ci), RAYSPACE_SCENES=../shared/scenes.
set -euo pipefail
BIN=${BIN:-target/ci/rayspace}
for h in bvh mesh-spheres; do
    "$BIN" render bench/scenes/sponza.toml -W 512 -H 512 --bounces 0 --backend gpu --engine crsh \
        --object-hierarchy "$h" --stats "sponza-512-shadows-crsh-$h.json" --out "sponza-$h.png"
    "$BIN" render office -W 128 -H 128 --bounces 3 --backend gpu --engine crsh \
        --object-hierarchy "$h" --stats "office-128-b3-crsh-$h.json" --out "office-$h.png"
done
for e in rah grid; do
    "$BIN" render office -W 128 -H 128 --bounces 3 --backend gpu --engine "$e" \
        --stats "office-128-b3-$e.json" --out "office-$e.png"
done
# --frames: every CRSH shadow frame's read-backs (the stats list each frame's).
printf '[camera]\neye = [0, 2, 8]\ntarget = [0, 0, 0]\n[[meshes]]\nshape = "plane"\nscale = 5\n[[meshes]]\nshape = "box"\n[meshes.animation]\nkeys = [{ t = 0 }, { t = 1, translate = [2, 1, 0], rotate = [0, 90, 0] }]\n' >anim.toml
"$BIN" render anim.toml --frames 3 --bounces 0 -W 64 -H 64 --backend gpu --engine crsh \
    --stats anim-frames.json --out "anim-%02d.png"
