//! Plots: the SVG is well formed, ticks are nice, lines are clipped and broken at gaps; the
//! pictures have the right size and colours.
//!
//! Set `CDRF_PLOT_SAMPLES=DIR` to also write the sample plots there for a look.

use cdrf_core::image_file::linear_to_srgb;
use cdrf_fit::image_io::srgb_to_linear;
use cdrf_fit::plot::{
    ColorScale, Colormap, LinePlot, LineStyle, NO_DATA_COLOR, PALETTE, Series, heatmap_png,
    rgb_png_srgb, upscale_nearest,
};
use glam::Vec3;

/// Checks that every tag is closed in order; returns the number of elements.
#[track_caller]
fn assert_well_formed(svg: &str) -> usize {
    assert!(
        svg.starts_with("<svg xmlns=\"http://www.w3.org/2000/svg\""),
        "{}",
        &svg[..svg.len().min(80)]
    );
    assert!(svg.trim_end().ends_with("</svg>"));
    // (The plots' own text avoids these words.)
    for bad in ["NaN", "inf", "e+", "<>"] {
        assert!(!svg.contains(bad), "SVG contains {bad:?}");
    }
    let mut stack: Vec<&str> = Vec::new();
    let mut elements = 0;
    let mut rest = svg;
    while let Some(start) = rest.find('<') {
        let end = rest[start..].find('>').expect("unterminated tag") + start;
        let tag = &rest[start + 1..end];
        if let Some(name) = tag.strip_prefix('/') {
            let open = stack
                .pop()
                .unwrap_or_else(|| panic!("</{name}> closes nothing"));
            assert_eq!(open, name, "</{name}> closes <{open}>");
        } else {
            elements += 1;
            let name = tag.split_whitespace().next().unwrap_or("");
            assert!(!name.is_empty(), "empty tag name");
            if !tag.ends_with('/') {
                stack.push(name);
            }
        }
        rest = &rest[end + 1..];
    }
    assert!(stack.is_empty(), "unclosed: {stack:?}");
    elements
}

/// The text of the tick labels in the group with `class`.
fn tick_labels(svg: &str, class: &str) -> Vec<String> {
    let start = svg
        .find(&format!("<g class=\"{class}\""))
        .unwrap_or_else(|| panic!("no {class} group"));
    let group = &svg[start..start + svg[start..].find("</g>").unwrap()];
    group
        .split("<text")
        .skip(1)
        .map(|t| {
            let body = &t[t.find('>').unwrap() + 1..t.find("</text>").unwrap()];
            body.replace('\u{2212}', "-")
        })
        .collect()
}

/// Asserts labels are equally spaced multiples of 1, 2 or 5 × 10^k; returns the step.
#[track_caller]
fn assert_nice(labels: &[String]) -> f64 {
    let values: Vec<f64> = labels
        .iter()
        .map(|l| {
            l.parse::<f64>()
                .unwrap_or_else(|_| panic!("tick label {l:?} is not a number"))
        })
        .collect();
    assert!(values.len() >= 3, "too few ticks: {labels:?}");
    assert!(values.len() <= 12, "too many ticks: {labels:?}");
    let step = values[1] - values[0];
    for pair in values.windows(2) {
        let d = pair[1] - pair[0];
        assert!(
            (d - step).abs() <= 1e-9 * step.abs(),
            "uneven ticks {labels:?}"
        );
    }
    let mantissa = step / 10f64.powf(step.log10().floor());
    assert!(
        [1.0, 2.0, 5.0].iter().any(|m| (mantissa - m).abs() < 1e-6),
        "step {step} is not 1/2/5 × 10^k: {labels:?}"
    );
    for v in &values {
        let k = (v / step).round();
        assert!(
            (v - k * step).abs() <= 1e-9 * step,
            "{v} is not a multiple of {step}"
        );
    }
    step
}

/// `(x0, y0, x1, y1)` of the plot frame.
fn frame(svg: &str) -> (f64, f64, f64, f64) {
    let line = svg
        .lines()
        .find(|l| l.contains("class=\"frame\""))
        .expect("no frame");
    let attr = |name: &str| -> f64 {
        let key = format!(" {name}=\"");
        let s = &line[line.find(&key).unwrap() + key.len()..];
        s[..s.find('"').unwrap()].parse().unwrap()
    };
    let (x, y) = (attr("x"), attr("y"));
    (x, y, x + attr("width"), y + attr("height"))
}

