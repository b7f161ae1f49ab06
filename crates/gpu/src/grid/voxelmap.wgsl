// The voxel map flattened into blocks and the cells renumbered (paper §3, Figure 1), the twin
// of accel/src/grid/voxelmap.rs `flatten` and the cells part of build.rs `finish`.
//
// The CPU flattens each top cell's octree depth first: a block of 8^k entries (k = the
// subtree's depth, at most MAX_BLOCK_LEVELS) is allocated when its root is met, children are
// visited in order 0..7, a leaf is numbered when met, an inner node at the block's bottom
// becomes the root of a new block. Both numberings are therefore pre-orders of the octree
// forest (top cells in order), which the kernels compute level by level without recursion:
// subtree depth and leaf count bottom-up; which nodes are block roots (and each node's place
// in its enclosing block) top-down; block entries per subtree bottom-up; pre-order offsets
// (first block entry, first leaf) top-down; then every node paints its part of its block.
//
// Node arrays are indexed by the node's entry in the sparse map (levels in order; the
// children of inner entry e are entries (e & INDEX) + 0..7).

// Parameters of the per-level kernels (vm_up, vm_down, vm_bsum, vm_offsets, vm_fill).
struct VmLevelParams {
    nodes: u32, // nodes of the level
    first: u32, // the level's first entry
    top: u32, // 1: the top level
    top_cells: u32, // cells of the top grid
}

// Parameters of vm_cells.
struct VmCellsParams {
    cells: u32, // leaf cells
    shift: u32, // log2 of the top cells' resolution in voxels
}

// Parameters of vm_keys.
struct VmKeysParams {
    refs: u32, // kept references
}

@group(0) @binding(1) var<storage, read> v_entries: array<u32>;
@group(0) @binding(2) var<storage, read_write> v_depth: array<u32>;
@group(0) @binding(3) var<storage, read_write> v_leaves: array<u32>;
// k of the block a node roots (0: not a root).
@group(0) @binding(4) var<storage, read_write> v_kown: array<u32>;
// Per node: [2i] its depth below its enclosing block's root, [2i + 1] that block's k.
@group(0) @binding(5) var<storage, read_write> v_place: array<u32>;
// Per node: its enclosing block's root.
@group(0) @binding(6) var<storage, read_write> v_root: array<u32>;
@group(0) @binding(7) var<storage, read_write> v_bsum: array<u32>;
@group(0) @binding(8) var<storage, read_write> v_boff: array<u32>;
@group(0) @binding(9) var<storage, read_write> v_loff: array<u32>;
@group(0) @binding(10) var<storage, read> v_coords: array<vec4<u32>>;
@group(0) @binding(11) var<storage, read_write> v_out: array<u32>;
@group(0) @binding(12) var<storage, read_write> v_new_index: array<u32>;
@group(0) @binding(13) var<storage, read_write> v_order: array<u32>;
@group(0) @binding(14) var<storage, read> v_cells: array<vec4<u32>>;
@group(0) @binding(15) var<storage, read> v_cell_level: array<u32>;
@group(0) @binding(16) var<storage, read_write> v_cell_min: array<vec4<u32>>;
@group(0) @binding(17) var<storage, read_write> v_cell_max: array<vec4<u32>>;
@group(0) @binding(18) var<storage, read_write> v_count: array<u32>;
@group(0) @binding(19) var<storage, read> v_kept_cell: array<u32>;
@group(0) @binding(20) var<storage, read_write> v_keys: array<u32>;
// Exclusive scans of the top cells' block entries and leaf counts.
@group(0) @binding(21) var<storage, read> v_top_b: array<u32>;
@group(0) @binding(22) var<storage, read> v_top_l: array<u32>;

const NODE: u32 = 0x80000000u;
const LOG_DIM_SHIFT: u32 = 28u; // voxelmap::LOG_DIM_SHIFT
const INDEX: u32 = 0x0fffffffu; // voxelmap::INDEX
const MAX_BLOCK_LEVELS: u32 = 4u;

fn lin(gid: vec3<u32>, nwg: vec3<u32>) -> u32 {
    return gid.x + gid.y * nwg.x * 256u;
}

fn node_index(gid: vec3<u32>, nwg: vec3<u32>) -> u32 {
    let prm = vm_level_params();
    let i = lin(gid, nwg);
    if i >= prm.nodes {
        return 0xffffffffu;
    }
    return prm.first + i;
}

fn block_size(k: u32) -> u32 {
    return select(0u, 1u << (3u * k), k > 0u);
}

// Bottom-up (deepest level first): subtree depth and leaf count.
@compute @workgroup_size(256)
fn vm_up(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = node_index(gid, nwg);
    if i == 0xffffffffu {
        return;
    }
    let e = v_entries[i];
    if (e & NODE) == 0u {
        v_depth[i] = 0u;
        v_leaves[i] = 1u;
        return;
    }
    let first = e & INDEX;
    var d = 0u;
    var n = 0u;
    for (var c = 0u; c < 8u; c++) {
        d = max(d, v_depth[first + c]);
        n += v_leaves[first + c];
    }
    v_depth[i] = d + 1u;
    v_leaves[i] = n;
}

