//! Cell expansion on the GPU (paper §4.3; `expand.wgsl`), the twin of
//! `accel/src/grid/expand.rs`: per pass, axis and side one launch in which every cell not yet
//! blocked on that side walks the face layer and grows by the smallest overhang, exactly as
//! the CPU's walk (integer voxel arithmetic only). Also the traversal's cell records.

use super::DeviceGrid;
use crate::device::Gpu;
use crate::kernels::{Exec, Kernel, Kernels, Params};

fn params(d: &DeviceGrid, n: u64, a: u32, b: u32) -> Params {
    let f = &d.frame;
    let mut p = Params::n(n as u32, a, f.shift, b);
    p.u[1] = [f.dims[0], f.dims[1], f.dims[2], 0];
    p.u[2] = [f.top_dims[0], f.top_dims[1], f.top_dims[2], 0];
    p
}

/// `passes` expansion passes over `d`'s cells, as `accel::grid::expand::expand`.
pub fn expand(g: &Gpu, k: &Kernels, d: &mut DeviceGrid, passes: u32, empty_only: bool) {
    let mut ex = Exec::new(g, k);
    let n = d.ncells;
    let exp_min = g.storage("expanded boxes (min)", (n * 16).max(16));
    let exp_max = g.storage("expanded boxes (max)", (n * 16).max(16));
    let blocked = g.storage("blocked sides", n * 4);
    let binds = [
        (1, &d.entries),
        (2, &d.cell_min),
        (3, &d.cell_max),
        (4, &d.ref_first),
        (5, &d.refs),
        (6, &exp_min),
        (7, &exp_max),
        (8, &blocked),
    ];
    ex.run(
        Kernel::EInit,
        params(d, n, empty_only as u32, 0),
        &[
            (2, &d.cell_min),
            (3, &d.cell_max),
            (4, &d.ref_first),
            (6, &exp_min),
            (7, &exp_max),
            (8, &blocked),
        ],
        n,
        256,
    );
    for _ in 0..passes {
        for axis in 0..3u32 {
            for positive in [0u32, 1] {
                ex.run(Kernel::ESide, params(d, n, axis, positive), &binds, n, 256);
            }
        }
    }
    ex.finish();
    d.exp_min = exp_min;
    d.exp_max = exp_max;
}

/// The traversal's cell records (2 × `vec4<u32>`: expanded min | first reference, expanded max
/// | end), built on the device.
pub fn records(g: &Gpu, k: &Kernels, d: &DeviceGrid) -> wgpu::Buffer {
    let mut ex = Exec::new(g, k);
    let n = d.ncells;
    let rec = g.storage("grid cells", n * 32);
    ex.run(
        Kernel::ERecords,
        params(d, n, 0, 0),
        &[
            (4, &d.ref_first),
            (6, &d.exp_min),
            (7, &d.exp_max),
            (9, &rec),
        ],
        n,
        256,
    );
    ex.finish();
    rec
}
