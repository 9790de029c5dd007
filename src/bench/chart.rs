//! The two benchmark charts, drawn with `plotters` to SVG and PNG: GPU time (log axis)
//! against PSNR with one labelled point per variant (the speed–accuracy chart), and GPU time
//! against view-samples per frame with the fitted cost model (the scaling chart).
//!
//! PNG text is rasterised by `ab_glyph` from a font compiled into the binary
//! (`assets/fonts/DejaVuSans.ttf`), so no system font library is needed; SVG text names the
//! family and leaves rendering to the viewer.

use std::path::PathBuf;

use plotters::coord::Shift;
use plotters::prelude::*;

use super::{BenchReport, VariantReport};
use crate::error::{Error, Result};

const FONT: &str = "sans-serif";
const SIZE: (u32, u32) = (1000, 680);

/// Registers the embedded font once per process.
fn register_font() -> Result<()> {
    static ONCE: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    let ok = *ONCE.get_or_init(|| {
        plotters::style::register_font(
            FONT,
            FontStyle::Normal,
            include_bytes!("../../assets/fonts/DejaVuSans.ttf"),
        )
        .is_ok()
    });
    if ok {
        Ok(())
    } else {
        Err(Error::Invalid(
            "the embedded chart font does not parse".into(),
        ))
    }
}

fn chart_err(e: impl std::fmt::Display) -> Error {
    Error::Invalid(format!("drawing a chart: {e}"))
}

/// Draws both charts as `speed_accuracy.{svg,png}` and `scaling.{svg,png}` in `folder`; the
/// scaling chart only when the report has a sweep. Returns the files written.
pub fn write_charts(
    report: &BenchReport,
    folder: &crate::io::OutputFolder,
) -> Result<Vec<PathBuf>> {
    register_font()?;
    let mut written = Vec::new();
    for (stem, kind) in [
        ("speed_accuracy", Kind::SpeedAccuracy),
        ("scaling", Kind::Scaling),
    ] {
        if kind == Kind::Scaling && report.scaling.len() < 2 {
            continue;
        }
        let mut svg = String::new();
        {
            let root = SVGBackend::with_string(&mut svg, SIZE).into_drawing_area();
            draw(kind, report, &root)?;
            root.present().map_err(chart_err)?;
        }
        written.push(folder.write_bytes(format!("{stem}.svg"), "SVG", svg.as_bytes())?);
        let mut rgb = vec![0u8; (SIZE.0 * SIZE.1 * 3) as usize];
        {
            let root = BitMapBackend::with_buffer(&mut rgb, SIZE).into_drawing_area();
            draw(kind, report, &root)?;
            root.present().map_err(chart_err)?;
        }
        let img = image::RgbImage::from_raw(SIZE.0, SIZE.1, rgb)
            .ok_or_else(|| Error::Invalid("chart buffer size".into()))?;
        written.push(folder.write_with(format!("{stem}.png"), "PNG", |w| {
            crate::io::encode_png(&img, w)
        })?);
    }
    Ok(written)
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    SpeedAccuracy,
    Scaling,
}

fn draw<DB: DrawingBackend>(
    kind: Kind,
    report: &BenchReport,
    root: &DrawingArea<DB, Shift>,
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE).map_err(chart_err)?;
    match kind {
        Kind::SpeedAccuracy => speed_accuracy(report, root),
        Kind::Scaling => scaling(report, root),
    }
}

/// Lower and upper end of a padded range containing `values` (a fallback for none).
fn span(values: impl Iterator<Item = f64>, pad: f64, fallback: (f64, f64)) -> (f64, f64) {
    let (lo, hi) = values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
    if !lo.is_finite() {
        return fallback;
    }
    if hi - lo < 1e-9 {
        return (lo - pad.max(1.0), hi + pad.max(1.0));
    }
    (lo - pad * (hi - lo), hi + pad * (hi - lo))
}

/// Tick labels of a log axis: only at 1, 2 and 5 times a power of ten (the others stay as
/// unlabelled ticks), in plain or scientific notation by magnitude.
fn log_label(v: &f64) -> String {
    if *v <= 0.0 {
        return String::new();
    }
    let e = v.log10().floor();
    let lead = (v / 10f64.powf(e)).round();
    if !matches!(lead as i64, 1 | 2 | 5) || (v / 10f64.powf(e) - lead).abs() > 1e-6 {
        return String::new();
    }
    if (-2.0..5.0).contains(&e) {
        format!("{}", (v * 1000.0).round() / 1000.0)
    } else {
        format!("{lead}e{e}")
    }
}

