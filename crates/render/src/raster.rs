//! A software rasterizer that fills the thesis's G-buffer (§3.1).
//!
//! Shaped like a hardware pipeline, one pass per function:
//! 1. **setup** (parallel over triangles): camera space, clipping against the near plane and a
//!    guard band (homogeneous Sutherland–Hodgman), projection, snapping to 12 sub-pixel bits;
//! 2. **binning** into 32×32 tiles by count → exclusive scan → scatter (stable, so each tile
//!    sees its triangles in id order);
//! 3. **tile rasterization** (parallel over tiles): integer edge functions with the top-left
//!    fill rule (no cracks, no double coverage on shared edges), perspective-correct
//!    barycentrics, a z-buffer on 1/z (ties keep the smaller triangle id, like closest-hit);
//! 4. **resolve** (parallel over pixels): position, normal, diffuse, specular/shininess from
//!    triangle id and barycentrics.

use geom::{Vec3, NO_HIT};
use rayon::prelude::*;
use scene::{Geometry, Material};

use crate::view::View;

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
#[inline]
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
fn clip_plane(view: &View, near: f32, poly: &[CVert], k: usize, out: &mut Vec<CVert>) {
    out.clear();
    let n = poly.len();
    for i in 0..n {
        let a = poly[i];
        let b = poly[(i + 1) % n];
        let da = plane_dist(view, near, a.c, k);
        let db = plane_dist(view, near, b.c, k);
        if da >= 0.0 {
            out.push(a);
        }
        if (da >= 0.0) != (db >= 0.0) {
            let swap = (a.c.x, a.c.y, a.c.z).partial_cmp(&(b.c.x, b.c.y, b.c.z))
                == Some(std::cmp::Ordering::Greater);
            let (p, q, dp, dq) = if swap { (b, a, db, da) } else { (a, b, da, db) };
            let t = dp / (dp - dq);
            out.push(CVert {
                c: p.c + (q.c - p.c) * t,
                uv: [
                    p.uv[0] + (q.uv[0] - p.uv[0]) * t,
                    p.uv[1] + (q.uv[1] - p.uv[1]) * t,
                ],
            });
        }
    }
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

fn setup_triangle(view: &View, near: f32, id: u32, t: &[Vec3; 3], out: &mut Vec<Setup>) {
    let verts = [
        CVert {
            c: view.to_camera(t[0]),
            uv: [0.0, 0.0],
        },
        CVert {
            c: view.to_camera(t[1]),
            uv: [1.0, 0.0],
        },
        CVert {
            c: view.to_camera(t[2]),
            uv: [0.0, 1.0],
        },
    ];
    let mut inside_all = true;
    for k in 0..5 {
        let d = verts.map(|v| plane_dist(view, near, v.c, k));
        if d.iter().all(|&x| x < 0.0) {
            return; // Entirely outside one plane.
        }
        inside_all &= d.iter().all(|&x| x >= 0.0);
    }
    let mut poly: Vec<CVert> = verts.to_vec();
    if !inside_all {
        let mut tmp = Vec::with_capacity(9);
        for k in 0..5 {
            clip_plane(view, near, &poly, k, &mut tmp);
            std::mem::swap(&mut poly, &mut tmp);
            if poly.len() < 3 {
                return;
            }
        }
    }
    let (w, h) = (view.width as i32, view.height as i32);
    let snapped: Vec<(i64, i64, f32)> = poly
        .iter()
        .map(|v| {
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
        })
        .collect();
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
        let x = idx.map(|j| snapped[j].0);
        let y = idx.map(|j| snapped[j].1);
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
            inv_z: idx.map(|j| snapped[j].2),
            uv: idx.map(|j| poly[j].uv),
            area,
            bbox,
        });
    }
}

/// Per-tile rasterization result (local z-buffer).
struct TileOut {
    tri: Vec<u32>,
    bary: Vec<[f32; 2]>,
    inv_z: Vec<f32>,
    pixel_tests: u64,
    fragments: u64,
}

