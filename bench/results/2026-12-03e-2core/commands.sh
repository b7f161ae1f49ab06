#!/bin/bash
# Figures of record 2026-12-03e (issues 43 and 44). Binaries, `ci` profile, Embree on:
#   cargo build --profile ci --bin rayspace --features embree   (BASE = c7ada16, NEW = 7d46ec9)
#   cargo build --profile ci -p accel --example grid_build        (BASE = c7ada16, NEW = 8e562bc)
# Interleaved in one sitting, 2 threads, this VM. Only ratios within this sitting are compared.
set -e
cd "$(dirname "$0")/../../.."
export RAYSPACE_SCENES=${RAYSPACE_SCENES:-../shared/scenes}
BASE=${BASE:-/tmp/rs-base}
NEW=${NEW:-target/ci/rayspace}
BASE_GB=${BASE_GB:-/tmp/gb-base}
NEW_GB=${NEW_GB:-target/ci/examples/grid_build}
RAYS=${RAYS:-/tmp/rays}
OUT=bench/results/2026-12-03e-2core
mkdir -p "$RAYS"
for s in sponza conference kitchen; do
  for k in shadow ao random; do
    [ -f "$RAYS/$s-$k.rays" ] || $NEW rays bench/scenes/$s.toml --kind $k -W 512 -H 512 -o "$RAYS/$s-$k.rays" >/dev/null
  done
done
# 1. CRSH's build + trace (issue 43): BASE and NEW CRSH, Embree single-ray and stream, three
# rounds of `trace --repeat 8` per batch (shadow and AO any hit, random closest hit).
{
for round in 1 2 3; do
  for s in sponza conference kitchen; do
    for k in shadow ao random; do
      mode=--any-hit; [ $k = random ] && mode=
      for run in "base crsh" "new crsh" "new embree" "new embree-stream"; do
        set -- $run; bin=$NEW; [ $1 = base ] && bin=$BASE
        echo "== round $round $s $k $1 $2"
        $bin trace "$RAYS/$s-$k.rays" --scene bench/scenes/$s.toml --engine $2 $mode --repeat 8 2>&1 | grep -E "^runs|^hits"
      done
    done
  done
done
} > $OUT/trace.txt
# 2. BART Kitchen 512², 3 bounces, 8 frames, two rounds (the second in reverse order).
K=$RAYSPACE_SCENES/bart-kitchen/aff/kitchen.aff
for round in "" "2-"; do
  runs=("base crsh" "new crsh" "new embree-stream")
  [ "$round" = "2-" ] && runs=("new embree-stream" "new crsh" "base crsh")
  for run in "${runs[@]}"; do
    set -- $run; bin=$NEW; [ $1 = base ] && bin=$BASE
    rm -rf /tmp/kframes
    $bin render "$K" -W 512 -H 512 -b 3 --frames 8 --engine $2 --out /tmp/kframes/%04d.png --frame-csv "$OUT/kitchen-$round$1-$2.csv" >/dev/null
  done
done
# 3. The grid's 2 M-triangle build (issue 44): each pass's time and the structure hash, two
# rounds, BASE and NEW (the expansion change), with the whole-process peak.
{
for round in 1 2; do
  for b in base new; do
    gb=$NEW_GB; [ $b = base ] && gb=$BASE_GB
    echo "== round $round $b"
    /usr/bin/time -f "peak %M KB" $gb hairball:2M 1 2>&1
  done
done
} > $OUT/grid-2m.txt
# 4. The build's peak (render --stats: build_peak_bytes) against the structure, NEW only.
{
echo "| scene | engine | triangles | structure bytes | build peak bytes | build peak / structure | process peak bytes |"
echo "|---|---|---:|---:|---:|---:|---:|"
for s in bench/scenes/sponza.toml bench/scenes/conference.toml bench/scenes/kitchen.toml city:1M hairball:200k hairball:1M hairball:2M; do
  for e in grid crsh embree; do
    $NEW render $s -e $e -W 64 -H 64 -b 0 -o /tmp/peak.png --stats /tmp/peak.json >/dev/null 2>&1
    python3 - "$s" "$e" <<'PY'
import json, sys
j = json.load(open("/tmp/peak.json"))
st, bp = j.get("structure_bytes"), j.get("build_peak_bytes")
tris = j.get("triangles", "")
ratio = f"{bp / st:.2f}" if st and bp else "n/a"
print(f"| {sys.argv[1]} | {sys.argv[2]} | {tris} | {st if st is not None else 'n/a'} | {bp} | {ratio} | {j.get('peak_rss_bytes')} |")
PY
  done
done
} > $OUT/build-peak.md
python3 $OUT/summarize.py
