//! Morton codes: three coordinates' bits interleaved, so that sorting by the code orders
//! points along a Z-order curve (the LBVH of `rsh::objects`, Karras 2012; the automatic
//! camera's triangle runs in `scene::autocam`).

use crate::{Aabb, Vec3};

/// The low `bits` bits of `v` spread to every third bit (the Morton interleave).
#[inline]
pub fn spread(v: u32, bits: u32) -> u64 {
    // The classic shift-and-mask interleave of 21 bits (bits ≤ 21), not a loop per bit.
    let mut x = (v as u64) & ((1u64 << bits) - 1);
    x = (x | x << 32) & 0x001f_0000_0000_ffff;
    x = (x | x << 16) & 0x001f_0000_ff00_00ff;
    x = (x | x << 8) & 0x100f_00f0_0f00_f00f;
    x = (x | x << 4) & 0x10c3_0c30_c30c_30c3;
    x = (x | x << 2) & 0x1249_2492_4924_9249;
    x
}

/// The Morton code of `p` in `b`, `bits` per axis (clamped to the box).
#[inline]
pub fn morton(p: Vec3, b: &Aabb, bits: u32) -> u64 {
    let e = (b.max - b.min).max(Vec3::splat(f32::MIN_POSITIVE));
    let cells = (1u32 << bits) as f32;
    let q = ((p - b.min) / e * cells).clamp(Vec3::ZERO, Vec3::splat(cells - 1.0));
    spread(q.x as u32, bits) | spread(q.y as u32, bits) << 1 | spread(q.z as u32, bits) << 2
}
