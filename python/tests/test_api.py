"""The bindings against the command line and brute force: same rays, same hits bit for bit,
same image bytes, same counts; bad input raises rayspace.Error with the CLI's message."""

import json
import threading

import numpy as np
import pytest

import rayspace as rs
from conftest import run_cli

ENGINES = ["bvh", "crsh", "rah", "grid", "grid2l", "obvhs-cwbvh", "obvhs-bvh2"]


@pytest.fixture(scope="module")
def office():
    return rs.Scene.load("office")


def same_hits(a, b):
    assert np.array_equal(a["triangle"], b["triangle"])
    # Bit for bit: compare the float32 words.
    for k in ("t", "u", "v"):
        assert np.array_equal(a[k].view(np.uint32), b[k].view(np.uint32)), k


def test_scene_properties():
    s = rs.Scene.load("cornell")
    assert s.name == "cornell" and s.triangle_count > 0 and s.mesh_count > 0 and s.light_count == 1
    lo, hi = s.bounds
    assert all(a < b for a, b in zip(lo, hi))
    t = s.triangles()
    assert t.shape == (s.triangle_count, 3, 3) and t.dtype == np.float32
    assert not s.animated and s.time_range is None
    with pytest.raises(rs.Error, match="is not animated"):
        s.at_time(0.5)
    with pytest.raises(rs.Error, match="not a built-in scene"):
        rs.Scene.load("no-such-scene")
    with pytest.raises(rs.Error, match="meshes='x'"):
        rs.Scene.load("cornell", meshes="x")


@pytest.mark.parametrize("kind", ["primary", "shadow", "random"])
def test_every_engine_returns_brute_forces_hits(office, kind):
    r = rs.rays(office, kind, width=48, height=40, seed=3)
    assert r["origins"].shape == (len(r["tmin"]), 3) and r["origins"].dtype == np.float32
    any_hit = False
    brute = rs.Engine(office, "brute").trace(**r, any_hit=any_hit)
    assert (brute["triangle"] != rs.MISS).any()
    for name in ENGINES:
        e = rs.Engine(office, name)
        same_hits(e.trace(**r), brute)
        c = e.counters()
        assert c["rays"] == len(r["tmin"]) and c["total_tests"] > 0, name


def test_any_hit_agrees_on_occlusion(office):
    r = rs.rays(office, "shadow", width=32, height=32)
    occluded = rs.Engine(office, "brute").trace(**r, any_hit=True)["triangle"] != rs.MISS
    for name in ENGINES:
        got = rs.Engine(office, name).trace(**r, any_hit=True)["triangle"] != rs.MISS
        assert np.array_equal(got, occluded), name


def test_rays_and_hits_equal_the_command_lines_files(tmp_path):
    rays_file, hits_file, mine = tmp_path / "r.rays", tmp_path / "h.hits", tmp_path / "mine.hits"
    run_cli("rays", "office", "--kind", "random", "--width", "40", "--height", "30", "--seed", "5", "--out", str(rays_file))
    run_cli("trace", str(rays_file), "--scene", "office", "--engine", "grid", "--out", str(hits_file))
    scene = rs.Scene.load("office")
    made = rs.rays(scene, "random", width=40, height=30, seed=5)
    read = rs.read_rays(rays_file)
    for k in made:
        assert np.array_equal(made[k], read[k]), k
    hits = rs.Engine(scene, "grid").trace(**read)
    cli_hits = rs.read_hits(hits_file)
    assert cli_hits["any_hit"] is False
    same_hits(hits, cli_hits)
    rs.write_hits(mine, **hits)
    assert mine.read_bytes() == hits_file.read_bytes()
    rs.write_rays(tmp_path / "again.rays", **made, scene=scene)
    assert (tmp_path / "again.rays").read_bytes() == rays_file.read_bytes()


