//! `--strategy auto` (the default): the strategy is measured once per device, kept in the
//! calibration cache and read back from there; `--json` says which strategy ran and whether it
//! was chosen or given; a damaged cache entry is measured again, never an error. Every run has
//! the validation layer on (the binary fails on any validation error).

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use common::*;

fn run_with_cache(args: &[&str], cache: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_tiltfield"))
        .args(args)
        .env("TILTFIELD_VALIDATION", "1")
        .env("TILTFIELD_STRATEGY_CACHE_DIR", cache)
        .env_remove("RUST_LOG")
        .output()
        .expect("run tiltfield")
}

fn render_json(dir: &Path, cache: &Path, extra: &[&str]) -> serde_json::Value {
    let out = dir.join("out.png");
    let mut args = vec![
        "render",
        "builtin:demo",
        "-o",
        out.to_str().unwrap(),
        "--disparity",
        "0.5",
        "--antialias",
        "off",
        "--json",
    ];
    args.extend_from_slice(extra);
    json_of(&run_with_cache(&args, cache))
}

fn entries(cache: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(cache)
        .map(|d| d.flatten().map(|e| e.path()).collect())
        .unwrap_or_default();
    v.retain(|p| p.extension().is_some_and(|e| e == "json"));
    v
}

const CANDIDATES: [&str; 3] = ["fragment", "compute", "batched:16"];

#[test]
fn auto_measures_once_keeps_the_choice_and_reads_it_back() {
    let dir = tempfile::tempdir().unwrap();
    let cache = dir.path().join("strategy");
    let first = render_json(dir.path(), &cache, &[]);
    assert_eq!(first["strategy_source"], "auto");
    let chosen = first["strategy"].as_str().unwrap().to_string();
    assert!(CANDIDATES.contains(&chosen.as_str()), "{chosen}");

    // The entry names the device and every candidate's median, and its choice is the render's.
    let files = entries(&cache);
    assert_eq!(files.len(), 1, "{files:?}");
    let entry: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&files[0]).unwrap()).unwrap();
    assert_eq!(entry["chosen"], chosen.as_str());
    assert_eq!(entry["device"], first["device"]);
    for c in CANDIDATES {
        let ms = entry["medians_ms"][c].as_f64().unwrap_or(-1.0);
        assert!(ms > 0.0 && ms.is_finite(), "{c}: {ms}");
    }

    // A later run reads the entry: one planted with another choice is obeyed.
    let other = CANDIDATES.iter().find(|c| **c != chosen).unwrap();
    let mut planted = entry.clone();
    planted["chosen"] = serde_json::json!(other);
    std::fs::write(&files[0], serde_json::to_vec(&planted).unwrap()).unwrap();
    let second = render_json(dir.path(), &cache, &[]);
    assert_eq!(second["strategy"], *other);
    assert_eq!(second["strategy_source"], "auto");

    // A given strategy wins and says so; --views-per-draw is batched:N.
    let given = render_json(dir.path(), &cache, &["--strategy", "compute"]);
    assert_eq!(
        (
            given["strategy"].as_str(),
            given["strategy_source"].as_str()
        ),
        (Some("compute"), Some("option"))
    );
    let batched = render_json(dir.path(), &cache, &["--views-per-draw", "4"]);
    assert_eq!(
        (
            batched["strategy"].as_str(),
            batched["strategy_source"].as_str()
        ),
        (Some("batched:4"), Some("option"))
    );
}

#[test]
fn a_damaged_or_foreign_entry_is_measured_again() {
    let dir = tempfile::tempdir().unwrap();
    let cache = dir.path().join("strategy");
    render_json(dir.path(), &cache, &[]);
    let file = entries(&cache).pop().unwrap();
    let good: serde_json::Value = serde_json::from_slice(&std::fs::read(&file).unwrap()).unwrap();
    let mut foreign = good.clone();
    foreign["device"] = serde_json::json!("another GPU");
    foreign["chosen"] = serde_json::json!("batched:16");
    let mut unknown = good.clone();
    unknown["chosen"] = serde_json::json!("batched:3");
    for damaged in [
        b"{ not json".to_vec(),
        Vec::new(),
        serde_json::to_vec(&foreign).unwrap(),
        serde_json::to_vec(&unknown).unwrap(),
    ] {
        std::fs::write(&file, &damaged).unwrap();
        let j = render_json(dir.path(), &cache, &[]);
        assert_eq!(j["strategy_source"], "auto");
        let s = j["strategy"].as_str().unwrap();
        assert!(CANDIDATES.contains(&s), "{s}");
        // Replaced by a valid entry for this device.
        let again: serde_json::Value =
            serde_json::from_slice(&std::fs::read(&file).unwrap()).expect("rewritten as JSON");
        assert_eq!(again["device"], good["device"]);
        assert_eq!(again["chosen"], s);
    }
}

#[test]
fn an_unwritable_cache_costs_a_measurement_not_an_error() {
    let dir = tempfile::tempdir().unwrap();
    // A file where the folder should be: nothing can be kept there.
    let blocked = dir.path().join("blocked");
    std::fs::write(&blocked, b"x").unwrap();
    let j = render_json(dir.path(), &blocked, &[]);
    assert_eq!(j["strategy_source"], "auto");
    assert!(CANDIDATES.contains(&j["strategy"].as_str().unwrap()));
}

#[test]
fn devices_calibrate_prints_every_candidate_and_keeps_the_choice() {
    let dir = tempfile::tempdir().unwrap();
    let cache = dir.path().join("strategy");
    let j = json_of(&run_with_cache(
        &["devices", "--calibrate", "--json"],
        &cache,
    ));
    for c in CANDIDATES {
        assert!(j["medians_ms"][c].as_f64().unwrap() > 0.0, "{c}");
    }
    let chosen = j["chosen"].as_str().unwrap();
    let kept = PathBuf::from(j["cache_file"].as_str().unwrap());
    assert!(kept.starts_with(&cache), "{kept:?}");
    // A render then uses it without measuring again.
    let r = render_json(dir.path(), &cache, &[]);
    assert_eq!(r["strategy"], chosen);
    fails_with(
        &[
            "render",
            "builtin:demo",
            "-o",
            "x.png",
            "--strategy",
            "fast",
        ],
        &["unknown strategy 'fast'", "auto"],
    );
}
