//! The benchmark charts, drawn with `plotters` to SVG and PNG: GPU time (log axis) against
//! PSNR with one labelled point per variant (the speed–accuracy chart), GPU time against
//! view-samples per frame with the fitted cost model (the scaling chart), and the anti-aliasing
//! study's cost (× the plain sum, log axis) against its PSNR to the lens (the anti-aliasing
//! chart).
//!
//! PNG text is rasterised by `ab_glyph` from a font compiled into the binary
//! (`assets/fonts/DejaVuSans.ttf`), so no system font library is needed; SVG text names the
//! family and leaves rendering to the viewer.

use std::path::PathBuf;

use plotters::coord::Shift;
use plotters::prelude::*;

use super::antialias::AntialiasPoint;
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

/// Draws the charts as `speed_accuracy.{svg,png}`, `scaling.{svg,png}` and
/// `antialias.{svg,png}` in `folder`; the scaling chart only when the report has a sweep, the
/// anti-aliasing chart only when it has the study. Returns the files written.
pub fn write_charts(
    report: &BenchReport,
    folder: &crate::io::OutputFolder,
) -> Result<Vec<PathBuf>> {
    register_font()?;
    let mut written = Vec::new();
    for (stem, kind) in [
        ("speed_accuracy", Kind::SpeedAccuracy),
        ("scaling", Kind::Scaling),
        ("antialias", Kind::Antialias),
    ] {
        if kind == Kind::Scaling && report.scaling.len() < 2 {
            continue;
        }
        if kind == Kind::Antialias && study_points(report).len() < 2 {
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
    Antialias,
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
        Kind::Antialias => antialias(report, root),
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
    let (tlo, thi) = span(
        points.iter().map(|v| v.gpu_ms_median.ln()),
        0.08,
        (0.0, 1.0),
    );
    // Room on the right for the labels of the slowest variants.
    let thi = thi + 0.15 * (thi - tlo);
    let (plo, phi) = span(
        points
            .iter()
            .map(|v| v.psnr_vs_reference_db)
            .chain(truth.iter().map(|t| t.1)),
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
    // Labels: beside each point, moved up or down where they would overlap one already placed
    // (sizes estimated from the font size: about 0.6 em per character).
    let mut placed = Vec::new();
    let mut by_x: Vec<&&VariantReport> = points.iter().collect();
    by_x.sort_by(|a, b| a.gpu_ms_median.total_cmp(&b.gpu_ms_median));
    for v in by_x {
        let at = chart.backend_coord(&(v.gpu_ms_median, v.psnr_vs_reference_db));
        let (x0, y0) = place_label(&mut placed, at, &v.label);
        leader(root, at, (x0, y0))?;
        let style =
            TextStyle::from((FONT, 13).into_font()).color(if v.default { &RED } else { &BLACK });
        root.draw(&Text::new(v.label.clone(), (x0, y0), style))
            .map_err(chart_err)?;
    }
    legend(&mut chart)
}

/// The legend box of a chart's labelled series, top left.
fn legend<'a, DB: DrawingBackend + 'a, CT: plotters::coord::CoordTranslate>(
    chart: &mut ChartContext<'a, DB, CT>,
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperLeft)
        .label_font((FONT, 14))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(chart_err)
}

/// Where the label `text` of the point at backend position `(px, py)` goes: beside it, moved
/// up or down (by up to ten lines) where it would overlap one already `placed` (sizes
/// estimated from the 13-px font: about 0.6 em per character); where every place overlaps,
/// the one that overlaps least. The box is added to `placed`.
fn place_label(
    placed: &mut Vec<(i32, i32, i32, i32)>,
    (px, py): (i32, i32),
    text: &str,
) -> (i32, i32) {
    let w = 8 * text.chars().count() as i32;
    let h = 14;
    let at = |dy: i32| (px + 8, py - h / 2 + dy);
    // The area the label's box at `dy` shares with the boxes placed before.
    let overlap = |dy: i32| -> i32 {
        let (x0, y0) = at(dy);
        placed
            .iter()
            .map(|&(a, b, c, d)| {
                let ox = (x0 + w).min(c) - x0.max(a);
                let oy = (y0 + h).min(d) - y0.max(b);
                ox.max(0) * oy.max(0)
            })
            .sum()
    };
    let offsets = std::iter::once(0).chain((1..=10).flat_map(|k| [-15 * k, 15 * k]));
    // The first free place, nearest the point first; min_by_key keeps the first of equals.
    let dy = offsets.min_by_key(|&dy| overlap(dy)).unwrap_or(0);
    let (x0, y0) = at(dy);
    placed.push((x0, y0, x0 + w, y0 + h));
    (x0, y0)
}

/// A thin grey line from the point at `at` to its label at `(x0, y0)` where the label moved
/// off the point's row (crowded points): which label is whose stays readable.
fn leader<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    at: (i32, i32),
    (x0, y0): (i32, i32),
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let mid = y0 + 7;
    if (mid - at.1).abs() <= 10 {
        return Ok(());
    }
    root.draw(&PathElement::new(
        vec![(at.0 + 4, at.1), (x0 - 1, mid)],
        RGBColor(150, 150, 150).stroke_width(1),
    ))
    .map_err(chart_err)
}

/// The anti-aliasing study's points with a measured time and score.
fn study_points(report: &BenchReport) -> Vec<&AntialiasPoint> {
    report
        .antialias
        .iter()
        .flat_map(|a| &a.points)
        .filter(|p| p.cost_ratio > 0.0 && p.psnr_vs_truth_db.is_finite())
        .collect()
}

/// The anti-aliasing study: cost (× the plain sum's GPU time, log axis) against PSNR to the
/// lens, overall (filled) and out of focus (hollow), one labelled point per setting; lines
/// join the plain sum to the prefiltered settings and to the sharp ones in order of their
/// sample cap, so each line is the trade-off one switch offers.
fn antialias<DB: DrawingBackend>(report: &BenchReport, root: &DrawingArea<DB, Shift>) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let points = study_points(report);
    let (xlo, xhi) = span(points.iter().map(|p| p.cost_ratio.ln()), 0.08, (0.0, 1.0));
    // Room on the right for the labels of the costliest settings.
    let xhi = xhi + 0.2 * (xhi - xlo);
    let (ylo, yhi) = span(
        points
            .iter()
            .flat_map(|p| [p.psnr_vs_truth_db, p.psnr_out_of_focus_db]),
        0.08,
        (0.0, 50.0),
    );
    // Room at the top for the legend.
    let yhi = yhi + 0.25 * (yhi - ylo);
    let (flo, fhi) = points
        .iter()
        .map(|p| p.psnr_focused_db)
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
    let focused = if !flo.is_finite() {
        String::new()
    } else if fhi - flo < 0.05 {
        format!("; focused plane {flo:.1} dB for all")
    } else {
        format!("; focused plane {flo:.1}–{fhi:.1} dB")
    };
    // The title, then the scene on a line of its own (it is a sentence long).
    let scene = report
        .antialias
        .as_ref()
        .map_or(String::new(), |a| a.scene.clone());
    let area = root
        .titled(
            &format!(
                "Anti-aliasing: cost against accuracy on {}",
                report.device.name
            ),
            (FONT, 20),
        )
        .map_err(chart_err)?
        .titled(&format!("{scene}{focused}"), (FONT, 14))
        .map_err(chart_err)?;
    let mut chart = ChartBuilder::on(&area)
        .margin(18)
        .x_label_area_size(50)
        .y_label_area_size(65)
        .build_cartesian_2d((xlo.exp()..xhi.exp()).log_scale(), ylo..yhi)
        .map_err(chart_err)?;
    chart
        .configure_mesh()
        .x_desc("GPU time × the plain sum's (same run, medians, log scale)")
        .y_desc("PSNR against the lens (dB)")
        .light_line_style(WHITE)
        .x_label_formatter(&log_label)
        .label_style((FONT, 14))
        .axis_desc_style((FONT, 16))
        .draw()
        .map_err(chart_err)?;
    let green = RGBColor(30, 140, 60);
    let blue = RGBColor(31, 119, 180);
    // The plain sum, then each family by its cap.
    let family = |prefilter: bool| {
        let mut f: Vec<&&AntialiasPoint> = points
            .iter()
            .filter(|p| {
                p.max_samples.is_none()
                    || (p.prefilter == prefilter
                        && p.route.is_none()
                        && p.focus_test
                        && p.focused_bicubic
                        && p.occlusion)
            })
            .collect();
        f.sort_by_key(|p| p.max_samples.unwrap_or(0));
        f
    };
    for (prefilter, dash) in [(true, false), (false, true)] {
        let f = family(prefilter);
        for (y, colour) in [
            (
                f.iter()
                    .map(|p| (p.cost_ratio, p.psnr_vs_truth_db))
                    .collect::<Vec<_>>(),
                green,
            ),
            (
                f.iter()
                    .map(|p| (p.cost_ratio, p.psnr_out_of_focus_db))
                    .collect(),
                blue,
            ),
        ] {
            let style = colour.mix(if dash { 0.35 } else { 0.7 }).stroke_width(2);
            chart
                .draw_series(LineSeries::new(y, style))
                .map_err(chart_err)?;
        }
    }
    chart
        .draw_series(points.iter().map(|p| {
            Rectangle::new(
                [
                    (p.cost_ratio * 0.98, p.psnr_vs_truth_db - 0.15),
                    (p.cost_ratio * 1.02, p.psnr_vs_truth_db + 0.15),
                ],
                green.filled(),
            )
        }))
        .map_err(chart_err)?
        .label("overall (solid line: prefiltered, faint: sharp)")
        .legend(move |(x, y)| Rectangle::new([(x - 5, y - 5), (x + 5, y + 5)], green.filled()));
    chart
        .draw_series(points.iter().map(|p| {
            Circle::new(
                (p.cost_ratio, p.psnr_out_of_focus_db),
                5,
                blue.stroke_width(2),
            )
        }))
        .map_err(chart_err)?
        .label("out of focus")
        .legend(move |(x, y)| Circle::new((x, y), 5, blue.stroke_width(2)));
    // Labels keep clear of every marker as well as of each other.
    let mut placed: Vec<(i32, i32, i32, i32)> = points
        .iter()
        .flat_map(|p| [p.psnr_vs_truth_db, p.psnr_out_of_focus_db].map(|y| (p.cost_ratio, y)))
        .map(|c| {
            let (x, y) = chart.backend_coord(&c);
            (x - 6, y - 6, x + 6, y + 6)
        })
        .collect();
    let mut by_x: Vec<&&AntialiasPoint> = points.iter().collect();
    by_x.sort_by(|a, b| a.cost_ratio.total_cmp(&b.cost_ratio));
    for p in by_x {
        let label = format!("{} ×{:.1}", p.name, p.cost_ratio);
        let at = chart.backend_coord(&(p.cost_ratio, p.psnr_vs_truth_db));
        let (x0, y0) = place_label(&mut placed, at, &label);
        leader(root, at, (x0, y0))?;
        let style = TextStyle::from((FONT, 13).into_font()).color(&green);
        root.draw(&Text::new(label, (x0, y0), style))
            .map_err(chart_err)?;
    }
    legend(&mut chart)
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
    legend(&mut chart)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Boxes overlap where they share area.
    fn overlaps(a: (i32, i32, i32, i32), b: (i32, i32, i32, i32)) -> bool {
        a.0 < b.2 && b.0 < a.2 && a.1 < b.3 && b.1 < a.3
    }

    /// Fourteen points on one spot (the anti-aliasing study's crowd near ×19): every label
    /// finds a place of its own, the first beside its point, the others as near it as they
    /// can; beyond the ten lines each way a label takes the place that overlaps least.
    #[test]
    fn crowded_labels_take_places_of_their_own() {
        let mut placed = Vec::new();
        let at = (400, 300);
        let boxes: Vec<_> = (0..14)
            .map(|k| {
                let (x0, y0) = place_label(&mut placed, at, &format!("label {k} ×19.0"));
                (x0, y0, x0 + 8 * 13, y0 + 14)
            })
            .collect();
        assert_eq!((boxes[0].0, boxes[0].1), (408, 293));
        for (i, a) in boxes.iter().enumerate() {
            for b in &boxes[..i] {
                assert!(!overlaps(*a, *b), "{a:?} over {b:?}");
            }
            assert!((a.1 - 293).abs() <= 150, "{a:?}");
        }
        // A 22nd label on the same spot has no free place left (21 rows, all taken): it goes
        // where it overlaps least, beside the point over the first label, whose one-digit
        // name is narrower than the two-digit ones on the rows from label 10 on.
        for k in 14..21 {
            place_label(&mut placed, at, &format!("label {k} ×19.0"));
        }
        let (x0, y0) = place_label(&mut placed, at, "label 21 ×19.0");
        assert_eq!((x0, y0), (408, 293));
    }
}
