//! A software rasterizer that fills the thesis's G-buffer (§3.1).
//!
//! Shaped like a hardware pipeline, one pass per function:
//! 1. **setup** (parallel over triangles): camera space, clipping against the near plane and a
//!    guard band (homogeneous Sutherland–Hodgman), projection, snapping to 12 sub-pixel bits;
//! 2. **binning** into 32×32 tiles by count → exclusive scan → scatter, in parallel over
//!    pieces of triangles (the scan runs in (tile, piece) order, so each tile still sees its
//!    triangles in id order);
//! 3. **tile rasterization** (parallel over rows of tiles, each writing its rows of the
//!    G-buffer): integer edge functions with the top-left fill rule (no cracks, no double
//!    coverage on shared edges), stepped across each row's exact span (integer bounds), then
//!    perspective-correct barycentrics and a z-buffer on 1/z (ties keep the smaller triangle
//!    id, like closest-hit);
//! 4. **resolve** (parallel over pixels): position, normal, diffuse, specular/shininess from
//!    triangle id and barycentrics.
//!
//! [`rasterize_into`] keeps the G-buffer and the scratch of the passes from one frame to the
//! next, so a frame sequence allocates nothing here.

use geom::{Vec3, NO_HIT};
use rayon::prelude::*;
use scene::{Geometry, Material};

use crate::view::View;

mod cull;

/// Sub-pixel precision. With the guard band below, snapped coordinates stay under 2^28 for
/// images up to 16384 pixels wide, so edge functions (differences of products of
/// coordinate differences) stay under 2^58 and are exact in i64.
const SUB_BITS: u32 = 12;
const SUB: i64 = 1 << SUB_BITS;
const TILE: u32 = 32;
/// Guard band in NDC units: geometry is clipped to |x|, |y| ≤ GUARD·z, i.e. to screen
/// positions within [−1.5, 2.5] image sizes.
const GUARD: f32 = 4.0;

/// The G-buffer, one entry per pixel (row-major, y down). Uncovered pixels have
/// `tri == NO_HIT`.
#[derive(Clone, Debug, Default)]
pub struct GBuffer {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Triangle seen at each pixel ([`NO_HIT`] where uncovered).
    pub tri: Vec<u32>,
    /// Barycentrics (u, v) of vertices 1 and 2 of `tri`.
    pub bary: Vec<[f32; 2]>,
    /// 1 / camera-space depth (larger is closer; 0 where uncovered).
    pub inv_depth: Vec<f32>,
    /// World-space surface point.
    pub position: Vec<Vec3>,
    /// Unit interpolated shading normal.
    pub normal: Vec<Vec3>,
    /// Diffuse colour of the surface's material.
    pub diffuse: Vec<Vec3>,
    /// Specular colour and shininess.
    pub specular: Vec<[f32; 4]>,
}

impl GBuffer {
    /// Pixels that see a triangle.
    pub fn covered(&self) -> usize {
        self.tri.iter().filter(|&&t| t != NO_HIT).count()
    }
}

/// Counters of one rasterization.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct RasterStats {
    /// Triangles submitted.
    pub triangles: u64,
    /// Screen-space triangles after clipping (a clipped triangle may become several).
    pub setup: u64,
    /// (tile, triangle) pairs after binning.
    pub bin_entries: u64,
    /// Pixels whose centre was tested against a triangle.
    pub pixel_tests: u64,
    /// Fragments that passed coverage and depth and were written.
    pub fragments: u64,
}

/// A clip-space vertex: camera-space position and barycentrics in the source triangle.
#[derive(Clone, Copy, Debug)]
struct CVert {
    c: Vec3,
    uv: [f32; 2],
}

/// A screen-space triangle ready for tile rasterization.
#[derive(Clone, Copy, Debug)]
struct Setup {
    tri: u32,
    x: [i64; 3],
    y: [i64; 3],
    inv_z: [f32; 3],
    uv: [[f32; 2]; 3],
    area: i64,
    /// Inclusive pixel bounds (x0, y0, x1, y1).
    bbox: [i32; 4],
}

