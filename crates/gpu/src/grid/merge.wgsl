// SAH cell merging (Pérard-Gayot et al. 2017, §4.2), the twin of accel/src/grid/merge.rs: a
// pass along one axis makes every live cell whose +axis neighbour is exactly aligned and
// whose merge lowers the SAH cost a candidate; chains of candidates are walked from their
// heads and cut into merges; reference lists merge as merge sort (ascending, duplicates
// once). The CPU caches candidates between passes and keeps a
// growing reference pool; here every live cell is evaluated in every pass and the lists are
// rewritten compactly after each pass. Neither changes what is merged: the candidates are
// the same function of the same cells, and list contents do not depend on where they lie.
//
// Chains are cut into merges by pairs (the paper: even positions absorb their successor) or
// by runs (merge.rs `walk_chains`: a cell absorbs its successor and then each next cell of
// the chain while the SAH test between the run so far and that cell passes, up to MAX_RUN
// cells). A run's list is the union of its cells' lists, never stored while the chain is
// walked: its size comes from |run ∪ L| = |run| + |L| − |L ∩ run| (L's references looked
// for in the run's lists, `run_common`), and the counts and emit passes take the smallest
// successor over the run's lists again and again. Same sets, same sizes, same test bits as
// the CPU's.
//
// Cells keep their initial index while merging; owner[i] is the live cell holding cell i.

// Parameters of a merge pass's kernels (m_candidates, m_predecessors, m_chains, m_counts,
// m_emit, m_live_flags).
struct MergeParams {
    cells: u32, // live cells
    axis: u32, // the pass's axis
    shift: u32, // log2 of the top cells' resolution in voxels
    empty_only: u32, // 1: only empty cells merge
    dims: vec3<u32>, // the virtual grid's dimensions in voxels
    runs: u32, // 1: runs of cells merge (MergeRule::Runs), 0: pairs
    top_dims: vec3<u32>, // the top grid's dimensions
    voxel: vec3<f32>, // the voxel's size in world units
}

// Parameters of the kernels that take one count (m_init, m_compress, m_final_*).
struct MergeCountParams {
    n: u32, // the elements, as each kernel says
}

@group(0) @binding(1) var<storage, read> m_map: array<u32>;
@group(0) @binding(2) var<storage, read> m_live: array<u32>;
@group(0) @binding(3) var<storage, read_write> m_owner: array<u32>;
@group(0) @binding(4) var<storage, read_write> m_min: array<vec4<u32>>;
@group(0) @binding(5) var<storage, read_write> m_max: array<vec4<u32>>;
// Each live cell's list: pool[begin[i] .. end[i]] (2 per cell: begin, end).
@group(0) @binding(6) var<storage, read> m_range: array<u32>;
@group(0) @binding(7) var<storage, read> m_pool: array<u32>;
@group(0) @binding(8) var<storage, read_write> m_cand: array<u32>;
// Per cell: [2i] has a predecessor, [2i + 1] absorbed in this pass.
@group(0) @binding(9) var<storage, read_write> m_mark: array<u32>;
// Per absorber: the last cell of its run (its successor, for a pair); NONE otherwise.
@group(0) @binding(10) var<storage, read_write> m_partner: array<u32>;
@group(0) @binding(11) var<storage, read_write> m_count: array<u32>;
@group(0) @binding(12) var<storage, read> m_offs: array<u32>;
@group(0) @binding(13) var<storage, read_write> m_range_out: array<u32>;
@group(0) @binding(14) var<storage, read_write> m_pool_out: array<u32>;
@group(0) @binding(15) var<storage, read_write> m_owner_out: array<u32>;
@group(0) @binding(16) var<storage, read_write> m_out: array<u32>;

// The voxel map read by `lookup` (map.wgsl).
fn map_entry(i: u32) -> u32 {
    return m_map[i];
}
const NONE: u32 = 0xffffffffu;
// merge.rs MAX_RUN: most cells in one run.
const MAX_RUN: u32 = 8u;

fn lin(gid: vec3<u32>, nwg: vec3<u32>) -> u32 {
    return gid.x + gid.y * nwg.x * 256u;
}


