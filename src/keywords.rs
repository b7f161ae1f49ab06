//! Engine options by keyword, without a command-line parser: what the Python bindings'
//! `Engine(scene, name, **options)` builds engines from. Each keyword is the option's name
//! in [`EngineOptions`] terms (`levels`, `object_hierarchy`, `grid_top_density`); the
//! command line spells the same options `--levels`, `--object-hierarchy`,
//! `--grid-top-density` (`src/options.rs`), and a test holds the two lists equal.

use crate::engines::EngineOptions;
use accel::grid::{GridConfig, MergeRule, Subdivision};
use rsh::{
    Descent, HashBits, HashKind, NodeTest, ObjectBuilder, ObjectHierarchy, RayPath, RshConfig,
    Schedule, Union,
};
use trace::{by_name, OptionError};

/// A keyword's value, as a dynamic language passes it.
#[derive(Clone, Debug, PartialEq)]
pub enum Value {
    /// `True`/`False`.
    Bool(bool),
    /// An integer.
    Int(i64),
    /// A float.
    Float(f64),
    /// A string (enum names, hash bit budgets).
    Str(String),
}

impl std::fmt::Display for Value {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Value::Bool(b) => write!(f, "{}", if *b { "True" } else { "False" }),
            Value::Int(i) => write!(f, "{i}"),
            Value::Float(x) => write!(f, "{x}"),
            Value::Str(s) => write!(f, "'{s}'"),
        }
    }
}

/// Why keyword options were refused.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum KeywordError {
    /// No engine option has this name.
    #[error("unknown engine option '{key}' (options: {})", KEYWORDS.join(", "))]
    Unknown {
        /// The keyword given.
        key: String,
    },
    /// The value is of the wrong kind (a string for a number, say).
    #[error("`{key}`={value}: expected {expected}")]
    Type {
        /// The keyword.
        key: &'static str,
        /// The value given.
        value: String,
        /// What the option takes.
        expected: &'static str,
    },
    /// The value is of the right kind but not accepted.
    #[error(transparent)]
    Value(#[from] OptionError),
}

/// Every engine option's keyword: CRSH/RAH's, then the grid's.
pub const KEYWORDS: [&str; 21] = [
    "branching",
    "levels",
    "hash",
    "hash_bits",
    "union",
    "node_test",
    "mesh_culling",
    "pair_budget",
    "object_hierarchy",
    "descent",
    "schedule",
    "ray_path",
    "object_builder",
    "grid_top_density",
    "grid_leaf_density",
    "grid_alpha",
    "grid_merge",
    "grid_merge_rule",
    "grid_expansion",
    "grid_max_depth",
    "grid_subdivision",
];

/// The keywords of [`KEYWORDS`] that shape the ray hierarchy itself (its nodes, hash, tests,
/// budget and culling, and the bundles' traversal): single rays through the object tree
/// read none of them.
pub const RAY_HIERARCHY: [&str; 10] = [
    "branching",
    "levels",
    "hash",
    "hash_bits",
    "union",
    "node_test",
    "mesh_culling",
    "pair_budget",
    "descent",
    "schedule",
];

/// The engine options with the given keywords and every other option at its default, as
/// the command line's defaults are (`dynamic`: a frame of an animation, whose grid expands
/// once unless `grid_expansion` says otherwise). Values are checked for their kind here and
/// for their range by [`EngineOptions::validate`].
pub fn engine_options(
    keywords: &[(String, Value)],
    dynamic: bool,
) -> Result<EngineOptions, KeywordError> {
    let grid = GridConfig::default();
    let mut o = EngineOptions {
        rsh: RshConfig::crsh(),
        mesh_culling: None,
        objects: None,
        path: None,
        grid: GridConfig {
            expansion_passes: if dynamic { 1 } else { grid.expansion_passes },
            ..grid
        },
    };
    for (k, v) in keywords {
        let key = KEYWORDS
            .iter()
            .copied()
            .find(|n| n == k)
            .ok_or_else(|| KeywordError::Unknown { key: k.clone() })?;
        set(&mut o, key, v)?;
    }
    Ok(o)
}

