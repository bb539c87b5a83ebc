//! `sonarproj bench`: the same batches on every backend, samples and poses per second.

use sonarproj::bench::{self, STANDARD, Timing};
use sonarproj::{Backend, BackendChoice, Result, Sonar};

/// Options of `sonarproj bench`.
#[derive(Debug, clap::Args)]
pub struct BenchArgs {
    /// Timed runs per backend and batch (the median is reported, after one warm-up run).
    #[arg(long, default_value_t = 5)]
    runs: usize,
    /// Leave out the CPU reference (slow on big batches).
    #[arg(long)]
    no_reference: bool,
}

/// Runs `sonarproj bench`.
pub fn run(a: BenchArgs) -> Result<()> {
    let mut backends = vec![Backend::CpuFast];
    if !a.no_reference {
        backends.push(Backend::Cpu);
    }
    match Backend::select(BackendChoice::Gpu) {
        Ok((gpu, _)) => backends.insert(0, gpu),
        Err(e) => println!("GPU: not measured ({e})"),
    }
    for b in &backends {
        println!("{:8} {}", b.name(), b.device());
    }
    println!();
    println!(
        "{:28} {:8} {:>8} {:>12} {:>14} {:>14} {:>12}",
        "batch", "backend", "poses", "median (ms)", "poses/s", "samples/s", "vs reference"
    );
    for (from, to, n) in STANDARD {
        let batch = bench::batch(
            &Sonar::preset(from).expect("preset"),
            &Sonar::preset(to).expect("preset"),
            n,
        )?;
        let timings: Vec<(&Backend, Timing)> = backends
            .iter()
            .map(|b| Ok((b, bench::time(b, &batch, a.runs)?)))
            .collect::<Result<_>>()?;
        let reference = timings
            .iter()
            .find(|(b, _)| matches!(b, Backend::Cpu))
            .map(|t| t.1.samples_per_second());
        for (b, t) in &timings {
            let ratio = reference
                .map(|r| format!("{:.1}x", t.samples_per_second() / r))
                .unwrap_or_default();
            println!(
                "{:28} {:8} {:>8} {:>12.2} {:>14.0} {:>14.3e} {:>12}",
                format!("{from} -> {to}"),
                b.name(),
                t.poses,
                t.median.as_secs_f64() * 1e3,
                t.poses_per_second(),
                t.samples_per_second(),
                ratio
            );
        }
    }
    Ok(())
}
