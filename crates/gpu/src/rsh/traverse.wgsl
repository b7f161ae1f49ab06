// Top-down traversal (thesis §3.2.8), mirroring rsh::traverse; its final tests (§3.2.9)
// are final.wgsl.
// Counters: from word `counters` (a parameter) of cnt, 64-bit (low, high) counters of the level: [kind] =
// node–triangle tests, [4 + kind] = passes (for the final tests, [kind] = ray–triangle
// tests), gathered per workgroup, then added once per workgroup.
//
// Bindings (shared by every entry point, so one layout serves them all):
//   1 node sphere, 2 node cone, 3 node sc, 4 node first (children of the tested level),
//   5 triangle sphere, 6 mesh of triangle / mesh sphere, 7 pass bits (node · meshes + mesh),
//   8 pairs: node, 9 pairs: triangle, 10 out (counts, flags or child nodes),
//   11 out triangles, 12 counters, 13 scanned offsets.

@group(0) @binding(1) var<storage, read> n_sphere: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> n_cone: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> n_sc: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read> n_first: array<u32>;
@group(0) @binding(5) var<storage, read> t_sphere: array<vec4<f32>>;
@group(0) @binding(6) var<storage, read> t_mesh: array<u32>;
@group(0) @binding(7) var<storage, read> m_pass: array<u32>;
@group(0) @binding(8) var<storage, read> p_node: array<u32>;
@group(0) @binding(9) var<storage, read> p_tri: array<u32>;
@group(0) @binding(10) var<storage, read_write> o_a: array<u32>;
@group(0) @binding(11) var<storage, read_write> o_b: array<u32>;
@group(0) @binding(12) var<storage, read_write> cnt: array<atomic<u32>>;
@group(0) @binding(13) var<storage, read> e_off: array<u32>;

var<workgroup> wcnt: array<atomic<u32>, 8>;

// Parameters of mesh_test: the node × mesh pass table.
struct MeshTestParams {
    entries: u32, // the table's bits: nodes · meshes
    meshes: u32, // meshes per node
    exact: u32, // 1: the exact node test (rsh::NodeTest::Exact), 0: the thesis's
}

// Parameters of top_count and top_emit: one batch of (top node, triangle tile) slots.
struct TopParams {
    slots: u32, // nodes · tiles
    tiles: u32, // triangle tiles per node
    first_node: u32, // the batch's first node
    exact: u32, // 1: the exact node test
    tri_start: u32, // the batch's first triangle
    tri_end: u32, // the batch's end triangle (exclusive)
    meshes: u32, // meshes per node in the pass table
    tile: u32, // triangles per tile
    counters: u32, // the level's first counter word in cnt
}

// Parameters of pair_test.
struct PairTestParams {
    pairs: u32, // pairs tested
    exact: u32, // 1: the exact node test
    counters: u32, // the level's first counter word in cnt
}

// Parameters of child_count and child_emit.
struct ChildParams {
    pairs: u32, // surviving pairs whose children are counted or written
}

fn test_node(exact: u32, n: u32, p: vec4<f32>) -> bool {
    return node_test(exact == 1u, n_sphere[n], n_cone[n], n_sc[n], p.xyz, p.w);
}

fn node_kind(n: u32) -> u32 {
    return bitcast<u32>(n_sc[n].w) & 3u;
}

fn wcnt_reset(li: u32) {
    if li < 8u {
        atomicStore(&wcnt[li], 0u);
    }
    workgroupBarrier();
}

// A 64-bit device counter (low, high words) at word `at` of cnt: the add that wraps the low
// word carries into the high one, so a whole trace call's counts add up on the device and
// are read back once.
fn add64(at: u32, v: u32) {
    let old = atomicAdd(&cnt[at], v);
    if old + v < old {
        atomicAdd(&cnt[at + 1u], 1u);
    }
}

fn wcnt_flush(li: u32, counters: u32) {
    workgroupBarrier();
    if li < 8u {
        let v = atomicLoad(&wcnt[li]);
        if v > 0u {
            add64(counters + 2u * li, v);
        }
    }
}