fn polylines(svg: &str) -> Vec<Vec<(f64, f64)>> {
    svg.lines()
        .filter_map(|l| l.strip_prefix("<polyline points=\""))
        .map(|l| {
            l[..l.find('"').unwrap()]
                .split(' ')
                .map(|p| {
                    let (x, y) = p.split_once(',').unwrap();
                    (x.parse().unwrap(), y.parse().unwrap())
                })
                .collect()
        })
        .collect()
}

fn sample_curves() -> LinePlot {
    let radii = [15.0_f32, 25.0, 35.0, 50.0];
    let mut plot = LinePlot::new(
        "Wax spheres: radiance against θ",
        "θ (degrees)",
        "radiance / irradiance",
    );
    for (i, r) in radii.iter().enumerate() {
        let t = i as f32 / (radii.len() - 1) as f32;
        let fit: Vec<(f32, f32)> = (0..=180)
            .map(|d| {
                let theta = (d as f32).to_radians();
                let lit = theta.cos().max(0.0) * 0.3;
                let glow = 0.02 * (15.0 / r) * (-(theta - 1.5).max(0.0) * r / 10.0).exp();
                (d as f32, lit + glow)
            })
            .collect();
        let measured: Vec<(f32, f32)> = fit
            .iter()
            .step_by(6)
            .map(|&(x, y)| (x, y * (1.0 + 0.05 * ((x * 0.7 + r).sin()))))
            .collect();
        let color = Colormap::Viridis.color_at(0.9 * t);
        plot = plot
            .with_series(Series::new(format!("r = {r} mm"), color, fit))
            .with_series(Series::new("", color, measured).with_style(LineStyle::Markers));
    }
    plot.with_series(
        Series::new(
            "Lambert 0.8/π",
            PALETTE[6],
            (0..=90)
                .map(|d| {
                    (
                        d as f32,
                        0.8 / std::f32::consts::PI * (d as f32).to_radians().cos().max(0.0),
                    )
                })
                .collect(),
        )
        .with_style(LineStyle::Dashed),
    )
}

#[test]
fn sample_plot_is_well_formed_with_labels_legend_and_nice_ticks() {
    let plot = sample_curves();
    let svg = plot.to_svg();
    let elements = assert_well_formed(&svg);
    println!("sample plot: {} bytes, {elements} elements", svg.len());
    for needle in [
        "Wax spheres: radiance against θ",
        "θ (degrees)",
        "radiance / irradiance",
        "r = 15 mm",
        "r = 50 mm",
        "Lambert 0.8/π",
        "stroke-dasharray",
        "<circle",
        r#"width="720" height="480""#,
    ] {
        assert!(svg.contains(needle), "SVG lacks {needle:?}");
    }
    let x_labels = tick_labels(&svg, "x-ticks");
    println!(
        "x ticks: {x_labels:?}, y ticks: {:?}",
        tick_labels(&svg, "y-ticks")
    );
    assert_eq!(assert_nice(&x_labels), 20.0);
    assert_eq!(x_labels.first().map(String::as_str), Some("0"));
    assert_eq!(x_labels.last().map(String::as_str), Some("180"));
    assert_nice(&tick_labels(&svg, "y-ticks"));
    // Unlabelled series stay out of the legend: 4 radii + Lambert.
    let legend = &svg[svg.find("<g class=\"legend\"").unwrap()..];
    assert_eq!(legend.matches("<text").count(), 5);

    let log_svg = plot.clone().with_log_y(true).to_svg();
    assert_well_formed(&log_svg);

    if let Some(dir) = std::env::var_os("CDRF_PLOT_SAMPLES") {
        let dir = std::path::PathBuf::from(dir);
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("sample_plot.svg"), &svg).unwrap();
        std::fs::write(dir.join("sample_plot_log.svg"), &log_svg).unwrap();
        let (w, h) = (181, 64);
        let values: Vec<f32> = (0..w * h)
            .map(|i| {
                let (theta, k) = ((i % w) as f32, (i / w) as f32 / (h - 1) as f32);
                theta.to_radians().cos().max(0.0) * 0.3
                    + 0.03 * k * (-(theta - 90.0).max(0.0) / (10.0 + 30.0 * k)).exp()
            })
            .collect();
        upscale_nearest(&heatmap_png(&values, w, h, ColorScale::log()), 4, 4)
            .save(dir.join("sample_heatmap_log.png"))
            .unwrap();
        upscale_nearest(
            &heatmap_png(
                &values,
                w,
                h,
                ColorScale::linear().with_colormap(Colormap::Inferno),
            ),
            4,
            4,
        )
        .save(dir.join("sample_heatmap_inferno.png"))
        .unwrap();
        let rgb: Vec<Vec3> = values
            .iter()
            .map(|&v| Vec3::new(v, v * 0.9, v * 0.8))
            .collect();
        upscale_nearest(&rgb_png_srgb(&rgb, w, h, 3.0), 4, 4)
            .save(dir.join("sample_rgb.png"))
            .unwrap();
        println!("sample plots written to {}", dir.display());
    }
}

