//! CRSH's single-ray path on the GPU, the twin of `crates/rsh/src/single.rs`: every ray
//! walks the object tree built on the device ([`super::objects`]) on its own thread
//! (`single.wgsl`), with the CPU walk's slab test, order and stopping rules, so hits and
//! counts are the CPU's. One launch per batch: no hashing, sorting or bundles, no size to
//! read back before the next launch; the counters come back in one small read-back.
//!
//! A ray's stack lives in registers and holds [`STACK`] entries (a node test pushes at
//! most 7 more than it pops, so a tree 9 box levels deep never fills it). A ray that would
//! overflow it stops on the device, adds none of its counts and is listed; the host then
//! traces the listed rays with the CPU twin ([`::rsh::single::trace`]) over the same tree
//! read back once (bit for bit the device's), so no ray is dropped and the counts stay the
//! CPU's.

use super::objects::DeviceTree;
use crate::kernels::params::SingleWalkParams;
use crate::kernels::{launch, Exec};
use crate::rays::DeviceRays;
use ::rsh::single::SingleCounts;

/// Most stack entries a ray's walk holds on the device (`single.wgsl`'s `STACK`).
pub const STACK: u32 = 64;

/// Counter words before the overflow list: 7 64-bit counters, then the overflow count.
const HEAD: usize = 15;

/// One batch walked on the device: every ray's best (triangle, t bits; the records kernel's
/// input) and the counter block.
pub(crate) struct Walked {
    pub best: wgpu::Buffer,
    cnt: wgpu::Buffer,
}

/// Walk rays `dr` through `tree` (`any`: stop at a ray's first hit), each with at most
/// `stack` entries (≤ [`STACK`]; tests lower it to make walks overflow).
pub(crate) fn walk(
    ex: &mut Exec,
    tree: &DeviceTree,
    dr: &DeviceRays,
    any: bool,
    stack: u32,
) -> Walked {
    let n = dr.len;
    let g = ex.g;
    let best = g.storage("single-ray best", n * 8);
    // Zeroed by a clear command, not a dispatch.
    let cnt = g.storage("single-ray counters", (HEAD as u64 + n) * 4);
    ex.clear(&cnt);
    ex.run(
        launch::SingleWalk {
            s_org: &dr.org,
            s_dir: &dr.dir,
            s_kl: &dr.kl,
            s_boxes: &tree.boxes,
            s_leaf_tris: &tree.leaf_tris,
            s_order: &tree.order,
            s_best: &best,
            s_cnt: &cnt,
            s_pre: &dr.pre,
        },
        SingleWalkParams {
            rays: n as u32,
            leaves: tree.leaves,
            any: any as u32,
            stack: stack.min(STACK),
        },
        n,
        256,
    );
    Walked { best, cnt }
}

impl Walked {
    /// The counts of the rays that finished on the device, and the rays that overflowed
    /// (ascending): one read-back, and a second only when some ray overflowed.
    pub(crate) fn counts(&self, ex: &mut Exec) -> (SingleCounts, Vec<u32>) {
        let head: Vec<u32> = ex.read(&self.cnt, HEAD);
        let c = |i: usize| head[2 * i] as u64 | (head[2 * i + 1] as u64) << 32;
        let counts = SingleCounts {
            final_tests: [c(0), c(1), c(2), c(3)],
            box_tests: c(4),
            box_passes: c(5),
            hits: c(6),
        };
        let over = head[HEAD - 1] as usize;
        let mut list = Vec::new();
        if over > 0 {
            list = ex.read::<u32>(&self.cnt, HEAD + over)[HEAD..].to_vec();
            list.sort_unstable();
        }
        (counts, list)
    }
}
