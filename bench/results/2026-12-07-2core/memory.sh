#!/usr/bin/env bash
# The memory models' measurements (issue 69): per engine, on a hairball and a city of 400k
# triangles, a 64² shadow-free render's whole-process peak and what the engine's build
# added at its peak, per triangle (`--stats`: peak_rss_bytes, build_peak_bytes), and the
# same for brute force (its build is a copy of the triangles), whose peak less its build
# is what the scene and its geometry hold. Run from the repository root with a release
# build with the Embree peer.
set -euo pipefail
R=${1:-target/release/rayspace}
"$R" --version
for sc in cornell hairball:400k city:400k; do
  for e in brute bvh "bvh --object-builder lbvh" crsh "crsh --object-hierarchy mesh-spheres" rah grid grid2l obvhs-cwbvh obvhs-bvh2 embree; do
    "$R" render $sc -b 0 -W 64 -H 64 -e $e --stats /tmp/m.json -o /tmp/m.png >/dev/null 2>&1 || { echo "$sc | $e | failed"; continue; }
    python3 -c "
import json; j=json.load(open('/tmp/m.json')); n=j['triangles']
print(f\"$sc | $e | {n} | peak {j['peak_rss_bytes']/1e6:.1f} MB | build peak {(j.get('build_peak_bytes') or 0)/n:.0f} B/tri | structure {(j.get('structure_bytes') or 0)/n:.0f} B/tri\")"
  done
done
