//! The figure of a case: the reference and each model's render, the regions and each model's
//! signed error per block, with column and row labels and a colour key.

use cdrf_core::block_error::{BLOCK_PX, Region};

use crate::models::ComparedModel;
use crate::result::CaseResult;
use crate::run::{Geometry, blocks};
use crate::tone::tone_map;

/// Colours of the figure: the region map, the signed block error, labels and background.
mod colours {
    pub const BACKGROUND: [u8; 3] = [24, 24, 24];
    pub const NOT_COMPARED: [u8; 3] = [20, 20, 20];
    pub const TEXT: [u8; 3] = [235, 235, 235];
    pub const LIT: [u8; 3] = [230, 150, 60];
    pub const TERMINATOR: [u8; 3] = [235, 235, 235];
    pub const SHADOW: [u8; 3] = [60, 110, 220];
    pub const CAST_SHADOW: [u8; 3] = [150, 60, 170];
    pub const TOO_BRIGHT: [u8; 3] = [255, 60, 40];
    pub const TOO_DARK: [u8; 3] = [40, 120, 255];
    /// A block with no error.
    pub const EXACT: u8 = 35;
}

/// Where the panels and labels of a case's figure go: column labels on top (the reference and
/// the models), row labels on the left, the colour key at the bottom.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FigureLayout {
    /// One panel's (one image's) size, pixels.
    pub panel_width_px: u32,
    /// See `panel_width_px`.
    pub panel_height_px: u32,
    /// Panels across: the reference and one per model.
    pub columns: u32,
    /// Panels down: radiance, then regions and signed error.
    pub rows: u32,
    /// Width of the row labels left of the panels, pixels.
    pub label_width_px: u32,
    /// Height of the column labels above the panels, pixels.
    pub header_height_px: u32,
    /// Height of the colour key below the panels, pixels.
    pub footer_height_px: u32,
    /// Text size, pixels.
    text_px: f32,
}

impl FigureLayout {
    /// Lines of a column label (longer labels are wrapped to this many and clipped).
    const HEADER_LINES: u32 = 3;
    /// Lines of the colour key.
    const FOOTER_LINES: u32 = 2;

    /// The layout for panels of `panel_width_px` × `panel_height_px` (the compared size), the
    /// reference and `model_count` models across.
    pub fn new(panel_width_px: u32, panel_height_px: u32, model_count: usize) -> Self {
        let text_px = (panel_width_px as f32 / 11.0).clamp(11.0, 22.0);
        let line = Self::line_px(text_px);
        let padding = (text_px / 2.0).ceil() as u32;
        Self {
            panel_width_px,
            panel_height_px,
            columns: 1 + model_count as u32,
            rows: 2,
            label_width_px: (8.0 * text_px).ceil() as u32,
            header_height_px: Self::HEADER_LINES * line + padding,
            footer_height_px: Self::FOOTER_LINES * line + padding,
            text_px,
        }
    }

    fn line_px(text_px: f32) -> u32 {
        (1.3 * text_px).ceil() as u32
    }

    /// The figure's width, pixels.
    pub fn width(&self) -> u32 {
        self.label_width_px + self.columns * self.panel_width_px
    }

    /// The figure's height, pixels.
    pub fn height(&self) -> u32 {
        self.header_height_px + self.rows * self.panel_height_px + self.footer_height_px
    }

    /// The top-left pixel of panel (`column`, `row`).
    fn panel(&self, column: u32, row: u32) -> (u32, u32) {
        (
            self.label_width_px + column * self.panel_width_px,
            self.header_height_px + row * self.panel_height_px,
        )
    }
}

/// Figure labels: egui's default proportional font (Ubuntu Light, from the crate egui bundles
/// its fonts in), rasterized with ab_glyph.
struct Text<'f> {
    font: ab_glyph::FontRef<'f>,
    px: f32,
}

/// A word-wrapped line: words and their colours.
type Line<'t> = Vec<(&'t str, [u8; 3])>;

