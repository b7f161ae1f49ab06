//! Engine options from the engines' own declarations (`rsh::options::OPTIONS`,
//! `accel::bvh::OPTIONS`, `accel::grid::OPTIONS`: each option once, a
//! [`trace::options::Spec`]), and what the registry makes of them: an engine's
//! configuration from the options asked for ([`config`]), its defaults on each backend
//! ([`defaults`]), its options' values as the stats and `rayspace engines` report them
//! ([`values`]), and every option with the engines that take it ([`options`]) for the
//! command line's flags and the Python keywords.

use super::{Engine, EngineError};
use accel::bvh::BvhConfig;
use accel::grid::GridConfig;
use rsh::{Method, RshConfig};
use std::collections::BTreeMap;
use trace::options::{Kind, OnGpu, Spec, Value};

/// Where an engine runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Backend {
    /// On the host's cores.
    Cpu,
    /// As wgpu kernels on the device.
    Gpu,
}

/// `--backend cpu|gpu`.
#[cfg(feature = "cli")]
impl clap::ValueEnum for Backend {
    fn value_variants<'a>() -> &'a [Self] {
        &[Backend::Cpu, Backend::Gpu]
    }

    fn to_possible_value(&self) -> Option<clap::builder::PossibleValue> {
        Some(clap::builder::PossibleValue::new(match self {
            Backend::Cpu => "cpu",
            Backend::Gpu => "gpu",
        }))
    }
}

/// An engine's configuration, every option set (defaults filled in).
#[derive(Clone, Debug, PartialEq)]
pub enum Config {
    /// CRSH or RAH.
    Rsh(RshConfig),
    /// The object-tree walk.
    Bvh(BvhConfig),
    /// The irregular grid or the two-level grid.
    Grid(GridConfig),
    /// An engine without options (brute force, the peers).
    Plain,
}

/// The options asked for, by keyword (`levels`, `grid_top_density`; `-` for `_` is
/// accepted too), with the values as a front end passes them; every other option keeps its
/// default.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct EngineOptions {
    /// The options given, in order (a later value of the same option wins).
    pub given: Vec<(String, Value)>,
    /// A frame of an animation (the grid expands once per frame unless asked otherwise, as
    /// the paper's dynamic scenes do).
    pub dynamic: bool,
}

/// One option as the registry lists it: its declaration's fields and the engines that
/// take it.
#[derive(Clone, Debug)]
pub struct OptionInfo {
    /// The keyword (`pair_budget`); the command line's flag is `--pair-budget`.
    pub name: &'static str,
    /// What it takes.
    pub kind: Kind,
    /// What it does, in one line.
    pub doc: &'static str,
    /// The engines that take it.
    pub engines: Vec<Engine>,
    /// On the GPU backend.
    pub gpu: OnGpu,
}

impl OptionInfo {
    /// The option's name as the command line spells it, without the dashes
    /// (`pair-budget`): the keys of `engines --json` and `engine_config`.
    pub fn flag(&self) -> String {
        self.name.replace('_', "-")
    }

    /// Its default in words, for help: one value where every engine, backend and frame
    /// kind agree (`8`), else each (`on for crsh, off for rah`; `sah; GPU: lbvh`;
    /// `3; 1 per frame of an animation`).
    pub fn default_text(&self) -> String {
        let value = |e: Engine, b: Backend, dynamic: bool| {
            values(e, &defaults(e, b, dynamic))
                .remove(&self.flag())
                .map(|v| v.to_string())
        };
        let per_engine: Vec<(Engine, String)> = self
            .engines
            .iter()
            .filter_map(|&e| Some((e, value(e, Backend::Cpu, false)?)))
            .collect();
        let mut text = match per_engine.first() {
            Some((_, v)) if per_engine.iter().all(|(_, w)| w == v) => v.clone(),
            _ => per_engine
                .iter()
                .map(|(e, v)| format!("{v} for {}", e.name()))
                .collect::<Vec<_>>()
                .join(", "),
        };
        if let OnGpu::Only(v) = self.gpu {
            if per_engine.iter().any(|(_, w)| w != v) {
                text += &format!("; GPU: {v}");
            }
        }
        let e = self.engines[0];
        if let (Some(still), Some(frame)) =
            (value(e, Backend::Cpu, false), value(e, Backend::Cpu, true))
        {
            if still != frame {
                text += &format!("; {frame} per frame of an animation");
            }
        }
        text
    }
}

