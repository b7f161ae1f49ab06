//! SAH cell merging (paper §4.2), with the paper's pairs or wider runs ([`MergeRule`]).
//!
//! A pass along one axis: every cell whose +axis face neighbour is exactly aligned (same
//! extent on the other two axes) and whose merge lowers the SAH cost — with C_t = C_i = 1,
//! (|T₁ ∪ T₂| + 1)·A(B₁ ∪ B₂) ≤ (|T₁| + 1)·A(B₁) + (|T₂| + 1)·A(B₂), A the half surface
//! area — becomes a merge candidate. Candidates form chains, walked from their heads:
//! - `pairs` (the paper): cells at even positions merge with their successor, which
//!   becomes residue, so a pass at most halves a chain and a long run of mergeable cells
//!   takes log₂ of its length in rounds;
//! - `runs`: a cell with a candidate absorbs it and then each next cell of the chain while
//!   the same test, between the run so far (its box and list) and that cell, still says
//!   the merge lowers the cost, up to [`MAX_RUN`] cells; the next run starts where one
//!   stops. A run makes in one pass merges that pairs reach over several rounds (long empty
//!   stretches, same-list columns): on Sponza 3 rounds instead of 6 and 0.67× the merge's
//!   time, with N_T and N_I per primary ray within 8.5 % of the paper's rule on cornell,
//!   office, Sponza, Conference and Kitchen (stadium's N_T rises 27 %, under its 1,098
//!   tests per ray; `bench/results/2026-11-29g-epyc-2core`).
//!
//! Reference lists merge like merge sort (ascending, duplicates once). Passes alternate x,
//! y, z; merging stops when a round keeps at least α of the cells.
//!
//! How it is computed avoids redoing work that a pass cannot change, since the build runs
//! every frame (none of this changes what is merged):
//! - cells keep their initial index while merging (an absorbed cell points to the cell that
//!   absorbed it, `owner`, compressed after every pass), so the voxel map is not rewritten
//!   per pass and a pass touches only the cells it merges;
//! - a cell's candidate along an axis depends only on the cell and the neighbour at its +axis
//!   probe voxel; it is re-evaluated only when one of the two changed since the last pass
//!   along that axis (late rounds re-evaluate a few percent of the cells);
//! - the initial cell at a probe voxel is looked up in the voxel map once per axis and cell:
//!   a merge along another axis leaves the probe voxel where it was, and a merge along the
//!   axis moves it to the last absorbed cell's probe voxel (they are aligned), so the
//!   absorber takes that cell's probe (after the first round no pass reads the voxel map);
//! - a cell's box and reference range sit in one 32-byte record (the traversal's
//!   [`CellRec`]), so reading a neighbour costs one cache line instead of four arrays' worth;
//! - each run's list is made while its chain is walked and appended to one pool (a chunk of
//!   runs at a time, placed by a scan of the chunks' lengths), and the cells, references
//!   and voxel map are compacted once at the end.

use super::{cell_records, half_area, union_each, union_len, CellRec, Grid, MergeRule, NODE};
use par::{exclusive_scan, SharedMut};
use rayon::prelude::*;
use std::sync::atomic::{AtomicU8, Ordering::Relaxed};

const NONE: u32 = u32::MAX;

/// The probe's initial cell is not known yet.
const UNKNOWN: u32 = u32::MAX - 1;

/// Per-cell merge state, indexed by initial cell.
struct Merger {
    /// The live cell that holds cell i (i itself while i is live), and its scratch twin.
    owner: Vec<u32>,
    owner_next: Vec<u32>,
    initial_refs: usize,
    /// Live cell i's box on the virtual grid and its references `pool[begin .. end]`,
    /// ascending (one record: a candidate's evaluation reads all of them).
    cells: Vec<CellRec>,
    /// The pool of ascending reference lists the cells point into.
    pool: Vec<u32>,
    /// Pass at which cell i last changed (0: initial).
    changed: Vec<u32>,
    /// Per axis: the initial cell at live cell i's +axis probe voxel (NONE beyond the grid,
    /// UNKNOWN until first needed) …
    probe0: [Vec<u32>; 3],
    /// … the pass that last evaluated cell i (0: never), the live cell found at its probe
    /// voxel then, and its candidate (NONE: none).
    stamp: [Vec<u32>; 3],
    probe: [Vec<u32>; 3],
    cand: [Vec<u32>; 3],
    pass: u32,
    empty_only: bool,
    rule: MergeRule,
}

