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
//! ([`GpuDual::run`] resets the best hits and the counters).

use super::{region, GpuDual, Region, Scratch};
use crate::kernels::{launch, DevLen, Exec, Threads};
use ::rsh::objects::LEAF;
use trace::Phase;

/// Rounds per level of one pass (Sponza's 512² shadow rays take 10–11 at each of their two
/// levels; office's 3-bounce batches 2–6).
pub const ROUNDS: usize = 12;

impl GpuDual<'_> {
    /// The pairs every buffer of the rounds holds: room for 8 pairs per ray, or 64 Ki pairs
    /// (half a MiB a buffer) for small batches, whose incoherent rays (BART kitchen's
    /// reflections at 128²: 1,422 rays) passed 8 a ray; below the chunk (so that no stack
    /// reaches it), at least the top level's nodes; `None` where the rounds cannot keep the
    /// host's schedule (the top level alone fills a chunk).
    pub(super) fn round_cap(&self, chunk: u64) -> Option<u64> {
        let nt = self.levels.last()?.len() as u64;
        let own = (8 * self.m).max(1 << 16).min(chunk.saturating_sub(1));
        let cap = self.rounds.1.map_or(own, |c| c.min(own));
        (nt <= cap && nt > 0).then_some(cap)
    }

    /// The traversal in rounds over buffers of `cap` pairs; the beams are `beams`. Returns
    /// whether it finished (else a round overflowed, and its work must be traced again).
    /// The most pairs held at once goes into the counter block (word 16 · levels + 16).
    pub(super) fn run_rounds(&self, ex: &mut Exec, beams: &[wgpu::Buffer], cap: u64) -> bool {
        let g = ex.g;
        let nl = self.levels.len();
        let nt = self.levels[nl - 1].len();
        let root = if self.tree.leaves == 1 { LEAF } else { 0 };
        let state = g.upload("dual round state", &[0u32, nt, 0, 0, 0, nl as u32, 0]);
        // Per ray level L ≥ 1 (index L): its input and the next round's (swapped each
        // round), and its stack of pairs one level down (the input of level L − 1).
        let mut io: Vec<Option<(Region, Region)>> = (0..=nl + 1).map(|_| None).collect();
        let mut below: Vec<Option<Region>> = (0..=nl + 1).map(|_| None).collect();
        let top = region(ex, "dual round input", cap);
        let ids: Vec<u32> = (0..nt).collect();
        ex.copy(&g.upload("dual top nodes", &ids), 0, &top.0, nt as u64 * 4);
        let roots = g.upload("dual top roots", &vec![root; nt as usize]);
        ex.copy(&roots, 0, &top.1, nt as u64 * 4);
        io[nl] = Some((top, region(ex, "dual round output", cap)));
        let scratch = Scratch {
            act: g.storage("dual round actions", cap * 4),
            counts: g.storage("dual round counts", 3 * cap * 4),
            offs: g.storage("dual round offsets", (3 * cap + 1) * 4),
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
        // The peak next to the counters (read with them).
        ex.copy_at(&state, 12, self.counters, (self.tail() as u64 + 16) * 4, 4);
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
        ex.phase(Phase::Traversal);
        self.classify(ex, beams, l, input, state, s, prm);
        ex.scan(&s.counts, &s.offs, 3 * cap);
        self.emit(ex, l, input, state, s, out, prm);
        ex.run(
            launch::DualRoundUpdate {
                p_cnt: &s.offs,
                r_state: state,
            },
            prm,
            1,
            1,
        );
        if l == 1 {
            let len = DevLen {
                buf: state.clone(),
                at: 4,
                cap,
            };
            let size = ex.sizes(&len, &[(1, 256)]).remove(0);
            self.final_tests(ex, out.0, cap, Threads::of(Some(&size), cap));
        }
    }

    /// The single rays' step over `pairs` (a copy of their stack; its count in the state,
    /// zero until the device reaches them): padded, sorted by ray over all `cap` slots,
    /// each ray's run walked by the thread at its head.
    fn round_walks(&self, ex: &mut Exec, state: &wgpu::Buffer, pairs: &Region, cap: u64) {
        ex.phase(Phase::FinalTests);
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
        ex.phase(Phase::Traversal);
    }
}