/// The option families: CRSH/RAH's, the object-tree walk's, the grids'.
fn family(engine: Engine) -> Option<&'static str> {
    match engine {
        Engine::Crsh | Engine::Rah => Some("rsh"),
        Engine::Bvh => Some("bvh"),
        Engine::Grid | Engine::Grid2l => Some("grid"),
        _ => None,
    }
}

/// What the registry needs of a family's declarations, whatever its configuration type.
struct Erased {
    name: &'static str,
    kind: Kind,
    doc: &'static str,
    gpu: OnGpu,
    applies: Box<dyn Fn(&str) -> bool>,
}

/// The declarations of a family, erased.
fn erase<C>(specs: &'static [Spec<C>]) -> impl Iterator<Item = Erased> {
    specs.iter().map(|s| Erased {
        name: s.name,
        kind: s.kind,
        doc: s.doc,
        gpu: s.gpu,
        applies: Box::new(move |e| s.applies_to(e)),
    })
}

/// Every engine option, in the order the command line lists them (CRSH/RAH's, the
/// object-tree walk's, the grids'), each once, with the engines that take it. An option
/// two families declare (the object tree's builder, `object_builder`, of `bvh`, `crsh`
/// and `rah`) is one option.
pub fn options() -> Vec<OptionInfo> {
    let all = erase(rsh::options::OPTIONS)
        .map(|e| ("rsh", e))
        .chain(erase(accel::bvh::OPTIONS).map(|e| ("bvh", e)))
        .chain(erase(accel::grid::OPTIONS).map(|e| ("grid", e)));
    let mut out: Vec<OptionInfo> = Vec::new();
    for (fam, e) in all {
        let takers: Vec<Engine> = Engine::NAMES
            .iter()
            .map(|&(_, x)| x)
            .filter(|&x| family(x) == Some(fam) && (e.applies)(x.name()))
            .collect();
        match out.iter_mut().find(|o| o.name == e.name) {
            Some(o) => {
                debug_assert_eq!(o.kind, e.kind, "{}: one option, one kind", e.name);
                o.engines.extend(takers);
                o.engines.sort();
            }
            None => out.push(OptionInfo {
                name: e.name,
                kind: e.kind,
                doc: e.doc,
                engines: takers,
                gpu: e.gpu,
            }),
        }
    }
    out
}

/// The configuration `engine` runs with on `backend` when no option is asked for (`dynamic`:
/// a frame of an animation). On the GPU backend an option the device takes one value of
/// has that value.
pub fn defaults(engine: Engine, backend: Backend, dynamic: bool) -> Config {
    fn device<C>(specs: &'static [Spec<C>], c: &mut C, engine: Engine) {
        for s in specs.iter().filter(|s| s.applies_to(engine.name())) {
            if let OnGpu::Only(v) = s.gpu {
                s.apply(c, &Value::Str(v.into()))
                    .expect("a declared device value is valid");
            }
        }
    }
    let gpu = backend == Backend::Gpu;
    match engine {
        Engine::Crsh | Engine::Rah => {
            let mut c = match engine.rsh_method() {
                Some(Method::Rah) => RshConfig::rah(),
                _ => RshConfig::crsh(),
            };
            if gpu {
                device(rsh::options::OPTIONS, &mut c, engine);
            }
            Config::Rsh(c)
        }
        Engine::Bvh => {
            let mut c = BvhConfig::default();
            if gpu {
                device(accel::bvh::OPTIONS, &mut c, engine);
            }
            Config::Bvh(c)
        }
        Engine::Grid | Engine::Grid2l => {
            let mut c = if engine == Engine::Grid2l {
                GridConfig::two_level()
            } else {
                GridConfig::default()
            };
            if dynamic && engine == Engine::Grid {
                c.expansion_passes = 1;
            }
            Config::Grid(c)
        }
        _ => Config::Plain,
    }
}