/// Signed distances of a camera-space point to the five clip planes (inside ≥ 0).
#[inline(always)]
fn plane_dist(view: &View, near: f32, c: Vec3, k: usize) -> f32 {
    match k {
        0 => c.z - near,
        1 => c.x / view.tan_x + GUARD * c.z,
        2 => GUARD * c.z - c.x / view.tan_x,
        3 => c.y / view.tan_y + GUARD * c.z,
        _ => GUARD * c.z - c.y / view.tan_y,
    }
}

/// Clip a polygon against one plane. Intersections are computed from the endpoints in a
/// canonical order, so the two triangles sharing a clipped edge get bit-identical vertices.
/// The most vertices a clipped triangle can have: a convex polygon gains at most one
/// vertex per plane, so a triangle clipped by the five planes has at most 8 (one spare).
const MAX_POLY: usize = 9;

/// Clip a polygon against one plane into `out`, returning its vertex count. Intersections
/// are computed from the endpoints in a canonical order, so the two triangles sharing a
/// clipped edge get bit-identical vertices.
fn clip_plane(
    view: &View,
    near: f32,
    poly: &[CVert],
    k: usize,
    out: &mut [CVert; MAX_POLY],
) -> usize {
    let mut m = 0;
    let n = poly.len();
    for i in 0..n {
        let a = poly[i];
        let b = poly[(i + 1) % n];
        let da = plane_dist(view, near, a.c, k);
        let db = plane_dist(view, near, b.c, k);
        if da >= 0.0 {
            out[m] = a;
            m += 1;
        }
        if (da >= 0.0) != (db >= 0.0) {
            let swap = (a.c.x, a.c.y, a.c.z).partial_cmp(&(b.c.x, b.c.y, b.c.z))
                == Some(std::cmp::Ordering::Greater);
            let (p, q, dp, dq) = if swap { (b, a, db, da) } else { (a, b, da, db) };
            let t = dp / (dp - dq);
            out[m] = CVert {
                c: p.c + (q.c - p.c) * t,
                uv: [
                    p.uv[0] + (q.uv[0] - p.uv[0]) * t,
                    p.uv[1] + (q.uv[1] - p.uv[1]) * t,
                ],
            };
            m += 1;
        }
    }
    m
}

/// Edge function of edge a→b at p (twice the signed area of (a, b, p)), exact in i64.
#[inline]
fn edge(ax: i64, ay: i64, bx: i64, by: i64, px: i64, py: i64) -> i64 {
    (bx - ax) * (py - ay) - (by - ay) * (px - ax)
}

/// Top-left rule for positively oriented triangles (y down): an edge owns the pixels exactly
/// on it iff it is a left edge (dy < 0) or a top edge (dy = 0, dx > 0).
#[inline]
fn top_left(ax: i64, ay: i64, bx: i64, by: i64) -> bool {
    let (dx, dy) = (bx - ax, by - ay);
    dy < 0 || (dy == 0 && dx > 0)
}