// grid::half_area: the box's extent in world units, e.x e.y + e.y e.z + e.z e.x.
fn half_area(lo: vec3<u32>, hi: vec3<u32>) -> f32 {
    let v = merge_params().voxel;
    let e = vec3<f32>(mul(f32(hi.x - lo.x), v.x), mul(f32(hi.y - lo.y), v.y), mul(f32(hi.z - lo.z), v.z));
    return keep(keep(mul(e.x, e.y) + mul(e.y, e.z)) + mul(e.z, e.x));
}

// grid::union_len of two live cells' ascending lists.
fn union_len(i: u32, j: u32) -> u32 {
    var a = m_range[2u * i];
    let ae = m_range[2u * i + 1u];
    var b = m_range[2u * j];
    let be = m_range[2u * j + 1u];
    var n = 0u;
    while a < ae && b < be {
        let x = m_pool[a];
        let y = m_pool[b];
        if x <= y {
            a++;
        }
        if y <= x {
            b++;
        }
        n++;
    }
    return n + (ae - a) + (be - b);
}

fn list_len(i: u32) -> u32 {
    return m_range[2u * i + 1u] - m_range[2u * i];
}

// merge.rs `sah_lowered`: (n_u + 1)·A_u ≤ (n_a + 1)·A_a + (n_b + 1)·A_b, in its order of
// operations. Each count + 1 kept: a sum that a product takes must not be folded into it
// (see common.wgsl).
fn sah_lowered(au: f32, nu: u32, aa: f32, na: u32, ab: f32, nb: u32) -> bool {
    let lhs = mul(au, keep(f32(nu) + 1.0));
    let rhs = keep(mul(aa, keep(f32(na) + 1.0))) + mul(ab, keep(f32(nb) + 1.0));
    return lhs <= rhs;
}

// The first reference ≥ x in cell c's list (NONE: none), by binary search.
fn successor(c: u32, x: u32) -> u32 {
    var lo = m_range[2u * c];
    var hi = m_range[2u * c + 1u];
    while lo < hi {
        let mid = lo + (hi - lo) / 2u;
        if m_pool[mid] < x {
            lo = mid + 1u;
        } else {
            hi = mid;
        }
    }
    if lo < m_range[2u * c + 1u] {
        return m_pool[lo];
    }
    return NONE;
}

// The first reference ≥ x over the lists of the run from absorber i to its last cell
// (the chain's cells in between, through the candidates).
fn run_successor(i: u32, last: u32, x: u32) -> u32 {
    var best = NONE;
    var c = i;
    loop {
        best = min(best, successor(c, x));
        if c == last {
            break;
        }
        c = m_cand[c];
    }
    return best;
}

// How many references of cell c's list some list of the run i … last holds: each looked for
// in the run's ascending lists in turn, a list's scan stopping at the first reference not
// below it. (Binary searches here, through `successor`, came out wrong under lavapipe on
// Conference's long runs, while the same calls in the counts and emit passes do not; the
// scan gives the CPU's counts there.)
fn run_common(i: u32, last: u32, c: u32) -> u32 {
    var n = 0u;
    let e = m_range[2u * c + 1u];
    for (var a = m_range[2u * c]; a < e; a++) {
        let x = m_pool[a];
        var m = i;
        loop {
            var found = false;
            let me = m_range[2u * m + 1u];
            for (var b = m_range[2u * m]; b < me; b++) {
                let y = m_pool[b];
                if y >= x {
                    found = y == x;
                    break;
                }
            }
            if found {
                n++;
                break;
            }
            if m == last {
                break;
            }
            m = m_cand[m];
        }
    }
    return n;
}

// The size of the union of the run's lists (references are below 2^27, so x + 1 never
// wraps and NONE is never a reference) …
fn run_union_len(i: u32, last: u32) -> u32 {
    var n = 0u;
    var x = run_successor(i, last, 0u);
    while x != NONE {
        n++;
        x = run_successor(i, last, x + 1u);
    }
    return n;
}

// … and the union written from `at` (a function of its own: the counts pass binds no
// output pool).
fn run_union_write(i: u32, last: u32, at: u32) {
    var n = 0u;
    var x = run_successor(i, last, 0u);
    while x != NONE {
        m_pool_out[at + n] = x;
        n++;
        x = run_successor(i, last, x + 1u);
    }
}

