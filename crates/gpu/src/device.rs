//! Device set-up and the small amount of plumbing every kernel needs: storage buffers from
//! slices, read-back, one-shot compute dispatches, and timestamp queries per phase.
//!
//! There is deliberately no global state: a [`Gpu`] owns its device and queue, and every
//! kernel module builds its pipelines from it once ([`crate::kernels::Kernels`]).

use std::borrow::Cow;
use std::fmt;

/// Why no GPU context could be made.
#[derive(Debug, Clone)]
pub enum GpuError {
    /// No adapter (no Vulkan/Metal/DX12 driver, not even a software one such as lavapipe).
    NoAdapter(String),
    /// The adapter exists but refused the device (missing feature or limit).
    Device(String),
    /// The work does not fit the device (a buffer above its binding limit, say).
    Limits(String),
    /// An option value the GPU pipeline does not implement or cannot hold.
    Option(trace::OptionError),
    /// The grid's build refused its input or its size.
    Grid(accel::GridError),
    /// What was asked cannot be done by this engine (a grid uploaded from the CPU has no
    /// configuration to rebuild with).
    Unsupported(&'static str),
}

impl From<trace::OptionError> for GpuError {
    fn from(e: trace::OptionError) -> Self {
        GpuError::Option(e)
    }
}

impl From<accel::GridError> for GpuError {
    fn from(e: accel::GridError) -> Self {
        GpuError::Grid(e)
    }
}

impl fmt::Display for GpuError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            GpuError::NoAdapter(e) => write!(
                f,
                "no GPU adapter found ({e}); install a Vulkan driver (on Debian without a GPU: \
                 `apt-get install mesa-vulkan-drivers` for lavapipe)"
            ),
            GpuError::Device(e) => write!(f, "the GPU adapter refused a device: {e}"),
            GpuError::Limits(e) => write!(f, "the GPU device's limits are too small: {e}"),
            GpuError::Option(e) => write!(f, "GPU backend: {e}"),
            GpuError::Grid(e) => write!(f, "GPU backend: {e}"),
            GpuError::Unsupported(e) => write!(f, "GPU backend: {e}"),
        }
    }
}

impl std::error::Error for GpuError {}

/// A device, its queue, and what the backend needs to know about it. A clone is another
/// handle to the same device, queue and byte count (wgpu's handles are shared).
#[derive(Clone)]
pub struct Gpu {
    /// The logical device.
    pub device: wgpu::Device,
    /// Its queue.
    pub queue: wgpu::Queue,
    /// What the adapter says of itself.
    pub info: wgpu::AdapterInfo,
    /// The device's limits (as requested: the adapter's).
    pub limits: wgpu::Limits,
    /// Timestamp queries between passes are available.
    pub timestamps: bool,
    /// How phases are timed: GPU timestamps, or (where they are absent or do not mean GPU
    /// execution time) wall-clock time with a wait at every phase boundary.
    pub timer: PhaseTimer,
    /// Bytes written to the device by [`Gpu::upload`] and [`Gpu::uniform`] and read back by
    /// [`Gpu::map_read`], since the device was made (every transfer goes through them).
    moved: std::sync::Arc<std::sync::atomic::AtomicU64>,
    /// Read-backs since the device was made: each one a wait for the device
    /// ([`Gpu::map_read`]).
    reads: std::sync::Arc<std::sync::atomic::AtomicU64>,
    /// Compute dispatches recorded since the device was made (every one goes through
    /// `Exec::run`).
    dispatches: std::sync::Arc<std::sync::atomic::AtomicU64>,
    /// The device's compiled kernels, made on first use and shared by every engine and
    /// handle of the device ([`Gpu::kernels`]).
    kernels: std::sync::Arc<std::sync::OnceLock<std::sync::Arc<crate::kernels::Kernels>>>,
}

/// How [`crate::kernels::Exec`] times phases.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PhaseTimer {
    /// GPU timestamp queries around every pass.
    Timestamps,
    /// lavapipe writes a timestamp when the command is reached, without waiting for the
    /// compute dispatches before it (they run on its thread pool), so its timestamps do not
    /// measure kernels; and some adapters have no timestamp queries at all.
    WallClock,
}

impl Gpu {
    /// Every kernel compiled for this device: compiled by the first call (17 WGSL modules,
    /// seconds on a software device), then shared by every engine, rebuild and handle of
    /// the device, so a device compiles its kernels once.
    pub fn kernels(&self) -> std::sync::Arc<crate::kernels::Kernels> {
        self.kernels
            .get_or_init(|| std::sync::Arc::new(crate::kernels::Kernels::new(self)))
            .clone()
    }

