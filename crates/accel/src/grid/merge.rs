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
//!   probe voxel, so it is re-evaluated only when one of the two changed since the last pass
//!   along that axis. Every cell that had a candidate then was merged then (as an absorber,
//!   which changed, or as a member, which is gone), so a cell that did not change keeps "no
//!   candidate": the candidate is one bit per axis, and no pass stamps are kept;
//! - late passes (a few percent of the cells changed since the last pass along the axis)
//!   do not scan the live cells: the cells to re-evaluate are those that changed and the
//!   cells on their −axis faces (whose probe voxels lie in them), found by walking each
//!   changed cell's face layer in the voxel map. Both schedules evaluate the same cells
//!   (tested: [`Schedule`]);
//! - the cell at a probe voxel is looked up in the voxel map when it is needed (the top
//!   entry and a block entry or two) rather than kept: three probes per cell would be 12
//!   bytes per initial cell, 228 MB on a 2 M-triangle hairball, for lookups that cost a
//!   tenth of an evaluation;
//! - a cell's box and reference range sit in one 32-byte record (the traversal's
//!   [`CellRec`]), so reading a neighbour costs one cache line instead of four arrays' worth;
//! - each run's list is made while its chain is walked and appended to one pool (a chunk of
//!   runs at a time, placed by a scan of the chunks' lengths), and the cells, references
//!   and voxel map are compacted once at the end.
//!
//! The per-cell state is 37 bytes per initial cell: the owner, the record, and one byte of
//! marks (the candidate bits, the chain mark, and which of the last three passes changed
//! the cell). On a 2 M-triangle hairball's 19 M initial cells it sets the build's peak; it
//! was 97 bytes (a stamp, a probe and a candidate per axis and cell, the change pass, a
//! scratch owner and a live list), 1.1 GB more.

use super::{half_area, union_each, union_len, CellRec, Grid, MergeRule, NODE};
use par::{collect_blocks, exclusive_scan, SharedMut};
use rayon::prelude::*;
use std::sync::atomic::{AtomicU8, Ordering::Relaxed};

const NONE: u32 = u32::MAX;

/// `marks` bit: the cell is some chain cell's candidate in the current pass.
const PRED: u8 = 1 << 3;

/// `marks` bits: the cell absorbed others in pass p, at bit 4 + p % 3 (the last three
/// passes: those since the last pass along the current axis).
const CHANGED: u8 = 0b111 << 4;

/// The `marks` bit of a change in pass `pass`.
#[inline]
fn changed_in(pass: u32) -> u8 {
    1 << (4 + pass % 3)
}

/// How a pass finds the cells whose candidate may have changed. The result is the same.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Schedule {
    /// Evaluate every live cell in every pass: the definition the others are tested against.
    Every,
    /// Scan every live cell and test whether it or its probe neighbour changed.
    Scan,
    /// Walk the changed cells and their −axis faces.
    Faces,
    /// Faces when few cells changed since the last pass along the axis (at most
    /// 1/[`FACES_BELOW`] of the live ones), else the scan.
    Auto,
}

/// [`Schedule::Auto`] walks faces when the changed cells are at most 1/`FACES_BELOW` of the
/// live ones: a face walk reads a changed cell's neighbours through the voxel map (a few
/// lookups each), a scan reads every live cell's probe owner and change marks.
pub const FACES_BELOW: usize = 8;

/// Per-cell merge state, indexed by initial cell.
struct Merger {
    /// The live cell that holds cell i (i itself while i is live).
    owner: Vec<u32>,
    initial_refs: usize,
    /// Live cell i's box on the virtual grid and its references `pool[begin .. end]`,
    /// ascending (one record: a candidate's evaluation reads all of them).
    cells: Vec<CellRec>,
    /// The pool of ascending reference lists the cells point into.
    pool: Vec<u32>,
    /// Bit `axis`: at the last evaluation along `axis`, cell i's candidate was the live cell
    /// at its probe voxel; [`PRED`]: some cell's candidate is i (within a pass);
    /// [`CHANGED`]: the passes of the last three in which i absorbed others.
    marks: Vec<AtomicU8>,
    /// The cells that absorbed others in each of the last three passes (pass p at p % 3).
    absorbers: [Vec<u32>; 3],
    live_count: usize,
    pass: u32,
    empty_only: bool,
    rule: MergeRule,
    schedule: Schedule,
}

