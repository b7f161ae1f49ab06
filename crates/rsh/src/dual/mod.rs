//! Dual traversal of the ray hierarchy and the object hierarchy (`accel::bvh::objects`): the
//! thesis's future work (§5.1) built. Instead of pushing every triangle through the ray
//! hierarchy (§3.2.8), (ray node, object node) pairs descend both trees together:
//!
//! 1. test every pair (the node test of eq. 3.16 or the exact cone test, with the object
//!    node's bounding sphere in place of the triangle's; a leaf is a triangle, tested exactly
//!    as in §3.2.8);
//! 2. expand each surviving pair on one side ([`Descent`]): the object side gives the up to 8
//!    children of the node's collapsed node ([`accel::bvh::objects::WideNode`]: descendants of the
//!    binary node, tested against the ray node 8 at a time), the ray side the node's b
//!    children one level down;
//! 3. (level-1 node, triangle) pairs go to the exact final tests (§3.2.9); so do a level-1
//!    node's pairs with the triangles of a small subtree (at most 8, `SMALL_SUBTREE`) that
//!    its rays would otherwise walk one by one.
//!
//! Besides the cone test, every pair's ray node is tested as a *beam* against the object
//! node's box: interval arithmetic over its rays' origins and reciprocal directions bounds
//! each ray's slab entry and exit, so a box that no ray of the node can reach is culled for
//! all of them at once (this is what lets the ray hierarchy cut work on real scenes: the
//! sphere–cone test alone passes most object nodes).
//!
//! Two schedules take the same pairs ([`Schedule`]):
//! - `depth` (the default): every top ray node is one task that
//!   pops its pairs from its own stack, so no pair array is made, a ray node stays in cache
//!   while it walks an object subtree, and an any-hit node whose rays all hit drops out. The
//!   children a ray-side expansion makes, and a collapsed object node's children, are
//!   tested 8 at a time in AVX lanes ([`crate::node8`]), with the scalar test's bits;
//! - `breadth`: one stack of pairs per ray level, each step a
//!   data-parallel test → count → scan → emit over a chunk (the GPU's shape), memory bounded
//!   by the pair budget.
//!
//! Nothing is ever dropped. The closest hit per ray is an atomic minimum over (t, triangle),
//! as in [`crate::traverse`]. Depth first, a ray's work all happens in its top node's task,
//! in one order; level by level, single rays read the hits of earlier steps only (never of
//! their own step's other rays), and the sequence of steps depends only on the pair counts.
//! Either way hits and counts are the same from run to run.

use crate::node8::{self, NodeFields, NodeLanes};
use crate::traverse::{pack, Counters, NodeTest, Traversal};
use accel::bvh::objects::{ObjectTree, LEAF};
use geom::cone::{exact_test, rah_test, ConeSc};
use geom::{intersect, Vec3};
use par::{compress_runs, emit_streams, sort_pairs, Pairs, SortScratch};
use rayon::prelude::*;
use std::sync::atomic::{AtomicU32, Ordering};
use std::time::Instant;

/// With any hit, [`Descent::Size`] expands the object node while its radius is at least
/// this many times the ray node's reach (once with the closest hit): the ray nodes' `reach`
/// is scaled by it.
pub const ANY_HIT_SIZE_RATIO: f32 = 2.0;

/// Which side of a surviving (ray node, inner object node) pair is expanded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Descent {
    /// The larger one (the default): the object node while its sphere's radius is at least
    /// the ray node's reach (origin radius + sin α · its rays' length, capped at the
    /// scene's diagonal; unbounded for wide cones), twice the reach with any hit
    /// (`ANY_HIT_SIZE_RATIO`), else the ray node. Twice against once with any hit (and
    /// `ANY_HIT_BIAS`'s order), on the bench scenes' 512² shadow rays (8/2) and BART
    /// Kitchen's first 4 frames at 512², 3 bounces: Sponza −9.8 % tests, Conference
    /// −10.0 %, Kitchen's shadow rays −4.1 %, Kitchen's frames −5.4 % (three times, tried
    /// with a bias of 8: fewer tests still on Sponza, more time). Closest-hit batches keep
    /// once: twice cost Kitchen's 3-bounce frames 9 % more tests.
    Size,
    /// The object node until it is a triangle, then the ray node.
    ObjectFirst,
    /// The ray node until single rays, then the object node (each ray walks its subtree;
    /// a subtree of at most 8 triangles gets the level-1 node's final tests instead).
    RayFirst,
}

