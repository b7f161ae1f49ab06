//! The `bvh` engine's single rays on the GPU, the twin of `crates/accel/src/bvh/single.rs`: every ray
//! walks the object tree built on the device ([`super::objects`]) on its own thread
//! (`single.wgsl`), with the CPU walk's slab test, order and stopping rules, so hits and
//! counts are the CPU's; each ray writes its own hit record as it finishes. One launch per
//! batch (and the second pass below): no hashing, sorting or bundles, no records pass, no
//! size to read back before the next launch; the counters come back in one small read-back.
//!
//! A ray's stack lives in private memory and holds [`STACK`] entries. A ray that would
//! overflow it stops, adds none of its counts and is listed; a second pass walks the listed
//! rays again with [`DEEP`] entries each in storage memory, a pool of [`POOL`] threads taking
//! the list in turn, which no LBVH can exceed (`single.wgsl` gives the bound). Both passes
//! are always dispatched, so nothing waits for the host, no ray is dropped and the counts
//! stay the CPU's; the stats count the rays that took the second pass
//! (`gpu stack overflows`).

use super::objects::DeviceTree;
use crate::kernels::params::SingleWalkParams;
use crate::kernels::{launch, DevSize, Exec, Threads};
use crate::rays::DeviceRays;
use accel::bvh::single::SingleCounts;

/// Most stack entries a ray's walk holds in private memory (`single.wgsl`'s `STACK`).
pub const STACK: u32 = 64;

/// Stack entries per ray of the second pass (`single.wgsl`'s `DEEP`).
pub const DEEP: u64 = 1024;

/// Threads of the second pass.
pub const POOL: u64 = 1024;

/// Counter words before the overflow list: 7 64-bit counters, the second pass's failures,
/// the overflow count.
pub(crate) const HEAD: usize = 16;

/// The second pass's stacks ([`POOL`] × [`DEEP`] entries of 8 bytes), made once per engine.
pub(crate) fn deep_stacks(g: &crate::device::Gpu) -> wgpu::Buffer {
    g.storage("single-ray deep stacks", POOL * DEEP * 8)
}

/// One batch walked on the device: every ray's hit record (triangle, t, u, v bits; triangle
/// `NO_HIT`: a miss), written by the walk itself, and the counter block.
pub(crate) struct Walked {
    pub rec: wgpu::Buffer,
    /// The counter block ([`HEAD`] words, then the second pass's list).
    pub cnt: wgpu::Buffer,
}

/// Walk rays `dr` through `tree` (`any`: stop at a ray's first hit), each with at most
/// `stack` entries (≤ [`STACK`]; tests lower it to make walks overflow); `count`: only the
/// first `count.n` of the `dr.len` rays, a size the device holds (an indirect launch).
pub(crate) fn walk(
    ex: &mut Exec,
    tree: &DeviceTree,
    dr: &DeviceRays,
    any: bool,
    stack: u32,
    deep: &wgpu::Buffer,
    count: Option<&DevSize>,
) -> Walked {
    let n = dr.len;
    let g = ex.g;
    let rec = g.storage("single-ray records", n * 16);
    // Zeroed by a clear command, not a dispatch.
    let cnt = g.storage("single-ray counters", (HEAD as u64 + n) * 4);
    ex.clear(&cnt);
    let prm = SingleWalkParams {
        rays: n as u32,
        leaves: tree.leaves,
        any: any as u32,
        stack: stack.min(STACK),
        pool: POOL.min(n) as u32,
    };
    let first = launch::SingleWalk {
        s_org: &dr.org,
        s_dir: &dr.dir,
        s_kl: &dr.kl,
        s_boxes: &tree.boxes,
        s_leaf_tris: &tree.leaf_tris,
        s_order: &tree.order,
        s_rec: &rec,
        s_cnt: &cnt,
        s_stack: deep,
    };
    ex.run_on(first, prm, Threads::of(count, n), 256);
    ex.run(
        launch::SingleWalkDeep {
            s_org: &dr.org,
            s_dir: &dr.dir,
            s_kl: &dr.kl,
            s_boxes: &tree.boxes,
            s_leaf_tris: &tree.leaf_tris,
            s_order: &tree.order,
            s_rec: &rec,
            s_cnt: &cnt,
            s_stack: deep,
        },
        prm,
        POOL.min(n),
        256,
    );
    Walked { rec, cnt }
}

/// The counts and second-pass rays of a counter block's first [`HEAD`] words.
pub(crate) fn counts_of(head: &[u32]) -> (SingleCounts, u64) {
    let c = |i: usize| head[2 * i] as u64 | (head[2 * i + 1] as u64) << 32;
    // The bound in `single.wgsl` makes this impossible for an LBVH: a failure is a bug.
    assert_eq!(
        head[HEAD - 2],
        0,
        "a single ray outgrew the device's deep stack"
    );
    let counts = SingleCounts {
        final_tests: [c(0), c(1), c(2), c(3)],
        box_tests: c(4),
        box_passes: c(5),
        hits: c(6),
    };
    (counts, head[HEAD - 1] as u64)
}
