// The object tree on the device, the twin of crates/accel/src/bvh/objects.rs's LBVH (Karras 2012,
// "Maximizing parallelism in the construction of BVHs, octrees and k-d trees", §3–4; the
// boxes bottom up as in Apetrei 2014 and Karras §4): the same tree, bit for bit.
//   obj_boxes:  every triangle's box (Aabb::from_points) and the reductions of the scene box
//               and the centroids' box (ordered-key atomics: min and max are exact in any
//               order);
//   obj_keys:   every triangle's 64-bit key (mesh index above the Morton code of its box
//               centre in the centroids' box) as two u32 words, the low word's copy kept;
//   (the host radix-sorts the keys with the triangle ids as values: low word, then high)
//   obj_nodes:  inner node i's key range and split by Karras's binary searches (Figure 4),
//               its children (LEAF | triangle for a leaf) and every node's parent;
//   obj_climb:  one thread per leaf climbs while it is the second child to reach a node
//               (an atomic counter per node) and makes the node's box (left ∪ right, in
//               that order, as the CPU) and depth;
//   obj_finish: every inner node's bounds (the sphere around its exact box, or its mesh's
//               sphere when smaller and the node holds exactly that mesh; the box grown by 8
//               ulps of the scene) and its children's grown boxes side by side;
//   obj_leaves: every triangle's bounds (its sphere, its grown box);
//   obj_positions: every triangle's leaf position and the triangles in leaf order;
//   obj_box_nodes: the single-ray path's nodes (objects/boxes.rs): every inner node's
//               frontier of up to 8 members by box area, as a node of slab-test lanes, stored
//               at its binary node's index (only the root's and its descendants' are read),
//               so that no numbering pass is needed; inner members refer to their binary node.
// min and max are glam's (`a < b ? a : b`), so a tie between +0 and −0 keeps the CPU's bits.
// The climb reads a sibling's box that another workgroup wrote: node boxes and depths are
// atomics, written after the box is made and read after the node's counter says both
// children are done (the ordering GPUs give device-scope atomics; checked on lavapipe).
//
// Bindings: 1 triangles (3 × vec4), 2 triangle boxes (min, max), 3 bounds (12 ordered keys:
// scene min xyz, max xyz, centroids' min xyz, max xyz), 4 triangle meshes, 5 key low words,
// 6 key high words, 7 low words' copy, 8 triangles in leaf order, 9 children, 10 ranges,
// 11 parents (inner nodes, then leaf positions), 12 arrival counters, 13 node boxes
// (8 words: min xyz, depth, max xyz, 0), 14 node bounds (sphere, box min, box max),
// 15 children's boxes (4 × vec4), 16 leaf bounds, 17 triangle spheres, 18 mesh spheres,
// 19 mesh starts, 20 leaf positions (per triangle), 21 box nodes (BOX_WORDS words each, by
// binary node), 22 triangles in leaf order (3 × vec4).

// Parameters of obj_boxes, obj_keys and obj_leaves.
struct ObjTrisParams {
    triangles: u32, // triangles of the scene
    axis_bits: u32, // Morton bits per axis
    code_bits: u32, // bits of the Morton code (3 × axis_bits), below the mesh index
}

// Parameters of obj_nodes, obj_climb and obj_finish.
struct ObjNodesParams {
    leaves: u32, // triangles (leaves); inner nodes are one fewer
    mesh_spheres: u32, // 1: a node holding exactly one mesh takes the mesh's sphere when smaller
}

@group(0) @binding(1) var<storage, read> o_tris: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> o_tbox: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read_write> o_bounds: array<atomic<u32>>;
@group(0) @binding(4) var<storage, read> o_tri_mesh: array<u32>;
@group(0) @binding(5) var<storage, read_write> o_key_lo: array<u32>;
@group(0) @binding(6) var<storage, read_write> o_key_hi: array<u32>;
@group(0) @binding(7) var<storage, read_write> o_key_lo_copy: array<u32>;
@group(0) @binding(8) var<storage, read> o_order: array<u32>;
@group(0) @binding(9) var<storage, read_write> o_child: array<vec2<u32>>;
@group(0) @binding(10) var<storage, read_write> o_range: array<vec2<u32>>;
@group(0) @binding(11) var<storage, read_write> o_parent: array<u32>;
@group(0) @binding(12) var<storage, read_write> o_arrived: array<atomic<u32>>;
@group(0) @binding(13) var<storage, read_write> o_nbox: array<atomic<u32>>;
@group(0) @binding(14) var<storage, read_write> o_node: array<vec4<f32>>;
@group(0) @binding(15) var<storage, read_write> o_child_box: array<vec4<f32>>;
@group(0) @binding(16) var<storage, read_write> o_leaf: array<vec4<f32>>;
@group(0) @binding(17) var<storage, read> o_tri_sphere: array<vec4<f32>>;
@group(0) @binding(18) var<storage, read> o_mesh_sphere: array<vec4<f32>>;
@group(0) @binding(19) var<storage, read> o_mesh_first: array<u32>;
@group(0) @binding(20) var<storage, read_write> o_pos: array<u32>;
@group(0) @binding(21) var<storage, read_write> o_boxes: array<u32>;
@group(0) @binding(22) var<storage, read_write> o_leaf_tris: array<vec4<f32>>;

