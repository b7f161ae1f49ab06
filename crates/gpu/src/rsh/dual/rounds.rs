//! The dual traversal's steps without the host (`dual_rounds.wgsl`): where every stack
//! stays below the pair budget's chunk, the host's schedule ([`GpuDual::run`]) is "the
//! highest ray level holding pairs, all of them, until it holds none", so the device can
//! run it alone: rounds over a count it holds, each round's pairs of collapsed nodes'
//! children the next round's input, the pairs one level down appended to that level's
//! stack, the final tests over a count on the device (an indirect dispatch). The host
//! encodes passes of [`ROUNDS`] rounds for every level from the one the device is at, then
//! the single rays' step, and reads back the state's words after each pass (the overflow
//! flag, the device's level, whether the single rays walked): the only read-backs of the
//! traversal, one where no level needs more than [`ROUNDS`] rounds. A kernel acts only
//! while the device is at its level, so the rounds a level does not need do nothing. Every
//! buffer holds `cap` pairs (below the chunk, so the schedule is the host's); a round that
//! would pass it flags the trace, which the host then traces again with its own steps
//! ([`GpuDual::run`] resets the best hits and the counters). Where the device laid the
//! hierarchy out ([`GpuDual::laid`]), the host never looks: one pass is encoded, the device
//! starts at the top level it built, and the state's flag, walked word and most rounds go
//! into the counter block ([`GpuDual::outcome`]), read with the frame's image.

use super::{region, GpuDual, Region, Scratch};
use crate::kernels::{launch, DevSize, Exec, Threads};
use accel::bvh::objects::LEAF;

/// Rounds per level of one pass (Sponza's 512² shadow rays take 10–11 at each of their two
/// levels; office's 3-bounce batches 2–6).
pub const ROUNDS: usize = 12;

/// The pairs every buffer of the rounds holds, for a trace that asks room for `pairs` (8 per
/// leaf: [`GpuDual::room`]), a top level of at most `nt` nodes and the schedule's `chunk`:
/// `pairs`, or 64 Ki pairs (half a MiB a buffer) for small batches, whose incoherent rays
/// (BART kitchen's reflections at 128²: 1,422 rays) passed 8 a ray; below the chunk (so
/// that no stack reaches it), at most `bound` (tests), at least the top level's nodes;
/// `None` where the rounds cannot keep the host's schedule (the top level alone fills a
/// chunk).
pub fn rounds_cap(pairs: u64, nt: u64, chunk: u64, bound: Option<u64>) -> Option<u64> {
    let own = pairs.max(1 << 16).min(chunk.saturating_sub(1));
    let cap = bound.map_or(own, |c| c.min(own));
    (nt <= cap && nt > 0).then_some(cap)
}

