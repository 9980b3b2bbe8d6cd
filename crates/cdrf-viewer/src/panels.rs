//! The viewer's widgets: light gizmo, LUT image, radiance plot, overlays and legends.

use std::f32::consts::PI;

use cdrf_core::gaussian::GaussianCdrf;
use cdrf_core::glam::{Mat3, Vec2 as GlamVec2, Vec3};
use cdrf_core::image_file::linear_to_srgb;
use cdrf_core::{Cdrf, CdrfLut, Filter};
use egui::{Color32, Pos2, Rect, Stroke, Vec2};
use egui_plot::{Line, LineStyle, Plot, PlotPoints, VLine};

use crate::app::{Hover, Settings, model_colour};
use crate::gpu::Layout;

/// A shaded sphere showing the light as seen from the camera; click or drag on it to put the
/// light at that point of the front hemisphere. Returns whether `to_light` changed.
pub fn light_gizmo(ui: &mut egui::Ui, to_light: &mut Vec3, world_to_view: Mat3) -> bool {
    let size = 110.0;
    let (rect, response) = ui.allocate_exact_size(Vec2::splat(size), egui::Sense::click_and_drag());
    let center = rect.center();
    let radius = size * 0.5 - 4.0;
    let light_view = world_to_view * *to_light;

    // The sphere: a fan of rings, each vertex shaded max(n·l, 0) + a little ambient.
    let mut mesh = egui::Mesh::default();
    let (rings, segments) = (12, 48);
    let shade = |normal: Vec3| {
        let value = 0.08 + 0.92 * normal.dot(light_view).max(0.0);
        let v = (linear_to_srgb(value) * 255.0) as u8;
        Color32::from_rgb(v, (v as f32 * 0.93) as u8, (v as f32 * 0.85) as u8)
    };
    mesh.colored_vertex(center, shade(Vec3::Z));
    for ring in 1..=rings {
        let r = ring as f32 / rings as f32;
        for segment in 0..segments {
            let angle = segment as f32 / segments as f32 * 2.0 * PI;
            let (x, y) = (r * angle.cos(), r * angle.sin());
            let normal = Vec3::new(x, y, (1.0 - r * r).max(0.0).sqrt());
            mesh.colored_vertex(center + Vec2::new(x, -y) * radius, shade(normal));
        }
    }
    for segment in 0..segments {
        let next = (segment + 1) % segments;
        mesh.add_triangle(0, 1 + segment, 1 + next);
        for ring in 1..rings {
            let (a, b) = (
                1 + (ring - 1) * segments + segment,
                1 + (ring - 1) * segments + next,
            );
            let (c, d) = (1 + ring * segments + segment, 1 + ring * segments + next);
            mesh.add_triangle(a, c, b);
            mesh.add_triangle(b, c, d);
        }
    }
    let painter = ui.painter_at(rect);
    painter.add(egui::Shape::mesh(mesh));
    let marker = center + Vec2::new(light_view.x, -light_view.y) * radius;
    let stroke = Stroke::new(1.5, Color32::from_rgb(255, 210, 80));
    if light_view.z >= 0.0 {
        painter.circle_filled(marker, 4.0, stroke.color);
    } else {
        painter.circle_stroke(marker, 4.0, stroke);
    }

    let mut changed = false;
    if (response.dragged() || response.clicked())
        && let Some(pointer) = response.interact_pointer_pos()
    {
        let offset = (pointer - center) / radius;
        let mut xy = GlamVec2::new(offset.x, -offset.y);
        if xy.length() > 1.0 {
            xy = xy.normalize();
        }
        let view_direction = Vec3::new(xy.x, xy.y, (1.0 - xy.length_squared()).max(0.0).sqrt());
        *to_light = world_to_view.transpose() * view_direction;
        changed = true;
    }
    response
        .on_hover_text("drag to move the light (front hemisphere; use the sliders for back light)");
    changed
}

