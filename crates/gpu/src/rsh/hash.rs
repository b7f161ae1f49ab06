//! The ray hash on the GPU, the twin of `crates/rsh/src/hash.rs`: one kernel (`hash.wgsl`)
//! computes every ray's key (the thesis's typed 32-bit hash, eqs. 3.3–3.11, or RAH's
//! screen key), whether it can hit anything (t_min < t_max) and its intersection constants.

use super::device_scene::DeviceScene;
use crate::kernels::params::HashParams;
use crate::kernels::{launch, DevSize, Exec, Threads};
use crate::rays::DeviceRays;

/// Keys and validity flags of every ray (`screen`: RAH's pixel Z-order key). `count`: of
/// the first `count.n` rays only (a size on the device); the flags of the rest stay zero,
/// so the trim drops them.
pub fn hash_keys(
    eng: &DeviceScene,
    ex: &mut Exec,
    rays: &DeviceRays,
    screen: bool,
    count: Option<&DevSize>,
) -> (wgpu::Buffer, wgpu::Buffer) {
    let n = rays.len;
    let keys = eng.gpu.storage("keys", n * 4);
    let valid = eng.gpu.storage("valid", n * 4);
    let hb = &eng.cfg.hash_bits;
    ex.run_on(
        launch::HashKeys {
            h_org: &rays.org,
            h_dir: &rays.dir,
            h_kl: &rays.kl,
            h_pixel: &rays.pix,
            h_keys: &keys,
            h_valid: &valid,
            h_pre: &rays.pre,
        },
        HashParams {
            rays: n as u32,
            screen: screen as u32,
            width: rays.width,
            light_bits: hb.light,
            shadow_dir_bits: hb.shadow_dir,
            origin_bits: hb.origin,
            dir_bits: hb.dir,
            box_min: eng.box_min,
            box_ext: eng.box_ext,
        },
        Threads::of(count, n),
        256,
    );
    (keys, valid)
}
