//! Plots for the fit report: SVG line charts written by hand, and colour pictures of the table.
//!
//! No plotting crate and no fonts: [`LinePlot::to_svg`] writes a small, self-contained SVG
//! (text is drawn by whatever opens it), and the image helpers return [`image::RgbImage`]s for
//! the caller to save as PNG.
//!
//! ```
//! use cdrf_fit::plot::{LinePlot, LineStyle, Series, PALETTE};
//!
//! let curve: Vec<(f32, f32)> = (0..=180).map(|d| (d as f32, (d as f32).to_radians().cos().max(0.0))).collect();
//! let svg = LinePlot::new("Lambert", "θ (degrees)", "radiance")
//!     .with_series(Series::new("cos θ", PALETTE[1], curve).with_style(LineStyle::Dashed))
//!     .to_svg();
//! assert!(svg.starts_with("<svg"));
//! ```

use std::fmt::Write as _;

use cdrf_core::image_file::linear_to_srgb;
use glam::Vec3;
use image::{Rgb, RgbImage};

/// A colour-blind-safe cycle for unrelated series (Okabe & Ito): black, orange, sky blue,
/// bluish green, yellow, blue, vermillion, reddish purple. For series ordered by a quantity
/// (sphere radius), [`Colormap::color_at`] is the better choice.
pub const PALETTE: [[u8; 3]; 8] = [
    [0, 0, 0],
    [230, 159, 0],
    [86, 180, 233],
    [0, 158, 115],
    [240, 228, 66],
    [0, 114, 178],
    [213, 94, 0],
    [204, 121, 167],
];

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LineStyle {
    /// A solid line through the points.
    #[default]
    Solid,
    /// A dashed line through the points.
    Dashed,
    /// A small dot at each point, no line.
    Markers,
    /// A thin, faint line: the edge of a confidence band.
    Faint,
}

/// One curve of a [`LinePlot`].
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    /// Legend entry (an empty label leaves the series out of the legend).
    pub label: String,
    /// sRGB colour.
    pub color: [u8; 3],
    /// `(x, y)` in data units. Non-finite points (and, on a log axis, `y ≤ 0`) break the line.
    pub points: Vec<(f32, f32)>,
    /// How the series is drawn.
    pub style: LineStyle,
}

impl Series {
    /// A solid line.
    pub fn new(label: impl Into<String>, color: [u8; 3], points: Vec<(f32, f32)>) -> Self {
        Self {
            label: label.into(),
            color,
            points,
            style: LineStyle::Solid,
        }
    }

    /// The same series drawn with `style`.
    pub fn with_style(mut self, style: LineStyle) -> Self {
        self.style = style;
        self
    }
}

/// A line chart with axes, nice ticks, labels, a title and a legend; see [`LinePlot::to_svg`].
#[derive(Debug, Clone, PartialEq)]
pub struct LinePlot {
    /// Title above the plot.
    pub title: String,
    /// Label under the x axis.
    pub x_label: String,
    /// Label beside the y axis.
    pub y_label: String,
    /// Visible x range; `None` (or an empty/invalid range) fits the data, widened to whole ticks.
    pub x_range: Option<(f32, f32)>,
    /// Visible y range; `None` (or an empty/invalid range) fits the data, widened to whole
    /// ticks (to whole decades on a log axis).
    pub y_range: Option<(f32, f32)>,
    /// Logarithmic y axis (values ≤ 0 are skipped).
    pub log_y: bool,
    /// The curves, drawn in order (later on top).
    pub series: Vec<Series>,
    /// Width of the SVG in pixels (default 720).
    pub width_px: u32,
    /// Height of the SVG in pixels (default 480).
    pub height_px: u32,
}

impl Default for LinePlot {
    fn default() -> Self {
        Self {
            title: String::new(),
            x_label: String::new(),
            y_label: String::new(),
            x_range: None,
            y_range: None,
            log_y: false,
            series: Vec::new(),
            width_px: 720,
            height_px: 480,
        }
    }
}

