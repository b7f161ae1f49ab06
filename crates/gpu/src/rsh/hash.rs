//! The ray hash on the GPU, the twin of `crates/rsh/src/hash.rs`: one kernel (`hash.wgsl`)
//! computes every ray's key (the thesis's typed 32-bit hash, eqs. 3.3–3.11, or RAH's
//! screen key), whether it can hit anything (t_min < t_max) and its intersection constants.

use super::device_scene::DeviceScene;
use crate::kernels::{Exec, Kernel, Params};
use crate::rays::DeviceRays;

/// Keys and validity flags of every ray (`screen`: RAH's pixel Z-order key).
pub fn hash_keys(
    eng: &DeviceScene,
    ex: &mut Exec,
    rays: &DeviceRays,
    screen: bool,
) -> (wgpu::Buffer, wgpu::Buffer) {
    let n = rays.len;
    let keys = eng.gpu.storage("keys", n * 4);
    let valid = eng.gpu.storage("valid", n * 4);
    let hb = &eng.cfg.hash_bits;
    ex.run(
        Kernel::HashKeys,
        Params {
            u: [
                [n as u32, screen as u32, rays.width, hb.light],
                [hb.shadow_dir, hb.origin, hb.dir, 0],
                [0; 4],
                [0; 4],
            ],
            f: [eng.box_min, eng.box_ext],
        },
        &[
            (1, &rays.org),
            (2, &rays.dir),
            (3, &rays.kl),
            (4, &rays.pix),
            (5, &keys),
            (6, &valid),
            (7, &rays.pre),
        ],
        n,
        256,
    );
    (keys, valid)
}