impl Merger {
    #[inline]
    fn refs(&self, i: usize) -> &[u32] {
        let c = &self.cells[i];
        &self.pool[c.begin as usize..c.end as usize]
    }

    #[inline]
    fn is_live(&self, i: u32) -> bool {
        self.owner[i as usize] == i
    }

    /// The live cell at live cell i's +axis probe voxel (NONE beyond the grid).
    #[inline]
    fn probe_owner(&self, g: &Grid, i: usize, axis: usize) -> u32 {
        match probe_cell(g, &self.cells[i], axis) {
            NONE => NONE,
            p0 => self.owner[p0 as usize],
        }
    }

    /// Cell i's candidate along `axis` in this pass (valid once it was evaluated).
    #[inline]
    fn next(&self, g: &Grid, i: usize, axis: usize) -> u32 {
        if self.marks[i].load(Relaxed) & (1 << axis) != 0 {
            self.probe_owner(g, i, axis)
        } else {
            NONE
        }
    }

    /// Did cell i absorb others since the last pass along the current axis?
    #[inline]
    fn changed(&self, i: usize) -> bool {
        self.marks[i].load(Relaxed) & CHANGED != 0
    }

    /// The live cells, ascending (a count → scan → write compaction: rayon's filtered
    /// collect took 200 ms for a 1 M-triangle hairball's 4.8 M of 9 M cells, this 25).
    fn live(&self) -> Vec<u32> {
        let mut out = vec![0u32; self.live_count];
        let kept = par::compact_with(
            self.owner.len(),
            |i| self.owner[i] == i as u32,
            |i| i as u32,
            &mut out,
        );
        debug_assert_eq!(kept, self.live_count);
        out
    }
}

/// Cells per task of a pass's parallel loops.
const BLOCK: usize = 4096;

/// The cells a pass evaluates.
enum EvalSet {
    /// Every live cell.
    Live,
    /// The live cells that changed or whose probe neighbour did.
    Stale,
    /// These cells.
    List(Vec<u32>),
}

/// Merge until a full x, y, z round keeps at least `alpha` of the cells; returns the rounds.
/// With `empty_only`, only two empty cells merge (Devillers's macro regions).
pub fn merge(g: &mut Grid, alpha: f32, empty_only: bool, rule: MergeRule) -> usize {
    merge_scheduled(g, alpha, empty_only, rule, Schedule::Auto)
}

/// [`merge`], with the passes' schedule chosen (every schedule gives the same grid).
pub fn merge_scheduled(
    g: &mut Grid,
    alpha: f32,
    empty_only: bool,
    rule: MergeRule,
    schedule: Schedule,
) -> usize {
    let n = g.cells();
    // The records hold everything merging reads of the initial cells, and `compact` writes
    // the grid's arrays anew from them: the initial ones go as the records are made, before
    // the merge's own per-cell state is allocated.
    let cells = take_records(g);
    // The initial build's freed scratch stays in the heap (`trace::memory`), where none of
    // the merge's large buffers can reuse it: give it back when it is worth a peak.
    trace::memory::release_free_heap(RELEASE_AT);
    let mut m = Merger {
        owner: iota(n),
        initial_refs: g.refs.len(),
        cells,
        pool: std::mem::take(&mut g.refs),
        marks: (0..n)
            .into_par_iter()
            .with_min_len(1 << 14)
            .map(|_| AtomicU8::new(0))
            .collect(),
        absorbers: Default::default(),
        live_count: n,
        pass: 0,
        empty_only,
        rule,
        schedule,
    };
    let mut rounds = 0;
    loop {
        let before = m.live_count;
        for axis in 0..3 {
            m.pass += 1;
            m.live_count -= merge_pass(g, &mut m, axis);
        }
        rounds += 1;
        let after = m.live_count;
        if after == before || after as f64 >= alpha as f64 * before as f64 {
            break;
        }
    }
    compact(g, m);
    rounds
}

