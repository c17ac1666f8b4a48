//! Plots of histories: line plots written as SVG and PNG by fdem itself (no Python), for
//! `fdem plot DIR` and `sim.plot(…)`.
//!
//! A [`Figure`] is one or more panels stacked over a shared x axis, each with its own y axis
//! and a legend at its right. Text is laid out (and drawn into the PNG) with DejaVu Sans,
//! bundled in the binary (`data/fonts/`, its licence beside it), so a machine with no fonts
//! and no fontconfig draws the same picture; the SVG names the family `sans-serif`.
//!
//! What is drawn, and how it can be checked:
//! - every finite point of a series, in sample order, as one polyline (a non-finite value
//!   breaks the line there); a series of more than [`DECIMATE_FACTOR`] × width points is
//!   reduced to the first, smallest, largest and last point of each of `width` equal runs of
//!   samples, so peaks survive and the file stays small;
//! - axis labels with units: time, the energy terms and a monitor's `unit` (its CSV header
//!   says `name [unit]`) are scaled by an SI prefix where the unit takes one (`time [ms]`,
//!   `energy [kJ]`, `force [kN]`), else by a power of ten written in the label
//!   (`stress [×10³ MPa]`); a monitor given no unit says so (`platen_force (unit not
//!   recorded)`);
//! - the same figure gives the same bytes: the SVG is a deterministic function of the data.
//!
//! CSV histories are read by [`read_csv`]; [`plot_dir`] makes the standard figures of an
//! output directory (the energy account with its balance error, broken joints against time,
//! one figure per other CSV, e.g. each monitor) or one figure of chosen columns.

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters_backend::{BackendColor, BackendCoord, DrawingErrorKind};
use std::path::{Path, PathBuf};

/// Above this many points per pixel of width a series is decimated (see the module docs).
pub const DECIMATE_FACTOR: usize = 4;

/// DejaVu Sans (Bitstream Vera licence + public domain changes: data/fonts/LICENSE-DejaVu.txt).
static FONT: &[u8] = include_bytes!("../../data/fonts/DejaVuSans.ttf");

const FAMILY: &str = "sans-serif";

/// Register the bundled font with plotters (once per process).
fn register_font() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        // The bytes are a valid TrueType font (a test draws text with it); a failure here
        // would show as a "font unavailable" error of the first plot, never a panic.
        let _ = plotters::style::register_font(FAMILY, FontStyle::Normal, FONT);
    });
}

/// A quantity on an axis: its name and unit as recorded.
#[derive(Clone, Debug, PartialEq)]
pub enum Unit {
    /// An SI unit ("s", "J", "N", "m", "Pa", "m/s", …).
    Si(String),
    /// A pure number (a count, a ratio).
    None,
    /// Not recorded where the data came from (a monitor given no `unit`).
    Unknown,
    /// Several series of different units on one axis: each legend entry carries its own.
    Mixed,
    /// The label is given whole by the user: drawn as given, numbers unscaled.
    Given,
}

/// An axis: what it shows and in which unit.
#[derive(Clone, Debug, PartialEq)]
pub struct Axis {
    pub name: String,
    pub unit: Unit,
}

impl Axis {
    pub fn new(name: &str, unit: Unit) -> Self {
        Axis {
            name: name.to_string(),
            unit,
        }
    }
}

/// One line of a panel.
#[derive(Clone, Debug)]
pub struct Series {
    /// Legend entry.
    pub label: String,
    pub x: Vec<f64>,
    pub y: Vec<f64>,
}

/// One plot area: a y axis and its lines, sharing the figure's x axis.
#[derive(Clone, Debug)]
pub struct Panel {
    pub y: Axis,
    pub series: Vec<Series>,
}

/// A figure: a title, an x axis, panels stacked top to bottom, a size in pixels.
#[derive(Clone, Debug)]
pub struct Figure {
    pub title: String,
    pub x: Axis,
    pub panels: Vec<Panel>,
    pub width: u32,
    pub height: u32,
}

/// Which files to write.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    Png,
    Svg,
    Both,
}

impl Format {
    /// "png", "svg" or "both"; the error names them.
    pub fn parse(s: &str) -> Result<Format, String> {
        match s {
            "png" => Ok(Format::Png),
            "svg" => Ok(Format::Svg),
            "both" => Ok(Format::Both),
            _ => Err(format!(
                "format \"{s}\" is not one of \"png\", \"svg\", \"both\""
            )),
        }
    }
}

/// Sizes accepted for a figure (pixels).
pub const MIN_SIZE: u32 = 200;
pub const MAX_SIZE: u32 = 8000;

/// Error unless `w` × `h` is a size a figure can have.
pub fn check_size(w: u32, h: u32) -> Result<(), String> {
    if !(MIN_SIZE..=MAX_SIZE).contains(&w) || !(MIN_SIZE..=MAX_SIZE).contains(&h) {
        return Err(format!(
            "plot size {w} × {h} pixels: width and height must lie in [{MIN_SIZE}, {MAX_SIZE}]"
        ));
    }
    Ok(())
}

/// Write the figure as `<stem>.svg` and/or `<stem>.png` (each atomically); the paths written.
pub fn write(fig: &Figure, stem: &Path, format: Format) -> Result<Vec<PathBuf>, String> {
    let mut out = Vec::new();
    if let Some(dir) = stem.parent() {
        super::create_dir(dir)?;
    }
    let with_ext = |ext: &str| {
        let mut s = stem.as_os_str().to_owned();
        s.push(".");
        s.push(ext);
        PathBuf::from(s)
    };
    if format != Format::Png {
        let path = with_ext("svg");
        let svg = svg_string(fig)?;
        super::write_atomic(&path, svg.as_bytes())
            .map_err(|e| format!("writing {}: {e}", path.display()))?;
        out.push(path);
    }
    if format != Format::Svg {
        let path = with_ext("png");
        let png = png_bytes(fig)?;
        super::write_atomic(&path, &png).map_err(|e| format!("writing {}: {e}", path.display()))?;
        out.push(path);
    }
    Ok(out)
}

