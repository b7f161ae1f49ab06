//! Dual traversal of the ray hierarchy and the object hierarchy ([`crate::objects`]): the
//! thesis's future work (§5.1) built. Instead of pushing every triangle through the ray
//! hierarchy (§3.2.8), (ray node, object node) pairs descend both trees together:
//!
//! 1. test every pair (the node test of eq. 3.16 or the exact cone test, with the object
//!    node's bounding sphere in place of the triangle's; a leaf is a triangle, tested exactly
//!    as in §3.2.8);
//! 2. expand each surviving pair on one side ([`Descent`]): the object side gives the up to 8
//!    children of the node's collapsed node ([`crate::objects::WideNode`]: descendants of the
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
use crate::objects::{ObjectTree, LEAF};
use crate::traverse::{pack, Counters, NodeTest, Traversal};
use geom::cone::{exact_test, rah_test, ConeSc};
use geom::{intersect, Vec3};
use par::{compress_runs, emit_streams, sort_pairs, Pairs, SortScratch};
use rayon::prelude::*;
use std::sync::atomic::{AtomicU32, Ordering};
use std::time::Instant;

/// With any hit, [`Descent::Size`] expands the object node while its radius is at least
/// this many times the ray node's reach (once with the closest hit): the ray nodes' `reach`
/// is scaled by it.
const ANY_HIT_SIZE_RATIO: f32 = 2.0;

/// Which side of a surviving (ray node, inner object node) pair is expanded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
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

