//! One file per subcommand, named as the CLI names it: its arguments and a `run()` that calls
//! the library.

pub mod compare_data;
pub mod config;
pub mod convert;
pub mod coverage;
pub mod detect;
pub mod eval;
pub mod export;
pub mod inspect;
pub mod plot;
pub mod prepare;
pub mod render;
pub mod stream_eval;
pub mod synth;
pub mod train;
pub mod view;
