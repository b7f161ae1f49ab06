//! The viewer's window: winit for the window and input, wgpu to show the frame (the frame's
//! RGB8 pixels uploaded to a texture and drawn by a full-screen triangle, nearest texel per
//! window pixel), with the overlay's text drawn into the pixels before the upload.
//!
//! Progressive display: while the view changes (a drag, a key, a playing animation) and
//! the last full frame took longer than the display interval, frames are rendered at a
//! lower resolution chosen so that they fit it; once the view rests, one full-resolution
//! frame follows. `--screenshot` renders `--frames` full frames through the same path,
//! reads the last one back from the GPU after the draw, and writes it as a PNG.

use super::session::Session;
use anyhow::{anyhow, Context, Result};
use gpu::wgpu;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant};
use winit::application::ApplicationHandler;
use winit::event::{ElementState, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::keyboard::{Key, NamedKey};
use winit::window::{Window, WindowId};

/// How the viewer runs.
pub struct WindowOptions {
    /// Write the last of `frames` full-resolution frames here and exit.
    pub screenshot: Option<PathBuf>,
    pub frames: u32,
    /// Draw the text overlay (default on; off in screenshots unless asked).
    pub overlay: bool,
    /// The display interval the progressive preview aims at.
    pub interval: Duration,
    /// Screenshot frames at 1/scale resolution (to measure the preview's rate); 1 = full.
    pub scale: u32,
}

/// The blit's bind group by name: the one place its binding numbers are written (the
/// shader's declarations are made from it, [`shader`]).
struct BlitBindings<'a> {
    img: &'a wgpu::TextureView,
    size: &'a wgpu::Buffer,
}

impl BlitBindings<'_> {
    const IMG: u32 = 0;
    const SIZE: u32 = 1;

    fn entries(&self) -> [wgpu::BindGroupEntry<'_>; 2] {
        [
            wgpu::BindGroupEntry {
                binding: Self::IMG,
                resource: wgpu::BindingResource::TextureView(self.img),
            },
            wgpu::BindGroupEntry {
                binding: Self::SIZE,
                resource: self.size.as_entire_binding(),
            },
        ]
    }
}

/// The blit shader, its bindings declared from [`BlitBindings`].
fn shader() -> String {
    format!(
        "@group(0) @binding({}) var img: texture_2d<f32>;\n@group(0) @binding({}) var<uniform> size: Size;\n{BLIT}",
        BlitBindings::IMG,
        BlitBindings::SIZE
    )
}

const BLIT: &str = r#"
struct Out { @builtin(position) pos: vec4<f32> };
@vertex fn vs(@builtin(vertex_index) i: u32) -> Out {
    let p = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    return Out(vec4<f32>(p * 2.0 - 1.0, 0.0, 1.0));
}
struct Size { target_size: vec2<f32> };
fn texel(pos: vec4<f32>) -> vec4<f32> {
    let d = vec2<f32>(textureDimensions(img));
    let xy = vec2<i32>(floor(pos.xy * d / size.target_size));
    return textureLoad(img, clamp(xy, vec2<i32>(0), vec2<i32>(d) - 1), 0);
}
// The pixels are sRGB-encoded already: a UNORM target takes them as they are, an sRGB
// target would encode them again, so they are decoded first.
@fragment fn fs_unorm(i: Out) -> @location(0) vec4<f32> { return texel(i.pos); }
@fragment fn fs_srgb(i: Out) -> @location(0) vec4<f32> {
    let c = texel(i.pos).rgb;
    let lin = select(pow((c + 0.055) / 1.055, vec3<f32>(2.4)), c / 12.92, c <= vec3<f32>(0.04045));
    return vec4<f32>(lin, 1.0);
}
"#;

struct Gfx {
    window: Arc<Window>,
    surface: wgpu::Surface<'static>,
    device: wgpu::Device,
    queue: wgpu::Queue,
    config: wgpu::SurfaceConfiguration,
    module: wgpu::ShaderModule,
    surface_pipe: wgpu::RenderPipeline,
    texture: wgpu::Texture,
    size_buf: wgpu::Buffer,
    describe: String,
}

