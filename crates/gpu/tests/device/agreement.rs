//! The GPU backend against its oracles: on every built-in scene's recorded Whitted batches,
//! for CRSH and RAH in several configurations, the GPU engine returns the CPU engine's hit
//! records bit for bit (and so brute force's) and the same counters: intersection tests and
//! passes per level and ray kind, final tests, mesh-sphere tests, chunks, triangle batches,
//! budget splits, top nodes.
//!
//! The kernels compute the CPU's bits on any Vulkan device: products that feed sums are kept
//! unfused, ÷ and sqrt are correctly rounded through f64, and sums that a constant multiplies
//! are kept from being distributed (`shaders/common.wgsl`); checked on lavapipe in CI and on an
//! NVIDIA H100 (`bench/results/`). Without any adapter every test prints why and passes
//! locally (CI installs lavapipe and requires the GPU, so there they run).

use gpu::{Gpu, GpuRsh};
use rsh::{NodeTest, RshConfig, RshEngine, Union};
use scene::{builtin, Geometry};
use testkit::record_render;
use trace::{Hit, RayBatch, TraceMode, TraceStats, Tracer};

fn gpu() -> Option<Gpu> {
    testkit::or_skip(Gpu::new(), "gpu")
}

use gpu::rsh::engine::comparable_counters as counters;

fn compare(
    cpu: &RshEngine,
    gpu: &GpuRsh,
    rays: &RayBatch,
    mode: TraceMode,
    expect: &[Hit],
    what: &str,
) {
    let (mut hc, mut hg) = (vec![Hit::MISS; rays.len()], vec![Hit::MISS; rays.len()]);
    let (mut sc, mut sg) = (TraceStats::default(), TraceStats::default());
    cpu.trace(rays, mode, &mut hc, &mut sc);
    gpu.trace(rays, mode, &mut hg, &mut sg);
    for i in 0..rays.len() {
        assert_eq!(hg[i], hc[i], "{what}: ray {i} GPU vs CPU");
        if mode == TraceMode::Closest {
            assert_eq!(hg[i], expect[i], "{what}: ray {i} GPU vs brute force");
        } else {
            assert_eq!(
                hg[i].is_hit(),
                expect[i].is_hit(),
                "{what}: ray {i} any hit"
            );
        }
    }
    assert_eq!(counters(&sg), counters(&sc), "{what}: counters");
    assert!(sg.counters.contains(gpu::stats::KERNEL_LAUNCHES));
}

#[test]
fn builtin_scenes_match_cpu_crsh_and_rah() {
    let Some(g) = gpu() else { return };
    eprintln!("adapter: {}", g.describe());
    drop(g);
    for name in builtin::NAMES {
        let s = builtin::by_name(name).unwrap();
        let geo = Geometry::from_scene(&s);
        let batches = record_render(&s, &geo, 48, 40, 2);
        let configs = [
            crate::common::crsh_spheres(),
            crate::common::rah_spheres(),
            RshConfig {
                branching: 16,
                levels: 3,
                ..crate::common::crsh_spheres()
            },
            RshConfig {
                branching: 4,
                levels: 0,
                union: Union::Thesis,
                node_test: NodeTest::Exact,
                ..crate::common::crsh_spheres()
            },
        ];
        for cfg in configs {
            let cpu = RshEngine::new(&geo, cfg.clone()).unwrap();
            let gpu = GpuRsh::new(Gpu::new().unwrap(), &geo, cfg.clone()).unwrap();
            for (k, (rays, mode, hits)) in batches.iter().enumerate() {
                let what = format!(
                    "{name} {:?} {}/{} {:?} {:?} batch {k}",
                    cfg.method, cfg.branching, cfg.levels, cfg.union, cfg.node_test
                );
                compare(&cpu, &gpu, rays, *mode, hits, &what);
            }
        }
    }
}

#[test]
fn tiny_budget_batches_and_splits_match() {
    let Some(g) = gpu() else { return };
    let s = builtin::by_name("cornell").unwrap();
    let geo = Geometry::from_scene(&s);
    let batches = record_render(&s, &geo, 32, 32, 1);
    let cfg = RshConfig {
        pair_budget: 1024,
        levels: 3,
        ..crate::common::crsh_spheres()
    };
    let cpu = RshEngine::new(&geo, cfg.clone()).unwrap();
    let gpu = GpuRsh::new(g, &geo, cfg).unwrap();
    let mut splits = 0;
    for (k, (rays, mode, hits)) in batches.iter().enumerate() {
        compare(&cpu, &gpu, rays, *mode, hits, &format!("budget batch {k}"));
        let mut st = TraceStats::default();
        let mut h = vec![Hit::MISS; rays.len()];
        gpu.trace(rays, *mode, &mut h, &mut st);
        splits += st.counters.get(::rsh::stats::BUDGET_SPLITS).unwrap_or(0);
    }
    assert!(splits > 0, "the tiny budget forced split expansions");
}

