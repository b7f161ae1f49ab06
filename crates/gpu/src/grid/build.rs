//! The irregular grid's initial cells built on the GPU (paper §4.1; `build.wgsl`), the twin of
//! `accel/src/grid/build.rs`'s [`accel::grid::build::subdivide`] pass for pass:
//! - **top_refs**: triangle boxes and the scene box (one launch; the box is read back, since
//!   the top grid's size sizes every later buffer), the frame from
//!   [`accel::grid::build::setup`] on the host (the same function as the CPU's), then the
//!   references to the top cells by count → scan → emit with exact triangle–box tests;
//! - **octrees**, level by level: reference histogram, which nodes want to split (the paper's
//!   depth from [`accel::grid::build::Setup::depth_table`]), child masks, which nodes split,
//!   the level's voxel-map entries and leaf cells, the kept references and the children's.
//!
//! The only host round trips are the totals that size the next buffers (the scene box, the
//! reference count, per level the split and leaf counts and the kept and child reference
//! counts); each total is checked against the build's caps ([`accel::grid::build::Limits`])
//! before anything is allocated for it, with the CPU's error messages. The result is the
//! CPU's [`Octrees`] bit for bit (tests compare them), read back once; the voxel map,
//! merging and expansion then run on the CPU (their kernels are not written yet).

use crate::device::{Gpu, GpuError};
use crate::kernels::params::{OctreeLevelParams, TopRefsParams, TriBoxesParams};
use crate::kernels::{launch, Exec};
use accel::grid::build::{self, Octrees, Setup, ADAPTIVE_COPIES, ADAPTIVE_SPLIT};
use accel::grid::{GridConfig, Subdivision};
use geom::{Aabb, Vec3};
use std::time::Instant;

/// The GPU's subdivision read back: the frame, the octrees and the seconds of the passes.
pub fn subdivide(
    g: &Gpu,
    k: &crate::kernels::Kernels,
    tris: &wgpu::Buffer,
    ntris: usize,
    cfg: &GridConfig,
) -> Result<(Setup, Octrees, [f64; 2]), GpuError> {
    let (st, d, t) = subdivide_on_device(g, k, tris, ntris, cfg)?;
    let oct = d.read(&mut Exec::new(g, k));
    Ok((st, oct, t))
}