// merge.rs `neighbour` and `worth_merging`: the cell at i's +axis probe voxel, if exactly
// aligned and if merging lowers the SAH cost.
fn candidate(i: u32, axis: u32) -> u32 {
    let prm = merge_params();
    let lo = m_min[i].xyz;
    let hi = m_max[i].xyz;
    if hi[axis] >= prm.dims[axis] {
        return NONE;
    }
    var p = lo;
    p[axis] = hi[axis];
    let j = m_owner[lookup(p, prm.shift, prm.top_dims)];
    let jl = m_min[j].xyz;
    let jh = m_max[j].xyz;
    for (var k = 0u; k < 3u; k++) {
        let ok = select(jl[k] == lo[k] && jh[k] == hi[k], jl[k] == hi[k], k == axis);
        if !ok {
            return NONE;
        }
    }
    let ni = list_len(i);
    let nj = list_len(j);
    if prm.empty_only != 0u && !(ni == 0u && nj == 0u) {
        return NONE;
    }
    var uh = hi;
    uh[axis] = jh[axis];
    if sah_lowered(half_area(lo, uh), union_len(i, j), half_area(lo, hi), ni, half_area(jl, jh), nj) {
        return j;
    }
    return NONE;
}

// 1. Candidates of the live cells; their marks cleared.
@compute @workgroup_size(256)
fn m_candidates(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let prm = merge_params();
    let k = lin(gid, nwg);
    if k >= prm.cells {
        return;
    }
    let i = m_live[k];
    m_cand[i] = candidate(i, prm.axis);
    m_mark[2u * i] = 0u;
    m_mark[2u * i + 1u] = 0u;
    m_partner[i] = NONE;
}

// 2. Cells that some candidate points at (at most one: the neighbour's face is exactly the
// pointing cell's).
@compute @workgroup_size(256)
fn m_predecessors(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let prm = merge_params();
    let k = lin(gid, nwg);
    if k >= prm.cells {
        return;
    }
    let j = m_cand[m_live[k]];
    if j != NONE {
        m_mark[2u * j] = 1u;
    }
}

// 3. From each chain's head: each run's absorber takes its successor (pairs: that is the
// run) and, by runs, each next cell while the SAH test of the run so far and that cell
// passes; the next run starts after the run's last cell.
@compute @workgroup_size(256)
fn m_chains(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let prm = merge_params();
    let k = lin(gid, nwg);
    if k >= prm.cells {
        return;
    }
    let head = m_live[k];
    if m_cand[head] == NONE || m_mark[2u * head] != 0u {
        return;
    }
    let axis = prm.axis;
    var i = head;
    loop {
        let j = m_cand[i];
        if j == NONE {
            break;
        }
        m_mark[2u * j + 1u] = 1u;
        var last = j;
        if prm.runs != 0u {
            let lo = m_min[i].xyz;
            var hi = m_max[i].xyz;
            hi[axis] = m_max[j][axis];
            var len = union_len(i, j);
            var cells = 2u;
            loop {
                let c = m_cand[last];
                if c == NONE || cells >= MAX_RUN {
                    break;
                }
                let nc = list_len(c);
                if prm.empty_only != 0u && !(len == 0u && nc == 0u) {
                    break;
                }
                let cl = m_min[c].xyz;
                let ch = m_max[c].xyz;
                var uh = hi;
                uh[axis] = ch[axis];
                let nu = len + nc - run_common(i, last, c);
                if !sah_lowered(half_area(lo, uh), nu, half_area(lo, hi), len, half_area(cl, ch), nc) {
                    break;
                }
                m_mark[2u * c + 1u] = 1u;
                len = nu;
                hi = uh;
                last = c;
                cells++;
            }
        }
        m_partner[i] = last;
        let n = m_cand[last];
        if n == NONE {
            break;
        }
        i = n;
    }
}

// 4. Each live cell's list length after the pass (absorbers: the union; residue: none).
@compute @workgroup_size(256)
fn m_counts(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let prm = merge_params();
    let k = lin(gid, nwg);
    if k >= prm.cells {
        return;
    }
    let i = m_live[k];
    let last = m_partner[i];
    var n = list_len(i);
    if last == m_cand[i] && last != NONE {
        n = union_len(i, last);
    } else if last != NONE {
        n = run_union_len(i, last);
    } else if m_mark[2u * i + 1u] != 0u {
        n = 0u;
    }
    m_count[k] = n;
}

