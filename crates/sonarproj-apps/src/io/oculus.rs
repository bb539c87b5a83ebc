//! Saved pings of Blueprint Subsea's Oculus M-series imaging sonars: a file of network messages
//! as the sonar sends them (little-endian, packed), of which the simple ping results (message id
//! 0x23) are read, in the two layouts of the vendor's SDK header (`Oculus.h`):
//!
//! - every message starts with `OculusMessageHeader` (16 bytes): `oculusId` 0x4f53, source and
//!   destination ids, `msgId`, `msgVersion`, `payloadSize` (u32, the bytes after the header),
//!   a spare u16;
//! - version 1 (`msgVersion` 0 or 1): the fire message (mode, ping rate, network speed, gamma,
//!   flags as u8; range, gain, speed of sound, salinity as f64: 53 bytes with the header), then
//!   ping id and status (u32), frequency, temperature, pressure, speed of sound used (f64), ping
//!   start time (u32), data size (u8), range resolution (f64), ranges and beams (u16), image
//!   offset, image size, message size (u32): 122 bytes;
//! - version 2: the fire message adds extended flags and 8 reserved u32 (89 bytes); the result
//!   adds heading, pitch and roll (f64), its ping start time is an f64, and four spare u32 come
//!   before the image offset: 202 bytes;
//! - then one i16 bearing per beam in hundredths of a degree, and the image at `imageOffset` from
//!   the start of the message: `nRanges` rows of `nBeams` samples (8 or 16 bits), each row
//!   preceded by a u32 gain when the fire message's flag bit 2 asked for gains.
//!
//! The sonar a ping describes is an FLS with the ping's exact beams (edges halfway between the
//! bearings, the outer ones half a spacing beyond), `nRanges` bins of `rangeResolution` from 0,
//! and the elevation aperture of its frequency (20° at 750 kHz and 1.2 MHz, 12° at 2.1 MHz, 20°
//! at 3 MHz: the data sheets; other frequencies need it given). **A positive Oculus bearing is to
//! port**, as in this project's azimuth (the UW-APL `oculus_sonar_driver`, whose test pings these
//! layouts were checked on, publishes a bearing `b` as the ProjectedSonarImage direction
//! `(0, −sin b, cos b)`, Y to starboard; other public drivers flip it, and the vendor's header
//! does not say): the image's column 0, the most negative bearing, is the starboard-most beam,
//! so the image is in this project's layout as it comes (row 0 the nearest range line).

use std::path::Path;

use sonarproj::{BeamLayout, Sonar, SonarKind};

use crate::error::{Error, Result};

/// The largest Oculus file read whole (bytes): a ping of 2^16 × 2^16 16-bit samples is far
/// beyond every unit (512 beams, a few thousand ranges); a recording of many pings is bigger,
/// and is read ping by ping by its owner's tools.
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
    /// The sonar of this ping (exact beams, its range lines as bins).
    pub sonar: Sonar,
    /// Its image in this project's layout: row 0 the nearest range line, column 0 the
    /// starboard-most beam.
    pub image: OculusImage,
    /// The gain of each row when the ping carried them.
    pub gains: Option<Vec<u32>>,
    /// The bearings (deg), as the ping gives them (positive to port).
    pub bearings_deg: Vec<f64>,
    /// The message's byte offset in the file, its layout version (1 or 2) and its ping id.
    pub offset: usize,
    /// The layout version read (1 or 2).
    pub version: u8,
    /// The ping's id.
    pub ping_id: u32,
    /// Acoustic frequency (Hz) and range resolution (m).
    pub frequency: f64,
    /// Metres per range line.
    pub range_resolution: f64,
}

/// The message id of a simple ping result.
const SIMPLE_PING_RESULT: u16 = 0x23;
/// The Oculus check id that starts every message.
const OCULUS_ID: u16 = 0x4f53;
/// Sizes of the message header and of the two result layouts (bearings follow).
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

/// Returns the elevation aperture (deg) of an Oculus at `frequency` (Hz), when it is one of the
/// units' frequencies.
fn elevation_of(frequency: f64) -> Option<f64> {
    match frequency {
        f if (0.6e6..0.9e6).contains(&f) => Some(20.0),
        f if (1.0e6..1.5e6).contains(&f) => Some(20.0),
        f if (1.8e6..2.4e6).contains(&f) => Some(12.0),
        f if (2.8e6..3.2e6).contains(&f) => Some(20.0),
        _ => None,
    }
}

/// Returns every simple ping result of the Oculus file at `path` (other messages are skipped);
/// `elevation` (deg) overrides the aperture the frequency gives.
///
/// # Errors
/// [`Error::ReadInput`] when the file cannot be read or is larger than
/// [`MAX_OCULUS_FILE_BYTES`]; an input error naming the offset and the field for a foreign or
/// truncated file, an image that is not what its fields say, 24- or 32-bit samples, a frequency
/// without a known aperture (and no `elevation`), or no ping at all.
pub fn read_oculus(path: &Path, elevation: Option<f64>) -> Result<Vec<OculusPing>> {
    let meta = std::fs::metadata(path).map_err(|source| Error::ReadInput {
        path: path.to_path_buf(),
        source,
    })?;
    if !meta.is_file() || meta.len() > MAX_OCULUS_FILE_BYTES {
        return Err(Error::ReadInput {
            path: path.to_path_buf(),
            source: std::io::Error::other(format!(
                "not a regular file of at most {MAX_OCULUS_FILE_BYTES} bytes"
            )),
        });
    }
    crate::report::note_input(path);
    let bytes = std::fs::read(path).map_err(|source| Error::ReadInput {
        path: path.to_path_buf(),
        source,
    })?;
    parse_oculus(&path.display().to_string(), &bytes, elevation)
}

