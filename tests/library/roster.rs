//! The engines the library tests check against brute force: ours (bit for bit) and the
//! peers (within `accel::oracle::Agreement`'s rule, each with its floor).

use accel::oracle::{assert_same_hits, Agreement};
use accel::peers::{BvhKind, ObvhsEngine};
use scene::Geometry;
use trace::{Hit, RayBatch, TraceMode, TraceStats, Tracer};

/// `bvh` (both builders, packets and single rays), both grids, CRSH and RAH over `geo`.
pub fn ours(geo: &Geometry) -> Vec<Box<dyn Tracer>> {
    use accel::bvh::{ObjectBuilder, RayPath};
    let mut v: Vec<Box<dyn Tracer>> = vec![
        Box::new(accel::GridEngine::new(geo, &accel::GridConfig::default()).unwrap()),
        Box::new(accel::GridEngine::new(geo, &accel::GridConfig::two_level()).unwrap()),
    ];
    for cfg in [rsh::RshConfig::crsh(), rsh::RshConfig::rah()] {
        v.push(Box::new(rsh::RshEngine::new(geo, cfg).unwrap()));
    }
    for (builder, path) in [
        (ObjectBuilder::Sah, RayPath::Packets),
        (ObjectBuilder::Lbvh, RayPath::Single),
    ] {
        let cfg = accel::BvhConfig { builder, path };
        v.push(Box::new(accel::BvhEngine::new(geo, cfg).unwrap()));
    }
    v
}

/// obvhs (BVH2, CWBVH) and, with the `embree` feature, Embree (single rays, streams), each
/// with the distance floor its agreement is checked with.
pub fn peers(geo: &Geometry) -> Vec<(Box<dyn Tracer>, f32)> {
    #[allow(unused_mut)] // pushed to only with the `embree` feature
    let mut v: Vec<(Box<dyn Tracer>, f32)> = vec![
        (Box::new(ObvhsEngine::new(geo, BvhKind::Bvh2)), 0.0),
        (Box::new(ObvhsEngine::new(geo, BvhKind::CwBvh)), 1e-4),
    ];
    #[cfg(feature = "embree")]
    for m in [
        accel::peers::EmbreeMode::Single,
        accel::peers::EmbreeMode::Stream,
    ] {
        v.push((
            Box::new(accel::peers::EmbreeEngine::new(geo, m).unwrap()),
            0.0,
        ));
    }
    v
}

/// Every engine of `ours` returns `expect` (brute force's records) bit for bit, and every
/// peer agrees with it; `what` names the case in a failure.
pub fn check(
    geo: &Geometry,
    ours: &[Box<dyn Tracer>],
    peers: &[(Box<dyn Tracer>, f32)],
    rays: &RayBatch,
    mode: TraceMode,
    expect: &[Hit],
    what: &str,
) {
    for e in ours {
        assert_same_hits(
            e.as_ref(),
            rays,
            mode,
            expect,
            &format!("{what} {}", e.name()),
        );
    }
    for (p, floor) in peers {
        let mut got = vec![Hit::MISS; rays.len()];
        p.trace(rays, mode, &mut got, &mut TraceStats::default());
        let mut a = Agreement::default();
        a.check(&geo.tris, rays, mode, expect, &got, *floor);
        assert_eq!(a.wrong, 0, "{what} {}: {a:?}", p.name());
        eprintln!("{what} {}: {a:?}", p.name());
    }
}
