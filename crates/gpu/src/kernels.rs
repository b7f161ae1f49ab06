//! The WGSL kernels, compiled once per device and named by [`Kernel`], and [`Exec`]: a
//! command recorder that runs one compute pass per kernel launch, with a timestamp pair per
//! pass attributed to the current phase (GPU time, not wall-clock). The data-parallel
//! primitives built on it are in [`crate::prims`].

use crate::device::{Gpu, PhaseTimer};
use std::sync::Mutex;
use std::time::Instant;
use trace::Phase;

/// Launch parameters, the `Params` block of `common.wgsl`. `f[1][3]` is reserved: [`Exec::run`]
/// always sets it to 0, the zero the kernels' `mul()` hides products behind.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Params {
    /// u0..u3: integer parameters (counts, offsets, flags), as each kernel documents.
    pub u: [[u32; 4]; 4],
    /// f0, f1: float parameters (f1.w is reserved, always 0).
    pub f: [[f32; 4]; 2],
}
const _: () = assert!(std::mem::size_of::<Params>() == 96);

impl Params {
    /// Parameters with `u0 = (n, a, b, c)`.
    pub fn n(n: u32, a: u32, b: u32, c: u32) -> Params {
        Params {
            u: [[n, a, b, c], [0; 4], [0; 4], [0; 4]],
            f: [[0.0; 4]; 2],
        }
    }
}

const COMMON: &str = include_str!("shaders/common.wgsl");
const GEOM: &str = include_str!("shaders/geom.wgsl");
const PRIM_BINDINGS: &str = include_str!("prims/bindings.wgsl");
/// The voxel map's layout and lookup, shared by the grid kernels that look voxels up.
const GRID_MAP: &str = include_str!("grid/map.wgsl");

/// A compiled WGSL module: its files after the shared prelude (constants, `common.wgsl`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Module {
    Scan,
    Sort,
    Compact,
    Runs,
    Permute,
    Kinds,
    Hash,
    Build,
    Traverse,
    Final,
    Stages,
    Grid,
    GridBuild,
    VoxelMap,
    Merge,
    Expand,
    Frame,
}

impl Module {
    const ALL: [Module; 17] = [
        Module::Scan,
        Module::Sort,
        Module::Compact,
        Module::Runs,
        Module::Permute,
        Module::Kinds,
        Module::Hash,
        Module::Build,
        Module::Traverse,
        Module::Final,
        Module::Stages,
        Module::Grid,
        Module::GridBuild,
        Module::VoxelMap,
        Module::Merge,
        Module::Expand,
        Module::Frame,
    ];

    /// The module's source after the prelude.
    fn source(self) -> String {
        match self {
            Module::Scan => include_str!("prims/scan.wgsl").into(),
            Module::Sort => include_str!("prims/sort.wgsl").into(),
            Module::Compact => format!("{PRIM_BINDINGS}{}", include_str!("prims/compact.wgsl")),
            Module::Runs => format!("{PRIM_BINDINGS}{}", include_str!("prims/runs.wgsl")),
            Module::Permute => format!("{PRIM_BINDINGS}{}", include_str!("prims/permute.wgsl")),
            Module::Kinds => format!("{PRIM_BINDINGS}{}", include_str!("rsh/kinds.wgsl")),
            Module::Hash => format!("{GEOM}{}", include_str!("rsh/hash.wgsl")),
            Module::Build => format!("{GEOM}{}", include_str!("rsh/build.wgsl")),
            Module::Traverse => format!("{GEOM}{}", include_str!("rsh/traverse.wgsl")),
            Module::Final => format!("{GEOM}{}", include_str!("rsh/final.wgsl")),
            Module::Stages => include_str!("stages.wgsl").into(),
            Module::Grid => format!("{GEOM}{}{GRID_MAP}", include_str!("grid/traverse.wgsl")),
            Module::GridBuild => include_str!("grid/build.wgsl").into(),
            Module::VoxelMap => include_str!("grid/voxelmap.wgsl").into(),
            Module::Merge => format!("{}{GRID_MAP}", include_str!("grid/merge.wgsl")),
            Module::Expand => format!("{}{GRID_MAP}", include_str!("grid/expand.wgsl")),
            Module::Frame => include_str!("frame.wgsl").into(),
        }
    }
}

