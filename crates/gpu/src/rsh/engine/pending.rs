//! What [`GpuRsh`]'s traces in a frame leave on the device until the frame reads it with its
//! image ([`crate::GpuEngine::take_pending`], [`crate::GpuEngine::settle`]), and what the
//! engine learns from it: whether a trace the device paced alone finished, and the rounds
//! and room its later traces take ([`crate::GpuEngine::take_incomplete`]).

use super::GpuRsh;
use crate::rsh::dual::{GpuDual, Outcome};
use ::rsh::traverse::Counters;
use std::sync::atomic::Ordering;
use trace::TraceStats;

/// A trace's counts left on the device until the frame reads them with its image.
#[derive(Clone)]
pub(super) enum Pending {
    /// The bundles' counts: a dual traversal's counters ([`GpuDual::counter_words`] words,
    /// where `levels` is some), then the records' totals (`frame::totals_on_device`), with
    /// what the host counted (the mesh-sphere traversal's counters, the dual's peaks) and
    /// the hierarchy's top nodes.
    Bundles {
        block: wgpu::Buffer,
        words: u64,
        levels: Option<usize>,
        c: Counters,
        top: u64,
        /// The device laid the hierarchy out and paced the traversal: its levels, top
        /// nodes and whether it finished are in the block ([`GpuDual::outcome`]).
        laid: bool,
    },
}

/// Rounds per level a device-laid trace takes beyond the most its engine's last frame took
/// (the next frame's traces differ a little: an animation's next view).
pub const ROUND_MARGIN: usize = 2;

impl GpuRsh {
    /// [`crate::GpuEngine::take_pending`].
    pub(crate) fn take_pending(&self) -> Vec<(wgpu::Buffer, u64)> {
        let taken = std::mem::take(&mut *self.pending.lock().unwrap());
        let out = taken
            .iter()
            .map(|p| match p {
                Pending::Bundles { block, words, .. } => (block.clone(), *words),
            })
            .collect();
        *self.settling.lock().unwrap() = taken;
        out
    }

    /// [`crate::GpuEngine::settle`].
    pub(crate) fn settle(&self, words: &[u32], stats: &mut TraceStats) {
        let mut at = 0;
        for p in std::mem::take(&mut *self.settling.lock().unwrap()) {
            match p {
                Pending::Bundles {
                    words: n,
                    levels,
                    mut c,
                    mut top,
                    laid,
                    ..
                } => {
                    let w = &words[at..at + n as usize];
                    let cw = levels.map_or(0, |l| GpuDual::counter_words(l) as usize);
                    if let Some(levels) = levels {
                        let over = GpuDual::counts(&w[..cw], levels, &mut c);
                        stats.count(crate::stats::STACK_OVERFLOWS, over);
                        let o = GpuDual::outcome(&w[..cw], levels);
                        if laid {
                            self.learn(&o);
                            let most = o.most_rounds as usize;
                            self.frame_most.fetch_max(most, Ordering::Relaxed);
                            // The levels the device built, of those laid out.
                            c.tests.truncate(o.levels);
                            c.hits.truncate(o.levels);
                            top = o.top;
                            if self.s.cfg.method == ::rsh::Method::Crsh {
                                stats.count(::rsh::stats::CHUNKS, o.chunks);
                            }
                        }
                        let most = o.most_rounds as usize;
                        self.learned.fetch_max(most, Ordering::Relaxed);
                    }
                    let hits = crate::frame::sum_totals(&w[cw..]).hits;
                    self.report(&c, top, hits, stats);
                    at += n as usize;
                }
            }
        }
    }

    /// What a device-laid trace's outcome teaches: one that did not finish makes the frame
    /// incomplete ([`GpuRsh::take_incomplete`]), for want of rounds or of room.
    fn learn(&self, o: &Outcome) {
        if o.finished() {
            return;
        }
        let short = if o.overflowed { 2 } else { 1 };
        self.incomplete.fetch_or(short, Ordering::Relaxed);
    }

    /// [`crate::GpuEngine::take_incomplete`], once per frame: after a frame that did not
    /// finish, the later frames' traces take twice the rounds, or twice the room, up to 64
    /// pairs per leaf (then none is laid out: the host paces them); after one that did, as
    /// many rounds per level as its traces' most, and [`ROUND_MARGIN`] more (a frame's
    /// rounds are launches whether a level needs them or not).
    pub(crate) fn take_incomplete(&self) -> bool {
        let short = self.incomplete.swap(0, Ordering::Relaxed);
        let most = self.frame_most.swap(0, Ordering::Relaxed);
        if short == 0 && most > 0 {
            self.learned.store(most + ROUND_MARGIN, Ordering::Relaxed);
        }
        if short & 1 != 0 {
            let r = self.learned.load(Ordering::Relaxed);
            self.learned.store((2 * r).min(1 << 10), Ordering::Relaxed);
        }
        if short & 2 != 0 {
            let per = self.per_ray.load(Ordering::Relaxed);
            if per < 64 {
                self.per_ray.store(2 * per, Ordering::Relaxed);
            } else {
                self.laid_off.store(true, Ordering::Relaxed);
            }
        }
        short != 0
    }

    /// [`crate::GpuEngine::pace`].
    pub(crate) fn pace(&self, on: bool) {
        self.paced.store(on, Ordering::Relaxed);
    }
}