fn speed_accuracy<DB: DrawingBackend>(
    report: &BenchReport,
    root: &DrawingArea<DB, Shift>,
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let finite = |v: &&VariantReport| v.gpu_ms_median > 0.0 && v.psnr_vs_reference_db.is_finite();
    let points: Vec<&VariantReport> = report.variants.iter().filter(finite).collect();
    let truth: Vec<(f64, f64)> = report
        .variants
        .iter()
        .filter_map(|v| {
            v.psnr_vs_truth_db
                .flatten()
                .filter(|p| p.is_finite() && v.gpu_ms_median > 0.0)
                .map(|p| (v.gpu_ms_median, p))
        })
        .collect();
    // The anti-aliasing study's points: (GPU ms, PSNR against its lens, name with the cost
    // ratio to the plain sum).
    let mut aa: Vec<(f64, f64, String)> = report
        .antialias
        .iter()
        .flat_map(|a| &a.points)
        .filter(|p| p.gpu_ms_median > 0.0 && p.psnr_vs_truth_db.is_finite())
        .map(|p| {
            let label = format!("{} ×{:.1}", p.name, p.cost_ratio);
            (p.gpu_ms_median, p.psnr_vs_truth_db, label)
        })
        .collect();
    // By time, so that alternating labels below and above separates neighbours on the chart
    // (the study lists prefiltered and sharp settings apart, whose times interleave).
    aa.sort_by(|a, b| a.0.total_cmp(&b.0));
    let (tlo, thi) = span(
        points
            .iter()
            .map(|v| v.gpu_ms_median.ln())
            .chain(aa.iter().map(|a| a.0.ln())),
        0.08,
        (0.0, 1.0),
    );
    // Room on the right for the labels of the slowest variants.
    let thi = thi + 0.15 * (thi - tlo);
    let (plo, phi) = span(
        points
            .iter()
            .map(|v| v.psnr_vs_reference_db)
            .chain(truth.iter().map(|t| t.1))
            .chain(aa.iter().map(|a| a.1)),
        0.08,
        (0.0, 100.0),
    );
    // Room at the top for the legend.
    let phi = phi + 0.2 * (phi - plo);
    let caption = format!(
        "Speed and accuracy: {} on {}",
        report.light_field.name, report.device.name
    );
    let mut chart = ChartBuilder::on(root)
        .caption(caption, (FONT, 20))
        .margin(18)
        .x_label_area_size(50)
        .y_label_area_size(65)
        .build_cartesian_2d((tlo.exp()..thi.exp()).log_scale(), plo..phi)
        .map_err(chart_err)?;
    chart
        .configure_mesh()
        .x_desc("GPU time per refocus (ms, median, log scale)")
        .y_desc("PSNR (dB)")
        .light_line_style(WHITE)
        .x_label_formatter(&log_label)
        .label_style((FONT, 14))
        .axis_desc_style((FONT, 16))
        .draw()
        .map_err(chart_err)?;
    let blue = RGBColor(31, 119, 180);
    let orange = RGBColor(230, 110, 20);
    // The default last, so that it is drawn on top of variants measured at the same point.
    let mut ordered: Vec<&&VariantReport> = points.iter().collect();
    ordered.sort_by_key(|v| v.default);
    chart
        .draw_series(ordered.iter().map(|v| {
            let style = if v.default {
                RED.filled()
            } else {
                blue.filled()
            };
            Circle::new((v.gpu_ms_median, v.psnr_vs_reference_db), 5, style)
        }))
        .map_err(chart_err)?
        .label("vs the f64 bilinear reference (red: render's default)")
        .legend(move |(x, y)| Circle::new((x, y), 5, blue.filled()));
    if !truth.is_empty() {
        chart
            .draw_series(
                truth
                    .iter()
                    .map(|&(t, p)| TriangleMarker::new((t, p), 6, orange.stroke_width(2))),
            )
            .map_err(chart_err)?
            .label("vs the optical ground truth")
            .legend(move |(x, y)| TriangleMarker::new((x, y), 6, orange.stroke_width(2)));
    }
    if !aa.is_empty() {
        let green = RGBColor(30, 140, 60);
        chart
            .draw_series(aa.iter().map(|(t, p, _)| {
                Rectangle::new([(*t * 0.97, p - 0.4), (*t * 1.03, p + 0.4)], green.filled())
            }))
            .map_err(chart_err)?
            .label("anti-aliasing study vs its lens (× plain sum's time)")
            .legend(move |(x, y)| Rectangle::new([(x - 5, y - 5), (x + 5, y + 5)], green.filled()));
        // Below, above and further below in turn, since neighbouring settings often sit close
        // together (two rows were not enough for seven settings).
        for (k, (t, p, label)) in aa.iter().enumerate() {
            let (px, py) = chart.backend_coord(&(*t, *p));
            let style = TextStyle::from((FONT, 13).into_font()).color(&green);
            let dy = [4, -18, 20][k % 3];
            root.draw(&Text::new(label.clone(), (px + 8, py + dy), style))
                .map_err(chart_err)?;
        }
    }
    // Labels: beside each point, moved up or down where they would overlap one already placed
    // (sizes estimated from the font size: about 0.6 em per character).
    let mut placed: Vec<(i32, i32, i32, i32)> = Vec::new();
    let mut by_x: Vec<&&VariantReport> = points.iter().collect();
    by_x.sort_by(|a, b| a.gpu_ms_median.total_cmp(&b.gpu_ms_median));
    for v in by_x {
        let (px, py) = chart.backend_coord(&(v.gpu_ms_median, v.psnr_vs_reference_db));
        let w = 8 * v.label.chars().count() as i32;
        let h = 14;
        let offsets = [0, -15, 15, -30, 30, -45, 45, -60, 60];
        let dy = offsets
            .iter()
            .copied()
            .find(|dy| {
                let (x0, y0) = (px + 8, py - h / 2 + dy);
                placed
                    .iter()
                    .all(|&(a, b, c, d)| x0 + w <= a || c <= x0 || y0 + h <= b || d <= y0)
            })
            .unwrap_or(0);
        let (x0, y0) = (px + 8, py - h / 2 + dy);
        placed.push((x0, y0, x0 + w, y0 + h));
        let style =
            TextStyle::from((FONT, 13).into_font()).color(if v.default { &RED } else { &BLACK });
        root.draw(&Text::new(v.label.clone(), (x0, y0), style))
            .map_err(chart_err)?;
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperLeft)
        .label_font((FONT, 14))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(chart_err)?;
    Ok(())
}