fn raster_tile(view: &View, tx: u32, ty: u32, setups: &[Setup], list: &[u32]) -> TileOut {
    let n = (TILE * TILE) as usize;
    let mut o = TileOut {
        tri: vec![NO_HIT; n],
        bary: vec![[0.0; 2]; n],
        inv_z: vec![0.0; n],
        pixel_tests: 0,
        fragments: 0,
    };
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
        for py in by0..=by1 {
            let sy = py as i64 * SUB + SUB / 2;
            for px in bx0..=bx1 {
                let sx = px as i64 * SUB + SUB / 2;
                o.pixel_tests += 1;
                let e0 = edge(bx, by, cx, cy, sx, sy);
                let e1 = edge(cx, cy, ax, ay, sx, sy);
                let e2 = edge(ax, ay, bx, by, sx, sy);
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
                if izf > o.inv_z[k] || (izf == o.inv_z[k] && s.tri < o.tri[k]) {
                    let w = [lz[0] / iz, lz[1] / iz, lz[2] / iz];
                    let u = w[0] * s.uv[0][0] as f64
                        + w[1] * s.uv[1][0] as f64
                        + w[2] * s.uv[2][0] as f64;
                    let v = w[0] * s.uv[0][1] as f64
                        + w[1] * s.uv[1][1] as f64
                        + w[2] * s.uv[2][1] as f64;
                    o.inv_z[k] = izf;
                    o.tri[k] = s.tri;
                    o.bary[k] = [u as f32, v as f32];
                    o.fragments += 1;
                }
            }
        }
    }
    o
}

/// Rasterize `geo` into a G-buffer. `near` is the near-plane distance (geometry closer to the
/// eye is clipped).
pub fn rasterize(
    geo: &Geometry,
    materials: &[Material],
    view: &View,
    near: f32,
) -> (GBuffer, RasterStats) {
    // 1. Setup, in triangle order.
    let setups: Vec<Setup> = geo
        .tris
        .par_iter()
        .enumerate()
        .fold(Vec::new, |mut acc, (i, t)| {
            setup_triangle(view, near, i as u32, t, &mut acc);
            acc
        })
        .reduce(Vec::new, |mut a, b| {
            a.extend(b);
            a
        });
    // 2. Binning: count → exclusive scan → stable scatter.
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
    let mut count = vec![0u32; ntiles + 1];
    for s in &setups {
        let (a, b, c, d) = tile_range(s);
        for ty in b..=d {
            for tx in a..=c {
                count[(ty * tiles_x + tx) as usize] += 1;
            }
        }
    }
    let mut offset = vec![0u32; ntiles + 1];
    for i in 0..ntiles {
        offset[i + 1] = offset[i] + count[i];
    }
    let mut cursor = offset.clone();
    let mut lists = vec![0u32; offset[ntiles] as usize];
    for (si, s) in setups.iter().enumerate() {
        let (a, b, c, d) = tile_range(s);
        for ty in b..=d {
            for tx in a..=c {
                let t = (ty * tiles_x + tx) as usize;
                lists[cursor[t] as usize] = si as u32;
                cursor[t] += 1;
            }
        }
    }
    // 3. Tiles in parallel.
    let outs: Vec<TileOut> = (0..ntiles)
        .into_par_iter()
        .map(|t| {
            let (tx, ty) = (t as u32 % tiles_x, t as u32 / tiles_x);
            raster_tile(
                view,
                tx,
                ty,
                &setups,
                &lists[offset[t] as usize..offset[t + 1] as usize],
            )
        })
        .collect();
    let (w, h) = (view.width as usize, view.height as usize);
    let mut gb = GBuffer {
        width: view.width,
        height: view.height,
        tri: vec![NO_HIT; w * h],
        bary: vec![[0.0; 2]; w * h],
        inv_depth: vec![0.0; w * h],
        ..Default::default()
    };
    let mut stats = RasterStats {
        triangles: geo.len() as u64,
        setup: setups.len() as u64,
        bin_entries: lists.len() as u64,
        ..Default::default()
    };
    for (t, o) in outs.iter().enumerate() {
        let (tx, ty) = (t as u32 % tiles_x, t as u32 / tiles_x);
        stats.pixel_tests += o.pixel_tests;
        stats.fragments += o.fragments;
        for ly in 0..TILE {
            let y = ty * TILE + ly;
            if y >= view.height {
                break;
            }
            for lx in 0..TILE {
                let x = tx * TILE + lx;
                if x >= view.width {
                    break;
                }
                let (k, p) = ((ly * TILE + lx) as usize, (y * view.width + x) as usize);
                gb.tri[p] = o.tri[k];
                gb.bary[p] = o.bary[k];
                gb.inv_depth[p] = o.inv_z[k];
            }
        }
    }
    // 4. Resolve the surface attributes, one pass writing all four arrays.
    gb.position = vec![Vec3::ZERO; w * h];
    gb.normal = vec![Vec3::ZERO; w * h];
    gb.diffuse = vec![Vec3::ZERO; w * h];
    gb.specular = vec![[0.0; 4]; w * h];
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
    (gb, stats)
}

/// A near-plane distance suited to the scene: small against its size, never zero.
pub fn default_near(geo: &Geometry) -> f32 {
    (geo.bounds.diagonal() * 1e-5).max(1e-6)
}

#[cfg(test)]
mod tests {
    use super::*;
    use scene::Camera;

