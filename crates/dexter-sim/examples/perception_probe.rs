//! The robot's eyes on the execute experiment's scenes, against the truth: `cargo run --release -p
//! dexter-sim --example perception_probe -- [scenes] [seed] [objects]` looks over the table of each
//! random scene (the scenes `pbd experiment execute --seed S` draws) and prints one Markdown table:
//! centroid, height and footprint errors (median and max) of the objects seen, objects missed,
//! duplicates and phantom segments ([`dexter_sim::perception`]).

use dexter_sim::experiment::random_scene;
use dexter_sim::perception::scan_scene;
use dexter_sim::scene::Scene;
use rand::Rng as _;

fn median_max(mut v: Vec<f64>) -> String {
    if v.is_empty() {
        return "-".into();
    }
    v.sort_by(f64::total_cmp);
    let m = if v.len() % 2 == 1 {
        v[v.len() / 2]
    } else {
        0.5 * (v[v.len() / 2 - 1] + v[v.len() / 2])
    };
    format!("{:.1} / {:.1}", 100.0 * m, 100.0 * v[v.len() - 1])
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let scenes: usize = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(50);
    let seed: u64 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(1);
    let objects: usize = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(3);
    let base = Scene::builtin("sorting-demo")?;
    let (mut xy, mut z, mut height, mut footprint) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let (mut presented, mut missed, mut duplicates, mut phantoms) = (0, 0, 0, 0);
    for i in 0..scenes {
        let scene = random_scene(&base, objects, &mut bayes::rng::stream(seed, i as u64))?;
        let run_seed = bayes::rng::stream(seed ^ 0x5EED_0F5C_E4E5, i as u64).next_u64();
        let r = scan_scene(&scene, run_seed)?;
        phantoms += r.phantoms;
        for o in &r.objects {
            presented += 1;
            missed += usize::from(o.segments == 0);
            duplicates += o.segments.saturating_sub(1);
            xy.extend(o.centroid_error_xy);
            z.extend(o.centroid_error_z.map(f64::abs));
            height.extend(o.height_error.map(f64::abs));
            footprint.extend(o.footprint_error);
        }
        eprint!("\rscene {}/{scenes}", i + 1);
    }
    eprintln!();
    println!("| figure (seed {seed}, {scenes} scenes) | value |");
    println!("|---|---|");
    println!("| objects presented | {presented} |");
    println!("| missed (no segment within 8 cm) | {missed} |");
    println!("| duplicate segments | {duplicates} |");
    println!("| phantom segments | {phantoms} |");
    println!(
        "| centroid error in the table plane, median / max (cm) | {} |",
        median_max(xy)
    );
    println!("| centroid height error, median / max (cm) | {} |", median_max(z));
    println!("| object height error, median / max (cm) | {} |", median_max(height));
    println!(
        "| footprint half-extent error, median / max (cm) | {} |",
        median_max(footprint)
    );
    Ok(())
}
