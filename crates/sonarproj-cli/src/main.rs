//! The `sonarproj` command line: one sub-command per job. Exit status 2 on bad input, 1 on other
//! failures.

mod cli;

/// mimalloc keeps the pages it frees for the next allocation: a sweep allocates and frees its
/// chunk buffers many times, and glibc's returning them to the system and faulting them in again
/// cost a third of a sweep's time (BENCHMARKS.md).
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

use std::process::ExitCode;

use clap::Parser;

fn main() -> ExitCode {
    quiet_headless_vulkan();
    clean_up_on_signals();
    let args = cli::Cli::parse();
    match cli::run(args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {}", e.render(&cli::name));
            if let sonarproj_apps::Error::Engine(sonarproj::Error::NoAdapter { .. }) = e {
                eprintln!("hint: --backend cpu-fast runs on the CPU, without a GPU");
            }
            ExitCode::from(if e.is_input() { 2 } else { 1 })
        }
    }
}

/// On SIGINT, SIGTERM or SIGHUP, removes the temporary files of outputs being written, then ends
/// the process as the signal would have (the shell sees the signal, e.g. status 130 for Ctrl-C).
/// Finished outputs and a sweep's finished chunks stay; a re-run goes on from them.
fn clean_up_on_signals() {
    use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
    let Ok(mut signals) = signal_hook::iterator::Signals::new([SIGINT, SIGTERM, SIGHUP]) else {
        return;
    };
    std::thread::spawn(move || {
        if let Some(signal) = signals.forever().next() {
            sonarproj_apps::report::remove_live_temporaries();
            let _ = signal_hook::low_level::emulate_default_handler(signal);
            std::process::exit(128 + signal);
        }
    });
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
