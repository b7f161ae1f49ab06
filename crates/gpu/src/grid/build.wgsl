// Irregular-grid construction, initial cells (Pérard-Gayot et al. 2017, §4.1), the twin of
// accel/src/grid/build.rs pass for pass: triangle boxes and the scene box, references to the
// top cells (count → scan → emit, exact triangle–box tests), then the octrees level by level
// (reference histogram, which nodes want to split, child masks, which nodes split, the level's
// voxel-map entries and leaf cells, the kept and the children's references). Every float
// operation is the CPU's in the CPU's order (`common.wgsl`: products kept from fusing,
// quotients correctly rounded), so masks, cells and references equal the CPU's bit for bit.
//
// Frame constants (binding 4, vec4 each): 0 = (scene box min, padding), 1 = (size of the
// cells whose centres are tested, half-size bound of an adaptive "small" triangle),
// 2 = (half-extent of the tested boxes, padded, 0).

// Parameters of grid_tri_boxes.
struct TriBoxesParams {
    triangles: u32, // triangles of the scene
}

// Parameters of grid_top_refs: the references to the top cells counted or written.
struct TopRefsParams {
    triangles: u32, // triangles of the scene
    emit: u32, // 1: write the references at b_offs[t], 0: count them into b_cnt[t]
    top_dims: vec3<u32>, // the top grid's dimensions
}

// Parameters of the kernels of one octree level (grid_histogram, grid_wants, grid_masks,
// grid_split, grid_nodes, grid_ref_flags, grid_ref_emit).
struct OctreeLevelParams {
    n: u32, // references (histogram, masks, ref_flags, ref_emit) or nodes (wants, split, nodes)
    level: u32, // the level's depth below the top cells
    adaptive: u32, // 1: adaptive subdivision (grid_wants)
    count_small: u32, // 1: small triangles counted (grid_histogram)
    max_depth: u32, // the deepest level
    table_len: u32, // entries of the depth table
    first_cell: u32, // the level's first leaf cell (grid_nodes, grid_ref_emit)
    next_entry: u32, // the next level's first voxel-map entry (grid_nodes)
    emit_kept: u32, // grid_ref_emit: 1 the kept references, 0 the children's
    lambda2: f32, // λ₂, the leaf density
    adaptive_split: f32, // ADAPTIVE_SPLIT (accel::grid::build)
    adaptive_copies: f32, // ADAPTIVE_COPIES (accel::grid::build)
}

@group(0) @binding(1) var<storage, read> b_tris: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> b_tbox: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read_write> b_bounds: array<atomic<u32>>;
@group(0) @binding(4) var<storage, read> b_frame: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read_write> b_cnt: array<u32>;
@group(0) @binding(6) var<storage, read> b_offs: array<u32>;
@group(0) @binding(7) var<storage, read_write> b_out_key: array<u32>;
@group(0) @binding(8) var<storage, read_write> b_out_tri: array<u32>;
@group(0) @binding(9) var<storage, read> b_ref_node: array<u32>;
@group(0) @binding(10) var<storage, read> b_ref_tri: array<u32>;
@group(0) @binding(11) var<storage, read_write> b_count: array<atomic<u32>>;
@group(0) @binding(12) var<storage, read_write> b_small: array<atomic<u32>>;
@group(0) @binding(13) var<storage, read_write> b_depth: array<u32>;
@group(0) @binding(14) var<storage, read> b_dtab: array<u32>;
// Node coordinates at their level, w = the node's top cell.
@group(0) @binding(15) var<storage, read> b_coords: array<vec4<u32>>;
// Per node: bit 0 wants to split, bit 1 below the paper's depth (an adaptive split).
@group(0) @binding(16) var<storage, read_write> b_flags: array<u32>;
@group(0) @binding(17) var<storage, read_write> b_mask: array<u32>;
// Per node: [2i] some reference separates, [2i + 1] the children's reference copies.
@group(0) @binding(18) var<storage, read_write> b_sepcop: array<atomic<u32>>;
@group(0) @binding(19) var<storage, read_write> b_split: array<u32>;
@group(0) @binding(20) var<storage, read_write> b_leaf: array<u32>;
@group(0) @binding(21) var<storage, read> b_child_base: array<u32>;
@group(0) @binding(22) var<storage, read> b_leaf_index: array<u32>;
@group(0) @binding(23) var<storage, read_write> b_entries: array<u32>;
// Leaf cells of the level: octree coordinates, w = reference count.
@group(0) @binding(24) var<storage, read_write> b_cells: array<vec4<u32>>;
@group(0) @binding(25) var<storage, read_write> b_new_coords: array<vec4<u32>>;
@group(0) @binding(26) var<storage, read_write> b_kept: array<u32>;
// Leaf cells' levels (beside binding 24).
@group(0) @binding(27) var<storage, read_write> b_cell_level: array<u32>;

