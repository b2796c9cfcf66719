//! Fuzzing every parser a user's files reach (`fuzzing::targets`): 10,000 mutated inputs per
//! parser by default, the pass CI runs; the long campaign is
//! `STARNET_FUZZ_EXECS=1000000 cargo test -p starnet-train --test fuzz -- --nocapture`, which
//! prints a table per parser (inputs, accepted, panics, seconds). A panic fails the test, its
//! inputs written to `fuzz-crashes/` for reproduction.

mod common;
mod fuzzing;

use std::time::Instant;

#[test]
fn no_parser_panics_on_mutated_input() {
    let execs = std::env::var("STARNET_FUZZ_EXECS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(10_000);
    // Caught panics are counted and reported below; the default hook would print each one.
    std::panic::set_hook(Box::new(|_| {}));
    let mut failures = Vec::new();
    println!("| parser | inputs | accepted | panics | seconds |\n|---|---|---|---|---|");
    for (i, target) in fuzzing::targets(&common::sample_root()).iter().enumerate() {
        let start = Instant::now();
        let out = fuzzing::campaign(target, execs, 1000 + i as u64);
        println!(
            "| {} | {} | {} | {} | {:.0} |",
            target.name,
            out.execs,
            out.accepted,
            out.panic_count,
            start.elapsed().as_secs_f64()
        );
        // Some mutants must parse, or the campaign never got past the first check.
        assert!(out.accepted > 0, "{}: no mutated input was accepted", target.name);
        for (k, (input, msg)) in out.panics.iter().enumerate() {
            let path = std::path::PathBuf::from("fuzz-crashes").join(format!("{i}-{k}.bin"));
            std::fs::create_dir_all("fuzz-crashes").unwrap();
            std::fs::write(&path, input).unwrap();
            failures.push(format!("{}: panic `{msg}`, input in {}", target.name, path.display()));
        }
    }
    let _ = std::panic::take_hook();
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