/// Every compute kernel, by a key the compiler checks: a launch cannot name a kernel that
/// does not exist, and every key's entry point is compiled (and so checked against its WGSL)
/// when the kernels are built.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Kernel {
    /// Block sums of a scan.
    ScanReduce,
    /// Exclusive scan within blocks, plus the scanned block sums.
    ScanDown,
    /// The AND and OR of all keys (digits equal in every key need no sort pass).
    KeyBits,
    /// Per-tile digit histograms of a radix pass.
    SortCount,
    /// Stable scatter of a radix pass.
    SortScatter,
    /// Stream compaction by flags and scanned offsets.
    Compact,
    /// Head flags of runs of equal keys.
    RunHeads,
    /// Each run's key and first position.
    RunChunks,
    /// Each run's length.
    RunSizes,
    /// Runs expanded back to elements (decompression).
    ExpandRuns,
    /// The values 0..n.
    Iota,
    /// Every word set to one value.
    Fill,
    /// `y[i] = x[order[i]]`.
    Gather,
    /// Where each ray kind starts among the sorted leaves.
    KindHist,
    /// Ray hash keys, validity flags and intersection constants.
    HashKeys,
    /// Level 1 of the hierarchy over the sorted leaves.
    BuildLeafLevel,
    /// A level of the hierarchy over the level below.
    BuildUpperLevel,
    /// Top nodes against the mesh spheres.
    MeshTest,
    /// Candidate (top node, triangle) pairs counted per slot.
    TopCount,
    /// Candidate (top node, triangle) pairs written.
    TopEmit,
    /// (Node, triangle) pairs tested.
    PairTest,
    /// Children of the surviving pairs counted.
    ChildCount,
    /// (Child, triangle) pairs written.
    ChildEmit,
    /// Exact ray–triangle tests of level 1's survivors.
    FinalTests,
    /// Hit records from the best hits.
    Records,
    /// Shadow rays of the surfaces.
    ShadowRays,
    /// Reflection and refraction rays of the surfaces.
    BounceRays,
    /// Blinn-Phong shading of the surfaces.
    ShadeLocal,
    /// Irregular-grid traversal, one thread per ray.
    GridTrace,
    /// Grid build: triangle boxes and the scene box.
    GridTriBoxes,
    /// Grid build: references to the top cells, counted or emitted.
    GridTopRefs,
    /// Grid build: references per octree node.
    GridHistogram,
    /// Grid build: which nodes want to split.
    GridWants,
    /// Grid build: child masks of the references.
    GridMasks,
    /// Grid build: which nodes split.
    GridSplit,
    /// Grid build: a level's voxel-map entries, leaf cells and children.
    GridNodes,
    /// Grid build: kept and child reference counts.
    GridRefFlags,
    /// Grid build: kept or child references written.
    GridRefEmit,
    /// Voxel map: subtree depths and leaf counts (bottom-up).
    VmUp,
    /// Voxel map: block roots and places in blocks (top-down).
    VmDown,
    /// Voxel map: block entries per subtree (bottom-up).
    VmBsum,
    /// Voxel map: pre-order block and leaf offsets (top-down).
    VmOffsets,
    /// Voxel map: entries painted, cells renumbered.
    VmFill,
    /// Voxel map: cells in map order.
    VmCells,
    /// Voxel map: references' renumbered cells.
    VmKeys,
    /// Merge: list ranges from the reference ranges.
    MInit,
    /// Merge: candidates of the live cells.
    MCandidates,
    /// Merge: cells a candidate points at.
    MPredecessors,
    /// Merge: chains walked from their heads into pairs.
    MChains,
    /// Merge: list lengths after the pass.
    MCounts,
    /// Merge: lists rewritten, pairs merged.
    MEmit,
    /// Merge: owners one step deep.
    MCompress,
    /// Merge: cells still live.
    MLiveFlags,
    /// Merge: live cells renumbered.
    MFinalIndex,
    /// Merge: the voxel map repointed.
    MFinalMap,
    /// Merge: live cells gathered.
    MFinalCells,
    /// Expansion: blocked sides and boxes at the start.
    EInit,
    /// Expansion: one side of every cell.
    ESide,
    /// The traversal's cell records.
    ERecords,
    /// Device frame: covered pixels and the image's start.
    FrGbFlags,
    /// Device frame: surfaces of the covered pixels.
    FrGbSurfaces,
    /// Device frame: shadow rays' kinds, lights and pixels.
    FrShadowMeta,
    /// Device frame: occlusion flags from hit records.
    FrOccluded,
    /// Device frame: colours added to their pixels in surface order.
    FrAccumulate,
    /// Device frame: the background behind bounce rays that hit nothing.
    FrMisses,
    /// Device frame: bounce slots that hold a ray.
    FrSlotFlags,
    /// Device frame: the filled bounce slots as a ray batch.
    FrBounceEmit,
    /// Device frame: rays that hit something.
    FrHitFlags,
    /// Device frame: surfaces of the hits.
    FrHitSurfaces,
    /// Device frame: the image as sRGB bytes.
    FrEncode,
    /// A trace's hits and counter sums per chunk of rays.
    FrTotals,
    /// Device frame: rays of one kind per chunk.
    FrKindCount,
}

