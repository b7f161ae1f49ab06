//! Initial irregular-grid construction (paper §4.1): top-level grid, per-cell octrees,
//! references by exact triangle–box tests, and the two-level voxel map.

use super::{BuildStats, Grid, GridConfig};
use geom::aabb::tri_overlaps_box;
use geom::{Aabb, Vec3};
use par::{exclusive_scan, sort_pairs, SharedMut, SortScratch};
use rayon::prelude::*;
use std::time::Instant;

/// Cleary's resolution (paper eq. 1): R = d · cbrt(λ N / V), at least 1 per axis.
pub fn resolution(extent: Vec3, n: usize, density: f32) -> [u32; 3] {
    let v = (extent.x * extent.y * extent.z).max(1e-30);
    let k = (density * n as f32 / v).cbrt();
    let r = |e: f32| ((e * k).ceil() as u32).clamp(1, 512);
    [r(extent.x), r(extent.y), r(extent.z)]
}

/// The scene box padded by 0.1% per side (as hagrid), with no axis thinner than 1e-3 of the
/// largest, so flat scenes still get volume.
pub fn padded_bounds(tris: &[[Vec3; 3]]) -> Aabb {
    let b = Aabb::from_points(tris.iter().flatten().copied());
    let e = b.extent();
    let m = e.max_element().max(1e-6);
    let pad = (e * 0.001).max(Vec3::splat(m * 1e-3));
    Aabb::new(b.min - pad, b.max + pad)
}

/// How far cell boxes are grown for reference tests: far above the rounding of coordinates
/// of this magnitude (f32 ε ≈ 1.2e-7) and far below a voxel.
pub fn ref_padding(bounds: &Aabb) -> f32 {
    let m = bounds
        .min
        .abs()
        .max(bounds.max.abs())
        .max_element()
        .max(bounds.diagonal());
    m * 1e-5
}

/// Emit (key, tri) pairs through count → exclusive scan → emit: `count(t)` says how many
/// pairs triangle t makes, `emit(t, out)` pushes them in the same order.
fn count_scan_emit(
    ntris: usize,
    count: impl Fn(usize) -> u32 + Sync,
    emit: impl Fn(usize, &mut dyn FnMut(u32)) + Sync,
) -> (Vec<u32>, Vec<u32>) {
    let counts: Vec<u32> = (0..ntris).into_par_iter().map(&count).collect();
    let mut offs = vec![0u32; ntris];
    let total = exclusive_scan(&counts, &mut offs) as usize;
    let mut keys = vec![0u32; total];
    let mut tris = vec![0u32; total];
    {
        let kp = SharedMut(keys.as_mut_ptr());
        let tp = SharedMut(tris.as_mut_ptr());
        (0..ntris).into_par_iter().for_each(|t| {
            let mut k = offs[t] as usize;
            let end = k + counts[t] as usize;
            emit(t, &mut |key| {
                assert!(k < end, "emit made more pairs than count");
                // SAFETY: triangle t owns [offs[t], offs[t] + counts[t]) by the exclusive scan.
                unsafe {
                    kp.write(k, key);
                    tp.write(k, t as u32);
                }
                k += 1;
            });
        });
    }
    (keys, tris)
}

/// Octree node within a top cell, packed: x | y << 8 | z << 16 | level << 24.
#[inline]
fn pack(l: [u32; 3], level: u32) -> u32 {
    l[0] | l[1] << 8 | l[2] << 16 | level << 24
}

#[inline]
fn unpack(p: u32) -> ([u32; 3], u32) {
    ([p & 0xff, (p >> 8) & 0xff, (p >> 16) & 0xff], p >> 24)
}