/// The figure as an SVG document.
pub fn svg_string(fig: &Figure) -> Result<String, String> {
    check_size(fig.width, fig.height)?;
    register_font();
    let mut s = String::new();
    {
        let root = SVGBackend::with_string(&mut s, (fig.width, fig.height)).into_drawing_area();
        draw(fig, &root)?;
        root.present().map_err(perr)?;
    }
    Ok(s)
}

/// The figure as PNG bytes (8-bit RGB).
pub fn png_bytes(fig: &Figure) -> Result<Vec<u8>, String> {
    check_size(fig.width, fig.height)?;
    register_font();
    let (w, h) = (fig.width, fig.height);
    let mut rgb = vec![255u8; (w as usize) * (h as usize) * 3];
    {
        let root = Bitmap(BitMapBackend::with_buffer(&mut rgb, (w, h))).into_drawing_area();
        draw(fig, &root)?;
        root.present().map_err(perr)?;
    }
    let mut bytes = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut bytes, w, h);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        // Plots are mostly flat colour: the best deflate with per-row filters makes them
        // several times smaller than the default, in milliseconds.
        enc.set_compression(png::Compression::Best);
        enc.set_adaptive_filter(png::AdaptiveFilterType::Adaptive);
        let mut writer = enc.write_header().map_err(|e| format!("PNG: {e}"))?;
        writer
            .write_image_data(&rgb)
            .map_err(|e| format!("PNG: {e}"))?;
    }
    Ok(bytes)
}

/// plotters' bitmap backend, with text drawn here: plotters 0.3.7 draws each ab_glyph glyph
/// from the left edge of its ink, without its side bearing, so letters sat unevenly
/// ("tim e"). Here every glyph is placed at its advance, kerned, and anti-aliased, and the
/// layout box is plotters' own (the sum of the advances by the height size / 1.24), so text
/// is where plotters measured it.
struct Bitmap<'a>(BitMapBackend<'a>);

type BitmapError = <BitMapBackend<'static> as DrawingBackend>::ErrorType;
type DrawResult = Result<(), DrawingErrorKind<BitmapError>>;

impl DrawingBackend for Bitmap<'_> {
    type ErrorType = BitmapError;

    fn get_size(&self) -> (u32, u32) {
        self.0.get_size()
    }
    fn ensure_prepared(&mut self) -> DrawResult {
        self.0.ensure_prepared()
    }
    fn present(&mut self) -> DrawResult {
        self.0.present()
    }
    fn draw_pixel(&mut self, p: BackendCoord, c: BackendColor) -> DrawResult {
        self.0.draw_pixel(p, c)
    }
    fn draw_line<S: plotters_backend::BackendStyle>(
        &mut self,
        a: BackendCoord,
        b: BackendCoord,
        s: &S,
    ) -> DrawResult {
        self.0.draw_line(a, b, s)
    }
    fn draw_rect<S: plotters_backend::BackendStyle>(
        &mut self,
        a: BackendCoord,
        b: BackendCoord,
        s: &S,
        fill: bool,
    ) -> DrawResult {
        self.0.draw_rect(a, b, s, fill)
    }
    fn draw_path<S: plotters_backend::BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        path: I,
        s: &S,
    ) -> DrawResult {
        self.0.draw_path(path, s)
    }
    fn draw_circle<S: plotters_backend::BackendStyle>(
        &mut self,
        c: BackendCoord,
        r: u32,
        s: &S,
        fill: bool,
    ) -> DrawResult {
        self.0.draw_circle(c, r, s, fill)
    }
    fn fill_polygon<S: plotters_backend::BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        vert: I,
        s: &S,
    ) -> DrawResult {
        self.0.fill_polygon(vert, s)
    }
    fn blit_bitmap(&mut self, pos: BackendCoord, size: (u32, u32), src: &[u8]) -> DrawResult {
        self.0.blit_bitmap(pos, size, src)
    }

    fn draw_text<T: plotters_backend::BackendTextStyle>(
        &mut self,
        text: &str,
        style: &T,
        pos: BackendCoord,
    ) -> DrawResult {
        use ab_glyph::{Font, ScaleFont};
        use plotters_backend::text_anchor::{HPos, VPos};
        let color = style.color();
        if color.alpha == 0.0 {
            return Ok(());
        }
        let font = ab_glyph::FontRef::try_from_slice(FONT)
            .map_err(|e| DrawingErrorKind::FontError(Box::new(e)))?;
        let size = style.size() as f32;
        let sf = font.as_scaled(size);
        // Glyphs on a baseline at the font's ascent below the top of the box.
        let mut glyphs = Vec::new();
        let mut caret = 0f32;
        let mut prev = None;
        for c in text.chars() {
            let id = sf.glyph_id(c);
            if let Some(p) = prev {
                caret += sf.kern(p, id);
            }
            glyphs.push(id.with_scale_and_position(size, ab_glyph::point(caret, sf.ascent())));
            caret += sf.h_advance(id);
            prev = Some(id);
        }
        let (width, height) = (caret as i32, (style.size() / 1.24) as i32);
        let dx = match style.anchor().h_pos {
            HPos::Left => 0,
            HPos::Right => -width,
            HPos::Center => -width / 2,
        };
        let dy = match style.anchor().v_pos {
            VPos::Top => 0,
            VPos::Center => -height / 2,
            VPos::Bottom => -height,
        };
        let trans = style.transform();
        for g in glyphs {
            let Some(outline) = font.outline_glyph(g) else {
                continue;
            };
            let b = outline.px_bounds();
            let mut pixels = Vec::new();
            outline.draw(|x, y, cov| {
                if cov > 0.02 {
                    pixels.push((b.min.x as i32 + x as i32, b.min.y as i32 + y as i32, cov));
                }
            });
            for (x, y, cov) in pixels {
                let (x, y) = trans.transform(x + dx, y + dy);
                let c = BackendColor {
                    alpha: color.alpha * cov.min(1.0) as f64,
                    rgb: color.rgb,
                };
                self.0.draw_pixel((pos.0 + x, pos.1 + y), c)?;
            }
        }
        Ok(())
    }
}

