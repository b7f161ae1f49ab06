//! CRSH's and RAH's options, each declared once ([`trace::options::Spec`]): the thesis's
//! parameters (§3.2: branching factor B, levels D, hash, unions, node test, mesh culling,
//! §4's configurations) and the object side's (the dual traversal over the object tree,
//! §5.1's future work). The command line, the Python keywords and `rayspace engines` are
//! made from [`OPTIONS`]; [`RshConfig::validate`] checks a configuration against it.

use crate::dual::{Descent, Schedule};
use crate::engine::{ObjectHierarchy, RshConfig};
use crate::hash::{HashBits, HashKind};
use crate::{NodeTest, Union};
use accel::bvh::ObjectBuilder;
use trace::options::{int, name_of, named, switch, Kind, OnGpu, Spec, Value};

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
