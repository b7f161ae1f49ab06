//! The dual traversal on the device (`gpu::rsh::dual`: the ray hierarchy's bundles and the
//! object tree built on the device, level by level) against the CPU engine with the same
//! configuration (`--object-hierarchy bvh --ray-path bundles --schedule breadth
//! --object-builder lbvh`): hit records bit for bit (so brute force's for closest hits) and
//! every counter (tests and passes per level and kind, object-node tests, final tests, the
//! single rays' slab tests and passes, the peak of waiting pairs), in both trace modes, for
//! CRSH and RAH, every descent rule, a pair budget small enough to cut every level into many
//! steps, on every built-in scene's recorded Whitted batches and on Sponza.

use gpu::{Gpu, GpuRsh};
use rsh::{Descent, RshConfig, RshEngine};
use scene::{builtin, Geometry, Scene};
use testkit::record_render;
use trace::{Hit, RayBatch, TraceMode, TraceStats, Tracer};

fn gpu() -> Option<Gpu> {
    testkit::or_skip(Gpu::new(), "gpu")
}

/// Traces `rays` on both and compares records and counters; the pairs met inner object nodes
/// and no walk overflowed.
fn compare(cpu: &RshEngine, gpu: &GpuRsh, rays: &RayBatch, mode: TraceMode, what: &str) {
    let (sc, sg) = crate::common::compare_traces(cpu, gpu, rays, mode, what);
    assert_eq!(
        sg.counters.get(gpu::stats::STACK_OVERFLOWS),
        Some(0),
        "{what}"
    );
    assert!(
        rays.is_empty()
            || sc
                .counters
                .get(::rsh::stats::OBJECT_NODE_TESTS)
                .unwrap_or(0)
                > 0,
        "{what}: the pairs met inner object nodes"
    );
}

/// Every batch of `scene` at `w`×`h` (`bounces`) in both modes, each configuration of
/// `cfgs` on both backends; closest hits also against brute force.
fn check_scene(g: &Gpu, name: &str, s: &Scene, size: (u32, u32), bounces: u32, cfgs: &[RshConfig]) {
    check_scene_with(g, name, s, size, bounces, cfgs, |e| e);
}

/// [`check_scene`] with the GPU engine as `tune` makes it.
fn check_scene_with(
    g: &Gpu,
    name: &str,
    s: &Scene,
    size: (u32, u32),
    bounces: u32,
    cfgs: &[RshConfig],
    tune: impl Fn(GpuRsh) -> GpuRsh,
) {
    let geo = Geometry::from_scene(s);
    let batches = record_render(s, &geo, size.0, size.1, bounces);
    for cfg in cfgs {
        let cpu = RshEngine::new(&geo, cfg.clone()).unwrap();
        let dev = tune(GpuRsh::new(g.clone(), &geo, cfg.clone()).unwrap());
        let what = |k: usize| {
            format!(
                "{name} batch {k}, {:?} {:?} budget {}",
                cfg.method, cfg.descent, cfg.pair_budget
            )
        };
        for (k, (rays, mode, expect)) in batches.iter().enumerate() {
            for m in [TraceMode::Closest, TraceMode::Any] {
                compare(&cpu, &dev, rays, m, &what(k));
            }
            if *mode == TraceMode::Closest {
                let mut h = vec![Hit::MISS; rays.len()];
                dev.trace(rays, *mode, &mut h, &mut TraceStats::default());
                assert_eq!(&h, expect, "{}: brute force", what(k));
            }
        }
    }
}

#[test]
fn dual_traversal_matches_the_cpu_on_builtin_scenes() {
    let Some(g) = gpu() else { return };
    let base = crate::common::crsh_dual();
    let mut cfgs = vec![base.clone(), crate::common::rah_dual()];
    for descent in [Descent::ObjectFirst, Descent::RayFirst] {
        cfgs.push(RshConfig {
            descent,
            ..base.clone()
        });
    }
    for name in builtin::NAMES {
        let s = builtin::by_name(name).unwrap();
        check_scene(&g, name, &s, (48, 40), 2, &cfgs);
    }
}