fn scaling<DB: DrawingBackend>(report: &BenchReport, root: &DrawingArea<DB, Shift>) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let pts: Vec<(f64, f64)> = report
        .scaling
        .iter()
        .filter(|p| p.view_samples > 0.0 && p.gpu_ms_median > 0.0)
        .map(|p| (p.view_samples, p.gpu_ms_median))
        .collect();
    let (xlo, xhi) = span(pts.iter().map(|p| p.0.ln()), 0.08, (0.0, 1.0));
    let (ylo, yhi) = span(pts.iter().map(|p| p.1.ln()), 0.1, (0.0, 1.0));
    let caption = format!(
        "Scaling: {} ({}) on {}",
        report.light_field.name, report.scaling_variant, report.device.name
    );
    let mut chart = ChartBuilder::on(root)
        .caption(caption, (FONT, 20))
        .margin(18)
        .x_label_area_size(50)
        .y_label_area_size(65)
        .build_cartesian_2d(
            (xlo.exp()..xhi.exp()).log_scale(),
            (ylo.exp()..yhi.exp()).log_scale(),
        )
        .map_err(chart_err)?;
    chart
        .configure_mesh()
        .x_desc("view-samples per frame (views × output pixels, log scale)")
        .y_desc("GPU time per refocus (ms, median, log scale)")
        .light_line_style(WHITE)
        .x_label_formatter(&log_label)
        .y_label_formatter(&log_label)
        .label_style((FONT, 14))
        .axis_desc_style((FONT, 16))
        .draw()
        .map_err(chart_err)?;
    let blue = RGBColor(31, 119, 180);
    chart
        .draw_series(pts.iter().map(|&p| Circle::new(p, 5, blue.filled())))
        .map_err(chart_err)?
        .label("measured (median)")
        .legend(move |(x, y)| Circle::new((x, y), 5, blue.filled()));
    if let Some(fit) = report.scaling_fit {
        let (a, b) = (xlo.exp(), xhi.exp());
        let line: Vec<(f64, f64)> = (0..=64)
            .map(|i| a * (b / a).powf(i as f64 / 64.0))
            .map(|x| (x, fit.predict_ms(x)))
            .filter(|p| p.1 > 0.0)
            .collect();
        chart
            .draw_series(LineSeries::new(line, RED.stroke_width(2)))
            .map_err(chart_err)?
            .label(format!(
                "fit: {:.2} ms + {:.3} ns per view-sample (R² {:.3})",
                fit.fixed_ms, fit.ns_per_sample, fit.r_squared
            ))
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], RED.stroke_width(2)));
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperLeft)
        .label_font((FONT, 14))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(chart_err)?;
    Ok(())
}
