//! The `opengraph` command-line tool.

/// `println!` that returns an error instead of panicking when stdout is closed (`| head`);
/// `main` turns that error into a quiet exit.
macro_rules! outln {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        writeln!(std::io::stdout(), $($t)*)?
    }};
}

/// `print!` with the same closed-pipe handling as [`outln!`].
macro_rules! out {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        write!(std::io::stdout(), $($t)*)?
    }};
}

/// `eprintln!` that never panics: a log line is dropped when stderr is gone, so a build never
/// stops because its log reader left.
macro_rules! errln {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stderr(), $($t)*);
    }};
}

mod cli;

/// Counts each thread's allocations, so a Cypher statement's memory budget measures what it
/// holds (see `graphstore::mem`).
#[global_allocator]
static ALLOC: graphstore::mem::CountingAlloc = graphstore::mem::CountingAlloc;

use std::process::ExitCode;

use clap::Parser;

use cli::args::Cli;
use cli::common::{is_closed_pipe, is_input_error};
use cli::run::run;

fn main() -> ExitCode {
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                // warnings, and live ingest's progress (a line per commit)
                .unwrap_or_else(|_| {
                    tracing_subscriber::EnvFilter::new("warn,opengraph::live=info")
                }),
        )
        .with_writer(std::io::stderr)
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
        .init();
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        // the reader of our output went away (`| head`): nothing is wrong, stop quietly
        Err(e) if is_closed_pipe(&e) => ExitCode::SUCCESS,
        Err(e) => {
            errln!("error: {e:#}");
            if is_input_error(&e) {
                ExitCode::from(2)
            } else {
                ExitCode::from(1)
            }
        }
    }
}
