//! Reads saved pings of Blueprint Subsea's Oculus M-series imaging sonars.
//!
//! A file holds network messages as the sonar sends them, little-endian and packed. Only
//! simple ping results (message id 0x23) are read, in the two layouts of the vendor's SDK
//! header (`Oculus.h`):
//!
//! - Every message starts with `OculusMessageHeader` (16 bytes): `oculusId` 0x4f53, source and
//!   destination ids, `msgId`, `msgVersion`, `payloadSize` (u32, the bytes after the header)
//!   and a spare u16.
//! - Version 1 (`msgVersion` 0 or 1) is 122 bytes. The fire message comes first (53 bytes with
//!   the header): mode, ping rate, network speed, gamma and flags as u8, then range, gain,
//!   speed of sound and salinity as f64. Then: ping id and status (u32), frequency,
//!   temperature, pressure and speed of sound used (f64), ping start time (u32), data size
//!   (u8), range resolution (f64), ranges and beams (u16), image offset, image size and
//!   message size (u32).
//! - Version 2 is 202 bytes. Its fire message adds extended flags and 8 reserved u32 (89
//!   bytes). The result adds heading, pitch and roll (f64), has an f64 ping start time, and
//!   puts four spare u32 before the image offset.
//! - Next come the bearings, one i16 per beam in hundredths of a degree. The image sits at
//!   `imageOffset` from the message start: `nRanges` rows of `nBeams` 8- or 16-bit samples.
//!   Each row starts with an f32 gain when bit 2 of the fire message's flags asked for gains.
//!
//! A ping describes an FLS with the ping's exact beams, `nRanges` bins of `rangeResolution`
//! from 0, and the elevation aperture of its mode. Beam edges lie halfway between bearings,
//! the outer ones half a spacing beyond, and must be symmetric about the boresight.
//!
//! **A positive Oculus bearing is to port**, as in this project's azimuth. The vendor's header
//! does not say, and public drivers disagree. The UW-APL `oculus_sonar_driver`, whose test
//! pings these layouts were checked on, publishes bearing `b` as the ProjectedSonarImage
//! direction `(0, −sin b, cos b)`, Y to starboard. So the image's column 0 (the most negative
//! bearing) is the starboard-most beam, and the image comes in this project's layout, with
//! row 0 the nearest range line.

use std::path::Path;

use sonarproj::{BeamLayout, Sonar, SonarKind};

use crate::error::{Error, Result};

/// The largest Oculus file read, in bytes. One ping of 2^16 × 2^16 16-bit samples is far
/// beyond every unit (512 beams, a few thousand ranges). Longer recordings of many pings are
/// for their owner's tools, which read them ping by ping.
pub const MAX_OCULUS_FILE_BYTES: u64 = 1 << 30;

/// The image of one ping: `(ranges, beams)` samples, row-major.
#[derive(Clone, Debug, PartialEq)]
pub enum OculusImage {
    /// 8-bit samples.
    U8(Vec<u8>),
    /// 16-bit samples.
    U16(Vec<u16>),
}

/// One simple ping result.
#[derive(Clone, Debug, PartialEq)]
pub struct OculusPing {
    /// The sonar of this ping: exact beams, with its range lines as bins.
    pub sonar: Sonar,
    /// Its image in this project's layout: row 0 the nearest range line, column 0 the
    /// starboard-most beam.
    pub image: OculusImage,
    /// The gain of each row when the ping carried them.
    pub gains: Option<Vec<f32>>,
    /// The bearings (deg), as the ping gives them (positive to port).
    pub bearings_deg: Vec<f64>,
    /// The message's byte offset in the file.
    pub offset: usize,
    /// The layout version read (1 or 2).
    pub version: u8,
    /// The ping's id.
    pub ping_id: u32,
    /// Acoustic frequency (Hz).
    pub frequency: f64,
    /// Metres per range line.
    pub range_resolution: f64,
}

/// The message id of a simple ping result.
const SIMPLE_PING_RESULT: u16 = 0x23;
/// The Oculus check id that starts every message.
const OCULUS_ID: u16 = 0x4f53;
/// Sizes of the message header and of the two result layouts. The bearings follow.
const HEADER: usize = 16;
const RESULT_V1: usize = 122;
const RESULT_V2: usize = 202;

