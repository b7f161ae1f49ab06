//! CRSH's and RAH's configuration ([`RshConfig`], the methods' defaults) and its options,
//! each declared once beside it ([`OPTIONS`], [`trace::options::Spec`]): the thesis's
//! parameters (§3.2: branching factor B, levels D, hash, unions, node test, mesh culling,
//! §4's configurations) and the object side's (the dual traversal over the object tree,
//! §5.1's future work). The command line, the Python keywords and `rayspace engines` are
//! made from [`OPTIONS`]; [`RshConfig::validate`] checks a configuration against it.

use crate::dual::{Descent, Schedule};
use crate::hash::{HashBits, HashKind};
use crate::{NodeTest, Union};
use accel::bvh::ObjectBuilder;
use trace::options::{int, name_of, named, switch, Kind, OnGpu, Spec, Value};
use trace::OptionError;

/// Which paper's method.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// Reis 2015: hashed, compressed, sorted rays; mesh-sphere culling at the top.
    Crsh,
    /// Roger et al. 2007: rays in screen order; no culling at the top.
    Rah,
}

/// What the traversal pushes through the ray hierarchy.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ObjectHierarchy {
    /// The thesis (§3.2.8): every triangle, culled at the top by the per-mesh spheres when
    /// mesh culling is on.
    MeshSpheres,
    /// A BVH over the triangles, built per frame (`accel::bvh::objects`, the `bvh` engine's
    /// tree), descended together with the ray hierarchy ([`crate::dual`]: the thesis's
    /// future work, §5.1); the mesh spheres bound the meshes' subtrees when mesh culling is
    /// on.
    Bvh,
}

impl ObjectHierarchy {
    /// Every value by its name (as options spell it).
    pub const NAMES: [(&'static str, ObjectHierarchy); 2] = [
        ("mesh-spheres", ObjectHierarchy::MeshSpheres),
        ("bvh", ObjectHierarchy::Bvh),
    ];
}

/// Configuration of CRSH or RAH (the thesis's parameters and ours).
#[derive(Clone, Debug, PartialEq)]
pub struct RshConfig {
    /// Which paper's method.
    pub method: Method,
    /// Children per node (thesis: 8 or 16; RAH's pyramid: 4).
    pub branching: u32,
    /// Levels above the leaves (thesis: 2–4); 0 builds up to one root per ray kind.
    pub levels: u32,
    /// CRSH's hash (ignored by RAH).
    pub hash: HashKind,
    /// Bit budgets of the thesis hash.
    pub hash_bits: HashBits,
    /// Sphere and cone union formulas.
    pub union: Union,
    /// Node–triangle test.
    pub node_test: NodeTest,
    /// Test top nodes against per-mesh bounding spheres first.
    pub mesh_culling: bool,
    /// Most (node, triangle) pairs held in one buffer.
    pub pair_budget: usize,
    /// The object side of the traversal.
    pub objects: ObjectHierarchy,
    /// With [`ObjectHierarchy::Bvh`]: which node of a pair is expanded.
    pub descent: Descent,
    /// With [`ObjectHierarchy::Bvh`]: in which order the pairs are taken.
    pub schedule: Schedule,
    /// With [`ObjectHierarchy::Bvh`]: how the object tree is built.
    pub builder: ObjectBuilder,
}

/// Default pair budget: 2^24 pairs (128 MiB for the two u32 arrays of one buffer).
pub const DEFAULT_PAIR_BUDGET: usize = 1 << 24;

/// The traversal's memory model: bytes per pair of the budget (node and triangle ids, the
/// test's flag and its scan offset: 4 × u32) …
pub const BYTES_PER_PAIR: u64 = 16;

impl RshConfig {
    /// … and the most the traversal holds: one buffer per level of the depth-first descent
    /// plus the top level's candidates and the final tests' (`levels + 2` buffers of
    /// `pair_budget` pairs).
    pub fn pair_bytes(&self) -> u64 {
        self.pair_budget as u64 * BYTES_PER_PAIR * (self.levels as u64 + 2)
    }

    /// [`RshConfig::pair_bytes`] with a budget of `budget` pairs.
    pub fn pair_bytes_of(&self, budget: usize) -> u64 {
        budget as u64 * BYTES_PER_PAIR * (self.levels as u64 + 2)
    }

