//! The WGSL kernels, compiled once per device and named by [`Kernel`], and [`Exec`]: a
//! command recorder that runs one compute pass per kernel launch, with a timestamp pair per
//! pass attributed to the current phase (GPU time, not wall-clock). The data-parallel
//! primitives built on it are in [`crate::prims`].

use crate::device::{Gpu, PhaseTimer};
use std::sync::Mutex;
use std::time::Instant;
use trace::Phase;

/// The launch-parameter block, `Params` of `common.wgsl`: what a kernel's typed parameter
/// struct ([`params`]) packs into ([`ParamBlock`]). `f[1][3]` is reserved: [`Exec::run`]
/// always sets it to 0, the zero the kernels' `mul()` hides products behind.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Params {
    /// u0..u3: words 0–15.
    pub u: [[u32; 4]; 4],
    /// f0, f1: words 16–23 (f1.w is reserved, always 0).
    pub f: [[f32; 4]; 2],
}
const _: () = assert!(std::mem::size_of::<Params>() == 96);

/// Launch parameters that pack into the [`Params`] block.
pub trait ParamBlock {
    /// The block.
    fn block(&self) -> Params;
}

impl Params {
    /// The block from its 24 words (16 integers, then the bits of the 8 floats).
    pub fn from_words(w: [u32; 24]) -> Params {
        let mut p = Params::default();
        for (i, &x) in w.iter().enumerate() {
            if i < 16 {
                p.u[i / 4][i % 4] = x;
            } else {
                p.f[(i - 16) / 4][i % 4] = f32::from_bits(x);
            }
        }
        p
    }
}

const COMMON: &str = include_str!("shaders/common.wgsl");

// `Module`, `Kernel` and `launch::*`, derived from the WGSL by `build.rs`.
include!(concat!(env!("OUT_DIR"), "/kernels.rs"));

impl Kernel {
    /// The WGSL entry point's name.
    pub fn entry(self) -> &'static str {
        self.def().0
    }
}

/// A kernel launch's buffers: one implementation per kernel (the generated
/// [`launch`] structs), whose fields are the storage buffers the entry point uses.
pub trait Launch {
    /// The kernel launched.
    const KERNEL: Kernel;
    /// Its parameters: the struct its WGSL declares ([`params`]).
    type Params: ParamBlock;
    /// The buffers, in the order of [`Kernel::bindings`].
    fn buffers(&self) -> Vec<&wgpu::Buffer>;
}

/// Constants as exact bit patterns (see `common.wgsl`): the f32 values the CPU code uses,
/// folded in f32 as Rust folds them.
fn constants() -> String {
    use geom::pmath;
    use std::f32::consts::*;
    let eps = f32::EPSILON;
    let list: &[(&str, f32)] = &[
        ("C_PI", PI),
        ("C_FRAC_PI_2", FRAC_PI_2),
        ("C_FRAC_PI_4", FRAC_PI_4),
        ("C_FRAC_1_PI", FRAC_1_PI),
        ("C_HALF_FRAC_1_PI", 0.5 * FRAC_1_PI),
        ("C_PI_M_1EM6", PI - 1e-6),
        ("C_ONE_P_4EPS", 1.0 + 4.0 * eps),
        ("C_ONE_P_8EPS", 1.0 + 8.0 * eps),
        ("C_8EPS", 8.0 * eps),
        ("C_PAD", 8.0 * eps),
        ("C_ONE_P_PAD", 1.0 + 8.0 * eps),
        ("C_ONE_P_1EM5", 1.0 + 1e-5),
        ("C_SLAB_ROBUST", geom::aabb::SLAB_ROBUST),
        ("C_OFFSET_REL", geom::ray::OFFSET_REL),
        ("C_T3P8", pmath::T3P8),
        ("C_TP8", pmath::TP8),
        ("C_AT0", pmath::AT[0]),
        ("C_AT1", pmath::AT[1]),
        ("C_AT2", pmath::AT[2]),
        ("C_AT3", pmath::AT[3]),
        ("C_DP1", pmath::DP1),
        ("C_DP2", pmath::DP2),
        ("C_DP3", pmath::DP3),
        ("C_TWO_OVER_PI", pmath::TWO_OVER_PI),
        ("C_S0", pmath::SN[0]),
        ("C_S1", pmath::SN[1]),
        ("C_S2", pmath::SN[2]),
        ("C_C0", pmath::CS[0]),
        ("C_C1", pmath::CS[1]),
        ("C_C2", pmath::CS[2]),
    ];
    let mut s = String::new();
    for &(name, v) in list {
        s += &format!("const {name}: f32 = {};\n", hex_f32(v));
    }
    s
}