fn pipeline(
    device: &wgpu::Device,
    module: &wgpu::ShaderModule,
    format: wgpu::TextureFormat,
) -> wgpu::RenderPipeline {
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some("viewer blit"),
        layout: None,
        vertex: wgpu::VertexState {
            module,
            entry_point: Some("vs"),
            compilation_options: Default::default(),
            buffers: &[],
        },
        primitive: Default::default(),
        depth_stencil: None,
        multisample: Default::default(),
        fragment: Some(wgpu::FragmentState {
            module,
            entry_point: Some(if format.is_srgb() {
                "fs_srgb"
            } else {
                "fs_unorm"
            }),
            compilation_options: Default::default(),
            targets: &[Some(format.into())],
        }),
        multiview_mask: None,
        cache: None,
    })
}

impl Gfx {
    fn new(window: Arc<Window>, w: u32, h: u32) -> Result<Gfx> {
        let mut desc = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
        if std::env::var_os("WGPU_BACKEND").is_none() {
            desc.backends = wgpu::Backends::VULKAN | wgpu::Backends::METAL | wgpu::Backends::DX12;
        }
        let instance = wgpu::Instance::new(desc);
        let surface = instance
            .create_surface(window.clone())
            .map_err(|e| anyhow!("view: cannot show a window through the GPU driver: {e}"))?;
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            compatible_surface: Some(&surface),
            ..Default::default()
        }))
        .map_err(|e| anyhow!("view: no GPU adapter can present to this window: {e}"))?;
        let info = adapter.get_info();
        let (device, queue) = pollster::block_on(adapter.request_device(&Default::default()))
            .map_err(|e| anyhow!("view: {e}"))?;
        let size = window.inner_size();
        let mut config = surface
            .get_default_config(&adapter, size.width.max(1), size.height.max(1))
            .ok_or_else(|| {
                anyhow!(
                    "view: the window's surface is not supported by {}",
                    info.name
                )
            })?;
        // Prefer a UNORM format, so the frame's bytes reach the screen unchanged.
        let caps = surface.get_capabilities(&adapter);
        if let Some(f) = caps.formats.iter().find(|f| !f.is_srgb()) {
            config.format = *f;
        }
        config.present_mode = wgpu::PresentMode::AutoVsync;
        surface.configure(&device, &config);
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("viewer"),
            source: wgpu::ShaderSource::Wgsl(shader().into()),
        });
        let surface_pipe = pipeline(&device, &module, config.format);
        let texture = Self::texture(
            &device,
            w,
            h,
            wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
        );
        let size_buf = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("viewer target size"),
            size: 16,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Ok(Gfx {
            window,
            surface,
            device,
            queue,
            config,
            module,
            surface_pipe,
            texture,
            size_buf,
            describe: format!("{} ({:?})", info.name, info.backend),
        })
    }

    /// An RGBA8 texture of `w × h` (the frame; the screenshot's target).
    fn texture(device: &wgpu::Device, w: u32, h: u32, usage: wgpu::TextureUsages) -> wgpu::Texture {
        device.create_texture(&wgpu::TextureDescriptor {
            label: Some("viewer frame"),
            size: wgpu::Extent3d {
                width: w,
                height: h,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::Rgba8Unorm,
            usage,
            view_formats: &[],
        })
    }

    fn resize(&mut self, w: u32, h: u32) {
        if w > 0 && h > 0 {
            self.config.width = w;
            self.config.height = h;
            self.surface.configure(&self.device, &self.config);
        }
    }

    fn upload(&self, rgb: &[u8], w: u32, h: u32) {
        let rgba: Vec<u8> = rgb
            .chunks_exact(3)
            .flat_map(|p| [p[0], p[1], p[2], 255])
            .collect();
        self.queue.write_texture(
            self.texture.as_image_copy(),
            &rgba,
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(w * 4),
                rows_per_image: Some(h),
            },
            wgpu::Extent3d {
                width: w,
                height: h,
                depth_or_array_layers: 1,
            },
        );
    }

    /// Draw the frame texture into `view` (of `tw × th` pixels) with `pipe`.
    fn draw(
        &self,
        enc: &mut wgpu::CommandEncoder,
        pipe: &wgpu::RenderPipeline,
        view: &wgpu::TextureView,
        tw: u32,
        th: u32,
    ) {
        self.queue.write_buffer(
            &self.size_buf,
            0,
            bytemuck::cast_slice(&[tw as f32, th as f32, 0.0, 0.0]),
        );
        let tv = self.texture.create_view(&Default::default());
        let bg = self.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("viewer blit"),
            layout: &pipe.get_bind_group_layout(0),
            entries: &BlitBindings {
                img: &tv,
                size: &self.size_buf,
            }
            .entries(),
        });
        let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("viewer blit"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: None,
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(pipe);
        pass.set_bind_group(0, &bg, &[]);
        pass.draw(0..3, 0..1);
    }

    fn present(&mut self) -> Result<()> {
        let frame = match self.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(f)
            | wgpu::CurrentSurfaceTexture::Suboptimal(f) => f,
            wgpu::CurrentSurfaceTexture::Timeout | wgpu::CurrentSurfaceTexture::Occluded => {
                return Ok(());
            }
            _ => {
                // Outdated or lost: configure again and skip this frame.
                self.surface.configure(&self.device, &self.config);
                return Ok(());
            }
        };
        let view = frame.texture.create_view(&Default::default());
        let mut enc = self.device.create_command_encoder(&Default::default());
        self.draw(
            &mut enc,
            &self.surface_pipe,
            &view,
            self.config.width,
            self.config.height,
        );
        self.queue.submit([enc.finish()]);
        self.queue.present(frame);
        Ok(())
    }

    /// The frame drawn by the same shader into an offscreen `w × h` RGBA8 target and read
    /// back: what the window shows, at the frame's own resolution, as RGB8.
    fn read_back(&self, w: u32, h: u32) -> Result<Vec<u8>> {
        let format = wgpu::TextureFormat::Rgba8Unorm;
        let target = Self::texture(
            &self.device,
            w,
            h,
            wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
        );
        let pipe = pipeline(&self.device, &self.module, format);
        let row = (w as u64 * 4).next_multiple_of(256);
        let buf = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("viewer screenshot read-back"),
            size: row * h as u64,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut enc = self.device.create_command_encoder(&Default::default());
        self.draw(
            &mut enc,
            &pipe,
            &target.create_view(&Default::default()),
            w,
            h,
        );
        enc.copy_texture_to_buffer(
            target.as_image_copy(),
            wgpu::TexelCopyBufferInfo {
                buffer: &buf,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(row as u32),
                    rows_per_image: Some(h),
                },
            },
            wgpu::Extent3d {
                width: w,
                height: h,
                depth_or_array_layers: 1,
            },
        );
        self.queue.submit([enc.finish()]);
        let slice = buf.slice(..);
        let (tx, rx) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| anyhow!("view: the GPU was lost reading the screenshot: {e}"))?;
        rx.recv()
            .map_err(|e| anyhow!("view: {e}"))?
            .map_err(|e| anyhow!("view: mapping the screenshot: {e}"))?;
        let data = slice
            .get_mapped_range()
            .map_err(|e| anyhow!("view: mapping the screenshot: {e:?}"))?;
        let mut rgb = Vec::with_capacity(w as usize * h as usize * 3);
        for y in 0..h as usize {
            let r = &data[y * row as usize..y * row as usize + w as usize * 4];
            for p in r.chunks_exact(4) {
                rgb.extend_from_slice(&p[..3]);
            }
        }
        Ok(rgb)
    }
}

