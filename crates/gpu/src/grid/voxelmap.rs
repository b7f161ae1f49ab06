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
use crate::kernels::params::{VmCellsParams, VmKeysParams, VmLevelParams};
use crate::kernels::{launch, Exec, Kernels};
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
    // A level's parameters and thread count.
    let level = |l: usize| {
        let (first, n) = d.levels[l];
        let p = VmLevelParams {
            nodes: n as u32,
            first: first as u32,
            top: (l == 0) as u32,
            top_cells: d.ntop as u32,
        };
        (p, n)
    };
    let deepest_first: Vec<usize> = (0..d.levels.len()).rev().collect();
    for &l in &deepest_first {
        let (p, n) = level(l);
        ex.run(
            launch::VmUp {
                v_entries: &d.entries,
                v_depth: &depth,
                v_leaves: &leaves,
            },
            p,
            n,
            256,
        );
    }
    for l in 0..d.levels.len() {
        let (p, n) = level(l);
        ex.run(
            launch::VmDown {
                v_entries: &d.entries,
                v_depth: &depth,
                v_kown: &kown,
                v_place: &place,
                v_root: &root,
            },
            p,
            n,
            256,
        );
    }
    for &l in &deepest_first {
        let (p, n) = level(l);
        ex.run(
            launch::VmBsum {
                v_entries: &d.entries,
                v_kown: &kown,
                v_bsum: &bsum,
            },
            p,
            n,
            256,
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
        let (p, n) = level(l);
        ex.run(
            launch::VmOffsets {
                v_entries: &d.entries,
                v_leaves: &leaves,
                v_kown: &kown,
                v_bsum: &bsum,
                v_boff: &boff,
                v_loff: &loff,
                v_top_b: &top_b,
                v_top_l: &top_l,
            },
            p,
            n,
            256,
        );
    }
    let out = g.storage("voxel map", total * 4);
    let new_index = g.storage("cells' new numbers", d.ncells * 4);
    let order = g.storage("cells in map order", d.ncells * 4);
    for l in 0..d.levels.len() {
        let (p, n) = level(l);
        ex.run(
            launch::VmFill {
                v_entries: &d.entries,
                v_kown: &kown,
                v_place: &place,
                v_root: &root,
                v_boff: &boff,
                v_loff: &loff,
                v_coords: &d.coords,
                v_out: &out,
                v_new_index: &new_index,
                v_order: &order,
            },
            p,
            n,
            256,
        );
    }
    // Cells in map order, their reference ranges, the references sorted by cell.
    let nc = d.ncells;
    let cell_min = g.storage("cells' footprints (min)", (nc * 16).max(16));
    let cell_max = g.storage("cells' footprints (max)", (nc * 16).max(16));
    let count = g.storage("cells' reference counts", nc * 4);
    ex.run(
        launch::VmCells {
            v_order: &order,
            v_cells: &d.cells,
            v_cell_level: &d.cell_level,
            v_cell_min: &cell_min,
            v_cell_max: &cell_max,
            v_count: &count,
        },
        VmCellsParams {
            cells: nc as u32,
            shift: d.shift,
        },
        nc,
        256,
    );
    let ref_first = g.storage("cells' first references", (nc + 1) * 4);
    ex.scan(&count, &ref_first, nc);
    let keys = g.storage("references' cells", d.nkept * 4);
    let refs = g.storage("references", d.nkept * 4);
    ex.run(
        launch::VmKeys {
            v_new_index: &new_index,
            v_kept_cell: &d.kept_cell,
            v_keys: &keys,
        },
        VmKeysParams {
            refs: d.nkept as u32,
        },
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
