//! CRSH and RAH on the GPU: [`GpuRsh`] implements [`render::Tracer`] with the same
//! configuration ([`rsh::RshConfig`]), the same phases and the same counters as
//! [`rsh::RshEngine`], every step a WGSL kernel (see `shaders/`). The host only sequences the
//! kernels, reads back the few totals that size the next buffers (as a CUDA/CUB version
//! would), and mirrors the CPU's batching decisions (triangle batches, budget splits), so the
//! pair streams, and therefore all counters, are the CPU's.

use crate::device::{Gpu, GpuError};
use crate::kernels::{Exec, Kernels, Params};
use geom::{Pcg32, Sphere};
use render::stats::counter;
use render::{Hit, Phase, RayBatch, TraceMode, TraceStats, Tracer};
use rsh::traverse::Counters;
use rsh::{HashKind, Method, NodeTest, RshConfig, Union};
use scene::Geometry;
use std::sync::Mutex;

/// Triangles per thread of the top-level candidate kernels (more when the per-thread count
/// buffer would not fit one binding; the pair order, node-major then triangle, is the same).
const TILE: u32 = 256;

/// One level of nodes on the device (structure of arrays, as `rsh::build::Level`).
struct Level {
    sphere: wgpu::Buffer,
    cone: wgpu::Buffer,
    sc: wgpu::Buffer,
    first: wgpu::Buffer,
    /// Nodes per kind (kinds are sorted, so this is the level's whole layout).
    per_kind: [u32; 4],
}

impl Level {
    fn len(&self) -> u32 {
        self.per_kind.iter().sum()
    }
}

/// The GPU engine. Scene data is uploaded once; each trace call builds its hierarchy.
pub struct GpuRsh {
    gpu: Gpu,
    kernels: Kernels,
    cfg: RshConfig,
    ntri: u32,
    tris: wgpu::Buffer,
    tri_sphere: wgpu::Buffer,
    tri_mesh: wgpu::Buffer,
    mesh_sphere: wgpu::Buffer,
    mesh_first: Vec<u32>,
    shuffles: wgpu::Buffer,
    box_min: [f32; 4],
    box_ext: [f32; 4],
    /// Most rays per hierarchy, from the binding limit (a larger batch is traced in parts).
    max_rays: usize,
    /// GPU seconds per phase of the last trace calls (drained by [`GpuRsh::take_times`]).
    times: Mutex<Vec<(Phase, f64)>>,
}

/// The CPU's fixed minimal-ball shuffle (`geom::miniball`) for every count 1..=b, as rows of
/// source indices; row c starts at c·(c−1)/2.
fn shuffle_table(b: u32) -> Vec<u32> {
    let mut out = Vec::new();
    for c in 1..=b as usize {
        let mut perm: Vec<u32> = (0..c as u32).collect();
        let mut rng = Pcg32::new(0x6d696e69, 0x62616c6c);
        for i in (1..c).rev() {
            let j = rng.below(i as u32 + 1) as usize;
            perm.swap(i, j);
        }
        out.extend(perm);
    }
    out
}

fn v4(s: &Sphere) -> [f32; 4] {
    [s.center.x, s.center.y, s.center.z, s.radius]
}

