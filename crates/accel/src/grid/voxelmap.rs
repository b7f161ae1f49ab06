//! The voxel map (paper §3, Figure 1): from a virtual-grid voxel to the cell containing it.
//!
//! Entries are u32: a cell index, or [`NODE`] | log₂ of a child block's resolution (k, in
//! bits 27–30) | the index of the block's first entry. A block covers its node with
//! 2^k × 2^k × 2^k entries, child (x, y, z) at x | y << k | z << 2k. This is hagrid's entry
//! layout (`Entry { log_dim, begin }`): the paper's two-level map is the case of one block
//! per top cell, and deeper blocks appear only below octrees deeper than [`MAX_BLOCK_LEVELS`]
//! (the adaptive subdivision's small dense objects), so the map's size follows the cells.
//!
//! The octree build emits the sparse form (every node a 2×2×2 block, k = 1); [`flatten`]
//! turns it into blocks of up to [`MAX_BLOCK_LEVELS`] levels, so a lookup on Sponza reads the
//! top entry and one block entry, as the paper's map, instead of one entry per octree level.

use super::GridError;
use par::SharedMut;
use rayon::prelude::*;

/// The entry is a child block, not a cell.
pub const NODE: u32 = 1 << 31;
/// Where a block entry keeps log₂ of its block's resolution (3 bits: at most
/// [`MAX_BLOCK_LEVELS`]), below [`NODE`]; the 28 bits below it index entries (268 M: a
/// 10 M-triangle hairball's octrees pass 134 M).
pub const LOG_DIM_SHIFT: u32 = 28;
/// The bits of a block entry's log₂ resolution, after the shift.
pub const LOG_DIM_MASK: u32 = 0x7;
/// The index bits of an entry.
pub const INDEX: u32 = (1 << LOG_DIM_SHIFT) - 1;
/// The most octree levels one block holds (8^4 = 4096 entries).
pub const MAX_BLOCK_LEVELS: u32 = 4;

/// An entry pointing at a block of 2^log_dim entries per axis starting at `first`.
#[inline]
pub fn node(first: u32, log_dim: u32) -> u32 {
    debug_assert!(first <= INDEX && (1..=LOG_DIM_MASK).contains(&log_dim));
    NODE | log_dim << LOG_DIM_SHIFT | first
}

/// One level down from block entry `e` (with `NODE` set) covering a node whose voxels are
/// `v >> *s`: the index of the child entry holding voxel `v`; `*s` becomes the child's shift.
#[inline]
pub fn child(e: u32, s: &mut u32, v: [u32; 3]) -> usize {
    let k = (e >> LOG_DIM_SHIFT) & LOG_DIM_MASK;
    *s -= k;
    let m = (1u32 << k) - 1;
    let i = ((v[0] >> *s) & m) | ((v[1] >> *s) & m) << k | ((v[2] >> *s) & m) << (2 * k);
    ((e & INDEX) + i) as usize
}

/// Descend from entry `e` (covering a node whose voxels are v >> s) to the cell of voxel `v`.
#[inline]
pub fn descend(entries: &[u32], mut e: u32, mut s: u32, v: [u32; 3]) -> u32 {
    while e & NODE != 0 {
        e = entries[child(e, &mut s, v)];
    }
    e
}

/// Depth (in octree levels) of the deepest leaf below sparse entry `e`.
fn depth(sparse: &[u32], e: u32) -> u32 {
    if e & NODE == 0 {
        return 0;
    }
    let first = (e & INDEX) as usize;
    1 + (0..8)
        .map(|k| depth(sparse, sparse[first + k]))
        .max()
        .unwrap_or(0)
}

/// A block being written: its entries (relative indices) and the cells in the order their
/// leaves are met (depth first, children in Morton order).
struct Out {
    entries: Vec<u32>,
    cells: Vec<u32>,
}

/// Flatten the subtree of sparse node entry `e` into a block appended to `out`; returns the
/// block's entry (indices relative to `out`'s start).
fn flatten_node(sparse: &[u32], e: u32, out: &mut Out) -> u32 {
    let k = depth(sparse, e).min(MAX_BLOCK_LEVELS);
    let start = out.entries.len();
    out.entries.resize(start + (1usize << (3 * k)), 0);
    paint(sparse, e, [0; 3], [k, k], start, out);
    node(start as u32, k)
}

/// Write sparse entry `e`, covering the block region at `lo` of `lk[0]` octree levels
/// (2^lk[0] voxels per axis of a block of 2^lk[1]), into the block at `start`.
fn paint(sparse: &[u32], e: u32, lo: [u32; 3], lk: [u32; 2], start: usize, out: &mut Out) {
    let [levels, k] = lk;
    if e & NODE == 0 || levels == 0 {
        let v = if e & NODE == 0 {
            out.cells.push(e);
            e
        } else {
            flatten_node(sparse, e, out)
        };
        let n = 1u32 << levels;
        for z in lo[2]..lo[2] + n {
            for y in lo[1]..lo[1] + n {
                for x in lo[0]..lo[0] + n {
                    out.entries[start + (x | y << k | z << (2 * k)) as usize] = v;
                }
            }
        }
        return;
    }
    let first = (e & INDEX) as usize;
    let h = 1u32 << (levels - 1);
    for c in 0..8u32 {
        let clo = [
            lo[0] + (c & 1) * h,
            lo[1] + ((c >> 1) & 1) * h,
            lo[2] + (c >> 2) * h,
        ];
        let child = sparse[first + c as usize];
        paint(sparse, child, clo, [levels - 1, k], start, out);
    }
}

