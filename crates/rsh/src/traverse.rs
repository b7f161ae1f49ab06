//! Top-down traversal (thesis §3.2.8) and the final tests (§3.2.9).
//!
//! Top level: every top node is tested against every mesh's bounding sphere (§3.2.1–3.2.2);
//! the triangles of the meshes that pass become (node, triangle) candidates. Then, level by
//! level: each pair's triangle bounding sphere is tested against its node (eq. 3.16, or the
//! exact sphere–cone test), survivors are compacted (`par::compact_pairs`) and expanded to the
//! node's children. Pairs surviving level 1 give (ray, triangle) exact tests: closest hit per
//! ray by an atomic minimum over (t, triangle id) — the tie rule of the brute-force oracle —
//! so the result does not depend on the order the pairs are processed in.
//!
//! Memory is bounded by `pair_budget` (pairs per buffer): the top-level candidates are made
//! for node chunks × triangle batches (RAH's scene batches) that fit it, and a level whose
//! expansion would exceed it is processed in halves, depth first. No pair is ever dropped.

use crate::build::{Hierarchy, Level};
use geom::cone::{exact_test, rah_test};
use geom::tri8::{intersect8, RayLanes};
use geom::{intersect, Sphere, Vec3};
use par::{compact_pairs, exclusive_scan, SharedMut};
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

/// The conservative test of a node against a triangle's bounding sphere.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NodeTest {
    /// Roger et al.'s test (thesis eq. 3.16); wide cones pass.
    Rah,
    /// Exact distance from the triangle sphere's centre to the node's cone.
    Exact,
}

impl NodeTest {
    /// Every value by its name (as options spell it).
    pub const NAMES: [(&'static str, NodeTest); 2] =
        [("rah", NodeTest::Rah), ("exact", NodeTest::Exact)];
}

/// Scene data the traversal reads.
pub struct SceneData<'a> {
    /// World-space triangles.
    pub tris: &'a [[Vec3; 3]],
    /// Triangle bounding-sphere centres.
    pub tri_center: &'a [Vec3],
    /// Triangle bounding-sphere radii.
    pub tri_radius: &'a [f32],
    /// Prefix offsets of the meshes' triangles.
    pub mesh_first: &'a [u32],
    /// Per-mesh culling spheres (thesis §3.2.2).
    pub mesh_sphere: &'a [Sphere],
}

/// Counts by level (index 0 = level 1) and ray kind.
#[derive(Clone, Debug, Default)]
pub struct Counters {
    /// Node–triangle tests per level and kind.
    pub tests: Vec<[u64; 4]>,
    /// Tests that passed, per level and kind.
    pub hits: Vec<[u64; 4]>,
    /// Final ray–triangle tests per kind.
    pub final_tests: [u64; 4],
    /// Node–mesh-sphere tests at the top level.
    pub mesh_tests: u64,
    /// (Node, mesh) pairs that passed.
    pub mesh_passes: u64,
    /// Triangle batches of the top level.
    pub batches: u64,
    /// Levels halved because their children exceeded the pair budget.
    pub splits: u64,
    /// Seconds in the final tests (the rest of the traversal is the traversal phase).
    pub final_seconds: f64,
    /// Dual traversal: tests of ray nodes against inner object nodes (also in `tests`).
    pub object_tests: u64,
    /// Dual traversal: slab tests of single rays against object-node boxes.
    pub ray_box_tests: u64,
    /// Dual traversal: slab tests that passed.
    pub ray_box_passes: u64,
    /// Dual traversal: the most pairs waiting at once (depth first: on one worker's stack).
    pub peak_pairs: u64,
    /// Dual traversal: the bytes of the pairs waiting at once, at most.
    pub peak_pair_bytes: u64,
}

/// One trace call's traversal: the hierarchy, the scene, the rays' constants and their best
/// hits so far, and the test, culling and budget it runs with.
pub struct Traversal<'a> {
    /// The ray hierarchy.
    pub h: &'a Hierarchy,
    /// The scene's triangles and spheres.
    pub scene: SceneData<'a>,
    /// Per-ray constants of the intersection kernel in leaf order, as lanes of the 8-wide
    /// kernel (lane p: ray `h.order[p]`; [`RayLanes::pre`] gives one ray's record).
    pub lanes: &'a RayLanes,
    /// Per ray, the closest hit so far as (t bits << 32 | triangle), by atomic minimum
    /// (by plain loads and stores where `bary` is kept: one task owns each ray).
    pub best: &'a [AtomicU64],
    /// Per ray (as `best`), the barycentrics of its hit in `best` (u bits << 32 | v bits),
    /// kept where one task does all of a ray's tests ([`crate::dual::Schedule::Depth`]), so
    /// its `best` and these change together (by plain loads and stores) and the records
    /// need not test the triangle again. `None` elsewhere: there, two tasks may improve a
    /// ray's hit at once (an atomic minimum), and the records recompute the barycentrics.
    pub bary: Option<&'a [AtomicU64]>,
    /// The node test.
    pub test: NodeTest,
    /// Cull top nodes by mesh spheres first.
    pub mesh_culling: bool,
    /// Most (node, triangle) pairs held at once.
    pub budget: usize,
}

