// Permutation helpers of the chunk sort: identity values and gathers; bindings in
// bindings.wgsl.

// Parameters of iota, fill and gather.
struct PermuteParams {
    n: u32, // elements written
    value: u32, // fill's value
}

// Identity values 0..n (the chunk indices that travel with the chunk keys through the sort).
@compute @workgroup_size(256)
fn iota(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let p = permute_params();
    let i = lin(gid, nwg);
    if i < p.n {
        y_a[i] = i;
    }
}

// Every word of y set to u0.y (a buffer filled on the device instead of uploaded).
@compute @workgroup_size(256)
fn fill(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let p = permute_params();
    let i = lin(gid, nwg);
    if i < p.n {
        y_a[i] = p.value;
    }
}

// Sizes of the chunks in sorted order: y[j] = size[order[j]] (order in binding 3, sizes in 4).
@compute @workgroup_size(256)
fn gather(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let p = permute_params();
    let i = lin(gid, nwg);
    if i < p.n {
        y_a[i] = x_b[x_a[i]];
    }
}