/// Free heap memory worth returning before the merge allocates its state. The initial
/// build leaves 25 MiB free on Sponza, 38 on Kitchen, 52 on Conference, 78 on a 100 k
/// hairball (their per-frame rebuilds keep reusing it), about 300 on 1 M and 2 M hairballs.
const RELEASE_AT: u64 = 128 << 20;

/// The initial cells' records (box and reference range), made from the grid's per-cell
/// arrays, which are emptied: a slice at a time from the end, each array cut back after
/// each slice, so the records (32 bytes a cell) and the arrays (28) are not all held at once
/// (on a 2 M-triangle hairball, 19 M initial cells: 0.5 GB less at the build's peak, where
/// the allocator returns a cut-back array's tail).
fn take_records(g: &mut Grid) -> Vec<CellRec> {
    let n = g.cells();
    let mut out: Vec<CellRec> = Vec::with_capacity(n);
    let dst = SharedMut(out.as_mut_ptr());
    let slice = (n / 16).max(1 << 16);
    let mut end = n;
    while end > 0 {
        let start = end.saturating_sub(slice);
        let (lo, hi, first) = (&g.cell_min, &g.cell_max, &g.ref_first);
        (start..end)
            .into_par_iter()
            .with_min_len(4096)
            .for_each(|c| {
                let dst = &dst;
                // SAFETY: c < n, the capacity, and each c is written once, by one task.
                unsafe {
                    dst.write(
                        c,
                        CellRec {
                            lo: lo[c],
                            hi: hi[c],
                            begin: first[c],
                            end: first[c + 1],
                        },
                    )
                };
            });
        g.cell_min.truncate(start);
        g.cell_max.truncate(start);
        g.ref_first.truncate(start + 1);
        for v in [&mut g.cell_min, &mut g.cell_max] {
            v.shrink_to_fit();
        }
        g.ref_first.shrink_to_fit();
        end = start;
    }
    // SAFETY: the slices cover 0..n, so every record is written.
    unsafe { out.set_len(n) };
    g.cell_min = Vec::new();
    g.cell_max = Vec::new();
    g.exp_min = Vec::new();
    g.exp_max = Vec::new();
    g.ref_first = Vec::new();
    out
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

/// Evaluate live cell `i`'s candidate along `axis` and record it in its `marks` bit;
/// returns `(i, candidate)` when it has one.
fn evaluate(g: &Grid, m: &Merger, i: usize, axis: usize) -> Option<(u32, u32)> {
    evaluate_with(g, m, i, m.probe_owner(g, i, axis), axis)
}

/// [`evaluate`], the live cell at `i`'s probe voxel (`j`) already found.
fn evaluate_with(g: &Grid, m: &Merger, i: usize, j: u32, axis: usize) -> Option<(u32, u32)> {
    let ci = &m.cells[i];
    let cand = j != NONE
        && aligned(ci, &m.cells[j as usize], axis)
        && worth_merging(g, m, i, j as usize, axis);
    let bit = 1u8 << axis;
    let old = m.marks[i].load(Relaxed);
    m.marks[i].store(if cand { old | bit } else { old & !bit }, Relaxed);
    cand.then_some((i as u32, j))
}

/// The live cells whose probe voxel along `axis` lies in live cell `k`: the cells met on
/// the voxel layer just outside `k`'s −axis face whose minimum corner is inside `k`'s
/// footprint (a cell may be met on several rows: `out` is deduplicated later).
fn face_cells(g: &Grid, m: &Merger, k: usize, axis: usize, out: &mut Vec<u32>) {
    let ck = &m.cells[k];
    if ck.lo[axis] == 0 {
        return;
    }
    let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
    let mut p = [0u32; 3];
    p[axis] = ck.lo[axis] - 1;
    // Walk the layer row by row, jumping over each cell's footprint along u; the next row
    // is the nearest end along v of the cells met (as the expansion's face walk).
    let mut pv = ck.lo[v];
    while pv < ck.hi[v] {
        let mut pu = ck.lo[u];
        let mut row_next = u32::MAX;
        while pu < ck.hi[u] {
            p[u] = pu;
            p[v] = pv;
            let x = m.owner[g.lookup(p) as usize];
            let cx = &m.cells[x as usize];
            if cx.lo[u] >= ck.lo[u] && cx.lo[v] >= ck.lo[v] {
                out.push(x);
            }
            row_next = row_next.min(cx.hi[v]);
            pu = cx.hi[u];
        }
        pv = row_next.max(pv + 1);
    }
}

/// The live cells to evaluate in this pass along `axis`: every one in the first pass along
/// it; later, those that changed since the last pass along it or whose probe neighbour did
/// (the others keep "no candidate").
fn to_evaluate(g: &Grid, m: &Merger, axis: usize) -> EvalSet {
    if m.pass <= 3 || m.schedule == Schedule::Every {
        return EvalSet::Live;
    }
    let faces = match m.schedule {
        Schedule::Scan | Schedule::Every => false,
        Schedule::Faces => true,
        Schedule::Auto => {
            m.absorbers.iter().map(Vec::len).sum::<usize>() * FACES_BELOW <= m.live_count
        }
    };
    if !faces {
        return EvalSet::Stale;
    }
    let mut changed: Vec<u32> = m
        .absorbers
        .iter()
        .flatten()
        .copied()
        .filter(|&i| m.is_live(i))
        .collect();
    changed.par_sort_unstable();
    changed.dedup();
    let mut out: Vec<u32> = changed
        .par_iter()
        .with_min_len(256)
        .fold(Vec::new, |mut out, &k| {
            out.push(k);
            face_cells(g, m, k as usize, axis, &mut out);
            out
        })
        .flatten_iter()
        .collect();
    out.par_sort_unstable();
    out.dedup();
    EvalSet::List(out)
}

/// One merge pass along `axis`; returns how many cells were absorbed.
fn merge_pass(g: &mut Grid, m: &mut Merger, axis: usize) -> usize {
    let pass = m.pass;
    let (gr, mr) = (&*g, &*m);
    // 1. Candidates, re-evaluated where the cell or its probe neighbour changed.
    // Every cell with a candidate is evaluated in this pass (module docs), so `cands` (cell,
    // candidate) is every one, in ascending cell order.
    let set = to_evaluate(gr, mr, axis);
    let cands: Vec<(u32, u32)> = match &set {
        EvalSet::Stale => collect_blocks(m.owner.len(), BLOCK, |r, out| {
            for i in r {
                if !mr.is_live(i as u32) {
                    continue;
                }
                let c = if mr.changed(i) {
                    evaluate(gr, mr, i, axis)
                } else {
                    let j = mr.probe_owner(gr, i, axis);
                    if j != NONE && mr.changed(j as usize) {
                        evaluate_with(gr, mr, i, j, axis)
                    } else {
                        None
                    }
                };
                out.extend(c);
            }
        }),
        EvalSet::Live => collect_blocks(m.owner.len(), BLOCK, |r, out| {
            for i in r {
                if mr.is_live(i as u32) {
                    out.extend(evaluate(gr, mr, i, axis));
                }
            }
        }),
        EvalSet::List(v) => collect_blocks(v.len(), BLOCK, |r, out| {
            for &i in &v[r] {
                out.extend(evaluate(gr, mr, i as usize, axis));
            }
        }),
    };
    drop(set);
    // 2. Chains: heads are candidates nobody points at; walk each, cutting it into runs.
    cands.par_iter().with_min_len(4096).for_each(|&(_, j)| {
        mr.marks[j as usize].fetch_or(PRED, Relaxed);
    });
    let heads: Vec<u32> = collect_blocks(cands.len(), BLOCK, |r, out| {
        for &(i, _) in &cands[r] {
            if mr.marks[i as usize].load(Relaxed) & PRED == 0 {
                out.push(i);
            }
        }
    });
    cands.par_iter().with_min_len(4096).for_each(|&(_, j)| {
        mr.marks[j as usize].fetch_and(!PRED, Relaxed);
    });
    drop(cands);
    let chunks = walk_chains(g, m, &heads, axis);
    // The changes of the pass three back are no longer "since the last pass along" any axis.
    let slot = pass as usize % 3;
    for &i in &m.absorbers[slot] {
        m.marks[i as usize].fetch_and(!changed_in(pass), Relaxed);
    }
    m.absorbers[slot].clear();
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
        compact_pool(m);
    }
    // Cannot overflow: the pool stays under 4× the initial references (≤ 2^28, checked by
    // the build) or is compacted to the live lists, and `total` is at most as many again
    // (a run's list is at most its cells' lists together).
    let base = m.pool.len();
    debug_assert!(base + total < u32::MAX as usize);
    m.pool.resize(base + total, 0);
    {
        let out = SharedMut(m.pool[base..].as_mut_ptr());
        let (xp, op, marks) = (
            SharedMut(m.cells.as_mut_ptr()),
            SharedMut(m.owner.as_mut_ptr()),
            &m.marks,
        );
        chunks
            .par_iter()
            .zip(offs.par_iter())
            .for_each(|(ch, &at)| {
                // The wrappers, not their raw fields, cross threads.
                let (lists, cells, owners) = (&out, &xp, &op);
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
                        marks[i].fetch_or(changed_in(pass), Relaxed);
                        for &j in &ch.members[run.members.0 as usize..run.members.1 as usize] {
                            owners.write(j as usize, i as u32);
                        }
                    }
                }
            });
    }
    m.absorbers[slot] = chunks
        .iter()
        .flat_map(|ch| ch.runs.iter().map(|r| r.absorber))
        .collect();
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
    let next = |i: u32| m.next(g, i as usize, axis);
    let runs = m.rule == MergeRule::Runs;
    heads
        .par_iter()
        .with_min_len(256)
        .fold(
            || (Chunk::default(), Vec::new(), Vec::new()),
            |(mut ch, mut acc, mut tmp): (Chunk, Vec<u32>, Vec<u32>), &head| {
                let mut i = head;
                loop {
                    let j = next(i);
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
                        let k = next(last);
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
                    let k = next(last);
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
    let owner = SharedMut(m.owner.as_mut_ptr());
    let n = m.owner.len();
    (0..n).into_par_iter().with_min_len(8192).for_each(|x| {
        let owner = &owner;
        // SAFETY: before the pass every owner was live; now an owner is live or was
        // absorbed in this pass, and then its own entry names its (live) absorber. Only
        // entries naming an absorbed cell change, each by its own task, and the entries
        // read through them (absorbed cells') do not change: no entry is read by one task
        // while another writes it.
        unsafe {
            let o = owner.0.add(x).read();
            let oo = owner.0.add(o as usize).read();
            if oo != o {
                owner.write(x, oo);
            }
        }
    });
}

/// The lists of `len` cells, the k-th's `pool[rec(k).begin .. rec(k).end]`, gathered in
/// order (count → scan → emit): the offsets (one per cell, and the total last) and the
/// references.
fn gather<'a>(
    pool: &[u32],
    len: usize,
    rec: impl Fn(usize) -> &'a CellRec + Sync,
) -> (Vec<u32>, Vec<u32>) {
    // The counts are written where their offsets go and scanned in place (no second array
    // per cell at the merge's peak).
    let mut first: Vec<u32> = (0..len + 1)
        .into_par_iter()
        .with_min_len(4096)
        .map(|k| {
            if k < len {
                rec(k).end - rec(k).begin
            } else {
                0
            }
        })
        .collect();
    let mut total = 0u32;
    for f in &mut first {
        (*f, total) = (total, total + *f);
    }
    let mut refs = vec![0u32; total as usize];
    {
        let out = SharedMut(refs.as_mut_ptr());
        (0..len).into_par_iter().with_min_len(1024).for_each(|k| {
            let r = rec(k);
            for (x, &t) in pool[r.begin as usize..r.end as usize].iter().enumerate() {
                // SAFETY: cell k owns [first[k], first[k + 1]).
                unsafe { out.write(first[k] as usize + x, t) };
            }
        });
    }
    (first, refs)
}

/// Rewrite the pool with only the live cells' lists.
fn compact_pool(m: &mut Merger) {
    let live = m.live();
    let cells = &m.cells;
    let (first, pool) = gather(&m.pool, live.len(), |k| &cells[live[k] as usize]);
    for (k, &i) in live.iter().enumerate() {
        m.cells[i as usize].begin = first[k];
        m.cells[i as usize].end = first[k + 1];
    }
    m.pool = pool;
}

/// Renumber the live cells in their initial order, gather their references, and point the
/// voxel map at the new indices. What is no longer needed goes as soon as it can: the
/// records are moved to the front in live order and their dead tail's pages released, and
/// the owners become the new indices in place, so nothing per initial cell is allocated
/// here (on a 2 M-triangle hairball, 19 M initial cells of which 10 M live: 0.3 GB of
/// records released before the references are gathered).
fn compact(g: &mut Grid, mut m: Merger) {
    m.marks = Vec::new();
    let live = m.live();
    // Live cell k (ascending) moves to index k ≤ its own: in order, nothing is overwritten
    // before it is moved.
    for (k, &i) in live.iter().enumerate() {
        m.cells[k] = m.cells[i as usize];
    }
    trace::memory::release_tail(&mut m.cells, live.len());
    // A live cell's owner entry becomes its new index, flagged; an absorbed cell's still
    // names its live owner, whose entry now holds the index.
    const NEW: u32 = 1 << 31;
    {
        let owner = SharedMut(m.owner.as_mut_ptr());
        live.par_iter()
            .enumerate()
            .with_min_len(4096)
            .for_each(|(k, &i)| {
                let owner = &owner;
                // SAFETY: live cells are distinct; nothing reads owners in this loop.
                unsafe { owner.write(i as usize, k as u32 | NEW) };
            });
    }
    drop(live);
    let owner = &m.owner;
    g.entries.par_iter_mut().with_min_len(4096).for_each(|e| {
        if *e & NODE == 0 {
            let o = owner[*e as usize];
            let k = if o & NEW != 0 { o } else { owner[o as usize] };
            *e = k & !NEW;
        }
    });
    m.owner = Vec::new();
    let cells = &m.cells;
    let (ref_first, refs) = gather(&m.pool, cells.len(), |k| &cells[k]);
    m.pool = Vec::new();
    let lo: Vec<[u32; 3]> = cells.par_iter().with_min_len(4096).map(|c| c.lo).collect();
    let hi: Vec<[u32; 3]> = cells.par_iter().with_min_len(4096).map(|c| c.hi).collect();
    m.cells = Vec::new();
    // Expansion starts from the cells' own boxes.
    g.exp_min = lo.clone();
    g.exp_max = hi.clone();
    g.cell_min = lo;
    g.cell_max = hi;
    g.ref_first = ref_first;
    g.refs = refs;
}
