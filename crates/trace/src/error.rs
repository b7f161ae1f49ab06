//! The one error every configuration shares: an option whose value is out of its range.
//!
//! Options are named as the library's callers name them: the keyword a Python caller passes
//! (`levels`, `grid_top_density`, `object_hierarchy`). In a message an option's name is
//! written between backticks (`` `levels`=99: at most 16 levels ``), so that each front end
//! spells it its own way: the command line as `--levels`, the Python bindings as
//! `levels=99`. A library message never names a flag.

/// An option's value is not accepted.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("`{name}`={value}: {reason}")]
pub struct OptionError {
    /// The option, as a keyword (`branching`, `grid_alpha`).
    pub name: &'static str,
    /// The value given, as it was written or printed.
    pub value: String,
    /// Why it is refused ("the branching factor must be in 2..=64").
    pub reason: String,
}

impl OptionError {
    /// `name` with `value` is refused for `reason`.
    pub fn new(name: &'static str, value: impl ToString, reason: impl Into<String>) -> Self {
        OptionError {
            name,
            value: value.to_string(),
            reason: reason.into(),
        }
    }
}

/// A name that is not one of the values an option takes.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{what} {given:?} is not one of {names:?}")]
pub struct NameError {
    /// What was named ("merge rule").
    pub what: &'static str,
    /// The name given.
    pub given: String,
    /// The names accepted.
    pub names: Vec<&'static str>,
}

/// The value `given` names in `names`, or the [`NameError`] listing them (`what`: what the
/// names are of).
pub fn by_name<T: Copy>(
    given: &str,
    what: &'static str,
    names: &[(&'static str, T)],
) -> Result<T, NameError> {
    names
        .iter()
        .find(|(n, _)| *n == given)
        .map(|&(_, v)| v)
        .ok_or_else(|| NameError {
            what,
            given: given.to_string(),
            names: names.iter().map(|(n, _)| *n).collect(),
        })
}
