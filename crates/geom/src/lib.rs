//! Geometric kernels shared by every rayspace engine.
//!
//! Everything here is a plain `Copy` value or a function over slices, so that a GPU backend can
//! mirror it 1:1: rays, the one ray–triangle kernel all engines use ([`tri::intersect`]), the
//! ray–box slab test, spheres and cones (the two halves of a ray-space hierarchy node), the
//! conservative node tests, and the minimal enclosing ball used to cull meshes; [`tri8`] runs the
//! triangle kernel on 8 rays at once, [`tris8`] one ray against 8 triangles, and [`cone8`]
//! grows 8 cones at once, with the same bits.

#![warn(missing_docs)]

pub mod aabb;
pub mod cone;
pub mod cone8;
pub mod isa;
pub mod miniball;
pub mod morton;
pub mod pmath;
pub mod polyhedra;
pub mod ray;
pub mod rng;
pub mod sphere;
pub mod tri;
pub mod tri8;
pub mod tris8;

pub use aabb::Aabb;
pub use cone::Cone;
pub use glam::{Mat3, Mat4, Quat, Vec3, Vec3A};
pub use isa::Isa;
pub use ray::Ray;
pub use rng::Pcg32;
pub use sphere::Sphere;
pub use tri::{intersect, TriHit};

/// Sentinel for "no triangle" in u32 triangle-id buffers.
pub const NO_HIT: u32 = u32::MAX;

/// True when every component of `v` is finite (not NaN, not ±inf).
#[inline]
pub fn finite3(v: Vec3) -> bool {
    v.x.is_finite() && v.y.is_finite() && v.z.is_finite()
}
