//! The peers (obvhs; Embree with `--features embree`) against the brute-force oracle on the
//! built-in scenes' rendered rays, and on random scenes.
//!
//! Same triangle and t within `T_TOL` (obvhs calls our kernel, so its t is bit-identical
//! where it finds the hit), except for hits exactly on a triangle edge or vertex, which a
//! peer may lose (Embree's kernel is not watertight; obvhs's box tests are not conservative
//! at box faces): see `accel::oracle::Agreement`. Such cases must stay rare (≤ 0.1 %).

use accel::oracle::Agreement;
use accel::peers::{BvhKind, ObvhsEngine};
use scene::{builtin, Geometry};
use testkit::record_render;
use trace::{Hit, TraceMode, TraceStats, Tracer};

fn scenes() -> Vec<(&'static str, scene::Scene)> {
    vec![
        ("cornell", builtin::cornell()),
        ("spheres", builtin::spheres()),
        ("soup", builtin::soup(1500, 7)),
        ("stadium", builtin::stadium()),
        ("office", builtin::office(3)),
    ]
}

/// obvhs's CWBVH node test clamps the entry distance to `max(t, 1e-4)` (an absolute
/// epsilon, `obvhs::cwbvh::node::EPSILON`, which also ignores the ray's t_min), so it cannot
/// see hits nearer than this. Its BVH2 has no such clamp.
const CWBVH_T_EPS: f32 = 1e-4;

#[test]
fn obvhs_agrees_with_brute_force() {
    for (name, s) in scenes() {
        let geo = Geometry::from_scene(&s);
        let batches = record_render(&s, &geo, 96, 80, 3);
        for (kind, floor) in [(BvhKind::Bvh2, 0.0), (BvhKind::CwBvh, CWBVH_T_EPS)] {
            let e = ObvhsEngine::new(&geo, kind);
            let mut a = Agreement::default();
            for (rays, tm, hits) in &batches {
                let mut got = vec![Hit::MISS; rays.len()];
                e.trace(rays, *tm, &mut got, &mut TraceStats::default());
                a.check(&geo.tris, rays, *tm, hits, &got, floor);
            }
            assert_eq!(a.wrong, 0, "{name} {kind:?}: {a:?}");
            assert!(a.at_edges * 1000 <= a.rays, "{name} {kind:?}: {a:?}");
            eprintln!("{name} obvhs {kind:?}: {a:?}");
        }
    }
}

#[cfg(feature = "embree")]
fn embree_records(
    e: &accel::peers::EmbreeEngine,
    rays: &trace::RayBatch,
    mode: TraceMode,
) -> Vec<Hit> {
    let mut got = vec![Hit::MISS; rays.len()];
    e.trace(rays, mode, &mut got, &mut TraceStats::default());
    got
}

#[cfg(feature = "embree")]
#[test]
fn embree_agrees_with_brute_force() {
    use accel::peers::{EmbreeEngine, EmbreeMode};
    for (name, s) in scenes() {
        let geo = Geometry::from_scene(&s);
        let batches = record_render(&s, &geo, 48, 40, 2);
        for mode in [EmbreeMode::Single, EmbreeMode::Stream] {
            let e = EmbreeEngine::new(&geo, mode).unwrap();
            let mut a = Agreement::default();
            for (rays, tm, hits) in &batches {
                a.check(
                    &geo.tris,
                    rays,
                    *tm,
                    hits,
                    &embree_records(&e, rays, *tm),
                    0.0,
                );
            }
            assert_eq!(a.wrong, 0, "{name} {mode:?}: {a:?}");
            // Edge cases are rare; many would mean a systematic error hiding behind them.
            assert!(a.at_edges * 1000 <= a.rays, "{name} {mode:?}: {a:?}");
            eprintln!("{name} embree {mode:?}: {a:?}");
        }
    }
}

