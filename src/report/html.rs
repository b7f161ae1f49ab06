//! The report's page: one static HTML file, with its images and SVG charts beside it.
//!
//! No script and no network: the page is the numbers of `report.json` laid out, each table
//! beside the published figures it reproduces ([`super::published`]). Cells that the
//! browser test checks against `report.json` carry stable ids (`render-…-tests`,
//! `rsh-…-pct`, `slope-…`).

use super::published;
use super::ray_hierarchy::RayHierarchy;
use super::Report;
use crate::bench::charts::slug;
use std::fmt::Write;

/// Text as HTML (element content and attribute values alike).
pub fn esc(s: &str) -> String {
    let mut o = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => o.push_str("&amp;"),
            '<' => o.push_str("&lt;"),
            '>' => o.push_str("&gt;"),
            '"' => o.push_str("&quot;"),
            '\'' => o.push_str("&#39;"),
            c => o.push(c),
        }
    }
    o
}

/// Ours ÷ published, or a dash.
fn ratio(ours: f64, published: Option<f64>) -> String {
    match published {
        Some(p) if p > 0.0 => format!("{:.2}", ours / p),
        _ => "—".into(),
    }
}

fn opt(v: Option<f64>, digits: usize) -> String {
    v.map_or("—".into(), |x| format!("{x:.digits$}"))
}

