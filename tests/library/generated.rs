//! The generated scenes (`hairball`, `city`, `nested` at a few thousand triangles): every
//! rayspace engine returns brute force's hits bit for bit on primary, shadow and
//! ambient-occlusion rays, and the peers agree within `accel::oracle::Agreement`'s rule.

use accel::oracle::{assert_same_hits, Agreement};
use accel::peers::{BvhKind, ObvhsEngine};
use accel::BruteForce;
use render::raygen::{generate, Kind, Options};
use scene::{load, Geometry, LoadOptions};
use trace::{Hit, TraceMode, TraceStats, Tracer};

#[test]
fn engines_match_brute_force_on_generated_scenes() {
    for spec in ["hairball:4k:2", "city:4k:3", "nested:6k"] {
        let s = load(spec, &LoadOptions::default()).unwrap();
        let geo = Geometry::from_scene(&s);
        let mut ours: Vec<Box<dyn Tracer>> = vec![
            Box::new(accel::GridEngine::new(&geo, &accel::GridConfig::default()).unwrap()),
            Box::new(accel::GridEngine::new(&geo, &accel::GridConfig::two_level()).unwrap()),
        ];
        for cfg in [rsh::RshConfig::crsh(), rsh::RshConfig::rah()] {
            ours.push(Box::new(rsh::RshEngine::new(&geo, cfg).unwrap()));
        }
        let peers: Vec<(Box<dyn Tracer>, f32)> = vec![
            (Box::new(ObvhsEngine::new(&geo, BvhKind::Bvh2)), 0.0),
            (Box::new(ObvhsEngine::new(&geo, BvhKind::CwBvh)), 1e-4),
        ];
        let opts = Options {
            width: 40,
            height: 30,
            spp: 1,
            seed: 3,
            ao_distance: None,
        };
        for (kind, name, mode) in [
            (Kind::Primary, "primary", TraceMode::Closest),
            (Kind::Shadow, "shadow", TraceMode::Any),
            (Kind::Ao, "ao", TraceMode::Closest),
            (Kind::Random, "random", TraceMode::Closest),
        ] {
            let rays = generate(&s, &geo, kind, &opts);
            assert!(!rays.is_empty(), "{spec} {name}: rays");
            let mut expect = vec![Hit::MISS; rays.len()];
            BruteForce::new(&geo).trace(&rays, mode, &mut expect, &mut TraceStats::default());
            let hits = expect.iter().filter(|h| h.is_hit()).count();
            // (Nothing shadows the nested bowls, open to the light above.)
            assert!(
                hits > 0 || kind != Kind::Primary,
                "{spec} {name}: something is hit"
            );
            for e in &ours {
                let what = format!("{spec} {name} {}", e.name());
                assert_same_hits(e.as_ref(), &rays, mode, &expect, &what);
            }
            for (p, floor) in &peers {
                let mut got = vec![Hit::MISS; rays.len()];
                p.trace(&rays, mode, &mut got, &mut TraceStats::default());
                let mut a = Agreement::default();
                a.check(&geo.tris, &rays, mode, &expect, &got, *floor);
                assert_eq!(a.wrong, 0, "{spec} {name} {}: {a:?}", p.name());
            }
        }
    }
}