/// In which order the pairs are taken (the same pairs are tested either way, except those an
/// any-hit ray that already hit no longer needs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
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
const SMALL_SUBTREE: u32 = 8;

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

    /// [`Schedule::Breadth`] over `nl ≥ 1` ray levels. Pairs wait in
    /// one stack per ray level. Each step takes at most a chunk of `budget / max(b, 2)`
    /// pairs from the top of one stack, so its output fits the pair budget: from the lowest
    /// level holding a full chunk, else from the highest level holding any, so steps are
    /// whole waves and no stack holds more than a chunk plus one step's output. The top
    /// level's pairs are made one chunk of top nodes at a time.
    fn level_by_level(
        &self,
        tree: &ObjectTree,
        descent: Descent,
        diag: f32,
        rays: &RaySide,
        c: &mut Counters,
    ) {
        let nl = self.h.levels.len();
        let widest = self
            .h
            .levels
            .iter()
            .flat_map(|l| l.first.windows(2).map(|w| w[1] - w[0]))
            .max()
            .unwrap_or(1);
        let chunk = (self.budget / widest.max(2) as usize).max(1);
        let ray_nodes = self.ray_nodes(rays, diag);
        let nt = self.h.levels[nl - 1].len();
        let mut next_top = 0usize;
        // stacks[L]: pairs at ray level L (0: single rays by leaf position; L ≥ 1: nodes of
        // `levels[L − 1]`).
        let mut stacks: Vec<Pairs> = vec![(Vec::new(), Vec::new()); nl + 1];
        loop {
            if stacks[nl].0.is_empty() && next_top < nt {
                let end = (next_top + chunk).min(nt);
                stacks[nl].0.extend(next_top as u32..end as u32);
                stacks[nl].1.resize(end - next_top, tree.root);
                next_top = end;
            }
            // The lowest level holding a full chunk, else the highest holding any pairs:
            // steps stay large (few passes, each a whole wave), and no stack ever holds
            // more than a chunk plus one step's output.
            let full = stacks.iter().position(|s| s.0.len() >= chunk);
            let Some(l) = full.or_else(|| stacks.iter().rposition(|s| !s.0.is_empty())) else {
                break;
            };
            let held: usize = stacks.iter().map(|s| s.0.len()).sum();
            c.peak_pairs = c.peak_pairs.max(held as u64);
            // Two u32 per pair waiting (ray node, object node).
            c.peak_pair_bytes = c.peak_pair_bytes.max(8 * held as u64);
            let s = &mut stacks[l];
            let at = s.0.len().saturating_sub(chunk);
            let (rn, on) = (s.0.split_off(at), s.1.split_off(at));
            if l == 0 {
                self.ray_step(tree, rays, rn, on, c);
                continue;
            }
            let (below, here) =
                self.node_step(tree, descent, &ray_nodes[l - 1], l - 1, &rn, &on, c);
            for (s, p) in [(l, here), (l - 1, below)] {
                stacks[s].0.extend_from_slice(&p.0);
                stacks[s].1.extend_from_slice(&p.1);
            }
        }
    }

    /// [`Schedule::Depth`] over `nl ≥ 1` ray levels, the final tests among it: every top
    /// ray node is one task that pops pairs from its own stack (`peak_pairs`: the most one
    /// task held). An object node's children are pushed in [`ANY_HIT_BIAS`]'s order
    /// (nearer first along the ray node's cone axis for the closest hit), a ray node's
    /// children in leaf order.
    fn depth_first(
        &self,
        tree: &ObjectTree,
        descent: Descent,
        diag: f32,
        rays: &RaySide,
        c: &mut Counters,
    ) {
        let nl = self.h.levels.len();
        let ray_nodes = self.ray_nodes(rays, diag);
        // Any hit: per node, its rays still without a hit (a node at 0 has no work left),
        // and each node's parent, so a ray's first hit is counted off every node above it.
        // Only the task of the ray's top node touches these (Relaxed atomics, never
        // contended).
        let open = rays.any_hit.then(|| self.open_rays());
        let resolve = |p: usize| {
            if let Some((left, parent)) = &open {
                let mut n = p;
                for (l, up) in left.iter().zip(parent) {
                    n = up[n] as usize;
                    l[n].fetch_sub(1, Ordering::Relaxed);
                }
            }
        };
        let done = |li: usize, n: usize| {
            open.as_ref()
                .is_some_and(|(left, _)| left[li][n].load(Ordering::Relaxed) == 0)
        };
        // Ray nodes as lanes for the children tests (RAH's node test on a CPU with AVX; every
        // level but the top is some node's children).
        let lanes = (self.test == NodeTest::Rah && node8::available()).then(|| {
            ray_nodes[..nl - 1]
                .iter()
                .map(|level| NodeLanes::new(level.len(), |i| level[i].fields()))
                .collect::<Vec<_>>()
        });
        let nt = self.h.levels[nl - 1].len();
        let bias = if rays.any_hit { ANY_HIT_BIAS } else { 0.0 };
        let t = (0..nt)
            .into_par_iter()
            .with_min_len(4)
            .fold(
                || (Tally::new(nl), Vec::<Job>::new(), Vec::<u32>::new()),
                |(mut t, mut stack, mut walk), top| {
                    stack.push(Job {
                        l: nl as u32,
                        r: top as u32,
                        o: tree.root,
                        act: DROP,
                    });
                    while let Some(j) = stack.pop() {
                        t.peak = t.peak.max(stack.len() as u64 + 1);
                        let (r, o) = (j.r as usize, j.o);
                        let li = j.l as usize - 1;
                        let node = &ray_nodes[li][r];
                        let k = node.kind as usize;
                        // An any-hit node whose rays all hit has no work left, whatever
                        // the pair was to become.
                        if done(li, r) {
                            continue;
                        }
                        let a = if j.act != DROP {
                            j.act
                        } else {
                            let a = self.classify(tree, descent, node, li, o);
                            t.count(li, k, a != DROP, o);
                            a
                        };
                        match a {
                            FINAL => {
                                t.finals[k] += self.final_test(r, o & !LEAF, &mut |p| resolve(p))
                            }
                            RAY if li >= 1 && lanes.is_some() => {
                                // The children against the object 8 at a time; the pairs
                                // that pass wait with their action, first child on top.
                                let (cl, lanes) = (li - 1, &lanes.as_ref().unwrap()[li - 1]);
                                let ch = self.h.levels[li].children(r);
                                let ob = tree.bounds(o);
                                let (p, d) = (ob.sphere.center, ob.sphere.radius);
                                let from = stack.len();
                                for x0 in ch.clone().step_by(8) {
                                    let n = (ch.end - x0).min(8);
                                    let m = node8::test8(lanes, x0, p, d, &ob.bbox);
                                    for (i, x) in (x0..x0 + n).enumerate() {
                                        if done(cl, x) {
                                            continue;
                                        }
                                        let cn = &ray_nodes[cl][x];
                                        let pass = m >> i & 1 != 0;
                                        t.count(cl, cn.kind as usize, pass, o);
                                        if pass {
                                            stack.push(Job {
                                                l: li as u32,
                                                r: x as u32,
                                                o,
                                                act: action(descent, cn, cl, o, d),
                                            });
                                        }
                                    }
                                }
                                stack[from..].reverse();
                            }
                            RAY if li == 0 && small(tree, o) => {
                                // A small subtree: its triangles' exact tests, the node's
                                // rays 8 lanes at a time, in leaf order (each of the node's
                                // rays walking it alone would cost more: a walk's set-up, its
                                // slab tests and scalar triangle tests, per ray).
                                let [lo, hi] = tree.range[o as usize];
                                for &tri in &tree.tri_order[lo as usize..=hi as usize] {
                                    if done(li, r) {
                                        break;
                                    }
                                    t.finals[k] += self.final_test(r, tri, &mut |p| resolve(p));
                                }
                            }
                            RAY if li == 0 => {
                                // Single rays: each walks the object's subtree now, first
                                // ray first (the order their pairs would leave the stack).
                                for x in self.h.levels[0].children(r) {
                                    walk.clear();
                                    walk.push(o);
                                    let (kind, w, first) = self.walk_ray(tree, rays, x, &mut walk);
                                    if first {
                                        resolve(x);
                                    }
                                    t.finals[kind] += w[0];
                                    t.boxes += w[1];
                                    t.passes += w[2];
                                }
                            }
                            RAY => {
                                let ch = self.h.levels[li].children(r);
                                stack.extend(ch.rev().map(|x| Job {
                                    l: li as u32,
                                    r: x as u32,
                                    o,
                                    act: DROP,
                                }));
                            }
                            OBJECT => {
                                // The collapsed node's children against the ray node, 8 at
                                // a time (or one by one: the same tests); the survivors wait
                                // with their action, in `ANY_HIT_BIAS`'s order (nearest along
                                // the cone's axis on top with the closest hit).
                                let w = &tree.wide[tree.wide_of[o as usize] as usize];
                                let n = w.count as usize;
                                let m = if lanes.is_some() {
                                    node8::test8_objects(&node.fields(), w)
                                } else {
                                    (0..n).fold(0u8, |m, i| {
                                        let b = tree.bounds(w.child[i]);
                                        let pass = node.beam_test(&b.bbox)
                                            && node.cone_test(
                                                self.test,
                                                b.sphere.center,
                                                b.sphere.radius,
                                            );
                                        m | (pass as u8) << i
                                    })
                                };
                                let mut near = [(0.0f32, 0u32, DROP); 8];
                                let mut ns = 0;
                                for (i, &x) in w.child[..n].iter().enumerate() {
                                    let pass = m >> i & 1 != 0;
                                    t.count(li, k, pass, x);
                                    if pass {
                                        // The child's sphere from the collapsed node's lanes
                                        // (not its own record, elsewhere in memory).
                                        let c = Vec3::new(
                                            w.center[0][i],
                                            w.center[1][i],
                                            w.center[2][i],
                                        );
                                        let along = (c - node.center).dot(node.cone.axis);
                                        let a = action(descent, node, li, x, w.radius[i]);
                                        let key = along - bias * w.radius[i];
                                        // Insertion by key (ties keep the children's order).
                                        let mut at = ns;
                                        while at > 0 && near[at - 1].0 > key {
                                            near[at] = near[at - 1];
                                            at -= 1;
                                        }
                                        near[at] = (key, x, a);
                                        ns += 1;
                                    }
                                }
                                stack.extend(near[..ns].iter().rev().map(|&(_, o, act)| Job {
                                    l: j.l,
                                    r: j.r,
                                    o,
                                    act,
                                }));
                            }
                            _ => {}
                        }
                    }
                    (t, stack, walk)
                },
            )
            .map(|(t, _, _)| t)
            .reduce(|| Tally::new(nl), Tally::merge);
        for li in 0..nl {
            c.tests[li] = t.tests[li];
            c.hits[li] = t.hits[li];
        }
        c.object_tests += t.inner;
        c.final_tests = std::array::from_fn(|k| c.final_tests[k] + t.finals[k]);
        c.ray_box_tests += t.boxes;
        c.ray_box_passes += t.passes;
        c.peak_pairs = c.peak_pairs.max(t.peak);
        let workers = rayon::current_num_threads() as u64;
        let bytes = t.peak * std::mem::size_of::<Job>() as u64 * workers;
        c.peak_pair_bytes = c.peak_pair_bytes.max(bytes);
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

    /// Test (node of `levels[li]`, object node) pairs; run the final tests of the (level-1
    /// node, triangle) survivors and return the expanded pairs: (one ray level down, same
    /// level).
    #[allow(clippy::too_many_arguments)]
    fn node_step(
        &self,
        tree: &ObjectTree,
        descent: Descent,
        nodes: &[RayNode],
        li: usize,
        rn: &[u32],
        on: &[u32],
        c: &mut Counters,
    ) -> (Pairs, Pairs) {
        let level = &self.h.levels[li];
        // Test, decide what each survivor becomes, and count (in the same pass): tests and
        // passes per ray kind, object-node tests apart as well.
        let classify = |node: &RayNode, o: u32| self.classify(tree, descent, node, li, o);
        const BLOCK: usize = 2048;
        let mut action = vec![DROP; rn.len()];
        let (tests, hits, inner) = action
            .par_chunks_mut(BLOCK)
            .enumerate()
            .map(|(b, out)| {
                let (mut t, mut h, mut i) = ([0u64; 4], [0u64; 4], 0u64);
                for (j, a) in out.iter_mut().enumerate() {
                    let (r, o) = (rn[b * BLOCK + j], on[b * BLOCK + j]);
                    let node = &nodes[r as usize];
                    *a = classify(node, o);
                    let k = node.kind as usize;
                    t[k] += 1;
                    h[k] += (*a != DROP) as u64;
                    i += (o & LEAF == 0) as u64;
                }
                (t, h, i)
            })
            .reduce(
                || ([0; 4], [0; 4], 0),
                |a, b| {
                    (
                        std::array::from_fn(|k| a.0[k] + b.0[k]),
                        std::array::from_fn(|k| a.1[k] + b.1[k]),
                        a.2 + b.2,
                    )
                },
            );
        for k in 0..4 {
            c.tests[li][k] += tests[k];
            c.hits[li][k] += hits[k];
        }
        c.object_tests += inner;
        // What the survivors make, in one count pass and one emit pass: (level-1 node,
        // triangle) pairs for the final tests; on the ray side (child, object) for the
        // node's children one level down (leaf positions below level 1); on the object side
        // (node, child) for the collapsed node's children.
        let never = |_| Ok::<(), std::convert::Infallible>(());
        let made = emit_streams(
            action.len(),
            |i| match action[i] {
                FINAL => [1, 0, 0],
                RAY if li == 0 && small(tree, on[i]) => {
                    let [lo, hi] = tree.range[on[i] as usize];
                    [hi - lo + 1, 0, 0]
                }
                RAY => [0, level.children(rn[i] as usize).len() as u32, 0],
                OBJECT => [0, 0, tree.wide[tree.wide_of[on[i] as usize] as usize].count],
                _ => [0; 3],
            },
            never,
            |i, out| match action[i] {
                FINAL => out(0, rn[i], on[i] & !LEAF),
                RAY if li == 0 && small(tree, on[i]) => {
                    let [lo, hi] = tree.range[on[i] as usize];
                    for &tri in &tree.tri_order[lo as usize..=hi as usize] {
                        out(0, rn[i], tri);
                    }
                }
                RAY => {
                    for ch in level.children(rn[i] as usize) {
                        out(1, ch as u32, on[i]);
                    }
                }
                _ => {
                    let w = &tree.wide[tree.wide_of[on[i] as usize] as usize];
                    for &ch in &w.child[..w.count as usize] {
                        out(2, rn[i], ch);
                    }
                }
            },
        );
        let [(fn_, ft), below, here] = match made {
            Ok(m) => m,
            Err(e) => match e {},
        };
        if li == 0 {
            let t0 = Instant::now();
            self.final_tests(&fn_, &ft, c);
            c.final_seconds += t0.elapsed().as_secs_f64();
        }
        (below, here)
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

    /// Single rays (leaf positions) against object nodes: the pairs are sorted by ray, then
    /// each ray walks its object subtrees depth first on its own (a triangle is a final
    /// test, an inner node's children get robust slab tests, the nearer child first). A ray
    /// reads the closest hit of the steps before this one and its own, so the counts do not
    /// depend on scheduling; its hit's t caps the slabs (inclusive, so a tie with a smaller
    /// triangle id still gets through), and with any-hit a ray stops at its first hit.
    fn ray_step(
        &self,
        tree: &ObjectTree,
        rays: &RaySide,
        mut pos: Vec<u32>,
        mut on: Vec<u32>,
        c: &mut Counters,
    ) {
        let t0 = Instant::now();
        let bits = 32 - (self.h.order.len() as u32).leading_zeros();
        sort_pairs(&mut pos, &mut on, bits.max(1), &mut SortScratch::new());
        let mut head = vec![0u32; pos.len()];
        let mut run_ray = vec![0u32; pos.len()];
        let mut run_size = vec![0u32; pos.len()];
        let runs = compress_runs(&pos, &mut run_ray, &mut head, &mut run_size);
        let (finals, boxes, passes) = (0..runs)
            .into_par_iter()
            .with_min_len(256)
            .fold(
                || ([0u64; 4], 0u64, 0u64, Vec::<u32>::new()),
                |(mut f, mut b, mut p, mut stack), k| {
                    let start = head[k] as usize;
                    stack.clear();
                    stack.extend(on[start..start + run_size[k] as usize].iter().rev());
                    let (kind, w, _) = self.walk_ray(tree, rays, run_ray[k] as usize, &mut stack);
                    f[kind] += w[0];
                    b += w[1];
                    p += w[2];
                    (f, b, p, stack)
                },
            )
            .map(|(f, b, p, _)| (f, b, p))
            .reduce(
                || ([0; 4], 0, 0),
                |a, b| {
                    (
                        std::array::from_fn(|k| a.0[k] + b.0[k]),
                        a.1 + b.1,
                        a.2 + b.2,
                    )
                },
            );
        c.final_seconds += t0.elapsed().as_secs_f64();
        c.final_tests = std::array::from_fn(|k| c.final_tests[k] + finals[k]);
        c.ray_box_tests += boxes;
        c.ray_box_passes += passes;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use geom::{Aabb, Pcg32};
    use proptest::prelude::*;

    /// Whether the ray meets the box, in f64 (the slab test without rounding to speak of).
    fn meets(o: Vec3, d: Vec3, t0: f32, t1: f32, b: &Aabb) -> bool {
        let (mut tn, mut tf) = (t0 as f64, t1 as f64);
        for k in 0..3 {
            let (o, d, lo, hi) = (o[k] as f64, d[k] as f64, b.min[k] as f64, b.max[k] as f64);
            if d == 0.0 {
                if o < lo || o > hi {
                    return false;
                }
                continue;
            }
            let (a, c) = ((lo - o) / d, (hi - o) / d);
            tn = tn.max(a.min(c));
            tf = tf.min(a.max(c));
        }
        tn <= tf
    }

    /// A node of `rays` for the beam test alone (its cone fields are not read).
    fn beam_node(rays: &[(Vec3, Vec3, f32, f32)]) -> RayNode {
        let beam = beam_union(
            rays.iter()
                .map(|&(o, d, t0, t1)| (o, o, d.recip(), d.recip(), t0, t1)),
        );
        RayNode {
            center: Vec3::ZERO,
            radius: 0.0,
            cone: ConeSc {
                axis: Vec3::X,
                sin: 1.0,
                cos: 0.0,
                wide: true,
                full: true,
            },
            max_t: rays.iter().map(|r| r.3).fold(0.0, f32::max),
            reach: f32::INFINITY,
            kind: 0,
            omin: beam.0,
            omax: beam.1,
            ilo: beam.2,
            ihi: beam.3,
            tmin: beam.4,
            tmax: beam.5,
        }
    }

    /// A random ray node: a bundle of up to 8 rays (some axis-parallel, some unbounded) with
    /// a random cone, sometimes wide.
    fn random_node(rng: &mut Pcg32, scale: f32) -> RayNode {
        let c = Vec3::new(
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
        ) * scale;
        let axis = rng.unit_vector();
        let spread = rng.range(0.0, 1.0);
        let n = 1 + (rng.next_f32() * 8.0) as usize;
        let flat = (rng.next_f32() * 5.0) as usize;
        let rays: Vec<_> = (0..n)
            .map(|i| {
                let o = c + rng.unit_vector() * spread * scale * 0.1;
                let mut d = (axis + rng.unit_vector() * spread).normalize_or(Vec3::X);
                if i % 2 == 0 && flat < 3 {
                    d[flat] = 0.0;
                    d = d.normalize_or(Vec3::Y);
                }
                let t1 = if rng.next_f32() < 0.3 {
                    f32::INFINITY
                } else {
                    rng.range(0.1, 4.0) * scale
                };
                (o, d, rng.range(0.0, 0.01) * scale, t1)
            })
            .collect();
        let mut node = beam_node(&rays);
        let angle = rng.range(0.0, 2.0);
        node.center = c;
        node.radius = spread * scale * 0.1;
        node.cone = ConeSc {
            axis,
            sin: angle.sin(),
            cos: angle.cos(),
            wide: angle >= std::f32::consts::FRAC_PI_2,
            full: false,
        };
        if rng.next_f32() < 0.2 {
            node.max_t = f32::INFINITY;
        }
        if rng.next_f32() < 0.2 {
            node.tmax = f32::INFINITY;
        }
        node
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(2048))]

        /// Eight nodes in lanes give the scalar tests' answers bit for bit (RAH's cone test and
        /// the beam test), whatever the nodes and the object.
        #[test]
        fn lanes_equal_the_scalar_node_test(seed in 0u64..1_000_000, scale in 0.01f32..1000.0) {
            if !node8::available() {
                testkit::skip("avx2", "this CPU has no AVX: the dual traversal tests nodes one at a time");
                return Ok(());
            }
            let mut rng = Pcg32::new(seed, 11);
            let nodes: Vec<RayNode> = (0..13).map(|_| random_node(&mut rng, scale)).collect();
            let lanes = NodeLanes::new(nodes.len(), |i| nodes[i].fields());
            for _ in 0..16 {
                let lo = Vec3::new(rng.range(-2.0, 2.0), rng.range(-2.0, 2.0), rng.range(-2.0, 2.0)) * scale;
                let ext = Vec3::new(rng.range(0.0, 1.0), rng.range(0.0, 1.0), rng.range(0.0, 1.0)) * scale * rng.range(0.0, 1.0);
                let b = Aabb::new(lo, lo + ext);
                let (p, d) = (b.center(), ext.length() * 0.5);
                // Besides the object's own radius, radii right at each node's cone boundary
                // (where one rounding decides), a few ulps either side.
                let at_boundary = |x: &RayNode| {
                    let cp = p - x.center;
                    let along = cp.dot(x.cone.axis);
                    let radial = (cp - x.cone.axis * along).length();
                    radial * x.cone.cos - along.abs() * x.cone.sin - x.radius - 1e-5 * cp.length()
                };
                let mut radii = vec![d];
                for x in &nodes[..3] {
                    let d0 = at_boundary(x).max(0.0);
                    radii.extend((0..7u32).map(|k| f32::from_bits((d0.to_bits() + k).saturating_sub(3))));
                }
                for d in radii {
                    for first in [0usize, 5] {
                        let m = node8::test8(&lanes, first, p, d, &b);
                        for i in 0..8.min(nodes.len() - first) {
                            let x = &nodes[first + i];
                            let scalar = x.beam_test(&b) && x.cone_test(NodeTest::Rah, p, d);
                            prop_assert_eq!(m >> i & 1 != 0, scalar, "node {} radius {}", first + i, d);
                        }
                    }
                }
            }
        }

        /// One node against a collapsed node's children in lanes gives the scalar tests'
        /// answers bit for bit, lanes past the children masked off: objects near and far,
        /// radii at the node's cone boundary, nodes of every kind.
        #[test]
        fn object_lanes_equal_the_scalar_node_test(seed in 0u64..1_000_000, scale in 0.01f32..1000.0, count in 1usize..9) {
            if !node8::available() {
                testkit::skip("avx2", "this CPU has no AVX: the dual traversal tests nodes one at a time");
                return Ok(());
            }
            let mut rng = Pcg32::new(seed, 13);
            for _ in 0..8 {
                let x = random_node(&mut rng, scale);
                let mut w = crate::objects::WideNode {
                    center: [[0.0; 8]; 3],
                    radius: [0.0; 8],
                    min: [[0.0; 8]; 3],
                    max: [[0.0; 8]; 3],
                    child: [0; 8],
                    count: count as u32,
                };
                let mut objects = Vec::new();
                for i in 0..8 {
                    let lo = Vec3::new(rng.range(-2.0, 2.0), rng.range(-2.0, 2.0), rng.range(-2.0, 2.0)) * scale;
                    let ext = Vec3::new(rng.range(0.0, 1.0), rng.range(0.0, 1.0), rng.range(0.0, 1.0)) * scale * rng.range(0.0, 1.0);
                    let b = Aabb::new(lo, lo + ext);
                    let p = b.center();
                    // Half the lanes right at the node's cone boundary (one rounding decides).
                    let d = if i % 2 == 0 {
                        ext.length() * 0.5
                    } else {
                        let cp = p - x.center;
                        let along = cp.dot(x.cone.axis);
                        let radial = (cp - x.cone.axis * along).length();
                        let d0 = (radial * x.cone.cos - along.abs() * x.cone.sin - x.radius - 1e-5 * cp.length()).max(0.0);
                        f32::from_bits((d0.to_bits() + rng.below(7)).saturating_sub(3))
                    };
                    for k in 0..3 {
                        w.center[k][i] = p[k];
                        w.min[k][i] = b.min[k];
                        w.max[k][i] = b.max[k];
                    }
                    w.radius[i] = d;
                    objects.push((b, p, d));
                }
                let m = node8::test8_objects(&x.fields(), &w);
                for (i, (b, p, d)) in objects.iter().enumerate() {
                    let scalar = i < count && x.beam_test(b) && x.cone_test(NodeTest::Rah, *p, *d);
                    prop_assert_eq!(m >> i & 1 != 0, scalar, "lane {} of {}", i, count);
                }
            }
        }

        /// The beam test never culls a box that one of the node's rays meets: coherent
        /// and incoherent bundles, axis-parallel directions, boxes thin and far.
        #[test]
        fn beam_test_is_conservative(seed in 0u64..1_000_000, n in 1usize..9, spread in 0.0f32..1.0, scale in 0.01f32..1000.0, flat in 0usize..4) {
            let mut rng = Pcg32::new(seed, 7);
            let c = Vec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0)) * scale;
            let axis = rng.unit_vector();
            let rays: Vec<_> = (0..n).map(|i| {
                let o = c + Vec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0)) * spread * scale * 0.1;
                let mut d = (axis + rng.unit_vector() * spread).normalize_or(Vec3::X);
                if i % 3 == 0 && flat < 3 {
                    d[flat] = 0.0;
                    d = d.normalize_or(Vec3::Y);
                }
                let t1 = if rng.next_f32() < 0.3 { f32::INFINITY } else { rng.range(0.1, 4.0) * scale };
                (o, d, rng.range(0.0, 0.01) * scale, t1)
            }).collect();
            let node = beam_node(&rays);
            for _ in 0..16 {
                let lo = Vec3::new(rng.range(-2.0, 2.0), rng.range(-2.0, 2.0), rng.range(-2.0, 2.0)) * scale;
                let mut ext = Vec3::new(rng.range(0.0, 1.0), rng.range(0.0, 1.0), rng.range(0.0, 1.0)) * scale;
                if flat < 3 {
                    ext[flat] = 0.0;
                }
                let b = Aabb::new(lo, lo + ext);
                if rays.iter().any(|&(o, d, t0, t1)| meets(o, d, t0, t1, &b)) {
                    prop_assert!(node.beam_test(&b), "{b:?} culled for {rays:?}");
                }
            }
        }
    }
}