// 5. The lists rewritten (a run's: the union of its cells'); absorbers take their run's far
// face and become its cells' owner.
@compute @workgroup_size(256)
fn m_emit(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let prm = merge_params();
    let k = lin(gid, nwg);
    if k >= prm.cells {
        return;
    }
    let i = m_live[k];
    let last = m_partner[i];
    var at = m_offs[k];
    m_range_out[2u * i] = at;
    m_range_out[2u * i + 1u] = m_offs[k + 1u];
    if m_mark[2u * i + 1u] != 0u {
        return;
    }
    var a = m_range[2u * i];
    let ae = m_range[2u * i + 1u];
    if last == NONE {
        for (; a < ae; a++) {
            m_pool_out[at] = m_pool[a];
            at++;
        }
        return;
    }
    let j = m_cand[i];
    if last == j {
        var b = m_range[2u * j];
        let be = m_range[2u * j + 1u];
        while a < ae && b < be {
            let x = m_pool[a];
            let y = m_pool[b];
            m_pool_out[at] = min(x, y);
            at++;
            if x <= y {
                a++;
            }
            if y <= x {
                b++;
            }
        }
        for (; a < ae; a++) {
            m_pool_out[at] = m_pool[a];
            at++;
        }
        for (; b < be; b++) {
            m_pool_out[at] = m_pool[b];
            at++;
        }
    } else {
        run_union_write(i, last, at);
    }
    let axis = prm.axis;
    var hi = m_max[i];
    hi[axis] = m_max[last][axis];
    m_max[i] = hi;
    var c = j;
    loop {
        m_owner[c] = i;
        if c == last {
            break;
        }
        c = m_cand[c];
    }
}

// 6. Owners one step deep again (merge.rs `compress_owners`); n = all cells.
@compute @workgroup_size(256)
fn m_compress(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let prm = merge_count_params();
    let x = lin(gid, nwg);
    if x >= prm.n {
        return;
    }
    m_owner_out[x] = m_owner[m_owner[x]];
}

// 7. Flags of the cells still live (for the compaction of the live list).
@compute @workgroup_size(256)
fn m_live_flags(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let prm = merge_params();
    let k = lin(gid, nwg);
    if k >= prm.cells {
        return;
    }
    let i = m_live[k];
    m_out[k] = u32(m_owner[i] == i);
}

// Final compaction (merge.rs `compact`): the live cells' new numbers (n = live cells) …
@compute @workgroup_size(256)
fn m_final_index(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let prm = merge_count_params();
    let k = lin(gid, nwg);
    if k >= prm.n {
        return;
    }
    m_out[m_live[k]] = k;
}

// … and the voxel map pointed at them (n = entries; binding 16 holds the new numbers,
// binding 15 the map rewritten).
@compute @workgroup_size(256)
fn m_final_map(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let prm = merge_count_params();
    let x = lin(gid, nwg);
    if x >= prm.n {
        return;
    }
    let e = m_map[x];
    if (e & NODE) == 0u {
        m_owner_out[x] = m_out[m_owner[e]];
    } else {
        m_owner_out[x] = e;
    }
}

@group(0) @binding(17) var<storage, read_write> m_min_out: array<vec4<u32>>;
@group(0) @binding(18) var<storage, read_write> m_max_out: array<vec4<u32>>;

// … and the live cells gathered in their order: boxes and first references (n = live
// cells; the pool is already in live order, the residue's lists being empty).
@compute @workgroup_size(256)
fn m_final_cells(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let prm = merge_count_params();
    let k = lin(gid, nwg);
    if k >= prm.n {
        return;
    }
    let i = m_live[k];
    m_min_out[k] = m_min[i];
    m_max_out[k] = m_max[i];
    m_count[k] = m_range[2u * i];
    if k + 1u == prm.n {
        m_count[k + 1u] = m_range[2u * i + 1u];
    }
}

// The initial lists' ranges from the reference ranges (n = cells; binding 11 holds them).
@compute @workgroup_size(256)
fn m_init(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let prm = merge_count_params();
    let i = lin(gid, nwg);
    if i >= prm.n {
        return;
    }
    m_range_out[2u * i] = m_count[i];
    m_range_out[2u * i + 1u] = m_count[i + 1u];
}
