//! `sonarproj sonar`: sonars read from what their owners have. `from-oculus` reads a saved
//! Oculus ping, `from-bag` a ROS 2 bag's ping, into a sonar file and the ping's image.

use std::path::PathBuf;

use sonarproj_apps::Result;
use sonarproj_apps::io::oculus::{OculusImage, Pick, read_oculus};
use sonarproj_apps::report::{check_output_dir, check_output_file, output_dir, write_atomic, write_npy};

/// The sub-commands of `sonarproj sonar`.
#[derive(Debug, clap::Subcommand)]
pub(super) enum SonarCommand {
    /// Read a saved Oculus M-series ping (simple ping result, version 1 or 2) into DIR/sonar.toml
    /// (its exact beams and range lines) and DIR/image.npy (uint8 or uint16, ranges × beams,
    /// row 0 the nearest range, column 0 the starboard-most beam). --to DIR/sonar.toml then
    /// works everywhere a sonar file does.
    FromOculus(FromOculusArgs),
    /// Read a ping of a ROS 2 bag (MCAP) into DIR/sonar.toml and DIR/image.npy, as from-oculus
    /// does: a `marine_acoustic_msgs/msg/ProjectedSonarImage` message of --topic (its beam
    /// directions, range bins and image; uint8, uint16 or float32 samples).
    FromBag(FromBagArgs),
}

/// Options of `sonarproj sonar from-bag`.
#[derive(Debug, clap::Args)]
pub(super) struct FromBagArgs {
    /// The bag: an MCAP file (ROS 2's default storage).
    #[arg(value_name = "BAG")]
    file: PathBuf,
    /// The topic of the pings (by default the bag's first topic of ProjectedSonarImage).
    #[arg(long, value_name = "TOPIC")]
    topic: Option<String>,
    /// Which ping of the topic (0 for the first).
    #[arg(long, value_name = "K", default_value_t = 0)]
    ping: usize,
    /// Elevation aperture (deg), when the message's ping_info.tx_beamwidths does not give it
    /// (their largest is taken otherwise).
    #[arg(long, value_name = "DEG")]
    elevation: Option<f64>,
    /// Output directory (created when missing).
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
}

/// Options of `sonarproj sonar from-oculus`.
#[derive(Debug, clap::Args)]
pub(super) struct FromOculusArgs {
    /// The saved ping(s): Oculus network messages back to back.
    #[arg(value_name = "PING")]
    file: PathBuf,
    /// Output directory (created when missing).
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
    /// Which ping of the file (0 for the first).
    #[arg(long, value_name = "K", default_value_t = 0)]
    ping: usize,
    /// Elevation aperture (deg), for a frequency whose aperture is not known (the units' are:
    /// 20° at 750 kHz, 1.2 and 3 MHz, 12° at 2.1 MHz).
    #[arg(long, value_name = "DEG")]
    elevation: Option<f64>,
    /// Also write DIR/gains.npy (float32, one per range line). The ping must carry gains.
    #[arg(long)]
    gains: bool,
}

/// Runs `sonarproj sonar …`.
pub(super) fn run(c: SonarCommand) -> Result<()> {
    match c {
        SonarCommand::FromOculus(a) => from_oculus(a),
        SonarCommand::FromBag(a) => from_bag(a),
    }
}