fn perr<E: std::fmt::Debug>(e: E) -> String {
    format!("drawing the plot: {e:?}")
}

/// Line colours (matplotlib's tab10, then six more).
const COLORS: [(u8, u8, u8); 16] = [
    (0x1f, 0x77, 0xb4),
    (0xff, 0x7f, 0x0e),
    (0x2c, 0xa0, 0x2c),
    (0xd6, 0x27, 0x28),
    (0x94, 0x67, 0xbd),
    (0x8c, 0x56, 0x4b),
    (0xe3, 0x77, 0xc2),
    (0x7f, 0x7f, 0x7f),
    (0xbc, 0xbd, 0x22),
    (0x17, 0xbe, 0xcf),
    (0x00, 0x00, 0x00),
    (0x00, 0x00, 0x80),
    (0x80, 0x80, 0x00),
    (0x00, 0x80, 0x80),
    (0x80, 0x00, 0x00),
    (0xff, 0x00, 0xff),
];

/// The colour of the `i`-th series of a panel.
pub fn color(i: usize) -> RGBColor {
    let (r, g, b) = COLORS[i % COLORS.len()];
    RGBColor(r, g, b)
}

/// SI prefixes by power of ten.
const PREFIXES: [(i32, &str); 8] = [
    (-12, "p"),
    (-9, "n"),
    (-6, "µ"),
    (-3, "m"),
    (3, "k"),
    (6, "M"),
    (9, "G"),
    (12, "T"),
];

/// Engineering exponent (a multiple of 3) of the largest |value|; 0 for values of order 1
/// (0.1 to 1000 are drawn as they are) and for no finite value.
fn exponent(values: impl Iterator<Item = f64>) -> i32 {
    let m = values
        .filter(|v| v.is_finite())
        .fold(0.0f64, |m, v| m.max(v.abs()));
    if m == 0.0 || (0.1..1e3).contains(&m) {
        return 0;
    }
    (m.log10() / 3.0).floor() as i32 * 3
}

/// "10⁻³" with superscript digits.
fn power_of_ten(e: i32) -> String {
    const SUP: [char; 10] = ['⁰', '¹', '²', '³', '⁴', '⁵', '⁶', '⁷', '⁸', '⁹'];
    let mut s = String::from("10");
    if e < 0 {
        s.push('⁻');
    }
    for c in e.unsigned_abs().to_string().chars() {
        s.push(SUP[c.to_digit(10).unwrap() as usize]);
    }
    s
}

/// Units an SI prefix may be put in front of: coherent SI units without a prefix of their own.
const PREFIXABLE: [&str; 10] = ["s", "m", "N", "J", "Pa", "W", "Hz", "rad", "V", "A"];

/// Whether an SI prefix can go in front of unit `u`: its first symbol is one of
/// [`PREFIXABLE`], not raised to a power (`N` → `kN`, `m/s` → `mm/s`, `N·m` → `kN·m`; not
/// `kg`, `MPa`, `g` or `m²`, where `mm²` would mean 10⁻⁶ m²).
fn takes_prefix(u: &str) -> bool {
    let end = u.find(|c: char| !c.is_alphabetic()).unwrap_or(u.len());
    let (symbol, rest) = u.split_at(end);
    PREFIXABLE.contains(&symbol) && (rest.is_empty() || rest.starts_with(['/', '·', '*', '.', ' ']))
}

/// The label of an axis whose numbers are divided by 10^e, and the e used (0 for a label the
/// user gave: numbers are drawn as they are).
fn axis_label(a: &Axis, e: i32) -> (String, i32) {
    let prefix = PREFIXES.iter().find(|p| p.0 == e).map(|p| p.1);
    match &a.unit {
        Unit::Given => (a.name.clone(), 0),
        Unit::Si(u) if e == 0 => (format!("{} [{u}]", a.name), 0),
        Unit::Si(u) if prefix.is_some() && takes_prefix(u) => {
            (format!("{} [{}{u}]", a.name, prefix.unwrap()), e)
        }
        Unit::Si(u) => (format!("{} [×{} {u}]", a.name, power_of_ten(e)), e),
        Unit::None if e == 0 => (a.name.clone(), 0),
        Unit::None => (format!("{} [×{}]", a.name, power_of_ten(e)), e),
        Unit::Unknown if e == 0 => (format!("{} (unit not recorded)", a.name), 0),
        Unit::Unknown => (
            format!("{} (×{}, unit not recorded)", a.name, power_of_ten(e)),
            e,
        ),
        Unit::Mixed if e == 0 => (format!("{} (units in the legend)", a.name), 0),
        Unit::Mixed => (
            format!("{} (×{}, units in the legend)", a.name, power_of_ten(e)),
            e,
        ),
    }
}

/// The unit a monitor or CSV header records: `"-"` is a pure number, anything else a unit.
pub fn unit_of(u: &str) -> Unit {
    if u == "-" {
        Unit::None
    } else {
        Unit::Si(u.to_string())
    }
}

/// One y axis named `name` for series on `axes`: their common unit, or [`Unit::Mixed`]
/// when they differ (label the series with [`legend_label`] then).
pub fn shared_axis(name: &str, axes: &[Axis]) -> Axis {
    let unit = match axes.first() {
        Some(a) if axes.iter().all(|b| b.unit == a.unit) => a.unit.clone(),
        _ => Unit::Mixed,
    };
    Axis::new(name, unit)
}

/// A legend entry for a series on `a`: its name, with its unit when the y axis is
/// [`Unit::Mixed`] (`force [N]`).
pub fn legend_label(a: &Axis, y: &Axis) -> String {
    match (&y.unit, &a.unit) {
        (Unit::Mixed, Unit::Si(u)) => format!("{} [{u}]", a.name),
        _ => a.name.clone(),
    }
}

