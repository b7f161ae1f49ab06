//! Derives the Rust side of every kernel launch from the WGSL itself, so that a binding
//! number, a kernel's name and the set of buffers it binds are written once, in the shader.
//!
//! For each module (the files compiled together after the shared prelude, listed once in
//! [`MODULES`]) it reads the `@group(0) @binding(N) var… name: …;` declarations and the
//! `@compute` entry points, follows each entry point's calls to find the globals it uses
//! (wgpu infers a pipeline's bind-group layout from exactly those), and writes
//! `$OUT_DIR/kernels.rs`: the `Module` and `Kernel` enums (a kernel's doc is the WGSL comment
//! above its entry point), and one `launch::` struct per kernel whose fields are the
//! buffers it binds, by their WGSL names. `kernels.rs` includes it; a unit test there checks
//! the derived binding sets against naga's own analysis of the same sources.

use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write as _;
use std::path::Path;

/// The modules: name and files after the prelude (`shaders/common.wgsl`), concatenated in
/// this order.
const MODULES: &[(&str, &[&str])] = &[
    ("Scan", &["prims/scan.wgsl"]),
    ("Size", &["prims/size.wgsl"]),
    ("Sort", &["prims/sort.wgsl"]),
    ("Compact", &["prims/bindings.wgsl", "prims/compact.wgsl"]),
    ("Runs", &["prims/bindings.wgsl", "prims/runs.wgsl"]),
    ("Permute", &["prims/bindings.wgsl", "prims/permute.wgsl"]),
    ("Kinds", &["prims/bindings.wgsl", "rsh/kinds.wgsl"]),
    ("Hash", &["shaders/geom.wgsl", "rsh/hash.wgsl"]),
    ("Build", &["shaders/geom.wgsl", "rsh/build.wgsl"]),
    ("Traverse", &["shaders/geom.wgsl", "rsh/traverse.wgsl"]),
    ("Final", &["shaders/geom.wgsl", "rsh/final.wgsl"]),
    ("Objects", &["shaders/geom.wgsl", "bvh/objects.wgsl"]),
    ("Single", &["shaders/geom.wgsl", "bvh/single.wgsl"]),
    (
        "Dual",
        &["shaders/geom.wgsl", "rsh/dual.wgsl", "rsh/dual_rounds.wgsl"],
    ),
    ("Stages", &["stages.wgsl"]),
    (
        "Grid",
        &["shaders/geom.wgsl", "grid/traverse.wgsl", "grid/map.wgsl"],
    ),
    ("GridBuild", &["grid/build.wgsl"]),
    ("VoxelMap", &["grid/voxelmap.wgsl"]),
    ("Merge", &["grid/merge.wgsl", "grid/map.wgsl"]),
    ("Expand", &["grid/expand.wgsl", "grid/map.wgsl"]),
    ("Frame", &["frame.wgsl"]),
];

/// Render pipelines (name, file): a `…Bindings` struct of every binding of the file.
const RENDER_PIPELINES: &[(&str, &str)] = &[("Raster", "raster.wgsl")];

/// The prelude every module starts with (after the host's constants).
const PRELUDE: &str = "shaders/common.wgsl";

/// A resource binding of group 0.
struct Global {
    binding: u32,
    name: String,
}

/// A kernel: its enum variant, entry point, doc, module and storage bindings.
struct KernelDef {
    camel: String,
    entry: String,
    doc: Vec<String>,
    module: &'static str,
    used: Vec<Global>,
    /// The kernel's parameter struct.
    params: String,
}

/// A function: its name, whether it is a compute entry point (with the comment above it),
/// and the identifiers its body names.
struct Func {
    name: String,
    entry_doc: Option<Vec<String>>,
    idents: BTreeSet<String>,
}

