//! The WGSL kernels, compiled once per device, and [`Exec`]: a command recorder that runs one
//! compute pass per kernel launch, with a timestamp pair per pass attributed to the current
//! phase (GPU time, not wall-clock), and the data-parallel primitives the pipeline is made
//! of (scan, compaction, radix sort) as host functions that record passes.

use crate::device::{Gpu, PhaseTimer};
use render::Phase;
use std::collections::HashMap;
use std::time::Instant;

/// Launch parameters, the `Params` block of `common.wgsl`. `f[1][3]` is reserved: [`Exec::run`]
/// always sets it to 0, the zero the kernels' `mul()` hides products behind.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Params {
    pub u: [[u32; 4]; 4],
    pub f: [[f32; 4]; 2],
}
const _: () = assert!(std::mem::size_of::<Params>() == 96);

impl Params {
    /// Parameters with `u0 = (n, a, b, c)`.
    pub fn n(n: u32, a: u32, b: u32, c: u32) -> Params {
        Params {
            u: [[n, a, b, c], [0; 4], [0; 4], [0; 4]],
            f: [[0.0; 4]; 2],
        }
    }
}

const COMMON: &str = include_str!("shaders/common.wgsl");
const GEOM: &str = include_str!("shaders/geom.wgsl");

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

/// Every pipeline by entry-point name.
pub struct Kernels {
    pipes: HashMap<&'static str, wgpu::ComputePipeline>,
}

