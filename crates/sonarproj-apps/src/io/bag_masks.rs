//! Masks for a whole log: for every ping of a bag's topic, the union of the masks of the features
//! sonar 1 measured at the ping's stamp, under the rig's pose from the bag's transforms at that
//! stamp, written as `sensor_msgs/msg/Image` messages into an MCAP that Foxglove opens beside the
//! original pings.

use std::collections::BTreeMap;
use std::path::Path;
use std::sync::Arc;

use serde::{Deserialize, Serialize};
use sonarproj::masks::{MaskEngine, Noise};
use sonarproj::{Measurement, Sonar, SonarKind};

use super::bag::{BagPing, Header, Time, read_bag};
use super::tf::{Axes, Frames};
use crate::error::{Error, Result};

/// The schema name of the masks written.
pub const IMAGE: &str = "sensor_msgs/msg/Image";

/// The definition of [`IMAGE`] with the messages it uses, as an MCAP schema holds it.
pub const IMAGE_DEFINITION: &str = concat!(
    "std_msgs/Header header
uint32 height
uint32 width
string encoding
uint8 is_bigendian
uint32 step
uint8[] data
",
    super::bag::header_definitions!()
);

/// The most features a features file may hold (1 000 000, about 50 MB): they are held, grouped
/// by stamp.
pub const MAX_BAG_FEATURES: usize = 1_000_000;

/// A feature's stamp matches a ping's within this many nanoseconds (a microsecond: the
/// resolution of a stamp in seconds written as a decimal).
pub const STAMP_TOLERANCE_NS: i64 = 1_000;

/// `sensor_msgs/Image`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Image {
    /// Stamp and frame.
    pub header: Header,
    /// Rows.
    pub height: u32,
    /// Columns.
    pub width: u32,
    /// Pixel encoding: `mono8` here.
    pub encoding: String,
    /// Whether multi-byte pixels are big-endian.
    pub is_bigendian: u8,
    /// Bytes a row.
    pub step: u32,
    /// The pixels, row by row.
    pub data: Vec<u8>,
}

/// What [`masks_of_bag`] needs besides the bag.
pub struct BagMasks<'a> {
    /// The bag.
    pub bag: &'a Path,
    /// Its topic of pings (the first of ProjectedSonarImage when `None`).
    pub topic: Option<&'a str>,
    /// The pings' elevation aperture (deg) when their messages do not give it.
    pub elevation: Option<f64>,
    /// Sonar 1, which measured the features.
    pub source: &'a Sonar,
    /// Sonar 1's frame in the transforms (REP 103 axes: x forward, y left, z up).
    pub from_frame: &'a str,
    /// Sonar 2's frame: by default each ping's own (in the message's axes: X up, Z forward).
    /// Another frame is taken in REP 103 axes.
    pub to_frame: Option<&'a str>,
    /// The features file: `stamp` (s) or `stamp_ns`, `range` (m) and, for an imaging sonar 1,
    /// `azimuth` (deg).
    pub features: &'a Path,
    /// The pose and measurement noise the masks are widened for.
    pub noise: Option<Noise>,
}

/// What [`masks_of_bag`] wrote.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct BagMasksReport {
    /// The topic read and the topic written.
    pub topic: String,
    /// The topic of the masks.
    pub masks_topic: String,
    /// Pings read (one mask image each).
    pub pings: usize,
    /// Pings with at least one feature.
    pub pings_with_features: usize,
    /// Features drawn.
    pub features: usize,
    /// Features whose stamp matched no ping.
    pub unmatched: usize,
}