fn main() {
    let src = Path::new(&std::env::var("CARGO_MANIFEST_DIR").unwrap()).join("src");
    let read = |f: &str| {
        println!("cargo:rerun-if-changed=src/{f}");
        std::fs::read_to_string(src.join(f)).unwrap_or_else(|e| panic!("src/{f}: {e}"))
    };
    let prelude = read(PRELUDE);
    let mut out = String::new();
    let mut kernels: Vec<KernelDef> = Vec::new();
    let mut params: Vec<ParamStruct> = Vec::new();
    let mut module_accessors: Vec<(&str, String)> = Vec::new();
    for &(module, files) in MODULES {
        let text: String = std::iter::once(prelude.clone())
            .chain(files.iter().map(|f| read(f)))
            .collect::<Vec<_>>()
            .join("\n");
        // The parameter structs' accessors are part of the module (they read binding 0).
        let structs = param_structs(&text, module);
        let mut accessors = String::new();
        for st in &structs {
            accessors += &st.wgsl_accessor();
            match params.iter().find(|p: &&ParamStruct| p.name == st.name) {
                // A struct of a shared file (e.g. grid/map.wgsl) is declared in each module.
                Some(p) => assert!(
                    p.fields
                        .iter()
                        .map(|f| (&f.name, f.word))
                        .eq(st.fields.iter().map(|f| (&f.name, f.word))),
                    "{module}: struct {} differs from another module's",
                    st.name
                ),
                None => params.push(st.clone()),
            }
        }
        let (globals, funcs) = scan(&format!("{text}\n{accessors}"), module);
        module_accessors.push((module, accessors));
        let by_name: BTreeMap<&str, &Func> = funcs.iter().map(|f| (f.name.as_str(), f)).collect();
        for f in funcs.iter() {
            let Some(doc) = &f.entry_doc else { continue };
            // Every function reachable from the entry point, then the globals they name.
            let mut seen = BTreeSet::new();
            let mut todo = vec![f.name.as_str()];
            while let Some(n) = todo.pop() {
                if !seen.insert(n) {
                    continue;
                }
                for id in &by_name[n].idents {
                    if by_name.contains_key(id.as_str()) {
                        todo.push(id);
                    }
                }
            }
            let mut used: Vec<Global> = globals
                .iter()
                .filter(|g| seen.iter().any(|n| by_name[n].idents.contains(&g.name)))
                .map(|g| Global {
                    binding: g.binding,
                    name: g.name.clone(),
                })
                .collect();
            used.sort_by_key(|g| g.binding);
            assert!(
                used.iter().any(|g| g.binding == 0),
                "{module}: entry point {} does not read the launch parameters (binding 0), which every launch binds",
                f.name
            );
            used.retain(|g| g.binding != 0);
            // The parameter struct: the one whose accessor the entry point reaches.
            let reached: Vec<&str> = params
                .iter()
                .filter(|p| seen.contains(p.accessor().as_str()))
                .map(|p| p.name.as_str())
                .collect();
            assert!(
                reached.len() <= 1,
                "{module}: entry point {} reads two parameter structs {reached:?}",
                f.name
            );
            let params_ty = reached.first().map(|s| s.to_string()).unwrap_or_else(|| {
                panic!(
                    "{module}: entry point {} reads no parameter struct (a `struct …Params` of its module, through its generated accessor)",
                    f.name
                )
            });
            if let Some(k) = kernels.iter().find(|k| k.entry == f.name) {
                panic!("entry point {} in both {} and {module}", f.name, k.module);
            }
            kernels.push(KernelDef {
                camel: camel(&f.name),
                entry: f.name.clone(),
                doc: doc.clone(),
                module,
                used,
                params: params_ty,
            });
        }
    }

    // The modules.
    out += "/// A compiled WGSL module: its files after the shared prelude (constants, `common.wgsl`).\n";
    out += "#[derive(Clone, Copy, Debug, PartialEq, Eq)]\nenum Module {\n";
    for &(m, _) in MODULES {
        writeln!(out, "    {m},").unwrap();
    }
    out += "}\n\nimpl Module {\n";
    writeln!(out, "    const ALL: [Module; {}] = [", MODULES.len()).unwrap();
    for &(m, _) in MODULES {
        writeln!(out, "        Module::{m},").unwrap();
    }
    out += "    ];\n\n    /// The module's source after the prelude.\n    fn source(self) -> &'static str {\n        match self {\n";
    for &(m, files) in MODULES {
        let mut parts: Vec<String> = files
            .iter()
            .map(|f| format!("include_str!(concat!(env!(\"CARGO_MANIFEST_DIR\"), \"/src/{f}\"))"))
            .collect();
        let acc = &module_accessors.iter().find(|a| a.0 == m).unwrap().1;
        if !acc.is_empty() {
            parts.push(format!("{acc:?}"));
        }
        writeln!(
            out,
            "            Module::{m} => concat!({}),",
            parts.join(", ")
        )
        .unwrap();
    }
    out += "        }\n    }\n}\n\n";

    // The kernels.
    out += "/// Every compute kernel: one per `@compute` entry point of the modules, derived from the\n";
    out += "/// WGSL by `build.rs` (so a launch cannot name a kernel that does not exist).\n";
    out += "#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]\npub enum Kernel {\n";
    for k in &kernels {
        // One line: a WGSL comment's wrapped lines are one paragraph.
        writeln!(out, "    /// {}", doc(&k.doc.join(" "))).unwrap();
        writeln!(out, "    {},", k.camel).unwrap();
    }
    out += "}\n\nimpl Kernel {\n    /// Every kernel.\n";
    writeln!(out, "    pub const ALL: [Kernel; {}] = [", kernels.len()).unwrap();
    for k in &kernels {
        writeln!(out, "        Kernel::{},", k.camel).unwrap();
    }
    out += "    ];\n\n    /// The WGSL entry point and the module that holds it.\n    fn def(self) -> (&'static str, Module) {\n        match self {\n";
    for k in &kernels {
        let (camel, entry, module) = (&k.camel, &k.entry, k.module);
        writeln!(
            out,
            "            Kernel::{camel} => (\"{entry}\", Module::{module}),"
        )
        .unwrap();
    }
    out += "        }\n    }\n\n    /// The storage bindings the kernel uses (number, WGSL name), binding 0 (the launch\n    /// parameters) aside.\n    pub fn bindings(self) -> &'static [(u32, &'static str)] {\n        match self {\n";
    for KernelDef { camel, used, .. } in &kernels {
        let list: Vec<String> = used
            .iter()
            .map(|g| format!("({}, \"{}\")", g.binding, g.name))
            .collect();
        writeln!(
            out,
            "            Kernel::{camel} => &[{}],",
            list.join(", ")
        )
        .unwrap();
    }
    out += "        }\n    }\n}\n\n";

    // One launch struct per kernel.
    out += "/// One struct per kernel: the buffers a launch binds, named as the WGSL names them (the\n";
    out += "/// binding numbers stay in the WGSL). [`Exec::run`](crate::kernels::Exec::run) takes one.\n";
    out += "pub mod launch {\n    use super::{Kernel, Launch};\n\n";
    for KernelDef {
        camel,
        entry,
        used,
        params: ptype,
        ..
    } in &kernels
    {
        writeln!(
            out,
            "    /// The buffers of [`Kernel::{camel}`] (`{entry}`)."
        )
        .unwrap();
        writeln!(out, "    pub struct {camel}<'a> {{").unwrap();
        for g in used {
            writeln!(out, "        /// `@binding({})`.", g.binding).unwrap();
            writeln!(out, "        pub {}: &'a wgpu::Buffer,", g.name).unwrap();
        }
        if used.is_empty() {
            out += "        /// No buffer besides the parameters.\n        pub _none: std::marker::PhantomData<&'a ()>,\n";
        }
        out += "    }\n\n";
        writeln!(out, "    impl Launch for {camel}<'_> {{").unwrap();
        writeln!(out, "        const KERNEL: Kernel = Kernel::{camel};").unwrap();
        writeln!(out, "        type Params = super::params::{ptype};").unwrap();
        out += "        fn buffers(&self) -> Vec<&wgpu::Buffer> {\n";
        let fields: Vec<String> = used.iter().map(|g| format!("self.{}", g.name)).collect();
        writeln!(out, "            vec![{}]", fields.join(", ")).unwrap();
        out += "        }\n    }\n\n";
    }
    out += "}\n\n";

    // The parameter structs.
    out += "/// The kernels' parameter structs, declared in the WGSL (`struct …Params`) and read\n";
    out += "/// there through their generated accessor (`fn …_params()`), which unpacks the\n";
    out += "/// launch's parameter block at the same offsets as [`ParamBlock::block`] packs it.\n";
    out += "pub mod params {\n";
    if !params.is_empty() {
        out += "    use crate::kernels::{ParamBlock, Params};\n\n";
    }
    for p in &params {
        out += &p.rust();
    }
    out += "}\n";

    // The render pipelines' bind groups: every binding of their file, by name.
    for &(name, file) in RENDER_PIPELINES {
        let (globals, _) = scan(&read(file), name);
        writeln!(
            out,
            "\n/// The buffers of `{file}`'s bind group, named as the WGSL names them."
        )
        .unwrap();
        writeln!(out, "pub struct {name}Bindings<'a> {{").unwrap();
        for g in &globals {
            writeln!(out, "    /// `@binding({})`.", g.binding).unwrap();
            writeln!(out, "    pub {}: &'a wgpu::Buffer,", g.name).unwrap();
        }
        out += "}\n\n";
        writeln!(out, "impl {name}Bindings<'_> {{").unwrap();
        out += "    /// The bind group's entries.\n";
        out += "    pub fn entries(&self) -> Vec<wgpu::BindGroupEntry<'_>> {\n        vec![\n";
        for g in &globals {
            writeln!(
                out,
                "            wgpu::BindGroupEntry {{ binding: {}, resource: self.{}.as_entire_binding() }},",
                g.binding, g.name
            )
            .unwrap();
        }
        out += "        ]\n    }\n}\n";
    }

    let dest = Path::new(&std::env::var("OUT_DIR").unwrap()).join("kernels.rs");
    std::fs::write(&dest, out).unwrap();
    println!("cargo:rerun-if-changed=build.rs");
}