/// [`read_oculus`] of the bytes of a file called `file` in messages.
///
/// # Errors
/// As [`read_oculus`].
pub fn parse_oculus(file: &str, bytes: &[u8], elevation: Option<f64>) -> Result<Vec<OculusPing>> {
    let mut pings = Vec::new();
    let mut at = 0;
    while at < bytes.len() {
        let head = Reader {
            file,
            bytes: &bytes[at..],
            base: at,
        };
        let id = head.u16(0, "oculusId")?;
        if id != OCULUS_ID {
            return Err(head.bad(
                0,
                "oculusId",
                format!("0x{id:04x} is not 0x4f53: not an Oculus message"),
            ));
        }
        let msg_id = head.u16(6, "msgId")?;
        let version = head.u16(8, "msgVersion")?;
        let payload = head.u32(10, "payloadSize")? as usize;
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
        return Err(Error::invalid(
            format!("Oculus file {file}"),
            format!("{} bytes", bytes.len()),
            "holds no simple ping result (message id 0x23)",
        ));
    }
    Ok(pings)
}

/// Returns the ping of one simple ping result message.
#[expect(clippy::too_many_lines, reason = "one message's fields in their order")]
fn ping(m: &Reader<'_>, version: u16, elevation: Option<f64>) -> Result<OculusPing> {
    let v2 = version == 2;
    if version > 2 {
        return Err(m.bad(8, "msgVersion", format!("{version}: versions 1 and 2 are read")));
    }
    let flags = m.u8(20, "flags")?;
    let fire = if v2 { 89 } else { 53 };
    let ping_id = m.u32(fire, "pingId")?;
    let frequency = m.f64(fire + 8, "frequency")?;
    // v1: ..., speedOfSoundUsed (f64), pingStartTime (u32), dataSize; v2: heading, pitch, roll
    // and pingStartTime (f64) come between.
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
    if !(range_resolution.is_finite() && range_resolution > 0.0) {
        return Err(m.bad(
            after_sos + 1,
            "rangeResolution",
            format!("{range_resolution} m: must be > 0"),
        ));
    }
    let bearings_deg = (0..n_beams)
        .map(|j| {
            let raw = m.take::<2>(fixed + 2 * j, "bearings")?;
            Ok(f64::from(i16::from_le_bytes(raw)) / 100.0)
        })
        .collect::<Result<Vec<f64>>>()?;
    if bearings_deg.windows(2).any(|w| w[1] <= w[0]) {
        return Err(m.bad(fixed, "bearings", "do not increase strictly from beam to beam"));
    }
    let gain = flags & 0x04 != 0;
    let stride = n_beams * sample + if gain { 4 } else { 0 };
    if image_size != n_ranges * stride {
        return Err(m.bad(
            offsets + 4,
            "imageSize",
            format!(
                "{image_size} bytes is not nRanges × (nBeams × {sample}{}) = {}",
                if gain { " + 4 gain bytes" } else { "" },
                n_ranges * stride
            ),
        ));
    }
    if image_offset < fixed + 2 * n_beams || image_offset + image_size > m.bytes.len() {
        return Err(m.bad(
            offsets,
            "imageOffset",
            format!(
                "{image_offset} + {image_size} bytes lies outside the message (bearings end at {}, the message at {})",
                fixed + 2 * n_beams,
                m.bytes.len()
            ),
        ));
    }
    let rows = &m.bytes[image_offset..image_offset + image_size];
    let mut gains = gain.then(|| Vec::with_capacity(n_ranges));
    let (mut u8s, mut u16s) = (Vec::new(), Vec::new());
    for row in rows.chunks_exact(stride) {
        let samples = if let Some(g) = &mut gains {
            g.push(u32::from_le_bytes(row[..4].try_into().expect("4 bytes")));
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
    let elevation = match elevation.or_else(|| elevation_of(frequency)) {
        Some(e) => e,
        None => {
            return Err(m.bad(
                fire + 8,
                "frequency",
                format!("{frequency} Hz is not an Oculus frequency whose elevation aperture is known: give it (elevation)"),
            ));
        }
    };
    let range_bins = u32::try_from(n_ranges).expect("a u16");
    #[expect(clippy::cast_precision_loss, reason = "a u16 count")]
    let range_max = n_ranges as f64 * range_resolution;
    // Provisional beams for the builder; the ping's own replace them.
    let sonar = Sonar {
        name: format!("oculus-ping-{ping_id}"),
        kind: SonarKind::Fls,
        range_min: 0.0,
        range_max,
        azimuth_aperture: 180.0,
        elevation_aperture: elevation,
        range_bins,
        beams: BeamLayout::Uniform { count: 1 },
    }
    .with_beam_centres(&bearings_deg, None)
    .map_err(|e| Error::from(e.in_context(&format!("Oculus file {}: offset {}", m.file, m.base))))?;
    Ok(OculusPing {
        sonar,
        image,
        gains,
        bearings_deg,
        offset: m.base,
        version: if v2 { 2 } else { 1 },
        ping_id,
        frequency,
        range_resolution,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Returns a simple ping result message of `version` built field by field from the SDK
    /// header's layout: `bearings` (0.01°), an image of `rows` × bearings samples of `sample`
    /// bytes whose value is `row * 7 + column` (wrapping), gains when `gain`.
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
                m.extend_from_slice(&(1000 + u32::try_from(r).unwrap()).to_le_bytes());
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
        refused(&bearings, &["bearings", "increase"]);
        bearings[8..10].copy_from_slice(&3u16.to_le_bytes());
        refused(&bearings, &["msgVersion", "3"]);
    }
}