/// Range of the finite values, widened by 4 % each side (a constant by ±1 or ±5 %).
fn range(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    if lo > hi {
        return (0.0, 1.0);
    }
    if lo == hi {
        let d = if lo == 0.0 { 1.0 } else { 0.05 * lo.abs() };
        return (lo - d, hi + d);
    }
    let pad = 0.04 * (hi - lo);
    (lo - pad, hi + pad)
}

/// A tick label: enough decimals for ticks `span / 10` apart, exponent form for numbers the
/// user's unscaled axis leaves very large or very small.
fn tick(v: f64, span: f64) -> String {
    let big = v.abs().max(span);
    if !(1e-3..1e5).contains(&big) {
        let s = format!("{v:.2e}");
        return s;
    }
    // About ten ticks, at a 1-2-5 spacing (as the axis draws them).
    let raw = span / 10.0;
    let decimals = if raw > 0.0 {
        let p = 10f64.powf(raw.log10().floor());
        let m = raw / p;
        let nice = p * if m < 1.5 {
            1.0
        } else if m < 3.5 {
            2.0
        } else if m < 7.5 {
            5.0
        } else {
            10.0
        };
        (-nice.log10().floor()).clamp(0.0, 9.0) as usize
    } else {
        0
    };
    let s = format!("{v:.decimals$}");
    // "-0" and "-0.00" read as 0.
    if s.trim_start_matches('-')
        .chars()
        .all(|c| c == '0' || c == '.')
    {
        return s.trim_start_matches('-').to_string();
    }
    s
}

/// The points of a series as drawn, divided by 10^ex and 10^ey: runs of finite points
/// (a non-finite x or y ends a run), decimated as the module docs say.
pub fn drawn_runs(s: &Series, ex: i32, ey: i32, width: u32) -> Vec<Vec<(f64, f64)>> {
    let (fx, fy) = (10f64.powi(-ex), 10f64.powi(-ey));
    let mut runs: Vec<Vec<(f64, f64)>> = Vec::new();
    let mut cur = Vec::new();
    for (&x, &y) in s.x.iter().zip(&s.y) {
        if x.is_finite() && y.is_finite() {
            cur.push((x * fx, y * fy));
        } else if !cur.is_empty() {
            runs.push(std::mem::take(&mut cur));
        }
    }
    if !cur.is_empty() {
        runs.push(cur);
    }
    let limit = DECIMATE_FACTOR * width as usize;
    runs.into_iter()
        .map(|r| {
            if r.len() > limit {
                decimate(&r, width as usize)
            } else {
                r
            }
        })
        .collect()
}

/// `buckets` equal runs of samples, each reduced to its first, smallest-y, largest-y and
/// last point, in sample order (duplicates dropped).
fn decimate(p: &[(f64, f64)], buckets: usize) -> Vec<(f64, f64)> {
    let n = p.len();
    let mut out = Vec::with_capacity(4 * buckets);
    for b in 0..buckets {
        let (i0, i1) = (b * n / buckets, (b + 1) * n / buckets);
        if i0 >= i1 {
            continue;
        }
        let run = &p[i0..i1];
        let lo = (0..run.len())
            .min_by(|&a, &b| run[a].1.total_cmp(&run[b].1))
            .unwrap();
        let hi = (0..run.len())
            .max_by(|&a, &b| run[a].1.total_cmp(&run[b].1))
            .unwrap();
        let mut idx = [0, lo, hi, run.len() - 1];
        idx.sort_unstable();
        let mut last = usize::MAX;
        for i in idx {
            if i != last {
                out.push(run[i]);
                last = i;
            }
        }
    }
    out
}

const TITLE_SIZE: f64 = 22.0;
const LABEL_SIZE: f64 = 15.0;
const TICK_SIZE: f64 = 13.0;
const LEGEND_SIZE: f64 = 14.0;

/// Draw the figure on a drawing area of any backend.
fn draw<DB: DrawingBackend>(fig: &Figure, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
    root.fill(&WHITE).map_err(perr)?;
    if fig.panels.is_empty() || fig.panels.iter().all(|p| p.series.is_empty()) {
        return Err("a plot needs at least one series".into());
    }
    let area = if fig.title.is_empty() {
        root.clone()
    } else {
        root.titled(&fig.title, (FAMILY, TITLE_SIZE))
            .map_err(perr)?
    };
    let all_x = || {
        fig.panels
            .iter()
            .flat_map(|p| p.series.iter().flat_map(|s| s.x.iter().copied()))
    };
    let (x_label, ex) = axis_label(&fig.x, exponent(all_x()));
    let fx = 10f64.powi(-ex);
    let (x0, x1) = range(all_x().map(|v| v * fx));
    // The legend column: as wide as the longest entry (measured with the bundled font).
    let legend_style = TextStyle::from((FAMILY, LEGEND_SIZE).into_font()).color(&BLACK);
    let mut legend_w = 0u32;
    for p in &fig.panels {
        for s in &p.series {
            let (w, _) = root
                .estimate_text_size(&s.label, &legend_style)
                .map_err(perr)?;
            legend_w = legend_w.max(w);
        }
    }
    let legend_w = (legend_w + 56).min(fig.width / 3);
    let n = fig.panels.len();
    let panels = area.split_evenly((n, 1));
    for (k, (panel, region)) in fig.panels.iter().zip(&panels).enumerate() {
        let (pw, _) = region.dim_in_pixel();
        let (plot, legend) = region.split_horizontally(pw.saturating_sub(legend_w));
        let all_y = || panel.series.iter().flat_map(|s| s.y.iter().copied());
        let (y_label, ey) = axis_label(&panel.y, exponent(all_y()));
        let fy = 10f64.powi(-ey);
        let (y0, y1) = range(all_y().map(|v| v * fy));
        let last = k + 1 == n;
        let mut chart = ChartBuilder::on(&plot)
            .margin(8)
            .margin_right(16)
            .x_label_area_size(if last { 48 } else { 24 })
            .y_label_area_size(78)
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(perr)?;
        let (xs, ys) = (x1 - x0, y1 - y0);
        let fmt_x = |v: &f64| tick(*v, xs);
        let fmt_y = |v: &f64| tick(*v, ys);
        let mut mesh = chart.configure_mesh();
        mesh.x_label_formatter(&fmt_x)
            .y_label_formatter(&fmt_y)
            .y_desc(y_label.as_str())
            .label_style((FAMILY, TICK_SIZE))
            .axis_desc_style((FAMILY, LABEL_SIZE))
            .light_line_style(RGBColor(235, 235, 235))
            .bold_line_style(RGBColor(215, 215, 215));
        if last {
            mesh.x_desc(x_label.as_str());
        }
        mesh.draw().map_err(perr)?;
        for (i, s) in panel.series.iter().enumerate() {
            let style = color(i).stroke_width(2);
            for run in drawn_runs(s, ex, ey, fig.width) {
                chart
                    .draw_series(LineSeries::new(run, style))
                    .map_err(perr)?;
            }
        }
        // Legend: a short line of the series' colour and its label, one row each.
        for (i, s) in panel.series.iter().enumerate() {
            let y = 16 + 22 * i as i32;
            legend
                .draw(&PathElement::new(
                    vec![(4, y), (32, y)],
                    color(i).stroke_width(2),
                ))
                .map_err(perr)?;
            legend
                .draw(&Text::new(
                    s.label.clone(),
                    (40, y - 8),
                    legend_style.clone(),
                ))
                .map_err(perr)?;
        }
    }
    Ok(())
}

