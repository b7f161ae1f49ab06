//! The irregular grid of Pérard-Gayot, Kalojanov & Slusallek (2017), and its two-level-grid
//! baseline (Kalojanov et al. 2011: the same structure stopped before merging).
//!
//! Structure (paper §3): cells aligned on a *virtual base grid*, each with a box and a range
//! of triangle references, plus a two-level *voxel map* from virtual voxels to cells.
//! Build (§4, [`build`]): a top-level uniform grid (Cleary's formula with density λ₁), an
//! octree per top cell (density λ₂; only non-empty nodes split, as in the paper's reference
//! code), references emitted with exact triangle–box tests through count → scan → emit
//! passes; then SAH cell merging ([`merge`]) and cell expansion ([`expand`]).
//!
//! The voxel map (§3, Figure 1; [`voxelmap`]) is stored as in hagrid: one entry per top cell
//! pointing at a block of its octree's voxels, with further blocks only below octrees deeper
//! than a block holds, so octrees may be deep where a small dense object needs it.
//! Traversal (§5, [`traverse`]): look up the cell of the current voxel, test its triangles,
//! exit through the far planes of the cell's (expanded) box, step forward; [`lanes`] runs
//! those steps for eight rays at a time in AVX2 lanes with the same bits.
//!
//! Robustness: cell boxes are padded by a small fraction of a voxel when references are
//! emitted, so a triangle within rounding distance of a cell boundary is referenced on both
//! sides; the traversal's float position errors are far below that padding, so it can never
//! step past a triangle that brute force hits.

pub mod build;
pub mod expand;
pub mod lanes;
pub mod merge;
pub mod traverse;
pub mod voxelmap;

use geom::{Aabb, Vec3};
use trace::options::{float, int, name_of, named, single, switch, Kind, OnGpu, Spec, Value};
use trace::{by_name, NameError, OptionError};

pub use voxelmap::NODE;

/// Which octree nodes split during the initial subdivision (see [`build`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Subdivision {
    /// One depth per top cell from eq. 1 with the top cell's count (the paper's rule).
    Paper,
    /// The paper's depth, and below it every node whose own count of small triangles calls
    /// for a split (see [`build`]), up to the maximum depth.
    Adaptive,
}

impl Subdivision {
    /// The rules by name (as options spell them).
    pub const NAMES: [(&'static str, Subdivision); 2] = [
        ("paper", Subdivision::Paper),
        ("adaptive", Subdivision::Adaptive),
    ];
}

impl std::str::FromStr for Subdivision {
    type Err = NameError;
    fn from_str(s: &str) -> Result<Self, NameError> {
        by_name(s, "subdivision rule", &Self::NAMES)
    }
}

/// How a merge pass cuts its chains of candidates into merges (see [`merge`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MergeRule {
    /// Cells at even positions of a chain absorb their successor (the paper's §4.2).
    Pairs,
    /// A cell absorbs its successor and every next one, up to [`merge::MAX_RUN`] cells,
    /// while the SAH cost of the run so far still drops: in one pass, merges that pairs reach
    /// over several rounds.
    Runs,
}

