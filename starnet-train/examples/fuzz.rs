//! The long fuzzing campaign: `cargo run -p starnet-train --example fuzz [EXECS]` runs EXECS
//! (default 1,000,000) mutated inputs through every parser a user's files reach (velodyne,
//! labels, calib, poses, splits, the sidecar, configs, the ground-truth database, checkpoints,
//! exports) and prints per parser the inputs run, those accepted and the panics; it exits
//! non-zero on a panic, with the first inputs that caused one in `fuzz-crashes/`. The dev
//! profile is optimised and keeps overflow checks, so an arithmetic overflow is a panic too.

#[path = "../../tests/fuzzing/mod.rs"]
mod fuzz;

use std::time::Instant;

fn main() {
    let execs: u64 = std::env::args()
        .nth(1)
        .map_or(1_000_000, |a| a.parse().expect("EXECS is a count"));
    // Expected panics are caught and counted; keep the report readable.
    std::panic::set_hook(Box::new(|_| {}));
    let mut panicked = false;
    println!("| parser | inputs | accepted | panics | seconds |\n|---|---|---|---|---|");
    for (i, target) in fuzz::targets().iter().enumerate() {
        let start = Instant::now();
        let out = fuzz::campaign(target, execs, 1000 + i as u64);
        let secs = start.elapsed().as_secs_f64();
        println!(
            "| {} | {} | {} | {} | {secs:.0} |",
            target.name, out.execs, out.accepted, out.panic_count
        );
        for (k, (input, msg)) in out.panics.iter().enumerate() {
            panicked = true;
            let path = std::path::PathBuf::from("fuzz-crashes").join(format!("{i}-{k}.bin"));
            std::fs::create_dir_all("fuzz-crashes").expect("creating fuzz-crashes/");
            std::fs::write(&path, input).expect("writing a crash input");
            eprintln!("{}: panic `{msg}`, input in {}", target.name, path.display());
        }
    }
    std::process::exit(i32::from(panicked));
}