/// Little-endian reads within one message, naming the offset in the file on failure.
struct Reader<'a> {
    file: &'a str,
    bytes: &'a [u8],
    /// Where `bytes` starts in the file.
    base: usize,
}

impl Reader<'_> {
    fn take<const N: usize>(&self, at: usize, field: &str) -> Result<[u8; N]> {
        self.bytes
            .get(at..at + N)
            .and_then(|b| b.try_into().ok())
            .ok_or_else(|| self.bad(at, field, "past the end of the message: truncated"))
    }
    fn u8(&self, at: usize, field: &str) -> Result<u8> {
        Ok(self.take::<1>(at, field)?[0])
    }
    fn u16(&self, at: usize, field: &str) -> Result<u16> {
        Ok(u16::from_le_bytes(self.take(at, field)?))
    }
    fn u32(&self, at: usize, field: &str) -> Result<u32> {
        Ok(u32::from_le_bytes(self.take(at, field)?))
    }
    fn f64(&self, at: usize, field: &str) -> Result<f64> {
        Ok(f64::from_le_bytes(self.take(at, field)?))
    }
    /// Returns the input error for `field` at message offset `at`.
    fn bad(&self, at: usize, field: &str, what: impl std::fmt::Display) -> Error {
        Error::from(sonarproj::Error::input(
            format!("Oculus file {}: offset {}: {field}", self.file, self.base + at),
            what.to_string(),
        ))
    }
}

/// Returns the elevation aperture (deg) of an Oculus mode at `frequency` (Hz) whose beams span
/// `aperture` (deg), or `None` for an unknown frequency. At 1.2 MHz the span tells the M750d
/// from the others. From Blueprint Subsea's data sheets:
/// - M750d: 750 kHz 130° × 20°, 1.2 MHz 70° × 12°.
/// - M1200d: 1.2 MHz 130° × 20°, 2.1 MHz 60° × 12°.
/// - M3000d: 1.2 MHz 130° × 20°, 3 MHz 40° × 20°.
fn elevation_of(frequency: f64, aperture: f64) -> Option<f64> {
    match frequency {
        f if (0.6e6..0.9e6).contains(&f) => Some(20.0),
        f if (1.0e6..1.5e6).contains(&f) => Some(if aperture < 100.0 { 12.0 } else { 20.0 }),
        f if (1.8e6..2.4e6).contains(&f) => Some(12.0),
        f if (2.8e6..3.2e6).contains(&f) => Some(20.0),
        _ => None,
    }
}

/// The finest range resolution read (m): a micrometre, far below every unit's millimetres.
const MIN_RANGE_RESOLUTION: f64 = 1e-6;

/// Returns a frequency in Hz as a person reads an Oculus one: megahertz to the kilohertz,
/// without trailing zeros (`2.1 MHz`, `2.099 MHz`, `0.75 MHz`).
#[must_use]
pub fn megahertz(hz: f64) -> String {
    let text = format!("{:.3}", hz / 1e6);
    let text = text.trim_end_matches('0').trim_end_matches('.');
    format!("{text} MHz")
}

/// Which pings of a file to keep.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pick {
    /// Every ping.
    All,
    /// Only ping `k` (0 for the first). Pings before it are skipped unparsed, and messages
    /// after it are not read.
    One(usize),
}