// voxelmap.rs: an inner entry is NODE | log2 of its block's resolution << 27 | first entry.
const NODE: u32 = 0x80000000u;
const LOG_DIM_SHIFT: u32 = 28u; // voxelmap::LOG_DIM_SHIFT

fn lin(gid: vec3<u32>, nwg: vec3<u32>) -> u32 {
    return gid.x + gid.y * nwg.x * 256u;
}

// ------------------------------------------------------------ geom::aabb::TriBoxSat
struct Sat {
    axis: array<vec3<f32>, 13>,
    lo: array<f32, 13>,
    hi: array<f32, 13>,
}

// `project`: a box axis reads one coordinate, the normal takes the full dot product, an edge
// axis (box axis × edge, one zero component) drops the zero product.
fn project(i: u32, a: vec3<f32>, v: vec3<f32>) -> f32 {
    if i < 3u {
        return v[i];
    }
    // Results kept: the tests add a radius to them, and a sum of three or more terms keeps
    // its partial sums (common.wgsl).
    if i == 3u {
        return keep(dot3(a, v));
    }
    switch (i - 4u) % 3u {
        case 0u: {
            return keep(mul(a.y, v.y) + mul(a.z, v.z));
        }
        case 1u: {
            return keep(mul(a.x, v.x) + mul(a.z, v.z));
        }
        default: {
            return keep(mul(a.x, v.x) + mul(a.y, v.y));
        }
    }
}

fn tri_vertex(t: u32, k: u32) -> vec3<f32> {
    return b_tris[3u * t + k].xyz;
}

fn sat_new(t: u32) -> Sat {
    var s: Sat;
    let v = array<vec3<f32>, 3>(tri_vertex(t, 0u), tri_vertex(t, 1u), tri_vertex(t, 2u));
    let e = array<vec3<f32>, 3>(v[1] - v[0], v[2] - v[1], v[0] - v[2]);
    s.axis[0] = vec3<f32>(1.0, 0.0, 0.0);
    s.axis[1] = vec3<f32>(0.0, 1.0, 0.0);
    s.axis[2] = vec3<f32>(0.0, 0.0, 1.0);
    s.axis[3] = cross3(e[0], e[1]);
    for (var i = 0u; i < 3u; i++) {
        for (var k = 0u; k < 3u; k++) {
            s.axis[4u + 3u * i + k] = cross3(s.axis[k], e[i]);
        }
    }
    for (var i = 0u; i < 13u; i++) {
        let a = s.axis[i];
        let p0 = project(i, a, v[0]);
        let p1 = project(i, a, v[1]);
        let p2 = project(i, a, v[2]);
        s.lo[i] = min(min(p0, p1), p2);
        s.hi[i] = max(max(p0, p1), p2);
    }
    return s;
}

// A box's projected radius on every axis, for half-extent h.
fn sat_radii(s: Sat, h: vec3<f32>) -> array<f32, 13> {
    var r: array<f32, 13>;
    for (var i = 0u; i < 13u; i++) {
        let a = s.axis[i];
        r[i] = keep(keep(mul(h.x, abs(a.x)) + mul(h.y, abs(a.y))) + mul(h.z, abs(a.z)));
    }
    return r;
}

