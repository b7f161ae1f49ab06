// Stable key–value LSD radix sort of u32 keys, 4 bits per pass, tiles of 256 threads ×
// 16 consecutive elements (reduce-then-scan; no subgroup operations, no inter-workgroup
// waiting):
//   sort_count:   per-tile digit histogram, stored digit-major: hist[d · tiles + tile]
//   (the host scans hist exclusively: the global base of every (digit, tile))
//   sort_scatter: each thread counts its 16 elements' digits (16 packed 16-bit counters),
//                 a workgroup scan of those gives every thread its per-digit start inside
//                 the tile, and the thread walks its elements again in order:
//                 out[base(digit, tile) + start + running count] = (key, value).
// Many elements per thread keep the number of workgroup barriers per element low, which
// matters on CPU implementations of Vulkan (lavapipe), where a barrier is a context switch.
// Bindings: 1 keys in, 2 values in, 3 hist, 4 keys out, 5 values out.

// Parameters of key_bits, sort_count and sort_scatter: one radix pass.
struct SortParams {
    n: u32, // keys
    shift: u32, // the pass's digit: key >> shift & 15
    tiles: u32, // tiles of the keys
}

@group(0) @binding(1) var<storage, read> k_in: array<u32>;
@group(0) @binding(2) var<storage, read> v_in: array<u32>;
@group(0) @binding(3) var<storage, read_write> hist: array<u32>;
@group(0) @binding(4) var<storage, read_write> k_out: array<u32>;
@group(0) @binding(5) var<storage, read_write> v_out: array<u32>;
// key_bits: (OR, AND) of all keys, so the host skips the passes whose digit is the same in
// every key (a stable pass over equal digits is the identity).
@group(0) @binding(6) var<storage, read_write> kbits: array<atomic<u32>>;

const PER: u32 = 16u;
var<workgroup> bins: array<atomic<u32>, 16>;
var<workgroup> packed: array<array<u32, 8>, 256>;

var<workgroup> w_or: atomic<u32>;
var<workgroup> w_and: atomic<u32>;

// The AND and OR of all keys (digits equal in every key need no sort pass).
@compute @workgroup_size(256)
fn key_bits(@builtin(local_invocation_index) li: u32, @builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let p = sort_params();
    if li == 0u {
        atomicStore(&w_or, 0u);
        atomicStore(&w_and, 0xffffffffu);
    }
    workgroupBarrier();
    let base = (wg_linear(wid, nwg) * WG + li) * PER;
    var o = 0u;
    var a = 0xffffffffu;
    for (var k = 0u; k < PER; k++) {
        if base + k < p.n {
            o |= k_in[base + k];
            a &= k_in[base + k];
        }
    }
    atomicOr(&w_or, o);
    atomicAnd(&w_and, a);
    workgroupBarrier();
    if li == 0u {
        atomicOr(&kbits[0], atomicLoad(&w_or));
        atomicAnd(&kbits[1], atomicLoad(&w_and));
    }
}

// Per-tile digit histograms of a radix pass.
@compute @workgroup_size(256)
fn sort_count(@builtin(local_invocation_index) li: u32, @builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let p = sort_params();
    let tile = wg_linear(wid, nwg);
    if li < 16u {
        atomicStore(&bins[li], 0u);
    }
    workgroupBarrier();
    let base = (tile * WG + li) * PER;
    for (var k = 0u; k < PER; k++) {
        if base + k < p.n {
            atomicAdd(&bins[(k_in[base + k] >> p.shift) & 15u], 1u);
        }
    }
    workgroupBarrier();
    if li < 16u && tile < p.tiles {
        hist[li * p.tiles + tile] = atomicLoad(&bins[li]);
    }
}

// Stable scatter of a radix pass.
@compute @workgroup_size(256)
fn sort_scatter(@builtin(local_invocation_index) li: u32, @builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let p = sort_params();
    let tile = wg_linear(wid, nwg);
    let base = (tile * WG + li) * PER;
    // This thread's digit counts, digit d in lane d / 2, half d % 2.
    var own: array<u32, 8>;
    for (var j = 0u; j < 8u; j++) {
        own[j] = 0u;
    }
    for (var k = 0u; k < PER; k++) {
        if base + k < p.n {
            let d = (k_in[base + k] >> p.shift) & 15u;
            own[d >> 1u] += 1u << ((d & 1u) * 16u);
        }
    }
    packed[li] = own;
    workgroupBarrier();
    for (var s = 1u; s < 256u; s <<= 1u) {
        var add: array<u32, 8>;
        for (var j = 0u; j < 8u; j++) {
            add[j] = 0u;
            if li >= s {
                add[j] = packed[li - s][j];
            }
        }
        workgroupBarrier();
        for (var j = 0u; j < 8u; j++) {
            packed[li][j] += add[j];
        }
        workgroupBarrier();
    }
    // Exclusive start of every digit for this thread, then its elements in order.
    var run: array<u32, 8>;
    for (var j = 0u; j < 8u; j++) {
        run[j] = packed[li][j] - own[j];
    }
    if tile >= p.tiles {
        return;
    }
    for (var k = 0u; k < PER; k++) {
        let i = base + k;
        if i < p.n {
            let key = k_in[i];
            let d = (key >> p.shift) & 15u;
            let sh = (d & 1u) * 16u;
            let rank = (run[d >> 1u] >> sh) & 0xffffu;
            run[d >> 1u] += 1u << sh;
            let dst = hist[d * p.tiles + tile] + rank;
            k_out[dst] = key;
            v_out[dst] = v_in[i];
        }
    }
}