/// Returns the simple ping results that `pick` asks for from the Oculus file at `path`.
///
/// Other messages are skipped. `elevation` (deg) overrides the aperture the frequency gives.
/// The file is read one message at a time, so memory follows the pings kept, not the file.
///
/// # Errors
/// - [`Error::ReadInput`] when the file cannot be read, is not a regular file or is larger
///   than [`MAX_OCULUS_FILE_BYTES`].
/// - An input error naming the offset and field for: a foreign or truncated file, an image
///   that does not match its fields, 24- or 32-bit samples, a frequency without a known
///   aperture and no `elevation`, a bad `elevation`, or no ping (or no ping `k`).
pub fn read_oculus(path: &Path, elevation: Option<f64>, pick: Pick) -> Result<Vec<OculusPing>> {
    use std::io::Read;
    let fail = |source| Error::ReadInput {
        path: path.to_path_buf(),
        source,
    };
    check_elevation(elevation)?;
    let meta = std::fs::metadata(path).map_err(fail)?;
    if !meta.is_file() || meta.len() > MAX_OCULUS_FILE_BYTES {
        return Err(fail(std::io::Error::other(format!(
            "not a regular file of at most {MAX_OCULUS_FILE_BYTES} bytes"
        ))));
    }
    crate::report::note_input(path);
    let file_name = format!("{:?}", path.display().to_string());
    let mut file = std::io::BufReader::new(std::fs::File::open(path).map_err(fail)?);
    let len = usize::try_from(meta.len()).unwrap_or(usize::MAX);
    let (mut at, mut seen, mut pings) = (0usize, 0usize, Vec::new());
    let mut message = Vec::new();
    while at < len {
        let mut head = [0u8; HEADER];
        let got = read_up_to(&mut file, &mut head).map_err(fail)?;
        let reader = Reader {
            file: &file_name,
            bytes: &head[..got],
            base: at,
        };
        let (msg_id, version, payload) = message_header(&reader)?;
        let total = HEADER + payload;
        if len - at < total {
            return Err(reader.bad(
                10,
                "payloadSize",
                format!(
                    "{payload} bytes, past the end of the file ({} bytes left): truncated",
                    len - at - got
                ),
            ));
        }
        let wanted = msg_id == SIMPLE_PING_RESULT && (pick == Pick::All || pick == Pick::One(seen));
        if wanted {
            message.clear();
            message.extend_from_slice(&head);
            message.resize(total, 0);
            file.read_exact(&mut message[HEADER..]).map_err(fail)?;
            let m = Reader {
                file: &file_name,
                bytes: &message,
                base: at,
            };
            pings.push(ping(&m, version, elevation)?);
        } else {
            std::io::copy(&mut (&mut file).take(payload as u64), &mut std::io::sink()).map_err(fail)?;
        }
        if msg_id == SIMPLE_PING_RESULT {
            if pick == Pick::One(seen) {
                return Ok(pings);
            }
            seen += 1;
        }
        at += total;
    }
    match pick {
        Pick::One(k) => Err(Error::invalid(
            "ping",
            k,
            format!(
                "the file holds {seen} ping{} (0 to {})",
                if seen == 1 { "" } else { "s" },
                seen.saturating_sub(1)
            ),
        )),
        Pick::All if pings.is_empty() => Err(no_ping(&file_name, len)),
        Pick::All => Ok(pings),
    }
}

/// Reads as much of `buf` as the file has left, and returns how many bytes.
fn read_up_to(r: &mut impl std::io::Read, buf: &mut [u8]) -> std::io::Result<usize> {
    let mut got = 0;
    while got < buf.len() {
        match r.read(&mut buf[got..])? {
            0 => break,
            n => got += n,
        }
    }
    Ok(got)
}

/// Returns a message header's `(msgId, msgVersion, payloadSize)`, checking its id.
fn message_header(head: &Reader<'_>) -> Result<(u16, u16, usize)> {
    let id = head.u16(0, "oculusId")?;
    if id != OCULUS_ID {
        return Err(head.bad(
            0,
            "oculusId",
            format!("0x{id:04x} is not 0x4f53: not an Oculus message"),
        ));
    }
    Ok((
        head.u16(6, "msgId")?,
        head.u16(8, "msgVersion")?,
        head.u32(10, "payloadSize")? as usize,
    ))
}

fn no_ping(file: &str, len: usize) -> Error {
    Error::invalid(
        format!("Oculus file {file}"),
        format!("{len} bytes"),
        "holds no simple ping result (message id 0x23)",
    )
}

/// Checks an elevation aperture given for the pings: in (0, 180] deg.
fn check_elevation(elevation: Option<f64>) -> Result<()> {
    match elevation {
        Some(e) if !(e > 0.0 && e <= 180.0) => Err(Error::invalid("elevation", e, "must be in (0, 180] deg")),
        _ => Ok(()),
    }
}

