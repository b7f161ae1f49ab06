//! The box nodes' leaf triangles, 8 to a block as structure of arrays ([`Tris8`]): leaf
//! position `p` is lane `p % 8` of block `p / 8`, the positions numbered node by node
//! ([`box_order`]: a node's leaf lanes consecutive), so the lanes a ray enters at one node
//! share a block or two: the single-ray walk
//! ([`crate::single`]) tests all their triangles with one 8-lane vector test per block
//! ([`geom::tris8`]) instead of one scalar test each, as Embree's BVH8 tests its leaves
//! several triangles at a time. The blocks hold the same bytes as triangles side by side
//! would (36 per triangle, the last block padded), so the layout costs the build nothing;
//! the packets ([`crate::packet`]) read a triangle's nine floats from its lane.

use super::{BoxNode, ObjectTree, LEAF};
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

/// Renumber the leaf lanes of `nodes` (whose references are leaf positions of the binary
/// tree's order) so that every node's leaf lanes take consecutive positions, node after node
/// in `nodes`' order, lanes in lane order (the CPU's build numbers them so as it makes the
/// nodes, `boxes::collapse_boxes`; this is for nodes made elsewhere, the GPU's read back): a node's leaf triangles then share a block or
/// two, where in the binary order an inner lane's subtree may lie between them. Returns,
/// per new position, the triangle there: `order[q]` for the binary position q it came from
/// (`order` the binary tree's leaf order).
pub fn box_order(nodes: &mut [BoxNode], order: &[u32]) -> Vec<u32> {
    use par::SharedMut;
    // Each node's first position: one cheap sequential pass (8 lanes a node).
    let mut first = Vec::with_capacity(nodes.len());
    let mut next = 0u32;
    for b in nodes.iter() {
        first.push(next);
        for l in 0..b.count as usize {
            if b.leaves >> l & 1 != 0 {
                next += b.ntri[l] as u32;
            }
        }
    }
    let mut ids: Vec<u32> = Vec::with_capacity(next as usize);
    let out = SharedMut(ids.as_mut_ptr());
    nodes
        .par_iter_mut()
        .zip(&first)
        .with_min_len(256)
        .for_each(|(b, &f)| {
            let mut p = f;
            for l in 0..b.count as usize {
                if b.leaves >> l & 1 == 0 {
                    continue;
                }
                let lo = b.child[l] & !LEAF;
                for j in 0..b.ntri[l] as u32 {
                    // SAFETY: positions f.. are this node's (the next node's start past
                    // them), each written once, within the capacity.
                    unsafe { out.write((p + j) as usize, order[(lo + j) as usize]) };
                }
                b.child[l] = LEAF | p;
                p += b.ntri[l] as u32;
            }
            // Masked lanes repeat lane 0.
            for i in b.count as usize..8 {
                b.child[i] = b.child[0];
            }
        });
    // SAFETY: the nodes' ranges tile 0..next and each was written whole.
    unsafe { ids.set_len(next as usize) };
    ids
}
