//! The dual traversal on the device, level by level: the twin of `crates/rsh/src/dual/`
//! (`breadth.rs`'s schedule, `mod.rs`'s ray nodes, pair tests and single-ray walks;
//! kernels in `dual.wgsl`). CRSH's or RAH's ray hierarchy and the object tree (the LBVH
//! built on the device, [`crate::bvh::objects`]) descend together as (ray node, object node)
//! pairs, the thesis's future work (§5.1) on the GPU it was written for.
//!
//! The host keeps the CPU's schedule exactly: one stack of pairs per ray level, each step a
//! chunk of `pair budget / widest node` pairs from the lowest level holding a full chunk,
//! else from the highest holding any. A step at a ray level ≥ 1 is test → count → scan →
//! emit on the device (`dual_classify`, [`Exec::scan`], `dual_emit`): its final tests go
//! to `final.wgsl`'s kernel at once, its other two streams onto the stacks. A step of
//! single rays sorts its pairs by ray ([`Exec::sort_pairs_all`]) and walks each ray's run in
//! the thread of its first pair (`dual_walk`). A step of ray nodes reads back its three
//! stream sizes (the schedule depends on them), a step of single rays nothing; the pairs
//! stay on the device. So hits and every counter are the CPU's `--schedule breadth` with the same
//! object builder (the LBVH), tested on lavapipe (`tests/device/dual.rs`).

use super::build::{Laid, Level};
use super::device_scene::DeviceScene;
use super::traverse::GpuTraversal;
use crate::bvh::objects::DeviceTree;
use crate::kernels::params::{DualBeamParams, DualPairParams, DualWalkParams, PermuteParams};
use crate::kernels::{launch, Exec, Threads};
use crate::rays::DeviceRays;
use ::rsh::dual::{ANY_HIT_SIZE_RATIO, SMALL_SUBTREE};
use ::rsh::traverse::Counters;
use ::rsh::{Descent, NodeTest};
use accel::bvh::objects::LEAF;

mod rounds;
pub use rounds::{rounds_cap, ROUNDS};

// `dual.wgsl` writes the CPU's small-subtree rule with this constant.
const _: () = assert!(SMALL_SUBTREE == 8, "dual.wgsl's SMALL_SUBTREE is 8");

/// One trace call's dual traversal: the scene, its object tree, the ray hierarchy and rays.
pub struct GpuDual<'a> {
    /// The engine (scene buffers, configuration).
    pub eng: &'a DeviceScene,
    /// The object tree of the frame.
    pub tree: &'a DeviceTree,
    /// The ray hierarchy, level 1 first (at least one level).
    pub levels: &'a [Level],
    /// The rays.
    pub rays: &'a DeviceRays,
    /// The sorted leaves: ray index by leaf position.
    pub leaves: &'a wgpu::Buffer,
    /// Leaves (rays in the hierarchy).
    pub m: u64,
    /// Per ray, the closest hit so far as (t bits << 32 | triangle), by 64-bit atomic min.
    pub best: &'a wgpu::Buffer,
    /// The counters on the device, zeroed ([`GpuDual::counter_words`] words of 64-bit
    /// (low, high) counters): per level 16 words from 16 · level (tests, then passes, per
    /// kind), then from 16 · levels the final tests per kind, the tests against inner
    /// object nodes, the single rays' slab tests, their passes, the walks that overflowed
    /// their stack and (one word) the most pairs held at once by the device's rounds.
    pub counters: &'a wgpu::Buffer,
    /// Any hit will do (shadow rays): a ray that hit stops.
    pub any: bool,
    /// The scene's diagonal (caps unbounded rays in the [`Descent::Size`] rule).
    pub diag: f32,
    /// The device rounds' per-pass rounds ([`ROUNDS`]) and a bound on their buffers
    /// (`None`: their own; tests make traces take many passes or overflow).
    pub rounds: (usize, Option<u64>),
    /// The hierarchy as the device laid it out ([`super::build::build_laid`]): the
    /// traversal is then one pass of rounds that the host never looks at; whether it
    /// finished is read with the counters ([`GpuDual::outcome`]). `None`: the host paces it.
    pub laid: Option<&'a Laid>,
    /// The pairs the rounds' buffers are to hold: 8 per leaf, or as the engine grew it
    /// after a device-laid trace overflowed ([`rounds_cap`]).
    pub room: u64,
}

