//! Files of a benchmark run: `bench.json` (the whole report), `bench.csv` (one row per
//! measurement: every variant, then every scaling point), `homographies.json` (the default
//! plan's per-view homographies, for tools that redo the same work) and the charts.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use super::{chart, BenchReport, Homographies};
use crate::error::Result;

/// Columns of `bench.csv`.
pub const CSV_HEADER: &str = "kind,name,strategy,filter,storage,accumulation,views,width,height,\
default,frames,gpu_ms_median,gpu_ms_min,gpu_ms_max,samples_per_s,psnr_vs_reference_db,\
max_error_vs_reference,ambiguous_pixels,psnr_vs_model_db,max_error_vs_model,within_bound,psnr_vs_truth_db,\
max_error_vs_truth,texture_roof_fraction,gbps,bandwidth_roof_fraction";

fn quote(s: &str) -> String {
    format!("\"{}\"", s.replace('"', "\"\""))
}

fn num(v: Option<f64>) -> String {
    match v {
        Some(v) if v.is_finite() => format!("{v}"),
        Some(v) if v > 0.0 => "inf".into(),
        _ => String::new(),
    }
}

/// The CSV text of `report`.
pub fn csv(report: &BenchReport) -> String {
    let mut out = String::from(CSV_HEADER);
    out.push('\n');
    for v in &report.variants {
        let _ = writeln!(
            out,
            "variant,{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
            quote(&v.name),
            quote(&v.strategy),
            v.filter.name(),
            match v.storage {
                crate::refocus::settings::ViewStorage::Srgb8 => "srgb8",
                crate::refocus::settings::ViewStorage::Linear16 => "linear16",
            },
            v.accumulation.name(),
            v.views,
            v.width,
            v.height,
            v.default,
            v.frames,
            v.gpu_ms_median,
            v.gpu_ms_min,
            v.gpu_ms_max,
            v.samples_per_s,
            num(Some(v.psnr_vs_reference_db)),
            v.max_error_vs_reference,
            v.ambiguous_pixels,
            num(Some(v.psnr_vs_model_db)),
            v.max_error_vs_model,
            v.within_bound,
            num(v.psnr_vs_truth_db.flatten()),
            num(v.max_error_vs_truth.flatten()),
            num(v.texture_roof_fraction),
            num(Some(v.gbps)),
            num(v.bandwidth_roof_fraction),
        );
    }
    let d = super::Variant::default();
    for p in &report.scaling {
        let _ = writeln!(
            out,
            "scaling,{},{},{},linear16,{},{},{},{},true,{},{},{},{},{},,,,,,,,,,,",
            quote(&format!(
                "scaling {} views {}x{}",
                p.views, p.width, p.height
            )),
            quote(&report.scaling_strategy),
            d.filter.name(),
            d.accumulation.name(),
            p.views,
            p.width,
            p.height,
            p.frames,
            p.gpu_ms_median,
            p.gpu_ms_min,
            p.gpu_ms_max,
            p.samples_per_s,
        );
    }
    out
}

/// Writes every output of a run into `dir` (created if needed; on failure nothing written
/// stays). Returns the files written.
pub fn write_all(
    report: &BenchReport,
    homographies: &Homographies,
    dir: &Path,
) -> Result<Vec<PathBuf>> {
    let folder = crate::io::OutputFolder::create(dir)?;
    let json = |v: &dyn erased::Json| v.pretty();
    let mut written = vec![
        folder.write_bytes("bench.json", "JSON", json(report)?.as_bytes())?,
        folder.write_bytes("bench.csv", "CSV", csv(report).as_bytes())?,
        folder.write_bytes("homographies.json", "JSON", json(homographies)?.as_bytes())?,
    ];
    written.extend(chart::write_charts(report, &folder)?);
    folder.finish();
    Ok(written)
}

mod erased {
    use crate::error::{Error, Result};

    /// Pretty JSON of any serialisable value, behind a trait object.
    pub trait Json {
        fn pretty(&self) -> Result<String>;
    }

    impl<T: serde::Serialize> Json for T {
        fn pretty(&self) -> Result<String> {
            serde_json::to_string_pretty(self).map_err(|e| Error::Invalid(e.to_string()))
        }
    }
}
