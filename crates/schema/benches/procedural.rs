//! Procedural-model cost (model version 4, default hyper-parameters: 4 × 4 grid of place and
//! object concentrations, 30 colour draws per object): learning and the structure posterior from a
//! three-per-class red-vs-blue sort, and one prediction (place posterior and ln B10) for a new
//! object — what `pbd execute` pays per presented object.

use criterion::{Criterion, criterion_group, criterion_main};
use schema::procedural::{Example, Features, Hyper, ProceduralModel};
use std::hint::black_box;

fn example(colors: &[(u8, f64)], px: u32, place: &str) -> Example {
    Example {
        features: Features {
            histogram: Vec::new(),
            pixels: [px, px + 15],
            colors: colors.to_vec(),
        },
        reference: place.into(),
    }
}

fn demos() -> Vec<Example> {
    // Colour terms: 0 black, 2 white, 3 red, 7 blue, 9 pink.
    vec![
        example(&[(3, 0.7), (2, 0.3)], 400, "bin-right"),
        example(&[(3, 0.9), (0, 0.1)], 900, "bin-right"),
        example(&[(3, 0.5), (9, 0.3), (2, 0.2)], 600, "bin-right"),
        example(&[(7, 0.8), (2, 0.2)], 500, "bin-left"),
        example(&[(7, 1.0)], 1200, "bin-left"),
        example(&[(7, 0.6), (0, 0.4)], 700, "bin-left"),
    ]
}

fn bench(c: &mut Criterion) {
    let demos = demos();
    c.bench_function("procedural_learn_and_structure_6_demos", |b| {
        b.iter(|| {
            let m = ProceduralModel::learn(Hyper::default(), black_box(&demos)).unwrap();
            black_box(m.structure_posterior().unwrap());
        })
    });
    let m = ProceduralModel::learn(Hyper::default(), &demos).unwrap();
    let probe = example(&[(3, 0.6), (2, 0.4)], 800, "?").features;
    c.bench_function("procedural_predict_6_demos", |b| {
        b.iter(|| black_box(m.predict(black_box(&probe)).unwrap()))
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