// Mesh culling (§3.2.1–3.2.2): bit (node · meshes + mesh) of o_a says whether the node's
// rays may reach the mesh; one thread per word of 32 bits, so the table is made as the bit
// set the top level reads (m_pass) and read back in that size.
// Binding 6 holds the mesh spheres here.
@compute @workgroup_size(256)
fn mesh_test(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let p = mesh_test_params();
    let w = gid.x + gid.y * nwg.x * 256u;
    if w >= (p.entries + 31u) / 32u {
        return;
    }
    var word = 0u;
    for (var b = 0u; b < 32u; b++) {
        let i = 32u * w + b;
        if i >= p.entries {
            break;
        }
        let n = i / p.meshes;
        let m = i % p.meshes;
        let s = vec4<f32>(bitcast<f32>(t_mesh[4u * m]), bitcast<f32>(t_mesh[4u * m + 1u]), bitcast<f32>(t_mesh[4u * m + 2u]), bitcast<f32>(t_mesh[4u * m + 3u]));
        if test_node(p.exact, n, s) {
            word = word | (1u << b);
        }
    }
    o_a[w] = word;
}

// Top level, per (node, triangle tile): candidates are the triangles of meshes whose sphere
// passed; count the ones whose sphere passes the node (top_count) or emit them (top_emit,
// at the scanned offset). Node-major, triangles ascending: the CPU's pair order.
fn top_slot(p: TopParams, i: u32, emit: bool) -> vec2<u32> {
    let n = p.first_node + i / p.tiles;
    let tile = i % p.tiles;
    let t0 = p.tri_start + tile * p.tile;
    let t1 = min(t0 + p.tile, p.tri_end);
    var tested = 0u;
    var passed = 0u;
    var at = 0u;
    if emit {
        at = e_off[i];
    }
    for (var t = t0; t < t1; t++) {
        let bit = n * p.meshes + t_mesh[t];
        if ((m_pass[bit >> 5u] >> (bit & 31u)) & 1u) == 0u {
            continue;
        }
        tested++;
        if test_node(p.exact, n, t_sphere[t]) {
            if emit {
                o_a[at + passed] = n;
                o_b[at + passed] = t;
            }
            passed++;
        }
    }
    return vec2<u32>(tested, passed);
}

// Candidate (top node, triangle) pairs counted per slot.
@compute @workgroup_size(256)
fn top_count(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(local_invocation_index) li: u32, @builtin(num_workgroups) nwg: vec3<u32>) {
    let p = top_params();
    wcnt_reset(li);
    let i = gid.x + gid.y * nwg.x * 256u;
    if i < p.slots {
        let r = top_slot(p, i, false);
        o_a[i] = r.y;
        let k = node_kind(p.first_node + i / p.tiles);
        atomicAdd(&wcnt[k], r.x);
        atomicAdd(&wcnt[4u + k], r.y);
    }
    wcnt_flush(li, p.counters);
}

// Binding 13 holds the scanned counts: each slot's first output position.
@compute @workgroup_size(256)
fn top_emit(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let p = top_params();
    let i = gid.x + gid.y * nwg.x * 256u;
    if i < p.slots {
        _ = top_slot(p, i, true);
    }
}

// A level below the top: test every pair, flag survivors.
@compute @workgroup_size(256)
fn pair_test(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(local_invocation_index) li: u32, @builtin(num_workgroups) nwg: vec3<u32>) {
    let p = pair_test_params();
    wcnt_reset(li);
    let i = gid.x + gid.y * nwg.x * 256u;
    if i < p.pairs {
        let n = p_node[i];
        let f = test_node(p.exact, n, t_sphere[p_tri[i]]);
        o_a[i] = select(0u, 1u, f);
        let k = node_kind(n);
        atomicAdd(&wcnt[k], 1u);
        if f {
            atomicAdd(&wcnt[4u + k], 1u);
        }
    }
    wcnt_flush(li, p.counters);
}

// Children counts of surviving pairs.
@compute @workgroup_size(256)
fn child_count(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = gid.x + gid.y * nwg.x * 256u;
    if i < child_params().pairs {
        let n = p_node[i];
        o_a[i] = n_first[n + 1u] - n_first[n];
    }
}

// Expand pair j into (child, triangle) at its scanned offset (binding 13).
@compute @workgroup_size(256)
fn child_emit(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = gid.x + gid.y * nwg.x * 256u;
    if i < child_params().pairs {
        let n = p_node[i];
        let o = e_off[i];
        let c0 = n_first[n];
        let c1 = n_first[n + 1u];
        for (var c = c0; c < c1; c++) {
            o_a[o + c - c0] = c;
            o_b[o + c - c0] = p_tri[i];
        }
    }
}
