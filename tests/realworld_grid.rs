//! Folders of views named as real exports name them: each naming case of the grid-folder rule
//! (`src/lightfield/grid_naming.rs`) on real image files, and every ambiguous folder a clear
//! error listing what was found.

mod common;

use std::path::Path;

use common::*;
use image::{Rgb, RgbImage};
use tiltfield::lightfield::grid_naming::FieldRole;
use tiltfield::lightfield::{self, GridSize, LightField, Source};

const W: u32 = 24;
const H: u32 = 16;

/// View (s, t): a colour that encodes s and t, with a gradient so it is not flat.
fn view(s: usize, t: usize) -> RgbImage {
    RgbImage::from_fn(W, H, |x, y| {
        Rgb([
            (s * 20 + 10) as u8,
            (t * 20 + 10) as u8,
            (100 + x + y) as u8,
        ])
    })
}

/// Writes rows `rows` × columns `cols`, named by `name(row, col)`; the pixels encode the
/// (s, t) the file should load as.
fn write_grid(
    dir: &Path,
    rows: std::ops::RangeInclusive<usize>,
    cols: std::ops::RangeInclusive<usize>,
    name: impl Fn(usize, usize) -> String,
) {
    for r in rows.clone() {
        for c in cols.clone() {
            view(c - cols.start(), r - rows.start())
                .save(dir.join(name(r, c)))
                .unwrap();
        }
    }
}

fn open(dir: &Path) -> tiltfield::Result<LightField> {
    lightfield::open(dir, &Default::default())
}

fn open_err(dir: &Path) -> String {
    match open(dir) {
        Ok(lf) => panic!("{} loaded as {:?}", dir.display(), lf.grid),
        Err(e) => e.to_string(),
    }
}

/// Every view holds the pixels of its own (s, t), within `tolerance` levels (JPEG).
fn assert_grid(lf: &LightField, cols: usize, rows: usize, tolerance: i32) {
    assert_eq!(lf.grid, GridSize { cols, rows });
    for t in 0..rows {
        for s in 0..cols {
            let got = lf.view(s, t).image.get_pixel(5, 7).0;
            let want = view(s, t).get_pixel(5, 7).0;
            for k in 0..3 {
                assert!(
                    (got[k] as i32 - want[k] as i32).abs() <= tolerance,
                    "view ({s}, {t}) from {}: {got:?} vs {want:?}",
                    lf.view(s, t).source
                );
            }
        }
    }
}

