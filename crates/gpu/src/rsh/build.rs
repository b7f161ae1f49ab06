//! The hierarchy's construction on the GPU, the twin of `crates/rsh/src/build.rs`: level 1
//! over the sorted leaves, then unions level by level (thesis §3.2.7; `build.wgsl`), with
//! the CPU's stop rules; the leaves per kind come from the ordering (`kinds.wgsl`, read back
//! with the trim's count). Where the host reads nothing ([`build_laid`]), the device lays the
//! levels out itself (`kinds.wgsl`'s `level_layout`) in buffers of the batch's bound, and
//! each launch reads its size and parameters there.

use super::device_scene::DeviceScene;
use crate::kernels::params::{LevelLayoutParams, LevelParams};
use crate::kernels::{launch, DevSize, Exec, Threads};
use crate::rays::DeviceRays;
use ::rsh::Union;

/// One level of nodes on the device (structure of arrays, as `rsh::build::Level`).
pub struct Level {
    /// Origin spheres (centre, radius).
    pub sphere: wgpu::Buffer,
    /// Cone axes and half-angles.
    pub cone: wgpu::Buffer,
    /// Per node: sin α, cos α, longest t_max, kind (bits).
    pub sc: wgpu::Buffer,
    /// Children of node i: `first[i] .. first[i + 1]` in the level below.
    pub first: wgpu::Buffer,
    /// Nodes per kind (kinds are sorted, so this is the level's whole layout).
    pub per_kind: [u32; 4],
    /// Children per kind in the level below (leaves for level 1): each kind's nodes take
    /// `b` of them but the last, which takes the rest.
    pub children: [u32; 4],
    /// Laid out on the device ([`build_laid`]): the level's size block (n: its nodes) and
    /// parameters there; `per_kind` and `children` are then zero, and [`Level::cap`] bounds
    /// the nodes.
    pub sized: Option<DevSize>,
    /// Most nodes the level's buffers hold.
    pub cap: u32,
}

/// Words of one level's block in the device's layout (`kinds.wgsl`'s `LAYOUT_WORDS`): its
/// size block, then its `LevelParams`.
pub const LAYOUT_WORDS: u64 = 20;

/// The layout the device computed for a hierarchy ([`build_laid`]): per level
/// [`LAYOUT_WORDS`] words, then the levels built and the top level's nodes.
pub struct Laid {
    /// The blocks.
    pub block: wgpu::Buffer,
    /// Levels laid out (a bound of those built).
    pub levels: usize,
}

impl Laid {
    /// The byte of the word holding the levels built (the top level's nodes follow).
    pub fn tail_byte(&self) -> u64 {
        4 * LAYOUT_WORDS * self.levels as u64
    }
}

impl Level {
    /// Nodes in the level (laid out on the host).
    pub fn len(&self) -> u32 {
        self.per_kind.iter().sum()
    }

