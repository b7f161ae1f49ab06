// Stable key–value LSD radix sort of u32 keys, 4 bits per pass, tiles of 256 elements
// (reduce-then-scan; no subgroup operations, no inter-workgroup waiting):
//   sort_count:   per-tile digit histogram, stored digit-major: hist[d · tiles + tile]
//   (the host scans hist exclusively: the global base of every (digit, tile))
//   sort_scatter: stable rank inside the tile by a workgroup scan of 16 packed 16-bit
//                 counters per thread, then out[base + rank] = (key, value)
// Params: n = element count, a = shift, b = tile count.
// Bindings: 1 keys in, 2 values in, 3 hist, 4 keys out, 5 values out.

@group(0) @binding(1) var<storage, read> k_in: array<u32>;
@group(0) @binding(2) var<storage, read> v_in: array<u32>;
@group(0) @binding(3) var<storage, read_write> hist: array<u32>;
@group(0) @binding(4) var<storage, read_write> k_out: array<u32>;
@group(0) @binding(5) var<storage, read_write> v_out: array<u32>;

var<workgroup> bins: array<atomic<u32>, 16>;
var<workgroup> packed: array<array<u32, 8>, 256>;

@compute @workgroup_size(256)
fn sort_count(@builtin(local_invocation_index) li: u32, @builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let tile = wg_linear(wid, nwg);
    if li < 16u {
        atomicStore(&bins[li], 0u);
    }
    workgroupBarrier();
    let i = tile * WG + li;
    if i < P.u0.x {
        atomicAdd(&bins[(k_in[i] >> P.u0.y) & 15u], 1u);
    }
    workgroupBarrier();
    if li < 16u && tile < P.u0.z {
        hist[li * P.u0.z + tile] = atomicLoad(&bins[li]);
    }
}

@compute @workgroup_size(256)
fn sort_scatter(@builtin(local_invocation_index) li: u32, @builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let tile = wg_linear(wid, nwg);
    let i = tile * WG + li;
    let valid = i < P.u0.x && tile < P.u0.z;
    var key = 0u;
    var d = 0u;
    if valid {
        key = k_in[i];
        d = (key >> P.u0.y) & 15u;
    }
    // One-hot counter of this element's digit: lane d / 2, half d % 2.
    let lane = d >> 1u;
    var one = 0u;
    if valid {
        one = 1u << ((d & 1u) * 16u);
    }
    for (var k = 0u; k < 8u; k++) {
        packed[li][k] = select(0u, one, k == lane);
    }
    workgroupBarrier();
    for (var s = 1u; s < 256u; s <<= 1u) {
        var add: array<u32, 8>;
        for (var k = 0u; k < 8u; k++) {
            add[k] = 0u;
            if li >= s {
                add[k] = packed[li - s][k];
            }
        }
        workgroupBarrier();
        for (var k = 0u; k < 8u; k++) {
            packed[li][k] += add[k];
        }
        workgroupBarrier();
    }
    if valid {
        let incl = (packed[li][lane] >> ((d & 1u) * 16u)) & 0xffffu;
        let dst = hist[d * P.u0.z + tile] + incl - 1u;
        k_out[dst] = key;
        v_out[dst] = v_in[i];
    }
}