const STYLE: &str = "body{font-family:system-ui,sans-serif;margin:2em auto;max-width:1200px;color:#222;line-height:1.4}
table{border-collapse:collapse;margin:.6em 0 1.4em}th,td{border:1px solid #ccc;padding:.25em .55em;text-align:right}
th{background:#f2f2f2}td:first-child,th:first-child{text-align:left}.pub{background:#fff8e0}
img.r{width:192px;image-rendering:pixelated;border:1px solid #999}img.c{max-width:100%}
figure{display:inline-block;margin:.3em;text-align:center;font-size:.85em}.note{color:#555;font-size:.9em}
nav a{margin-right:1em}code{background:#f4f4f4;padding:0 .2em}";

/// The whole page.
pub fn page(r: &Report) -> String {
    let mut h = String::new();
    let _ = write!(
        h,
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>rayspace report</title><link rel=\"icon\" href=\"data:,\"><style>{STYLE}</style></head><body>\n<h1>rayspace report{}</h1>\n<p id=\"provenance\">{}</p>\n<p class=\"note\">Made by <code>rayspace report{}</code> in {:.1} s. Every number here is in <a href=\"report.json\">report.json</a>. Published figures are shaded; ratios are ours ÷ published.</p>\n<nav><a href=\"#scenes\">Renders</a><a href=\"#thesis\">CRSH thesis, chapter 4</a><a href=\"#pays\">When a ray hierarchy pays</a><a href=\"#grid\">Irregular grids, Tables 1–5</a><a href=\"#scaling\">Scaling</a><a href=\"#generated\">Generated scenes</a></nav>\n",
        if r.quick { " (quick)" } else { "" },
        esc(&r.provenance),
        if r.quick { " --quick" } else { "" },
        r.seconds
    );
    if let Some(n) = &r.charts_note {
        let _ = writeln!(h, "<p class=\"note\">{}</p>", esc(n));
    }
    scenes(&mut h, r);
    thesis(&mut h, r);
    pays(&mut h, &r.ray_hierarchy, r.side);
    grid(&mut h, r);
    scaling(&mut h, r);
    generated(&mut h, r);
    h.push_str("</body></html>\n");
    h
}

fn charts(h: &mut String, r: &Report, section: &str, alt: &str) {
    for (_, f) in r.charts.iter().filter(|(s, _)| s == section) {
        let _ = writeln!(
            h,
            "<p><img class=\"c\" src=\"{}\" alt=\"{}\"></p>",
            esc(f),
            esc(alt)
        );
    }
}

fn scenes(h: &mut String, r: &Report) {
    h.push_str("<h2 id=\"scenes\">Renders</h2>\n<p class=\"note\">Each scene rendered by every engine on the same rays (rasterized primaries, shadow rays, reflection and refraction generations). The difference image is |engine − reference| per channel × 8: all black when the engines agree, which ours must (CRSH, RAH and the grids return brute force's hits bit for bit); the peers (obvhs, Embree) agree within their stated tolerance, where a ray on an edge shared by two triangles may report the other one.</p>\n");
    for s in &r.scenes {
        let id = &s.id;
        let _ = writeln!(
            h,
            "<h3 id=\"scene-{id}\">{} — {} triangles, {}×{}, {} bounces (reference: {})</h3>",
            esc(&s.name),
            s.triangles,
            s.width,
            s.height,
            s.bounces,
            esc(&s.reference)
        );
        h.push_str("<table><tr><th>engine</th><th>image</th><th>difference to the reference</th><th>build ms</th><th>render ms</th><th>rays</th><th>tests</th><th>differing pixels</th><th>max channel difference</th></tr>\n");
        for x in &s.renders {
            let e = slug(&x.engine);
            let diff = x
                .diff_image
                .as_ref()
                .map_or("(reference)".to_string(), |d| {
                    format!(
                        "<img class=\"r\" src=\"{}\" alt=\"difference {}\">",
                        esc(d),
                        esc(&x.engine)
                    )
                });
            let _ = writeln!(
                h,
                "<tr><td>{}{}</td><td><img class=\"r\" src=\"{}\" alt=\"{} render\"></td><td>{diff}</td><td>{:.1}</td><td>{:.1}</td><td>{}</td><td id=\"render-{id}-{e}-tests\">{}</td><td id=\"render-{id}-{e}-differing\">{}</td><td>{}</td></tr>",
                esc(&x.engine),
                if x.exact { "" } else { " (peer)" },
                esc(&x.image),
                esc(&x.engine),
                x.build_ms,
                x.render_ms,
                x.rays,
                x.total_tests,
                x.differing_pixels,
                x.max_channel_difference
            );
        }
        h.push_str("</table>\n");
        for (e, why) in &s.skipped {
            let _ = writeln!(h, "<p class=\"note\">{} not run: {}</p>", esc(e), esc(why));
        }
        h.push_str("<p>Where each ray kind was traced (rays per pixel, brighter = more):</p>\n");
        for k in &s.ray_kinds {
            let _ = writeln!(
                h,
                "<figure><img class=\"r\" src=\"{}\" alt=\"{} rays\"><figcaption>{} ({} rays)</figcaption></figure>",
                esc(&k.image),
                esc(&k.kind),
                esc(&k.kind),
                k.rays
            );
        }
    }
}

fn thesis(h: &mut String, r: &Report) {
    h.push_str("<h2 id=\"thesis\">CRSH thesis, chapter 4: intersection tests as % of brute force</h2>\n<p class=\"note\">Our renders: shadow rays plus one reflection/refraction generation, at the size above; the thesis's: 512×512, OFFICE and SPONZA shadow rays, CORNELL shadow and reflection rays (Tables 4.4–4.24; Sponza there is the same 66 k-triangle Dabrovic model). “+BVH” is the object hierarchy of the thesis's §5.1 future work, which the thesis did not have.</p>\n");
    let mut scenes: Vec<&str> = r.rsh.iter().map(|x| x.scene.as_str()).collect();
    scenes.dedup();
    for sc in scenes {
        let id = slug(sc);
        let _ = writeln!(h, "<h3>{}</h3>", esc(sc));
        h.push_str("<table><tr><th>B/D</th><th>thesis table</th><th>CRSH %</th><th class=\"pub\">thesis CRSH %</th><th>ratio</th><th>RAH %</th><th class=\"pub\">thesis RAH %</th><th>ratio</th><th>RAH ÷ CRSH tests</th><th>CRSH+BVH %</th><th>RAH+BVH %</th><th>CRSH ms</th><th>CRSH+BVH build + trace ms</th></tr>\n");
        let rows: Vec<&crate::bench::rsh::Row> = r.rsh.iter().filter(|x| x.scene == sc).collect();
        for quad in rows.chunks(4) {
            let find = |engine: &str, objects: &str| {
                quad.iter()
                    .find(|x| x.engine == engine && x.objects == objects)
                    .copied()
            };
            let (Some(c), Some(a), Some(cb), Some(ab)) = (
                find("crsh", "mesh-spheres"),
                find("rah", "mesh-spheres"),
                find("crsh", "bvh"),
                find("rah", "bvh"),
            ) else {
                continue;
            };
            let (b, d) = (c.branching, c.levels);
            let p = published::thesis(sc, b, d);
            let pct = |x: &crate::bench::rsh::Row| {
                format!(
                    "<td id=\"rsh-{id}-{}-{}-{b}-{d}-pct\">{:.3}</td>",
                    x.engine, x.objects, x.percent_of_brute_force
                )
            };
            let _ = writeln!(
                h,
                "<tr><td>{b}/{d}</td><td>{}</td>{}<td class=\"pub\">{}</td><td>{}</td>{}<td class=\"pub\">{}</td><td>{}</td><td>{:.2}</td>{}{}<td>{:.0}</td><td>{:.0}</td></tr>",
                p.map_or("—".into(), |x| x.0.to_string()),
                pct(c),
                opt(p.map(|x| x.2), 2),
                ratio(c.percent_of_brute_force, p.map(|x| x.2)),
                pct(a),
                opt(p.map(|x| x.1), 2),
                ratio(a.percent_of_brute_force, p.map(|x| x.1)),
                a.total_tests as f64 / c.total_tests.max(1) as f64,
                pct(cb),
                pct(ab),
                c.trace_seconds * 1e3,
                (cb.build_seconds + cb.trace_seconds) * 1e3
            );
        }
        h.push_str("</table>\n");
    }
    h.push_str("<h3>Intersections per hierarchy level (log scale; thesis Figures 4.7–4.23)</h3>\n");
    charts(h, r, "rsh-levels", "intersections per level");
    h.push_str("<h3>Phase times</h3>\n");
    charts(h, r, "rsh-phases", "phase times");
}

fn grid(h: &mut String, r: &Report) {
    h.push_str("<h2 id=\"grid\">Irregular grids (Pérard-Gayot et al. 2017), Tables 1, 2, 3 and 5</h2>\n<p class=\"note\">Ours: this machine's CPU at the size above. Published: a GeForce Titan X at 1024×1024 on the 262 k-triangle Crytek Sponza and the 283 k-triangle Conference (our Sponza is the 66 k-triangle Dabrovic model), so MRays/s ratios measure the hardware as much as the method; N_T and N_I are comparable.</p>\n");
    let mut scenes: Vec<&str> = r.grid_builds.iter().map(|x| x.scene.as_str()).collect();
    scenes.dedup();
    for sc in scenes {
        let _ = writeln!(h, "<h3>{}</h3>", esc(sc));
        let rows = |t: &'static str| {
            r.grid_builds
                .iter()
                .filter(move |x| x.scene == sc && x.table == t)
        };
        let sponza = published::grid_scene(sc) == Some("sponza");
        h.push_str("<h4>Table 1: per primary ray after each build stage</h4><table><tr><th>stage</th><th>cells</th><th>N_T</th><th class=\"pub\">paper N_T</th><th>N_I</th><th class=\"pub\">paper N_I</th><th>MRays/s</th><th class=\"pub\">paper MRays/s</th><th>build ms</th></tr>\n");
        for (i, x) in rows("1").enumerate() {
            let p = sponza
                .then(|| published::GRID_TABLE1_SPONZA.get(i).copied())
                .flatten();
            let _ = writeln!(
                h,
                "<tr><td>{}</td><td>{}</td><td>{:.2}</td><td class=\"pub\">{}</td><td>{:.2}</td><td class=\"pub\">{}</td><td>{:.2}</td><td class=\"pub\">{}</td><td>{:.1}</td></tr>",
                esc(&x.variant),
                x.cells,
                x.n_t,
                opt(p.map(|p| p.0), 0),
                x.n_i,
                opt(p.map(|p| p.1), 0),
                x.mrays_per_s,
                opt(p.map(|p| p.2), 0),
                x.build_seconds * 1e3
            );
        }
        h.push_str("</table>\n<h4>Table 2: build time, memory and traversal over densities</h4><table><tr><th>structure</th><th>λ₁</th><th>λ₂</th><th>cells</th><th>build ms</th><th>memory MB</th><th>N_T</th><th>N_I</th><th>MRays/s</th></tr>\n");
        for x in rows("2") {
            let _ = writeln!(
                h,
                "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{:.1}</td><td>{:.2}</td><td>{:.2}</td><td>{:.2}</td><td>{:.2}</td></tr>",
                esc(&x.variant),
                x.top_density,
                x.leaf_density,
                x.cells,
                x.build_seconds * 1e3,
                x.memory_bytes as f64 / 1048576.0,
                x.n_t,
                x.n_i,
                x.mrays_per_s
            );
        }
        h.push_str("</table>\n");
        if let Some(t) = published::grid_scene(sc) {
            let _ = writeln!(
                h,
                "<p class=\"note pub\">Published (Table 2, {t}, densities λ₁ ∈ [0.012, 0.12], λ₂ ∈ [0.24, 2.4]): {}</p>",
                if t == "sponza" {
                    "build 12–26 ms (two-level grid 7 ms), 201–653 MRays/s, 4–23 MB"
                } else {
                    "build 16–22 ms (two-level grid 7 ms), 182–597 MRays/s, 4–12 MB"
                }
            );
        }
        h.push_str("<h4>Table 3: MRays/s per engine and ray kind</h4><table><tr><th>engine</th><th>ray kind</th><th>MRays/s</th><th class=\"pub\">paper (irregular grid)</th><th>ratio</th><th>N_T</th><th>N_I</th><th>build ms</th><th>disagreements (edge/coincident/wrong)</th></tr>\n");
        for x in r.grid_perf.iter().filter(|x| x.scene == sc) {
            let p = (x.engine == "grid")
                .then(|| published::grid_table3(sc, &x.kind))
                .flatten();
            let _ = writeln!(
                h,
                "<tr><td>{}</td><td>{}</td><td>{:.2}</td><td class=\"pub\">{}</td><td>{}</td><td>{}</td><td>{}</td><td>{:.1}</td><td>{}/{}/{}</td></tr>",
                esc(&x.engine),
                esc(&x.kind),
                x.mrays_per_s,
                opt(p, 0),
                ratio(x.mrays_per_s, p),
                opt(x.n_t, 2),
                opt(x.n_i, 2),
                x.build_seconds * 1e3,
                x.at_edges,
                x.coincident,
                x.wrong
            );
        }
        h.push_str("</table>\n<h4>Table 5: merge (M) and expansion (E) on a uniform grid (λ = 5), and Devillers's macro regions</h4><table><tr><th>variant</th><th>cells</th><th>MRays/s</th><th class=\"pub\">paper MRays/s</th><th>ratio</th><th>memory MB</th><th class=\"pub\">paper MB</th><th>N_T</th><th>N_I</th></tr>\n");
        for x in rows("5") {
            let p = published::grid_table5(sc, &x.variant);
            let _ = writeln!(
                h,
                "<tr><td>{}</td><td>{}</td><td>{:.2}</td><td class=\"pub\">{}</td><td>{}</td><td>{:.2}</td><td class=\"pub\">{}</td><td>{:.2}</td><td>{:.2}</td></tr>",
                esc(&x.variant),
                x.cells,
                x.mrays_per_s,
                opt(p.map(|p| p.0), 0),
                ratio(x.mrays_per_s, p.map(|p| p.0)),
                x.memory_bytes as f64 / 1048576.0,
                opt(p.map(|p| p.1), 0),
                x.n_t,
                x.n_i
            );
        }
        h.push_str("</table>\n");
    }
    h.push_str("<h3>MRays/s by ray kind</h3>\n");
    charts(h, r, "grid-mrays", "MRays/s by ray kind");
}

fn scaling(h: &mut String, r: &Report) {
    let s = &r.scaling;
    let tri = s.triangles.first().map_or(0, |p| p.pixels);
    let pix = s.pixels.first().map_or(0, |p| p.triangles);
    let _ = writeln!(
        h,
        "<h2 id=\"scaling\">Scaling: how each engine's frame cost grows</h2>\n<p class=\"note\">The <code>spheres</code> scene tessellated from {} to {} triangles at {} pixels, and at {} triangles from {} to {} pixels; one frame each (engine build + raster + shadow rays + one reflection/refraction generation), one run per point. Tests: CRSH and RAH count every node and triangle test, the grid its triangle tests (its traversal steps visit cells); the BVH peers are left out (their box tests are not counted); brute force's are rays × triangles of the same frames. The slope k is the least-squares fit of log y = k log x + c: 1 is linear growth.</p>",
        s.triangles.first().map_or(0, |p| p.triangles),
        s.triangles.last().map_or(0, |p| p.triangles),
        tri,
        pix,
        s.pixels.first().map_or(0, |p| p.pixels),
        s.pixels.last().map_or(0, |p| p.pixels)
    );
    for (axis, measure) in [
        ("triangles", "seconds"),
        ("triangles", "tests"),
        ("pixels", "seconds"),
        ("pixels", "tests"),
    ] {
        charts(
            h,
            r,
            &format!("scaling-{measure}-{axis}"),
            &format!("{measure} against {axis}"),
        );
    }
    h.push_str("<table><tr><th>engine</th><th>measure</th><th>slope against triangles</th><th>slope against pixels</th></tr>\n");
    let mut keys: Vec<(&str, &str)> = Vec::new();
    for x in &s.slopes {
        if !keys.contains(&(x.engine.as_str(), x.measure.as_str())) {
            keys.push((x.engine.as_str(), x.measure.as_str()));
        }
    }
    for (e, m) in keys {
        let cell = |axis: &str| {
            let id = format!("slope-{axis}-{m}-{}", slug(e));
            let v = s
                .slopes
                .iter()
                .find(|x| x.engine == e && x.measure == m && x.axis == axis)
                .map_or("—".to_string(), |x| format!("{:.2}", x.slope));
            format!("<td id=\"{id}\">{v}</td>")
        };
        let _ = writeln!(
            h,
            "<tr><td>{}</td><td>{m}</td>{}{}</tr>",
            esc(e),
            cell("triangles"),
            cell("pixels")
        );
    }
    h.push_str("</table>\n<h3>Points</h3><table><tr><th>axis</th><th>engine</th><th>triangles</th><th>pixels</th><th>rays</th><th>build ms</th><th>frame ms</th><th>tests</th></tr>\n");
    for (axis, pts) in [("triangles", &s.triangles), ("pixels", &s.pixels)] {
        for p in pts.iter() {
            let _ = writeln!(
                h,
                "<tr><td>{axis}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{:.1}</td><td>{:.1}</td><td>{}</td></tr>",
                esc(&p.engine),
                p.triangles,
                p.pixels,
                p.rays,
                p.build_seconds * 1e3,
                p.frame_seconds * 1e3,
                p.total_tests.map_or("—".into(), |t| t.to_string())
            );
        }
    }
    h.push_str("</table>\n");
}

/// `bench scale` on the generated scenes: per generator and size, each engine's build,
/// structure, MRays/s and tests per ray, the rows whose hits disagree with the grid's, and
/// the fitted slopes against the triangle count.
fn generated(h: &mut String, r: &Report) {
    let mut sizes: Vec<u64> = r.generated.iter().map(|x| x.triangles).collect();
    sizes.sort_unstable();
    let _ = writeln!(
        h,
        "<h2 id=\"generated\">Generated scenes: {} to {} triangles</h2>\n<p class=\"note\">The irregular-grid paper's scene classes made by <code>scene::generate</code> (a hairball of thin tangled tubes, a city of many mid-size objects, a scene nested in scaled copies of itself), as <code>rayspace bench scale</code> runs them: every engine built on the same scene and traced on the same primary, shadow (any hit) and random rays, one run each; hits checked against the irregular grid's (<em>wrong</em>: records beyond the peers' tolerance). Peak memory is <code>bench scale</code>'s (a child process per engine), not measured here. The slope k fits log y = k log triangles + c: 1 is linear growth.</p>",
        sizes.first().copied().unwrap_or(0),
        sizes.last().copied().unwrap_or(0)
    );
    charts(
        h,
        r,
        "generated",
        "build time and random rays against triangles",
    );
    h.push_str("<table><tr><th>scene</th><th>triangles</th><th>engine</th><th>build ms</th><th>structure B/triangle</th><th>primary MRays/s</th><th>shadow MRays/s</th><th>random MRays/s</th><th>tests/ray (random)</th><th>wrong</th></tr>\n");
    for x in &r.generated {
        let id = format!(
            "generated-{}-{}-{}",
            slug(&x.generator),
            x.requested,
            slug(&x.engine)
        );
        let opt = |v: Option<f64>| v.map_or("—".to_string(), |v| format!("{v:.1}"));
        let _ = writeln!(
            h,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{:.1}</td><td>{}</td><td>{:.2}</td><td>{:.2}</td><td>{:.2}</td><td>{}</td><td id=\"{id}-wrong\">{}</td></tr>",
            esc(&x.generator),
            x.triangles,
            esc(&x.engine),
            x.build_ms,
            opt(x.structure_bytes_per_triangle),
            x.primary_mrays,
            x.shadow_mrays,
            x.random_mrays,
            opt(x.random_tests_per_ray),
            x.wrong
        );
    }
    h.push_str("</table>\n<h3>Slopes against the triangle count</h3><table><tr><th>scene</th><th>engine</th><th>measure</th><th>slope</th></tr>\n");
    for x in &r.generated_slopes {
        let _ = writeln!(
            h,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{:.2}</td></tr>",
            esc(&x.generator),
            esc(&x.engine),
            esc(&x.measure),
            x.slope
        );
    }
    h.push_str("</table>\n");
}

/// "When does a ray-space hierarchy pay?" ([`super::ray_hierarchy`]): a table per scene,
/// CRSH's and RAH's rows beside `bvh`'s, and the thesis's claim. Cells the browser test reads carry ids
/// (`pays-{scene}-{kind}-{engine}-tests`, `…-ns`).
fn pays(h: &mut String, r: &RayHierarchy, side: u32) {
    h.push_str("<h2 id=\"pays\">When does a ray-space hierarchy pay?</h2>\n");
    let _ = writeln!(
        h,
        "<p class=\"note\">The rays a CRSH render of each scene traces at {side}×{side} (shadow rays, then the reflection and refraction generations), split by kind and traced in the render's batches by CRSH and RAH (their ray hierarchies over the per-frame object tree: the dual traversal) and by <code>bvh</code> (the same kind of tree walked by packets and single rays, no ray hierarchy). The ray side is the hierarchy's construction (hash, trim, compress, sort, decompress or screen order, hierarchy creation); CRSH against RAH over the same tree is what the hash and sort buy over screen order, with and without their cost. Every engine's records equal brute force's. The best of the runs; tests are counted once each (node, ray–box, ray–triangle).</p>"
    );
    let mut scenes: Vec<&str> = r.rows.iter().map(|x| x.scene.as_str()).collect();
    scenes.dedup();
    for sc in scenes {
        let _ = writeln!(
            h,
            "<h3>{}</h3>\n<table><tr><th>rays</th><th>engine</th><th>rays</th><th>node tests</th><th>ray–box tests</th><th>ray–triangle tests</th><th>all tests</th><th>ray side ms</th><th>traversal ms</th><th>total ms</th><th>ns per ray</th><th>÷ bvh time</th></tr>",
            esc(sc)
        );
        for x in r.rows.iter().filter(|x| x.scene == sc) {
            let bvh = r
                .rows
                .iter()
                .find(|y| y.scene == x.scene && y.kind == x.kind && y.engine == "bvh")
                .map(|y| y.total_ms);
            let id = format!("pays-{}-{}-{}", slug(&x.scene), x.kind, x.engine);
            let _ = writeln!(
                h,
                "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td id=\"{id}-tests\">{}</td><td>{:.2}</td><td>{:.2}</td><td>{:.2}</td><td id=\"{id}-ns\">{:.1}</td><td>{}</td></tr>",
                x.kind,
                x.engine,
                x.rays,
                x.node_tests,
                x.ray_box_tests,
                x.ray_tri_tests,
                x.tests,
                x.ray_side_ms,
                x.trace_ms,
                x.total_ms,
                x.ns_per_ray,
                bvh.map_or("—".into(), |b| format!("{:.2}", x.total_ms / b.max(1e-9)))
            );
        }
        h.push_str("</table>\n");
    }
    if !r.claim.is_empty() {
        h.push_str("<p class=\"note\">The thesis's claim (Tables 4.4–4.24): with mesh spheres, its own object side, CRSH makes fewer tests than RAH. From this report's chapter-4 rows:</p>\n<table><tr><th>scene</th><th>B × D</th><th>CRSH tests</th><th>RAH tests</th><th>RAH ÷ CRSH</th><th>CRSH fewer</th></tr>\n");
        for c in &r.claim {
            let _ = writeln!(
                h,
                "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{:.2}</td><td>{}</td></tr>",
                esc(&c.scene),
                c.config,
                c.crsh_tests,
                c.rah_tests,
                c.rah_tests as f64 / c.crsh_tests.max(1) as f64,
                if c.holds { "yes" } else { "no" }
            );
        }
        h.push_str("</table>\n");
    }
}