/// A scalar or vector field type of a parameter struct.
#[derive(Clone, Copy, PartialEq)]
enum Scalar {
    U32,
    I32,
    F32,
}

/// A field of a parameter struct: name, scalar, lanes (1–4), first word, doc.
#[derive(Clone)]
struct Field {
    name: String,
    scalar: Scalar,
    lanes: u32,
    word: u32,
    doc: String,
}

/// A `struct …Params` of the WGSL, laid out in the 24-word launch block (words 0–15 the
/// block's `u0..u3`, 16–23 its `f0, f1`; word 23 is the reserved opaque zero).
#[derive(Clone)]
struct ParamStruct {
    name: String,
    doc: String,
    fields: Vec<Field>,
}

impl ParamStruct {
    /// `TopParams` → `top_params`.
    fn accessor(&self) -> String {
        let mut s = String::new();
        for (i, c) in self.name.chars().enumerate() {
            if c.is_ascii_uppercase() {
                if i > 0 {
                    s.push('_');
                }
                s.push(c.to_ascii_lowercase());
            } else {
                s.push(c);
            }
        }
        s
    }

    /// The WGSL word `w` of the block as bits (`u32`).
    fn word(w: u32) -> String {
        let c = ["x", "y", "z", "w"][(w % 4) as usize];
        if w < 16 {
            format!("P.u{}.{c}", w / 4)
        } else {
            format!("bitcast<u32>(P.f{}.{c})", (w - 16) / 4)
        }
    }