impl Descent {
    /// Every value by its name (as options spell it).
    pub const NAMES: [(&'static str, Descent); 3] = [
        ("ray-first", Descent::RayFirst),
        ("size", Descent::Size),
        ("object-first", Descent::ObjectFirst),
    ];
}

/// In which order the pairs are taken (the same pairs are tested either way, except those an
/// any-hit ray that already hit no longer needs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Schedule {
    /// Each top ray node's pairs depth first on one worker's stack, top nodes in parallel
    /// (the default): no pair array is ever materialised, a ray node's record stays in
    /// cache while it walks an object subtree, and a ray's hits are known to its later
    /// pairs (an any-hit ray that hit drops out). Every ray belongs to one top node, so a
    /// ray's work happens in one task, in one order: hits and counts do not depend on the
    /// schedule of the workers.
    Depth,
    /// Level by level, the GPU's shape: one stack of pairs per ray level; each step tests a
    /// chunk of one stack data-parallel and emits the survivors' expansions (count → scan
    /// → emit), memory bounded by the pair budget.
    Breadth,
}

impl Schedule {
    /// Every value by its name (as options spell it).
    pub const NAMES: [(&'static str, Schedule); 2] =
        [("depth", Schedule::Depth), ("breadth", Schedule::Breadth)];
}

/// A pair waiting on a depth-first task's stack: node `r` of ray level `l ≥ 1`
/// (`levels[l − 1]`; single rays never wait, they walk at once), object node `o`, and what it
/// becomes when it was tested already (with its siblings, in lanes), else `DROP`.
#[derive(Clone, Copy)]
struct Job {
    l: u32,
    r: u32,
    o: u32,
    act: u8,
}

/// One depth-first task's counts (merged in a fixed order: sums and a maximum).
#[derive(Clone)]
struct Tally {
    tests: Vec<[u64; 4]>,
    hits: Vec<[u64; 4]>,
    inner: u64,
    finals: [u64; 4],
    boxes: u64,
    passes: u64,
    peak: u64,
}

impl Tally {
    fn new(levels: usize) -> Tally {
        Tally {
            tests: vec![[0; 4]; levels],
            hits: vec![[0; 4]; levels],
            inner: 0,
            finals: [0; 4],
            boxes: 0,
            passes: 0,
            peak: 0,
        }
    }

    /// One test of a ray node of `levels[li]` (kind `k`) against object node `o`.
    #[inline]
    fn count(&mut self, li: usize, k: usize, pass: bool, o: u32) {
        self.tests[li][k] += 1;
        self.hits[li][k] += pass as u64;
        self.inner += (o & LEAF == 0) as u64;
    }

    fn merge(mut self, o: Tally) -> Tally {
        for (a, b) in self.tests.iter_mut().zip(&o.tests) {
            *a = std::array::from_fn(|k| a[k] + b[k]);
        }
        for (a, b) in self.hits.iter_mut().zip(&o.hits) {
            *a = std::array::from_fn(|k| a[k] + b[k]);
        }
        self.inner += o.inner;
        self.finals = std::array::from_fn(|k| self.finals[k] + o.finals[k]);
        self.boxes += o.boxes;
        self.passes += o.passes;
        self.peak = self.peak.max(o.peak);
        self
    }
}

/// What a pair (ray node `node` of `levels[li]`, object node `o` of sphere radius `d`) that
/// passed its test becomes: a final test (a triangle at level 1), else an expansion of the
/// side `descent` picks (always the ray side against a triangle).
#[inline]
fn action(descent: Descent, node: &RayNode, li: usize, o: u32, d: f32) -> u8 {
    if o & LEAF != 0 {
        return if li == 0 { FINAL } else { RAY };
    }
    let object = match descent {
        Descent::ObjectFirst => true,
        Descent::RayFirst => false,
        Descent::Size => d >= node.reach,
    };
    if object {
        OBJECT
    } else {
        RAY
    }
}

/// A level-1 node meeting an inner object node of at most this many triangles (one collapsed
/// node's worth) when its rays would walk the node one by one ([`Descent`] chose the ray
/// side) tests the triangles exactly instead, 8 rays in lanes (on Sponza's shadow rays: 15 %
/// more final tests, 7 % more tests in all, 9 % less traversal time than the walks). Both
/// schedules do this.
pub const SMALL_SUBTREE: u32 = 8;

/// Whether inner object node `o` holds at most [`SMALL_SUBTREE`] triangles.
#[inline]
fn small(tree: &ObjectTree, o: u32) -> bool {
    let [lo, hi] = tree.range[o as usize];
    hi - lo < SMALL_SUBTREE
}

/// The order in which an object-side expansion's survivors are taken, depth first: by
/// distance along the ray node's cone axis minus this many times their sphere's radius with
/// any hit (shadow rays), nearest first with the closest hit (0). An any-hit ray stops at
/// its first hit, and a large node is the likelier to hold an occluder, so large nodes go
/// first unless they lie far beyond small ones. Tests against nearest first (0), both with
/// [`ANY_HIT_SIZE_RATIO`], on the bench scenes' 512² shadow rays (8/2) and on BART Kitchen's
/// first 4 frames at 512², 3 bounces: 2 gives Sponza −9.7 %, Conference −6.7 %, Kitchen's
/// shadow rays +2.4 %, Kitchen's frames +4.7 %; 8 gives −11.5 %, −7.5 %, +2.2 %, +10.2 %.
const ANY_HIT_BIAS: f32 = 2.0;

/// What a tested pair becomes (on a depth-first stack, `DROP` marks a pair not tested yet).
const DROP: u8 = 0;
const FINAL: u8 = 1;
const RAY: u8 = 2;
const OBJECT: u8 = 3;

/// What the single-ray level reads of each ray (by ray index).
pub struct RaySide<'a> {
    /// Reciprocal directions (the slab tests), by the hierarchy's ray index (what its
    /// `order` holds).
    pub inv_dir: &'a [Vec3],
    /// Origins and t ranges by the same index (level 1's beams read them in order).
    pub org: &'a [Vec3],
    /// Smallest t (with `org`).
    pub t_min: &'a [f32],
    /// Largest t (with `org`).
    pub t_max: &'a [f32],
    /// Ray kinds (the counters).
    pub kind: &'a [u8],
    /// Any hit will do (shadow rays): a ray that hit stops.
    pub any_hit: bool,
}

/// One ray node as the pair tests read it, in one record: its sphere and cone (the node
/// tests of eq. 3.16), its reach (the [`Descent::Size`] rule), its kind, and the node as a
/// *beam* for a conservative interval slab test against object boxes (the interval
/// arithmetic of Boulos et al. 2007's packet tests, applied to the node's rays): the box of
/// its rays' origins, per axis the interval of their reciprocal directions, the smallest
/// t_min and the largest t_max (in the rays' own parameter, which is a distance only for unit
/// directions: `max_t` is the distance, for the cone test).
#[derive(Clone, Copy)]
struct RayNode {
    center: Vec3,
    radius: f32,
    cone: ConeSc,
    max_t: f32,
    reach: f32,
    kind: u8,
    omin: Vec3,
    omax: Vec3,
    ilo: Vec3,
    ihi: Vec3,
    tmin: f32,
    tmax: f32,
}

/// The beam part of a [`RayNode`]: origins' box, reciprocal directions' box, smallest t_min,
/// largest t_max.
type Beam = (Vec3, Vec3, Vec3, Vec3, f32, f32);

/// The smallest beam holding every beam of `it`.
fn beam_union(it: impl Iterator<Item = Beam>) -> Beam {
    let (inf, ninf) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    it.fold((inf, ninf, inf, ninf, f32::INFINITY, 0.0), |a, b| {
        (
            a.0.min(b.0),
            a.1.max(b.1),
            a.2.min(b.2),
            a.3.max(b.3),
            a.4.min(b.4),
            a.5.max(b.5),
        )
    })
}

impl RayNode {
    /// The fields the AVX node tests read ([`crate::node8`]).
    fn fields(&self) -> NodeFields {
        NodeFields {
            center: self.center,
            radius: self.radius,
            axis: self.cone.axis,
            sin: self.cone.sin,
            cos: self.cone.cos,
            wide: self.cone.wide,
            max_t: self.max_t,
            tmin: self.tmin,
            tmax: self.tmax,
            omin: self.omin,
            omax: self.omax,
            ilo: self.ilo,
            ihi: self.ihi,
        }
    }