impl GpuRsh {
    /// Upload the scene; fails when no adapter is found or the configuration is one the GPU
    /// pipeline does not implement (the 64-bit Morton hash).
    pub fn new(gpu: Gpu, geo: &Geometry, cfg: RshConfig) -> Result<GpuRsh, GpuError> {
        cfg.validate().map_err(GpuError::Config)?;
        if cfg.method == Method::Crsh && cfg.hash != HashKind::Thesis {
            return Err(GpuError::Config(
                "the GPU backend implements the thesis's 32-bit hash only".into(),
            ));
        }
        let kernels = Kernels::new(&gpu);
        let ntri = geo.tris.len();
        // Pair buffers hold at most `pair_budget` u32s each (as on the CPU, where the budget
        // bounds the same buffers); they must fit one binding.
        if cfg.pair_budget as u64 * 4 > gpu.max_binding() {
            return Err(GpuError::Limits(format!(
                "--pair-budget {} needs {} MiB per binding; this device allows {} MiB (use at most {})",
                cfg.pair_budget,
                (cfg.pair_budget as u64 * 4) >> 20,
                gpu.max_binding() >> 20,
                gpu.max_binding() / 4
            )));
        }
        let max_tris = gpu.max_binding() / 48;
        if ntri as u64 > max_tris {
            return Err(GpuError::Limits(format!(
                "{ntri} triangles exceed one binding ({max_tris} at most)"
            )));
        }
        let tris: Vec<[f32; 4]> = geo
            .tris
            .iter()
            .flat_map(|t| t.map(|v| [v.x, v.y, v.z, 0.0]))
            .collect();
        let spheres: Vec<[f32; 4]> = geo
            .tris
            .iter()
            .map(|t| v4(&Sphere::of_triangle(t[0], t[1], t[2])))
            .collect();
        let nm = geo.mesh_first.len() - 1;
        let mut tri_mesh = vec![0u32; ntri];
        for m in 0..nm {
            for t in geo.mesh_first[m]..geo.mesh_first[m + 1] {
                tri_mesh[t as usize] = m as u32;
            }
        }
        let meshes: Vec<[f32; 4]> = geo.mesh_sphere.iter().map(v4).collect();
        let ext = geo.bounds.extent().max(geom::Vec3::splat(1e-30));
        let b = geo.bounds.min;
        // Rays: 16 bytes of origin and of direction per ray in one binding. The top level has
        // at most ⌈rays / b⌉ + 3 nodes, and its node × mesh pass bits must fit one binding
        // too (and index in u32); a larger batch is traced in parts.
        let bit_entries = (gpu.max_binding() * 8).min(1 << 31);
        let by_pass = (bit_entries / nm.max(1) as u64).saturating_sub(4) * cfg.branching as u64;
        let max_rays = (gpu.max_binding() / 16).min(1 << 26).min(by_pass).max(1) as usize;
        Ok(GpuRsh {
            tris: gpu.upload("triangles", &tris),
            tri_sphere: gpu.upload("triangle spheres", &spheres),
            tri_mesh: gpu.upload("triangle meshes", &tri_mesh),
            mesh_sphere: gpu.upload("mesh spheres", &meshes),
            shuffles: gpu.upload("miniball shuffles", &shuffle_table(cfg.branching)),
            mesh_first: geo.mesh_first.clone(),
            ntri: ntri as u32,
            box_min: [b.x, b.y, b.z, 0.0],
            box_ext: [ext.x, ext.y, ext.z, 0.0],
            max_rays,
            gpu,
            kernels,
            cfg,
            times: Mutex::new(Vec::new()),
        })
    }

    pub fn gpu(&self) -> &Gpu {
        &self.gpu
    }

    /// The compiled kernels (shared with [`crate::GpuStages`], so nothing compiles twice).
    pub fn kernels(&self) -> &Kernels {
        &self.kernels
    }

    /// GPU time per phase accumulated since the last call (empty without timestamp queries).
    pub fn take_times(&self) -> Vec<(Phase, f64)> {
        std::mem::take(&mut *self.times.lock().unwrap())
    }

