//! The report's pictures: the error-against-time plot (SVG), heat maps of the per-pixel
//! relative error and magnified crops (PNG).

use super::figures::{Group, Method, Run};
use super::metrics::relative_errors;
use irr_render::{Image, tone_map};
use std::path::Path;

/// Writes an 8-bit RGB PNG.
pub fn write_png(path: &Path, width: u32, height: u32, rgb: &[u8]) -> Result<(), String> {
    let file = std::fs::File::create(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut encoder = png::Encoder::new(std::io::BufWriter::new(file), width, height);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    let mut writer = encoder
        .write_header()
        .map_err(|e| format!("{}: {e}", path.display()))?;
    writer
        .write_image_data(rgb)
        .map_err(|e| format!("{}: {e}", path.display()))
}

/// The upper end of the heat maps' scale: a relative error of 0.25 or more is the brightest.
pub const HEAT_MAP_MAX: f32 = 0.25;

/// A heat map of the per-pixel relative error, through FLIP's magma colour map, 0 (black) to
/// [`HEAT_MAP_MAX`] (white-yellow).
pub fn write_heat_map(path: &Path, image: &Image, reference: &Image) -> Result<(), String> {
    let lut = nv_flip::magma_lut().to_vec();
    let rgb: Vec<u8> = relative_errors(image, reference)
        .into_iter()
        .flat_map(|e| {
            let i = ((e / HEAT_MAP_MAX).clamp(0.0, 1.0) * 255.0) as usize;
            [lut[3 * i], lut[3 * i + 1], lut[3 * i + 2]]
        })
        .collect();
    write_png(path, image.width(), image.height(), &rgb)
}

/// The top-left corner of the `size`-pixel window where `image` errs most against `reference`
/// (windows stepped by a quarter of their size).
pub fn worst_window(image: &Image, reference: &Image, size: u32) -> (u32, u32) {
    let (w, h) = (image.width(), image.height());
    let size = size.min(w).min(h);
    let err = relative_errors(image, reference);
    let mut best = (0u32, 0u32, -1.0f64);
    let step = (size / 4).max(1);
    for y0 in (0..=h - size).step_by(step as usize) {
        for x0 in (0..=w - size).step_by(step as usize) {
            let mut sum = 0.0f64;
            for y in y0..y0 + size {
                for x in x0..x0 + size {
                    sum += f64::from(err[(y * w + x) as usize]);
                }
            }
            if sum > best.2 {
                best = (x0, y0, sum);
            }
        }
    }
    (best.0, best.1)
}

/// The `size`-pixel window at `corner` of each panel, magnified ×4, side by side.
pub fn write_crops(
    path: &Path,
    panels: &[&Image],
    corner: (u32, u32),
    size: u32,
) -> Result<(), String> {
    let Some(first) = panels.first() else {
        return Ok(());
    };
    let size = size.min(first.width()).min(first.height());
    let (x0, y0) = corner;
    let zoom = 4u32;
    let n = panels.len() as u32;
    let (pw, ph) = (n * size * zoom + (n - 1) * zoom, size * zoom);
    let mut rgb = vec![255u8; (pw * ph * 3) as usize];
    for (k, panel) in panels.iter().enumerate() {
        let ox = k as u32 * (size * zoom + zoom);
        for y in 0..size * zoom {
            for x in 0..size * zoom {
                let v = panel.get(x0 + x / zoom, y0 + y / zoom);
                let at = ((y * pw + ox + x) * 3) as usize;
                for c in 0..3 {
                    rgb[at + c] = tone_map(v[c], 0.0);
                }
            }
        }
    }
    write_png(path, pw, ph, &rgb)
}

/// Log-log plot of relMSE against seconds, as SVG (plotters; text needs no font file in SVG):
/// each method's primary series as a line with its points labelled, the path tracer's adaptive
/// runs as crosses of its colour, the cache's ablations as grey labelled points.
pub fn write_plot(path: &Path, runs: &[Run], title: &str) -> Result<(), String> {
    use plotters::prelude::*;
    let err = |e: &dyn std::fmt::Display| format!("{}: {e}", path.display());
    let t_min = runs
        .iter()
        .map(|r| r.seconds)
        .fold(f64::INFINITY, f64::min)
        .max(1e-3);
    let t_max = runs
        .iter()
        .map(|r| r.seconds)
        .fold(0.0, f64::max)
        .max(t_min * 2.0);
    let e_min = runs
        .iter()
        .map(|r| r.metrics.rel_mse)
        .fold(f64::INFINITY, f64::min)
        .max(1e-9);
    let e_max = runs
        .iter()
        .map(|r| r.metrics.rel_mse)
        .fold(0.0, f64::max)
        .max(e_min * 2.0);
    let root = SVGBackend::new(path, (960, 680)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 20))
        .margin(20)
        .x_label_area_size(45)
        .y_label_area_size(70)
        .build_cartesian_2d(
            (t_min * 0.7..t_max * 1.4).log_scale(),
            (e_min * 0.7..e_max * 1.4).log_scale(),
        )
        .map_err(|e| err(&e))?;
    chart
        .configure_mesh()
        .x_desc("wall-clock seconds (construction + final pass + denoiser)")
        .y_desc("relMSE against the reference")
        .y_label_formatter(&|v| format!("{v:.0e}"))
        .draw()
        .map_err(|e| err(&e))?;
    let styles = [
        (Method::Path, "path tracer", RGBColor(31, 90, 200)),
        (
            Method::PathDenoised,
            "path tracer + OIDN",
            RGBColor(20, 170, 200),
        ),
        (
            Method::Cache,
            "irradiance cache (κ ladder)",
            RGBColor(200, 30, 30),
        ),
        (
            Method::CacheDenoised,
            "irradiance cache + OIDN",
            RGBColor(230, 140, 20),
        ),
    ];
    for (method, name, colour) in styles {
        let mut pts: Vec<(f64, f64, String)> = runs
            .iter()
            .filter(|r| r.method == method && r.group.primary())
            .map(|r| (r.seconds, r.metrics.rel_mse, r.label.clone()))
            .collect();
        if pts.is_empty() {
            continue;
        }
        pts.sort_by(|a, b| a.0.total_cmp(&b.0));
        chart
            .draw_series(LineSeries::new(pts.iter().map(|p| (p.0, p.1)), colour))
            .map_err(|e| err(&e))?
            .label(name)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], colour));
        chart
            .draw_series(pts.iter().map(|p| {
                EmptyElement::at((p.0, p.1))
                    + Circle::new((0, 0), 4, colour.filled())
                    + Text::new(p.2.clone(), (6, -6), ("sans-serif", 11).into_font())
            }))
            .map_err(|e| err(&e))?;
        chart
            .draw_series(
                runs.iter()
                    .filter(|r| r.method == method && r.group == Group::Adaptive)
                    .map(|r| {
                        EmptyElement::at((r.seconds, r.metrics.rel_mse))
                            + Cross::new((0, 0), 5, colour.stroke_width(2))
                            + Text::new(r.label.clone(), (6, 4), ("sans-serif", 11).into_font())
                    }),
            )
            .map_err(|e| err(&e))?;
    }
    let grey = RGBColor(130, 130, 130);
    let ablations: Vec<&Run> = runs
        .iter()
        .filter(|r| r.method.cache() && !r.group.primary())
        .collect();
    if !ablations.is_empty() {
        chart
            .draw_series(ablations.iter().map(|r| {
                EmptyElement::at((r.seconds, r.metrics.rel_mse))
                    + Circle::new((0, 0), 3, grey.filled())
                    + Text::new(r.label.clone(), (6, 4), ("sans-serif", 10).into_font())
            }))
            .map_err(|e| err(&e))?
            .label("cache ablations")
            .legend(move |(x, y)| Circle::new((x + 10, y), 3, grey.filled()));
    }
    chart
        .configure_series_labels()
        .border_style(BLACK)
        .background_style(WHITE.mix(0.9))
        .draw()
        .map_err(|e| err(&e))?;
    root.present().map_err(|e| err(&e))?;
    Ok(())
}
