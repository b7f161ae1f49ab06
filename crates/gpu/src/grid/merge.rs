//! SAH cell merging on the GPU (paper §4.2; `merge.wgsl`), the twin of
//! `accel/src/grid/merge.rs`, by pairs or runs: passes along x, y, z (candidates →
//! predecessors → chains cut into pairs or runs → list lengths → scan → merged lists →
//! owners compressed → live cells compacted) until a round keeps at least α of the cells,
//! then the live cells renumbered in order with their boxes, reference ranges and the voxel
//! map pointed at them. The host reads only the totals that size the next buffers (each
//! pass's reference count and live count).

use super::DeviceGrid;
use crate::device::Gpu;
use crate::kernels::{Exec, Kernel, Kernels, Params};
use accel::grid::MergeRule;

/// Merge `d`'s cells as `accel::grid::merge::merge` does; returns the rounds run.
pub fn merge(
    g: &Gpu,
    k: &Kernels,
    d: &mut DeviceGrid,
    alpha: f32,
    empty_only: bool,
    rule: MergeRule,
) -> usize {
    let mut ex = Exec::new(g, k);
    let n = d.ncells;
    let f = &d.frame;
    let params = |count: u64, axis: u32| {
        let mut p = Params::n(count as u32, axis, f.shift, empty_only as u32);
        p.u[1] = [
            f.dims[0],
            f.dims[1],
            f.dims[2],
            (rule == MergeRule::Runs) as u32,
        ];
        p.u[2] = [f.top_dims[0], f.top_dims[1], f.top_dims[2], 0];
        p.f[0] = [f.voxel.x, f.voxel.y, f.voxel.z, 0.0];
        p
    };
    // Per initial cell: owner, list range (begin, end), candidate, marks, partner.
    let mut owner = ex.iota(n);
    let mut owner_next = g.storage("owners", n * 4);
    let mut range = g.storage("list ranges", n * 8);
    ex.run(
        Kernel::MInit,
        params(n, 0),
        &[(11, &d.ref_first), (13, &range)],
        n,
        256,
    );
    let mut pool = d.refs.clone();
    let cand = g.storage("candidates", n * 4);
    let mark = g.storage("marks", n * 8);
    let partner = g.storage("partners", n * 4);
    let mut live = ex.iota(n);
    let mut nlive = n;
    let mut rounds = 0;
    loop {
        let before = nlive;
        for axis in 0..3u32 {
            let p = params(nlive, axis);
            ex.run(
                Kernel::MCandidates,
                p,
                &[
                    (1, &d.entries),
                    (2, &live),
                    (3, &owner),
                    (4, &d.cell_min),
                    (5, &d.cell_max),
                    (6, &range),
                    (7, &pool),
                    (8, &cand),
                    (9, &mark),
                    (10, &partner),
                ],
                nlive,
                256,
            );
            ex.run(
                Kernel::MPredecessors,
                p,
                &[(2, &live), (8, &cand), (9, &mark)],
                nlive,
                256,
            );
            ex.run(
                Kernel::MChains,
                p,
                &[
                    (2, &live),
                    (4, &d.cell_min),
                    (5, &d.cell_max),
                    (6, &range),
                    (7, &pool),
                    (8, &cand),
                    (9, &mark),
                    (10, &partner),
                ],
                nlive,
                256,
            );
            let count = g.storage("list lengths", nlive * 4);
            ex.run(
                Kernel::MCounts,
                p,
                &[
                    (2, &live),
                    (6, &range),
                    (7, &pool),
                    (8, &cand),
                    (9, &mark),
                    (10, &partner),
                    (11, &count),
                ],
                nlive,
                256,
            );
            let offs = g.storage("list offsets", (nlive + 1) * 4);
            ex.scan(&count, &offs, nlive);
            let total = ex.read_at(&offs, nlive as usize) as u64;
            let range_out = g.storage("list ranges", n * 8);
            ex.copy(&range, 0, &range_out, n * 8);
            let pool_out = g.storage("reference pool", total * 4);
            ex.run(
                Kernel::MEmit,
                p,
                &[
                    (2, &live),
                    (3, &owner),
                    (5, &d.cell_max),
                    (6, &range),
                    (7, &pool),
                    (8, &cand),
                    (9, &mark),
                    (10, &partner),
                    (12, &offs),
                    (13, &range_out),
                    (14, &pool_out),
                ],
                nlive,
                256,
            );
            range = range_out;
            pool = pool_out;
            ex.run(
                Kernel::MCompress,
                params(n, axis),
                &[(3, &owner), (15, &owner_next)],
                n,
                256,
            );
            std::mem::swap(&mut owner, &mut owner_next);
            let flags = g.storage("live flags", nlive * 4);
            ex.run(
                Kernel::MLiveFlags,
                p,
                &[(2, &live), (3, &owner), (16, &flags)],
                nlive,
                256,
            );
            let (l, _, m) = ex.compact(&flags, &live, None, nlive);
            live = l;
            nlive = m;
        }
        rounds += 1;
        if nlive == before || nlive as f64 >= alpha as f64 * before as f64 {
            break;
        }
    }
    // Renumber the live cells in order; gather their boxes and ranges; repoint the map.
    let p = params(nlive, 0);
    let new_index = g.storage("merged cells' numbers", n * 4);
    ex.run(
        Kernel::MFinalIndex,
        p,
        &[(2, &live), (16, &new_index)],
        nlive,
        256,
    );
    let map = g.storage("voxel map", d.nentries * 4);
    ex.run(
        Kernel::MFinalMap,
        params(d.nentries, 0),
        &[(1, &d.entries), (3, &owner), (15, &map), (16, &new_index)],
        d.nentries,
        256,
    );
    let cmin = g.storage("cells' min", (nlive * 16).max(16));
    let cmax = g.storage("cells' max", (nlive * 16).max(16));
    let first = g.storage("cells' first references", (nlive + 1) * 4);
    ex.run(
        Kernel::MFinalCells,
        p,
        &[
            (2, &live),
            (4, &d.cell_min),
            (5, &d.cell_max),
            (6, &range),
            (11, &first),
            (17, &cmin),
            (18, &cmax),
        ],
        nlive,
        256,
    );
    let nrefs = ex.read_at(&first, nlive as usize) as u64;
    ex.finish();
    d.entries = map;
    d.exp_min = cmin.clone();
    d.exp_max = cmax.clone();
    d.cell_min = cmin;
    d.cell_max = cmax;
    d.ref_first = first;
    d.refs = pool;
    d.ncells = nlive;
    d.nrefs = nrefs;
    rounds
}