def test_render_equals_the_command_lines_png_and_stats(tmp_path):
    png, stats = tmp_path / "a.png", tmp_path / "a.json"
    run_cli("render", "cornell", "--engine", "crsh", "--width", "64", "--height", "48", "--out", str(png), "--stats", str(stats))
    img, st = rs.render(rs.Scene.load("cornell"), "crsh", width=64, height=48)
    assert img.shape == (48, 64, 3) and img.dtype == np.uint8
    assert rs.png_bytes(img) == png.read_bytes()
    cli_stats = json.loads(stats.read_text())
    assert set(st) == set(cli_stats)
    for k in ("total_tests", "covered_pixels", "rays_shadow", "triangles"):
        assert st[k] == cli_stats[k], k
    rs.write_png(tmp_path / "b.png", img)
    assert (tmp_path / "b.png").read_bytes() == png.read_bytes()


def test_engine_options_are_the_command_lines(office):
    r = rs.rays(office, "shadow", width=32, height=32)
    a = rs.Engine(office, "crsh", levels=2, branching=4, object_hierarchy="mesh-spheres")
    b = rs.Engine(office, "crsh")
    same_hits(a.trace(**r), b.trace(**r))
    assert a.counters()["node_tri_tests"] != b.counters()["node_tri_tests"]
    g = rs.Engine(office, "grid", grid_merge=False, grid_expansion=0)
    assert "cells" in g.build_report and g.build_passes
    with pytest.raises(rs.Error, match='levels="many": expected an integer'):
        rs.Engine(office, "crsh", levels="many")
    with pytest.raises(TypeError, match="unknown engine option no_such_option"):
        rs.Engine(office, "crsh", no_such_option=1)
    with pytest.raises(rs.Error, match="nope"):
        rs.Engine(office, "nope")
    with pytest.raises(rs.Error, match=r"branching=1: must be in 2\.\.=64"):
        rs.Engine(office, "crsh", branching=1)
    with pytest.raises(rs.Error, match=r"levels=-3: must be in 0\.\.=16"):
        rs.Engine(office, "crsh", levels=-3)
    # An option of another engine is refused, as the command line refuses it.
    with pytest.raises(rs.Error, match="ray_path does not apply to engine=crsh"):
        rs.Engine(office, "crsh", ray_path="single")
    names = {o["name"]: o for o in rs.engine_options()}
    assert names["ray_path"]["engines"] == ["bvh"] and names["branching"]["default"] == "8"
    assert rs.DEFAULT_ENGINE in rs.engines()


def test_numpy_input_of_any_real_dtype_and_strides_traces_as_float32(office):
    e = rs.Engine(office, "grid")
    r = rs.rays(office, "random", width=16, height=16, seed=3)
    o, d = r["origins"], r["directions"]
    want = e.trace(o, d, tmin=np.zeros(len(o), np.float32), tmax=np.full(len(o), np.inf, np.float32))
    assert (want["triangle"] != rs.MISS).any()
    # float64 (NumPy's default), Fortran order, strided views, plain lists, scalar bounds.
    wide = np.zeros((len(o), 6), np.float64)
    wide[:, ::2] = o
    for oo, dd in [
        (o.astype(np.float64), d.astype(np.float64)),
        (np.asfortranarray(o), np.asfortranarray(d)),
        (wide[:, ::2], np.repeat(d, 2, axis=0)[::2]),
        (o.tolist(), d.tolist()),
    ]:
        got = e.trace(oo, dd, tmin=0, tmax=np.inf)
        assert np.array_equal(got["triangle"], want["triangle"])
        assert np.array_equal(got["t"].view(np.uint32), want["t"].view(np.uint32))
    # Integer origins are real numbers too.
    ints = e.trace(np.zeros((2, 3), np.int64), np.array([[0, 0, 1], [1, 0, 0]]))
    assert len(ints["t"]) == 2
    # A float32 C-contiguous array is used as it is (no copy is made of it).
    assert rs._array("origins", o, np.float32, (None, 3)) is o


