//! How an engine declares its options, once: a [`Spec`] per option (name, kind and range,
//! one-line doc, the engines and backends it applies to, and how it reads and writes the
//! engine's configuration). The command line's flags and their help, the Python keywords,
//! the checks of what applies where, `rayspace engines` and the `--stats` JSON's
//! `engine_config` are all made from these declarations (the registry in the root crate
//! collects every engine's), so adding an option touches its engine and its spec only.
//!
//! An option's name is its keyword (`pair_budget`, `grid_top_density`): the Python keyword
//! as written, and the command line's flag with `-` for `_` (`--pair-budget`).

use crate::OptionError;
use serde::{Serialize, Serializer};

/// An option's value, as a front end passes it (a parsed flag, a Python keyword).
#[derive(Clone, Debug, PartialEq)]
pub enum Value {
    /// `on`/`off`, `True`/`False`.
    Bool(bool),
    /// An integer.
    Int(i64),
    /// A number.
    Float(f64),
    /// A name (one of a choice's) or text in the option's own format.
    Str(String),
}

impl std::fmt::Display for Value {
    /// As the command line spells it (`on`, `8`, `0.12`, `sah`).
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Value::Bool(b) => f.write_str(if *b { "on" } else { "off" }),
            Value::Int(i) => write!(f, "{i}"),
            Value::Float(x) => write!(f, "{x}"),
            Value::Str(s) => f.write_str(s),
        }
    }
}

/// In JSON: a boolean, a number or a string.
impl Serialize for Value {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            Value::Bool(b) => s.serialize_bool(*b),
            Value::Int(i) => s.serialize_i64(*i),
            Value::Float(x) => s.serialize_f64(*x),
            Value::Str(t) => s.serialize_str(t),
        }
    }
}

