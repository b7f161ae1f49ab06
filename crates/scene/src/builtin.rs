//! Built-in scenes: usable without any file, deterministic from a fixed seed.
//!
//! - `cornell`: the thesis's CORNELL idea: a closed room whose six walls are (tinted) mirrors
//!   around a diffuse torus, plus a glass sphere; 812 triangles in 8 meshes.
//! - `spheres`: reflective, refractive and diffuse spheres on a checkered plane.
//! - `soup`: 2,000 random triangles (seeded).
//! - `stadium`: a dense torus knot in a huge empty room ("teapot in a stadium").
//! - `office`: a room with many small separate objects (desks, monitors, chairs, mugs), so
//!   that culling by mesh bounding sphere matters.

use crate::model::{Camera, Light, LoadReport, Material, Mesh, Scene};
use crate::shapes::{cuboid, icosphere, quad_grid, torus, torus_knot};
use geom::{Mat4, Pcg32, Quat, Vec3};

/// The built-in scenes' names.
pub const NAMES: [&str; 5] = ["cornell", "spheres", "soup", "stadium", "office"];

/// The built-in scene `name`, or `None`.
pub fn by_name(name: &str) -> Option<Scene> {
    Some(match name {
        "cornell" => cornell(),
        "spheres" => spheres(),
        "soup" => soup(2000, 1),
        "stadium" => stadium(),
        "office" => office(7),
        _ => return None,
    })
}

fn scene(
    name: &str,
    meshes: Vec<Mesh>,
    materials: Vec<Material>,
    lights: Vec<Light>,
    camera: Camera,
    background: Vec3,
) -> Scene {
    Scene {
        id: crate::model::SceneId::fresh(),
        name: name.into(),
        meshes,
        materials,
        lights,
        camera,
        background,
        ambient: Vec3::ZERO,
        report: LoadReport {
            notes: vec![format!("built-in scene '{name}'")],
            ..Default::default()
        },
        animation: None,
    }
}

/// The closed mirror room (thesis CORNELL): 6 walls × 50 + glass icosphere 320 + torus 192.
pub fn cornell() -> Scene {
    let materials = vec![
        Material {
            specular: Vec3::splat(0.15),
            ..Material::mirror("wall-white", Vec3::splat(0.3), 0.5)
        },
        Material {
            specular: Vec3::splat(0.15),
            ..Material::mirror("wall-red", Vec3::new(0.45, 0.06, 0.05), 0.45)
        },
        Material {
            specular: Vec3::splat(0.15),
            ..Material::mirror("wall-green", Vec3::new(0.06, 0.35, 0.08), 0.45)
        },
        Material {
            specular: Vec3::splat(0.15),
            ..Material::mirror("wall-blue", Vec3::new(0.1, 0.14, 0.4), 0.45)
        },
        Material {
            name: "torus".into(),
            diffuse: Vec3::new(0.85, 0.6, 0.15),
            specular: Vec3::splat(0.4),
            shininess: 48.0,
            ..Default::default()
        },
        Material::glass("glass", 1.5),
    ];
    let n = 5;
    let s = 2.0;
    let lo = Vec3::splat(-1.0);
    // Walls face into the room: quad_grid faces u × v.
    let meshes = vec![
        quad_grid("floor", lo, Vec3::Z * s, Vec3::X * s, n, 0),
        quad_grid(
            "ceiling",
            Vec3::new(-1.0, 1.0, -1.0),
            Vec3::X * s,
            Vec3::Z * s,
            n,
            0,
        ),
        quad_grid("left", lo, Vec3::Y * s, Vec3::Z * s, n, 1),
        quad_grid(
            "right",
            Vec3::new(1.0, -1.0, -1.0),
            Vec3::Z * s,
            Vec3::Y * s,
            n,
            2,
        ),
        quad_grid("back", lo, Vec3::X * s, Vec3::Y * s, n, 3),
        quad_grid(
            "front",
            Vec3::new(-1.0, -1.0, 1.0),
            Vec3::Y * s,
            Vec3::X * s,
            n,
            0,
        ),
        {
            let mut t = torus("torus", Vec3::ZERO, 0.32, 0.12, 12, 8, 4);
            t.transform = Mat4::from_rotation_translation(
                Quat::from_rotation_x(0.9) * Quat::from_rotation_z(0.3),
                Vec3::new(-0.35, -0.55, -0.25),
            );
            t
        },
        icosphere("glass-sphere", Vec3::new(0.4, -0.62, 0.1), 0.36, 2, 5),
    ];
    let lights = vec![Light {
        position: Vec3::new(0.0, 0.85, 0.15),
        color: Vec3::new(1.0, 0.97, 0.9),
        intensity: 1.3,
        attenuation: [1.0, 0.15, 0.1],
    }];
    let camera = Camera {
        eye: Vec3::new(0.0, 0.0, 0.97),
        target: Vec3::new(0.0, -0.15, -1.0),
        up: Vec3::Y,
        vfov: 62.0,
    };
    scene("cornell", meshes, materials, lights, camera, Vec3::ZERO)
}

