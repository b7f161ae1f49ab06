//! The object tree: a binary BVH over the scene's triangles, one triangle per leaf, rebuilt
//! per frame (the thesis's future work, §5.1: "combine our coherent ray hierarchy with a
//! deeper object hierarchy"), and the collapsed records each traversal reads.
//!
//! Two builders ([`ObjectBuilder`]) give the same layout (triangles in leaf order, every
//! inner node's leaves a contiguous range of it, Karras's node numbering), so every
//! traversal takes either:
//! - `lbvh` (Karras 2012, "Maximizing parallelism in the construction of BVHs, octrees and
//!   k-d trees", §3–4): each triangle gets a 64-bit key, its mesh index above the Morton
//!   code of its bounding-box centre in the scene box; the keys are radix-sorted (`par`);
//!   the binary radix tree over the sorted keys (Karras's, the index breaking ties between
//!   equal keys) and its boxes are made in one bottom-up pass (Apetrei 2014, "Fast and
//!   simple agglomerative LBVH construction"): one task per leaf, the second child to reach
//!   a node making it (the GPU's atomic-counter pass), numbered as Karras's emission
//!   (Figure 4) numbers it, which the tests check node for node. Every mesh's triangles
//!   form one subtree (the mesh index is the key's top bits);
//! - `sah` ([`sah`]): binned SAH, top down; fewer node visits per ray for a slower build.
//!
//! With mesh culling on, a node holding exactly one mesh's triangles gets the smaller of its
//! box sphere and the mesh's minimal sphere (the thesis's per-mesh culling spheres, §3.2.2).
//!
//! The ray hierarchy's dual traversal (`rsh::dual`) bounds every node by a sphere (the node
//! tests of eq. 3.16 and the exact cone test take spheres), padded so that it contains its triangles, the
//! leaves by their own; its depth-first schedule reads the tree 8 children at a time
//! ([`WideNode`]): each binary node it expands is *collapsed* into up to 8 descendants (the
//! frontier grown by splitting its largest-sphere inner node, as Embree and Wald et al. 2008
//! collapse binary BVHs into wide ones), with exactly the binary nodes' bounds, so one ray
//! node is tested against all 8 in AVX lanes and every lane's answer is the binary node's.
//! The single-ray path ([`crate::bvh::single`]) reads its own collapse ([`BoxNode`], [`boxes`]).
//! [`Parts`] says which of the two a tree is built with.

use geom::morton::morton;
use geom::{Aabb, Sphere, Vec3};
use par::{sort_pairs, SharedMut, SortScratch};
use rayon::prelude::*;
use std::sync::atomic::{AtomicU32, Ordering};

/// A child reference with this bit set is a leaf: the low bits are a triangle id.
pub const LEAF: u32 = 1 << 31;

/// The tree: internal nodes `0 .. n − 1` (node 0 the root), leaves as `LEAF | triangle`.
#[derive(Clone, Debug, Default)]
pub struct ObjectTree {
    /// The root: internal node 0, or a leaf when the scene has one triangle.
    pub root: u32,
    /// Left and right children of every internal node.
    pub child: Vec<[u32; 2]>,
    /// Every internal node's sphere and box (one record: a pair test reads both).
    pub node: Vec<Bounds>,
    /// Every triangle's sphere ([`Sphere::of_triangle`]) and box.
    pub leaf: Vec<Bounds>,
    /// Per internal node, its two children's boxes side by side (a single ray's descent
    /// tests both at once: one cache line), grown by a few ulps of the scene's coordinates
    /// so that the robust slab test never misses a triangle inside; a leaf child's box is
    /// its triangle's.
    pub child_box: Vec<[Aabb; 2]>,