const LEAF: u32 = 0x80000000u; // rsh::objects::LEAF

fn lin(gid: vec3<u32>, nwg: vec3<u32>) -> u32 {
    return gid.x + gid.y * nwg.x * 256u;
}

// glam's Vec3::min and max.
fn gmin3(a: vec3<f32>, b: vec3<f32>) -> vec3<f32> {
    return select(b, a, a < b);
}

fn gmax3(a: vec3<f32>, b: vec3<f32>) -> vec3<f32> {
    return select(b, a, a > b);
}

// A box corner from the bounds' ordered keys (`order_key`, common.wgsl) at word k.
fn bound(k: u32) -> vec3<f32> {
    return vec3<f32>(unorder_key(atomicLoad(&o_bounds[k])), unorder_key(atomicLoad(&o_bounds[k + 1u])), unorder_key(atomicLoad(&o_bounds[k + 2u])));
}

// Aabb::center.
fn center_of(mn: vec3<f32>, mx: vec3<f32>) -> vec3<f32> {
    return mul3(mn + mx, 0.5);
}

// ---------------------------------------------------------------- triangle boxes
var<workgroup> w_bounds: array<atomic<u32>, 12>;

// Every triangle's box and the reductions of the scene box and the centroids' box (the
// bounds start at u32::MAX for the minima and 0 for the maxima).
@compute @workgroup_size(256)
fn obj_boxes(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(local_invocation_index) li: u32, @builtin(num_workgroups) nwg: vec3<u32>) {
    let prm = obj_tris_params();
    if li < 12u {
        atomicStore(&w_bounds[li], select(0u, 0xffffffffu, li % 6u < 3u));
    }
    workgroupBarrier();
    let t = lin(gid, nwg);
    if t < prm.triangles {
        let a = o_tris[3u * t].xyz;
        let b = o_tris[3u * t + 1u].xyz;
        let c = o_tris[3u * t + 2u].xyz;
        let lo = gmin3(gmin3(a, b), c);
        let hi = gmax3(gmax3(a, b), c);
        o_tbox[2u * t] = vec4<f32>(lo, 0.0);
        o_tbox[2u * t + 1u] = vec4<f32>(hi, 0.0);
        let m = center_of(lo, hi);
        for (var k = 0u; k < 3u; k++) {
            atomicMin(&w_bounds[k], order_key(lo[k]));
            atomicMax(&w_bounds[k + 3u], order_key(hi[k]));
            atomicMin(&w_bounds[k + 6u], order_key(m[k]));
            atomicMax(&w_bounds[k + 9u], order_key(m[k]));
        }
    }
    workgroupBarrier();
    if li < 12u {
        if li % 6u < 3u {
            atomicMin(&o_bounds[li], atomicLoad(&w_bounds[li]));
        } else {
            atomicMax(&o_bounds[li], atomicLoad(&w_bounds[li]));
        }
    }
}

// ---------------------------------------------------------------- keys
// The key of triangle t: its mesh index above the Morton code of its box centre in the
// centroids' box (geom::morton::morton, bit by bit into two words).
@compute @workgroup_size(256)
fn obj_keys(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let prm = obj_tris_params();
    let t = lin(gid, nwg);
    if t >= prm.triangles {
        return;
    }
    let p = center_of(o_tbox[2u * t].xyz, o_tbox[2u * t + 1u].xyz);
    let cmin = bound(6u);
    let cmax = bound(9u);
    // f32::MIN_POSITIVE
    let e = gmax3(cmax - cmin, vec3<f32>(bitcast<f32>(0x00800000u)));
    let cells = f32(1u << prm.axis_bits);
    let q0 = div3v(p - cmin, e) * cells;
    let q = gmin3(gmax3(q0, vec3<f32>(0.0)), vec3<f32>(cells - 1.0));
    let g = vec3<u32>(u32(q.x), u32(q.y), u32(q.z));
    var lo = 0u;
    var hi = 0u;
    for (var i = 0u; i < prm.axis_bits; i++) {
        for (var k = 0u; k < 3u; k++) {
            let bit = (g[k] >> i) & 1u;
            let at = 3u * i + k;
            if at < 32u {
                lo |= bit << at;
            } else {
                hi |= bit << (at - 32u);
            }
        }
    }
    let m = o_tri_mesh[t];
    if prm.code_bits >= 32u {
        hi |= m << (prm.code_bits - 32u);
    } else {
        lo |= m << prm.code_bits;
        if prm.code_bits > 0u {
            hi |= m >> (32u - prm.code_bits);
        }
    }
    o_key_lo[t] = lo;
    o_key_lo_copy[t] = lo;
    o_key_hi[t] = hi;
}