/// Reflective and refractive spheres on a checkered plane (open scene with a sky).
pub fn spheres() -> Scene {
    spheres_with("spheres", 12, [3, 3, 2, 2, 2])
}

/// The highest [`spheres_family`] level (≈ 1.9 M triangles).
pub const FAMILY_MAX_LEVEL: u32 = 7;

/// The `spheres` scene tessellated at `level` (1..=[`FAMILY_MAX_LEVEL`]): every sphere an
/// icosphere of `level` subdivisions and the plane 12·2^(level−2) quads a side (at least
/// 12, so the 12 × 12 checkerboard stays), so the triangle count is 118·4^level from level 2
/// (688 at level 1, 1,888 at 2, 483,328 at 6) while the picture stays the same. It is the scene family of the report's cost-growth curves (`rayspace
/// report`): the same view, lights and materials at every size.
pub fn spheres_family(level: u32) -> Scene {
    let level = level.clamp(1, FAMILY_MAX_LEVEL);
    spheres_with(
        &format!("spheres-l{level}"),
        12 << level.saturating_sub(2),
        [level; 5],
    )
}

/// `spheres` with a `plane_n`² checkerboard and the five spheres at the given icosphere
/// levels.
fn spheres_with(name: &str, plane_n: u32, levels: [u32; 5]) -> Scene {
    let materials = vec![
        Material {
            name: "tile-light".into(),
            diffuse: Vec3::splat(0.8),
            specular: Vec3::splat(0.1),
            shininess: 16.0,
            reflectivity: 0.15,
            ..Default::default()
        },
        Material {
            name: "tile-dark".into(),
            diffuse: Vec3::splat(0.15),
            specular: Vec3::splat(0.1),
            shininess: 16.0,
            reflectivity: 0.15,
            ..Default::default()
        },
        Material::mirror("chrome", Vec3::splat(0.05), 0.9),
        Material::glass("glass", 1.5),
        Material {
            name: "red".into(),
            diffuse: Vec3::new(0.8, 0.1, 0.1),
            specular: Vec3::splat(0.6),
            shininess: 80.0,
            ..Default::default()
        },
        Material {
            name: "gold".into(),
            diffuse: Vec3::new(0.3, 0.2, 0.05),
            specular: Vec3::new(0.9, 0.7, 0.3),
            shininess: 100.0,
            reflectivity: 0.6,
            ..Default::default()
        },
        Material {
            name: "water".into(),
            diffuse: Vec3::new(0.0, 0.03, 0.05),
            specular: Vec3::splat(0.8),
            shininess: 128.0,
            reflectivity: 0.08,
            transparency: 0.9,
            ior: 1.33,
            ..Default::default()
        },
    ];
    let mut plane = quad_grid(
        "plane",
        Vec3::new(-6.0, 0.0, -6.0),
        Vec3::Z * 12.0,
        Vec3::X * 12.0,
        plane_n,
        0,
    );
    // Checkerboard of 12 × 12 tiles whatever the tessellation: both triangles of quad
    // (i, j) take the colour of its tile.
    for (k, m) in plane.materials.iter_mut().enumerate() {
        let q = k as u32 / 2;
        let (i, j) = (q % plane_n, q / plane_n);
        *m = (i * 12 / plane_n + j * 12 / plane_n) % 2;
    }
    let meshes = vec![
        plane,
        icosphere("chrome", Vec3::new(-1.6, 1.0, -0.5), 1.0, levels[0], 2),
        icosphere("glass", Vec3::new(0.6, 0.8, 1.0), 0.8, levels[1], 3),
        icosphere("red", Vec3::new(1.9, 0.6, -1.2), 0.6, levels[2], 4),
        icosphere("gold", Vec3::new(-0.3, 0.45, 2.2), 0.45, levels[3], 5),
        icosphere("water", Vec3::new(2.4, 0.5, 1.5), 0.5, levels[4], 6),
    ];
    let lights = vec![
        Light {
            position: Vec3::new(-4.0, 7.0, 5.0),
            color: Vec3::new(1.0, 0.95, 0.85),
            intensity: 0.9,
            attenuation: [1.0, 0.0, 0.0],
        },
        Light {
            position: Vec3::new(5.0, 4.0, 2.0),
            color: Vec3::new(0.6, 0.7, 1.0),
            intensity: 0.5,
            attenuation: [1.0, 0.0, 0.0],
        },
    ];
    let camera = Camera {
        eye: Vec3::new(0.5, 2.6, 7.5),
        target: Vec3::new(0.2, 0.6, 0.0),
        up: Vec3::Y,
        vfov: 45.0,
    };
    scene(
        name,
        meshes,
        materials,
        lights,
        camera,
        Vec3::new(0.45, 0.6, 0.85),
    )
}

