//! The CPU backend of the Whitted loop ([`crate::whitted::run`]): the CPU rasterizer's
//! G-buffer (thesis §3.1), surfaces and rays as host arrays ([`crate::secondary`],
//! eqs. 3.1–3.7), Blinn-Phong shading on rayon's threads ([`crate::shade`], eqs.
//! 3.17–3.19), and any [`Tracer`] for the batches. The GPU backend (`gpu::frame`) is its twin
//! with device buffers.

use crate::raster::{rasterize, GBuffer, RasterStats};
use crate::secondary::{bounce_rays, shadow_rays, Surfaces};
use crate::shade;
use crate::stats::RenderStats;
use crate::view::View;
use crate::whitted::{Backend, Rendered};
use geom::Vec3;
use rayon::prelude::*;
use scene::{Geometry, Scene};
use trace::batch::{Hit, RayBatch};
use trace::tracer::{TraceMode, Tracer};
use trace::TraceStats;

/// A render on the CPU with `tracer`: the image as linear RGB on the host.
pub struct CpuBackend<'a> {
    scene: &'a Scene,
    geo: &'a Geometry,
    tracer: &'a dyn Tracer,
    given: Option<GBuffer>,
    gb: GBuffer,
    raster: RasterStats,
    pixels: Vec<Vec3>,
}

impl<'a> CpuBackend<'a> {
    /// A backend for frames of `scene` (geometry `geo`) traced by `tracer`.
    pub fn new(scene: &'a Scene, geo: &'a Geometry, tracer: &'a dyn Tracer) -> Self {
        CpuBackend {
            scene,
            geo,
            tracer,
            given: None,
            gb: GBuffer::default(),
            raster: RasterStats::default(),
            pixels: Vec::new(),
        }
    }
}

impl CpuBackend<'_> {
    /// The frame over `gb`, a G-buffer of the frame's size made elsewhere (the GPU's
    /// rasterizer, read back), instead of the CPU rasterizer's.
    pub fn with_gbuffer(mut self, gb: GBuffer) -> Self {
        self.given = Some(gb);
        self
    }
}

/// Local illumination of every surface of `s` times its throughput ([`shade::local`]) under
/// `scene`'s materials and lights; `occluded[i · lights + l]` says whether light l is hidden
/// from surface i.
pub fn local_shading(s: &Surfaces, scene: &Scene, occluded: &[bool]) -> Vec<Vec3> {
    let (materials, lights) = (&scene.materials, &scene.lights);
    let nl = lights.len();
    (0..s.len())
        .into_par_iter()
        .map(|i| {
            let visible: Vec<bool> = (0..nl).map(|l| !occluded[i * nl + l]).collect();
            let m = &materials[s.material[i] as usize];
            shade::local(s, i, m, lights, &visible, scene.ambient) * s.throughput[i]
        })
        .collect()
}

impl Backend for CpuBackend<'_> {
    type Surfaces = Surfaces;
    type Rays = RayBatch;
    type Hits = Vec<Hit>;

    fn engine_name(&self) -> String {
        self.tracer.name().to_string()
    }

    fn rasterize(&mut self, view: &View, near: f32) {
        match self.given.take() {
            Some(gb) => {
                self.gb = gb;
                self.raster = RasterStats {
                    triangles: self.geo.len() as u64,
                    ..Default::default()
                };
            }
            None => (self.gb, self.raster) = rasterize(self.geo, &self.scene.materials, view, near),
        }
    }

    fn primary_surfaces(&mut self, view: &View) -> Surfaces {
        let bg = self.scene.background;
        self.pixels = self
            .gb
            .tri
            .iter()
            .map(|&t| if t == geom::NO_HIT { bg } else { Vec3::ZERO })
            .collect();
        Surfaces::from_gbuffer(&self.gb, self.geo, view.eye)
    }

    fn surfaces_len(&self, s: &Surfaces) -> u64 {
        s.len() as u64
    }

    fn shadow_rays(&mut self, s: &Surfaces) -> RayBatch {
        shadow_rays(s, &self.scene.lights)
    }

    fn bounce_rays(&mut self, s: &Surfaces) -> RayBatch {
        bounce_rays(s, &self.scene.materials)
    }

    fn rays_len(&self, r: &RayBatch) -> u64 {
        r.len() as u64
    }

    fn count_kinds(&mut self, r: &RayBatch) -> [u64; 4] {
        r.count_by_kind()
    }

    fn trace(&mut self, r: &RayBatch, mode: TraceMode, stats: &mut TraceStats) -> Vec<Hit> {
        let mut hits = vec![Hit::MISS; r.len()];
        self.tracer.trace(r, mode, &mut hits, stats);
        hits
    }

    fn shade(&mut self, s: &Surfaces, shadows: Option<(&RayBatch, &Vec<Hit>)>) {
        let occluded: Vec<bool> = match shadows {
            Some((_, h)) => h.iter().map(|h| h.is_hit()).collect(),
            None => vec![false; s.len() * self.scene.lights.len()],
        };
        for (i, c) in local_shading(s, self.scene, &occluded)
            .into_iter()
            .enumerate()
        {
            self.pixels[s.pixel[i] as usize] += c;
        }
    }

    fn next_surfaces(&mut self, r: &RayBatch, h: &Vec<Hit>) -> Surfaces {
        let bg = self.scene.background;
        for (i, h) in h.iter().enumerate() {
            if !h.is_hit() {
                self.pixels[r.pixel[i] as usize] += bg * r.throughput[i];
            }
        }
        Surfaces::from_hits(r, h, self.geo)
    }

    fn sync(&mut self) {}

    fn finish(&mut self, stats: RenderStats, _linear: bool) -> Rendered {
        Rendered {
            pixels: std::mem::take(&mut self.pixels),
            srgb8: None,
            gbuffer: std::mem::take(&mut self.gb),
            raster: std::mem::take(&mut self.raster),
            stats,
        }
    }
}
