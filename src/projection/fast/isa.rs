//! Which build of the pose loop runs: baseline x86-64, AVX2 or AVX-512, the widest the processor
//! runs, detected at run time. The binary itself targets baseline x86-64. Every build gives the
//! same bits, since Rust never fuses a multiply and an add.

use super::scratch::Scratch;
use super::tables::Directions;
use super::{Geometry, PoseArgs};
use crate::metrics::Extremes;

/// Which build of the lane stage runs: baseline x86-64, AVX2, AVX-512.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Isa {
    Baseline,
    #[cfg(target_arch = "x86_64")]
    Avx2,
    #[cfg(target_arch = "x86_64")]
    Avx512,
}

impl Isa {
    /// Returns the widest build this processor runs, detected at run time.
    pub(super) fn detect() -> Self {
        #[cfg(target_arch = "x86_64")]
        {
            if is_x86_feature_detected!("avx512f")
                && is_x86_feature_detected!("avx512dq")
                && is_x86_feature_detected!("avx512vl")
            {
                return Isa::Avx512;
            }
            if is_x86_feature_detected!("avx2") {
                return Isa::Avx2;
            }
        }
        Isa::Baseline
    }

    /// Returns every build this processor runs (tests compare them).
    #[cfg(test)]
    pub(super) fn available() -> Vec<Self> {
        let mut all = vec![Isa::Baseline];
        #[cfg(target_arch = "x86_64")]
        {
            if is_x86_feature_detected!("avx2") {
                all.push(Isa::Avx2);
            }
            if Isa::detect() == Isa::Avx512 {
                all.push(Isa::Avx512);
            }
        }
        all
    }
}

/// [`Scratch::draw_pose`] compiled for AVX2 (four f64 lanes a vector). The IEEE operations are the
/// same (Rust never fuses a multiply and an add), so the bits are the same.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn draw_pose_avx2<const BEAMS: bool>(
    s: &mut Scratch,
    geo: &Geometry<'_>,
    dirs: &Directions,
    pose: PoseArgs,
    azimuths: bool,
) -> (u64, Extremes) {
    s.draw_pose::<BEAMS>(geo, dirs, pose, azimuths)
}

/// [`Scratch::draw_pose`] compiled for AVX-512 (eight f64 lanes a vector), the same bits again.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512dq,avx512vl")]
fn draw_pose_avx512<const BEAMS: bool>(
    s: &mut Scratch,
    geo: &Geometry<'_>,
    dirs: &Directions,
    pose: PoseArgs,
    azimuths: bool,
) -> (u64, Extremes) {
    s.draw_pose::<BEAMS>(geo, dirs, pose, azimuths)
}

/// Runs [`Scratch::draw_pose`] in the build `isa` names, which this processor runs
/// ([`Isa::detect`]).
pub(super) fn draw_pose<const BEAMS: bool>(
    isa: Isa,
    s: &mut Scratch,
    geo: &Geometry<'_>,
    dirs: &Directions,
    pose: PoseArgs,
    azimuths: bool,
) -> (u64, Extremes) {
    match isa {
        Isa::Baseline => s.draw_pose::<BEAMS>(geo, dirs, pose, azimuths),
        // SAFETY: `isa` came from `Isa::detect` or `Isa::available`, which saw the processor run
        // these instructions.
        #[cfg(target_arch = "x86_64")]
        Isa::Avx2 => unsafe { draw_pose_avx2::<BEAMS>(s, geo, dirs, pose, azimuths) },
        #[cfg(target_arch = "x86_64")]
        Isa::Avx512 => unsafe { draw_pose_avx512::<BEAMS>(s, geo, dirs, pose, azimuths) },
    }
}