struct App {
    session: Session,
    opts: WindowOptions,
    gfx: Option<Gfx>,
    error: Option<anyhow::Error>,
    frames: u32,
    started: Instant,
    overlay: bool,
    /// When the view last changed; a full frame follows once it has rested.
    changed: Option<Instant>,
    /// Seconds of the last full-resolution frame (chooses the preview scale).
    full_seconds: f64,
    needs_full: bool,
    drag: Option<(MouseButton, (f64, f64))>,
    cursor: (f64, f64),
    last_tick: Instant,
}

impl App {
    fn fail(&mut self, el: &ActiveEventLoop, e: anyhow::Error) {
        self.error = Some(e);
        el.exit();
    }

    fn touch(&mut self) {
        self.changed = Some(Instant::now());
        self.needs_full = true;
        if let Some(g) = &self.gfx {
            g.window.request_redraw();
        }
    }

    fn redraw(&mut self, el: &ActiveEventLoop) -> Result<()> {
        let now = Instant::now();
        if self.session.playing {
            let dt = now.duration_since(self.last_tick).as_secs_f32();
            let t = self.session.time + dt;
            self.session.set_time(t);
        }
        self.last_tick = now;
        // Preview while the view moves and a full frame would miss the display interval.
        let moving = self.session.playing
            || self
                .changed
                .is_some_and(|c| c.elapsed() < Duration::from_millis(150));
        let interval = self.opts.interval.as_secs_f64();
        let scale = if self.opts.screenshot.is_some() {
            self.opts.scale.max(1)
        } else if !moving || self.full_seconds <= interval {
            1
        } else {
            // Cost falls with the pixel count (1/scale²); aim at 80 % of the interval,
            // leaving room for the upload and the present.
            ((self.full_seconds / (0.8 * interval)).sqrt().ceil() as u32).clamp(2, 8)
        };
        let mut rgb = self.session.frame(scale)?;
        if scale == 1 {
            self.full_seconds = self.session.last.seconds;
            self.needs_full = false;
        }
        let (w, h) = (self.session.width, self.session.height);
        if self.overlay {
            let lines = self.session.overlay();
            if super::overlay::draw(&mut rgb, w, h, &lines).is_err() {
                // No font: the overlay's first lines go to the title bar instead.
                if let Some(g) = &self.gfx {
                    g.window.set_title(&lines[..2.min(lines.len())].join(" | "));
                }
            }
        }
        let g = self.gfx.as_mut().ok_or_else(|| anyhow!("no window"))?;
        g.upload(&rgb, w, h);
        g.present()?;
        self.frames += 1;
        if let Some(path) = &self.opts.screenshot {
            if self.frames >= self.opts.frames {
                let shot = g.read_back(w, h)?;
                let png = render::output::rgb8_png(&shot, w, h).map_err(|e| anyhow!(e))?;
                render::output::write_atomic(path, &png)
                    .map_err(|e| anyhow!("`screenshot` {e}"))?;
                let secs = self.started.elapsed().as_secs_f64();
                println!(
                    "{} frames in {:.2} s ({:.1} frames/s; last frame {:.1} ms) on {}; wrote {}",
                    self.frames,
                    secs,
                    self.frames as f64 / secs,
                    self.session.last.seconds * 1e3,
                    g.describe,
                    path.display()
                );
                el.exit();
                return Ok(());
            }
            g.window.request_redraw();
        } else if self.session.playing || self.needs_full || moving {
            g.window.request_redraw();
        }
        Ok(())
    }