    /// The largest pair budget whose [`RshConfig::pair_bytes`] fit `bytes` (batching more,
    /// never dropping a pair), at most the configured one; `None` below the minimum 1024.
    pub fn budget_within(&self, bytes: u64) -> Option<usize> {
        let per = BYTES_PER_PAIR * (self.levels as u64 + 2);
        let fit = (bytes / per).min(self.pair_budget as u64) as usize;
        (fit >= 1024).then_some(fit)
    }
}

impl RshConfig {
    /// CRSH's defaults: B = 8, D = 2, thesis hash, exact unions, RAH node test, mesh culling,
    /// the dual traversal over the SAH object tree, depth first.
    pub fn crsh() -> Self {
        RshConfig {
            method: Method::Crsh,
            branching: 8,
            levels: 2,
            hash: HashKind::Thesis,
            hash_bits: HashBits::default(),
            union: Union::Exact,
            node_test: NodeTest::Rah,
            mesh_culling: true,
            pair_budget: DEFAULT_PAIR_BUDGET,
            objects: ObjectHierarchy::Bvh,
            descent: Descent::Size,
            schedule: Schedule::Depth,
            builder: ObjectBuilder::Sah,
        }
    }

    /// RAH's defaults: CRSH's without mesh culling (the leaf order is RAH's screen order).
    pub fn rah() -> Self {
        RshConfig {
            method: Method::Rah,
            mesh_culling: false,
            ..Self::crsh()
        }
    }