impl Kernel {
    /// Every kernel.
    pub const ALL: [Kernel; 72] = [
        Kernel::ScanReduce,
        Kernel::ScanDown,
        Kernel::KeyBits,
        Kernel::SortCount,
        Kernel::SortScatter,
        Kernel::Compact,
        Kernel::RunHeads,
        Kernel::RunChunks,
        Kernel::RunSizes,
        Kernel::ExpandRuns,
        Kernel::Iota,
        Kernel::Fill,
        Kernel::Gather,
        Kernel::KindHist,
        Kernel::HashKeys,
        Kernel::BuildLeafLevel,
        Kernel::BuildUpperLevel,
        Kernel::MeshTest,
        Kernel::TopCount,
        Kernel::TopEmit,
        Kernel::PairTest,
        Kernel::ChildCount,
        Kernel::ChildEmit,
        Kernel::FinalTests,
        Kernel::Records,
        Kernel::ShadowRays,
        Kernel::BounceRays,
        Kernel::ShadeLocal,
        Kernel::GridTrace,
        Kernel::GridTriBoxes,
        Kernel::GridTopRefs,
        Kernel::GridHistogram,
        Kernel::GridWants,
        Kernel::GridMasks,
        Kernel::GridSplit,
        Kernel::GridNodes,
        Kernel::GridRefFlags,
        Kernel::GridRefEmit,
        Kernel::VmUp,
        Kernel::VmDown,
        Kernel::VmBsum,
        Kernel::VmOffsets,
        Kernel::VmFill,
        Kernel::VmCells,
        Kernel::VmKeys,
        Kernel::MInit,
        Kernel::MCandidates,
        Kernel::MPredecessors,
        Kernel::MChains,
        Kernel::MCounts,
        Kernel::MEmit,
        Kernel::MCompress,
        Kernel::MLiveFlags,
        Kernel::MFinalIndex,
        Kernel::MFinalMap,
        Kernel::MFinalCells,
        Kernel::EInit,
        Kernel::ESide,
        Kernel::ERecords,
        Kernel::FrGbFlags,
        Kernel::FrGbSurfaces,
        Kernel::FrShadowMeta,
        Kernel::FrOccluded,
        Kernel::FrAccumulate,
        Kernel::FrMisses,
        Kernel::FrSlotFlags,
        Kernel::FrBounceEmit,
        Kernel::FrHitFlags,
        Kernel::FrHitSurfaces,
        Kernel::FrEncode,
        Kernel::FrTotals,
        Kernel::FrKindCount,
    ];

