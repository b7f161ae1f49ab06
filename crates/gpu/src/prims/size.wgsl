// Sizes the device computed, made ready for the launches that depend on them, so that the
// host never reads them back (frame.rs's device-sized generations; kernels.rs's `DevSize`):
//   size_args: for block k < blocks, n = count · mul_k (count: word `at` of s_count) and the
//              workgroup grid of a dispatch over n threads of wg_k, folded into 2-D as
//              Gpu::grid folds it, written at words 4k.. as [n, x, y, 1]: word 0 patches a
//              launch's first parameter, words 1–3 are dispatch_workgroups_indirect's
//              arguments.
// Bindings: 1 = the count's buffer, 2 = the size blocks (4 words each).

// Parameters of size_args.
struct SizeParams {
    mul: vec4<u32>, // block k's n = count · mul[k]
    wg: vec4<u32>, // threads per workgroup of the launches block k sizes
    at: u32, // the count's word in s_count
    maxd: u32, // the device's most workgroups per dimension
    blocks: u32, // blocks written (at most 4)
}

@group(0) @binding(1) var<storage, read> s_count: array<u32>;
@group(0) @binding(2) var<storage, read_write> s_block: array<u32>;

// Thread k: size block k of one device count.
@compute @workgroup_size(4)
fn size_args(@builtin(local_invocation_index) k: u32) {
    let p = size_params();
    if k >= p.blocks {
        return;
    }
    let n = s_count[p.at] * p.mul[k];
    let wg = p.wg[k];
    let groups = (n + wg - 1u) / wg;
    var x = groups;
    var y = 1u;
    if groups > p.maxd {
        y = (groups + p.maxd - 1u) / p.maxd;
        x = (groups + y - 1u) / y;
    }
    s_block[4u * k] = n;
    s_block[4u * k + 1u] = x;
    s_block[4u * k + 2u] = y;
    s_block[4u * k + 3u] = 1u;
}
