//! Sonar pings read from a ROS 2 bag in MCAP: the `marine_acoustic_msgs/msg/ProjectedSonarImage`
//! messages of one topic, each made into a sonar (its beam table and range bins, as
//! [`Sonar::from_projected_sonar_image`] reads them), its image in this project's beam order and
//! its stamp.
//!
//! The container is read by the `mcap` crate a record at a time, so memory follows the largest
//! chunk, not the bag; the messages' CDR encoding by `cdr-encoding` into the structs below, which
//! mirror the message definitions field for field ([`PROJECTED_SONAR_IMAGE_DEFINITION`]).

use std::collections::BTreeMap;
use std::io::BufReader;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use serde::{Deserialize, Serialize};
use sonarproj::Sonar;

use crate::error::{Error, Result};

/// The schema name of the sonar pings a bag is read for.
pub const PROJECTED_SONAR_IMAGE: &str = "marine_acoustic_msgs/msg/ProjectedSonarImage";

/// The largest record (a chunk, or a message outside chunks) read from a bag: 512 MiB. A record
/// claiming more is refused before it is held.
pub const MAX_BAG_RECORD_BYTES: usize = 512 << 20;

/// Expands to the definitions of `std_msgs/Header` and `builtin_interfaces/Time` as an MCAP
/// schema lists the messages a message uses, each after its separator line.
macro_rules! header_definitions {
    () => {
        "================================================================================
MSG: std_msgs/Header
builtin_interfaces/Time stamp
string frame_id
================================================================================
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec
"
    };
}
pub(crate) use header_definitions;

/// The definition of [`PROJECTED_SONAR_IMAGE`] with the messages it uses, in the `ros2msg` form
/// an MCAP schema holds (marine_acoustic_msgs 2.x, std_msgs, geometry_msgs, builtin_interfaces).
pub const PROJECTED_SONAR_IMAGE_DEFINITION: &str = concat!(
    "std_msgs/Header header
PingInfo ping_info
geometry_msgs/Vector3[] beam_directions
float32[] ranges
SonarImageData image
",
    header_definitions!(),
    "================================================================================
MSG: marine_acoustic_msgs/PingInfo
float32 frequency
float32 sound_speed
float32[] tx_beamwidths
float32[] rx_beamwidths
================================================================================
MSG: geometry_msgs/Vector3
float64 x
float64 y
float64 z
================================================================================
MSG: marine_acoustic_msgs/SonarImageData
bool is_bigendian
uint32 DTYPE_UINT8=0
uint32 DTYPE_INT8=1
uint32 DTYPE_UINT16=2
uint32 DTYPE_INT16=3
uint32 DTYPE_UINT32=4
uint32 DTYPE_INT32=5
uint32 DTYPE_UINT64=6
uint32 DTYPE_INT64=7
uint32 DTYPE_FLOAT32=8
uint32 DTYPE_FLOAT64=9
uint32 dtype
uint32 beam_count
uint8[] data
"
);

/// `builtin_interfaces/Time`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Time {
    /// Seconds.
    pub sec: i32,
    /// Nanoseconds, below 10^9.
    pub nanosec: u32,
}

/// `std_msgs/Header`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Header {
    /// When the ping was sent.
    pub stamp: Time,
    /// The sonar's frame.
    pub frame_id: String,
}

/// `geometry_msgs/Vector3`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Vector3 {
    /// X (up, in the message's sonar frame).
    pub x: f64,
    /// Y (starboard).
    pub y: f64,
    /// Z (forward).
    pub z: f64,
}

/// `marine_acoustic_msgs/PingInfo`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PingInfo {
    /// Centre frequency (Hz), 0 when unknown.
    pub frequency: f32,
    /// Speed of sound (m/s), 0 when unknown.
    pub sound_speed: f32,
    /// Transmit −3 dB beam widths (rad): an imaging sonar's elevation aperture.
    pub tx_beamwidths: Vec<f32>,
    /// Receive −3 dB beam widths (rad).
    pub rx_beamwidths: Vec<f32>,
}

/// `marine_acoustic_msgs/SonarImageData`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SonarImageData {
    /// Whether multi-byte samples are big-endian.
    pub is_bigendian: bool,
    /// The sample type: 0 uint8, 2 uint16, 8 float32 are read (the message defines 0–9).
    pub dtype: u32,
    /// The beams of a row.
    pub beam_count: u32,
    /// The samples, a row of `beam_count` per range.
    pub data: Vec<u8>,
}