#[test]
fn a_small_pair_budget_cuts_the_levels_into_many_steps() {
    let Some(g) = gpu() else { return };
    // Chunks of 128 pairs (the smallest budget): every level takes many steps, and the stacks grow and shrink.
    let cfgs = [
        RshConfig {
            pair_budget: 1024,
            ..crate::common::crsh_dual()
        },
        RshConfig {
            pair_budget: 1024,
            ..crate::common::rah_dual()
        },
    ];
    for name in ["office", "cornell"] {
        let s = builtin::by_name(name).unwrap();
        check_scene(&g, name, &s, (64, 48), 1, &cfgs);
    }
}

#[test]
fn device_rounds_in_many_passes_or_overflowing_equal_the_cpu() {
    // The device's rounds with one or three rounds a pass (many passes: levels left
    // unfinished and resumed), with buffers of 64 pairs (they overflow, and the host's
    // steps trace the batch again), and never (the host's steps alone).
    let Some(g) = gpu() else { return };
    let cfgs = [crate::common::crsh_dual(), crate::common::rah_dual()];
    for (rounds, cap) in [(1, None), (3, None), (12, Some(64)), (12, Some(0))] {
        for name in ["office", "cornell"] {
            let s = builtin::by_name(name).unwrap();
            let what = format!("{name}, {rounds} rounds a pass, cap {cap:?}");
            check_scene_with(&g, &what, &s, (48, 40), 1, &cfgs, |e| {
                e.with_rounds(rounds, cap)
            });
        }
    }
}

#[test]
fn device_rounds_read_back_once_a_trace_where_a_pass_suffices() {
    // A shadow batch of office: the host's steps read each step's sizes back; the device's
    // rounds read the trim's count and one state block.
    let Some(g) = gpu() else { return };
    let s = builtin::by_name("office").unwrap();
    let geo = Geometry::from_scene(&s);
    let batches = record_render(&s, &geo, 64, 48, 0);
    let (rays, mode, _) = batches
        .iter()
        .find(|b| !b.0.is_empty() && b.1 == TraceMode::Any)
        .expect("a shadow batch");
    let mut reads = Vec::new();
    for cap in [None, Some(0)] {
        let e = GpuRsh::new(g.clone(), &geo, crate::common::rah_dual())
            .unwrap()
            .with_rounds(12, cap);
        let mut h = vec![Hit::MISS; rays.len()];
        let before = g.read_backs();
        e.trace(rays, *mode, &mut h, &mut TraceStats::default());
        reads.push(g.read_backs() - before);
    }
    // The trim's count, one pass's state, the records with the counters.
    assert_eq!(reads[0], 3, "rounds: {reads:?}");
    assert!(reads[1] > reads[0] + 2, "host steps: {reads:?}");
}

#[test]
fn dual_traversal_matches_the_cpu_on_sponza() {
    let Some(s) = crate::common::sponza() else {
        return;
    };
    let Some(g) = gpu() else { return };
    let cfgs = [crate::common::crsh_dual(), crate::common::rah_dual()];
    check_scene(&g, "sponza", &s, (64, 48), 1, &cfgs);
}

/// At the size the benchmarks trace (Sponza 512², its 257 k shadow rays, any hit), the
/// device's dual traversal makes the CPU's `--schedule breadth` counts exactly, given the
/// same rays. (A GPU *frame* makes its own rays: its rasterizer and ray creation are the
/// device's, and a few of Sponza's 257 k shadow rays start a rounding away from the CPU
/// frame's, so a frame's counts may differ by a few hundred tests in six million while the
/// traversal's do not.)
#[test]
fn dual_traversal_counts_equal_the_cpu_on_sponza_512_shadows() {
    let Some(s) = crate::common::sponza() else {
        return;
    };
    let Some(g) = gpu() else { return };
    let geo = Geometry::from_scene(&s);
    let opts = render::raygen::Options {
        width: 512,
        height: 512,
        spp: 1,
        seed: 1,
        ao_distance: None,
    };
    let rays = render::raygen::generate(&s, &geo, render::raygen::Kind::Shadow, &opts);
    assert!(rays.len() > 250_000, "{} rays", rays.len());
    let cfg = crate::common::crsh_dual();
    let cpu = RshEngine::new(&geo, cfg.clone()).unwrap();
    let dev = GpuRsh::new(g.clone(), &geo, cfg).unwrap();
    compare(&cpu, &dev, &rays, TraceMode::Any, "sponza 512² shadows");
}