    /// The triangles in leaf order (left to right), …
    pub tri_order: Vec<u32>,
    /// … and every internal node's leaves as the range `[lo, hi]` (inclusive) of it: a small
    /// subtree's triangles are listed without walking it.
    pub range: Vec<[u32; 2]>,
    /// Depth of the deepest leaf (root = 0).
    pub depth: u32,
    /// The collapsed nodes: one per binary inner node that the traversal expands (the root
    /// and every inner node on a collapsed node's frontier).
    pub wide: Vec<WideNode>,
    /// Per binary inner node, its collapsed node in `wide` (`u32::MAX` where it has none:
    /// it lies inside some other node's frontier and is never expanded on its own).
    pub wide_of: Vec<u32>,
    /// The single-ray path's collapsed nodes ([`BoxNode`], node 0 the root's), made when
    /// [`Parts::single`] is asked for.
    pub boxes: Vec<BoxNode>,
    /// The box nodes' leaf triangles, 8 to a block ([`blocks`]: a box node's leaf lanes
    /// at consecutive positions, position `p`, triangle `leaf_ids[p]`, lane `p % 8` of
    /// block `p / 8`; [`ObjectTree::leaf_tri`]): a node's triangles lie side by side, so the
    /// single-ray path reads a few cache lines where it would gather one line per
    /// triangle, and tests a block's triangles at once.
    pub leaf_tris: Vec<geom::tris8::Tris8>,
    /// The triangle at each position of [`ObjectTree::leaf_tris`].
    pub leaf_ids: Vec<u32>,
}

/// Up to 8 descendants of one binary inner node, side by side as lanes (structure of arrays
/// for the AVX node test): child references (`LEAF | triangle` or a binary inner node) and
/// their bounds, copied bit for bit from [`ObjectTree::bounds`]. Lanes `count..8` repeat
/// lane 0 and are masked off.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
pub struct WideNode {
    /// Sphere centres (x, y, z lanes).
    pub center: [[f32; 8]; 3],
    /// Sphere radii.
    pub radius: [f32; 8],
    /// Grown boxes' minima (x, y, z lanes).
    pub min: [[f32; 8]; 3],
    /// Grown boxes' maxima.
    pub max: [[f32; 8]; 3],
    /// Child references.
    pub child: [u32; 8],
    /// Children in use.
    pub count: u32,
}

/// How many children a collapsed node holds at most (the AVX width).
pub const WIDTH: usize = 8;

/// The frontier of binary inner node `h`: start with its two children and split the inner
/// member of largest sphere (the first such on ties) until `WIDTH` members or only leaves;
/// a split member's children take its place, so members stay in the tree's left-to-right
/// order. Each member's radius is read once (the records are scattered over the tree).
fn frontier(child: &[[u32; 2]], node: &[Bounds], h: u32) -> ([u32; WIDTH], usize) {
    let radius = |x: u32| {
        if x & LEAF != 0 {
            f32::NEG_INFINITY
        } else {
            node[x as usize].sphere.radius
        }
    };
    let mut f = [0u32; WIDTH];
    let mut r = [f32::NEG_INFINITY; WIDTH];
    f[..2].copy_from_slice(&child[h as usize]);
    r[0] = radius(f[0]);
    r[1] = radius(f[1]);
    let mut n = 2;
    while n < WIDTH {
        let mut best: Option<usize> = None;
        for i in 0..n {
            if f[i] & LEAF == 0 && best.is_none_or(|b| r[i] > r[b]) {
                best = Some(i);
            }
        }
        let Some(i) = best else { break };
        let [a, b] = child[f[i] as usize];
        f.copy_within(i + 1..n, i + 2);
        r.copy_within(i + 1..n, i + 2);
        (f[i], f[i + 1]) = (a, b);
        (r[i], r[i + 1]) = (radius(a), radius(b));
        n += 1;
    }
    (f, n)
}

