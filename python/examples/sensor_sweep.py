"""A sensor sweeping its rays over a mesh that moves: the Python front door.

A flapping sheet (a height field whose vertices change every frame, as a simulator's would)
is made from NumPy arrays; a line sensor above it sweeps across, casting a fan of rays per
frame; after each update the engine is rebuilt and the hit points give the profile the
sensor sees. Prints one line per frame: the time, the rays that hit and the mean height
seen.

    python python/examples/sensor_sweep.py [--frames N] [--engine NAME]
"""

import argparse

import numpy as np

import rayspace as rs


def sheet(n: int, t: float):
    """An n × n grid over [-1, 1]² waving with time t: (vertices, faces)."""
    x, z = np.meshgrid(np.linspace(-1, 1, n), np.linspace(-1, 1, n), indexing="ij")
    y = 0.15 * np.sin(3.0 * x + 2.0 * t) * np.cos(2.0 * z - t)
    vertices = np.stack([x, y, z], axis=-1).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(n - 1), np.arange(n - 1), indexing="ij")
    a = (i * n + j).ravel()
    b, c, d = a + n, a + n + 1, a + 1
    faces = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    return vertices, faces


def fan(x: float, rays: int):
    """A fan of rays from a sensor at (x, 1, 0), spread across z, pointing down."""
    z = np.linspace(-0.9, 0.9, rays)
    origins = np.tile([x, 1.0, 0.0], (rays, 1))
    directions = np.stack([np.zeros(rays), -np.ones(rays), z], axis=1)
    return origins, directions


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=8)
    ap.add_argument("--engine", default=rs.DEFAULT_ENGINE)
    ap.add_argument("--rays", type=int, default=4096)
    args = ap.parse_args()
    vertices, faces = sheet(64, 0.0)
    scene = rs.Scene.from_arrays(vertices, faces)
    engine = rs.Engine(scene, args.engine)
    for frame in range(args.frames):
        t = frame / max(args.frames - 1, 1)
        scene.update(vertices=sheet(64, 4.0 * t)[0])
        engine.rebuild()
        origins, directions = fan(-0.8 + 1.6 * t, args.rays)
        hits = engine.trace(origins, directions, points=True)
        seen = hits["triangle"] != rs.MISS
        height = hits["point"][seen, 1].mean() if seen.any() else float("nan")
        print(f"t={t:.3f}: {seen.sum()} of {args.rays} rays hit, mean height {height:+.4f}")


if __name__ == "__main__":
    main()