    /// The cone test (RAH's or the exact one) against sphere `(p, d)`.
    #[inline]
    fn cone_test(&self, test: NodeTest, p: Vec3, d: f32) -> bool {
        match test {
            NodeTest::Rah => rah_test(self.center, self.radius, &self.cone, p, d, self.max_t),
            NodeTest::Exact => exact_test(self.center, self.radius, &self.cone, p, d, self.max_t),
        }
    }

    /// Whether some ray of the node may meet box `b`. Per axis whose reciprocal directions
    /// are finite and of one sign, the earliest entry and the latest exit over every origin
    /// and direction of the node bound each ray's own (interval products, mirrored for
    /// negative directions), widened by far more than their rounding; the other axes do
    /// not restrict.
    #[inline]
    fn beam_test(&self, b: &geom::Aabb) -> bool {
        let (mut tn, mut tf) = (self.tmin, self.tmax);
        for k in 0..3 {
            let (ilo, ihi) = (self.ilo[k], self.ihi[k]);
            if !(ilo.is_finite() && ihi.is_finite()) {
                continue;
            }
            let (near, far, olo, ohi, a, c) = if ilo > 0.0 {
                (b.min[k], b.max[k], self.omin[k], self.omax[k], ilo, ihi)
            } else if ihi < 0.0 {
                (
                    -b.max[k],
                    -b.min[k],
                    -self.omax[k],
                    -self.omin[k],
                    -ihi,
                    -ilo,
                )
            } else {
                continue;
            };
            let e = near - ohi;
            let enter = if e >= 0.0 { e * a } else { e * c };
            let x = far - olo;
            let exit = if x >= 0.0 { x * c } else { x * a };
            let slack = (near.abs().max(far.abs()) + olo.abs().max(ohi.abs())) * c * 1e-6;
            tn = tn.max(enter - slack);
            tf = tf.min(exit + slack);
        }
        tn <= tf
    }
}

mod breadth;
mod depth;

impl Traversal<'_> {
    /// Run the dual traversal over `tree` and the final tests in the order `schedule` takes
    /// the pairs, adding to `c`. `descent` picks the side to expand, `diag` caps unbounded
    /// rays' lengths for [`Descent::Size`].
    pub fn run_dual(
        &self,
        schedule: Schedule,
        tree: &ObjectTree,
        descent: Descent,
        diag: f32,
        rays: &RaySide,
        c: &mut Counters,
    ) {
        let nl = self.h.levels.len();
        c.tests = vec![[0; 4]; nl];
        c.hits = vec![[0; 4]; nl];
        if nl == 0 {
            return;
        }
        match schedule {
            Schedule::Depth => self.depth_first(tree, descent, diag, rays, c),
            Schedule::Breadth => self.level_by_level(tree, descent, diag, rays, c),
        }
    }