#[test]
fn nice_ticks_for_awkward_ranges() {
    // (data from, data to), explicit x range.
    type Case = ((f32, f32), Option<(f32, f32)>);
    let cases: &[Case] = &[
        ((-0.013, 0.047), None),
        ((1.2e6, 3.4e6), None),
        ((2e-6, 9e-6), None),
        ((0.3, 0.3), None),
        ((0.0, 0.0), None),
        ((-7.0, 3.0), None),
        ((0.0, 1.0), Some((0.0, 180.0))),
        ((0.0, 1.0), Some((0.05, 0.95))),
    ];
    for &((lo, hi), range) in cases {
        let mut plot = LinePlot::new("t", "x", "y").with_series(Series::new(
            "s",
            PALETTE[0],
            vec![(lo, lo), (hi, hi)],
        ));
        if let Some((a, b)) = range {
            plot = plot.with_x_range(a, b);
        }
        let svg = plot.to_svg();
        assert_well_formed(&svg);
        let x = tick_labels(&svg, "x-ticks");
        let y = tick_labels(&svg, "y-ticks");
        println!("data {lo}..{hi}, range {range:?}: x {x:?}, y {y:?}");
        let step = assert_nice(&x);
        assert_nice(&y);
        let values: Vec<f64> = x.iter().map(|l| l.parse().unwrap()).collect();
        match range {
            Some((a, b)) => {
                assert!(
                    values[0] >= f64::from(a) - 1e-9
                        && *values.last().unwrap() <= f64::from(b) + 1e-9
                );
            }
            None => {
                // The axis is widened to whole ticks around the data.
                assert!(
                    values[0] <= f64::from(lo) + 1e-9 * step
                        && *values.last().unwrap() >= f64::from(hi) - 1e-9 * step
                );
            }
        }
    }
}