fn sat_overlaps(s: Sat, c: vec3<f32>, r: array<f32, 13>) -> bool {
    for (var i = 0u; i < 13u; i++) {
        let p = project(i, s.axis[i], c);
        if s.lo[i] > p + r[i] || s.hi[i] < p - r[i] {
            return false;
        }
    }
    return true;
}

// ------------------------------------------------------------ frame
fn bmin() -> vec3<f32> {
    return b_frame[0].xyz;
}

fn pad() -> f32 {
    return b_frame[0].w;
}

// Frame::node_centre: box min + (c + 0.5) · size, size from the frame constants.
fn centre(c: vec3<u32>) -> vec3<f32> {
    let size = b_frame[1].xyz;
    let m = bmin();
    // Kept, so that no compiler turns (c + 0.5) · size into one fused multiply–add.
    let f = vec3<f32>(keep(f32(c.x) + 0.5), keep(f32(c.y) + 0.5), keep(f32(c.z) + 0.5));
    return vec3<f32>(
        keep(m.x + mul(f.x, size.x)),
        keep(m.y + mul(f.y, size.y)),
        keep(m.z + mul(f.z, size.z)),
    );
}

fn tri_box_min(t: u32) -> vec3<f32> {
    return b_tbox[2u * t].xyz;
}

fn tri_box_max(t: u32) -> vec3<f32> {
    return b_tbox[2u * t + 1u].xyz;
}

// ------------------------------------------------------------ triangle boxes, scene box
// (the bounds as `order_key`s, common.wgsl)
var<workgroup> w_bounds: array<atomic<u32>, 6>;

// Bounds (6 keys: min xyz, max xyz) start at (u32::MAX, 0).
@compute @workgroup_size(256)
fn grid_tri_boxes(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(local_invocation_index) li: u32, @builtin(num_workgroups) nwg: vec3<u32>) {
    let prm = tri_boxes_params();
    if li < 3u {
        atomicStore(&w_bounds[li], 0xffffffffu);
        atomicStore(&w_bounds[li + 3u], 0u);
    }
    workgroupBarrier();
    let t = lin(gid, nwg);
    if t < prm.triangles {
        let a = tri_vertex(t, 0u);
        let b = tri_vertex(t, 1u);
        let c = tri_vertex(t, 2u);
        let lo = min(min(a, b), c);
        let hi = max(max(a, b), c);
        b_tbox[2u * t] = vec4<f32>(lo, 0.0);
        b_tbox[2u * t + 1u] = vec4<f32>(hi, 0.0);
        for (var k = 0u; k < 3u; k++) {
            atomicMin(&w_bounds[k], order_key(lo[k]));
            atomicMax(&w_bounds[k + 3u], order_key(hi[k]));
        }
    }
    workgroupBarrier();
    if li < 3u {
        atomicMin(&b_bounds[li], atomicLoad(&w_bounds[li]));
        atomicMax(&b_bounds[li + 3u], atomicLoad(&w_bounds[li + 3u]));
    }
}

// ------------------------------------------------------------ top-level references
// build.rs `top_refs`: the top cells triangle t's padded box spans; a range of one cell needs
// no test, the others share one prepared separating-axis test.
fn top_pass(t: u32, emit: bool) -> u32 {
    let prm = top_refs_params();
    let dims = prm.top_dims;
    let m = bmin();
    let p = pad();
    let tsize = b_frame[1].xyz;
    let bl = tri_box_min(t);
    let bh = tri_box_max(t);
    var lo: vec3<u32>;
    var hi: vec3<u32>;
    for (var k = 0u; k < 3u; k++) {
        let top = f32(dims[k] - 1u);
        let a = floor(div(keep(bl[k] - p) - m[k], tsize[k]));
        let b = floor(div(keep(bh[k] + p) - m[k], tsize[k]));
        lo[k] = u32(min(max(a, 0.0), top));
        hi[k] = u32(min(max(b, 0.0), top));
    }
    let single = all(lo == hi);
    var s: Sat;
    var r: array<f32, 13>;
    if !single {
        s = sat_new(t);
        r = sat_radii(s, b_frame[2].xyz);
    }
    var n = 0u;
    var at = 0u;
    if emit {
        at = b_offs[t];
    }
    for (var z = lo.z; z <= hi.z; z++) {
        for (var y = lo.y; y <= hi.y; y++) {
            for (var x = lo.x; x <= hi.x; x++) {
                let c = vec3<u32>(x, y, z);
                if single || sat_overlaps(s, centre(c), r) {
                    if emit {
                        b_out_key[at + n] = x + dims.x * (y + dims.y * z);
                        b_out_tri[at + n] = t;
                    }
                    n++;
                }
            }
        }
    }
    return n;
}

