//! What the binary shows of the library's [`Event`]s: notes on stdout, tasks as progress bars
//! on a terminal, a task's log lines on stderr where no bar is drawn (a log file, CI).

use indicatif::{MultiProgress, ProgressBar, ProgressState, ProgressStyle};
use starnet_data::events::{Event, Observer, TaskId};
use std::collections::HashMap;
use std::io::IsTerminal;
use std::sync::Mutex;

/// The observer `main` installs.
pub struct Terminal {
    bars: MultiProgress,
    live: Mutex<HashMap<TaskId, ProgressBar>>,
    drawn: bool,
}

impl Terminal {
    /// Bars on stderr when it is a terminal (indicatif draws nothing otherwise).
    pub fn new() -> Self {
        Self {
            bars: MultiProgress::new(),
            live: Mutex::new(HashMap::new()),
            drawn: std::io::stderr().is_terminal(),
        }
    }

    fn with_bar(&self, task: TaskId, f: impl FnOnce(&ProgressBar)) {
        if let Some(bar) = self.live.lock().unwrap_or_else(|e| e.into_inner()).get(&task) {
            f(bar);
        }
    }
}

impl Observer for Terminal {
    fn event(&self, event: &Event<'_>) {
        match *event {
            Event::Note(text) => self.bars.suspend(|| println!("{text}")),
            Event::Begin { task, label, len } => {
                let bar = self.bars.add(progress_bar(len, label));
                self.live.lock().unwrap_or_else(|e| e.into_inner()).insert(task, bar);
            }
            // Worker threads' advances may arrive out of order: a bar never moves back.
            Event::Advance { task, position } => {
                self.with_bar(task, |bar| bar.set_position(position.max(bar.position())))
            }
            Event::Status { task, text } => self.with_bar(task, |bar| bar.set_message(text.to_string())),
            Event::Log { text, .. } if !self.drawn => eprintln!("{text}"),
            Event::End { task } => {
                if let Some(bar) = self.live.lock().unwrap_or_else(|e| e.into_inner()).remove(&task) {
                    bar.finish_and_clear();
                    self.bars.remove(&bar);
                }
            }
            _ => {}
        }
    }
}

/// A bar: its label (or the task's status), progress, rate and time left.
fn progress_bar(total: u64, label: &str) -> ProgressBar {
    let bar = ProgressBar::new(total);
    bar.set_style(
        ProgressStyle::with_template("{msg} [{bar:40}] {pos}/{len} {rate} eta {eta}")
            .expect("valid template")
            .with_key("rate", |s: &ProgressState, w: &mut dyn std::fmt::Write| {
                let _ = write!(w, "{:.1}/s", s.per_sec());
            })
            .progress_chars("=> "),
    );
    bar.set_message(label.to_string());
    bar
}
