//! What the library reports: the library never prints. Every crate of the workspace sends its
//! messages and the progress of its long tasks as [`Event`]s to the one observer the program
//! installed with [`set_observer`]; without one they are dropped. The `starnet` binary's
//! observer prints notes on stdout and draws tasks as progress bars; a user's own loop can
//! silence them (install nothing), collect them, or send them to its own logger:
//!
//! ```
//! use starnet_data::events::{Event, Task, note, set_observer};
//!
//! set_observer(|event: &Event| match event {
//!     Event::Note(text) => eprintln!("[starnet] {text}"),
//!     Event::Log { text, .. } => eprintln!("[starnet] {text}"),
//!     _ => {} // no progress bars
//! });
//! note("wrote out/eval.json");
//! let task = Task::begin("score", 3);
//! task.inc(3);
//! ```
//!
//! The observer is process-wide, as a logger is: it is what the program shows, not part of any
//! computation's state.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, RwLock};

/// Identifies one [`Task`] among those running at once.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct TaskId(u64);

/// Something the library reports.
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub enum Event<'a> {
    /// A finished piece of output for the user: a report, a table, "wrote FILE".
    Note(&'a str),
    /// A task of `len` units began (a progress bar's start).
    Begin {
        /// The task.
        task: TaskId,
        /// What it does, e.g. `eval 256 x 32`.
        label: &'a str,
        /// Units of work in all.
        len: u64,
    },
    /// A task reached `position` of its `len` units. A task shared by worker threads sends
    /// these from each: they may arrive out of order, so an observer keeps the largest.
    Advance {
        /// The task.
        task: TaskId,
        /// Units done.
        position: u64,
    },
    /// How a task goes, replacing the last status (training: epoch, loss, learning rate).
    Status {
        /// The task.
        task: TaskId,
        /// The status line.
        text: &'a str,
    },
    /// A line for a log of the task, sent at the task's own pace (training: every
    /// `train.log_every` steps); the binary prints these only where no bar is drawn.
    Log {
        /// The task.
        task: TaskId,
        /// The line.
        text: &'a str,
    },
    /// A task ended (done, failed or abandoned).
    End {
        /// The task.
        task: TaskId,
    },
}

/// What receives the events.
pub trait Observer: Send + Sync {
    /// Called for every event, on the thread that sent it.
    fn event(&self, event: &Event<'_>);
}

impl<F: Fn(&Event<'_>) + Send + Sync> Observer for F {
    fn event(&self, event: &Event<'_>) {
        self(event)
    }
}

static OBSERVER: RwLock<Option<Arc<dyn Observer>>> = RwLock::new(None);
static NEXT_TASK: AtomicU64 = AtomicU64::new(0);

/// Installs the observer of every later event, replacing the last one.
pub fn set_observer(observer: impl Observer + 'static) {
    *OBSERVER.write().unwrap_or_else(|e| e.into_inner()) = Some(Arc::new(observer));
}

/// Removes the observer: later events are dropped.
pub fn clear_observer() {
    *OBSERVER.write().unwrap_or_else(|e| e.into_inner()) = None;
}

/// Sends `event` to the observer, if there is one.
pub fn emit(event: &Event<'_>) {
    let observer = OBSERVER.read().unwrap_or_else(|e| e.into_inner()).clone();
    if let Some(observer) = observer {
        observer.event(event);
    }
}

/// Reports a finished piece of output ([`Event::Note`]).
pub fn note(text: impl AsRef<str>) {
    emit(&Event::Note(text.as_ref()));
}

/// A long task's progress, reported as [`Event::Begin`], [`Event::Advance`] … and
/// [`Event::End`] when dropped. Shared by reference between worker threads.
#[derive(Debug)]
pub struct Task {
    id: TaskId,
    position: AtomicU64,
}

impl Task {
    /// Begins a task of `len` units.
    pub fn begin(label: &str, len: u64) -> Self {
        let id = TaskId(NEXT_TASK.fetch_add(1, Ordering::Relaxed));
        emit(&Event::Begin { task: id, label, len });
        Self {
            id,
            position: AtomicU64::new(0),
        }
    }

    /// Its id, as the events carry it.
    pub fn id(&self) -> TaskId {
        self.id
    }

    /// `n` more units done.
    pub fn inc(&self, n: u64) {
        let position = self.position.fetch_add(n, Ordering::Relaxed) + n;
        emit(&Event::Advance {
            task: self.id,
            position,
        });
    }

    /// `position` units done.
    pub fn set_position(&self, position: u64) {
        self.position.store(position, Ordering::Relaxed);
        emit(&Event::Advance {
            task: self.id,
            position,
        });
    }

    /// Its status line ([`Event::Status`]).
    pub fn status(&self, text: &str) {
        emit(&Event::Status { task: self.id, text });
    }

    /// A line for its log ([`Event::Log`]).
    pub fn log(&self, text: &str) {
        emit(&Event::Log { task: self.id, text });
    }
}

impl Drop for Task {
    fn drop(&mut self) {
        emit(&Event::End { task: self.id });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Mutex;

    /// The observer is process-wide: a test that installs one must not run beside another.
    static SERIAL: Mutex<()> = Mutex::new(());

    #[test]
    fn a_task_reports_begin_positions_and_end_in_order() {
        let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
        let seen = Arc::new(Mutex::new(Vec::new()));
        let sink = Arc::clone(&seen);
        set_observer(move |e: &Event| {
            let line = match e {
                Event::Note(t) => format!("note {t}"),
                Event::Begin { label, len, .. } => format!("begin {label} {len}"),
                Event::Advance { position, .. } => format!("at {position}"),
                Event::Status { text, .. } => format!("status {text}"),
                Event::Log { text, .. } => format!("log {text}"),
                Event::End { .. } => "end".into(),
            };
            sink.lock().unwrap().push(line);
        });
        {
            let task = Task::begin("score", 4);
            task.inc(1);
            task.inc(2);
            task.set_position(4);
            task.status("fine");
            task.log("step 4");
        }
        note("wrote x");
        clear_observer();
        note("dropped");
        let seen = seen.lock().unwrap().clone();
        let expected = [
            "begin score 4",
            "at 1",
            "at 3",
            "at 4",
            "status fine",
            "log step 4",
            "end",
            "note wrote x",
        ];
        // Other tests of this crate may report tasks of their own meanwhile: keep this one's lines.
        let ours: Vec<&str> = seen
            .iter()
            .map(String::as_str)
            .filter(|l| expected.contains(l))
            .collect();
        assert_eq!(ours, expected);
    }
}
