//! Dual traversal of the ray hierarchy and the object hierarchy ([`crate::objects`]): the
//! thesis's future work (§5.1) built. Instead of pushing every triangle through the ray
//! hierarchy (§3.2.8), (ray node, object node) pairs descend both trees together:
//!
//! 1. test every pair (the node test of eq. 3.16 or the exact cone test, with the object
//!    node's bounding sphere in place of the triangle's; a leaf is a triangle, tested exactly
//!    as in §3.2.8);
//! 2. expand each surviving pair on one side ([`Descent`]): the object side gives the node's
//!    2 children, the ray side the node's b children one level down;
//! 3. (level-1 node, triangle) pairs go to the exact final tests (§3.2.9).
//!
//! Pairs wait in one stack per ray level. The loop always works on the lowest level that has
//! pairs, taking at most `budget / max(b, 2)` of them from the top of its stack, so every
//! step's output fits the pair budget and the stacks stay shallow (depth first); the top
//! level's pairs are made one chunk of top nodes at a time. Nothing is ever dropped. The
//! closest hit per ray is an atomic minimum over (t, triangle), as in [`crate::traverse`],
//! so the order pairs are processed in changes neither the hits nor the counts.

use crate::objects::{ObjectTree, LEAF};
use crate::traverse::{node_test, pack, Counters, Traversal};
use geom::{intersect, Vec3};
use par::{compress_runs, exclusive_scan, sort_pairs, SharedMut, SortScratch};
use rayon::prelude::*;
use std::sync::atomic::Ordering;
use std::time::Instant;

/// Which side of a surviving (ray node, inner object node) pair is expanded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum Descent {
    /// The larger one: the object node while its sphere's radius is at least the ray node's
    /// reach (origin radius + sin α · its rays' length, capped at the scene's diagonal;
    /// unbounded for wide cones), else the ray node.
    Size,
    /// The object node until it is a triangle, then the ray node.
    ObjectFirst,
    /// The ray node until level 1, then the object node.
    RayFirst,
}

/// What a tested pair becomes.
const DROP: u8 = 0;
const FINAL: u8 = 1;
const RAY: u8 = 2;
const OBJECT: u8 = 3;

/// What the single-ray level reads of each ray (by ray index).
pub struct RaySide<'a> {
    /// Reciprocal directions (the slab tests).
    pub inv_dir: &'a [Vec3],
    /// Ray kinds (the counters).
    pub kind: &'a [u8],
    /// Any hit will do (shadow rays): a ray that hit stops.
    pub any_hit: bool,
}

/// Pairs of one ray level: (ray node or leaf position, object node).
type Pairs = (Vec<u32>, Vec<u32>);