/// The collapsed nodes of a binary tree (root 0, at least one inner node), heads level by
/// level from the root (each level's nodes made in parallel, in order); returns (`wide`,
/// `wide_of`).
fn collapse(child: &[[u32; 2]], node: &[Bounds], leaf: &[Bounds]) -> (Vec<WideNode>, Vec<u32>) {
    let ni = child.len();
    let mut wide_of = vec![u32::MAX; ni];
    let mut wide: Vec<WideNode> = Vec::with_capacity(ni / 3 + 1);
    let bounds = |x: u32| {
        if x & LEAF != 0 {
            &leaf[(x & !LEAF) as usize]
        } else {
            &node[x as usize]
        }
    };
    let make = |h: u32| {
        let (f, n) = frontier(child, node, h);
        let mut w = WideNode {
            center: [[0.0; 8]; 3],
            radius: [0.0; 8],
            min: [[0.0; 8]; 3],
            max: [[0.0; 8]; 3],
            child: [f[0]; 8],
            count: n as u32,
        };
        for i in 0..WIDTH {
            let x = f[if i < n { i } else { 0 }];
            let b = bounds(x);
            for k in 0..3 {
                w.center[k][i] = b.sphere.center[k];
                w.min[k][i] = b.bbox.min[k];
                w.max[k][i] = b.bbox.max[k];
            }
            w.radius[i] = b.sphere.radius;
            w.child[i] = x;
        }
        w
    };
    let mut heads = vec![0u32];
    while !heads.is_empty() {
        let base = wide.len();
        // Straight into the array's spare room (no second copy: fresh memory costs a page
        // fault per 4 KiB, on every frame).
        wide.par_extend(heads.par_iter().with_min_len(256).map(|&h| make(h)));
        for (i, &h) in heads.iter().enumerate() {
            wide_of[h as usize] = (base + i) as u32;
        }
        heads = wide[base..]
            .iter()
            .flat_map(|w| w.child[..w.count as usize].iter().copied())
            .filter(|&x| x & LEAF == 0)
            .collect();
    }
    (wide, wide_of)
}

/// An object node's bounds, as the pair tests read them: the sphere (the cone test) and the
/// box grown by a few ulps of the scene's coordinates (the beam and slab tests).
#[derive(Clone, Copy, Debug, Default)]
pub struct Bounds {
    /// Bounding sphere.
    pub sphere: Sphere,
    /// Grown bounding box.
    pub bbox: Aabb,
}

impl ObjectTree {
    /// Bytes of the tree's arrays (what the traversal reads; the triangles not included).
    pub fn bytes(&self) -> usize {
        use std::mem::size_of_val;
        size_of_val(&self.child[..])
            + size_of_val(&self.node[..])
            + size_of_val(&self.leaf[..])
            + size_of_val(&self.child_box[..])
            + size_of_val(&self.tri_order[..])
            + size_of_val(&self.range[..])
            + size_of_val(&self.wide[..])
            + size_of_val(&self.wide_of[..])
            + size_of_val(&self.boxes[..])
            + size_of_val(&self.leaf_tris[..])
            + size_of_val(&self.leaf_ids[..])
    }

    /// Internal nodes.
    pub fn len(&self) -> usize {
        self.child.len()
    }

    /// The bounds of node reference `o`: an internal node's, or a leaf's triangle's.
    #[inline]
    pub fn bounds(&self, o: u32) -> &Bounds {
        if o & LEAF != 0 {
            &self.leaf[(o & !LEAF) as usize]
        } else {
            &self.node[o as usize]
        }
    }

    /// Whether the tree has no internal node (zero or one triangle).
    pub fn is_empty(&self) -> bool {
        self.child.is_empty()
    }
}

/// Karras's δ(i, j): the common prefix length of sorted keys i and j, the index breaking ties
/// between equal keys; −1 outside the array.
#[inline]
fn delta(keys: &[u64], i: usize, j: i64) -> i32 {
    if j < 0 || j >= keys.len() as i64 {
        return -1;
    }
    let (a, b) = (keys[i], keys[j as usize]);
    if a == b {
        64 + (i as u64 ^ j as u64).leading_zeros() as i32
    } else {
        (a ^ b).leading_zeros() as i32
    }
}

