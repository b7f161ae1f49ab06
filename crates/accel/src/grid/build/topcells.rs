//! The CPU's initial grid (paper §4.1) built top cell by top cell: the same cells, references
//! and voxel map as the level-by-level passes ([`subdivide`] then [`finish`], which the GPU
//! mirrors and its tests compare with), in a fraction of the memory traffic.
//!
//! Why: every decision of the level-by-level build is local to one node (its reference count,
//! its references' child masks, its top cell's depth), but a level's passes visit nodes in
//! the order of their references, so at a million triangles each pass is a random walk over
//! arrays of tens of MB (histograms, split flags, coordinates, scans), ten passes per level,
//! and the cells pass then sorts the leaves' references into map order with another random
//! scatter. Here the references are grouped by top cell once (a counting sort), and each top
//! cell's octree is subdivided depth first on a few KB that stay in cache:
//! - a node decides exactly as [`subdivide`] does (eq. 1's depth of its top cell, the
//!   adaptive rule, "a node whose every reference overlaps all 8 children stays a leaf");
//! - its children's lists are cut from its own (child k in Morton order, references kept in
//!   ascending triangle order, so a leaf's list is already sorted);
//! - the leaves come out depth first in Morton order, which is the voxel map's cell order
//!   ([`voxelmap::flatten_top`] writes the top cell's blocks), so cells, their references and
//!   the map are appended once, in order: top cells go in waves of about 2^18 top-cell
//!   references, each wave's tasks build parts that are then appended (placed by scans) and
//!   reused by the next wave, so the build holds one wave's parts beside the grid.
//!
//! The caps ([`Limits`]) hold as before: every leaf's references and every split's 8 nodes
//! are counted against them (shared atomic tallies) before they are stored, and the first
//! build to pass one stops every task with the same kind of error.

use super::cells::assemble_cells;
use super::*;
use std::sync::atomic::AtomicU64;
use std::sync::Mutex;

/// Top cells per task: enough work to amortise a task, few enough to balance 2–16 threads.
const TOP_CELLS_PER_TASK: usize = 32;

/// One task's top cells: their map entries (root entries, then the blocks), and their cells
/// in map order with their references. Cell ids and block indices are relative to the task.
#[derive(Default)]
struct Part {
    roots: Vec<u32>,
    blocks: Vec<u32>,
    coord: Vec<[u32; 3]>,
    level: Vec<u8>,
    count: Vec<u32>,
    refs: Vec<u32>,
    deepest: u32,
}

impl Part {
    /// Empty, keeping the buffers (parts are reused from wave to wave).
    fn clear(&mut self) {
        self.roots.clear();
        self.blocks.clear();
        self.coord.clear();
        self.level.clear();
        self.count.clear();
        self.refs.clear();
        self.deepest = 0;
    }
}

/// A thread's working memory, reused from top cell to top cell: the top cell's triangles
/// (the nodes' lists hold positions in it), the lists of the nodes on the current path (each
/// node's children's lists appended after it), their child masks, the top cell's sparse map,
/// and each triangle's prepared separating-axis test.
struct Scratch {
    tris: Vec<u32>,
    lists: Vec<u32>,
    masks: Vec<u8>,
    sparse: Vec<u32>,
    prepared: Vec<Local>,
    /// The references and nodes this top cell made so far (added to the tallies after it).
    held: (u64, u64),
}

impl Scratch {
    /// Ready for a top cell whose references are `tris`: the root's list holds them all,
    /// nothing is prepared, the map and the counts are empty.
    fn start(&mut self, tris: &[u32]) {
        self.tris.clear();
        self.tris.extend_from_slice(tris);
        self.lists.clear();
        self.lists.extend(0..tris.len() as u32);
        self.prepared.clear();
        self.prepared.resize(
            tris.len(),
            Local {
                sat: None,
                radii: [0.0; 13],
                level: u32::MAX,
            },
        );
        self.sparse.clear();
        self.held = (0, 0);
    }
}

/// A top cell's triangle's prepared test (made when first needed: most references are
/// placed by the half-space tests alone) and its radii for one level's children (a
/// triangle meets its sibling nodes at one level, so the radii are mostly reused).
#[derive(Clone, Copy)]
struct Local {
    sat: Option<TriBoxSat>,
    radii: [f32; 13],
    /// The level of `radii` (`u32::MAX`: none).
    level: u32,
}