/// Set up a triangle the clip test kept ([`cull::cull_group`]): camera-space vertices `c`,
/// `inside_all` when no clip plane cuts it.
fn setup_triangle(
    view: &View,
    near: f32,
    id: u32,
    c: [Vec3; 3],
    inside_all: bool,
    out: &mut Vec<Setup>,
) {
    let verts = [
        CVert {
            c: c[0],
            uv: [0.0, 0.0],
        },
        CVert {
            c: c[1],
            uv: [1.0, 0.0],
        },
        CVert {
            c: c[2],
            uv: [0.0, 1.0],
        },
    ];
    // The polygon lives on the stack, clipped back and forth between two buffers.
    let zero = CVert {
        c: Vec3::ZERO,
        uv: [0.0; 2],
    };
    let mut bufs = [[zero; MAX_POLY]; 2];
    bufs[0][..3].copy_from_slice(&verts);
    let (mut cur, mut len) = (0, 3);
    if !inside_all {
        for k in 0..5 {
            let [a, b] = &mut bufs;
            let (src, dst) = if cur == 0 { (a, b) } else { (b, a) };
            len = clip_plane(view, near, &src[..len], k, dst);
            cur ^= 1;
            if len < 3 {
                return;
            }
        }
    }
    let poly = &bufs[cur][..len];
    let (w, h) = (view.width as i32, view.height as i32);
    let mut snapped = [(0i64, 0i64, 0f32); MAX_POLY];
    for (dst, v) in snapped.iter_mut().zip(poly) {
        *dst = {
            // In f64: the snap, not the projection, should be the only rounding that matters.
            let (cx, cy, cz) = (v.c.x as f64, v.c.y as f64, v.c.z as f64);
            let sx = (cx / cz / view.tan_x as f64 + 1.0) * 0.5 * view.width as f64;
            let sy = (1.0 - cy / cz / view.tan_y as f64) * 0.5 * view.height as f64;
            // A jittered view samples at centre + jitter: the same as moving the triangle
            // by −jitter (zero for the centre, which leaves every bit as it was).
            let (sx, sy) = (sx - view.jitter[0] as f64, sy - view.jitter[1] as f64);
            (
                (sx * SUB as f64).round() as i64,
                (sy * SUB as f64).round() as i64,
                1.0 / v.c.z,
            )
        };
    }
    for i in 1..poly.len() - 1 {
        let mut idx = [0, i, i + 1];
        let p = |j: usize| snapped[idx[j]];
        let mut area = edge(p(0).0, p(0).1, p(1).0, p(1).1, p(2).0, p(2).1);
        if area == 0 {
            continue;
        }
        if area < 0 {
            idx.swap(1, 2);
            area = -area;
        }
        let x = [snapped[idx[0]].0, snapped[idx[1]].0, snapped[idx[2]].0];
        let y = [snapped[idx[0]].1, snapped[idx[1]].1, snapped[idx[2]].1];
        // Pixel centres sit at k·SUB + SUB/2.
        let lo = |m: i64| (m - SUB / 2 + SUB - 1).div_euclid(SUB) as i32;
        let hi = |m: i64| (m - SUB / 2).div_euclid(SUB) as i32;
        let bbox = [
            lo(*x.iter().min().unwrap()).max(0),
            lo(*y.iter().min().unwrap()).max(0),
            hi(*x.iter().max().unwrap()).min(w - 1),
            hi(*y.iter().max().unwrap()).min(h - 1),
        ];
        if bbox[0] > bbox[2] || bbox[1] > bbox[3] {
            continue;
        }
        out.push(Setup {
            tri: id,
            x,
            y,
            inv_z: [snapped[idx[0]].2, snapped[idx[1]].2, snapped[idx[2]].2],
            uv: [poly[idx[0]].uv, poly[idx[1]].uv, poly[idx[2]].uv],
            area,
            bbox,
        });
    }
}

/// Triangles per setup piece (each piece's screen triangles go to its own kept vector).
const SETUP_PIECE: usize = 4096;

/// The rasterizer's scratch, kept from one frame to the next (the renderer's
/// `FrameArena`): the pieces' screen triangles, the binned lists and their counts.
#[derive(Default)]
pub struct RasterScratch {
    pieces: Vec<Vec<Setup>>,
    setups: Vec<Setup>,
    counts: Vec<u32>,
    offsets: Vec<u32>,
    lists: Vec<u32>,
}

