//! Ray sets for evaluation (the irregular-grid paper's Table 3 kinds and the renderer's
//! secondary kinds), all deterministic for a given seed.

use crate::raster::{default_near, rasterize};
use crate::secondary::{reflect, shadow_rays, Surfaces};
use crate::view::View;
use geom::ray::offset_point;
use geom::{Pcg32, Ray, Vec3};
use scene::{Geometry, Scene};
use trace::batch::{RayBatch, RayKind};

/// Which rays to make.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum Kind {
    /// One ray through every pixel centre.
    Primary,
    /// From every light to every rasterized surface point (thesis eqs. 3.1–3.2).
    Shadow,
    /// The mirror ray of every rasterized surface point, whatever its material.
    Reflection,
    /// `spp` cosine-weighted rays per rasterized surface point, at most `ao_distance` long.
    Ao,
    /// `width · height · spp` rays with origins uniform in the scene box and directions
    /// uniform on the sphere.
    Random,
}

impl Kind {
    /// Every value by its name (as options spell it).
    pub const NAMES: [(&'static str, Kind); 5] = [
        ("primary", Kind::Primary),
        ("shadow", Kind::Shadow),
        ("reflection", Kind::Reflection),
        ("ao", Kind::Ao),
        ("random", Kind::Random),
    ];
}

/// What [`generate`] makes: the image (for primary, shadow, reflection and AO rays), samples, seed and AO length.
pub struct Options {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Rays per pixel (AO and random rays).
    pub spp: u32,
    /// Seed of the random rays (AO directions, random rays): same seed, same rays.
    pub seed: u64,
    /// AO ray length; `None` = 10 % of the scene box diagonal.
    pub ao_distance: Option<f32>,
}

fn surfaces(scene: &Scene, geo: &Geometry, view: &View) -> Surfaces {
    let (gb, _) = rasterize(geo, &scene.materials, view, default_near(geo));
    Surfaces::from_gbuffer(&gb, geo, view.eye)
}

/// An orthonormal basis (t, b) around unit `n` (Duff et al. 2017, branchless).
fn basis(n: Vec3) -> (Vec3, Vec3) {
    let s = 1.0f32.copysign(n.z);
    let a = -1.0 / (s + n.z);
    let b = n.x * n.y * a;
    (
        Vec3::new(1.0 + s * n.x * n.x * a, s * b, -s * n.x),
        Vec3::new(b, s + n.y * n.y * a, -n.y),
    )
}

/// Make the rays of `kind` for the scene (see [`Kind`]).
pub fn generate(scene: &Scene, geo: &Geometry, kind: Kind, o: &Options) -> RayBatch {
    let view = View::new(&scene.camera, o.width, o.height);
    let mut b = match kind {
        Kind::Primary => view.primary_rays(),
        Kind::Shadow => shadow_rays(&surfaces(scene, geo, &view), &scene.lights),
        Kind::Reflection => {
            let s = surfaces(scene, geo, &view);
            let mut b = RayBatch::with_capacity(s.len());
            for i in 0..s.len() {
                let (ngf, nsf) = s.facing_normals(i);
                let mut d = reflect(s.incident[i], nsf);
                if d.dot(ngf) <= 0.0 {
                    d = reflect(s.incident[i], ngf);
                }
                b.push(
                    Ray::new(
                        offset_point(s.pos[i], ngf, s.scale[i]),
                        d,
                        0.0,
                        f32::INFINITY,
                    ),
                    RayKind::Reflection,
                    s.pixel[i],
                    0,
                    Vec3::ONE,
                    0,
                );
            }
            b
        }
        Kind::Ao => {
            let s = surfaces(scene, geo, &view);
            let dist = o.ao_distance.unwrap_or(geo.bounds.diagonal() * 0.1);
            let mut b = RayBatch::with_capacity(s.len() * o.spp as usize);
            for i in 0..s.len() {
                let (ngf, _) = s.facing_normals(i);
                let (t, bt) = basis(ngf);
                let org = offset_point(s.pos[i], ngf, s.scale[i]);
                // One stream per pixel: the rays of a pixel do not depend on other pixels.
                let mut rng = Pcg32::new(o.seed, s.pixel[i] as u64);
                for _ in 0..o.spp {
                    let (r1, r2) = (rng.next_f32(), rng.next_f32());
                    let phi = std::f32::consts::TAU * r1;
                    let (sin_t, cos_t) = (r2.sqrt(), (1.0 - r2).max(0.0).sqrt());
                    let d = (t * (phi.cos() * sin_t) + bt * (phi.sin() * sin_t) + ngf * cos_t)
                        .normalize_or(ngf);
                    b.push(
                        Ray::new(org, d, 0.0, dist),
                        RayKind::Primary,
                        s.pixel[i],
                        0,
                        Vec3::ONE,
                        0,
                    );
                }
            }
            b
        }
        Kind::Random => {
            let n = o.width as usize * o.height as usize * o.spp as usize;
            let bx = geo.bounds;
            let mut rng = Pcg32::new(o.seed, 0x72616e64);
            let mut b = RayBatch::with_capacity(n);
            for i in 0..n {
                let p = Vec3::new(
                    rng.range(bx.min.x, bx.max.x),
                    rng.range(bx.min.y, bx.max.y),
                    rng.range(bx.min.z, bx.max.z),
                );
                b.push(
                    Ray::new(p, rng.unit_vector(), 0.0, f32::INFINITY),
                    RayKind::Primary,
                    i as u32,
                    0,
                    Vec3::ONE,
                    0,
                );
            }
            b
        }
    };
    if kind != Kind::Random {
        b.width = o.width;
    }
    b
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kinds_are_deterministic_and_sane() {
        let s = scene::builtin::cornell();
        let geo = Geometry::from_scene(&s);
        let o = Options {
            width: 16,
            height: 12,
            spp: 4,
            seed: 9,
            ao_distance: Some(0.5),
        };
        for kind in [
            Kind::Primary,
            Kind::Shadow,
            Kind::Reflection,
            Kind::Ao,
            Kind::Random,
        ] {
            let a = generate(&s, &geo, kind, &o);
            let b = generate(&s, &geo, kind, &o);
            assert!(!a.is_empty());
            assert_eq!(a.org, b.org);
            assert_eq!(a.dir, b.dir);
            a.validate().unwrap();
            for d in &a.dir {
                assert!((d.length() - 1.0).abs() < 1e-4);
            }
        }
        let ao = generate(&s, &geo, Kind::Ao, &o);
        assert_eq!(
            ao.len(),
            16 * 12 * 4,
            "cornell is closed: every pixel is covered"
        );
        assert!(ao.t_max.iter().all(|&t| t == 0.5));
        // Cosine-weighted: mean cos θ about the normal is 2/3.
        let big = generate(
            &s,
            &geo,
            Kind::Ao,
            &Options {
                width: 32,
                height: 32,
                spp: 16,
                seed: 1,
                ao_distance: None,
            },
        );
        let sur = surfaces(&s, &geo, &View::new(&s.camera, 32, 32));
        let mut mean = 0.0f64;
        for (k, d) in big.dir.iter().enumerate() {
            let (n, _) = sur.facing_normals(k / 16);
            mean += d.dot(n) as f64;
        }
        mean /= big.len() as f64;
        assert!((mean - 2.0 / 3.0).abs() < 0.01, "mean cos {mean}");
    }
}
