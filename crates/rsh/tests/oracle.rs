//! CRSH and RAH return exactly the brute-force engine's hits: on every built-in scene's
//! Whitted batches for every (b, d) in {4, 8, 16} × {1, 2, 3, 4} and both engines, and on
//! random scenes and rays (proptest).
//!
//! Closest-hit records are compared bit for bit (all engines share one ray–triangle kernel
//! and the tie rule "smallest t, then smallest triangle id"), so the stated t tolerance is 0.
//! Any-hit results are compared as booleans.

use accel::oracle::assert_same_hits;
use accel::BruteForce;
use geom::{Pcg32, Ray, Vec3};
use proptest::prelude::*;
use rsh::{
    Descent, HashKind, NodeTest, ObjectBuilder, ObjectHierarchy, RshConfig, RshEngine, Schedule,
    Union,
};
use scene::{builtin, Geometry};
use testkit::record_render;
use testkit::soup_case as random_case;
use trace::{Hit, RayBatch, RayKind, TraceMode, TraceStats, Tracer};

/// `base` with the thesis's object side: every triangle behind the per-mesh spheres.
fn mesh_spheres(base: RshConfig) -> RshConfig {
    RshConfig {
        objects: ObjectHierarchy::MeshSpheres,
        ..base
    }
}

#[test]
fn builtin_scenes_all_configs_match_brute_force() {
    for name in builtin::NAMES {
        let s = builtin::by_name(name).unwrap();
        let geo = Geometry::from_scene(&s);
        let batches = record_render(&s, &geo, 40, 30, 2);
        assert!(
            batches.len() >= 3,
            "{name}: shadow and secondary batches were traced"
        );
        for base in [
            mesh_spheres(RshConfig::crsh()),
            mesh_spheres(RshConfig::rah()),
        ] {
            for b in [4u32, 8, 16] {
                for d in [1u32, 2, 3, 4] {
                    let cfg = RshConfig {
                        branching: b,
                        levels: d,
                        ..base.clone()
                    };
                    let e = RshEngine::new(&geo, cfg.clone()).unwrap();
                    for (k, (rays, mode, hits)) in batches.iter().enumerate() {
                        assert_same_hits(
                            &e,
                            rays,
                            *mode,
                            hits,
                            &format!("{name} {:?} {b}/{d} batch {k}", cfg.method),
                        );
                    }
                }
            }
        }
    }
}

/// The object hierarchy (LBVH and dual traversal) on every built-in scene: each descent
/// rule, both methods, with and without mesh culling, several shapes of the ray hierarchy
/// and a tiny pair budget.
#[test]
fn object_hierarchy_matches_brute_force() {
    let descents = [Descent::RayFirst, Descent::Size, Descent::ObjectFirst];
    for name in builtin::NAMES {
        let s = builtin::by_name(name).unwrap();
        let geo = Geometry::from_scene(&s);
        let batches = record_render(&s, &geo, 32, 24, 2);
        for base in [RshConfig::crsh(), RshConfig::rah()] {
            for (k, descent) in descents.into_iter().enumerate() {
                for (b, d, budget) in [(8u32, 2u32, 1 << 20), (4, 3, 1024), (16, 0, 1 << 20)] {
                    for schedule in [Schedule::Depth, Schedule::Breadth] {
                        let cfg = RshConfig {
                            objects: ObjectHierarchy::Bvh,
                            descent,
                            schedule,
                            branching: b,
                            levels: d,
                            pair_budget: budget,
                            mesh_culling: base.mesh_culling ^ (k == 1),
                            // Either builder's tree.
                            builder: if schedule == Schedule::Breadth {
                                ObjectBuilder::Sah
                            } else {
                                ObjectBuilder::Lbvh
                            },
                            ..base.clone()
                        };
                        let e = RshEngine::new(&geo, cfg.clone()).unwrap();
                        for (j, (rays, mode, hits)) in batches.iter().enumerate() {
                            let what = format!(
                                "{name} {:?} {descent:?} {schedule:?} {b}/{d} batch {j}",
                                cfg.method
                            );
                            assert_same_hits(&e, rays, *mode, hits, &what);
                        }
                    }
                }
            }
        }
    }
}