fn from_bag(a: FromBagArgs) -> Result<()> {
    use sonarproj_apps::io::bag::{BagImage, read_bag};
    check_output_dir(&a.out, "--out")?;
    let toml = a.out.join("sonar.toml");
    let image = a.out.join("image.npy");
    for path in [&image, &toml] {
        check_output_file(path, "--out")?;
    }
    let mut pings = read_bag(&a.file, a.topic.as_deref(), a.elevation)?;
    let mut found = None;
    for p in pings.by_ref() {
        let p = p?;
        if p.index == a.ping {
            found = Some(p);
            break;
        }
    }
    let Some(p) = found else {
        return Err(sonarproj_apps::Error::invalid(
            "--ping",
            a.ping,
            "past the topic's last ping (counted from 0)",
        ));
    };
    output_dir(&a.out, "--out")?;
    let shape = [u64::from(p.sonar.range_bins), u64::from(p.sonar.beam_count())];
    write_atomic(&image, |w| match &p.image {
        BagImage::U8(v) => write_npy(w, &shape, v.iter().copied(), &image),
        BagImage::U16(v) => write_npy(w, &shape, v.iter().copied(), &image),
        BagImage::F32(v) => write_npy(w, &shape, v.iter().copied(), &image),
    })?;
    let header = format!(
        "# Ping {} of topic {:?} in {:?}: frame {:?}, stamp {}.{:09} s.\n",
        p.index,
        a.topic.as_deref().unwrap_or(&p.sonar.name),
        a.file.display().to_string(),
        p.frame_id,
        p.stamp_ns.div_euclid(1_000_000_000),
        p.stamp_ns.rem_euclid(1_000_000_000)
    );
    write_sonar_file(&toml, &header, &p.sonar)?;
    outln!(
        "ping {}: {} ranges × {} beams, {:.4}–{:.4} m, frame {:?}; wrote {}, {}",
        p.index,
        shape[0],
        shape[1],
        p.sonar.range_min,
        p.sonar.range_max,
        p.frame_id,
        toml.display(),
        image.display()
    )
}

fn from_oculus(a: FromOculusArgs) -> Result<()> {
    check_output_dir(&a.out, "--out")?;
    let Some(p) = read_oculus(&a.file, a.elevation, Pick::One(a.ping))?.pop() else {
        unreachable!("read_oculus returns ping k or an error")
    };
    if a.gains && p.gains.is_none() {
        return Err(sonarproj_apps::Error::invalid(
            "--gains",
            format!("ping {}", a.ping),
            "the ping carries no gains (its fire message did not ask for them)",
        ));
    }
    let toml = a.out.join("sonar.toml");
    let image = a.out.join("image.npy");
    let gains = a.out.join("gains.npy");
    // Check every output before writing any. The sonar file goes last, so it never stands beside
    // an image of another ping.
    for path in [&image, &toml, &gains] {
        check_output_file(path, "--out")?;
    }
    output_dir(&a.out, "--out")?;
    let shape = [u64::from(p.sonar.range_bins), u64::from(p.sonar.beam_count())];
    write_atomic(&image, |w| match &p.image {
        OculusImage::U8(v) => write_npy(w, &shape, v.iter().copied(), &image),
        OculusImage::U16(v) => write_npy(w, &shape, v.iter().copied(), &image),
    })?;
    if a.gains
        && let Some(g) = &p.gains
    {
        write_atomic(&gains, |w| write_npy(w, &[shape[0]], g.iter().copied(), &gains))?;
    }
    let header = format!(
        "# Oculus ping {} of {:?} (message at byte {}, layout version {}): {}, {} m per range line.\n\
         # Bearings as the ping gives them (deg, positive to port): the beam centres.\n",
        p.ping_id,
        a.file.display().to_string(),
        p.offset,
        p.version,
        sonarproj_apps::io::oculus::megahertz(p.frequency),
        p.range_resolution
    );
    write_sonar_file(&toml, &header, &p.sonar)?;
    outln!(
        "ping {}: {} ranges × {} beams ({}-bit), {:.4}–{:.4} m, beams {:.2}° to {:.2}°; wrote {}, {}{}",
        a.ping,
        shape[0],
        shape[1],
        if matches!(p.image, OculusImage::U8(_)) {
            8
        } else {
            16
        },
        p.sonar.range_min,
        p.sonar.range_max,
        p.bearings_deg.first().copied().unwrap_or(0.0),
        p.bearings_deg.last().copied().unwrap_or(0.0),
        toml.display(),
        image.display(),
        if a.gains {
            format!(", {}", gains.display())
        } else {
            String::new()
        }
    )
}

/// Writes `sonar`'s file at `path`, `header` (comment lines) first.
fn write_sonar_file(path: &std::path::Path, header: &str, sonar: &sonarproj::Sonar) -> Result<()> {
    let text = format!("{header}{}", sonar.to_toml());
    write_atomic(path, |w| {
        w.write_all(text.as_bytes())
            .map_err(|e| sonarproj_apps::Error::write_output(path, e))
    })
}