    /// Per level, every node's count of rays without a hit yet, and every node's parent one
    /// level up (level 0's parents: the leaf positions'). Nodes are counted in parallel
    /// (level 1 alone has a node per `b` rays of the batch).
    #[allow(clippy::type_complexity)]
    fn open_rays(&self) -> (Vec<Vec<AtomicU32>>, Vec<Vec<u32>>) {
        let levels = &self.h.levels;
        let mut left: Vec<Vec<AtomicU32>> = Vec::with_capacity(levels.len());
        let mut parent: Vec<Vec<u32>> = Vec::with_capacity(levels.len());
        for (li, level) in levels.iter().enumerate() {
            let below = if li == 0 {
                self.h.order.len()
            } else {
                levels[li - 1].len()
            };
            let mut up = vec![0u32; below];
            let count: Vec<AtomicU32> = {
                let out = par::SharedMut(up.as_mut_ptr());
                let lower = left.last();
                (0..level.len())
                    .into_par_iter()
                    .with_min_len(1024)
                    .map(|n| {
                        let out = &out;
                        let mut rays = 0u32;
                        for ch in level.children(n) {
                            // SAFETY: children ranges of distinct nodes are disjoint and
                            // within the level below.
                            unsafe { out.write(ch, n as u32) };
                            rays += match lower {
                                None => {
                                    (self.best[self.h.order[ch] as usize].load(Ordering::Relaxed)
                                        == u64::MAX) as u32
                                }
                                Some(l) => l[ch].load(Ordering::Relaxed),
                            };
                        }
                        AtomicU32::new(rays)
                    })
                    .collect()
            };
            left.push(count);
            parent.push(up);
        }
        (left, parent)
    }