/// Hit records carry the shared kernel's own (t, u, v) for the ray and the triangle they
/// name, whichever schedule found them: the depth-first traversal keeps a hit's barycentrics
/// from its test (the 8-lane kernel's or a walk's), the others recompute them. Closest hits
/// are compared with brute force elsewhere; this holds any-hit records to it too.
#[test]
fn hit_records_are_the_kernels_own() {
    for name in builtin::NAMES {
        let s = builtin::by_name(name).unwrap();
        let geo = Geometry::from_scene(&s);
        let batches = record_render(&s, &geo, 32, 24, 2);
        let mut hits = 0;
        for schedule in [Schedule::Depth, Schedule::Breadth] {
            let e = RshEngine::new(&geo, bvh(Descent::Size, schedule)).unwrap();
            for (j, (rays, _, _)) in batches.iter().enumerate() {
                for mode in [TraceMode::Any, TraceMode::Closest] {
                    let mut got = vec![Hit::MISS; rays.len()];
                    e.trace(rays, mode, &mut got, &mut TraceStats::default());
                    for (i, h) in got.iter().enumerate().filter(|(_, h)| h.is_hit()) {
                        let [a, b, c] = geo.tris[h.tri as usize];
                        let pre = geom::tri::RayPre::new(&rays.ray(i));
                        let k = geom::intersect(&pre, a, b, c).expect("a recorded hit repeats");
                        let want = (k.t.to_bits(), k.u.to_bits(), k.v.to_bits());
                        let have = (h.t.to_bits(), h.u.to_bits(), h.v.to_bits());
                        assert_eq!(have, want, "{name} {schedule:?} {mode:?} batch {j} ray {i}");
                        hits += 1;
                    }
                }
            }
        }
        assert!(hits > 0, "{name}: some records were checked");
    }
}

/// CRSH's defaults with the object hierarchy, `descent` and `schedule`.
fn bvh(descent: Descent, schedule: Schedule) -> RshConfig {
    RshConfig {
        objects: ObjectHierarchy::Bvh,
        descent,
        schedule,
        ..RshConfig::crsh()
    }
}

/// The dual traversal's counters are the same from run to run (rayon schedules differ).
#[test]
fn object_hierarchy_counts_are_deterministic() {
    let s = builtin::office(7);
    let geo = Geometry::from_scene(&s);
    let batches = record_render(&s, &geo, 48, 40, 2);
    let runs = [Descent::RayFirst, Descent::Size, Descent::ObjectFirst]
        .into_iter()
        .flat_map(|d| [(d, Schedule::Depth), (d, Schedule::Breadth)]);
    for (descent, schedule) in runs {
        let cfg = bvh(descent, schedule);
        let e = RshEngine::new(&geo, cfg).unwrap();
        let run = || {
            let mut st = TraceStats::default();
            for (rays, mode, _) in &batches {
                let mut got = vec![Hit::MISS; rays.len()];
                e.trace(rays, *mode, &mut got, &mut st);
            }
            (st.counters.clone(), st.levels.clone(), st.total_tests())
        };
        let first = run();
        for _ in 0..3 {
            assert_eq!(run(), first, "{descent:?} {schedule:?}");
        }
    }
}

#[test]
fn variants_match_brute_force() {
    // Hash, union, node test, culling, the full pyramid and a tiny pair budget (forcing
    // triangle batches and split expansions) on the office and cornell scenes.
    for name in ["office", "cornell"] {
        let s = builtin::by_name(name).unwrap();
        let geo = Geometry::from_scene(&s);
        let batches = record_render(&s, &geo, 32, 32, 2);
        let variants = [
            RshConfig {
                hash: HashKind::Morton64,
                ..mesh_spheres(RshConfig::crsh())
            },
            RshConfig {
                union: Union::Thesis,
                ..mesh_spheres(RshConfig::crsh())
            },
            RshConfig {
                node_test: NodeTest::Exact,
                ..mesh_spheres(RshConfig::crsh())
            },
            RshConfig {
                mesh_culling: false,
                ..mesh_spheres(RshConfig::crsh())
            },
            RshConfig {
                mesh_culling: true,
                ..mesh_spheres(RshConfig::rah())
            },
            RshConfig {
                branching: 4,
                levels: 0,
                ..mesh_spheres(RshConfig::rah())
            },
            RshConfig {
                pair_budget: 1024,
                ..mesh_spheres(RshConfig::crsh())
            },
            RshConfig {
                branching: 2,
                levels: 6,
                pair_budget: 1500,
                ..mesh_spheres(RshConfig::rah())
            },
        ];
        for cfg in variants {
            let e = RshEngine::new(&geo, cfg.clone()).unwrap();
            for (k, (rays, mode, hits)) in batches.iter().enumerate() {
                assert_same_hits(&e, rays, *mode, hits, &format!("{name} {cfg:?} batch {k}"));
            }
        }
    }
}

