//! SAH cell merging on the GPU (paper §4.2; `merge.wgsl`), the twin of
//! `accel/src/grid/merge.rs`, by pairs or runs: passes along x, y, z (candidates →
//! predecessors → chains cut into pairs or runs → list lengths → scan → merged lists →
//! owners compressed → live cells compacted) until a round keeps at least α of the cells,
//! then the live cells renumbered in order with their boxes, reference ranges and the voxel
//! map pointed at them. The host reads only the totals that size the next buffers (each
//! pass's reference count and live count).

use super::DeviceGrid;
use crate::device::Gpu;
use crate::kernels::params::{MergeCountParams, MergeParams};
use crate::kernels::{launch, Exec, Kernels};
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
    let params = |count: u64, axis: u32| MergeParams {
        cells: count as u32,
        axis,
        shift: f.shift,
        empty_only: empty_only as u32,
        dims: f.dims,
        runs: (rule == MergeRule::Runs) as u32,
        top_dims: f.top_dims,
        voxel: f.voxel.to_array(),
    };
    let counted = |n: u64| MergeCountParams { n: n as u32 };
    // Per initial cell: owner, list range (begin, end), candidate, marks, partner.
    let mut owner = ex.iota(n);
    let mut owner_next = g.storage("owners", n * 4);
    let mut range = g.storage("list ranges", n * 8);
    ex.run(
        launch::MInit {
            m_count: &d.ref_first,
            m_range_out: &range,
        },
        counted(n),
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
                launch::MCandidates {
                    m_map: &d.entries,
                    m_live: &live,
                    m_owner: &owner,
                    m_min: &d.cell_min,
                    m_max: &d.cell_max,
                    m_range: &range,
                    m_pool: &pool,
                    m_cand: &cand,
                    m_mark: &mark,
                    m_partner: &partner,
                },
                p,
                nlive,
                256,
            );
            ex.run(
                launch::MPredecessors {
                    m_live: &live,
                    m_cand: &cand,
                    m_mark: &mark,
                },
                p,
                nlive,
                256,
            );
            ex.run(
                launch::MChains {
                    m_live: &live,
                    m_min: &d.cell_min,
                    m_max: &d.cell_max,
                    m_range: &range,
                    m_pool: &pool,
                    m_cand: &cand,
                    m_mark: &mark,
                    m_partner: &partner,
                },
                p,
                nlive,
                256,
            );
            let count = g.storage("list lengths", nlive * 4);
            ex.run(
                launch::MCounts {
                    m_live: &live,
                    m_range: &range,
                    m_pool: &pool,
                    m_cand: &cand,
                    m_mark: &mark,
                    m_partner: &partner,
                    m_count: &count,
                },
                p,
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
                launch::MEmit {
                    m_live: &live,
                    m_owner: &owner,
                    m_max: &d.cell_max,
                    m_range: &range,
                    m_pool: &pool,
                    m_cand: &cand,
                    m_mark: &mark,
                    m_partner: &partner,
                    m_offs: &offs,
                    m_range_out: &range_out,
                    m_pool_out: &pool_out,
                },
                p,
                nlive,
                256,
            );
            range = range_out;
            pool = pool_out;
            ex.run(
                launch::MCompress {
                    m_owner: &owner,
                    m_owner_out: &owner_next,
                },
                counted(n),
                n,
                256,
            );
            std::mem::swap(&mut owner, &mut owner_next);
            let flags = g.storage("live flags", nlive * 4);
            ex.run(
                launch::MLiveFlags {
                    m_live: &live,
                    m_owner: &owner,
                    m_out: &flags,
                },
                p,
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
    let p = counted(nlive);
    let new_index = g.storage("merged cells' numbers", n * 4);
    ex.run(
        launch::MFinalIndex {
            m_live: &live,
            m_out: &new_index,
        },
        p,
        nlive,
        256,
    );
    let map = g.storage("voxel map", d.nentries * 4);
    ex.run(
        launch::MFinalMap {
            m_map: &d.entries,
            m_owner: &owner,
            m_owner_out: &map,
            m_out: &new_index,
        },
        counted(d.nentries),
        d.nentries,
        256,
    );
    let cmin = g.storage("cells' min", (nlive * 16).max(16));
    let cmax = g.storage("cells' max", (nlive * 16).max(16));
    let first = g.storage("cells' first references", (nlive + 1) * 4);
    ex.run(
        launch::MFinalCells {
            m_live: &live,
            m_min: &d.cell_min,
            m_max: &d.cell_max,
            m_range: &range,
            m_count: &first,
            m_min_out: &cmin,
            m_max_out: &cmax,
        },
        p,
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
