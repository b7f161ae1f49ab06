//! Benchmark charts (PNG and SVG, with `plotters`): grouped bar charts, one group per
//! category (a configuration, a ray kind) and one bar per series (a level, an engine).
//!
//! Text needs a TrueType font. plotters' own font lookup links fontconfig, so instead one
//! font file is read at run time: `$RAYSPACE_FONT`, else a few common system paths. Without
//! one, charts are skipped with a message and the tables are still written.

use anyhow::{anyhow, Result};
use plotters::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

const FONT_PATHS: &[&str] = &[
    "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/TTF/DejaVuSans.ttf",
    "/usr/share/fonts/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/truetype/liberation/LiberationSans-Regular.ttf",
    "/System/Library/Fonts/Supplemental/Arial.ttf",
    "/Library/Fonts/Arial.ttf",
    "C:\\Windows\\Fonts\\arial.ttf",
];

/// Why no font could be registered for the charts.
#[derive(Clone, Debug, thiserror::Error)]
pub enum FontError {
    /// The file is not a TrueType font plotters can use.
    #[error("{0} is not a usable TrueType font")]
    Unusable(String),
    /// No candidate file exists.
    #[error("no TrueType font found (set RAYSPACE_FONT to a .ttf file; looked in {0})")]
    None(String),
}

/// Register a font for plotters once; the error says where fonts were looked for.
pub fn font() -> Result<()> {
    static FONT: OnceLock<Result<(), FontError>> = OnceLock::new();
    FONT.get_or_init(|| {
        let env = std::env::var("RAYSPACE_FONT").ok();
        let candidates: Vec<String> = env
            .iter()
            .cloned()
            .chain(FONT_PATHS.iter().map(|s| s.to_string()))
            .collect();
        for p in &candidates {
            // A font is a regular file of at most 64 MiB (a device or FIFO named by the
            // environment is not read); one named by RAYSPACE_FONT that cannot be used is
            // said, once, before the system's fonts are tried.
            let read = read_font(p);
            if let (Err(e), Some(named)) = (&read, &env) {
                if named == p {
                    eprintln!("warning: RAYSPACE_FONT={p}: {e}; trying the system's fonts");
                }
            }
            if let Ok(bytes) = read {
                let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
                return plotters::style::register_font("sans-serif", FontStyle::Normal, bytes)
                    .map_err(|_| FontError::Unusable(p.clone()));
            }
        }
        Err(FontError::None(candidates.join(", ")))
    })
    .clone()
    .map_err(|e| anyhow!(e))
}

/// The bytes of the font file `p`: a regular file of at most 64 MiB.
fn read_font(p: &str) -> std::io::Result<Vec<u8>> {
    use std::io::Read as _;
    const MAX: u64 = 64 << 20;
    let bad = |m: &str| std::io::Error::new(std::io::ErrorKind::InvalidInput, m.to_string());
    let m = std::fs::metadata(p)?;
    if !m.is_file() {
        return Err(bad("not a regular file"));
    }
    let mut bytes = Vec::new();
    std::fs::File::open(p)?
        .take(MAX + 1)
        .read_to_end(&mut bytes)?;
    if bytes.len() as u64 > MAX {
        return Err(bad("more than 64 MiB"));
    }
    Ok(bytes)
}

/// One chart's data: `values[s][g]` is series `s` in group `g`.
pub struct Bars<'a> {
    pub title: &'a str,
    pub y_label: &'a str,
    pub groups: &'a [String],
    pub series: &'a [String],
    pub values: &'a [Vec<f64>],
    /// Logarithmic y axis (for counts spanning orders of magnitude).
    pub log_y: bool,
}

const PALETTE: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
];

