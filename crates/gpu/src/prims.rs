//! The GPU's `par`: exclusive scan, stream compaction, run-length compression and expansion
//! and the stable radix sort, as host functions that record kernel launches on an [`Exec`]
//! (kernels in `prims/*.wgsl`). Each mirrors its CPU twin in `crates/par`, so the CRSH
//! pipeline calls the same primitives in the same order on both backends.

use crate::kernels::params::{CompactParams, PermuteParams, RunsParams, ScanParams, SortParams};
use crate::kernels::{launch, Exec};

/// A sort tile: 256 threads × 16 elements (sort.wgsl).
const SORT_TILE: u64 = 256 * 16;

impl Exec<'_> {
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
                launch::ScanReduce {
                    s_in: input,
                    s_sums: &sums,
                },
                ScanParams {
                    n: n as u32,
                    single: 0,
                },
                blocks * 256,
                256,
            );
            sums_scanned = self.g.storage("scan sums scanned", (blocks + 1) * 4);
            self.scan(&sums, &sums_scanned, blocks);
            &sums_scanned
        };
        self.run(
            launch::ScanDown {
                s_in: input,
                s_out: out,
                s_sums: sums_ref,
            },
            ScanParams {
                n: n as u32,
                single: single as u32,
            },
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
        let tiles = n.div_ceil(SORT_TILE);
        // Digits that are equal in every key need no pass (as in `par::sort_pairs`).
        let kb = self.g.upload("key bits", &[0u32, u32::MAX]);
        self.run(
            launch::KeyBits {
                k_in: keys,
                kbits: &kb,
            },
            SortParams {
                n: n as u32,
                shift: 0,
                tiles: tiles as u32,
            },
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
        self.sort_digits(keys, vals, n, &digits);
    }

    /// [`Exec::sort_pairs`] without its read-back: every 4-bit digit of the low `bits` gets
    /// a pass (one whose digit is equal in every key is the identity, so the result is the
    /// same), and nothing waits for the host.
    pub fn sort_pairs_all(&mut self, keys: &wgpu::Buffer, vals: &wgpu::Buffer, n: u64, bits: u32) {
        if n <= 1 {
            return;
        }
        let digits: Vec<u32> = (0..bits.min(32).div_ceil(4)).collect();
        self.sort_digits(keys, vals, n, &digits);
    }

    /// The radix passes of the sorts, one per digit in `digits` (low to high).
    fn sort_digits(&mut self, keys: &wgpu::Buffer, vals: &wgpu::Buffer, n: u64, digits: &[u32]) {
        let tiles = n.div_ceil(SORT_TILE);
        let hist = self.g.storage("sort hist", 16 * tiles * 4);
        let hist_s = self.g.storage("sort hist scanned", (16 * tiles + 1) * 4);
        let k2 = self.g.storage("sort keys", n * 4);
        let v2 = self.g.storage("sort vals", n * 4);
        let passes = digits.len() as u32;
        let (mut src, mut dst) = ((keys, vals), (&k2, &v2));
        for &p in digits {
            let prm = SortParams {
                n: n as u32,
                shift: 4 * p,
                tiles: tiles as u32,
            };
            self.run(
                launch::SortCount {
                    k_in: src.0,
                    hist: &hist,
                },
                prm,
                tiles * 256,
                256,
            );
            self.scan(&hist, &hist_s, 16 * tiles);
            self.run(
                launch::SortScatter {
                    k_in: src.0,
                    v_in: src.1,
                    hist: &hist_s,
                    k_out: dst.0,
                    v_out: dst.1,
                },
                prm,
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
        let (oa, ob, m, _) = self.compact_reading(flags, a, b, n, None);
        (oa, ob, m)
    }

    /// [`Exec::compact`], reading the first `extra.1` words of buffer `extra.0` (made ready
    /// before the call) in the same read-back as the length; returns them too.
    pub fn compact_reading(
        &mut self,
        flags: &wgpu::Buffer,
        a: &wgpu::Buffer,
        b: Option<&wgpu::Buffer>,
        n: u64,
        extra: Option<(&wgpu::Buffer, u64)>,
    ) -> (wgpu::Buffer, wgpu::Buffer, u64, Vec<u32>) {
        let offs = self.g.storage("compact offsets", (n + 1) * 4);
        self.scan(flags, &offs, n);
        let (m, words) = match extra {
            None => (self.read_at(&offs, n as usize) as u64, Vec::new()),
            Some((buf, w)) => {
                let both = self.g.storage("compacted length and more", (w + 1) * 4);
                self.copy(&offs, n * 4, &both, 4);
                self.copy_at(buf, 0, &both, 4, w * 4);
                let r: Vec<u32> = self.read(&both, w as usize + 1);
                (r[0] as u64, r[1..].to_vec())
            }
        };
        let (oa, ob) = (
            self.g.storage("compacted a", m * 4),
            self.g.storage("compacted b", m * 4),
        );
        if m > 0 {
            self.run(
                launch::Compact {
                    x_flag: flags,
                    x_off: &offs,
                    x_a: a,
                    x_b: b.unwrap_or(a),
                    y_a: &oa,
                    y_b: &ob,
                },
                CompactParams {
                    n: n as u32,
                    index_as_b: b.is_none() as u32,
                },
                n,
                256,
            );
        }
        (oa, ob, m, words)
    }
}

/// Runs of equal consecutive keys on the device (the GPU's `par::compress_runs`): each run's
/// key, first position and length.
pub struct Runs {
    /// Each run's key.
    pub keys: wgpu::Buffer,
    /// Each run's first position.
    pub bases: wgpu::Buffer,
    /// Each run's length.
    pub sizes: wgpu::Buffer,
    /// Number of runs.
    pub len: u64,
}

impl Exec<'_> {
    /// The runs of the `n > 0` keys (thesis §3.2.4, compression).
    pub fn compress_runs(&mut self, keys: &wgpu::Buffer, n: u64) -> Runs {
        let g = self.g;
        let heads = g.storage("heads", n * 4);
        let p = RunsParams {
            n: n as u32,
            total: 0,
        };
        self.run(
            launch::RunHeads {
                x_a: keys,
                y_a: &heads,
            },
            p,
            n,
            256,
        );
        let offs = g.storage("head offsets", (n + 1) * 4);
        self.scan(&heads, &offs, n);
        let len = self.read_at(&offs, n as usize) as u64;
        let runs = Runs {
            keys: g.storage("chunk keys", len * 4),
            bases: g.storage("chunk bases", len * 4),
            sizes: g.storage("chunk sizes", len * 4),
            len,
        };
        self.run(
            launch::RunChunks {
                x_flag: &heads,
                x_off: &offs,
                x_a: keys,
                y_a: &runs.keys,
                y_b: &runs.bases,
            },
            p,
            n,
            256,
        );
        let p = RunsParams {
            n: len as u32,
            total: n as u32,
        };
        self.run(
            launch::RunSizes {
                x_b: &runs.bases,
                y_c: &runs.sizes,
            },
            p,
            len,
            256,
        );
        runs
    }

    /// The values 0..n (what travels with keys through a sort to name their origin).
    pub fn iota(&mut self, n: u64) -> wgpu::Buffer {
        let out = self.g.storage("iota", n.max(1) * 4);
        self.run(
            launch::Iota { y_a: &out },
            PermuteParams {
                n: n as u32,
                value: 0,
            },
            n,
            256,
        );
        out
    }

    /// A buffer of `words` u32, every one `value`, filled on the device.
    pub fn filled(&mut self, label: &str, words: u64, value: u32) -> wgpu::Buffer {
        let out = self.g.storage(label, words.max(1) * 4);
        self.run(
            launch::Fill { y_a: &out },
            PermuteParams {
                n: words as u32,
                value,
            },
            words,
            256,
        );
        out
    }

    /// Decompression (thesis §3.2.6, the GPU's `par::expand_runs`): the runs taken in
    /// `order` (run indices) expanded back to their `n` elements, each element's value
    /// looked up in `vals` at its position.
    pub fn expand_runs(
        &mut self,
        runs: &Runs,
        order: &wgpu::Buffer,
        vals: &wgpu::Buffer,
        n: u64,
    ) -> wgpu::Buffer {
        let g = self.g;
        let len = runs.len;
        let (pg, pe) = (
            PermuteParams {
                n: len as u32,
                value: 0,
            },
            RunsParams {
                n: len as u32,
                total: 0,
            },
        );
        let sizes = g.storage("sorted sizes", len * 4);
        self.run(
            launch::Gather {
                x_a: order,
                x_b: &runs.sizes,
                y_a: &sizes,
            },
            pg,
            len,
            256,
        );
        let offs = g.storage("sorted offsets", (len + 1) * 4);
        self.scan(&sizes, &offs, len);
        let out = g.storage("expanded", n * 4);
        self.run(
            launch::ExpandRuns {
                x_flag: vals,
                x_off: &offs,
                x_a: order,
                x_b: &runs.bases,
                y_a: &out,
            },
            pe,
            len,
            256,
        );
        out
    }
}
