//! The irregular grid and the two-level grid: structural invariants, and exactly the
//! brute-force engine's hits on built-in scenes and random scenes (closest-hit records bit
//! for bit — same kernel, same tie rule — and any-hit booleans).

use accel::grid::voxelmap::{INDEX, LOG_DIM_MASK, LOG_DIM_SHIFT};
use accel::grid::{build_grid, Grid, GridConfig, GridEngine, MergeRule, Subdivision, NODE};
use accel::oracle::assert_same_hits;
use accel::BruteForce;
use geom::aabb::tri_overlaps_box;
use geom::Vec3;
use proptest::prelude::*;
use render::whitted::trace_primary;
use render::View;
use scene::{builtin, Geometry};
use testkit::grid_case as random_case;
use testkit::record_render;
use trace::{Hit, TraceMode, TraceStats, Tracer};

fn configs() -> Vec<(&'static str, GridConfig)> {
    vec![
        ("grid", GridConfig::default()),
        ("two-level", GridConfig::two_level()),
        (
            "merge only",
            GridConfig {
                expansion_passes: 0,
                ..Default::default()
            },
        ),
        (
            "expansion only",
            GridConfig {
                merge: false,
                ..Default::default()
            },
        ),
        (
            "adaptive subdivision",
            GridConfig {
                subdivision: Subdivision::Adaptive,
                ..Default::default()
            },
        ),
        (
            "merge by pairs (paper)",
            GridConfig {
                merge_rule: MergeRule::Pairs,
                ..Default::default()
            },
        ),
        (
            "macro regions",
            GridConfig {
                top_density: 2.0,
                max_depth: 0,
                empty_only: true,
                ..Default::default()
            },
        ),
        (
            "dense, 1 pass",
            GridConfig {
                top_density: 0.5,
                leaf_density: 8.0,
                expansion_passes: 1,
                ..Default::default()
            },
        ),
    ]
}

/// The voxel map covers every cell exactly: walking the entry tree, every leaf entry's region
/// lies inside the box of the cell it names, and each cell's regions add up to its volume.
fn check_voxel_map(g: &Grid) {
    let mut covered = vec![0u128; g.cells()];
    let mut stack: Vec<(u32, [u32; 3], u32)> = Vec::new();
    for z in 0..g.top_dims[2] {
        for y in 0..g.top_dims[1] {
            for x in 0..g.top_dims[0] {
                let e = g.entries[g.top_index([x, y, z])];
                stack.push((e, [x, y, z].map(|v| v << g.shift), g.shift));
            }
        }
    }
    while let Some((e, lo, s)) = stack.pop() {
        if e & NODE != 0 {
            let k = (e >> LOG_DIM_SHIFT) & LOG_DIM_MASK;
            assert!(k >= 1 && k <= s, "a block of {k} levels below level {s}");
            let n = 1u32 << k;
            let step = 1u32 << (s - k);
            for z in 0..n {
                for y in 0..n {
                    for x in 0..n {
                        let i = x | y << k | z << (2 * k);
                        let c = [lo[0] + x * step, lo[1] + y * step, lo[2] + z * step];
                        stack.push((g.entries[((e & INDEX) + i) as usize], c, s - k));
                    }
                }
            }
            continue;
        }
        let c = e as usize;
        assert!(c < g.cells(), "entry names cell {c} of {}", g.cells());
        let hi = lo.map(|v| v + (1 << s));
        assert!(
            (0..3).all(|k| g.cell_min[c][k] <= lo[k] && hi[k] <= g.cell_max[c][k]),
            "region {lo:?}..{hi:?} maps to cell {c} {:?}..{:?}",
            g.cell_min[c],
            g.cell_max[c]
        );
        covered[c] += 1u128 << (3 * s);
    }
    for (c, &cov) in covered.iter().enumerate() {
        let vol: u128 = (0..3)
            .map(|k| (g.cell_max[c][k] - g.cell_min[c][k]) as u128)
            .product();
        assert_eq!(cov, vol, "cell {c}: voxel map covers {cov} of {vol} voxels");
    }
}