/// The GPU's subdivision: the frame, the octrees on the device and the wall-clock seconds of
/// the two passes (top-level references; octrees).
pub fn subdivide_on_device(
    g: &Gpu,
    k: &crate::kernels::Kernels,
    tris: &wgpu::Buffer,
    ntris: usize,
    cfg: &GridConfig,
) -> Result<(Setup, DeviceOctrees, [f64; 2]), GpuError> {
    build::check_input(ntris, cfg)?;
    let limit = g.max_binding();
    let check = |what: &str, bytes: u64| {
        if bytes > limit {
            Err(GpuError::Limits(format!(
                "the grid build's {what} need {} MiB in one binding; this device allows {} MiB (raise `grid_top_density` or lower `grid_leaf_density` for fewer references)",
                bytes.div_ceil(1 << 20),
                limit >> 20
            )))
        } else {
            Ok(())
        }
    };
    check("triangle boxes", ntris as u64 * 32)?;
    let t0 = Instant::now();
    let mut ex = Exec::new(g, k);
    let n = ntris as u32;

    // Triangle boxes and the scene box.
    let tbox = g.storage("triangle boxes", ntris as u64 * 32);
    let bounds = g.upload("scene box", &[u32::MAX, u32::MAX, u32::MAX, 0, 0, 0]);
    ex.run(
        launch::GridTriBoxes {
            b_tris: tris,
            b_tbox: &tbox,
            b_bounds: &bounds,
        },
        TriBoxesParams { triangles: n },
        ntris as u64,
        256,
    );
    let key: Vec<u32> = ex.read(&bounds, 6);
    let unkey = |b: u32| {
        f32::from_bits(if b & 0x8000_0000 != 0 {
            b & 0x7fff_ffff
        } else {
            !b
        })
    };
    let v = |o: usize| Vec3::new(unkey(key[o]), unkey(key[o + 1]), unkey(key[o + 2]));
    let st = build::setup(Aabb::new(v(0), v(3)), ntris, cfg)?;
    let lim = st.limits;
    let v4 = |a: Vec3, w: f32| [a.x, a.y, a.z, w];
    let frame = |size: Vec3, small: f32, half: Vec3| {
        g.upload(
            "grid build frame",
            &[v4(st.bounds.min, st.pad), v4(size, small), v4(half, 0.0)],
        )
    };
    let count_refs = TopRefsParams {
        triangles: n,
        emit: 0,
        top_dims: st.top_dims,
    };

    // References to the top cells.
    let fr = frame(st.tsize, 0.0, st.tsize / 2.0 + Vec3::splat(st.pad));
    let cnt = g.storage("top reference counts", ntris as u64 * 4);
    let offs = g.storage("top reference offsets", (ntris as u64 + 1) * 4);
    // Every launch binds all the kernel uses (its layout is inferred); the count launch's
    // outputs are placeholders it never writes.
    let none = g.storage("unused", 4);
    ex.run(
        launch::GridTopRefs {
            b_tris: tris,
            b_tbox: &tbox,
            b_frame: &fr,
            b_cnt: &cnt,
            b_offs: &offs,
            b_out_key: &none,
            b_out_tri: &none,
        },
        count_refs,
        ntris as u64,
        256,
    );
    ex.scan(&cnt, &offs, ntris as u64);
    let nref = ex.read_at(&offs, ntris) as u64;
    lim.check_refs(nref)?;
    check("references", nref * 4)?;
    let mut ref_node = g.storage("references' nodes", nref * 4);
    let mut ref_tri = g.storage("references' triangles", nref * 4);
    let emit = TopRefsParams {
        emit: 1,
        ..count_refs
    };
    ex.run(
        launch::GridTopRefs {
            b_tris: tris,
            b_tbox: &tbox,
            b_frame: &fr,
            b_cnt: &cnt,
            b_offs: &offs,
            b_out_key: &ref_node,
            b_out_tri: &ref_tri,
        },
        emit,
        ntris as u64,
        256,
    );
    ex.finish();
    let top_refs_seconds = t0.elapsed().as_secs_f64();

    // Octree levels.
    let t1 = Instant::now();
    let ntop = st.ntop;
    let table = st.depth_table(cfg.leaf_density, ntris);
    let dtab = g.upload("depth table", &table);
    let depth = g.storage("top cells' depths", ntop as u64 * 4);
    let td = st.top_dims;
    let top_coords: Vec<[u32; 4]> = (0..ntop as u32)
        .map(|t| [t % td[0], (t / td[0]) % td[1], t / (td[0] * td[1]), t])
        .collect();
    let mut coords = g.upload("node coordinates", &top_coords);
    let adaptive = cfg.subdivision == Subdivision::Adaptive;
    let mut nodes = ntop;
    let mut nref = nref;
    let mut level = 0u32;
    let mut entries_at = 0u64;
    // Per level, gathered into whole-build buffers at the end.
    struct Level {
        entries: wgpu::Buffer,
        coords: wgpu::Buffer,
        nodes: u64,
        cells: wgpu::Buffer,
        cell_level: wgpu::Buffer,
        nleaf: u64,
        kept: [wgpu::Buffer; 2],
        nkept: u64,
    }
    let mut parts: Vec<Level> = Vec::new();
    let mut ncells = 0u64;
    let mut nkept_all = 0u64;
    loop {
        let nn = nodes as u64;
        check("octree nodes", nn * 16)?;
        let size = st.tsize / (1u32 << (level + 1)) as f32;
        let half = st.tsize / (2u32 << (level + 1)) as f32 + Vec3::splat(st.pad);
        let fr = frame(size, size.min_element(), half);
        let small = adaptive && level >= 1;
        let prm = OctreeLevelParams {
            n: nref as u32,
            level,
            adaptive: adaptive as u32,
            count_small: small as u32,
            max_depth: st.max_depth,
            table_len: table.len() as u32,
            first_cell: 0,
            next_entry: 0,
            emit_kept: 0,
            lambda2: cfg.leaf_density,
            adaptive_split: ADAPTIVE_SPLIT,
            adaptive_copies: ADAPTIVE_COPIES,
        };
        let with_n = |n: u64| OctreeLevelParams { n: n as u32, ..prm };
        let count = g.storage("node counts", nn * 4);
        let smallc = g.storage("node small counts", nn * 4);
        ex.run(
            launch::GridHistogram {
                b_tbox: &tbox,
                b_frame: &fr,
                b_ref_node: &ref_node,
                b_ref_tri: &ref_tri,
                b_count: &count,
                b_small: &smallc,
            },
            with_n(nref),
            nref,
            256,
        );
        let flags = g.storage("node flags", nn * 4);
        ex.run(
            launch::GridWants {
                b_count: &count,
                b_small: &smallc,
                b_depth: &depth,
                b_dtab: &dtab,
                b_coords: &coords,
                b_flags: &flags,
            },
            with_n(nn),
            nn,
            256,
        );
        let mask = g.storage("child masks", nref * 4);
        let sepcop = g.storage("node separation and copies", nn * 8);
        ex.run(
            launch::GridMasks {
                b_tris: tris,
                b_tbox: &tbox,
                b_frame: &fr,
                b_ref_node: &ref_node,
                b_ref_tri: &ref_tri,
                b_coords: &coords,
                b_flags: &flags,
                b_mask: &mask,
                b_sepcop: &sepcop,
            },
            with_n(nref),
            nref,
            256,
        );
        let split = g.storage("split", nn * 4);
        let leaf = g.storage("leaf", nn * 4);
        ex.run(
            launch::GridSplit {
                b_count: &count,
                b_flags: &flags,
                b_sepcop: &sepcop,
                b_split: &split,
                b_leaf: &leaf,
            },
            with_n(nn),
            nn,
            256,
        );
        let child_base = g.storage("child base", (nn + 1) * 4);
        let leaf_index = g.storage("leaf index", (nn + 1) * 4);
        ex.scan(&split, &child_base, nn);
        ex.scan(&leaf, &leaf_index, nn);
        let nsplit = ex.read_at(&child_base, nodes) as u64;
        let nleaf = ex.read_at(&leaf_index, nodes) as u64;
        let next_level_entry = entries_at + nn;
        let need = (next_level_entry + 8 * nsplit).max(ncells + nleaf);
        lim.check_nodes(need, level)?;
        check("octree nodes", 8 * nsplit * 16)?;
        let entries = g.storage("voxel-map entries", nn * 4);
        let cells = g.storage("leaf cells", (nleaf * 16).max(16));
        let new_coords = g.storage("node coordinates", (8 * nsplit * 16).max(16));
        let cell_level = g.storage("leaf cells' levels", nleaf * 4);
        let p = OctreeLevelParams {
            first_cell: ncells as u32,
            next_entry: next_level_entry as u32,
            ..with_n(nn)
        };
        ex.run(
            launch::GridNodes {
                b_count: &count,
                b_coords: &coords,
                b_split: &split,
                b_child_base: &child_base,
                b_leaf_index: &leaf_index,
                b_entries: &entries,
                b_cells: &cells,
                b_new_coords: &new_coords,
                b_cell_level: &cell_level,
            },
            p,
            nn,
            256,
        );
        // References: kept by leaves, or one per child overlapped.
        let kept = g.storage("kept flags", nref * 4);
        let ccnt = g.storage("child reference counts", nref * 4);
        ex.run(
            launch::GridRefFlags {
                b_cnt: &ccnt,
                b_ref_node: &ref_node,
                b_mask: &mask,
                b_split: &split,
                b_kept: &kept,
            },
            with_n(nref),
            nref,
            256,
        );
        let kept_at = g.storage("kept slots", (nref + 1) * 4);
        let child_at = g.storage("child reference slots", (nref + 1) * 4);
        ex.scan(&kept, &kept_at, nref);
        ex.scan(&ccnt, &child_at, nref);
        let nkept = ex.read_at(&kept_at, nref as usize) as u64;
        let nnew = ex.read_at(&child_at, nref as usize) as u64;
        lim.check_refs(nkept_all + nkept)?;
        lim.check_refs(nnew)?;
        check("references", nnew * 4)?;
        let kept_cell = g.storage("kept references' cells", nkept * 4);
        let kept_tri = g.storage("kept references' triangles", nkept * 4);
        let p = OctreeLevelParams {
            emit_kept: 1,
            first_cell: ncells as u32,
            ..with_n(nref)
        };
        ex.run(
            launch::GridRefEmit {
                b_offs: &child_at,
                b_out_key: &kept_cell,
                b_out_tri: &kept_tri,
                b_ref_node: &ref_node,
                b_ref_tri: &ref_tri,
                b_mask: &mask,
                b_split: &split,
                b_child_base: &child_base,
                b_leaf_index: &leaf_index,
                b_kept: &kept_at,
            },
            p,
            nref,
            256,
        );
        parts.push(Level {
            entries,
            coords: coords.clone(),
            nodes: nn,
            cells,
            cell_level,
            nleaf,
            kept: [kept_cell, kept_tri],
            nkept,
        });
        entries_at = next_level_entry;
        ncells += nleaf;
        nkept_all += nkept;
        if nsplit == 0 {
            break;
        }
        let new_node = g.storage("references' nodes", nnew * 4);
        let new_tri = g.storage("references' triangles", nnew * 4);
        let p = with_n(nref);
        ex.run(
            launch::GridRefEmit {
                b_offs: &child_at,
                b_out_key: &new_node,
                b_out_tri: &new_tri,
                b_ref_node: &ref_node,
                b_ref_tri: &ref_tri,
                b_mask: &mask,
                b_split: &split,
                b_child_base: &child_base,
                b_leaf_index: &leaf_index,
                b_kept: &kept_at,
            },
            p,
            nref,
            256,
        );
        coords = new_coords;
        ref_node = new_node;
        ref_tri = new_tri;
        nodes = 8 * nsplit as usize;
        nref = nnew;
        level += 1;
    }
    // Every level's results gathered, in level order, into buffers of the whole build.
    let sum = |f: &dyn Fn(&Level) -> u64| parts.iter().map(f).sum::<u64>();
    let (nentries, ncells, nkept) = (sum(&|l| l.nodes), sum(&|l| l.nleaf), sum(&|l| l.nkept));
    check("voxel-map entries", nentries * 16)?;
    let mut d = DeviceOctrees {
        entries: g.storage("sparse voxel map", nentries * 4),
        coords: g.storage("node coordinates", nentries * 16),
        cells: g.storage("leaf cells", (ncells * 16).max(16)),
        cell_level: g.storage("leaf cells' levels", ncells * 4),
        kept_cell: g.storage("kept references' cells", nkept * 4),
        kept_tri: g.storage("kept references' triangles", nkept * 4),
        levels: Vec::new(),
        ntop: st.ntop as u64,
        ncells,
        nkept,
        shift: level,
    };
    let (mut at_e, mut at_c, mut at_k) = (0u64, 0u64, 0u64);
    for l in &parts {
        ex.copy_at(&l.entries, 0, &d.entries, at_e * 4, l.nodes * 4);
        ex.copy_at(&l.coords, 0, &d.coords, at_e * 16, l.nodes * 16);
        ex.copy_at(&l.cells, 0, &d.cells, at_c * 16, l.nleaf * 16);
        ex.copy_at(&l.cell_level, 0, &d.cell_level, at_c * 4, l.nleaf * 4);
        ex.copy_at(&l.kept[0], 0, &d.kept_cell, at_k * 4, l.nkept * 4);
        ex.copy_at(&l.kept[1], 0, &d.kept_tri, at_k * 4, l.nkept * 4);
        d.levels.push((at_e, l.nodes));
        at_e += l.nodes;
        at_c += l.nleaf;
        at_k += l.nkept;
    }
    ex.finish();
    Ok((st, d, [top_refs_seconds, t1.elapsed().as_secs_f64()]))
}