/// Returns every simple ping result in `bytes`, the messages of a file called `file`. Other
/// messages are skipped. `elevation` is as in [`read_oculus`].
///
/// # Errors
/// As [`read_oculus`].
pub fn parse_oculus(file: &str, bytes: &[u8], elevation: Option<f64>) -> Result<Vec<OculusPing>> {
    check_elevation(elevation)?;
    let mut pings = Vec::new();
    let mut at = 0;
    while at < bytes.len() {
        let head = Reader {
            file,
            bytes: &bytes[at..],
            base: at,
        };
        let (msg_id, version, payload) = message_header(&head)?;
        let len = HEADER + payload;
        if bytes.len() - at < len {
            return Err(head.bad(
                10,
                "payloadSize",
                format!(
                    "{payload} bytes, past the end of the file ({} bytes left): truncated",
                    bytes.len() - at - HEADER.min(bytes.len() - at)
                ),
            ));
        }
        if msg_id == SIMPLE_PING_RESULT {
            let msg = Reader {
                file,
                bytes: &bytes[at..at + len],
                base: at,
            };
            pings.push(ping(&msg, version, elevation)?);
        }
        at += len;
    }
    if pings.is_empty() {
        return Err(no_ping(file, bytes.len()));
    }
    Ok(pings)
}

/// The fixed fields of one simple ping result message, and where its parts are.
struct Header {
    v2: bool,
    flags: u8,
    /// The end of the fire message: the ping id starts here, then the frequency.
    fire: usize,
    ping_id: u32,
    frequency: f64,
    range_resolution: f64,
    n_ranges: usize,
    n_beams: usize,
    /// Where `imageOffset` and `imageSize` are.
    offsets: usize,
    image_offset: usize,
    image_size: usize,
    /// The fixed part's length. The bearings follow it.
    fixed: usize,
    /// Bytes per sample: 1 or 2.
    sample: usize,
}

/// Returns the fixed fields of message `m` of `version`, checked. It needs a readable version,
/// 8- or 16-bit samples, a non-empty image, and range lines within the engine's range.
fn header(m: &Reader<'_>, version: u16) -> Result<Header> {
    let v2 = version == 2;
    if version > 2 {
        return Err(m.bad(8, "msgVersion", format!("{version}: versions 1 and 2 are read")));
    }
    let flags = m.u8(20, "flags")?;
    let fire = if v2 { 89 } else { 53 };
    let ping_id = m.u32(fire, "pingId")?;
    let frequency = m.f64(fire + 8, "frequency")?;
    // v1: speedOfSoundUsed (f64), then pingStartTime (u32), then dataSize.
    // v2: heading, pitch, roll and pingStartTime (f64) come in between.
    let after_sos = if v2 {
        fire + 8 + 8 * 8
    } else {
        fire + 8 + 4 * 8 + 4
    };
    let data_size = m.u8(after_sos, "dataSize")?;
    let range_resolution = m.f64(after_sos + 1, "rangeResolution")?;
    let n_ranges = m.u16(after_sos + 9, "nRanges")? as usize;
    let n_beams = m.u16(after_sos + 11, "nBeams")? as usize;
    let offsets = after_sos + 13 + if v2 { 16 } else { 0 };
    let image_offset = m.u32(offsets, "imageOffset")? as usize;
    let image_size = m.u32(offsets + 4, "imageSize")? as usize;
    let fixed = if v2 { RESULT_V2 } else { RESULT_V1 };
    debug_assert_eq!(offsets + 12, fixed);
    let sample = match data_size {
        0 => 1,
        1 => 2,
        other => {
            return Err(m.bad(
                after_sos,
                "dataSize",
                format!(
                    "{other} ({} bits): 8- and 16-bit images are read",
                    8 * (usize::from(other) + 1)
                ),
            ));
        }
    };
    if n_ranges == 0 || n_beams == 0 {
        return Err(m.bad(
            after_sos + 9,
            "nRanges/nBeams",
            format!("{n_ranges} × {n_beams}: an empty image"),
        ));
    }
    #[expect(clippy::cast_precision_loss, reason = "a u16 count")]
    let span = n_ranges as f64 * range_resolution;
    if !(range_resolution >= MIN_RANGE_RESOLUTION && span <= sonarproj::limits::MAX_RANGE) {
        return Err(m.bad(
            after_sos + 1,
            "rangeResolution",
            format!(
                "{range_resolution:e} m: must be at least {MIN_RANGE_RESOLUTION:e} m, and its {n_ranges} \
                 range lines within {} m",
                sonarproj::limits::MAX_RANGE
            ),
        ));
    }
    Ok(Header {
        v2,
        flags,
        fire,
        ping_id,
        frequency,
        range_resolution,
        n_ranges,
        n_beams,
        offsets,
        image_offset,
        image_size,
        fixed,
        sample,
    })
}

