#!/usr/bin/env bash
# Issue 68's sitting: every engine under its new name, against Embree, one build, two
# interleaved rounds (../shared/tools/peer-table.sh), then the thesis's claim (CRSH's tests
# against RAH's on Sponza 512² shadow rays, mesh spheres and object tree).
# Run from the repository root at the commit in peer-table.txt's header.
set -euo pipefail
export RAYSPACE_SCENES=${RAYSPACE_SCENES:-../shared/scenes} XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-/tmp}
cargo build --release --features embree
R=target/release/rayspace
OUT=bench/results/2026-12-07-2core
{ $R --version; nproc; grep -m1 'model name' /proc/cpuinfo; date -u; } > $OUT/peer-table.txt
../shared/tools/peer-table.sh $R $R bvh crsh rah grid grid2l >> $OUT/peer-table.txt
S=bench/scenes/sponza.toml
$R rays $S --kind shadow -W 512 -H 512 -o /tmp/sponza-shadow.rays
for e in "crsh --object-hierarchy mesh-spheres" "rah --object-hierarchy mesh-spheres" crsh rah bvh; do
    echo "== $e"
    $R trace /tmp/sponza-shadow.rays --scene $S -e $e --any-hit | grep -E 'MRays/s|^hits|configuration'
done > $OUT/thesis-claim.txt