    fn trace_part(&self, rays: &RayBatch, hits: &mut [Hit], stats: &mut TraceStats) {
        let n = rays.len();
        let g = &self.gpu;
        let mut ex = Exec::new(g, &self.kernels);
        let org: Vec<[f32; 4]> = (0..n)
            .map(|i| {
                let o = rays.org[i];
                [o.x, o.y, o.z, rays.t_min[i]]
            })
            .collect();
        let dir: Vec<[f32; 4]> = (0..n)
            .map(|i| {
                let d = rays.dir[i];
                [d.x, d.y, d.z, rays.t_max[i]]
            })
            .collect();
        let kl: Vec<u32> = (0..n)
            .map(|i| (rays.kind[i] as u32 & 3) | (rays.light[i] & 0x3fff_ffff) << 2)
            .collect();
        let b_org = g.upload("ray org", &org);
        let b_dir = g.upload("ray dir", &dir);
        let b_kl = g.upload("ray kind", &kl);
        let b_pix = g.upload("ray pixel", &rays.pixel);
        let n64 = n as u64;
        let keys = g.storage("keys", n64 * 4);
        let valid = g.storage("valid", n64 * 4);
        let pre = g.storage("ray constants", n64 * 16);
        let crsh = self.cfg.method == Method::Crsh;
        let hb = &self.cfg.hash_bits;
        ex.phase(if crsh {
            Phase::Hash
        } else {
            Phase::ScreenOrder
        });
        ex.run(
            "hash_keys",
            Params {
                u: [
                    [n as u32, (!crsh) as u32, rays.width, hb.light],
                    [hb.shadow_dir, hb.origin, hb.dir, 0],
                    [0; 4],
                    [0; 4],
                ],
                f: [self.box_min, self.box_ext],
            },
            &[
                (1, &b_org),
                (2, &b_dir),
                (3, &b_kl),
                (4, &b_pix),
                (5, &keys),
                (6, &valid),
                (7, &pre),
            ],
            n64,
            256,
        );
        ex.phase(Phase::Trim);
        let (tk, tv, m) = ex.compact(&valid, &keys, None, n64);
        drop((keys, valid));
        let leaves = if crsh {
            self.chunked_order(&mut ex, &tk, &tv, m, stats)
        } else {
            ex.phase(Phase::ScreenOrder);
            ex.sort_pairs(&tk, &tv, m, 32);
            tv
        };
        // Hierarchy (thesis §3.2.7).
        ex.phase(Phase::HierarchyCreation);
        let levels = self.build(&mut ex, &leaves, &b_org, &b_dir, &b_kl, m);
        // Traversal and final tests.
        let best = g.upload("best", &vec![u64::MAX; n]);
        let mut c = Counters {
            tests: vec![[0; 4]; levels.len()],
            hits: vec![[0; 4]; levels.len()],
            ..Default::default()
        };
        let rays_g = RaysOnGpu {
            org: &b_org,
            dir: &b_dir,
            pre: &pre,
            leaves: &leaves,
            best: &best,
        };
        if self.ntri > 0 && !levels.is_empty() && levels.last().unwrap().len() > 0 {
            self.traverse(&mut ex, &levels, &rays_g, &mut c);
        }
        ex.phase(Phase::FinalTests);
        let rec = g.storage("records", n64 * 16);
        ex.run(
            "records",
            Params::n(0, 0, n as u32, 0),
            &[
                (6, &b_org),
                (7, &b_dir),
                (8, &pre),
                (9, &self.tris),
                (11, &best),
                (13, &rec),
            ],
            n64,
            256,
        );
        ex.phase(Phase::ReadBack);
        let recs: Vec<[u32; 4]> = ex.read(&rec, n);
        for (h, r) in hits.iter_mut().zip(&recs) {
            *h = if r[0] == geom::NO_HIT {
                Hit::MISS
            } else {
                Hit {
                    tri: r[0],
                    t: f32::from_bits(r[1]),
                    u: f32::from_bits(r[2]),
                    v: f32::from_bits(r[3]),
                }
            };
        }
        ex.finish();
        let mut times = self.times.lock().unwrap();
        for (p, t) in ex.times.drain(..) {
            stats.time(p, t);
            match times.iter_mut().find(|(q, _)| *q == p) {
                Some(e) => e.1 += t,
                None => times.push((p, t)),
            }
        }
        stats.count(counter::GPU_KERNEL_LAUNCHES, ex.launches);
        self.report(&c, &levels, hits, stats);
    }