/// The configuration of `engine` on `backend` with the options `asked`: its defaults, each
/// option asked for checked (its name, whether the engine and backend take it, its value)
/// and set, then whether the options that depend on another one's value have it.
pub fn config(
    engine: Engine,
    backend: Backend,
    asked: &EngineOptions,
) -> Result<Config, EngineError> {
    if backend == Backend::Gpu && !engine.has_gpu() {
        return Err(EngineError::NoGpu {
            engine: engine.name(),
        });
    }
    let mut cfg = defaults(engine, backend, asked.dynamic);
    let gpu = backend == Backend::Gpu;
    let all = options();
    for (given, v) in &asked.given {
        let key = given.replace('-', "_");
        let Some(info) = all.iter().find(|o| o.name == key) else {
            return Err(EngineError::Unknown {
                option: given.clone(),
                known: all.iter().map(|o| o.name).collect(),
            });
        };
        if !info.engines.contains(&engine) {
            return Err(EngineError::NotFor {
                option: info.name,
                engine: engine.name(),
                takers: info.engines.iter().map(|e| e.name()).collect(),
            });
        }
        match &mut cfg {
            Config::Rsh(c) => set(rsh::options::OPTIONS, c, info.name, v, gpu)?,
            Config::Bvh(c) => set(accel::bvh::OPTIONS, c, info.name, v, gpu)?,
            Config::Grid(c) => set(accel::grid::OPTIONS, c, info.name, v, gpu)?,
            Config::Plain => unreachable!("an engine without options took one"),
        }
    }
    for (given, _) in &asked.given {
        let key = given.replace('-', "_");
        match &cfg {
            Config::Rsh(c) => requires(rsh::options::OPTIONS, c, &key, engine)?,
            Config::Bvh(c) => requires(accel::bvh::OPTIONS, c, &key, engine)?,
            Config::Grid(c) => requires(accel::grid::OPTIONS, c, &key, engine)?,
            Config::Plain => {}
        }
    }
    cfg.validate(engine)?;
    Ok(cfg)
}

/// Set option `name` of `specs` to `v` in `c`; on the GPU backend only its device value.
fn set<C>(
    specs: &'static [Spec<C>],
    c: &mut C,
    name: &str,
    v: &Value,
    gpu: bool,
) -> Result<(), EngineError> {
    let s = specs
        .iter()
        .find(|s| s.name == name)
        .expect("the registry lists the family's options");
    if let (true, OnGpu::Only(only)) = (gpu, s.gpu) {
        let v = s.kind.check(s.name, v)?;
        if v != Value::Str(only.into()) {
            return Err(EngineError::GpuOnly {
                option: s.name,
                value: v.to_string(),
                only,
            });
        }
    }
    Ok(s.apply(c, v)?)
}

/// Refuse option `name` of `specs` where the option it depends on does not have the value
/// it needs in `c`.
fn requires<C>(
    specs: &'static [Spec<C>],
    c: &C,
    name: &str,
    engine: Engine,
) -> Result<(), EngineError> {
    let Some(s) = specs.iter().find(|s| s.name == name) else {
        return Ok(());
    };
    let Some((needs, value)) = s.requires else {
        return Ok(());
    };
    let dep = specs
        .iter()
        .find(|d| d.name == needs)
        .expect("an option depends on an option of its family");
    let has = (dep.get)(c);
    if has != Value::Str(value.into()) {
        return Err(EngineError::Requires {
            option: s.name,
            needs,
            value,
            has: has.to_string(),
            engine: engine.name(),
        });
    }
    Ok(())
}

/// The value of every option `engine` takes in `cfg`, by the command line's name without
/// the dashes (`pair-budget`): the `--stats` JSON's `engine_config`, `engines --json`'s
/// `options`.
pub fn values(engine: Engine, cfg: &Config) -> BTreeMap<String, Value> {
    fn of<C>(specs: &'static [Spec<C>], c: &C, engine: Engine) -> BTreeMap<String, Value> {
        specs
            .iter()
            .filter(|s| s.applies_to(engine.name()))
            .map(|s| (s.name.replace('_', "-"), (s.get)(c)))
            .collect()
    }
    match cfg {
        Config::Rsh(c) => of(rsh::options::OPTIONS, c, engine),
        Config::Bvh(c) => of(accel::bvh::OPTIONS, c, engine),
        Config::Grid(c) => of(accel::grid::OPTIONS, c, engine),
        Config::Plain => BTreeMap::new(),
    }
}

/// `engine` with its configuration as a command line spells it, for the benchmarks' rows:
/// `bvh --object-builder sah --ray-path packets`; only the name for an engine without
/// options.
pub fn describe(engine: Engine, cfg: &Config) -> String {
    let mut s = engine.name().to_string();
    for (k, v) in values(engine, cfg) {
        s += &format!(" --{k} {v}");
    }
    s
}

impl Config {
    /// The CPU backend's defaults of `engine` for a still image.
    pub fn of(engine: Engine) -> Config {
        defaults(engine, Backend::Cpu, false)
    }

