//! Writes a generated camera-array video in the Technicolor dataset layout: what the README's
//! `render --frames` throughput was measured on.
//!
//! ```sh
//! cargo run --example technicolor_video -- OUT_DIR [FRAMES] [SIZE] [GRID]
//! cargo run --example technicolor_video -- /tmp/video 30 512 4     # 30 frames, 4×4 × 512²
//! tiltfield render /tmp/video --frames 1.. --focus 2.4 -o '/tmp/out/refocus_{frame:05}.png'
//! ```
//!
//! The rig (rotated, converging cameras; the world frame not a camera's) and the scene (a
//! textured wall whose texture changes every frame and a card moving across it) are those of
//! the tests (`tests/realworld_rig/mod.rs`). Frames are numbered from 1 and named
//! `Generated_undist_<frame:05d>_<cam:02d>.png`, with a 12-column `cameras_parameters.txt`.

#[path = "../tests/realworld_rig/mod.rs"]
mod realworld_rig;

use std::path::PathBuf;

use tiltfield::lightfield::GridSize;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(out) = args.first().map(PathBuf::from) else {
        anyhow::bail!("usage: technicolor_video OUT_DIR [FRAMES] [SIZE] [GRID]");
    };
    let number = |i: usize, default: u64| -> anyhow::Result<u64> {
        Ok(match args.get(i) {
            Some(s) => s.parse()?,
            None => default,
        })
    };
    let frames = number(1, 30)?;
    let size = number(2, 512)? as u32;
    let side = number(3, 4)? as usize;
    anyhow::ensure!(
        (1..=10_000).contains(&frames) && (8..=4096).contains(&size) && (2..=16).contains(&side),
        "FRAMES 1–10000, SIZE 8–4096, GRID 2–16"
    );
    std::fs::create_dir_all(&out)?;
    let rig = realworld_rig::rig(
        GridSize {
            cols: side,
            rows: side,
        },
        size,
        size,
    );
    realworld_rig::write_parameters(&out, &rig.cameras, None);
    let bar = indicatif::ProgressBar::new(frames);
    for f in 1..=frames {
        realworld_rig::write_frame(&out, "Generated", true, f, &rig.render(f));
        bar.inc(1);
    }
    bar.finish_and_clear();
    eprintln!(
        "wrote {frames} frames of {side}×{side} views of {size}×{size} to {}",
        out.display()
    );
    Ok(())
}
