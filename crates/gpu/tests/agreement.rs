//! The GPU backend against its oracles: on every built-in scene's recorded Whitted batches,
//! for CRSH and RAH in several configurations, the GPU engine returns the CPU engine's hit
//! records bit for bit (and so brute force's) and the same counters: intersection tests and
//! passes per level and ray kind, final tests, mesh-sphere tests, chunks, triangle batches,
//! budget splits, top nodes.
//!
//! Bit-identical counters need a device whose f32 +, −, ×, ÷ and sqrt round to nearest and
//! are not fused (lavapipe: checked by `arithmetic_is_ieee_unfused`); on other devices only
//! the hit records are required to match. Without any adapter every test prints why and
//! passes (CI installs lavapipe, so there they run).

use accel::oracle::record_render;
use gpu::{Gpu, GpuRsh};
use render::{Hit, RayBatch, TraceMode, TraceStats, Tracer};
use rsh::{NodeTest, RshConfig, RshEngine, Union};
use scene::{builtin, Geometry};

fn gpu() -> Option<Gpu> {
    testkit::or_skip(Gpu::new(), "gpu")
}

fn lavapipe(g: &Gpu) -> bool {
    g.info.device_type == wgpu::DeviceType::Cpu
}

use gpu::rsh::engine::comparable_counters as counters;

fn compare(
    cpu: &RshEngine,
    gpu: &GpuRsh,
    rays: &RayBatch,
    mode: TraceMode,
    expect: &[Hit],
    exact_counts: bool,
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
    if exact_counts {
        assert_eq!(counters(&sg), counters(&sc), "{what}: counters");
    }
    assert!(sg
        .counters
        .contains_key(render::stats::counter::GPU_KERNEL_LAUNCHES));
}

#[test]
fn builtin_scenes_match_cpu_crsh_and_rah() {
    let Some(g) = gpu() else { return };
    let exact = lavapipe(&g);
    eprintln!("adapter: {} (counters compared: {exact})", g.describe());
    drop(g);
    for name in builtin::NAMES {
        let s = builtin::by_name(name).unwrap();
        let geo = Geometry::from_scene(&s);
        let batches = record_render(&s, &geo, 48, 40, 2);
        let configs = [
            RshConfig::crsh(),
            RshConfig::rah(),
            RshConfig {
                branching: 16,
                levels: 3,
                ..RshConfig::crsh()
            },
            RshConfig {
                branching: 4,
                levels: 0,
                union: Union::Thesis,
                node_test: NodeTest::Exact,
                ..RshConfig::crsh()
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
                compare(&cpu, &gpu, rays, *mode, hits, exact, &what);
            }
        }
    }
}

#[test]
fn tiny_budget_batches_and_splits_match() {
    let Some(g) = gpu() else { return };
    let exact = lavapipe(&g);
    let s = builtin::by_name("cornell").unwrap();
    let geo = Geometry::from_scene(&s);
    let batches = record_render(&s, &geo, 32, 32, 1);
    let cfg = RshConfig {
        pair_budget: 1024,
        levels: 3,
        ..RshConfig::crsh()
    };
    let cpu = RshEngine::new(&geo, cfg.clone()).unwrap();
    let gpu = GpuRsh::new(g, &geo, cfg).unwrap();
    let mut splits = 0;
    for (k, (rays, mode, hits)) in batches.iter().enumerate() {
        compare(
            &cpu,
            &gpu,
            rays,
            *mode,
            hits,
            exact,
            &format!("budget batch {k}"),
        );
        let mut st = TraceStats::default();
        let mut h = vec![Hit::MISS; rays.len()];
        gpu.trace(rays, *mode, &mut h, &mut st);
        splits += st
            .counters
            .get(render::stats::counter::BUDGET_SPLITS)
            .copied()
            .unwrap_or(0);
    }
    assert!(splits > 0, "the tiny budget forced split expansions");
}

#[test]
fn multi_tile_batches_match() {
    // Batches of tens of thousands of rays: many scan blocks and sort tiles.
    let Some(g) = gpu() else { return };
    let exact = lavapipe(&g);
    let s = builtin::by_name("office").unwrap();
    let geo = Geometry::from_scene(&s);
    let batches = record_render(&s, &geo, 192, 144, 1);
    assert!(batches.iter().any(|b| b.0.len() > 20_000));
    for cfg in [RshConfig::crsh(), RshConfig::rah()] {
        let cpu = RshEngine::new(&geo, cfg.clone()).unwrap();
        let gpu = GpuRsh::new(Gpu::new().unwrap(), &geo, cfg.clone()).unwrap();
        for (k, (rays, mode, hits)) in batches.iter().enumerate() {
            let what = format!("office 192x144 {:?} batch {k}", cfg.method);
            compare(&cpu, &gpu, rays, *mode, hits, exact, &what);
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
        ..RshConfig::crsh()
    };
    let err = GpuRsh::new(Gpu::new().unwrap(), &geo, too_big.clone());
    assert!(err.is_ok(), "a real device allows 4 MiB bindings");
    let err = GpuRsh::new(g, &geo, too_big).err().expect("refused");
    assert!(err.to_string().contains("--pair-budget"), "{err}");
    let Some(mut g) = gpu() else { return };
    g.limits.max_storage_buffer_binding_size = 1 << 17;
    let cfg = RshConfig {
        pair_budget: 4096,
        levels: 1,
        ..RshConfig::crsh()
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
