//! Generated scenes of any size, for the irregular-grid paper's scene classes (Pérard-Gayot
//! et al. 2017, §6 and Figure 8): named `generator:size[:seed]`, e.g. `hairball:2M`,
//! `city:500k:3`, `nested:10M`.
//!
//! - `hairball`: thin tangled tubes filling a ball, one mesh (the paper's Hairball, its
//!   hardest case: every ray meets many long thin triangles that overlap every cell).
//! - `city`: a city of separate tessellated buildings on a ground plane (many mid-size
//!   objects, like the paper's forest and San Miguel's clutter).
//! - `nested`: a stadium bowl with a 1/20-scale copy of itself in its field, three levels
//!   deep, and a knot in the innermost field: the "teapot in a stadium" of Figure 8, where
//!   equal triangle counts at every level make the density differ 8,000-fold.
//!
//! Sizes are triangle counts (`10000`, `250k`, `2M`, `2.5M`) from [`MIN_TRIANGLES`] to
//! [`MAX_TRIANGLES`]; the generated count is within a few per cent of the request. The same
//! spec gives the same triangles, bit for bit, on any number of threads: each object is
//! generated from its own random stream (`Pcg32::new(seed, object)`) into its own slice.

pub use crate::error::SpecError;
use crate::model::{smooth_normals, Camera, Light, LoadReport, Material, Mesh, Scene};
use crate::shapes::torus_knot;
use geom::{Mat4, Pcg32, Vec3};
use rayon::prelude::*;

/// The generators' names.
pub const NAMES: [&str; 3] = ["hairball", "city", "nested"];

/// The smallest size a generator accepts.
pub const MIN_TRIANGLES: u64 = 1_000;
/// The largest size a generator accepts (about 4.8 GB of scene model).
pub const MAX_TRIANGLES: u64 = 50_000_000;

/// A parsed generator spec.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Spec {
    /// Which generator ([`NAMES`]).
    pub generator: &'static str,
    /// Requested triangles.
    pub triangles: u64,
    /// Random seed (1 when not given).
    pub seed: u64,
}

impl Spec {
    /// `spec` as a generator spec: `None` when it does not name a generator (so it may be a
    /// file or another scene), `Some(Err(why))` when it names one but the rest is wrong.
    pub fn parse(spec: &str) -> Option<Result<Spec, SpecError>> {
        let mut parts = spec.split(':');
        let head = parts.next()?;
        let generator = *NAMES.iter().find(|n| **n == head)?;
        let rest: Vec<&str> = parts.collect();
        Some(Self::parse_rest(generator, &rest))
    }

    fn parse_rest(generator: &'static str, rest: &[&str]) -> Result<Spec, SpecError> {
        let (size, seed) = match rest {
            [size] => (*size, None),
            [size, seed] => (*size, Some(*seed)),
            _ => return Err(SpecError::Form(generator)),
        };
        let triangles = parse_size(size).ok_or_else(|| SpecError::Size {
            generator,
            size: size.to_string(),
        })?;
        if !(MIN_TRIANGLES..=MAX_TRIANGLES).contains(&triangles) {
            return Err(SpecError::Range {
                triangles,
                min: MIN_TRIANGLES,
                max: MAX_TRIANGLES,
            });
        }
        let seed = match seed {
            None => 1,
            Some(s) => s.parse::<u64>().map_err(|_| SpecError::Seed {
                generator,
                seed: s.to_string(),
            })?,
        };
        Ok(Spec {
            generator,
            triangles,
            seed,
        })
    }

    /// The name the generated scene goes by (also an output file's stem): `hairball-2M`.
    pub fn stem(spec: &str) -> String {
        spec.replace(':', "-")
    }

    /// Generate the scene.
    pub fn generate(&self) -> Scene {
        let n = self.triangles as usize;
        let mut scene = match self.generator {
            "hairball" => hairball(n, self.seed),
            "city" => city(n, self.seed),
            _ => nested(n, self.seed),
        };
        let got = scene.triangle_count();
        scene.report.notes.push(format!(
            "generated scene '{}': {got} triangles (requested {n}), seed {}",
            scene.name, self.seed
        ));
        scene
    }
}

/// `10000`, `250k`, `2M`, `2.5m` as a count (k = 10³, M = 10⁶).
fn parse_size(s: &str) -> Option<u64> {
    let (num, mult) = match s.char_indices().last()? {
        (i, 'k') | (i, 'K') => (&s[..i], 1e3),
        (i, 'm') | (i, 'M') => (&s[..i], 1e6),
        _ => (s, 1.0),
    };
    if num.is_empty() || !num.chars().all(|c| c.is_ascii_digit() || c == '.') {
        return None;
    }
    let v: f64 = num.parse().ok()?;
    let n = (v * mult).round();
    (n.is_finite() && n >= 0.0 && n <= u64::MAX as f64).then_some(n as u64)
}

