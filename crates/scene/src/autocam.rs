//! The automatic camera and light of a scene file that brings none (a bare OBJ or glTF, a
//! TOML file without `[camera]`), and the ambient fill such scenes get.
//!
//! A model seen from outside is framed from a three-quarter view ([`Camera::framing`]). An
//! enclosed model (an atrium, a room) would then show only its outer walls, so the camera
//! first looks for a place *inside*: it casts a few rays from candidate points on a grid in
//! the scene's box (eight horizontal directions, up and down). A model open on one side (a
//! third of the candidates see out one way, none the three opposite ways) is framed from outside,
//! through its opening; otherwise the candidates that are
//! enclosed: the floor below, walls in all eight horizontal directions, and most of
//! those surfaces facing the point (inside a closed solid such as the bunny they face away,
//! so a solid is still framed from outside). Among them it takes the most open one (the
//! largest geometric mean of the horizontal free distances), backs the eye up towards the
//! wall behind and looks along the longest free direction, slightly down. The light hangs
//! above the eye, below the ceiling.
//!
//! The rays are brute force over the triangles in cache-sized chunks (a few hundred rays;
//! Conference's 278 k triangles in a fraction of a second on two cores) with the shared
//! watertight kernel ([`geom::tri::intersect`]).

use crate::model::{Camera, Light, Scene};
use geom::tri::{geometric_normal, intersect, RayPre};
use geom::{Ray, Vec3};
use rayon::prelude::*;

/// Candidate points per horizontal axis of the box, and their heights (fractions of it).
const GRID: [f32; 3] = [0.25, 0.5, 0.75];
const HEIGHTS: [f32; 2] = [0.2, 0.35];
/// Horizontal directions cast from each candidate (every 45°), then up and down.
const HORIZONTAL: usize = 8;
/// Scenes above this many triangles are framed from outside without the search (its brute
/// force would take seconds).
const MAX_SEARCH_TRIANGLES: usize = 4_000_000;

/// The automatic light's intensity inside a model: with the fill, a white diffuse
/// surface facing it stays below 1 (the sRGB clamp).
const INTERIOR_LIGHT: f32 = 0.75;

/// The ambient light of the fill ([`apply_fill`]): grey, a quarter of the automatic light.
pub const FILL: f32 = 0.25;

/// The nearest hit of a ray: its distance and whether the surface faces the ray's origin.
#[derive(Clone, Copy, Debug)]
struct Probe {
    t: f32,
    front: bool,
}

/// Nearest hits of `rays` against every triangle of `tris` (None: a miss): by brute force
/// below [`CULLED_FROM`] triangles, else through boxes of Morton-ordered triangle runs.
fn probe(tris: &[[Vec3; 3]], rays: &[Ray]) -> Vec<Option<Probe>> {
    if tris.len() < CULLED_FROM {
        probe_all(tris, rays)
    } else {
        probe_culled(tris, rays)
    }
}

/// From this many triangles the probes skip runs of triangles by their boxes: 180 rays
/// against every triangle of a 2 M-triangle OBJ took 3.5 s of its load.
const CULLED_FROM: usize = 1 << 16;
/// Triangles per run.
const RUN: usize = 32;