/// `n` random triangles in the cube [-1, 1]³ (each a separate small mesh group of 100).
pub fn soup(n: usize, seed: u64) -> Scene {
    let mut rng = Pcg32::new(seed, 0x736f7570);
    let materials: Vec<Material> = (0..8)
        .map(|i| Material {
            name: format!("soup-{i}"),
            diffuse: Vec3::new(
                rng.range(0.2, 0.9),
                rng.range(0.2, 0.9),
                rng.range(0.2, 0.9),
            ),
            specular: Vec3::splat(0.3),
            shininess: 32.0,
            reflectivity: if i == 0 { 0.5 } else { 0.0 },
            ..Default::default()
        })
        .collect();
    let mut meshes = Vec::new();
    for chunk in 0..n.div_ceil(100) {
        let count = (n - chunk * 100).min(100);
        let mut pos = Vec::with_capacity(count * 3);
        let mut tris = Vec::with_capacity(count);
        let mut mats = Vec::with_capacity(count);
        while tris.len() < count {
            let c = Vec3::new(
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
            );
            let size = rng.range(0.05, 0.25);
            let p = [0, 1, 2].map(|_| c + rng.unit_vector() * size);
            if geom::tri::is_degenerate(p[0], p[1], p[2]) {
                continue;
            }
            let b = pos.len() as u32;
            pos.extend_from_slice(&p);
            tris.push([b, b + 1, b + 2]);
            mats.push(rng.below(8));
        }
        let mut m = Mesh::new(format!("soup-{chunk}"), pos, tris, 0);
        m.materials = mats;
        meshes.push(m);
    }
    let lights = vec![
        Light::white(Vec3::new(2.0, 3.0, 4.0), 1.0),
        Light::white(Vec3::new(-3.0, 1.0, -2.0), 0.4),
    ];
    let camera = Camera {
        eye: Vec3::new(1.6, 1.2, 3.4),
        target: Vec3::ZERO,
        up: Vec3::Y,
        vfov: 45.0,
    };
    scene(
        "soup",
        meshes,
        materials,
        lights,
        camera,
        Vec3::new(0.05, 0.05, 0.08),
    )
}

/// The stadium's knot: glossy copper (also the nested stadium's, `generate::nested`).
pub(crate) fn knot_material() -> Material {
    Material {
        name: "knot".into(),
        diffuse: Vec3::new(0.7, 0.25, 0.1),
        specular: Vec3::splat(0.6),
        shininess: 64.0,
        reflectivity: 0.3,
        ..Default::default()
    }
}

