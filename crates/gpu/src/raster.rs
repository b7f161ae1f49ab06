//! Primary visibility on the GPU: a render pipeline with a depth test that writes the
//! thesis's G-buffer (§3.1) into render targets (position, shading normal, diffuse,
//! specular + shininess, and triangle id + barycentrics), read back into a
//! [`render::raster::GBuffer`] so the Whitted loop continues from it exactly as from the
//! CPU rasterizer's.
//!
//! It is not bit-identical to the CPU rasterizer, and is not meant to be: the hardware
//! snaps to its own sub-pixel grid (8 bits on lavapipe, 12 on the CPU rasterizer) and
//! interpolates barycentrics in its own precision. Pixels on triangle edges can be covered
//! by the neighbouring triangle, and positions differ by a few ulps; the tests state the
//! tolerance.

use crate::device::{Gpu, GpuError};
use geom::{Vec3, NO_HIT};
use render::raster::{GBuffer, RasterStats};
use render::View;
use scene::{Geometry, Material};

const FORMATS: [wgpu::TextureFormat; 5] = [
    wgpu::TextureFormat::Rgba32Float,
    wgpu::TextureFormat::Rgba32Float,
    wgpu::TextureFormat::Rgba32Float,
    wgpu::TextureFormat::Rgba32Float,
    wgpu::TextureFormat::Rgba32Uint,
];

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct ViewU {
    eye: [f32; 4],
    right: [f32; 4],
    up: [f32; 4],
    fwd: [f32; 4],
    proj: [f32; 4],
}
const _: () = assert!(std::mem::size_of::<ViewU>() == 80);

/// A G-buffer left on the device by [`GpuRaster::rasterize_device`]: three render targets
/// copied into storage buffers, pixel (x, y) at texel `y · stride + x`.
pub struct DeviceGBuffer {
    /// Position (xyz) and depth = near / z.
    pub pos: wgpu::Buffer,
    /// Interpolated shading normal (xyz).
    pub normal: wgpu::Buffer,
    /// Triangle id, u and v bits, and 1 where covered (0 elsewhere).
    pub id: wgpu::Buffer,
    /// Texels per row (rows are padded to 256 bytes).
    pub stride: u32,
}

/// The scene's triangles, normals and materials on the device, and the pipeline.
pub struct GpuRaster {
    gpu: Gpu,
    pipe: wgpu::RenderPipeline,
    tris: wgpu::Buffer,
    normals: wgpu::Buffer,
    material: wgpu::Buffer,
    mats: wgpu::Buffer,
    ntri: u32,
    /// Seconds of the last rasterization: GPU time from timestamps, or wall-clock time of
    /// the render pass and the read-back ([`crate::device::PhaseTimer`]).
    pub last_gpu_seconds: std::cell::Cell<Option<f64>>,
}

impl GpuRaster {
    /// Upload the scene's triangles and materials and build the render pipeline.
    pub fn new(gpu: &Gpu, geo: &Geometry, materials: &[Material]) -> Result<Self, GpuError> {
        let tris: Vec<[f32; 4]> = geo
            .tris
            .iter()
            .flat_map(|t| t.map(|v| [v.x, v.y, v.z, 1.0]))
            .collect();
        Self::with_triangles(gpu, gpu.upload("raster triangles", &tris), geo, materials)
    }

