//! The top-down traversal on the GPU, the twin of `crates/rsh/src/traverse.rs` (thesis
//! §3.2.8–3.2.9; `traverse.wgsl`, `final.wgsl`): mesh culling at the top, then node chunks ×
//! triangle batches within the pair budget on the CPU's schedule
//! (`rsh::traverse::batches`); each level's (node, triangle) pairs are tested, compacted and
//! expanded to the children, halved when over budget, and level 1's survivors go to the
//! final ray–triangle tests. [`GpuTraversal`] holds what stays fixed over one trace call, as
//! `rsh::traverse::Traversal` does on the CPU.

use super::build::Level;
use super::device_scene::DeviceScene;
use crate::kernels::params::{
    ChildParams, FinalTestsParams, MeshTestParams, PairTestParams, TopParams,
};
use crate::kernels::{launch, Exec, Threads};
use crate::rays::DeviceRays;
use ::rsh::traverse::Counters;
use ::rsh::NodeTest;

/// Triangles per thread of the top-level candidate kernels (more when the per-thread count
/// buffer would not fit one binding; the pair order, node-major then triangle, is the same).
const TILE: u32 = 256;

/// One trace call's traversal state: the engine's scene buffers, the hierarchy and the rays.
pub struct GpuTraversal<'a> {
    /// The engine (scene buffers, configuration).
    pub eng: &'a DeviceScene,
    /// The hierarchy, level 1 first.
    pub levels: &'a [Level],
    /// The rays.
    pub rays: &'a DeviceRays,
    /// The sorted leaves (ray indices).
    pub leaves: &'a wgpu::Buffer,
    /// Per ray, the closest hit so far as (t bits << 32 | triangle), by 64-bit atomic min.
    pub best: &'a wgpu::Buffer,
    /// The trace call's counters on the device, zeroed ([`GpuTraversal::counter_words`]
    /// words): 64-bit (low, high) counters, per level 8 (tests and passes per ray kind)
    /// from word 16 · level, then the final tests per kind from word 16 · levels. Read
    /// back once, at the end of [`GpuTraversal::run`].
    pub counters: &'a wgpu::Buffer,
}

/// (node, triangle) pairs of one level on the device.
struct Pairs {
    node: wgpu::Buffer,
    tri: wgpu::Buffer,
    len: u64,
}

