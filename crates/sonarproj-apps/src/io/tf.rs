//! The rig from a robot's log: the transforms of a ROS 2 bag's `tf2_msgs/msg/TFMessage` topics
//! (`/tf_static`, `/tf`), and the relative pose of two sonar frames at a ping's stamp.
//!
//! A transform stamped with parent frame `P` and child `C` maps a point of `C` into `P`:
//! `p_P = q p_C + t`. Static transforms hold at every stamp; the others are interpolated between
//! the samples around the stamp (translation linearly, rotation along the shortest arc), as tf2
//! does, and a stamp outside their samples is refused rather than extrapolated.

use std::collections::HashMap;
use std::io::BufReader;
use std::path::{Path, PathBuf};

use glam::{DMat3, DQuat, DVec3};
use serde::{Deserialize, Serialize};
use sonarproj::{RelativePose, Rotation};

use super::bag::{Header, MAX_BAG_RECORD_BYTES, Vector3};
use crate::error::{Error, Result};

/// The schema name of the transforms read.
pub const TF_MESSAGE: &str = "tf2_msgs/msg/TFMessage";

/// The most transform samples kept from one bag (8 388 608, about 0.5 GiB: over 20 hours of
/// ten joints at 100 Hz): a longer `/tf` is refused.
pub const MAX_TF_SAMPLES: usize = 1 << 23;

/// The definition of [`TF_MESSAGE`] with the messages it uses, as an MCAP schema holds it.
pub const TF_MESSAGE_DEFINITION: &str = concat!(
    "geometry_msgs/TransformStamped[] transforms
================================================================================
MSG: geometry_msgs/TransformStamped
std_msgs/Header header
string child_frame_id
Transform transform
",
    super::bag::header_definitions!(),
    "================================================================================
MSG: geometry_msgs/Transform
Vector3 translation
Quaternion rotation
================================================================================
MSG: geometry_msgs/Vector3
float64 x
float64 y
float64 z
================================================================================
MSG: geometry_msgs/Quaternion
float64 x 0
float64 y 0
float64 z 0
float64 w 1
"
);

/// `geometry_msgs/Quaternion`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Quaternion {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
    /// w (the scalar).
    pub w: f64,
}

/// `geometry_msgs/Transform`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Transform {
    /// Translation (m).
    pub translation: Vector3,
    /// Rotation.
    pub rotation: Quaternion,
}

/// `geometry_msgs/TransformStamped`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TransformStamped {
    /// Stamp and parent frame.
    pub header: Header,
    /// The child frame.
    pub child_frame_id: String,
    /// The child frame's pose in the parent's.
    pub transform: Transform,
}

/// `tf2_msgs/TFMessage`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TfMessage {
    /// The transforms.
    pub transforms: Vec<TransformStamped>,
}

impl TfMessage {
    /// Returns the message CDR-encoded as a ROS 2 bag holds it (little-endian).
    ///
    /// # Errors
    /// [`Error::WriteOutput`] should the encoder fail.
    pub fn to_cdr(&self) -> Result<Vec<u8>> {
        super::bag::to_cdr(self)
    }
}

/// A rigid transform: `p ↦ q p + t`.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Rigid {
    q: DQuat,
    t: DVec3,
}

impl Rigid {
    const IDENTITY: Rigid = Rigid {
        q: DQuat::IDENTITY,
        t: DVec3::ZERO,
    };

    /// Returns `self ∘ other`: `other` first.
    fn then_after(self, other: Rigid) -> Rigid {
        Rigid {
            q: self.q * other.q,
            t: self.q * other.t + self.t,
        }
    }

    fn inverse(self) -> Rigid {
        let q = self.q.conjugate();
        Rigid { q, t: -(q * self.t) }
    }
}

/// One child frame's link to its parent: static, or samples in time.
#[derive(Clone, Debug)]
struct Link {
    parent: String,
    fixed: Option<Rigid>,
    samples: Vec<(i64, Rigid)>,
}

/// The transforms of a bag, by child frame.
#[derive(Clone, Debug)]
pub struct Frames {
    path: PathBuf,
    links: HashMap<String, Link>,
}

/// The axes of a frame: this project's and REP 103's (x forward, y port, z up), or those of a
/// `ProjectedSonarImage`'s header frame (X up, Y starboard, Z forward).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Axes {
    /// x forward, y port (left), z up.
    ForwardLeftUp,
    /// X up, Y starboard, Z forward.
    SonarImage,
}

