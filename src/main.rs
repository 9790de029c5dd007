//! The `tiltfield` binary: parses the command line, runs it, prints one clear error message
//! and exits non-zero on failure (no panics or backtraces for user errors).

use clap::Parser;

fn main() -> std::process::ExitCode {
    // Output piped into a reader that stops early (`tiltfield synth --list | head -1`): end
    // quietly like every Unix tool (SIGPIPE), instead of panicking in `println!`.
    // SAFETY: called first in main, before any thread exists; SIG_DFL is a valid disposition.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    let cli = tiltfield::cli::Cli::parse();
    let level = match cli.verbose {
        0 => "warn",
        1 => "info",
        _ => "debug",
    };
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or(level))
        .format_target(false)
        .init();
    match tiltfield::cli::run(cli) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            std::process::ExitCode::FAILURE
        }
    }
}