/// The initial structure: top grid, octrees, voxel map, sorted references.
pub fn initial(tris: &[[Vec3; 3]], cfg: &GridConfig) -> Result<Grid, String> {
    cfg.validate()?;
    if tris.is_empty() {
        return Err("the grid needs at least one triangle".into());
    }
    let t0 = Instant::now();
    let bounds = padded_bounds(tris);
    let pad = ref_padding(&bounds);
    let ext = bounds.extent();
    let top_dims = resolution(ext, tris.len(), cfg.top_density);
    let tsize = ext / Vec3::new(top_dims[0] as f32, top_dims[1] as f32, top_dims[2] as f32);
    let ntop = (top_dims[0] * top_dims[1] * top_dims[2]) as usize;
    let top_box = |c: [u32; 3]| {
        let lo = bounds.min + Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32) * tsize;
        Aabb::new(lo - Vec3::splat(pad), lo + tsize + Vec3::splat(pad))
    };
    let range = |t: &[Vec3; 3]| {
        let b = Aabb::from_points(t.iter().copied());
        let lo = ((b.min - Vec3::splat(pad) - bounds.min) / tsize).floor();
        let hi = ((b.max + Vec3::splat(pad) - bounds.min) / tsize).floor();
        let c = |v: f32, k: usize| (v.max(0.0) as u32).min(top_dims[k] - 1);
        (
            [c(lo.x, 0), c(lo.y, 1), c(lo.z, 2)],
            [c(hi.x, 0), c(hi.y, 1), c(hi.z, 2)],
        )
    };
    let visit = |t: usize, f: &mut dyn FnMut(u32)| {
        let (lo, hi) = range(&tris[t]);
        for z in lo[2]..=hi[2] {
            for y in lo[1]..=hi[1] {
                for x in lo[0]..=hi[0] {
                    if tri_overlaps_box(&top_box([x, y, z]), &tris[t]) {
                        f(x + top_dims[0] * (y + top_dims[1] * z));
                    }
                }
            }
        }
    };
    let (top_cell, top_tri) = count_scan_emit(
        tris.len(),
        |t| {
            let mut n = 0;
            visit(t, &mut |_| n += 1);
            n
        },
        visit,
    );
    let top_refs_seconds = t0.elapsed().as_secs_f64();

    // Octree depth per top cell from the same formula with λ₂ and the cell's own count.
    let t1 = Instant::now();
    let mut per_cell = vec![0u32; ntop];
    for &c in &top_cell {
        per_cell[c as usize] += 1;
    }
    let depth: Vec<u32> = per_cell
        .iter()
        .map(|&n| {
            if n == 0 {
                return 0; // Empty cells never split.
            }
            let r = resolution(tsize, n as usize, cfg.leaf_density);
            let m = r[0].max(r[1]).max(r[2]);
            (32 - (m - 1).leading_zeros()).min(cfg.max_depth) // ceil(log2 m)
        })
        .collect();
    let shift = depth.iter().copied().max().unwrap_or(0);
    // Split passes: each pass takes every reference one octree level down, emitting a child
    // reference for each of the 8 children its triangle overlaps.
    let mut node: Vec<u32> = vec![pack([0; 3], 0); top_cell.len()];
    let (mut rc, mut rt) = (top_cell, top_tri);
    for _ in 0..shift {
        let child_box = |top: u32, l: [u32; 3], level: u32| {
            let tc = [
                top % top_dims[0],
                (top / top_dims[0]) % top_dims[1],
                top / (top_dims[0] * top_dims[1]),
            ];
            let size = tsize / (1u32 << level) as f32;
            let lo = bounds.min
                + Vec3::new(tc[0] as f32, tc[1] as f32, tc[2] as f32) * tsize
                + Vec3::new(l[0] as f32, l[1] as f32, l[2] as f32) * size;
            Aabb::new(lo - Vec3::splat(pad), lo + size + Vec3::splat(pad))
        };
        let visit = |i: usize, f: &mut dyn FnMut(u32)| {
            let (l, level) = unpack(node[i]);
            if level >= depth[rc[i] as usize] {
                f(node[i]);
                return;
            }
            for k in 0..8u32 {
                let c = [
                    2 * l[0] + (k & 1),
                    2 * l[1] + ((k >> 1) & 1),
                    2 * l[2] + (k >> 2),
                ];
                if tri_overlaps_box(&child_box(rc[i], c, level + 1), &tris[rt[i] as usize]) {
                    f(pack(c, level + 1));
                }
            }
        };
        let (new_node, src) = count_scan_emit(
            node.len(),
            |i| {
                let mut n = 0;
                visit(i, &mut |_| n += 1);
                n
            },
            visit,
        );
        // `src` holds the index of the parent reference; carry its top cell and triangle.
        rc = src.par_iter().map(|&i| rc[i as usize]).collect();
        rt = src.par_iter().map(|&i| rt[i as usize]).collect();
        node = new_node;
    }
    let octree_seconds = t1.elapsed().as_secs_f64();

    // Cells: 8^D per top cell, and the voxel map.
    let t2 = Instant::now();
    let sizes: Vec<u32> = depth.iter().map(|&d| 1u32 << (3 * d)).collect();
    let mut cell_offset = vec![0u32; ntop];
    let ncells = exclusive_scan(&sizes, &mut cell_offset) as usize;
    if ncells >= 1 << 28 {
        return Err(format!("{ncells} initial cells exceed the voxel map's 28-bit index; lower the densities or the octree depth"));
    }
    let top: Vec<u32> = (0..ntop).map(|t| depth[t] << 28 | cell_offset[t]).collect();
    let leaf: Vec<u32> = (0..ncells as u32).collect();
    let mut cell_min = vec![[0u32; 3]; ncells];
    let mut cell_max = vec![[0u32; 3]; ncells];
    {
        let (pmin, pmax) = (
            SharedMut(cell_min.as_mut_ptr()),
            SharedMut(cell_max.as_mut_ptr()),
        );
        (0..ntop).into_par_iter().for_each(|t| {
            let d = depth[t];
            let tc = [
                t as u32 % top_dims[0],
                (t as u32 / top_dims[0]) % top_dims[1],
                t as u32 / (top_dims[0] * top_dims[1]),
            ];
            let step = 1u32 << (shift - d);
            let n = 1u32 << d;
            for i in 0..sizes[t] {
                let l = [i % n, (i / n) % n, i / (n * n)];
                let lo = [0, 1, 2].map(|k| (tc[k] << shift) + l[k] * step);
                let hi = lo.map(|v| v + step);
                // SAFETY: top cell t owns [cell_offset[t], cell_offset[t] + sizes[t]).
                unsafe {
                    pmin.write((cell_offset[t] + i) as usize, lo);
                    pmax.write((cell_offset[t] + i) as usize, hi);
                }
            }
        });
    }
    // References sorted by (cell, triangle): one radix sort of 64-bit keys.
    let mut keys: Vec<u64> = (0..node.len())
        .into_par_iter()
        .map(|i| {
            let (l, level) = unpack(node[i]);
            let n = 1u32 << level;
            let cell = cell_offset[rc[i] as usize] + l[0] + n * (l[1] + n * l[2]);
            (cell as u64) << 32 | rt[i] as u64
        })
        .collect();
    let mut dummy = vec![0u32; keys.len()];
    let cell_bits = 64 - (ncells.max(1) as u64).leading_zeros();
    sort_pairs(
        &mut keys,
        &mut dummy,
        32 + cell_bits,
        &mut SortScratch::new(),
    );
    let refs: Vec<u32> = keys.par_iter().map(|&k| k as u32).collect();
    let mut ref_first = vec![0u32; ncells + 1];
    for &k in &keys {
        ref_first[(k >> 32) as usize + 1] += 1;
    }
    for c in 0..ncells {
        ref_first[c + 1] += ref_first[c];
    }
    let dims = top_dims.map(|d| d << shift);
    let voxel = ext / Vec3::new(dims[0] as f32, dims[1] as f32, dims[2] as f32);
    let voxel_map_seconds = t2.elapsed().as_secs_f64();
    Ok(Grid {
        bounds,
        top_dims,
        shift,
        dims,
        voxel,
        inv_voxel: voxel.recip(),
        exp_min: cell_min.clone(),
        exp_max: cell_max.clone(),
        cell_min,
        cell_max,
        ref_first,
        refs,
        top,
        leaf,
        build: BuildStats {
            top_refs_seconds,
            octree_seconds,
            voxel_map_seconds,
            initial_cells: ncells,
            ..Default::default()
        },
    })
}

/// The reference padding of `grid`, for checks that must use the builder's boxes.
pub fn padding(grid: &Grid) -> f32 {
    ref_padding(&grid.bounds)
}
