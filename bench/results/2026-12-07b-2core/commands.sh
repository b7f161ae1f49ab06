#!/usr/bin/env bash
# The commands behind this folder's figures (a release build with Embree, 2 threads).
set -euo pipefail
cargo build --release --features embree
B=target/release/rayspace
export RAYSPACE_SCENES=${RAYSPACE_SCENES:-../shared/scenes}
# peer-table.txt: bvh, crsh, rah and grid against Embree, two interleaved rounds.
../shared/tools/peer-table.sh $B $B bvh crsh rah grid
# ray-hierarchy.md: the report's "When does a ray-space hierarchy pay?" at 512².
$B report --quick --scenes office,sponza,kitchen --size 512 --out /tmp/rk
# kitchen-ray-side.txt: CRSH's ray side per phase on Kitchen 512², 3 bounces, 8 frames.
$B render "$RAYSPACE_SCENES/bart-kitchen/aff/kitchen.aff" -W 512 -H 512 -b 3 -e crsh --frames 8 --frame-csv /tmp/kc.csv --out /tmp/kc/%02d.png
# gpu-counts.txt: Sponza 512² shadows, CPU breadth schedule against the GPU frame (lavapipe).
$B render sponza -W 512 -H 512 -b 0 -e crsh --object-builder lbvh --schedule breadth --stats /tmp/cpu.json
$B render sponza -W 512 -H 512 -b 0 -e crsh --backend gpu --stats /tmp/gpu.json