mod random {
    use super::*;
    use accel::BruteForce;
    use proptest::prelude::*;
    use testkit::grid_case as random_case;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        #[test]
        fn peers_match_brute_force_on_random_scenes(seed in 0u64..1_000_000, ntri in 1usize..400, nray in 1usize..600, any_hit in any::<bool>()) {
            let (geo, rays) = random_case(seed, ntri, nray);
            let mode = if any_hit { TraceMode::Any } else { TraceMode::Closest };
            let mut expect = vec![Hit::MISS; rays.len()];
            BruteForce::new(&geo).trace(&rays, mode, &mut expect, &mut TraceStats::default());
            for (kind, floor) in [(BvhKind::Bvh2, 0.0), (BvhKind::CwBvh, CWBVH_T_EPS)] {
                let mut got = vec![Hit::MISS; rays.len()];
                ObvhsEngine::new(&geo, kind).trace(&rays, mode, &mut got, &mut TraceStats::default());
                let mut a = Agreement::default();
                a.check(&geo.tris, &rays, mode, &expect, &got, floor);
                prop_assert_eq!(a.wrong, 0, "{:?}: {:?}", kind, a);
            }
            #[cfg(feature = "embree")]
            for m in [accel::peers::EmbreeMode::Single, accel::peers::EmbreeMode::Stream] {
                let e = accel::peers::EmbreeEngine::new(&geo, m).unwrap();
                let mut a = Agreement::default();
                let got = embree_records(&e, &rays, mode);
                a.check(&geo.tris, &rays, mode, &expect, &got, 0.0);
                prop_assert_eq!(a.wrong, 0, "{:?}: {:?}", m, a);
            }
        }
    }
}

/// The agreement check is not vacuous: a wrong triangle, a lost hit and an invented hit
/// away from any edge are all counted as wrong.
#[test]
fn agreement_detects_wrong_records() {
    let s = builtin::cornell();
    let geo = Geometry::from_scene(&s);
    let batches = record_render(&s, &geo, 32, 32, 1);
    let (rays, mode, hits) = batches
        .iter()
        .find(|b| b.1 == TraceMode::Closest)
        .expect("a closest-hit batch");
    let mut got = hits.clone();
    let victims: Vec<usize> = (0..rays.len())
        .filter(|&i| hits[i].is_hit())
        .step_by(97)
        .take(3)
        .collect();
    got[victims[0]].tri ^= 1;
    got[victims[1]] = Hit::MISS;
    got[victims[2]].t *= 1.5;
    let mut a = Agreement::default();
    a.check(&geo.tris, rays, *mode, hits, &got, 0.0);
    assert_eq!(a.wrong, 3, "{a:?}");
}

proptest::proptest! {
    /// The point–triangle distance used to confirm coincident-surface ties: 0 inside, never
    /// more than the distance to any vertex, and the offset along the normal above the inside.
    #[test]
    fn point_triangle_distance_is_right(seed in 0u64..100_000, h in -2.0f32..2.0) {
        use accel::oracle::point_triangle_distance;
        let mut rng = geom::Pcg32::new(seed, 3);
        let t = [0, 1, 2].map(|_| rng.unit_vector() * 3.0);
        let n = (t[1] - t[0]).cross(t[2] - t[0]);
        proptest::prop_assume!(n.length() > 0.1);
        let (u, v) = (rng.next_f32(), rng.next_f32());
        let (u, v) = if u + v > 1.0 { (1.0 - u, 1.0 - v) } else { (u, v) };
        let inside = t[0] + (t[1] - t[0]) * u + (t[2] - t[0]) * v;
        proptest::prop_assert!(point_triangle_distance(inside, &t) < 1e-4);
        let above = inside + n.normalize() * h;
        proptest::prop_assert!((point_triangle_distance(above, &t) - h.abs()).abs() < 1e-3);
        let p = rng.unit_vector() * 5.0;
        let d = point_triangle_distance(p, &t);
        proptest::prop_assert!(t.iter().all(|v| d <= (p - *v).length() + 1e-4));
    }
}