/// Internal node i's key range `[lo, hi]` and split γ (Karras 2012, Figure 4): the
/// reference [`radix_tree`] is tested against.
#[cfg(test)]
fn emit_node(keys: &[u64], i: usize) -> (usize, usize, usize) {
    let ii = i as i64;
    let d: i64 = if delta(keys, i, ii + 1) > delta(keys, i, ii - 1) {
        1
    } else {
        -1
    };
    let dmin = delta(keys, i, ii - d);
    let mut lmax: i64 = 2;
    while delta(keys, i, ii + lmax * d) > dmin {
        lmax *= 2;
    }
    let mut l: i64 = 0;
    let mut t = lmax / 2;
    while t >= 1 {
        if delta(keys, i, ii + (l + t) * d) > dmin {
            l += t;
        }
        t /= 2;
    }
    let j = ii + l * d;
    let dnode = delta(keys, i, j);
    let mut s: i64 = 0;
    let mut t = l;
    loop {
        t = (t + 1) / 2;
        if delta(keys, i, ii + (s + t) * d) > dnode {
            s += t;
        }
        if t <= 1 {
            break;
        }
    }
    let gamma = ii + s * d + d.min(0);
    (ii.min(j) as usize, ii.max(j) as usize, gamma as usize)
}

/// The binary radix tree over `n ≥ 2` sorted keys, as Karras's emission numbers it (root 0;
/// an inner node's index is its range's right end when it is a left child, its left end
/// when a right child), with every inner node's box and the tree's depth.
struct RadixTree {
    child: Vec<[u32; 2]>,
    range: Vec<[u32; 2]>,
    nbox: Vec<Aabb>,
    depth: u32,
}

/// [`RadixTree`] in one bottom-up pass (Apetrei 2014, "Fast and simple agglomerative LBVH
/// construction"): one task per leaf climbs while it is the second child to arrive at a
/// node. A node covering sorted keys `[l, r]` is the left child of the node split at `r`
/// when keys r and r + 1 share a longer prefix than keys l − 1 and l (Karras's δ, the index
/// breaking ties, so no two are equal), else the right child of the node split at l − 1.
/// The first child to arrive leaves its end of the range in the parent's split slot (an
/// atomic swap); the second reads it and makes the node: its range, children, box (left ∪
/// right, in that order) and depth. This is the tree Karras's emission builds (the same
/// radix tree), with the same numbering and the same box bits, without a binary search
/// per node and without a second pass for the boxes.
fn radix_tree(keys: &[u64], order: &[u32], boxes: &[Aabb]) -> RadixTree {
    let n = keys.len();
    debug_assert!(n >= 2);
    let ni = n - 1;
    let mut child = vec![[0u32; 2]; ni];
    let mut range = vec![[0u32; 2]; ni];
    let mut nbox = vec![Aabb::default(); ni];
    let mut depth = vec![0u32; ni];
    // Per split s: the range end the first child to arrive left (u32::MAX: none yet), and
    // each side's child reference.
    let end: Vec<AtomicU32> = (0..ni)
        .into_par_iter()
        .with_min_len(1 << 14)
        .map(|_| AtomicU32::new(u32::MAX))
        .collect();
    let kid: Vec<[AtomicU32; 2]> = (0..ni)
        .into_par_iter()
        .with_min_len(1 << 14)
        .map(|_| [AtomicU32::new(0), AtomicU32::new(0)])
        .collect();
    // The parent of node [l, r]: (split, 0 when this is its left child, 1 when right); None
    // for the root.
    let parent = |l: usize, r: usize| -> Option<(usize, usize)> {
        let left = delta(keys, l, l as i64 - 1);
        let right = delta(keys, r, r as i64 + 1);
        if left < 0 && right < 0 {
            None
        } else if right > left {
            Some((r, 0))
        } else {
            Some((l - 1, 1))
        }
    };
    let out = (
        SharedMut(child.as_mut_ptr()),
        SharedMut(range.as_mut_ptr()),
        SharedMut(nbox.as_mut_ptr()),
        SharedMut(depth.as_mut_ptr()),
    );
    (0..n).into_par_iter().with_min_len(1024).for_each(|i| {
        let out = &out;
        let (mut l, mut r, mut me) = (i, i, LEAF | order[i]);
        let get = |c: u32| -> (Aabb, u32) {
            if c & LEAF != 0 {
                (boxes[(c & !LEAF) as usize], 0)
            } else {
                // SAFETY: inner node c is complete (its maker handed it up through the swap
                // below, which orders its writes before this read), and no one writes it
                // any more.
                unsafe { (*out.2 .0.add(c as usize), *out.3 .0.add(c as usize)) }
            }
        };
        // The parent of the node this task holds, found once per node: it gives both the
        // split to climb to and, once the node is made, its own index.
        let mut up = parent(l, r);
        while let Some((s, side)) = up {
            kid[s][side].store(me, Ordering::Relaxed);
            let mine = if side == 0 { l } else { r } as u32;
            // AcqRel: the second child to arrive sees the first one's node and reference.
            let other = end[s].swap(mine, Ordering::AcqRel);
            if other == u32::MAX {
                return;
            }
            (l, r) = if side == 0 {
                (l, other as usize)
            } else {
                (other as usize, r)
            };
            up = parent(l, r);
            let k = match up {
                None => 0,
                Some((_, 0)) => r,
                Some(_) => l,
            };
            let ch = [
                kid[s][0].load(Ordering::Relaxed),
                kid[s][1].load(Ordering::Relaxed),
            ];
            let ((a, da), (b, db)) = (get(ch[0]), get(ch[1]));
            // SAFETY: node k is made once, by the second child to arrive at split s (every
            // node has one index and one split).
            unsafe {
                out.0.write(k, ch);
                out.1.write(k, [l as u32, r as u32]);
                out.2.write(k, a.union(&b));
                out.3.write(k, 1 + da.max(db));
            }
            me = k as u32;
        }
    });
    RadixTree {
        child,
        range,
        depth: depth[0],
        nbox,
    }
}