/// Rasterize one tile into its local z-buffer (`tri`, `bary`, `inv_z`, TILE × TILE, row by
/// row): the triangles of `list` in order. Returns (pixel tests, fragments).
#[allow(clippy::too_many_arguments)]
fn raster_tile(
    view: &View,
    tx: u32,
    ty: u32,
    setups: &[Setup],
    list: &[u32],
    tri: &mut [u32],
    bary: &mut [[f32; 2]],
    inv_z: &mut [f32],
) -> (u64, u64) {
    tri.fill(NO_HIT);
    bary.fill([0.0; 2]);
    inv_z.fill(0.0);
    let (mut pixel_tests, mut fragments) = (0u64, 0u64);
    let x0 = (tx * TILE) as i32;
    let y0 = (ty * TILE) as i32;
    let x1 = (x0 + TILE as i32 - 1).min(view.width as i32 - 1);
    let y1 = (y0 + TILE as i32 - 1).min(view.height as i32 - 1);
    for &si in list {
        let s = &setups[si as usize];
        let (bx0, by0) = (s.bbox[0].max(x0), s.bbox[1].max(y0));
        let (bx1, by1) = (s.bbox[2].min(x1), s.bbox[3].min(y1));
        let [ax, bx, cx] = s.x;
        let [ay, by, cy] = s.y;
        // Bias: pixels exactly on a non-owning edge are excluded.
        let b0 = if top_left(bx, by, cx, cy) { 0 } else { -1 };
        let b1 = if top_left(cx, cy, ax, ay) { 0 } else { -1 };
        let b2 = if top_left(ax, ay, bx, by) { 0 } else { -1 };
        let inv_area = 1.0 / s.area as f64;
        if bx0 > bx1 || by0 > by1 {
            continue;
        }
        // Edge functions stepped across a row: one pixel to the right changes edge a→b by
        // −(by − ay)·SUB, exactly (integers), so each pixel's values are the ones the
        // direct formula gives. Each row visits only the span where all three can pass,
        // found exactly by integer division (the pixels left out would fail a test).
        let (d0, d1, d2) = ((cy - by) * SUB, (ay - cy) * SUB, (by - ay) * SUB);
        let last = (bx1 - bx0) as i64;
        for py in by0..=by1 {
            let sy = py as i64 * SUB + SUB / 2;
            let sx0 = bx0 as i64 * SUB + SUB / 2;
            let start = [
                edge(bx, by, cx, cy, sx0, sy),
                edge(cx, cy, ax, ay, sx0, sy),
                edge(ax, ay, bx, by, sx0, sy),
            ];
            let Some((lo, hi)) = span(
                [start[0] + b0, start[1] + b1, start[2] + b2],
                [d0, d1, d2],
                last,
            ) else {
                continue;
            };
            pixel_tests += (hi - lo + 1) as u64;
            let (mut e0, mut e1, mut e2) = (
                start[0] - (lo - 1) * d0,
                start[1] - (lo - 1) * d1,
                start[2] - (lo - 1) * d2,
            );
            for px in bx0 + lo as i32..=bx0 + hi as i32 {
                e0 -= d0;
                e1 -= d1;
                e2 -= d2;
                if e0 + b0 < 0 || e1 + b1 < 0 || e2 + b2 < 0 {
                    continue;
                }
                // Screen-space barycentrics, then perspective correction with 1/z.
                let l = [
                    e0 as f64 * inv_area,
                    e1 as f64 * inv_area,
                    e2 as f64 * inv_area,
                ];
                let lz = [
                    l[0] * s.inv_z[0] as f64,
                    l[1] * s.inv_z[1] as f64,
                    l[2] * s.inv_z[2] as f64,
                ];
                let iz = lz[0] + lz[1] + lz[2];
                let k = ((py - y0) as u32 * TILE + (px - x0) as u32) as usize;
                let izf = iz as f32;
                if izf > inv_z[k] || (izf == inv_z[k] && s.tri < tri[k]) {
                    let w = [lz[0] / iz, lz[1] / iz, lz[2] / iz];
                    let u = w[0] * s.uv[0][0] as f64
                        + w[1] * s.uv[1][0] as f64
                        + w[2] * s.uv[2][0] as f64;
                    let v = w[0] * s.uv[0][1] as f64
                        + w[1] * s.uv[1][1] as f64
                        + w[2] * s.uv[2][1] as f64;
                    inv_z[k] = izf;
                    tri[k] = s.tri;
                    bary[k] = [u as f32, v as f32];
                    fragments += 1;
                }
            }
        }
    }
    (pixel_tests, fragments)
}