// ---------------------------------------------------------------- radix tree
// Karras's δ(i, j) over the sorted keys: their common prefix length, the index breaking ties
// between equal keys; −1 outside the array.
fn delta(i: i32, j: i32, n: i32) -> i32 {
    if j < 0 || j >= n {
        return -1;
    }
    let a = vec2<u32>(o_key_lo[i], o_key_hi[i]);
    let b = vec2<u32>(o_key_lo[j], o_key_hi[j]);
    if a.x == b.x && a.y == b.y {
        return 96 + i32(countLeadingZeros(u32(i) ^ u32(j)));
    }
    if a.y != b.y {
        return i32(countLeadingZeros(a.y ^ b.y));
    }
    return 32 + i32(countLeadingZeros(a.x ^ b.x));
}

// A child reference: a leaf (LEAF | its triangle) where the range is one key, else the node.
fn child_ref(at: u32, lo_or_hi: u32) -> u32 {
    if at == lo_or_hi {
        return LEAF | o_order[at];
    }
    return at;
}

// Inner node i (Karras 2012, Figure 4): its range [lo, hi], split γ, children and their parent.
@compute @workgroup_size(256)
fn obj_nodes(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let prm = obj_nodes_params();
    let n = i32(prm.leaves);
    let iu = lin(gid, nwg);
    if iu + 1u >= prm.leaves {
        return;
    }
    let i = i32(iu);
    var d = -1;
    if delta(i, i + 1, n) > delta(i, i - 1, n) {
        d = 1;
    }
    let dmin = delta(i, i - d, n);
    var lmax = 2;
    while delta(i, i + lmax * d, n) > dmin {
        lmax *= 2;
    }
    var l = 0;
    var t = lmax / 2;
    while t >= 1 {
        if delta(i, i + (l + t) * d, n) > dmin {
            l += t;
        }
        t /= 2;
    }
    let j = i + l * d;
    let dnode = delta(i, j, n);
    var s = 0;
    t = l;
    loop {
        t = (t + 1) / 2;
        if delta(i, i + (s + t) * d, n) > dnode {
            s += t;
        }
        if t <= 1 {
            break;
        }
    }
    let gamma = u32(i + s * d + min(d, 0));
    let lo = u32(min(i, j));
    let hi = u32(max(i, j));
    let left = child_ref(gamma, lo);
    let right = child_ref(gamma + 1u, hi);
    o_child[iu] = vec2<u32>(left, right);
    o_range[iu] = vec2<u32>(lo, hi);
    let inner = prm.leaves - 1u;
    // Parents: an inner child's by its index, a leaf's after the inner nodes by its position.
    o_parent[select(left, inner + gamma, (left & LEAF) != 0u)] = iu;
    o_parent[select(right, inner + gamma + 1u, (right & LEAF) != 0u)] = iu;
}

// A child's exact box and depth (leaves: the triangle's box, depth 0).
fn child_box_depth(c: u32, mn: ptr<function, vec3<f32>>, mx: ptr<function, vec3<f32>>) -> u32 {
    if (c & LEAF) != 0u {
        let t = c & ~LEAF;
        *mn = o_tbox[2u * t].xyz;
        *mx = o_tbox[2u * t + 1u].xyz;
        return 0u;
    }
    let w = 8u * c;
    *mn = vec3<f32>(bitcast<f32>(atomicLoad(&o_nbox[w])), bitcast<f32>(atomicLoad(&o_nbox[w + 1u])), bitcast<f32>(atomicLoad(&o_nbox[w + 2u])));
    *mx = vec3<f32>(bitcast<f32>(atomicLoad(&o_nbox[w + 4u])), bitcast<f32>(atomicLoad(&o_nbox[w + 5u])), bitcast<f32>(atomicLoad(&o_nbox[w + 6u])));
    return atomicLoad(&o_nbox[w + 3u]);
}