/// `marine_acoustic_msgs/ProjectedSonarImage`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ProjectedSonarImage {
    /// Stamp and frame.
    pub header: Header,
    /// Frequency, sound speed, beam widths.
    pub ping_info: PingInfo,
    /// One direction per beam, in the message's frame (X up, Y starboard, Z forward).
    pub beam_directions: Vec<Vector3>,
    /// The centre of each range bin (m).
    pub ranges: Vec<f32>,
    /// The image.
    pub image: SonarImageData,
}

impl ProjectedSonarImage {
    /// Returns the message CDR-encoded as a ROS 2 bag holds it: the little-endian encapsulation
    /// header, then the fields.
    ///
    /// # Errors
    /// [`Error::WriteOutput`] should the encoder fail.
    pub fn to_cdr(&self) -> Result<Vec<u8>> {
        to_cdr(self)
    }
}

/// Returns `value` CDR-encoded as a ROS 2 bag holds a message: the little-endian encapsulation
/// header, then the fields.
///
/// # Errors
/// [`Error::WriteOutput`] should the encoder fail.
pub fn to_cdr<T: Serialize>(value: &T) -> Result<Vec<u8>> {
    let body = cdr_encoding::to_vec::<_, byteorder::LittleEndian>(value).map_err(|e| Error::WriteOutput {
        path: "message".into(),
        message: e.to_string(),
    })?;
    let mut out = vec![0, 1, 0, 0];
    out.extend(body);
    Ok(out)
}

/// Returns the message `T` decoded from `data` (a CDR encapsulation header, then the fields in
/// either byte order).
///
/// # Errors
/// Why not, in words: too short, not plain CDR, or not a `T`.
pub fn from_cdr<T: serde::de::DeserializeOwned>(data: &[u8]) -> std::result::Result<T, String> {
    let name = std::any::type_name::<T>()
        .rsplit("::")
        .next()
        .unwrap_or("message");
    let body = data.get(4..).ok_or("shorter than its 4-byte CDR header")?;
    let decoded = match data[..2] {
        [0, 1] => cdr_encoding::from_bytes::<T, byteorder::LittleEndian>(body),
        [0, 0] => cdr_encoding::from_bytes::<T, byteorder::BigEndian>(body),
        _ => return Err(format!("CDR header {:02x?}: not plain CDR", &data[..4])),
    };
    decoded
        .map(|d| d.0)
        .map_err(|e| format!("does not decode as {name}: {e}"))
}

/// A ping's image, ranges × beams, row 0 the nearest range and column 0 the sonar's beam 0 (the
/// starboard-most).
#[derive(Clone, Debug, PartialEq)]
pub enum BagImage {
    /// 8-bit samples.
    U8(Vec<u8>),
    /// 16-bit samples.
    U16(Vec<u16>),
    /// 32-bit float samples.
    F32(Vec<f32>),
}

/// One ping of a bag's topic.
#[derive(Clone, Debug)]
pub struct BagPing {
    /// The topic it came on.
    pub topic: String,
    /// The ping's place among the topic's messages, from 0.
    pub index: usize,
    /// The header's stamp (ns since the epoch).
    pub stamp_ns: i64,
    /// When the bag logged it (ns).
    pub log_time: u64,
    /// The header's frame.
    pub frame_id: String,
    /// The sonar its beam table and ranges describe, shared by the pings whose tables are the same.
    pub sonar: Arc<Sonar>,
    /// The image in the sonar's layout.
    pub image: BagImage,
    /// Beam `k` of the sonar is column `columns[k]` of the message's image.
    pub columns: Vec<usize>,
}

/// The pings of one topic of a bag, read as they come ([`read_bag`]).
pub struct BagPings {
    reader: mcap::io::MessageReader<BufReader<std::fs::File>>,
    path: PathBuf,
    topic: Option<String>,
    elevation: Option<f64>,
    /// Every topic seen with its schema name, for the error when the asked one is missing.
    topics: BTreeMap<String, String>,
    /// The last beam table, ranges and elevation, with the sonar and columns made of them.
    last: Option<(TableKey, Arc<Sonar>, Vec<usize>)>,
    index: usize,
    done: bool,
}