impl Kernels {
    pub fn new(g: &Gpu) -> Kernels {
        let prelude = format!("{}\n{COMMON}\n", constants());
        let modules: [(&str, String, &[&'static str]); 8] = [
            (
                "scan",
                format!("{prelude}{}", include_str!("shaders/scan.wgsl")),
                &["scan_reduce", "scan_down"],
            ),
            (
                "sort",
                format!("{prelude}{}", include_str!("shaders/sort.wgsl")),
                &["key_bits", "sort_count", "sort_scatter"],
            ),
            (
                "misc",
                format!("{prelude}{}", include_str!("shaders/misc.wgsl")),
                &[
                    "compact",
                    "run_heads",
                    "run_chunks",
                    "run_sizes",
                    "iota",
                    "gather",
                    "expand_runs",
                    "kind_hist",
                ],
            ),
            (
                "order",
                format!("{prelude}{GEOM}{}", include_str!("shaders/order.wgsl")),
                &["hash_keys"],
            ),
            (
                "build",
                format!("{prelude}{GEOM}{}", include_str!("shaders/build.wgsl")),
                &["build_leaf_level", "build_upper_level"],
            ),
            (
                "traverse",
                format!("{prelude}{GEOM}{}", include_str!("shaders/traverse.wgsl")),
                &[
                    "mesh_test",
                    "top_count",
                    "top_emit",
                    "pair_test",
                    "child_count",
                    "child_emit",
                ],
            ),
            (
                "stages",
                format!("{prelude}{}", include_str!("shaders/stages.wgsl")),
                &["shadow_rays", "bounce_rays", "shade_local"],
            ),
            (
                "final",
                format!("{prelude}{GEOM}{}", include_str!("shaders/final.wgsl")),
                &["final_tests", "records"],
            ),
        ];
        let mut pipes = HashMap::new();
        for (label, src, entries) in modules {
            let m = g.shader(label, &src);
            for &e in entries {
                pipes.insert(e, g.pipeline(&m, e));
            }
        }
        Kernels { pipes }
    }

    pub fn get(&self, name: &str) -> &wgpu::ComputePipeline {
        self.pipes
            .get(name)
            .unwrap_or_else(|| panic!("no kernel {name}"))
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

/// Records kernel launches; submits at read-backs (the pipeline's only synchronisation).
pub struct Exec<'a> {
    pub g: &'a Gpu,
    pub k: &'a Kernels,
    enc: Option<wgpu::CommandEncoder>,
    phase: Phase,
    timer: Timer,
    /// Seconds per phase, in first-seen order: GPU time from timestamps, or wall-clock time
    /// with a wait at each phase boundary ([`PhaseTimer`]).
    pub times: Vec<(Phase, f64)>,
    pub launches: u64,
    wall_start: Option<Instant>,
}

impl<'a> Exec<'a> {
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
            phase: Phase::Upload,
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

    /// Launch `kernel` over `threads` threads of workgroups of `wg`, with `params` at binding 0
    /// and `binds` (binding, buffer) after it.
    pub fn run(
        &mut self,
        kernel: &str,
        params: Params,
        binds: &[(u32, &wgpu::Buffer)],
        threads: u64,
        wg: u32,
    ) {
        if threads == 0 {
            return;
        }
        let mut params = params;
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
        for (b, buf) in binds {
            entries.push(wgpu::BindGroupEntry {
                binding: *b,
                resource: buf.as_entire_binding(),
            });
        }
        let bg = g.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(kernel),
            layout: &pipe.get_bind_group_layout(0),
            entries: &entries,
        });
        let (gx, gy) = g.grid(threads, wg);
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
        {
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some(kernel),
                timestamp_writes: ts,
            });
            pass.set_pipeline(pipe);
            pass.set_bind_group(0, &bg, &[]);
            pass.dispatch_workgroups(gx, gy, 1);
        }
        self.launches += 1;
    }

    pub fn copy(&mut self, src: &wgpu::Buffer, src_off: u64, dst: &wgpu::Buffer, bytes: u64) {
        if bytes > 0 {
            self.encoder()
                .copy_buffer_to_buffer(src, src_off, dst, 0, bytes);
        }
    }

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

    /// One u32 at index `i` of `buf`.
    pub fn read_at(&mut self, buf: &wgpu::Buffer, i: usize) -> u32 {
        self.flush();
        let tmp = self.g.storage("read one", 4);
        let mut enc = self.g.device.create_command_encoder(&Default::default());
        enc.copy_buffer_to_buffer(buf, i as u64 * 4, &tmp, 0, 4);
        self.g.queue.submit([enc.finish()]);
        self.g.read::<u32>(&tmp, 1)[0]
    }

    // ------------------------------------------------------------ primitives

    /// Exclusive scan of `n` u32 of `input` into `out` (n + 1 entries: the total last).
    pub fn scan(&mut self, input: &wgpu::Buffer, out: &wgpu::Buffer, n: u64) {
        const BLOCK: u64 = 256 * 4;
        if n == 0 {
            return;
        }
        let blocks = n.div_ceil(BLOCK);
        let dummy;
        let sums_scanned;
        let single = blocks == 1;
        let sums_ref = if single {
            dummy = self.g.storage("scan dummy", 4);
            &dummy
        } else {
            let sums = self.g.storage("scan sums", blocks * 4);
            self.run(
                "scan_reduce",
                Params::n(n as u32, 0, 0, 0),
                &[(1, input), (3, &sums)],
                blocks * 256,
                256,
            );
            sums_scanned = self.g.storage("scan sums scanned", (blocks + 1) * 4);
            self.scan(&sums, &sums_scanned, blocks);
            &sums_scanned
        };
        self.run(
            "scan_down",
            Params::n(n as u32, single as u32, 0, 0),
            &[(1, input), (2, out), (3, sums_ref)],
            blocks * 256,
            256,
        );
    }

    /// Stable key–value radix sort of `n` pairs over the low `bits` key bits; the result is
    /// back in `keys`/`vals`.
    pub fn sort_pairs(&mut self, keys: &wgpu::Buffer, vals: &wgpu::Buffer, n: u64, bits: u32) {
        if n <= 1 {
            return;
        }
        // A tile is 256 threads × 16 elements (sort.wgsl).
        const SORT_TILE: u64 = 256 * 16;
        let tiles = n.div_ceil(SORT_TILE);
        let hist = self.g.storage("sort hist", 16 * tiles * 4);
        let hist_s = self.g.storage("sort hist scanned", (16 * tiles + 1) * 4);
        let k2 = self.g.storage("sort keys", n * 4);
        let v2 = self.g.storage("sort vals", n * 4);
        // Digits that are equal in every key need no pass (as in `par::sort_pairs`).
        let kb = self.g.upload("key bits", &[0u32, u32::MAX]);
        self.run(
            "key_bits",
            Params::n(n as u32, 0, 0, 0),
            &[(1, keys), (6, &kb)],
            tiles * 256,
            256,
        );
        let ka: Vec<u32> = self.read(&kb, 2);
        let varying = (ka[0] ^ ka[1])
            & if bits >= 32 {
                u32::MAX
            } else {
                (1 << bits) - 1
            };
        let digits: Vec<u32> = (0..bits.div_ceil(4))
            .filter(|&p| (varying >> (4 * p)) & 15 != 0)
            .collect();
        let passes = digits.len() as u32;
        let (mut src, mut dst) = ((keys, vals), (&k2, &v2));
        for &p in &digits {
            let prm = Params::n(n as u32, 4 * p, tiles as u32, 0);
            self.run(
                "sort_count",
                prm,
                &[(1, src.0), (3, &hist)],
                tiles * 256,
                256,
            );
            self.scan(&hist, &hist_s, 16 * tiles);
            self.run(
                "sort_scatter",
                prm,
                &[(1, src.0), (2, src.1), (3, &hist_s), (4, dst.0), (5, dst.1)],
                tiles * 256,
                256,
            );
            std::mem::swap(&mut src, &mut dst);
        }
        if passes % 2 == 1 {
            self.copy(&k2, 0, keys, n * 4);
            self.copy(&v2, 0, vals, n * 4);
        }
    }

    /// Compact (a, b) by `flags` (n entries) into new buffers; `b == None` stores the index.
    /// Returns the outputs and their length.
    pub fn compact(
        &mut self,
        flags: &wgpu::Buffer,
        a: &wgpu::Buffer,
        b: Option<&wgpu::Buffer>,
        n: u64,
    ) -> (wgpu::Buffer, wgpu::Buffer, u64) {
        let offs = self.g.storage("compact offsets", (n + 1) * 4);
        self.scan(flags, &offs, n);
        let m = self.read_at(&offs, n as usize) as u64;
        let (oa, ob) = (
            self.g.storage("compacted a", m * 4),
            self.g.storage("compacted b", m * 4),
        );
        if m > 0 {
            self.run(
                "compact",
                Params::n(n as u32, b.is_none() as u32, 0, 0),
                &[
                    (1, flags),
                    (2, &offs),
                    (3, a),
                    (4, b.unwrap_or(a)),
                    (5, &oa),
                    (6, &ob),
                ],
                n,
                256,
            );
        }
        (oa, ob, m)
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn hex_literals_are_exact() {
        assert_eq!(super::hex_f32(1.0), "0x1.000000p0f");
        assert_eq!(super::hex_f32(-0.75), "-0x1.800000p-1f");
        assert_eq!(super::hex_f32(std::f32::consts::PI), "0x1.921fb6p1f");
    }
}