/// An exact WGSL literal of a normal f32: a hexadecimal float with the 24-bit significand
/// (naga cannot fold `bitcast` in constants, and a decimal literal could round twice).
fn hex_f32(v: f32) -> String {
    assert!(v.is_normal(), "constant {v} is not a normal float");
    let b = v.to_bits();
    let sign = if b >> 31 == 1 { "-" } else { "" };
    let exp = ((b >> 23) & 0xff) as i32 - 127;
    let mant = (b & 0x7f_ffff) << 1;
    format!("{sign}0x1.{mant:06x}p{exp}f")
}

/// Every pipeline, indexed by [`Kernel`].
pub struct Kernels {
    pipes: Vec<wgpu::ComputePipeline>,
}

impl Kernels {
    /// Compile every module and create every kernel's pipeline.
    pub fn new(g: &Gpu) -> Kernels {
        let prelude = format!("{}\n{COMMON}\n", constants());
        let mut pipes: Vec<Option<wgpu::ComputePipeline>> =
            Kernel::ALL.iter().map(|_| None).collect();
        for m in Module::ALL {
            let module = g.shader(&format!("{m:?}"), &format!("{prelude}{}", m.source()));
            for k in Kernel::ALL.into_iter().filter(|k| k.def().1 == m) {
                pipes[k as usize] = Some(g.pipeline(&module, k.entry()));
            }
        }
        Kernels {
            pipes: pipes
                .into_iter()
                .map(|p| p.expect("every kernel belongs to a module"))
                .collect(),
        }
    }

    /// The pipeline of kernel `k`.
    pub fn get(&self, k: Kernel) -> &wgpu::ComputePipeline {
        &self.pipes[k as usize]
    }
}

/// GPU time per phase from timestamp queries.
#[derive(Default)]
struct Timer {
    set: Option<wgpu::QuerySet>,
    resolve: Option<wgpu::Buffer>,
    used: u32,
    phases: Vec<Phase>,
}

const MAX_QUERIES: u32 = 4096;

/// A count the device holds and the host does not read: word `at` (u32 index) of `buf`, at
/// most `cap` (the host's bound, which sized the buffers it counts into).
#[derive(Clone, Debug)]
pub struct DevLen {
    /// The buffer holding the count.
    pub buf: wgpu::Buffer,
    /// The count's word.
    pub at: u64,
    /// Its upper bound.
    pub cap: u64,
}

/// A device count made ready for launches ([`Exec::sizes`]): a 16-byte block
/// `[n, x, y, 1]` at byte `at` of `block` on the device, n = count · mul and (x, y, 1) the
/// workgroups of a dispatch over n threads; `cap` bounds n.
#[derive(Clone, Debug)]
pub struct DevSize {
    /// The blocks' buffer (storage, indirect-argument and copy usage).
    pub block: wgpu::Buffer,
    /// The block's byte offset.
    pub at: u64,
    /// Upper bound of n.
    pub cap: u64,
}

impl DevSize {
    /// The block's n as a count ([`DevLen`]) of its own.
    pub fn count(&self) -> DevLen {
        DevLen {
            buf: self.block.clone(),
            at: self.at / 4,
            cap: self.cap,
        }
    }
}