/// How a device-laid traversal ended ([`GpuDual::outcome`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Outcome {
    /// A round's output passed its buffers (nothing after it ran).
    pub overflowed: bool,
    /// The single rays' step ran (else the pass's rounds did not reach it).
    pub walked: bool,
    /// The most rounds one ray level took.
    pub most_rounds: u32,
    /// The hierarchy's levels (the layout's bound may be more).
    pub levels: usize,
    /// The top level's nodes.
    pub top: u64,
    /// CRSH's chunks where its order was laid out on the device (else 0).
    pub chunks: u64,
}

impl Outcome {
    /// Whether every pair was traversed (the hits and counts are the CPU's).
    pub fn finished(&self) -> bool {
        !self.overflowed && self.walked
    }
}

/// A stack of (ray node, object node) pairs on the device; its length lives on the host.
struct Stack {
    bufs: Option<(wgpu::Buffer, wgpu::Buffer)>,
    len: u64,
    cap: u64,
}

impl Stack {
    fn new() -> Stack {
        Stack {
            bufs: None,
            len: 0,
            cap: 0,
        }
    }

    /// Append `n` pairs of `(ray, obj)` from element `from` on.
    fn push(&mut self, ex: &mut Exec, src: (&wgpu::Buffer, &wgpu::Buffer), from: u64, n: u64) {
        if n == 0 {
            return;
        }
        if self.len + n > self.cap {
            let cap = (self.len + n).max(2 * self.cap).max(1024);
            let grown = (
                ex.g.storage("dual stack: ray nodes", cap * 4),
                ex.g.storage("dual stack: object nodes", cap * 4),
            );
            if let Some((r, o)) = &self.bufs {
                ex.copy(r, 0, &grown.0, self.len * 4);
                ex.copy(o, 0, &grown.1, self.len * 4);
            }
            self.bufs = Some(grown);
            self.cap = cap;
        }
        let (r, o) = self.bufs.as_ref().unwrap();
        ex.copy_at(src.0, from * 4, r, self.len * 4, n * 4);
        ex.copy_at(src.1, from * 4, o, self.len * 4, n * 4);
        self.len += n;
    }

    /// Take the top `chunk` pairs (fewer when the stack holds fewer), in stack order.
    fn take(&mut self, ex: &mut Exec, chunk: u64) -> (wgpu::Buffer, wgpu::Buffer, u64) {
        let at = self.len.saturating_sub(chunk);
        let n = self.len - at;
        let out = (
            ex.g.storage("dual step: ray nodes", n * 4),
            ex.g.storage("dual step: object nodes", n * 4),
        );
        let (r, o) = self
            .bufs
            .as_ref()
            .expect("a stack that holds pairs has buffers");
        ex.copy_at(r, at * 4, &out.0, 0, n * 4);
        ex.copy_at(o, at * 4, &out.1, 0, n * 4);
        self.len = at;
        (out.0, out.1, n)
    }
}

/// The words of `buf` at the element indices `at`, in one read-back.
fn read_words(ex: &mut Exec, buf: &wgpu::Buffer, at: &[u64]) -> Vec<u32> {
    let tmp = ex.g.storage("dual sizes", at.len() as u64 * 4);
    for (j, &i) in at.iter().enumerate() {
        ex.copy_at(buf, i * 4, &tmp, j as u64 * 4, 4);
    }
    ex.read(&tmp, at.len())
}