fn draw<DB: DrawingBackend>(root: DrawingArea<DB, plotters::coord::Shift>, b: &Bars) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let err = |e: DrawingAreaErrorKind<DB::ErrorType>| anyhow!("chart '{}': {e:?}", b.title);
    root.fill(&WHITE).map_err(err)?;
    let ng = b.groups.len().max(1);
    let ns = b.series.len().max(1);
    let finite = b
        .values
        .iter()
        .flatten()
        .copied()
        .filter(|v| v.is_finite() && *v > 0.0);
    let ymax = finite.clone().fold(0.0f64, f64::max).max(1e-9) * 1.15;
    let ymin = finite.fold(f64::INFINITY, f64::min);
    let mut cb = ChartBuilder::on(&root);
    cb.caption(b.title, ("sans-serif", 22))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(80);
    let groups = b.groups;
    let xfmt = move |x: &f64| {
        let i = (*x - 0.5).round();
        if (x - 0.5 - i).abs() < 1e-6 && i >= 0.0 && (i as usize) < groups.len() {
            groups[i as usize].clone()
        } else {
            String::new()
        }
    };
    macro_rules! body {
        ($chart:ident, $floor:expr) => {{
            $chart
                .configure_mesh()
                .disable_x_mesh()
                .x_labels(ng * 2 + 1)
                .x_label_formatter(&xfmt)
                .y_desc(b.y_label)
                .y_label_formatter(&|v: &f64| human(*v))
                .label_style(("sans-serif", 14))
                .draw()
                .map_err(err)?;
            for (s, name) in b.series.iter().enumerate() {
                let color = PALETTE[s % PALETTE.len()];
                let rects: Vec<_> = (0..ng)
                    .filter_map(|g| {
                        let v = *b.values.get(s)?.get(g)?;
                        (v.is_finite() && v > $floor).then(|| {
                            let w = 0.8 / ns as f64;
                            let x0 = g as f64 + 0.1 + s as f64 * w;
                            Rectangle::new([(x0, $floor), (x0 + w * 0.92, v)], color.filled())
                        })
                    })
                    .collect();
                $chart
                    .draw_series(rects)
                    .map_err(err)?
                    .label(name.as_str())
                    .legend(move |(x, y)| {
                        Rectangle::new([(x, y - 5), (x + 10, y + 5)], color.filled())
                    });
            }
            $chart
                .configure_series_labels()
                .position(SeriesLabelPosition::UpperLeft)
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK)
                .label_font(("sans-serif", 14))
                .draw()
                .map_err(err)?;
        }};
    }
    if b.log_y {
        let floor = if ymin.is_finite() { ymin / 2.0 } else { 0.5 };
        let mut chart = cb
            .build_cartesian_2d(0f64..ng as f64, (floor..ymax).log_scale())
            .map_err(err)?;
        body!(chart, floor);
    } else {
        let mut chart = cb
            .build_cartesian_2d(0f64..ng as f64, 0f64..ymax)
            .map_err(err)?;
        body!(chart, 0.0);
    }
    root.present().map_err(err)?;
    Ok(())
}

/// Write `stem.png` and `stem.svg`; returns their paths.
pub fn grouped_bars(stem: &Path, b: &Bars) -> Result<Vec<PathBuf>> {
    font()?;
    let w =
        (160 + 90 * b.groups.len() as u32 * (b.series.len() as u32).max(1) / 2).clamp(640, 1600);
    write_png_svg(stem, (w, 480), |a| draw(a, b), |a| draw(a, b))
}

/// Draw a chart twice, into an RGB bitmap and an SVG string, and write `stem.png` and
/// `stem.svg` atomically (as every output: `render::output::write_atomic`); returns
/// their paths.
fn write_png_svg(
    stem: &Path,
    (w, h): (u32, u32),
    bitmap: impl FnOnce(DrawingArea<BitMapBackend, plotters::coord::Shift>) -> Result<()>,
    svg: impl FnOnce(DrawingArea<SVGBackend, plotters::coord::Shift>) -> Result<()>,
) -> Result<Vec<PathBuf>> {
    let png = stem.with_extension("png");
    let svg_path = stem.with_extension("svg");
    let mut rgb = vec![0u8; w as usize * h as usize * 3];
    bitmap(BitMapBackend::with_buffer(&mut rgb, (w, h)).into_drawing_area())?;
    let png_bytes =
        render::output::rgb8_png(&rgb, w, h).map_err(|e| anyhow!("{}: {e}", png.display()))?;
    render::output::write_atomic(&png, &png_bytes).map_err(|e| anyhow!(e))?;
    let mut svg_text = String::new();
    svg(SVGBackend::with_string(&mut svg_text, (w, h)).into_drawing_area())?;
    render::output::write_atomic(&svg_path, svg_text.as_bytes()).map_err(|e| anyhow!(e))?;
    Ok(vec![png, svg_path])
}

/// One log-log chart's data: `series[s]` is a name and its (x, y) points.
pub struct Lines<'a> {
    pub title: &'a str,
    pub x_label: &'a str,
    pub y_label: &'a str,
    pub series: &'a [(String, Vec<(f64, f64)>)],
}