/// Running totals of what the build holds, against the caps (checked before each store).
struct Tally {
    refs: AtomicU64,
    nodes: AtomicU64,
    failed: AtomicBool,
}

/// What every node of one top cell's octree reads.
struct Tree<'a, 'b> {
    f: &'a Frame<'b>,
    cfg: &'a GridConfig,
    lim: &'a Limits,
    /// What every task held (references, nodes) when this top cell started.
    held: (u64, u64),
    max_depth: u32,
    /// Eq. 1's depth of this top cell.
    depth: u32,
    adaptive: bool,
}

impl Tree<'_, '_> {
    /// Subdivide the node at coordinates `c` of level `level` whose references are the top
    /// cell's triangles at positions `s.lists[lo..hi]`; returns its sparse map entry (a cell
    /// id relative to `out`, or a block of 8 children in `s.sparse`).
    fn node(
        &self,
        s: &mut Scratch,
        out: &mut Part,
        c: [u32; 3],
        level: u32,
        (lo, hi): (usize, usize),
    ) -> Result<u32, GridError> {
        let n = hi - lo;
        // The same decision as one node of `subdivide`'s level.
        let small = if !self.adaptive || level == 0 {
            n
        } else {
            let half = (self.f.tsize / (1u32 << (level + 1)) as f32).min_element();
            s.lists[lo..hi]
                .iter()
                .filter(|&&l| {
                    let t = s.tris[l as usize] as usize;
                    self.f.tri_box[t].extent().max_element() <= half
                })
                .count()
        };
        let wants = n > 0
            && level < self.max_depth
            && (level < self.depth
                || (self.adaptive && self.cfg.leaf_density * small as f32 >= ADAPTIVE_SPLIT));
        let split = wants && {
            s.masks.clear();
            let (mut separates, mut copies) = (false, 0u32);
            let node = (self.f.mid_planes(c, level), self.f.child_centres(c, level));
            for i in lo..hi {
                let m = self.child_mask(s, level, s.lists[i] as usize, &node);
                separates |= m != 0xff;
                copies += m.count_ones();
                s.masks.push(m);
            }
            let beyond = self.adaptive && level >= self.depth;
            separates && (!beyond || (copies as f32) < ADAPTIVE_COPIES * n as f32)
        };
        if !split {
            s.held.0 += n as u64;
            self.lim.check_refs(self.held.0 + s.held.0)?;
            let id = out.coord.len() as u32;
            out.coord.push(c);
            out.level.push(level as u8);
            out.count.push(n as u32);
            out.refs
                .extend(s.lists[lo..hi].iter().map(|&l| s.tris[l as usize]));
            out.deepest = out.deepest.max(level);
            return Ok(id);
        }
        s.held.1 += 8;
        self.lim.check_nodes(self.held.1 + s.held.1, level)?;
        // The children's lists, child k's after child k − 1's, each in its parent's order:
        // their sizes from the masks, then one pass placing each reference.
        let base = s.lists.len();
        let mut at = [0usize; 8];
        for &m in &s.masks {
            for (k, a) in at.iter_mut().enumerate() {
                *a += (m >> k & 1) as usize;
            }
        }
        let mut ends = [0usize; 8];
        let mut end = base;
        for k in 0..8 {
            let size = at[k];
            at[k] = end;
            end += size;
            ends[k] = end;
        }
        s.lists.resize(end, 0);
        for i in 0..n {
            let (t, mut m) = (s.lists[lo + i], s.masks[i]);
            while m != 0 {
                let k = m.trailing_zeros() as usize;
                m &= m - 1;
                s.lists[at[k]] = t;
                at[k] += 1;
            }
        }
        let first = s.sparse.len();
        s.sparse.extend_from_slice(&[0; 8]);
        let mut from = base;
        for (k, &end) in ends.iter().enumerate() {
            let k = k as u32;
            let cc = [
                2 * c[0] + (k & 1),
                2 * c[1] + ((k >> 1) & 1),
                2 * c[2] + (k >> 2),
            ];
            let e = self.node(s, out, cc, level + 1, (from, end))?;
            s.sparse[first + k as usize] = e;
            from = end;
        }
        s.lists.truncate(base);
        Ok(voxelmap::node(first as u32, 1))
    }