/// A CSV file of numbers: its column names, their units and rows. A header `name [unit]`
/// is read as the column `name` in `unit` ([`super::split_unit`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Table {
    pub path: PathBuf,
    pub columns: Vec<String>,
    /// The unit of each column as its header gives it (None: the header gives none).
    pub units: Vec<Option<String>>,
    pub rows: Vec<Vec<f64>>,
}

impl Table {
    /// The values of column `name` (None if there is no such column).
    pub fn column(&self, name: &str) -> Option<Vec<f64>> {
        let i = self.columns.iter().position(|c| c == name)?;
        Some(self.rows.iter().map(|r| r[i]).collect())
    }

    /// The axis of column `name`: its unit from the header, else as [`column_axis`] knows it.
    pub fn axis(&self, name: &str) -> Axis {
        let unit = self
            .columns
            .iter()
            .position(|c| c == name)
            .and_then(|i| self.units[i].as_deref());
        column_axis(&stem_of(&self.path), name, unit)
    }
}

/// Split one CSV line into fields (RFC 4180 quotes, as [`super::csv_header`] writes them).
fn split_csv_line(line: &str) -> Vec<String> {
    let mut fields = Vec::new();
    let mut cur = String::new();
    let mut quoted = false;
    let mut chars = line.chars().peekable();
    while let Some(c) = chars.next() {
        match c {
            '"' if quoted && chars.peek() == Some(&'"') => {
                cur.push('"');
                chars.next();
            }
            '"' => quoted = !quoted,
            ',' if !quoted => fields.push(std::mem::take(&mut cur)),
            _ => cur.push(c),
        }
    }
    fields.push(cur);
    fields
}

/// Read a CSV history: a header row, then rows of numbers (`NaN`, `inf` accepted). Errors
/// name the file and line.
pub fn read_csv(path: &Path) -> Result<Table, String> {
    let text =
        std::fs::read_to_string(path).map_err(|e| format!("reading {}: {e}", path.display()))?;
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty());
    let Some((_, header)) = lines.next() else {
        return Err(format!("{}: empty file (no header row)", path.display()));
    };
    let (columns, units): (Vec<String>, Vec<Option<String>>) = split_csv_line(header)
        .into_iter()
        .map(|c| super::split_unit(c.trim()))
        .unzip();
    let mut rows = Vec::new();
    for (i, line) in lines {
        let cells: Vec<&str> = line.split(',').collect();
        if cells.len() != columns.len() {
            return Err(format!(
                "{}:{}: {} fields, the header has {}",
                path.display(),
                i + 1,
                cells.len(),
                columns.len()
            ));
        }
        let mut row = Vec::with_capacity(cells.len());
        for (c, name) in cells.iter().zip(&columns) {
            let v: f64 = c.trim().parse().map_err(|_| {
                format!(
                    "{}:{}: column '{name}': '{}' is not a number",
                    path.display(),
                    i + 1,
                    c.trim()
                )
            })?;
            row.push(v);
        }
        rows.push(row);
    }
    Ok(Table {
        path: path.to_path_buf(),
        columns,
        units,
        rows,
    })
}

/// The axis of column `column` of file `file` (its stem): in `unit` when one was recorded
/// (a monitor's `unit`, a header `name [unit]`); else fdem's own columns by name ("time" s,
/// energy terms J, "step" and counts none); anything else is not recorded.
pub fn column_axis(file: &str, column: &str, unit: Option<&str>) -> Axis {
    if let Some(u) = unit {
        return Axis::new(column, unit_of(u));
    }
    match (file, column) {
        (_, "time") => Axis::new("time", Unit::Si("s".into())),
        (_, "step") => Axis::new("step", Unit::None),
        ("energy", c) => Axis::new(c, Unit::Si("J".into())),
        ("cracks", "x" | "y" | "z") => Axis::new(column, Unit::Si("m".into())),
        ("cracks", _) => Axis::new(column, Unit::None),
        _ => Axis::new(column, Unit::Unknown),
    }
}

/// Options of [`plot_dir`] (`fdem plot`).
#[derive(Clone, Debug)]
pub struct PlotOptions {
    /// One figure of these columns instead of the standard figures: x and y columns, found
    /// in any CSV of the directory (CSVs joined on `step` when they differ).
    pub x: Option<String>,
    pub y: Vec<String>,
    /// File name (without extension) of that figure; default `<y1>_vs_<x>`.
    pub name: Option<String>,
    pub title: Option<String>,
    pub format: Format,
    pub width: u32,
    pub height: u32,
}

