//! The object tree collapsed for single rays ([`crate::bvh::single`]): nodes of up to 8 children
//! whose boxes one ray tests at once in AVX lanes (a BVH8, as Embree and Wald et al. 2008
//! collapse binary trees into wide ones), where a child is either another such node or a
//! *leaf lane* of up to [`LANE_TRIS`] triangles, contiguous in the leaf order.
//!
//! Why leaf lanes of several triangles: with one triangle per lane (the dual traversal's
//! [`super::WideNode`]s), a subtree of 2–3 triangles left over by a frontier becomes a node
//! of its own, a whole node visit for a ray to test 2–3 boxes; Conference's 277 k triangles
//! made 86 k such nodes, 4.2 children each. Holding small subtrees as lanes makes the
//! nodes fuller and the tree shallower, at the price of testing a lane's triangles without
//! their own boxes. Two triangles per lane measured best (Sponza 512², 2 threads, mins of
//! 15 runs, SAH tree: shadow rays 37.0 ms against 38.4 with one and 44.6 with four; random
//! rays 80.1 against 85.9 and 105.2).
//!
//! The frontier of a node grows from its binary node's two children by splitting the
//! member of largest box area (the surface-area heuristic's probability that a ray through
//! the parent meets it) that holds more than [`LANE_TRIS`] triangles, until 8 members or
//! none to split.

use super::{ObjectTree, LEAF};
use geom::Aabb;
use par::SharedMut;
use rayon::prelude::*;

/// Most triangles one leaf lane holds.
pub const LANE_TRIS: u32 = 2;

/// Children per node.
const WIDTH: usize = 8;

/// A node of the single-ray path's tree: its children's grown boxes (one ray's slab test
/// reads them as 8 lanes) and references, in four cache lines. Lanes `count..8` repeat
/// lane 0 and are masked off.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub struct BoxNode {
    /// Grown boxes' minima (x, y, z lanes).
    pub min: [[f32; 8]; 3],
    /// Grown boxes' maxima.
    pub max: [[f32; 8]; 3],
    /// A leaf lane: `LEAF | p`, its triangles at positions `p .. p + ntri` of the box order
    /// (ids [`ObjectTree::leaf_ids`], vertices [`ObjectTree::leaf_tris`]; a node's leaf
    /// lanes at consecutive positions, [`number_level`]); else the index of the child node.
    pub child: [u32; 8],
    /// Children in use.
    pub count: u32,
    /// Bit i set when child i (of the first `count`) is a leaf lane.
    pub leaves: u32,
    /// Triangles of each leaf lane.
    pub ntri: [u8; 8],
}

/// Every triangle's position in the leaf order `order` (its inverse).
pub(super) fn leaf_positions(order: &[u32]) -> Vec<u32> {
    let mut pos = vec![0u32; order.len()];
    let out = SharedMut(pos.as_mut_ptr());
    order
        .par_iter()
        .enumerate()
        .with_min_len(4096)
        .for_each(|(p, &t)| {
            // SAFETY: `order` is a permutation: every triangle is written once.
            unsafe { out.write(t as usize, p as u32) }
        });
    pos
}

/// The frontier of binary inner node `h` (see the module doc), members in the tree's
/// left-to-right order.
fn frontier(
    child: &[[u32; 2]],
    range: &[[u32; 2]],
    gbox: &[Aabb],
    h: u32,
) -> ([u32; WIDTH], usize) {
    // A member's weight: its box's area when it may be split, else −∞.
    let weight = |x: u32| {
        if x & LEAF != 0 {
            return f32::NEG_INFINITY;
        }
        let [lo, hi] = range[x as usize];
        if hi - lo < LANE_TRIS {
            f32::NEG_INFINITY
        } else {
            gbox[x as usize].half_area()
        }
    };
    let mut f = [0u32; WIDTH];
    let mut w = [f32::NEG_INFINITY; WIDTH];
    f[..2].copy_from_slice(&child[h as usize]);
    w[0] = weight(f[0]);
    w[1] = weight(f[1]);
    let mut n = 2;
    while n < WIDTH {
        let mut best: Option<usize> = None;
        for i in 0..n {
            if w[i] > f32::NEG_INFINITY && best.is_none_or(|b| w[i] > w[b]) {
                best = Some(i);
            }
        }
        let Some(i) = best else { break };
        let [a, b] = child[f[i] as usize];
        f.copy_within(i + 1..n, i + 2);
        w.copy_within(i + 1..n, i + 2);
        (f[i], f[i + 1]) = (a, b);
        (w[i], w[i + 1]) = (weight(a), weight(b));
        n += 1;
    }
    (f, n)
}