/// A dense knot (3,072 triangles) in a room 2,000 units wide: the "teapot in a stadium".
pub fn stadium() -> Scene {
    let materials = vec![
        Material::diffuse("stadium", Vec3::new(0.5, 0.55, 0.5)),
        knot_material(),
        Material::mirror("floor", Vec3::splat(0.2), 0.4),
    ];
    let meshes = vec![
        cuboid(
            "stadium",
            Vec3::new(-1000.0, -1.5, -1000.0),
            Vec3::new(1000.0, 400.0, 1000.0),
            true,
            0,
        ),
        torus_knot("knot", Vec3::ZERO, 1.0, (2.0, 3.0), 256, 6, 1),
        quad_grid(
            "pad",
            Vec3::new(-3.0, -1.49, -3.0),
            Vec3::Z * 6.0,
            Vec3::X * 6.0,
            1,
            2,
        ),
    ];
    let lights = vec![Light {
        position: Vec3::new(2.0, 4.0, 3.0),
        color: Vec3::ONE,
        intensity: 1.2,
        attenuation: [1.0, 0.0, 0.01],
    }];
    let camera = Camera {
        eye: Vec3::new(0.0, 1.5, 4.2),
        target: Vec3::new(0.0, -0.2, 0.0),
        up: Vec3::Y,
        vfov: 50.0,
    };
    scene("stadium", meshes, materials, lights, camera, Vec3::ZERO)
}

