// Run-length compression of equal consecutive keys and run expansion (the GPU's
// `par::runs`: thesis §3.2.4 compression, §3.2.6 decompression); bindings in bindings.wgsl.

// Head flags of runs of equal keys (keys in binding 3).
@compute @workgroup_size(256)
fn run_heads(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = lin(gid, nwg);
    if i < P.u0.x {
        y_a[i] = select(0u, 1u, i == 0u || x_a[i] != x_a[i - 1u]);
    }
}

// Chunks: key and base (the head position) at the head's scanned index; keys in binding 3.
@compute @workgroup_size(256)
fn run_chunks(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = lin(gid, nwg);
    if i < P.u0.x && x_flag[i] != 0u {
        let c = x_off[i];
        y_a[c] = x_a[i];
        y_b[c] = i;
    }
}

// Chunk sizes from consecutive bases (bases in binding 4); P.u0.z = the element count.
@compute @workgroup_size(256)
fn run_sizes(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let c = lin(gid, nwg);
    if c < P.u0.x {
        var end = P.u0.z;
        if c + 1u < P.u0.x {
            end = x_b[c + 1u];
        }
        y_c[c] = end - x_b[c];
    }
}

// Decompression: chunk j (in sorted order) expands to positions base[c] .. base[c] + size[c]
// (c = order[j]) at its scanned offset, mapped through the trimmed ray ids.
// Bindings: 1 trimmed ray ids, 2 offsets (chunks + 1), 3 sorted order, 4 bases, 5 leaves.
@compute @workgroup_size(256)
fn expand_runs(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let j = lin(gid, nwg);
    if j < P.u0.x {
        let c = x_a[j];
        let base = x_b[c];
        let o = x_off[j];
        let size = x_off[j + 1u] - o;
        for (var k = 0u; k < size; k++) {
            y_a[o + k] = x_flag[base + k];
        }
    }
}
