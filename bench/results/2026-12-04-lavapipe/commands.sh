#!/usr/bin/env bash
# This stop's GPU frames on Mesa's lavapipe (no GPU was lent), BASE against NEW in one run:
# BASE=2a4cef6 (the session's start) and NEW=this stop, each `cargo build --profile ci
# --features embree`; RAYSPACE_SCENES=../shared/scenes. Writes counts.md (every count is
# deterministic) and the stats JSON it is made from; image bytes are compared with cmp.
# Rows: RAH's default on the GPU (BASE: the thesis's bundles behind mesh spheres; NEW: the
# dual traversal over the object tree built on the device), RAH with mesh spheres asked for
# on both, and NEW's CRSH with --ray-path bundles (BASE refuses it on the GPU).
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
cd "$here/../../.."
BASE=${BASE:?the session-start binary}
NEW=${NEW:-target/ci/rayspace}
out=${OUT:-/tmp/lavapipe-dual}
mkdir -p "$out"
row() { # name bin args... (an animation's frames go to name-00.png, name-01.png, ...)
    local name=$1 bin=$2; shift 2
    local png="$out/$name.png"
    case " $* " in *" --frames "*) png="$out/$name-%02d.png" ;; esac
    "$bin" render "$@" --stats "$out/$name.json" --out "$png" >"$out/$name.log" 2>&1 ||
        { cat "$out/$name.log"; exit 1; }
}
frames() { # name bin engine-args...
    local name=$1 bin=$2; shift 2
    row "office-b3-$name" "$bin" office -W 128 -H 128 --bounces 3 --backend gpu "$@"
    row "sponza-b0-$name" "$bin" bench/scenes/sponza.toml -W 512 -H 512 --bounces 0 --backend gpu "$@"
    row "kitchen-frames-$name" "$bin" kitchen -W 128 -H 128 --bounces 3 --frames 3 --backend gpu "$@"
    row "cornell-spp3-$name" "$bin" cornell -W 64 -H 48 --bounces 3 --spp 3 --backend gpu "$@"
}
frames rah-BASE "$BASE" --engine rah
frames rah-NEW "$NEW" --engine rah
frames rahms-BASE "$BASE" --engine rah --object-hierarchy mesh-spheres
frames rahms-NEW "$NEW" --engine rah --object-hierarchy mesh-spheres
frames crshb-NEW "$NEW" --engine crsh --ray-path bundles
frames crsh-NEW "$NEW" --engine crsh
python3 - "$out" <<'PY' > "$here/counts.md"
import json, sys, os, filecmp
out = sys.argv[1]
def load(f, run):
    v = json.load(open(f"{out}/{f}-{run}.json"))
    return v if isinstance(v, list) else [v]
def pngs(f, run):
    return sorted(p[len(f"{f}-{run}"):] for p in os.listdir(out) if p.startswith(f"{f}-{run}") and p.endswith(".png"))
def same_images(f, a, b):
    ps = pngs(f, a)
    return bool(ps) and ps == pngs(f, b) and all(filecmp.cmp(f"{out}/{f}-{a}{p}", f"{out}/{f}-{b}{p}", shallow=False) for p in ps)
col = lambda xs, k: " / ".join(str(x[k]) for x in xs)
print("| frame | run | object side | read-backs | dispatches | host↔device bytes | total tests | tests per ray | hits | image = BASE RAH's |")
print("|---|---|---|---:|---:|---:|---:|---:|---:|---|")
for f in ["office-b3", "sponza-b0", "kitchen-frames", "cornell-spp3"]:
    for run, label in [("rah-BASE", "BASE rah (default)"), ("rah-NEW", "NEW rah (default)"),
                       ("rahms-BASE", "BASE rah, mesh-spheres"), ("rahms-NEW", "NEW rah, mesh-spheres"),
                       ("crshb-NEW", "NEW crsh --ray-path bundles"), ("crsh-NEW", "NEW crsh (default: single rays)")]:
        xs = load(f, run)
        rays = [x["trace"]["rays"] for x in xs]
        tpr = " / ".join(f"{x['total_tests'] / max(r, 1):.1f}" for x, r in zip(xs, rays))
        hits = " / ".join(str(x["trace"]["hits"]) for x in xs)
        eq = "yes" if same_images(f, run, "rah-BASE") else "NO"
        # (--frames' per-frame stats carry no object_hierarchy: the run's single-frame rows say it.)
        side = xs[0].get("object_hierarchy") or load("office-b3", run)[0]["object_hierarchy"]
        print(f"| {f} | {label} | {side} | {col(xs, 'host_read_backs')} | {col(xs, 'gpu_dispatches')} | {col(xs, 'host_device_bytes')} | {col(xs, 'total_tests')} | {tpr} | {hits} | {eq} |")
PY
echo "wrote $here/counts.md"
