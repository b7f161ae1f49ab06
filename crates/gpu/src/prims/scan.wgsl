// Exclusive prefix sum of u32, reduce-then-scan (no inter-workgroup communication inside a
// dispatch, so no forward-progress assumption, and no subgroup operations, so any subgroup
// size works). A block is 256 threads × 4 elements.
//   scan_reduce: block sums              (P.u0.x = element count)
//   (the block sums are scanned recursively by the host)
//   scan_down:   local scan + block offset; out[n] = total
// Bindings: 1 = input, 2 = output (n + 1 entries), 3 = block sums (scanned for scan_down).

@group(0) @binding(1) var<storage, read> s_in: array<u32>;
@group(0) @binding(2) var<storage, read_write> s_out: array<u32>;
@group(0) @binding(3) var<storage, read_write> s_sums: array<u32>;

const ITEMS: u32 = 4u;
var<workgroup> wsum: array<u32, 256>;

fn load4(base: u32) -> vec4<u32> {
    var v = vec4<u32>(0u);
    for (var k = 0u; k < ITEMS; k++) {
        if base + k < P.u0.x {
            v[k] = s_in[base + k];
        }
    }
    return v;
}

@compute @workgroup_size(256)
fn scan_reduce(@builtin(local_invocation_index) li: u32, @builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
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
    if li == 0u && block * WG * ITEMS < P.u0.x {
        s_sums[block] = wsum[0];
    }
}

@compute @workgroup_size(256)
fn scan_down(@builtin(local_invocation_index) li: u32, @builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let block = wg_linear(wid, nwg);
    if block * WG * ITEMS >= P.u0.x {
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
    // P.u0.y = 1 when there is a single block (no block sums to add).
    var acc = wsum[li] - own;
    if P.u0.y == 0u {
        acc += s_sums[block];
    }
    for (var k = 0u; k < ITEMS; k++) {
        if base + k < P.u0.x {
            s_out[base + k] = acc;
        }
        acc += v[k];
    }
    if base < P.u0.x && base + ITEMS >= P.u0.x {
        s_out[P.u0.x] = acc;
    }
}