/// [`probe_all`]'s answers, each ray testing only the runs (of [`RUN`] triangles, in Morton
/// order of their centroids) whose box it enters before its nearest hit so far. A tie in t
/// goes to the lower triangle index, as in the brute-force scan, so the answers are the same;
/// the box test is conservative (robust slab test, boxes padded, the distance bound loosened
/// by 1e-5), so no nearer hit is skipped.
fn probe_culled(tris: &[[Vec3; 3]], rays: &[Ray]) -> Vec<Option<Probe>> {
    let bounds = geom::Aabb::from_points(tris.iter().flatten().copied());
    let mut order: Vec<(u64, u32)> = tris
        .par_iter()
        .enumerate()
        .map(|(i, t)| {
            (
                geom::morton::morton((t[0] + t[1] + t[2]) / 3.0, &bounds, 10),
                i as u32,
            )
        })
        .collect();
    order.par_sort_unstable();
    let pad = Vec3::splat(bounds.diagonal() * 1e-6);
    // The triangles in that order (with their indices), so that a run is read in one go.
    let sorted: Vec<([Vec3; 3], u32)> = order
        .par_iter()
        .map(|&(_, i)| (tris[i as usize], i))
        .collect();
    drop(order);
    let boxes: Vec<geom::Aabb> = sorted
        .par_chunks(RUN)
        .map(|run| {
            let b = geom::Aabb::from_points(run.iter().flat_map(|(t, _)| *t));
            geom::Aabb::new(b.min - pad, b.max + pad)
        })
        .collect();
    let pre: Vec<(RayPre, Vec3)> = rays
        .iter()
        .map(|r| (RayPre::new(r), r.dir.recip()))
        .collect();
    type Best = Option<(f32, u32, bool)>;
    let nearer = |a: Best, b: Best| match (a, b) {
        (Some(x), Some(y)) => Some(if (y.0, y.1) < (x.0, x.1) { y } else { x }),
        (x, y) => x.or(y),
    };
    // Runs in parallel blocks (as the brute-force scan takes chunks), each ray skipping the
    // runs whose box it does not enter before its nearest hit in the block so far.
    let best = (0..boxes.len())
        .into_par_iter()
        .with_min_len(256)
        .fold(
            || vec![None; rays.len()],
            |mut acc: Vec<Best>, k| {
                let run = &sorted[k * RUN..((k + 1) * RUN).min(sorted.len())];
                for ((b, (p, inv)), ray) in acc.iter_mut().zip(&pre).zip(rays) {
                    let bound = b.map_or(f32::INFINITY, |(t, _, _)| t * (1.0 + 1e-5));
                    if boxes[k].intersect(ray.org, *inv, 0.0, bound).is_none() {
                        continue;
                    }
                    for (t, i) in run {
                        if let Some(h) = intersect(p, t[0], t[1], t[2]) {
                            if b.is_none_or(|(bt, bi, _)| (h.t, *i) < (bt, bi)) {
                                let n = geometric_normal(t[0], t[1], t[2]);
                                *b = Some((h.t, *i, n.dot(ray.dir) < 0.0));
                            }
                        }
                    }
                }
                acc
            },
        )
        .reduce(
            || vec![None; rays.len()],
            |a, b| a.into_iter().zip(b).map(|(x, y)| nearer(x, y)).collect(),
        );
    best.into_iter()
        .map(|b| b.map(|(t, _, front)| Probe { t, front }))
        .collect()
}

/// Nearest hits of `rays` against every triangle of `tris` (None: a miss).
fn probe_all(tris: &[[Vec3; 3]], rays: &[Ray]) -> Vec<Option<Probe>> {
    let pre: Vec<RayPre> = rays.iter().map(RayPre::new).collect();
    let best = |mut acc: Vec<Option<Probe>>, chunk: &[[Vec3; 3]]| {
        for (r, (p, ray)) in acc.iter_mut().zip(pre.iter().zip(rays)) {
            for t in chunk {
                if let Some(h) = intersect(p, t[0], t[1], t[2]) {
                    if r.is_none_or(|b| h.t < b.t) {
                        let n = geometric_normal(t[0], t[1], t[2]);
                        *r = Some(Probe {
                            t: h.t,
                            front: n.dot(ray.dir) < 0.0,
                        });
                    }
                }
            }
        }
        acc
    };
    let merge = |a: Vec<Option<Probe>>, b: Vec<Option<Probe>>| {
        a.into_iter()
            .zip(b)
            .map(|(x, y)| match (x, y) {
                (Some(x), Some(y)) => Some(if y.t < x.t { y } else { x }),
                (x, y) => x.or(y),
            })
            .collect()
    };
    tris.par_chunks(4096)
        .fold(|| vec![None; rays.len()], best)
        .reduce(|| vec![None; rays.len()], merge)
}

/// The unit horizontal direction k of [`HORIZONTAL`] (k · 45° from +x, in the xz plane).
fn horizontal(k: usize) -> Vec3 {
    let a = k as f32 * std::f32::consts::TAU / HORIZONTAL as f32;
    Vec3::new(a.cos(), 0.0, a.sin())
}