/// Every voxel maps to the cell containing it; every triangle overlapping a cell's box is
/// referenced by it; every expanded box overlaps only cells whose references it holds.
fn check_structure(g: &Grid, tris: &[[Vec3; 3]]) {
    check_voxel_map(g);
    let voxels: u64 = g.dims.iter().map(|&d| d as u64).product();
    if voxels > 3_000_000 {
        return check_refs(g, tris);
    }
    for z in 0..g.dims[2] {
        for y in 0..g.dims[1] {
            for x in 0..g.dims[0] {
                let c = g.lookup([x, y, z]) as usize;
                let (lo, hi) = (g.cell_min[c], g.cell_max[c]);
                assert!(
                    (0..3).all(|k| lo[k] <= [x, y, z][k] && [x, y, z][k] < hi[k]),
                    "voxel {:?} maps to cell {c} {:?}..{:?}",
                    [x, y, z],
                    lo,
                    hi
                );
            }
        }
    }
    check_refs(g, tris);
    for c in 0..g.cells() {
        let refs = g.cell_refs(c);
        let (lo, hi) = (g.exp_min[c], g.exp_max[c]);
        for z in lo[2]..hi[2] {
            for y in lo[1]..hi[1] {
                for x in lo[0]..hi[0] {
                    let n = g.lookup([x, y, z]) as usize;
                    assert!(
                        g.cell_refs(n).iter().all(|r| refs.binary_search(r).is_ok()),
                        "expanded cell {c} covers cell {n} with other triangles"
                    );
                }
            }
        }
    }
}

/// References are ascending and complete: every triangle overlapping a cell's box is referenced.
fn check_refs(g: &Grid, tris: &[[Vec3; 3]]) {
    for c in 0..g.cells() {
        let refs = g.cell_refs(c);
        assert!(
            refs.windows(2).all(|w| w[0] < w[1]),
            "cell {c}: references ascending and unique"
        );
        let b = g.world_box(g.cell_min[c], g.cell_max[c]);
        for (t, tri) in tris.iter().enumerate() {
            if tri_overlaps_box(&b, tri) {
                assert!(
                    refs.binary_search(&(t as u32)).is_ok(),
                    "cell {c} misses overlapping triangle {t}"
                );
            }
        }
    }
}

#[test]
fn structure_on_small_scenes() {
    for (name, s) in [
        ("soup", builtin::soup(300, 4)),
        ("cornell", builtin::cornell()),
        ("office", builtin::office(2)),
        ("stadium", builtin::stadium()),
    ] {
        let geo = Geometry::from_scene(&s);
        for (what, cfg) in configs() {
            let g = build_grid(&geo.tris, &cfg).unwrap();
            check_structure(&g, &geo.tris);
            if cfg.empty_only {
                // Macro regions: cells with triangles stay single uniform cells, unexpanded.
                for c in (0..g.cells()).filter(|&c| !g.cell_refs(c).is_empty()) {
                    assert!((0..3).all(|k| g.cell_max[c][k] - g.cell_min[c][k] == 1 << g.shift));
                    assert_eq!((g.exp_min[c], g.exp_max[c]), (g.cell_min[c], g.cell_max[c]));
                }
            }
            if cfg.merge {
                assert!(
                    g.cells() < g.build.initial_cells,
                    "{name} {what}: merging removed cells"
                );
            }
        }
    }
}

#[test]
fn builtin_scenes_match_brute_force() {
    for name in builtin::NAMES {
        let s = builtin::by_name(name).unwrap();
        let geo = Geometry::from_scene(&s);
        let mut batches = record_render(&s, &geo, 48, 36, 2);
        // Primary rays too (the grid is a general engine).
        let view = View::new(&s.camera, 48, 36);
        let (prim, hits, _) = trace_primary(&view, &BruteForce::new(&geo));
        batches.push((prim, TraceMode::Closest, hits));
        for (what, cfg) in configs() {
            let e = GridEngine::new(&geo, &cfg).unwrap();
            for (k, (rays, mode, hits)) in batches.iter().enumerate() {
                assert_same_hits(&e, rays, *mode, hits, &format!("{name} {what} batch {k}"));
            }
        }
    }
}

/// The 8-lane traversal against the scalar stream on the same grid and rays: the same hit
/// records bit for bit and the same N_T and N_I, ray by ray.
fn lanes_equal_scalar(
    g: &Grid,
    tris: &[[Vec3; 3]],
    rays: &trace::RayBatch,
    mode: TraceMode,
    what: &str,
) {
    use accel::grid::{lanes, traverse};
    let mut a = vec![Hit::MISS; rays.len()];
    let mut b = vec![Hit::MISS; rays.len()];
    for i in 0..rays.len() {
        let ca = lanes::trace(g, tris, rays, i, &mut a[i..i + 1], mode);
        let cb = traverse::trace_stream(g, tris, rays, i, &mut b[i..i + 1], mode);
        assert_eq!(
            (ca.steps, ca.tests),
            (cb.steps, cb.tests),
            "{what}: counts of ray {i}"
        );
    }
    let ca = lanes::trace(g, tris, rays, 0, &mut a, mode);
    let cb = traverse::trace_stream(g, tris, rays, 0, &mut b, mode);
    assert_eq!(
        (ca.steps, ca.tests),
        (cb.steps, cb.tests),
        "{what}: summed counts"
    );
    for (i, (x, y)) in a.iter().zip(&b).enumerate() {
        assert!(
            x.tri == y.tri
                && x.t.to_bits() == y.t.to_bits()
                && x.u.to_bits() == y.u.to_bits()
                && x.v.to_bits() == y.v.to_bits(),
            "{what}: ray {i}: lanes {x:?}, scalar {y:?}"
        );
    }
}

