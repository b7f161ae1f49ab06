//! The box nodes' leaf triangles, 8 to a block as structure of arrays ([`Tris8`]): leaf
//! position `p` is lane `p % 8` of block `p / 8`, the positions numbered node by node
//! ([`super::boxes::number_level`]: a node's leaf lanes consecutive), so the lanes a ray
//! enters at one node
//! share a block or two: the single-ray walk
//! ([`crate::bvh::single`]) tests all their triangles with one 8-lane vector test per block
//! ([`geom::tris8`]) instead of one scalar test each, as Embree's BVH8 tests its leaves
//! several triangles at a time. The blocks hold the same bytes as triangles side by side
//! would (36 per triangle, the last block padded), so the layout costs the build nothing;
//! the packets ([`crate::bvh::packet`]) read a triangle's nine floats from its lane.

use super::ObjectTree;
use geom::tris8::Tris8;
use geom::Vec3;
use rayon::prelude::*;

/// The blocks of `n` triangles in leaf order, triangle `p` being `tri(p)` (made in
/// parallel, each block whole; the last block's unused lanes hold zeros).
pub fn leaf_blocks(n: usize, tri: impl Fn(usize) -> [Vec3; 3] + Sync) -> Vec<Tris8> {
    let nb = n.div_ceil(8);
    let mut blocks: Vec<Tris8> = Vec::with_capacity(nb);
    // Each block written in place (a block returned by value is copied once more).
    blocks.spare_capacity_mut()[..nb]
        .par_iter_mut()
        .enumerate()
        .with_min_len(512)
        .for_each(|(b, slot)| {
            let t = slot.write(Tris8::default());
            for l in 0..8.min(n - 8 * b) {
                t.set(l, tri(8 * b + l));
            }
        });
    // SAFETY: blocks 0..nb were written above.
    unsafe { blocks.set_len(nb) };
    blocks
}

impl ObjectTree {
    /// The triangle at leaf position `p`, bit for bit.
    #[inline(always)]
    pub fn leaf_tri(&self, p: usize) -> [Vec3; 3] {
        self.leaf_tris[p / 8].tri(p % 8)
    }
}