impl GpuDual<'_> {
    /// The pairs every buffer of the rounds holds ([`rounds_cap`] of this trace).
    pub(super) fn round_cap(&self, chunk: u64) -> Option<u64> {
        let nt = self.levels.last()?.cap as u64;
        rounds_cap(self.room, nt, chunk, self.rounds.1)
    }

    /// The traversal in rounds over buffers of `cap` pairs; the beams are `beams`. Returns
    /// whether it finished (else a round overflowed, and its work must be traced again).
    /// Laid out on the device ([`GpuDual::laid`]): one pass, never read, and `true`; the
    /// counters then say whether it finished ([`GpuDual::outcome`]).
    /// The most pairs held at once goes into the counter block (word 16 · levels + 16).
    pub(super) fn run_rounds(&self, ex: &mut Exec, beams: &[wgpu::Buffer], cap: u64) -> bool {
        let g = ex.g;
        let nl = self.levels.len();
        let nt = self.levels[nl - 1].cap;
        let root = if self.tree.leaves == 1 { LEAF } else { 0 };
        let state = g.upload("dual round state", &super::step_state(nt as u64, nl));
        if let Some(laid) = self.laid {
            // The levels built and the top level's nodes: the device's own.
            ex.copy_at(&laid.block, laid.tail_byte(), &state, 20, 4);
            ex.copy_at(&laid.block, laid.tail_byte() + 4, &state, 4, 4);
        }
        // Per ray level L ≥ 1 (index L): its input and the next round's (swapped each
        // round), and its stack of pairs one level down (the input of level L − 1).
        let mut io: Vec<Option<(Region, Region)>> = (0..=nl + 1).map(|_| None).collect();
        let mut below: Vec<Option<Region>> = (0..=nl + 1).map(|_| None).collect();
        let top = region(ex, "dual round input", cap);
        let ids: Vec<u32> = (0..nt).collect();
        ex.copy(&g.upload("dual top nodes", &ids), 0, &top.0, nt as u64 * 4);
        let roots = g.upload("dual top roots", &vec![root; nt as usize]);
        ex.copy(&roots, 0, &top.1, nt as u64 * 4);
        if self.laid.is_some() {
            // The device starts at the top level it built, which may be below the layout's
            // last: every level's input starts as the top nodes (a level above the one
            // built never runs; one that does overwrites its stack from its start).
            for b in below.iter_mut().take(nl + 1).skip(2) {
                let r = region(ex, "dual round stack below", cap);
                ex.copy(&top.0, 0, &r.0, nt as u64 * 4);
                ex.copy(&top.1, 0, &r.1, nt as u64 * 4);
                *b = Some(r);
            }
        }
        io[nl] = Some((top, region(ex, "dual round output", cap)));
        let scratch = Scratch {
            act: g.storage("dual round actions", cap * 4),
            counts: g.storage("dual round counts", 3 * cap * 4),
            offs: g.storage("dual round offsets", (3 * cap + 1) * 4),
            size: g.indirect("dual round final tests' size", 16),
        };
        let fin = region(ex, "dual round final tests", cap);
        let walk = region(ex, "dual round single rays", cap);
        let mut at = nl;
        loop {
            for l in (1..=at).rev() {
                if io[l].is_none() {
                    // The level's input: the stack the level above fills (and may still
                    // append to, should it need another pass: then these rounds do nothing).
                    let input = below[l + 1].clone().expect("the level above comes first");
                    io[l] = Some((input, region(ex, "dual round output", cap)));
                }
                if below[l].is_none() {
                    below[l] = Some(region(ex, "dual round stack below", cap));
                }
                let (input, spare) = io[l].as_mut().unwrap();
                let b = below[l].as_ref().unwrap();
                for _ in 0..self.rounds.0 {
                    let out = (&fin, b, &*spare);
                    self.round(ex, beams, cap, l, &state, &*input, out, &scratch);
                    std::mem::swap(input, spare);
                }
                ex.run(
                    launch::DualRoundDescend { r_state: &state },
                    self.pair_params(cap, l, cap as u32, 0),
                    1,
                    1,
                );
            }
            // The single rays' step, on a copy of their stack (the sort must not reorder a
            // stack that level 1 may still append to in a later pass).
            let stack = below[1].as_ref().unwrap();
            ex.copy(&stack.0, 0, &walk.0, cap * 4);
            ex.copy(&stack.1, 0, &walk.1, cap * 4);
            self.round_walks(ex, &state, &walk, cap);
            if self.laid.is_some() {
                // Nobody looks: whether the pass finished is read with the counters.
                break;
            }
            // The overflow flag, the device's level and whether the single rays walked.
            let w: Vec<u32> = ex.read(&state, 7);
            if w[0] != 0 {
                return false;
            }
            if w[6] != 0 {
                break;
            }
            at = w[5] as usize;
            assert!((1..=nl).contains(&at), "the device's level {at} of {nl}");
            // The levels below it did nothing: their inputs start again from the stacks.
            for x in io.iter_mut().take(at) {
                *x = None;
            }
        }
        // The peak next to the counters (read with them), then the outcome
        // ([`GpuDual::outcome`]): the flag, walked, the most rounds a level took and, laid
        // out on the device, its levels and top nodes.
        let t = self.tail() as u64 * 4;
        ex.copy_at(&state, 12, self.counters, t + 64, 4);
        ex.copy_at(&state, 0, self.counters, t + 68, 4);
        ex.copy_at(&state, 24, self.counters, t + 72, 8);
        match self.laid {
            Some(laid) => ex.copy_at(&laid.block, laid.tail_byte(), self.counters, t + 80, 8),
            None => {
                let shape = [nl as u32, nt];
                let w = g.upload("dual hierarchy shape", &shape);
                ex.copy_at(&w, 0, self.counters, t + 80, 8);
            }
        }
        true
    }

    /// One round at ray level `l ≥ 1` over `input`: classify, scan the streams' counts,
    /// emit into `out` (final tests, the stack below, the next round's input), update the
    /// state, and at level 1 the round's final tests over the count the update left.
    #[allow(clippy::too_many_arguments)]
    fn round(
        &self,
        ex: &mut Exec,
        beams: &[wgpu::Buffer],
        cap: u64,
        l: usize,
        state: &wgpu::Buffer,
        input: &Region,
        out: (&Region, &Region, &Region),
        s: &Scratch,
    ) {
        let prm = self.pair_params(cap, l, cap as u32, 0);
        ex.phase(trace::TRAVERSAL);
        self.classify(ex, beams, l, input, state, s, prm);
        ex.scan(&s.counts, &s.offs, 3 * cap);
        self.emit(ex, l, input, state, s, out, prm);
        let size = DevSize {
            block: s.size.clone(),
            at: 0,
            cap,
        };
        ex.run(
            launch::DualRoundUpdate {
                p_cnt: &s.offs,
                r_state: state,
                r_size: &size.block,
            },
            prm,
            1,
            1,
        );
        if l == 1 {
            // Over the count the update left (its size block).
            self.final_tests(ex, out.0, cap, Threads::of(Some(&size), cap));
        }
    }

    /// The single rays' step over `pairs` (a copy of their stack; its count in the state,
    /// zero until the device reaches them): padded, sorted by ray over all `cap` slots,
    /// each ray's run walked by the thread at its head.
    fn round_walks(&self, ex: &mut Exec, state: &wgpu::Buffer, pairs: &Region, cap: u64) {
        ex.phase(::rsh::stats::FINAL_TESTS);
        let bits = (32 - (self.m as u32).leading_zeros()).max(1);
        let pad = if bits >= 32 {
            u32::MAX
        } else {
            (1 << bits) - 1
        };
        ex.run(
            launch::DualRoundPad {
                r_state: state,
                r_below_ray: &pairs.0,
                r_below_obj: &pairs.1,
            },
            self.pair_params(cap, 0, cap as u32, pad),
            cap,
            256,
        );
        ex.sort_pairs_all(&pairs.0, &pairs.1, cap, bits);
        self.walks(ex, state, pairs, cap);
        ex.phase(trace::TRAVERSAL);
    }
}