    /// The WGSL entry point and the module that holds it.
    fn def(self) -> (&'static str, Module) {
        use Kernel::*;
        match self {
            ScanReduce => ("scan_reduce", Module::Scan),
            ScanDown => ("scan_down", Module::Scan),
            KeyBits => ("key_bits", Module::Sort),
            SortCount => ("sort_count", Module::Sort),
            SortScatter => ("sort_scatter", Module::Sort),
            Compact => ("compact", Module::Compact),
            RunHeads => ("run_heads", Module::Runs),
            RunChunks => ("run_chunks", Module::Runs),
            RunSizes => ("run_sizes", Module::Runs),
            ExpandRuns => ("expand_runs", Module::Runs),
            Iota => ("iota", Module::Permute),
            Fill => ("fill", Module::Permute),
            Gather => ("gather", Module::Permute),
            KindHist => ("kind_hist", Module::Kinds),
            HashKeys => ("hash_keys", Module::Hash),
            BuildLeafLevel => ("build_leaf_level", Module::Build),
            BuildUpperLevel => ("build_upper_level", Module::Build),
            MeshTest => ("mesh_test", Module::Traverse),
            TopCount => ("top_count", Module::Traverse),
            TopEmit => ("top_emit", Module::Traverse),
            PairTest => ("pair_test", Module::Traverse),
            ChildCount => ("child_count", Module::Traverse),
            ChildEmit => ("child_emit", Module::Traverse),
            FinalTests => ("final_tests", Module::Final),
            Records => ("records", Module::Final),
            ShadowRays => ("shadow_rays", Module::Stages),
            BounceRays => ("bounce_rays", Module::Stages),
            ShadeLocal => ("shade_local", Module::Stages),
            GridTrace => ("grid_trace", Module::Grid),
            GridTriBoxes => ("grid_tri_boxes", Module::GridBuild),
            GridTopRefs => ("grid_top_refs", Module::GridBuild),
            GridHistogram => ("grid_histogram", Module::GridBuild),
            GridWants => ("grid_wants", Module::GridBuild),
            GridMasks => ("grid_masks", Module::GridBuild),
            GridSplit => ("grid_split", Module::GridBuild),
            GridNodes => ("grid_nodes", Module::GridBuild),
            GridRefFlags => ("grid_ref_flags", Module::GridBuild),
            GridRefEmit => ("grid_ref_emit", Module::GridBuild),
            VmUp => ("vm_up", Module::VoxelMap),
            VmDown => ("vm_down", Module::VoxelMap),
            VmBsum => ("vm_bsum", Module::VoxelMap),
            VmOffsets => ("vm_offsets", Module::VoxelMap),
            VmFill => ("vm_fill", Module::VoxelMap),
            VmCells => ("vm_cells", Module::VoxelMap),
            VmKeys => ("vm_keys", Module::VoxelMap),
            MInit => ("m_init", Module::Merge),
            MCandidates => ("m_candidates", Module::Merge),
            MPredecessors => ("m_predecessors", Module::Merge),
            MChains => ("m_chains", Module::Merge),
            MCounts => ("m_counts", Module::Merge),
            MEmit => ("m_emit", Module::Merge),
            MCompress => ("m_compress", Module::Merge),
            MLiveFlags => ("m_live_flags", Module::Merge),
            MFinalIndex => ("m_final_index", Module::Merge),
            MFinalMap => ("m_final_map", Module::Merge),
            MFinalCells => ("m_final_cells", Module::Merge),
            EInit => ("e_init", Module::Expand),
            ESide => ("e_side", Module::Expand),
            ERecords => ("e_records", Module::Expand),
            FrGbFlags => ("fr_gb_flags", Module::Frame),
            FrGbSurfaces => ("fr_gb_surfaces", Module::Frame),
            FrShadowMeta => ("fr_shadow_meta", Module::Frame),
            FrOccluded => ("fr_occluded", Module::Frame),
            FrAccumulate => ("fr_accumulate", Module::Frame),
            FrMisses => ("fr_misses", Module::Frame),
            FrSlotFlags => ("fr_slot_flags", Module::Frame),
            FrBounceEmit => ("fr_bounce_emit", Module::Frame),
            FrHitFlags => ("fr_hit_flags", Module::Frame),
            FrHitSurfaces => ("fr_hit_surfaces", Module::Frame),
            FrEncode => ("fr_encode", Module::Frame),
            FrTotals => ("fr_totals", Module::Frame),
            FrKindCount => ("fr_kind_count", Module::Frame),
        }
    }

    /// The WGSL entry point's name.
    pub fn entry(self) -> &'static str {
        self.def().0
    }
}

