// Stream compaction of (a, b) pairs by flags with scanned offsets (the GPU's
// `par::compact_pairs`); bindings in bindings.wgsl.

// y[off[i]] = x[i] where flag[i]; mode 1: b is the index i itself.
@compute @workgroup_size(256)
fn compact(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = lin(gid, nwg);
    if i < P.u0.x && x_flag[i] != 0u {
        let o = x_off[i];
        y_a[o] = x_a[i];
        if P.u0.y == 1u {
            y_b[o] = i;
        } else {
            y_b[o] = x_b[i];
        }
    }
}
