#!/usr/bin/env bash
# This stop's GPU frames on Mesa's lavapipe (no GPU was lent), BASE against NEW in one run:
# BASE=1cd8085 (the session's start) and NEW=this stop, each `cargo build --profile ci
# --features embree`; RAYSPACE_SCENES=../shared/scenes. Writes counts.md (every count is
# deterministic) from the stats JSON; image bytes are compared with cmp. Rows: RAH's default
# on the GPU (the dual traversal over the object tree: NEW lays the hierarchy out and paces
# the traversal on the device), CRSH with --ray-path bundles (still paced by the host), and
# CRSH's and the grid's defaults (unchanged).
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
cd "$here/../../.."
BASE=${BASE:?the session-start binary}
NEW=${NEW:-target/ci/rayspace}
out=${OUT:-/tmp/lavapipe-laid}
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
for run in BASE NEW; do
    bin=$BASE; [ "$run" = NEW ] && bin=$NEW
    frames "rah-$run" "$bin" --engine rah
    frames "crshb-$run" "$bin" --engine crsh --ray-path bundles
    frames "crsh-$run" "$bin" --engine crsh
    frames "grid-$run" "$bin" --engine grid
done
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
print("| frame | run | read-backs | dispatches | host↔device bytes | total tests | hits | image and tests = BASE's |")
print("|---|---|---:|---:|---:|---:|---:|---|")
for f in ["office-b3", "sponza-b0", "kitchen-frames", "cornell-spp3"]:
    for eng, label in [("rah", "rah (default)"), ("crshb", "crsh --ray-path bundles"),
                       ("crsh", "crsh (default)"), ("grid", "grid")]:
        for run in ["BASE", "NEW"]:
            xs = load(f, f"{eng}-{run}")
            hits = " / ".join(str(x["trace"]["hits"]) for x in xs)
            base = load(f, f"{eng}-BASE")
            eq = "yes" if same_images(f, f"{eng}-{run}", f"{eng}-BASE") and [x["total_tests"] for x in xs] == [x["total_tests"] for x in base] else "NO"
            gf = xs[-1].get("gpu_frame", "")
            print(f"| {f} | {run} {label} | {col(xs, 'host_read_backs')} | {col(xs, 'gpu_dispatches')} | {col(xs, 'host_device_bytes')} | {col(xs, 'total_tests')} | {hits} | {eq} |")
PY
echo "wrote $here/counts.md"
