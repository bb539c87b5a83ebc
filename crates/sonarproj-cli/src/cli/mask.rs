//! `sonarproj mask`: where each feature of sonar 1 can be in sonar 2 — PNG, NPY, JSON, or a
//! stream of JSON lines for a live pipeline.

use std::path::PathBuf;
use std::time::Instant;

use serde_json::{Value, json};
use sonarproj::masks::{Counts, MaskEngine, Noise};
use sonarproj::{RelativePose, SonarKind};
use sonarproj_apps::io::text::{feature, one_or_three};
use sonarproj_apps::report::mask_image;
use sonarproj_apps::{Error, Result};

use super::mask_json::{features_json, summary_json};
use super::pose_args::PoseArgs;

/// Where `sonarproj mask` draws: `--backend auto|cpu|cpu-fast|gpu`, described as masks use it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
enum MaskBackendArg {
    /// A hardware GPU when one exists, else the CPU (with a one-line notice). The CPU also draws
    /// --counts and pings too small to gain from the GPU.
    Auto,
    /// The CPU: f64 on every core, the one CPU engine of masks.
    Cpu,
    /// The same CPU engine as cpu.
    CpuFast,
    /// The GPU (WGSL through wgpu); fails when no adapter exists.
    Gpu,
}

impl From<MaskBackendArg> for sonarproj::BackendChoice {
    fn from(a: MaskBackendArg) -> sonarproj::BackendChoice {
        match a {
            MaskBackendArg::Auto => sonarproj::BackendChoice::Auto,
            MaskBackendArg::Cpu => sonarproj::BackendChoice::Cpu,
            MaskBackendArg::CpuFast => sonarproj::BackendChoice::CpuFast,
            MaskBackendArg::Gpu => sonarproj::BackendChoice::Gpu,
        }
    }
}

