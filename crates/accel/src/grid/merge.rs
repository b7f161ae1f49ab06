//! SAH cell merging (paper §4.2).
//!
//! A pass along one axis: every cell whose +axis face neighbour is exactly aligned (same
//! extent on the other two axes) and whose merge lowers the SAH cost — with C_t = C_i = 1,
//! (|T₁ ∪ T₂| + 1)·A(B₁ ∪ B₂) ≤ (|T₁| + 1)·A(B₁) + (|T₂| + 1)·A(B₂), A the half surface
//! area — becomes a merge candidate. Candidates form chains; walking each chain, cells at
//! even positions merge with their successor, which becomes residue. Reference lists merge
//! like merge sort (ascending, duplicates once) and the voxel map is remapped to the new
//! cells. Passes alternate x, y, z; merging stops when a round keeps at least α of the cells.

use super::{half_area, union_each, union_len, Grid, NODE};
use par::{exclusive_scan, SharedMut};
use rayon::prelude::*;

const NONE: u32 = u32::MAX;

/// Merge until a full x, y, z round keeps at least `alpha` of the cells; returns the rounds.
pub fn merge(g: &mut Grid, alpha: f32) -> usize {
    let mut rounds = 0;
    loop {
        let before = g.cells();
        for axis in 0..3 {
            merge_pass(g, axis);
        }
        rounds += 1;
        let after = g.cells();
        if after == before || after as f64 >= alpha as f64 * before as f64 {
            break;
        }
    }
    rounds
}

/// The +axis neighbour of cell i when it is exactly aligned, else NONE.
fn aligned_neighbour(g: &Grid, i: usize, axis: usize) -> u32 {
    let (lo, hi) = (g.cell_min[i], g.cell_max[i]);
    if hi[axis] >= g.dims[axis] {
        return NONE;
    }
    let mut p = lo;
    p[axis] = hi[axis];
    let j = g.lookup(p) as usize;
    let (jl, jh) = (g.cell_min[j], g.cell_max[j]);
    let aligned = (0..3).all(|k| {
        if k == axis {
            jl[k] == hi[k]
        } else {
            jl[k] == lo[k] && jh[k] == hi[k]
        }
    });
    if aligned {
        j as u32
    } else {
        NONE
    }
}

/// One merge pass along `axis`; returns how many cells were removed.
pub fn merge_pass(g: &mut Grid, axis: usize) -> usize {
    let n = g.cells();
    // 1. Merge candidates: next[i] = the neighbour i would absorb.
    let next: Vec<u32> = (0..n)
        .into_par_iter()
        .map(|i| {
            let j = aligned_neighbour(g, i, axis);
            if j == NONE {
                return NONE;
            }
            let j = j as usize;
            let (ri, rj) = (g.cell_refs(i), g.cell_refs(j));
            let ai = half_area(g.voxel, g.cell_min[i], g.cell_max[i]);
            let aj = half_area(g.voxel, g.cell_min[j], g.cell_max[j]);
            let mut hi = g.cell_max[i];
            hi[axis] = g.cell_max[j][axis];
            let au = half_area(g.voxel, g.cell_min[i], hi);
            let nu = union_len(ri, rj) as f32;
            let merged = au * (nu + 1.0);
            let separate = ai * (ri.len() as f32 + 1.0) + aj * (rj.len() as f32 + 1.0);
            if merged <= separate {
                j as u32
            } else {
                NONE
            }
        })
        .collect();
    // 2. Chains: heads are candidates nobody points at; walk each, pairing even positions
    // with their successor (which becomes residue).
    let mut has_prev = vec![false; n];
    for &j in &next {
        if j != NONE {
            has_prev[j as usize] = true;
        }
    }
    // partner[i]: the cell i absorbs; consumed[j]: j is residue.
    let mut partner = vec![NONE; n];
    let mut consumed = vec![0u8; n];
    {
        let (pp, cp) = (
            SharedMut(partner.as_mut_ptr()),
            SharedMut(consumed.as_mut_ptr()),
        );
        (0..n)
            .into_par_iter()
            .filter(|&i| next[i] != NONE && !has_prev[i])
            .for_each(|head| {
                let mut i = head;
                loop {
                    let j = next[i];
                    if j == NONE {
                        break;
                    }
                    // SAFETY: chains are disjoint paths, so each cell is written by one walk.
                    unsafe {
                        pp.write(i, j);
                        cp.write(j as usize, 1);
                    }
                    let k = next[j as usize];
                    if k == NONE {
                        break;
                    }
                    i = k as usize;
                }
            });
    }
    let removed = consumed.iter().filter(|&&c| c != 0).count();
    if removed == 0 {
        return 0;
    }
    // 3. New cells in the old order: kept cells and merged pairs.
    let keep: Vec<u32> = consumed.iter().map(|&c| (c == 0) as u32).collect();
    let mut new_index = vec![0u32; n];
    let m = exclusive_scan(&keep, &mut new_index) as usize;
    let old_of_new: Vec<u32> = (0..n as u32)
        .filter(|&i| consumed[i as usize] == 0)
        .collect();
    let counts: Vec<u32> = old_of_new
        .par_iter()
        .map(|&i| {
            let i = i as usize;
            match partner[i] {
                NONE => g.cell_refs(i).len() as u32,
                j => union_len(g.cell_refs(i), g.cell_refs(j as usize)) as u32,
            }
        })
        .collect();
    let mut ref_first = vec![0u32; m + 1];
    let total = exclusive_scan(&counts, &mut ref_first[..m]) as usize;
    ref_first[m] = total as u32;
    // Emit every new cell's list at its offset (count → scan → emit, no per-cell vectors).
    let mut refs = vec![0u32; total];
    {
        let out = SharedMut(refs.as_mut_ptr());
        old_of_new.par_iter().enumerate().for_each(|(k, &i)| {
            let i = i as usize;
            let mut at = ref_first[k] as usize;
            let mut push = |r: u32| {
                // SAFETY: new cell k owns [ref_first[k], ref_first[k + 1]) by the scan.
                unsafe { out.write(at, r) };
                at += 1;
            };
            match partner[i] {
                NONE => g.cell_refs(i).iter().for_each(|&r| push(r)),
                j => union_each(g.cell_refs(i), g.cell_refs(j as usize), &mut push),
            }
            debug_assert_eq!(at, ref_first[k + 1] as usize);
        });
    }
    let boxes: Vec<([u32; 3], [u32; 3])> = old_of_new
        .iter()
        .map(|&i| {
            let i = i as usize;
            let (lo, mut hi) = (g.cell_min[i], g.cell_max[i]);
            if partner[i] != NONE {
                hi[axis] = g.cell_max[partner[i] as usize][axis];
            }
            (lo, hi)
        })
        .collect();
    // 4. Voxel map: old cell → new cell (residue → its absorber).
    let mut remap: Vec<u32> = (0..n)
        .map(|i| if consumed[i] == 0 { new_index[i] } else { NONE })
        .collect();
    for i in 0..n {
        if partner[i] != NONE {
            remap[partner[i] as usize] = new_index[i];
        }
    }
    g.entries.par_iter_mut().with_min_len(4096).for_each(|e| {
        if *e & NODE == 0 {
            *e = remap[*e as usize];
        }
    });
    g.cell_min = boxes.iter().map(|b| b.0).collect();
    g.cell_max = boxes.iter().map(|b| b.1).collect();
    g.exp_min = g.cell_min.clone();
    g.exp_max = g.cell_max.clone();
    g.ref_first = ref_first;
    g.refs = refs;
    removed
}
