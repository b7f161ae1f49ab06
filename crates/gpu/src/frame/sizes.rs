//! The sizes a device-resident frame leaves on the device, so that nothing inside a frame
//! waits for the host. A generation's surfaces, rays and hits are counted by scans on the device; where
//! the generation's bound fits (`Capacity`), its buffers are allocated at that bound and
//! every launch over them reads the count there (`Exec::run_on`: the first parameter
//! word patched on the device, the workgroups from an indirect-dispatch block), so the host
//! never waits for it. The statistics those counts feed (covered pixels, rays by kind, rays
//! traced) are read with the image, in the frame's one read-back (`Deferrals`).
//!
//! The bounds are exact: a generation has at most one surface per covered pixel, or per
//! bounce ray; at most two bounce rays per surface (thesis eqs. 3.3–3.7: a reflection and
//! a refraction), one in a scene where no material both reflects and is transparent, and
//! none where no material does either (then the loop stops after the first generation, as
//! it would on reading a zero). A bound that would not fit one binding, the engine's part or the memory
//! budget falls back to reading the count back (one read-back, the buffers sized exactly).

use crate::kernels::{DevLen, Exec};
use render::stats::RenderStats;

/// Bytes a device-sized generation allocates per surface of its bound with `nl` lights:
/// the surfaces and their pixel (88), colours (16), per shadow ray its rays, constants,
/// records, best pair, occlusion and counter words (88), the two bounce slots with flags
/// and offsets (112) and two bounce rays with weights, records, best pairs, hit flags and
/// offsets (216).
pub fn bytes_per_surface(nl: u64) -> u64 {
    88 + 16 + 88 * nl + 112 + 216
}

/// Most bytes one device-sized generation may allocate at its bound by default; a larger
/// bound reads its count back and allocates exactly.
pub const BUDGET: u64 = 1 << 30;

/// Which bounds a frame may allocate at instead of reading a count back.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Capacity {
    /// The engine traces batches whose size is on the device.
    pub engine: bool,
    /// Most surfaces of one part ([`super::GpuBackend::part_size`]).
    pub part: u64,
    /// Most rays of one engine trace.
    pub rays: u64,
    /// Lights of the scene.
    pub lights: u64,
    /// Most bytes a device-sized generation may allocate ([`BUDGET`] unless set).
    pub budget: u64,
}

impl Capacity {
    /// Whether a generation of at most `surfaces` surfaces may be device-sized: the
    /// engine can trace its batches so, and one part, one engine trace of its shadow and
    /// bounce rays, and the budget hold its bound.
    pub fn fits(&self, surfaces: u64) -> bool {
        let per = self.lights.max(2);
        self.engine
            && surfaces > 0
            && surfaces <= self.part
            && surfaces * per <= self.rays
            && surfaces.saturating_mul(bytes_per_surface(self.lights)) <= self.budget
    }
}

/// What a count left on the device adds to the frame's statistics.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Counted {
    /// Covered pixels (the first generation's surfaces).
    Covered,
    /// Shadow rays.
    Shadow,
    /// Bounce rays (reflection until [`Counted::Refractions`] moves its share).
    Bounce,
    /// Per-chunk refraction counts of a bounce batch's slots.
    Refractions,
    /// Rays traced (`stats.trace.rays`).
    Traced,
}

/// Counts the frame left on the device, read with its image.
#[derive(Default)]
pub(crate) struct Deferrals {
    list: Vec<(Counted, wgpu::Buffer, u64, u64)>,
}

impl Deferrals {
    /// The count `len` adds to `what`.
    pub fn push(&mut self, what: Counted, len: &DevLen) {
        self.list.push((what, len.buf.clone(), len.at, 1));
    }

    /// `words` words of `buf` from its start add to `what`.
    pub fn push_words(&mut self, what: Counted, buf: &wgpu::Buffer, words: u64) {
        self.list.push((what, buf.clone(), 0, words));
    }

    /// Words [`Deferrals::copy`] lays out.
    pub fn words(&self) -> u64 {
        self.list.iter().map(|d| d.3).sum()
    }

    /// Every count copied, end to end, into `all` from byte `at`.
    pub fn copy(&self, ex: &mut Exec, all: &wgpu::Buffer, at: u64) {
        let mut at = at;
        for (_, buf, word, words) in &self.list {
            ex.copy_at(buf, word * 4, all, at, words * 4);
            at += words * 4;
        }
    }

    /// The counts `words` (laid out by [`Deferrals::copy`]) into `stats`, drained.
    pub fn settle(&mut self, words: &[u32], stats: &mut RenderStats) {
        let mut rest = words;
        for (what, _, _, n) in std::mem::take(&mut self.list) {
            let (mine, more) = rest.split_at(n as usize);
            rest = more;
            let v: u64 = mine.iter().map(|&w| w as u64).sum();
            match what {
                Counted::Covered => stats.covered_pixels += v,
                Counted::Shadow => stats.rays_shadow += v,
                Counted::Bounce => stats.rays_reflection += v,
                Counted::Refractions => {
                    // A batch's bounce count came first: its refractions move across.
                    stats.rays_reflection -= v;
                    stats.rays_refraction += v;
                }
                Counted::Traced => stats.trace.rays += v,
            }
        }
    }
}