    fn wgsl_accessor(&self) -> String {
        let mut args = Vec::new();
        for f in &self.fields {
            let words: Vec<String> = (f.word..f.word + f.lanes).map(Self::word).collect();
            let bits = if f.lanes == 1 {
                words[0].clone()
            } else {
                format!("vec{}<u32>({})", f.lanes, words.join(", "))
            };
            let ty = match f.scalar {
                Scalar::U32 => "u32",
                Scalar::I32 => "i32",
                Scalar::F32 => "f32",
            };
            args.push(match (f.scalar, f.lanes) {
                (Scalar::U32, _) => bits,
                (_, 1) => format!("bitcast<{ty}>({bits})"),
                (_, n) => format!("bitcast<vec{n}<{ty}>>({bits})"),
            });
        }
        format!(
            "\n// The launch parameters as {n} (generated by build.rs).\nfn {a}() -> {n} {{\n    return {n}({});\n}}\n",
            args.join(", "),
            n = self.name,
            a = self.accessor()
        )
    }

    fn rust(&self) -> String {
        let mut o = String::new();
        writeln!(o, "    /// {}", doc(&self.doc)).unwrap();
        o += "    #[derive(Clone, Copy, Debug, Default, PartialEq)]\n";
        writeln!(o, "    pub struct {} {{", self.name).unwrap();
        for f in &self.fields {
            let t = match f.scalar {
                Scalar::U32 => "u32",
                Scalar::I32 => "i32",
                Scalar::F32 => "f32",
            };
            let ty = if f.lanes == 1 {
                t.to_string()
            } else {
                format!("[{t}; {}]", f.lanes)
            };
            writeln!(o, "        /// {}", doc(&f.doc)).unwrap();
            writeln!(o, "        pub {}: {ty},", f.name).unwrap();
        }
        o += "    }\n\n";
        writeln!(o, "    impl ParamBlock for {} {{", self.name).unwrap();
        o += "        fn block(&self) -> Params {\n            let mut w = [0u32; 24];\n";
        for f in &self.fields {
            let bits = |e: String| match f.scalar {
                Scalar::U32 => e,
                Scalar::I32 => format!("{e} as u32"),
                Scalar::F32 => format!("{e}.to_bits()"),
            };
            if f.lanes == 1 {
                writeln!(
                    o,
                    "            w[{}] = {};",
                    f.word,
                    bits(format!("self.{}", f.name))
                )
                .unwrap();
            } else {
                for l in 0..f.lanes {
                    writeln!(
                        o,
                        "            w[{}] = {};",
                        f.word + l,
                        bits(format!("self.{}[{l}]", f.name))
                    )
                    .unwrap();
                }
            }
        }
        o += "            Params::from_words(w)\n        }\n    }\n\n";
        o
    }
}