impl Traversal<'_> {
    /// Run the dual traversal over `tree` and the final tests, adding to `c`; `descent` picks
    /// the side to expand, `diag` caps unbounded rays' lengths for [`Descent::Size`].
    pub fn run_dual(
        &self,
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
        let widest = self
            .h
            .levels
            .iter()
            .flat_map(|l| l.first.windows(2).map(|w| w[1] - w[0]))
            .max()
            .unwrap_or(1);
        let chunk = (self.budget / widest.max(2) as usize).max(1);
        let nt = self.h.levels[nl - 1].len();
        let mut next_top = 0usize;
        // stacks[L]: pairs at ray level L (0: single rays by leaf position; L ≥ 1: nodes of
        // `levels[L − 1]`).
        let mut stacks: Vec<Pairs> = vec![(Vec::new(), Vec::new()); nl + 1];
        loop {
            let Some(l) = stacks.iter().position(|s| !s.0.is_empty()) else {
                if next_top == nt {
                    break;
                }
                let end = (next_top + chunk).min(nt);
                stacks[nl].0.extend(next_top as u32..end as u32);
                stacks[nl].1.resize(end - next_top, tree.root);
                next_top = end;
                continue;
            };
            let held: usize = stacks.iter().map(|s| s.0.len()).sum();
            c.peak_pairs = c.peak_pairs.max(held as u64);
            let s = &mut stacks[l];
            let at = s.0.len().saturating_sub(chunk);
            let (rn, on) = (s.0.split_off(at), s.1.split_off(at));
            if l == 0 {
                self.ray_step(tree, rays, &rn, &on, c);
                continue;
            }
            let (below, here) = self.node_step(tree, descent, diag, l - 1, &rn, &on, c);
            let s = &mut stacks[l];
            s.0.extend_from_slice(&here.0);
            s.1.extend_from_slice(&here.1);
            if l > 0 {
                let s = &mut stacks[l - 1];
                s.0.extend_from_slice(&below.0);
                s.1.extend_from_slice(&below.1);
            }
        }
    }

    /// Test (node of `levels[li]`, object node) pairs; run the final tests of the (level-1
    /// node, triangle) survivors and return the expanded pairs: (one ray level down, same
    /// level).
    #[allow(clippy::too_many_arguments)]
    fn node_step(
        &self,
        tree: &ObjectTree,
        descent: Descent,
        diag: f32,
        li: usize,
        rn: &[u32],
        on: &[u32],
        c: &mut Counters,
    ) -> (Pairs, Pairs) {
        let level = &self.h.levels[li];
        let s = &self.scene;
        let reach = |n: usize| {
            if level.angle[n] >= std::f32::consts::FRAC_PI_2 {
                f32::INFINITY
            } else {
                level.radius[n] + level.max_t[n].min(diag) * level.sin[n]
            }
        };
        // Test, and decide what each survivor becomes.
        let action: Vec<u8> = rn
            .par_iter()
            .zip(on.par_iter())
            .with_min_len(256)
            .map(|(&r, &o)| {
                let r = r as usize;
                let leaf = o & LEAF != 0;
                let (p, d) = if leaf {
                    let t = (o & !LEAF) as usize;
                    (s.tri_center[t], s.tri_radius[t])
                } else {
                    (tree.center[o as usize], tree.radius[o as usize])
                };
                if !node_test(self.test, level, r, p, d) {
                    return DROP;
                }
                if leaf {
                    return if li == 0 { FINAL } else { RAY };
                }
                let object = match descent {
                    Descent::ObjectFirst => true,
                    Descent::RayFirst => false,
                    Descent::Size => d >= reach(r),
                };
                if object {
                    OBJECT
                } else {
                    RAY
                }
            })
            .collect();
        // Counters: tests and passes per ray kind; object-node tests apart as well.
        let (tests, hits, inner) = rn
            .par_iter()
            .zip(on.par_iter())
            .zip(action.par_iter())
            .with_min_len(4096)
            .fold(
                || ([0u64; 4], [0u64; 4], 0u64),
                |(mut t, mut h, mut i), ((&r, &o), &a)| {
                    let k = level.kind[r as usize] as usize & 3;
                    t[k] += 1;
                    h[k] += (a != DROP) as u64;
                    i += (o & LEAF == 0) as u64;
                    (t, h, i)
                },
            )
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
        // Final tests of the level-1 survivors with triangles.
        let (fn_, ft) = emit(
            &action,
            |_, a| (a == FINAL) as u32,
            |i, _, out| out(rn[i], on[i] & !LEAF),
        );
        if !fn_.is_empty() {
            let t0 = Instant::now();
            self.final_tests(&fn_, &ft, c);
            c.final_seconds += t0.elapsed().as_secs_f64();
        }
        // Ray side: (child, object) for the node's children one level down (leaf positions
        // below level 1).
        let below = emit(
            &action,
            |i, a| {
                if a == RAY {
                    level.children(rn[i] as usize).len() as u32
                } else {
                    0
                }
            },
            |i, _, out| {
                for ch in level.children(rn[i] as usize) {
                    out(ch as u32, on[i]);
                }
            },
        );
        // Object side: (node, child) for both children.
        let here = emit(
            &action,
            |_, a| 2 * (a == OBJECT) as u32,
            |i, _, out| {
                for ch in tree.child[on[i] as usize] {
                    out(rn[i], ch);
                }
            },
        );
        (below, here)
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
        pos: &[u32],
        on: &[u32],
        c: &mut Counters,
    ) {
        let t0 = Instant::now();
        let (mut pos, mut on) = (pos.to_vec(), on.to_vec());
        let bits = 32 - (self.h.order.len() as u32).leading_zeros();
        sort_pairs(&mut pos, &mut on, bits.max(1), &mut SortScratch::new());
        let mut head = vec![0u32; pos.len()];
        let mut run_ray = vec![0u32; pos.len()];
        let mut run_size = vec![0u32; pos.len()];
        let runs = compress_runs(&pos, &mut run_ray, &mut head, &mut run_size);
        let order = &self.h.order;
        let (finals, boxes, passes) = (0..runs)
            .into_par_iter()
            .with_min_len(64)
            .fold(
                || ([0u64; 4], 0u64, 0u64, Vec::<u32>::new()),
                |(mut f, mut b, mut p, mut stack), k| {
                    let r = order[run_ray[k] as usize] as usize;
                    let kind = rays.kind[r] as usize & 3;
                    let pre = &self.pre[r];
                    let inv = rays.inv_dir[r];
                    let mut best = self.best[r].load(Ordering::Relaxed);
                    let start = head[k] as usize;
                    stack.clear();
                    stack.extend(on[start..start + run_size[k] as usize].iter().rev());
                    while let Some(o) = stack.pop() {
                        if rays.any_hit && best != u64::MAX {
                            break;
                        }
                        if o & LEAF != 0 {
                            let t = o & !LEAF;
                            let [a, bb, cc] = self.scene.tris[t as usize];
                            f[kind] += 1;
                            if let Some(hit) = intersect(pre, a, bb, cc) {
                                best = best.min(pack(hit.t, t));
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
                    if best != u64::MAX {
                        self.best[r].fetch_min(best, Ordering::Relaxed);
                    }
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

/// Pairs through count → exclusive scan → emit: `count(i, action)` says how many pairs item
/// i makes, `make(i, action, out)` writes them in the same order.
fn emit(
    action: &[u8],
    count: impl Fn(usize, u8) -> u32 + Sync,
    make: impl Fn(usize, u8, &mut dyn FnMut(u32, u32)) + Sync,
) -> (Vec<u32>, Vec<u32>) {
    let counts: Vec<u32> = action
        .par_iter()
        .enumerate()
        .with_min_len(4096)
        .map(|(i, &a)| count(i, a))
        .collect();
    let mut offs = vec![0u32; counts.len()];
    let total = exclusive_scan(&counts, &mut offs) as usize;
    let (mut xs, mut ys) = (vec![0u32; total], vec![0u32; total]);
    let (xp, yp) = (SharedMut(xs.as_mut_ptr()), SharedMut(ys.as_mut_ptr()));
    action
        .par_iter()
        .enumerate()
        .with_min_len(1024)
        .filter(|(i, _)| counts[*i] != 0)
        .for_each(|(i, &a)| {
            let mut k = offs[i] as usize;
            let end = k + counts[i] as usize;
            make(i, a, &mut |x, y| {
                assert!(k < end, "emit made more pairs than it counted");
                // SAFETY: item i owns [offs[i], offs[i] + counts[i]) by the exclusive scan.
                unsafe {
                    xp.write(k, x);
                    yp.write(k, y);
                }
                k += 1;
            });
        });
    (xs, ys)
}