    fn quad_scene(tris: Vec<[Vec3; 3]>) -> Geometry {
        Geometry::soup(tris, Vec3::Z)
    }

    fn cam() -> Camera {
        Camera {
            eye: Vec3::new(0.0, 0.0, 5.0),
            target: Vec3::ZERO,
            up: Vec3::Y,
            vfov: 40.0,
        }
    }

    /// Two triangles sharing a diagonal cover every pixel of their square exactly once: no
    /// cracks, no double coverage (each covered pixel is written exactly once).
    #[test]
    fn shared_edges_no_cracks_no_overlap() {
        let a = Vec3::new(-1.0, -1.0, 0.0);
        let b = Vec3::new(1.0, -1.0, 0.0);
        let c = Vec3::new(1.0, 1.0, 0.0);
        let d = Vec3::new(-1.0, 1.0, 0.0);
        // A fan of 8 triangles around an off-centre point, all sharing edges.
        let m = Vec3::new(0.13, -0.07, 0.0);
        let e = Vec3::new(0.0, -1.0, 0.0);
        let f = Vec3::new(1.0, 0.0, 0.0);
        let g = Vec3::new(0.0, 1.0, 0.0);
        let h = Vec3::new(-1.0, 0.0, 0.0);
        let ring = [a, e, b, f, c, g, d, h];
        let tris: Vec<[Vec3; 3]> = (0..8).map(|i| [m, ring[i], ring[(i + 1) % 8]]).collect();
        let geo = quad_scene(tris);
        let view = View::new(&cam(), 97, 89);
        let (gb, st) = rasterize(&geo, &[Material::default()], &view, 1e-3);
        // Exactly one fragment per covered pixel: the fan has no overlaps.
        assert_eq!(st.fragments as usize, gb.covered());
        // Every pixel whose centre is strictly inside the square (by a margin) is covered.
        for y in 0..view.height {
            for x in 0..view.width {
                let r = view.primary_ray(x, y);
                let t = -r.org.z / r.dir.z;
                let p = r.at(t);
                let inside = p.x.abs() < 0.999 && p.y.abs() < 0.999;
                if inside {
                    assert_ne!(
                        gb.tri[(y * view.width + x) as usize],
                        NO_HIT,
                        "crack at {x},{y}"
                    );
                }
            }
        }
    }

    /// Perspective-correct barycentrics reproduce the world point under the pixel centre.
    #[test]
    fn perspective_correct_positions() {
        let tris = vec![[
            Vec3::new(-2.0, -1.0, -3.0),
            Vec3::new(2.0, -1.0, 1.0),
            Vec3::new(0.0, 2.0, -1.0),
        ]];
        let geo = quad_scene(tris);
        let view = View::new(&cam(), 64, 64);
        let (gb, _) = rasterize(&geo, &[Material::default()], &view, 1e-3);
        let mut n = 0;
        for y in 0..64 {
            for x in 0..64 {
                let p = (y * 64 + x) as usize;
                if gb.tri[p] == NO_HIT {
                    continue;
                }
                n += 1;
                // The G-buffer position lies on the pixel's primary ray.
                let r = view.primary_ray(x, y);
                let q = gb.position[p] - r.org;
                let off_ray = (q - r.dir * q.dot(r.dir)).length();
                assert!(off_ray < 2e-3, "pixel {x},{y}: {off_ray}");
            }
        }
        assert!(n > 300);
    }

    /// Geometry crossing the near plane and far outside the guard band is clipped, not lost.
    #[test]
    fn clipping_keeps_visible_parts() {
        // A huge floor under the camera, extending behind it and far to the sides.
        let s = 1e4;
        let tris = vec![
            [
                Vec3::new(-s, -1.0, s),
                Vec3::new(s, -1.0, s),
                Vec3::new(s, -1.0, -s),
            ],
            [
                Vec3::new(-s, -1.0, s),
                Vec3::new(s, -1.0, -s),
                Vec3::new(-s, -1.0, -s),
            ],
        ];
        let geo = quad_scene(tris);
        let cam = Camera {
            eye: Vec3::new(0.0, 0.0, 0.0),
            target: Vec3::new(0.0, -0.3, -1.0),
            up: Vec3::Y,
            vfov: 60.0,
        };
        let view = View::new(&cam, 80, 60);
        let (gb, st) = rasterize(&geo, &[Material::default()], &view, 1e-3);
        assert!(st.setup > 2, "the floor was clipped into several pieces");
        // Below the horizon every pixel sees the floor.
        for y in 0..60 {
            for x in 0..80 {
                let r = view.primary_ray(x, y);
                if r.dir.y < -0.01 {
                    assert_ne!(gb.tri[(y * 80 + x) as usize], NO_HIT, "{x},{y}");
                }
            }
        }
    }
}