/// `b` grown by 8 ulps of the largest coordinate of `scene`: more than the rounding of any
/// slab or beam computation on it can take away.
fn grown(b: &Aabb, scene: &Aabb) -> Aabb {
    let m = scene.min.abs().max(scene.max.abs()).max_element();
    let pad = Vec3::splat(m * 8.0 * f32::EPSILON);
    Aabb::new(b.min - pad, b.max + pad)
}

/// The LBVH's key layout: a mesh index above a Morton code (the GPU's build, `gpu::rsh::
/// objects`, lays its keys out by the same numbers).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct KeyBits {
    /// Morton bits per axis.
    pub axis_bits: u32,
    /// Bits of the Morton code (3 × `axis_bits`), the mesh index above them.
    pub code_bits: u32,
    /// Bits of the mesh index.
    pub mesh_bits: u32,
}

impl KeyBits {
    /// The layout for `n ≥ 2` triangles in `meshes` meshes.
    pub fn new(n: usize, meshes: usize) -> KeyBits {
        let mesh_bits = 64 - (meshes.max(1) as u64 - 1).leading_zeros().min(63);
        // Morton bits per axis: about 2^12 grid cells per triangle (⌈log2 n / 3⌉ + 4 bits),
        // as many as the mesh index leaves room for and at most 21. Finer codes would only
        // order triangles that share a cell (equal keys fall back to their index, which is
        // file order), and each 8 bits more is one more pass of the radix sort: on Sponza,
        // 10 bits instead of 21 give the same tree quality within 0.1 % of the tests, in 5
        // sort passes instead of 8.
        let log_n = usize::BITS - (n.max(2) - 1).leading_zeros();
        let axis_bits = (log_n.div_ceil(3) + 4).min((64 - mesh_bits) / 3).min(21);
        KeyBits {
            axis_bits,
            code_bits: 3 * axis_bits,
            mesh_bits,
        }
    }
}