// Count: b_cnt[t]; emit: at b_offs[t].
@compute @workgroup_size(256)
fn grid_top_refs(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let prm = top_refs_params();
    let t = lin(gid, nwg);
    if t >= prm.triangles {
        return;
    }
    let emit = prm.emit != 0u;
    let n = top_pass(t, emit);
    if !emit {
        b_cnt[t] = n;
    }
}

// ------------------------------------------------------------ octree levels
// References per node, and (adaptive, below the top) those to triangles at most half the
// node's size.
@compute @workgroup_size(256)
fn grid_histogram(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let prm = octree_level_params();
    let r = lin(gid, nwg);
    if r >= prm.n {
        return;
    }
    let p = b_ref_node[r];
    atomicAdd(&b_count[p], 1u);
    if prm.count_small != 0u {
        let t = b_ref_tri[r];
        let e = tri_box_max(t) - tri_box_min(t);
        if max_element3(e) <= b_frame[1].w {
            atomicAdd(&b_small[p], 1u);
        }
    }
}

// Which nodes want to split: below their top cell's paper depth, or (adaptive) their own
// count of small triangles calls for it. At the top level each node's paper depth is
// looked up in the depth table first.
@compute @workgroup_size(256)
fn grid_wants(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let prm = octree_level_params();
    let i = lin(gid, nwg);
    if i >= prm.n {
        return;
    }
    let level = prm.level;
    let adaptive = prm.adaptive != 0u;
    let n = atomicLoad(&b_count[i]);
    if level == 0u {
        var d = 0u;
        for (var k = 0u; k < prm.table_len; k++) {
            d += u32(b_dtab[k] <= n);
        }
        b_depth[i] = select(d, 0u, n == 0u);
    }
    let top = b_coords[i].w;
    let depth = b_depth[top];
    var small = n;
    if level > 0u && adaptive {
        small = atomicLoad(&b_small[i]);
    }
    let rule = level < depth || (adaptive && mul(prm.lambda2, f32(small)) >= prm.adaptive_split);
    let wants = n > 0u && level < prm.max_depth && rule;
    let beyond = adaptive && level >= depth;
    b_flags[i] = u32(wants) | (u32(beyond) << 1u);
}

// Frame::child_mask: the children of node c that triangle t overlaps (child k at
// 2c + (k & 1, (k >> 1) & 1, k >> 2)); half-spaces first, a single child needs no test.
fn child_mask(c: vec3<u32>, t: u32) -> u32 {
    let size = b_frame[1].xyz;
    let m = bmin();
    let p = pad();
    let bl = tri_box_min(t);
    let bh = tri_box_max(t);
    var mask = 0xffu;
    let low = vec3<u32>(0x55u, 0x33u, 0x0fu);
    for (var k = 0u; k < 3u; k++) {
        let mid = keep(m[k] + mul(f32(2u * c[k] + 1u), size[k]));
        if bl[k] > mid + p {
            mask &= ~low[k] & 0xffu;
        }
        if bh[k] < mid - p {
            mask &= low[k];
        }
    }
    if countOneBits(mask) <= 1u {
        return mask;
    }
    let s = sat_new(t);
    let r = sat_radii(s, b_frame[2].xyz);
    var out = 0u;
    for (var l = 0u; l < 8u; l++) {
        if ((mask >> l) & 1u) != 0u {
            let cc = 2u * c + vec3<u32>(l & 1u, (l >> 1u) & 1u, l >> 2u);
            if sat_overlaps(s, centre(cc), r) {
                out |= 1u << l;
            }
        }
    }
    return out;
}

