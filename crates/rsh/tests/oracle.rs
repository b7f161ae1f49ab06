//! CRSH and RAH return exactly the brute-force engine's hits: on every built-in scene's
//! Whitted batches for every (b, d) in {4, 8, 16} × {1, 2, 3, 4} and both engines, and on
//! random scenes and rays (proptest).
//!
//! Closest-hit records are compared bit for bit (all engines share one ray–triangle kernel
//! and the tie rule "smallest t, then smallest triangle id"), so the stated t tolerance is 0.
//! Any-hit results are compared as booleans.

use accel::oracle::{assert_same_hits, record_render};
use accel::BruteForce;
use geom::{Pcg32, Ray, Vec3};
use proptest::prelude::*;
use render::{Hit, RayBatch, RayKind, TraceMode, TraceStats, Tracer};
use rsh::{HashKind, NodeTest, RshConfig, RshEngine, Union};
use scene::{builtin, Geometry};
use testkit::soup_case as random_case;

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
        for base in [RshConfig::crsh(), RshConfig::rah()] {
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
                ..RshConfig::crsh()
            },
            RshConfig {
                union: Union::Thesis,
                ..RshConfig::crsh()
            },
            RshConfig {
                node_test: NodeTest::Exact,
                ..RshConfig::crsh()
            },
            RshConfig {
                mesh_culling: false,
                ..RshConfig::crsh()
            },
            RshConfig {
                mesh_culling: true,
                ..RshConfig::rah()
            },
            RshConfig {
                branching: 4,
                levels: 0,
                ..RshConfig::rah()
            },
            RshConfig {
                pair_budget: 1024,
                ..RshConfig::crsh()
            },
            RshConfig {
                branching: 2,
                levels: 6,
                pair_budget: 1500,
                ..RshConfig::rah()
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
            ..RshConfig::crsh()
        },
    )
    .unwrap();
    let mut got = vec![Hit::MISS; rays.len()];
    let mut st = TraceStats::default();
    e.trace(&rays, TraceMode::Closest, &mut got, &mut st);
    assert_eq!(got, expect);
    assert!(
        st.counters[render::stats::counter::TRIANGLE_BATCHES] > 1,
        "the budget forced triangle batches"
    );
    assert!(
        st.counters[render::stats::counter::BUDGET_SPLITS] > 0,
        "the budget forced split expansions"
    );
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    #[test]
    fn random_scenes_match_brute_force(seed in 0u64..1_000_000, ntri in 1usize..400, nray in 1usize..1500, b in 2u32..17, d in 0u32..5, rah in any::<bool>(), exact in any::<bool>(), any_hit in any::<bool>()) {
        let (geo, rays) = random_case(seed, ntri, nray);
        let base = if rah { RshConfig::rah() } else { RshConfig::crsh() };
        let cfg = RshConfig { branching: b, levels: d, node_test: if exact { NodeTest::Exact } else { NodeTest::Rah }, union: if exact { Union::Exact } else { Union::Thesis }, ..base };
        let mode = if any_hit { TraceMode::Any } else { TraceMode::Closest };
        let mut expect = vec![Hit::MISS; rays.len()];
        BruteForce::new(&geo).trace(&rays, mode, &mut expect, &mut TraceStats::default());
        assert_same_hits(&RshEngine::new(&geo, cfg).unwrap(), &rays, mode, &expect, "random");
    }
}