/// The LBVH's tree over `n ≥ 2` triangles: keys (mesh index above the Morton code of the
/// box centre in the centroids' box), radix-sorted, and the radix tree over them; returns
/// the tree and the triangles in leaf order.
fn lbvh(boxes: &[Aabb], mesh_first: &[u32]) -> (RadixTree, Vec<u32>) {
    let n = boxes.len();
    // The centroids' box: the Morton grid.
    let centroid_box = boxes
        .par_iter()
        .with_min_len(4096)
        .map(|b| {
            let c = b.center();
            Aabb::new(c, c)
        })
        .reduce(Aabb::default, |a, b| a.union(&b));
    let centroid_box = &centroid_box;
    // Keys: mesh index above the Morton code (triangles are stored mesh by mesh).
    let KeyBits {
        axis_bits,
        code_bits,
        mesh_bits,
    } = KeyBits::new(n, mesh_first.len().saturating_sub(1));
    let mut keys: Vec<u64> = boxes
        .par_iter()
        .enumerate()
        .with_min_len(4096)
        .map(|(t, bx)| {
            let m = mesh_first
                .partition_point(|&f| f as usize <= t)
                .saturating_sub(1);
            (m as u64) << code_bits | morton(bx.center(), centroid_box, axis_bits)
        })
        .collect();
    let mut order: Vec<u32> = (0..n as u32).collect();
    sort_pairs(
        &mut keys,
        &mut order,
        code_bits + mesh_bits,
        &mut SortScratch::new(),
    );
    // The radix tree and its boxes in one bottom-up pass (Apetrei 2014).
    (radix_tree(&keys, &order, boxes), order)
}

/// Which traversals' records [`build`] makes (each costs build time; a tree is only
/// walked by the ones it was built for).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Parts {
    /// The ray hierarchy's dual traversal's (`rsh::dual`): bounds with spheres, children's
    /// boxes, [`WideNode`]s.
    pub dual: bool,
    /// The single-ray path's ([`crate::bvh::single`]): [`BoxNode`]s and the triangles in leaf
    /// order.
    pub single: bool,
}

impl Parts {
    /// Both traversals' records.
    pub const ALL: Parts = Parts {
        dual: true,
        single: true,
    };
}

/// How the object tree is built.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ObjectBuilder {
    /// Karras's linear BVH over Morton codes ([`build`]'s radix tree): the fastest build.
    Lbvh,
    /// Binned SAH, top down ([`sah`]): a better tree for a slower build.
    Sah,
}