impl GpuDual<'_> {
    /// Words of the counter buffer for a hierarchy of `levels` levels.
    pub fn counter_words(levels: usize) -> u64 {
        16 * levels as u64 + 24
    }

    /// The first word of the counters after the levels'.
    fn tail(&self) -> u32 {
        16 * self.levels.len() as u32
    }

    /// The most children of any node of any level: each kind's nodes take `b` children
    /// but the last, which takes the rest (`build`'s layout, the CPU's); `b` where the
    /// device laid the levels out (a smaller chunk: the rounds' bound stays below the CPU's).
    fn widest(&self) -> usize {
        let b = self.eng.cfg.branching;
        if self.laid.is_some() {
            return b as usize;
        }
        self.levels
            .iter()
            .flat_map(|l| l.children)
            .filter(|&c| c > 0)
            .map(|c| c.min(b))
            .max()
            .unwrap_or(1) as usize
    }

    /// Run the traversal and the final tests, as `rsh`'s `level_by_level`: by the device's
    /// rounds where they keep its schedule (`dual/rounds.rs`), else (or when a round overflows
    /// its buffers, after which the trace starts again) by the host's steps. The device's
    /// counts stay in [`GpuDual::counters`] (read them with [`GpuDual::counts`]); the host
    /// steps' peaks go into `c` now.
    pub fn run(&self, ex: &mut Exec, c: &mut Counters) {
        let nl = self.levels.len();
        ex.phase(trace::TRAVERSAL);
        let chunk = (self.eng.cfg.pair_budget / self.widest().max(2)).max(1) as u64;
        let beams = self.beams(ex);
        if self.laid.is_some() {
            let cap = self
                .round_cap(chunk)
                .expect("a device-laid trace fits the rounds (GpuRsh checks)");
            self.run_rounds(ex, &beams, cap);
            return;
        }
        if let Some(cap) = self.round_cap(chunk) {
            if self.run_rounds(ex, &beams, cap) {
                return;
            }
            // Overflowed: every count and hit of the rounds is dropped, and the host's
            // steps trace the batch from the start.
            ex.clear(self.counters);
            ex.run(
                launch::Fill { y_a: self.best },
                PermuteParams {
                    n: 2 * self.rays.len as u32,
                    value: u32::MAX,
                },
                2 * self.rays.len,
                256,
            );
        }
        let nt = self.levels[nl - 1].len() as u64;
        let root = if self.tree.leaves == 1 { LEAF } else { 0 };
        let mut next_top = 0u64;
        // stacks[L]: pairs at ray level L (0: single rays by leaf position; L ≥ 1: nodes of
        // `levels[L − 1]`).
        let mut stacks: Vec<Stack> = (0..=nl).map(|_| Stack::new()).collect();
        loop {
            if stacks[nl].len == 0 && next_top < nt {
                let end = (next_top + chunk).min(nt);
                let ray: Vec<u32> = (next_top as u32..end as u32).collect();
                let top = (
                    ex.g.upload("dual top nodes", &ray),
                    ex.g.upload("dual top roots", &vec![root; ray.len()]),
                );
                stacks[nl].push(ex, (&top.0, &top.1), 0, end - next_top);
                next_top = end;
            }
            let full = stacks.iter().position(|s| s.len >= chunk);
            let Some(l) = full.or_else(|| stacks.iter().rposition(|s| s.len > 0)) else {
                break;
            };
            let held: u64 = stacks.iter().map(|s| s.len).sum();
            c.peak_pairs = c.peak_pairs.max(held);
            // Two u32 per pair waiting (ray node, object node).
            c.peak_pair_bytes = c.peak_pair_bytes.max(8 * held);
            let (rn, on, n) = stacks[l].take(ex, chunk);
            if l == 0 {
                self.ray_step(ex, &(rn, on), n);
                continue;
            }
            let (below, here, [nb, nh]) = self.node_step(ex, &beams, l, &(rn, on), n);
            stacks[l].push(ex, (&here.0, &here.1), 0, nh);
            stacks[l - 1].push(ex, (&below.0, &below.1), 0, nb);
        }
    }

    /// The counter block's words `w` (of a hierarchy of `levels` levels) into `c`; returns
    /// the walks' stack overflows (none in any LBVH).
    pub fn counts(w: &[u32], levels: usize, c: &mut Counters) -> u64 {
        let nl = levels;
        let at = |i: usize| w[i] as u64 | (w[i + 1] as u64) << 32;
        for li in 0..nl {
            for k in 0..4 {
                c.tests[li][k] += at(16 * li + 2 * k);
                c.hits[li][k] += at(16 * li + 8 + 2 * k);
            }
        }
        let t = 16 * nl;
        for k in 0..4 {
            c.final_tests[k] += at(t + 2 * k);
        }
        c.object_tests += at(t + 8);
        c.ray_box_tests += at(t + 10);
        c.ray_box_passes += at(t + 12);
        // The rounds' peak (zero where the host's steps counted it in `c`).
        c.peak_pairs = c.peak_pairs.max(w[t + 16] as u64);
        c.peak_pair_bytes = 8 * c.peak_pairs;
        at(t + 14)
    }

    /// How the traversal whose counter block is `w` (of `levels` levels laid out) ended:
    /// words 16 · levels + 17.. (the rounds' overflow flag, walked, most rounds a level
    /// took; for a device-laid hierarchy, its levels and top nodes, and CRSH's chunks).
    pub fn outcome(w: &[u32], levels: usize) -> Outcome {
        let t = 16 * levels;
        Outcome {
            overflowed: w[t + 17] != 0,
            walked: w[t + 18] != 0,
            most_rounds: w[t + 19],
            levels: w[t + 20] as usize,
            top: w[t + 21] as u64,
            chunks: w[t + 22] as u64,
        }
    }

    /// Every level's beams and reaches (`Traversal::ray_nodes`): level 1's from its rays,
    /// each level above from its children's.
    fn beams(&self, ex: &mut Exec) -> Vec<wgpu::Buffer> {
        let scale = if self.any { ANY_HIT_SIZE_RATIO } else { 1.0 };
        let mut out: Vec<wgpu::Buffer> = Vec::with_capacity(self.levels.len());
        for lv in self.levels {
            let nodes = lv.cap;
            let beam = ex.g.storage("dual beams", nodes as u64 * 64);
            let prm = DualBeamParams {
                nodes,
                scale,
                diag: self.diag,
            };
            let threads = match &lv.sized {
                Some(s) => Threads::Device { first: s, over: s },
                None => Threads::Host(nodes as u64),
            };
            match out.last() {
                None => ex.run_on(
                    launch::DualBeamsLeaf {
                        n_sphere: &lv.sphere,
                        n_cone: &lv.cone,
                        n_sc: &lv.sc,
                        n_first: &lv.first,
                        b_beam: &beam,
                        d_leaf: self.leaves,
                        d_org: &self.rays.org,
                        d_dir: &self.rays.dir,
                    },
                    prm,
                    threads,
                    64,
                ),
                Some(below) => ex.run_on(
                    launch::DualBeamsUpper {
                        n_sphere: &lv.sphere,
                        n_cone: &lv.cone,
                        n_sc: &lv.sc,
                        n_first: &lv.first,
                        b_below: below,
                        b_beam: &beam,
                    },
                    prm,
                    threads,
                    64,
                ),
            }
            out.push(beam);
        }
        out
    }

    /// The launch parameters of a step at ray level `l` (0: the single rays): counts in
    /// `stride` slots per stream, outputs of at most `room` pairs.
    fn pair_params(&self, stride: u64, l: usize, room: u32, pad: u32) -> DualPairParams {
        let li = l.saturating_sub(1);
        DualPairParams {
            stride: stride as u32,
            level: li as u32,
            exact: (self.eng.cfg.node_test == NodeTest::Exact) as u32,
            descent: match self.eng.cfg.descent {
                Descent::Size => 0,
                Descent::ObjectFirst => 1,
                Descent::RayFirst => 2,
            },
            counters: 16 * li as u32,
            objects: self.tail() + 8,
            room,
            pad,
            stage: l as u32,
            maxd: self.eng.gpu.limits.max_compute_workgroups_per_dimension,
        }
    }

    /// The test and count of a step at ray level `l ≥ 1` over `pairs` (their count in
    /// `state`): actions into `s.act`, the streams' counts into `s.counts`.
    #[allow(clippy::too_many_arguments)]
    fn classify(
        &self,
        ex: &mut Exec,
        beams: &[wgpu::Buffer],
        l: usize,
        pairs: &Region,
        state: &wgpu::Buffer,
        s: &Scratch,
        prm: DualPairParams,
    ) {
        let (lv, t) = (&self.levels[l - 1], self.tree);
        ex.run(
            launch::DualClassify {
                n_sphere: &lv.sphere,
                n_cone: &lv.cone,
                n_sc: &lv.sc,
                n_first: &lv.first,
                b_beam: &beams[l - 1],
                t_child: &t.child,
                t_node: &t.node,
                t_leaf: &t.leaf,
                t_range: &t.range,
                p_ray: &pairs.0,
                p_obj: &pairs.1,
                p_act: &s.act,
                p_cnt: &s.counts,
                cnt: self.counters,
                r_state: state,
            },
            prm,
            prm.stride as u64,
            256,
        );
    }

    /// The emission of a step at ray level `l ≥ 1` over `pairs` (their count in `state`),
    /// at the offsets `s.offs`: (final tests, pairs one level down appended after the
    /// state's count, the collapsed nodes' children) into `out`.
    #[allow(clippy::too_many_arguments)]
    fn emit(
        &self,
        ex: &mut Exec,
        l: usize,
        pairs: &Region,
        state: &wgpu::Buffer,
        s: &Scratch,
        out: (&Region, &Region, &Region),
        prm: DualPairParams,
    ) {
        let (lv, t) = (&self.levels[l - 1], self.tree);
        let (fin, below, here) = out;
        ex.run(
            launch::DualEmit {
                n_first: &lv.first,
                t_child: &t.child,
                t_node: &t.node,
                t_range: &t.range,
                t_order: &t.order,
                p_ray: &pairs.0,
                p_obj: &pairs.1,
                p_act: &s.act,
                p_cnt: &s.offs,
                o_ray: &here.0,
                o_obj: &here.1,
                r_state: state,
                r_below_ray: &below.0,
                r_below_obj: &below.1,
                r_fin_ray: &fin.0,
                r_fin_obj: &fin.1,
            },
            prm,
            prm.stride as u64,
            256,
        );
    }

    /// The final tests (thesis §3.2.9, `final.wgsl`) of the (level-1 node, triangle) pairs
    /// `fin`, over `threads` (their count `pairs`, or a count on the device).
    fn final_tests(&self, ex: &mut Exec, fin: &Region, pairs: u64, threads: Threads) {
        // The mesh-sphere traversal's launch: the same kernel, buffers and counter words.
        let trav = GpuTraversal {
            eng: self.eng,
            levels: self.levels,
            rays: self.rays,
            leaves: self.leaves,
            best: self.best,
            counters: self.counters,
        };
        trav.final_tests(ex, (&fin.0, &fin.1), pairs, threads);
    }

    /// The single rays' walks over `pairs` sorted by ray (their count in `state`), `bound`
    /// threads: each ray's run walked by the thread at its head (`Traversal::ray_step`).
    fn walks(&self, ex: &mut Exec, state: &wgpu::Buffer, pairs: &Region, bound: u64) {
        let t = self.tail();
        ex.run(
            launch::DualWalk {
                d_leaf: self.leaves,
                d_org: &self.rays.org,
                d_dir: &self.rays.dir,
                d_pre: &self.rays.pre,
                d_kl: &self.rays.kl,
                t_child: &self.tree.child,
                t_cbox: &self.tree.child_box,
                d_tris: &self.eng.tris,
                w_key: &pairs.0,
                p_obj: &pairs.1,
                d_best: self.best,
                cnt: self.counters,
                r_state: state,
            },
            DualWalkParams {
                pairs: bound as u32,
                any: self.any as u32,
                finals: t,
                boxes: t + 10,
            },
            bound,
            64,
        );
    }

    /// The host's step of `n` pairs at ray level `l ≥ 1`: test, count, scan, read the three
    /// streams' sizes back, emit; runs the final tests and returns (the pairs one level
    /// down, the collapsed nodes' children) with their sizes.
    fn node_step(
        &self,
        ex: &mut Exec,
        beams: &[wgpu::Buffer],
        l: usize,
        pairs: &Region,
        n: u64,
    ) -> (Region, Region, [u64; 2]) {
        let g = ex.g;
        let state = g.upload("dual step state", &step_state(n, l));
        let prm = self.pair_params(n, l, u32::MAX, 0);
        let s = Scratch {
            act: g.storage("dual actions", n * 4),
            counts: g.storage("dual stream counts", 3 * n * 4),
            offs: g.storage("dual stream offsets", (3 * n + 1) * 4),
            size: g.storage("unused", 4),
        };
        self.classify(ex, beams, l, pairs, &state, &s, prm);
        ex.scan(&s.counts, &s.offs, 3 * n);
        let ends = read_words(ex, &s.offs, &[n, 2 * n, 3 * n]);
        let (f, b, h) = (
            ends[0] as u64,
            (ends[1] - ends[0]) as u64,
            (ends[2] - ends[1]) as u64,
        );
        let fin = region(ex, "dual final tests", f);
        let below = region(ex, "dual pairs one level down", b);
        let here = region(ex, "dual pairs of collapsed nodes' children", h);
        if f + b + h > 0 {
            self.emit(ex, l, pairs, &state, &s, (&fin, &below, &here), prm);
        }
        if f > 0 {
            self.final_tests(ex, &fin, f, Threads::Host(f));
        }
        (below, here, [b, h])
    }

    /// The host's step of `n` single rays' pairs (leaf positions): sorted by ray, then
    /// walked; nothing is read back.
    fn ray_step(&self, ex: &mut Exec, pairs: &Region, n: u64) {
        ex.phase(::rsh::stats::FINAL_TESTS);
        let bits = (32 - (self.m as u32).leading_zeros()).max(1);
        ex.sort_pairs_all(&pairs.0, &pairs.1, n, bits);
        let state = ex.g.upload("dual step state", &step_state(n, 0));
        self.walks(ex, &state, pairs, n);
        ex.phase(trace::TRAVERSAL);
    }
}

/// The state of one host step of `n` pairs at ray level `l` (`dual_rounds.wgsl`'s layout).
fn step_state(n: u64, l: usize) -> [u32; STATE_WORDS] {
    let mut w = [0; STATE_WORDS];
    (w[1], w[5]) = (n as u32, l as u32);
    w
}

/// Words of the device's state (`dual_rounds.wgsl`).
const STATE_WORDS: usize = 9;

/// A buffer pair of `len` (ray node, object node) pairs.
type Region = (wgpu::Buffer, wgpu::Buffer);

fn region(ex: &Exec, what: &str, len: u64) -> Region {
    (
        ex.g.storage(&format!("{what}: ray nodes"), len * 4),
        ex.g.storage(&format!("{what}: object nodes"), len * 4),
    )
}

/// A step's scratch: actions, stream counts and their offsets, and (the rounds') the size
/// block of a round's final tests.
struct Scratch {
    act: wgpu::Buffer,
    counts: wgpu::Buffer,
    offs: wgpu::Buffer,
    size: wgpu::Buffer,
}
