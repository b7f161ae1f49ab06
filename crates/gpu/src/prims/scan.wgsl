// Exclusive prefix sum of u32, reduce-then-scan (no inter-workgroup communication inside a
// dispatch, so no forward-progress assumption, and no subgroup operations, so any subgroup
// size works). A block is 256 threads × 4 elements.
//   scan_reduce: block sums
//   (the block sums are scanned recursively by the host)
//   scan_down:   local scan + block offset; out[n] = total
// Bindings: 1 = input, 2 = output (n + 1 entries), 3 = block sums (scanned for scan_down).

// Parameters of scan_reduce and scan_down.
struct ScanParams {
    n: u32, // elements scanned
    single: u32, // 1: a single block (scan_down adds no block sums)
}

@group(0) @binding(1) var<storage, read> s_in: array<u32>;
@group(0) @binding(2) var<storage, read_write> s_out: array<u32>;
@group(0) @binding(3) var<storage, read_write> s_sums: array<u32>;

const ITEMS: u32 = 4u;
var<workgroup> wsum: array<u32, 256>;

fn load4(base: u32) -> vec4<u32> {
    let p = scan_params();
    var v = vec4<u32>(0u);
    for (var k = 0u; k < ITEMS; k++) {
        if base + k < p.n {
            v[k] = s_in[base + k];
        }
    }
    return v;
}

// Block sums of a scan.
@compute @workgroup_size(256)
fn scan_reduce(@builtin(local_invocation_index) li: u32, @builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let p = scan_params();
    let block = wg_linear(wid, nwg);
    let v = load4((block * WG + li) * ITEMS);
    wsum[li] = v.x + v.y + v.z + v.w;
    workgroupBarrier();
    for (var s = 128u; s > 0u; s >>= 1u) {
        if li < s {
            wsum[li] += wsum[li + s];
        }
        workgroupBarrier();
    }
    if li == 0u && block * WG * ITEMS < p.n {
        s_sums[block] = wsum[0];
    }
}

// Exclusive scan within blocks, plus the scanned block sums.
@compute @workgroup_size(256)
fn scan_down(@builtin(local_invocation_index) li: u32, @builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let p = scan_params();
    let block = wg_linear(wid, nwg);
    if block * WG * ITEMS >= p.n {
        return;
    }
    let base = (block * WG + li) * ITEMS;
    let v = load4(base);
    let own = v.x + v.y + v.z + v.w;
    // Hillis–Steele inclusive scan of the 256 thread totals.
    wsum[li] = own;
    workgroupBarrier();
    for (var s = 1u; s < 256u; s <<= 1u) {
        var add = 0u;
        if li >= s {
            add = wsum[li - s];
        }
        workgroupBarrier();
        wsum[li] += add;
        workgroupBarrier();
    }
    var acc = wsum[li] - own;
    if p.single == 0u {
        acc += s_sums[block];
    }
    for (var k = 0u; k < ITEMS; k++) {
        if base + k < p.n {
            s_out[base + k] = acc;
        }
        acc += v[k];
    }
    if base < p.n && base + ITEMS >= p.n {
        s_out[p.n] = acc;
    }
}