/// Returns the image of message `m` with header `h`, and each range line's gain when the
/// message carries them.
fn image(m: &Reader<'_>, h: &Header) -> Result<(OculusImage, Option<Vec<f32>>)> {
    let (n_ranges, n_beams, sample) = (h.n_ranges, h.n_beams, h.sample);
    let (image_offset, image_size) = (h.image_offset, h.image_size);
    let gain = h.flags & 0x04 != 0;
    let stride = n_beams * sample + if gain { 4 } else { 0 };
    if image_size != n_ranges * stride {
        return Err(m.bad(
            h.offsets + 4,
            "imageSize",
            format!(
                "{image_size} bytes is not nRanges × (nBeams × {sample}{}) = {}",
                if gain { " + 4 gain bytes" } else { "" },
                n_ranges * stride
            ),
        ));
    }
    if image_offset < h.fixed + 2 * n_beams || image_offset + image_size > m.bytes.len() {
        return Err(m.bad(
            h.offsets,
            "imageOffset",
            format!(
                "{image_offset} + {image_size} bytes lies outside the message (bearings end at {}, the message at {})",
                h.fixed + 2 * n_beams,
                m.bytes.len()
            ),
        ));
    }
    let rows = &m.bytes[image_offset..image_offset + image_size];
    let mut gains = gain.then(|| Vec::with_capacity(n_ranges));
    let (mut u8s, mut u16s) = (Vec::new(), Vec::new());
    for (line, row) in rows.chunks_exact(stride).enumerate() {
        let samples = if let Some(g) = &mut gains {
            let value = f32::from_le_bytes(row[..4].try_into().expect("4 bytes"));
            // A gain scales a range line's samples: one that is not a number is damage.
            if !value.is_finite() {
                return Err(m.bad(
                    image_offset + line * stride,
                    "gain",
                    format!("range line {line}'s gain is {value}: a gain must be a finite number"),
                ));
            }
            g.push(value);
            &row[4..]
        } else {
            row
        };
        if sample == 1 {
            u8s.extend_from_slice(samples);
        } else {
            u16s.extend(samples.chunks_exact(2).map(|b| u16::from_le_bytes([b[0], b[1]])));
        }
    }
    let image = if sample == 1 {
        OculusImage::U8(u8s)
    } else {
        OculusImage::U16(u16s)
    };
    Ok((image, gains))
}

fn ping(m: &Reader<'_>, version: u16, elevation: Option<f64>) -> Result<OculusPing> {
    let h = header(m, version)?;
    let bearings_deg = (0..h.n_beams)
        .map(|j| {
            let raw = m.take::<2>(h.fixed + 2 * j, "bearings")?;
            Ok(f64::from(i16::from_le_bytes(raw)) / 100.0)
        })
        .collect::<Result<Vec<f64>>>()?;
    let aperture = sonarproj::geometry::beam_table::aperture_of_beam_centres(&bearings_deg)
        .map_err(|why| m.bad(h.fixed, "bearings", why))?;
    let (image, gains) = image(m, &h)?;
    let frequency = h.frequency;
    let elevation = match elevation.or_else(|| elevation_of(frequency, aperture)) {
        Some(e) => e,
        None => {
            return Err(m.bad(
                h.fire + 8,
                "frequency",
                format!("{frequency} Hz is not an Oculus frequency whose elevation aperture is known: give it (elevation)"),
            ));
        }
    };
    #[expect(clippy::cast_precision_loss, reason = "a u16 count")]
    let range_max = h.n_ranges as f64 * h.range_resolution;
    // Provisional beams for the builder. The ping's own beams replace them.
    let sonar = Sonar {
        name: format!("oculus-ping-{}", h.ping_id),
        kind: SonarKind::Fls,
        range_min: 0.0,
        range_max,
        azimuth_aperture: 180.0,
        elevation_aperture: elevation,
        range_bins: u32::try_from(h.n_ranges).expect("a u16"),
        beams: BeamLayout::Uniform { count: 1 },
    }
    .with_beam_centres(&bearings_deg, Some(aperture))
    .map_err(|e| Error::from(e.in_context(format!("Oculus file {}: offset {}", m.file, m.base))))?;
    Ok(OculusPing {
        sonar,
        image,
        gains,
        bearings_deg,
        offset: m.base,
        version: if h.v2 { 2 } else { 1 },
        ping_id: h.ping_id,
        frequency,
        range_resolution: h.range_resolution,
    })
}