/// What an option takes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Kind {
    /// An integer in `min..=max`.
    Int {
        /// The smallest value.
        min: i64,
        /// The largest value.
        max: i64,
    },
    /// A finite number in `min..=max` (above `min` where `above_min`).
    Float {
        /// The smallest value, or the bound the values lie above.
        min: f64,
        /// The values lie above `min`, not at it.
        above_min: bool,
        /// The largest value.
        max: f64,
    },
    /// `on` or `off`.
    Switch,
    /// One of these names, each with a one-line description.
    Choice(&'static [(&'static str, &'static str)]),
    /// Text in the option's own format, described by this placeholder (`L,S,O,D`); the
    /// option's setter parses it.
    Text(&'static str),
}

impl Kind {
    /// A value of this kind from the command line's text.
    pub fn parse(&self, s: &str) -> Result<Value, String> {
        let s = s.trim();
        match self {
            Kind::Int { .. } => s
                .parse::<i64>()
                .map(Value::Int)
                .map_err(|_| format!("'{s}' is not an integer")),
            Kind::Float { .. } => s
                .parse::<f64>()
                .map(Value::Float)
                .map_err(|_| format!("'{s}' is not a number")),
            Kind::Switch => match s {
                "on" => Ok(Value::Bool(true)),
                "off" => Ok(Value::Bool(false)),
                _ => Err(format!("'{s}' is not on or off")),
            },
            Kind::Choice(_) | Kind::Text(_) => Ok(Value::Str(s.to_string())),
        }
    }

    /// `v` checked against this kind for option `name` and brought to its form (an integer
    /// given for a number becomes a number; `on`/`off` given as names become switches).
    pub fn check(&self, name: &'static str, v: &Value) -> Result<Value, OptionError> {
        // A string given where it is not wanted is quoted (`levels`="many").
        let shown = match v {
            Value::Str(s) => format!("{s:?}"),
            _ => v.to_string(),
        };
        let wrong = |what: &str| OptionError::new(name, &shown, format!("expected {what}"));
        match (self, v) {
            (Kind::Int { min, max }, Value::Int(i)) => {
                if (*min..=*max).contains(i) {
                    Ok(Value::Int(*i))
                } else {
                    Err(OptionError::new(
                        name,
                        i,
                        format!("must be in {}", self.range()),
                    ))
                }
            }
            (Kind::Int { .. }, _) => Err(wrong("an integer")),
            (
                Kind::Float {
                    min,
                    above_min,
                    max,
                },
                Value::Int(_) | Value::Float(_),
            ) => {
                let x = float(v);
                if x.is_finite() && (*min..=*max).contains(&x) && !(*above_min && x == *min) {
                    Ok(Value::Float(x))
                } else {
                    Err(OptionError::new(
                        name,
                        x,
                        format!("must be in {}", self.range()),
                    ))
                }
            }
            (Kind::Float { .. }, _) => Err(wrong("a number")),
            (Kind::Switch, Value::Bool(b)) => Ok(Value::Bool(*b)),
            (Kind::Switch, Value::Str(s)) if s == "on" || s == "off" => Ok(Value::Bool(s == "on")),
            (Kind::Switch, _) => Err(wrong("on or off (True or False)")),
            (Kind::Choice(names), Value::Str(s)) => {
                if names.iter().any(|(n, _)| n == s) {
                    Ok(v.clone())
                } else {
                    Err(OptionError::new(
                        name,
                        format!("{s:?}"),
                        format!("not one of {}", self.range()),
                    ))
                }
            }
            (Kind::Choice(_), _) => Err(wrong(&format!("one of {}", self.range()))),
            (Kind::Text(_), Value::Str(_)) => Ok(v.clone()),
            (Kind::Text(p), _) => Err(wrong(&format!("a string {p}"))),
        }
    }

    /// The values this kind takes, for help and messages (`2..=64`, `sah|lbvh`, `on|off`).
    pub fn range(&self) -> String {
        match self {
            Kind::Int { min, max } => format!("{}..={}", power(*min), power(*max)),
            Kind::Float {
                min,
                above_min: true,
                max,
            } => format!("({min}, {max}]"),
            Kind::Float { min, max, .. } => format!("{min}..={max}"),
            Kind::Switch => "on|off".into(),
            Kind::Choice(names) => names.iter().map(|(n, _)| *n).collect::<Vec<_>>().join("|"),
            Kind::Text(p) => (*p).into(),
        }
    }
}

/// `n` as a power of two where it is one of at least 2^16 (`2^31`), else as it is.
fn power(n: i64) -> String {
    if n >= 1 << 16 && (n as u64).is_power_of_two() {
        format!("2^{}", n.trailing_zeros())
    } else {
        n.to_string()
    }
}

/// Whether the GPU backend takes an option.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OnGpu {
    /// With any value.
    Any,
    /// With this value only, which is its default there.
    Only(&'static str),
}

/// One option of an engine whose configuration is `C`.
pub struct Spec<C: 'static> {
    /// The keyword (`pair_budget`); the command line's flag is it with `-` for `_`.
    pub name: &'static str,
    /// What it takes.
    pub kind: Kind,
    /// One line: what it does.
    pub doc: &'static str,
    /// The engines of this configuration's family that take it (`None`: all of them).
    pub engines: Option<&'static [&'static str]>,
    /// Another option of the family that must have this value for this one to matter
    /// (`("object_hierarchy", "bvh")`).
    pub requires: Option<(&'static str, &'static str)>,
    /// On the GPU backend.
    pub gpu: OnGpu,
    /// The option's value in a configuration.
    pub get: fn(&C) -> Value,
    /// Set it (the value already checked against [`Spec::kind`]); the reason when the value
    /// is refused all the same (text that does not parse).
    pub set: fn(&mut C, &Value) -> Result<(), String>,
}

impl<C> Spec<C> {
    /// Whether engine `engine` (of this family) takes the option.
    pub fn applies_to(&self, engine: &str) -> bool {
        self.engines.is_none_or(|e| e.contains(&engine))
    }