#[test]
fn multi_tile_batches_match() {
    // Batches of tens of thousands of rays: many scan blocks and sort tiles.
    let Some(g) = gpu() else { return };
    let s = builtin::by_name("office").unwrap();
    let geo = Geometry::from_scene(&s);
    let batches = record_render(&s, &geo, 192, 144, 1);
    assert!(batches.iter().any(|b| b.0.len() > 20_000));
    for cfg in [crate::common::crsh_spheres(), crate::common::rah_spheres()] {
        let cpu = RshEngine::new(&geo, cfg.clone()).unwrap();
        let gpu = GpuRsh::new(Gpu::new().unwrap(), &geo, cfg.clone()).unwrap();
        for (k, (rays, mode, hits)) in batches.iter().enumerate() {
            let what = format!("office 192x144 {:?} batch {k}", cfg.method);
            compare(&cpu, &gpu, rays, *mode, hits, &what);
        }
    }
    drop(g);
}

#[test]
fn small_bindings_split_the_work_and_keep_the_hits() {
    // A device that allows only 128 KiB per binding: batches are traced in parts of 8192
    // rays, the node × mesh culling runs in node ranges, the top-level candidate kernels take
    // more triangles per thread, and a pair budget above the binding is refused. The parts
    // build their own hierarchies, so only the hits are compared (with brute force).
    let Some(mut g) = gpu() else { return };
    g.limits.max_storage_buffer_binding_size = 1 << 17;
    let s = builtin::by_name("office").unwrap();
    let geo = Geometry::from_scene(&s);
    let too_big = RshConfig {
        pair_budget: 1 << 20,
        ..crate::common::crsh_spheres()
    };
    let err = GpuRsh::new(Gpu::new().unwrap(), &geo, too_big.clone());
    assert!(err.is_ok(), "a real device allows 4 MiB bindings");
    let err = GpuRsh::new(g, &geo, too_big).err().expect("refused");
    assert!(err.to_string().contains("`pair_budget`=1048576"), "{err}");
    let Some(mut g) = gpu() else { return };
    g.limits.max_storage_buffer_binding_size = 1 << 17;
    let cfg = RshConfig {
        pair_budget: 4096,
        levels: 1,
        ..crate::common::crsh_spheres()
    };
    let gpu = GpuRsh::new(g, &geo, cfg).unwrap();
    let batches = record_render(&s, &geo, 128, 96, 1);
    assert!(batches.iter().any(|b| b.0.len() > 8192));
    for (k, (rays, mode, hits)) in batches.iter().enumerate() {
        let mut got = vec![Hit::MISS; rays.len()];
        gpu.trace(rays, *mode, &mut got, &mut TraceStats::default());
        for i in 0..rays.len() {
            if *mode == TraceMode::Closest {
                assert_eq!(got[i], hits[i], "batch {k} ray {i}");
            } else {
                assert_eq!(got[i].is_hit(), hits[i].is_hit(), "batch {k} ray {i}");
            }
        }
    }
}

/// The hash pass alone, on every device: 2^20 random rays of all kinds (directions of every
/// octant, some along an axis or with a zero component) get the CPU's keys and validity
/// flags. A key off by one quantisation step changes the chunks and hence every count after
/// it, so this pins such a disagreement to the pass and the ray.
#[test]
fn hash_keys_match_the_cpu_on_random_rays() {
    let Some(g) = gpu() else { return };
    let s = builtin::by_name("office").unwrap();
    let geo = Geometry::from_scene(&s);
    let cfg = crate::common::crsh_spheres();
    let bits = cfg.hash_bits;
    let gpu = GpuRsh::new(g, &geo, cfg).unwrap();
    let mut rng = geom::Pcg32::new(20261128, 7);
    let mut rays = RayBatch::with_capacity(1 << 20);
    let b = geo.bounds;
    for i in 0..1u32 << 20 {
        let mut c = || 2.0 * rng.next_f32() - 1.0;
        let mut d = geom::Vec3::new(c(), c(), c());
        // Every 16th ray loses a component: axis-aligned and planar directions.
        if i % 16 == 0 {
            d[(i / 16 % 3) as usize] = 0.0;
        }
        let d = d.normalize_or(geom::Vec3::Y);
        let u = geom::Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
        let o = b.min + u * (b.max - b.min) * 1.2 - (b.max - b.min) * 0.1;
        let kind = [
            trace::RayKind::Primary,
            trace::RayKind::Shadow,
            trace::RayKind::Reflection,
            trace::RayKind::Refraction,
        ][(i % 4) as usize];
        let t_max = if i % 97 == 0 { 0.0 } else { 10.0 };
        let ray = geom::Ray::new(o, d, 1e-4, t_max);
        rays.push(ray, kind, i, i % 5, geom::Vec3::ONE, 0);
    }
    let (keys, valid) = gpu.hash_keys(&rays, false);
    let mut wrong = Vec::new();
    for i in 0..rays.len() {
        let cpu = rsh::hash::thesis_key(&rays, i, &geo.bounds, &bits);
        let ok = (rays.t_min[i] < rays.t_max[i]) as u32;
        if keys[i] != cpu || valid[i] != ok {
            let (t, p) = rsh::hash::spherical01(rays.dir[i]);
            wrong.push(format!(
                "ray {i}: key {:#010x} (CPU {cpu:#010x}), valid {} ({ok}), dir {:?} bits {:08x?}, θ {t:e} φ {p:e}",
                keys[i],
                valid[i],
                rays.dir[i],
                rays.dir[i].to_array().map(f32::to_bits)
            ));
        }
    }
    assert!(
        wrong.is_empty(),
        "{} of {} keys differ; first: {:#?}",
        wrong.len(),
        rays.len(),
        &wrong[..wrong.len().min(8)]
    );
}