impl Default for PlotOptions {
    fn default() -> Self {
        PlotOptions {
            x: None,
            y: Vec::new(),
            name: None,
            title: None,
            format: Format::Both,
            width: 1000,
            height: 600,
        }
    }
}

/// The CSV files of a directory, by name (deterministic order).
fn csv_files(dir: &Path) -> Result<Vec<PathBuf>, String> {
    let rd = std::fs::read_dir(dir).map_err(|e| format!("reading {}: {e}", dir.display()))?;
    let mut v: Vec<PathBuf> = rd
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_file() && p.extension().is_some_and(|e| e == "csv"))
        .collect();
    v.sort();
    if v.is_empty() {
        return Err(format!(
            "{}: no CSV files here; give the output directory of a run (the one with energy.csv and the monitors' CSVs)",
            dir.display()
        ));
    }
    Ok(v)
}

fn stem_of(p: &Path) -> String {
    p.file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default()
}

/// The energy account: every term that is not zero throughout against time, and the
/// balance error in a panel of its own. None when the table has no rows.
pub fn energy_figure(t: &Table, width: u32, height: u32) -> Option<Figure> {
    let time = t.column("time")?;
    if time.is_empty() {
        return None;
    }
    let mut terms = Vec::new();
    for c in &t.columns {
        if matches!(c.as_str(), "step" | "time" | "balance_error") {
            continue;
        }
        let y = t.column(c)?;
        if y.iter().any(|&v| v != 0.0) {
            terms.push(Series {
                label: c.clone(),
                x: time.clone(),
                y,
            });
        }
    }
    let mut panels = Vec::new();
    if !terms.is_empty() {
        panels.push(Panel {
            y: Axis::new("energy", Unit::Si("J".into())),
            series: terms,
        });
    }
    if let Some(err) = t.column("balance_error") {
        panels.push(Panel {
            y: Axis::new("balance error", Unit::Si("J".into())),
            series: vec![Series {
                label: "balance_error".into(),
                x: time.clone(),
                y: err,
            }],
        });
    }
    (!panels.is_empty()).then(|| Figure {
        title: "Energy account".into(),
        x: Axis::new("time", Unit::Si("s".into())),
        panels,
        width,
        height,
    })
}

/// Broken joints against time (a staircase from 0 at t = 0, one step per break), None
/// without breaks.
pub fn cracks_figure(t: &Table, width: u32, height: u32) -> Option<Figure> {
    let time = t.column("time")?;
    if time.is_empty() {
        return None;
    }
    let mut sorted = time.clone();
    sorted.sort_by(f64::total_cmp);
    // From none at t = 0 (the start of the simulation), one step up per break.
    let (mut x, mut y) = (vec![0.0f64.min(sorted[0])], vec![0.0]);
    for (i, &ti) in sorted.iter().enumerate() {
        x.extend([ti, ti]);
        y.extend([i as f64, (i + 1) as f64]);
    }
    Some(Figure {
        title: "Broken joints".into(),
        x: Axis::new("time", Unit::Si("s".into())),
        panels: vec![Panel {
            y: Axis::new("broken joints", Unit::None),
            series: vec![Series {
                label: "broken joints".into(),
                x,
                y,
            }],
        }],
        width,
        height,
    })
}

/// Any other history: its columns (but `step`) against `time` (or the first column).
pub fn table_figure(t: &Table, width: u32, height: u32) -> Option<Figure> {
    if t.rows.is_empty() {
        return None;
    }
    let file = stem_of(&t.path);
    let xname = if t.columns.iter().any(|c| c == "time") {
        "time".to_string()
    } else {
        t.columns.first()?.clone()
    };
    let x = t.column(&xname)?;
    let ys: Vec<&String> = t
        .columns
        .iter()
        .filter(|c| **c != xname && *c != "step")
        .collect();
    if ys.is_empty() {
        return None;
    }
    let axes: Vec<Axis> = ys.iter().map(|c| t.axis(c)).collect();
    let y_axis = if ys.len() == 1 {
        axes[0].clone()
    } else {
        // One axis for several columns: their common unit, if all have the same.
        shared_axis(&file, &axes)
    };
    Some(Figure {
        title: file.clone(),
        x: t.axis(&xname),
        panels: vec![Panel {
            series: ys
                .iter()
                .zip(&axes)
                .map(|(c, a)| Series {
                    label: legend_label(a, &y_axis),
                    x: x.clone(),
                    y: t.column(c).unwrap(),
                })
                .collect(),
            y: y_axis,
        }],
        width,
        height,
    })
}

/// `fdem plot DIR`: the standard figures of an output directory, or with `x`/`y` one figure
/// of chosen columns. Returns the files written and notes (CSVs skipped, and why).
pub fn plot_dir(dir: &Path, o: &PlotOptions) -> Result<(Vec<PathBuf>, Vec<String>), String> {
    check_size(o.width, o.height)?;
    let files = csv_files(dir)?;
    let tables = files
        .iter()
        .map(PathBuf::as_path)
        .map(read_csv)
        .collect::<Result<Vec<_>, _>>()?;
    if o.x.is_some() || !o.y.is_empty() {
        let fig = chosen_figure(&tables, o)?;
        let name = o.name.clone().unwrap_or_else(|| {
            let plain = |c: &str| c.rsplit(':').next().unwrap_or(c).to_string();
            format!(
                "{}_vs_{}",
                plain(&o.y[0]),
                plain(o.x.as_deref().unwrap_or("time"))
            )
        });
        check_name(&name)?;
        return Ok((write(&fig, &dir.join(name), o.format)?, Vec::new()));
    }
    let mut written = Vec::new();
    let mut notes = Vec::new();
    for t in &tables {
        let file = stem_of(&t.path);
        let fig = match file.as_str() {
            // Two panels: a third taller.
            "energy" => energy_figure(t, o.width, (o.height * 4 / 3).min(MAX_SIZE)),
            "cracks" => cracks_figure(t, o.width, o.height),
            _ => table_figure(t, o.width, o.height),
        };
        match fig {
            Some(mut f) => {
                if let Some(title) = &o.title {
                    f.title = format!("{title}: {}", f.title);
                }
                written.extend(write(&f, &dir.join(&file), o.format)?);
            }
            None => notes.push(format!(
                "{}: nothing to plot (no rows, or no column besides step and time)",
                t.path.display()
            )),
        }
    }
    Ok((written, notes))
}