/// The `struct …Params { … }` declarations of a module's text, laid out.
fn param_structs(text: &str, module: &str) -> Vec<ParamStruct> {
    let lines: Vec<&str> = text.lines().collect();
    let mut out = Vec::new();
    let mut i = 0;
    while i < lines.len() {
        let l = lines[i].trim();
        let name = l
            .strip_prefix("struct ")
            .and_then(|r| r.strip_suffix('{'))
            .map(str::trim)
            .filter(|n| n.ends_with("Params") && *n != "Params");
        let Some(name) = name else {
            i += 1;
            continue;
        };
        let mut doc = Vec::new();
        let mut k = i;
        while k > 0 && lines[k - 1].trim_start().starts_with("//") {
            k -= 1;
            doc.push(
                lines[k]
                    .trim_start()
                    .trim_start_matches('/')
                    .trim()
                    .to_string(),
            );
        }
        doc.reverse();
        assert!(
            !doc.is_empty(),
            "{module}: struct {name} has no comment above it"
        );
        let mut fields = Vec::new();
        let mut word = 0u32;
        i += 1;
        while !lines[i].trim().starts_with('}') {
            let raw = lines[i];
            let (code, comment) = raw.split_once("//").unwrap_or((raw, ""));
            let code = code.trim().trim_end_matches(',');
            i += 1;
            if code.is_empty() {
                continue;
            }
            let (fname, ty) = code
                .split_once(':')
                .unwrap_or_else(|| panic!("{module}: {name}: field line {raw}"));
            let ty = ty.trim();
            let (lanes, sc) = match ty.strip_prefix("vec") {
                Some(r) => (r[..1].parse::<u32>().unwrap(), &r[2..r.len() - 1]),
                None => (1, ty),
            };
            let scalar = match sc {
                "u32" => Scalar::U32,
                "i32" => Scalar::I32,
                "f32" => Scalar::F32,
                _ => panic!("{module}: {name}: field type {ty}"),
            };
            // WGSL's uniform layout: vec2 on 2 words, vec3 and vec4 on 4.
            let align = match lanes {
                1 => 1,
                2 => 2,
                _ => 4,
            };
            word = word.next_multiple_of(align);
            assert!(
                !comment.trim().is_empty(),
                "{module}: {name}.{fname} has no comment"
            );
            fields.push(Field {
                name: fname.trim().to_string(),
                scalar,
                lanes,
                word,
                doc: comment.trim().to_string(),
            });
            word += lanes;
        }
        assert!(
            word <= 23,
            "{module}: {name} needs {word} words (23 at most: word 23 is the opaque zero)"
        );
        out.push(ParamStruct {
            name: name.to_string(),
            doc: doc.join(" "),
            fields,
        });
        i += 1;
    }
    out
}