/// The LUT as an image: θ across (0…180°), κ down (the table's rows), each channel divided by
/// the table's largest value, sRGB.
pub fn lut_texture(ctx: &egui::Context, lut: &CdrfLut) -> egui::TextureHandle {
    let (width, height) = (lut.theta_count(), lut.curvature_axis().count);
    let largest = lut
        .radiance()
        .iter()
        .fold(0.0f32, |m, v| m.max(v.max_element()))
        .max(1e-12);
    let pixels = lut
        .radiance()
        .iter()
        .map(|v| {
            let [r, g, b] = (*v / largest)
                .to_array()
                .map(|c| (linear_to_srgb(c) * 255.0) as u8);
            Color32::from_rgb(r, g, b)
        })
        .collect();
    let image = egui::ColorImage::new([width, height], pixels);
    ctx.load_texture("cdrf-lut", image, egui::TextureOptions::LINEAR)
}

/// The LUT image with axes and the pointer's (κ, θ) marked.
pub fn lut_image(
    ui: &mut egui::Ui,
    lut: &CdrfLut,
    texture: &egui::TextureHandle,
    hover: Option<Hover>,
) {
    let axis = lut.curvature_axis();
    let width = ui.available_width().min(310.0);
    let (rect, _) = ui.allocate_exact_size(Vec2::new(width, 110.0), egui::Sense::hover());
    let painter = ui.painter_at(rect.expand(1.0));
    painter.image(
        texture.id(),
        rect,
        Rect::from_min_max(Pos2::ZERO, Pos2::new(1.0, 1.0)),
        Color32::WHITE,
    );
    if let Some(hover) = hover {
        let u = (hover.theta_rad / PI).clamp(0.0, 1.0);
        let rows = (axis.count.max(2) - 1) as f32;
        let v = axis.row_coordinate(hover.curvature_per_mm) / rows;
        let point = rect.min + Vec2::new(u * rect.width(), v * rect.height());
        let stroke = Stroke::new(1.0, Color32::from_rgb(80, 255, 120));
        painter.hline(rect.x_range(), point.y, stroke);
        painter.vline(point.x, rect.y_range(), stroke);
        painter.circle_stroke(point, 4.0, Stroke::new(2.0, stroke.color));
    }
    let small = egui::TextStyle::Small.resolve(ui.style());
    ui.horizontal(|ui| {
        ui.label(
            egui::RichText::new(format!(
                "θ 0…180° across; κ {:.4}…{:.4} /mm (r {:.0}…{:.0} mm) down",
                axis.curvature_per_mm(0),
                axis.curvature_per_mm(axis.count - 1),
                1.0 / axis.curvature_per_mm(0),
                1.0 / axis.curvature_per_mm(axis.count - 1),
            ))
            .font(small),
        );
    });
}

/// f(θ) at one curvature for both models, per RGB channel (measured solid, Gaussian dashed),
/// like the poster's Fig. 2.
pub fn radiance_plot(
    ui: &mut egui::Ui,
    curvature_per_mm: f32,
    lut: Option<&CdrfLut>,
    gaussian: Option<&GaussianCdrf>,
    theta_rad: Option<f32>,
) {
    let samples = 181;
    let thetas: Vec<f32> = (0..samples)
        .map(|i| i as f32 / (samples - 1) as f32 * PI)
        .collect();
    let channels = [
        ("R", Color32::from_rgb(240, 80, 70)),
        ("G", Color32::from_rgb(90, 200, 90)),
        ("B", Color32::from_rgb(90, 140, 250)),
    ];
    Plot::new("cdrf-radiance-plot")
        .height(170.0)
        .x_axis_label("θ (°)")
        .y_axis_label("f = πL/E")
        .default_x_bounds(0.0, 180.0)
        .include_y(0.0)
        .allow_drag(false)
        .allow_zoom(false)
        .allow_scroll(false)
        .show(ui, |plot| {
            for (channel, (name, colour)) in channels.into_iter().enumerate() {
                if let Some(lut) = lut {
                    let points: PlotPoints = thetas
                        .iter()
                        .map(|&t| {
                            let f = lut.sample(curvature_per_mm, t, Filter::Bilinear);
                            [f64::from(t.to_degrees()), f64::from(f[channel])]
                        })
                        .collect();
                    plot.line(Line::new(format!("measured {name}"), points).color(colour));
                }
                if let Some(gaussian) = gaussian {
                    let points: PlotPoints = thetas
                        .iter()
                        .map(|&t| {
                            let f = gaussian.reflectance(curvature_per_mm, t);
                            [f64::from(t.to_degrees()), f64::from(f[channel])]
                        })
                        .collect();
                    plot.line(
                        Line::new(format!("Gaussian {name}"), points)
                            .color(colour)
                            .style(LineStyle::dashed_loose()),
                    );
                }
            }
            if let Some(theta) = theta_rad {
                plot.vline(
                    VLine::new("pointer θ", f64::from(theta.to_degrees())).color(Color32::GRAY),
                );
            }
        });
    ui.label(
        egui::RichText::new("solid: measured, dashed: Gaussian; R, G, B channels; without g(θ, φ)")
            .small()
            .weak(),
    );
}