    /// Whether the level has no nodes.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// Bottom-up build: level 1 over the sorted leaves (`per_kind` of each ray kind, kinds in
/// order: [`super::order::leaf_order`]), then unions, as `rsh::build::build`.
pub fn build(
    eng: &DeviceScene,
    ex: &mut Exec,
    rays: &DeviceRays,
    leaves: &wgpu::Buffer,
    per_kind: [u32; 4],
) -> Vec<Level> {
    let g = &eng.gpu;
    let b = eng.cfg.branching;
    let union = (eng.cfg.union == Union::Thesis) as u32;
    let mut levels: Vec<Level> = Vec::new();
    let mut below = per_kind;
    loop {
        let nodes: [u32; 4] = below.map(|c| c.div_ceil(b));
        let total: u32 = nodes.iter().sum();
        let children: u32 = below.iter().sum();
        let mut run = [0u32; 4];
        let mut cum = [0u32; 4];
        for k in 1..4 {
            run[k] = run[k - 1] + below[k - 1];
            cum[k] = cum[k - 1] + nodes[k - 1];
        }
        let lv = Level {
            sphere: g.storage("node spheres", total as u64 * 16),
            cone: g.storage("node cones", total as u64 * 16),
            sc: g.storage("node sc", total as u64 * 16),
            first: g.storage("node first", (total as u64 + 1) * 4),
            per_kind: nodes,
            children: below,
            sized: None,
            cap: total,
        };
        let prm = LevelParams {
            nodes: total,
            b,
            union_thesis: union,
            children,
            run,
            cum,
            below,
        };
        launch_level(
            eng,
            ex,
            rays,
            leaves,
            levels.last(),
            &lv,
            prm,
            Threads::Host(total as u64),
        );
        levels.push(lv);
        // Stop rules of rsh::build.
        let top = levels.last().unwrap();
        let done = if eng.cfg.levels == 0 {
            top.per_kind.iter().all(|&c| c <= 1)
        } else {
            levels.len() as u32 >= eng.cfg.levels
        };
        if done || top.len() <= 1 {
            break;
        }
        below = top.per_kind;
    }
    levels
}

/// [`build`] with nothing read back: the leaves' kinds are counted on the device (`kinds`, 4
/// words), the trimmed leaves at most `n`. The device lays the levels out (`level_layout`)
/// by `build`'s rules; the host allocates each level at its bound (a level has at most
/// ⌈below / b⌉ + 3 nodes, one partial node per kind) for as many levels as the rules could
/// build from `n` leaves, and every launch reads its size and parameters from the layout.
/// Levels past those the rules build stay empty.
pub fn build_laid(
    eng: &DeviceScene,
    ex: &mut Exec,
    rays: &DeviceRays,
    leaves: &wgpu::Buffer,
    kinds: &wgpu::Buffer,
    n: u64,
) -> (Vec<Level>, Laid) {
    let g = &eng.gpu;
    let b = eng.cfg.branching as u64;
    let caps = laid_caps(n, b, eng.cfg.levels);
    let levels = caps.len();
    let laid = Laid {
        block: g.indirect("hierarchy layout", 4 * (LAYOUT_WORDS * levels as u64 + 2)),
        levels,
    };
    ex.run(
        launch::LevelLayout {
            x_a: kinds,
            y_a: &laid.block,
        },
        LevelLayoutParams {
            b: b as u32,
            union_thesis: (eng.cfg.union == Union::Thesis) as u32,
            levels: eng.cfg.levels,
            max_levels: levels as u32,
            maxd: g.limits.max_compute_workgroups_per_dimension,
        },
        1,
        1,
    );
    let mut out: Vec<Level> = Vec::with_capacity(levels);
    for (l, &cap) in caps.iter().enumerate() {
        let lv = Level {
            sphere: g.storage("node spheres", cap * 16),
            cone: g.storage("node cones", cap * 16),
            sc: g.storage("node sc", cap * 16),
            first: g.storage("node first", (cap + 1) * 4),
            per_kind: [0; 4],
            children: [0; 4],
            sized: Some(DevSize {
                block: laid.block.clone(),
                at: 4 * LAYOUT_WORDS * l as u64,
                cap,
            }),
            cap: cap as u32,
        };
        let over = lv.sized.as_ref().unwrap();
        // The parameters come from the layout; the host's block is overwritten.
        let threads = Threads::Laid { over, words: 16 };
        let prm = LevelParams::default();
        launch_level(eng, ex, rays, leaves, out.last(), &lv, prm, threads);
        out.push(lv);
    }
    (out, laid)
}

/// One level's build launch: level 1 over the sorted leaves (`below` none), a level above
/// from the level `below`, with the level's parameters `prm` over `threads`.
#[allow(clippy::too_many_arguments)]
fn launch_level(
    eng: &DeviceScene,
    ex: &mut Exec,
    rays: &DeviceRays,
    leaves: &wgpu::Buffer,
    below: Option<&Level>,
    lv: &Level,
    prm: LevelParams,
    threads: Threads,
) {
    match below {
        None => ex.run_on(
            launch::BuildLeafLevel {
                b_leaf: leaves,
                b_org: &rays.org,
                b_dir: &rays.dir,
                b_shuffle: &eng.shuffles,
                o_sphere: &lv.sphere,
                o_cone: &lv.cone,
                o_sc: &lv.sc,
                o_first: &lv.first,
            },
            prm,
            threads,
            64,
        ),
        Some(c) => ex.run_on(
            launch::BuildUpperLevel {
                c_sphere: &c.sphere,
                c_cone: &c.cone,
                c_sc: &c.sc,
                o_sphere: &lv.sphere,
                o_cone: &lv.cone,
                o_sc: &lv.sc,
                o_first: &lv.first,
            },
            prm,
            threads,
            64,
        ),
    }
}

/// The nodes [`build_laid`] allocates per level for at most `n` leaves, branching `b` and
/// `levels` configured levels (0: until one root per kind): a level has at most one node
/// per child, and ⌈children / b⌉ + 3 (one partial node per kind); as many levels as the
/// rules could build (one root per kind: a kind of all `n` leaves needs ⌈log_b n⌉).
pub fn laid_caps(n: u64, b: u64, levels: u32) -> Vec<u64> {
    let count = if levels > 0 {
        levels as usize
    } else {
        let (mut l, mut c) = (1, n.div_ceil(b));
        while c > 1 {
            c = c.div_ceil(b);
            l += 1;
        }
        l
    };
    let mut below = n;
    (0..count)
        .map(|_| {
            below = below.min(below.div_ceil(b) + 3).max(1);
            below
        })
        .collect()
}