/// Constants as exact bit patterns (see `common.wgsl`): the f32 values the CPU code uses,
/// folded in f32 as Rust folds them.
fn constants() -> String {
    use geom::pmath;
    use std::f32::consts::*;
    let eps = f32::EPSILON;
    let list: &[(&str, f32)] = &[
        ("C_PI", PI),
        ("C_FRAC_PI_2", FRAC_PI_2),
        ("C_FRAC_PI_4", FRAC_PI_4),
        ("C_FRAC_1_PI", FRAC_1_PI),
        ("C_HALF_FRAC_1_PI", 0.5 * FRAC_1_PI),
        ("C_PI_M_1EM6", PI - 1e-6),
        ("C_ONE_P_4EPS", 1.0 + 4.0 * eps),
        ("C_ONE_P_8EPS", 1.0 + 8.0 * eps),
        ("C_8EPS", 8.0 * eps),
        ("C_PAD", 8.0 * eps),
        ("C_ONE_P_PAD", 1.0 + 8.0 * eps),
        ("C_ONE_P_1EM5", 1.0 + 1e-5),
        ("C_SLAB_ROBUST", geom::aabb::SLAB_ROBUST),
        ("C_OFFSET_REL", geom::ray::OFFSET_REL),
        ("C_T3P8", pmath::T3P8),
        ("C_TP8", pmath::TP8),
        ("C_AT0", pmath::AT[0]),
        ("C_AT1", pmath::AT[1]),
        ("C_AT2", pmath::AT[2]),
        ("C_AT3", pmath::AT[3]),
        ("C_DP1", pmath::DP1),
        ("C_DP2", pmath::DP2),
        ("C_DP3", pmath::DP3),
        ("C_TWO_OVER_PI", pmath::TWO_OVER_PI),
        ("C_S0", pmath::SN[0]),
        ("C_S1", pmath::SN[1]),
        ("C_S2", pmath::SN[2]),
        ("C_C0", pmath::CS[0]),
        ("C_C1", pmath::CS[1]),
        ("C_C2", pmath::CS[2]),
    ];
    let mut s = String::new();
    for &(name, v) in list {
        s += &format!("const {name}: f32 = {};\n", hex_f32(v));
    }
    s
}

/// An exact WGSL literal of a normal f32: a hexadecimal float with the 24-bit significand
/// (naga cannot fold `bitcast` in constants, and a decimal literal could round twice).
fn hex_f32(v: f32) -> String {
    assert!(v.is_normal(), "constant {v} is not a normal float");
    let b = v.to_bits();
    let sign = if b >> 31 == 1 { "-" } else { "" };
    let exp = ((b >> 23) & 0xff) as i32 - 127;
    let mant = (b & 0x7f_ffff) << 1;
    format!("{sign}0x1.{mant:06x}p{exp}f")
}

/// Every pipeline, indexed by [`Kernel`].
pub struct Kernels {
    pipes: Vec<wgpu::ComputePipeline>,
}

impl Kernels {
    /// Compile every module and create every kernel's pipeline.
    pub fn new(g: &Gpu) -> Kernels {
        let prelude = format!("{}\n{COMMON}\n", constants());
        let mut pipes: Vec<Option<wgpu::ComputePipeline>> =
            Kernel::ALL.iter().map(|_| None).collect();
        for m in Module::ALL {
            let module = g.shader(&format!("{m:?}"), &format!("{prelude}{}", m.source()));
            for k in Kernel::ALL.into_iter().filter(|k| k.def().1 == m) {
                pipes[k as usize] = Some(g.pipeline(&module, k.entry()));
            }
        }
        Kernels {
            pipes: pipes
                .into_iter()
                .map(|p| p.expect("every kernel belongs to a module"))
                .collect(),
        }
    }

    /// The pipeline of kernel `k`.
    pub fn get(&self, k: Kernel) -> &wgpu::ComputePipeline {
        &self.pipes[k as usize]
    }
}

/// GPU time per phase from timestamp queries.
#[derive(Default)]
struct Timer {
    set: Option<wgpu::QuerySet>,
    resolve: Option<wgpu::Buffer>,
    used: u32,
    phases: Vec<Phase>,
}

const MAX_QUERIES: u32 = 4096;

