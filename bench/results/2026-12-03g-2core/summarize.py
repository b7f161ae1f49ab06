#!/usr/bin/env python3
"""summary.md from this sitting's logs: the grid's passes (grid-build*.txt), its real-scene
builds (grid-real.txt) and CRSH's packets against Embree (packets.txt)."""
import collections, os, re, statistics

here = os.path.dirname(os.path.abspath(__file__))
med = statistics.median
out = []

# 1. Grid passes per (scene, binary): every run's ms per pass, its peak, the hashes seen.
passes = collections.defaultdict(lambda: collections.defaultdict(list))
hashes = collections.defaultdict(set)
for name in ("grid-build.txt", "grid-build-more.txt", "grid-200k.txt"):
    path = os.path.join(here, name)
    if not os.path.exists(path):
        continue
    key = None
    for line in open(path):
        m = re.match(r"== round \d+ (\S+) (base|new)", line)
        if m:
            key = (m.group(1), m.group(2))
            continue
        m = re.match(r"\s*(top_refs|octrees|cells|merge|expansion|total)\s+([\d.]+) ms", line)
        if m and key:
            passes[key][m.group(1)].append(float(m.group(2)))
        m = re.match(r"structure hash (\S+)", line)
        if m and key:
            hashes[key[0]].add(m.group(1))
        m = re.match(r"peak (\d+) KB", line)
        if m and key:
            passes[key]["peak KB"].append(float(m.group(1)))
out.append("## The grid's passes (grid_build, medians over the runs; NEW/BASE of the medians; 200k: each run the best of 6 builds)\n")
out.append("| scene | pass | runs | BASE ms | NEW ms | NEW/BASE |")
out.append("|---|---|---:|---:|---:|---:|")
for scene in sorted({k[0] for k in passes}):
    b, n = passes[(scene, "base")], passes[(scene, "new")]
    for p in ("top_refs", "octrees", "cells", "merge", "expansion", "total", "peak KB"):
        if b[p] and n[p]:
            out.append(f"| {scene} | {p} | {len(n[p])} | {med(b[p]):.0f} | {med(n[p]):.0f} | {med(n[p]) / med(b[p]):.2f} |")
    # Paired by round: the runs were interleaved.
    ratios = [y / x for x, y in zip(b["merge"], n["merge"])]
    out.append(f"| {scene} | merge, run by run | | | | {', '.join(f'{r:.2f}' for r in ratios)} |")
out.append("")
for scene, hs in sorted(hashes.items()):
    out.append(f"- {scene}: structure hash {', '.join(sorted(hs))} in every run of both binaries")
out.append("")

# 2. Real scenes: the grid's build medians.
real = collections.defaultdict(list)
for line in open(os.path.join(here, "grid-real.txt")):
    m = re.match(r"== round \d+ (\S+) (base|new): .*build ([\d.]+) ms", line)
    if m:
        real[(m.group(1), m.group(2))].append(float(m.group(3)))
out.append("## The grid's build on real scenes (trace --repeat 5 medians, per round)\n")
out.append("| scene | BASE ms | NEW ms | NEW/BASE |")
out.append("|---|---|---|---|")
for scene in ("sponza", "conference"):
    b, n = real[(scene, "base")], real[(scene, "new")]
    out.append(f"| {scene} | {', '.join(map(str, b))} | {', '.join(map(str, n))} | {', '.join(f'{y / x:.2f}' for x, y in zip(b, n))} |")
out.append("")

# 3. Packets: trace medians over every run of every round.
runs = collections.defaultdict(list)
hits = collections.defaultdict(set)
key = None
for line in open(os.path.join(here, "packets.txt")):
    m = re.match(r"== round \d+ (\S+) (\S+) (base|new) (\S+)", line)
    if m:
        key = (f"{m.group(1)} {m.group(2)}", f"{m.group(3)} {m.group(4)}")
    elif line.startswith("runs") and key:
        for r in line.split(": ", 1)[1].split(","):
            runs[key].append(float(r.strip().split("+")[1]))
    elif line.startswith("hits") and key:
        hits[key].add(line.split(",")[0])
out.append("## CRSH's packets (any hit), trace ms, medians of 30 runs (3 rounds × 10)\n")
out.append("| batch | BASE crsh | NEW crsh | NEW/BASE | Embree single-ray | Embree stream | NEW / single-ray | NEW / stream |")
out.append("|---|---:|---:|---:|---:|---:|---:|---:|")
for batch in dict.fromkeys(k[0] for k in runs):
    b, n, e, s = (med(runs[(batch, w)]) for w in ("base crsh", "new crsh", "new embree", "new embree-stream"))
    out.append(f"| {batch} | {b:.1f} | {n:.1f} | {n / b:.2f} | {e:.1f} | {s:.1f} | {n / e:.2f} | {n / s:.2f} |")
out.append("")
for batch in dict.fromkeys(k[0] for k in runs):
    b, n = hits[(batch, "base crsh")], hits[(batch, "new crsh")]
    out.append(f"- {batch}: BASE {sorted(b)}, NEW {sorted(n)}")
open(os.path.join(here, "summary.md"), "w").write("\n".join(out) + "\n")