fn naming(lf: &LightField) -> &tiltfield::lightfield::grid_naming::GridNaming {
    match &lf.source {
        Source::GridFolder { naming, .. } => naming,
        other => panic!("not a grid folder: {other:?}"),
    }
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

#[test]
fn lytro_names_with_a_constant_scene_number() {
    // The case of the bug report: `2067_01_01.png … 2067_05_05.png`, counted from 1.
    let tmp = tempfile::tempdir().unwrap();
    write_grid(tmp.path(), 1..=5, 1..=5, |r, c| {
        format!("2067_{r:02}_{c:02}.png")
    });
    let lf = open(tmp.path()).unwrap();
    assert_grid(&lf, 5, 5, 0);
    let n = naming(&lf);
    assert_eq!(n.pattern, "2067_{row}_{col}.png");
    assert_eq!(
        n.fields,
        vec![
            FieldRole::Constant {
                text: "2067".into()
            },
            FieldRole::Row { first: 1, last: 5 },
            FieldRole::Column { first: 1, last: 5 },
        ]
    );
    // `info` says which numbers it used, in text and JSON; `render` works on it.
    let o = tiltfield(&["info", s(tmp.path())]);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        text.contains(
            "row = number 2 (1–5), column = number 3 (1–5) from names like 2067_{row}_{col}.png"
        ) && text.contains("number 1 (2067) is the same in every name"),
        "{text}"
    );
    let v = json_of(&tiltfield(&["info", s(tmp.path()), "--json"]));
    assert_eq!(v["source"]["format"], "grid_folder");
    assert_eq!(v["source"]["naming"]["fields"][1]["kind"], "row");
    // A grid folder is one light field, not a video.
    fails_with(
        &["info", s(tmp.path()), "--frame", "1"],
        &["frame 1", "single light field, not a video"],
    );
    let out = tmp.path().join("out/refocus.png");
    let o = tiltfield(&["render", s(tmp.path()), "--disparity", "0.5", "-o", s(&out)]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(image::open(&out).unwrap().width(), W);
}

#[test]
fn stanford_names_with_camera_positions_after_the_indices() {
    // `out_00_00_-381.909271_1103.376221_.png`: the positions vary with every view (and
    // change sign across the row) but carry decimals, so they are not indices.
    let tmp = tempfile::tempdir().unwrap();
    write_grid(tmp.path(), 0..=2, 0..=3, |r, c| {
        format!(
            "out_{r:02}_{c:02}_{:.6}_{:.6}_.png",
            -30.5 + 20.25 * c as f64,
            1103.376221 - 17.5 * r as f64
        )
    });
    let lf = open(tmp.path()).unwrap();
    assert_grid(&lf, 4, 3, 0);
    let n = naming(&lf);
    assert_eq!(n.pattern, "out_{row}_{col}_{pos}_{pos}_.png");
    assert_eq!(n.fields[2], FieldRole::Position);
}

#[test]
fn epfl_bmp_exports_with_black_vignetted_corners() {
    // `R_C.bmp`, 1-based and unpadded, the four corner views black (vignetting of the
    // plenoptic camera): they load, `info` lists them and `render` leaves them out.
    let tmp = tempfile::tempdir().unwrap();
    write_grid(tmp.path(), 1..=5, 1..=5, |r, c| format!("{r}_{c}.bmp"));
    for (r, c) in [(1, 1), (1, 5), (5, 1), (5, 5)] {
        RgbImage::new(W, H)
            .save(tmp.path().join(format!("{r}_{c}.bmp")))
            .unwrap();
    }
    let lf = open(tmp.path()).unwrap();
    assert_eq!(lf.grid, GridSize { cols: 5, rows: 5 });
    assert_eq!(*lf.view(2, 3).image.get_pixel(5, 7), {
        let p = view(2, 3).get_pixel(5, 7).0;
        image::Rgba([p[0], p[1], p[2], 255])
    });
    let v = json_of(&tiltfield(&["info", s(tmp.path()), "--json"]));
    assert_eq!(
        v["dark_views"],
        serde_json::json!([[0, 0], [4, 0], [0, 4], [4, 4]])
    );
    let out = tmp.path().join("r.png");
    let o = tiltfield(&[
        "render",
        s(tmp.path()),
        "--disparity",
        "0",
        "-o",
        s(&out),
        "--json",
    ]);
    let report = json_of(&o);
    assert_eq!(report["views_used"], 21);
    assert!(
        stderr(&o).contains("4 (almost) black views are left out"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn sixteen_bit_pngs_zero_padded_from_zero() {
    let tmp = tempfile::tempdir().unwrap();
    for t in 0..3 {
        for s_ in 0..3 {
            let v = view(s_, t);
            let wide: image::ImageBuffer<Rgb<u16>, Vec<u16>> =
                image::ImageBuffer::from_fn(W, H, |x, y| {
                    let p = v.get_pixel(x, y).0;
                    Rgb([p[0] as u16 * 257, p[1] as u16 * 257, p[2] as u16 * 257])
                });
            wide.save(tmp.path().join(format!("Sub_{t:02}_{s_:02}.png")))
                .unwrap();
        }
    }
    let lf = open(tmp.path()).unwrap();
    assert_grid(&lf, 3, 3, 0);
}

#[test]
fn jpeg_views_unpadded_with_ten_or_more_columns() {
    // `10` sorts before `2` as text; the grid must still be in numeric order.
    let tmp = tempfile::tempdir().unwrap();
    write_grid(tmp.path(), 0..=1, 0..=11, |r, c| format!("{r}_{c}.JPG"));
    let lf = open(tmp.path()).unwrap();
    assert_grid(&lf, 12, 2, 6);
    assert!(lf.view(10, 1).source.ends_with("1_10.JPG"));
}

#[test]
fn views_in_a_subfolder() {
    let tmp = tempfile::tempdir().unwrap();
    let sub = tmp.path().join("rectified");
    std::fs::create_dir(&sub).unwrap();
    std::fs::write(tmp.path().join("README.txt"), "a light field").unwrap();
    write_grid(&sub, 0..=1, 0..=2, |r, c| format!("view_{r:02}_{c:02}.png"));
    let lf = open(tmp.path()).unwrap();
    assert_grid(&lf, 3, 2, 0);
    assert_eq!(naming(&lf).subfolder.as_deref(), Some("rectified"));
    let o = tiltfield(&["info", s(tmp.path())]);
    assert!(
        String::from_utf8_lossy(&o.stdout).contains("views in sub-folder rectified"),
        "{}",
        String::from_utf8_lossy(&o.stdout)
    );
    // Two sub-folders with views: which one is meant is not guessed.
    let other = tmp.path().join("raw");
    std::fs::create_dir(&other).unwrap();
    write_grid(&other, 0..=1, 0..=2, |r, c| {
        format!("view_{r:02}_{c:02}.png")
    });
    let e = open_err(tmp.path());
    assert!(
        e.contains("2 sub-folders")
            && e.contains("raw (6 images)")
            && e.contains("rectified (6 images)"),
        "{e}"
    );
}

#[test]
fn constant_frame_number_after_the_indices() {
    let tmp = tempfile::tempdir().unwrap();
    write_grid(tmp.path(), 0..=2, 0..=1, |r, c| {
        format!("view_{r}_{c}_frame0042.png")
    });
    let lf = open(tmp.path()).unwrap();
    assert_grid(&lf, 2, 3, 0);
    assert_eq!(naming(&lf).pattern, "view_{row}_{col}_frame0042.png");
}

#[test]
fn labels_put_the_column_first() {
    let tmp = tempfile::tempdir().unwrap();
    write_grid(tmp.path(), 0..=1, 0..=3, |r, c| {
        format!("col_{c}_row_{r}.png")
    });
    let lf = open(tmp.path()).unwrap();
    assert_grid(&lf, 4, 2, 0);
}

#[test]
fn hidden_files_and_strays_are_not_views() {
    // macOS `._` resource forks (not even images) and a numbered thumbnail next to the grid.
    let tmp = tempfile::tempdir().unwrap();
    write_grid(tmp.path(), 0..=1, 0..=1, |r, c| {
        format!("{r:02}_{c:02}.png")
    });
    for name in ["._00_00.png", "._00_01.png", "._01_00.png", "._01_01.png"] {
        std::fs::write(tmp.path().join(name), b"\0\x05\x16\x07resource fork").unwrap();
    }
    RgbImage::new(8, 8)
        .save(tmp.path().join("preview_512.png"))
        .unwrap();
    let lf = open(tmp.path()).unwrap();
    assert_grid(&lf, 2, 2, 0);
}

#[test]
fn two_complete_grids_are_an_error_listing_both() {
    let tmp = tempfile::tempdir().unwrap();
    write_grid(tmp.path(), 0..=1, 0..=1, |r, c| format!("a_{r}_{c}.png"));
    write_grid(tmp.path(), 0..=2, 0..=2, |r, c| format!("b_{r}_{c}.png"));
    let e = open_err(tmp.path());
    assert!(
        e.contains("2 different complete grids")
            && e.contains("4 files like a_0_0.png")
            && e.contains("9 files like b_0_0.png"),
        "{e}"
    );
}

#[test]
fn a_missing_view_is_an_error_listing_what_was_found() {
    let tmp = tempfile::tempdir().unwrap();
    write_grid(tmp.path(), 1..=3, 1..=3, |r, c| {
        format!("2067_{r:02}_{c:02}.png")
    });
    std::fs::remove_file(tmp.path().join("2067_02_03.png")).unwrap();
    let e = open_err(tmp.path());
    assert!(
        e.contains("8 image files named like 2067_01_01.png")
            && e.contains("number 1 always 2067, number 2 1–3, number 3 1–3")
            && e.contains("8 of 9 views")
            && e.contains("the first at row 2, column 3"),
        "{e}"
    );
}

#[test]
fn mixed_sizes_are_an_error_listing_the_sizes() {
    let tmp = tempfile::tempdir().unwrap();
    write_grid(tmp.path(), 0..=2, 0..=2, |r, c| format!("{r}_{c}.png"));
    RgbImage::new(W + 8, H)
        .save(tmp.path().join("1_1.png"))
        .unwrap();
    let e = open_err(tmp.path());
    assert!(
        e.contains("2 different sizes")
            && e.contains("24×16 (8 views, e.g. 0_0.png)")
            && e.contains("32×16 (1 view, e.g. 1_1.png)"),
        "{e}"
    );
}

#[test]
fn one_varying_number_is_not_a_grid() {
    let tmp = tempfile::tempdir().unwrap();
    for k in 0..6 {
        view(k, 0)
            .save(tmp.path().join(format!("cam_{k}.png")))
            .unwrap();
    }
    let e = open_err(tmp.path());
    assert!(
        e.contains("6 image files named like cam_0.png")
            && e.contains("only one whole number that varies")
            && e.contains("row and a column"),
        "{e}"
    );
}
