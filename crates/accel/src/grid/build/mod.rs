//! Initial irregular-grid construction (paper §4.1): top-level grid, per-cell octrees,
//! references by exact triangle–box tests, and the hierarchical voxel map.
//!
//! The octrees are built level by level, as the paper's reference implementation (hagrid's
//! `build_iter`) does: every reference of a node that splits is tested against the node's 8
//! children and re-emitted for those it overlaps (count → scan → emit), and only *non-empty*
//! nodes split. Empty space is therefore never materialised at the finest resolution (on
//! Sponza this is 2.4× fewer initial cells than a dense 8^D block per top cell), and every
//! pass is a flat loop over references or nodes.
//!
//! A node whose every reference overlaps all 8 of its children stays a leaf whatever the rule
//! says: splitting it would make 8 cells with one list, which traversal would visit in turn
//! and merging would put back together.
//!
//! Which nodes split ([`Subdivision`]):
//! - `paper`: eq. 1 with λ₂ and the *top cell's* primitive count gives one octree depth D per
//!   top cell (rounded up to a power of two, §4.1); non-empty nodes split until depth D.
//! - `adaptive` (the paper's §7 future work, "changing the initial subdivision scheme"): as
//!   `paper`, and below depth D a node keeps splitting while its *own* count calls for it:
//!   λ₂ · (its references to triangles at most half its size) ≥ `ADAPTIVE_SPLIT` (eq. 1 on
//!   the node asks for 4 cells per axis), up to the maximum depth. A small dense object in a
//!   huge top cell (the teapot in a stadium) thus gets cells its own size, while regions the
//!   paper's rule already resolves are unchanged. Such a split is kept only while it
//!   separates: its children must receive fewer than `ADAPTIVE_COPIES` copies of each
//!   reference on average.
//!
//! Robustness: node boxes are grown by [`ref_padding`] for every reference test, so a triangle
//! within rounding distance of a boundary is referenced on both sides.
//!
//! Two schedules make the same grid bit for bit (tested): level by level ([`subdivide`],
//! then [`finish`]; the GPU's passes mirror it) and top cell by top cell ([`initial`], the
//! CPU's: each octree depth first in cache, the cells written once in map order; see
//! `topcells.rs`).

use super::voxelmap::{self, INDEX};
use super::{BuildStats, Grid, GridConfig, GridError, Subdivision};
use geom::aabb::TriBoxSat;
use geom::{Aabb, Vec3};
use par::{emit_pairs, exclusive_scan, SharedMut};
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use std::time::Instant;

mod cells;
mod octrees;
mod topcells;
pub use cells::{assemble, finish};
pub use octrees::subdivide;
pub use topcells::initial;

/// Cleary's resolution (paper eq. 1): R = d · cbrt(λ N / V), at least 1 per axis.
pub fn resolution(extent: Vec3, n: usize, density: f32) -> [u32; 3] {
    let v = (extent.x * extent.y * extent.z).max(1e-30);
    let k = (density * n as f32 / v).cbrt();
    let r = |e: f32| ((e * k).ceil() as u32).clamp(1, 512);
    [r(extent.x), r(extent.y), r(extent.z)]
}

/// The scene box padded by 0.1% per side (as hagrid), with no axis thinner than 1e-3 of the
/// largest, so flat scenes still get volume.
pub fn padded_bounds(tris: &[[Vec3; 3]]) -> Aabb {
    let b = tris
        .par_iter()
        .with_min_len(4096)
        .map(Aabb::of_triangle)
        .reduce(Aabb::default, |a, b| a.union(&b));
    pad_bounds(b)
}

/// [`padded_bounds`] from the triangles' box `b` (the GPU reduces the box on the device).
pub fn pad_bounds(b: Aabb) -> Aabb {
    let e = b.extent();
    let m = e.max_element().max(1e-6);
    let pad = (e * 0.001).max(Vec3::splat(m * 1e-3));
    Aabb::new(b.min - pad, b.max + pad)
}

/// How far cell boxes are grown for reference tests: far above the rounding of coordinates
/// of this magnitude (f32 ε ≈ 1.2e-7) and far below a voxel.
pub fn ref_padding(bounds: &Aabb) -> f32 {
    let m = bounds
        .min
        .abs()
        .max(bounds.max.abs())
        .max_element()
        .max(bounds.diagonal());
    m * 1e-5
}