/// Over how many threads a launch runs: a count the host knows, or one the device holds
/// ([`Exec::run_on`]).
#[derive(Clone, Copy)]
pub enum Threads<'s> {
    /// This many threads (the kernel's first parameter word as its caller set it).
    Host(u64),
    /// `over.n` threads, the first parameter word replaced by `first.n`.
    Device {
        /// Its n replaces the first parameter word.
        first: &'s DevSize,
        /// Its block holds the workgroups.
        over: &'s DevSize,
    },
    /// This many threads (a bound), the first parameter word replaced by `first.n`: for a
    /// launch of a thread per chunk of items, whose bound is small.
    Patched {
        /// Its n replaces the first parameter word.
        first: &'s DevSize,
        /// Threads launched.
        threads: u64,
    },
    /// `over.n` threads, the first `words` parameter words copied from `over`'s block
    /// after its 4 size words: for kernels whose whole parameter block the device laid
    /// out (the hierarchy's levels, `rsh/kinds.wgsl`'s `level_layout`).
    Laid {
        /// Its block holds the workgroups, then the parameter words.
        over: &'s DevSize,
        /// Parameter words copied.
        words: u64,
    },
}

impl<'s> Threads<'s> {
    /// Over `s.n` threads, with `s.n` as the first parameter word; `None`: `host` threads.
    pub fn of(s: Option<&'s DevSize>, host: u64) -> Threads<'s> {
        match s {
            Some(s) => Threads::Device { first: s, over: s },
            None => Threads::Host(host),
        }
    }
}

/// How a launch's workgroups are given: by the host, or read from a size block on the
/// device, whose n also replaces the first parameter word of `first`'s launch.
#[derive(Clone, Copy)]
enum Dispatch<'b> {
    Direct(u32, u32),
    Indirect {
        first: &'b DevSize,
        args: &'b DevSize,
    },
    Patched {
        first: &'b DevSize,
        groups: (u32, u32),
    },
    Laid {
        args: &'b DevSize,
        words: u64,
    },
}

/// Records kernel launches; submits at read-backs (the pipeline's only synchronisation).
pub struct Exec<'a> {
    /// The device.
    pub g: &'a Gpu,
    /// The compiled kernels.
    pub k: &'a Kernels,
    enc: Option<wgpu::CommandEncoder>,
    phase: Phase,
    timer: Timer,
    /// Seconds per phase, in first-seen order: GPU time from timestamps, or wall-clock time
    /// with a wait at each phase boundary ([`PhaseTimer`]).
    pub times: Vec<(Phase, f64)>,
    /// Kernel launches recorded.
    pub launches: u64,
    wall_start: Option<Instant>,
}