fn set(o: &mut EngineOptions, key: &'static str, v: &Value) -> Result<(), KeywordError> {
    let wrong = |expected| KeywordError::Type {
        key,
        value: v.to_string(),
        expected,
    };
    let uint = || match v {
        Value::Int(i) if *i >= 0 => Ok(*i as u64),
        Value::Int(i) => Err(KeywordError::Value(OptionError::new(
            key,
            i,
            "must not be negative",
        ))),
        _ => Err(wrong("an integer")),
    };
    let u32_ = || -> Result<u32, KeywordError> {
        let n = uint()?;
        u32::try_from(n).map_err(|_| OptionError::new(key, n, "too large").into())
    };
    let float = || match v {
        Value::Float(x) => Ok(*x as f32),
        Value::Int(i) => Ok(*i as f32),
        _ => Err(wrong("a number")),
    };
    let boolean = || match v {
        Value::Bool(b) => Ok(*b),
        Value::Str(s) if s == "on" => Ok(true),
        Value::Str(s) if s == "off" => Ok(false),
        _ => Err(wrong("True or False")),
    };
    fn named<T: Copy>(
        key: &'static str,
        v: &Value,
        names: &[(&'static str, T)],
    ) -> Result<T, KeywordError> {
        match v {
            Value::Str(s) => by_name(s, key, names)
                .map_err(|e| OptionError::new(key, format!("{s:?}"), e.to_string()).into()),
            _ => Err(KeywordError::Type {
                key,
                value: v.to_string(),
                expected: "a name",
            }),
        }
    }
    match key {
        "branching" => o.rsh.branching = u32_()?,
        "levels" => o.rsh.levels = u32_()?,
        "hash" => o.rsh.hash = named(key, v, &HashKind::NAMES)?,
        "hash_bits" => {
            let Value::Str(s) = v else {
                return Err(wrong("a string LIGHT,SHADOW_DIR,ORIGIN,DIR"));
            };
            o.rsh.hash_bits = s
                .parse::<HashBits>()
                .map_err(|e| OptionError::new(key, format!("{s:?}"), e.to_string()))?;
        }
        "union" => o.rsh.union = named(key, v, &Union::NAMES)?,
        "node_test" => o.rsh.node_test = named(key, v, &NodeTest::NAMES)?,
        "mesh_culling" => o.mesh_culling = Some(boolean()?),
        "pair_budget" => {
            let n = uint()?;
            o.rsh.pair_budget = usize::try_from(n).unwrap_or(usize::MAX);
        }
        "object_hierarchy" => o.objects = Some(named(key, v, &ObjectHierarchy::NAMES)?),
        "descent" => o.rsh.descent = named(key, v, &Descent::NAMES)?,
        "schedule" => o.rsh.schedule = named(key, v, &Schedule::NAMES)?,
        "ray_path" => o.path = Some(named(key, v, &RayPath::NAMES)?),
        "object_builder" => o.rsh.builder = named(key, v, &ObjectBuilder::NAMES)?,
        "grid_top_density" => o.grid.top_density = float()?,
        "grid_leaf_density" => o.grid.leaf_density = float()?,
        "grid_alpha" => o.grid.alpha = float()?,
        "grid_merge" => o.grid.merge = boolean()?,
        "grid_merge_rule" => o.grid.merge_rule = named(key, v, &MergeRule::NAMES)?,
        "grid_expansion" => o.grid.expansion_passes = u32_()?,
        "grid_max_depth" => o.grid.max_depth = u32_()?,
        "grid_subdivision" => o.grid.subdivision = named(key, v, &Subdivision::NAMES)?,
        _ => unreachable!("every keyword of KEYWORDS is set"),
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ray_hierarchy_keywords_are_keywords() {
        for k in RAY_HIERARCHY {
            assert!(KEYWORDS.contains(&k), "{k}");
        }
    }

    #[test]
    fn keywords_set_what_the_command_line_sets() {
        let kw = |k: &str, v: Value| vec![(k.to_string(), v)];
        let o = engine_options(&kw("levels", Value::Int(3)), false).unwrap();
        assert_eq!(o.rsh.levels, 3);
        let o = engine_options(
            &kw("object_hierarchy", Value::Str("mesh-spheres".into())),
            true,
        )
        .unwrap();
        assert_eq!(o.objects, Some(ObjectHierarchy::MeshSpheres));
        assert_eq!(
            o.grid.expansion_passes, 1,
            "a frame of an animation expands once"
        );
        let e = engine_options(&kw("bogus", Value::Int(3)), false).unwrap_err();
        assert!(matches!(e, KeywordError::Unknown { .. }), "{e}");
        let e = engine_options(&kw("levels", Value::Int(-3)), false).unwrap_err();
        assert_eq!(e.to_string(), "`levels`=-3: must not be negative");
        let e = engine_options(&kw("levels", Value::Str("x".into())), false).unwrap_err();
        assert!(matches!(e, KeywordError::Type { .. }), "{e}");
        let e = engine_options(&kw("schedule", Value::Str("wide".into())), false).unwrap_err();
        assert!(e.to_string().contains("\"depth\""), "{e}");
    }

    #[cfg(feature = "cli")]
    #[test]
    fn every_keyword_is_a_command_line_option_and_back() {
        use clap::CommandFactory;
        let cmd = crate::options::EngineArgs::command();
        let mut flags: Vec<String> = cmd
            .get_arguments()
            .filter_map(|a| a.get_long())
            .filter(|l| *l != "engine")
            .map(|l| l.replace('-', "_"))
            .collect();
        flags.sort();
        let mut kws: Vec<String> = KEYWORDS.iter().map(|k| k.to_string()).collect();
        kws.sort();
        assert_eq!(flags, kws);
        // And the defaults are the command line's.
        for dynamic in [false, true] {
            let cli = crate::options::engine_options(
                &crate::options::defaults(),
                &crate::options::defaults(),
                dynamic,
            );
            let kw = engine_options(&[], dynamic).unwrap();
            assert_eq!(format!("{cli:?}"), format!("{kw:?}"));
        }
    }
}