/// The reference padding of `grid`, for checks that must use the builder's boxes.
pub fn padding(grid: &Grid) -> f32 {
    ref_padding(&grid.bounds)
}

/// The deepest octree level whose virtual grid still has exact f32 voxel coordinates
/// (top_dims · 2^level ≤ 2^24), so traversal's voxel arithmetic stays exact.
fn coordinate_depth_limit(top_dims: [u32; 3]) -> u32 {
    let m = top_dims.iter().copied().max().unwrap_or(1).max(1);
    24 - (32 - (m - 1).leading_zeros()).min(24)
}

/// `ceil(log2(m))` for m ≥ 1.
#[inline]
fn ceil_log2(m: u32) -> u32 {
    32 - (m.max(1) - 1).leading_zeros()
}

/// The geometry every reference test of one build shares.
struct Frame<'a> {
    tris: &'a [[Vec3; 3]],
    /// Per-triangle bounding boxes (the cheap half-space prefilter of every split).
    tri_box: Vec<Aabb>,
    bounds: Aabb,
    tsize: Vec3,
    pad: f32,
}

impl<'a> Frame<'a> {
    /// The build's [`Setup`] and frame for `tris` (both schedules of the initial cells start
    /// here): the triangles' boxes, their union, and every check before the first pass.
    fn of(tris: &'a [[Vec3; 3]], cfg: &GridConfig) -> Result<(Setup, Frame<'a>), GridError> {
        let (tri_box, tb) = geom::aabb::triangle_boxes(tris);
        let st = setup(tb, tris.len(), cfg)?;
        let frame = Frame {
            tris,
            tri_box,
            bounds: st.bounds,
            tsize: st.tsize,
            pad: st.pad,
        };
        Ok((st, frame))
    }
}

impl Frame<'_> {
    /// The centre of the node at integer coordinates `c` of octree level `level`.
    #[inline]
    fn node_centre(&self, c: [u32; 3], level: u32) -> Vec3 {
        let size = self.tsize / (1u32 << level) as f32;
        self.bounds.min
            + (Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32) + Vec3::splat(0.5)) * size
    }

    /// The padded half-extent shared by every node of octree level `level`.
    #[inline]
    fn node_half(&self, level: u32) -> Vec3 {
        self.tsize / (2u32 << level) as f32 + Vec3::splat(self.pad)
    }

    /// Which of the 8 children of node `c` (level `level`) triangle `t` overlaps, child k at
    /// 2c + (k & 1, (k >> 1) & 1, k >> 2). The triangle overlaps the node's padded box.
    /// Children its box misses are dropped by half-space tests first (hagrid's
    /// `compute_split_masks`); a single remaining child needs no test, since the triangle
    /// meets the parent box and lies entirely inside that child's half-spaces. The others
    /// share one prepared separating-axis test (same axes, same radii), run for the 8
    /// children at once in SIMD lanes ([`TriBoxSat::overlaps8`], the same bits as 8 tests).
    /// `prep` caches the prepared test of the last triangle: a level's references come in
    /// triangle order, so a triangle spanning many nodes is prepared once per run of them
    /// (the prepared values are the same however often they are made).
    fn child_mask(&self, c: [u32; 3], level: u32, t: usize, prep: &mut Prepared) -> u8 {
        let mask = self.half_space_mask(c, level, t);
        if mask.count_ones() <= 1 {
            return mask;
        }
        if prep.tri != t {
            let sat = TriBoxSat::new(&self.tris[t]);
            *prep = Prepared {
                tri: t,
                radii: sat.radii(self.node_half(level + 1)),
                sat,
            };
        }
        prep.sat
            .overlaps8(&self.child_centres(c, level), &prep.radii)
            & mask
    }

    /// The children of node `c` (level `level`) whose half-spaces triangle `t`'s box reaches
    /// (all 8 bits where the box straddles every mid-plane).
    #[inline]
    fn half_space_mask(&self, c: [u32; 3], level: u32, t: usize) -> u8 {
        self.mid_planes(c, level).mask(&self.tri_box[t])
    }

    /// Node `c`'s (level `level`) mid-planes, padded to both sides.
    #[inline]
    fn mid_planes(&self, c: [u32; 3], level: u32) -> MidPlanes {
        let size = self.tsize / (1u32 << (level + 1)) as f32;
        let mid: [f32; 3] =
            std::array::from_fn(|k| self.bounds.min[k] + (2 * c[k] + 1) as f32 * size[k]);
        MidPlanes {
            above: mid.map(|m| m + self.pad),
            below: mid.map(|m| m - self.pad),
        }
    }

    /// The centres of node `c`'s 8 children (level `level` + 1) as `node_centre` computes
    /// them, one lane each.
    #[inline]
    fn child_centres(&self, c: [u32; 3], level: u32) -> [[f32; 8]; 3] {
        let size = self.tsize / (1u32 << (level + 1)) as f32;
        let mut centres = [[0f32; 8]; 3];
        for (k, axis) in centres.iter_mut().enumerate() {
            for (lane, v) in axis.iter_mut().enumerate() {
                let cc = 2 * c[k] + ((lane >> k) & 1) as u32;
                *v = self.bounds.min[k] + (cc as f32 + 0.5) * size[k];
            }
        }
        centres
    }
}

