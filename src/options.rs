//! The options that build an engine and load a scene, as the command line spells them:
//! the engines' options as flags made from their declarations ([`EngineFlags`]; the Python
//! bindings take the same declarations as keywords), how scenes load (`--meshes`, ...) and
//! how a render looks (`--fill`, `--exposure`).

use crate::engines::config::options;
use crate::engines::{Engine, EngineOptions};
use clap::builder::TypedValueParser as _;
use clap::Args;
use scene::MeshSplit;
use trace::options::{Kind, Value};

/// A command's options with every default, as if given no arguments.
pub fn defaults<T: Args + clap::FromArgMatches>() -> T {
    let m = T::augment_args(clap::Command::new("defaults"))
        .try_get_matches_from(["defaults"])
        .expect("every option has a default");
    T::from_arg_matches(&m).expect("defaults parse")
}

/// `on`/`off` as a boolean.
pub fn on_off() -> impl clap::builder::TypedValueParser<Value = bool> {
    clap::builder::PossibleValuesParser::new(["on", "off"]).map(|s| s == "on")
}

/// How a scene file is loaded.
#[derive(Args, Clone, Debug)]
pub struct LoadArgs {
    /// How an OBJ is cut into meshes, the unit of sphere culling
    #[arg(long, value_enum, value_name = "groups|materials|single", hide_possible_values = true, default_value_t = MeshSplit::Groups)]
    pub meshes: MeshSplit,
    /// Read referenced files outside the scene's and the scenes' folders
    #[arg(long = "allow-outside-paths")]
    pub allow_outside_paths: bool,
}

impl LoadArgs {
    /// The loader's options, with a triangle budget from the memory limit (`--max-memory`
    /// in MiB where the command has it): a scene whose model alone would exceed it stops
    /// while it loads.
    pub fn options(&self, max_mib: Option<u64>) -> scene::LoadOptions {
        self.within(::trace::memory::limit(max_mib), 0)
    }

    /// The loader's options for a process that may take `bytes` more, each triangle costing
    /// the scene's memory and `extra` more (the engine built over it): a scene too large for
    /// the work stops while it loads, and no file larger than `bytes` is read.
    pub fn within(&self, bytes: u64, extra: u64) -> scene::LoadOptions {
        scene::LoadOptions {
            split: self.meshes,
            allow_outside_paths: self.allow_outside_paths,
            ..Default::default()
        }
        .for_process(bytes, extra)
    }
}

/// How a rendered scene is lit and exposed (`render`, `view`).
#[derive(Args, Clone, Debug, Default)]
pub struct LookArgs {
    /// Grey ambient fill [default: on where the lights are automatic]
    #[arg(long, value_name = "on|off", value_parser = on_off(), hide_possible_values = true, help_heading = "Look")]
    pub fill: Option<bool>,
    /// Exposure in stops, -16..=16: every light and emission times 2^EV [default: 0; the
    /// named scenes' own]
    #[arg(long, allow_negative_numbers = true, value_name = "EV", value_parser = exposure(), help_heading = "Look")]
    pub exposure: Option<f32>,
}

/// `--exposure`: a finite number of stops in -16..=16.
fn exposure() -> impl clap::builder::TypedValueParser<Value = f32> {
    clap::builder::StringValueParser::new().try_map(|s: String| match s.parse::<f32>() {
        Ok(v) if v.is_finite() && (-16.0..=16.0).contains(&v) => Ok(v),
        _ => Err(format!("'{s}' is not a number of stops in -16..=16")),
    })
}

impl LookArgs {
    /// `o` with the fill and exposure asked for, for viewing scene `spec`: a named shared
    /// scene takes its own look ([`scene::named_look`]) where none is asked for.
    pub fn apply(&self, spec: &str, o: scene::LoadOptions) -> scene::LoadOptions {
        let named = scene::named_look(spec);
        scene::LoadOptions {
            fill: self.fill.or(named.map(|n| n.0)),
            exposure: self.exposure.or(named.map(|n| n.1)).unwrap_or(0.0),
            ..o
        }
    }
}