// Top-down: whether a node roots a block (an inner top cell, or an inner node at its block's
// bottom) and its block's k; its children's places and enclosing roots.
@compute @workgroup_size(256)
fn vm_down(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let prm = vm_level_params();
    let i = node_index(gid, nwg);
    if i == 0xffffffffu {
        return;
    }
    let e = v_entries[i];
    let inner = (e & NODE) != 0u;
    let top = prm.top != 0u;
    let is_root = inner && (top || v_place[2u * i] == v_place[2u * i + 1u]);
    let k = select(0u, min(v_depth[i], MAX_BLOCK_LEVELS), is_root);
    v_kown[i] = k;
    if !inner {
        return;
    }
    let first = e & INDEX;
    for (var c = 0u; c < 8u; c++) {
        let j = first + c;
        if is_root {
            v_place[2u * j] = 1u;
            v_place[2u * j + 1u] = k;
            v_root[j] = i;
        } else {
            v_place[2u * j] = v_place[2u * i] + 1u;
            v_place[2u * j + 1u] = v_place[2u * i + 1u];
            v_root[j] = v_root[i];
        }
    }
}

// Bottom-up: block entries in each subtree (its own block and all below).
@compute @workgroup_size(256)
fn vm_bsum(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = node_index(gid, nwg);
    if i == 0xffffffffu {
        return;
    }
    let e = v_entries[i];
    var b = block_size(v_kown[i]);
    if (e & NODE) != 0u {
        let first = e & INDEX;
        for (var c = 0u; c < 8u; c++) {
            b += v_bsum[first + c];
        }
    }
    v_bsum[i] = b;
}

// Top-down pre-order offsets: a node's first block entry (its own block, if it roots one,
// comes before its children's) and its first leaf; top cells take theirs from the scans.
@compute @workgroup_size(256)
fn vm_offsets(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let prm = vm_level_params();
    let i = node_index(gid, nwg);
    if i == 0xffffffffu {
        return;
    }
    if prm.top != 0u {
        v_boff[i] = prm.top_cells + v_top_b[i];
        v_loff[i] = v_top_l[i];
    }
    let e = v_entries[i];
    if (e & NODE) == 0u {
        return;
    }
    let first = e & INDEX;
    var b = v_boff[i] + block_size(v_kown[i]);
    var l = v_loff[i];
    for (var c = 0u; c < 8u; c++) {
        let j = first + c;
        v_boff[j] = b;
        v_loff[j] = l;
        b += v_bsum[j];
        l += v_leaves[j];
    }
}

// Every node's part of the map: a top cell's entry; a leaf fills its region of its block, a
// block root its one entry there; the leaves' new numbers both ways.
@compute @workgroup_size(256)
fn vm_fill(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let prm = vm_level_params();
    let i = node_index(gid, nwg);
    if i == 0xffffffffu {
        return;
    }
    let e = v_entries[i];
    let leaf = (e & NODE) == 0u;
    var v: u32;
    if leaf {
        v = v_loff[i];
        v_new_index[e] = v;
        v_order[v] = e;
    } else {
        v = NODE | (v_kown[i] << LOG_DIM_SHIFT) | v_boff[i];
    }
    if prm.top != 0u {
        v_out[i] = v;
        return;
    }
    let d = v_place[2u * i];
    let k = v_place[2u * i + 1u];
    if !leaf && d < k {
        return; // painted by its descendants
    }
    let r = v_root[i];
    let lo = (v_coords[i].xyz - (v_coords[r].xyz << vec3<u32>(d))) << vec3<u32>(k - d);
    let n = 1u << (k - d);
    let base = v_boff[r];
    for (var z = lo.z; z < lo.z + n; z++) {
        for (var y = lo.y; y < lo.y + n; y++) {
            for (var x = lo.x; x < lo.x + n; x++) {
                v_out[base + (x | (y << k) | (z << (2u * k)))] = v;
            }
        }
    }
}

// Cells in map order: footprint on the virtual grid and reference count.
@compute @workgroup_size(256)
fn vm_cells(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let prm = vm_cells_params();
    let n = lin(gid, nwg);
    if n >= prm.cells {
        return;
    }
    let old = v_order[n];
    let c = v_cells[old];
    let s = prm.shift - v_cell_level[old];
    let lo = c.xyz << vec3<u32>(s);
    v_cell_min[n] = vec4<u32>(lo, 0u);
    v_cell_max[n] = vec4<u32>(lo + vec3<u32>(1u << s), 0u);
    v_count[n] = c.w;
}

// References' cells renumbered (the sort keys).
@compute @workgroup_size(256)
fn vm_keys(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let prm = vm_keys_params();
    let r = lin(gid, nwg);
    if r >= prm.refs {
        return;
    }
    v_keys[r] = v_new_index[v_kept_cell[r]];
}