// Child masks of the references of nodes that want to split; whether any reference of a node
// separates its children, and (adaptive splits) how many copies its children receive.
@compute @workgroup_size(256)
fn grid_masks(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let prm = octree_level_params();
    let r = lin(gid, nwg);
    if r >= prm.n {
        return;
    }
    let p = b_ref_node[r];
    let f = b_flags[p];
    var m = 0u;
    if (f & 1u) != 0u {
        m = child_mask(b_coords[p].xyz, b_ref_tri[r]);
        if m != 0xffu {
            atomicOr(&b_sepcop[2u * p], 1u);
        }
        if (f & 2u) != 0u {
            atomicAdd(&b_sepcop[2u * p + 1u], countOneBits(m));
        }
    }
    b_mask[r] = m;
}

// Which nodes split: they want to, some reference separates, and an adaptive split copies
// fewer than ADAPTIVE_COPIES of each reference on average.
@compute @workgroup_size(256)
fn grid_split(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let prm = octree_level_params();
    let i = lin(gid, nwg);
    if i >= prm.n {
        return;
    }
    let f = b_flags[i];
    let n = atomicLoad(&b_count[i]);
    let copies = atomicLoad(&b_sepcop[2u * i + 1u]);
    let useful = (f & 2u) == 0u || f32(copies) < mul(prm.adaptive_copies, f32(n));
    let s = (f & 1u) != 0u && atomicLoad(&b_sepcop[2u * i]) != 0u && useful;
    b_split[i] = u32(s);
    b_leaf[i] = 1u - u32(s);
}

// The level's voxel-map entries; its leaves' cells at their scanned slots; the children of
// split nodes.
@compute @workgroup_size(256)
fn grid_nodes(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let prm = octree_level_params();
    let i = lin(gid, nwg);
    if i >= prm.n {
        return;
    }
    let c = b_coords[i];
    if b_split[i] != 0u {
        let base = 8u * b_child_base[i];
        b_entries[i] = NODE | (1u << LOG_DIM_SHIFT) | (prm.next_entry + base);
        for (var k = 0u; k < 8u; k++) {
            let cc = 2u * c.xyz + vec3<u32>(k & 1u, (k >> 1u) & 1u, k >> 2u);
            b_new_coords[base + k] = vec4<u32>(cc, c.w);
        }
    } else {
        let l = b_leaf_index[i];
        b_entries[i] = prm.first_cell + l;
        b_cells[l] = vec4<u32>(c.xyz, atomicLoad(&b_count[i]));
        b_cell_level[l] = prm.level;
    }
}

// Per reference: kept (its node is a leaf) and how many child references it makes.
@compute @workgroup_size(256)
fn grid_ref_flags(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let prm = octree_level_params();
    let r = lin(gid, nwg);
    if r >= prm.n {
        return;
    }
    let s = b_split[b_ref_node[r]];
    b_kept[r] = 1u - s;
    b_cnt[r] = select(0u, countOneBits(b_mask[r]), s != 0u);
}

// Kept references to their leaf cells (kept slots in binding 26 after the scan, outputs at
// 7/8), or one reference per child overlapped (slots in 6, outputs at 7/8 of the other
// launch).
@compute @workgroup_size(256)
fn grid_ref_emit(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let prm = octree_level_params();
    let r = lin(gid, nwg);
    if r >= prm.n {
        return;
    }
    let p = b_ref_node[r];
    let t = b_ref_tri[r];
    if prm.emit_kept != 0u {
        if b_split[p] == 0u {
            let at = b_kept[r];
            b_out_key[at] = prm.first_cell + b_leaf_index[p];
            b_out_tri[at] = t;
        }
        return;
    }
    if b_split[p] != 0u {
        var m = b_mask[r];
        let base = 8u * b_child_base[p];
        var at = b_offs[r];
        while m != 0u {
            let k = countTrailingZeros(m);
            m &= m - 1u;
            b_out_key[at] = base + k;
            b_out_tri[at] = t;
            at++;
        }
    }
}