/// The pixels k ∈ 0..=last of a row where every edge value e_i − k·d_i (biased by its
/// fill rule, `e`) is non-negative: exact integer bounds, `None` when there are none.
#[inline]
fn span(e: [i64; 3], d: [i64; 3], last: i64) -> Option<(i64, i64)> {
    let (mut lo, mut hi) = (0i64, last);
    for i in 0..3 {
        match d[i].cmp(&0) {
            std::cmp::Ordering::Greater => hi = hi.min(floor_div_capped(e[i], d[i], last)),
            // k·(−d) ≥ −e: k ≥ ⌈−e / −d⌉ = −⌊e / −d⌋.
            std::cmp::Ordering::Less => lo = lo.max(-floor_div_capped(e[i], -d[i], last)),
            std::cmp::Ordering::Equal if e[i] < 0 => return None,
            std::cmp::Ordering::Equal => {}
        }
    }
    (lo <= hi).then_some((lo, hi))
}

/// ⌊e / d⌋ for d > 0, clamped to [−cap − 1, cap] (a span needs no more: its pixels are
/// 0..=cap), exactly, without a 64-bit integer division (the row loop's costliest
/// instruction): within the clamp the quotient is small, so f64's estimate is off by at
/// most one near an integer, and the integer products correct it.
#[inline]
fn floor_div_capped(e: i64, d: i64, cap: i64) -> i64 {
    debug_assert!(d > 0 && (0..=TILE as i64).contains(&cap));
    // cap · d and (cap + 1) · d stay far inside i64: d < 2^59 / 2^5 by the snapping bound.
    if e >= cap * d {
        return cap;
    }
    if e < -(cap + 1) * d {
        return -cap - 1;
    }
    let mut q = (e as f64 / d as f64) as i64;
    while q * d > e {
        q -= 1;
    }
    while (q + 1) * d <= e {
        q += 1;
    }
    q
}

/// Rasterize `geo` into a G-buffer. `near` is the near-plane distance (geometry closer to the
/// eye is clipped).
pub fn rasterize(
    geo: &Geometry,
    materials: &[Material],
    view: &View,
    near: f32,
) -> (GBuffer, RasterStats) {
    let mut gb = GBuffer::default();
    let st = rasterize_into(
        geo,
        materials,
        view,
        near,
        &mut gb,
        &mut RasterScratch::default(),
    );
    (gb, st)
}