/// WGSL comment text as rustdoc text: brackets (`x[i]`) are not links.
fn doc(s: &str) -> String {
    s.replace('[', "\\[").replace(']', "\\]")
}

/// `scan_reduce` → `ScanReduce`.
fn camel(s: &str) -> String {
    s.split('_')
        .map(|w| {
            let mut c = w.chars();
            match c.next() {
                Some(f) => f.to_ascii_uppercase().to_string() + c.as_str(),
                None => String::new(),
            }
        })
        .collect()
}

/// The group-0 bindings and the functions of one module's text.
fn scan(text: &str, module: &str) -> (Vec<Global>, Vec<Func>) {
    let lines: Vec<&str> = text.lines().collect();
    let code: Vec<&str> = lines
        .iter()
        .map(|l| l.find("//").map_or(*l, |i| &l[..i]))
        .collect();
    let mut globals = Vec::new();
    for l in &code {
        let l = l.trim();
        if let Some(rest) = l.strip_prefix("@group(0) @binding(") {
            let (num, rest) = rest.split_once(')').expect("binding number");
            let binding: u32 = num.trim().parse().expect("binding number");
            // `var<…> name: type;`
            let after = rest
                .split_once('>')
                .map(|(_, a)| a)
                .unwrap_or_else(|| panic!("{module}: unexpected binding line {l}"));
            let name = after.split(':').next().unwrap().trim().to_string();
            if let Some(g) = globals.iter().find(|g: &&Global| g.binding == binding) {
                panic!(
                    "{module}: binding {binding} declared twice ({} and {name})",
                    g.name
                );
            }
            globals.push(Global { binding, name });
        } else if l.contains("@binding(") {
            panic!("{module}: bindings must be `@group(0) @binding(N) var…` lines: {l}");
        }
    }
    // Tokens with their line, comments removed.
    let mut toks: Vec<(String, usize)> = Vec::new();
    for (ln, l) in code.iter().enumerate() {
        let mut cur = String::new();
        for ch in l.chars() {
            if ch.is_ascii_alphanumeric() || ch == '_' {
                cur.push(ch);
            } else {
                if !cur.is_empty() {
                    toks.push((std::mem::take(&mut cur), ln));
                }
                if !ch.is_whitespace() {
                    toks.push((ch.to_string(), ln));
                }
            }
        }
        if !cur.is_empty() {
            toks.push((cur, ln));
        }
    }
    let mut funcs = Vec::new();
    let mut i = 0;
    while i < toks.len() {
        if toks[i].0 != "fn" {
            i += 1;
            continue;
        }
        let name = toks[i + 1].0.clone();
        // An entry point's attributes lie between the previous item's end and `fn`.
        let entry = toks[..i]
            .iter()
            .rev()
            .take_while(|t| t.0 != "}" && t.0 != ";")
            .any(|t| t.0 == "compute");
        let entry_doc = entry.then(|| {
            // The comment lines right above the attribute line.
            let mut ln = toks[i].1;
            while ln > 0 && lines[ln - 1].trim_start().starts_with('@') {
                ln -= 1;
            }
            let mut doc = Vec::new();
            let mut k = ln;
            while k > 0 && lines[k - 1].trim_start().starts_with("//") {
                k -= 1;
                let c = lines[k].trim_start().trim_start_matches('/');
                doc.push(c.strip_prefix(' ').unwrap_or(c).to_string());
            }
            doc.reverse();
            assert!(
                !doc.is_empty(),
                "{module}: entry point {name} has no comment above it (its Kernel's doc)"
            );
            doc
        });
        // The body: from the first `{` to its match.
        let mut j = i;
        while toks[j].0 != "{" {
            j += 1;
        }
        let mut depth = 0;
        let mut idents = BTreeSet::new();
        loop {
            let t = &toks[j].0;
            if t == "{" {
                depth += 1;
            } else if t == "}" {
                depth -= 1;
                if depth == 0 {
                    break;
                }
            } else if t.starts_with(|c: char| c.is_ascii_alphabetic() || c == '_')
                && toks[j - 1].0 != "."
            {
                idents.insert(t.clone());
            }
            j += 1;
        }
        funcs.push(Func {
            name,
            entry_doc,
            idents,
        });
        i = j + 1;
    }
    (globals, funcs)
}