    /// Every level's node records: beams of level 1 from its rays, of each level above
    /// from its children; `diag` caps unbounded rays' lengths in the reach, which any-hit
    /// batches scale by [`ANY_HIT_SIZE_RATIO`].
    fn ray_nodes(&self, rays: &RaySide, diag: f32) -> Vec<Vec<RayNode>> {
        let order = &self.h.order;
        let scale = if rays.any_hit {
            ANY_HIT_SIZE_RATIO
        } else {
            1.0
        };
        let mut out: Vec<Vec<RayNode>> = Vec::with_capacity(self.h.levels.len());
        for (li, level) in self.h.levels.iter().enumerate() {
            let below = out.last();
            let nodes: Vec<RayNode> = (0..level.len())
                .into_par_iter()
                .with_min_len(1024)
                .map(|n| {
                    let beam = match below {
                        None => beam_union(level.children(n).map(|pos| {
                            let r = order[pos] as usize;
                            let (o, i) = (rays.org[r], rays.inv_dir[r]);
                            (o, o, i, i, rays.t_min[r], rays.t_max[r])
                        })),
                        Some(b) => beam_union(level.children(n).map(|c| {
                            let x = &b[c];
                            (x.omin, x.omax, x.ilo, x.ihi, x.tmin, x.tmax)
                        })),
                    };
                    let cone = level.cone_sc(n);
                    let reach = if cone.wide {
                        f32::INFINITY
                    } else {
                        (level.radius[n] + level.max_t[n].min(diag) * cone.sin) * scale
                    };
                    RayNode {
                        center: level.center[n],
                        radius: level.radius[n],
                        cone,
                        max_t: level.max_t[n],
                        reach,
                        kind: level.kind[n] & 3,
                        omin: beam.0,
                        omax: beam.1,
                        ilo: beam.2,
                        ihi: beam.3,
                        tmin: beam.4,
                        tmax: beam.5,
                    }
                })
                .collect();
            debug_assert!(li == 0 || below.is_some());
            out.push(nodes);
        }
        out
    }