/// Records kernel launches; submits at read-backs (the pipeline's only synchronisation).
pub struct Exec<'a> {
    /// The device.
    pub g: &'a Gpu,
    /// The compiled kernels.
    pub k: &'a Kernels,
    enc: Option<wgpu::CommandEncoder>,
    phase: Phase,
    timer: Timer,
    /// Seconds per phase, in first-seen order: GPU time from timestamps, or wall-clock time
    /// with a wait at each phase boundary ([`PhaseTimer`]).
    pub times: Vec<(Phase, f64)>,
    /// Kernel launches recorded.
    pub launches: u64,
    wall_start: Option<Instant>,
}

impl<'a> Exec<'a> {
    /// A recorder on `g` with kernels `k`, in the upload phase.
    pub fn new(g: &'a Gpu, k: &'a Kernels) -> Exec<'a> {
        let mut timer = Timer::default();
        let wall = g.timer == PhaseTimer::WallClock;
        if !wall {
            timer.set = Some(g.device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("phase timestamps"),
                ty: wgpu::QueryType::Timestamp,
                count: MAX_QUERIES,
            }));
            timer.resolve = Some(g.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("timestamp resolve"),
                size: MAX_QUERIES as u64 * 8,
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            }));
        }
        Exec {
            g,
            k,
            enc: None,
            phase: Phase::Upload,
            timer,
            times: Vec::new(),
            launches: 0,
            wall_start: wall.then(Instant::now),
        }
    }

    fn add_time(&mut self, ph: Phase, dt: f64) {
        match self.times.iter_mut().find(|(p, _)| *p == ph) {
            Some(e) => e.1 += dt,
            None => self.times.push((ph, dt)),
        }
    }

    /// Start phase `name` (with the wall-clock timer: finish the previous phase's work first).
    pub fn phase(&mut self, name: Phase) {
        if self.wall_start.is_some() && name != self.phase {
            self.finish();
        }
        self.phase = name;
    }

    /// Submit and wait for everything recorded; with the wall-clock timer, the time since
    /// the phase started is added to it.
    pub fn finish(&mut self) {
        self.flush();
        if let Some(t0) = self.wall_start {
            self.g
                .device
                .poll(wgpu::PollType::wait_indefinitely())
                .expect("GPU device lost");
            let now = Instant::now();
            self.add_time(self.phase, (now - t0).as_secs_f64());
            self.wall_start = Some(now);
        }
    }

    fn encoder(&mut self) -> &mut wgpu::CommandEncoder {
        let g = self.g;
        self.enc
            .get_or_insert_with(|| g.device.create_command_encoder(&Default::default()))
    }

    /// Launch `kernel` over `threads` threads of workgroups of `wg`, with `params` at binding 0
    /// and `binds` (binding, buffer) after it.
    pub fn run(
        &mut self,
        kernel: Kernel,
        params: Params,
        binds: &[(u32, &wgpu::Buffer)],
        threads: u64,
        wg: u32,
    ) {
        if threads == 0 {
            return;
        }
        let mut params = params;
        params.f[1][3] = 0.0;
        if self.timer.used + 2 > MAX_QUERIES {
            self.flush();
        }
        let g = self.g;
        let pipe = self.k.get(kernel);
        let ub = g.uniform("params", &params);
        let mut entries = vec![wgpu::BindGroupEntry {
            binding: 0,
            resource: ub.as_entire_binding(),
        }];
        for (b, buf) in binds {
            entries.push(wgpu::BindGroupEntry {
                binding: *b,
                resource: buf.as_entire_binding(),
            });
        }
        let bg = g.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(kernel.entry()),
            layout: &pipe.get_bind_group_layout(0),
            entries: &entries,
        });
        let (gx, gy) = g.grid(threads, wg);
        let q = self.timer.used;
        let ts = self
            .timer
            .set
            .as_ref()
            .map(|set| wgpu::ComputePassTimestampWrites {
                query_set: set,
                beginning_of_pass_write_index: Some(q),
                end_of_pass_write_index: Some(q + 1),
            });
        if ts.is_some() {
            self.timer.used += 2;
            self.timer.phases.push(self.phase);
        }
        let enc = self
            .enc
            .get_or_insert_with(|| g.device.create_command_encoder(&Default::default()));
        {
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some(kernel.entry()),
                timestamp_writes: ts,
            });
            pass.set_pipeline(pipe);
            pass.set_bind_group(0, &bg, &[]);
            pass.dispatch_workgroups(gx, gy, 1);
        }
        self.launches += 1;
    }

    /// Copy `bytes` from `src` at `src_off` to the start of `dst`.
    pub fn copy(&mut self, src: &wgpu::Buffer, src_off: u64, dst: &wgpu::Buffer, bytes: u64) {
        if bytes > 0 {
            self.encoder()
                .copy_buffer_to_buffer(src, src_off, dst, 0, bytes);
        }
    }

    /// Copy `bytes` from `src` at `src_off` to `dst` at `dst_off`.
    pub fn copy_at(
        &mut self,
        src: &wgpu::Buffer,
        src_off: u64,
        dst: &wgpu::Buffer,
        dst_off: u64,
        bytes: u64,
    ) {
        if bytes > 0 {
            self.encoder()
                .copy_buffer_to_buffer(src, src_off, dst, dst_off, bytes);
        }
    }

    /// Zero `buf`.
    pub fn clear(&mut self, buf: &wgpu::Buffer) {
        self.encoder().clear_buffer(buf, 0, None);
    }

    /// Submit what is recorded and wait; collect the timestamps.
    pub fn flush(&mut self) {
        let used = self.timer.used;
        if used > 0 {
            let (set, res) = (
                self.timer.set.as_ref().unwrap(),
                self.timer.resolve.as_ref().unwrap(),
            );
            let enc = self
                .enc
                .get_or_insert_with(|| self.g.device.create_command_encoder(&Default::default()));
            enc.resolve_query_set(set, 0..used, res, 0);
        }
        if let Some(enc) = self.enc.take() {
            self.g.queue.submit([enc.finish()]);
        }
        if used > 0 {
            let res = self.timer.resolve.as_ref().unwrap();
            let ticks: Vec<u64> = self.g.read(res, used as usize);
            let period = self.g.queue.get_timestamp_period() as f64 * 1e-9;
            let phases = std::mem::take(&mut self.timer.phases);
            for (i, ph) in phases.into_iter().enumerate() {
                let dt = ticks[2 * i + 1].saturating_sub(ticks[2 * i]) as f64 * period;
                self.add_time(ph, dt);
            }
            self.timer.used = 0;
        }
    }

    /// Flush, then read `count` elements of `buf`.
    pub fn read<T: bytemuck::Pod>(&mut self, buf: &wgpu::Buffer, count: usize) -> Vec<T> {
        self.flush();
        self.g.read(buf, count)
    }

    /// Finish the trace call's work and report it: every phase's time into `stats` and into
    /// `sink` (an engine's running totals, drained by its `take_times`), and the launches.
    pub fn report(mut self, stats: &mut trace::TraceStats, sink: &Mutex<Vec<(Phase, f64)>>) {
        self.finish();
        let mut totals = sink.lock().unwrap();
        for (p, t) in self.times.drain(..) {
            stats.time(p, t);
            match totals.iter_mut().find(|(q, _)| *q == p) {
                Some(e) => e.1 += t,
                None => totals.push((p, t)),
            }
        }
        stats.count(trace::Counter::GpuKernelLaunches, self.launches);
    }

    /// One u32 at index `i` of `buf`.
    pub fn read_at(&mut self, buf: &wgpu::Buffer, i: usize) -> u32 {
        self.flush();
        let tmp = self.g.storage("read one", 4);
        let mut enc = self.g.device.create_command_encoder(&Default::default());
        enc.copy_buffer_to_buffer(buf, i as u64 * 4, &tmp, 0, 4);
        self.g.queue.submit([enc.finish()]);
        self.g.read::<u32>(&tmp, 1)[0]
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn hex_literals_are_exact() {
        assert_eq!(super::hex_f32(1.0), "0x1.000000p0f");
        assert_eq!(super::hex_f32(-0.75), "-0x1.800000p-1f");
        assert_eq!(super::hex_f32(std::f32::consts::PI), "0x1.921fb6p1f");
    }
}
