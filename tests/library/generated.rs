//! The generated scenes (`hairball`, `city`, `nested` at a few thousand triangles): every
//! rayspace engine returns brute force's hits bit for bit on primary, shadow,
//! ambient-occlusion and random rays, and the peers agree within
//! `accel::oracle::Agreement`'s rule (`roster`).

use accel::BruteForce;
use render::raygen::{generate, Kind, Options};
use scene::{load, Geometry, LoadOptions};
use trace::{Hit, TraceMode, TraceStats, Tracer};

#[test]
fn engines_match_brute_force_on_generated_scenes() {
    for spec in ["hairball:4k:2", "city:4k:3", "nested:6k"] {
        let s = load(spec, &LoadOptions::default()).unwrap();
        let geo = Geometry::from_scene(&s);
        let (ours, peers) = (crate::roster::ours(&geo), crate::roster::peers(&geo));
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
            let what = format!("{spec} {name}");
            crate::roster::check(&geo, &ours, &peers, &rays, mode, &expect, &what);
        }
    }
}