    /// Trim is done; compress → sort → decompress (thesis §3.2.4–3.2.6).
    fn chunked_order(
        &self,
        ex: &mut Exec,
        tk: &wgpu::Buffer,
        tv: &wgpu::Buffer,
        m: u64,
        stats: &mut TraceStats,
    ) -> wgpu::Buffer {
        let g = self.gpu();
        ex.phase(Phase::Compress);
        if m == 0 {
            stats.count(counter::CHUNKS, 0);
            return g.storage("leaves", 4);
        }
        let heads = g.storage("heads", m * 4);
        ex.run(
            "run_heads",
            Params::n(m as u32, 0, 0, 0),
            &[(3, tk), (5, &heads)],
            m,
            256,
        );
        let offs = g.storage("head offsets", (m + 1) * 4);
        ex.scan(&heads, &offs, m);
        let nch = ex.read_at(&offs, m as usize) as u64;
        stats.count(counter::CHUNKS, nch);
        let (ck, cb, cs) = (
            g.storage("chunk keys", nch * 4),
            g.storage("chunk bases", nch * 4),
            g.storage("chunk sizes", nch * 4),
        );
        ex.run(
            "run_chunks",
            Params::n(m as u32, 0, 0, 0),
            &[(1, &heads), (2, &offs), (3, tk), (5, &ck), (6, &cb)],
            m,
            256,
        );
        ex.run(
            "run_sizes",
            Params::n(nch as u32, 0, m as u32, 0),
            &[(4, &cb), (7, &cs)],
            nch,
            256,
        );
        ex.phase(Phase::Sort);
        let order = g.storage("chunk order", nch * 4);
        ex.run(
            "iota",
            Params::n(nch as u32, 0, 0, 0),
            &[(5, &order)],
            nch,
            256,
        );
        ex.sort_pairs(&ck, &order, nch, 32);
        ex.phase(Phase::Decompress);
        let sizes = g.storage("sorted sizes", nch * 4);
        ex.run(
            "gather",
            Params::n(nch as u32, 0, 0, 0),
            &[(3, &order), (4, &cs), (5, &sizes)],
            nch,
            256,
        );
        let soffs = g.storage("sorted offsets", (nch + 1) * 4);
        ex.scan(&sizes, &soffs, nch);
        let leaves = g.storage("leaves", m * 4);
        ex.run(
            "expand_runs",
            Params::n(nch as u32, 0, 0, 0),
            &[(1, tv), (2, &soffs), (3, &order), (4, &cb), (5, &leaves)],
            nch,
            256,
        );
        leaves
    }

    /// Bottom-up build: level 1 over the sorted leaves, then unions, as `rsh::build::build`.
    fn build(
        &self,
        ex: &mut Exec,
        leaves: &wgpu::Buffer,
        org: &wgpu::Buffer,
        dir: &wgpu::Buffer,
        kl: &wgpu::Buffer,
        m: u64,
    ) -> Vec<Level> {
        let g = self.gpu();
        let b = self.cfg.branching;
        // Leaf counts per kind (kinds are sorted: find where each starts).
        let mut counts = [0u32; 4];
        if m > 0 {
            let starts = g.upload("kind starts", &[0u32; 4]);
            let present = g.upload("kind present", &[0u32; 4]);
            ex.run(
                "kind_hist",
                Params::n(m as u32, 0, 0, 0),
                &[(3, kl), (4, leaves), (5, &starts), (6, &present)],
                m,
                256,
            );
            let st: Vec<u32> = ex.read(&starts, 4);
            let pr: Vec<u32> = ex.read(&present, 4);
            for k in 0..4 {
                if pr[k] != 0 {
                    let end = (k + 1..4)
                        .find(|&j| pr[j] != 0)
                        .map(|j| st[j])
                        .unwrap_or(m as u32);
                    counts[k] = end - st[k];
                }
            }
        }
        let union = (self.cfg.union == Union::Thesis) as u32;
        let mut levels: Vec<Level> = Vec::new();
        let mut below = counts;
        loop {
            let nodes: [u32; 4] = below.map(|c| c.div_ceil(b));
            let total: u32 = nodes.iter().sum();
            let children: u32 = below.iter().sum();
            let mut run = [0u32; 4];
            let mut cum = [0u32; 4];
            for k in 1..4 {
                run[k] = run[k - 1] + below[k - 1];
                cum[k] = cum[k - 1] + nodes[k - 1];
            }
            let lv = Level {
                sphere: g.storage("node spheres", total as u64 * 16),
                cone: g.storage("node cones", total as u64 * 16),
                sc: g.storage("node sc", total as u64 * 16),
                first: g.storage("node first", (total as u64 + 1) * 4),
                per_kind: nodes,
            };
            let prm = Params {
                u: [[total, b, union, children], run, cum, below],
                f: [[0.0; 4]; 2],
            };
            let outs = [(5, &lv.sphere), (6, &lv.cone), (7, &lv.sc), (8, &lv.first)];
            if levels.is_empty() {
                let mut binds = vec![(1, leaves), (2, org), (3, dir), (4, &self.shuffles)];
                binds.extend(outs);
                ex.run("build_leaf_level", prm, &binds, total as u64, 64);
            } else {
                let c = levels.last().unwrap();
                let mut binds = vec![(9, &c.sphere), (10, &c.cone), (11, &c.sc)];
                binds.extend(outs);
                ex.run("build_upper_level", prm, &binds, total as u64, 64);
            }
            levels.push(lv);
            // Stop rules of rsh::build.
            let top = levels.last().unwrap();
            let done = if self.cfg.levels == 0 {
                top.per_kind.iter().all(|&c| c <= 1)
            } else {
                levels.len() as u32 >= self.cfg.levels
            };
            if done || top.len() <= 1 {
                break;
            }
            below = top.per_kind;
        }
        levels
    }
}

