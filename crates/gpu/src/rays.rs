//! Rays on the device, shared by every GPU engine and the device-resident frame: a batch's
//! buffers ([`DeviceRays`]), uploading a host batch's segments, and the hit records a
//! kernel writes (triangle, t, u, v bits) read back into [`trace::Hit`]s. The host-side twin
//! is [`trace::RayBatch`]; the layout is the one `shaders/common.wgsl` reads.

use crate::device::Gpu;
use trace::{Hit, RayBatch};

/// A ray batch on the device: origin | t_min and direction | t_max as vec4, kind | light << 2,
/// pixel, and the intersection kernel's per-ray constants (written by the hash kernel).
pub struct DeviceRays {
    /// Origin | t_min.
    pub org: wgpu::Buffer,
    /// Direction | t_max.
    pub dir: wgpu::Buffer,
    /// Kind | light << 2.
    pub kl: wgpu::Buffer,
    /// Pixel index.
    pub pix: wgpu::Buffer,
    /// Per-ray intersection constants (written by the hash kernel).
    pub pre: wgpu::Buffer,
    /// Number of rays.
    pub len: u64,
    /// The image width (RAH's screen key).
    pub width: u32,
}

impl DeviceRays {
    /// Room for `len` rays that kernels on the device will write (`what` names the buffers,
    /// e.g. "shadow"), with no screen layout.
    pub(crate) fn storage(g: &Gpu, what: &str, len: u64) -> DeviceRays {
        let buf = |field: &str, size: u64| g.storage(&format!("{what} {field}"), len * size);
        DeviceRays {
            org: buf("org", 16),
            dir: buf("dir", 16),
            kl: buf("kind", 4),
            pix: buf("pixel", 4),
            pre: buf("ray constants", 16),
            len,
            width: 0,
        }
    }

    /// Upload `rays` (the ray constants are left for the hash kernel to write).
    pub(crate) fn upload(g: &Gpu, rays: &RayBatch) -> DeviceRays {
        let n = rays.len();
        let (org, dir) = upload_segments(g, rays);
        let kl: Vec<u32> = (0..n)
            .map(|i| (rays.kind[i] as u32 & 3) | (rays.light[i] & 0x3fff_ffff) << 2)
            .collect();
        DeviceRays {
            org,
            dir,
            kl: g.upload("ray kind", &kl),
            pix: g.upload("ray pixel", &rays.pixel),
            pre: g.storage("ray constants", n as u64 * 16),
            len: n as u64,
            width: rays.width,
        }
    }
}

/// Only the rays' segments on the device: origin | t_min and direction | t_max (what a
/// traversal that needs no ray kinds, pixels or hash reads, such as the grid's).
pub(crate) fn upload_segments(g: &Gpu, rays: &RayBatch) -> (wgpu::Buffer, wgpu::Buffer) {
    let n = rays.len();
    let org: Vec<[f32; 4]> = (0..n)
        .map(|i| {
            let o = rays.org[i];
            [o.x, o.y, o.z, rays.t_min[i]]
        })
        .collect();
    let dir: Vec<[f32; 4]> = (0..n)
        .map(|i| {
            let d = rays.dir[i];
            [d.x, d.y, d.z, rays.t_max[i]]
        })
        .collect();
    (g.upload("ray org", &org), g.upload("ray dir", &dir))
}

/// Hit records read back from a kernel (triangle, t, u, v bits; triangle `NO_HIT`: a miss)
/// into `hits`.
pub(crate) fn records_to_hits(recs: &[[u32; 4]], hits: &mut [Hit]) {
    for (h, r) in hits.iter_mut().zip(recs) {
        *h = if r[0] == geom::NO_HIT {
            Hit::MISS
        } else {
            Hit {
                tri: r[0],
                t: f32::from_bits(r[1]),
                u: f32::from_bits(r[2]),
                v: f32::from_bits(r[3]),
            }
        };
    }
}
