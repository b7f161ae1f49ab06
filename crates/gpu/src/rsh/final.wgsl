// Final tests (thesis §3.2.9): every ray of a surviving level-1 node against the pair's
// triangle, with the shared watertight kernel. The closest hit per ray is the smallest
// (t, triangle id), the tie rule of the brute-force oracle, taken by a 64-bit atomic minimum
// of (t bits << 32 | id) exactly as the CPU engine does (positive floats order like their
// bits), so the result does not depend on the order the pairs are processed in.
// Bindings: 1 pairs: node, 2 pairs: triangle, 3 level-1 first, 4 level-1 sc (kind), 5 leaves,
//           6 ray org, 7 ray dir, 8 ray constants, 9 triangles (3 × vec4), 10 best (u64),
//           12 counters; records (records.wgsl): 11 best as (id, t bits), 13 records out.

// Parameters of final_tests.
struct FinalTestsParams {
    pairs: u32, // surviving (level-1 node, triangle) pairs
    counters: u32, // the first counter word in f_cnt
}

// Parameters of records.
struct RecordsParams {
    rays: u32, // rays of the trace call
}

@group(0) @binding(1) var<storage, read> f_node: array<u32>;
@group(0) @binding(2) var<storage, read> f_tri: array<u32>;
@group(0) @binding(3) var<storage, read> f_first: array<u32>;
@group(0) @binding(4) var<storage, read> f_sc: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read> f_leaf: array<u32>;
@group(0) @binding(6) var<storage, read> f_org: array<vec4<f32>>;
@group(0) @binding(7) var<storage, read> f_dir: array<vec4<f32>>;
@group(0) @binding(8) var<storage, read> f_pre: array<vec4<f32>>;
@group(0) @binding(9) var<storage, read> f_tris: array<vec4<f32>>;
@group(0) @binding(10) var<storage, read_write> f_best: array<atomic<u64>>;
@group(0) @binding(11) var<storage, read> f_best_pair: array<vec2<u32>>;
@group(0) @binding(12) var<storage, read_write> f_cnt: array<atomic<u32>>;
@group(0) @binding(13) var<storage, read_write> f_rec: array<vec4<u32>>;

var<workgroup> fcnt: array<atomic<u32>, 4>;

fn hit_of(r: u32, t: u32) -> vec4<f32> {
    let o = f_org[r];
    return intersect(o.xyz, f_dir[r].xyz, f_pre[r], o.w, f_dir[r].w, f_tris[3u * t].xyz, f_tris[3u * t + 1u].xyz, f_tris[3u * t + 2u].xyz);
}

// Exact ray–triangle tests of level 1's survivors.
@compute @workgroup_size(256)
fn final_tests(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(local_invocation_index) li: u32, @builtin(num_workgroups) nwg: vec3<u32>) {
    if li < 4u {
        atomicStore(&fcnt[li], 0u);
    }
    workgroupBarrier();
    let p = final_tests_params();
    let i = gid.x + gid.y * nwg.x * 256u;
    if i < p.pairs {
        let n = f_node[i];
        let t = f_tri[i];
        let l0 = f_first[n];
        let l1 = f_first[n + 1u];
        atomicAdd(&fcnt[bitcast<u32>(f_sc[n].w) & 3u], l1 - l0);
        for (var l = l0; l < l1; l++) {
            let r = f_leaf[l];
            let h = hit_of(r, t);
            if h.w != 0.0 {
                atomicMin(&f_best[r], (u64(bitcast<u32>(h.x)) << 32u) | u64(t));
            }
        }
    }
    workgroupBarrier();
    if li < 4u {
        let v = atomicLoad(&fcnt[li]);
        if v > 0u {
            // 64-bit (low, high) counters from word `counters`, as traverse.wgsl's add64.
            let at = p.counters + 2u * li;
            let old = atomicAdd(&f_cnt[at], v);
            if old + v < old {
                atomicAdd(&f_cnt[at + 1u], 1u);
            }
        }
    }
}

// One record per ray: the winner's hit recomputed with the shared kernel.
@compute @workgroup_size(256)
fn records(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let r = gid.x + gid.y * nwg.x * 256u;
    if r >= records_params().rays {
        return;
    }
    let t = f_best_pair[r].x;
    if f_best_pair[r].y == 0xffffffffu {
        f_rec[r] = vec4<u32>(0xffffffffu, 0x7f800000u, 0u, 0u);
        return;
    }
    let h = hit_of(r, t);
    f_rec[r] = vec4<u32>(t, bitcast<u32>(h.x), bitcast<u32>(h.y), bitcast<u32>(h.z));
}