fn generated(
    name: String,
    meshes: Vec<Mesh>,
    materials: Vec<Material>,
    lights: Vec<Light>,
    camera: Camera,
) -> Scene {
    Scene {
        id: crate::model::SceneId::fresh(),
        name,
        meshes,
        materials,
        lights,
        camera,
        background: Vec3::new(0.05, 0.06, 0.08),
        ambient: Vec3::splat(0.08),
        report: LoadReport::default(),
        animation: None,
    }
}

fn mesh(
    name: String,
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    triangles: Vec<[u32; 3]>,
    material: u32,
) -> Mesh {
    let materials = vec![material; triangles.len()];
    Mesh {
        name,
        positions,
        normals,
        triangles,
        materials,
        transform: Mat4::IDENTITY,
    }
}

/// Sides of a hair's tube; segments along a hair at 2 M triangles (2·6·64 = 768 triangles
/// per hair there).
const HAIR_SIDES: usize = 6;
const HAIR_SEGMENTS: usize = 64;
/// A hair's length (the ball's diameter is 2).
const HAIR_LENGTH: f32 = 2.56;

/// Thin tubes, each a smooth random walk steered back into the unit ball. The series is
/// self-similar: a grid's cells shrink as n^(-1/3), so the segments along a hair grow as
/// n^(1/3) (64 at 2 M), the hairs as n^(2/3) and the tubes' radius shrinks as n^(-1/3)
/// (0.003–0.005 at 2 M), which keeps each triangle's size in cells (and so references per
/// triangle) the same at every size.
/// Every hair has the same number of segments; the hair count meets the request.
pub fn hairball(n: usize, seed: u64) -> Scene {
    let segments = hair_segments(n);
    let hairs = ((n as f64 / (2 * HAIR_SIDES * segments) as f64).round() as usize).max(1);
    let per_hair = 2 * HAIR_SIDES * segments;
    let rings = segments + 1;
    let verts = rings * HAIR_SIDES;
    let mut positions = vec![Vec3::ZERO; hairs * verts];
    let mut normals = vec![Vec3::ZERO; hairs * verts];
    positions
        .par_chunks_mut(verts)
        .zip(normals.par_chunks_mut(verts))
        .enumerate()
        .for_each(|(h, (pos, nrm))| hair(seed, h as u64, segments, n, pos, nrm));
    let mut triangles = vec![[0u32; 3]; hairs * per_hair];
    triangles
        .par_chunks_mut(per_hair)
        .enumerate()
        .for_each(|(h, tris)| {
            let base = (h * verts) as u32;
            tube_triangles(base, rings, HAIR_SIDES, tris);
        });
    let materials = vec![Material {
        name: "hair".into(),
        diffuse: Vec3::new(0.55, 0.42, 0.3),
        specular: Vec3::splat(0.35),
        shininess: 48.0,
        ..Default::default()
    }];
    let meshes = vec![mesh("hairball".into(), positions, normals, triangles, 0)];
    let lights = vec![Light {
        position: Vec3::new(2.5, 3.0, 3.5),
        color: Vec3::ONE,
        intensity: 1.0,
        attenuation: [1.0, 0.0, 0.0],
    }];
    let camera = Camera {
        eye: Vec3::new(0.9, 0.7, 2.6),
        target: Vec3::ZERO,
        up: Vec3::Y,
        vfov: 45.0,
    };
    generated(format!("hairball-{n}"), meshes, materials, lights, camera)
}

/// Segments along each hair of an `n`-triangle hairball.
fn hair_segments(n: usize) -> usize {
    ((HAIR_SEGMENTS as f64 * (n as f64 / 2e6).cbrt()).round() as usize).max(4)
}