/// An office: a room with a grid of workstations, each made of separate small meshes.
pub fn office(seed: u64) -> Scene {
    let mut rng = Pcg32::new(seed, 0x6f666663);
    let materials = vec![
        Material {
            name: "floor".into(),
            diffuse: Vec3::new(0.45, 0.4, 0.35),
            specular: Vec3::splat(0.2),
            shininess: 24.0,
            reflectivity: 0.2,
            ..Default::default()
        },
        Material::diffuse("wall", Vec3::new(0.75, 0.75, 0.7)),
        Material {
            name: "desk".into(),
            diffuse: Vec3::new(0.55, 0.35, 0.2),
            specular: Vec3::splat(0.3),
            shininess: 32.0,
            ..Default::default()
        },
        Material {
            name: "metal".into(),
            diffuse: Vec3::splat(0.3),
            specular: Vec3::splat(0.7),
            shininess: 90.0,
            reflectivity: 0.3,
            ..Default::default()
        },
        Material {
            name: "screen".into(),
            diffuse: Vec3::new(0.02, 0.03, 0.05),
            specular: Vec3::splat(0.8),
            shininess: 120.0,
            reflectivity: 0.35,
            ..Default::default()
        },
        Material::diffuse("chair", Vec3::new(0.15, 0.2, 0.45)),
        Material::glass("glass", 1.45),
    ];
    let mut meshes = vec![cuboid(
        "room",
        Vec3::new(-10.0, 0.0, -10.0),
        Vec3::new(10.0, 3.2, 10.0),
        true,
        1,
    )];
    meshes.push(quad_grid(
        "floor-finish",
        Vec3::new(-9.99, 0.001, -9.99),
        Vec3::Z * 19.98,
        Vec3::X * 19.98,
        4,
        0,
    ));
    for gx in 0..4 {
        for gz in 0..3 {
            let base = Vec3::new(-6.0 + gx as f32 * 4.0, 0.0, -5.0 + gz as f32 * 4.5);
            let turn = Quat::from_rotation_y(rng.range(-0.25, 0.25));
            let place = Mat4::from_rotation_translation(turn, base);
            let tag = format!("{gx}-{gz}");
            let mut parts = vec![
                cuboid(
                    &format!("desk-{tag}"),
                    Vec3::new(-0.8, 0.72, -0.4),
                    Vec3::new(0.8, 0.76, 0.4),
                    false,
                    2,
                ),
                cuboid(
                    &format!("desk-legs-l-{tag}"),
                    Vec3::new(-0.78, 0.0, -0.38),
                    Vec3::new(-0.72, 0.72, 0.38),
                    false,
                    3,
                ),
                cuboid(
                    &format!("desk-legs-r-{tag}"),
                    Vec3::new(0.72, 0.0, -0.38),
                    Vec3::new(0.78, 0.72, 0.38),
                    false,
                    3,
                ),
                cuboid(
                    &format!("monitor-{tag}"),
                    Vec3::new(-0.35, 0.85, -0.3),
                    Vec3::new(0.35, 1.25, -0.27),
                    false,
                    4,
                ),
                cuboid(
                    &format!("stand-{tag}"),
                    Vec3::new(-0.03, 0.76, -0.31),
                    Vec3::new(0.03, 0.86, -0.28),
                    false,
                    3,
                ),
                cuboid(
                    &format!("seat-{tag}"),
                    Vec3::new(-0.25, 0.45, 0.55),
                    Vec3::new(0.25, 0.5, 1.0),
                    false,
                    5,
                ),
                cuboid(
                    &format!("back-{tag}"),
                    Vec3::new(-0.25, 0.5, 0.98),
                    Vec3::new(0.25, 1.0, 1.02),
                    false,
                    5,
                ),
                icosphere(
                    &format!("mug-{tag}"),
                    Vec3::new(rng.range(0.3, 0.6), 0.82, rng.range(-0.1, 0.2)),
                    0.06,
                    1,
                    6,
                ),
            ];
            for p in &mut parts {
                p.transform = place;
            }
            meshes.extend(parts);
        }
    }
    let lights = vec![
        Light {
            position: Vec3::new(-4.0, 3.0, -2.0),
            color: Vec3::new(1.0, 0.95, 0.85),
            intensity: 1.0,
            attenuation: [1.0, 0.05, 0.01],
        },
        Light {
            position: Vec3::new(4.0, 3.0, 3.0),
            color: Vec3::new(0.9, 0.95, 1.0),
            intensity: 0.8,
            attenuation: [1.0, 0.05, 0.01],
        },
    ];
    let camera = Camera {
        eye: Vec3::new(-8.5, 2.6, 8.5),
        target: Vec3::new(0.0, 0.6, 0.0),
        up: Vec3::Y,
        vfov: 55.0,
    };
    scene("office", meshes, materials, lights, camera, Vec3::ZERO)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spheres_family_grows_by_four_with_the_same_picture() {
        let tris = |s: &Scene| s.meshes.iter().map(|m| m.triangles.len()).sum::<usize>();
        assert_eq!(tris(&spheres_family(1)), 688);
        for l in 2..=5 {
            let s = spheres_family(l);
            assert_eq!(tris(&s), 118 << (2 * l), "level {l}");
            // The same 12 × 12 checkerboard at every tessellation: the plane's triangles
            // split evenly, and its first tile is light, the next one dark.
            let plane = &s.meshes[0];
            let dark = plane.materials.iter().filter(|&&m| m == 1).count();
            assert_eq!(dark * 2, plane.triangles.len());
            let n = 12 << (l - 2);
            let per_tile = n / 12;
            assert_eq!(plane.materials[0], 0);
            assert_eq!(plane.materials[2 * per_tile as usize], 1);
            // Same lights, camera and materials as `spheres`.
            let base = spheres();
            assert_eq!(s.lights.len(), base.lights.len());
            assert_eq!(s.camera.eye, base.camera.eye);
            assert_eq!(s.materials.len(), base.materials.len());
        }
    }

    #[test]
    fn builtins_are_valid_and_deterministic() {
        for name in NAMES {
            let a = by_name(name).unwrap();
            a.validate().unwrap();
            let b = by_name(name).unwrap();
            assert_eq!(a.triangle_count(), b.triangle_count());
            let ga = crate::Geometry::from_scene(&a);
            let gb = crate::Geometry::from_scene(&b);
            assert_eq!(ga.tris, gb.tris, "{name} is deterministic");
        }
        assert_eq!(cornell().triangle_count(), 812);
        assert!(office(7).meshes.len() > 90);
    }

    #[test]
    fn cornell_room_is_closed() {
        // Every ray from inside the room hits some wall: brute force over the wall triangles.
        let s = cornell();
        let g = crate::Geometry::from_scene(&s);
        let mut rng = Pcg32::new(5, 5);
        for _ in 0..2000 {
            let o = Vec3::new(
                rng.range(-0.9, 0.9),
                rng.range(-0.9, 0.9),
                rng.range(-0.9, 0.9),
            );
            let r =
                geom::tri::RayPre::new(&geom::Ray::new(o, rng.unit_vector(), 0.0, f32::INFINITY));
            assert!(g
                .tris
                .iter()
                .any(|t| geom::intersect(&r, t[0], t[1], t[2]).is_some()));
        }
    }
}