    /// What pair (ray node `node` of `levels[li]`, object node `o`) becomes: the node's cone
    /// against the object's sphere, then its rays as a beam against the object's box (both
    /// conservative, so both must pass); a survivor is a final test (a triangle at level 1),
    /// or expands the side `descent` picks (always the ray side against a triangle).
    #[inline]
    fn classify(
        &self,
        tree: &ObjectTree,
        descent: Descent,
        node: &RayNode,
        li: usize,
        o: u32,
    ) -> u8 {
        let ob = tree.bounds(o);
        let (p, d) = (ob.sphere.center, ob.sphere.radius);
        if !node.beam_test(&ob.bbox) || !node.cone_test(self.test, p, d) {
            return DROP;
        }
        action(descent, node, li, o, d)
    }

    /// The ray at leaf position `pos` walks the object subtrees on `stack` (popped from the
    /// top) depth first: a triangle is a final test, an inner node's children get robust
    /// slab tests, the nearer child first. The ray's closest hit so far caps the slabs
    /// (inclusive, so a tie with a smaller triangle id still gets through); with any-hit it
    /// stops at its first hit. Returns the ray's kind, (final tests, slab tests, slab
    /// passes) and whether this walk gave the ray its first hit.
    fn walk_ray(
        &self,
        tree: &ObjectTree,
        rays: &RaySide,
        pos: usize,
        stack: &mut Vec<u32>,
    ) -> (usize, [u64; 3], bool) {
        let r = self.h.order[pos] as usize;
        let kind = rays.kind[r] as usize & 3;
        let mut best = self.best[r].load(Ordering::Relaxed);
        if rays.any_hit && best != u64::MAX {
            // Any hit will do, and the ray has one.
            stack.clear();
            return (kind, [0; 3], false);
        }
        let pre = &self.lanes.pre(pos);
        let inv = rays.inv_dir[r];
        let (mut f, mut b, mut p) = (0u64, 0u64, 0u64);
        // The barycentrics of a hit this walk found (with `best`).
        let mut uv = (0.0, 0.0);
        let had = best;
        while let Some(o) = stack.pop() {
            if rays.any_hit && best != u64::MAX {
                stack.clear();
                break;
            }
            if o & LEAF != 0 {
                let t = o & !LEAF;
                let [a, bb, cc] = self.scene.tris[t as usize];
                f += 1;
                if let Some(hit) = intersect(pre, a, bb, cc) {
                    let key = pack(hit.t, t);
                    if key < best {
                        (best, uv) = (key, (hit.u, hit.v));
                    }
                }
                continue;
            }
            let far = pre.t_max.min(f32::from_bits((best >> 32) as u32));
            let [bx, by] = &tree.child_box[o as usize];
            let slab = |x: u32, b: &geom::Aabb| {
                if x & LEAF != 0 {
                    Some(0.0)
                } else {
                    b.intersect(pre.org, inv, pre.t_min, far).map(|h| h.0)
                }
            };
            let [x, y] = tree.child[o as usize];
            let inner = (x & LEAF == 0) as u64 + (y & LEAF == 0) as u64;
            let (hx, hy) = (slab(x, bx), slab(y, by));
            b += inner;
            p += inner
                - (x & LEAF == 0 && hx.is_none()) as u64
                - (y & LEAF == 0 && hy.is_none()) as u64;
            match (hx, hy) {
                (Some(tx), Some(ty)) => {
                    // Nearer child on top of the stack.
                    if tx <= ty {
                        stack.extend([y, x]);
                    } else {
                        stack.extend([x, y]);
                    }
                }
                (Some(_), None) => stack.push(x),
                (None, Some(_)) => stack.push(y),
                (None, None) => {}
            }
        }
        let first = best < had
            && self.offer(
                r,
                f32::from_bits((best >> 32) as u32),
                best as u32,
                uv.0,
                uv.1,
            );
        (kind, [f, b, p], first)
    }
}

#[cfg(test)]
mod tests;