    /// Every option's value against its declaration.
    pub fn validate(&self, engine: Engine) -> Result<(), EngineError> {
        match self {
            Config::Rsh(c) => Ok(c.validate()?),
            Config::Bvh(_) | Config::Plain => Ok(()),
            Config::Grid(c) => c.validate().map_err(|e| EngineError::Grid {
                engine: engine.name(),
                error: e.into(),
            }),
        }
    }

    /// The object side CRSH and RAH traverse (`bvh` or `mesh-spheres`); `None` for the
    /// other engines.
    pub fn object_hierarchy(&self) -> Option<&'static str> {
        match self {
            Config::Rsh(c) => Some(trace::options::name_of(
                &rsh::ObjectHierarchy::NAMES,
                c.objects,
            )),
            _ => None,
        }
    }

    /// Fit the configuration to `bytes` of memory, what the memory limit leaves once the
    /// scene is loaded and the render's buffers counted, for `engine` built over
    /// `triangles`: its build's model ([`build_bytes`]) must fit, else the typed
    /// [`EngineError::Memory`] refuses it before anything is allocated; the grid's build
    /// checks its own model against what is left; CRSH and RAH lower their pair budget
    /// until its model fits what the build leaves (more, smaller batches; no pair dropped).
    /// Returns what was changed to fit, as (option, asked, now).
    pub fn fit_memory(
        &mut self,
        engine: Engine,
        triangles: u64,
        bytes: u64,
    ) -> Result<Vec<(&'static str, Value, Value)>, EngineError> {
        let build = build_bytes(engine, self, triangles);
        if build > bytes {
            return Err(EngineError::Memory {
                engine: engine.name(),
                triangles,
                need: build,
                left: bytes,
            });
        }
        let left = bytes - build;
        match self {
            Config::Grid(c) => {
                c.max_bytes = bytes;
                Ok(Vec::new())
            }
            Config::Rsh(c) if c.pair_bytes() > left => {
                let b = c.budget_within(left).ok_or(EngineError::Memory {
                    engine: engine.name(),
                    triangles,
                    need: build + c.pair_bytes_of(1024),
                    left: bytes,
                })?;
                let was = c.pair_budget;
                c.pair_budget = b;
                Ok(vec![(
                    "pair_budget",
                    Value::Int(was as i64),
                    Value::Int(b as i64),
                )])
            }
            _ => Ok(Vec::new()),
        }
    }
}

/// The memory model of `engine`'s build over `triangles` triangles with configuration
/// `cfg`: the resident bytes it adds at its peak, each engine's own model (the least the
/// grid's takes: its build checks the rest itself).
pub fn build_bytes(engine: Engine, cfg: &Config, triangles: u64) -> u64 {
    triangles.saturating_mul(build_bytes_per_triangle(engine, cfg))
}

/// [`build_bytes`] per triangle.
pub fn build_bytes_per_triangle(engine: Engine, cfg: &Config) -> u64 {
    match (engine, cfg) {
        (Engine::Bvh, _) => accel::bvh::BUILD_BYTES_PER_TRIANGLE,
        (Engine::Crsh | Engine::Rah, Config::Rsh(c)) => rsh::engine::build_bytes_per_triangle(c),
        (Engine::Crsh | Engine::Rah, _) => {
            rsh::engine::build_bytes_per_triangle(&RshConfig::crsh())
        }
        (Engine::Grid | Engine::Grid2l, Config::Grid(c)) => {
            accel::grid::build_bytes_per_triangle(c)
        }
        (Engine::Grid | Engine::Grid2l, _) => {
            accel::grid::build_bytes_per_triangle(&accel::grid::GridConfig::two_level())
        }
        (Engine::Brute, _) => accel::brute::BUILD_BYTES_PER_TRIANGLE,
        (Engine::ObvhsCwbvh, _) => accel::peers::CWBVH_BUILD_BYTES_PER_TRIANGLE,
        (Engine::ObvhsBvh2, _) => accel::peers::BVH2_BUILD_BYTES_PER_TRIANGLE,
        (Engine::Embree | Engine::EmbreeStream, _) => accel::peers::EMBREE_BUILD_BYTES_PER_TRIANGLE,
    }
}