impl MergeRule {
    /// The rules by name (as options spell them).
    pub const NAMES: [(&'static str, MergeRule); 2] =
        [("pairs", MergeRule::Pairs), ("runs", MergeRule::Runs)];
}

impl std::str::FromStr for MergeRule {
    type Err = NameError;
    fn from_str(s: &str) -> Result<Self, NameError> {
        by_name(s, "merge rule", &Self::NAMES)
    }
}

/// Build parameters (paper defaults: λ₁ = 0.12, λ₂ = 2.4, α = 0.995, 3 expansion passes, the
/// paper's subdivision rule; merging by runs, not the paper's pairs, since runs build
/// Sponza's grid in 0.83× the time for N_T and N_I within 8.5 % on the real scenes; adaptive
/// subdivision resolves a teapot in a stadium but costs Conference 1.7× the references and
/// 1.35× the build time for 2.5 % fewer tests, so it is not the default).
#[derive(Clone, Debug, PartialEq)]
pub struct GridConfig {
    /// Top-level density λ₁ (eq. 1: top cells ≈ λ₁ · triangles, cubic in the box's shape).
    pub top_density: f32,
    /// Second-level density λ₂ (each top cell's octree depth from its own count).
    pub leaf_density: f32,
    /// Merge rounds stop when a round keeps at least α of the cells.
    pub alpha: f32,
    /// Merge cells by the SAH (§4.2).
    pub merge: bool,
    /// How a merge pass cuts chains into merges: the paper's pairs, or runs (the default:
    /// the same test, fewer rounds).
    pub merge_rule: MergeRule,
    /// Expansion passes (§4.3).
    pub expansion_passes: u32,
    /// Largest octree depth per top cell.
    pub max_depth: u32,
    /// Which octree nodes split.
    pub subdivision: Subdivision,
    /// Merge and expand empty cells only: Devillers's macro regions (1989), which the paper
    /// (§6, Table 5) describes as this restriction of its merge and expansion steps.
    pub empty_only: bool,
    /// The most bytes the build may hold, by its memory model ([`build::BYTES_PER_REF`],
    /// [`build::BYTES_PER_NODE`]), checked level by level before each allocation (default:
    /// [`trace::memory::default_limit`]; the CLI passes what `--max-memory` leaves after
    /// the render). It decides only whether a build is refused, never what it builds.
    pub max_bytes: u64,
}

impl Default for GridConfig {
    fn default() -> Self {
        GridConfig {
            top_density: 0.12,
            leaf_density: 2.4,
            alpha: 0.995,
            merge: true,
            merge_rule: MergeRule::Runs,
            expansion_passes: 3,
            max_depth: 10,
            subdivision: Subdivision::Paper,
            empty_only: false,
            max_bytes: trace::memory::default_limit(),
        }
    }
}

impl GridConfig {
    /// The two-level grid baseline: initial cells only.
    pub fn two_level() -> Self {
        GridConfig {
            merge: false,
            expansion_passes: 0,
            ..Self::default()
        }
    }

    /// The build stages of Table 1: the initial cells (two-level grid), after merging, after
    /// merging and expansion, with the paper's pairs (its Table 1) and then with runs (the
    /// default), so one run shows both rules on the same initial cells.
    pub fn stages() -> [(&'static str, GridConfig); 5] {
        let rule = |merge_rule, expansion_passes| GridConfig {
            merge_rule,
            expansion_passes,
            ..Self::default()
        };
        let passes = Self::default().expansion_passes;
        [
            ("initial (two-level grid)", Self::two_level()),
            ("+ merge (pairs, paper)", rule(MergeRule::Pairs, 0)),
            (
                "+ merge (pairs, paper) + expansion",
                rule(MergeRule::Pairs, passes),
            ),
            ("+ merge (runs)", rule(MergeRule::Runs, 0)),
            ("+ merge (runs) + expansion", rule(MergeRule::Runs, passes)),
        ]
    }

    /// The one check of a configuration (the CLI, the bindings, the benchmarks and the
    /// engine call it): every option against its declaration ([`OPTIONS`]).
    pub fn validate(&self) -> Result<(), OptionError> {
        trace::options::check_all(OPTIONS, self)
    }
}

/// Grid densities (λ₁, λ₂) lie in (0, 10⁴].
const DENSITY: Kind = Kind::Float {
    min: 0.0,
    above_min: true,
    max: 1e4,
};

/// Every option of the irregular grid and the two-level grid (which stops after the initial
/// cells, so merging and expansion are not its options).
pub const OPTIONS: &[Spec<GridConfig>] = &[
    Spec {
        name: "grid_top_density",
        kind: DENSITY,
        doc: "top-level density, lambda1 (§4.1, eq. 1)",
        engines: None,
        requires: None,
        gpu: OnGpu::Any,
        get: |c| single(c.top_density),
        set: |c, v| {
            c.top_density = float(v) as f32;
            Ok(())
        },
    },
    Spec {
        name: "grid_leaf_density",
        kind: DENSITY,
        doc: "second-level (octree) density, lambda2 (§4.1)",
        engines: None,
        requires: None,
        gpu: OnGpu::Any,
        get: |c| single(c.leaf_density),
        set: |c, v| {
            c.leaf_density = float(v) as f32;
            Ok(())
        },
    },
    Spec {
        name: "grid_alpha",
        kind: Kind::Float {
            min: 0.0,
            above_min: false,
            max: 1.0,
        },
        doc: "merging stops when a round keeps this share of cells (§4.2)",
        engines: Some(&["grid"]),
        requires: None,
        gpu: OnGpu::Any,
        get: |c| single(c.alpha),
        set: |c, v| {
            c.alpha = float(v) as f32;
            Ok(())
        },
    },
    Spec {
        name: "grid_merge",
        kind: Kind::Switch,
        doc: "SAH cell merging (§4.2)",
        engines: Some(&["grid"]),
        requires: None,
        gpu: OnGpu::Any,
        get: |c| Value::Bool(c.merge),
        set: |c, v| {
            c.merge = switch(v);
            Ok(())
        },
    },
    Spec {
        name: "grid_merge_rule",
        kind: Kind::Choice(&[
            (
                "runs",
                "a cell absorbs its successors (up to 8) while the SAH cost still drops",
            ),
            (
                "pairs",
                "even positions of a chain absorb their successor (the paper's §4.2)",
            ),
        ]),
        doc: "how a merge pass cuts its chains of candidates into merges",
        engines: Some(&["grid"]),
        requires: None,
        gpu: OnGpu::Any,
        get: |c| Value::Str(name_of(&MergeRule::NAMES, c.merge_rule).into()),
        set: |c, v| {
            c.merge_rule = named(&MergeRule::NAMES, v)?;
            Ok(())
        },
    },
    Spec {
        name: "grid_expansion",
        kind: Kind::Int { min: 0, max: 16 },
        doc: "cell expansion passes (§4.3)",
        engines: Some(&["grid"]),
        requires: None,
        gpu: OnGpu::Any,
        get: |c| Value::Int(c.expansion_passes as i64),
        set: |c, v| {
            c.expansion_passes = int(v) as u32;
            Ok(())
        },
    },
    Spec {
        name: "grid_max_depth",
        kind: Kind::Int { min: 0, max: 12 },
        doc: "largest octree depth per top-level cell",
        engines: None,
        requires: None,
        gpu: OnGpu::Any,
        get: |c| Value::Int(c.max_depth as i64),
        set: |c, v| {
            c.max_depth = int(v) as u32;
            Ok(())
        },
    },
    Spec {
        name: "grid_subdivision",
        kind: Kind::Choice(&[
            (
                "paper",
                "one octree depth per top cell, from its count (the paper's §4.1)",
            ),
            (
                "adaptive",
                "also split deeper nodes whose own count calls for it",
            ),
        ]),
        doc: "which octree nodes split",
        engines: None,
        requires: None,
        gpu: OnGpu::Any,
        get: |c| Value::Str(name_of(&Subdivision::NAMES, c.subdivision).into()),
        set: |c, v| {
            c.subdivision = named(&Subdivision::NAMES, v)?;
            Ok(())
        },
    },
];

/// Why an irregular grid cannot be built.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum GridError {
    /// A configuration value out of range.
    #[error(transparent)]
    Option(#[from] OptionError),
    /// No triangles to build over.
    #[error("the grid needs at least one triangle")]
    NoTriangles,
    /// More triangles than the references' 27-bit triangle ids hold.
    #[error("{0} triangles exceed the grid's 27-bit references")]
    TooManyTriangles(usize),
    /// The top grid's resolution (from `grid_top_density`) is beyond its cap.
    #[error("a top grid of {}×{}×{} cells is more than {cap}; lower `grid_top_density`", .dims[0], .dims[1], .dims[2])]
    TopGrid {
        /// Its cells per axis.
        dims: [u32; 3],
        /// The most top cells.
        cap: u64,
    },
    /// The build would hold more of something than its cap: a fixed index limit, or what
    /// the memory limit (`max_bytes`) holds at `unit` bytes each. Lower densities or depth
    /// shrink it; raising the memory limit helps too when `by_memory`.
    #[error("{}", size_message(what, *need, *cap, *unit, *by_memory))]
    TooBig {
        /// What ("triangle references", "octree nodes at level 3", "top cells", "voxel
        /// map entries").
        what: String,
        /// How many it would need, at least.
        need: u64,
        /// The cap.
        cap: u64,
        /// Bytes each in the memory model.
        unit: u64,
        /// The memory limit, when it set the cap (else the index limit did).
        by_memory: Option<u64>,
    },
    /// A device cannot hold the grid (the GPU build's binding limits).
    #[error("{0}")]
    Device(String),
}

/// The message of [`GridError::TooBig`]: the cap, what set it, and the options that lower it.
fn size_message(what: &str, need: u64, cap: u64, unit: u64, by_memory: Option<u64>) -> String {
    let shrink = "lower `grid_top_density`, `grid_leaf_density` or `grid_max_depth`";
    match by_memory {
        Some(max) => format!(
            "the grid would hold {need} {what} or more (about {} at {unit} B each), more than the {} allowed (`max_memory`); {shrink}, or raise `max_memory`",
            trace::memory::gib(need.saturating_mul(unit)),
            trace::memory::gib(max)
        ),
        None => format!(
            "the grid would hold {need} {what} or more, beyond its limit of {cap}; {shrink}"
        ),
    }
}

/// Times (seconds) and sizes of a build.
#[derive(Clone, Debug, Default)]
pub struct BuildStats {
    /// Top-level cell references.
    pub top_refs_seconds: f64,
    /// Sparse octrees, level by level.
    pub octree_seconds: f64,
    /// Cells and voxel map.
    pub voxel_map_seconds: f64,
    /// Merging.
    pub merge_seconds: f64,
    /// Expansion.
    pub expand_seconds: f64,
    /// Cells before merging.
    pub initial_cells: usize,
    /// Merge rounds run.
    pub merge_rounds: usize,
}

/// The build's passes in order, as reports name them: top-level references and octrees
/// ([`build::subdivide`]), cells and voxel map ([`build::finish`]), [`merge`], [`expand`].
/// (The CPU makes the first three top cell by top cell, [`build::initial`], with the same
/// result; the GPU runs them level by level.)
/// The GPU build (`gpu::grid`) states where it runs each one against this list, so a pass
/// added here and not there fails its test.
pub const PASSES: [trace::BuildPass; 5] = [
    trace::BuildPass::new("top_refs"),
    trace::BuildPass::new("octrees"),
    trace::BuildPass::new("cells"),
    trace::BuildPass::new("merge"),
    trace::BuildPass::new("expansion"),
];

/// Cells visited per ray, summed (the paper's N_T).
pub const TRAVERSAL_STEPS: trace::Counter = trace::Counter::sum("traversal steps");

impl BuildStats {
    /// Each build pass's time in seconds, in build order ([`PASSES`]).
    pub fn passes(&self) -> [trace::PassTime; 5] {
        let t = [
            self.top_refs_seconds,
            self.octree_seconds,
            self.voxel_map_seconds,
            self.merge_seconds,
            self.expand_seconds,
        ];
        std::array::from_fn(|i| trace::PassTime::new(PASSES[i], t[i]))
    }
}

/// What traversal reads of a cell, in one 32-byte record (one cache line half instead of
/// four arrays, aligned so that no record straddles two lines): the expanded exit box and
/// the cell's reference range. The merge keeps its cells' own boxes in the same record.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[repr(C, align(32))]
pub struct CellRec {
    /// Expanded exit box, minimum corner (virtual grid units).
    pub lo: [u32; 3],
    /// Expanded exit box, maximum corner (exclusive).
    pub hi: [u32; 3],
    /// First reference.
    pub begin: u32,
    /// One past the last reference.
    pub end: u32,
}

/// An irregular grid (or two-level grid) over a triangle set.
#[derive(Clone, Debug)]
pub struct Grid {
    /// Padded scene box.
    pub bounds: Aabb,
    /// Top-grid resolution.
    pub top_dims: [u32; 3],
    /// log2 of the virtual voxels per top cell along each axis (the largest octree depth).
    pub shift: u32,
    /// Virtual grid resolution: top_dims << shift.
    pub dims: [u32; 3],
    /// Size of one virtual voxel.
    pub voxel: Vec3,
    /// 1 / voxel size.
    pub inv_voxel: Vec3,
    /// Voxel-map footprint of each cell on the virtual grid, [min, max).
    pub cell_min: Vec<[u32; 3]>,
    /// Footprint maximum corners (exclusive), as `cell_min`.
    pub cell_max: Vec<[u32; 3]>,
    /// Expanded box (virtual grid units) used to exit the cell during traversal.
    pub exp_min: Vec<[u32; 3]>,
    /// Expanded box maximum corners (exclusive), as `exp_min`.
    pub exp_max: Vec<[u32; 3]>,
    /// Traversal records, built from the boxes and ranges once the build is done.
    pub trav: Vec<CellRec>,
    /// References of cell c: `refs[ref_first[c] .. ref_first[c + 1]]`, ascending.
    pub ref_first: Vec<u32>,
    /// Triangle indices of every cell, cell after cell.
    pub refs: Vec<u32>,
    /// Voxel map ([`voxelmap`]): entries `0..top cells` for the top grid, then the blocks;
    /// each entry a cell index or a block.
    pub entries: Vec<u32>,
    /// Times and sizes of the build.
    pub build: BuildStats,
}

impl Grid {
    /// Number of cells.
    pub fn cells(&self) -> usize {
        self.cell_min.len().max(self.trav.len())
    }

    /// Free what only the build reads (the footprints, expanded boxes and reference offsets,
    /// 52 bytes per cell; traversal reads the records, references and voxel map): an engine
    /// keeps the grid it traces, not the build's state.
    pub fn shed_build_arrays(&mut self) {
        debug_assert_eq!(
            self.trav.len(),
            self.exp_min.len(),
            "shed after the records"
        );
        for v in [
            &mut self.cell_min,
            &mut self.cell_max,
            &mut self.exp_min,
            &mut self.exp_max,
        ] {
            *v = Vec::new();
        }
        self.ref_first = Vec::new();
    }

    /// Bytes of what traversal reads: the cell records (exit box and reference range), the
    /// references and the voxel map. (The build's own per-cell arrays are not counted.)
    pub fn memory(&self) -> (usize, usize, usize) {
        let cells = self.cells() * std::mem::size_of::<CellRec>();
        (cells, self.refs.len() * 4, self.entries.len() * 4)
    }

    /// Voxel-map index of top cell `t`.
    #[inline]
    pub fn top_index(&self, t: [u32; 3]) -> usize {
        (t[0] + self.top_dims[0] * (t[1] + self.top_dims[1] * t[2])) as usize
    }

    /// The cell containing virtual voxel `v`: the top cell's entry, then one entry per block
    /// below it (one for octrees up to [`voxelmap::MAX_BLOCK_LEVELS`] deep).
    #[inline]
    pub fn lookup(&self, v: [u32; 3]) -> u32 {
        let s = self.shift;
        let e = self.entries[self.top_index([v[0] >> s, v[1] >> s, v[2] >> s])];
        voxelmap::descend(&self.entries, e, s, v)
    }

    /// World-space box of a virtual-grid box.
    #[inline]
    pub fn world_box(&self, lo: [u32; 3], hi: [u32; 3]) -> Aabb {
        let f = |v: [u32; 3]| Vec3::new(v[0] as f32, v[1] as f32, v[2] as f32);
        Aabb::new(
            self.bounds.min + f(lo) * self.voxel,
            self.bounds.min + f(hi) * self.voxel,
        )
    }

    /// The triangle indices of cell `c`.
    #[inline]
    pub fn cell_refs(&self, c: usize) -> &[u32] {
        match self.trav.get(c) {
            Some(t) => &self.refs[t.begin as usize..t.end as usize],
            None => &self.refs[self.ref_first[c] as usize..self.ref_first[c + 1] as usize],
        }
    }
}

/// Half the surface area of a virtual-grid box in world units (the SAH area term).
#[inline]
pub(crate) fn half_area(voxel: Vec3, lo: [u32; 3], hi: [u32; 3]) -> f32 {
    let e = Vec3::new(
        (hi[0] - lo[0]) as f32,
        (hi[1] - lo[1]) as f32,
        (hi[2] - lo[2]) as f32,
    ) * voxel;
    e.x * e.y + e.y * e.z + e.z * e.x
}

/// Size of the union of two ascending reference lists (merge-sort style, duplicates once).
pub(crate) fn union_len(a: &[u32], b: &[u32]) -> usize {
    let (mut i, mut j, mut n) = (0, 0, 0);
    while i < a.len() && j < b.len() {
        match a[i].cmp(&b[j]) {
            std::cmp::Ordering::Less => i += 1,
            std::cmp::Ordering::Greater => j += 1,
            std::cmp::Ordering::Equal => {
                i += 1;
                j += 1;
            }
        }
        n += 1;
    }
    n + (a.len() - i) + (b.len() - j)
}

/// Visit the union of two ascending lists in order (duplicates once).
pub(crate) fn union_each(a: &[u32], b: &[u32], f: &mut impl FnMut(u32)) {
    let (mut i, mut j) = (0, 0);
    while i < a.len() && j < b.len() {
        match a[i].cmp(&b[j]) {
            std::cmp::Ordering::Less => {
                f(a[i]);
                i += 1
            }
            std::cmp::Ordering::Greater => {
                f(b[j]);
                j += 1
            }
            std::cmp::Ordering::Equal => {
                f(a[i]);
                i += 1;
                j += 1;
            }
        }
    }
    a[i..].iter().for_each(|&x| f(x));
    b[j..].iter().for_each(|&x| f(x));
}

/// True when ascending `a` ⊆ ascending `b`.
pub(crate) fn is_subset(a: &[u32], b: &[u32]) -> bool {
    let mut j = 0;
    for &x in a {
        while j < b.len() && b[j] < x {
            j += 1;
        }
        if j == b.len() || b[j] != x {
            return false;
        }
        j += 1;
    }
    true
}

/// Build an irregular grid (or, with `merge: false, expansion_passes: 0`, the two-level grid).
pub fn build_grid(tris: &[[Vec3; 3]], cfg: &GridConfig) -> Result<Grid, GridError> {
    Ok(complete(build::initial(tris, cfg)?, cfg))
}

/// [`build_grid`] for tracing only: the build's own arrays are freed as soon as the traversal
/// records no longer need them ([`Grid::shed_build_arrays`]), the footprints before the
/// records are made (on a 2 M-triangle hairball, 0.25 GB less at that point).
pub fn build_grid_for_tracing(tris: &[[Vec3; 3]], cfg: &GridConfig) -> Result<Grid, GridError> {
    let mut g = complete_with(build::initial(tris, cfg)?, cfg, true);
    g.shed_build_arrays();
    Ok(g)
}

/// The passes after the initial cells: merging and expansion as `cfg` asks, then the
/// traversal records.
pub fn complete(g: Grid, cfg: &GridConfig) -> Grid {
    complete_with(g, cfg, false)
}

/// [`complete`]; with `shed`, the footprints go before the traversal records are made.
fn complete_with(mut g: Grid, cfg: &GridConfig, shed: bool) -> Grid {
    if !cfg.merge && g.exp_min.len() != g.cells() {
        // Unmerged cells exit through their own boxes until expansion grows them.
        g.exp_min = g.cell_min.clone();
        g.exp_max = g.cell_max.clone();
    }
    if cfg.merge {
        let t0 = std::time::Instant::now();
        g.build.merge_rounds = merge::merge(&mut g, cfg.alpha, cfg.empty_only, cfg.merge_rule);
        g.build.merge_seconds = t0.elapsed().as_secs_f64();
    }
    if cfg.expansion_passes > 0 {
        let t0 = std::time::Instant::now();
        expand::expand(&mut g, cfg.expansion_passes, cfg.empty_only);
        g.build.expand_seconds = t0.elapsed().as_secs_f64();
    }
    if shed {
        g.cell_min = Vec::new();
        g.cell_max = Vec::new();
    }
    g.trav = cell_records(&g.exp_min, &g.exp_max, &g.ref_first);
    g
}

/// Every cell's record from boxes `lo`/`hi` and the reference ranges `ref_first` (traversal
/// takes the expanded boxes, the merge the cells' own).
pub(crate) fn cell_records(lo: &[[u32; 3]], hi: &[[u32; 3]], ref_first: &[u32]) -> Vec<CellRec> {
    use rayon::prelude::*;
    (0..lo.len())
        .into_par_iter()
        .with_min_len(4096)
        .map(|c| CellRec {
            lo: lo[c],
            hi: hi[c],
            begin: ref_first[c],
            end: ref_first[c + 1],
        })
        .collect()
}

/// The memory model of the grid's build: the resident bytes it adds per triangle at its
/// peak, checked against the memory limit before the build starts. It is the most measured
/// (`bench/results/2026-12-07-2core/memory.txt`, and 891 and 1,069 in a second run): a
/// hairball, the grid paper's worst case (about 20 references per triangle), takes 864–891
/// bytes with merging and 973–1,069 without (`grid2l`); a city of compact triangles takes
/// 402 and 430, so for such scenes the model is twice what they need. The build's level-by-level caps ([`GridConfig::max_bytes`])
/// count references and octree nodes only, not the merge's and the expansion's state, so
/// they alone would not keep the limit.
pub fn build_bytes_per_triangle(cfg: &GridConfig) -> u64 {
    if cfg.merge {
        950
    } else {
        1150
    }
}

/// The irregular grid (or two-level grid) as a tracing engine.
pub struct GridEngine {
    /// The grid.
    pub grid: Grid,
    /// The triangles it indexes (a copy of the scene's).
    pub tris: Vec<[Vec3; 3]>,
    /// `grid` or `grid2l`.
    pub name: &'static str,
}

impl GridEngine {
    /// Build the grid of `cfg` over `geo` (errors name the limit or option at fault).
    pub fn new(geo: &scene::Geometry, cfg: &GridConfig) -> Result<Self, GridError> {
        let grid = build_grid_for_tracing(&geo.tris, cfg)?;
        let name = if cfg.merge || cfg.expansion_passes > 0 {
            "grid"
        } else {
            "grid2l"
        };
        Ok(GridEngine {
            grid,
            tris: geo.tris.clone(),
            name,
        })
    }
}

impl trace::Tracer for GridEngine {
    fn name(&self) -> &str {
        self.name
    }

    fn build_passes(&self) -> Vec<trace::PassTime> {
        self.grid.build.passes().to_vec()
    }

    fn structure_bytes(&self) -> Option<u64> {
        let (c, r, v) = self.grid.memory();
        Some((c + r + v) as u64)
    }

    fn trace(
        &self,
        rays: &trace::RayBatch,
        mode: trace::TraceMode,
        hits: &mut [trace::Hit],
        stats: &mut trace::TraceStats,
    ) {
        use rayon::prelude::*;
        assert_eq!(hits.len(), rays.len(), "one hit record per ray");
        // Chunks of consecutive rays (coherent batches stay coherent within a chunk), each
        // traced eight rays at a time (or, without AVX2, as one interleaved stream).
        const CHUNK: usize = 1024;
        let c = hits
            .par_chunks_mut(CHUNK)
            .enumerate()
            .map(|(k, out)| lanes::trace(&self.grid, &self.tris, rays, k * CHUNK, out, mode))
            .reduce(traverse::RayCounts::default, |a, b| a + b);
        let (steps, tests) = (c.steps, c.tests);
        stats.rays += rays.len() as u64;
        stats.ray_tri_tests += tests;
        stats.hits += hits.iter().filter(|h| h.is_hit()).count() as u64;
        stats.count(TRAVERSAL_STEPS, steps);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn sorted_list_ops(mut a in prop::collection::vec(0u32..200, 0..60), mut b in prop::collection::vec(0u32..200, 0..60)) {
            a.sort_unstable();
            a.dedup();
            b.sort_unstable();
            b.dedup();
            let mut u = Vec::new();
            union_each(&a, &b, &mut |x| u.push(x));
            let mut e: Vec<u32> = a.iter().chain(&b).copied().collect();
            e.sort_unstable();
            e.dedup();
            prop_assert_eq!(&u, &e);
            prop_assert_eq!(union_len(&a, &b), e.len());
            prop_assert_eq!(is_subset(&a, &b), a.iter().all(|x| b.contains(x)));
            prop_assert!(is_subset(&a, &u) && is_subset(&b, &u));
        }
    }
}
