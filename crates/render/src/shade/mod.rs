//! Blinn-Phong shading with distance attenuation, exactly as thesis eqs. 3.19a–i, plus an
//! ambient term for scenes that define an ambient light.
//!
//! The thesis's model (§3.4, eq. 3.19) has no ambient term. BART scenes do (`am`, the
//! global ambient light, times each material's `fm` ambient colour), and without it a BART
//! room whose point light is enclosed renders black where BART's reference images show it
//! ambient-lit; OBJ `Ka` is lit the same way by a TOML scene's `ambient`. The term is
//! k_a ⊙ L_a, added with the emission before the lights. A scene without an ambient light
//! has L_a = 0, and adding that zero leaves every bit of eq. 3.19's result unchanged.

pub mod lanes;

use crate::secondary::Surfaces;
use geom::Vec3;
use scene::{Light, Material};

/// Local illumination of surface `i` from the lights it sees (`visible[l]`), plus emission
/// and the ambient term k_a ⊙ `ambient` (the scene's ambient light).
///
/// The view vector (3.19d) is the incident direction of the ray that found the surface (for
/// the rasterized generation that is hit − camera); the normal is the interpolated shading
/// normal turned towards the viewer.
pub fn local(
    s: &Surfaces,
    i: usize,
    m: &Material,
    lights: &[Light],
    visible: &[bool],
    ambient: Vec3,
) -> Vec3 {
    local_with(s, i, m, lights, |l| visible[l], ambient)
}

/// [`local`] with light l's visibility from `visible(l)` (the renderer reads it straight
/// from the shadow rays' hits, so no per-surface array is made).
#[inline]
pub fn local_with(
    s: &Surfaces,
    i: usize,
    m: &Material,
    lights: &[Light],
    visible: impl Fn(usize) -> bool,
    ambient: Vec3,
) -> Vec3 {
    let (_, n) = s.facing_normals(i);
    let p = s.pos[i];
    let view = s.incident[i];
    let mut color = m.emission + m.ambient * ambient;
    for (l, light) in lights.iter().enumerate() {
        if !visible(l) {
            continue;
        }
        let to_light = light.position - p;
        let dist = to_light.length(); // 3.19b
        if dist <= 0.0 {
            continue;
        }
        let ldir = to_light / dist; // 3.19a
        let [c, lin, q] = light.attenuation;
        let att = 1.0 / (c + dist * lin + dist * dist * q); // 3.19c
        let half = (ldir - view).normalize_or_zero(); // 3.19e
        let diffuse_factor = ldir.dot(n).clamp(0.0, 1.0); // 3.19f
        let specular_factor = half.dot(n).max(0.0).powf(m.shininess).clamp(0.0, 1.0); // 3.19g
        let scale = light.color * light.intensity * att;
        color += m.diffuse * scale * diffuse_factor; // 3.19h
        color += m.specular * scale * specular_factor; // 3.19i
    }
    color
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn head_on_light() {
        let s = Surfaces {
            pixel: vec![0],
            pos: vec![Vec3::ZERO],
            ng: vec![Vec3::Y],
            ns: vec![Vec3::Y],
            incident: vec![-Vec3::Y],
            material: vec![0],
            throughput: vec![Vec3::ONE],
            depth: vec![0],
            scale: vec![1.0],
        };
        let m = Material {
            diffuse: Vec3::new(0.5, 0.0, 0.0),
            specular: Vec3::new(0.0, 0.25, 0.0),
            shininess: 10.0,
            ..Default::default()
        };
        let l = Light {
            position: Vec3::new(0.0, 2.0, 0.0),
            color: Vec3::ONE,
            intensity: 1.0,
            attenuation: [1.0, 0.5, 0.25],
        };
        // att = 1 / (1 + 1 + 1) at distance 2; diffuse and specular factors are 1.
        let c = local(&s, 0, &m, std::slice::from_ref(&l), &[true], Vec3::ZERO);
        assert!((c - Vec3::new(0.5 / 3.0, 0.25 / 3.0, 0.0)).length() < 1e-6);
        assert_eq!(
            local(&s, 0, &m, std::slice::from_ref(&l), &[false], Vec3::ZERO),
            Vec3::ZERO
        );
        // The ambient term: k_a ⊙ L_a, lit or not; with no ambient light, eq. 3.19 exactly.
        let ma = Material {
            ambient: Vec3::new(0.5, 0.25, 1.0),
            ..m.clone()
        };
        let la = Vec3::new(0.2, 0.4, 0.0);
        assert_eq!(
            local(&s, 0, &ma, std::slice::from_ref(&l), &[false], la),
            Vec3::new(0.1, 0.1, 0.0)
        );
        let lit = local(&s, 0, &ma, std::slice::from_ref(&l), &[true], la);
        assert!((lit - c - Vec3::new(0.1, 0.1, 0.0)).length() < 1e-6);
        for v in [true, false] {
            let plain = local(&s, 0, &m, std::slice::from_ref(&l), &[v], Vec3::ZERO);
            let with_ka = local(&s, 0, &ma, std::slice::from_ref(&l), &[v], Vec3::ZERO);
            assert_eq!(
                plain.to_array().map(f32::to_bits),
                with_ka.to_array().map(f32::to_bits)
            );
        }
    }
}
