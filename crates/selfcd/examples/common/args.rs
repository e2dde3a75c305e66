//! The cloth examples' command lines: positional arguments with defaults,
//! and an error printed on stderr with a failing exit status.

use std::process::ExitCode;

/// Argument `i` of `args`, parsed, or `default` when there is none.
pub fn arg<T: std::str::FromStr>(args: &[String], i: usize, default: T) -> Result<T, String> {
    match args.get(i) {
        None => Ok(default),
        Some(s) => s.parse().map_err(|_| format!("bad argument {i}: {s:?}")),
    }
}

/// The exit status of an example's run, its error printed on stderr.
pub fn exit_status(run: Result<(), String>) -> ExitCode {
    match run {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