/// A node's mid-planes per axis, padded up (`above`) and down (`below`): a box wholly above
/// `above[k]` misses the low children along k, one wholly below `below[k]` the high ones.
struct MidPlanes {
    above: [f32; 3],
    below: [f32; 3],
}

impl MidPlanes {
    /// The children (bit k: child k, at (k & 1, (k >> 1) & 1, k >> 2)) whose half-spaces
    /// box `tb` reaches.
    #[inline]
    fn mask(&self, tb: &Aabb) -> u8 {
        const LOW: [u8; 3] = [0x55, 0x33, 0x0f];
        let mut mask = 0xffu8;
        for (k, low) in LOW.iter().enumerate() {
            if tb.min[k] > self.above[k] {
                mask &= !low;
            }
            if tb.max[k] < self.below[k] {
                mask &= low;
            }
        }
        mask
    }
}

/// A triangle's prepared separating-axis test and its radii for one octree level's children
/// (`tri == usize::MAX`: none yet).
struct Prepared {
    tri: usize,
    sat: TriBoxSat,
    radii: [f32; 13],
}

impl Prepared {
    fn none() -> Prepared {
        Prepared {
            tri: usize::MAX,
            sat: TriBoxSat::new(&[Vec3::ZERO; 3]),
            radii: [0.0; 13],
        }
    }
}

/// Emit (key, tri) pairs through count → exclusive scan → emit (`par::emit_pairs`), the
/// total checked against the reference cap before anything is allocated for it.
fn count_scan_emit(
    lim: &Limits,
    n: usize,
    count: impl Fn(usize) -> u32 + Sync,
    emit: impl Fn(usize, &mut dyn FnMut(u32, u32)) + Sync,
) -> Result<(Vec<u32>, Vec<u32>), GridError> {
    emit_pairs(n, count, |total| lim.check_refs(total), emit)
}

/// Most references one build holds, per level and in all, whatever the memory: the larger
/// of 2^28 and [`REFS_PER_TRIANGLE`] per triangle, at most 2^30 (which keeps every
/// reference offset and cell count within u32, and the merge's pool, compacted before it
/// passes 4× the initial references or u32, too).
const MAX_REFS: [u64; 2] = [1 << 28, 1 << 30];
/// Most voxel-map entries (octree nodes) one build makes, whatever the memory: the larger of
/// 2^25 and [`NODES_PER_TRIANGLE`] per triangle, at most the voxel map's index range.
const MAX_NODES: [u64; 2] = [1 << 25, voxelmap::INDEX as u64];
/// The caps grow with the input past their floors: a 10 M-triangle hairball needs 135 M
/// octree nodes and 322 M references at its deepest level, while absurd densities on a
/// small scene are still refused at the floors, after a few GB at most, not most of the
/// machine's memory.
const REFS_PER_TRIANGLE: u64 = 64;
const NODES_PER_TRIANGLE: u64 = 32;