/// What a sonar is made of: the beam directions, ranges and elevation aperture, to the bit.
type TableKey = (Vec<[u64; 3]>, Vec<u32>, u64);

/// Returns the pings of `topic` in the bag at `path`, read as they come (the first topic of
/// [`PROJECTED_SONAR_IMAGE`] messages when `topic` is `None`). `elevation` (deg) is the elevation
/// aperture, else each ping's largest `tx_beamwidths` (rad) is taken.
///
/// # Errors
/// [`Error::ReadInput`] when the file cannot be opened or is not a regular file. The iterator
/// gives input errors naming the bag, topic and message: a container that is not MCAP or is
/// truncated, the topic missing (with the topics there are) or of another type, a message that
/// does not decode, an image that does not match its beams and ranges, a sample type other
/// than uint8, uint16 or float32, no elevation aperture, and every check of
/// [`Sonar::from_projected_sonar_image`].
pub fn read_bag(path: &Path, topic: Option<&str>, elevation: Option<f64>) -> Result<BagPings> {
    if let Some(e) = elevation
        && !(e.is_finite() && e > 0.0 && e < 180.0)
    {
        return Err(Error::invalid("elevation", e, "must be in (0, 180) degrees"));
    }
    let file = sonarproj::files::open_regular(path).map_err(|source| Error::ReadInput {
        path: path.to_path_buf(),
        source,
    })?;
    crate::report::note_input(path);
    let options =
        mcap::sans_io::LinearReaderOptions::default().with_record_length_limit(MAX_BAG_RECORD_BYTES);
    Ok(BagPings {
        reader: mcap::io::MessageReader::new_with_options(BufReader::new(file), options),
        path: path.to_path_buf(),
        topic: topic.map(str::to_string),
        elevation,
        topics: BTreeMap::new(),
        last: None,
        index: 0,
        done: false,
    })
}

impl BagPings {
    /// Returns the error `what` about this bag.
    fn bad(&self, what: impl std::fmt::Display) -> Error {
        Error::from(sonarproj::Error::input(
            format!("bag {:?}", self.path.display().to_string()),
            what.to_string(),
        ))
    }

    /// Returns the ping of `message` (of the chosen topic).
    fn ping(&mut self, message: &mcap::Message<'_>) -> Result<BagPing> {
        let at = format!(
            "bag {:?}: topic {:?} message {}",
            self.path.display().to_string(),
            message.channel.topic,
            self.index
        );
        let bad = |what: String| Error::from(sonarproj::Error::input(at.clone(), what));
        let msg: ProjectedSonarImage = from_cdr(&message.data)
            .map_err(|e| bad(e.replace("as ProjectedSonarImage", &format!("as {PROJECTED_SONAR_IMAGE}"))))?;
        let elevation = match self.elevation {
            Some(e) => e,
            None => {
                let widest = msg
                    .ping_info
                    .tx_beamwidths
                    .iter()
                    .copied()
                    .fold(f32::NAN, f32::max);
                if !(widest.is_finite() && widest > 0.0) {
                    return Err(bad(
                        "ping_info.tx_beamwidths gives no elevation aperture: give it (--elevation DEG, or elevation= from Python)"
                            .into(),
                    ));
                }
                f64::from(widest).to_degrees()
            }
        };
        let key: TableKey = (
            msg.beam_directions
                .iter()
                .map(|v| [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()])
                .collect(),
            msg.ranges.iter().map(|r| r.to_bits()).collect(),
            elevation.to_bits(),
        );
        let (sonar, columns) = match &self.last {
            Some((k, s, c)) if *k == key => (Arc::clone(s), c.clone()),
            _ => {
                let dirs: Vec<[f64; 3]> = msg.beam_directions.iter().map(|v| [v.x, v.y, v.z]).collect();
                let ranges: Vec<f64> = msg.ranges.iter().map(|&r| f64::from(r)).collect();
                let name = message.channel.topic.trim_start_matches('/').to_string();
                let (s, c) = Sonar::from_projected_sonar_image(&name, &dirs, &ranges, elevation)
                    .map_err(|e| bad(e.to_string()))?;
                let s = Arc::new(s);
                self.last = Some((key, Arc::clone(&s), c.clone()));
                (s, c)
            }
        };
        let image = reorder(&msg.image, msg.ranges.len(), &columns).map_err(bad)?;
        let stamp = &msg.header.stamp;
        Ok(BagPing {
            topic: message.channel.topic.clone(),
            index: self.index,
            stamp_ns: i64::from(stamp.sec) * 1_000_000_000 + i64::from(stamp.nanosec),
            log_time: message.log_time,
            frame_id: msg.header.frame_id,
            sonar,
            image,
            columns,
        })
    }
}

