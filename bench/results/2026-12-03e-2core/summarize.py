#!/usr/bin/env python3
"""Summarise trace.txt (medians over every run of the three rounds, and minima), the
Kitchen frame CSVs (medians of frames 1-7 of build_ms + trace_ms) and grid-2m.txt (each
pass's median) into summary.md."""
import collections, csv, glob, os, re, statistics
here = os.path.dirname(os.path.abspath(__file__))
runs = collections.defaultdict(lambda: ([], []))
key = None
for line in open(os.path.join(here, "trace.txt")):
    m = re.match(r"== round \d+ (\S+) (\S+) (\S+) (\S+)", line)
    if m:
        key = m.groups()
    elif line.startswith("runs"):
        for r in line.split(":", 1)[1].split(","):
            b, t = r.strip().split("+")
            runs[key][0].append(float(b))
            runs[key][1].append(float(t))
out = ["| scene | rays | run | build ms (median / min) | trace ms (median / min) | frame ms (median) |",
       "|---|---|---|---:|---:|---:|"]
med = {}
for (s, k, b, e), (bl, tl) in runs.items():
    fr = [x + y for x, y in zip(bl, tl)]
    med[(s, k, b, e)] = (statistics.median(bl), statistics.median(tl), statistics.median(fr), min(tl))
    out.append(f"| {s} | {k} | {b} {e} | {statistics.median(bl):.1f} / {min(bl):.1f} | "
               f"{statistics.median(tl):.1f} / {min(tl):.1f} | {statistics.median(fr):.1f} |")
out += ["", "| scene | rays | NEW/BASE trace | NEW/BASE frame | NEW/embree trace | NEW frame / embree-stream frame | NEW trace / embree-stream trace |",
        "|---|---|---:|---:|---:|---:|---:|"]
for (s, k) in sorted({(s, k) for (s, k, _, _) in med}):
    n, b = med[(s, k, "new", "crsh")], med[(s, k, "base", "crsh")]
    em, es = med[(s, k, "new", "embree")], med[(s, k, "new", "embree-stream")]
    out.append(f"| {s} | {k} | {n[1]/b[1]:.2f} | {n[2]/b[2]:.2f} | {n[1]/em[1]:.2f} | {n[2]/es[2]:.2f} | {n[1]/es[1]:.2f} |")
out += ["", "Kitchen 512², 3 bounces, 8 frames: medians of frames 1-7 (ms)", "",
        "| run | build | trace | build + trace |", "|---|---:|---:|---:|"]
for f in sorted(glob.glob(os.path.join(here, "kitchen-*.csv"))):
    rows = list(csv.DictReader(open(f)))[1:]
    b = statistics.median(float(r["build_ms"]) for r in rows)
    t = statistics.median(float(r["trace_ms"]) for r in rows)
    bt = statistics.median(float(r["build_ms"]) + float(r["trace_ms"]) for r in rows)
    out.append(f"| {os.path.basename(f)[:-4]} | {b:.1f} | {t:.1f} | {bt:.1f} |")
passes = collections.defaultdict(list)
b = None
for line in open(os.path.join(here, "grid-2m.txt")):
    m = re.match(r"== round \d+ (\S+)", line)
    if m:
        b = m.group(1)
    m = re.match(r"\s+(\S+)\s+([0-9.]+) ms", line)
    if m and b:
        passes[(b, m.group(1))].append(float(m.group(2)))
    m = re.match(r"peak (\d+) KB", line)
    if m and b:
        passes[(b, "peak KB")].append(float(m.group(1)))
out += ["", "hairball:2M grid build, medians of two rounds (ms; peak in KB)", "",
        "| pass | BASE | NEW | NEW/BASE |", "|---|---:|---:|---:|"]
for p in ["top_refs", "octrees", "cells", "merge", "expansion", "total", "peak KB"]:
    x, y = passes.get(("base", p)), passes.get(("new", p))
    if x and y:
        out.append(f"| {p} | {statistics.median(x):.0f} | {statistics.median(y):.0f} | {statistics.median(y) / statistics.median(x):.2f} |")
open(os.path.join(here, "summary.md"), "w").write("\n".join(out) + "\n")
print("\n".join(out))