impl Text<'_> {
    fn width(&self, text: &str) -> f32 {
        use ab_glyph::{Font, ScaleFont};
        let scaled = self.font.as_scaled(self.px);
        let mut previous = None;
        let mut width = 0.0;
        for ch in text.chars() {
            let id = scaled.glyph_id(ch);
            if let Some(previous) = previous {
                width += scaled.kern(previous, id);
            }
            width += scaled.h_advance(id);
            previous = Some(id);
        }
        width
    }

    /// Draws `text` in `colour` with its top left at (`x`, `y`), clipped to the image.
    fn draw(&self, image: &mut image::RgbImage, x: f32, y: f32, text: &str, colour: [u8; 3]) {
        use ab_glyph::{Font, ScaleFont};
        let scaled = self.font.as_scaled(self.px);
        let baseline = y + scaled.ascent();
        let mut caret = x;
        let mut previous = None;
        for ch in text.chars() {
            let id = scaled.glyph_id(ch);
            if let Some(previous) = previous {
                caret += scaled.kern(previous, id);
            }
            previous = Some(id);
            let glyph = id.with_scale_and_position(self.px, ab_glyph::point(caret, baseline));
            caret += scaled.h_advance(id);
            let Some(outline) = self.font.outline_glyph(glyph) else {
                continue;
            };
            let bounds = outline.px_bounds();
            outline.draw(|gx, gy, coverage| {
                let px = bounds.min.x as i64 + i64::from(gx);
                let py = bounds.min.y as i64 + i64::from(gy);
                if px < 0 || py < 0 || px >= i64::from(image.width()) {
                    return;
                }
                if py >= i64::from(image.height()) {
                    return;
                }
                let pixel = image.get_pixel_mut(px as u32, py as u32);
                let coverage = coverage.clamp(0.0, 1.0);
                for c in 0..3 {
                    let blended =
                        f32::from(pixel[c]) * (1.0 - coverage) + f32::from(colour[c]) * coverage;
                    pixel[c] = blended.round() as u8;
                }
            });
        }
    }

    /// Word-wraps `runs` (text and its colour) at spaces into lines at most `max_width` wide (a
    /// word wider than that gets a line of its own; no-break spaces hold words together).
    fn wrap<'t>(&self, runs: &[(&'t str, [u8; 3])], max_width: f32) -> Vec<Line<'t>> {
        let space = self.width(" ");
        let mut lines: Vec<Line<'t>> = Vec::new();
        let (mut line, mut width): (Line<'t>, f32) = (Vec::new(), 0.0);
        for &(text, colour) in runs {
            for word in text.split(' ').filter(|word| !word.is_empty()) {
                let word_width = self.width(word);
                if !line.is_empty() && width + space + word_width > max_width {
                    lines.push(std::mem::take(&mut line));
                    width = 0.0;
                }
                width += if line.is_empty() { 0.0 } else { space } + word_width;
                line.push((word, colour));
            }
        }
        if !line.is_empty() {
            lines.push(line);
        }
        lines
    }

    /// Draws `lines` from (`x`, `y`) down, at most `max_lines` of them; `centre_width`: centre
    /// each line in that width.
    fn draw_lines(
        &self,
        image: &mut image::RgbImage,
        (x, y): (f32, f32),
        lines: &[Line<'_>],
        max_lines: usize,
        centre_width: Option<f32>,
    ) {
        let space = self.width(" ");
        let line_px = FigureLayout::line_px(self.px) as f32;
        for (index, line) in lines.iter().take(max_lines).enumerate() {
            let line_width: f32 = line.iter().map(|(word, _)| self.width(word)).sum::<f32>()
                + space * line.len().saturating_sub(1) as f32;
            let mut caret = x + centre_width.map_or(0.0, |w| ((w - line_width) / 2.0).max(0.0));
            for &(word, colour) in line {
                self.draw(image, caret, y + index as f32 * line_px, word, colour);
                caret += self.width(word) + space;
            }
        }
    }
}

/// The labels of the figure's columns: the path-traced reference, then the models.
pub fn figure_column_labels(models: &[ComparedModel]) -> Vec<String> {
    std::iter::once("path-traced reference".to_owned())
        .chain(models.iter().map(|model| model.label()))
        .collect()
}

/// The labels of the figure's rows.
pub const FIGURE_ROW_LABELS: [&str; 2] = [
    "radiance (tone-mapped)",
    "regions, then signed error per 8\u{a0}×\u{a0}8 block",
];

