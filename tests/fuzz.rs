//! The short fuzzing pass CI runs: 10,000 mutated inputs per parser (`STARNET_FUZZ_EXECS`
//! overrides), none may panic. The long campaign (≥ 1,000,000 per parser) is
//! `cargo run -p starnet-train --example fuzz`.

mod fuzzing;
use fuzzing as fuzz;

#[test]
fn no_parser_panics_on_mutated_input() {
    let execs = std::env::var("STARNET_FUZZ_EXECS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(10_000);
    let mut failures = Vec::new();
    for (i, target) in fuzz::targets().iter().enumerate() {
        let out = fuzz::campaign(target, execs, 1000 + i as u64);
        println!(
            "{}: {} inputs, {} accepted, {} panics",
            target.name, out.execs, out.accepted, out.panic_count
        );
        // Some mutants must parse, or the campaign never got past the first check.
        assert!(out.accepted > 0, "{}: no mutated input was accepted", target.name);
        for (input, msg) in &out.panics {
            failures.push(format!(
                "{}: {msg} on {:?}",
                target.name,
                String::from_utf8_lossy(&input[..input.len().min(200)])
            ));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