#[test]
fn lanes_equal_the_scalar_traversal_on_builtin_scenes() {
    if !accel::grid::lanes::available() {
        testkit::skip(
            "avx2",
            "this CPU has no AVX2: the grid traces with the scalar stream only",
        );
        return;
    }
    for name in builtin::NAMES {
        let s = builtin::by_name(name).unwrap();
        let geo = Geometry::from_scene(&s);
        let mut batches: Vec<(trace::RayBatch, TraceMode)> = record_render(&s, &geo, 40, 30, 2)
            .into_iter()
            .map(|(r, m, _)| (r, m))
            .collect();
        batches.push((
            View::new(&s.camera, 40, 30).primary_rays(),
            TraceMode::Closest,
        ));
        for (what, cfg) in configs() {
            let g = build_grid(&geo.tris, &cfg).unwrap();
            for (k, (rays, mode)) in batches.iter().enumerate() {
                lanes_equal_scalar(
                    &g,
                    &geo.tris,
                    rays,
                    *mode,
                    &format!("{name} {what} batch {k}"),
                );
            }
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(40))]

    #[test]
    fn lanes_equal_the_scalar_traversal_on_random_scenes(seed in 0u64..1_000_000, ntri in 1usize..400, nray in 1usize..600, which in 0usize..7, any_hit in any::<bool>()) {
        let (geo, rays) = random_case(seed, ntri, nray);
        let cfg = configs()[which % configs().len()].1.clone();
        let mode = if any_hit { TraceMode::Any } else { TraceMode::Closest };
        let g = build_grid(&geo.tris, &cfg).unwrap();
        lanes_equal_scalar(&g, &geo.tris, &rays, mode, "random");
    }

    /// The lanes' edge paths: direction components that are ±0, subnormal (their reciprocal
    /// is infinite) or tiny, origins far outside the grid or on its planes, bounded and
    /// unbounded rays — where the entry's slab test skips NaN axes and the walk's floor
    /// conversions saturate.
    #[test]
    fn lanes_equal_the_scalar_traversal_on_edge_rays(seed in 0u64..1_000_000, ntri in 1usize..200, any_hit in any::<bool>()) {
        let (geo, _) = random_case(seed, ntri, 1);
        let g = build_grid(&geo.tris, &GridConfig::default()).unwrap();
        let mut rng = geom::rng::Pcg32::new(seed, 77);
        let comps = [0.0f32, -0.0, 1e-40, -1e-40, 1e-30, -1e-20, 0.5, -1.0, 1.0];
        let places = [0.0f32, -0.0, 1.0, -1.0, 1e6, -1e6, 0.25, 1e-38];
        let mut rays = trace::RayBatch::default();
        for i in 0..256u32 {
            let d = Vec3::new(
                comps[rng.below(comps.len() as u32) as usize],
                comps[rng.below(comps.len() as u32) as usize],
                comps[rng.below(comps.len() as u32) as usize],
            );
            if d == Vec3::ZERO {
                continue;
            }
            let o = Vec3::new(
                places[rng.below(places.len() as u32) as usize] + rng.range(-0.01, 0.01) * (i % 2) as f32,
                places[rng.below(places.len() as u32) as usize],
                places[rng.below(places.len() as u32) as usize],
            );
            let t_max = if i % 3 == 0 { rng.range(0.0, 3.0) } else { f32::INFINITY };
            rays.push(geom::Ray::new(o, d, 0.0, t_max), trace::RayKind::Reflection, i, 0, Vec3::ONE, 0);
        }
        let mode = if any_hit { TraceMode::Any } else { TraceMode::Closest };
        lanes_equal_scalar(&g, &geo.tris, &rays, mode, "edge rays");
        let mut expect = vec![Hit::MISS; rays.len()];
        BruteForce::new(&geo).trace(&rays, mode, &mut expect, &mut TraceStats::default());
        assert_same_hits(&GridEngine::new(&geo, &GridConfig::default()).unwrap(), &rays, mode, &expect, "edge rays");
    }

    #[test]
    fn random_scenes_match_brute_force(seed in 0u64..1_000_000, ntri in 1usize..500, nray in 1usize..800, which in 0usize..7, any_hit in any::<bool>()) {
        let (geo, rays) = random_case(seed, ntri, nray);
        let cfg = configs()[which % configs().len()].1.clone();
        let mode = if any_hit { TraceMode::Any } else { TraceMode::Closest };
        let mut expect = vec![Hit::MISS; rays.len()];
        BruteForce::new(&geo).trace(&rays, mode, &mut expect, &mut TraceStats::default());
        assert_same_hits(&GridEngine::new(&geo, &cfg).unwrap(), &rays, mode, &expect, "random");
    }
}