/// The octrees on the device, as [`Octrees`] holds them on the host: nodes by their index
/// in the sparse voxel map (level after level), leaf cells in level order, kept references.
pub struct DeviceOctrees {
    /// The sparse voxel map.
    pub entries: wgpu::Buffer,
    /// Per entry: the node's coordinates at its level and its top cell (`vec4<u32>`).
    pub coords: wgpu::Buffer,
    /// Per leaf cell: coordinates and reference count (`vec4<u32>`).
    pub cells: wgpu::Buffer,
    /// Per leaf cell: its level.
    pub cell_level: wgpu::Buffer,
    /// Kept references' cells (level order).
    pub kept_cell: wgpu::Buffer,
    /// Kept references' triangles.
    pub kept_tri: wgpu::Buffer,
    /// Per level: its first entry and its node count.
    pub levels: Vec<(u64, u64)>,
    /// Top cells (level 0's nodes).
    pub ntop: u64,
    /// Leaf cells.
    pub ncells: u64,
    /// Kept references.
    pub nkept: u64,
    /// Levels below the top.
    pub shift: u32,
}

impl DeviceOctrees {
    /// Read the octrees back (tests compare them with the CPU's).
    pub fn read(&self, ex: &mut Exec) -> Octrees {
        let nentries = self.levels.iter().map(|l| l.1).sum::<u64>() as usize;
        let cells: Vec<[u32; 4]> = ex.read(&self.cells, self.ncells as usize);
        let levels: Vec<u32> = ex.read(&self.cell_level, self.ncells as usize);
        Octrees {
            entries: ex.read(&self.entries, nentries),
            cell_coord: cells.iter().map(|c| [c[0], c[1], c[2]]).collect(),
            cell_level: levels.iter().map(|&l| l as u8).collect(),
            cell_count: cells.iter().map(|c| c[3]).collect(),
            kept_cell: ex.read(&self.kept_cell, self.nkept as usize),
            kept_tri: ex.read(&self.kept_tri, self.nkept as usize),
            levels: self.shift,
        }
    }
}