/// Draws the labels of `layout` into `figure`: column labels, row labels and the colour key.
fn draw_labels(figure: &mut image::RgbImage, layout: &FigureLayout, models: &[ComparedModel]) {
    let Ok(font) = ab_glyph::FontRef::try_from_slice(epaint_default_fonts::UBUNTU_LIGHT) else {
        return;
    };
    let text = Text {
        font,
        px: layout.text_px,
    };
    let padding = (layout.text_px / 4.0).ceil();
    let panel_width = layout.panel_width_px as f32;
    for (column, label) in figure_column_labels(models).iter().enumerate() {
        let (x, _) = layout.panel(column as u32, 0);
        let lines = text.wrap(&[(label, colours::TEXT)], panel_width - 2.0 * padding);
        text.draw_lines(
            figure,
            (x as f32 + padding, padding),
            &lines,
            FigureLayout::HEADER_LINES as usize,
            Some(panel_width - 2.0 * padding),
        );
    }
    let label_width = layout.label_width_px as f32 - 2.0 * padding;
    for (row, label) in FIGURE_ROW_LABELS.into_iter().enumerate() {
        let (_, y) = layout.panel(0, row as u32);
        let lines = text.wrap(&[(label, colours::TEXT)], label_width);
        text.draw_lines(
            figure,
            (padding, y as f32 + padding),
            &lines,
            usize::MAX,
            None,
        );
    }
    let key = [
        ("regions:", colours::TEXT),
        ("lit", colours::LIT),
        ("terminator", colours::TERMINATOR),
        ("shadow", colours::SHADOW),
        ("cast shadow", colours::CAST_SHADOW),
        (
            "(dark: not compared). Signed error of each 8\u{a0}×\u{a0}8 block:",
            colours::TEXT,
        ),
        ("too bright", colours::TOO_BRIGHT),
        ("too dark", colours::TOO_DARK),
        ("(full colour at ±50 %).", colours::TEXT),
    ];
    let (_, y) = layout.panel(0, layout.rows);
    let lines = text.wrap(&key, layout.width() as f32 - 2.0 * padding);
    text.draw_lines(
        figure,
        (padding, y as f32 + padding),
        &lines,
        FigureLayout::FOOTER_LINES as usize,
        None,
    );
}

/// The case's figure ([`FigureLayout`]): the reference and each model's render, tone-mapped;
/// beneath, the regions (lit orange, terminator white, shadow blue, cast shadow purple; dark =
/// not compared) and each model's signed relative error per 8 × 8 block (red: too bright, blue:
/// too dark, full colour at ±50 %); column labels name the reference and the models, row labels
/// what each row shows, and a colour key runs along the bottom.
pub fn figure(result: &CaseResult) -> image::RgbImage {
    let images = &result.images;
    let (w, h) = (result.width, result.height);
    let layout = FigureLayout::new(w, h, result.models.len());
    let mut figure = image::RgbImage::from_pixel(
        layout.width(),
        layout.height(),
        image::Rgb(colours::BACKGROUND),
    );
    draw_labels(&mut figure, &layout, &result.models);
    let Some(reference) = &images.reference else {
        return figure;
    };
    let mut fill = |column: u32, row: u32, x: u32, y: u32, colour: [u8; 3]| {
        let (x0, y0) = layout.panel(column, row);
        figure.put_pixel(x0 + x, y0 + y, image::Rgb(colour));
    };
    for (column, image) in std::iter::once(reference)
        .chain(&images.renders)
        .enumerate()
    {
        let rgb = tone_map(image, result.exposure);
        for y in 0..h {
            for x in 0..w {
                let i = ((y * w + x) * 3) as usize;
                fill(column as u32, 0, x, y, [rgb[i], rgb[i + 1], rgb[i + 2]]);
            }
        }
    }
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            let (cos, occluded) = (images.cos_theta[i], images.occluded[i]);
            let colour = if !images.mask[i] {
                colours::NOT_COMPARED
            } else if Region::CastShadow.contains(cos, occluded) {
                colours::CAST_SHADOW
            } else if Region::Lit.contains(cos, occluded) {
                colours::LIT
            } else if Region::Terminator.contains(cos, occluded) {
                colours::TERMINATOR
            } else {
                colours::SHADOW
            };
            fill(0, 1, x, y, colour);
        }
    }
    let geometry = Geometry {
        mask: &images.mask,
        cos_theta: &images.cos_theta,
        occluded: &images.occluded,
    };
    for (index, render) in images.renders.iter().enumerate() {
        let column = index as u32 + 1;
        for y in 0..h {
            for x in 0..w {
                fill(column, 1, x, y, colours::NOT_COMPARED);
            }
        }
        for block in blocks(render, reference, &geometry) {
            let relative = block.signed_relative_error().clamp(-0.5, 0.5) / 0.5;
            let strength = relative.abs();
            let base = if relative > 0.0 {
                colours::TOO_BRIGHT
            } else {
                colours::TOO_DARK
            };
            let colour = base.map(|c| {
                (f32::from(c) * strength + f32::from(colours::EXACT) * (1.0 - strength)) as u8
            });
            for y in block.row * BLOCK_PX..(block.row + 1) * BLOCK_PX {
                for x in block.column * BLOCK_PX..(block.column + 1) * BLOCK_PX {
                    fill(column, 1, x, y, colour);
                }
            }
        }
    }
    figure
}
