//! The `sonarproj` command line: one sub-command per job. Exit status 2 on bad input, 1 on other
//! failures.

mod cli;

use std::process::ExitCode;

use clap::Parser;

fn main() -> ExitCode {
    quiet_headless_vulkan();
    let args = cli::Cli::parse();
    match cli::run(args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            if let sonarproj_apps::Error::Engine(sonarproj::Error::NoAdapter { .. }) = e {
                eprintln!("hint: --backend cpu-fast runs on the CPU, without a GPU");
            }
            ExitCode::from(if e.is_input() { 2 } else { 1 })
        }
    }
}

/// On a headless machine (no `XDG_RUNTIME_DIR`), Mesa's Vulkan device-select layer tries to reach
/// a Wayland display and prints an error line for every instance; it only reorders adapters, so
/// it is switched off there (`NODEVICE_SELECT=1`) unless the user set that variable.
fn quiet_headless_vulkan() {
    if std::env::var_os("XDG_RUNTIME_DIR").is_none() && std::env::var_os("NODEVICE_SELECT").is_none() {
        // SAFETY: called first thing in main, before any other thread exists.
        unsafe { std::env::set_var("NODEVICE_SELECT", "1") };
    }
}