impl<'a> Exec<'a> {
    /// A recorder on `g` with kernels `k`, in the upload phase.
    pub fn new(g: &'a Gpu, k: &'a Kernels) -> Exec<'a> {
        let mut timer = Timer::default();
        let wall = g.timer == PhaseTimer::WallClock;
        if !wall {
            timer.set = Some(g.device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("phase timestamps"),
                ty: wgpu::QueryType::Timestamp,
                count: MAX_QUERIES,
            }));
            timer.resolve = Some(g.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("timestamp resolve"),
                size: MAX_QUERIES as u64 * 8,
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            }));
        }
        Exec {
            g,
            k,
            enc: None,
            phase: crate::stats::UPLOAD,
            timer,
            times: Vec::new(),
            launches: 0,
            wall_start: wall.then(Instant::now),
        }
    }

    fn add_time(&mut self, ph: Phase, dt: f64) {
        match self.times.iter_mut().find(|(p, _)| *p == ph) {
            Some(e) => e.1 += dt,
            None => self.times.push((ph, dt)),
        }
    }

    /// Start phase `name` (with the wall-clock timer: finish the previous phase's work first).
    pub fn phase(&mut self, name: Phase) {
        if self.wall_start.is_some() && name != self.phase {
            self.finish();
        }
        self.phase = name;
    }

    /// Submit and wait for everything recorded; with the wall-clock timer, the time since
    /// the phase started is added to it.
    pub fn finish(&mut self) {
        self.flush();
        if let Some(t0) = self.wall_start {
            self.g
                .device
                .poll(wgpu::PollType::wait_indefinitely())
                .expect("GPU device lost");
            let now = Instant::now();
            self.add_time(self.phase, (now - t0).as_secs_f64());
            self.wall_start = Some(now);
        }
    }

    fn encoder(&mut self) -> &mut wgpu::CommandEncoder {
        let g = self.g;
        self.enc
            .get_or_insert_with(|| g.device.create_command_encoder(&Default::default()))
    }

    /// Launch `launch`'s kernel with its buffers over `threads` threads of workgroups of
    /// `wg`, with `params` at binding 0.
    pub fn run<L: Launch>(&mut self, launch: L, params: L::Params, threads: u64, wg: u32) {
        if threads == 0 {
            return;
        }
        let (gx, gy) = self.g.grid(threads, wg);
        self.record(launch, params, Dispatch::Direct(gx, gy));
    }

    /// Launch `launch`'s kernel over the threads `threads` says: as [`Exec::run`], or over
    /// a size the device computed ([`Exec::sizes`]), its first parameter word (the count
    /// the kernel stops at) replaced on the device by `first.n` and its workgroups read
    /// from `over`'s block (`dispatch_workgroups_indirect`; `over` sized for workgroups of
    /// `wg`), or given for a bound ([`Threads::Patched`]); so nothing is read back.
    pub fn run_on<L: Launch>(&mut self, launch: L, params: L::Params, threads: Threads, wg: u32) {
        match threads {
            Threads::Host(n) => self.run(launch, params, n, wg),
            Threads::Device { first, over } => {
                self.record(launch, params, Dispatch::Indirect { first, args: over })
            }
            Threads::Patched { first, threads } => {
                let groups = self.g.grid(threads, wg);
                self.record(launch, params, Dispatch::Patched { first, groups });
            }
            Threads::Laid { over, words } => {
                self.record(launch, params, Dispatch::Laid { args: over, words })
            }
        }
    }

    /// Size blocks of the count `len`, one per `(mul, wg)`: n = count · mul for launches of
    /// workgroups of `wg` (`size.wgsl`), all in one single-workgroup dispatch; nothing is
    /// read back.
    pub fn sizes(&mut self, len: &DevLen, each: &[(u32, u32)]) -> Vec<DevSize> {
        assert!(
            (1..=4).contains(&each.len()),
            "one to four size blocks a launch"
        );
        let block = self.g.indirect("size blocks", 16 * each.len() as u64);
        let at = u32::try_from(len.at).expect("a count's word indexes in u32");
        let (mut mul, mut wg) = ([0u32; 4], [1u32; 4]);
        for (k, &(m, w)) in each.iter().enumerate() {
            (mul[k], wg[k]) = (m, w);
        }
        self.record(
            launch::SizeArgs {
                s_count: &len.buf,
                s_block: &block,
            },
            params::SizeParams {
                mul,
                wg,
                at,
                maxd: self.g.limits.max_compute_workgroups_per_dimension,
                blocks: each.len() as u32,
            },
            Dispatch::Direct(1, 1),
        );
        each.iter()
            .enumerate()
            .map(|(k, &(m, _))| DevSize {
                block: block.clone(),
                at: 16 * k as u64,
                cap: len.cap * m as u64,
            })
            .collect()
    }

    /// One size block of the count `len` ([`Exec::sizes`]).
    pub fn size(&mut self, len: &DevLen, mul: u32, wg: u32) -> DevSize {
        self.sizes(len, &[(mul, wg)]).remove(0)
    }

    /// Record one compute pass of `launch`'s kernel.
    fn record<L: Launch>(&mut self, launch: L, params: L::Params, dispatch: Dispatch) {
        let kernel = L::KERNEL;
        let mut params = params.block();
        params.f[1][3] = 0.0;
        if self.timer.used + 2 > MAX_QUERIES {
            self.flush();
        }
        let g = self.g;
        let pipe = self.k.get(kernel);
        let ub = g.uniform("params", &params);
        let mut entries = vec![wgpu::BindGroupEntry {
            binding: 0,
            resource: ub.as_entire_binding(),
        }];
        let buffers = launch.buffers();
        for (&(binding, _), buf) in kernel.bindings().iter().zip(buffers) {
            entries.push(wgpu::BindGroupEntry {
                binding,
                resource: buf.as_entire_binding(),
            });
        }
        let bg = g.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(kernel.entry()),
            layout: &pipe.get_bind_group_layout(0),
            entries: &entries,
        });
        let q = self.timer.used;
        let ts = self
            .timer
            .set
            .as_ref()
            .map(|set| wgpu::ComputePassTimestampWrites {
                query_set: set,
                beginning_of_pass_write_index: Some(q),
                end_of_pass_write_index: Some(q + 1),
            });
        if ts.is_some() {
            self.timer.used += 2;
            self.timer.phases.push(self.phase);
        }
        let enc = self
            .enc
            .get_or_insert_with(|| g.device.create_command_encoder(&Default::default()));
        if let Dispatch::Indirect { first, .. } | Dispatch::Patched { first, .. } = dispatch {
            // The device's count becomes the first parameter word (the queue's write of
            // the block lands before this command buffer runs).
            enc.copy_buffer_to_buffer(&first.block, first.at, &ub, 0, 4);
        }
        if let Dispatch::Laid { args, words } = dispatch {
            enc.copy_buffer_to_buffer(&args.block, args.at + 16, &ub, 0, 4 * words);
        }
        {
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some(kernel.entry()),
                timestamp_writes: ts,
            });
            pass.set_pipeline(pipe);
            pass.set_bind_group(0, &bg, &[]);
            match dispatch {
                Dispatch::Direct(gx, gy)
                | Dispatch::Patched {
                    groups: (gx, gy), ..
                } => pass.dispatch_workgroups(gx, gy, 1),
                Dispatch::Indirect { args, .. } | Dispatch::Laid { args, .. } => {
                    pass.dispatch_workgroups_indirect(&args.block, args.at + 4)
                }
            }
        }
        self.launches += 1;
        g.count_dispatch();
    }

    /// Copy `bytes` from `src` at `src_off` to the start of `dst`.
    pub fn copy(&mut self, src: &wgpu::Buffer, src_off: u64, dst: &wgpu::Buffer, bytes: u64) {
        if bytes > 0 {
            self.encoder()
                .copy_buffer_to_buffer(src, src_off, dst, 0, bytes);
        }
    }

    /// Copy `bytes` from `src` at `src_off` to `dst` at `dst_off`.
    pub fn copy_at(
        &mut self,
        src: &wgpu::Buffer,
        src_off: u64,
        dst: &wgpu::Buffer,
        dst_off: u64,
        bytes: u64,
    ) {
        if bytes > 0 {
            self.encoder()
                .copy_buffer_to_buffer(src, src_off, dst, dst_off, bytes);
        }
    }

    /// Zero `buf`.
    pub fn clear(&mut self, buf: &wgpu::Buffer) {
        self.encoder().clear_buffer(buf, 0, None);
    }

    /// Submit what is recorded and wait; collect the timestamps.
    pub fn flush(&mut self) {
        let used = self.timer.used;
        if used > 0 {
            let (set, res) = (
                self.timer.set.as_ref().unwrap(),
                self.timer.resolve.as_ref().unwrap(),
            );
            let enc = self
                .enc
                .get_or_insert_with(|| self.g.device.create_command_encoder(&Default::default()));
            enc.resolve_query_set(set, 0..used, res, 0);
        }
        if let Some(enc) = self.enc.take() {
            self.g.queue.submit([enc.finish()]);
        }
        if used > 0 {
            let res = self.timer.resolve.as_ref().unwrap();
            let ticks: Vec<u64> = self.g.read(res, used as usize);
            let period = self.g.queue.get_timestamp_period() as f64 * 1e-9;
            let phases = std::mem::take(&mut self.timer.phases);
            for (i, ph) in phases.into_iter().enumerate() {
                let dt = ticks[2 * i + 1].saturating_sub(ticks[2 * i]) as f64 * period;
                self.add_time(ph, dt);
            }
            self.timer.used = 0;
        }
    }

    /// Flush, then read `count` elements of `buf`.
    pub fn read<T: bytemuck::Pod>(&mut self, buf: &wgpu::Buffer, count: usize) -> Vec<T> {
        self.flush();
        self.g.read(buf, count)
    }

    /// Finish the trace call's work and report it: every phase's time into `stats` and into
    /// `sink` (an engine's running totals, drained by its `take_times`), and the launches.
    pub fn report(mut self, stats: &mut trace::TraceStats, sink: &Mutex<Vec<(Phase, f64)>>) {
        self.finish();
        let mut totals = sink.lock().unwrap();
        for (p, t) in self.times.drain(..) {
            stats.time(p, t);
            match totals.iter_mut().find(|(q, _)| *q == p) {
                Some(e) => e.1 += t,
                None => totals.push((p, t)),
            }
        }
        stats.count(crate::stats::KERNEL_LAUNCHES, self.launches);
    }

    /// One u32 at index `i` of `buf`.
    pub fn read_at(&mut self, buf: &wgpu::Buffer, i: usize) -> u32 {
        self.flush();
        let tmp = self.g.storage("read one", 4);
        let mut enc = self.g.device.create_command_encoder(&Default::default());
        enc.copy_buffer_to_buffer(buf, i as u64 * 4, &tmp, 0, 4);
        self.g.queue.submit([enc.finish()]);
        self.g.read::<u32>(&tmp, 1)[0]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `build.rs` derives each kernel's bindings by following the WGSL's calls textually; naga's
    /// validator, which wgpu uses to infer the bind-group layouts, must find the same: every
    /// entry point a kernel of its module, and each kernel's storage bindings those its entry
    /// point uses, besides the parameters at binding 0. Needs no GPU.
    #[test]
    fn derived_bindings_are_what_naga_finds() {
        use naga::valid::{Capabilities, ValidationFlags, Validator};
        let prelude = format!("{}\n{COMMON}\n", constants());
        let mut seen = 0;
        for m in Module::ALL {
            let src = format!("{prelude}{}", m.source());
            let module = naga::front::wgsl::parse_str(&src)
                .unwrap_or_else(|e| panic!("{m:?}: {}", e.emit_to_string(&src)));
            let info = Validator::new(ValidationFlags::all(), Capabilities::all())
                .validate(&module)
                .unwrap_or_else(|e| panic!("{m:?}: {e:?}"));
            for (i, ep) in module.entry_points.iter().enumerate() {
                let uses = info.get_entry_point(i);
                let mut used: Vec<(u32, &str)> = module
                    .global_variables
                    .iter()
                    .filter(|(h, _)| !uses[*h].is_empty())
                    .filter_map(|(_, g)| {
                        let b = g.binding.as_ref()?;
                        assert_eq!(b.group, 0, "{}: group {}", ep.name, b.group);
                        Some((b.binding, g.name.as_deref().unwrap()))
                    })
                    .collect();
                used.sort();
                assert_eq!(
                    used.first().map(|u| u.0),
                    Some(0),
                    "{} reads no parameters",
                    ep.name
                );
                let k = Kernel::ALL
                    .into_iter()
                    .find(|k| k.entry() == ep.name)
                    .unwrap_or_else(|| panic!("entry point {} is no Kernel", ep.name));
                assert_eq!(k.def().1, m, "{}", ep.name);
                assert_eq!(k.bindings(), &used[1..], "{}", ep.name);
                seen += 1;
            }
        }
        assert_eq!(
            seen,
            Kernel::ALL.len(),
            "every Kernel is an entry point of its module"
        );
    }

    #[test]
    fn hex_literals_are_exact() {
        assert_eq!(super::hex_f32(1.0), "0x1.000000p0f");
        assert_eq!(super::hex_f32(-0.75), "-0x1.800000p-1f");
        assert_eq!(super::hex_f32(std::f32::consts::PI), "0x1.921fb6p1f");
    }
}