#[test]
fn tiny_budget_forces_batches_and_keeps_every_pair() {
    let s = builtin::office(7);
    let geo = Geometry::from_scene(&s);
    let rays = {
        let mut rng = Pcg32::new(3, 3);
        let r: Vec<Ray> = (0..3000)
            .map(|_| {
                Ray::new(
                    Vec3::new(
                        rng.range(-9.0, 9.0),
                        rng.range(0.1, 3.0),
                        rng.range(-9.0, 9.0),
                    ),
                    rng.unit_vector(),
                    0.0,
                    f32::INFINITY,
                )
            })
            .collect();
        RayBatch::from_rays(&r, RayKind::Reflection)
    };
    let mut expect = vec![Hit::MISS; rays.len()];
    BruteForce::new(&geo).trace(
        &rays,
        TraceMode::Closest,
        &mut expect,
        &mut TraceStats::default(),
    );
    let e = RshEngine::new(
        &geo,
        RshConfig {
            pair_budget: 1024,
            ..mesh_spheres(RshConfig::crsh())
        },
    )
    .unwrap();
    let mut got = vec![Hit::MISS; rays.len()];
    let mut st = TraceStats::default();
    e.trace(&rays, TraceMode::Closest, &mut got, &mut st);
    assert_eq!(got, expect);
    assert!(
        st.counters[rsh::stats::TRIANGLE_BATCHES] > 1,
        "the budget forced triangle batches"
    );
    assert!(
        st.counters[rsh::stats::BUDGET_SPLITS] > 0,
        "the budget forced split expansions"
    );
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    #[test]
    fn random_scenes_match_brute_force(seed in 0u64..1_000_000, ntri in 1usize..400, nray in 1usize..1500, b in 2u32..17, d in 0u32..5, rah in any::<bool>(), exact in any::<bool>(), any_hit in any::<bool>(), objects in 0usize..4, breadth in any::<bool>(), sah in any::<bool>()) {
        let (geo, rays) = random_case(seed, ntri, nray);
        let base = if rah { RshConfig::rah() } else { RshConfig::crsh() };
        // 0: the thesis's mesh spheres; 1–3: the object hierarchy with each descent rule.
        let descents = [Descent::RayFirst, Descent::RayFirst, Descent::Size, Descent::ObjectFirst];
        let objects_kind = if objects == 0 { ObjectHierarchy::MeshSpheres } else { ObjectHierarchy::Bvh };
        let cfg = RshConfig { branching: b, levels: d, node_test: if exact { NodeTest::Exact } else { NodeTest::Rah }, union: if exact { Union::Exact } else { Union::Thesis }, objects: objects_kind, descent: descents[objects], schedule: if breadth { Schedule::Breadth } else { Schedule::Depth }, builder: if sah { ObjectBuilder::Sah } else { ObjectBuilder::Lbvh }, ..base };
        let mode = if any_hit { TraceMode::Any } else { TraceMode::Closest };
        let mut expect = vec![Hit::MISS; rays.len()];
        BruteForce::new(&geo).trace(&rays, mode, &mut expect, &mut TraceStats::default());
        assert_same_hits(&RshEngine::new(&geo, cfg).unwrap(), &rays, mode, &expect, "random");
    }
}