/// Flatten one top cell's sparse octree (node entry `root` of `sparse`, every node a 2×2×2
/// block) into blocks appended to `blocks`, as [`flatten`] does for each top cell; returns
/// the root's entry (block indices relative to `blocks`). The cell ids in `sparse` are kept:
/// the top-cell builder numbers its leaves depth first in Morton order from `first_cell`,
/// which is the map's order (checked in debug builds).
pub(crate) fn flatten_top(
    sparse: &[u32],
    root: u32,
    blocks: &mut Vec<u32>,
    first_cell: u32,
) -> u32 {
    let mut out = Out {
        entries: std::mem::take(blocks),
        cells: Vec::new(),
    };
    let e = flatten_node(sparse, root, &mut out);
    debug_assert!(out
        .cells
        .iter()
        .enumerate()
        .all(|(k, &c)| c == first_cell + k as u32));
    let _ = first_cell;
    *blocks = out.entries;
    e
}

/// A flattened map of `total` entries fits the entries' index bits, or the error naming the
/// options that shrink it (the GPU's cells pass checks its total with the same line).
pub fn check_total(total: u64) -> Result<(), GridError> {
    if total > INDEX as u64 {
        return Err(GridError::TooBig {
            what: "voxel map entries".into(),
            need: total,
            cap: INDEX as u64,
            unit: 4,
            by_memory: None,
        });
    }
    Ok(())
}

/// What [`flatten`] returns.
pub struct Flattened {
    /// The voxel map: top entries, then the blocks.
    pub entries: Vec<u32>,
    /// New cell k is old cell `order[k]`.
    pub order: Vec<u32>,
    /// Old cell c is new cell `new_index[c]`.
    pub new_index: Vec<u32>,
}

/// Flatten a sparse map (entries `0..ntop` the top cells, every node a 2×2×2 block) into
/// blocks of up to [`MAX_BLOCK_LEVELS`] levels, and renumber the cells in the order of the
/// map (top cells in index order, each octree depth first in Morton order), so that cells
/// close in space are close in memory for the merge, the expansion and traversal. Returns
/// the map and the renumbering both ways: new cell k is old cell `order[k]`, and old cell c
/// is new cell `new_index[c]`.
pub fn flatten(sparse: &[u32], ntop: usize, ncells: usize) -> Result<Flattened, GridError> {
    // Each top cell's blocks are made independently (relative indices), then placed after
    // the top entries by an exclusive scan of their sizes.
    let parts: Vec<(u32, Out)> = sparse[..ntop]
        .par_iter()
        .with_min_len(64)
        .map(|&e| {
            let mut out = Out {
                entries: Vec::new(),
                cells: Vec::new(),
            };
            if e & NODE == 0 {
                out.cells.push(e);
                return (e, out);
            }
            let root = flatten_node(sparse, e, &mut out);
            (root, out)
        })
        .collect();
    let total: usize = ntop + parts.iter().map(|p| p.1.entries.len()).sum::<usize>();
    check_total(total as u64)?;
    // The cells in map order, each top cell's at its scanned offset, and the inverse.
    let counts: Vec<u32> = parts.iter().map(|p| p.1.cells.len() as u32).collect();
    let mut cell_at = vec![0u32; ntop];
    let placed = par::exclusive_scan(&counts, &mut cell_at) as usize;
    debug_assert_eq!(placed, ncells, "every cell is one leaf of the map");
    let mut order = vec![0u32; placed];
    let mut new_index = vec![0u32; ncells];
    {
        let (op, np) = (
            SharedMut(order.as_mut_ptr()),
            SharedMut(new_index.as_mut_ptr()),
        );
        parts
            .par_iter()
            .zip(cell_at.par_iter())
            .with_min_len(64)
            .for_each(|(p, &at)| {
                for (k, &c) in p.1.cells.iter().enumerate() {
                    let at = at as usize + k;
                    // SAFETY: top cell t owns [cell_at[t], + its cells) by the scan, and
                    // every cell is one leaf of the map, so each index is written once.
                    unsafe {
                        op.write(at, c);
                        np.write(c as usize, at as u32);
                    }
                }
            });
    }
    let mut base = Vec::with_capacity(ntop);
    let mut at = ntop as u32;
    for p in &parts {
        base.push(at);
        at += p.1.entries.len() as u32;
    }
    // Blocks move by their base; cells take their new index.
    let rebase = |e: u32, b: u32| {
        if e & NODE == 0 {
            new_index[e as usize]
        } else {
            e + b // the index field cannot overflow: total ≤ INDEX
        }
    };
    let mut entries = vec![0u32; total];
    let (top, rest) = entries.split_at_mut(ntop);
    for (t, p) in parts.iter().enumerate() {
        top[t] = rebase(p.0, base[t]);
    }
    let mut slices: Vec<&mut [u32]> = Vec::with_capacity(ntop);
    let mut tail = rest;
    for p in &parts {
        let (a, b) = tail.split_at_mut(p.1.entries.len());
        slices.push(a);
        tail = b;
    }
    slices
        .into_par_iter()
        .zip(parts.par_iter().zip(base.par_iter()))
        .with_min_len(64)
        .for_each(|(dst, (p, &b))| {
            for (d, &e) in dst.iter_mut().zip(&p.1.entries) {
                *d = rebase(e, b);
            }
        });
    Ok(Flattened {
        entries,
        order,
        new_index,
    })
}