    /// [`Frame::child_mask`] of the top cell's triangle at position `l`, its prepared test
    /// and radii kept in `s.prepared` (the same values as made afresh).
    #[inline]
    fn child_mask(
        &self,
        s: &mut Scratch,
        level: u32,
        l: usize,
        (planes, centres): &(MidPlanes, [[f32; 8]; 3]),
    ) -> u8 {
        let t = s.tris[l] as usize;
        let mask = planes.mask(&self.f.tri_box[t]);
        if mask.count_ones() <= 1 {
            return mask;
        }
        let p = &mut s.prepared[l];
        let sat = p.sat.get_or_insert_with(|| TriBoxSat::new(&self.f.tris[t]));
        if p.level != level {
            p.radii = sat.radii(self.f.node_half(level + 1));
            p.level = level;
        }
        sat.overlaps8(centres, &p.radii) & mask
    }
}

/// The initial structure (§4.1), top cell by top cell: the same [`Grid`] as [`subdivide`]
/// followed by [`finish`].
pub fn initial(tris: &[[Vec3; 3]], cfg: &GridConfig) -> Result<Grid, GridError> {
    initial_in_waves(tris, cfg, WAVE_REFS)
}

/// [`initial`] in waves of about `wave_refs` top-cell references (tests use small waves).
pub(super) fn initial_in_waves(
    tris: &[[Vec3; 3]],
    cfg: &GridConfig,
    wave_refs: u64,
) -> Result<Grid, GridError> {
    let t0 = Instant::now();
    let (st, frame) = Frame::of(tris, cfg)?;
    let (ref_top, ref_tri) = top_refs(&frame, st.top_dims, &st.limits)?;
    let top_refs_seconds = t0.elapsed().as_secs_f64();

    // The top cells' lists: a counting sort by top cell, each list then ascending.
    let t1 = Instant::now();
    let ntop = st.ntop;
    let count = histogram(&ref_top, ntop);
    let mut first = vec![0u32; ntop + 1];
    let total = exclusive_scan(&count, &mut first[..ntop]);
    first[ntop] = total;
    let grouped = group_sorted(&first, &ref_top, &ref_tri);
    drop((ref_top, ref_tri));
    let depth: Vec<u32> = count
        .par_iter()
        .with_min_len(4096)
        .map(|&n| paper_depth(frame.tsize, n, cfg.leaf_density, st.max_depth))
        .collect();
    drop(count);

    let tally = Tally {
        refs: AtomicU64::new(0),
        nodes: AtomicU64::new(ntop as u64),
        failed: AtomicBool::new(false),
    };
    // Waves of top cells ([`WAVE_REFS`] top-cell references each): a wave's parts are placed
    // (appended to the grid's arrays) before the next wave is built, and their buffers are reused, so
    // the build holds one wave's parts on top of the grid, not a second copy of it.
    let waves = waves(&first, wave_refs);
    let pool: Mutex<Vec<Part>> = Mutex::new(Vec::new());
    let mut placed = Placed::new(ntop);
    let mut octree_seconds = t1.elapsed().as_secs_f64();
    for wave in waves {
        let tw = Instant::now();
        let tasks = wave.len().div_ceil(TOP_CELLS_PER_TASK);
        let parts: Result<Vec<Part>, GridError> = (0..tasks)
            .into_par_iter()
            .map_init(
                || Scratch {
                    tris: Vec::new(),
                    lists: Vec::new(),
                    masks: Vec::new(),
                    sparse: Vec::new(),
                    prepared: Vec::new(),
                    held: (0, 0),
                },
                |s, task| {
                    let at = wave.start + task * TOP_CELLS_PER_TASK;
                    let tops = at..(at + TOP_CELLS_PER_TASK).min(wave.end);
                    let mut out = pool
                        .lock()
                        .ok()
                        .and_then(|mut p| p.pop())
                        .unwrap_or_default();
                    out.clear();
                    for t in tops {
                        if tally.failed.load(Ordering::Relaxed) {
                            break; // Another task passed a cap: its error is returned.
                        }
                        let tree = Tree {
                            f: &frame,
                            cfg,
                            lim: &st.limits,
                            held: (
                                tally.refs.load(Ordering::Relaxed),
                                tally.nodes.load(Ordering::Relaxed),
                            ),
                            max_depth: st.max_depth,
                            depth: depth[t],
                            adaptive: cfg.subdivision == Subdivision::Adaptive,
                        };
                        s.start(&grouped[first[t] as usize..first[t + 1] as usize]);
                        let c = [
                            t as u32 % st.top_dims[0],
                            (t as u32 / st.top_dims[0]) % st.top_dims[1],
                            t as u32 / (st.top_dims[0] * st.top_dims[1]),
                        ];
                        let cells_before = out.coord.len() as u32;
                        let root = tree.node(s, &mut out, c, 0, (0, s.lists.len()));
                        tally.refs.fetch_add(s.held.0, Ordering::Relaxed);
                        tally.nodes.fetch_add(s.held.1, Ordering::Relaxed);
                        let root = match root {
                            Ok(e) => e,
                            Err(e) => {
                                tally.failed.store(true, Ordering::Relaxed);
                                return Err(e);
                            }
                        };
                        let root = if root & voxelmap::NODE == 0 {
                            root
                        } else {
                            voxelmap::flatten_top(&s.sparse, root, &mut out.blocks, cells_before)
                        };
                        out.roots.push(root);
                    }
                    Ok(out)
                },
            )
            .collect();
        let parts = parts?;
        octree_seconds += tw.elapsed().as_secs_f64();
        placed.append(wave.start, &parts)?;
        if let Ok(mut p) = pool.lock() {
            p.extend(parts); // (A poisoned pool only follows a panic, which rayon re-raises.)
        }
    }
    drop((grouped, first, depth, pool));

    let mut g = placed.finish(&st);
    g.build.top_refs_seconds = top_refs_seconds;
    // The octrees' time is the waves' builds (and the grouping before them); the cells'
    // is their placement and the footprints.
    g.build.octree_seconds = octree_seconds;
    g.build.voxel_map_seconds = t1.elapsed().as_secs_f64() - octree_seconds;
    Ok(g)
}