// One thread per leaf position climbs while it is the second child to reach a node, and
// makes that node's box and depth (the arrival counters start at 0).
@compute @workgroup_size(256)
fn obj_climb(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let prm = obj_nodes_params();
    let p = lin(gid, nwg);
    if p >= prm.leaves {
        return;
    }
    var node = o_parent[prm.leaves - 1u + p];
    loop {
        if atomicAdd(&o_arrived[node], 1u) == 0u {
            return;
        }
        let ch = o_child[node];
        var amin: vec3<f32>;
        var amax: vec3<f32>;
        var bmin: vec3<f32>;
        var bmax: vec3<f32>;
        let da = child_box_depth(ch.x, &amin, &amax);
        let db = child_box_depth(ch.y, &bmin, &bmax);
        let mn = gmin3(amin, bmin);
        let mx = gmax3(amax, bmax);
        let w = 8u * node;
        atomicStore(&o_nbox[w], bitcast<u32>(mn.x));
        atomicStore(&o_nbox[w + 1u], bitcast<u32>(mn.y));
        atomicStore(&o_nbox[w + 2u], bitcast<u32>(mn.z));
        atomicStore(&o_nbox[w + 3u], 1u + max(da, db));
        atomicStore(&o_nbox[w + 4u], bitcast<u32>(mx.x));
        atomicStore(&o_nbox[w + 5u], bitcast<u32>(mx.y));
        atomicStore(&o_nbox[w + 6u], bitcast<u32>(mx.z));
        if node == 0u {
            return;
        }
        node = o_parent[node];
    }
}

// ---------------------------------------------------------------- bounds
// The padding of objects.rs `grown`: 8 ulps of the scene's largest coordinate.
fn grow_pad() -> f32 {
    let a = abs(bound(0u));
    let b = abs(bound(3u));
    let m = max_element3(gmax3(a, b));
    // m · 8 · f32::EPSILON, in that order (both factors powers of two).
    return mul(mul(m, 8.0), bitcast<f32>(0x34000000u));
}

// Sphere::around_box: the sphere about the box centre through its farthest corner, padded.
fn around_box(mn: vec3<f32>, mx: vec3<f32>) -> vec4<f32> {
    let c = center_of(mn, mx);
    let r = max(len3(mx - c), len3(c - mn));
    return vec4<f32>(c, padded(r, c));
}

// Inner node i's bounds (sphere; grown box) and its two children's grown boxes.
@compute @workgroup_size(256)
fn obj_finish(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let prm = obj_nodes_params();
    let i = lin(gid, nwg);
    if i + 1u >= prm.leaves {
        return;
    }
    let pad = vec3<f32>(grow_pad());
    var mn: vec3<f32>;
    var mx: vec3<f32>;
    _ = child_box_depth(i, &mn, &mx);
    var s = around_box(mn, mx);
    if prm.mesh_spheres != 0u {
        // A node holding exactly one mesh's triangles (keys are mesh-major, so its first and
        // last triangles' meshes agree, and its count is the mesh's) may take its sphere.
        let r = o_range[i];
        let m = o_tri_mesh[o_order[r.x]];
        let whole = r.y - r.x + 1u == o_mesh_first[m + 1u] - o_mesh_first[m] && o_tri_mesh[o_order[r.y]] == m;
        let ms = o_mesh_sphere[m];
        if whole && ms.w < s.w {
            s = ms;
        }
    }
    o_node[3u * i] = s;
    o_node[3u * i + 1u] = vec4<f32>(mn - pad, 0.0);
    o_node[3u * i + 2u] = vec4<f32>(mx + pad, 0.0);
    let ch = o_child[i];
    for (var k = 0u; k < 2u; k++) {
        var cmn: vec3<f32>;
        var cmx: vec3<f32>;
        _ = child_box_depth(ch[k], &cmn, &cmx);
        o_child_box[4u * i + 2u * k] = vec4<f32>(cmn - pad, 0.0);
        o_child_box[4u * i + 2u * k + 1u] = vec4<f32>(cmx + pad, 0.0);
    }
}

// Every triangle's bounds: its sphere (Sphere::of_triangle, from the scene's upload) and its
// grown box.
@compute @workgroup_size(256)
fn obj_leaves(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let prm = obj_tris_params();
    let t = lin(gid, nwg);
    if t >= prm.triangles {
        return;
    }
    let pad = vec3<f32>(grow_pad());
    o_leaf[3u * t] = o_tri_sphere[t];
    o_leaf[3u * t + 1u] = vec4<f32>(o_tbox[2u * t].xyz - pad, 0.0);
    o_leaf[3u * t + 2u] = vec4<f32>(o_tbox[2u * t + 1u].xyz + pad, 0.0);
}

