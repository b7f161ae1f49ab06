#!/bin/bash
# Figures of record 2026-12-03g (issue 44: the grid merge's parallel collections; issue 43:
# the packets' per-kind test counts). Binaries, `ci` profile, Embree on:
#   cargo build --profile ci --bin rayspace --features embree
#   cargo build --profile ci -p accel --example grid_build
# BASE = 168e947 (this session's start), NEW = this stop's code. Interleaved in one sitting,
# 2 threads, this VM. Only ratios within this sitting are compared.
set -e
cd "$(dirname "$0")/../../.."
export RAYSPACE_SCENES=${RAYSPACE_SCENES:-../shared/scenes}
BASE=${BASE:-/tmp/rs-base0}
NEW=${NEW:-target/ci/rayspace}
BASE_GB=${BASE_GB:-/tmp/gb-base0}
NEW_GB=${NEW_GB:-target/ci/examples/grid_build}
RAYS=${RAYS:-/tmp/rays}
OUT=bench/results/2026-12-03g-2core
mkdir -p "$RAYS"
for s in sponza conference; do
  for k in shadow ao; do
    [ -f "$RAYS/$s-$k.rays" ] || $NEW rays bench/scenes/$s.toml --kind $k -W 512 -H 512 -o "$RAYS/$s-$k.rays" >/dev/null
  done
done
# 1. The grid's passes (grid_build: one build, each pass's time, the structure hash, the
# whole-process peak) on the 1 M and 2 M hairballs, two rounds of BASE and NEW.
grid_build() { # round, size, base|new
  local gb=$NEW_GB; [ "$3" = base ] && gb=$BASE_GB
  echo "== round $1 hairball:$2 $3"
  /usr/bin/time -f "peak %M KB" $gb hairball:$2 1 2>&1
}
for round in 1 2; do
  for n in 1M 2M; do grid_build $round $n base; grid_build $round $n new; done
done > $OUT/grid-build.txt
# 1b. More rounds of the same (the VM's speed moved ±25 % from run to run in this sitting):
# six of 1M and three of 2M, BASE and NEW alternating, which one goes first alternating too.
for round in 1 2 3 4 5 6; do
  order="base new"; [ $((round % 2)) = 0 ] && order="new base"
  for b in $order; do grid_build $round 1M $b; done
  if [ $round -le 3 ]; then for b in $order; do grid_build $round 2M $b; done; fi
done > $OUT/grid-build-more.txt
# 1c. After the rest (and after `.ci/run`): hairball:200k, best of 6 builds per run, four
# rounds, NEW first in each (the runs above put BASE first in most rounds).
for round in 1 2 3 4; do
  for b in new base; do
    gb=$NEW_GB; [ $b = base ] && gb=$BASE_GB
    echo "== round $round hairball:200k $b"
    $gb hairball:200k 6 2>&1
  done
done > $OUT/grid-200k.txt
# 2. The grid's build on real scenes (`trace --repeat 5`, medians), BASE and NEW, two rounds.
{
for round in 1 2; do
  for s in sponza conference; do
    for b in base new; do
      bin=$NEW; [ $b = base ] && bin=$BASE
      echo "== round $round $s $b: $($bin trace "$RAYS/$s-shadow.rays" --scene bench/scenes/$s.toml -e grid --any-hit --repeat 5 2>&1 | grep -E '^[0-9]+ rays')"
    done
  done
done
} > $OUT/grid-real.txt
# 3. The grid against Embree's build in the same sitting (NEW): `render --stats`, engine
# build, 1 M and 2 M hairballs and Sponza.
{
echo "| scene | engine | engine build (s) | process peak (bytes) |"
echo "|---|---|---:|---:|"
for s in bench/scenes/sponza.toml hairball:1M hairball:2M; do
  for e in grid embree crsh; do
    $NEW render $s -e $e -W 256 -H 256 -b 0 -o /tmp/g.png --stats /tmp/g.json >/dev/null 2>&1
    python3 - "$s" "$e" <<'PY'
import json, sys
j = json.load(open("/tmp/g.json"))
build = dict((p[0], p[1]) for p in j["phases"]).get("engine build")
print(f"| {sys.argv[1]} | {sys.argv[2]} | {build:.3f} | {j.get('peak_rss_bytes')} |")
PY
  done
done
} > $OUT/builds.md
# 4. CRSH's packets (any hit), BASE and NEW, with Embree's single-ray and stream engines:
# three rounds of `trace --repeat 10` on Sponza's and Conference's shadow and AO batches.
{
for round in 1 2 3; do
  for s in sponza conference; do
    for k in shadow ao; do
      for run in "base crsh" "new crsh" "new embree" "new embree-stream"; do
        set -- $run; bin=$NEW; [ $1 = base ] && bin=$BASE
        echo "== round $round $s $k $1 $2"
        $bin trace "$RAYS/$s-$k.rays" --scene bench/scenes/$s.toml -e $2 --any-hit --repeat 10 2>&1 | grep -E "^[0-9]+ rays|^runs|^hits"
      done
    done
  done
done
} > $OUT/packets.txt
python3 $OUT/summarize.py