    fn key(&mut self, el: &ActiveEventLoop, key: &Key) {
        let s = &mut self.session;
        let step = 0.05;
        match key {
            Key::Named(NamedKey::Escape) => {
                el.exit();
                return;
            }
            Key::Named(NamedKey::Space) => {
                s.playing = !s.playing && s.animated();
                self.last_tick = Instant::now();
            }
            Key::Character(c) => match c.as_str() {
                "e" | "E" => s.cycle_engine(),
                "g" | "G" => s.toggle_backend(),
                "v" | "V" => s.cycle_buffer(),
                "b" => s.set_bounces(s.bounces + 1),
                "B" => s.set_bounces(s.bounces.saturating_sub(1)),
                "o" | "O" => self.overlay = !self.overlay,
                "[" => s.set_time(s.time - 0.1),
                "]" => s.set_time(s.time + 0.1),
                "w" | "W" => s.fly(0.0, 0.0, step),
                "s" | "S" => s.fly(0.0, 0.0, -step),
                "a" | "A" => s.fly(-step, 0.0, 0.0),
                "d" | "D" => s.fly(step, 0.0, 0.0),
                "q" | "Q" => s.fly(0.0, -step, 0.0),
                "z" | "Z" => s.fly(0.0, step, 0.0),
                _ => return,
            },
            _ => return,
        }
        self.touch();
    }
}

