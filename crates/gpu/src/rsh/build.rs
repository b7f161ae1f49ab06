//! The hierarchy's construction on the GPU, the twin of `crates/rsh/src/build.rs`: level 1
//! over the sorted leaves, then unions level by level (thesis §3.2.7; `build.wgsl`), with
//! the CPU's stop rules; the leaves per kind come from the ordering (`kinds.wgsl`, read back
//! with the trim's count).

use super::device_scene::DeviceScene;
use crate::kernels::params::LevelParams;
use crate::kernels::{launch, Exec};
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
}

impl Level {
    /// Nodes in the level.
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
    let (org, dir) = (&rays.org, &rays.dir);
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
        if levels.is_empty() {
            let l = launch::BuildLeafLevel {
                b_leaf: leaves,
                b_org: org,
                b_dir: dir,
                b_shuffle: &eng.shuffles,
                o_sphere: &lv.sphere,
                o_cone: &lv.cone,
                o_sc: &lv.sc,
                o_first: &lv.first,
            };
            ex.run(l, prm, total as u64, 64);
        } else {
            let c = levels.last().unwrap();
            let l = launch::BuildUpperLevel {
                c_sphere: &c.sphere,
                c_cone: &c.cone,
                c_sc: &c.sc,
                o_sphere: &lv.sphere,
                o_cone: &lv.cone,
                o_sc: &lv.sc,
                o_first: &lv.first,
            };
            ex.run(l, prm, total as u64, 64);
        }
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