/// The two schedules take the same pairs in different orders: with closest hits (where no
/// pair depends on a hit) they test the same pairs, level by level, and with any hit the
/// depth-first one, which drops rays that hit, tests no more.
#[test]
fn schedules_test_the_same_pairs() {
    let s = builtin::office(7);
    let geo = Geometry::from_scene(&s);
    let batches = record_render(&s, &geo, 48, 40, 2);
    for descent in [Descent::RayFirst, Descent::Size, Descent::ObjectFirst] {
        let counts = |schedule| {
            let cfg = bvh(descent, schedule);
            let e = RshEngine::new(&geo, cfg).unwrap();
            batches
                .iter()
                .map(|(rays, mode, _)| {
                    let mut st = TraceStats::default();
                    let mut got = vec![Hit::MISS; rays.len()];
                    e.trace(rays, *mode, &mut got, &mut st);
                    let object = st.counters[rsh::stats::OBJECT_NODE_TESTS];
                    (*mode, st.levels.clone(), object)
                })
                .collect::<Vec<_>>()
        };
        let (depth, breadth) = (counts(Schedule::Depth), counts(Schedule::Breadth));
        let mut any = 0;
        for ((mode, dl, dobj), (_, bl, bobj)) in depth.iter().zip(&breadth) {
            match mode {
                TraceMode::Closest => {
                    assert_eq!(dl.tests, bl.tests, "{descent:?}: per-level tests");
                    assert_eq!(dl.hits, bl.hits, "{descent:?}: per-level passes");
                    assert_eq!(dobj, bobj, "{descent:?}: object-node tests");
                }
                TraceMode::Any => {
                    any += 1;
                    for (d, b) in dl.tests.iter().flatten().zip(bl.tests.iter().flatten()) {
                        assert!(d <= b, "{descent:?}: depth first tested more ({d} > {b})");
                    }
                }
            }
        }
        assert!(any > 0, "the render traced shadow rays");
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(160))]

    /// Rays whose directions are not unit vectors (ray files may hold any): the hierarchy
    /// measures lengths in distance, the traversal's slab and beam tests in the rays' own
    /// parameter; hits stay brute force's for every object hierarchy and schedule.
    #[test]
    fn unnormalised_directions_match_brute_force(seed in 0u64..1_000_000, ntri in 1usize..300, nray in 1usize..1200, scale_pow in -6i32..7, any_hit in any::<bool>(), objects in 0usize..4) {
        let (geo, mut rays) = random_case(seed, ntri, nray);
        let s = 2f32.powi(scale_pow);
        for i in 0..rays.len() {
            // Bounded rays (most nodes then have a finite reach), lengths in distance units
            // before the scaling.
            let len = if i % 5 == 0 { f32::INFINITY } else { 0.25 + (i % 11) as f32 * 0.5 };
            rays.dir[i] *= s;
            rays.t_min[i] /= s;
            rays.t_max[i] = len / s;
        }
        let mode = if any_hit { TraceMode::Any } else { TraceMode::Closest };
        let mut expect = vec![Hit::MISS; rays.len()];
        BruteForce::new(&geo).trace(&rays, mode, &mut expect, &mut TraceStats::default());
        let (objects, schedule, builder) = [
            (ObjectHierarchy::MeshSpheres, Schedule::Depth, ObjectBuilder::Sah),
            (ObjectHierarchy::Bvh, Schedule::Depth, ObjectBuilder::Sah),
            (ObjectHierarchy::Bvh, Schedule::Breadth, ObjectBuilder::Lbvh),
            (ObjectHierarchy::Bvh, Schedule::Depth, ObjectBuilder::Lbvh),
        ][objects];
        for base in [RshConfig::crsh(), RshConfig::rah()] {
            let cfg = RshConfig { objects, schedule, builder, ..base };
            assert_same_hits(&RshEngine::new(&geo, cfg).unwrap(), &rays, mode, &expect, "unnormalised");
        }
    }
}

/// A short direction and a long parameter range: the hierarchy's lengths are distances,
/// the beam's entry and exit are ray parameters.
#[test]
fn short_directions_reach_far_triangles() {
    let tris = vec![
        [
            Vec3::new(-1.0, -1.0, 2.0),
            Vec3::new(1.0, -1.0, 2.0),
            Vec3::new(0.0, 1.0, 2.0),
        ],
        [
            Vec3::new(-1.0, -1.0, 3.0),
            Vec3::new(1.0, -1.0, 3.0),
            Vec3::new(0.0, 1.0, 3.0),
        ],
    ];
    let geo = Geometry::soup(tris, Vec3::Y);
    let mut rays = RayBatch::default();
    for i in 0..16 {
        let o = Vec3::new(i as f32 * 0.01, 0.0, 0.0);
        let r = Ray::new(o, Vec3::new(0.0, 0.0, 1.0 / 64.0), 0.0, 4.0 * 64.0);
        rays.push(r, RayKind::Shadow, i, 0, Vec3::ONE, 0);
    }
    let mut expect = vec![Hit::MISS; rays.len()];
    BruteForce::new(&geo).trace(
        &rays,
        TraceMode::Closest,
        &mut expect,
        &mut TraceStats::default(),
    );
    assert!(expect.iter().all(|h| h.is_hit()));
    for objects in [ObjectHierarchy::MeshSpheres, ObjectHierarchy::Bvh] {
        for schedule in [Schedule::Depth, Schedule::Breadth] {
            let cfg = RshConfig {
                objects,
                schedule,
                mesh_culling: false,
                ..RshConfig::crsh()
            };
            let e = RshEngine::new(&geo, cfg).unwrap();
            assert_same_hits(
                &e,
                &rays,
                TraceMode::Closest,
                &expect,
                &format!("{objects:?} {schedule:?}"),
            );
        }
    }
}