/// The top level's work units (RAH's scene batches): node chunks of at most `budget` nodes ×
/// triangle ranges grown triangle by triangle while their candidates (the nodes whose test
/// against the triangle's mesh sphere passed, `pass[node · nm + mesh]`) fit the budget; a
/// single triangle is always taken. Both the CPU and the GPU traversal follow this schedule,
/// so their pair streams, and so their counters, are the same.
pub fn batches(
    pass: &[u8],
    nm: usize,
    mesh_first: &[u32],
    budget: usize,
) -> Vec<(std::ops::Range<usize>, std::ops::Range<usize>)> {
    let nt = pass.len().checked_div(nm).unwrap_or(0);
    let ntri = *mesh_first.last().unwrap_or(&0) as usize;
    let mesh_of = |t: usize| mesh_first.partition_point(|&f| f as usize <= t) - 1;
    let mut out = Vec::new();
    let node_chunk = nt.min(budget).max(1);
    for n0 in (0..nt).step_by(node_chunk) {
        let n1 = (n0 + node_chunk).min(nt);
        let mut per_mesh = vec![0u64; nm];
        for n in n0..n1 {
            for m in 0..nm {
                per_mesh[m] += pass[n * nm + m] as u64;
            }
        }
        let mut t0 = 0;
        while t0 < ntri {
            let mut t1 = t0;
            let mut load = 0u64;
            let mut m = mesh_of(t0);
            while t1 < ntri {
                while mesh_first[m + 1] as usize <= t1 {
                    m += 1;
                }
                let cost = per_mesh[m];
                if load + cost > budget as u64 && t1 > t0 {
                    break;
                }
                load += cost;
                t1 += 1;
            }
            out.push((n0..n1, t0..t1));
            t0 = t1;
        }
    }
    out
}

pub use geom::tri::pack;

/// A hit's barycentrics in one word (u bits << 32 | v bits), as [`Traversal::bary`] keeps them.
#[inline]
pub fn pack_uv(u: f32, v: f32) -> u64 {
    (u.to_bits() as u64) << 32 | v.to_bits() as u64
}

/// The barycentrics [`pack_uv`] packed.
#[inline]
pub fn unpack_uv(w: u64) -> (f32, f32) {
    (f32::from_bits((w >> 32) as u32), f32::from_bits(w as u32))
}

#[inline]
fn node_test(test: NodeTest, level: &Level, node: usize, p: Vec3, d: f32) -> bool {
    let k = level.cone_sc(node);
    let (c, r, l) = (level.center[node], level.radius[node], level.max_t[node]);
    match test {
        NodeTest::Rah => rah_test(c, r, &k, p, d, l),
        NodeTest::Exact => exact_test(c, r, &k, p, d, l),
    }
}

fn add4(a: [u64; 4], b: [u64; 4]) -> [u64; 4] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2], a[3] + b[3]]
}