/// The ordering and build passes alone, node for node: on every built-in scene's recorded
/// batches, for CRSH and RAH, the GPU's leaf order and every level's spheres, cones and
/// their sines and cosines carry the CPU's bits. A counter that differs (one node–triangle
/// test more) is pinned here to the node, with its children's values to replay on the CPU.
/// Known open (2026-11-28): on an NVIDIA H100 one leaf sphere of cornell's second CRSH 8/2
/// batch (a minimal ball over 8 origins on two perpendicular walls) lands one f32 ulp away
/// in centre x and radius, with no effect on any counter; lavapipe matches everywhere.
#[test]
fn hierarchies_match_the_cpu_node_for_node() {
    if gpu().is_none() {
        return;
    }
    let bits = |v: [f32; 4]| v.map(f32::to_bits);
    for name in builtin::NAMES {
        let s = builtin::by_name(name).unwrap();
        let geo = Geometry::from_scene(&s);
        let batches = record_render(&s, &geo, 192, 144, 2);
        for (b, d) in [(8, 2), (16, 3)] {
            for base in [crate::common::crsh_spheres(), crate::common::rah_spheres()] {
                let cfg = RshConfig {
                    branching: b,
                    levels: d,
                    ..base
                };
                let gpu = GpuRsh::new(gpu().unwrap(), &geo, cfg.clone()).unwrap();
                for (k, (rays, _, _)) in batches.iter().enumerate() {
                    let what = format!("{name} {:?} {b}/{d} batch {k}", cfg.method);
                    let grouping = match cfg.method {
                        rsh::Method::Crsh => rsh::order::Grouping::Hash(cfg.hash),
                        rsh::Method::Rah => rsh::order::Grouping::Screen,
                    };
                    let order = rsh::order::leaf_order(
                        rays,
                        grouping,
                        &geo.bounds,
                        &cfg.hash_bits,
                        &mut TraceStats::default(),
                    );
                    let h = rsh::build::build(rays, order, b as usize, d, cfg.union);
                    let (gorder, glevels) = gpu.hierarchy(rays);
                    assert_eq!(gorder, h.order, "{what}: leaf order");
                    assert_eq!(glevels.len(), h.levels.len(), "{what}: levels");
                    for (l, (cl, [gs, gc, gsc])) in h.levels.iter().zip(&glevels).enumerate() {
                        for i in 0..cl.len() {
                            let c = cl.sphere(i);
                            let k = cl.cone(i);
                            let cpu = [
                                [c.center.x, c.center.y, c.center.z, c.radius],
                                [k.axis.x, k.axis.y, k.axis.z, k.angle],
                            ];
                            let cpu_sc = [cl.sin[i], cl.cos[i], cl.max_t[i]];
                            let gpu_sc = [gsc[i][0], gsc[i][1], gsc[i][2]];
                            if bits(cpu[0]) == bits(gs[i])
                                && bits(cpu[1]) == bits(gc[i])
                                && cpu_sc.map(f32::to_bits) == gpu_sc.map(f32::to_bits)
                            {
                                continue;
                            }
                            // The children's values, as bits, to replay the node on the CPU.
                            let children: Vec<String> = cl
                                .children(i)
                                .map(|j| {
                                    if l == 0 {
                                        let r = h.order[j] as usize;
                                        format!(
                                            "ray {r}: org {:08x?} dir {:08x?}",
                                            rays.org[r].to_array().map(f32::to_bits),
                                            rays.dir[r].to_array().map(f32::to_bits)
                                        )
                                    } else {
                                        let lo = &h.levels[l - 1];
                                        let (c, k) = (lo.sphere(j), lo.cone(j));
                                        format!(
                                            "node {j}: sphere {:08x?} cone {:08x?}",
                                            bits([c.center.x, c.center.y, c.center.z, c.radius]),
                                            bits([k.axis.x, k.axis.y, k.axis.z, k.angle])
                                        )
                                    }
                                })
                                .collect();
                            panic!(
                                "{what}: level {} node {i}: CPU sphere {:?} cone {:?} sc {:?}, GPU sphere {:?} cone {:?} sc {:?}; children {children:#?}",
                                l + 1,
                                cpu[0],
                                cpu[1],
                                cpu_sc,
                                gs[i],
                                gc[i],
                                gpu_sc
                            );
                        }
                    }
                }
            }
        }
    }
}