/// Returns the features of `path` by stamp (ns), checked against sonar 1 `source`.
fn read_features(path: &Path, source: &Sonar) -> Result<BTreeMap<i64, Vec<Measurement>>> {
    let file = sonarproj::files::open_regular(path).map_err(|e| Error::ReadInput {
        path: path.to_path_buf(),
        source: e,
    })?;
    crate::report::note_input(path);
    let name = format!("features file {:?}", path.display().to_string());
    let bad = |what: String| Error::from(sonarproj::Error::input(name.clone(), what));
    let mut reader = csv::Reader::from_reader(std::io::BufReader::new(file));
    let headers = reader
        .headers()
        .map_err(|e| bad(format!("no header: {e}")))?
        .clone();
    let column = |n: &str| headers.iter().position(|h| h.trim() == n);
    let fls = source.kind == SonarKind::Fls;
    let (stamp_s, stamp_ns) = (column("stamp"), column("stamp_ns"));
    let range = column("range").ok_or_else(|| bad("no column \"range\"".into()))?;
    let azimuth = column("azimuth");
    if stamp_s.is_none() == stamp_ns.is_none() {
        return Err(bad(
            "needs one column of stamps: \"stamp\" (s) or \"stamp_ns\"".into()
        ));
    }
    if fls && azimuth.is_none() {
        return Err(bad("no column \"azimuth\": sonar 1 is an imaging sonar".into()));
    }
    let mut out: BTreeMap<i64, Vec<Measurement>> = BTreeMap::new();
    for (k, record) in reader.records().enumerate() {
        let row = format!("row {}", k + 1);
        let record = record.map_err(|e| bad(format!("{row}: {e}")))?;
        if k >= MAX_BAG_FEATURES {
            return Err(bad(format!("more than {MAX_BAG_FEATURES} features: split it")));
        }
        let field = |i: usize, n: &str| -> Result<f64> {
            let text = record.get(i).unwrap_or("").trim();
            text.parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| bad(format!("{row}: {n} = {text:?} is not a finite number")))
        };
        let stamp = match (stamp_ns, stamp_s) {
            (Some(i), _) => {
                let text = record.get(i).unwrap_or("").trim();
                text.parse::<i64>()
                    .map_err(|_| bad(format!("{row}: stamp_ns = {text:?} is not a whole number")))?
            }
            (None, Some(i)) => {
                let s = field(i, "stamp")?;
                if s.abs() > 9e9 {
                    return Err(bad(format!("{row}: stamp = {s} s is past the year 2255")));
                }
                #[expect(clippy::cast_possible_truncation, reason = "within ±9e18 ns, checked above")]
                let ns = (s * 1e9).round() as i64;
                ns
            }
            (None, None) => unreachable!("one stamp column, checked above"),
        };
        let r = field(range, "range")?;
        let a = match azimuth.filter(|_| fls) {
            Some(i) => field(i, "azimuth")?,
            None => 0.0,
        };
        let m = Measurement::of(source, r, a).map_err(|e| bad(format!("{row}: {e}")))?;
        out.entry(stamp).or_default().push(m);
    }
    Ok(out)
}

/// Returns the `mono8` image of `union` (sonar 2's data order, beam 0 the starboard-most) in
/// the message's column order (`columns[k]` is beam `k`'s column): 255 where a mask lies.
fn mask_image(ping: &BagPing, union: &sonarproj::Occupancy) -> Image {
    let (rows, beams) = (union.range_bins, union.beams);
    let mut data = vec![0u8; rows * beams];
    for (i, j) in union.pixels() {
        data[i * beams + ping.columns[j]] = 255;
    }
    let ns = ping.stamp_ns;
    #[expect(
        clippy::cast_possible_truncation,
        reason = "a stamp read from an int32 and a uint32"
    )]
    let stamp = Time {
        sec: ns.div_euclid(1_000_000_000) as i32,
        nanosec: ns.rem_euclid(1_000_000_000) as u32,
    };
    #[expect(
        clippy::cast_possible_truncation,
        reason = "a sonar's bins and beams fit in u32"
    )]
    Image {
        header: Header {
            stamp,
            frame_id: ping.frame_id.clone(),
        },
        height: rows as u32,
        width: beams as u32,
        encoding: "mono8".into(),
        is_bigendian: 0,
        step: beams as u32,
        data,
    }
}