/// The least-squares slope of log y against log x over the positive finite points (the
/// exponent k of y ∝ x^k); `None` with fewer than two distinct x.
pub fn loglog_slope(points: &[(f64, f64)]) -> Option<f64> {
    let p: Vec<(f64, f64)> = points
        .iter()
        .filter(|(x, y)| x.is_finite() && y.is_finite() && *x > 0.0 && *y > 0.0)
        .map(|(x, y)| (x.ln(), y.ln()))
        .collect();
    let n = p.len() as f64;
    let mx = p.iter().map(|q| q.0).sum::<f64>() / n;
    let my = p.iter().map(|q| q.1).sum::<f64>() / n;
    let sxx: f64 = p.iter().map(|q| (q.0 - mx) * (q.0 - mx)).sum();
    let sxy: f64 = p.iter().map(|q| (q.0 - mx) * (q.1 - my)).sum();
    (p.len() >= 2 && sxx > 1e-12).then(|| sxy / sxx)
}

fn draw_lines<DB: DrawingBackend>(
    root: DrawingArea<DB, plotters::coord::Shift>,
    l: &Lines,
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let err = |e: DrawingAreaErrorKind<DB::ErrorType>| anyhow!("chart '{}': {e:?}", l.title);
    root.fill(&WHITE).map_err(err)?;
    let pts = || {
        l.series
            .iter()
            .flat_map(|s| s.1.iter().copied())
            .filter(|(x, y)| x.is_finite() && y.is_finite() && *x > 0.0 && *y > 0.0)
    };
    let (mut x0, mut x1, mut y0, mut y1) = (f64::INFINITY, 0.0f64, f64::INFINITY, 0.0f64);
    for (x, y) in pts() {
        (x0, x1, y0, y1) = (x0.min(x), x1.max(x), y0.min(y), y1.max(y));
    }
    if !(x0.is_finite() && y0.is_finite()) {
        (x0, x1, y0, y1) = (1.0, 10.0, 1.0, 10.0);
    }
    // A margin of a fifth of a decade each side, so end points are not on the frame.
    let (x0, x1, y0, y1) = (x0 / 1.6, x1 * 1.6, y0 / 1.6, y1 * 1.6);
    let mut chart = ChartBuilder::on(&root)
        .caption(l.title, ("sans-serif", 22))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(80)
        .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
        .map_err(err)?;
    chart
        .configure_mesh()
        .x_desc(l.x_label)
        .y_desc(l.y_label)
        .x_labels(8)
        .y_labels(8)
        .x_label_formatter(&|v: &f64| human(*v))
        .y_label_formatter(&|v: &f64| human(*v))
        .label_style(("sans-serif", 14))
        .draw()
        .map_err(err)?;
    for (i, (name, points)) in l.series.iter().enumerate() {
        let color = PALETTE[i % PALETTE.len()];
        let p: Vec<(f64, f64)> = points
            .iter()
            .copied()
            .filter(|(x, y)| x.is_finite() && y.is_finite() && *x > 0.0 && *y > 0.0)
            .collect();
        let label = match loglog_slope(&p) {
            Some(k) => format!("{name} (slope {k:.2})"),
            None => name.clone(),
        };
        chart
            .draw_series(LineSeries::new(p.clone(), color.stroke_width(2)))
            .map_err(err)?
            .label(label)
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 16, y)], color.stroke_width(2))
            });
        chart
            .draw_series(p.iter().map(|&q| Circle::new(q, 3, color.filled())))
            .map_err(err)?;
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperLeft)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font(("sans-serif", 14))
        .draw()
        .map_err(err)?;
    root.present().map_err(err)?;
    Ok(())
}

/// Write the log-log chart as `stem.svg` (and `stem.png`); returns their paths.
pub fn loglog_lines(stem: &Path, l: &Lines) -> Result<Vec<PathBuf>> {
    font()?;
    write_png_svg(stem, (760, 480), |a| draw_lines(a, l), |a| draw_lines(a, l))
}

/// A file-name-safe form of `s`.
pub fn slug(s: &str) -> String {
    s.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() {
                c.to_ascii_lowercase()
            } else {
                '-'
            }
        })
        .collect::<String>()
        .split('-')
        .filter(|p| !p.is_empty())
        .collect::<Vec<_>>()
        .join("-")
}

/// 1234567 → "1.23M": short axis labels.
pub fn human(v: f64) -> String {
    let a = v.abs();
    let (x, suffix) = if a >= 1e9 {
        (v / 1e9, "G")
    } else if a >= 1e6 {
        (v / 1e6, "M")
    } else if a >= 1e3 {
        (v / 1e3, "k")
    } else {
        (v, "")
    };
    let s = format!("{x:.2}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    format!("{s}{suffix}")
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A font named by the environment is read only as a regular file of bounded size: a
    /// device (which would read forever) is refused.
    #[test]
    fn fonts_are_regular_files() {
        let e = read_font("/dev/zero").unwrap_err().to_string();
        assert!(e.contains("not a regular file"), "{e}");
        assert!(read_font("/no/such/font.ttf").is_err());
    }
}