/// Returns `image` (rows of `beam_count` samples, one per range) as ranges × beams in the
/// sonar's order: beam `k` is the message's column `columns[k]`.
fn reorder(
    image: &SonarImageData,
    ranges: usize,
    columns: &[usize],
) -> std::result::Result<BagImage, String> {
    let beams = columns.len();
    if image.beam_count as usize != beams {
        return Err(format!(
            "image.beam_count = {} where beam_directions has {beams}",
            image.beam_count
        ));
    }
    let size = match image.dtype {
        0 => 1,
        2 => 2,
        8 => 4,
        d => {
            return Err(format!(
                "image.dtype = {d}: only uint8 (0), uint16 (2) and float32 (8) samples are read"
            ));
        }
    };
    let want = ranges * beams * size;
    if image.data.len() != want {
        return Err(format!(
            "image.data holds {} bytes where {ranges} ranges × {beams} beams of {size} bytes take {want}",
            image.data.len()
        ));
    }
    let sample = |i: usize| -> [u8; 4] {
        let mut b = [0u8; 4];
        b[..size].copy_from_slice(&image.data[i * size..(i + 1) * size]);
        if image.is_bigendian {
            b[..size].reverse();
        }
        b
    };
    let order = (0..ranges).flat_map(|r| columns.iter().map(move |&c| r * beams + c));
    Ok(match size {
        1 => BagImage::U8(order.map(|i| image.data[i]).collect()),
        2 => BagImage::U16(
            order
                .map(|i| u16::from_le_bytes([sample(i)[0], sample(i)[1]]))
                .collect(),
        ),
        _ => BagImage::F32(order.map(|i| f32::from_le_bytes(sample(i))).collect()),
    })
}

impl Iterator for BagPings {
    type Item = Result<BagPing>;

    fn next(&mut self) -> Option<Result<BagPing>> {
        if self.done {
            return None;
        }
        let out = loop {
            let message = match self.reader.next() {
                None => break self.missing(),
                Some(Err(e)) => break Some(Err(self.bad(format!("not a readable MCAP file: {e}")))),
                Some(Ok(m)) => m,
            };
            let channel = &message.channel;
            let schema = channel.schema.as_ref().map_or("", |s| s.name.as_str());
            self.topics
                .entry(channel.topic.clone())
                .or_insert_with(|| schema.to_string());
            let wanted = match &self.topic {
                Some(t) => *t == channel.topic,
                None => schema == PROJECTED_SONAR_IMAGE,
            };
            if !wanted {
                continue;
            }
            if schema != PROJECTED_SONAR_IMAGE || channel.message_encoding != "cdr" {
                break Some(Err(self.bad(format!(
                    "topic {:?} holds {schema:?} in {:?}, not {PROJECTED_SONAR_IMAGE} in cdr",
                    channel.topic, channel.message_encoding
                ))));
            }
            if self.topic.is_none() {
                self.topic = Some(channel.topic.clone());
            }
            let ping = self.ping(&message);
            self.index += 1;
            break Some(ping);
        };
        if !matches!(out, Some(Ok(_))) {
            self.done = true;
        }
        out
    }
}

impl BagPings {
    /// Returns the end of the pings: an error when none was found, naming the topics there are.
    fn missing(&self) -> Option<Result<BagPing>> {
        if self.index > 0 {
            return None;
        }
        let topics = if self.topics.is_empty() {
            "it has no messages".to_string()
        } else {
            let list: Vec<String> = self.topics.iter().map(|(t, s)| format!("{t:?} ({s})")).collect();
            format!("its topics are {}", list.join(", "))
        };
        let what = match &self.topic {
            Some(t) => format!("no topic {t:?}: {topics}"),
            None => format!("no {PROJECTED_SONAR_IMAGE} messages: {topics}"),
        };
        Some(Err(self.bad(what)))
    }
}