#[test]
fn log_axis_labels_decades_from_1e_minus_5_to_1() {
    let points: Vec<(f32, f32)> = (0..=50)
        .map(|i| (i as f32, 10f32.powf(-5.0 + i as f32 / 10.0)))
        .collect();
    let svg = LinePlot::new("log", "x", "y")
        .with_log_y(true)
        .with_series(Series::new("decay", PALETTE[5], points))
        .to_svg();
    assert_well_formed(&svg);
    let labels = tick_labels(&svg, "y-ticks");
    println!("log y ticks: {labels:?}");
    let powers: Vec<String> = (-5..=0)
        .map(|k| format!(r#"10<tspan dy="-6" font-size="9">{k}</tspan>"#))
        .collect();
    assert_eq!(labels, powers);
    // Minor ticks at 2..9 × 10^k: 5 decades × 8.
    let ticks = &svg[svg.find("<g class=\"ticks\"").unwrap()..];
    let ticks = &ticks[..ticks.find("</g>").unwrap()];
    assert_eq!(
        ticks.matches("<line").count(),
        tick_labels(&svg, "x-ticks").len() + 6 + 5 * 8
    );

    // Less than two decades: 1/2/5 labels in plain numbers.
    let svg = LinePlot::new("", "", "")
        .with_log_y(true)
        .with_y_range(0.02, 0.6)
        .with_series(Series::new("s", PALETTE[1], vec![(0.0, 0.03), (1.0, 0.5)]))
        .to_svg();
    assert_well_formed(&svg);
    let labels = tick_labels(&svg, "y-ticks");
    println!("short log y ticks: {labels:?}");
    assert_eq!(labels, ["0.02", "0.05", "0.1", "0.2", "0.5"]);
}

#[test]
fn empty_and_degenerate_plots_do_not_panic() {
    let nan = f32::NAN;
    let plots = [
        LinePlot::default(),
        LinePlot::new("no data", "x", "y").with_series(Series::new("empty", PALETTE[1], vec![])),
        LinePlot::new("all not finite", "x", "y").with_series(Series::new(
            "bad",
            PALETTE[2],
            vec![(nan, 1.0), (1.0, nan)],
        )),
        LinePlot::new("log of zeros", "x", "y")
            .with_log_y(true)
            .with_series(Series::new("z", PALETTE[3], vec![(0.0, 0.0), (1.0, -1.0)])),
        LinePlot::new("one point", "x", "y").with_series(
            Series::new("p", PALETTE[4], vec![(3.0, 3.0)]).with_style(LineStyle::Markers),
        ),
        LinePlot::new("bad ranges", "x", "y")
            .with_x_range(5.0, 1.0)
            .with_y_range(nan, 1.0)
            .with_series(Series::new("s", PALETTE[5], vec![(0.0, 0.0), (1.0, 1.0)])),
        LinePlot::new("tiny", "x", "y")
            .with_size_px(10, 10)
            .with_series(Series::new("s", PALETTE[6], vec![(0.0, 0.0), (1.0, 1.0)])),
        LinePlot::new("huge values", "x", "y").with_series(Series::new(
            "s",
            PALETTE[7],
            vec![(0.0, -3e38), (1.0, 3e38), (2.0, f32::INFINITY)],
        )),
    ];
    for plot in &plots {
        println!("{}", plot.title);
        let svg = plot.to_svg();
        assert_well_formed(&svg);
        assert_nice(&tick_labels(&svg, "x-ticks"));
    }
}

#[test]
fn lines_are_clipped_to_the_frame_and_broken_at_gaps() {
    let points = vec![
        (0.0, 0.5),
        (1.0, 5.0), // far above the range: clipped
        (2.0, 0.5),
        (3.0, f32::NAN), // gap
        (4.0, 0.2),
        (5.0, 0.8),
        (6.0, -100.0), // below: clipped
    ];
    let svg = LinePlot::new("clip", "x", "y")
        .with_x_range(0.0, 6.0)
        .with_y_range(0.0, 1.0)
        .with_series(Series::new("s", PALETTE[1], points.clone()))
        .to_svg();
    assert_well_formed(&svg);
    let (x0, y0, x1, y1) = frame(&svg);
    let lines = polylines(&svg);
    println!("{} polylines: {lines:?}", lines.len());
    // (0)→(1) leaves at the top, (1)→(2) comes back: two runs; then (4)→(5)→(6) clipped at the bottom.
    assert_eq!(lines.len(), 3, "{lines:?}");
    for (x, y) in lines.iter().flatten() {
        assert!(
            *x >= x0 - 0.05 && *x <= x1 + 0.05 && *y >= y0 - 0.05 && *y <= y1 + 0.05,
            "({x}, {y}) outside the frame ({x0}, {y0})–({x1}, {y1})"
        );
    }
    assert!(
        (lines[0].last().unwrap().1 - y0).abs() < 0.06,
        "first run should end on the top edge"
    );
    assert!(
        (lines[2].last().unwrap().1 - y1).abs() < 0.06,
        "last run should end on the bottom edge"
    );

    // On a log axis, values ≤ 0 break the line.
    let svg = LinePlot::new("log gap", "x", "y")
        .with_log_y(true)
        .with_series(Series::new(
            "s",
            PALETTE[2],
            vec![
                (0.0, 1.0),
                (1.0, 0.1),
                (2.0, 0.0),
                (3.0, 0.01),
                (4.0, 0.001),
            ],
        ))
        .to_svg();
    assert_eq!(polylines(&svg).len(), 2);
}

#[test]
fn text_is_escaped() {
    let svg = LinePlot::new("a < b & \"c\"", "x > 0", "y")
        .with_series(Series::new(
            "<script>",
            PALETTE[0],
            vec![(0.0, 0.0), (1.0, 1.0)],
        ))
        .to_svg();
    assert_well_formed(&svg);
    assert!(svg.contains("a &lt; b &amp; &quot;c&quot;") && svg.contains("&lt;script&gt;"));
    assert!(!svg.contains("<script"));
}

#[test]
fn colormap_endpoints_and_heatmap_pixels() {
    assert_eq!(Colormap::Viridis.color_at(0.0), [68, 1, 84]);
    assert_eq!(Colormap::Viridis.color_at(1.0), [253, 231, 37]);
    assert_eq!(Colormap::Inferno.color_at(0.0), [0, 0, 4]);
    assert_eq!(Colormap::Inferno.color_at(1.0), [252, 255, 164]);
    // Mid points agree with matplotlib (viridis(0.5) = #21918c, inferno(0.5) = #bc3754).
    assert_eq!(Colormap::Viridis.color_at(0.5), [0x21, 0x91, 0x8c]);
    assert_eq!(Colormap::Inferno.color_at(0.5), [0xbc, 0x37, 0x54]);
    assert_eq!(
        Colormap::Viridis.color_at(-3.0),
        Colormap::Viridis.color_at(0.0)
    );
    assert_eq!(
        Colormap::Viridis.color_at(7.0),
        Colormap::Viridis.color_at(1.0)
    );
    // Perceptual maps get brighter monotonically (luma of the sRGB codes).
    for map in [Colormap::Viridis, Colormap::Inferno] {
        let luma = |c: [u8; 3]| {
            0.2126 * f32::from(c[0]) + 0.7152 * f32::from(c[1]) + 0.0722 * f32::from(c[2])
        };
        let l: Vec<f32> = (0..=100)
            .map(|i| luma(map.color_at(i as f32 / 100.0)))
            .collect();
        assert!(
            l.windows(2).all(|w| w[1] >= w[0] - 0.5),
            "{map:?} luma not increasing: {l:?}"
        );
    }

    let values = [0.0, 0.5, 1.0, f32::NAN, 2.0, -1.0];
    let image = heatmap_png(&values, 3, 2, ColorScale::linear().with_range(0.0, 1.0));
    assert_eq!(image.dimensions(), (3, 2));
    assert_eq!(image.get_pixel(0, 0).0, [68, 1, 84]);
    assert_eq!(image.get_pixel(1, 0).0, Colormap::Viridis.color_at(0.5));
    assert_eq!(image.get_pixel(2, 0).0, [253, 231, 37]);
    assert_eq!(image.get_pixel(0, 1).0, NO_DATA_COLOR);
    assert_eq!(
        image.get_pixel(1, 1).0,
        [253, 231, 37],
        "above the range clamps"
    );
    assert_eq!(
        image.get_pixel(2, 1).0,
        [68, 1, 84],
        "below the range clamps"
    );

    // Automatic log range over positive values; ≤ 0 gets the lowest colour.
    let values = [1e-3, 1e-2, 1e-1, 0.0];
    let scale = ColorScale::log();
    assert_eq!(scale.resolve_range(&values), Some((1e-3, 1e-1)));
    let image = heatmap_png(&values, 4, 1, scale);
    assert_eq!(image.get_pixel(0, 0).0, [68, 1, 84]);
    assert_eq!(image.get_pixel(1, 0).0, Colormap::Viridis.color_at(0.5));
    assert_eq!(image.get_pixel(2, 0).0, [253, 231, 37]);
    assert_eq!(image.get_pixel(3, 0).0, [68, 1, 84]);
    assert_eq!(
        ColorScale::log().resolve_range(&[0.0, -1.0, f32::NAN]),
        None
    );
    // No usable value at all still gives a picture.
    assert_eq!(
        heatmap_png(&[f32::NAN; 4], 2, 2, ColorScale::log())
            .get_pixel(1, 1)
            .0,
        NO_DATA_COLOR
    );
}

#[test]
fn rgb_pictures_are_srgb_encoded_and_upscaled() {
    assert_eq!(linear_to_srgb(0.0), 0.0);
    assert!((linear_to_srgb(1.0) - 1.0).abs() < 1e-6);
    for i in 0..=20 {
        let c = i as f32 / 20.0;
        let back = linear_to_srgb(srgb_to_linear(c));
        assert!((back - c).abs() < 1e-5, "sRGB round trip {c} → {back}");
    }
    let values = [
        Vec3::new(0.0, 0.5, 1.0),
        Vec3::new(2.0, f32::NAN, -1.0),
        Vec3::new(0.25, 0.25, 0.25),
    ];
    let image = rgb_png_srgb(&values, 3, 1, 1.0);
    assert_eq!(image.get_pixel(0, 0).0, [0, 188, 255]);
    assert_eq!(image.get_pixel(1, 0).0, [255, 0, 0], "clamped; NaN → 0");
    let brighter = rgb_png_srgb(&values, 3, 1, 2.0);
    assert_eq!(
        brighter.get_pixel(2, 0).0,
        [188, 188, 188],
        "exposure 2 × 0.25 = 0.5"
    );

    let big = upscale_nearest(&image, 4, 2);
    assert_eq!(big.dimensions(), (12, 2));
    assert_eq!(big.get_pixel(3, 1).0, [0, 188, 255]);
    assert_eq!(big.get_pixel(4, 0).0, [255, 0, 0]);
    assert_eq!(big.get_pixel(11, 1), image.get_pixel(2, 0));
    assert_eq!(upscale_nearest(&image, 0, 0).dimensions(), (3, 1));
}
