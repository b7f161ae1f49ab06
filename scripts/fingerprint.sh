#!/usr/bin/env bash
# Output fingerprint of the CLI: image bytes and every count, with times left out, for the
# built-in scenes on every engine (CPU; the GPU backend too when a Vulkan driver is there),
# plus ray files, traced hits and an animation's per-frame counts. A reshaping of the code
# must leave it unchanged:  scripts/fingerprint.sh > before.txt; ...; diff before.txt after.txt
# Usage: scripts/fingerprint.sh [path/to/rayspace]   (default: target/release/rayspace)
set -euo pipefail
bin="${1:-target/release/rayspace}"
tmp="$(mktemp -d)"; trap 'rm -rf "$tmp"' EXIT
# Strip times (keys or rows naming seconds/ms/MRays, `*_ms` keys) and the peak memories (process, build) from JSON
# and tables.
strip_json() {
    python3 - "$1" <<'PY'
import json, sys
def clean(v):
    if isinstance(v, dict):
        return {k: clean(x) for k, x in v.items()
                if k not in ("phases", "load_seconds", "build_passes", "peak_rss_bytes", "build_peak_bytes") and "time" not in k and "seconds" not in k and not k.endswith("_ms")}
    if isinstance(v, list):
        return [clean(x) for x in v]
    return v
print(json.dumps(clean(json.load(open(sys.argv[1]))), sort_keys=True))
PY
}
engines="bvh crsh rah grid grid2l brute obvhs-cwbvh obvhs-bvh2"
# Builds with the Embree peer say so in --version (features: ..., embree).
if "$bin" --version | grep embree >/dev/null; then engines="$engines embree embree-stream"; fi
for scene in cornell spheres soup stadium office; do
    for e in $engines; do
        "$bin" render "$scene" --width 64 --height 48 --engine "$e" --out "$tmp/o.png" --stats "$tmp/o.json" >/dev/null
        echo "render $scene $e $(sha256sum <"$tmp/o.png" | cut -c1-16) $(strip_json "$tmp/o.json")"
    done
done
# The ray hierarchy's own options, and bvh's paths and builders.
for args in "-e crsh --branching 8 --levels 2 --hash morton64" "-e crsh --union thesis --node-test exact" "-e crsh --mesh-culling off --pair-budget 4096" "-e crsh --object-hierarchy mesh-spheres" "-e crsh --schedule breadth --object-builder lbvh" "-e bvh --ray-path single --object-builder lbvh"; do
    # shellcheck disable=SC2086
    "$bin" render cornell --width 64 --height 48 $args --out "$tmp/o.png" --stats "$tmp/o.json" >/dev/null
    echo "render cornell $args $(sha256sum <"$tmp/o.png" | cut -c1-16) $(strip_json "$tmp/o.json")"
done
for args in "--grid-subdivision adaptive" "--grid-merge off --grid-expansion 0" "--grid-top-density 0.5 --grid-leaf-density 4"; do
    # shellcheck disable=SC2086
    "$bin" render stadium --width 64 --height 48 --engine grid $args --out "$tmp/o.png" --stats "$tmp/o.json" >/dev/null
    echo "render stadium grid $args $(sha256sum <"$tmp/o.png" | cut -c1-16) $(strip_json "$tmp/o.json")"
done
if [ "${FINGERPRINT_GPU:-1}" = 1 ] && "$bin" render cornell --width 8 --height 8 --backend gpu --out "$tmp/g.png" >/dev/null 2>&1; then
    for e in bvh crsh rah; do
        "$bin" render cornell --width 64 --height 48 --backend gpu --engine "$e" --out "$tmp/o.png" --stats "$tmp/o.json" >/dev/null
        echo "render-gpu cornell $e $(sha256sum <"$tmp/o.png" | cut -c1-16) $(strip_json "$tmp/o.json")"
    done
    # CRSH's bundles behind the mesh spheres on the device (the thesis's traversal).
    "$bin" render cornell --width 64 --height 48 --backend gpu --engine crsh --object-hierarchy mesh-spheres --out "$tmp/o.png" --stats "$tmp/o.json" >/dev/null
    echo "render-gpu cornell crsh mesh-spheres $(sha256sum <"$tmp/o.png" | cut -c1-16) $(strip_json "$tmp/o.json")"
else
    echo "SKIPPED: GPU backend (no Vulkan driver)" >&2
fi
for kind in primary shadow reflection ao random; do
    "$bin" rays office --kind "$kind" --width 40 --height 30 --seed 7 --out "$tmp/r.rays" >/dev/null
    echo "rays office $kind $(sha256sum <"$tmp/r.rays" | cut -c1-16)"
    for e in bvh crsh grid brute; do
        "$bin" trace "$tmp/r.rays" --scene office --engine "$e" --out "$tmp/h.hits" >/dev/null
        "$bin" trace "$tmp/r.rays" --scene office --engine "$e" --any-hit --out "$tmp/a.hits" >/dev/null
        echo "trace office $kind $e $(sha256sum <"$tmp/h.hits" | cut -c1-16) any-hit $(sha256sum <"$tmp/a.hits" | cut -c1-16)"
    done
done
printf '[camera]\neye = [0, 2, 8]\ntarget = [0, 0, 0]\n[[meshes]]\nshape = "plane"\nscale = 5\n[[meshes]]\nshape = "box"\n[meshes.animation]\nkeys = [{ t = 0 }, { t = 1, translate = [2, 1, 0], rotate = [0, 90, 0] }]\n' >"$tmp/anim.toml"
for e in bvh crsh grid; do
    "$bin" render "$tmp/anim.toml" --engine "$e" --width 48 --height 32 --frames 3 --out "$tmp/f%02d.png" --frame-csv "$tmp/f.csv" --gif "$tmp/f.gif" >/dev/null
    echo "frames anim $e $(cat "$tmp"/f0*.png | sha256sum | cut -c1-16) gif $(sha256sum <"$tmp/f.gif" | cut -c1-16) csv-header $(head -1 "$tmp/f.csv")"
    # Columns that are counts, not times (named in the header).
    python3 - "$tmp/f.csv" <<'PY'
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
for r in rows:
    print("  frame", {k: v for k, v in r.items() if "ms" not in k and "seconds" not in k and "_s" not in k and "time" not in k or k == "time"})
PY
done
