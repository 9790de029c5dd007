//! `tiltfield synth`: the Vulkan mesh rasterizer, built-in and glTF scenes, the HCI and manifest
//! layouts read back through the loaders, and the optical ground truth. Every GPU test runs with
//! the validation layer and asserts zero errors.

mod common;

use glam::{DVec2, DVec3};
use tiltfield::geometry::camera::Camera;
use tiltfield::lightfield::GridSize;
use tiltfield::synth::{synth_scene, Rasterizer, RigKind, SynthRig};

fn rasterizer(mesh: &tiltfield::synth::MeshScene) -> Rasterizer {
    Rasterizer::new(mesh, &common::gpu_options())
        .unwrap_or_else(|e| panic!("cannot create a validated rasterizer: {e}"))
}

fn assert_clean(r: &Rasterizer) {
    let log = r.context().validation();
    assert_eq!(log.errors(), 0, "validation errors: {:#?}", log.messages());
}

#[test]
fn smoke_each_scene() {
    for name in tiltfield::synth::synth_scene_names() {
        let s = synth_scene(name).unwrap();
        let mesh = s.mesh();
        let mut r = rasterizer(&mesh);
        let rig = SynthRig {
            grid: GridSize { cols: 3, rows: 3 },
            width: 128,
            height: 128,
            focal_px: s.focal_per_width * 128.0,
            baseline: s.baseline,
            focus_distance: s.focus_distance,
            kind: RigKind::Parallel,
        };
        let t = std::time::Instant::now();
        let lf = tiltfield::synth::raster::render_light_field(&mut r, &rig, 3, false).unwrap();
        eprintln!("{name}: {:.2} s", t.elapsed().as_secs_f64());
        lf.light_field.views[4].image.save(format!("/tmp/synthlook/{name}.png")).unwrap();
        assert_clean(&r);
    }
}