impl LinePlot {
    /// An empty 720 × 480 plot with a title and axis labels.
    pub fn new(
        title: impl Into<String>,
        x_label: impl Into<String>,
        y_label: impl Into<String>,
    ) -> Self {
        Self {
            title: title.into(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            ..Self::default()
        }
    }

    /// Fixes the visible x range.
    pub fn with_x_range(mut self, min: f32, max: f32) -> Self {
        self.x_range = Some((min, max));
        self
    }

    /// Fixes the visible y range.
    pub fn with_y_range(mut self, min: f32, max: f32) -> Self {
        self.y_range = Some((min, max));
        self
    }

    /// Switches the y axis to a logarithmic scale.
    pub fn with_log_y(mut self, log_y: bool) -> Self {
        self.log_y = log_y;
        self
    }

    /// Adds a series.
    pub fn with_series(mut self, series: Series) -> Self {
        self.series.push(series);
        self
    }

    /// Sets the size of the picture in pixels (at least 200 × 150 is used).
    pub fn with_size_px(mut self, width_px: u32, height_px: u32) -> Self {
        self.width_px = width_px;
        self.height_px = height_px;
        self
    }

    /// The plot as a standalone SVG document.
    ///
    /// Lines are clipped to the plot area (no coordinates outside it are written), broken at
    /// non-finite points; the legend goes in the corner of the plot area that covers the fewest
    /// points. Never panics, whatever the data (no series, no finite point, a single value).
    pub fn to_svg(&self) -> String {
        let width = f64::from(self.width_px.max(200));
        let height = f64::from(self.height_px.max(150));

        // Room for labels: about one per 60 px across, one per 40 px up.
        let max_x_intervals = ((width - 100.0) / 60.0).clamp(2.0, 10.0) as usize;
        let max_y_intervals = ((height - 90.0) / 40.0).clamp(2.0, 10.0) as usize;
        let x_axis = Axis::linear(
            self.x_range,
            self.finite_values(|p| Some(f64::from(p.0))),
            max_x_intervals,
        );
        let y_axis = if self.log_y {
            Axis::log(
                self.y_range,
                self.finite_values(|p| (p.1 > 0.0).then_some(f64::from(p.1).log10())),
            )
        } else {
            Axis::linear(
                self.y_range,
                self.finite_values(|p| Some(f64::from(p.1))),
                max_y_intervals,
            )
        };

        let y_label_chars = y_axis
            .ticks
            .iter()
            .filter_map(|t| t.label.as_ref())
            .map(Label::chars)
            .max()
            .unwrap_or(1);
        let left =
            24.0 + if self.y_label.is_empty() { 0.0 } else { 20.0 } + CHAR_W * y_label_chars as f64;
        let top = if self.title.is_empty() { 16.0 } else { 40.0 };
        let bottom = if self.x_label.is_empty() { 32.0 } else { 52.0 };
        let area = Rect {
            x0: left,
            y0: top,
            x1: width - 20.0,
            y1: height - bottom,
        };
        let to_px = |x: f64, y: f64| {
            (
                area.x0 + x_axis.fraction(x) * area.width(),
                area.y1 - y_axis.fraction(y) * area.height(),
            )
        };

        let mut svg = String::with_capacity(16 * 1024);
        let _ = writeln!(
            svg,
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" viewBox="0 0 {w} {h}" font-family="sans-serif" font-size="12">"#,
            w = width,
            h = height
        );
        let _ = writeln!(
            svg,
            r#"<rect width="{width}" height="{height}" fill="white"/>"#
        );
        if !self.title.is_empty() {
            let _ = writeln!(
                svg,
                r#"<text x="{:.1}" y="24" text-anchor="middle" font-size="16" font-weight="bold">{}</text>"#,
                (area.x0 + area.x1) / 2.0,
                escape(&self.title)
            );
        }

        // Grid lines and ticks.
        let _ = writeln!(
            svg,
            r##"<g class="grid" stroke="#e3e3e3" stroke-width="1">"##
        );
        for tick in x_axis.ticks.iter().filter(|t| t.label.is_some()) {
            let (x, _) = to_px(tick.value, y_axis.min);
            let _ = writeln!(
                svg,
                r#"<line x1="{x:.1}" y1="{:.1}" x2="{x:.1}" y2="{:.1}"/>"#,
                area.y0, area.y1
            );
        }
        for tick in y_axis.ticks.iter().filter(|t| t.label.is_some()) {
            let (_, y) = to_px(x_axis.min, tick.value);
            let _ = writeln!(
                svg,
                r#"<line x1="{:.1}" y1="{y:.1}" x2="{:.1}" y2="{y:.1}"/>"#,
                area.x0, area.x1
            );
        }
        let _ = writeln!(svg, "</g>");
        let _ = writeln!(
            svg,
            r##"<g class="ticks" stroke="#333333" stroke-width="1">"##
        );
        for tick in &x_axis.ticks {
            let (x, _) = to_px(tick.value, y_axis.min);
            let length = if tick.label.is_some() { 6.0 } else { 3.0 };
            let _ = writeln!(
                svg,
                r#"<line x1="{x:.1}" y1="{:.1}" x2="{x:.1}" y2="{:.1}"/>"#,
                area.y1,
                area.y1 + length
            );
        }
        for tick in &y_axis.ticks {
            let (_, y) = to_px(x_axis.min, tick.value);
            let length = if tick.label.is_some() { 6.0 } else { 3.0 };
            let _ = writeln!(
                svg,
                r#"<line x1="{:.1}" y1="{y:.1}" x2="{:.1}" y2="{y:.1}"/>"#,
                area.x0 - length,
                area.x0
            );
        }
        let _ = writeln!(svg, "</g>");

        // Tick labels.
        let _ = writeln!(
            svg,
            r##"<g class="x-ticks" fill="#333333" text-anchor="middle">"##
        );
        for tick in &x_axis.ticks {
            if let Some(label) = &tick.label {
                let (x, _) = to_px(tick.value, y_axis.min);
                let _ = writeln!(
                    svg,
                    r#"<text x="{x:.1}" y="{:.1}">{}</text>"#,
                    area.y1 + 20.0,
                    label.svg()
                );
            }
        }
        let _ = writeln!(svg, "</g>");
        let _ = writeln!(
            svg,
            r##"<g class="y-ticks" fill="#333333" text-anchor="end">"##
        );
        for tick in &y_axis.ticks {
            if let Some(label) = &tick.label {
                let (_, y) = to_px(x_axis.min, tick.value);
                let _ = writeln!(
                    svg,
                    r#"<text x="{:.1}" y="{:.1}">{}</text>"#,
                    area.x0 - 9.0,
                    y + 4.0,
                    label.svg()
                );
            }
        }
        let _ = writeln!(svg, "</g>");

        // Axis labels.
        if !self.x_label.is_empty() {
            let _ = writeln!(
                svg,
                r#"<text x="{:.1}" y="{:.1}" text-anchor="middle" font-size="13">{}</text>"#,
                (area.x0 + area.x1) / 2.0,
                height - 12.0,
                escape(&self.x_label)
            );
        }
        if !self.y_label.is_empty() {
            let (cx, cy) = (16.0, (area.y0 + area.y1) / 2.0);
            let _ = writeln!(
                svg,
                r#"<text x="{cx:.1}" y="{cy:.1}" transform="rotate(-90 {cx:.1} {cy:.1})" text-anchor="middle" font-size="13">{}</text>"#,
                escape(&self.y_label)
            );
        }

        // Data.
        let mut drawn_points: Vec<(f64, f64)> = Vec::new();
        for series in &self.series {
            let color = rgb(series.color);
            let mapped = series.points.iter().map(|&(x, y)| {
                let y = if self.log_y {
                    if y > 0.0 {
                        f64::from(y).log10()
                    } else {
                        f64::NAN
                    }
                } else {
                    f64::from(y)
                };
                let p = to_px(f64::from(x), y);
                (p.0.is_finite() && p.1.is_finite()).then_some(p)
            });
            match series.style {
                LineStyle::Markers => {
                    let _ = writeln!(svg, r#"<g class="series" fill="{color}">"#);
                    for (x, y) in mapped.flatten().filter(|&p| area.contains(p)) {
                        let _ = writeln!(svg, r#"<circle cx="{x:.1}" cy="{y:.1}" r="2.2"/>"#);
                        drawn_points.push((x, y));
                    }
                    let _ = writeln!(svg, "</g>");
                }
                LineStyle::Solid | LineStyle::Dashed | LineStyle::Faint => {
                    let dash = match series.style {
                        LineStyle::Dashed => r#" stroke-width="1.8" stroke-dasharray="7 4""#,
                        LineStyle::Faint => r#" stroke-width="0.8" stroke-opacity="0.45""#,
                        _ => r#" stroke-width="1.8""#,
                    };
                    let _ = writeln!(
                        svg,
                        r#"<g class="series" fill="none" stroke="{color}" stroke-linejoin="round"{dash}>"#
                    );
                    for run in clipped_runs(mapped, area) {
                        svg.push_str(r#"<polyline points=""#);
                        for (i, &(x, y)) in run.iter().enumerate() {
                            let sep = if i == 0 { "" } else { " " };
                            let _ = write!(svg, "{sep}{x:.1},{y:.1}");
                        }
                        svg.push_str("\"/>\n");
                        drawn_points.extend(run);
                    }
                    let _ = writeln!(svg, "</g>");
                }
            }
        }

        // Frame on top of the data.
        let _ = writeln!(
            svg,
            r##"<rect class="frame" x="{:.1}" y="{:.1}" width="{:.1}" height="{:.1}" fill="none" stroke="#333333" stroke-width="1"/>"##,
            area.x0,
            area.y0,
            area.width(),
            area.height()
        );

        self.write_legend(&mut svg, area, &drawn_points);
        svg.push_str("</svg>\n");
        svg
    }

    /// Finite values of the mapped coordinate over every point of every series.
    fn finite_values(&self, map: impl Fn(&(f32, f32)) -> Option<f64>) -> Vec<f64> {
        self.series
            .iter()
            .flat_map(|s| s.points.iter())
            .filter(|p| p.0.is_finite() && p.1.is_finite())
            .filter_map(map)
            .filter(|v| v.is_finite())
            .collect()
    }

    fn write_legend(&self, svg: &mut String, area: Rect, drawn_points: &[(f64, f64)]) {
        let entries: Vec<&Series> = self.series.iter().filter(|s| !s.label.is_empty()).collect();
        if entries.is_empty() {
            return;
        }
        let row_h = 18.0;
        let max_chars = entries
            .iter()
            .map(|s| s.label.chars().count())
            .max()
            .unwrap_or(0);
        let w = 44.0 + CHAR_W * max_chars as f64;
        let h = 8.0 + row_h * entries.len() as f64;
        let margin = 8.0;
        // Top right, top left, bottom right, bottom left: the first that covers fewest points.
        let corners = [
            (area.x1 - margin - w, area.y0 + margin),
            (area.x0 + margin, area.y0 + margin),
            (area.x1 - margin - w, area.y1 - margin - h),
            (area.x0 + margin, area.y1 - margin - h),
        ];
        let covered = |&(x, y): &(f64, f64)| {
            let rect = Rect {
                x0: x,
                y0: y,
                x1: x + w,
                y1: y + h,
            };
            drawn_points.iter().filter(|&&p| rect.contains(p)).count()
        };
        let (x, y) = corners
            .iter()
            .copied()
            .min_by_key(|corner| covered(corner))
            .unwrap_or(corners[0]);
        let _ = writeln!(svg, r#"<g class="legend">"#);
        let _ = writeln!(
            svg,
            r##"<rect x="{x:.1}" y="{y:.1}" width="{w:.1}" height="{h:.1}" fill="white" fill-opacity="0.85" stroke="#bbbbbb"/>"##
        );
        for (i, series) in entries.iter().enumerate() {
            let cy = y + 4.0 + row_h * (i as f64 + 0.5);
            let color = rgb(series.color);
            match series.style {
                LineStyle::Markers => {
                    let _ = writeln!(
                        svg,
                        r#"<circle cx="{:.1}" cy="{cy:.1}" r="3" fill="{color}"/>"#,
                        x + 20.0
                    );
                }
                LineStyle::Solid | LineStyle::Dashed | LineStyle::Faint => {
                    let dash = match series.style {
                        LineStyle::Dashed => r#" stroke-width="2" stroke-dasharray="7 4""#,
                        LineStyle::Faint => r#" stroke-width="1" stroke-opacity="0.45""#,
                        _ => r#" stroke-width="2""#,
                    };
                    let _ = writeln!(
                        svg,
                        r#"<line x1="{:.1}" y1="{cy:.1}" x2="{:.1}" y2="{cy:.1}" stroke="{color}"{dash}/>"#,
                        x + 8.0,
                        x + 32.0
                    );
                }
            }
            let _ = writeln!(
                svg,
                r#"<text x="{:.1}" y="{:.1}">{}</text>"#,
                x + 38.0,
                cy + 4.0,
                escape(&series.label)
            );
        }
        let _ = writeln!(svg, "</g>");
    }
}

/// Approximate advance of one character at font-size 12 (no font metrics available).
const CHAR_W: f64 = 7.0;

#[derive(Debug, Clone, Copy)]
struct Rect {
    x0: f64,
    y0: f64,
    x1: f64,
    y1: f64,
}

impl Rect {
    fn width(&self) -> f64 {
        self.x1 - self.x0
    }
    fn height(&self) -> f64 {
        self.y1 - self.y0
    }
    fn contains(&self, (x, y): (f64, f64)) -> bool {
        x >= self.x0 - 1e-6 && x <= self.x1 + 1e-6 && y >= self.y0 - 1e-6 && y <= self.y1 + 1e-6
    }
}

/// A tick label: plain text, or `10` with a superscript exponent.
#[derive(Debug, Clone, PartialEq)]
enum Label {
    Plain(String),
    Power(i32),
}

impl Label {
    fn chars(&self) -> usize {
        match self {
            Self::Plain(s) => s.chars().count(),
            Self::Power(k) => 2 + k.to_string().len(),
        }
    }

    fn svg(&self) -> String {
        match self {
            Self::Plain(s) => escape(s),
            Self::Power(k) => format!(
                r#"10<tspan dy="-6" font-size="9">{}</tspan>"#,
                k.to_string().replace('-', "\u{2212}")
            ),
        }
    }
}

#[derive(Debug, Clone)]
struct Tick {
    /// Position in axis space (log10 of the value on a log axis).
    value: f64,
    /// `None` for a minor tick.
    label: Option<Label>,
}

/// One axis: the visible range in axis space (log10 on a log axis) and its ticks.
#[derive(Debug, Clone)]
struct Axis {
    min: f64,
    max: f64,
    ticks: Vec<Tick>,
}

impl Axis {
    fn fraction(&self, value: f64) -> f64 {
        (value - self.min) / (self.max - self.min)
    }

    /// A linear axis over `range`, or over the data widened to whole ticks; at most
    /// `max_intervals` tick intervals.
    fn linear(range: Option<(f32, f32)>, values: Vec<f64>, max_intervals: usize) -> Self {
        let (min, max, widen) = match range {
            Some((a, b)) if a.is_finite() && b.is_finite() && a < b => {
                (f64::from(a), f64::from(b), false)
            }
            _ => {
                let (min, max) = min_max(&values).unwrap_or((0.0, 1.0));
                let scale = max.abs().max(min.abs());
                let (min, max) = if max - min > 1e-9 * scale {
                    (min, max)
                } else {
                    let pad = if scale == 0.0 { 1.0 } else { 0.5 * scale };
                    (min - pad, max + pad)
                };
                (min, max, true)
            }
        };
        let step = choose_step(min, max, widen, max_intervals);
        let (min, max) = if widen {
            ((min / step).floor() * step, (max / step).ceil() * step)
        } else {
            (min, max)
        };
        let ticks = nice_ticks(min, max, step)
            .into_iter()
            .map(|(value, label)| Tick {
                value,
                label: Some(Label::Plain(label)),
            })
            .collect();
        Self { min, max, ticks }
    }

    /// `log_values` are log10 of the positive data values.
    fn log(range: Option<(f32, f32)>, log_values: Vec<f64>) -> Self {
        let (min, max) = match range {
            Some((a, b)) if a > 0.0 && b.is_finite() && a < b => {
                (f64::from(a).log10(), f64::from(b).log10())
            }
            _ => {
                let (min, max) = min_max(&log_values).unwrap_or((-1.0, 0.0));
                // Tolerate f32 rounding: 10^-5 stored as 9.99999e-6 still starts at 10^-5.
                let (min, max) = ((min + 1e-5).floor(), (max - 1e-5).ceil());
                if max > min {
                    (min, max)
                } else {
                    (min, min + 1.0)
                }
            }
        };
        let eps = 1e-9 * (max - min).max(1.0);
        let first = (min - eps).ceil() as i32;
        let last = (max + eps).floor() as i32;
        let decades = (last - first + 1).max(0);
        let every = ((decades + 7) / 8).max(1);
        let mut ticks = Vec::new();
        if decades >= 2 {
            for k in first..=last {
                ticks.push(Tick {
                    value: f64::from(k),
                    label: ((k - first) % every == 0).then_some(Label::Power(k)),
                });
            }
            if max - min <= 6.0 {
                for k in (min.floor() as i32)..=(max.ceil() as i32) {
                    for m in 2..=9 {
                        let value = f64::from(k) + f64::from(m).log10();
                        if value >= min - eps && value <= max + eps {
                            ticks.push(Tick { value, label: None });
                        }
                    }
                }
            }
        } else {
            // Less than two decades visible: label 1, 2, 5 × 10^k (and every integer multiple as a
            // minor tick) in plain numbers.
            for k in (min.floor() as i32)..=(max.ceil() as i32) {
                for m in 1..=9 {
                    let value = f64::from(k) + f64::from(m).log10();
                    if value >= min - eps && value <= max + eps {
                        let label = matches!(m, 1 | 2 | 5).then(|| {
                            let exact = f64::from(m) * 10f64.powi(k);
                            Label::Plain(format_number(exact, (-k).max(0) as usize, 10f64.powi(k)))
                        });
                        ticks.push(Tick { value, label });
                    }
                }
            }
        }
        Self { min, max, ticks }
    }
}

fn min_max(values: &[f64]) -> Option<(f64, f64)> {
    values.iter().fold(None, |acc, &v| match acc {
        None => Some((v, v)),
        Some((lo, hi)) => Some((lo.min(v), hi.max(v))),
    })
}

/// The tick step (1, 2 or 5 × 10^k) for `[min, max]`: at most `max_intervals` intervals,
/// about 6 if possible, and (when the axis is `widen`ed to whole ticks) little empty space.
fn choose_step(min: f64, max: f64, widen: bool, max_intervals: usize) -> f64 {
    let span = max - min;
    if !(span.is_finite() && span > 0.0) {
        return 1.0;
    }
    let target = 6.0_f64.min(max_intervals as f64);
    let top = span.log10().floor() as i32;
    let mut best = (f64::NEG_INFINITY, 10f64.powi(top));
    for k in (top - 2)..=(top + 1) {
        for mantissa in [1.0, 2.0, 5.0] {
            let step = mantissa * 10f64.powi(k);
            let (lo, hi) = if widen {
                ((min / step).floor(), (max / step).ceil())
            } else {
                ((min / step).ceil(), (max / step).floor())
            };
            let intervals = hi - lo;
            if intervals < 2.0 || intervals > max_intervals as f64 {
                continue;
            }
            let cover = if widen {
                span / (intervals * step)
            } else {
                1.0
            };
            let score = cover - 0.02 * (intervals - target).abs();
            if score > best.0 {
                best = (score, step);
            }
        }
    }
    best.1
}

/// Multiples of `step` in `[min, max]` with labels printed to the step's precision.
fn nice_ticks(min: f64, max: f64, step: f64) -> Vec<(f64, String)> {
    let eps = 1e-9 * step;
    let first = ((min - eps) / step).ceil() as i64;
    let last = ((max + eps) / step).floor() as i64;
    if last < first || last - first > 1000 {
        return Vec::new();
    }
    let decimals = (-(step.log10() + 1e-9).floor()).max(0.0) as usize;
    (first..=last)
        .map(|k| {
            let value = k as f64 * step;
            (value, format_number(value, decimals, step))
        })
        .collect()
}

/// `value` with `decimals` digits, or in exponent form when the step is tiny or huge.
fn format_number(value: f64, decimals: usize, step: f64) -> String {
    if value.abs() < 1e-12 * step.max(1e-300) || value == 0.0 {
        return "0".to_owned();
    }
    if !(1e-4..1e5).contains(&step) {
        // As many significant digits as the step needs, e.g. "2e-5", "1.5e6".
        let digits = (value.abs().log10().floor() - step.log10().floor()).max(0.0) as usize;
        return format!("{:.*e}", digits, value)
            .replace(".0e", "e")
            .replace('-', "\u{2212}");
    }
    let text = format!("{value:.decimals$}");
    text.replace('-', "\u{2212}")
}

/// Pixel-space points split into runs clipped to `area`; `None` breaks the line.
fn clipped_runs(
    points: impl Iterator<Item = Option<(f64, f64)>>,
    area: Rect,
) -> Vec<Vec<(f64, f64)>> {
    let mut runs = Vec::new();
    let mut current: Vec<(f64, f64)> = Vec::new();
    let mut previous: Option<(f64, f64)> = None;
    for point in points {
        match (previous, point) {
            (Some(a), Some(b)) => match clip_segment(a, b, area) {
                Some(segment) => {
                    if segment.start_cut || current.is_empty() {
                        if current.len() > 1 {
                            runs.push(std::mem::take(&mut current));
                        }
                        current.clear();
                        current.push(segment.start);
                    }
                    current.push(segment.end);
                    if segment.end_cut {
                        runs.push(std::mem::take(&mut current));
                    }
                }
                None => {
                    if current.len() > 1 {
                        runs.push(std::mem::take(&mut current));
                    }
                    current.clear();
                }
            },
            _ => {
                if current.len() > 1 {
                    runs.push(std::mem::take(&mut current));
                }
                current.clear();
            }
        }
        previous = point;
    }
    if current.len() > 1 {
        runs.push(current);
    }
    runs
}

/// The part of a segment inside the plot area.
struct ClippedSegment {
    start: (f64, f64),
    end: (f64, f64),
    /// The start was moved onto the area's edge.
    start_cut: bool,
    /// The end was moved onto the area's edge.
    end_cut: bool,
}

/// Liang–Barsky: the part of segment `a → b` inside `area`.
fn clip_segment(a: (f64, f64), b: (f64, f64), area: Rect) -> Option<ClippedSegment> {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let mut t0 = 0.0_f64;
    let mut t1 = 1.0_f64;
    for (p, q) in [
        (-dx, a.0 - area.x0),
        (dx, area.x1 - a.0),
        (-dy, a.1 - area.y0),
        (dy, area.y1 - a.1),
    ] {
        if p == 0.0 {
            if q < 0.0 {
                return None;
            }
        } else {
            let r = q / p;
            if p < 0.0 {
                t0 = t0.max(r);
            } else {
                t1 = t1.min(r);
            }
        }
    }
    if t0 > t1 {
        return None;
    }
    let at = |t: f64| (a.0 + t * dx, a.1 + t * dy);
    Some(ClippedSegment {
        start: at(t0),
        end: at(t1),
        start_cut: t0 > 0.0,
        end_cut: t1 < 1.0,
    })
}

fn rgb([r, g, b]: [u8; 3]) -> String {
    format!("#{r:02x}{g:02x}{b:02x}")
}

/// Escapes text for SVG element content and attribute values.
fn escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            _ => out.push(c),
        }
    }
    out
}

/// A perceptually uniform colormap: matplotlib's (CC0), sampled at 17 equally spaced stops and
/// interpolated linearly (within 7 sRGB codes of the 256-entry original).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Colormap {
    /// Dark purple → blue → green → yellow.
    #[default]
    Viridis,
    /// Black → purple → orange → pale yellow.
    Inferno,
}

const VIRIDIS: [[u8; 3]; 17] = [
    [68, 1, 84],
    [72, 24, 106],
    [71, 45, 123],
    [66, 64, 134],
    [59, 82, 139],
    [51, 99, 141],
    [44, 114, 142],
    [38, 130, 142],
    [33, 145, 140],
    [31, 160, 136],
    [40, 174, 128],
    [63, 188, 115],
    [94, 201, 98],
    [132, 212, 75],
    [173, 220, 48],
    [216, 226, 25],
    [253, 231, 37],
];

const INFERNO: [[u8; 3]; 17] = [
    [0, 0, 4],
    [11, 7, 36],
    [33, 12, 74],
    [61, 9, 101],
    [87, 16, 110],
    [113, 25, 110],
    [138, 34, 106],
    [163, 44, 97],
    [188, 55, 84],
    [210, 70, 68],
    [228, 90, 49],
    [241, 115, 29],
    [249, 142, 9],
    [252, 172, 17],
    [249, 203, 53],
    [242, 234, 105],
    [252, 255, 164],
];

impl Colormap {
    /// The colour at `t` in [0, 1] (clamped; NaN gives the start).
    pub fn color_at(self, t: f32) -> [u8; 3] {
        let stops = match self {
            Self::Viridis => &VIRIDIS,
            Self::Inferno => &INFERNO,
        };
        let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) };
        let x = t * (stops.len() - 1) as f32;
        let i = (x.floor() as usize).min(stops.len() - 2);
        let f = x - i as f32;
        let (a, b) = (stops[i], stops[i + 1]);
        std::array::from_fn(|c| {
            (f32::from(a[c]) + f * (f32::from(b[c]) - f32::from(a[c]))).round() as u8
        })
    }
}