/// One hair: `segments + 1` rings of `HAIR_SIDES` vertices along a random walk, the rings'
/// frames carried along the walk (so the tube never twists into a bow tie).
fn hair(seed: u64, h: u64, segments: usize, n: usize, pos: &mut [Vec3], nrm: &mut [Vec3]) {
    let mut rng = Pcg32::new(seed, h);
    let mut p = rng.unit_vector() * rng.next_f32().cbrt() * 0.9;
    let mut dir = rng.unit_vector();
    let radius = (0.003 + 0.002 * rng.next_f32()) * (2e6 / n as f32).cbrt();
    let step = HAIR_LENGTH / segments as f32;
    // The walk's turning per step, so that hairs of fewer segments curl as much per length.
    let wander = 0.45 * (HAIR_SEGMENTS as f32 / segments as f32).sqrt().min(2.0);
    let helper = if dir.y.abs() < 0.9 { Vec3::Y } else { Vec3::X };
    let mut b1 = dir.cross(helper).normalize();
    let tau = std::f32::consts::TAU;
    for ring in 0..=segments {
        // Carry the frame: remove the new direction's component, renormalise.
        b1 = (b1 - dir * dir.dot(b1)).normalize_or(dir.any_orthonormal_vector());
        let b2 = dir.cross(b1);
        for j in 0..HAIR_SIDES {
            let a = j as f32 / HAIR_SIDES as f32 * tau;
            let d = b1 * a.cos() + b2 * a.sin();
            pos[ring * HAIR_SIDES + j] = p + d * radius;
            nrm[ring * HAIR_SIDES + j] = d;
        }
        // Wander, and turn back towards the centre the further out the walk has gone.
        let pull = p * (0.6 * p.length_squared());
        dir = (dir + rng.unit_vector() * wander - pull).normalize_or(dir);
        p += dir * step;
    }
}

/// The triangles of an open tube of `rings` rings of `sides` vertices from vertex `base`.
fn tube_triangles(base: u32, rings: usize, sides: usize, out: &mut [[u32; 3]]) {
    let mut k = 0;
    for i in 0..rings - 1 {
        for j in 0..sides {
            let v = |i: usize, j: usize| base + (i * sides + j % sides) as u32;
            let (a, b, c, d) = (v(i, j), v(i + 1, j), v(i + 1, j + 1), v(i, j + 1));
            out[k] = [a, b, c];
            out[k + 1] = [a, c, d];
            k += 2;
        }
    }
}

/// Append the `m × m` quads of the face `origin + s·u + t·v` (s, t ∈ [0, 1]).
fn face(pos: &mut Vec<Vec3>, tris: &mut Vec<[u32; 3]>, origin: Vec3, u: Vec3, v: Vec3, m: usize) {
    let base = pos.len() as u32;
    for i in 0..=m {
        for j in 0..=m {
            pos.push(origin + u * (i as f32 / m as f32) + v * (j as f32 / m as f32));
        }
    }
    let w = (m + 1) as u32;
    for i in 0..m as u32 {
        for j in 0..m as u32 {
            let a = base + i * w + j;
            tris.push([a, a + w, a + w + 1]);
            tris.push([a, a + w + 1, a + 1]);
        }
    }
}

/// A city: a square of blocks, one building per block, each a box whose four walls and roof
/// are tessellated `m × m` (10·m² triangles), heights spread from 0.5 to 6 blocks.
pub fn city(n: usize, seed: u64) -> Scene {
    let b0 = (n / 2000).clamp(4, 4096);
    let m = ((n as f64 / (10.0 * b0 as f64)).sqrt().round() as usize).max(1);
    let buildings = ((n as f64 / (10.0 * (m * m) as f64)).round() as usize).max(1);
    let side = (buildings as f64).sqrt().ceil() as usize;
    let half = side as f32 * 0.5;
    let mut meshes: Vec<Mesh> = (0..buildings)
        .into_par_iter()
        .map(|b| {
            let mut rng = Pcg32::new(seed, b as u64);
            let (gx, gz) = ((b % side) as f32 - half, (b / side) as f32 - half);
            let w = rng.range(0.45, 0.8);
            let d = rng.range(0.45, 0.8);
            let h = 0.5 * 12f32.powf(rng.next_f32());
            let min = Vec3::new(gx + 0.5 - w * 0.5, 0.0, gz + 0.5 - d * 0.5);
            let (x, y, z) = (Vec3::X * w, Vec3::Y * h, Vec3::Z * d);
            let mut pos = Vec::with_capacity(5 * (m + 1) * (m + 1));
            let mut tris = Vec::with_capacity(10 * m * m);
            // Outward-facing walls (counter-clockwise seen from outside), then the roof.
            face(&mut pos, &mut tris, min, y, x, m);
            face(&mut pos, &mut tris, min + x, y, z, m);
            face(&mut pos, &mut tris, min + x + z, y, -x, m);
            face(&mut pos, &mut tris, min + z, y, -z, m);
            face(&mut pos, &mut tris, min + y, z, x, m);
            let nrm = smooth_normals(&pos, &tris);
            mesh(format!("building-{b}"), pos, nrm, tris, 1 + (b % 3) as u32)
        })
        .collect();
    let extent = half + 1.0;
    let mut gpos = Vec::new();
    let mut gtris = Vec::new();
    face(
        &mut gpos,
        &mut gtris,
        Vec3::new(-extent, 0.0, -extent),
        Vec3::Z * 2.0 * extent,
        Vec3::X * 2.0 * extent,
        1,
    );
    let gn = vec![Vec3::Y; gpos.len()];
    meshes.insert(0, mesh("ground".into(), gpos, gn, gtris, 0));
    let materials = vec![
        Material::diffuse("ground", Vec3::new(0.3, 0.32, 0.3)),
        Material::diffuse("concrete", Vec3::new(0.6, 0.58, 0.55)),
        Material::diffuse("brick", Vec3::new(0.55, 0.3, 0.22)),
        Material {
            name: "glass".into(),
            diffuse: Vec3::new(0.25, 0.35, 0.45),
            specular: Vec3::splat(0.5),
            shininess: 64.0,
            reflectivity: 0.25,
            ..Default::default()
        },
    ];
    let lights = vec![Light {
        position: Vec3::new(0.6, 2.0, 0.9) * (extent * 2.0 + 10.0),
        color: Vec3::ONE,
        intensity: 1.0,
        attenuation: [1.0, 0.0, 0.0],
    }];
    let camera = Camera {
        eye: Vec3::new(-0.9, 0.8, 1.2) * extent,
        target: Vec3::new(0.05, 0.0, -0.05) * extent,
        up: Vec3::Y,
        vfov: 50.0,
    };
    generated(format!("city-{n}"), meshes, materials, lights, camera)
}

