//! Procedural-model cost (model version 4, default hyper-parameters: 4 × 4 grid of place and
//! object concentrations, 30 colour draws per object): learning and the structure posterior from a
//! three-per-class red-vs-blue sort, and one prediction (place posterior and ln B10) for a new
//! object — what `pbd execute` pays per presented object; and the cost at scale (issue 38: `pbd
//! learn` on 400 demonstrations within 2 s, `learn --explain` with 500 background objects within
//! 5 s): learning, the structure posterior and the explanation (with its 400 Monte-Carlo
//! predictions) of 400 demonstrations of a three-bin colour sort, and the explanation of a
//! six-demonstration model that has seen 500 background objects.

use criterion::{Criterion, criterion_group, criterion_main};
use schema::procedural::{Example, Features, Hyper, ProceduralModel, SizeUnit};
use std::hint::black_box;

fn example(colors: &[(u8, f64)], px: u32, place: &str) -> Example {
    Example {
        features: Features {
            histogram: Vec::new(),
            pixels: [px, px + 15],
            colors: colors.to_vec(),
            dimensions: None,
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

/// `n` demonstrations of a three-bin sort by colour (red, blue, green bins), each object showing
/// its bin's colour and one or two others, sizes spread — deterministic.
fn many(n: usize) -> Vec<Example> {
    let places = [("bin-red", 3u8), ("bin-blue", 7), ("bin-green", 6)];
    (0..n)
        .map(|i| {
            let (place, main) = places[i % 3];
            let other = ((i * 7 + 1) % 10) as u8;
            let third = ((i * 3 + 5) % 10) as u8;
            let share = 0.5 + 0.4 * ((i * 37 % 11) as f64 / 10.0);
            let mut colors = vec![(main, share)];
            if other != main {
                colors.push((other, (1.0 - share) * 0.7));
            }
            if third != main && third != other {
                colors.push((third, (1.0 - share) * 0.3));
            }
            example(&colors, 300 + (i * 53 % 900) as u32, place)
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let big = many(400);
    let mut g = c.benchmark_group("procedural_at_scale");
    g.sample_size(10);
    g.bench_function("learn_and_explain_400_demos", |b| {
        b.iter(|| {
            let m =
                ProceduralModel::learn(Hyper::default().with_size_unit(SizeUnit::DeciPixels), black_box(&big)).unwrap();
            black_box(m.explain().unwrap());
        })
    });
    let mut with_background =
        ProceduralModel::learn(Hyper::default().with_size_unit(SizeUnit::DeciPixels), &demos()).unwrap();
    for e in many(500) {
        with_background.observe_background(&e.features).unwrap();
    }
    g.bench_function("explain_6_demos_500_background", |b| {
        b.iter(|| black_box(with_background.explain().unwrap()))
    });
    g.finish();
    let demos = demos();
    c.bench_function("procedural_learn_and_structure_6_demos", |b| {
        b.iter(|| {
            let m = ProceduralModel::learn(Hyper::default().with_size_unit(SizeUnit::DeciPixels), black_box(&demos))
                .unwrap();
            black_box(m.structure_posterior().unwrap());
        })
    });
    let m = ProceduralModel::learn(Hyper::default().with_size_unit(SizeUnit::DeciPixels), &demos).unwrap();
    let probe = example(&[(3, 0.6), (2, 0.4)], 800, "?").features;
    c.bench_function("procedural_predict_6_demos", |b| {
        b.iter(|| black_box(m.predict(black_box(&probe)).unwrap()))
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