/// The grid's memory model: the peak bytes a reference costs while a level is built (node
/// and triangle of the level's list, the count/scan/emit keys and values, the kept-cell
/// and kept-triangle lists, the kept-at scan: 6 × u32) …
pub const BYTES_PER_REF: u64 = 24;
/// … and an octree node (coordinates, top cell, child base, leaf index, counts (all, and
/// small ones for adaptive splits), the adaptive split's reference copies, the voxel-map
/// entry and its share of the next level's coordinates: 13 × u32).
pub const BYTES_PER_NODE: u64 = 52;

/// The build's caps: the fixed index limits, lowered to what `max_bytes` holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Limits {
    /// Most references, per level and in all.
    pub refs: u64,
    /// Most octree nodes (voxel-map entries) and cells.
    pub nodes: u64,
    max_bytes: u64,
}

impl Limits {
    fn of(cfg: &GridConfig, ntris: usize) -> Limits {
        let n = ntris as u64;
        let refs = (REFS_PER_TRIANGLE * n).clamp(MAX_REFS[0], MAX_REFS[1]);
        let nodes = (NODES_PER_TRIANGLE * n).clamp(MAX_NODES[0], MAX_NODES[1]);
        Limits {
            refs: refs.min(cfg.max_bytes / BYTES_PER_REF),
            nodes: nodes.min(cfg.max_bytes / BYTES_PER_NODE),
            max_bytes: cfg.max_bytes,
        }
    }

    /// The error for a level that would pass a cap: which, and whether memory set it.
    fn error(&self, what: &str, need: u64, cap: u64, unit: u64) -> GridError {
        let by_memory = cap * unit >= self.max_bytes.saturating_sub(unit);
        GridError::TooBig {
            what: what.to_string(),
            need,
            cap,
            unit,
            by_memory: by_memory.then_some(self.max_bytes),
        }
    }

    fn refs_error(&self, need: u64) -> GridError {
        self.error("triangle references", need, self.refs, BYTES_PER_REF)
    }

    /// `total` references in a level or in all: within the cap, or the error naming it.
    pub fn check_refs(&self, total: u64) -> Result<(), GridError> {
        if total > self.refs {
            Err(self.refs_error(total))
        } else {
            Ok(())
        }
    }

    /// `need` nodes or cells after octree level `level`: within the cap, or the error.
    pub fn check_nodes(&self, need: u64, level: u32) -> Result<(), GridError> {
        if need >= self.nodes {
            Err(self.error(
                &format!("octree nodes at level {level}"),
                need,
                self.nodes,
                BYTES_PER_NODE,
            ))
        } else {
            Ok(())
        }
    }
}

/// Most top-level cells.
const MAX_TOP: u64 = 1 << 24;