impl Axes {
    /// Returns the matrix taking a point in these axes to this project's.
    fn to_project(self) -> DMat3 {
        match self {
            Axes::ForwardLeftUp => DMat3::IDENTITY,
            // (X, Y, Z) ↦ (Z, −Y, X): its own inverse.
            Axes::SonarImage => DMat3::from_cols(DVec3::Z, DVec3::NEG_Y, DVec3::X),
        }
    }
}

/// Returns the nanoseconds of a stamp.
fn nanos(h: &Header) -> i64 {
    i64::from(h.stamp.sec) * 1_000_000_000 + i64::from(h.stamp.nanosec)
}

impl Frames {
    /// Returns the transforms of every `tf2_msgs/msg/TFMessage` topic of the bag at `path`.
    ///
    /// # Errors
    /// [`Error::ReadInput`] when the file cannot be opened; input errors naming the bag, topic
    /// and message for a container that is not MCAP or is truncated, a message that does not
    /// decode, a transform that is not finite or whose quaternion is not of unit norm, a frame
    /// given two parents, and more than [`MAX_TF_SAMPLES`] samples.
    pub fn read(path: &Path) -> Result<Frames> {
        let file = sonarproj::files::open_regular(path).map_err(|source| Error::ReadInput {
            path: path.to_path_buf(),
            source,
        })?;
        crate::report::note_input(path);
        let bad = |what: String| {
            Error::from(sonarproj::Error::input(
                format!("bag {:?}", path.display().to_string()),
                what,
            ))
        };
        let options =
            mcap::sans_io::LinearReaderOptions::default().with_record_length_limit(MAX_BAG_RECORD_BYTES);
        let mut frames = Frames {
            path: path.to_path_buf(),
            links: HashMap::new(),
        };
        let (mut kept, mut index) = (0usize, HashMap::<String, usize>::new());
        for message in mcap::io::MessageReader::new_with_options(BufReader::new(file), options) {
            let message = message.map_err(|e| bad(format!("not a readable MCAP file: {e}")))?;
            let channel = &message.channel;
            if channel.schema.as_ref().is_none_or(|s| s.name != TF_MESSAGE) {
                continue;
            }
            let k = index.entry(channel.topic.clone()).or_default();
            let at = format!("topic {:?} message {k}", channel.topic);
            *k += 1;
            let msg: TfMessage =
                super::bag::from_cdr(&message.data).map_err(|e| bad(format!("{at}: {e}")))?;
            let fixed = channel.topic.ends_with("_static");
            for (j, ts) in msg.transforms.iter().enumerate() {
                let field = || format!("{at}: transforms[{j}]");
                let rigid = rigid(&ts.transform).map_err(|e| bad(format!("{}: {e}", field())))?;
                let (parent, child) = (&ts.header.frame_id, &ts.child_frame_id);
                let link = frames.links.entry(child.clone()).or_insert_with(|| Link {
                    parent: parent.clone(),
                    fixed: None,
                    samples: Vec::new(),
                });
                if link.parent != *parent {
                    return Err(bad(format!(
                        "{}: frame {child:?} has two parents, {:?} and {parent:?}",
                        field(),
                        link.parent
                    )));
                }
                if fixed {
                    link.fixed = Some(rigid);
                } else {
                    kept += 1;
                    if kept > MAX_TF_SAMPLES {
                        return Err(bad(format!(
                            "more than {MAX_TF_SAMPLES} transforms: split the log"
                        )));
                    }
                    link.samples.push((nanos(&ts.header), rigid));
                }
            }
        }
        for link in frames.links.values_mut() {
            link.samples.sort_by_key(|s| s.0);
        }
        Ok(frames)
    }

    /// Returns the error `what` about this bag's transforms.
    fn bad(&self, what: impl std::fmt::Display) -> Error {
        Error::from(sonarproj::Error::input(
            format!("bag {:?}: transforms", self.path.display().to_string()),
            what.to_string(),
        ))
    }

