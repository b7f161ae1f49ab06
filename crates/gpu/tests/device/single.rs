//! The `bvh` engine's single rays on the device (`gpu::bvh::single`, over the object tree
//! built on the device) against the CPU engine with the same configuration (`-e bvh
//! --ray-path single --object-builder lbvh`): hit records bit for bit (so brute force's for
//! closest hits) and every counter (ray-triangle tests, ray-box tests and passes, hits),
//! in both trace modes, on every built-in scene's recorded Whitted batches and on Sponza;
//! and with a private stack too small for the walks, the rays that overflow it are walked
//! again by the second pass (its stack in storage memory) with the same result.

use accel::BvhEngine;
use gpu::{Gpu, GpuBvh};
use scene::{builtin, Geometry};
use testkit::record_render;
use trace::{Hit, RayBatch, TraceMode, TraceStats, Tracer};

fn gpu() -> Option<Gpu> {
    testkit::or_skip(Gpu::new(), "gpu")
}

/// Traces `rays` on both (records and counters equal); returns the GPU's stack overflows.
fn compare(cpu: &BvhEngine, gpu: &GpuBvh, rays: &RayBatch, mode: TraceMode, what: &str) -> u64 {
    let (sc, sg) = crate::common::compare_traces(cpu, gpu, rays, mode, what);
    assert!(
        sc.counters.get(trace::RAY_BOX_TESTS).unwrap_or(0) > 0 || rays.is_empty(),
        "{what}: walked"
    );
    sg.counters.get(gpu::stats::STACK_OVERFLOWS).unwrap_or(0)
}

#[test]
fn single_rays_match_the_cpu_on_builtin_scenes() {
    let Some(g) = gpu() else { return };
    for name in builtin::NAMES {
        let s = builtin::by_name(name).unwrap();
        let geo = Geometry::from_scene(&s);
        let batches = record_render(&s, &geo, 48, 40, 2);
        let cpu = BvhEngine::new(&geo, crate::common::bvh_single()).unwrap();
        let dev = GpuBvh::new(g.clone(), &geo, crate::common::bvh_single()).unwrap();
        assert_eq!(dev.build_passes().len(), 1, "the tree's build is a pass");
        for (k, (rays, mode, expect)) in batches.iter().enumerate() {
            for m in [*mode, TraceMode::Closest, TraceMode::Any] {
                compare(&cpu, &dev, rays, m, &format!("{name} batch {k}"));
            }
            // Closest hits are brute force's.
            if *mode == TraceMode::Closest {
                let mut h = vec![Hit::MISS; rays.len()];
                dev.trace(rays, *mode, &mut h, &mut TraceStats::default());
                assert_eq!(&h, expect, "{name} batch {k}: brute force");
            }
        }
    }
}

#[test]
fn overflowing_walks_are_finished_by_the_second_pass() {
    let Some(g) = gpu() else { return };
    let s = builtin::by_name("office").unwrap();
    let geo = Geometry::from_scene(&s);
    let batches = record_render(&s, &geo, 64, 48, 1);
    let cpu = BvhEngine::new(&geo, crate::common::bvh_single()).unwrap();
    let dev = GpuBvh::new(g, &geo, crate::common::bvh_single())
        .unwrap()
        .with_stack(2);
    let mut over = 0;
    for (k, (rays, mode, _)) in batches.iter().enumerate() {
        over += compare(
            &cpu,
            &dev,
            rays,
            *mode,
            &format!("office batch {k}, stack 2"),
        );
    }
    assert!(over > 0, "a stack of 2 overflows");
}

#[test]
fn single_rays_match_the_cpu_on_sponza() {
    let Some(s) = crate::common::sponza() else {
        return;
    };
    let Some(g) = gpu() else { return };
    let geo = Geometry::from_scene(&s);
    let batches = record_render(&s, &geo, 64, 48, 1);
    let cpu = BvhEngine::new(&geo, crate::common::bvh_single()).unwrap();
    let dev = GpuBvh::new(g, &geo, crate::common::bvh_single()).unwrap();
    let mut over = 0;
    for (k, (rays, mode, _)) in batches.iter().enumerate() {
        over += compare(&cpu, &dev, rays, *mode, &format!("sponza batch {k}"));
    }
    assert_eq!(over, 0, "Sponza's walks fit the device stack");
}
