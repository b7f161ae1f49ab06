#!/usr/bin/env bash
# This stop's GPU frames on Mesa's lavapipe (no GPU was lent), BASE against NEW in one run:
# BASE=17ce51f and NEW=this stop, each `cargo build --profile ci --features embree,accel/embree`;
# RAYSPACE_SCENES=../shared/scenes. Writes counts.md (every count is deterministic) and the
# stats JSON it is made from; image bytes are compared with cmp.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
cd "$here/../../.."
BASE=${BASE:?the session-start binary}
NEW=${NEW:-target/ci/rayspace}
out=${OUT:-/tmp/lavapipe-counts}
mkdir -p "$out"
row() { # name bin args... (an animation's frames go to name-00.png, name-01.png, ...)
    local name=$1 bin=$2; shift 2
    local png="$out/$name.png"
    case " $* " in *" --frames "*) png="$out/$name-%02d.png" ;; esac
    "$bin" render "$@" --stats "$out/$name.json" --out "$png" >"$out/$name.log" 2>&1 ||
        { cat "$out/$name.log"; exit 1; }
}
for e in crsh grid rah; do
    for v in BASE NEW; do
        bin=${!v}
        row "office-b3-$e-$v" "$bin" office -W 128 -H 128 --bounces 3 --backend gpu --engine "$e"
        row "sponza-b0-$e-$v" "$bin" bench/scenes/sponza.toml -W 512 -H 512 --bounces 0 --backend gpu --engine "$e"
        row "sponza128-b3-$e-$v" "$bin" bench/scenes/sponza.toml -W 128 -H 128 --bounces 3 --backend gpu --engine "$e"
        row "kitchen-frames-$e-$v" "$bin" kitchen -W 128 -H 128 --bounces 3 --frames 3 --backend gpu --engine "$e"
        row "cornell-spp3-$e-$v" "$bin" cornell -W 64 -H 48 --bounces 3 --spp 3 --backend gpu --engine "$e"
    done
done
python3 - "$out" <<'PY' > "$here/counts.md"
import json, sys, os, filecmp
out = sys.argv[1]
keys = ["host_read_backs", "gpu_dispatches", "host_device_bytes", "total_tests", "rays_shadow", "rays_reflection", "rays_refraction"]
print("| frame | engine | read-backs BASE → NEW | dispatches BASE → NEW | host↔device bytes BASE → NEW | total tests (BASE = NEW) | image bytes |")
print("|---|---|---:|---:|---:|---:|---|")
for f in ["office-b3", "sponza-b0", "sponza128-b3", "kitchen-frames", "cornell-spp3"]:
    for e in ["crsh", "grid", "rah"]:
        b = json.load(open(f"{out}/{f}-{e}-BASE.json"))
        n = json.load(open(f"{out}/{f}-{e}-NEW.json"))
        if isinstance(b, dict):
            b, n = [b], [n]
        same = all(x.get(k) == y.get(k) for x, y in zip(b, n) for k in keys[3:])
        assert same, (f, e, "counts differ")
        col = lambda k: " / ".join(f"{x[k]} → {y[k]}" for x, y in zip(b, n))
        tests = " / ".join(str(x["total_tests"]) for x in b)
        pngs = sorted(p[len(f"{f}-{e}-NEW"):] for p in os.listdir(out) if p.startswith(f"{f}-{e}-NEW") and p.endswith(".png"))
        eq = all(filecmp.cmp(f"{out}/{f}-{e}-BASE{p}", f"{out}/{f}-{e}-NEW{p}", shallow=False) for p in pngs)
        eq = f"identical ({len(pngs)})" if eq and pngs else "DIFFER"
        print(f"| {f} | {e} | {col('host_read_backs')} | {col('gpu_dispatches')} | {col('host_device_bytes')} | {tests} | {eq} |")
PY