/// Error unless `name` is a plain file name.
pub fn check_name(name: &str) -> Result<(), String> {
    if name.is_empty()
        || name.starts_with('.')
        || name.contains(['/', '\\'])
        || name.chars().any(char::is_control)
    {
        return Err(format!(
            "plot name '{}' cannot name a file: use letters, digits, '_' or '-' (no '/', no leading '.')",
            name.escape_debug()
        ));
    }
    Ok(())
}

/// Where a column is: (table index, column name), from `column` or `file:column`. A name
/// that several files have (`strain`: the strain energy in energy.csv and a monitor named
/// strain) is the monitor's own file's (`strain.csv`), else an error asking for `file:column`.
fn find_column(tables: &[Table], spec: &str) -> Result<(usize, String), String> {
    let (file, name) = match spec.split_once(':') {
        Some((f, c)) => (Some(f), c),
        None => (None, spec),
    };
    let has = |t: &Table| t.columns.iter().any(|c| c == name);
    let found: Vec<usize> = (0..tables.len())
        .filter(|&i| has(&tables[i]) && file.is_none_or(|f| stem_of(&tables[i].path) == f))
        .collect();
    let own = found
        .iter()
        .copied()
        .find(|&i| stem_of(&tables[i].path) == name);
    match (found.len(), own) {
        (1, _) => Ok((found[0], name.to_string())),
        (_, Some(i)) => Ok((i, name.to_string())),
        (0, _) => {
            let mut all: Vec<&str> = tables
                .iter()
                .flat_map(|t| t.columns.iter().map(String::as_str))
                .collect();
            all.sort_unstable();
            all.dedup();
            Err(format!(
                "no column '{spec}' in the CSV files here; the columns are: {}",
                all.join(", ")
            ))
        }
        _ => Err(format!(
            "column '{name}' is in {}: say which with FILE:COLUMN (e.g. {}:{name})",
            found
                .iter()
                .map(|&i| format!("{}.csv", stem_of(&tables[i].path)))
                .collect::<Vec<_>>()
                .join(" and "),
            stem_of(&tables[found[0]].path)
        )),
    }
}

/// The values of `name` at the steps `steps` (from the table that has it, matched on its
/// `step` column); None where that table has no row at a step.
fn values_at_steps(t: &Table, name: &str, steps: &[f64]) -> Result<Vec<Option<f64>>, String> {
    let v = t.column(name).unwrap();
    let Some(st) = t.column("step") else {
        return Err(format!(
            "{} has no 'step' column, so its '{name}' cannot be matched with the other columns' rows",
            t.path.display()
        ));
    };
    let mut by_step: std::collections::BTreeMap<u64, f64> = Default::default();
    for (s, x) in st.iter().zip(&v) {
        // The last value at a step wins (a monitor records once a step).
        by_step.insert(*s as u64, *x);
    }
    Ok(steps
        .iter()
        .map(|s| by_step.get(&(*s as u64)).copied())
        .collect())
}

