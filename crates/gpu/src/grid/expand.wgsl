// Cell expansion (Pérard-Gayot et al. 2017, §4.3), the twin of accel/src/grid/expand.rs: one
// launch per pass, axis and side; each cell walks the voxel layer just outside that face of
// its expanded box and, if every cell there holds a subset of its references, grows by the
// smallest overhang. A side that cannot grow is blocked for good (as on the CPU). Then the
// traversal's cell records (expanded box and reference range).

@group(0) @binding(1) var<storage, read> e_map: array<u32>;
@group(0) @binding(2) var<storage, read> e_min: array<vec4<u32>>;
@group(0) @binding(3) var<storage, read> e_max: array<vec4<u32>>;
@group(0) @binding(4) var<storage, read> e_first: array<u32>;
@group(0) @binding(5) var<storage, read> e_refs: array<u32>;
@group(0) @binding(6) var<storage, read_write> e_exp_min: array<vec4<u32>>;
@group(0) @binding(7) var<storage, read_write> e_exp_max: array<vec4<u32>>;
@group(0) @binding(8) var<storage, read_write> e_blocked: array<u32>;
@group(0) @binding(9) var<storage, read_write> e_rec: array<vec4<u32>>;

// Parameters of e_init.
struct EInitParams {
    cells: u32, // cells of the grid
    empty_only: u32, // 1: only empty cells expand (every other cell starts blocked)
}

// Parameters of e_side: one pass over one side of every cell.
struct ESideParams {
    cells: u32, // cells of the grid
    axis: u32, // the side's axis
    positive: u32, // 1: the side towards +axis, 0: towards −axis
    shift: u32, // log2 of the top cells' resolution in voxels
    dims: vec3<u32>, // the virtual grid's dimensions in voxels
    top_dims: vec3<u32>, // the top grid's dimensions
}

// Parameters of e_records.
struct ERecordsParams {
    cells: u32, // cells of the grid
}

// The voxel map read by `lookup` (map.wgsl).
fn map_entry(i: u32) -> u32 {
    return e_map[i];
}

fn lin(gid: vec3<u32>, nwg: vec3<u32>) -> u32 {
    return gid.x + gid.y * nwg.x * 256u;
}


// grid::is_subset: cell a's ascending list within cell b's.
fn is_subset(a: u32, b: u32) -> bool {
    var j = e_first[b];
    let je = e_first[b + 1u];
    for (var i = e_first[a]; i < e_first[a + 1u]; i++) {
        let x = e_refs[i];
        while j < je && e_refs[j] < x {
            j++;
        }
        if j == je || e_refs[j] != x {
            return false;
        }
        j++;
    }
    return true;
}

// Blocked sides at the start: with empty cells only, every non-empty cell is blocked.
@compute @workgroup_size(256)
fn e_init(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let prm = e_init_params();
    let c = lin(gid, nwg);
    if c >= prm.cells {
        return;
    }
    let empty = e_first[c] == e_first[c + 1u];
    e_blocked[c] = select(0u, 0x3fu, prm.empty_only != 0u && !empty);
    e_exp_min[c] = e_min[c];
    e_exp_max[c] = e_max[c];
}

// expand.rs `expand_side` for every cell not blocked on this side.
@compute @workgroup_size(256)
fn e_side(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let prm = e_side_params();
    let c = lin(gid, nwg);
    if c >= prm.cells {
        return;
    }
    let axis = prm.axis;
    let positive = prm.positive != 0u;
    let bit = 1u << (2u * axis + u32(positive));
    if (e_blocked[c] & bit) != 0u {
        return;
    }
    var lo = e_exp_min[c].xyz;
    var hi = e_exp_max[c].xyz;
    var layer: u32;
    if positive {
        if hi[axis] >= prm.dims[axis] {
            e_blocked[c] |= bit;
            return;
        }
        layer = hi[axis];
    } else {
        if lo[axis] == 0u {
            e_blocked[c] |= bit;
            return;
        }
        layer = lo[axis] - 1u;
    }
    let u = (axis + 1u) % 3u;
    let v = (axis + 2u) % 3u;
    var step = 0xffffffffu;
    var pv = lo[v];
    while pv < hi[v] {
        var pu = lo[u];
        var row_next = 0xffffffffu;
        while pu < hi[u] {
            var p = vec3<u32>(0u);
            p[axis] = layer;
            p[u] = pu;
            p[v] = pv;
            let n = lookup(p, prm.shift, prm.top_dims);
            if !is_subset(n, c) {
                e_blocked[c] |= bit;
                return;
            }
            let nmin = e_min[n].xyz;
            let nmax = e_max[n].xyz;
            var over: u32;
            if positive {
                over = nmax[axis] - layer;
            } else {
                over = layer + 1u - nmin[axis];
            }
            step = min(step, over);
            row_next = min(row_next, nmax[v]);
            pu = nmax[u];
        }
        pv = max(row_next, pv + 1u);
    }
    if positive {
        hi[axis] += step;
    } else {
        lo[axis] -= step;
    }
    e_exp_min[c] = vec4<u32>(lo, 0u);
    e_exp_max[c] = vec4<u32>(hi, 0u);
}

// The traversal's records: expanded box min | first reference, max | end.
@compute @workgroup_size(256)
fn e_records(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let c = lin(gid, nwg);
    if c >= e_records_params().cells {
        return;
    }
    e_rec[2u * c] = vec4<u32>(e_exp_min[c].xyz, e_first[c]);
    e_rec[2u * c + 1u] = vec4<u32>(e_exp_max[c].xyz, e_first[c + 1u]);
}
