//! `rayspace engines`: every engine of this build, what it runs and its options with their
//! defaults, from the registry (`rayspace::engines`) and the engines' own declarations; with
//! `--json` the same as data (`{"engines": [{"name": "crsh", "options": {"branching": 8,
//! ...}}, ...]}`), whose `options` a render's `--stats` `engine_config` repeats.

use super::args::EnginesArgs;
use anyhow::Result;
use rayspace::engines::config::{defaults, options, values};
use rayspace::engines::{Backend, Engine, DEFAULT_ENGINE};
use serde::Serialize;
use std::collections::BTreeMap;
use trace::options::Value;

/// One engine as `--json` lists it.
#[derive(Serialize)]
struct EngineJson {
    name: &'static str,
    summary: &'static str,
    default: bool,
    gpu: bool,
    /// Every option with its default (a still image on the CPU backend).
    options: BTreeMap<String, Value>,
    /// The options whose default differs on the GPU backend, with that default.
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    gpu_options: BTreeMap<String, Value>,
}

pub fn cmd_engines(a: &EnginesArgs) -> Result<()> {
    let list: Vec<EngineJson> = Engine::NAMES
        .iter()
        .map(|&(name, e)| {
            let cpu = values(e, &defaults(e, Backend::Cpu, false));
            let gpu_options = if e.has_gpu() {
                values(e, &defaults(e, Backend::Gpu, false))
                    .into_iter()
                    .filter(|(k, v)| cpu.get(k) != Some(v))
                    .collect()
            } else {
                BTreeMap::new()
            };
            EngineJson {
                name,
                summary: e.summary(),
                default: e == DEFAULT_ENGINE,
                gpu: e.has_gpu(),
                options: cpu,
                gpu_options,
            }
        })
        .collect();
    if a.json {
        #[derive(Serialize)]
        struct All {
            engines: Vec<EngineJson>,
        }
        say!("{}", serde_json::to_string_pretty(&All { engines: list })?);
        return Ok(());
    }
    let all = options();
    for e in &list {
        say!(
            "{}{}{}: {}",
            e.name,
            if e.default { " (default)" } else { "" },
            if e.gpu { " [cpu, gpu]" } else { " [cpu]" },
            e.summary
        );
        for (k, v) in &e.options {
            let doc = all.iter().find(|o| o.flag() == *k).map_or("", |o| o.doc);
            let gpu = e
                .gpu_options
                .get(k)
                .map_or(String::new(), |g| format!(" (GPU: {g})"));
            say!("    --{k} {v}{gpu}  {doc}");
        }
    }
    Ok(())
}