/// Levels of the nested stadium and the scale from one to the next.
const LEVELS: usize = 3;
const LEVEL_SCALE: f32 = 1.0 / 20.0;
/// Outer radius of the outermost bowl; its field (no floor) spans 0.3 of it.
const BOWL_RADIUS: f32 = 100.0;

/// Stadium bowls nested in each other's fields, each with an equal share of the triangles,
/// and a knot in the innermost field.
pub fn nested(n: usize, seed: u64) -> Scene {
    let knot_tris = (n / 10).max(96);
    let per_level = (n - knot_tris.min(n)) / LEVELS;
    // A bowl of nu rings and 4·nu sectors has 8·nu² triangles.
    let nu = ((per_level as f64 / 8.0).sqrt().round() as usize).max(2);
    let mut meshes: Vec<Mesh> = (0..LEVELS)
        .into_par_iter()
        .map(|level| bowl(level, nu, seed))
        .collect();
    // The knot: k sides, knot_tris / (2k) rings; it fits inside the last field.
    let k = 8u32;
    let rings = ((knot_tris / (2 * k as usize)) as u32).max(12);
    let inner = BOWL_RADIUS * LEVEL_SCALE.powi(LEVELS as i32 - 1) * 0.3;
    let knot_scale = inner * 0.45;
    meshes.push(torus_knot(
        "knot",
        Vec3::new(0.0, knot_scale * 0.5, 0.0),
        knot_scale,
        (2.0, 3.0),
        rings,
        k,
        1,
    ));
    let materials = vec![
        Material::diffuse("stands", Vec3::new(0.55, 0.6, 0.55)),
        crate::builtin::knot_material(),
    ];
    let lights = vec![Light {
        position: Vec3::new(0.3, 1.2, 0.5) * BOWL_RADIUS,
        color: Vec3::ONE,
        intensity: 1.0,
        attenuation: [1.0, 0.0, 0.0],
    }];
    let camera = Camera {
        eye: Vec3::new(0.0, 0.55, 0.9) * BOWL_RADIUS,
        target: Vec3::ZERO,
        up: Vec3::Y,
        vfov: 40.0,
    };
    generated(format!("nested-{n}"), meshes, materials, lights, camera)
}