#[cfg(test)]
mod tests {

    #[test]
    fn frequencies_read_in_megahertz() {
        assert_eq!(super::megahertz(2_098_880.597), "2.099 MHz");
        assert_eq!(super::megahertz(2.1e6), "2.1 MHz");
        assert_eq!(super::megahertz(750e3), "0.75 MHz");
        assert_eq!(super::megahertz(1.2e6), "1.2 MHz");
    }

    use super::*;

    /// Returns a simple ping result message of `version`, built field by field from the SDK
    /// header's layout. It has `bearings` (0.01°) and `rows` × bearings samples of `sample` bytes,
    /// each worth `row * 7 + column` (wrapping), with gains when `gain`.
    fn message(
        version: u16,
        bearings: &[i16],
        rows: usize,
        sample: usize,
        gain: bool,
        frequency: f64,
    ) -> Vec<u8> {
        let v2 = version == 2;
        let n = bearings.len();
        let fixed = if v2 { RESULT_V2 } else { RESULT_V1 };
        let image_offset = fixed + 2 * n + 6; // a few spare bytes, as real pings have
        let stride = n * sample + if gain { 4 } else { 0 };
        let total = image_offset + rows * stride;
        let mut m = Vec::with_capacity(total);
        m.extend_from_slice(&OCULUS_ID.to_le_bytes());
        m.extend_from_slice(&7u16.to_le_bytes()); // source
        m.extend_from_slice(&0u16.to_le_bytes()); // destination
        m.extend_from_slice(&SIMPLE_PING_RESULT.to_le_bytes());
        m.extend_from_slice(&version.to_le_bytes());
        m.extend_from_slice(&u32::try_from(total - HEADER).unwrap().to_le_bytes());
        m.extend_from_slice(&0u16.to_le_bytes()); // spare
        // fire message: mode, ping rate, network speed, gamma, flags; range, gain, sos, salinity
        m.extend_from_slice(&[2, 0, 0xff, 127, 0x01 | 0x08 | if gain { 0x04 } else { 0 }]);
        for v in [5.0f64, 50.0, 1500.0, 0.0] {
            m.extend_from_slice(&v.to_le_bytes());
        }
        if v2 {
            m.extend_from_slice(&[0u8; 36]); // extFlags, reserved[8]
        }
        m.extend_from_slice(&42u32.to_le_bytes()); // pingId
        m.extend_from_slice(&0u32.to_le_bytes()); // status
        let mut doubles = vec![frequency, 10.0, 1.0];
        if v2 {
            doubles.extend([90.0, 1.0, 2.0]); // heading, pitch, roll
        }
        doubles.push(1500.0); // speed of sound used
        for v in doubles {
            m.extend_from_slice(&v.to_le_bytes());
        }
        if v2 {
            m.extend_from_slice(&12.5f64.to_le_bytes()); // pingStartTime
        } else {
            m.extend_from_slice(&125u32.to_le_bytes());
        }
        m.push(if sample == 2 { 1 } else { 0 }); // dataSize
        m.extend_from_slice(&0.01f64.to_le_bytes()); // rangeResolution
        m.extend_from_slice(&u16::try_from(rows).unwrap().to_le_bytes());
        m.extend_from_slice(&u16::try_from(n).unwrap().to_le_bytes());
        if v2 {
            m.extend_from_slice(&[0u8; 16]);
        }
        m.extend_from_slice(&u32::try_from(image_offset).unwrap().to_le_bytes());
        m.extend_from_slice(&u32::try_from(rows * stride).unwrap().to_le_bytes());
        m.extend_from_slice(&u32::try_from(total).unwrap().to_le_bytes());
        assert_eq!(m.len(), fixed);
        for b in bearings {
            m.extend_from_slice(&b.to_le_bytes());
        }
        m.resize(image_offset, 0);
        for r in 0..rows {
            if gain {
                m.extend_from_slice(&(1000.0f32 + f32::from(u16::try_from(r).unwrap())).to_le_bytes());
            }
            for c in 0..n {
                let v = r * 7 + c;
                if sample == 1 {
                    m.push(u8::try_from(v % 256).unwrap());
                } else {
                    m.extend_from_slice(&u16::try_from(v % 65536).unwrap().to_le_bytes());
                }
            }
        }
        assert_eq!(m.len(), total);
        m
    }

