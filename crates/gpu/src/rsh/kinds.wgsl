// How many of the trimmed rays are of each kind: every hierarchy level's layout (thesis
// §3.2.7: kinds are sorted, so each kind's leaves follow the previous kind's); bindings in
// prims/bindings.wgsl, and the counts here.

// Parameters of trim_kinds.
struct TrimKindsParams {
    rays: u32, // rays of the batch (trimmed or not: flags in x_flag)
}

@group(0) @binding(8) var<storage, read_write> y_kinds: array<atomic<u32>>;

var<workgroup> wkinds: array<atomic<u32>, 4>;

// Per kind (kind | light << 2 in x_a) the rays whose flag (x_flag: the trim's) is set, added
// per workgroup, then once per workgroup into y_kinds.
@compute @workgroup_size(256)
fn trim_kinds(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(local_invocation_index) li: u32, @builtin(num_workgroups) nwg: vec3<u32>) {
    if li < 4u {
        atomicStore(&wkinds[li], 0u);
    }
    workgroupBarrier();
    let i = lin(gid, nwg);
    if i < trim_kinds_params().rays && x_flag[i] != 0u {
        atomicAdd(&wkinds[x_a[i] & 3u], 1u);
    }
    workgroupBarrier();
    if li < 4u {
        let v = atomicLoad(&wkinds[li]);
        if v > 0u {
            atomicAdd(&y_kinds[li], v);
        }
    }
}