/// Level `level`'s bowl, centred on the origin at scale `LEVEL_SCALE^level`: a surface of
/// revolution from 0.3 to 1 of its radius, rising as terraces smoothed by a ripple, with
/// per-level random tilt of the ripple's phase.
fn bowl(level: usize, nu: usize, seed: u64) -> Mesh {
    let mut rng = Pcg32::new(seed, level as u64);
    let phase = rng.range(0.0, std::f32::consts::TAU);
    let r = BOWL_RADIUS * LEVEL_SCALE.powi(level as i32);
    let nt = 4 * nu;
    let mut pos = Vec::with_capacity((nu + 1) * nt);
    for i in 0..=nu {
        let u = i as f32 / nu as f32;
        let radius = r * (0.3 + 0.7 * u);
        let y = r * (0.3 * u * u + 0.01 * (40.0 * u + phase).sin());
        for j in 0..nt {
            let a = j as f32 / nt as f32 * std::f32::consts::TAU;
            pos.push(Vec3::new(radius * a.cos(), y, radius * a.sin()));
        }
    }
    let mut tris = Vec::with_capacity(2 * nu * nt);
    for i in 0..nu {
        for j in 0..nt {
            let v = |i: usize, j: usize| (i * nt + j % nt) as u32;
            // Facing up and inwards (towards the field).
            tris.push([v(i, j), v(i, j + 1), v(i + 1, j + 1)]);
            tris.push([v(i, j), v(i + 1, j + 1), v(i + 1, j)]);
        }
    }
    let nrm = smooth_normals(&pos, &tris);
    mesh(format!("stands-{level}"), pos, nrm, tris, 0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse_in_the_users_words() {
        assert_eq!(parse_size("10000"), Some(10_000));
        assert_eq!(parse_size("250k"), Some(250_000));
        assert_eq!(parse_size("2M"), Some(2_000_000));
        assert_eq!(parse_size("2.5m"), Some(2_500_000));
        for bad in ["", "k", "2G", "-5", "1e6", "two"] {
            assert_eq!(parse_size(bad), None, "{bad}");
        }
        assert_eq!(
            Spec::parse("city:20k:9"),
            Some(Ok(Spec {
                generator: "city",
                triangles: 20_000,
                seed: 9
            }))
        );
        assert!(Spec::parse("sponza").is_none());
        assert!(Spec::parse("hairball.obj").is_none());
        for bad in [
            "hairball",
            "hairball:",
            "hairball:2M:x",
            "hairball:10",
            "hairball:1G",
            "city:2M:1:2",
        ] {
            assert!(matches!(Spec::parse(bad), Some(Err(_))), "{bad}");
        }
    }

    #[test]
    fn generators_meet_their_size_deterministically_on_any_pool() {
        for g in NAMES {
            for n in [1_000u64, 30_000] {
                let spec = Spec {
                    generator: g,
                    triangles: n,
                    seed: 3,
                };
                let a = spec.generate();
                let got = a.triangle_count() as f64;
                assert!((got / n as f64 - 1.0).abs() < 0.12, "{g}:{n} made {got}");
                a.validate().unwrap();
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(1)
                    .build()
                    .unwrap();
                let b = pool.install(|| spec.generate());
                let (ga, gb) = (
                    crate::Geometry::from_scene(&a),
                    crate::Geometry::from_scene(&b),
                );
                assert_eq!(ga.tris, gb.tris, "{g}:{n} is deterministic");
                let other = crate::Geometry::from_scene(
                    &Spec {
                        seed: 4,
                        ..spec.clone()
                    }
                    .generate(),
                );
                assert_ne!(ga.tris, other.tris, "{g}:{n}'s seed matters");
            }
        }
    }

    #[test]
    fn load_names_generators_and_checks_the_budget_first() {
        let opts = crate::LoadOptions::default();
        let s = crate::load("city:5k:2", &opts).unwrap();
        assert!(s.report.notes.iter().any(|n| n.contains("generated scene")));
        let e = crate::load("city:5x", &opts).unwrap_err().to_string();
        assert!(e.contains("city:5x") && e.contains("SIZE"), "{e}");
        let small = crate::LoadOptions {
            max_triangles: 10_000,
            ..opts
        };
        // 40 M triangles would take seconds and gigabytes: refused before any is made.
        let e = crate::load("hairball:40M", &small).unwrap_err().to_string();
        assert!(e.contains("10000 triangles"), "{e}");
        let e = crate::load("hairbal:2M", &opts).unwrap_err().to_string();
        assert!(e.contains("hairball:SIZE"), "{e}");
    }

    #[test]
    fn hairs_are_thin_and_stay_near_the_ball() {
        let s = hairball(20_000, 1);
        let g = crate::Geometry::from_scene(&s);
        let b = geom::Aabb::from_points(g.tris.iter().flatten().copied());
        assert!(
            b.min.min_element() > -2.0 && b.max.max_element() < 2.0,
            "{b:?}"
        );
        let longest = g
            .tris
            .iter()
            .map(|t| (t[1] - t[0]).length().max((t[2] - t[1]).length()))
            .fold(0.0f32, f32::max);
        // A segment's length, plus the tube's diameter at most.
        let step = HAIR_LENGTH / hair_segments(20_000) as f32;
        let diameter = 0.01 * (2e6f32 / 20_000.0).cbrt();
        assert!(longest < step * 1.05 + diameter, "{longest} against {step}");
    }
}