    #[test]
    fn both_versions_read_their_fields_beams_and_image() {
        let bearings = [-3000i16, -1000, -200, 0, 150, 900, 3000];
        for (version, sample, gain) in [(1, 1, false), (2, 2, true), (0, 1, true), (2, 1, false)] {
            let bytes = message(version, &bearings, 9, sample, gain, 2.1e6);
            let pings = parse_oculus("t.raw", &bytes, None).unwrap();
            assert_eq!(pings.len(), 1);
            let p = &pings[0];
            assert_eq!(
                (p.version, p.ping_id, p.frequency, p.range_resolution),
                (if version == 2 { 2 } else { 1 }, 42, 2.1e6, 0.01)
            );
            assert_eq!(p.sonar.range_bins, 9);
            assert!((p.sonar.range_max - 0.09).abs() < 1e-15 && p.sonar.range_min == 0.0);
            assert_eq!(p.sonar.elevation_aperture, 12.0);
            // Beam j holds bearing j: its edges are the midpoints.
            let edges = p.sonar.beam_edges_deg();
            assert_eq!(edges.len(), bearings.len() + 1);
            for (j, b) in bearings.iter().enumerate() {
                let b = f64::from(*b) / 100.0;
                assert!(
                    edges[j] < b && b < edges[j + 1],
                    "beam {j}: {b} in {}..{}",
                    edges[j],
                    edges[j + 1]
                );
            }
            assert_eq!(p.gains.as_ref().map(Vec::len), gain.then_some(9));
            let want = |r: usize, c: usize| r * 7 + c;
            match &p.image {
                OculusImage::U8(v) => assert_eq!(v[3 * 7 + 5] as usize, want(3, 5) % 256),
                OculusImage::U16(v) => assert_eq!(v[8 * 7 + 6] as usize, want(8, 6)),
            }
        }
    }

    #[test]
    fn several_pings_and_other_messages_in_one_file() {
        let mut bytes = message(1, &[-100, 0, 100], 4, 1, false, 750e3);
        // A status-like message of another id in between is skipped.
        let mut other = vec![0u8; HEADER + 8];
        other[..2].copy_from_slice(&OCULUS_ID.to_le_bytes());
        other[6..8].copy_from_slice(&0x80u16.to_le_bytes());
        other[10..14].copy_from_slice(&8u32.to_le_bytes());
        bytes.extend(other);
        bytes.extend(message(2, &[-100, 0, 100], 5, 2, true, 1.2e6));
        let pings = parse_oculus("t.raw", &bytes, None).unwrap();
        assert_eq!(
            pings.iter().map(|p| p.sonar.range_bins).collect::<Vec<_>>(),
            [4, 5]
        );
        assert_eq!(
            pings[1].offset,
            bytes.len() - message(2, &[-100, 0, 100], 5, 2, true, 1.2e6).len()
        );
    }