/// The ray-side buffers the traversal needs.
struct RaysOnGpu<'a> {
    org: &'a wgpu::Buffer,
    dir: &'a wgpu::Buffer,
    pre: &'a wgpu::Buffer,
    leaves: &'a wgpu::Buffer,
    best: &'a wgpu::Buffer,
}

fn add4(a: &mut [u64; 4], c: &[u32]) {
    for k in 0..4 {
        a[k] += c[k] as u64;
    }
}

impl GpuRsh {
    fn exact(&self) -> u32 {
        (self.cfg.node_test == NodeTest::Exact) as u32
    }

    /// Mesh culling, then node chunks × triangle batches within the pair budget on the CPU's
    /// schedule (`rsh::traverse::batches`).
    fn traverse(&self, ex: &mut Exec, levels: &[Level], rays: &RaysOnGpu, c: &mut Counters) {
        let g = self.gpu();
        ex.phase(Phase::Traversal);
        let top = levels.last().unwrap();
        let nt = top.len() as usize;
        let nm = self.mesh_first.len() - 1;
        let budget = self.cfg.pair_budget;
        // The node × mesh pass table: tested in node ranges whose flags fit one binding,
        // kept as a bit set (the ray-count limit in `new` keeps it within one binding).
        let pass: Vec<u8> = if self.cfg.mesh_culling {
            c.mesh_tests += (nt * nm) as u64;
            let per = ((g.max_binding() / 4) as usize / nm.max(1)).max(1);
            let mut pass = Vec::with_capacity(nt * nm);
            for first in (0..nt).step_by(per) {
                let k = per.min(nt - first);
                let out = g.storage("mesh pass", (k * nm) as u64 * 4);
                ex.run(
                    "mesh_test",
                    Params::n((k * nm) as u32, nm as u32, first as u32, self.exact()),
                    &[
                        (1, &top.sphere),
                        (2, &top.cone),
                        (3, &top.sc),
                        (6, &self.mesh_sphere),
                        (10, &out),
                    ],
                    (k * nm) as u64,
                    256,
                );
                let flags: Vec<u32> = ex.read(&out, k * nm);
                pass.extend(flags.iter().map(|&f| f as u8));
            }
            pass
        } else {
            vec![1; nt * nm]
        };
        c.mesh_passes += pass.iter().map(|&p| p as u64).sum::<u64>();
        let mut bits = vec![0u32; (nt * nm).div_ceil(32)];
        for (i, &p) in pass.iter().enumerate() {
            bits[i >> 5] |= (p as u32) << (i & 31);
        }
        let pass_buf = g.upload("mesh pass bits", &bits);
        for (nodes, tris) in rsh::traverse::batches(&pass, nm, &self.mesh_first, budget) {
            self.top_batch(ex, levels, rays, &pass_buf, nodes, tris, c);
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn top_batch(
        &self,
        ex: &mut Exec,
        levels: &[Level],
        rays: &RaysOnGpu,
        pass: &wgpu::Buffer,
        nodes: std::ops::Range<usize>,
        tris: std::ops::Range<usize>,
        c: &mut Counters,
    ) {
        let g = self.gpu();
        c.batches += 1;
        let li = levels.len() - 1;
        let top = &levels[li];
        let nm = (self.mesh_first.len() - 1) as u32;
        let max_slots = (self.gpu.max_binding() / 4 - 1).min(u32::MAX as u64 / 2);
        let mut tile = TILE;
        while nodes.len() as u64 * (tris.len() as u64).div_ceil(tile as u64) > max_slots {
            tile *= 2;
        }
        let tiles = (tris.len() as u32).div_ceil(tile);
        let slots = nodes.len() as u64 * tiles as u64;
        let prm = Params {
            u: [
                [slots as u32, tiles, nodes.start as u32, self.exact()],
                [tris.start as u32, tris.end as u32, nm, tile],
                [0; 4],
                [0; 4],
            ],
            f: [[0.0; 4]; 2],
        };
        let counts = g.storage("top counts", slots * 4);
        let cnt = g.upload("counters", &[0u32; 8]);
        let common = [
            (1, &top.sphere),
            (2, &top.cone),
            (3, &top.sc),
            (5, &self.tri_sphere),
            (6, &self.tri_mesh),
            (7, pass),
        ];
        // top_count shares its candidate loop with top_emit, so its layout has the emit
        // bindings too; they are never written when counting.
        let (unused_a, unused_b) = (g.storage("unused", 4), g.storage("unused", 4));
        let mut binds = common.to_vec();
        binds.extend([(10, &counts), (11, &unused_a), (12, &cnt), (13, &unused_b)]);
        ex.run("top_count", prm, &binds, slots, 256);
        let offs = g.storage("top offsets", (slots + 1) * 4);
        ex.scan(&counts, &offs, slots);
        let cv: Vec<u32> = ex.read(&cnt, 8);
        add4(&mut c.tests[li], &cv[0..4]);
        add4(&mut c.hits[li], &cv[4..8]);
        let total = ex.read_at(&offs, slots as usize) as u64;
        if total == 0 {
            return;
        }
        let (sn, st) = (
            g.storage("pairs node", total * 4),
            g.storage("pairs tri", total * 4),
        );
        let mut binds = common.to_vec();
        binds.extend([(10, &sn), (11, &st), (13, &offs)]);
        ex.run("top_emit", prm, &binds, slots, 256);
        self.survivors(ex, levels, rays, li, sn, st, total, c);
    }

    #[allow(clippy::too_many_arguments)]
    fn survivors(
        &self,
        ex: &mut Exec,
        levels: &[Level],
        rays: &RaysOnGpu,
        li: usize,
        sn: wgpu::Buffer,
        st: wgpu::Buffer,
        count: u64,
        c: &mut Counters,
    ) {
        if li == 0 {
            ex.phase(Phase::FinalTests);
            let cnt = self.gpu.upload("counters", &[0u32; 4]);
            let l1 = &levels[0];
            ex.run(
                "final_tests",
                Params::n(count as u32, 0, 0, 0),
                &[
                    (1, &sn),
                    (2, &st),
                    (3, &l1.first),
                    (4, &l1.sc),
                    (5, rays.leaves),
                    (6, rays.org),
                    (7, rays.dir),
                    (8, rays.pre),
                    (9, &self.tris),
                    (10, rays.best),
                    (12, &cnt),
                ],
                count,
                256,
            );
            let cv: Vec<u32> = ex.read(&cnt, 4);
            add4(&mut c.final_tests, &cv);
            ex.phase(Phase::Traversal);
        } else {
            self.expand(ex, levels, rays, li, sn, st, count, c);
        }
    }

    /// Test pairs at level index `li`, compact the survivors, go on.
    #[allow(clippy::too_many_arguments)]
    fn process(
        &self,
        ex: &mut Exec,
        levels: &[Level],
        rays: &RaysOnGpu,
        li: usize,
        nodes: wgpu::Buffer,
        tris: wgpu::Buffer,
        count: u64,
        c: &mut Counters,
    ) {
        let g = self.gpu();
        let lv = &levels[li];
        let flags = g.storage("flags", count * 4);
        let cnt = g.upload("counters", &[0u32; 8]);
        ex.run(
            "pair_test",
            Params::n(count as u32, 0, 0, self.exact()),
            &[
                (1, &lv.sphere),
                (2, &lv.cone),
                (3, &lv.sc),
                (5, &self.tri_sphere),
                (8, &nodes),
                (9, &tris),
                (10, &flags),
                (12, &cnt),
            ],
            count,
            256,
        );
        let cv: Vec<u32> = ex.read(&cnt, 8);
        add4(&mut c.tests[li], &cv[0..4]);
        add4(&mut c.hits[li], &cv[4..8]);
        let (sn, st, m) = ex.compact(&flags, &nodes, Some(&tris), count);
        drop((nodes, tris, flags));
        if m > 0 {
            self.survivors(ex, levels, rays, li, sn, st, m, c);
        }
    }

    /// Children of the survivors at `li` become pairs at `li − 1`; halves when over budget.
    #[allow(clippy::too_many_arguments)]
    fn expand(
        &self,
        ex: &mut Exec,
        levels: &[Level],
        rays: &RaysOnGpu,
        li: usize,
        sn: wgpu::Buffer,
        st: wgpu::Buffer,
        count: u64,
        c: &mut Counters,
    ) {
        let g = self.gpu();
        let lv = &levels[li];
        let counts = g.storage("child counts", count * 4);
        ex.run(
            "child_count",
            Params::n(count as u32, 0, 0, 0),
            &[(4, &lv.first), (8, &sn), (10, &counts)],
            count,
            256,
        );
        let offs = g.storage("child offsets", (count + 1) * 4);
        ex.scan(&counts, &offs, count);
        let total = ex.read_at(&offs, count as usize) as u64;
        if total > self.cfg.pair_budget as u64 && count > 1 {
            c.splits += 1;
            let h = count / 2;
            for (start, len) in [(0, h), (h, count - h)] {
                let (a, b) = (
                    g.storage("half node", len * 4),
                    g.storage("half tri", len * 4),
                );
                ex.copy(&sn, start * 4, &a, len * 4);
                ex.copy(&st, start * 4, &b, len * 4);
                self.expand(ex, levels, rays, li, a, b, len, c);
            }
            return;
        }
        let (cn, ct) = (
            g.storage("pairs node", total * 4),
            g.storage("pairs tri", total * 4),
        );
        ex.run(
            "child_emit",
            Params::n(count as u32, 0, 0, 0),
            &[
                (4, &lv.first),
                (8, &sn),
                (9, &st),
                (10, &cn),
                (11, &ct),
                (13, &offs),
            ],
            count,
            256,
        );
        drop((sn, st));
        if total > 0 {
            self.process(ex, levels, rays, li - 1, cn, ct, total, c);
        }
    }

    /// Counters into `stats`, named as the CPU engine names them.
    fn report(&self, c: &Counters, levels: &[Level], hits: &[Hit], stats: &mut TraceStats) {
        stats.hits += hits.iter().filter(|h| h.is_hit()).count() as u64;
        let top = levels.last().map(|l| l.len() as u64).unwrap_or(0);
        rsh::engine::report_counters(c, self.cfg.mesh_culling, top, stats);
    }
}

/// The counts of a trace that the GPU engine must reproduce: everything in `s` (rays, hits,
/// test totals, per-level counts, engine counters) but the times and the GPU-only counter.
pub fn comparable_counters(s: &TraceStats) -> TraceStats {
    let mut c = s.clone();
    c.phases.clear();
    c.counters.remove(counter::GPU_KERNEL_LAUNCHES);
    c
}

/// Rays `r` of `rays` as a batch of their own.
fn sub_batch(rays: &RayBatch, r: std::ops::Range<usize>) -> RayBatch {
    RayBatch {
        org: rays.org[r.clone()].to_vec(),
        dir: rays.dir[r.clone()].to_vec(),
        t_min: rays.t_min[r.clone()].to_vec(),
        t_max: rays.t_max[r.clone()].to_vec(),
        kind: rays.kind[r.clone()].to_vec(),
        pixel: rays.pixel[r.clone()].to_vec(),
        light: rays.light[r.clone()].to_vec(),
        throughput: rays.throughput[r.clone()].to_vec(),
        depth: rays.depth[r].to_vec(),
        width: rays.width,
    }
}

impl Tracer for GpuRsh {
    fn name(&self) -> &str {
        match self.cfg.method {
            Method::Crsh => "crsh-gpu",
            Method::Rah => "rah-gpu",
        }
    }

    fn trace(&self, rays: &RayBatch, _mode: TraceMode, hits: &mut [Hit], stats: &mut TraceStats) {
        assert_eq!(hits.len(), rays.len(), "one hit record per ray");
        stats.rays += rays.len() as u64;
        if rays.is_empty() {
            return;
        }
        if rays.len() <= self.max_rays {
            self.trace_part(rays, hits, stats);
            return;
        }
        // Larger than one binding: consecutive parts, each with its own hierarchy.
        for (p, out) in hits.chunks_mut(self.max_rays).enumerate() {
            let lo = p * self.max_rays;
            let part = sub_batch(rays, lo..lo + out.len());
            self.trace_part(&part, out, stats);
        }
    }
}