/// Writes into `out`, for every ping of the bag, the union of the masks of the features sonar 1
/// measured at its stamp as a `mono8` [`IMAGE`] (255 inside a mask) on the topic
/// `<topic>/masks`, with the ping's stamp, frame and log time: range bins as rows (row 0 the
/// nearest), the message's beams as columns in its order, so a mask lies over its ping's image.
/// A ping without features gets an empty mask. `engine(sonar 2)` makes the mask engine of each
/// distinct sonar of the pings. The file is written whole or not at all.
///
/// # Errors
/// As [`read_bag`], [`Frames::read`] and [`Frames::relative_pose`] (naming the ping's stamp),
/// input errors naming the features file's row, the engine's errors, and writing `out`.
pub fn masks_of_bag(
    job: &BagMasks<'_>,
    engine: &dyn Fn(Sonar) -> Result<MaskEngine>,
    out: &Path,
) -> Result<BagMasksReport> {
    let mut features = read_features(job.features, job.source)?;
    let total: usize = features.values().map(Vec::len).sum();
    let frames = Frames::read(job.bag)?;
    let mut pings = read_bag(job.bag, job.topic, job.elevation)?;
    let mut report = BagMasksReport::default();
    crate::report::write_atomic(out, |w| {
        let write_error = |e: mcap::McapError| Error::WriteOutput {
            path: out.to_path_buf(),
            message: e.to_string(),
        };
        let options = mcap::WriteOptions::new().profile("ros2").disable_seeking(true);
        let mut writer = options.create(mcap::write::NoSeek::new(w)).map_err(write_error)?;
        let schema = writer
            .add_schema(IMAGE, "ros2msg", IMAGE_DEFINITION.as_bytes())
            .map_err(write_error)?;
        let mut channel = None;
        let mut last: Option<(Arc<Sonar>, MaskEngine)> = None;
        for ping in pings.by_ref() {
            let ping = ping?;
            let topic = ping.topic.clone();
            let id = match channel {
                Some(id) => id,
                None => {
                    report.masks_topic = format!("{}/masks", topic.trim_end_matches('/'));
                    report.topic = topic;
                    let id = writer
                        .add_channel(schema, &report.masks_topic, "cdr", &BTreeMap::new())
                        .map_err(write_error)?;
                    *channel.insert(id)
                }
            };
            let near = ping.stamp_ns.saturating_sub(STAMP_TOLERANCE_NS)
                ..=ping.stamp_ns.saturating_add(STAMP_TOLERANCE_NS);
            let stamps: Vec<i64> = features.range(near).map(|(s, _)| *s).collect();
            let measured: Vec<Measurement> = stamps
                .iter()
                .flat_map(|s| features.remove(s).unwrap_or_default())
                .collect();
            let at = |e: Error| {
                Error::from(sonarproj::Error::input(
                    format!("ping {} (stamp {} ns)", ping.index, ping.stamp_ns),
                    e.to_string(),
                ))
            };
            let union = if measured.is_empty() {
                sonarproj::Occupancy::new(ping.sonar.range_bins as usize, ping.sonar.beam_count() as usize)
            } else {
                let (to, axes) = match job.to_frame {
                    Some(f) if f != ping.frame_id => (f, Axes::ForwardLeftUp),
                    _ => (ping.frame_id.as_str(), Axes::SonarImage),
                };
                let pose = frames
                    .relative_pose((job.from_frame, Axes::ForwardLeftUp), (to, axes), ping.stamp_ns)
                    .map_err(at)?;
                if !last.as_ref().is_some_and(|(s, _)| Arc::ptr_eq(s, &ping.sonar)) {
                    last = Some((Arc::clone(&ping.sonar), engine((*ping.sonar).clone())?));
                }
                let (_, eng) = last.as_ref().expect("made above");
                report.pings_with_features += 1;
                report.features += measured.len();
                eng.summary(&pose, &measured, job.noise.as_ref())
                    .map_err(|e| at(e.into()))?
                    .union
            };
            let image = mask_image(&ping, &union);
            let header = mcap::records::MessageHeader {
                channel_id: id,
                sequence: u32::try_from(ping.index).unwrap_or(u32::MAX),
                log_time: ping.log_time,
                publish_time: ping.log_time,
            };
            writer
                .write_to_known_channel(&header, &super::bag::to_cdr(&image)?)
                .map_err(write_error)?;
            report.pings += 1;
        }
        writer.finish().map_err(write_error)?;
        Ok(())
    })?;
    report.unmatched = total - report.features;
    Ok(report)
}
