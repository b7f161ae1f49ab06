//! Radix sort against std, rayon and rdst; scans and compaction against memcpy.
//! Run: `cargo bench -p par --profile release`. Ratios within one run are the figures.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use rayon::prelude::*;

fn keys(n: usize, seed: u64) -> Vec<u32> {
    let mut s = seed;
    (0..n)
        .map(|_| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            s as u32
        })
        .collect()
}

/// rdst sorts whole records; the value rides along like ours (never read back).
#[derive(Clone, Copy)]
#[allow(dead_code)]
struct Pair {
    key: u32,
    val: u32,
}

impl rdst::RadixKey for Pair {
    const LEVELS: usize = 4;
    #[inline]
    fn get_level(&self, level: usize) -> u8 {
        (self.key >> (level * 8)) as u8
    }
}

fn sorts(c: &mut Criterion) {
    let mut g = c.benchmark_group("sort (u32 key, u32 value)");
    for log in [16u32, 20, 24] {
        let n = 1usize << log;
        g.throughput(Throughput::Elements(n as u64));
        if log == 24 {
            g.sample_size(10);
        }
        let k = keys(n, 0x9e3779b97f4a7c15);
        let v: Vec<u32> = (0..n as u32).collect();
        let mut scratch = par::SortScratch::new();
        g.bench_with_input(BenchmarkId::new("par::sort_pairs", n), &n, |b, _| {
            b.iter_batched_ref(
                || (k.clone(), v.clone()),
                |(k, v)| par::sort_pairs(k, v, 32, &mut scratch),
                criterion::BatchSize::LargeInput,
            )
        });
        let pairs: Vec<(u32, u32)> = k.iter().copied().zip(v.iter().copied()).collect();
        g.bench_with_input(BenchmarkId::new("rayon par_sort_by_key", n), &n, |b, _| {
            b.iter_batched_ref(
                || pairs.clone(),
                |p| p.par_sort_by_key(|x| x.0),
                criterion::BatchSize::LargeInput,
            )
        });
        if log <= 20 {
            g.bench_with_input(BenchmarkId::new("std sort_by_key", n), &n, |b, _| {
                b.iter_batched_ref(
                    || pairs.clone(),
                    |p| p.sort_by_key(|x| x.0),
                    criterion::BatchSize::LargeInput,
                )
            });
        }
        let rp: Vec<Pair> = k
            .iter()
            .zip(&v)
            .map(|(&key, &val)| Pair { key, val })
            .collect();
        g.bench_with_input(
            BenchmarkId::new("rdst radix_sort_unstable", n),
            &n,
            |b, _| {
                use rdst::RadixSort;
                b.iter_batched_ref(
                    || rp.clone(),
                    |p| p.radix_sort_unstable(),
                    criterion::BatchSize::LargeInput,
                )
            },
        );
    }
    g.finish();
}

fn scans(c: &mut Criterion) {
    let mut g = c.benchmark_group("scan and compaction (u32)");
    for log in [16u32, 20, 24] {
        let n = 1usize << log;
        if log == 24 {
            g.sample_size(10);
        }
        g.throughput(Throughput::Bytes((n * 4) as u64));
        let input: Vec<u32> = keys(n, 7).iter().map(|x| x & 0xff).collect();
        let flags: Vec<u8> = input.iter().map(|x| (x & 1) as u8).collect();
        let mut out = vec![0u32; n];
        g.bench_with_input(BenchmarkId::new("memcpy", n), &n, |b, _| {
            b.iter(|| out.copy_from_slice(&input))
        });
        g.bench_with_input(BenchmarkId::new("parallel memcpy", n), &n, |b, _| {
            b.iter(|| {
                out.par_chunks_mut(1 << 14)
                    .zip(input.par_chunks(1 << 14))
                    .for_each(|(d, s)| d.copy_from_slice(s))
            })
        });
        g.bench_with_input(BenchmarkId::new("exclusive_scan", n), &n, |b, _| {
            b.iter(|| par::exclusive_scan(&input, &mut out))
        });
        g.bench_with_input(BenchmarkId::new("compact (50%)", n), &n, |b, _| {
            b.iter(|| par::compact(&input, &flags, &mut out))
        });
    }
    g.finish();
}

criterion_group!(benches, sorts, scans);
criterion_main!(benches);