/// An interior view of `tris` (the scene's world-space triangles), if the model encloses a
/// place to stand: the camera and the light's position.
pub fn interior(tris: &[[Vec3; 3]], bounds: &geom::Aabb) -> Option<(Camera, Vec3)> {
    if tris.len() > MAX_SEARCH_TRIANGLES || bounds.is_empty() {
        return None;
    }
    let e = bounds.extent();
    let mut points = Vec::new();
    for &hy in &HEIGHTS {
        for &fx in &GRID {
            for &fz in &GRID {
                points.push(bounds.min + e * Vec3::new(fx, hy, fz));
            }
        }
    }
    let per = HORIZONTAL + 2;
    let mut rays = Vec::with_capacity(points.len() * per);
    for &p in &points {
        for k in 0..HORIZONTAL {
            rays.push(Ray::new(p, horizontal(k), 0.0, f32::INFINITY));
        }
        rays.push(Ray::new(p, Vec3::Y, 0.0, f32::INFINITY));
        rays.push(Ray::new(p, -Vec3::Y, 0.0, f32::INFINITY));
    }
    let hits = probe(tris, &rays);
    let diag = bounds.diagonal().max(1e-6);
    // A model open on one side (a stage, McGuire's Cornell box) is shown through its
    // opening, from outside: a third of the candidates see out in one direction while
    // none sees out in the three opposite ones. (A room among other things, BART's kitchen,
    // lets rays out on every side.)
    let mut out = [0usize; HORIZONTAL];
    for h in hits.chunks(per) {
        for (k, o) in out.iter_mut().enumerate() {
            *o += h[k].is_none() as usize;
        }
    }
    let h = HORIZONTAL;
    let one_sided = (0..h).any(|k| {
        3 * out[k] >= points.len() && (h / 2 - 1..=h / 2 + 1).all(|o| out[(k + o) % h] == 0)
    });
    if one_sided {
        return None;
    }
    let mut best: Option<(f32, usize)> = None;
    for (i, h) in hits.chunks(per).enumerate() {
        let walls = h[..HORIZONTAL].iter().filter(|x| x.is_some()).count();
        let Some(down) = h[HORIZONTAL + 1] else {
            continue;
        };
        let all: Vec<Probe> = h.iter().flatten().copied().collect();
        let front = all.iter().filter(|x| x.front).count();
        // Too close to a surface to see anything (inside a column, under a table).
        let cramped = all.iter().any(|x| x.t < 0.01 * diag) || down.t < 0.02 * diag;
        if walls < HORIZONTAL || 2 * front < all.len() || cramped {
            continue;
        }
        let open = h[..HORIZONTAL]
            .iter()
            .map(|x| x.map_or(diag, |x| x.t).ln())
            .sum::<f32>();
        // A place to stand is a room of the model's size, not the inside of one of its
        // parts: the horizontal distances' geometric mean at least a tenth of the box's
        // diagonal.
        if open / (HORIZONTAL as f32) < (0.1 * diag).ln() {
            continue;
        }
        if best.is_none_or(|(b, _)| open > b) {
            best = Some((open, i));
        }
    }
    let (_, i) = best?;
    let h = &hits[i * per..(i + 1) * per];
    let p = points[i];
    let dist = |k: usize| h[k].map_or(diag, |x| x.t);
    let k = (0..HORIZONTAL)
        .max_by(|&a, &b| dist(a).total_cmp(&dist(b)))
        .expect("eight directions");
    let look = horizontal(k);
    // Back the eye up towards the wall behind, keeping a third of the way free.
    let back = dist((k + HORIZONTAL / 2) % HORIZONTAL);
    let eye = p - look * (0.66 * back);
    let ahead = dist(k) + 0.66 * back;
    let target = eye + (look - Vec3::Y * 0.15).normalize() * (0.5 * ahead);
    // The light hangs above the eye, halfway to the ceiling (or, under an open sky, a
    // quarter of the box's height up), so that what the camera sees is lit and its shadows
    // fall mostly behind what casts them.
    let up = probe(tris, &[Ray::new(eye, Vec3::Y, 0.0, f32::INFINITY)])[0];
    let light = eye + Vec3::Y * (0.5 * up.map_or(0.5 * e.y, |x| x.t));
    Some((
        Camera {
            eye,
            target,
            up: Vec3::Y,
            vfov: 60.0,
        },
        light,
    ))
}

