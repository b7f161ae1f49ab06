//! CRSH and RAH on the GPU, file for file the CPU's `crates/rsh/src`: [`hash`] → [`order`] →
//! [`build`] → [`traverse`] (with the final tests), sequenced by [`engine`] over the scene
//! buffers of [`device_scene`]; [`dual`] descends the object tree that
//! [`crate::bvh::objects`] builds (the LBVH) with the ray hierarchy. Each host file
//! launches the kernels of the WGSL file of the same name beside it (`order` uses the
//! primitives of [`crate::prims`]; the kinds' starts for `build` are `kinds.wgsl`).

pub mod build;
pub mod device_scene;
pub mod dual;
pub mod engine;
pub mod hash;
pub mod order;
pub mod traverse;

pub use engine::GpuRsh;