impl Merger {
    #[inline]
    fn refs(&self, i: usize) -> &[u32] {
        let c = &self.cells[i];
        &self.pool[c.begin as usize..c.end as usize]
    }
}

/// Merge until a full x, y, z round keeps at least `alpha` of the cells; returns the rounds.
/// With `empty_only`, only two empty cells merge (Devillers's macro regions).
pub fn merge(g: &mut Grid, alpha: f32, empty_only: bool, rule: MergeRule) -> usize {
    let n = g.cells();
    let cells = cell_records(&g.cell_min, &g.cell_max, &g.ref_first);
    // The records hold everything merging reads of the initial cells, and `compact` writes
    // the grid's arrays anew from them: the initial ones go now, before the merge's own
    // per-cell state is allocated (on a 2 M-triangle hairball, 19 M initial cells: 1 GB
    // less at the build's peak).
    for v in [
        &mut g.cell_min,
        &mut g.cell_max,
        &mut g.exp_min,
        &mut g.exp_max,
    ] {
        *v = Vec::new();
    }
    g.ref_first = Vec::new();
    let mut m = Merger {
        owner: iota(n),
        owner_next: filled(n, 0),
        initial_refs: g.refs.len(),
        cells,
        pool: std::mem::take(&mut g.refs),
        changed: filled(n, 0),
        probe0: std::array::from_fn(|_| filled(n, UNKNOWN)),
        stamp: std::array::from_fn(|_| filled(n, 0)),
        probe: std::array::from_fn(|_| filled(n, NONE)),
        cand: std::array::from_fn(|_| filled(n, NONE)),
        pass: 0,
        empty_only,
        rule,
    };
    let mut live: Vec<u32> = iota(n);
    let flags: Vec<AtomicU8> = (0..n)
        .into_par_iter()
        .with_min_len(1 << 14)
        .map(|_| AtomicU8::new(0))
        .collect();
    let mut rounds = 0;
    loop {
        let before = live.len();
        for axis in 0..3 {
            m.pass += 1;
            if merge_pass(g, &mut m, &live, &flags, axis) > 0 {
                live.retain(|&i| m.owner[i as usize] == i);
            }
        }
        rounds += 1;
        let after = live.len();
        if after == before || after as f64 >= alpha as f64 * before as f64 {
            break;
        }
    }
    compact(g, &m, &live);
    rounds
}

/// `n` copies of `v`, written in parallel: the merge's per-cell state is a dozen arrays over
/// every initial cell (Sponza: 431 k), made on every build.
fn filled(n: usize, v: u32) -> Vec<u32> {
    (0..n)
        .into_par_iter()
        .with_min_len(1 << 14)
        .map(|_| v)
        .collect()
}

/// 0, 1, …, n − 1, written in parallel.
fn iota(n: usize) -> Vec<u32> {
    (0..n as u32)
        .into_par_iter()
        .with_min_len(1 << 14)
        .collect()
}

/// The initial cell at cell `c`'s +axis probe voxel (its min corner moved to the far face),
/// NONE when the face is the grid's.
fn probe_cell(g: &Grid, c: &CellRec, axis: usize) -> u32 {
    if c.hi[axis] >= g.dims[axis] {
        return NONE;
    }
    let mut p = c.lo;
    p[axis] = c.hi[axis];
    g.lookup(p)
}

/// Is live cell `j` (found at `c`'s +axis probe voxel) exactly aligned with `c`: starting at
/// its far face, with the same extent on the other two axes?
#[inline]
fn aligned(c: &CellRec, j: &CellRec, axis: usize) -> bool {
    (0..3).all(|k| {
        if k == axis {
            j.lo[k] == c.hi[k]
        } else {
            j.lo[k] == c.lo[k] && j.hi[k] == c.hi[k]
        }
    })
}

/// Does merging live cell i with its aligned +axis neighbour j lower the SAH cost?
fn worth_merging(g: &Grid, m: &Merger, i: usize, j: usize, axis: usize) -> bool {
    let (ri, rj) = (m.refs(i), m.refs(j));
    if m.empty_only && !(ri.is_empty() && rj.is_empty()) {
        return false;
    }
    let (ci, cj) = (&m.cells[i], &m.cells[j]);
    let ai = half_area(g.voxel, ci.lo, ci.hi);
    let aj = half_area(g.voxel, cj.lo, cj.hi);
    let mut hi = ci.hi;
    hi[axis] = cj.hi[axis];
    let au = half_area(g.voxel, ci.lo, hi);
    sah_lowered(au, union_len(ri, rj), ai, ri.len(), aj, rj.len())
}

