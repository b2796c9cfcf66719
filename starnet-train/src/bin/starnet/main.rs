//! `starnet`: train, evaluate, export and inspect StarNet detectors. Parses arguments and
//! calls the `starnet_train` library; nothing else happens here. Each subcommand is an
//! argument struct with a `run()`.

mod commands;
mod distributed;
mod parse;
mod terminal;

use clap::{Parser, Subcommand};

// Training allocates and frees the same large buffers every step; glibc hands each back to the
// kernel and faults it in again, mimalloc keeps them (BENCHMARKS.md, issue #16).
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

#[derive(Parser)]
#[command(
    name = "starnet",
    version,
    about = "StarNet point-cloud 3D object detection: data, training, evaluation, export"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    Inspect(commands::inspect::Inspect),
    Render(commands::render::Render),
    View(commands::view::View),
    Coverage(commands::coverage::Coverage),
    Prepare(commands::prepare::Prepare),
    Train(commands::train::Train),
    Eval(commands::eval::Eval),
    StreamEval(commands::stream_eval::StreamEval),
    Export(commands::export::Export),
    Detect(commands::detect::Detect),
    Plot(commands::plot::Plot),
    Config(commands::config::Config),
    Synth(commands::synth::Synth),
    CompareData(commands::compare_data::CompareData),
    Convert(commands::convert::Convert),
}

fn main() -> anyhow::Result<()> {
    // The model runs on this thread: let it take part in its own parallel work. Had another
    // pool been built first, everything would still work, only slower.
    starnet_model::backend::compute_on_this_thread();
    // The library reports; this prints.
    starnet_data::events::set_observer(terminal::Terminal::new());
    match Cli::parse().command {
        Command::Inspect(c) => c.run(),
        Command::Render(c) => c.run(),
        Command::View(c) => c.run(),
        Command::Coverage(c) => c.run(),
        Command::Prepare(c) => c.run(),
        Command::Train(c) => c.run(),
        Command::Eval(c) => c.run(),
        Command::StreamEval(c) => c.run(),
        Command::Export(c) => c.run(),
        Command::Detect(c) => c.run(),
        Command::Plot(c) => c.run(),
        Command::Config(c) => c.run(),
        Command::Synth(c) => c.run(),
        Command::CompareData(c) => c.run(),
        Command::Convert(c) => c.run(),
    }
}