/// Options of `sonarproj mask`.
#[derive(Debug, clap::Args)]
#[command(allow_negative_numbers = true)]
pub(super) struct MaskArgs {
    /// Sonar 1 (measured the features): a preset name or a sonar TOML file.
    #[arg(long, value_name = "SONAR")]
    from: String,
    /// Sonar 2 (where the masks are drawn): a preset name or a sonar TOML file. With --bag,
    /// each ping's own sonar.
    #[arg(
        long,
        value_name = "SONAR",
        required_unless_present = "bag",
        conflicts_with = "bag"
    )]
    to: Option<String>,
    #[command(flatten)]
    pose: PoseArgs,
    /// A feature measured by sonar 1: `R` (m) for a sidescan, `R,A` (m, deg) for an imaging
    /// sonar — an azimuth is required there and refused for a sidescan. Repeat for more.
    /// --place-* puts the first feature (at elevation 0) where it says.
    #[arg(
        long,
        value_name = "R[,A]",
        allow_hyphen_values = true,
        required_unless_present_any = ["stream", "bag"]
    )]
    feature: Vec<String>,
    /// Standard deviation of roll, pitch, yaw (deg): one value for all three, or three.
    #[arg(long, value_name = "DEG[,DEG,DEG]")]
    sigma_rotation: Option<String>,
    /// Standard deviation of the translation (m): one value for x, y, z, or three.
    #[arg(long, value_name = "M[,M,M]")]
    sigma_translation: Option<String>,
    /// Standard deviation of the measured range (m).
    #[arg(long, value_name = "M")]
    sigma_range: Option<f64>,
    /// Standard deviation of the measured azimuth (deg, FLS features).
    #[arg(long, value_name = "DEG")]
    sigma_azimuth: Option<f64>,
    /// Probability that a widened mask holds the true pixel (with any --sigma-*).
    #[arg(long, value_name = "P", default_value_t = 0.99)]
    coverage: f64,
    /// Write a PNG for a person, near range at the bottom and port on the left. An FLS target
    /// shows the fan seen from above (+azimuth, port, to the left) beside the raw range × beam
    /// layout (beam 0, starboard-most, at the right). An SSS target shows one vertical range strip
    /// per feature and their union. One colour per feature. With --bag: the MCAP of the masks
    /// (FILE.mcap).
    #[arg(long, value_name = "FILE.png")]
    out: Option<PathBuf>,
    /// Draw the --out picture over this image of sonar 2 (NPY, range bins × beams, row 0 the
    /// nearest range, column 0 the starboard-most beam: the image.npy of `sonar from-oculus`).
    /// Default: the image.npy beside --to's sonar file, when sonar 2 is an imaging sonar and
    /// there is one.
    #[arg(long, value_name = "FILE.npy", requires = "out")]
    image: Option<PathBuf>,
    /// Draw the --out picture without an image, even with an image.npy beside --to.
    #[arg(long, requires = "out", conflicts_with = "image")]
    no_image: bool,
    /// Write the masks as NPY, uint8 0/1 (uint32 counts with --counts). The shape is
    /// [feature][range_bin][beam] for an FLS and [feature][range_bin] for an SSS, or
    /// [feature][2 x range_bins] for a two-sided one (port far to near, then starboard near to
    /// far). Range bin 0 is range_min and beam 0 the starboard-most (-aperture/2): the PNG's raw
    /// layout with its columns mirrored.
    #[arg(long, value_name = "FILE.npy")]
    npy: Option<PathBuf>,
    /// Per-pixel counts (how many cells of the back-projected set may land there) instead of
    /// 0/1 in the NPY file.
    #[arg(long, requires = "npy")]
    counts: bool,
    /// Print JSON (per-feature occupied counts and bounding boxes); the default when neither
    /// --out nor --npy is given.
    #[arg(long)]
    json: bool,
    /// Where to draw. Masks have one CPU engine (f64, every core): cpu and cpu-fast both choose
    /// it.
    #[arg(long, value_enum, default_value = "auto")]
    backend: MaskBackendArg,
    /// Read one JSON object per line from stdin (pose, features, optional sigma) and write one
    /// JSON line per input: per-feature run-length masks, counts and timing.
    #[arg(long, conflicts_with_all = ["feature", "out", "npy", "json"])]
    stream: bool,
    /// With --stream: leave out each feature's run-length mask. Its count and bounding box, and
    /// the union's runs, stay. On a GPU only the union and 20 bytes a feature are read back.
    #[arg(long, requires = "stream")]
    no_runs: bool,
    /// Draw masks for every ping of a ROS 2 bag (MCAP): ProjectedSonarImage pings of --topic
    /// are sonar 2, the features of --features measured by --from at each ping's stamp, the
    /// pose from the bag's /tf_static and /tf between --from-frame and the pings' frame. Writes
    /// --out LOG-masks.mcap: a mono8 sensor_msgs/Image per ping on TOPIC/masks.
    #[arg(
        long,
        value_name = "LOG.mcap",
        requires_all = ["features", "from_frame", "out"],
        conflicts_with_all = ["feature", "stream", "npy", "json", "image", "no_image", "counts",
            "roll", "pitch", "yaw", "quaternion", "matrix", "translation", "place_range",
            "place_azimuth", "place_elevation"]
    )]
    bag: Option<PathBuf>,
    /// With --bag: the topic of the pings (by default the bag's first ProjectedSonarImage topic).
    #[arg(long, value_name = "TOPIC", requires = "bag")]
    topic: Option<String>,
    /// With --bag: sonar 1's frame in the bag's transforms (x forward, y left, z up).
    #[arg(long, value_name = "FRAME", requires = "bag")]
    from_frame: Option<String>,
    /// With --bag: sonar 2's frame (x forward, y left, z up); by default each ping's own frame,
    /// in the message's axes (X up, Y starboard, Z forward).
    #[arg(long, value_name = "FRAME", requires = "bag")]
    to_frame: Option<String>,
    /// With --bag: the features, a CSV of `stamp` (s) or `stamp_ns`, `range` (m) and, for an
    /// imaging sonar 1, `azimuth` (deg); a feature belongs to the ping of its stamp (within 1 µs).
    #[arg(long, value_name = "FILE.csv", requires = "bag")]
    features: Option<PathBuf>,
    /// With --bag: the pings' elevation aperture (deg) when their tx_beamwidths do not give it.
    #[arg(long, value_name = "DEG", requires = "bag")]
    elevation: Option<f64>,
}

