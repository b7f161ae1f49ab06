//! Cell expansion (paper §4.3): grow a cell's *exit* box over neighbours that hold a subset
//! of its references, by the smallest neighbour overhang, one axis and side at a time. The
//! voxel map is unchanged (entering a cell still uses it), so a ray exiting an expanded box
//! skips cells whose triangles it has already tested.

use super::{is_subset, Grid};
use rayon::prelude::*;

/// `passes` expansion passes, each over x, y, z and both sides.
///
/// A side's walk reads only its own cell's expanded box and the neighbours' *initial* boxes
/// and lists, never another cell's expanded box. So the paper's schedule (pass by pass, side
/// by side, every cell in parallel) gives the same boxes as running each cell's sides in that
/// order on their own, which is what this does: one parallel loop over the cells, each cell's
/// sides one after another while its list and its neighbourhood are in cache, instead of one
/// sweep over every cell's boxes per pass and side.
///
/// A side that cannot grow stays blocked in every later pass: its face layer does not move,
/// and the face only widens as other sides grow, so the neighbour that stopped it is still
/// there. Blocked sides are therefore not walked again, and a cell stops when all six are
/// blocked. The result is the same.
///
/// With `empty_only`, only empty cells grow (over empty neighbours): Devillers's macro
/// regions.
pub fn expand(g: &mut Grid, passes: u32, empty_only: bool) {
    let mut exp_min = std::mem::take(&mut g.exp_min);
    let mut exp_max = std::mem::take(&mut g.exp_max);
    let gr = &*g;
    exp_min
        .par_iter_mut()
        .zip(exp_max.par_iter_mut())
        .enumerate()
        .with_min_len(1024)
        .for_each(|(c, (lo, hi))| {
            let mut blocked = if empty_only && !gr.cell_refs(c).is_empty() {
                ALL_SIDES
            } else {
                0
            };
            for _ in 0..passes {
                for axis in 0..3 {
                    for positive in [false, true] {
                        let bit = 1u8 << (2 * axis + positive as usize);
                        if blocked & bit == 0 {
                            let (l, h) = expand_side(gr, c, (*lo, *hi), axis, positive);
                            if (l, h) == (*lo, *hi) {
                                blocked |= bit;
                            } else {
                                (*lo, *hi) = (l, h);
                            }
                        }
                    }
                }
                if blocked == ALL_SIDES {
                    break;
                }
            }
        });
    g.exp_min = exp_min;
    g.exp_max = exp_max;
}

/// The six sides' bits (bit 2·axis + positive).
const ALL_SIDES: u8 = 0x3f;

/// The cells on one side of cell c's expanded box `(lo, hi)` (the voxel layer just outside
/// the face): if all hold subsets of c's references, the box grows by the smallest overhang.
fn expand_side(
    g: &Grid,
    c: usize,
    (mut lo, mut hi): ([u32; 3], [u32; 3]),
    axis: usize,
    positive: bool,
) -> ([u32; 3], [u32; 3]) {
    let layer = if positive {
        if hi[axis] >= g.dims[axis] {
            return (lo, hi);
        }
        hi[axis]
    } else {
        if lo[axis] == 0 {
            return (lo, hi);
        }
        lo[axis] - 1
    };
    let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
    let mine = g.cell_refs(c);
    let mut step = u32::MAX;
    // Walk the face layer, jumping over each neighbour's footprint along u.
    let mut pv = lo[v];
    while pv < hi[v] {
        let mut pu = lo[u];
        let mut row_next = u32::MAX;
        while pu < hi[u] {
            let mut p = [0u32; 3];
            p[axis] = layer;
            p[u] = pu;
            p[v] = pv;
            let n = g.lookup(p) as usize;
            if !is_subset(g.cell_refs(n), mine) {
                return (lo, hi);
            }
            let over = if positive {
                g.cell_max[n][axis] - layer
            } else {
                layer + 1 - g.cell_min[n][axis]
            };
            step = step.min(over);
            row_next = row_next.min(g.cell_max[n][v]);
            pu = g.cell_max[n][u];
        }
        pv = row_next.max(pv + 1);
    }
    if positive {
        hi[axis] += step;
    } else {
        lo[axis] -= step;
    }
    (lo, hi)
}