/// The teapot in a stadium (§6 of the paper): the paper's one depth per top cell leaves the
/// small dense knot in a few huge cells (over a thousand tests per primary ray); adaptive
/// subdivision gives it cells of its own size. Counts are deterministic.
#[test]
fn adaptive_subdivision_resolves_the_stadium() {
    let s = builtin::stadium();
    let geo = Geometry::from_scene(&s);
    let view = View::new(&s.camera, 64, 64);
    let per_ray = |sub: Subdivision| {
        let cfg = GridConfig {
            subdivision: sub,
            ..Default::default()
        };
        let e = GridEngine::new(&geo, &cfg).unwrap();
        let rays = view.primary_rays();
        let mut hits = vec![Hit::MISS; rays.len()];
        let mut st = TraceStats::default();
        e.trace(&rays, TraceMode::Closest, &mut hits, &mut st);
        st.ray_tri_tests as f64 / rays.len() as f64
    };
    let (paper, adaptive) = (per_ray(Subdivision::Paper), per_ray(Subdivision::Adaptive));
    assert!(
        paper > 300.0,
        "paper rule: {paper:.1} tests per primary ray"
    );
    assert!(
        adaptive <= 30.0,
        "adaptive: {adaptive:.1} tests per primary ray"
    );
}

/// Absurd densities are refused with a message naming the options, before the memory is
/// allocated (no abort, no runaway allocation).
#[test]
fn absurd_densities_are_refused() {
    let small = Geometry::from_scene(&builtin::soup(300, 4));
    let large = Geometry::from_scene(&builtin::soup(20_000, 4));
    for (geo, cfg, option) in [
        (
            &large,
            GridConfig {
                top_density: 1e4,
                ..Default::default()
            },
            "`grid_top_density`",
        ),
        (
            &small,
            GridConfig {
                top_density: 1e4,
                leaf_density: 1e4,
                ..Default::default()
            },
            "`grid_leaf_density`",
        ),
    ] {
        let err = build_grid(&geo.tris, &cfg)
            .expect_err("refused")
            .to_string();
        assert!(err.contains(option), "{err}");
    }
}

/// Every merge schedule gives the grid of evaluating every live cell in every pass (the
/// paper's plain loop): the skipped cells keep "no candidate", and the face walks find
/// every cell whose probe neighbour changed. Scenes from a box to a hairball, both merge
/// rules, macro regions, and alpha 1 (merge until nothing merges: many late passes).
#[test]
fn merge_schedules_equal_evaluating_every_cell() {
    use accel::grid::merge::{merge_scheduled, Schedule};
    let hairball = scene::generate::Spec::parse("hairball:8k")
        .unwrap()
        .unwrap()
        .generate();
    let scenes = [
        ("cornell", builtin::cornell()),
        ("office", builtin::office(1)),
        ("stadium", builtin::stadium()),
        ("soup", builtin::soup(3000, 7)),
        ("hairball", hairball),
    ];
    let mut faces_used = 0;
    for (name, sc) in &scenes {
        let geo = Geometry::from_scene(sc);
        for (what, cfg) in configs().into_iter().filter(|(_, c)| c.merge) {
            let init = accel::grid::build::initial(&geo.tris, &cfg).unwrap();
            for alpha in [cfg.alpha, 1.0] {
                let run = |s: Schedule| {
                    let mut g = init.clone();
                    let rounds = merge_scheduled(&mut g, alpha, cfg.empty_only, cfg.merge_rule, s);
                    (rounds, g)
                };
                let (rounds, want) = run(Schedule::Every);
                for s in [Schedule::Scan, Schedule::Faces, Schedule::Auto] {
                    let (r, g) = run(s);
                    let at = format!("{name}, {what}, alpha {alpha}, {s:?}");
                    assert_eq!(r, rounds, "{at}: rounds");
                    assert_eq!(g.entries, want.entries, "{at}: voxel map");
                    assert_eq!(g.cell_min, want.cell_min, "{at}: cell minima");
                    assert_eq!(g.cell_max, want.cell_max, "{at}: cell maxima");
                    assert_eq!(g.ref_first, want.ref_first, "{at}: reference ranges");
                    assert_eq!(g.refs, want.refs, "{at}: references");
                }
                faces_used += (rounds > 1) as usize;
            }
        }
    }
    // Late passes exist (more than one round), so the face walks had work to do.
    assert!(faces_used > 10, "{faces_used}");
}