impl ApplicationHandler for App {
    fn resumed(&mut self, el: &ActiveEventLoop) {
        if self.gfx.is_some() {
            return;
        }
        let (w, h) = (self.session.width, self.session.height);
        let attrs = Window::default_attributes()
            .with_title(format!("rayspace — {}", self.session.scene_name()))
            .with_inner_size(winit::dpi::PhysicalSize::new(w, h));
        let window = match el.create_window(attrs) {
            Ok(w) => Arc::new(w),
            Err(e) => return self.fail(el, anyhow!("view: cannot open a window: {e}")),
        };
        match Gfx::new(window, w, h) {
            Ok(g) => {
                g.window.request_redraw();
                self.gfx = Some(g);
            }
            Err(e) => self.fail(el, e),
        }
        self.started = Instant::now();
    }

    fn window_event(&mut self, el: &ActiveEventLoop, _id: WindowId, ev: WindowEvent) {
        match ev {
            WindowEvent::CloseRequested => el.exit(),
            WindowEvent::Resized(s) => {
                if let Some(g) = &mut self.gfx {
                    g.resize(s.width, s.height);
                    g.window.request_redraw();
                }
            }
            WindowEvent::RedrawRequested => {
                if let Err(e) = self.redraw(el) {
                    self.fail(el, e);
                }
            }
            WindowEvent::KeyboardInput { event, .. }
                if event.state == ElementState::Pressed && self.opts.screenshot.is_none() =>
            {
                self.key(el, &event.logical_key);
            }
            WindowEvent::MouseInput { state, button, .. } => {
                self.drag = (state == ElementState::Pressed).then_some((button, self.cursor));
            }
            WindowEvent::CursorMoved { position, .. } => {
                let p = (position.x, position.y);
                if let Some((button, from)) = self.drag {
                    let (dx, dy) = ((p.0 - from.0) as f32, (p.1 - from.1) as f32);
                    let k = 0.005;
                    match button {
                        MouseButton::Left => self.session.orbit_by(dx * k, dy * k),
                        _ => self.session.fly(-dx * k * 0.5, dy * k * 0.5, 0.0),
                    }
                    self.drag = Some((button, p));
                    self.touch();
                }
                self.cursor = p;
            }
            WindowEvent::MouseWheel { delta, .. } => {
                let d = match delta {
                    MouseScrollDelta::LineDelta(_, y) => y * 0.1,
                    MouseScrollDelta::PixelDelta(p) => p.y as f32 * 0.002,
                };
                self.session.dolly(d);
                self.touch();
            }
            _ => {}
        }
    }

    fn about_to_wait(&mut self, el: &ActiveEventLoop) {
        // Idle until input, unless a full frame is due after a preview.
        if self.needs_full || self.session.playing {
            if let Some(g) = &self.gfx {
                g.window.request_redraw();
            }
            el.set_control_flow(ControlFlow::Poll);
        } else {
            el.set_control_flow(ControlFlow::Wait);
        }
    }
}

/// A windowing error's message without the source location winit puts before it (`os error
/// at /…/cargo/registry/…/mod.rs:765: neither …`): a path inside a dependency tells a user
/// nothing.
fn without_location(msg: &str) -> &str {
    let msg = msg.trim_end_matches('.');
    match msg.strip_prefix("os error at ") {
        Some(rest) => rest.find(": ").map_or(rest, |i| &rest[i + 2..]),
        None => msg,
    }
}

/// Open the window and run until it is closed (or the screenshot is written).
pub fn run(session: Session, opts: WindowOptions) -> Result<()> {
    let el = EventLoop::new().map_err(|e| {
        anyhow!(
            "view: cannot reach a display ({}); set DISPLAY or WAYLAND_DISPLAY, or run under xvfb-run",
            without_location(&e.to_string())
        )
    })?;
    let overlay = opts.overlay;
    let mut app = App {
        session,
        opts,
        gfx: None,
        error: None,
        frames: 0,
        started: Instant::now(),
        overlay,
        changed: None,
        full_seconds: 0.0,
        needs_full: true,
        drag: None,
        cursor: (0.0, 0.0),
        last_tick: Instant::now(),
    };
    el.run_app(&mut app)
        .context("view: the window's event loop failed")?;
    match app.error {
        Some(e) => Err(e),
        None => Ok(()),
    }
}