    /// The first adapter wgpu offers (high performance preferred), with timestamp queries when
    /// the adapter has them. Never blocks indefinitely: wgpu's adapter request returns an error
    /// when no driver is installed.
    pub fn new() -> Result<Gpu, GpuError> {
        let mut desc = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
        if std::env::var_os("WGPU_BACKEND").is_none() {
            desc.backends = wgpu::Backends::VULKAN | wgpu::Backends::METAL | wgpu::Backends::DX12;
        }
        let instance = wgpu::Instance::new(desc);
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            ..Default::default()
        }))
        .map_err(|e| GpuError::NoAdapter(e.to_string()))?;
        let info = adapter.get_info();
        let have = adapter.features();
        let ts = wgpu::Features::TIMESTAMP_QUERY;
        let timestamps = have.contains(ts);
        // f64 (the minimal ball and the watertight kernel's edge fallback, as on the CPU) and
        // 64-bit atomic minimum (closest hit as one (t, id) word, as on the CPU).
        let need = wgpu::Features::SHADER_F64
            | wgpu::Features::SHADER_INT64
            | wgpu::Features::SHADER_INT64_ATOMIC_MIN_MAX;
        if !have.contains(need) {
            return Err(GpuError::Device(format!(
                "adapter {} lacks {:?}",
                info.name,
                need - (have & need)
            )));
        }
        let alimits = adapter.limits();
        // Ask for the adapter's own storage limits: the defaults (128 MiB bindings, 8 storage
        // buffers per stage) are lower than most drivers offer.
        let limits = wgpu::Limits {
            max_storage_buffer_binding_size: alimits.max_storage_buffer_binding_size,
            max_buffer_size: alimits.max_buffer_size,
            max_storage_buffers_per_shader_stage: alimits.max_storage_buffers_per_shader_stage,
            max_compute_workgroups_per_dimension: alimits.max_compute_workgroups_per_dimension,
            // The G-buffer's five 16-byte render targets.
            max_color_attachment_bytes_per_sample: alimits.max_color_attachment_bytes_per_sample,
            max_texture_dimension_2d: alimits.max_texture_dimension_2d,
            ..wgpu::Limits::default()
        };
        if limits.max_storage_buffers_per_shader_stage < 10 {
            return Err(GpuError::Limits(format!(
                "{} storage buffers per shader stage (10 needed)",
                limits.max_storage_buffers_per_shader_stage
            )));
        }
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("rayspace"),
            required_features: if timestamps { need | ts } else { need },
            required_limits: limits.clone(),
            ..Default::default()
        }))
        .map_err(|e| GpuError::Device(e.to_string()))?;
        let timer = match std::env::var("RAYSPACE_GPU_TIMER").as_deref() {
            Ok("wall") => PhaseTimer::WallClock,
            Ok("timestamps") if timestamps => PhaseTimer::Timestamps,
            _ if timestamps && info.device_type != wgpu::DeviceType::Cpu => PhaseTimer::Timestamps,
            _ => PhaseTimer::WallClock,
        };
        Ok(Gpu {
            device,
            queue,
            info,
            limits,
            timestamps,
            timer,
            moved: std::sync::Arc::new(std::sync::atomic::AtomicU64::new(0)),
            kernels: Default::default(),
            reads: std::sync::Arc::new(std::sync::atomic::AtomicU64::new(0)),
            dispatches: std::sync::Arc::new(std::sync::atomic::AtomicU64::new(0)),
        })
    }

    /// Bytes moved between host and device so far, both ways (see the field).
    pub fn bytes_moved(&self) -> u64 {
        self.moved.load(std::sync::atomic::Ordering::Relaxed)
    }

    /// Read-backs so far (each waits for the device to finish the work before it: the
    /// host-sequencing cost a real GPU pays per read-back).
    pub fn read_backs(&self) -> u64 {
        self.reads.load(std::sync::atomic::Ordering::Relaxed)
    }

    /// Compute dispatches so far (see the field).
    pub fn dispatches(&self) -> u64 {
        self.dispatches.load(std::sync::atomic::Ordering::Relaxed)
    }

    pub(crate) fn count_dispatch(&self) {
        self.dispatches
            .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    }

    fn count_moved(&self, bytes: u64) {
        self.moved
            .fetch_add(bytes, std::sync::atomic::Ordering::Relaxed);
    }

    /// One line naming the adapter, for reports.
    pub fn describe(&self) -> String {
        format!(
            "{} ({:?}, {:?}, driver {} {})",
            self.info.name,
            self.info.device_type,
            self.info.backend,
            self.info.driver,
            self.info.driver_info
        )
    }

    /// Route errors the device reports outside any call that could return them (an
    /// allocation it cannot hold, say) to `f`, as one line, instead of wgpu's default panic.
    /// The work is sized to the device's limits beforehand; this is for what limits do not
    /// say (device memory).
    pub fn on_device_error(&self, f: impl Fn(String) + Send + Sync + 'static) {
        self.device
            .on_uncaptured_error(std::sync::Arc::new(move |e: wgpu::Error| {
                f(e.to_string()
                    .split_whitespace()
                    .collect::<Vec<_>>()
                    .join(" "))
            }));
    }

    /// The largest storage binding the device allows, in bytes.
    pub fn max_binding(&self) -> u64 {
        self.limits.max_storage_buffer_binding_size
    }

    /// Compile WGSL `src` (a naga error names `label` and the line).
    pub fn shader(&self, label: &str, src: &str) -> wgpu::ShaderModule {
        self.device
            .create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(label),
                source: wgpu::ShaderSource::Wgsl(Cow::Owned(src.to_string())),
            })
    }

    /// A storage buffer of `bytes` (at least 4), usable as copy source and destination.
    pub fn storage(&self, label: &str, bytes: u64) -> wgpu::Buffer {
        self.buffer(label, bytes, wgpu::BufferUsages::empty())
    }

    /// A buffer of `bytes` (at least 4, a multiple of 4) for storage and copies, and `more`.
    fn buffer(&self, label: &str, bytes: u64, more: wgpu::BufferUsages) -> wgpu::Buffer {
        self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: bytes.max(4).next_multiple_of(4),
            usage: wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::COPY_SRC
                | wgpu::BufferUsages::COPY_DST
                | more,
            mapped_at_creation: false,
        })
    }

    /// A storage buffer of `bytes` that launches may also read their workgroups from
    /// (`dispatch_workgroups_indirect`).
    pub fn indirect(&self, label: &str, bytes: u64) -> wgpu::Buffer {
        self.buffer(label, bytes, wgpu::BufferUsages::INDIRECT)
    }

    /// A storage buffer holding `data` (padded to at least 4 bytes).
    pub fn upload<T: bytemuck::Pod>(&self, label: &str, data: &[T]) -> wgpu::Buffer {
        let bytes: &[u8] = bytemuck::cast_slice(data);
        let buf = self.storage(label, bytes.len() as u64);
        if !bytes.is_empty() {
            self.queue.write_buffer(&buf, 0, bytes);
            self.count_moved(bytes.len() as u64);
        }
        buf
    }

    /// A uniform buffer holding `data`.
    pub fn uniform<T: bytemuck::Pod>(&self, label: &str, data: &T) -> wgpu::Buffer {
        let buf = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: (std::mem::size_of::<T>() as u64).next_multiple_of(16),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        self.queue.write_buffer(&buf, 0, bytemuck::bytes_of(data));
        self.count_moved(std::mem::size_of::<T>() as u64);
        buf
    }

    /// Copy `count` elements of `buf` back to the host (blocks until the GPU is done).
    pub fn read<T: bytemuck::Pod>(&self, buf: &wgpu::Buffer, count: usize) -> Vec<T> {
        let bytes = (count * std::mem::size_of::<T>()) as u64;
        if bytes == 0 {
            return Vec::new();
        }
        let staging = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("read-back"),
            size: bytes.next_multiple_of(4),
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut enc = self.device.create_command_encoder(&Default::default());
        enc.copy_buffer_to_buffer(buf, 0, &staging, 0, bytes.next_multiple_of(4));
        self.queue.submit([enc.finish()]);
        self.map_read(&staging, count)
    }

    /// Map a MAP_READ buffer and copy `count` elements out.
    pub fn map_read<T: bytemuck::Pod>(&self, staging: &wgpu::Buffer, count: usize) -> Vec<T> {
        self.reads
            .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let slice = staging.slice(..);
        let (tx, rx) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .expect("GPU device lost while waiting for a read-back");
        rx.recv()
            .expect("map callback")
            .expect("mapping a read-back buffer");
        let data = slice.get_mapped_range().expect("mapped read-back range");
        let bytes = count * std::mem::size_of::<T>();
        self.count_moved(data.len() as u64);
        let out: Vec<T> = bytemuck::pod_collect_to_vec(&data[..bytes]);
        drop(data);
        staging.unmap();
        out
    }

    /// A compute pipeline of `entry` in `module`, with the bind group layout inferred.
    pub fn pipeline(&self, module: &wgpu::ShaderModule, entry: &str) -> wgpu::ComputePipeline {
        self.device
            .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry),
                layout: None,
                module,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            })
    }

    /// A bind group for group 0 of `pipe` with `buffers` at bindings 0, 1, 2, …
    pub fn bind(&self, pipe: &wgpu::ComputePipeline, buffers: &[&wgpu::Buffer]) -> wgpu::BindGroup {
        let entries: Vec<wgpu::BindGroupEntry> = buffers
            .iter()
            .enumerate()
            .map(|(i, b)| wgpu::BindGroupEntry {
                binding: i as u32,
                resource: b.as_entire_binding(),
            })
            .collect();
        self.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: None,
            layout: &pipe.get_bind_group_layout(0),
            entries: &entries,
        })
    }

    /// Workgroup counts for `n` threads of `wg` each, folded into 2-D when the count is above
    /// the per-dimension limit. Kernels recover the linear id as `id.x + id.y · (nx · wg)`.
    pub fn grid(&self, n: u64, wg: u32) -> (u32, u32) {
        let groups = n.div_ceil(wg as u64).max(1);
        let maxd = self.limits.max_compute_workgroups_per_dimension as u64;
        if groups <= maxd {
            (groups as u32, 1)
        } else {
            let y = groups.div_ceil(maxd);
            (groups.div_ceil(y) as u32, y as u32)
        }
    }
}
