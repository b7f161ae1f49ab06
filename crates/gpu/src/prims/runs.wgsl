// Run-length compression of equal consecutive keys and run expansion (the GPU's
// `par::runs`: thesis §3.2.4 compression, §3.2.6 decompression); bindings in bindings.wgsl.

// Parameters of run_heads, run_chunks, run_sizes and expand_runs.
struct RunsParams {
    n: u32, // elements (run_heads, run_chunks) or runs (run_sizes, expand_runs)
    total: u32, // run_sizes: the element count, the end of the last run
}

// Head flags of runs of equal keys (keys in binding 3).
@compute @workgroup_size(256)
fn run_heads(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let p = runs_params();
    let i = lin(gid, nwg);
    if i < p.n {
        y_a[i] = select(0u, 1u, i == 0u || x_a[i] != x_a[i - 1u]);
    }
}

// Chunks: key and base (the head position) at the head's scanned index; keys in binding 3.
@compute @workgroup_size(256)
fn run_chunks(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let p = runs_params();
    let i = lin(gid, nwg);
    if i < p.n && x_flag[i] != 0u {
        let c = x_off[i];
        y_a[c] = x_a[i];
        y_b[c] = i;
    }
}

// Chunk sizes from consecutive bases (bases in binding 4); `total` = the element count.
@compute @workgroup_size(256)
fn run_sizes(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let p = runs_params();
    let c = lin(gid, nwg);
    if c < p.n {
        var end = p.total;
        if c + 1u < p.n {
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
    let p = runs_params();
    let j = lin(gid, nwg);
    if j < p.n {
        let c = x_a[j];
        let base = x_b[c];
        let o = x_off[j];
        let size = x_off[j + 1u] - o;
        for (var k = 0u; k < size; k++) {
            y_a[o + k] = x_flag[base + k];
        }
    }
}