    /// Returns the root of `frame` and the transform from `frame` to it at `stamp` (ns).
    fn to_root(&self, frame: &str, stamp: i64) -> Result<(String, Rigid)> {
        let mut acc = Rigid::IDENTITY;
        let mut at = frame.to_string();
        for _ in 0..=self.links.len() {
            let Some(link) = self.links.get(&at) else {
                return Ok((at, acc));
            };
            acc = self.link_at(&at, link, stamp)?.then_after(acc);
            at.clone_from(&link.parent);
        }
        Err(self.bad(format!("the frames above {frame:?} loop")))
    }

    /// Returns `link` (of child frame `child`) at `stamp`.
    fn link_at(&self, child: &str, link: &Link, stamp: i64) -> Result<Rigid> {
        if let Some(r) = link.fixed {
            return Ok(r);
        }
        let s = &link.samples;
        let after = s.partition_point(|x| x.0 < stamp);
        if after < s.len() && s[after].0 == stamp {
            return Ok(s[after].1);
        }
        if after == 0 || after == s.len() {
            #[expect(clippy::cast_precision_loss, reason = "stamps in ns, shown in s")]
            let secs = |ns: i64| ns as f64 * 1e-9;
            return Err(self.bad(format!(
                "no transform from {:?} to {child:?} at {:.9} s: /tf has it from {:.9} to {:.9} s \
                 (tf is not extrapolated)",
                link.parent,
                secs(stamp),
                secs(s[0].0),
                secs(s[s.len() - 1].0)
            )));
        }
        let ((t0, a), (t1, b)) = (s[after - 1], s[after]);
        #[expect(clippy::cast_precision_loss, reason = "a fraction of an interval of stamps")]
        let f = (stamp - t0) as f64 / (t1 - t0) as f64;
        Ok(Rigid {
            q: a.q.slerp(b.q, f),
            t: a.t.lerp(b.t, f),
        })
    }

    /// Returns the pose of sonar 2 (frame `to`, in axes `to_axes`) relative to sonar 1 (frame
    /// `from`, `from_axes`) at `stamp` (ns), in this project's convention: a point `p1` of sonar
    /// 1 is `p2 = R p1 + t` in sonar 2, both in this project's axes (x forward, y port, z up).
    ///
    /// # Errors
    /// Input errors naming the frames: a frame the transforms do not connect to the other, or a
    /// moving transform with no samples around `stamp`. As [`RelativePose::new`].
    pub fn relative_pose(
        &self,
        (from, from_axes): (&str, Axes),
        (to, to_axes): (&str, Axes),
        stamp: i64,
    ) -> Result<RelativePose> {
        let (root_a, a) = self.to_root(from, stamp)?;
        let (root_b, b) = self.to_root(to, stamp)?;
        if root_a != root_b {
            let known = |f: &str| {
                if self.links.contains_key(f) || self.links.values().any(|l| l.parent == f) {
                    String::new()
                } else {
                    format!(" ({f:?} is in no transform)")
                }
            };
            return Err(self.bad(format!(
                "frames {from:?} and {to:?} are not connected: their roots are {root_a:?} and \
                 {root_b:?}{}{}",
                known(from),
                known(to)
            )));
        }
        // p_to = T_b⁻¹ T_a p_from, in the frames' own axes.
        let ba = b.inverse().then_after(a);
        let (m1, m2) = (from_axes.to_project(), to_axes.to_project());
        // p2 = M2 (R (M1⁻¹ p1) + t), and M1⁻¹ = M1ᵀ.
        let r = m2 * DMat3::from_quat(ba.q) * m1.transpose();
        let t = m2 * ba.t;
        let rows = r.transpose().to_cols_array_2d();
        Ok(RelativePose::new(Rotation::Matrix(rows), t)?)
    }
}

/// Returns the rigid transform of `tf`, checked.
fn rigid(tf: &Transform) -> std::result::Result<Rigid, String> {
    let Vector3 { x, y, z } = tf.translation;
    let Quaternion {
        x: qx,
        y: qy,
        z: qz,
        w,
    } = tf.rotation;
    if ![x, y, z, qx, qy, qz, w].iter().all(|v| v.is_finite()) {
        return Err("a number that is not finite".into());
    }
    let q = DQuat::from_xyzw(qx, qy, qz, w);
    let norm = q.length();
    if (norm - 1.0).abs() > 1e-3 {
        return Err(format!("rotation's norm is {norm}, not 1"));
    }
    Ok(Rigid {
        q: q / norm,
        t: DVec3::new(x, y, z),
    })
}