/// Top-cell references per wave. A wave's parts hold about 16× this many leaf references
/// (a hairball's growth from top cell to leaf) plus their cells, ~50 MB here, and stay
/// resident once freed (the binaries keep freed buffers below 32 MB for reuse,
/// `trace::memory::keep_freed_memory`): waves of 2^20 raised hairball:1M's whole-process peak
/// from 1.62 to 1.78 GB.
const WAVE_REFS: u64 = 1 << 18;

/// Consecutive ranges of top cells with about `refs` references each (by `first`, the top
/// cells' reference offsets); every top cell in one range.
pub(super) fn waves(first: &[u32], refs: u64) -> Vec<std::ops::Range<usize>> {
    let ntop = first.len() - 1;
    let mut out = Vec::new();
    let mut start = 0;
    while start < ntop {
        let target = (first[start] as u64 + refs).min(first[ntop] as u64) as u32;
        // The first boundary past `start` at or beyond the target: the wave holds at least
        // top cell `start`. A wave that reaches the last reference takes the empty top
        // cells after it too (the search would make each its own wave: 1,281 of them on a
        // 1 M-triangle hairball).
        let end = start + 1 + first[start + 1..=ntop].partition_point(|&f| f < target);
        let end = if first[end.min(ntop)] == first[ntop] {
            ntop
        } else {
            end
        };
        out.push(start..end);
        start = end;
    }
    out
}

/// The grid's arrays as the waves append to them (top cells in index order): the voxel map
/// (top entries, then each top cell's blocks), the cells (octree coordinates and level until
/// the deepest level is known) and their references.
struct Placed {
    entries: Vec<u32>,
    coord: Vec<[u32; 3]>,
    level: Vec<u8>,
    ref_first: Vec<u32>,
    refs: Vec<u32>,
    deepest: u32,
}

impl Placed {
    fn new(ntop: usize) -> Placed {
        Placed {
            entries: vec![0; ntop],
            coord: Vec::new(),
            level: Vec::new(),
            ref_first: Vec::new(),
            refs: Vec::new(),
            deepest: 0,
        }
    }