/// The paper's merge test with C_t = C_i = 1: (n_u + 1)·A_u ≤ (n_a + 1)·A_a + (n_b + 1)·A_b,
/// in this order of operations (the GPU's `sah_lowered` computes the same bits).
#[inline]
fn sah_lowered(au: f32, nu: usize, aa: f32, na: usize, ab: f32, nb: usize) -> bool {
    au * (nu as f32 + 1.0) <= aa * (na as f32 + 1.0) + ab * (nb as f32 + 1.0)
}

/// One merge pass along `axis` over the live cells; returns how many cells were absorbed.
fn merge_pass(
    g: &mut Grid,
    m: &mut Merger,
    live: &[u32],
    flags: &[AtomicU8],
    axis: usize,
) -> usize {
    let pass = m.pass;
    // 1. Candidates, re-evaluated where the cell or its probe neighbour changed.
    {
        let (p0p, sp, pp, cp) = (
            SharedMut(m.probe0[axis].as_mut_ptr()),
            SharedMut(m.stamp[axis].as_mut_ptr()),
            SharedMut(m.probe[axis].as_mut_ptr()),
            SharedMut(m.cand[axis].as_mut_ptr()),
        );
        let (gr, mr) = (&*g, &*m);
        live.par_iter().with_min_len(2048).for_each(|&i| {
            let i = i as usize;
            let ci = &mr.cells[i];
            let mut p0 = mr.probe0[axis][i];
            if p0 == UNKNOWN {
                p0 = probe_cell(gr, ci, axis);
                // SAFETY: live cells are distinct, so each index is written by one task.
                unsafe { p0p.write(i, p0) };
            }
            let j = if p0 == NONE {
                NONE
            } else {
                mr.owner[p0 as usize]
            };
            let s = mr.stamp[axis][i];
            let stale = s == 0
                || mr.changed[i] >= s
                || j != mr.probe[axis][i]
                || (j != NONE && mr.changed[j as usize] >= s);
            if !stale {
                return;
            }
            let c = if j != NONE
                && aligned(ci, &mr.cells[j as usize], axis)
                && worth_merging(gr, mr, i, j as usize, axis)
            {
                j
            } else {
                NONE
            };
            // SAFETY: as above.
            unsafe {
                sp.write(i, pass);
                pp.write(i, j);
                cp.write(i, c);
            }
        });
    }
    // 2. Chains: heads are candidates nobody points at; walk each, pairing even positions
    // with their successor (which becomes residue).
    let next = &m.cand[axis];
    live.par_iter().with_min_len(4096).for_each(|&i| {
        let j = next[i as usize];
        if j != NONE {
            flags[j as usize].store(1, Relaxed); // j has a predecessor
        }
    });
    let heads: Vec<u32> = live
        .par_iter()
        .with_min_len(4096)
        .copied()
        .filter(|&i| next[i as usize] != NONE && flags[i as usize].load(Relaxed) == 0)
        .collect();
    live.par_iter()
        .with_min_len(4096)
        .for_each(|&i| flags[i as usize].store(0, Relaxed));
    let chunks = walk_chains(g, m, &heads, axis);
    let absorbed: usize = chunks.iter().map(|c| c.members.len()).sum();
    if absorbed == 0 {
        return 0;
    }
    // 3. The runs' reference lists, appended to the pool (each chunk's lists in one piece,
    // placed by a scan of the chunks' lengths), and the absorbers' records updated.
    let lens: Vec<u32> = chunks.iter().map(|c| c.lists.len() as u32).collect();
    let mut offs = vec![0u32; lens.len()];
    let total = exclusive_scan(&lens, &mut offs) as usize;
    // The pool only grows while merging; rewrite it with the live lists when it would
    // outgrow its 32-bit offsets or four times the initial references.
    if m.pool.len() + total >= (u32::MAX as usize).min(4 * m.initial_refs.max(1 << 16)) {
        compact_pool(m, live);
    }
    // Cannot overflow: the pool stays under 4× the initial references (≤ 2^28, checked by
    // the build) or is compacted to the live lists, and `total` is at most as many again
    // (a run's list is at most its cells' lists together).
    let base = m.pool.len();
    debug_assert!(base + total < u32::MAX as usize);
    m.pool.resize(base + total, 0);
    {
        let out = SharedMut(m.pool[base..].as_mut_ptr());
        let (xp, op, cp, p0p) = (
            SharedMut(m.cells.as_mut_ptr()),
            SharedMut(m.owner.as_mut_ptr()),
            SharedMut(m.changed.as_mut_ptr()),
            SharedMut(m.probe0[axis].as_mut_ptr()),
        );
        chunks
            .par_iter()
            .zip(offs.par_iter())
            .for_each(|(ch, &at)| {
                // The wrappers, not their raw fields, cross threads.
                let (lists, cells, owners, changed, probes) = (&out, &xp, &op, &cp, &p0p);
                // SAFETY: chunk c owns the pool room [at, at + its lists) by the scan; runs
                // are disjoint (each cell in at most one run, absorber or member), so every
                // index is written by one task, and no task reads an index another writes
                // (a run reads its last member's record, and writes its absorber's).
                unsafe {
                    for (x, &r) in ch.lists.iter().enumerate() {
                        lists.write(at as usize + x, r);
                    }
                    for run in &ch.runs {
                        let (i, last) = (run.absorber as usize, run.last as usize);
                        let mut c = cells.0.add(i).read();
                        c.hi[axis] = cells.0.add(last).read().hi[axis];
                        c.begin = (base + (at + run.list.0) as usize) as u32;
                        c.end = (base + (at + run.list.1) as usize) as u32;
                        cells.write(i, c);
                        // The merged box's probe voxel along `axis` is its last member's
                        // (the members are aligned).
                        probes.write(i, probes.0.add(last).read());
                        changed.write(i, pass);
                        for &j in &ch.members[run.members.0 as usize..run.members.1 as usize] {
                            owners.write(j as usize, i as u32);
                        }
                    }
                }
            });
    }
    compress_owners(m);
    absorbed
}