/// Returns the noise the --sigma-* options and --coverage give, or `None` without a sigma.
/// The noise is checked by its own rules even without a sigma: a coverage that means nothing is
/// still a mistake.
fn noise_of(a: &MaskArgs) -> Result<Option<Noise>> {
    let any_sigma = a.sigma_rotation.is_some()
        || a.sigma_translation.is_some()
        || a.sigma_range.is_some()
        || a.sigma_azimuth.is_some();
    let noise = Noise {
        rotation: a
            .sigma_rotation
            .as_deref()
            .map_or(Ok([0.0; 3]), |t| one_or_three("--sigma-rotation", t))?,
        translation: a
            .sigma_translation
            .as_deref()
            .map_or(Ok([0.0; 3]), |t| one_or_three("--sigma-translation", t))?,
        range: a.sigma_range.unwrap_or(0.0),
        azimuth: a.sigma_azimuth.unwrap_or(0.0),
        coverage: a.coverage,
    }
    .validated()
    .map_err(|e| Error::from(e).in_context("noise (--sigma-*, --coverage)"))?;
    Ok(any_sigma.then_some(noise))
}

/// Runs `sonarproj mask`.
pub(super) fn run(a: MaskArgs) -> Result<()> {
    // Checked before anything is built.
    let noise = noise_of(&a)?;
    let source = super::resolve_sonar(&a.from)?;
    if let Some(bag) = &a.bag {
        return run_bag(&a, bag, source, noise);
    }
    let to = a.to.as_deref().expect("clap requires --to without --bag");
    let target = super::resolve_sonar(to)?;
    let counts = if a.counts { Counts::Draw } else { Counts::Skip };
    let (engine, notice) = super::gpu_env::select_masks(source, target, a.backend.into(), counts)?;
    if let Some(n) = notice {
        eprintln!("{n}");
    }
    if a.stream {
        return super::mask_stream::stream(&engine, !a.no_runs);
    }
    let features = a
        .feature
        .iter()
        .enumerate()
        .map(|(k, t)| feature(engine.source(), k, t))
        .collect::<Result<Vec<_>>>()?;
    let first = features[0];
    let pose = a.pose.pose([first.range, first.azimuth, 0.0])?;
    for (path, ext) in [(&a.out, "png"), (&a.npy, "npy")] {
        if let Some(p) = path
            .as_ref()
            .filter(|p| p.extension().and_then(|e| e.to_str()) != Some(ext))
        {
            return Err(Error::invalid(
                format!("--{}", if ext == "png" { "out" } else { "npy" }),
                p.display(),
                format!("must end in .{ext}"),
            ));
        }
    }
    let image = match (&a.out, ping_image(&a, engine.target().kind)) {
        (Some(_), Some(path)) => Some(mask_image::PingImage::read(&path, engine.layout(), "--image")?),
        _ => None,
    };
    let start = Instant::now();
    if a.out.is_none() && a.npy.is_none() {
        // JSON only: the masks' summary is all it prints, and all a GPU reads back.
        let summary = engine.summary(&pose, &features, noise.as_ref())?;
        let elapsed = start.elapsed().as_secs_f64() * 1e3;
        let per_feature = summary_json(&engine, &features, &summary);
        return print_json(
            &engine,
            &pose,
            noise.as_ref(),
            per_feature,
            summary.union.count(),
            elapsed,
        );
    }
    let set = engine.masks(&pose, &features, noise.as_ref(), counts)?;
    let elapsed = start.elapsed().as_secs_f64() * 1e3;
    if let Some(path) = &a.out {
        let labels: Vec<String> = features
            .iter()
            .enumerate()
            .map(|(k, f)| match engine.source().kind {
                SonarKind::Fls => format!("{}: {} m, {}°", k + 1, f.range, f.azimuth),
                SonarKind::Sss => format!("{}: {} m", k + 1, f.range),
            })
            .collect();
        let title = format!(
            "{} feature{} of {} in {}{}",
            features.len(),
            if features.len() == 1 { "" } else { "s" },
            engine.source().name,
            engine.target().name,
            noise
                .map(|n| format!(", widened to {} coverage", n.coverage))
                .unwrap_or_default()
        );
        mask_image::write_png(
            path,
            engine.layout(),
            &set.masks,
            (&title, &labels),
            image.as_ref(),
        )?;
    }
    if let Some(path) = &a.npy {
        mask_image::write_npy(path, engine.layout(), &set.masks, a.counts)?;
    }
    if a.json {
        let per_feature = features_json(&engine, &features, &set, false);
        print_json(
            &engine,
            &pose,
            noise.as_ref(),
            per_feature,
            set.union.count(),
            elapsed,
        )?;
    }
    Ok(())
}