// ---------------------------------------------------------------- single-ray nodes
// Box node layout (words): 0..24 lane minima (axis-major: k · 8 + lane), 24..48 maxima,
// 48..56 child references, 56 count, 57 leaf-lane bits, 58 triangles per lane (4 bits each).
const BOX_WORDS: u32 = 64u;
const LANE_TRIS: u32 = 2u; // objects::boxes::LANE_TRIS
fn neg_inf() -> f32 {
    return bitcast<f32>(0xff800000u);
}

// Every triangle's leaf position and its vertices in leaf order.
@compute @workgroup_size(256)
fn obj_positions(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let prm = obj_nodes_params();
    let p = lin(gid, nwg);
    if p >= prm.leaves {
        return;
    }
    let t = o_order[p];
    o_pos[t] = p;
    for (var k = 0u; k < 3u; k++) {
        o_leaf_tris[3u * p + k] = o_tris[3u * t + k];
    }
}

// Aabb::half_area of a grown node box (never empty).
fn half_area(mn: vec3<f32>, mx: vec3<f32>) -> f32 {
    let e = mx - mn;
    return keep(mul(e.x, e.y) + mul(e.y, e.z)) + mul(e.z, e.x);
}

// A frontier member's weight: its grown box's area when it may be split, else −∞.
fn split_weight(x: u32) -> f32 {
    if (x & LEAF) != 0u {
        return neg_inf();
    }
    let r = o_range[x];
    if r.y - r.x < LANE_TRIS {
        return neg_inf();
    }
    return half_area(o_node[3u * x + 1u].xyz, o_node[3u * x + 2u].xyz);
}

// Inner node h's box node (boxes.rs `frontier` and `collapse_boxes`'s `make`).
@compute @workgroup_size(256)
fn obj_box_nodes(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let prm = obj_nodes_params();
    let h = lin(gid, nwg);
    if h + 1u >= prm.leaves {
        return;
    }
    var f: array<u32, 8>;
    var w: array<f32, 8>;
    let c = o_child[h];
    f[0] = c.x;
    f[1] = c.y;
    w[0] = split_weight(c.x);
    w[1] = split_weight(c.y);
    var n = 2u;
    while n < 8u {
        var best = 8u;
        for (var i = 0u; i < n; i++) {
            if w[i] > neg_inf() && (best == 8u || w[i] > w[best]) {
                best = i;
            }
        }
        if best == 8u {
            break;
        }
        let ab = o_child[f[best]];
        for (var j = n; j > best + 1u; j--) {
            f[j] = f[j - 1u];
            w[j] = w[j - 1u];
        }
        f[best] = ab.x;
        f[best + 1u] = ab.y;
        w[best] = split_weight(ab.x);
        w[best + 1u] = split_weight(ab.y);
        n += 1u;
    }
    let base = BOX_WORDS * h;
    var leaves = 0u;
    var ntri = 0u;
    for (var i = 0u; i < 8u; i++) {
        let x = f[select(0u, i, i < n)];
        var mn: vec3<f32>;
        var mx: vec3<f32>;
        var reference: u32;
        var k: u32;
        if (x & LEAF) != 0u {
            let t = x & ~LEAF;
            mn = o_leaf[3u * t + 1u].xyz;
            mx = o_leaf[3u * t + 2u].xyz;
            reference = LEAF | o_pos[t];
            k = 1u;
        } else {
            mn = o_node[3u * x + 1u].xyz;
            mx = o_node[3u * x + 2u].xyz;
            let r = o_range[x];
            if r.y - r.x >= LANE_TRIS {
                reference = x;
                k = 0u;
            } else {
                reference = LEAF | r.x;
                k = r.y - r.x + 1u;
            }
        }
        for (var a = 0u; a < 3u; a++) {
            o_boxes[base + 8u * a + i] = bitcast<u32>(mn[a]);
            o_boxes[base + 24u + 8u * a + i] = bitcast<u32>(mx[a]);
        }
        o_boxes[base + 48u + i] = reference;
        ntri |= k << (4u * i);
        if i < n && (reference & LEAF) != 0u {
            leaves |= 1u << i;
        }
    }
    o_boxes[base + 56u] = n;
    o_boxes[base + 57u] = leaves;
    o_boxes[base + 58u] = ntri;
}