/// One merge of a pass: live cell `absorber` takes the cells `members` of its chunk (its
/// chain's successors up to `last`, in order along the axis) and the reference list `list`
/// of its chunk (their union).
struct Run {
    absorber: u32,
    last: u32,
    members: (u32, u32),
    list: (u32, u32),
}

/// Most cells one run merges (the absorber and 7 more). Without a bound, runs along the
/// first axis grow into long slabs that no cell along the other axes is aligned with any
/// more: on `office` unbounded runs raise N_T per primary ray by 35 % over the paper's pairs,
/// runs of at most 4 or 8 cells by 8 %; 8 keeps Sponza's merge at 0.61× the pairs' time
/// where unbounded runs reach 0.58× (`grid_trace`, `grid_build`). It also bounds the GPU's
/// per-run scans.
pub const MAX_RUN: u32 = 8;

/// The runs found by one task of [`walk_chains`], with their members and lists.
#[derive(Default)]
struct Chunk {
    runs: Vec<Run>,
    members: Vec<u32>,
    lists: Vec<u32>,
}

/// Walk every chain from its head, cutting it into runs ([`MergeRule`]): a run starts at a
/// cell with a candidate and absorbs it (the pair the paper merges); under `Runs` it goes on
/// absorbing the next cell of the chain while that lowers the SAH cost of the run so far
/// (the same test as a pair's, between the run's box and list and the cell's), up to
/// [`MAX_RUN`] cells. The next
/// run starts at the cell after the run's last. Each run's list (the union of its cells')
/// is made here, by one union per absorbed cell, in the chain's order.
fn walk_chains(g: &Grid, m: &Merger, heads: &[u32], axis: usize) -> Vec<Chunk> {
    let next = &m.cand[axis];
    let runs = m.rule == MergeRule::Runs;
    heads
        .par_iter()
        .with_min_len(256)
        .fold(
            || (Chunk::default(), Vec::new(), Vec::new()),
            |(mut ch, mut acc, mut tmp): (Chunk, Vec<u32>, Vec<u32>), &head| {
                let mut i = head;
                loop {
                    let j = next[i as usize];
                    if j == NONE {
                        break;
                    }
                    acc.clear();
                    union_each(m.refs(i as usize), m.refs(j as usize), &mut |r| acc.push(r));
                    let lo = m.cells[i as usize].lo;
                    let mut hi = m.cells[i as usize].hi;
                    hi[axis] = m.cells[j as usize].hi[axis];
                    let first = ch.members.len() as u32;
                    ch.members.push(j);
                    let mut last = j;
                    // Under `Pairs` the run is the pair; a run holds at most `MAX_RUN` cells.
                    loop {
                        let k = next[last as usize];
                        let size = ch.members.len() as u32 - first + 1;
                        if !runs || k == NONE || size >= MAX_RUN {
                            break;
                        }
                        let (ck, rk) = (&m.cells[k as usize], m.refs(k as usize));
                        if m.empty_only && !(acc.is_empty() && rk.is_empty()) {
                            break;
                        }
                        let mut uh = hi;
                        uh[axis] = ck.hi[axis];
                        let (a, ak, au) = (
                            half_area(g.voxel, lo, hi),
                            half_area(g.voxel, ck.lo, ck.hi),
                            half_area(g.voxel, lo, uh),
                        );
                        // The union is made once: its length decides, and an accepted
                        // cell keeps it as the run's list.
                        tmp.clear();
                        union_each(&acc, rk, &mut |r| tmp.push(r));
                        if !sah_lowered(au, tmp.len(), a, acc.len(), ak, rk.len()) {
                            break;
                        }
                        std::mem::swap(&mut acc, &mut tmp);
                        hi = uh;
                        ch.members.push(k);
                        last = k;
                    }
                    let at = ch.lists.len() as u32;
                    ch.lists.extend_from_slice(&acc);
                    ch.runs.push(Run {
                        absorber: i,
                        last,
                        members: (first, ch.members.len() as u32),
                        list: (at, ch.lists.len() as u32),
                    });
                    let k = next[last as usize];
                    if k == NONE {
                        break;
                    }
                    i = k;
                }
                (ch, acc, tmp)
            },
        )
        .map(|(ch, _, _)| ch)
        .collect()
}