/// Labels over the 3D view: which model each part shows, the split handle, the difference
/// legend, and missing data.
pub fn view_overlay(
    ui: &egui::Ui,
    rect: Rect,
    layout: Layout,
    settings: &Settings,
    slot_points: cdrf_core::glam::Vec2,
    missing: &[Option<&'static str>; 2],
) {
    let painter = ui.painter_at(rect);
    let font = egui::FontId::proportional(15.0);
    let label = |position: Pos2, align: egui::Align2, index: usize| {
        let model = settings.models[index];
        painter.text(
            position,
            align,
            model.label(),
            font.clone(),
            model_colour(model),
        );
        if let Some(missing) = missing[index] {
            painter.text(
                position + Vec2::new(0.0, 20.0),
                align,
                missing,
                egui::FontId::proportional(13.0),
                ui.visuals().warn_fg_color,
            );
        }
    };
    let margin = Vec2::new(10.0, 8.0);
    match layout {
        Layout::Single if settings.curvature_view => {
            painter.text(
                rect.left_top() + margin,
                egui::Align2::LEFT_TOP,
                "curvature",
                font.clone(),
                Color32::WHITE,
            );
        }
        Layout::Single => {
            label(rect.left_top() + margin, egui::Align2::LEFT_TOP, 0);
            painter.text(
                rect.left_top() + margin + Vec2::new(0.0, 20.0),
                egui::Align2::LEFT_TOP,
                terms_label(settings.non_local),
                egui::FontId::proportional(13.0),
                ui.visuals().weak_text_color(),
            );
        }
        Layout::SideBySide => {
            let divider = rect.min.x + slot_points.x;
            painter.vline(
                divider,
                rect.y_range(),
                Stroke::new(1.0, Color32::from_gray(70)),
            );
            label(rect.left_top() + margin, egui::Align2::LEFT_TOP, 0);
            label(
                Pos2::new(divider, rect.min.y) + margin,
                egui::Align2::LEFT_TOP,
                1,
            );
        }
        Layout::Split => {
            let x = rect.min.x + settings.split * rect.width();
            painter.vline(x, rect.y_range(), Stroke::new(1.5, Color32::from_gray(220)));
            let grip = Rect::from_center_size(Pos2::new(x, rect.center().y), Vec2::new(10.0, 36.0));
            painter.rect_filled(grip, 3.0, Color32::from_gray(220));
            label(rect.left_top() + margin, egui::Align2::LEFT_TOP, 0);
            label(
                rect.right_top() + Vec2::new(-margin.x, margin.y),
                egui::Align2::RIGHT_TOP,
                1,
            );
        }
        Layout::Difference => {
            let text = format!(
                "luminance {} − {}",
                settings.models[0].label(),
                settings.models[1].label()
            );
            painter.text(
                rect.left_top() + margin,
                egui::Align2::LEFT_TOP,
                text,
                font.clone(),
                Color32::WHITE,
            );
            difference_legend(&painter, rect, settings.difference_range);
        }
    }
}

/// What the non-local terms add, in words.
fn terms_label(non_local: cdrf_core::light::NonLocal) -> String {
    let names: Vec<&str> = [
        (non_local.shadows, "cast shadows"),
        (non_local.transmission, "transmission"),
        (non_local.interreflection, "inter-reflection"),
        (non_local.subsurface, "subsurface gather"),
    ]
    .into_iter()
    .filter_map(|(on, name)| on.then_some(name))
    .collect();
    match names.len() {
        0 => "local model alone (the poster's)".to_owned(),
        4 => "+ every non-local term".to_owned(),
        _ => format!("+ {}", names.join(", ")),
    }
}

fn difference_legend(painter: &egui::Painter, rect: Rect, range: f32) {
    let bar = Rect::from_min_size(
        rect.left_bottom() + Vec2::new(16.0, -40.0),
        Vec2::new(220.0, 12.0),
    );
    let steps = 44;
    for i in 0..steps {
        let t = (i as f32 + 0.5) / steps as f32 * 2.0 - 1.0;
        let (base, weight) = if t > 0.0 {
            ([1.0, 0.35, 0.02], t)
        } else {
            ([0.05, 0.35, 1.0], -t)
        };
        let [r, g, b] = base.map(|c: f32| (linear_to_srgb(c * weight) * 255.0) as u8);
        let x0 = bar.min.x + bar.width() * i as f32 / steps as f32;
        let cell = Rect::from_min_max(
            Pos2::new(x0, bar.min.y),
            Pos2::new(x0 + bar.width() / steps as f32 + 0.5, bar.max.y),
        );
        painter.rect_filled(cell, 0.0, Color32::from_rgb(r, g, b));
    }
    let font = egui::FontId::proportional(12.0);
    let below = bar.max.y + 2.0;
    painter.text(
        Pos2::new(bar.min.x, below),
        egui::Align2::LEFT_TOP,
        format!("−{range:.3}"),
        font.clone(),
        Color32::WHITE,
    );
    painter.text(
        Pos2::new(bar.center().x, below),
        egui::Align2::CENTER_TOP,
        "0",
        font.clone(),
        Color32::WHITE,
    );
    painter.text(
        Pos2::new(bar.max.x, below),
        egui::Align2::RIGHT_TOP,
        format!("+{range:.3}"),
        font,
        Color32::WHITE,
    );
}

/// The curvature view's colours, as the shader draws them (`crates/cdrf-render/shaders/colour.wgsl`,
/// `cool_warm`: sRGB blue → grey → red, linear in sRGB), at `t` ∈ [0, 1].
pub fn curvature_colour(t: f32) -> Color32 {
    const COOL: [f32; 3] = [0.230, 0.299, 0.754];
    const MIDDLE: [f32; 3] = [0.865, 0.865, 0.865];
    const WARM: [f32; 3] = [0.706, 0.016, 0.150];
    let x = t.clamp(0.0, 1.0);
    let (from, to, s) = if x < 0.5 {
        (COOL, MIDDLE, x * 2.0)
    } else {
        (MIDDLE, WARM, x * 2.0 - 1.0)
    };
    let [r, g, b] = [0, 1, 2].map(|i| ((from[i] + (to[i] - from[i]) * s) * 255.0).round() as u8);
    Color32::from_rgb(r, g, b)
}

/// A colour bar for the curvature view with its range in mm⁻¹ (and the radius it means).
pub fn curvature_legend(ui: &egui::Ui, rect: Rect, range_per_mm: [f32; 2]) {
    let painter = ui.painter_at(rect);
    let bar = Rect::from_min_size(
        rect.left_bottom() + Vec2::new(16.0, -44.0),
        Vec2::new(240.0, 12.0),
    );
    let steps = 48;
    for i in 0..steps {
        let x0 = bar.min.x + bar.width() * i as f32 / steps as f32;
        let cell = Rect::from_min_max(
            Pos2::new(x0, bar.min.y),
            Pos2::new(x0 + bar.width() / steps as f32 + 0.5, bar.max.y),
        );
        painter.rect_filled(cell, 0.0, curvature_colour((i as f32 + 0.5) / steps as f32));
    }
    let font = egui::FontId::proportional(12.0);
    let below = bar.max.y + 2.0;
    let [low, high] = range_per_mm;
    painter.text(
        Pos2::new(bar.min.x, below),
        egui::Align2::LEFT_TOP,
        format!("{low:.3}"),
        font.clone(),
        Color32::WHITE,
    );
    painter.text(
        Pos2::new(bar.center().x, below),
        egui::Align2::CENTER_TOP,
        format!("{:.3} /mm", 0.5 * (low + high)),
        font.clone(),
        Color32::WHITE,
    );
    painter.text(
        Pos2::new(bar.max.x, below),
        egui::Align2::RIGHT_TOP,
        format!("{high:.3}"),
        font.clone(),
        Color32::WHITE,
    );
    painter.text(
        Pos2::new(bar.min.x, bar.min.y - 4.0),
        egui::Align2::LEFT_BOTTOM,
        format!(
            "mean curvature κ (convex > 0; r = 1/κ: {:.1} mm at the ends)",
            1.0 / high.abs().max(1e-6)
        ),
        font,
        Color32::WHITE,
    );
}