/// The engine options a command takes, as flags made from the engines' declarations
/// ([`crate::engines::config::options`]): one `--NAME` per option (its keyword with `-` for
/// `_`), its values and one-line help with its true default, grouped under the engines
/// that take it. Only the options given on the command line are kept (a default is the
/// engine's, not the flag's), in the order given; [`crate::engines::config::config`] checks
/// them against the engine and backend.
#[derive(Clone, Debug, Default)]
pub struct EngineFlags {
    /// (keyword, value) of every engine option given.
    pub given: Vec<(String, Value)>,
}

impl EngineFlags {
    /// The options asked for (`dynamic`: the frames of an animation).
    pub fn asked(&self, dynamic: bool) -> EngineOptions {
        EngineOptions {
            given: self.given.clone(),
            dynamic,
        }
    }

    /// The flag of option `keyword` (`--pair-budget`).
    pub fn flag(keyword: &str) -> String {
        format!("--{}", keyword.replace('_', "-"))
    }
}

/// The help heading of an option taken by `engines`.
fn heading(engines: &[Engine]) -> &'static str {
    match engines {
        [Engine::Bvh] => "BVH (--engine bvh)",
        [Engine::Bvh, ..] => "Object tree (--engine bvh, crsh, rah)",
        [Engine::Crsh] | [Engine::Crsh, Engine::Rah] | [Engine::Rah] => {
            "Ray hierarchy (--engine crsh, rah)"
        }
        _ => "Irregular grid (--engine grid, grid2l)",
    }
}

/// A flag's value parser: the option's kind parses and checks the text (its range and
/// names), so a bad value is refused by the parser with the option's own words.
fn value_parser(
    name: &'static str,
    kind: Kind,
) -> impl clap::builder::TypedValueParser<Value = String> {
    clap::builder::StringValueParser::new().try_map(move |s: String| {
        let v = kind.parse(&s)?;
        kind.check(name, &v).map_err(|e| e.reason)?;
        Ok::<_, String>(s)
    })
}

impl clap::FromArgMatches for EngineFlags {
    fn from_arg_matches(m: &clap::ArgMatches) -> Result<Self, clap::Error> {
        let mut given: Vec<(usize, String, Value)> = Vec::new();
        for o in options() {
            if m.value_source(o.name) != Some(clap::parser::ValueSource::CommandLine) {
                continue;
            }
            let (Some(text), Some(mut at)) = (m.get_one::<String>(o.name), m.indices_of(o.name))
            else {
                continue;
            };
            let v = o
                .kind
                .parse(text)
                .map_err(|e| clap::Error::raw(clap::error::ErrorKind::ValueValidation, e))?;
            given.push((at.next().unwrap_or(0), o.name.to_string(), v));
        }
        given.sort_by_key(|g| g.0);
        Ok(EngineFlags {
            given: given.into_iter().map(|(_, k, v)| (k, v)).collect(),
        })
    }

    fn update_from_arg_matches(&mut self, m: &clap::ArgMatches) -> Result<(), clap::Error> {
        *self = Self::from_arg_matches(m)?;
        Ok(())
    }
}

impl Args for EngineFlags {
    fn augment_args(mut cmd: clap::Command) -> clap::Command {
        for o in options() {
            let value_name = match o.kind {
                Kind::Int { .. } => "N".to_string(),
                Kind::Float { .. } => "X".to_string(),
                Kind::Switch => "on|off".to_string(),
                Kind::Choice(_) => o.kind.range(),
                Kind::Text(p) => p.to_string(),
            };
            let value_name = if value_name.len() > 28 {
                "NAME".to_string()
            } else {
                value_name
            };
            let range = match o.kind {
                Kind::Int { .. } | Kind::Float { .. } => format!("{}; ", o.kind.range()),
                _ => String::new(),
            };
            let help = format!("{} [{range}default: {}]", o.doc, o.default_text());
            cmd = cmd.arg(
                clap::Arg::new(o.name)
                    .long(o.flag())
                    .value_name(value_name)
                    .help(help)
                    .help_heading(heading(&o.engines))
                    .allow_negative_numbers(true)
                    .value_parser(value_parser(o.name, o.kind)),
            );
        }
        cmd
    }

    fn augment_args_for_update(cmd: clap::Command) -> clap::Command {
        Self::augment_args(cmd)
    }
}