impl ObjectBuilder {
    /// Every value by its name (as options spell it).
    pub const NAMES: [(&'static str, ObjectBuilder); 2] =
        [("lbvh", ObjectBuilder::Lbvh), ("sah", ObjectBuilder::Sah)];
}

/// Build the tree over `tris` (meshes as `mesh_first` ranges) with `builder`. With `mesh_spheres`, the root
/// of mesh m's subtree is bounded by the smaller of its box sphere and `mesh_spheres[m]`.
pub fn build(
    tris: &[[Vec3; 3]],
    mesh_first: &[u32],
    mesh_spheres: Option<&[Sphere]>,
    builder: ObjectBuilder,
    parts: Parts,
) -> ObjectTree {
    let n = tris.len();
    if n <= 1 {
        // A lone triangle is the root (and with none, nothing is ever traversed).
        let leaf = tris
            .iter()
            .map(|t| {
                let b = Aabb::of_triangle(t);
                Bounds {
                    sphere: Sphere::of_triangle(t[0], t[1], t[2]),
                    bbox: grown(&b, &b),
                }
            })
            .collect();
        return ObjectTree {
            root: LEAF,
            leaf,
            ..Default::default()
        };
    }
    assert!(
        n < LEAF as usize,
        "checked by RshEngine::new: fewer than 2^31 triangles"
    );
    // The triangles' boxes and the scene's box (the boxes' growth: the root's box).
    let (boxes, scene_box) = geom::aabb::triangle_boxes(tris);
    let grow = |b: &Aabb| grown(b, &scene_box);
    let (
        RadixTree {
            child,
            range,
            nbox,
            depth,
        },
        order,
    ) = match builder {
        ObjectBuilder::Lbvh => lbvh(&boxes, mesh_first),
        ObjectBuilder::Sah => sah::build(&boxes),
    };
    let gbox: Vec<Aabb> = nbox.par_iter().with_min_len(4096).map(grow).collect();
    let mut tree = ObjectTree {
        root: 0,
        child,
        range,
        depth,
        ..Default::default()
    };
    if parts.dual {
        let (leaf, node, child_box, wide, wide_of) = dual_parts(
            tris,
            mesh_first,
            mesh_spheres,
            &boxes,
            &nbox,
            &gbox,
            &order,
            &tree,
            grow,
        );
        tree.leaf = leaf;
        tree.node = node;
        tree.child_box = child_box;
        tree.wide = wide;
        tree.wide_of = wide_of;
    }
    if parts.single {
        let pos = leaf_positions(&order);
        let leaf_box = |t: u32| grow(&boxes[t as usize]);
        (tree.boxes, tree.leaf_ids) =
            collapse_boxes(&tree.child, &tree.range, &gbox, &leaf_box, &pos, &order);
        tree.leaf_tris = leaf_blocks(order.len(), |p| tris[tree.leaf_ids[p] as usize]);
    }
    tree.tri_order = order;
    tree
}

/// The dual traversal's records of the tree `t` (its children and ranges made): the leaves'
/// and inner nodes' bounds (with `mesh_spheres`, a node holding exactly one mesh's
/// triangles takes the mesh's sphere when smaller), the children's boxes side by side, and
/// the collapsed nodes.
#[allow(clippy::too_many_arguments, clippy::type_complexity)]
fn dual_parts(
    tris: &[[Vec3; 3]],
    mesh_first: &[u32],
    mesh_spheres: Option<&[Sphere]>,
    boxes: &[Aabb],
    nbox: &[Aabb],
    gbox: &[Aabb],
    order: &[u32],
    t: &ObjectTree,
    grow: impl Fn(&Aabb) -> Aabb + Sync,
) -> (
    Vec<Bounds>,
    Vec<Bounds>,
    Vec<[Aabb; 2]>,
    Vec<WideNode>,
    Vec<u32>,
) {
    let leaf: Vec<Bounds> = boxes
        .par_iter()
        .zip(tris)
        .with_min_len(4096)
        .map(|(bx, &[a, b, c])| Bounds {
            sphere: Sphere::of_triangle(a, b, c),
            bbox: grow(bx),
        })
        .collect();
    let mesh_of = |t: u32| mesh_first.partition_point(|&f| f <= t).saturating_sub(1);
    let node: Vec<Bounds> = (0..t.child.len())
        .into_par_iter()
        .with_min_len(1024)
        .map(|i| {
            // The sphere around the exact box (the grown one pads the slab tests only).
            let mut s = Sphere::around_box(&nbox[i]);
            let [lo, hi] = t.range[i].map(|x| x as usize);
            if let Some(ms) = mesh_spheres {
                // A node holding exactly one mesh's triangles (as many as the mesh has,
                // all of them in it) may take the mesh's sphere.
                let m = mesh_of(order[lo]);
                let (first, end) = (mesh_first[m], mesh_first[m + 1]);
                let whole_mesh = (hi - lo + 1) as u32 == end - first
                    && order[lo..=hi].iter().all(|&x| (first..end).contains(&x));
                if whole_mesh && ms[m].radius < s.radius {
                    s = ms[m];
                }
            }
            Bounds {
                sphere: s,
                bbox: gbox[i],
            }
        })
        .collect();
    let child_box = t
        .child
        .par_iter()
        .with_min_len(4096)
        .map(|ch| {
            ch.map(|c| {
                if c & LEAF != 0 {
                    leaf[(c & !LEAF) as usize].bbox
                } else {
                    node[c as usize].bbox
                }
            })
        })
        .collect();
    let (wide, wide_of) = collapse(&t.child, &node, &leaf);
    (leaf, node, child_box, wide, wide_of)
}

pub mod blocks;
pub mod boxes;
pub mod sah;
pub use blocks::leaf_blocks;
use boxes::{collapse_boxes, leaf_positions};
pub use boxes::{number_level, BoxNode, LANE_TRIS};
#[cfg(test)]
mod tests;