def test_bad_arrays_are_refused(office):
    e = rs.Engine(office, "grid")
    o = np.zeros((4, 3), np.float32)
    d = np.tile(np.array([0, 0, 1], np.float32), (4, 1))
    assert len(e.trace(o, d)["t"]) == 4
    with pytest.raises(ValueError, match=r"directions: expected shape \(N, 3\), got \(4, 4\)"):
        e.trace(o, np.ones((4, 4), np.float32))
    with pytest.raises(TypeError, match="origins: expected real numbers, got an array of dtype complex"):
        e.trace(o.astype(np.complex64), d)
    with pytest.raises(TypeError, match="expected real numbers"):
        e.trace([["a", "b", "c"]] * 4, d)
    with pytest.raises(ValueError, match=r"tmax: expected shape \(4,\)"):
        e.trace(o, d, tmax=np.ones(3))
    bad = o.copy()
    bad[2, 1] = np.nan
    with pytest.raises(rs.Error, match="origins: row 2 is not finite"):
        e.trace(bad, d)
    with pytest.raises(rs.Error, match="directions: 3 rays, but origins has 4"):
        e.trace(o, d[:3])
    with pytest.raises(rs.Error, match=r"ray 1: origin .* must be finite and the direction non-zero"):
        z = d.copy()
        z[1] = 0
        e.trace(o, z)
    with pytest.raises(rs.Error, match="tmin"):
        e.trace(o, d, tmin=np.zeros(3, np.float32))
    with pytest.raises(rs.Error, match=r"bad t range"):
        e.trace(o, d, tmin=np.full(4, 2, np.float32), tmax=np.ones(4, np.float32))
    with pytest.raises(rs.Error, match="width=0"):
        rs.rays(office, width=0)
    with pytest.raises(rs.Error, match="kind='sideways'"):
        rs.rays(office, "sideways")


def test_bad_files_raise_the_command_lines_message(tmp_path):
    p = tmp_path / "bad.rays"
    p.write_bytes(b"not a ray file at all")
    with pytest.raises(rs.Error, match="bad.rays"):
        rs.read_rays(p)
    with pytest.raises(rs.Error):
        rs.read_hits(tmp_path / "missing.hits")


def test_tracing_threads_share_an_engine(office):
    """The GIL is released while tracing, and one engine serves several threads."""
    r = rs.rays(office, "random", width=64, height=64)
    e = rs.Engine(office, "grid")
    want = e.trace(**r)
    got = [None] * 4

    def work(i):
        got[i] = e.trace(**r)

    ts = [threading.Thread(target=work, args=(i,)) for i in range(4)]
    for t in ts:
        t.start()
    for t in ts:
        t.join()
    for g in got:
        same_hits(g, want)


def test_version_and_a_clean_namespace():
    assert isinstance(rs.__version__, str) and rs.__version__[0].isdigit()
    public = {n for n in dir(rs) if not n.startswith("_")}
    for helper in ("np", "os", "json", "Dict", "List", "Any", "Optional", "Union", "Tuple"):
        assert helper not in public, helper
    assert set(rs.__all__) <= set(dir(rs))


def test_shared_scenes_by_name_as_the_command_line():
    from conftest import need, scenes_dir

    need(scenes_dir().is_dir(), f"no shared scenes at {scenes_dir()}")
    s = rs.Scene.load("sponza")
    assert s.name == "sponza" and s.triangle_count > 60_000
    # The automatic camera and light of a bare OBJ come with the ambient fill, and an
    # exposure of -1 halves every light.
    bare = str(scenes_dir() / "cornell-box" / "CornellBox-Original.obj")
    img, stats = rs.render(rs.Scene.load(bare), "grid", width=32, height=32)
    dark, _ = rs.render(rs.Scene.load(bare, exposure=-1), "grid", width=32, height=32)
    assert dark.astype(int).sum() < img.astype(int).sum()


def test_antialiasing_samples(office):
    one, s1 = rs.render(office, "grid", width=48, height=48, bounces=1)
    four, s4 = rs.render(office, "grid", width=48, height=48, bounces=1, spp=4)
    assert (s1["spp"], s4["spp"]) == (1, 4)
    assert s4["rays_shadow"] > 3 * s1["rays_shadow"]
    assert len({tuple(p) for p in four.reshape(-1, 3)}) > len({tuple(p) for p in one.reshape(-1, 3)})
    with pytest.raises(rs.Error, match="spp=0"):
        rs.render(office, "grid", width=8, height=8, spp=0)
