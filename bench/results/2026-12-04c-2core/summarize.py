#!/usr/bin/env python3
"""Medians and minima of build and trace per batch and run, and NEW's ratios (trace.txt)."""
import collections, statistics, sys

runs = collections.defaultdict(lambda: ([], []))
key = None
for line in open(sys.argv[1]):
    if line.startswith("== "):
        _, _, _, batch, who, engine = line.split()
        key = (batch, f"{who} {engine}")
    elif line.startswith("runs"):
        for r in line.split(": ", 1)[1].split(","):
            b, t = r.strip().split("+")
            runs[key][0].append(float(b))
            runs[key][1].append(float(t))
med = lambda v: statistics.median(v)
print("| batch | run | build ms (median / min) | trace ms (median / min) | build + trace (median) |")
print("|---|---|---:|---:|---:|")
batches = []
for (batch, who), (b, t) in runs.items():
    if batch not in batches:
        batches.append(batch)
    f = [x + y for x, y in zip(b, t)]
    print(f"| {batch} | {who} | {med(b):.1f} / {min(b):.1f} | {med(t):.1f} / {min(t):.1f} | {med(f):.1f} |")
print()
print("| batch | NEW/BASE trace (median) | NEW/BASE trace (min) | NEW/BASE build + trace | NEW trace / Embree trace |")
print("|---|---:|---:|---:|---:|")
for batch in batches:
    b, n, e = (runs[(batch, w)] for w in ("base crsh", "new crsh", "new embree"))
    fb = med([x + y for x, y in zip(*b)])
    fn = med([x + y for x, y in zip(*n)])
    print(f"| {batch} | {med(n[1]) / med(b[1]):.2f} | {min(n[1]) / min(b[1]):.2f} | {fn / fb:.2f} | {med(n[1]) / med(e[1]):.2f} |")
