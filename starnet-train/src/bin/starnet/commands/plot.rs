//! `starnet plot`: plot a run's training curves from its log.jsonl.

use clap::Args;
use starnet_train::evaluate::{replot_stream, replot_sweep, replot_temporal};
use starnet_train::train::plot_run;
use std::path::{Path, PathBuf};

/// Plot a run's training curves from its log.jsonl: loss.png (total and terms), lr.png and,
/// when it evaluated during training, ap.png. With --budget, redraw an `eval` sweep's table
/// and plots from its budget.json instead.
#[derive(Args)]
pub struct Plot {
    /// The run folder (holding log.jsonl).
    #[arg(long, required_unless_present = "budget", conflicts_with = "budget")]
    run: Option<PathBuf>,
    /// An `eval --out` or `stream-eval --out` folder: redraws its tables and plots from the
    /// budget.json, temporal.json or stream.json it holds.
    #[arg(long)]
    budget: Option<PathBuf>,
    /// Output folder for the training curves (default: the run folder).
    #[arg(long)]
    out: Option<PathBuf>,
}

type Replot = fn(&Path) -> starnet_train::Result<()>;

impl Plot {
    pub fn run(self) -> anyhow::Result<()> {
        if let Some(dir) = &self.budget {
            let replots: [(&str, Replot); 3] = [
                ("budget.json", replot_sweep),
                ("temporal.json", replot_temporal),
                ("stream.json", replot_stream),
            ];
            let mut found = false;
            for (file, replot) in replots.into_iter().filter(|(f, _)| dir.join(f).is_file()) {
                replot(dir)?;
                println!("redrew {} from {file}", dir.display());
                found = true;
            }
            anyhow::ensure!(
                found,
                "{} holds no budget.json, temporal.json or stream.json",
                dir.display()
            );
        }
        if let Some(run) = &self.run {
            for path in plot_run(run, self.out.as_deref())? {
                println!("wrote {}", path.display());
            }
        }
        Ok(())
    }
}