impl Traversal<'_> {
    /// Run the traversal and the final tests, adding to `c`.
    pub fn run(&self, c: &mut Counters) {
        let nl = self.h.levels.len();
        c.tests = vec![[0; 4]; nl];
        c.hits = vec![[0; 4]; nl];
        if nl == 0 {
            return;
        }
        let top = &self.h.levels[nl - 1];
        let nt = top.len();
        let nm = self.scene.mesh_first.len() - 1;
        // Mesh culling at the top level: pass[node · nm + mesh].
        let pass: Vec<u8> = if self.mesh_culling {
            c.mesh_tests += (nt * nm) as u64;
            (0..nt * nm)
                .into_par_iter()
                .map(|i| {
                    let s = &self.scene.mesh_sphere[i % nm];
                    node_test(self.test, top, i / nm, s.center, s.radius) as u8
                })
                .collect()
        } else {
            vec![1; nt * nm]
        };
        c.mesh_passes += pass.iter().map(|&p| p as u64).sum::<u64>();
        for (nodes, tris) in batches(&pass, nm, self.scene.mesh_first, self.budget) {
            self.top_batch(nodes, tris, &pass, nm, c);
        }
    }

    fn mesh_of(&self, t: usize) -> usize {
        self.scene.mesh_first.partition_point(|&f| f as usize <= t) - 1
    }

    /// Candidates (node, triangle) for a node range and triangle range, node-major.
    fn top_batch(
        &self,
        nodes: std::ops::Range<usize>,
        tris: std::ops::Range<usize>,
        pass: &[u8],
        nm: usize,
        c: &mut Counters,
    ) {
        c.batches += 1;
        let (m0, m1) = (self.mesh_of(tris.start), self.mesh_of(tris.end - 1));
        let mf = self.scene.mesh_first;
        let overlap = |m: usize| {
            let a = (mf[m] as usize).max(tris.start);
            let b = (mf[m + 1] as usize).min(tris.end);
            a..b.max(a)
        };
        // The top level tests candidates as it generates them (count survivors → scan →
        // emit survivors), like a GPU kernel would: the candidates themselves are never
        // stored, only the pairs that pass. Counts are the same as testing stored pairs.
        let nl = self.h.levels.len();
        let li = nl - 1;
        let top = &self.h.levels[li];
        let s = &self.scene;
        let test =
            |n: usize, t: usize| node_test(self.test, top, n, s.tri_center[t], s.tri_radius[t]);
        let per_node: Vec<(u32, u32)> = nodes
            .clone()
            .into_par_iter()
            .map(|n| {
                let (mut tested, mut passed) = (0u32, 0u32);
                for m in (m0..=m1).filter(|&m| pass[n * nm + m] != 0) {
                    for t in overlap(m) {
                        tested += 1;
                        passed += test(n, t) as u32;
                    }
                }
                (tested, passed)
            })
            .collect();
        let mut tests = [0u64; 4];
        let mut hits = [0u64; 4];
        for (n, &(t, h)) in nodes.clone().zip(&per_node) {
            let k = top.kind[n] as usize & 3;
            tests[k] += t as u64;
            hits[k] += h as u64;
        }
        c.tests[li] = add4(c.tests[li], tests);
        c.hits[li] = add4(c.hits[li], hits);
        let counts: Vec<u32> = per_node.iter().map(|p| p.1).collect();
        let mut offs = vec![0u32; counts.len()];
        let total = exclusive_scan(&counts, &mut offs) as usize;
        if total == 0 {
            return;
        }
        let mut sn = vec![0u32; total];
        let mut st = vec![0u32; total];
        {
            let (wn, wt) = (SharedMut(sn.as_mut_ptr()), SharedMut(st.as_mut_ptr()));
            nodes
                .clone()
                .into_par_iter()
                .zip(offs.par_iter())
                .for_each(|(n, &o)| {
                    let mut k = o as usize;
                    for m in (m0..=m1).filter(|&m| pass[n * nm + m] != 0) {
                        for t in overlap(m) {
                            if test(n, t) {
                                // SAFETY: node n owns [offs[n], offs[n] + survivors[n]) by the
                                // exclusive scan; the test is deterministic, so it passes the same
                                // candidates as in the counting pass.
                                unsafe {
                                    wn.write(k, n as u32);
                                    wt.write(k, t as u32);
                                }
                                k += 1;
                            }
                        }
                    }
                });
        }
        self.survivors(li, sn, st, c);
    }

    /// Pairs that passed level index `li`: exact tests at level 1, else on to the children.
    fn survivors(&self, li: usize, sn: Vec<u32>, st: Vec<u32>, c: &mut Counters) {
        if li == 0 {
            let t0 = Instant::now();
            self.final_tests(&sn, &st, c);
            c.final_seconds += t0.elapsed().as_secs_f64();
        } else {
            self.expand(li, sn, st, c);
        }
    }

    /// Test the pairs at level index `li`, compact the survivors, then expand or finish.
    fn process(&self, li: usize, nodes: Vec<u32>, tris: Vec<u32>, c: &mut Counters) {
        let level = &self.h.levels[li];
        let s = &self.scene;
        let flags: Vec<u8> = nodes
            .par_iter()
            .zip(tris.par_iter())
            .map(|(&n, &t)| {
                node_test(
                    self.test,
                    level,
                    n as usize,
                    s.tri_center[t as usize],
                    s.tri_radius[t as usize],
                ) as u8
            })
            .collect();
        let (tests, hits) = nodes
            .par_iter()
            .zip(flags.par_iter())
            .fold(
                || ([0u64; 4], [0u64; 4]),
                |(mut t, mut h), (&n, &f)| {
                    let k = level.kind[n as usize] as usize & 3;
                    t[k] += 1;
                    h[k] += f as u64;
                    (t, h)
                },
            )
            .reduce(|| ([0; 4], [0; 4]), |a, b| (add4(a.0, b.0), add4(a.1, b.1)));
        c.tests[li] = add4(c.tests[li], tests);
        c.hits[li] = add4(c.hits[li], hits);
        let m = hits.iter().sum::<u64>() as usize;
        let (mut sn, mut st) = (vec![0u32; m], vec![0u32; m]);
        compact_pairs(&nodes, &tris, &flags, &mut sn, &mut st);
        drop((nodes, tris, flags));
        self.survivors(li, sn, st, c);
    }

    /// Children of the survivors at level index `li` → pairs at `li − 1` (in halves when
    /// they would not fit the budget).
    fn expand(&self, li: usize, sn: Vec<u32>, st: Vec<u32>, c: &mut Counters) {
        let level = &self.h.levels[li];
        let counts: Vec<u32> = sn
            .par_iter()
            .map(|&n| level.first[n as usize + 1] - level.first[n as usize])
            .collect();
        let total: u64 = counts.iter().map(|&x| x as u64).sum();
        if total > self.budget as u64 && sn.len() > 1 {
            c.splits += 1;
            let h = sn.len() / 2;
            self.expand(li, sn[..h].to_vec(), st[..h].to_vec(), c);
            self.expand(li, sn[h..].to_vec(), st[h..].to_vec(), c);
            return;
        }
        let mut offs = vec![0u32; counts.len()];
        exclusive_scan(&counts, &mut offs);
        let total = total as usize;
        let (mut cn, mut ct) = (vec![0u32; total], vec![0u32; total]);
        {
            let (wn, wt) = (SharedMut(cn.as_mut_ptr()), SharedMut(ct.as_mut_ptr()));
            (0..sn.len()).into_par_iter().for_each(|j| {
                let n = sn[j] as usize;
                for (k, child) in level.children(n).enumerate() {
                    // SAFETY: survivor j owns [offs[j], offs[j] + counts[j]).
                    unsafe {
                        wn.write(offs[j] as usize + k, child as u32);
                        wt.write(offs[j] as usize + k, st[j]);
                    }
                }
            });
        }
        drop((sn, st));
        self.process(li - 1, cn, ct, c);
    }

    /// Level-1 survivors: every ray of the node against the triangle (§3.2.9).
    pub(crate) fn final_tests(&self, sn: &[u32], st: &[u32], c: &mut Counters) {
        let l1 = &self.h.levels[0];
        let tests = sn
            .par_iter()
            .zip(st.par_iter())
            .with_min_len(64)
            .fold(
                || [0u64; 4],
                |mut acc, (&n, &t)| {
                    acc[l1.kind[n as usize] as usize & 3] +=
                        self.final_test(n as usize, t, &mut |_| {});
                    acc
                },
            )
            .reduce(|| [0; 4], add4);
        c.final_tests = add4(c.final_tests, tests);
    }

    /// Offer ray `r` the hit (distance `t`, triangle `tri`, barycentrics `u`, `v`): the
    /// closest so far wins by atomic minimum (with [`Traversal::bary`], a winner's
    /// barycentrics are kept with it). Returns whether the ray had no hit before.
    #[inline]
    pub(crate) fn offer(&self, r: usize, t: f32, tri: u32, u: f32, v: f32) -> bool {
        let key = pack(t, tri);
        match self.bary {
            Some(bary) => {
                // One task does all of this ray's tests: a plain load and store (no locked
                // compare-and-swap loop, which an atomic minimum is on x86).
                let before = self.best[r].load(Ordering::Relaxed);
                if key < before {
                    self.best[r].store(key, Ordering::Relaxed);
                    bary[r].store(pack_uv(u, v), Ordering::Relaxed);
                }
                before == u64::MAX
            }
            None => self.best[r].fetch_min(key, Ordering::Relaxed) == u64::MAX,
        }
    }

    /// The exact tests of level-1 node `n`'s rays against triangle `t`, closest hits by
    /// atomic minimum; `first` is told the leaf position of every ray that had no hit
    /// before. Returns the tests made (the node's rays).
    #[inline]
    pub(crate) fn final_test(&self, n: usize, t: u32, first: &mut impl FnMut(usize)) -> u64 {
        let [a, b, cc] = self.scene.tris[t as usize];
        let leaves = self.h.levels[0].children(n);
        let order = &self.h.order;
        // The node's rays 8 lanes at a time: the vector test rejects misses, the scalar
        // kernel decides the rest (every lane without AVX).
        let mut p = leaves.start;
        while p < leaves.end {
            let k = (leaves.end - p).min(8);
            let redo = intersect8(self.lanes, p, k, a, b, cc);
            for_lanes(redo, |l| {
                let r = order[p + l] as usize;
                if let Some(hit) = intersect(&self.lanes.pre(p + l), a, b, cc) {
                    if self.offer(r, hit.t, t, hit.u, hit.v) {
                        first(p + l);
                    }
                }
            });
            p += k;
        }
        leaves.len() as u64
    }
}

/// Call `f` with the index of every set bit of `m`, lowest first.
#[inline]
fn for_lanes(mut m: u8, mut f: impl FnMut(usize)) {
    while m != 0 {
        f(m.trailing_zeros() as usize);
        m &= m - 1;
    }
}