/// Colour drawn for values that are NaN or infinite (a neutral grey that neither colormap uses).
pub const NO_DATA_COLOR: [u8; 3] = [128, 128, 128];

/// How values map to colours in [`heatmap_png`].
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ColorScale {
    /// The colormap.
    pub colormap: Colormap,
    /// Map log10 of the value (values ≤ 0 get the lowest colour).
    pub log: bool,
    /// Values mapped to the two ends; `None` uses the finite (on a log scale: positive) data's
    /// minimum and maximum.
    pub range: Option<(f32, f32)>,
}

impl ColorScale {
    /// Linear viridis over the data's range.
    pub fn linear() -> Self {
        Self::default()
    }

    /// Logarithmic viridis over the data's positive range.
    pub fn log() -> Self {
        Self {
            log: true,
            ..Self::default()
        }
    }

    /// The same scale with another colormap.
    pub fn with_colormap(mut self, colormap: Colormap) -> Self {
        self.colormap = colormap;
        self
    }

    /// The same scale over a fixed range of values.
    pub fn with_range(mut self, min: f32, max: f32) -> Self {
        self.range = Some((min, max));
        self
    }

    /// The values mapped to the ends of the colormap for `values`; `None` if there are no
    /// usable values (all non-finite, or none positive on a log scale).
    pub fn resolve_range(&self, values: &[f32]) -> Option<(f32, f32)> {
        if let Some((min, max)) = self.range
            && min.is_finite()
            && max.is_finite()
            && min < max
            && (!self.log || min > 0.0)
        {
            return Some((min, max));
        }
        values
            .iter()
            .copied()
            .filter(|v| v.is_finite() && (!self.log || *v > 0.0))
            .fold(None, |acc, v| match acc {
                None => Some((v, v)),
                Some((lo, hi)) => Some((lo.min(v), hi.max(v))),
            })
    }