/// The single-ray path's nodes of a binary tree (children `child`, leaf-order ranges
/// `range`, grown boxes `gbox`, root 0, at least one inner node; `leaf_box` a triangle's
/// grown box, `pos` its leaf position): node 0 the root's, the others level by level, each
/// level's nodes made in parallel.
pub(super) fn collapse_boxes(
    child: &[[u32; 2]],
    range: &[[u32; 2]],
    gbox: &[Aabb],
    leaf_box: &(impl Fn(u32) -> Aabb + Sync),
    pos: &[u32],
    order: &[u32],
) -> (Vec<BoxNode>, Vec<u32>) {
    // A member that stays a node: an inner node with more than LANE_TRIS triangles.
    let is_node =
        |x: u32| x & LEAF == 0 && range[x as usize][1] - range[x as usize][0] >= LANE_TRIS;
    // The node of head `h`, its node children still as binary node ids.
    let make = |h: u32| {
        let (f, n) = frontier(child, range, gbox, h);
        let mut b = BoxNode {
            min: [[0.0; 8]; 3],
            max: [[0.0; 8]; 3],
            child: [0; 8],
            count: n as u32,
            leaves: 0,
            ntri: [0; 8],
        };
        for i in 0..WIDTH {
            let x = f[if i < n { i } else { 0 }];
            let (bx, reference, k) = if x & LEAF != 0 {
                let t = x & !LEAF;
                (leaf_box(t), LEAF | pos[t as usize], 1)
            } else if is_node(x) {
                (gbox[x as usize], x, 0)
            } else {
                let [lo, hi] = range[x as usize];
                (gbox[x as usize], LEAF | lo, hi - lo + 1)
            };
            for a in 0..3 {
                b.min[a][i] = bx.min[a];
                b.max[a][i] = bx.max[a];
            }
            b.child[i] = reference;
            b.ntri[i] = k as u8;
            if i < n && reference & LEAF != 0 {
                b.leaves |= 1 << i;
            }
        }
        b
    };
    let mut nodes: Vec<BoxNode> = Vec::with_capacity(child.len() / 8 + 1);
    let mut ids: Vec<u32> = Vec::with_capacity(order.len());
    let mut heads = vec![0u32];
    while !heads.is_empty() {
        let base = nodes.len();
        nodes.par_extend(heads.par_iter().with_min_len(256).map(|&h| make(h)));
        let next = nodes.len() as u32;
        let mut at = ids.len() as u32;
        number_level(&mut nodes[base..], next, &mut heads, &mut at, |lo, k| {
            ids.extend_from_slice(&order[lo as usize..(lo + k) as usize])
        });
    }
    (nodes, ids)
}

/// Number one level of box nodes, made from binary node ids and binary leaf positions (the
/// nodes numbered from `next`, the leaf positions from `*at`): the next level's heads (each
/// inner lane's binary node, in lane order within node order) replace `heads`, each inner
/// lane gets its node's index; each leaf lane gets the next positions of the box order (a
/// node's leaf lanes consecutive, node after node: their triangles then share a block or
/// two of [`ObjectTree::leaf_tris`], where in the binary leaf order an inner lane's subtree
/// may lie between them), `leaf(lo, k)` told its binary positions `lo .. lo + k`; masked
/// lanes repeat lane 0. The CPU's build (`collapse_boxes`) and the GPU's read-back tree
/// number their levels with it.
pub fn number_level(
    level: &mut [BoxNode],
    mut next: u32,
    heads: &mut Vec<u32>,
    at: &mut u32,
    mut leaf: impl FnMut(u32, u32),
) {
    heads.clear();
    for b in level {
        for i in 0..b.count as usize {
            if b.leaves >> i & 1 == 0 {
                heads.push(b.child[i]);
                b.child[i] = next;
                next += 1;
            } else {
                let (lo, k) = (b.child[i] & !LEAF, b.ntri[i] as u32);
                b.child[i] = LEAF | *at;
                *at += k;
                leaf(lo, k);
            }
        }
        // Masked lanes repeat lane 0's reference.
        for i in b.count as usize..WIDTH {
            b.child[i] = b.child[0];
        }
    }
}

impl ObjectTree {
    /// The surface-area metric of the single-ray path's tree (MacDonald & Booth 1990): for a
    /// ray that meets the root's box, uniformly over such rays, the expected number of
    /// nodes whose children it is tested against (Σ A(node) / A(root)) and of triangles it
    /// tests (Σ A(leaf lane) · triangles / A(root)): its work, the lower the better. (0, 0)
    /// without such a tree.
    pub fn sah_metric(&self) -> (f64, f64) {
        let area = |b: &Aabb| b.half_area() as f64;
        let lanes = |n: &BoxNode, i: usize| {
            Aabb::new(
                geom::Vec3::new(n.min[0][i], n.min[1][i], n.min[2][i]),
                geom::Vec3::new(n.max[0][i], n.max[1][i], n.max[2][i]),
            )
        };
        let own =
            |n: &BoxNode| (0..n.count as usize).fold(Aabb::EMPTY, |b, i| b.union(&lanes(n, i)));
        let Some(root) = self.boxes.first().map(|n| area(&own(n))) else {
            return (0.0, 0.0);
        };
        if root <= 0.0 {
            return (0.0, 0.0);
        }
        let nodes: f64 = self.boxes.iter().map(|n| area(&own(n))).sum();
        let tris: f64 = self
            .boxes
            .iter()
            .flat_map(|n| {
                (0..n.count as usize)
                    .filter(move |&i| n.leaves >> i & 1 != 0)
                    .map(move |i| area(&lanes(n, i)) * n.ntri[i] as f64)
            })
            .sum();
        (nodes / root, tris / root)
    }
}
