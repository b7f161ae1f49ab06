//! The leaf order of the hierarchy: CRSH's hash → trim → compress → sort → decompress
//! (thesis §3.2.3–3.2.6), or RAH's screen-space order. Each step is one `par` primitive and
//! one timed phase.

use crate::hash::{morton64_key, screen_key, spherical01_8, thesis_keys8, HashBits, HashKind};
use geom::Aabb;
use par::{compact_pairs, compress_runs, expand_runs, sort_pairs, SortScratch};
use rayon::prelude::*;
use std::time::Instant;
use trace::{Phase, RayBatch, TraceStats};

/// How leaves are ordered before they are grouped into nodes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Grouping {
    /// CRSH: by ray hash, through compress–sort–decompress.
    Hash(HashKind),
    /// RAH: by screen position (pixel Z-order), the layout of its ray textures.
    Screen,
}

fn timed<T>(stats: &mut TraceStats, phase: Phase, f: impl FnOnce() -> T) -> T {
    let t0 = Instant::now();
    let r = f();
    stats.time(phase, t0.elapsed().as_secs_f64());
    r
}

/// Indices of the rays that can hit anything (t_min < t_max), in a coherent order.
pub fn leaf_order(
    rays: &RayBatch,
    grouping: Grouping,
    scene: &Aabb,
    bits: &HashBits,
    stats: &mut TraceStats,
) -> Vec<u32> {
    let n = rays.len();
    let ids: Vec<u32> = (0..n as u32).collect();
    let valid: Vec<u8> = (0..n)
        .into_par_iter()
        .map(|i| (rays.t_min[i] < rays.t_max[i]) as u8)
        .collect();
    match grouping {
        Grouping::Hash(HashKind::Thesis) => {
            let keys: Vec<u32> = timed(stats, crate::stats::HASH, || {
                // 8 rays' spherical angles and keys at a time (AVX lanes, the scalar bits).
                let mut keys = vec![0u32; n];
                keys.par_chunks_mut(8)
                    .with_min_len(512)
                    .enumerate()
                    .for_each(|(c, out)| {
                        let tp = spherical01_8(rays, c * 8);
                        thesis_keys8(rays, c * 8, &tp, scene, bits, out);
                    });
                keys
            });
            chunked_order(keys, ids, &valid, 32, stats)
        }
        Grouping::Hash(HashKind::Morton64) => {
            let keys: Vec<u64> = timed(stats, crate::stats::HASH, || {
                (0..n)
                    .into_par_iter()
                    .map(|i| morton64_key(rays, i, scene))
                    .collect()
            });
            chunked_order(keys, ids, &valid, 64, stats)
        }
        Grouping::Screen => {
            let keys: Vec<u32> = timed(stats, crate::stats::SCREEN_ORDER, || {
                (0..n)
                    .into_par_iter()
                    .map(|i| screen_key(rays, i))
                    .collect()
            });
            let (mut k, mut v) = (vec![0u32; n], vec![0u32; n]);
            let m = timed(stats, crate::stats::TRIM, || {
                compact_pairs(&keys, &ids, &valid, &mut k, &mut v)
            });
            k.truncate(m);
            v.truncate(m);
            timed(stats, crate::stats::SCREEN_ORDER, || {
                sort_pairs(&mut k, &mut v, 32, &mut SortScratch::new())
            });
            v
        }
    }
}

/// Trim → compress into chunks of equal keys → radix-sort the chunks → decompress.
fn chunked_order<K: par::RadixKey + PartialEq>(
    keys: Vec<K>,
    ids: Vec<u32>,
    valid: &[u8],
    bits: u32,
    stats: &mut TraceStats,
) -> Vec<u32> {
    let n = keys.len();
    // Trim (§3.2.3): drop rays that cannot hit (empty t range), keeping key and ray index.
    let (mut tk, mut tv) = (vec![K::default(); n], vec![0u32; n]);
    let m = timed(stats, crate::stats::TRIM, || {
        compact_pairs(&keys, &ids, valid, &mut tk, &mut tv)
    });
    // Compress (§3.2.4): runs of equal consecutive keys become (key, base, size) chunks.
    let (mut ck, mut cb, mut cs) = (vec![K::default(); m], vec![0u32; m], vec![0u32; m]);
    let chunks = timed(stats, crate::stats::COMPRESS, || {
        compress_runs(&tk[..m], &mut ck, &mut cb, &mut cs)
    });
    stats.count(crate::stats::CHUNKS, chunks as u64);
    ck.truncate(chunks);
    // Sort (§3.2.5): the chunk keys with the chunk index as value (stable radix sort).
    let mut order: Vec<u32> = (0..chunks as u32).collect();
    timed(stats, crate::stats::SORT, || {
        sort_pairs(&mut ck, &mut order, bits, &mut SortScratch::new())
    });
    // Decompress (§3.2.6): expand the sorted chunks back to positions, then to ray indices.
    timed(stats, crate::stats::DECOMPRESS, || {
        let mut offs = vec![0u32; chunks];
        let mut pos = vec![0u32; m];
        expand_runs(&order, &cb[..chunks], &cs[..chunks], &mut offs, &mut pos);
        pos.par_iter().map(|&p| tv[p as usize]).collect()
    })
}
