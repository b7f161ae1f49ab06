//! The octree pass (paper §4.1): the top grid's references, then the octrees level by level,
//! only non-empty nodes splitting (count → scan → emit over references), by the rule of
//! [`Subdivision`].

use super::*;

/// The top-level references and the octrees (§4.1), with the seconds of the two passes.
pub fn subdivide(
    tris: &[[Vec3; 3]],
    cfg: &GridConfig,
) -> Result<(Setup, Octrees, [f64; 2]), GridError> {
    let t0 = Instant::now();
    let (st, frame) = Frame::of(tris, cfg)?;
    let (top_dims, ntop, lim) = (st.top_dims, st.ntop, st.limits);
    let (mut ref_node, mut ref_tri) = top_refs(&frame, top_dims, &lim)?;
    let top_refs_seconds = t0.elapsed().as_secs_f64();

    // Octree levels. Per level: nodes (coordinates, top cell), references (node, triangle).
    let t1 = Instant::now();
    let max_depth = st.max_depth;
    let mut depth = vec![0u32; ntop];
    let mut coords: Vec<[u32; 3]> = (0..ntop as u32)
        .map(|t| {
            [
                t % top_dims[0],
                (t / top_dims[0]) % top_dims[1],
                t / (top_dims[0] * top_dims[1]),
            ]
        })
        .collect();
    let mut top_of: Vec<u32> = (0..ntop as u32).collect();
    let mut entries: Vec<u32> = Vec::with_capacity(ntop * 2);
    // Leaf cells in level order: coordinates, level, reference count.
    let mut cell_coord: Vec<[u32; 3]> = Vec::new();
    let mut cell_level: Vec<u8> = Vec::new();
    let mut cell_count: Vec<u32> = Vec::new();
    // Final references of the leaves, grouped by level; cells of one level take all their
    // references from that level, in triangle order.
    let mut kept_cell: Vec<u32> = Vec::new();
    let mut kept_tri: Vec<u32> = Vec::new();
    let mut level = 0u32;
    loop {
        let nodes = coords.len();
        let count = histogram(&ref_node, nodes);
        // Adaptive: the references a split can separate, to triangles at most half the
        // node's size (at the top level, all of them).
        let adaptive = cfg.subdivision == Subdivision::Adaptive;
        let small = if adaptive && level >= 1 {
            let half = (frame.tsize / (1u32 << (level + 1)) as f32).min_element();
            let keys: Vec<u32> = ref_node
                .par_iter()
                .zip(&ref_tri)
                .with_min_len(4096)
                .map(|(&p, &t)| {
                    if frame.tri_box[t as usize].extent().max_element() <= half {
                        p
                    } else {
                        u32::MAX
                    }
                })
                .collect();
            histogram(&keys, nodes)
        } else {
            Vec::new()
        };
        let small = |i: usize| if level == 0 { count[i] } else { small[i] };
        if level == 0 {
            depth = count
                .iter()
                .map(|&n| paper_depth(frame.tsize, n, cfg.leaf_density, max_depth))
                .collect();
        }
        let wants: Vec<bool> = (0..nodes)
            .into_par_iter()
            .with_min_len(4096)
            .map(|i| {
                let n = count[i];
                let rule = level < depth[top_of[i] as usize]
                    || (adaptive && cfg.leaf_density * small(i) as f32 >= ADAPTIVE_SPLIT);
                n > 0 && level < max_depth && rule
            })
            .collect();
        // The children each reference of a splitting node overlaps. A node whose every
        // reference overlaps all 8 children does not split after all: its 8 children would
        // hold the same list (and merging would only put them back together).
        // In chunks, each with its own cache of the last triangle's prepared test.
        let mut mask = vec![0u8; ref_node.len()];
        mask.par_chunks_mut(1024)
            .zip(ref_node.par_chunks(1024).zip(ref_tri.par_chunks(1024)))
            .for_each(|(out, (nodes, tris))| {
                let mut prep = Prepared::none();
                for ((m, &p), &t) in out.iter_mut().zip(nodes).zip(tris) {
                    let p = p as usize;
                    if wants[p] {
                        *m = frame.child_mask(coords[p], level, t as usize, &mut prep);
                    }
                }
            });
        let separates: Vec<AtomicBool> = (0..nodes).map(|_| AtomicBool::new(false)).collect();
        // Adaptive splits (below the paper's depth) also count the children's references:
        // a split that copies most references into most children separates nothing (a fan
        // of small triangles around one vertex) and only multiplies the lists.
        let beyond = |i: usize| adaptive && level >= depth[top_of[i] as usize];
        let copies: Vec<AtomicU32> = if adaptive {
            (0..nodes).map(|_| AtomicU32::new(0)).collect()
        } else {
            Vec::new()
        };
        (0..ref_node.len())
            .into_par_iter()
            .with_min_len(4096)
            .for_each(|r| {
                let p = ref_node[r] as usize;
                if wants[p] {
                    if mask[r] != 0xff {
                        separates[p].store(true, Ordering::Relaxed);
                    }
                    if beyond(p) {
                        copies[p].fetch_add(mask[r].count_ones(), Ordering::Relaxed);
                    }
                }
            });
        let split: Vec<u32> = (0..nodes)
            .into_par_iter()
            .with_min_len(4096)
            .map(|i| {
                let useful = !beyond(i)
                    || (copies[i].load(Ordering::Relaxed) as f32)
                        < ADAPTIVE_COPIES * count[i] as f32;
                (wants[i] && separates[i].load(Ordering::Relaxed) && useful) as u32
            })
            .collect();
        let mut child_base = vec![0u32; nodes];
        let nsplit = exclusive_scan(&split, &mut child_base) as usize;
        // A leaf's slot among the level's leaves: the nodes before it that do not split
        // (the scan of `1 − split`, read off the scan of `split`).
        let leaf_index = |i: usize| i as u32 - child_base[i];
        let nleaf = nodes - nsplit;
        let first_cell = cell_coord.len() as u32;
        let next_level_entry = (entries.len() + nodes) as u64;
        let need = (next_level_entry + 8 * nsplit as u64).max(first_cell as u64 + nleaf as u64);
        lim.check_nodes(need, level)?;
        // This level's voxel-map entries, and its leaves appended to the cell lists (each
        // leaf at its scanned slot).
        let at = entries.len();
        entries.resize(at + nodes, 0);
        let cells_at = cell_coord.len();
        cell_coord.resize(cells_at + nleaf, [0; 3]);
        cell_count.resize(cells_at + nleaf, 0);
        cell_level.resize(cells_at + nleaf, level as u8);
        {
            let (cp, np) = (
                SharedMut(cell_coord[cells_at..].as_mut_ptr()),
                SharedMut(cell_count[cells_at..].as_mut_ptr()),
            );
            entries[at..]
                .par_iter_mut()
                .enumerate()
                .with_min_len(4096)
                .for_each(|(i, e)| {
                    if split[i] != 0 {
                        *e = voxelmap::node(next_level_entry as u32 + 8 * child_base[i], 1);
                    } else {
                        let li = leaf_index(i);
                        *e = first_cell + li;
                        // SAFETY: leaf i owns slot leaf_index(i) by the exclusive scan.
                        unsafe {
                            cp.write(li as usize, coords[i]);
                            np.write(li as usize, count[i]);
                        }
                    }
                });
        }
        // References of leaves are final; those of split nodes go one level down. Where
        // nothing splits (the last level), every reference is kept in place.
        let base = kept_cell.len();
        if nsplit == 0 {
            lim.check_refs((base + ref_node.len()) as u64)?;
            kept_cell.par_extend(
                ref_node
                    .par_iter()
                    .with_min_len(4096)
                    .map(|&p| first_cell + leaf_index(p as usize)),
            );
            kept_tri.extend_from_slice(&ref_tri);
            break;
        }
        let kept: Vec<u32> = ref_node
            .par_iter()
            .with_min_len(4096)
            .map(|&p| 1 - split[p as usize])
            .collect();
        let mut kept_at = vec![0u32; ref_node.len()];
        let nkept = exclusive_scan(&kept, &mut kept_at) as usize;
        lim.check_refs((base + nkept) as u64)?;
        kept_cell.resize(base + nkept, 0);
        kept_tri.resize(base + nkept, 0);
        {
            let (cp, tp) = (
                SharedMut(kept_cell[base..].as_mut_ptr()),
                SharedMut(kept_tri[base..].as_mut_ptr()),
            );
            (0..ref_node.len())
                .into_par_iter()
                .with_min_len(4096)
                .filter(|&r| kept[r] != 0)
                .for_each(|r| {
                    let p = ref_node[r] as usize;
                    // SAFETY: kept reference r owns slot kept_at[r] by the exclusive scan.
                    unsafe {
                        cp.write(kept_at[r] as usize, first_cell + leaf_index(p));
                        tp.write(kept_at[r] as usize, ref_tri[r]);
                    }
                });
        }
        // Split references: one per child each overlaps (count → scan → emit).
        let (new_node, new_tri) = count_scan_emit(
            &lim,
            ref_node.len(),
            |r| {
                if split[ref_node[r] as usize] != 0 {
                    mask[r].count_ones()
                } else {
                    0
                }
            },
            |r, out| {
                if split[ref_node[r] as usize] == 0 {
                    return;
                }
                let mut m = mask[r];
                let base = 8 * child_base[ref_node[r] as usize];
                while m != 0 {
                    let k = m.trailing_zeros();
                    m &= m - 1;
                    out(base + k, ref_tri[r]);
                }
            },
        )?;
        let mut new_coords = vec![[0u32; 3]; 8 * nsplit];
        let mut new_top = vec![0u32; 8 * nsplit];
        {
            let (cp, tp) = (
                SharedMut(new_coords.as_mut_ptr()),
                SharedMut(new_top.as_mut_ptr()),
            );
            (0..nodes)
                .into_par_iter()
                .with_min_len(4096)
                .filter(|&i| split[i] != 0)
                .for_each(|i| {
                    let c = coords[i];
                    for k in 0..8u32 {
                        let cc = [
                            2 * c[0] + (k & 1),
                            2 * c[1] + ((k >> 1) & 1),
                            2 * c[2] + (k >> 2),
                        ];
                        let at = (8 * child_base[i] + k) as usize;
                        // SAFETY: split node i owns children [8 child_base[i], +8).
                        unsafe {
                            cp.write(at, cc);
                            tp.write(at, top_of[i]);
                        }
                    }
                });
        }
        coords = new_coords;
        top_of = new_top;
        ref_node = new_node;
        ref_tri = new_tri;
        level += 1;
    }
    let octree_seconds = t1.elapsed().as_secs_f64();
    let oct = Octrees {
        entries,
        cell_coord,
        cell_level,
        cell_count,
        kept_cell,
        kept_tri,
        levels: level,
    };
    Ok((st, oct, [top_refs_seconds, octree_seconds]))
}
