//! Cell expansion on the GPU (paper §4.3; `expand.wgsl`), the twin of
//! `accel/src/grid/expand.rs`: per pass, axis and side one launch in which every cell not yet
//! blocked on that side walks the face layer and grows by the smallest overhang, exactly as
//! the CPU's walk (integer voxel arithmetic only). Also the traversal's cell records.

use super::DeviceGrid;
use crate::device::Gpu;
use crate::kernels::params::{EInitParams, ERecordsParams, ESideParams};
use crate::kernels::{launch, Exec, Kernels};

fn side_params(d: &DeviceGrid, n: u64, axis: u32, positive: u32) -> ESideParams {
    let f = &d.frame;
    ESideParams {
        cells: n as u32,
        axis,
        positive,
        shift: f.shift,
        dims: f.dims,
        top_dims: f.top_dims,
    }
}

/// `passes` expansion passes over `d`'s cells, as `accel::grid::expand::expand`.
pub fn expand(g: &Gpu, k: &Kernels, d: &mut DeviceGrid, passes: u32, empty_only: bool) {
    let mut ex = Exec::new(g, k);
    let n = d.ncells;
    let exp_min = g.storage("expanded boxes (min)", (n * 16).max(16));
    let exp_max = g.storage("expanded boxes (max)", (n * 16).max(16));
    let blocked = g.storage("blocked sides", n * 4);
    ex.run(
        launch::EInit {
            e_min: &d.cell_min,
            e_max: &d.cell_max,
            e_first: &d.ref_first,
            e_exp_min: &exp_min,
            e_exp_max: &exp_max,
            e_blocked: &blocked,
        },
        EInitParams {
            cells: n as u32,
            empty_only: empty_only as u32,
        },
        n,
        256,
    );
    for _ in 0..passes {
        for axis in 0..3u32 {
            for positive in [0u32, 1] {
                let l = launch::ESide {
                    e_map: &d.entries,
                    e_min: &d.cell_min,
                    e_max: &d.cell_max,
                    e_first: &d.ref_first,
                    e_refs: &d.refs,
                    e_exp_min: &exp_min,
                    e_exp_max: &exp_max,
                    e_blocked: &blocked,
                };
                ex.run(l, side_params(d, n, axis, positive), n, 256);
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
        launch::ERecords {
            e_first: &d.ref_first,
            e_exp_min: &d.exp_min,
            e_exp_max: &d.exp_max,
            e_rec: &rec,
        },
        ERecordsParams { cells: n as u32 },
        n,
        256,
    );
    ex.finish();
    rec
}