/// References to the top cells: (top cell, triangle), in triangle order, by exact tests.
/// A triangle whose padded box lies in one top cell needs no test; the count pass keeps the
/// overlap bits of ranges up to 64 cells so the emit pass does not test them again.
fn top_refs(
    f: &Frame,
    top_dims: [u32; 3],
    lim: &Limits,
) -> Result<(Vec<u32>, Vec<u32>), GridError> {
    let range = |t: usize| {
        let b = &f.tri_box[t];
        let lo = ((b.min - Vec3::splat(f.pad) - f.bounds.min) / f.tsize).floor();
        let hi = ((b.max + Vec3::splat(f.pad) - f.bounds.min) / f.tsize).floor();
        let c = |v: f32, k: usize| (v.max(0.0) as u32).min(top_dims[k] - 1);
        (
            [c(lo.x, 0), c(lo.y, 1), c(lo.z, 2)],
            [c(hi.x, 0), c(hi.y, 1), c(hi.z, 2)],
        )
    };
    // The top cells of a range, x fastest, as (index, centre).
    let cells = |(lo, hi): ([u32; 3], [u32; 3])| {
        (lo[2]..=hi[2]).flat_map(move |z| {
            (lo[1]..=hi[1]).flat_map(move |y| {
                (lo[0]..=hi[0]).map(move |x| {
                    let i = x + top_dims[0] * (y + top_dims[1] * z);
                    (i, f.node_centre([x, y, z], 0))
                })
            })
        })
    };
    let half = f.node_half(0);
    let big = |r: ([u32; 3], [u32; 3])| {
        (0..3)
            .map(|k| (r.1[k] - r.0[k] + 1) as u64)
            .product::<u64>()
            > 64
    };
    // The top cells triangle t overlaps, as (position in its range, index); a range of one
    // cell needs no test.
    let overlapping = |t: usize| {
        let r = range(t);
        let sat = (r.0 != r.1).then(|| {
            let sat = TriBoxSat::new(&f.tris[t]);
            (sat, sat.radii(half))
        });
        cells(r)
            .enumerate()
            .filter(move |(_, (_, c))| sat.as_ref().is_none_or(|(s, radii)| s.overlaps(*c, radii)))
            .map(|(k, (i, _))| (k, i))
    };
    // The overlap bits of a range of up to 64 cells (bit k: its k-th cell), the cells'
    // tests 8 at a time in SIMD lanes (`TriBoxSat::overlaps8`: the same bits as one test
    // per cell, each lane's centre computed as `node_centre` computes it).
    let small_bits = |t: usize, (lo, hi): ([u32; 3], [u32; 3])| -> u64 {
        let n = (0..3).map(|k| hi[k] - lo[k] + 1).product::<u32>() as usize;
        if n == 1 {
            return 1;
        }
        let sat = TriBoxSat::new(&f.tris[t]);
        let radii = sat.radii(half);
        let mut centres = [[0f32; 8]; 3];
        let mut bits = 0u64;
        for (k, (_, c)) in cells((lo, hi)).enumerate() {
            let lane = k & 7;
            for (axis, v) in centres.iter_mut().enumerate() {
                v[lane] = c[axis];
            }
            if lane == 7 || k + 1 == n {
                // Lanes past the range's end hold stale centres: masked off.
                let live = if lane == 7 {
                    0xff
                } else {
                    (1u8 << (lane + 1)) - 1
                };
                let m = sat.overlaps8(&centres, &radii) & live;
                bits |= (m as u64) << (k & !7);
            }
        }
        bits
    };
    // Ranges of up to 64 cells keep their overlaps as bits, so the emit pass does not test
    // them again; larger ranges keep their count and are tested again when emitted.
    let bits: Vec<u64> = (0..f.tris.len())
        .into_par_iter()
        .with_min_len(1024)
        .map(|t| {
            let r = range(t);
            if big(r) {
                return overlapping(t).count() as u64;
            }
            small_bits(t, r)
        })
        .collect();
    count_scan_emit(
        lim,
        f.tris.len(),
        |t| {
            if big(range(t)) {
                bits[t] as u32
            } else {
                bits[t].count_ones()
            }
        },
        |t, out| {
            let r = range(t);
            if big(r) {
                overlapping(t).for_each(|(_, i)| out(i, t as u32));
            } else {
                for (k, (i, _)) in cells(r).enumerate() {
                    if bits[t] >> k & 1 != 0 {
                        out(i, t as u32);
                    }
                }
            }
        },
    )
}

/// `vals` grouped by `keys` into the ranges `first[k]..first[k + 1]` (the exclusive scan of
/// the keys' counts, its total last), each range then ascending: one cursor per key scatters
/// in parallel, and the sort makes the result independent of the scheduling.
fn group_sorted(first: &[u32], keys: &[u32], vals: &[u32]) -> Vec<u32> {
    let n = first.len() - 1;
    let cursor: Vec<AtomicU32> = first[..n]
        .par_iter()
        .with_min_len(4096)
        .map(|&f| AtomicU32::new(f))
        .collect();
    let mut out = vec![0u32; first[n] as usize];
    {
        let op = SharedMut(out.as_mut_ptr());
        keys.par_iter()
            .zip(vals.par_iter())
            .with_min_len(4096)
            .for_each(|(&k, &v)| {
                let at = cursor[k as usize].fetch_add(1, Ordering::Relaxed);
                let op = &op;
                // SAFETY: each cursor hands out distinct slots of its key's range.
                unsafe { op.write(at as usize, v) };
            });
    }
    {
        let op = SharedMut(out.as_mut_ptr());
        (0..n).into_par_iter().with_min_len(256).for_each(|k| {
            let (a, b) = (first[k] as usize, first[k + 1] as usize);
            // The wrapper, not its raw field, crosses threads.
            let whole = &op;
            // SAFETY: the keys' ranges are disjoint.
            unsafe { std::slice::from_raw_parts_mut(whole.0.add(a), b - a) }.sort_unstable();
        });
    }
    out
}