/// Give `scene` an automatic camera (inside an enclosed model, else framing it from
/// outside) and one white light, and mark its lights as automatic.
pub fn auto_camera_and_light(scene: &mut Scene) {
    let b = scene.bounds();
    if b.is_empty() {
        return;
    }
    let tris: Vec<[Vec3; 3]> = scene
        .meshes
        .iter()
        .flat_map(|m| {
            m.triangles
                .iter()
                .map(move |t| t.map(|i| m.transform.transform_point3(m.positions[i as usize])))
        })
        .collect();
    match interior(&tris, &b) {
        Some((cam, light)) => {
            scene.camera = cam;
            scene.lights = vec![Light::white(light, INTERIOR_LIGHT)];
            scene
                .report
                .notes
                .push("automatic camera inside the model, and light".into());
        }
        None => {
            scene.camera = Camera::framing(&b);
            let (_, up, _) = scene.camera.basis();
            let pos = scene.camera.eye + up * b.diagonal() * 0.3;
            scene.lights = vec![Light::white(pos, 1.0)];
            scene.report.notes.push("automatic camera and light".into());
        }
    }
    scene.report.automatic_lights = true;
}

/// The ambient fill of a scene whose lights are automatic (or of any scene, when asked):
/// an ambient light of [`FILL`] grey, reflected by each material's diffuse colour where
/// the material has no ambient colour of its own, so that nothing a point light cannot see
/// is pure black. A scene that defines its own ambient light keeps it. Returns whether the
/// scene changed.
pub fn apply_fill(scene: &mut Scene) -> bool {
    if scene.ambient != Vec3::ZERO {
        return false;
    }
    scene.ambient = Vec3::splat(FILL);
    for m in &mut scene.materials {
        if m.ambient == Vec3::ZERO {
            m.ambient = m.diffuse;
        }
    }
    scene.report.notes.push(format!("ambient fill {FILL}"));
    true
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shapes;

    /// The triangles of a box from `lo` to `hi`, its faces turned inwards (a room) or
    /// outwards (a solid).
    fn boxed(lo: Vec3, hi: Vec3, inward: bool) -> Vec<[Vec3; 3]> {
        let m = shapes::cuboid("box", lo, hi, inward, 0);
        m.triangles
            .iter()
            .map(|t| t.map(|i| m.positions[i as usize]))
            .collect()
    }

    #[test]
    fn culled_probes_answer_as_brute_force() {
        let mut rng = geom::Pcg32::new(5, 1);
        // A soup of small triangles and a closed box around it (nearest hits at every
        // distance), with duplicated triangles (ties in t).
        let mut tris: Vec<[Vec3; 3]> = (0..20_000)
            .map(|_| {
                let c = Vec3::new(
                    rng.range(-4.0, 4.0),
                    rng.range(-1.0, 1.0),
                    rng.range(-4.0, 4.0),
                );
                [c, c + rng.unit_vector() * 0.2, c + rng.unit_vector() * 0.2]
            })
            .collect();
        tris.extend(boxed(Vec3::splat(-5.0), Vec3::splat(5.0), true));
        let dup: Vec<[Vec3; 3]> = tris[..500].iter().map(|t| [t[1], t[2], t[0]]).collect();
        tris.extend(dup);
        let rays: Vec<Ray> = (0..400)
            .map(|_| {
                let o = Vec3::new(
                    rng.range(-4.5, 4.5),
                    rng.range(-4.5, 4.5),
                    rng.range(-4.5, 4.5),
                );
                Ray::new(o, rng.unit_vector(), 0.0, f32::INFINITY)
            })
            .collect();
        let a = probe_all(&tris, &rays);
        let b = probe_culled(&tris, &rays);
        for (x, y) in a.iter().zip(&b) {
            assert_eq!(
                x.map(|p| (p.t.to_bits(), p.front)),
                y.map(|p| (p.t.to_bits(), p.front))
            );
        }
        assert!(a.iter().filter(|p| p.is_some()).count() > 390);
    }

    #[test]
    fn a_room_is_seen_from_inside_and_a_solid_from_outside() {
        let (lo, hi) = (Vec3::new(-4.0, 0.0, -1.0), Vec3::new(4.0, 3.0, 1.0));
        let b = geom::Aabb::new(lo, hi);
        let (cam, light) = interior(&boxed(lo, hi, true), &b).expect("a room");
        assert!(b.contains(cam.eye) && b.contains(light));
        // It looks along the room's long side (x).
        let f = (cam.target - cam.eye).normalize();
        assert!(f.x.abs() > 0.9, "{f}");
        assert!(
            interior(&boxed(lo, hi, false), &b).is_none(),
            "a closed solid"
        );
        // An open plane encloses nothing.
        let floor = vec![[lo, Vec3::new(hi.x, 0.0, lo.z), Vec3::new(lo.x, 0.0, hi.z)]];
        assert!(interior(&floor, &b).is_none());
    }
}