    /// Append one wave's parts (its first top cell `top`), in order: each part's blocks,
    /// cells and references after the previous part's, its top entries rebased.
    fn append(&mut self, top: usize, parts: &[Part]) -> Result<(), GridError> {
        let scan = |f: &dyn Fn(&Part) -> usize, from: usize| {
            let mut at = from;
            let bases: Vec<usize> = parts
                .iter()
                .map(|p| {
                    let b = at;
                    at += f(p);
                    b
                })
                .collect();
            (bases, at)
        };
        let (cell_base, ncells) = scan(&|p| p.coord.len(), self.coord.len());
        let (block_base, nentries) = scan(&|p| p.blocks.len(), self.entries.len());
        let (ref_base, nrefs) = scan(&|p| p.refs.len(), self.refs.len());
        voxelmap::check_total(nentries as u64)?;
        // Room, not zeros: the parts write every new slot (a zero fill would be one more
        // pass over the grid's largest arrays).
        self.entries.reserve(nentries - self.entries.len());
        self.coord.reserve(ncells - self.coord.len());
        self.level.reserve(ncells - self.level.len());
        self.ref_first.reserve(ncells - self.ref_first.len());
        self.refs.reserve(nrefs - self.refs.len());
        self.deepest = parts.iter().map(|p| p.deepest).fold(self.deepest, u32::max);
        let (ep, cp, lp, fp, rp) = (
            SharedMut(self.entries.as_mut_ptr()),
            SharedMut(self.coord.as_mut_ptr()),
            SharedMut(self.level.as_mut_ptr()),
            SharedMut(self.ref_first.as_mut_ptr()),
            SharedMut(self.refs.as_mut_ptr()),
        );
        parts.par_iter().enumerate().for_each(|(task, p)| {
            let (ep, cp, lp, fp, rp) = (&ep, &cp, &lp, &fp, &rp);
            let (cb, bb, rb) = (cell_base[task], block_base[task], ref_base[task]);
            // Blocks move by their base, cells by theirs (as `voxelmap::flatten` rebases).
            let rebase = |e: u32| {
                if e & voxelmap::NODE == 0 {
                    e + cb as u32
                } else {
                    e + bb as u32
                }
            };
            // SAFETY: part `task` owns its top cells' entries, the entries [bb, + its
            // blocks), the cells [cb, + its cells) and the references [rb, + its
            // references), by the scans; the arrays were sized for all of them.
            unsafe {
                for (k, &e) in p.roots.iter().enumerate() {
                    ep.write(top + task * TOP_CELLS_PER_TASK + k, rebase(e));
                }
                for (k, &e) in p.blocks.iter().enumerate() {
                    ep.write(bb + k, rebase(e));
                }
                std::ptr::copy_nonoverlapping(p.coord.as_ptr(), cp.0.add(cb), p.coord.len());
                std::ptr::copy_nonoverlapping(p.level.as_ptr(), lp.0.add(cb), p.level.len());
                let mut r = rb as u32;
                for (k, &n) in p.count.iter().enumerate() {
                    fp.write(cb + k, r);
                    r += n;
                }
                std::ptr::copy_nonoverlapping(p.refs.as_ptr(), rp.0.add(rb), p.refs.len());
            }
        });
        // SAFETY: the parts wrote every slot up to the new lengths (their ranges tile them),
        // within the capacity reserved above.
        unsafe {
            self.entries.set_len(nentries);
            self.coord.set_len(ncells);
            self.level.set_len(ncells);
            self.ref_first.set_len(ncells);
            self.refs.set_len(nrefs);
        }
        Ok(())
    }

    /// The [`Grid`] of the initial cells: each cell's footprint on the virtual grid from its
    /// octree coordinates once the deepest level (the virtual grid's shift) is known.
    fn finish(self, st: &Setup) -> Grid {
        let Placed {
            entries,
            coord,
            level,
            mut ref_first,
            refs,
            deepest: shift,
        } = self;
        ref_first.push(refs.len() as u32);
        // The coordinates become the minima in place; the maxima are the one new array.
        let mut cell_min = coord;
        let cell_max: Vec<[u32; 3]> = cell_min
            .par_iter_mut()
            .zip(level.par_iter())
            .with_min_len(4096)
            .map(|(c, &l)| {
                let s = shift - l as u32;
                *c = c.map(|v| v << s);
                c.map(|v| v + (1 << s))
            })
            .collect();
        drop(level);
        assemble_cells(st, shift, entries, (cell_min, cell_max), ref_first, refs)
    }
}