    /// The one check of a configuration (the CLI, the bindings, the benchmarks, the CPU and
    /// GPU engines all call it): every option against its declaration
    /// ([`crate::options::OPTIONS`]), and the hash's bit budgets.
    pub fn validate(&self) -> Result<(), OptionError> {
        trace::options::check_all(OPTIONS, self)?;
        self.hash_bits
            .validate()
            .map_err(|e| OptionError::new("hash_bits", self.hash_bits, e.to_string()))
    }
}

/// `object_builder`'s kind and doc, shared with the `bvh` engine's (one tree, one builder).
const BUILDER: &Spec<accel::BvhConfig> = &accel::bvh::OPTIONS[0];

/// Every option of CRSH and RAH.
pub const OPTIONS: &[Spec<RshConfig>] = &[
    Spec {
        name: "branching",
        kind: Kind::Int { min: 2, max: 64 },
        doc: "children per ray-hierarchy node, B (thesis: 8 or 16)",
        engines: None,
        requires: None,
        gpu: OnGpu::Any,
        get: |c| Value::Int(c.branching as i64),
        set: |c, v| {
            c.branching = int(v) as u32;
            Ok(())
        },
    },
    Spec {
        name: "levels",
        kind: Kind::Int { min: 0, max: 16 },
        doc: "levels above the rays, D (0: up to one root per ray kind)",
        engines: None,
        requires: None,
        gpu: OnGpu::Any,
        get: |c| Value::Int(c.levels as i64),
        set: |c, v| {
            c.levels = int(v) as u32;
            Ok(())
        },
    },
    Spec {
        name: "hash",
        kind: Kind::Choice(&[
            ("thesis", "the thesis's typed 32-bit hash (§3.2.3)"),
            (
                "morton64",
                "a 64-bit 5-D Morton code of origin and direction",
            ),
        ]),
        doc: "the key the rays are sorted by",
        engines: Some(&["crsh"]),
        requires: None,
        gpu: OnGpu::Only("thesis"),
        get: |c| Value::Str(name_of(&HashKind::NAMES, c.hash).into()),
        set: |c, v| {
            c.hash = named(&HashKind::NAMES, v)?;
            Ok(())
        },
    },
    Spec {
        name: "hash_bits",
        kind: Kind::Text("L,S,O,D"),
        doc: "thesis hash bits: light, shadow angle, origin axis, angle",
        engines: Some(&["crsh"]),
        requires: None,
        gpu: OnGpu::Any,
        get: |c| Value::Str(c.hash_bits.to_string()),
        set: |c, v| {
            let Value::Str(s) = v else {
                return Err("expected a string".into());
            };
            let b: HashBits = s.parse().map_err(|e: crate::HashBitsError| e.to_string())?;
            b.validate().map_err(|e| e.to_string())?;
            c.hash_bits = b;
            Ok(())
        },
    },
    Spec {
        name: "union",
        kind: Kind::Choice(&[
            ("exact", "minimal enclosing balls and exact cone unions"),
            ("thesis", "the thesis's eqs. 3.12-3.15"),
        ]),
        doc: "sphere and cone union formulas of the nodes (§3.2.7)",
        engines: None,
        requires: None,
        gpu: OnGpu::Any,
        get: |c| Value::Str(name_of(&Union::NAMES, c.union).into()),
        set: |c, v| {
            c.union = named(&Union::NAMES, v)?;
            Ok(())
        },
    },
    Spec {
        name: "node_test",
        kind: Kind::Choice(&[
            ("rah", "Roger et al.'s test (thesis eq. 3.16)"),
            ("exact", "the exact distance of a sphere to the node's cone"),
        ]),
        doc: "conservative test of a node against a triangle or node",
        engines: None,
        requires: None,
        gpu: OnGpu::Any,
        get: |c| Value::Str(name_of(&NodeTest::NAMES, c.node_test).into()),
        set: |c, v| {
            c.node_test = named(&NodeTest::NAMES, v)?;
            Ok(())
        },
    },
    Spec {
        name: "mesh_culling",
        kind: Kind::Switch,
        doc: "cull by the per-mesh bounding spheres (§3.2.2)",
        engines: None,
        requires: None,
        gpu: OnGpu::Any,
        get: |c| Value::Bool(c.mesh_culling),
        set: |c, v| {
            c.mesh_culling = switch(v);
            Ok(())
        },
    },
    Spec {
        name: "pair_budget",
        kind: Kind::Int {
            min: 1024,
            max: 1 << 31,
        },
        doc: "most (node, triangle) pairs per buffer (more: in batches)",
        engines: None,
        requires: None,
        gpu: OnGpu::Any,
        get: |c| Value::Int(c.pair_budget as i64),
        set: |c, v| {
            c.pair_budget = int(v) as usize;
            Ok(())
        },
    },
    Spec {
        name: "object_hierarchy",
        kind: Kind::Choice(&[
            (
                "bvh",
                "the object tree, descended with the ray hierarchy (the dual traversal)",
            ),
            (
                "mesh-spheres",
                "every triangle behind the per-mesh spheres (the thesis)",
            ),
        ]),
        doc: "what the ray hierarchy is traversed against",
        engines: None,
        requires: None,
        gpu: OnGpu::Any,
        get: |c| Value::Str(name_of(&ObjectHierarchy::NAMES, c.objects).into()),
        set: |c, v| {
            c.objects = named(&ObjectHierarchy::NAMES, v)?;
            Ok(())
        },
    },
    Spec {
        name: "descent",
        kind: Kind::Choice(&[
            ("size", "the larger node of the pair"),
            (
                "object-first",
                "the object node until it is a triangle, then the ray node",
            ),
            (
                "ray-first",
                "the ray node until single rays, then the object node",
            ),
        ]),
        doc: "which node of a surviving (ray, object) pair is expanded",
        engines: None,
        requires: Some(("object_hierarchy", "bvh")),
        gpu: OnGpu::Any,
        get: |c| Value::Str(name_of(&Descent::NAMES, c.descent).into()),
        set: |c, v| {
            c.descent = named(&Descent::NAMES, v)?;
            Ok(())
        },
    },
    Spec {
        name: "schedule",
        kind: Kind::Choice(&[
            (
                "depth",
                "each top ray node's pairs depth first, in parallel",
            ),
            (
                "breadth",
                "level by level in data-parallel steps (the GPU's shape)",
            ),
        ]),
        doc: "in which order the dual traversal takes its pairs",
        engines: None,
        requires: Some(("object_hierarchy", "bvh")),
        gpu: OnGpu::Only("breadth"),
        get: |c| Value::Str(name_of(&Schedule::NAMES, c.schedule).into()),
        set: |c, v| {
            c.schedule = named(&Schedule::NAMES, v)?;
            Ok(())
        },
    },
    Spec {
        name: BUILDER.name,
        kind: BUILDER.kind,
        doc: BUILDER.doc,
        engines: None,
        requires: Some(("object_hierarchy", "bvh")),
        gpu: BUILDER.gpu,
        get: |c| Value::Str(name_of(&ObjectBuilder::NAMES, c.builder).into()),
        set: |c, v| {
            c.builder = named(&ObjectBuilder::NAMES, v)?;
            Ok(())
        },
    },
];