/// One figure of chosen columns: y columns against x, rows matched on `step` when the
/// columns are in different files (rows where any is missing are left out).
fn chosen_figure(tables: &[Table], o: &PlotOptions) -> Result<Figure, String> {
    if o.y.is_empty() {
        return Err("give the columns to plot with --y COLUMN[,COLUMN…] (with --x)".into());
    }
    let xspec = o.x.clone().unwrap_or_else(|| "time".into());
    let found: Vec<(usize, String)> =
        o.y.iter()
            .map(|c| find_column(tables, c))
            .collect::<Result<_, _>>()?;
    let (yi, ynames): (Vec<usize>, Vec<String>) = found.into_iter().unzip();
    // x = time or step: from the first y's own file; else the file that has it.
    let (xi, xname) = if xspec == "time" || xspec == "step" {
        (yi[0], xspec.clone())
    } else {
        find_column(tables, &xspec)?
    };
    let base = &tables[xi];
    let x_axis = base.axis(&xname);
    let x = base.column(&xname).ok_or_else(|| {
        format!(
            "{} has no '{xname}' column; its columns are: {}",
            base.path.display(),
            base.columns.join(", ")
        )
    })?;
    let same = yi.iter().all(|&i| i == xi);
    let axes: Vec<Axis> = ynames
        .iter()
        .zip(&yi)
        .map(|(c, &i)| tables[i].axis(c))
        .collect();
    let y_axis = if ynames.len() == 1 {
        axes[0].clone()
    } else {
        shared_axis(&ynames.join(", "), &axes)
    };
    let mut series = Vec::new();
    for ((name, &i), axis) in ynames.iter().zip(&yi).zip(&axes) {
        let (xs, ys): (Vec<f64>, Vec<f64>) = if same {
            (x.clone(), base.column(name).unwrap())
        } else {
            let steps = base.column("step").ok_or_else(|| {
                format!(
                    "{} has no 'step' column to match rows of other files on",
                    base.path.display()
                )
            })?;
            let y = values_at_steps(&tables[i], name, &steps)?;
            x.iter()
                .zip(y)
                .filter_map(|(&a, b)| b.map(|b| (a, b)))
                .unzip()
        };
        if xs.is_empty() {
            return Err(format!(
                "'{name}' ({}) and '{xname}' ({}) were never recorded at the same step: record them with the same `every`",
                tables[i].path.display(),
                base.path.display()
            ));
        }
        series.push(Series {
            label: legend_label(axis, &y_axis),
            x: xs,
            y: ys,
        });
    }
    Ok(Figure {
        title: o
            .title
            .clone()
            .unwrap_or_else(|| format!("{} against {xname}", ynames.join(", "))),
        x: x_axis,
        panels: vec![Panel { y: y_axis, series }],
        width: o.width,
        height: o.height,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn labels_scale_by_si_prefixes_and_say_when_the_unit_is_unknown() {
        let t = Axis::new("time", Unit::Si("s".into()));
        assert_eq!(
            axis_label(&t, exponent([2e-3, 1e-4].into_iter())),
            ("time [ms]".into(), -3)
        );
        assert_eq!(
            axis_label(&t, exponent([0.5].into_iter())),
            ("time [s]".into(), 0)
        );
        let f = Axis::new("platen_force", Unit::Unknown);
        assert_eq!(
            axis_label(&f, exponent([-2.5e6].into_iter())),
            ("platen_force (×10⁶, unit not recorded)".into(), 6)
        );
        assert_eq!(
            axis_label(&f, 0),
            ("platen_force (unit not recorded)".into(), 0)
        );
        assert_eq!(axis_label(&Axis::new("my label", Unit::Given), 6).1, 0);
    }

    /// A monitor's unit on its axis: an SI prefix where the unit takes one (the first symbol
    /// a coherent SI unit, not raised to a power), a power of ten otherwise; "-" a number.
    #[test]
    fn monitor_units_are_scaled_by_a_prefix_only_where_one_fits() {
        let label = |name: &str, unit: &str, v: f64| {
            axis_label(&Axis::new(name, unit_of(unit)), exponent([v].into_iter())).0
        };
        assert_eq!(label("force", "N", 2.5e4), "force [kN]");
        assert_eq!(label("force", "N", 250.0), "force [N]");
        assert_eq!(label("speed", "m/s", 2e-3), "speed [mm/s]");
        assert_eq!(label("moment", "N·m", 3e6), "moment [MN·m]");
        assert_eq!(label("stress", "MPa", 5e3), "stress [×10³ MPa]");
        assert_eq!(label("area", "m²", 2e-4), "area [×10⁻⁶ m²]");
        assert_eq!(label("mass", "kg", 2e3), "mass [×10³ kg]");
        assert_eq!(label("deceleration", "g", 40.0), "deceleration [g]");
        assert_eq!(label("broken", "-", 12.0), "broken");
        assert_eq!(label("broken", "-", 1.2e4), "broken [×10³]");
        // Several series: their common unit, or each unit in its legend entry.
        let (f, d) = (Axis::new("f", unit_of("N")), Axis::new("d", unit_of("m")));
        assert_eq!(
            shared_axis("f, f", &[f.clone(), f.clone()]).unit,
            Unit::Si("N".into())
        );
        let mixed = shared_axis("f, d", &[f.clone(), d.clone()]);
        assert_eq!(axis_label(&mixed, 0).0, "f, d (units in the legend)");
        assert_eq!(legend_label(&d, &mixed), "d [m]");
        assert_eq!(legend_label(&d, &Axis::new("d", unit_of("m"))), "d");
    }

    /// The header of a monitor with a unit reads back as its name and unit; a header without
    /// one (every CSV written before units, and `step`, `time`) reads as before.
    #[test]
    fn csv_headers_with_units_round_trip_and_old_headers_still_read() {
        use crate::io::{column_header, split_unit};
        for (name, unit) in [
            ("force", Some("kN")),
            ("a [b]", Some("m/s²")),
            ("x,y", Some("-")),
            ("load", None),
            ("step", None),
        ] {
            let h = column_header(name, unit);
            assert_eq!(
                split_unit(&h),
                (name.to_string(), unit.map(str::to_string)),
                "{h}"
            );
        }
        assert_eq!(
            split_unit("q []"),
            ("q []".to_string(), None),
            "no empty unit"
        );
        let dir = std::env::temp_dir().join(format!("fdem-plot-units-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let new = dir.join("load.csv");
        let header = crate::io::csv_header(&["step", "time", &column_header("load", Some("kN"))]);
        std::fs::write(&new, format!("{header}0,0,1.5\n")).unwrap();
        let t = read_csv(&new).unwrap();
        assert_eq!(t.columns, ["step", "time", "load"]);
        assert_eq!(t.units, [None, None, Some("kN".to_string())]);
        assert_eq!(t.axis("load"), Axis::new("load", Unit::Si("kN".into())));
        assert_eq!(t.axis("time"), Axis::new("time", Unit::Si("s".into())));
        let old = dir.join("old.csv");
        std::fs::write(&old, "step,time,load\n0,0,1.5\n").unwrap();
        let t = read_csv(&old).unwrap();
        assert_eq!(t.columns, ["step", "time", "load"]);
        assert_eq!(t.units, [None, None, None]);
        assert_eq!(t.axis("load"), Axis::new("load", Unit::Unknown));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn decimation_keeps_the_extremes_and_the_ends() {
        // A spike in the middle of 10 000 samples survives decimation to 100 runs.
        let mut p: Vec<(f64, f64)> = (0..10_000).map(|i| (i as f64, 0.0)).collect();
        p[5_123].1 = 7.0;
        p[777].1 = -3.0;
        let d = decimate(&p, 100);
        assert!(d.len() <= 400);
        assert_eq!(d[0], p[0]);
        assert_eq!(*d.last().unwrap(), p[9_999]);
        assert!(d.contains(&p[5_123]) && d.contains(&p[777]));
        assert!(d.windows(2).all(|w| w[0].0 < w[1].0), "sample order kept");
    }

    #[test]
    fn csv_headers_with_quotes_split_as_written() {
        let h = crate::io::csv_header(&["step", "a,b", "say \"hi\""]);
        assert_eq!(split_csv_line(h.trim_end()), ["step", "a,b", "say \"hi\""]);
    }
}
