//! The cells pass (paper §4.1): the octrees' leaves flattened into the hierarchical voxel map
//! in blocks, cells numbered in the map's order, their footprints on the virtual grid and
//! their references sorted by (cell, triangle).

use super::*;

/// The voxel map in blocks, cells renumbered in its order; cells on the virtual grid, and
/// their references sorted by (cell, triangle): the [`Grid`] of the initial cells.
pub fn finish(st: &Setup, oct: Octrees) -> Result<Grid, GridError> {
    let Octrees {
        entries,
        cell_coord,
        cell_level,
        cell_count,
        mut kept_cell,
        kept_tri,
        levels: level,
    } = oct;
    let ntop = st.ntop;
    let t2 = Instant::now();
    let ncells = cell_coord.len();
    let flat = voxelmap::flatten(&entries, ntop, ncells)?;
    drop(entries); // The level-order map (shadowing would keep it to the end).
    let voxelmap::Flattened {
        entries,
        order,
        new_index,
    } = flat;
    // The cells in the map's order: footprints on the virtual grid and reference counts,
    // gathered straight from the octrees' level-order arrays, which then go (the build's
    // peak is here and in the merge).
    let shift = level;
    let (cell_min, cell_max): (Vec<[u32; 3]>, Vec<[u32; 3]>) = order
        .par_iter()
        .with_min_len(4096)
        .map(|&c| {
            let c = c as usize;
            let s = shift - cell_level[c] as u32;
            let lo = cell_coord[c].map(|v| v << s);
            (lo, lo.map(|v| v + (1 << s)))
        })
        .unzip();
    drop((cell_coord, cell_level));
    let cell_count: Vec<u32> = order
        .par_iter()
        .with_min_len(4096)
        .map(|&c| cell_count[c as usize])
        .collect();
    drop(order);
    kept_cell
        .par_iter_mut()
        .with_min_len(4096)
        .for_each(|c| *c = new_index[*c as usize]);
    drop(new_index);
    let mut ref_first = vec![0u32; ncells + 1];
    let total = exclusive_scan(&cell_count, &mut ref_first[..ncells]);
    ref_first[ncells] = total;
    debug_assert_eq!(total as usize, kept_tri.len());
    // Each cell's references, ascending.
    let refs = group_sorted(&ref_first, &kept_cell, &kept_tri);
    drop((kept_cell, kept_tri, cell_count));
    let mut g = assemble_cells(st, shift, entries, (cell_min, cell_max), ref_first, refs);
    g.build.voxel_map_seconds = t2.elapsed().as_secs_f64();
    Ok(g)
}

/// The [`Grid`] of the initial cells from the cells pass's results: the flattened voxel map,
/// the cells' footprints on the virtual grid ([min, max)), their reference ranges and
/// references (the GPU's cells pass hands in the same arrays).
pub fn assemble(
    st: &Setup,
    shift: u32,
    entries: Vec<u32>,
    cells: (Vec<[u32; 3]>, Vec<[u32; 3]>),
    ref_first: Vec<u32>,
    refs: Vec<u32>,
) -> Grid {
    let mut g = assemble_cells(st, shift, entries, cells, ref_first, refs);
    // Copied in parallel: the initial cells are the build's largest arrays.
    g.exp_min = g.cell_min.par_iter().with_min_len(4096).copied().collect();
    g.exp_max = g.cell_max.par_iter().with_min_len(4096).copied().collect();
    g
}

/// [`assemble`] without the expanded boxes: the merge makes them from the merged cells, and
/// `grid::complete` copies the cells' where nothing is merged.
pub(super) fn assemble_cells(
    st: &Setup,
    shift: u32,
    entries: Vec<u32>,
    (cell_min, cell_max): (Vec<[u32; 3]>, Vec<[u32; 3]>),
    ref_first: Vec<u32>,
    refs: Vec<u32>,
) -> Grid {
    let dims = st.top_dims.map(|d| d << shift);
    let voxel = st.bounds.extent() / Vec3::new(dims[0] as f32, dims[1] as f32, dims[2] as f32);
    let ncells = cell_min.len();
    Grid {
        bounds: st.bounds,
        top_dims: st.top_dims,
        shift,
        dims,
        voxel,
        inv_voxel: voxel.recip(),
        exp_min: Vec::new(),
        exp_max: Vec::new(),
        cell_min,
        cell_max,
        trav: Vec::new(),
        ref_first,
        refs,
        entries,
        build: BuildStats {
            initial_cells: ncells,
            ..Default::default()
        },
    }
}
