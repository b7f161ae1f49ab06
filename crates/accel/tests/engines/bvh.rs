//! The `bvh` engine (`accel::bvh`): its walks return exactly brute force's hits on every
//! built-in scene's Whitted batches and on random scenes and rays, over both builders'
//! trees; the AVX2 and AVX-512 builds give the scalar build's bits and counts; a batch goes
//! as packets or single rays as its locality says, and the stats say which.

use accel::bvh::single::Isa;
use accel::bvh::{BvhConfig, BvhEngine, ObjectBuilder, RayPath};
use accel::oracle::assert_same_hits;
use accel::BruteForce;
use geom::{Ray, Vec3};
use proptest::prelude::*;
use scene::{builtin, Geometry};
use testkit::record_render;
use testkit::soup_case as random_case;
use trace::{Hit, RayBatch, RayKind, TraceMode, TraceStats, Tracer};

/// Every configuration of the engine.
fn configs() -> Vec<BvhConfig> {
    let mut v = Vec::new();
    for builder in [ObjectBuilder::Sah, ObjectBuilder::Lbvh] {
        for path in [RayPath::Packets, RayPath::Single] {
            v.push(BvhConfig { builder, path });
        }
    }
    v
}

/// The engine in every configuration on every built-in scene's Whitted batches.
#[test]
fn builtin_scenes_match_brute_force() {
    for name in builtin::NAMES {
        let s = builtin::by_name(name).unwrap();
        let geo = Geometry::from_scene(&s);
        let batches = record_render(&s, &geo, 40, 30, 2);
        for cfg in configs() {
            let e = BvhEngine::new(&geo, cfg.clone()).unwrap();
            for (k, (rays, mode, hits)) in batches.iter().enumerate() {
                assert_same_hits(&e, rays, *mode, hits, &format!("{name} {cfg:?} batch {k}"));
            }
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Random triangle soups and rays, directions of any length (ray files may hold any).
    #[test]
    fn random_scenes_match_brute_force(seed in 0u64..1_000_000, ntri in 1usize..400, nray in 1usize..1500, scale_pow in -6i32..7, any_hit in any::<bool>(), c in 0usize..4) {
        let (geo, mut rays) = random_case(seed, ntri, nray);
        let s = 2f32.powi(scale_pow);
        for i in 0..rays.len() {
            rays.dir[i] *= s;
            rays.t_min[i] /= s;
            rays.t_max[i] /= s;
        }
        let mode = if any_hit { TraceMode::Any } else { TraceMode::Closest };
        let mut expect = vec![Hit::MISS; rays.len()];
        BruteForce::new(&geo).trace(&rays, mode, &mut expect, &mut TraceStats::default());
        let e = BvhEngine::new(&geo, configs()[c].clone()).unwrap();
        assert_same_hits(&e, &rays, mode, &expect, "random");
    }
}

/// The walks, single rays (`bvh::single`) and packets (`bvh::packet`), on every built-in scene's Whitted batches and on random rays, over both
/// builders' trees: brute force's hits (closest hit bit for bit, the kernel's own records for
/// any hit too), and the AVX2 and AVX-512 builds give the scalar build's hits and counts
/// exactly.
#[test]
fn single_rays_and_packets_match_brute_force_and_the_scalar_path() {
    type Batches = Vec<(RayBatch, TraceMode, Vec<Hit>)>;
    let mut cases: Vec<(String, Geometry, Batches)> = Vec::new();
    for name in builtin::NAMES {
        let s = builtin::by_name(name).unwrap();
        let geo = Geometry::from_scene(&s);
        let batches = record_render(&s, &geo, 40, 30, 2);
        cases.push((name.to_string(), geo, batches));
    }
    for seed in 0..4u64 {
        let (geo, rays) = random_case(seed, 300 + 200 * seed as usize, 3000);
        let mut batches = Vec::new();
        for mode in [TraceMode::Closest, TraceMode::Any] {
            let mut expect = vec![Hit::MISS; rays.len()];
            BruteForce::new(&geo).trace(&rays, mode, &mut expect, &mut TraceStats::default());
            batches.push((rays.clone(), mode, expect));
        }
        cases.push((format!("soup {seed}"), geo, batches));
    }
    for (name, geo, batches) in &cases {
        for builder in [ObjectBuilder::Lbvh, ObjectBuilder::Sah] {
            let tree = accel::bvh::objects::build(
                &geo.tris,
                &geo.mesh_first,
                None,
                builder,
                accel::bvh::objects::Parts::ALL,
            );
            for (j, (rays, mode, expect), packets) in batches
                .iter()
                .enumerate()
                .flat_map(|(j, b)| [(j, b, false), (j, b, true)])
            {
                let walk = if packets { "packets" } else { "single" };
                let what = format!("{name} {builder:?} batch {j} {mode:?} {walk}");
                let run = |isa| {
                    let mut got = vec![Hit::MISS; rays.len()];
                    let f = if packets {
                        accel::bvh::packet::trace
                    } else {
                        accel::bvh::single::trace
                    };
                    let c = f(&tree, &geo.tris, rays, *mode, &mut got, isa);
                    (got, c)
                };
                let (scalar, sc) = run(Isa::Scalar);
                for isa in [Isa::Avx2, Isa::Avx512] {
                    if !isa.available() {
                        let need = if isa == Isa::Avx2 { "avx2" } else { "avx512" };
                        testkit::skip(need, format!("{what}: this CPU lacks {isa:?}"));
                        continue;
                    }
                    let (lanes, lc) = run(isa);
                    assert_eq!(lc, sc, "{what}: {isa:?} counts");
                    assert!(
                        lanes == scalar,
                        "{what}: {isa:?} hits against the scalar path's"
                    );
                }
                for (i, (l, e)) in scalar.iter().zip(expect).enumerate() {
                    match mode {
                        TraceMode::Closest => assert_eq!(l, e, "{what}: ray {i}"),
                        TraceMode::Any => assert_eq!(l.is_hit(), e.is_hit(), "{what}: ray {i}"),
                    }
                    if l.is_hit() {
                        let [a, b, c] = geo.tris[l.tri as usize];
                        let k = geom::intersect(&geom::tri::RayPre::new(&rays.ray(i)), a, b, c)
                            .expect("a recorded hit repeats");
                        assert_eq!((l.t, l.u, l.v), (k.t, k.u, k.v), "{what}: ray {i} record");
                    }
                }
                assert_eq!(sc.hits, scalar.iter().filter(|h| h.is_hit()).count() as u64);
            }
        }
    }
}

/// `RayPath::Packets` sends a batch of neighbouring rays (a view's primary rays) as packets
/// and rays scattered at random through the scene as single rays, `RayPath::Single` every
/// batch as single rays; the counters say which, there is no ray hierarchy in the stats,
/// and the hits are brute force's either way.
#[test]
fn packets_follow_the_batch_locality() {
    let s = builtin::office(7);
    let geo = Geometry::from_scene(&s);
    let batches = record_render(&s, &geo, 64, 48, 0);
    let (primary, pmode, pexpect) = batches[0].clone();
    // Rays from anywhere in the scene's box, in any direction, unbounded.
    let mut rng = geom::Pcg32::new(3, 11);
    let b = geo.bounds;
    let mut random = RayBatch::default();
    for i in 0..4000u32 {
        let mut f = || rng.next_f32();
        let o = b.min + (b.max - b.min) * Vec3::new(f(), f(), f());
        let d = Vec3::new(f() - 0.5, f() - 0.5, f() - 0.5).normalize_or(Vec3::Y);
        let r = Ray::new(o, d, 0.0, f32::INFINITY);
        random.push(r, RayKind::Reflection, i, 0, Vec3::ONE, 0);
    }
    let mut rexpect = vec![Hit::MISS; random.len()];
    BruteForce::new(&geo).trace(
        &random,
        TraceMode::Closest,
        &mut rexpect,
        &mut TraceStats::default(),
    );
    let diag = geo.bounds.extent().length();
    assert!(accel::bvh::locality(&primary, diag) >= accel::bvh::COHERENT_SHARE);
    assert!(accel::bvh::locality(&random, diag) < accel::bvh::COHERENT_SHARE);
    for (path, (rays, mode, expect, local)) in [RayPath::Packets, RayPath::Single]
        .into_iter()
        .flat_map(|p| {
            [
                (p, (&primary, pmode, &pexpect, 1)),
                (p, (&random, TraceMode::Closest, &rexpect, 0)),
            ]
        })
    {
        let cfg = BvhConfig {
            path,
            ..BvhConfig::default()
        };
        let e = BvhEngine::new(&geo, cfg).unwrap();
        let mut st = TraceStats::default();
        let mut got = vec![Hit::MISS; rays.len()];
        e.trace(rays, mode, &mut got, &mut st);
        for (g, x) in got.iter().zip(expect.iter()) {
            match mode {
                TraceMode::Closest => assert_eq!(g, x),
                TraceMode::Any => assert_eq!(g.is_hit(), x.is_hit()),
            }
        }
        let count = |c| st.counters.get(c).unwrap_or(0);
        let packets = if path == RayPath::Packets { local } else { 0 };
        assert_eq!(count(accel::bvh::PACKET_BATCHES), packets, "{path:?}");
        assert_eq!(
            count(accel::bvh::SINGLE_RAY_BATCHES),
            1 - packets,
            "{path:?}"
        );
        assert!(st.levels.is_empty(), "no ray hierarchy: {:?}", st.levels);
        assert_eq!(st.node_tri_tests, 0, "no ray hierarchy");
        assert!(count(trace::RAY_BOX_TESTS) > 0);
    }
}