/// Below the paper's depth, an adaptive node splits while λ₂ · (its references to triangles
/// at most half its size) reaches this: eq. 1 on the node asks for this many cells.
pub const ADAPTIVE_SPLIT: f32 = 64.0;

/// An adaptive split is made only while its children receive fewer than this many copies of
/// each reference on average (8: no separation at all). Measured (`grid_build`,
/// `grid_trace`): 3 keeps the stadium's 23 tests per primary ray (2 gives 45) and cuts
/// Conference's adaptive build from 680 to 555 ms (its deepest levels had copied fans of
/// small triangles around shared vertices: 3.3 M references in 17 k nodes at level 9).
pub const ADAPTIVE_COPIES: f32 = 3.0;

/// Reference counts per node (a histogram; the GPU's atomic add); keys ≥ n are not counted.
fn histogram(keys: &[u32], n: usize) -> Vec<u32> {
    let h: Vec<AtomicU32> = (0..n).map(|_| AtomicU32::new(0)).collect();
    keys.par_iter().with_min_len(4096).for_each(|&k| {
        if (k as usize) < n {
            h[k as usize].fetch_add(1, Ordering::Relaxed);
        }
    });
    h.into_iter().map(AtomicU32::into_inner).collect()
}

/// The octree depth the paper gives a top cell of `n` references: eq. 1 with λ₂, each axis's
/// resolution truncated (at least 1) as the paper's reference code (hagrid's
/// `compute_grid_dims`) does, the largest rounded up to a power of two.
///
/// Rounding each axis up before the power of two (as this build did until 2026-12-02) gave
/// a top cell of 27–213 references depth 3 where truncation gives 2 from 27 up to 106: 8×
/// the leaves. Truncation reproduces the paper's Table 1 on Sponza (N_I 11.0 per primary
/// ray after merge and expansion; published 11, rounding up gave 8.5) and builds Sponza and
/// Conference in 0.66–0.78× the time (same run, 512² primary and random rays) for trace
/// times within the machine's noise (−8 % to +22 %).
fn paper_depth(tsize: Vec3, n: u32, leaf_density: f32, max_depth: u32) -> u32 {
    if n == 0 {
        return 0; // Empty cells never split.
    }
    let v = (tsize.x * tsize.y * tsize.z).max(1e-30);
    let k = (leaf_density * n as f32 / v).cbrt();
    let r = |e: f32| ((e * k) as u32).clamp(1, 512);
    ceil_log2(r(tsize.x).max(r(tsize.y)).max(r(tsize.z))).min(max_depth)
}

/// The frame of one build (§4.1), from the triangles' box and count alone: the CPU and the
/// GPU (which reduces the box on the device) derive the same one with this function.
#[derive(Clone, Debug, PartialEq)]
pub struct Setup {
    /// Padded scene box ([`pad_bounds`]).
    pub bounds: Aabb,
    /// Top-grid resolution (eq. 1 with λ₁).
    pub top_dims: [u32; 3],
    /// Size of a top cell.
    pub tsize: Vec3,
    /// Reference-test padding ([`ref_padding`]).
    pub pad: f32,
    /// Top cells.
    pub ntop: usize,
    /// Deepest octree level: the configuration's, within exact voxel coordinates.
    pub max_depth: u32,
    /// The build's caps.
    pub limits: Limits,
}

/// The checks of a build's input before anything is computed: the configuration, and a
/// triangle count the references can index.
pub fn check_input(ntris: usize, cfg: &GridConfig) -> Result<(), GridError> {
    cfg.validate()?;
    if ntris == 0 {
        return Err(GridError::NoTriangles);
    }
    if ntris >= (INDEX as usize) {
        return Err(GridError::TooManyTriangles(ntris));
    }
    Ok(())
}

