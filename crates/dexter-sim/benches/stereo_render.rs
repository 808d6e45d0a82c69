//! Stereo vision throughput: one stereo render, and the whole perceive pipeline (render both
//! cameras, background subtraction with the robot self-filter, components, features, matching,
//! triangulation; `perceive_support_*` adds the support-plane centroids of objects on the table),
//! on a typical scene: table, two bins, 12 objects and 41 robot shapes with the arms
//! over the table, seen by Dexter's head cameras verged on the table.

use control_basis::math::Vec3;
use criterion::{Criterion, criterion_group, criterion_main};
use dexter_sim::scene::{CameraSpec, LightSpec};
use dexter_sim::vision::fixtures::{TABLE_FIXATION, TABLE_TOP, head_cameras, typical_scene};
use dexter_sim::vision::{StereoConfig, StereoVision, SupportPlane};
use std::hint::black_box;

fn bench(c: &mut Criterion) {
    let (scene, _) = typical_scene(1, 12, true);
    for (w, h) in [(160, 120), (320, 240)] {
        let spec = CameraSpec {
            width: w,
            height: h,
            ..CameraSpec::default()
        };
        let cams = head_cameras(&spec, Vec3::from(TABLE_FIXATION)).unwrap();
        let mut sv = StereoVision::new(&spec, &LightSpec::default(), 1).unwrap();
        let mut blobs = Vec::new();
        sv.perceive_into(&cams, &scene, &mut blobs).unwrap();
        c.bench_function(&format!("render_stereo_{w}x{h}"), |b| {
            b.iter(|| {
                let (l, r) = sv.render_stereo(black_box(&cams), black_box(&scene)).unwrap();
                black_box((l.rgb[0], r.rgb[0]));
            })
        });
        c.bench_function(&format!("perceive_{w}x{h}"), |b| {
            b.iter(|| {
                sv.perceive_into(black_box(&cams), black_box(&scene), &mut blobs)
                    .unwrap();
                black_box(blobs.len());
            })
        });
        sv.set_config(StereoConfig {
            support: Some(SupportPlane::at(TABLE_TOP)),
            ..StereoConfig::default()
        });
        c.bench_function(&format!("perceive_support_{w}x{h}"), |b| {
            b.iter(|| {
                sv.perceive_into(black_box(&cams), black_box(&scene), &mut blobs)
                    .unwrap();
                black_box(blobs.len());
            })
        });
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