/// Keep `owner` one step deep: cells that pointed at a cell absorbed in this pass now point
/// at its absorber (absorbers are live after the pass, since runs are disjoint).
fn compress_owners(m: &mut Merger) {
    let owner = &m.owner;
    m.owner_next
        .par_iter_mut()
        .enumerate()
        .with_min_len(8192)
        .for_each(|(x, o)| *o = owner[owner[x] as usize]);
    std::mem::swap(&mut m.owner, &mut m.owner_next);
}

/// The live cells' lists, gathered in `live` order (count → scan → emit): the offsets
/// (one per live cell, and the total last) and the references.
fn gather(m: &Merger, live: &[u32]) -> (Vec<u32>, Vec<u32>) {
    let counts: Vec<u32> = live
        .par_iter()
        .with_min_len(4096)
        .map(|&i| m.cells[i as usize].end - m.cells[i as usize].begin)
        .collect();
    let mut first = vec![0u32; live.len() + 1];
    let total = exclusive_scan(&counts, &mut first[..live.len()]);
    first[live.len()] = total;
    let mut refs = vec![0u32; total as usize];
    {
        let out = SharedMut(refs.as_mut_ptr());
        live.par_iter()
            .enumerate()
            .with_min_len(1024)
            .for_each(|(k, &i)| {
                for (x, &r) in m.refs(i as usize).iter().enumerate() {
                    // SAFETY: live cell k owns [first[k], first[k + 1]).
                    unsafe { out.write(first[k] as usize + x, r) };
                }
            });
    }
    (first, refs)
}

/// Rewrite the pool with only the live cells' lists.
fn compact_pool(m: &mut Merger, live: &[u32]) {
    let (first, pool) = gather(m, live);
    for (k, &i) in live.iter().enumerate() {
        m.cells[i as usize].begin = first[k];
        m.cells[i as usize].end = first[k + 1];
    }
    m.pool = pool;
}

/// Renumber the live cells in their initial order, gather their references, and point the
/// voxel map at the new indices.
fn compact(g: &mut Grid, m: &Merger, live: &[u32]) {
    let n = m.owner.len();
    let mut new_index = filled(n, NONE);
    {
        let out = SharedMut(new_index.as_mut_ptr());
        live.par_iter()
            .enumerate()
            .with_min_len(4096)
            .for_each(|(k, &i)| {
                let out = &out;
                // SAFETY: live cells are distinct.
                unsafe { out.write(i as usize, k as u32) };
            });
    }
    let (ref_first, refs) = gather(m, live);
    let lo: Vec<[u32; 3]> = live
        .par_iter()
        .with_min_len(4096)
        .map(|&i| m.cells[i as usize].lo)
        .collect();
    let hi: Vec<[u32; 3]> = live
        .par_iter()
        .with_min_len(4096)
        .map(|&i| m.cells[i as usize].hi)
        .collect();
    g.exp_min = lo.clone();
    g.exp_max = hi.clone();
    g.cell_min = lo;
    g.cell_max = hi;
    g.ref_first = ref_first;
    g.refs = refs;
    g.entries.par_iter_mut().with_min_len(4096).for_each(|e| {
        if *e & NODE == 0 {
            *e = new_index[m.owner[*e as usize] as usize];
        }
    });
}