    /// The colour of `value` given the resolved `range`.
    fn color(&self, value: f32, (min, max): (f32, f32)) -> [u8; 3] {
        if !value.is_finite() {
            return NO_DATA_COLOR;
        }
        let t = if self.log {
            if value <= 0.0 {
                0.0
            } else {
                let (lo, hi) = (min.log10(), max.log10());
                if hi > lo {
                    (value.log10() - lo) / (hi - lo)
                } else {
                    0.5
                }
            }
        } else if max > min {
            (value - min) / (max - min)
        } else {
            0.5
        };
        self.colormap.color_at(t)
    }
}

/// A false-colour picture of `values` (`width` × `height`, row-major, row 0 at the top).
///
/// Non-finite values are drawn in [`NO_DATA_COLOR`]; values outside the scale's range are
/// clamped to its ends.
///
/// # Panics
/// If `values.len() != width * height`, or a dimension does not fit in `u32`.
pub fn heatmap_png(values: &[f32], width: usize, height: usize, scale: ColorScale) -> RgbImage {
    assert_eq!(
        values.len(),
        width * height,
        "heatmap_png: {} values for a {width} × {height} picture",
        values.len()
    );
    let range = scale.resolve_range(values).unwrap_or((0.0, 1.0));
    let mut image = RgbImage::new(dimension(width), dimension(height));
    for (pixel, &value) in image.pixels_mut().zip(values) {
        *pixel = Rgb(scale.color(value, range));
    }
    image
}