    /// [`GpuRaster::new`] over triangles already on the device (3 × vec4 per triangle, xyz
    /// read): an engine's, so that a dynamic scene's frame uploads its triangles once.
    pub fn with_triangles(
        gpu: &Gpu,
        tris: wgpu::Buffer,
        geo: &Geometry,
        materials: &[Material],
    ) -> Result<Self, GpuError> {
        let bytes = 16 * FORMATS.len() as u32;
        if gpu.limits.max_color_attachment_bytes_per_sample < bytes {
            return Err(GpuError::Limits(format!(
                "the G-buffer needs {bytes} colour bytes per sample, the device allows {}",
                gpu.limits.max_color_attachment_bytes_per_sample
            )));
        }
        let v4 = |v: Vec3, w: f32| [v.x, v.y, v.z, w];
        let normals: Vec<[f32; 4]> = geo
            .normals
            .iter()
            .flat_map(|t| t.map(|v| v4(v, 0.0)))
            .collect();
        let mats: Vec<[f32; 4]> = materials
            .iter()
            .flat_map(|m| [v4(m.diffuse, 0.0), v4(m.specular, m.shininess)])
            .collect();
        let module = gpu.shader("raster", include_str!("raster.wgsl"));
        let targets: Vec<Option<wgpu::ColorTargetState>> =
            FORMATS.iter().map(|&format| Some(format.into())).collect();
        let pipe = gpu
            .device
            .create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some("g-buffer"),
                layout: None,
                vertex: wgpu::VertexState {
                    module: &module,
                    entry_point: Some("vs"),
                    compilation_options: Default::default(),
                    buffers: &[],
                },
                primitive: wgpu::PrimitiveState {
                    cull_mode: None,
                    ..Default::default()
                },
                depth_stencil: Some(wgpu::DepthStencilState {
                    format: wgpu::TextureFormat::Depth32Float,
                    depth_write_enabled: Some(true),
                    depth_compare: Some(wgpu::CompareFunction::Greater),
                    stencil: Default::default(),
                    bias: Default::default(),
                }),
                multisample: Default::default(),
                fragment: Some(wgpu::FragmentState {
                    module: &module,
                    entry_point: Some("fs"),
                    compilation_options: Default::default(),
                    targets: &targets,
                }),
                multiview_mask: None,
                cache: None,
            });
        Ok(GpuRaster {
            gpu: gpu.clone(),
            pipe,
            tris,
            normals: gpu.upload("raster normals", &normals),
            material: gpu.upload("raster material ids", &geo.material),
            mats: gpu.upload("raster materials", &mats),
            ntri: geo.tris.len() as u32,
            last_gpu_seconds: std::cell::Cell::new(None),
        })
    }

    /// The scene as the device frame's kernels read it: triangles (3 × vec4 per triangle),
    /// vertex normals (3 × vec4) and material ids.
    pub(crate) fn scene_buffers(&self) -> (&wgpu::Buffer, &wgpu::Buffer, &wgpu::Buffer) {
        (&self.tris, &self.normals, &self.material)
    }

    /// Whether a `width × height` G-buffer fits the device: its texture size limit, and one
    /// read-back buffer per render target.
    pub fn check_size(&self, width: u32, height: u32) -> Result<(), GpuError> {
        let lim = &self.gpu.limits;
        if width.max(height) > lim.max_texture_dimension_2d {
            return Err(GpuError::Limits(format!(
                "a {width}×{height} G-buffer exceeds the device's {} pixel texture limit",
                lim.max_texture_dimension_2d
            )));
        }
        let bytes = (width as u64 * 16).next_multiple_of(256) * height as u64;
        if bytes > lim.max_buffer_size {
            return Err(GpuError::Limits(format!(
                "a {width}×{height} G-buffer target needs {} MiB, above the device's {} MiB buffers",
                bytes >> 20,
                lim.max_buffer_size >> 20
            )));
        }
        Ok(())
    }

    /// Draw `view` into the render targets and copy targets `keep` into buffers of `usage`
    /// (rows padded to 256 bytes: the row length in bytes is returned), submitted; the GPU
    /// time is set from timestamps when the adapter has them.
    fn draw(
        &self,
        view: &View,
        near: f32,
        keep: &[usize],
        usage: wgpu::BufferUsages,
    ) -> (Vec<wgpu::Buffer>, u64) {
        let g = &self.gpu;
        let (w, h) = (view.width, view.height);
        let size = wgpu::Extent3d {
            width: w,
            height: h,
            depth_or_array_layers: 1,
        };
        let tex = |format, label| {
            g.device.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size,
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
                view_formats: &[],
            })
        };
        let targets: Vec<wgpu::Texture> = FORMATS.iter().map(|&f| tex(f, "g-buffer")).collect();
        let depth = tex(wgpu::TextureFormat::Depth32Float, "depth");
        let views: Vec<wgpu::TextureView> = targets
            .iter()
            .map(|t| t.create_view(&Default::default()))
            .collect();
        let dview = depth.create_view(&Default::default());
        let c = |v: Vec3| [v.x, v.y, v.z, 0.0];
        // A jittered view (antialiasing) moves the geometry by −jitter pixels: in clip
        // space x + jx·z and y + jy·z with these factors (`raster.wgsl`, applied only when
        // proj.w is 1, so a centred view's bits are untouched).
        let [jx, jy] = view.jitter;
        let jittered = jx != 0.0 || jy != 0.0;
        let vu = ViewU {
            eye: c(view.eye),
            right: [
                view.right.x,
                view.right.y,
                view.right.z,
                -2.0 * jx / view.width as f32,
            ],
            up: [
                view.up.x,
                view.up.y,
                view.up.z,
                2.0 * jy / view.height as f32,
            ],
            fwd: c(view.fwd),
            proj: [
                view.tan_x,
                view.tan_y,
                near,
                if jittered { 1.0 } else { 0.0 },
            ],
        };
        let ub = g.uniform("view", &vu);
        let bg = g.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("raster"),
            layout: &self.pipe.get_bind_group_layout(0),
            entries: &crate::kernels::RasterBindings {
                r_view: &ub,
                r_tris: &self.tris,
                r_normals: &self.normals,
                r_material: &self.material,
                r_mats: &self.mats,
            }
            .entries(),
        });
        let wall = g.timer == crate::device::PhaseTimer::WallClock;
        let qs = (!wall).then(|| {
            g.device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("raster timestamps"),
                ty: wgpu::QueryType::Timestamp,
                count: 2,
            })
        });
        let mut enc = g.device.create_command_encoder(&Default::default());
        {
            let attachments: Vec<Option<wgpu::RenderPassColorAttachment>> = views
                .iter()
                .map(|v| {
                    Some(wgpu::RenderPassColorAttachment {
                        view: v,
                        depth_slice: None,
                        resolve_target: None,
                        ops: wgpu::Operations {
                            load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                            store: wgpu::StoreOp::Store,
                        },
                    })
                })
                .collect();
            let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("g-buffer"),
                color_attachments: &attachments,
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &dview,
                    depth_ops: Some(wgpu::Operations {
                        load: wgpu::LoadOp::Clear(0.0),
                        store: wgpu::StoreOp::Store,
                    }),
                    stencil_ops: None,
                }),
                timestamp_writes: qs.as_ref().map(|q| wgpu::RenderPassTimestampWrites {
                    query_set: q,
                    beginning_of_pass_write_index: Some(0),
                    end_of_pass_write_index: Some(1),
                }),
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_pipeline(&self.pipe);
            pass.set_bind_group(0, &bg, &[]);
            pass.draw(0..3 * self.ntri, 0..1);
        }
        // Rows padded to 256 bytes, as texture copies require.
        let row = (w as u64 * 16).next_multiple_of(256);
        let bufs: Vec<wgpu::Buffer> = keep
            .iter()
            .map(|&k| {
                let b = g.device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("g-buffer copy"),
                    size: row * h as u64,
                    usage: usage | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                });
                enc.copy_texture_to_buffer(
                    targets[k].as_image_copy(),
                    wgpu::TexelCopyBufferInfo {
                        buffer: &b,
                        layout: wgpu::TexelCopyBufferLayout {
                            offset: 0,
                            bytes_per_row: Some(row as u32),
                            rows_per_image: Some(h),
                        },
                    },
                    size,
                );
                b
            })
            .collect();
        let ts_buf = qs.as_ref().map(|q| {
            let r = g.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("raster timestamps"),
                size: 16,
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            });
            enc.resolve_query_set(q, 0..2, &r, 0);
            r
        });
        g.queue.submit([enc.finish()]);
        if let Some(r) = ts_buf {
            let t: Vec<u64> = g.read(&r, 2);
            let secs =
                t[1].saturating_sub(t[0]) as f64 * g.queue.get_timestamp_period() as f64 * 1e-9;
            self.last_gpu_seconds.set(Some(secs));
        }
        (bufs, row)
    }

    /// Rasterize into a G-buffer that stays on the device (position | depth, shading
    /// normal and triangle id | barycentrics targets, as storage buffers): the device-resident
    /// frame's primary visibility ([`crate::frame`]). Nothing is read back.
    pub fn rasterize_device(&self, view: &View, near: f32) -> DeviceGBuffer {
        let t0 = std::time::Instant::now();
        let (mut b, row) = self.draw(view, near, &[0, 1, 4], wgpu::BufferUsages::STORAGE);
        if self.gpu.timer == crate::device::PhaseTimer::WallClock {
            self.gpu
                .device
                .poll(wgpu::PollType::wait_indefinitely())
                .expect("GPU device lost");
            self.last_gpu_seconds.set(Some(t0.elapsed().as_secs_f64()));
        }
        let id = b.pop().expect("three targets");
        let normal = b.pop().expect("three targets");
        let pos = b.pop().expect("three targets");
        DeviceGBuffer {
            pos,
            normal,
            id,
            stride: (row / 16) as u32,
        }
    }

    /// Rasterize into a G-buffer of `view`'s size (which [`GpuRaster::check_size`] accepts).
    pub fn rasterize(&self, view: &View, near: f32) -> (GBuffer, RasterStats) {
        let g = &self.gpu;
        let (w, h) = (view.width, view.height);
        let wall = g.timer == crate::device::PhaseTimer::WallClock;
        let t0 = std::time::Instant::now();
        let (bufs, row) = self.draw(view, near, &[0, 1, 2, 3, 4], wgpu::BufferUsages::MAP_READ);
        let data: Vec<Vec<[u32; 4]>> = bufs
            .iter()
            .map(|b| {
                let raw: Vec<[u32; 4]> = g.map_read(b, (row / 16 * h as u64) as usize);
                (0..h as usize)
                    .flat_map(|y| {
                        let s = y * (row / 16) as usize;
                        raw[s..s + w as usize].to_vec()
                    })
                    .collect()
            })
            .collect();
        if wall {
            self.last_gpu_seconds.set(Some(t0.elapsed().as_secs_f64()));
        }
        let n = (w * h) as usize;
        let f = |p: [u32; 4]| {
            Vec3::new(
                f32::from_bits(p[0]),
                f32::from_bits(p[1]),
                f32::from_bits(p[2]),
            )
        };
        let mut gb = GBuffer {
            width: w,
            height: h,
            tri: vec![NO_HIT; n],
            bary: vec![[0.0; 2]; n],
            inv_depth: vec![0.0; n],
            position: vec![Vec3::ZERO; n],
            normal: vec![Vec3::ZERO; n],
            diffuse: vec![Vec3::ZERO; n],
            specular: vec![[0.0; 4]; n],
        };
        #[allow(clippy::needless_range_loop)] // p indexes five parallel targets
        for p in 0..n {
            let id = data[4][p];
            if id[3] == 0 {
                continue;
            }
            gb.tri[p] = id[0];
            gb.bary[p] = [f32::from_bits(id[1]), f32::from_bits(id[2])];
            gb.position[p] = f(data[0][p]);
            // depth = near / z.
            gb.inv_depth[p] = f32::from_bits(data[0][p][3]) / near;
            gb.normal[p] = f(data[1][p]);
            gb.diffuse[p] = f(data[2][p]);
            gb.specular[p] = data[3][p].map(f32::from_bits);
        }
        // The hardware does not report set-up, binning or fragment counts.
        let stats = RasterStats {
            triangles: self.ntri as u64,
            ..Default::default()
        };
        (gb, stats)
    }
}
