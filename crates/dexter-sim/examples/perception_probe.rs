//! The robot's eyes on the execute experiment's scenes, against the truth: `cargo run --release -p
//! dexter-sim --example perception_probe -- [scenes] [seed] [objects]` looks over the table of each
//! random scene (the scenes `pbd experiment execute --seed S` draws) and prints one Markdown table
//! ([`dexter_sim::perception`]; `pbd experiment perception` runs the same in parallel and writes
//! files). With `PBD_PROBE_LIST=1` it also lists, per scene, every object missed, seen twice or
//! seen more than 2 cm off (centre or height).

use dexter_sim::perception::{MedianMax, scan_trial, summarize};
use dexter_sim::scene::Scene;

fn cm(m: Option<MedianMax>) -> String {
    m.map_or("-".into(), |m| {
        format!("{:.1} / {:.1}", 100.0 * m.median, 100.0 * m.max)
    })
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let scenes: usize = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(50);
    let seed: u64 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(1);
    let objects: usize = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(3);
    let base = Scene::builtin("sorting-demo")?;
    let mut reports = Vec::with_capacity(scenes);
    let list = std::env::var_os("PBD_PROBE_LIST").is_some();
    for i in 0..scenes {
        let r = scan_trial(&base, objects, seed, i)?;
        if list {
            let off = |e: Option<f64>| e.is_some_and(|e| e.abs() > 0.02);
            for o in &r.objects {
                if o.segments != 1 || off(o.centroid_error_xy) || off(o.height_error) {
                    eprintln!(
                        "\nscene {i}: {} segments {} centre off {:?} height off {:?} footprint off {:?}",
                        o.object, o.segments, o.centroid_error_xy, o.height_error, o.footprint_error
                    );
                }
            }
            if r.phantoms > 0 {
                eprintln!("\nscene {i}: {} phantom segments", r.phantoms);
            }
        }
        reports.push(r);
        eprint!("\rscene {}/{scenes}", i + 1);
    }
    eprintln!();
    let s = summarize(&reports);
    println!("| figure (seed {seed}, {scenes} scenes) | value |");
    println!("|---|---|");
    println!("| objects presented | {} |", s.objects);
    println!("| missed (no segment within 8 cm) | {} |", s.missed);
    println!("| duplicate segments | {} |", s.duplicates);
    println!("| phantom segments | {} |", s.phantoms);
    println!(
        "| centroid error in the table plane, median / max (cm) | {} |",
        cm(s.centroid_xy)
    );
    println!("| centroid height error, median / max (cm) | {} |", cm(s.centroid_z));
    println!("| object height error, median / max (cm) | {} |", cm(s.height));
    println!(
        "| footprint half-extent error, median / max (cm) | {} |",
        cm(s.footprint)
    );
    Ok(())
}