/// A picture of linear RGB values (`width` × `height`, row-major, row 0 at the top): multiplied
/// by `exposure`, clamped to [0, 1] (NaN → 0) and sRGB-encoded
/// ([`cdrf_core::image_file::linear_to_srgb`], the one sRGB curve of the workspace).
///
/// # Panics
/// If `values.len() != width * height`, or a dimension does not fit in `u32`.
pub fn rgb_png_srgb(values: &[Vec3], width: usize, height: usize, exposure: f32) -> RgbImage {
    assert_eq!(
        values.len(),
        width * height,
        "rgb_png_srgb: {} values for a {width} × {height} picture",
        values.len()
    );
    let encode = |linear: f32| {
        let v = linear * exposure;
        let v = if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) };
        (linear_to_srgb(v) * 255.0).round() as u8
    };
    let mut image = RgbImage::new(dimension(width), dimension(height));
    for (pixel, value) in image.pixels_mut().zip(values) {
        *pixel = Rgb([encode(value.x), encode(value.y), encode(value.z)]);
    }
    image
}

/// `image` enlarged by whole factors, each source pixel becoming a `scale_x` × `scale_y` block
/// (so that a 181 × 64 table becomes a picture one can see). Factors of 0 are taken as 1.
pub fn upscale_nearest(image: &RgbImage, scale_x: u32, scale_y: u32) -> RgbImage {
    let (sx, sy) = (scale_x.max(1), scale_y.max(1));
    RgbImage::from_fn(
        image.width().saturating_mul(sx),
        image.height().saturating_mul(sy),
        |x, y| *image.get_pixel(x / sx, y / sy),
    )
}

fn dimension(n: usize) -> u32 {
    u32::try_from(n).expect("picture dimension does not fit in u32")
}
