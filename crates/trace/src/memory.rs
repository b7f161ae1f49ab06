//! How much memory a command may use, for the memory models checked before allocating
//! (the render's: `render::whitted::render_bytes`; the irregular grid's:
//! `accel::grid::GridConfig::max_bytes`; CRSH's pair budget).
//!
//! The default is 80 % of the smallest of the machine's physical memory, the process's
//! address-space limit (`ulimit -v`) and its control group's limit, so that a request the
//! machine cannot hold is refused with an error naming the option instead of ending in an
//! out-of-memory abort.

use std::sync::atomic::{AtomicU64, Ordering};

/// Keep freed memory in the process for reuse, where the allocator is glibc's.
///
/// glibc hands a large freed buffer back to the kernel (`munmap`, or trimming the heap), so
/// a pass that frees its scratch and allocates it again, per octree level, merge round or
/// frame, pays a page fault for every 4 KiB of it each time: a Sponza grid rebuild faulted
/// in ~68 MB of fresh pages, about a quarter of its time on the 2-core VM. This serves
/// buffers up to 32 MiB (glibc's ceiling for the setting) from the heap and never trims it,
/// so freed pages are reused. The memory limits above count what the program allocates, not
/// what the allocator keeps. Call it once, first thing in `main`; elsewhere it does nothing.
pub fn keep_freed_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: mallopt only changes allocator parameters; called before other threads exist.
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, 32 << 20);
        libc::mallopt(libc::M_TRIM_THRESHOLD, i32::MAX);
    }
}

/// Give the heap's free memory back to the kernel when it holds at least `min_free` bytes
/// (glibc; elsewhere nothing): the exception to [`keep_freed_memory`] for a pass about to
/// allocate far more than the memory freed before it, where the freed pages would count
/// towards the peak without being reused. Returns the free bytes found.
///
/// The irregular grid's merge calls it: the initial cells' build leaves its scratch free in
/// the heap (about 270 MiB on a 2 M-triangle hairball), and the merge's state is allocated
/// in buffers above the heap's 32 MiB ceiling, which never reuse it.
pub fn release_free_heap(min_free: u64) -> u64 {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    {
        let free = heap_free();
        if free >= min_free {
            // SAFETY: malloc_trim only returns free pages, and is thread-safe.
            unsafe { libc::malloc_trim(0) };
        }
        free
    }
    #[cfg(not(all(target_os = "linux", target_env = "gnu")))]
    {
        let _ = min_free;
        0
    }
}

/// Shorten `v` to `len` elements and hand the whole pages of its buffer past them back to
/// the kernel (Linux; elsewhere it only shortens).
///
/// `Vec::shrink_to_fit` would do it by reallocating, which for an element alignment above
/// the allocator's 16 bytes is a copy: both buffers are resident at once, the opposite of
/// the point when a buffer of hundreds of MB is cut in half. The capacity is kept; the
/// pages come back zero-filled if the vector grows into them again.
pub fn release_tail<T: Copy>(v: &mut Vec<T>, len: usize) {
    v.truncate(len);
    #[cfg(target_os = "linux")]
    {
        let size = std::mem::size_of::<T>();
        let page = 4096usize;
        let start = (v.as_ptr() as usize + len * size).next_multiple_of(page);
        let end = (v.as_ptr() as usize + v.capacity() * size) / page * page;
        if size > 0 && end > start {
            // SAFETY: [start, end) lies inside `v`'s allocation and past its last element,
            // so no live value is in it and nothing borrows it; MADV_DONTNEED on private
            // anonymous memory (heap or mmap) only drops the pages, which read back as zeros.
            unsafe {
                libc::madvise(start as *mut libc::c_void, end - start, libc::MADV_DONTNEED);
            }
        }
    }
}