impl GpuTraversal<'_> {
    /// Words of the counter buffer for a hierarchy of `levels` levels.
    pub fn counter_words(levels: usize) -> u64 {
        16 * levels as u64 + 8
    }

    fn exact(&self) -> u32 {
        (self.eng.cfg.node_test == NodeTest::Exact) as u32
    }

    /// Mesh culling, then the top level's batches.
    pub fn run(&self, ex: &mut Exec, c: &mut Counters) {
        let eng = self.eng;
        let g = &eng.gpu;
        ex.phase(trace::TRAVERSAL);
        let top = self.levels.last().unwrap();
        let nt = top.len() as usize;
        let nm = eng.mesh_first.len() - 1;
        // The node × mesh pass table, as a bit set made on the device (the ray-count limit
        // of `DeviceScene::new` keeps it within one binding); the host reads the bits back to cut
        // the batches as the CPU does.
        let entries = nt * nm;
        let words = entries.div_ceil(32);
        let (pass, pass_buf) = if eng.cfg.mesh_culling {
            c.mesh_tests += entries as u64;
            let out = g.storage("mesh pass bits", words as u64 * 4);
            ex.run(
                launch::MeshTest {
                    n_sphere: &top.sphere,
                    n_cone: &top.cone,
                    n_sc: &top.sc,
                    t_mesh: &eng.mesh_sphere,
                    o_a: &out,
                },
                MeshTestParams {
                    entries: entries as u32,
                    meshes: nm as u32,
                    exact: self.exact(),
                },
                words as u64,
                256,
            );
            let bits: Vec<u32> = ex.read(&out, words);
            let pass: Vec<u8> = (0..entries)
                .map(|i| ((bits[i >> 5] >> (i & 31)) & 1) as u8)
                .collect();
            (pass, out)
        } else {
            let mut bits = vec![u32::MAX; words];
            if !entries.is_multiple_of(32) {
                bits[words - 1] = (1u32 << (entries % 32)) - 1;
            }
            (vec![1; entries], g.upload("mesh pass bits", &bits))
        };
        c.mesh_passes += pass.iter().map(|&p| p as u64).sum::<u64>();
        let budget = eng.cfg.pair_budget;
        for (nodes, tris) in ::rsh::traverse::batches(&pass, nm, &eng.mesh_first, budget) {
            self.top_batch(ex, &pass_buf, nodes, tris, c);
        }
        // Every level's and the final tests' counts, added up on the device: one read.
        let nl = self.levels.len();
        let w: Vec<u32> = ex.read(self.counters, Self::counter_words(nl) as usize);
        let at = |i: usize| w[i] as u64 | (w[i + 1] as u64) << 32;
        for li in 0..nl {
            for k in 0..4 {
                c.tests[li][k] += at(16 * li + 2 * k);
                c.hits[li][k] += at(16 * li + 8 + 2 * k);
            }
        }
        for k in 0..4 {
            c.final_tests[k] += at(16 * nl + 2 * k);
        }
    }

    /// One batch of the top level: its candidate pairs counted, scanned and emitted.
    fn top_batch(
        &self,
        ex: &mut Exec,
        pass: &wgpu::Buffer,
        nodes: std::ops::Range<usize>,
        tris: std::ops::Range<usize>,
        c: &mut Counters,
    ) {
        let eng = self.eng;
        let g = &eng.gpu;
        c.batches += 1;
        let li = self.levels.len() - 1;
        let top = &self.levels[li];
        let nm = (eng.mesh_first.len() - 1) as u32;
        let max_slots = (g.max_binding() / 4 - 1).min(u32::MAX as u64 / 2);
        let mut tile = TILE;
        while nodes.len() as u64 * (tris.len() as u64).div_ceil(tile as u64) > max_slots {
            tile *= 2;
        }
        let tiles = (tris.len() as u32).div_ceil(tile);
        let slots = nodes.len() as u64 * tiles as u64;
        let prm = TopParams {
            slots: slots as u32,
            tiles,
            first_node: nodes.start as u32,
            exact: self.exact(),
            tri_start: tris.start as u32,
            tri_end: tris.end as u32,
            meshes: nm,
            tile,
            counters: 16 * li as u32,
        };
        let counts = g.storage("top counts", slots * 4);
        // top_count shares its candidate loop with top_emit, so its layout has the emit
        // bindings too; they are never written when counting.
        let (unused_a, unused_b) = (g.storage("unused", 4), g.storage("unused", 4));
        let l = launch::TopCount {
            n_sphere: &top.sphere,
            n_cone: &top.cone,
            n_sc: &top.sc,
            t_sphere: &eng.tri_sphere,
            t_mesh: &eng.tri_mesh,
            m_pass: pass,
            o_a: &counts,
            o_b: &unused_a,
            cnt: self.counters,
            e_off: &unused_b,
        };
        ex.run(l, prm, slots, 256);
        let offs = g.storage("top offsets", (slots + 1) * 4);
        ex.scan(&counts, &offs, slots);
        let total = ex.read_at(&offs, slots as usize) as u64;
        if total == 0 {
            return;
        }
        let pairs = Pairs {
            node: g.storage("pairs node", total * 4),
            tri: g.storage("pairs tri", total * 4),
            len: total,
        };
        let l = launch::TopEmit {
            n_sphere: &top.sphere,
            n_cone: &top.cone,
            n_sc: &top.sc,
            t_sphere: &eng.tri_sphere,
            t_mesh: &eng.tri_mesh,
            m_pass: pass,
            o_a: &pairs.node,
            o_b: &pairs.tri,
            e_off: &offs,
        };
        ex.run(l, prm, slots, 256);
        self.survivors(ex, li, pairs, c);
    }

    /// Surviving pairs at level index `li`: the final tests at level 1, else expansion.
    fn survivors(&self, ex: &mut Exec, li: usize, pairs: Pairs, c: &mut Counters) {
        if li > 0 {
            self.expand(ex, li, pairs, c);
            return;
        }
        let n = pairs.len;
        self.final_tests(ex, (&pairs.node, &pairs.tri), n, Threads::Host(n));
    }

    /// The final tests (thesis §3.2.9, `final.wgsl`) of the (level-1 node, triangle) pairs
    /// `(node, tri)`, over `threads` (their count `pairs`, or a count on the device that
    /// replaces it); the tests per kind go to the counters from word 16 · levels (the dual
    /// traversal's layout too, [`super::dual`]).
    pub fn final_tests(
        &self,
        ex: &mut Exec,
        (node, tri): (&wgpu::Buffer, &wgpu::Buffer),
        pairs: u64,
        threads: Threads,
    ) {
        ex.phase(::rsh::stats::FINAL_TESTS);
        let l1 = &self.levels[0];
        ex.run_on(
            launch::FinalTests {
                f_node: node,
                f_tri: tri,
                f_first: &l1.first,
                f_sc: &l1.sc,
                f_leaf: self.leaves,
                f_org: &self.rays.org,
                f_dir: &self.rays.dir,
                f_pre: &self.rays.pre,
                f_tris: &self.eng.tris,
                f_best: self.best,
                f_cnt: self.counters,
            },
            FinalTestsParams {
                pairs: pairs as u32,
                counters: 16 * self.levels.len() as u32,
            },
            threads,
            256,
        );
        ex.phase(trace::TRAVERSAL);
    }

    /// Test pairs at level index `li`, compact the survivors, go on.
    fn process(&self, ex: &mut Exec, li: usize, pairs: Pairs, c: &mut Counters) {
        let g = &self.eng.gpu;
        let lv = &self.levels[li];
        let flags = g.storage("flags", pairs.len * 4);
        let prm = PairTestParams {
            pairs: pairs.len as u32,
            exact: self.exact(),
            counters: 16 * li as u32,
        };
        ex.run(
            launch::PairTest {
                n_sphere: &lv.sphere,
                n_cone: &lv.cone,
                n_sc: &lv.sc,
                t_sphere: &self.eng.tri_sphere,
                p_node: &pairs.node,
                p_tri: &pairs.tri,
                o_a: &flags,
                cnt: self.counters,
            },
            prm,
            pairs.len,
            256,
        );
        let (node, tri, len) = ex.compact(&flags, &pairs.node, Some(&pairs.tri), pairs.len);
        drop((pairs, flags));
        if len > 0 {
            self.survivors(ex, li, Pairs { node, tri, len }, c);
        }
    }

    /// Children of the survivors at `li` become pairs at `li − 1`; halves when over budget.
    fn expand(&self, ex: &mut Exec, li: usize, pairs: Pairs, c: &mut Counters) {
        let g = &self.eng.gpu;
        let lv = &self.levels[li];
        let count = pairs.len;
        let counts = g.storage("child counts", count * 4);
        ex.run(
            launch::ChildCount {
                n_first: &lv.first,
                p_node: &pairs.node,
                o_a: &counts,
            },
            ChildParams {
                pairs: count as u32,
            },
            count,
            256,
        );
        let offs = g.storage("child offsets", (count + 1) * 4);
        ex.scan(&counts, &offs, count);
        let total = ex.read_at(&offs, count as usize) as u64;
        if total > self.eng.cfg.pair_budget as u64 && count > 1 {
            c.splits += 1;
            let h = count / 2;
            for (start, len) in [(0, h), (h, count - h)] {
                let half = Pairs {
                    node: g.storage("half node", len * 4),
                    tri: g.storage("half tri", len * 4),
                    len,
                };
                ex.copy(&pairs.node, start * 4, &half.node, len * 4);
                ex.copy(&pairs.tri, start * 4, &half.tri, len * 4);
                self.expand(ex, li, half, c);
            }
            return;
        }
        let children = Pairs {
            node: g.storage("pairs node", total * 4),
            tri: g.storage("pairs tri", total * 4),
            len: total,
        };
        ex.run(
            launch::ChildEmit {
                n_first: &lv.first,
                p_node: &pairs.node,
                p_tri: &pairs.tri,
                o_a: &children.node,
                o_b: &children.tri,
                e_off: &offs,
            },
            ChildParams {
                pairs: count as u32,
            },
            count,
            256,
        );
        drop(pairs);
        if total > 0 {
            self.process(ex, li - 1, children, c);
        }
    }
}