    #[test]
    fn a_file_is_read_a_message_at_a_time_and_ping_k_despite_a_cut_tail() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("pings.raw");
        let one = message(1, &[-100, 0, 100], 4, 1, false, 750e3);
        let two = message(2, &[-100, 0, 100], 6, 2, true, 2.1e6);
        let mut bytes = [one.clone(), two.clone()].concat();
        bytes.extend_from_slice(&one[..40]); // a recording cut mid-message
        std::fs::write(&path, &bytes).unwrap();
        let k1 = read_oculus(&path, None, Pick::One(1)).unwrap();
        assert_eq!((k1.len(), k1[0].offset, k1[0].version), (1, one.len(), 2));
        let all = read_oculus(&path, None, Pick::All).unwrap_err().to_string();
        assert!(all.contains("truncated"), "{all}");
        let past = read_oculus(&path, None, Pick::One(2)).unwrap_err().to_string();
        assert!(past.contains("truncated"), "{past}");
        std::fs::write(&path, [one.clone(), two].concat()).unwrap();
        let e = read_oculus(&path, None, Pick::One(5)).unwrap_err().to_string();
        assert!(e.contains("ping = 5") && e.contains("holds 2 pings"), "{e}");
    }

    #[test]
    fn foreign_truncated_or_inconsistent_files_are_refused_naming_offset_and_field() {
        let good = message(1, &[-100, 0, 100], 4, 1, false, 750e3);
        let refused = |bytes: &[u8], words: &[&str]| {
            let e = parse_oculus("t.raw", bytes, None).unwrap_err();
            assert!(e.is_input(), "{e}");
            let text = e.to_string();
            for w in words {
                assert!(text.contains(w), "{text} lacks {w:?}");
            }
        };
        refused(
            b"PNG\x00 not a ping at all",
            &["offset 0: oculusId", "0x4e50", "not an Oculus message"],
        );
        refused(&good[..good.len() - 1], &["offset 10: payloadSize", "truncated"]);
        refused(&good[..10], &["offset 10: payloadSize", "truncated"]);
        let mut wrong = good.clone();
        wrong[RESULT_V1 - 8..RESULT_V1 - 4].copy_from_slice(&5u32.to_le_bytes());
        refused(
            &wrong,
            &["imageSize", "5 bytes is not nRanges × (nBeams × 1) = 12"],
        );
        let mut bits24 = good.clone();
        bits24[53 + 4 + 4 + 32 + 4] = 2;
        refused(&bits24, &["dataSize", "24 bits"]);
        let mut unknown = message(1, &[-100, 0, 100], 4, 1, false, 5.0e6);
        refused(&unknown, &["frequency", "5000000 Hz", "give it"]);
        assert!(parse_oculus("t.raw", &unknown, Some(15.0)).is_ok());
        unknown.truncate(0);
        refused(&unknown, &["no simple ping result"]);
        let mut bearings = message(1, &[100, 0, -100], 4, 1, false, 750e3);
        refused(&bearings, &["bearings", "increasing azimuth"]);
        bearings[8..10].copy_from_slice(&3u16.to_le_bytes());
        refused(&bearings, &["msgVersion", "3"]);
        // One beam, an off-centre fan, a resolution of nothing.
        refused(&message(1, &[0], 4, 1, false, 750e3), &["bearings", "1 beam"]);
        refused(
            &message(1, &[1000, 2000, 3000], 4, 1, false, 750e3),
            &["bearings", "not centred"],
        );
        // A gain that is not a number (line 2's, written as 1002.0).
        let mut nan_gain = message(2, &[-100, 0, 100], 4, 1, true, 750e3);
        let at = nan_gain
            .windows(4)
            .position(|w| w == 1002f32.to_le_bytes())
            .unwrap();
        nan_gain[at..at + 4].copy_from_slice(&f32::NAN.to_le_bytes());
        refused(&nan_gain, &["gain", "range line 2's gain is NaN", "finite"]);
        let mut tiny = good.clone();
        tiny[98..106].copy_from_slice(&1e-300f64.to_le_bytes());
        refused(&tiny, &["offset 98: rangeResolution", "1e-300"]);
        assert!(
            parse_oculus("t.raw", &good, Some(0.0))
                .unwrap_err()
                .to_string()
                .contains("elevation = 0")
        );
    }
}
