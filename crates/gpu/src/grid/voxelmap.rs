//! The grid's cells pass on the GPU (paper §3, Figure 1; `voxelmap.wgsl`), the twin of
//! `accel/src/grid/voxelmap.rs`'s `flatten` and the rest of `accel::grid::build::finish`: the
//! sparse octrees become the block voxel map, the cells are renumbered in the map's order with
//! their footprints on the virtual grid, and the references are sorted by (cell, triangle)
//! with the backend's stable radix sort (each cell's references already come in triangle
//! order, so sorting by cell alone gives the CPU's order).
//!
//! The CPU numbers blocks and cells in a recursive depth-first walk; here both are pre-order
//! offsets computed level by level (see the kernel file), so the map equals the CPU's entry
//! for entry. The only total read back is the map's size (checked against the entries'
//! index bits with the CPU's line, and against the binding limit).

use super::build::DeviceOctrees;
use super::DeviceGrid;
use crate::device::{Gpu, GpuError};
use crate::kernels::{Exec, Kernel, Kernels, Params};
use accel::grid::build::{assemble, Setup};

/// Flatten `d`'s octrees into the voxel map and the cells of the initial grid, on the device.
pub fn finish(g: &Gpu, k: &Kernels, st: &Setup, d: &DeviceOctrees) -> Result<DeviceGrid, GpuError> {
    let mut ex = Exec::new(g, k);
    let nentries: u64 = d.levels.iter().map(|l| l.1).sum();
    let node = |what: &str| g.storage(what, nentries * 4);
    let depth = node("subtree depths");
    let leaves = node("subtree leaves");
    let kown = node("block roots' k");
    let place = g.storage("places in blocks", nentries * 8);
    let root = node("enclosing roots");
    let bsum = node("subtree block entries");
    let boff = node("first block entries");
    let loff = node("first leaves");
    let level = |ex: &mut Exec, kernel: Kernel, l: usize, binds: &[(u32, &wgpu::Buffer)]| {
        let (first, n) = d.levels[l];
        let mut p = Params::n(n as u32, first as u32, (l == 0) as u32, 0);
        p.u[1][0] = d.ntop as u32;
        ex.run(kernel, p, binds, n, 256);
    };
    let deepest_first: Vec<usize> = (0..d.levels.len()).rev().collect();
    for &l in &deepest_first {
        level(
            &mut ex,
            Kernel::VmUp,
            l,
            &[(1, &d.entries), (2, &depth), (3, &leaves)],
        );
    }
    for l in 0..d.levels.len() {
        level(
            &mut ex,
            Kernel::VmDown,
            l,
            &[
                (1, &d.entries),
                (2, &depth),
                (4, &kown),
                (5, &place),
                (6, &root),
            ],
        );
    }
    for &l in &deepest_first {
        level(
            &mut ex,
            Kernel::VmBsum,
            l,
            &[(1, &d.entries), (4, &kown), (7, &bsum)],
        );
    }
    let top_b = g.storage("top cells' first block entries", (d.ntop + 1) * 4);
    let top_l = g.storage("top cells' first leaves", (d.ntop + 1) * 4);
    ex.scan(&bsum, &top_b, d.ntop);
    ex.scan(&leaves, &top_l, d.ntop);
    let total = d.ntop + ex.read_at(&top_b, d.ntop as usize) as u64;
    accel::grid::voxelmap::check_total(total)?;
    let limit = g.max_binding();
    if total * 4 > limit {
        return Err(GpuError::Limits(format!(
            "the grid's voxel map needs {} MiB in one binding; this device allows {} MiB (raise `grid_top_density` or lower `grid_leaf_density`)",
            (total * 4).div_ceil(1 << 20),
            limit >> 20
        )));
    }
    for l in 0..d.levels.len() {
        level(
            &mut ex,
            Kernel::VmOffsets,
            l,
            &[
                (1, &d.entries),
                (3, &leaves),
                (4, &kown),
                (7, &bsum),
                (8, &boff),
                (9, &loff),
                (21, &top_b),
                (22, &top_l),
            ],
        );
    }
    let out = g.storage("voxel map", total * 4);
    let new_index = g.storage("cells' new numbers", d.ncells * 4);
    let order = g.storage("cells in map order", d.ncells * 4);
    for l in 0..d.levels.len() {
        level(
            &mut ex,
            Kernel::VmFill,
            l,
            &[
                (1, &d.entries),
                (4, &kown),
                (5, &place),
                (6, &root),
                (8, &boff),
                (9, &loff),
                (10, &d.coords),
                (11, &out),
                (12, &new_index),
                (13, &order),
            ],
        );
    }
    // Cells in map order, their reference ranges, the references sorted by cell.
    let nc = d.ncells;
    let cell_min = g.storage("cells' footprints (min)", (nc * 16).max(16));
    let cell_max = g.storage("cells' footprints (max)", (nc * 16).max(16));
    let count = g.storage("cells' reference counts", nc * 4);
    ex.run(
        Kernel::VmCells,
        Params::n(nc as u32, d.shift, 0, 0),
        &[
            (13, &order),
            (14, &d.cells),
            (15, &d.cell_level),
            (16, &cell_min),
            (17, &cell_max),
            (18, &count),
        ],
        nc,
        256,
    );
    let ref_first = g.storage("cells' first references", (nc + 1) * 4);
    ex.scan(&count, &ref_first, nc);
    let keys = g.storage("references' cells", d.nkept * 4);
    let refs = g.storage("references", d.nkept * 4);
    ex.run(
        Kernel::VmKeys,
        Params::n(d.nkept as u32, 0, 0, 0),
        &[(12, &new_index), (19, &d.kept_cell), (20, &keys)],
        d.nkept,
        256,
    );
    ex.copy(&d.kept_tri, 0, &refs, d.nkept * 4);
    ex.sort_pairs(
        &keys,
        &refs,
        d.nkept,
        32 - (nc.max(1) as u32 - 1).leading_zeros(),
    );
    ex.finish();
    let mut frame = assemble(
        st,
        d.shift,
        Vec::new(),
        (Vec::new(), Vec::new()),
        Vec::new(),
        Vec::new(),
    );
    frame.build.initial_cells = nc as usize;
    Ok(DeviceGrid {
        frame,
        entries: out,
        nentries: total,
        exp_min: cell_min.clone(),
        exp_max: cell_max.clone(),
        cell_min,
        cell_max,
        ncells: nc,
        ref_first,
        refs,
        nrefs: d.nkept,
    })
}