/// 80 % of the smallest of the machine's physical memory, the process's address-space limit
/// (`ulimit -v`) and its control group's memory limit (a container's: cgroup v2
/// `memory.max`, v1 `memory.limit_in_bytes`), in bytes (`u64::MAX` where none is known).
pub fn default_limit() -> u64 {
    let kib = |text: &str, key: &str| -> Option<u64> {
        let l = text.lines().find(|l| l.starts_with(key))?;
        l.split_whitespace().nth(1)?.parse().ok()
    };
    let total = std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|t| kib(&t, "MemTotal:"))
        .map_or(u64::MAX, |k| k.saturating_mul(1024));
    // "Max address space  <soft> <hard> bytes" (or "unlimited").
    let rlimit = std::fs::read_to_string("/proc/self/limits")
        .ok()
        .and_then(|t| {
            let l = t.lines().find(|l| l.starts_with("Max address space"))?;
            l["Max address space".len()..]
                .split_whitespace()
                .next()?
                .parse::<u64>()
                .ok()
        })
        .unwrap_or(u64::MAX);
    let m = total.min(rlimit).min(cgroup_limit());
    if m == u64::MAX {
        m
    } else {
        m / 5 * 4
    }
}

/// The memory limit of the process's control group, in bytes (`u64::MAX` where there is
/// none or it cannot be read): cgroup v2's `memory.max` of the group `/proc/self/cgroup`
/// names (under `/sys/fs/cgroup`), else cgroup v1's `memory.limit_in_bytes`.
pub fn cgroup_limit() -> u64 {
    let read = |p: &str| -> Option<u64> {
        let t = std::fs::read_to_string(p).ok()?;
        t.trim().parse::<u64>().ok()
    };
    // v2: "0::/path" in /proc/self/cgroup.
    let group = std::fs::read_to_string("/proc/self/cgroup")
        .ok()
        .and_then(|t| {
            t.lines()
                .find_map(|l| l.strip_prefix("0::").map(|p| p.trim().to_string()))
        })
        .unwrap_or_default();
    let mut candidates = Vec::new();
    if !group.is_empty() && group != "/" {
        candidates.push(format!("/sys/fs/cgroup{group}/memory.max"));
    }
    candidates.push("/sys/fs/cgroup/memory.max".into());
    candidates.push("/sys/fs/cgroup/memory/memory.limit_in_bytes".into());
    candidates
        .iter()
        .filter_map(|p| read(p))
        // v1 reports "no limit" as a huge page-rounded number.
        .filter(|&b| b < 1 << 60)
        .min()
        .unwrap_or(u64::MAX)
}

/// The resident memory the process holds now, in bytes (`VmRSS`; `None` where the system
/// does not say): what a whole-process memory model starts from once the scene is loaded.
pub fn current_rss() -> Option<u64> {
    status_bytes("VmRSS:")
}

/// `--max-memory` in MiB when given, else [`default_limit`].
pub fn limit(max_mib: Option<u64>) -> u64 {
    max_mib.map_or_else(default_limit, |m| m.saturating_mul(1 << 20))
}

/// Bytes as GiB with one decimal (MiB below 1 GiB), for messages.
pub fn gib(bytes: u64) -> String {
    if bytes < 1 << 30 {
        format!("{} MiB", bytes.div_ceil(1 << 20))
    } else {
        format!("{:.1} GiB", bytes as f64 / (1u64 << 30) as f64)
    }
}

/// The process's peak resident memory so far, in bytes: `VmHWM` of `/proc/self/status`, or
/// the peak a [`PeakWatch`] set aside when it reset that mark, whichever is larger; `None`
/// where the system does not say.
pub fn peak_rss() -> Option<u64> {
    let hwm = status_bytes("VmHWM:")?;
    Some(hwm.max(EARLIER_PEAK.load(Ordering::Relaxed)))
}

/// A `/proc/self/status` line's value in bytes (Linux; `None` elsewhere).
fn status_bytes(key: &str) -> Option<u64> {
    let text = std::fs::read_to_string("/proc/self/status").ok()?;
    let l = text.lines().find(|l| l.starts_with(key))?;
    let kib: u64 = l.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib.saturating_mul(1024))
}

/// The process's peak before the last reset of its high-water mark ([`PeakWatch::start`]).
static EARLIER_PEAK: AtomicU64 = AtomicU64::new(0);

