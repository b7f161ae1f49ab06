#!/usr/bin/env bash
# The GPU numbers of record in one run, for a session that is lent a real GPU (the `device`
# tool): the grid built and traversed on the GPU (issue 17), whole frames and host↔device
# traffic (issue 18), CRSH/RAH phases, CRSH over the object tree on the device and the dual
# traversal there (issue 46), and the GPU tests that compare against the CPU.
#
# Prepare on the dev machine (no GPU needed), then carry `dev-bin` and the scenes:
#   cargo build --release && cargo test --release -p gpu --no-run 2>&1 | grep -o 'target/release/deps/[a-z_]*-[0-9a-f]*' > /tmp/tests.txt
#   mkdir -p dev-bin && cp target/release/rayspace $(cat /tmp/tests.txt) dev-bin/
#   mkdir -p dev-scenes && cp -r ../shared/scenes/{dabrovic-sponza,conference,cornell-box,bart-kitchen} dev-scenes/
# (both ignored by git; about 62 MB together, within the device tool's 64 MiB carry), then
# on the device: `scripts/device-bench.sh` (writes the reports and the log into $OUT).
# Each step is bounded by `timeout`, so one slow step cannot eat the device time of the rest.
set -uo pipefail
OUT=${OUT:-out}
mkdir -p "$OUT"
LOG="$OUT/device-log.txt"
BIN=${BIN:-dev-bin}
export RAYSPACE_SCENES=${RAYSPACE_SCENES:-dev-scenes}
export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-/tmp}
{
    git log -1 --format='commit %h' 2>/dev/null || true
    date
    nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv 2>/dev/null || true
    lscpu | grep -E 'Model name|^CPU\(s\)' || true
} >>"$LOG"
step() {
    local limit=$1 name=$2
    shift 2
    echo "== $name" >>"$LOG"
    timeout "$limit" "$@" >>"$LOG" 2>&1
    echo "rc $?" >>"$LOG"
}
R="$BIN/rayspace"
S=bench/scenes
# Issue 17: the grid built by kernels and traversed, against the CPU grid (Sponza's 512²
# primary target is the paper's 653 MRays/s on a Titan X; its build, 12–26 ms there).
step 150 "bench gpu grid 512" "$R" bench gpu --scenes cornell,$S/sponza.toml,$S/conference.toml \
    --grid-only --width 512 --height 512 --md "$OUT/bench-gpu-grid-512.md"
step 150 "bench gpu grid 1024" "$R" bench gpu --scenes $S/sponza.toml --grid-only \
    --width 1024 --height 1024 --md "$OUT/bench-gpu-grid-1024.md"
# Issue 18: CRSH/RAH phases, whole device-resident frames (shadow frames and 3-bounce frames)
# and their host↔device bytes against the image's + 1 MiB.
step 200 "bench gpu 512 shadows" "$R" bench gpu --scenes cornell,office,$S/sponza.toml \
    --width 512 --height 512 --bounces 0 --rah --md "$OUT/bench-gpu-512-shadows.md"
step 200 "bench gpu 1024 b3" "$R" bench gpu --scenes office,$S/sponza.toml \
    --width 1024 --height 1024 --bounces 3 --md "$OUT/bench-gpu-1024-b3.md"
# The object tree built and walked on the device by single rays (`bvh`; the tree's build is
# the stats' `build: object hierarchy`), the dual traversal (CRSH's and RAH's default there)
# against the thesis's bundles behind mesh spheres, and the grid: Sponza 512² shadow frames.
for run in "bvh" "crsh" "crsh --object-hierarchy mesh-spheres" "rah" "rah --object-hierarchy mesh-spheres" "grid"; do
    tag=$(echo "$run" | tr ' ' '_' | tr -d '-')
    step 120 "render sponza 512 shadows $run" "$R" render $S/sponza.toml -W 512 -H 512 \
        --bounces 0 --backend gpu --engine $run \
        --stats "$OUT/sponza-512-$tag.json" --out "$OUT/sponza-512-$tag.png"
done
step 150 "render kitchen 1024 b3 bvh frames" "$R" render kitchen -W 1024 -H 1024 --bounces 3 \
    --backend gpu --engine bvh --frames 6 --frame-csv "$OUT/kitchen-1024-b3-bvh.csv" \
    --out "$OUT/kitchen-%04d.png"
step 150 "render kitchen 1024 b3 crsh frames" "$R" render kitchen -W 1024 -H 1024 --bounces 3 \
    --backend gpu --engine crsh --frames 6 --frame-csv "$OUT/kitchen-1024-b3-crsh.csv" \
    --out "$OUT/kitchen-crsh-%04d.png"
# RAH's dual traversal, laid out and paced by the device (one read-back a frame on lavapipe).
step 150 "render kitchen 1024 b3 rah frames" "$R" render kitchen -W 1024 -H 1024 --bounces 3 \
    --backend gpu --engine rah --frames 6 --frame-csv "$OUT/kitchen-1024-b3-rah.csv" \
    --out "$OUT/kitchen-rah-%04d.png"
# The GPU tests (the GPU frame against the CPU loop over its G-buffer, in parts; the minimal-ball
# fix eb34266 is checked by hierarchies_match_the_cpu_node_for_node).
for m in objects single dual frame grid_build grid agreement; do
    for t in "$BIN"/device-*; do
        [ -x "$t" ] && step 120 "test $m" "$t" "$m::" --test-threads 4
    done
done
echo "== done" >>"$LOG"