/// The build's [`Setup`] for `ntris` triangles whose box is `tri_bounds`, with every check
/// that precedes the first pass.
pub fn setup(tri_bounds: Aabb, ntris: usize, cfg: &GridConfig) -> Result<Setup, GridError> {
    check_input(ntris, cfg)?;
    let bounds = pad_bounds(tri_bounds);
    let ext = bounds.extent();
    let top_dims = resolution(ext, ntris, cfg.top_density);
    let ntop = top_dims.iter().map(|&d| d as u64).product::<u64>();
    if ntop > MAX_TOP {
        return Err(GridError::TopGrid {
            dims: top_dims,
            cap: MAX_TOP,
        });
    }
    let limits = Limits::of(cfg, ntris);
    if ntop >= limits.nodes {
        return Err(limits.error("top cells", ntop, limits.nodes, BYTES_PER_NODE));
    }
    Ok(Setup {
        bounds,
        top_dims,
        tsize: ext / Vec3::new(top_dims[0] as f32, top_dims[1] as f32, top_dims[2] as f32),
        pad: ref_padding(&bounds),
        ntop: ntop as usize,
        max_depth: cfg.max_depth.min(coordinate_depth_limit(top_dims)),
        limits,
    })
}

impl Setup {
    /// The paper's octree depth as a table: entry d − 1 is the smallest reference count whose
    /// top cell gets depth ≥ d (u32::MAX when none does), so a count's depth is the number of
    /// entries at or below it. Eq. 1 rises with the count, which makes the table exact (a
    /// test checks it against [`Setup::paper_depth`] count by count); the GPU reads the
    /// table instead of evaluating `cbrt`, whose last bit a device may round differently.
    pub fn depth_table(&self, leaf_density: f32, ntris: usize) -> Vec<u32> {
        (1..=self.max_depth)
            .map(|d| {
                let hi = ntris.min(u32::MAX as usize - 1) as u32;
                if self.paper_depth(hi, leaf_density) < d {
                    return u32::MAX;
                }
                // The first count in [1, hi] with depth ≥ d.
                let (mut lo, mut hi) = (1u32, hi);
                while lo < hi {
                    let mid = lo + (hi - lo) / 2;
                    if self.paper_depth(mid, leaf_density) >= d {
                        hi = mid;
                    } else {
                        lo = mid + 1;
                    }
                }
                lo
            })
            .collect()
    }

    /// The octree depth the paper gives a top cell of `n` references.
    pub fn paper_depth(&self, n: u32, leaf_density: f32) -> u32 {
        paper_depth(self.tsize, n, leaf_density, self.max_depth)
    }
}

/// The octrees of §4.1 before the voxel map is flattened: the state the GPU's subdivision
/// passes must reproduce bit for bit.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Octrees {
    /// The sparse voxel map, level after level: a node's entry is its leaf cell (level
    /// order) or [`voxelmap::node`] of its 8 children's first entry.
    pub entries: Vec<u32>,
    /// Leaf cells in level order: octree coordinates at their level …
    pub cell_coord: Vec<[u32; 3]>,
    /// … their level …
    pub cell_level: Vec<u8>,
    /// … and their reference counts.
    pub cell_count: Vec<u32>,
    /// Final references (leaf cell, triangle), grouped by level, in each level's order.
    pub kept_cell: Vec<u32>,
    /// The triangles of `kept_cell`'s references.
    pub kept_tri: Vec<u32>,
    /// Levels below the top (the virtual grid's shift).
    pub levels: u32,
}

/// The initial structure level by level ([`subdivide`], then [`finish`]): the passes the GPU
/// mirrors, and the reference [`initial`] (top cell by top cell) is tested against.
pub fn initial_by_levels(tris: &[[Vec3; 3]], cfg: &GridConfig) -> Result<Grid, GridError> {
    let (setup, oct, [top_refs_seconds, octree_seconds]) = subdivide(tris, cfg)?;
    let mut g = finish(&setup, oct)?;
    g.build.top_refs_seconds = top_refs_seconds;
    g.build.octree_seconds = octree_seconds;
    Ok(g)
}

#[cfg(test)]
mod tests;
