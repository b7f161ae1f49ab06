// Where each ray kind starts among the sorted leaves (the layout of every hierarchy level,
// thesis §3.2.7); bindings in prims/bindings.wgsl.

// Parameters of kind_hist.
struct KindHistParams {
    leaves: u32, // sorted leaves
}

// Kind histogram of the sorted leaves (kind = top two key bits of the sorted keys).
@compute @workgroup_size(256)
fn kind_hist(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = lin(gid, nwg);
    if i < kind_hist_params().leaves {
        let k = x_a[x_b[i]] & 3u;
        // Counted with plain stores of run boundaries: the kinds are sorted, so the first
        // index of every kind is where it differs from its predecessor.
        if i == 0u || (x_a[x_b[i - 1u]] & 3u) != k {
            y_a[k] = i;
            y_b[k] = 1u;
        }
    }
}