/// Returns the image the --out picture is drawn over: --image, else the image.npy beside --to
/// when --to is the file of an imaging sonar 2 (of `kind`), as `sonar from-oculus` writes them,
/// else none. The image is an input no output may replace.
fn ping_image(a: &MaskArgs, kind: SonarKind) -> Option<PathBuf> {
    if a.no_image {
        return None;
    }
    let path = a.image.clone().or_else(|| {
        let to = a.to.as_deref()?;
        let is_file = sonarproj::Sonar::preset(to).is_none();
        let beside = std::path::Path::new(to).parent()?.join("image.npy");
        (is_file && kind == SonarKind::Fls && beside.is_file()).then_some(beside)
    })?;
    sonarproj_apps::report::note_input(&path);
    Some(path)
}

/// Prints the JSON of one `sonarproj mask` run: the sonars, pose, noise and device, the
/// per-feature entries and the union's size.
fn print_json(
    engine: &MaskEngine,
    pose: &RelativePose,
    noise: Option<&Noise>,
    features: Vec<Value>,
    union_occupied: u64,
    elapsed: f64,
) -> Result<()> {
    let out = json!({
        "from": engine.source().name,
        "to": engine.target().name,
        "pose": {
            "rotation": pose.rotation.transpose().to_cols_array_2d(),
            "translation": pose.translation.to_array(),
        },
        "noise": noise,
        "device": engine.device(),
        "features": features,
        "union_occupied": union_occupied,
        "elapsed_ms": elapsed,
    });
    outln!(
        "{}",
        serde_json::to_string_pretty(&out).expect("plain JSON values")
    )?;
    Ok(())
}

/// Runs `sonarproj mask --bag`: a mask image for every ping of the bag, into --out.
fn run_bag(
    a: &MaskArgs,
    bag: &std::path::Path,
    source: sonarproj::Sonar,
    noise: Option<Noise>,
) -> Result<()> {
    use sonarproj_apps::io::bag_masks::{BagMasks, masks_of_bag};
    let out = a.out.as_ref().expect("clap requires --out with --bag");
    if out.extension().and_then(|e| e.to_str()) != Some("mcap") {
        return Err(Error::invalid(
            "--out",
            out.display(),
            "must end in .mcap with --bag",
        ));
    }
    sonarproj_apps::report::check_output_file(out, "--out")?;
    let job = BagMasks {
        bag,
        topic: a.topic.as_deref(),
        elevation: a.elevation,
        source: &source,
        from_frame: a
            .from_frame
            .as_deref()
            .expect("clap requires --from-frame with --bag"),
        to_frame: a.to_frame.as_deref(),
        features: a
            .features
            .as_deref()
            .expect("clap requires --features with --bag"),
        noise,
    };
    // The engine's notice (a CPU fallback) once, however many sonars the pings have.
    let noticed = std::cell::Cell::new(false);
    let engine = |target: sonarproj::Sonar| -> Result<MaskEngine> {
        let (engine, notice) =
            super::gpu_env::select_masks(source.clone(), target, a.backend.into(), Counts::Skip)?;
        if let Some(n) = notice
            && !noticed.replace(true)
        {
            eprintln!("{n}");
        }
        Ok(engine)
    };
    let start = Instant::now();
    let report = masks_of_bag(&job, &engine, out)?;
    outln!(
        "{} pings of {:?} ({} with features, {} features drawn, {} matched no ping) in {:.2} s; wrote {} ({:?})",
        report.pings,
        report.topic,
        report.pings_with_features,
        report.features,
        report.unmatched,
        start.elapsed().as_secs_f64(),
        out.display(),
        report.masks_topic
    )
}
