//! `tiltfield depth` and the commands that estimate depth when a light field has none
//! (`render --click/--points`, `cloud`), run as a user would, with the validation layer on
//! (every GPU command fails on a validation error); and every bad input as a clear error.

mod common;

use std::path::Path;

use common::{fails_with, json_of, stderr, tiltfield_cached};
use tiltfield::bench::depth_scenes::{truth, DepthScene};
use tiltfield::lightfield::pfm::read_pfm_depth;
use tiltfield::lightfield::DepthKind;

/// `tiltfield ARGS` with the depth cache in `cache`.
fn run(args: &[&str], cache: &Path) -> std::process::Output {
    tiltfield_cached(args, cache)
}

/// The planes scene as a folder of views named by row and column (no depth, no calibration).
fn grid_folder(dir: &Path) -> Vec<f32> {
    let lf = DepthScene::Planes.light_field(5, 64);
    for v in &lf.views {
        v.image
            .save(dir.join(format!("view_{:02}_{:02}.png", v.t, v.s)))
            .unwrap();
    }
    truth(&lf, DepthKind::Disparity)
}

#[test]
fn depth_writes_the_hci_disparity_of_built_in_scenes_with_json_and_confidence() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("d.pfm");
    let conf = dir.path().join("c.png");
    let o = run(
        &[
            "depth",
            "builtin:planes",
            "-o",
            out.to_str().unwrap(),
            "--confidence",
            conf.to_str().unwrap(),
            "--json",
        ],
        dir.path(),
    );
    let j = json_of(&o);
    assert_eq!(j["kind"], "disparity");
    assert_eq!(j["estimate"]["convention"]["convention"], "hci");
    assert_eq!(j["estimate"]["range_origin"], "dataset");
    let d = read_pfm_depth(&out, DepthKind::Disparity).unwrap();
    assert_eq!((d.width, d.height), (64, 64));
    assert!(d.values.iter().all(|v| v.is_finite()));
    let c = image::open(&conf).unwrap().to_luma8();
    assert_eq!(c.dimensions(), (64, 64));
    // Depth as EXR: the channel the manifest reader takes, positive and finite.
    let exr = dir.path().join("z.exr");
    let o = run(
        &[
            "depth",
            "builtin:planes",
            "-o",
            exr.to_str().unwrap(),
            "--kind",
            "depth",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let z = tiltfield::lightfield::manifest::read_exr_depth(&exr, DepthKind::Depth).unwrap();
    assert!(z.values.iter().all(|v| v.is_finite() && *v > 0.0));
}

#[test]
fn a_grid_folder_gets_classic_disparity_and_clicks_to_focus() {
    let dir = tempfile::tempdir().unwrap();
    let cache = tempfile::tempdir().unwrap();
    let hci = grid_folder(dir.path());
    let lf = dir.path().to_str().unwrap();
    // Classic shift-and-sum disparity: view s sees x + (s − s_r)·D, so D = −(HCI disparity).
    let out = cache.path().join("d.pfm");
    let o = run(
        &["depth", lf, "-o", out.to_str().unwrap(), "--json"],
        cache.path(),
    );
    let j = json_of(&o);
    assert_eq!(j["estimate"]["convention"]["convention"], "classic");
    assert_eq!(j["estimate"]["range_origin"], "automatic");
    let d = read_pfm_depth(&out, DepthKind::Disparity).unwrap();
    for (x, y) in [(10usize, 10usize), (52, 52)] {
        let i = y * 64 + x;
        assert!(
            (d.values[i] + hci[i]).abs() < 0.1,
            "({x},{y}): {} vs −{}",
            d.values[i],
            hci[i]
        );
    }
    // A click: depth is estimated (and cached), the plane is found, the render written.
    let png = cache.path().join("r.png");
    let args = [
        "render",
        lf,
        "--click",
        "20,20",
        "-o",
        png.to_str().unwrap(),
        "--json",
    ];
    let j = json_of(&run(&args, cache.path()));
    assert_eq!(j["depth"]["origin"], "estimated");
    assert_eq!(j["depth"]["cached"], false);
    assert_eq!(j["focus"]["how"], "click");
    assert!(png.is_file());
    // Again: the cache answers.
    let j = json_of(&run(&args, cache.path()));
    assert_eq!(j["depth"]["cached"], true);
    // A changed view is new content: estimated again.
    let first = dir.path().join("view_00_00.png");
    let mut img = image::open(&first).unwrap().to_rgba8();
    img.get_pixel_mut(5, 5).0[1] ^= 0x20;
    img.save(&first).unwrap();
    let j = json_of(&run(&args, cache.path()));
    assert_eq!(j["depth"]["cached"], false);
    // Three clicks on the back plane, and the cloud of the estimated depth.
    let three = [
        "render",
        lf,
        "--points",
        "8,8,30,10,12,28",
        "-o",
        png.to_str().unwrap(),
        "--json",
    ];
    let j = json_of(&run(&three, cache.path()));
    assert_eq!(j["focus"]["how"], "three-points");
    let ply = cache.path().join("c.ply");
    let j = json_of(&run(
        &["cloud", lf, "-o", ply.to_str().unwrap(), "--json"],
        cache.path(),
    ));
    assert_eq!(j["depth"]["origin"], "estimated");
    assert!(j["points"].as_u64().unwrap() > 1000, "{j}");
}

#[test]
fn bad_depth_input_is_a_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("d.pfm");
    let o = out.to_str().unwrap();
    let lf = "builtin:planes";
    fails_with(
        &["depth", lf, "-o", o, "--planes", "0"],
        &["--planes", "from 3"],
    );
    fails_with(&["depth", lf, "-o", o, "--planes", "2"], &["--planes"]);
    fails_with(&["depth", lf, "-o", o, "--range", "1,1"], &["MIN < MAX"]);
    fails_with(&["depth", lf, "-o", o, "--range", "2,-1"], &["MIN < MAX"]);
    fails_with(&["depth", lf, "-o", o, "--range", "nan,1"], &["--range"]);
    // On this rig −8/3 px is infinitely far.
    fails_with(
        &["depth", lf, "-o", o, "--range=-100,-50"],
        &["entirely", "beyond infinity"],
    );
    fails_with(
        &["depth", lf, "-o", o, "--range=-5,1"],
        &["beyond infinity"],
    );
    fails_with(
        &["depth", lf, "-o", o, "--kind", "depth", "--range", "0,4"],
        &["positive"],
    );
    fails_with(
        &["depth", lf, "-o", o, "--kind", "height"],
        &["--kind", "height"],
    );
    fails_with(&["depth", lf, "-o", o, "--views", "cross:0"], &["cross:0"]);
    fails_with(
        &["depth", lf, "-o", o, "--median", "65"],
        &["median", "at most 64"],
    );
    fails_with(
        &["depth", lf, "-o", o, "--view", "7,1"],
        &["outside", "5×5"],
    );
    fails_with(
        &["depth", lf, "-o", o, "--view", "1.5,1"],
        &["whole grid positions"],
    );
    fails_with(&["depth", lf, "-o", "d.png"], &["d.png", ".pfm or .exr"]);
    fails_with(
        &["depth", lf, "-o", o, "--confidence", "c.jpg"],
        &["c.jpg", ".png"],
    );
    // An output that cannot be written: a folder, or a path under a file.
    let folder = dir.path().join("folder.pfm");
    std::fs::create_dir(&folder).unwrap();
    fails_with(&["depth", lf, "-o", folder.to_str().unwrap()], &["folder"]);
    let file = dir.path().join("file");
    std::fs::write(&file, "x").unwrap();
    let under = file.join("d.pfm");
    fails_with(&["depth", lf, "-o", under.to_str().unwrap()], &["file"]);
    // A folder of one view has nothing to match: the grid loader already refuses it, naming
    // why (a single name gives no row and column that vary).
    let one = tempfile::tempdir().unwrap();
    image::RgbaImage::new(8, 8)
        .save(one.path().join("view_00_00.png"))
        .unwrap();
    fails_with(
        &["depth", one.path().to_str().unwrap(), "-o", o],
        &["no views found", "no two share a naming rule"],
    );
    // A grid folder has no calibration: no depth range.
    let grid = tempfile::tempdir().unwrap();
    grid_folder(grid.path());
    fails_with(
        &[
            "depth",
            grid.path().to_str().unwrap(),
            "-o",
            o,
            "--kind",
            "depth",
            "--range",
            "1,4",
        ],
        &["no calibration"],
    );
    assert!(!out.exists(), "nothing is written on failure");
}
