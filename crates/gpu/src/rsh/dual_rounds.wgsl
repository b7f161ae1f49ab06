// The dual traversal's steps without the host (dual.rs's `run_rounds`, `dual/rounds.rs`):
// the kernels of dual.wgsl take their step's count from a state on the device, so where no
// stack reaches the pair budget's chunk, and the host's schedule is "the highest level
// holding pairs, all of them", the device runs it in rounds: each round takes every pair of
// the current ray level, emits its final tests, appends its pairs one ray level down to that
// level's stack and leaves the pairs of collapsed nodes' children as the next round's input.
// Every buffer holds `room` pairs (below the chunk); a round that would pass it sets the
// overflow flag, after which every round does nothing and the host traces the batch again
// with its own steps. The host encodes rounds for every level and the single rays' walk
// without knowing how many each needs: a kernel of ray level L (its `stage`) acts only while
// the state's level is L, and the state moves one level down when its level has no pairs
// left. The state (r_state, u32 words; dual.wgsl): 0 overflow flag, 1 pairs of the current
// level, 2 pairs of the level below, 3 the most pairs held at once, 4 the last round's final
// tests, 5 the current ray level (0: single rays), 6 walked (the single rays' step ran), 7 the
// most rounds a level took (the engine learns how many to encode), 8 the rounds the current
// level has taken.

// The size block of the round's final tests (kernels.rs's `DevSize`: n, then the workgroups
// of 256 threads, folded as Gpu::grid folds them), written by dual_round_update so that no
// size_args launch follows each round.
@group(0) @binding(35) var<storage, read_write> r_size: array<u32>;

fn put_finals(f: u32, maxd: u32) {
    atomicStore(&r_state[R_FINALS], f);
    let groups = (f + 255u) / 256u;
    var x = groups;
    var y = 1u;
    if groups > maxd {
        y = (groups + maxd - 1u) / maxd;
        x = (groups + y - 1u) / y;
    }
    r_size[0] = f;
    r_size[1] = x;
    r_size[2] = y;
    r_size[3] = 1u;
}

// After a round's emit (one thread): the most pairs held (this round's input and the level
// below's stack, as the host's steps count them), the overflow check, the level below's new
// length, the next round's input count and this round's final tests (their count and size
// block: none unless the round ran).
@compute @workgroup_size(1)
fn dual_round_update(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = dual_pair_params();
    let n = round_pairs(p.stage);
    if n == 0u {
        put_finals(0u, p.maxd);
        return;
    }
    let below = atomicLoad(&r_state[R_BELOW]);
    atomicMax(&r_state[R_PEAK], n + below);
    let rounds = atomicLoad(&r_state[R_ROUNDS]) + 1u;
    atomicStore(&r_state[R_ROUNDS], rounds);
    atomicMax(&r_state[R_MOST], rounds);
    let f = p_cnt[p.stride];
    let b = p_cnt[2u * p.stride] - f;
    let h = p_cnt[3u * p.stride] - f - b;
    if f > p.room || below + b > p.room || h > p.room {
        atomicStore(&r_state[R_FLAG], 1u);
        put_finals(0u, p.maxd);
        return;
    }
    atomicStore(&r_state[R_BELOW], below + b);
    atomicStore(&r_state[R_PAIRS], h);
    put_finals(f, p.maxd);
}

// After a level's rounds (one thread): where the state is at that level and it has no pairs
// left, the level below's stack becomes the input.
@compute @workgroup_size(1)
fn dual_round_descend(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = dual_pair_params();
    if atomicLoad(&r_state[R_FLAG]) != 0u || atomicLoad(&r_state[R_LEVEL]) != p.stage || atomicLoad(&r_state[R_PAIRS]) != 0u {
        return;
    }
    atomicStore(&r_state[R_LEVEL], p.stage - 1u);
    let n = atomicLoad(&r_state[R_BELOW]);
    atomicStore(&r_state[R_PAIRS], n);
    atomicStore(&r_state[R_BELOW], 0u);
    atomicStore(&r_state[R_ROUNDS], 0u);
    // Held now: the new level's pairs alone (the single rays' step counts them here).
    atomicMax(&r_state[R_PEAK], n);
}

// The single rays' stack (a copy) padded to cap with a key past every leaf position, so the
// sort over all cap slots leaves the pairs in the host's order, the padding last; where the
// state has not reached the single rays, every slot is padding (and nothing walks).
@compute @workgroup_size(256)
fn dual_round_pad(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let p = dual_pair_params();
    let i = gid.x + gid.y * nwg.x * 256u;
    let n = round_pairs(0u);
    if i == 0u && atomicLoad(&r_state[R_FLAG]) == 0u && atomicLoad(&r_state[R_LEVEL]) == 0u {
        atomicStore(&r_state[R_WALKED], 1u);
    }
    if i < p.stride && i >= n {
        r_below_ray[i] = p.pad;
        r_below_obj[i] = 0u;
    }
}

