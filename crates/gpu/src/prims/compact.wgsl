// Stream compaction of (a, b) pairs by flags with scanned offsets (the GPU's
// `par::compact_pairs`); bindings in bindings.wgsl.

// Parameters of compact.
struct CompactParams {
    n: u32, // elements
    index_as_b: u32, // 1: y_b gets each kept element's index (there is no x_b), 0: x_b
}

// y[off[i]] = x[i] where flag[i]; mode 1: b is the index i itself.
@compute @workgroup_size(256)
fn compact(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let p = compact_params();
    let i = lin(gid, nwg);
    if i < p.n && x_flag[i] != 0u {
        let o = x_off[i];
        y_a[o] = x_a[i];
        if p.index_as_b == 1u {
            y_b[o] = i;
        } else {
            y_b[o] = x_b[i];
        }
    }
}