/// The resident memory a piece of work adds at its peak (an engine's build: the paper's
/// "peak memory during construction", issue 44's bound of 3× the final structure).
///
/// [`PeakWatch::start`] notes the memory the process holds, then resets the kernel's
/// high-water mark to the resident memory now (`/proc/self/clear_refs`, "5"); [`added`]
/// is the mark since then minus what the process held. What it held is the resident memory
/// less the allocator's free bytes ([`heap_free`]): freed buffers the process keeps for
/// reuse ([`keep_freed_memory`]) and that the work fills again count as the work's. The
/// whole-process peak before the reset is set aside, so [`peak_rss`] still tells the
/// process's peak over its life.
///
/// [`added`]: PeakWatch::added
pub struct PeakWatch {
    held: u64,
}

impl PeakWatch {
    /// Start watching; `None` where the system cannot reset the mark (not Linux, or
    /// `/proc` not writable), so no figure is made up.
    pub fn start() -> Option<PeakWatch> {
        let before = status_bytes("VmHWM:")?;
        EARLIER_PEAK.fetch_max(before, Ordering::Relaxed);
        std::fs::write("/proc/self/clear_refs", "5").ok()?;
        let rss = status_bytes("VmRSS:")?;
        Some(PeakWatch {
            held: rss.saturating_sub(heap_free()),
        })
    }

    /// The resident memory added at the peak since [`PeakWatch::start`], in bytes.
    pub fn added(&self) -> Option<u64> {
        Some(status_bytes("VmHWM:")?.saturating_sub(self.held))
    }
}

/// Free bytes the allocator holds (glibc's `mallinfo2`; 0 elsewhere).
pub fn heap_free() -> u64 {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    {
        // SAFETY: mallinfo2 only reads the allocator's statistics.
        unsafe { libc::mallinfo2() }.fordblks as u64
    }
    #[cfg(not(all(target_os = "linux", target_env = "gnu")))]
    {
        0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn limits() {
        assert_eq!(limit(Some(3)), 3 << 20);
        assert_eq!(limit(Some(u64::MAX)), u64::MAX);
        let d = default_limit();
        assert!(d > 1 << 20, "{d}");
        assert_eq!(gib(3 << 29), "1.5 GiB");
        assert_eq!(gib(64 << 20), "64 MiB");
    }

    /// The watch sees a buffer touched while it watches, and the process's peak keeps what
    /// came before the reset. Where `/proc` cannot be read or reset (not Linux) it says so
    /// with `None`, which this test reports as skipped; `.ci/run` requires it on Linux.
    #[test]
    fn peak_watch_sees_the_work_and_keeps_the_process_peak() {
        const MB: usize = 1 << 20;
        // An earlier peak: 96 MiB touched and freed.
        let mut v = vec![0u8; 96 * MB];
        for i in (0..v.len()).step_by(4096) {
            v[i] = 1;
        }
        std::hint::black_box(&v);
        drop(v);
        let before = peak_rss();
        let Some(w) = PeakWatch::start() else {
            if std::env::var("RAYSPACE_REQUIRE").is_ok_and(|r| r.split(',').any(|x| x == "procmem"))
            {
                panic!("RAYSPACE_REQUIRE lists 'procmem', but /proc/self/clear_refs cannot reset the peak");
            }
            eprintln!("SKIPPED: no /proc/self/status or writable clear_refs: peak watch untested");
            return;
        };
        let mut v = vec![0u8; 48 * MB];
        for i in (0..v.len()).step_by(4096) {
            v[i] = 2;
        }
        std::hint::black_box(&v);
        drop(v);
        let added = w.added().unwrap();
        assert!(added >= 48 * MB as u64, "{added}");
        // Far less than the earlier 96 MiB (test threads may allocate beside it).
        assert!(added < 80 * MB as u64, "{added}");
        assert!(peak_rss() >= before, "the peak before the reset is kept");
        assert!(peak_rss().unwrap() >= 96 * MB as u64);
    }
}