impl EngineOptions {
    /// The options of a front end that names them by keyword (Python), `dynamic` for the
    /// frames of an animation.
    pub fn new(given: Vec<(String, Value)>, dynamic: bool) -> EngineOptions {
        EngineOptions { given, dynamic }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_option_is_taken_by_an_engine_and_named_once() {
        let all = options();
        for o in &all {
            assert!(!o.engines.is_empty(), "{}", o.name);
            assert_eq!(all.iter().filter(|p| p.name == o.name).count(), 1);
        }
        let builder = all.iter().find(|o| o.name == "object_builder").unwrap();
        assert_eq!(builder.engines, [Engine::Bvh, Engine::Crsh, Engine::Rah]);
        let hash = all.iter().find(|o| o.name == "hash").unwrap();
        assert_eq!(hash.engines, [Engine::Crsh]);
        let alpha = all.iter().find(|o| o.name == "grid_alpha").unwrap();
        assert_eq!(alpha.engines, [Engine::Grid]);
    }

    #[test]
    fn defaults_are_the_engines_own_and_the_help_says_them() {
        let all = options();
        let text = |n: &str| all.iter().find(|o| o.name == n).unwrap().default_text();
        assert_eq!(text("branching"), "8");
        assert_eq!(text("mesh_culling"), "on for crsh, off for rah");
        assert_eq!(text("object_builder"), "sah; GPU: lbvh");
        assert_eq!(text("ray_path"), "packets; GPU: single");
        assert_eq!(text("grid_expansion"), "3; 1 per frame of an animation");
        assert_eq!(Config::of(Engine::Crsh), Config::Rsh(RshConfig::crsh()));
        let Config::Rsh(g) = defaults(Engine::Crsh, Backend::Gpu, false) else {
            panic!()
        };
        assert_eq!(g.schedule, rsh::Schedule::Breadth);
        assert_eq!(g.builder, accel::bvh::ObjectBuilder::Lbvh);
    }

    #[test]
    fn options_are_checked_where_they_apply() {
        let asked = |kv: &[(&str, Value)]| EngineOptions {
            given: kv.iter().map(|(k, v)| (k.to_string(), v.clone())).collect(),
            dynamic: false,
        };
        let cpu = Backend::Cpu;
        let c = config(
            Engine::Crsh,
            cpu,
            &asked(&[("branching", Value::Int(16)), ("levels", Value::Int(3))]),
        )
        .unwrap();
        assert_eq!(values(Engine::Crsh, &c)["branching"], Value::Int(16));
        let e = config(Engine::Grid, cpu, &asked(&[("levels", Value::Int(3))])).unwrap_err();
        assert_eq!(
            e.to_string(),
            "`levels` does not apply to `engine`=grid (it is an option of crsh, rah)"
        );
        let e = config(
            Engine::Crsh,
            cpu,
            &asked(&[("ray_path", Value::Str("single".into()))]),
        )
        .unwrap_err();
        assert!(e.to_string().contains("option of bvh"), "{e}");
        let e = config(
            Engine::Crsh,
            cpu,
            &asked(&[
                ("object_hierarchy", Value::Str("mesh-spheres".into())),
                ("descent", Value::Str("size".into())),
            ]),
        )
        .unwrap_err();
        assert!(matches!(e, EngineError::Requires { .. }), "{e}");
        let e = config(
            Engine::Crsh,
            Backend::Gpu,
            &asked(&[("schedule", Value::Str("depth".into()))]),
        )
        .unwrap_err();
        assert_eq!(e.to_string(), "`schedule`=depth: the GPU backend takes only breadth (the others run on the CPU backend)");
        let e = config(Engine::Crsh, cpu, &asked(&[("levels", Value::Int(99))])).unwrap_err();
        assert_eq!(e.to_string(), "`levels`=99: must be in 0..=16");
        let e = config(Engine::Bvh, cpu, &asked(&[("bogus", Value::Int(1))])).unwrap_err();
        assert!(matches!(e, EngineError::Unknown { .. }), "{e}");
        let e = config(Engine::Brute, Backend::Gpu, &EngineOptions::default()).unwrap_err();
        assert!(matches!(e, EngineError::NoGpu { .. }), "{e}");
        // Dashes as the command line spells them; a later value wins.
        let c = config(
            Engine::Grid,
            cpu,
            &asked(&[
                ("grid-expansion", Value::Int(2)),
                ("grid_expansion", Value::Int(0)),
            ]),
        )
        .unwrap();
        assert_eq!(values(Engine::Grid, &c)["grid-expansion"], Value::Int(0));
        assert!(!values(Engine::Grid2l, &Config::of(Engine::Grid2l)).contains_key("grid-expansion"));
    }
}