/// [`rasterize`] into `gb`'s buffers with `scratch` (both kept from the last frame: no
/// allocation and no fresh pages once they are large enough). Every pass is parallel:
/// setup over pieces of triangles, binning by piece (count → scan → stable scatter), tiles
/// by rows of tiles writing their rows of the G-buffer, resolve by rows.
pub fn rasterize_into(
    geo: &Geometry,
    materials: &[Material],
    view: &View,
    near: f32,
    gb: &mut GBuffer,
    scratch: &mut RasterScratch,
) -> RasterStats {
    // 1. Setup, in triangle order: each piece into its own kept vector, then gathered; the
    // clip planes' verdicts in lanes first, as most triangles of a view leave there.
    let isa = geom::Isa::best();
    let npieces = geo.tris.len().div_ceil(SETUP_PIECE);
    scratch.pieces.resize_with(npieces, Vec::new);
    scratch
        .pieces
        .par_iter_mut()
        .zip(geo.tris.par_chunks(SETUP_PIECE))
        .enumerate()
        .for_each(|(p, (out, tris))| {
            out.clear();
            for (g, group) in tris.chunks(cull::LANES).enumerate() {
                let v = cull::cull_group(view, near, group, isa);
                for k in 0..group.len() {
                    if v.keep[k] {
                        let id = (p * SETUP_PIECE + g * cull::LANES + k) as u32;
                        setup_triangle(view, near, id, v.vertex(k), v.inside[k], out);
                    }
                }
            }
        });
    let setups = &mut scratch.setups;
    setups.clear();
    for piece in &scratch.pieces {
        setups.extend_from_slice(piece);
    }
    let setups = &scratch.setups;
    // 2. Binning: per piece of setups, count per tile → exclusive scan in (tile, piece)
    // order → each piece scatters its own entries, so every tile lists its triangles in
    // id order.
    let tiles_x = view.width.div_ceil(TILE);
    let tiles_y = view.height.div_ceil(TILE);
    let ntiles = (tiles_x * tiles_y) as usize;
    let tile_range = |s: &Setup| {
        (
            s.bbox[0] as u32 / TILE,
            s.bbox[1] as u32 / TILE,
            s.bbox[2] as u32 / TILE,
            s.bbox[3] as u32 / TILE,
        )
    };
    let bin_piece = SETUP_PIECE;
    let nbins = setups.len().div_ceil(bin_piece).max(1);
    let counts = &mut scratch.counts;
    counts.clear();
    counts.resize(nbins * ntiles, 0);
    counts
        .par_chunks_mut(ntiles)
        .zip(setups.par_chunks(bin_piece.max(1)))
        .for_each(|(count, part)| {
            for s in part {
                let (a, b, c, d) = tile_range(s);
                for ty in b..=d {
                    for tx in a..=c {
                        count[(ty * tiles_x + tx) as usize] += 1;
                    }
                }
            }
        });
    // offsets[t · nbins + b]: where piece b's entries of tile t start; tile t's list is
    // offsets[t · nbins] .. offsets[(t + 1) · nbins].
    let offsets = &mut scratch.offsets;
    offsets.clear();
    offsets.resize(ntiles * nbins + 1, 0);
    let mut run = 0u32;
    for t in 0..ntiles {
        for b in 0..nbins {
            offsets[t * nbins + b] = run;
            run += counts[b * ntiles + t];
        }
    }
    offsets[ntiles * nbins] = run;
    let lists = &mut scratch.lists;
    lists.clear();
    lists.resize(run as usize, 0);
    {
        // Each piece writes disjoint ranges of `lists` (its own runs of every tile).
        let shared = SharedSlice(lists.as_mut_ptr());
        let offsets = &*offsets;
        setups
            .par_chunks(bin_piece.max(1))
            .enumerate()
            .for_each(|(b, part)| {
                let shared = &shared;
                let mut cursor: Vec<u32> = (0..ntiles).map(|t| offsets[t * nbins + b]).collect();
                for (k, s) in part.iter().enumerate() {
                    let si = (b * bin_piece + k) as u32;
                    let (a, bb, c, d) = tile_range(s);
                    for ty in bb..=d {
                        for tx in a..=c {
                            let t = (ty * tiles_x + tx) as usize;
                            // SAFETY: piece b owns offsets[t·nbins + b] .. + its count in
                            // tile t, and writes each index of that range once.
                            unsafe { shared.0.add(cursor[t] as usize).write(si) };
                            cursor[t] += 1;
                        }
                    }
                }
            });
    }
    let lists = &scratch.lists;
    // 3. Tiles, a row of tiles per task, each writing its rows of the G-buffer.
    let (w, h) = (view.width as usize, view.height as usize);
    gb.width = view.width;
    gb.height = view.height;
    gb.inv_depth.resize(w * h, 0.0);
    gb.tri.resize(w * h, NO_HIT);
    gb.bary.resize(w * h, [0.0; 2]);
    let rows = TILE as usize * w;
    let counted: Vec<(u64, u64)> = gb
        .tri
        .par_chunks_mut(rows)
        .zip(gb.bary.par_chunks_mut(rows))
        .zip(gb.inv_depth.par_chunks_mut(rows))
        .enumerate()
        .map(|(ty, ((tri, bary), inv_z))| {
            const N: usize = (TILE * TILE) as usize;
            // The tile's own z-buffer, on the stack (no allocation per frame).
            let (mut lt, mut lb, mut lz) = ([NO_HIT; N], [[0.0f32; 2]; N], [0.0f32; N]);
            let mut sum = (0, 0);
            for tx in 0..tiles_x {
                let t = ty * tiles_x as usize + tx as usize;
                let list = &lists[offsets[t * nbins] as usize..offsets[(t + 1) * nbins] as usize];
                let c = raster_tile(view, tx, ty as u32, setups, list, &mut lt, &mut lb, &mut lz);
                sum = (sum.0 + c.0, sum.1 + c.1);
                for ly in 0..TILE as usize {
                    let y = ty * TILE as usize + ly;
                    if y >= h {
                        break;
                    }
                    let x0 = (tx * TILE) as usize;
                    let len = (TILE as usize).min(w - x0);
                    let (dst, src) = (ly * w + x0, ly * TILE as usize);
                    tri[dst..dst + len].copy_from_slice(&lt[src..src + len]);
                    bary[dst..dst + len].copy_from_slice(&lb[src..src + len]);
                    inv_z[dst..dst + len].copy_from_slice(&lz[src..src + len]);
                }
            }
            sum
        })
        .collect();
    let stats = RasterStats {
        triangles: geo.len() as u64,
        setup: setups.len() as u64,
        bin_entries: lists.len() as u64,
        pixel_tests: counted.iter().map(|c| c.0).sum(),
        fragments: counted.iter().map(|c| c.1).sum(),
    };
    // 4. Resolve the surface attributes, one pass writing all four arrays (every pixel:
    // the buffers may hold the last frame's values).
    gb.position.resize(w * h, Vec3::ZERO);
    gb.normal.resize(w * h, Vec3::ZERO);
    gb.diffuse.resize(w * h, Vec3::ZERO);
    gb.specular.resize(w * h, [0.0; 4]);
    let (tri, bary) = (&gb.tri, &gb.bary);
    gb.position
        .par_chunks_mut(w)
        .zip(gb.normal.par_chunks_mut(w))
        .zip(gb.diffuse.par_chunks_mut(w))
        .zip(gb.specular.par_chunks_mut(w))
        .enumerate()
        .for_each(|(y, (((pos, nrm), dif), spe))| {
            for x in 0..w {
                let t = tri[y * w + x];
                if t == NO_HIT {
                    pos[x] = Vec3::ZERO;
                    nrm[x] = Vec3::ZERO;
                    dif[x] = Vec3::ZERO;
                    spe[x] = [0.0; 4];
                    continue;
                }
                let [u, v] = bary[y * w + x];
                let m = &materials[geo.material[t as usize] as usize];
                pos[x] = geo.point(t, u, v);
                nrm[x] = geo.shading_normal(t, u, v);
                dif[x] = m.diffuse;
                spe[x] = [m.specular.x, m.specular.y, m.specular.z, m.shininess];
            }
        });
    stats
}

/// A pointer the binning's pieces write through, each to its own indices.
struct SharedSlice(*mut u32);
// SAFETY: the pieces write disjoint indices (see the binning above).
unsafe impl Sync for SharedSlice {}

/// A near-plane distance suited to the scene: small against its size, never zero.
pub fn default_near(geo: &Geometry) -> f32 {
    (geo.bounds.diagonal() * 1e-5).max(1e-6)
}

#[cfg(test)]
mod tests;