    /// Check `v` and set it in `c`.
    pub fn apply(&self, c: &mut C, v: &Value) -> Result<(), OptionError> {
        let v = self.kind.check(self.name, v)?;
        (self.set)(c, &v).map_err(|why| OptionError::new(self.name, &v, why))
    }
}

/// Check every option of `specs` in `c` against its kind (ranges and names): the one check
/// of a configuration made in code rather than through [`Spec::apply`].
pub fn check_all<C>(specs: &[Spec<C>], c: &C) -> Result<(), OptionError> {
    for s in specs {
        s.kind.check(s.name, &(s.get)(c))?;
    }
    Ok(())
}

/// The name of `v` in `names` (an option enum's `NAMES`).
pub fn name_of<T: Copy + PartialEq>(names: &[(&'static str, T)], v: T) -> &'static str {
    names
        .iter()
        .find(|(_, x)| *x == v)
        .map(|(n, _)| *n)
        .expect("every value is named")
}

/// The value of enum option `names` that `v` names (already checked against its choice).
pub fn named<T: Copy>(names: &[(&'static str, T)], v: &Value) -> Result<T, String> {
    match v {
        Value::Str(s) => names
            .iter()
            .find(|(n, _)| n == s)
            .map(|&(_, x)| x)
            .ok_or_else(|| {
                format!(
                    "not one of {:?}",
                    names.iter().map(|(n, _)| *n).collect::<Vec<_>>()
                )
            }),
        _ => Err("expected a name".into()),
    }
}

/// An integer option's value (already checked against its range).
pub fn int(v: &Value) -> i64 {
    match v {
        Value::Int(i) => *i,
        Value::Float(x) => *x as i64,
        Value::Bool(b) => *b as i64,
        Value::Str(_) => 0,
    }
}

/// A number option's value (already checked against its range).
pub fn float(v: &Value) -> f64 {
    match v {
        Value::Int(i) => *i as f64,
        Value::Float(x) => *x,
        Value::Bool(b) => *b as i64 as f64,
        Value::Str(_) => f64::NAN,
    }
}

/// An `f32` option's value as the number it was written as (0.12, not the nearest f64 to
/// the f32 nearest 0.12), so that reports and help print what a user would type.
pub fn single(x: f32) -> Value {
    Value::Float(x.to_string().parse().unwrap_or(x as f64))
}

/// A switch's value.
pub fn switch(v: &Value) -> bool {
    matches!(v, Value::Bool(true))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kinds_parse_check_and_describe() {
        let k = Kind::Int { min: 2, max: 64 };
        assert_eq!(k.parse("8"), Ok(Value::Int(8)));
        assert!(k.parse("x").is_err());
        assert_eq!(
            k.check("branching", &Value::Int(99))
                .unwrap_err()
                .to_string(),
            "`branching`=99: must be in 2..=64"
        );
        let f = Kind::Float {
            min: 0.0,
            above_min: true,
            max: 1.0,
        };
        assert_eq!(f.check("a", &Value::Int(1)), Ok(Value::Float(1.0)));
        assert!(f.check("a", &Value::Float(f64::NAN)).is_err());
        assert!(f.check("a", &Value::Float(0.0)).is_err());
        assert_eq!(f.range(), "(0, 1]");
        assert_eq!(
            Kind::Switch.check("s", &Value::Str("on".into())),
            Ok(Value::Bool(true))
        );
        let c = Kind::Choice(&[("sah", "binned SAH"), ("lbvh", "Morton codes")]);
        assert_eq!(c.range(), "sah|lbvh");
        assert!(c.check("b", &Value::Str("x".into())).is_err());
        assert!(c.check("b", &Value::Int(1)).is_err());
        assert_eq!(Value::Bool(false).to_string(), "off");
        assert_eq!(serde_json::to_string(&Value::Float(0.5)).unwrap(), "0.5");
    }
}
