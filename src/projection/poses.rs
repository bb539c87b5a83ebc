//! Pose sources: a sweep's poses as a grid or a list, so that a million poses cost no million
//! objects. A grid is decoded from the pose index where the work runs. [`PoseGrid::item`] defines a
//! grid's pose `i`. The fast path's decoder (`GridTables`) builds the same pose from tables made
//! once per grid, bit for bit. A unit test holds it to that.

use glam::{DMat3, DVec3};
use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::geometry::pose::{RelativePose, Rotation};
use crate::geometry::sonar::{Sonar, SonarKind};
use crate::limits::{MAX_AXIS_VALUES, MAX_POSES, MAX_TRANSLATION};
use crate::local_precision::TruePoint;
use crate::occupancy::Layout;
use crate::projection::pairs::PosePairs;
use crate::projection::{Batch, BatchItem};
use crate::sampling::{Measurement, Sampling, SamplingPlan};

/// The names of a grid's nine axes with a placement, in [`PoseGrid`] order. The second three are
/// where the feature appears in sonar 2.
pub const PLACEMENT_AXES: [&str; 9] = [
    "range",
    "azimuth",
    "elevation",
    "place_range",
    "place_azimuth",
    "place_elevation",
    "roll",
    "pitch",
    "yaw",
];

/// The names of a grid's nine axes with a translation (the second three are `t` in m).
pub const TRANSLATION_AXES: [&str; 9] = [
    "range",
    "azimuth",
    "elevation",
    "tx",
    "ty",
    "tz",
    "roll",
    "pitch",
    "yaw",
];

/// Returns the error for a grid of `axes` (name, values) with more than [`MAX_POSES`] poses. It
/// names `field`, the axes that multiply and their product.
#[must_use]
pub fn too_many_poses(field: &str, axes: &[(&str, usize)]) -> Error {
    let sizes: Vec<String> = axes
        .iter()
        .filter(|(_, n)| *n > 1)
        .map(|(name, n)| format!("{name} {n}"))
        .collect();
    // A float, since the product may overflow u64.
    #[expect(clippy::cast_precision_loss, reason = "an order of magnitude to show")]
    let total: f64 = axes.iter().map(|(_, n)| *n as f64).product();
    Error::invalid(
        field,
        format!("{} = {total:.3e} poses", sizes.join(" × ")),
        format!(
            "a grid may have at most {MAX_POSES} poses: fewer values an axis (a larger step), or \
             several grids"
        ),
    )
}

/// A grid of poses: every combination of nine axes' values, the last axis fastest (mixed radix).
/// The axes are, in order:
/// - the feature's true point in sonar 1: range (m), azimuth (deg), elevation (deg);
/// - its place in sonar 2 (range, azimuth, elevation), or the translation `t` (m);
/// - roll, pitch and yaw (deg, [`Rotation::RollPitchYaw`]).
#[derive(Clone, Debug, PartialEq)]
pub struct PoseGrid {
    axes: [Vec<f64>; 9],
    placement: bool,
}

/// Where a sweep's poses come from.
#[derive(Clone, Copy, Debug)]
pub enum PoseSource<'a> {
    /// A grid, decoded from the pose index where the work runs.
    Grid(&'a PoseGrid),
    /// An explicit list of items.
    List(&'a [BatchItem]),
    /// Poses paired with features, each pair an item.
    Pairs(&'a PosePairs),
}

impl PoseSource<'_> {
    /// Returns the number of poses.
    #[must_use]
    pub fn len(&self) -> u64 {
        match self {
            PoseSource::Grid(g) => g.len(),
            PoseSource::List(l) => l.len() as u64,
            PoseSource::Pairs(p) => p.len(),
        }
    }

    /// Returns whether there are no poses.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Returns pose `i` as a batch item (measured by `source`).
    ///
    /// # Errors
    /// As [`PoseGrid::item`]; [`Error::InvalidValue`] for an index past the end.
    pub fn item(&self, source: &Sonar, i: u64) -> Result<BatchItem> {
        let past = |n: u64| Error::invalid("pose index", i, format!("must be below {n}"));
        match self {
            PoseSource::Grid(g) => g.item(source, i),
            PoseSource::Pairs(p) => p.item(i).ok_or_else(|| past(p.len())),
            PoseSource::List(l) => usize::try_from(i)
                .ok()
                .and_then(|k| l.get(k).copied())
                .ok_or_else(|| past(l.len() as u64)),
        }
    }
}

impl PoseGrid {
    /// Returns the grid over `axes` after checking it against sonar 1 `source`, so that no pose of
    /// the grid can fail. The axes are in the order of [`PLACEMENT_AXES`] when `placement`, else of
    /// [`TRANSLATION_AXES`]. Every axis must have 1 to [`MAX_AXIS_VALUES`] finite values, and the
    /// grid at most [`MAX_POSES`] poses. Every feature point must lie in `source`'s field of view.
    /// Every translation must be within [`MAX_TRANSLATION`]. For a placement, the largest place
    /// range plus the largest feature range must be within it.
    ///
    /// # Errors
    /// [`Error::InvalidValue`] naming the axis, the value and the allowed range.
    pub fn new(axes: [Vec<f64>; 9], placement: bool, source: &Sonar) -> Result<Self> {
        let names = if placement {
            PLACEMENT_AXES
        } else {
            TRANSLATION_AXES
        };
        for (a, name) in axes.iter().zip(names) {
            if a.is_empty() || a.len() as u64 > MAX_AXIS_VALUES {
                return Err(Error::invalid(
                    format!("grid axis {name}"),
                    format!("{} values", a.len()),
                    format!("must have 1 to {MAX_AXIS_VALUES} values"),
                ));
            }
            if let Some(v) = a.iter().find(|v| !v.is_finite()) {
                return Err(Error::invalid(format!("grid axis {name}"), v, "must be finite"));
            }
        }
        let grid = PoseGrid { axes, placement };
        grid.checked_len()?;
        grid.check_features(source)?;
        let largest = |a: &[f64]| a.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        if placement {
            if let Some(r) = grid.axes[3].iter().find(|&&r| r < 0.0) {
                return Err(Error::invalid("grid axis place_range", r, "must be >= 0 m"));
            }
            let reach = largest(&grid.axes[3]) + largest(&grid.axes[0]);
            if reach > MAX_TRANSLATION {
                return Err(Error::invalid(
                    "grid axis place_range",
                    largest(&grid.axes[3]),
                    format!(
                        "too large: with the largest feature range the translation could exceed \
                         {MAX_TRANSLATION} m per axis"
                    ),
                ));
            }
        } else {
            for (axis, name) in grid.axes[3..6].iter().zip(&names[3..6]) {
                if largest(axis) > MAX_TRANSLATION {
                    return Err(Error::invalid(
                        format!("grid axis {name}"),
                        largest(axis),
                        format!("must be within ±{MAX_TRANSLATION} m"),
                    ));
                }
            }
        }
        Ok(grid)
    }

    /// Returns `Ok(())` when every feature point of the grid lies in `source`'s field of view.
    ///
    /// # Errors
    /// [`Error::InvalidValue`] naming the axis.
    fn check_features(&self, source: &Sonar) -> Result<()> {
        // Bounds are per coordinate, so checking each value with the others at their first values
        // covers every combination.
        for k in 0..3 {
            for &v in &self.axes[k] {
                let mut p = [self.axes[0][0], self.axes[1][0], self.axes[2][0]];
                p[k] = v;
                source
                    .check_point("feature", p[0], p[1], p[2])
                    .map_err(|e| e.in_context(format!("grid axis {}", self.names()[k])))?;
            }
        }
        Ok(())
    }

    /// Returns the number of poses, or an error past [`MAX_POSES`].
    fn checked_len(&self) -> Result<u64> {
        self.axes
            .iter()
            .try_fold(1u64, |n, a| n.checked_mul(a.len() as u64))
            .filter(|&n| n <= MAX_POSES)
            .ok_or_else(|| {
                let names = if self.placement {
                    PLACEMENT_AXES
                } else {
                    TRANSLATION_AXES
                };
                let axes: Vec<(&str, usize)> = names
                    .iter()
                    .copied()
                    .zip(self.axes.iter().map(Vec::len))
                    .collect();
                too_many_poses("pose grid", &axes)
            })
    }

    /// Returns the number of poses (the product of the axes' lengths).
    #[must_use]
    pub fn len(&self) -> u64 {
        self.axes.iter().map(|a| a.len() as u64).product()
    }

    /// Returns whether the grid has no poses (never: every axis has a value).
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Returns the nine axes' values.
    #[must_use]
    pub fn axes(&self) -> &[Vec<f64>; 9] {
        &self.axes
    }

    /// Returns whether the second three axes are a placement (else a translation).
    #[must_use]
    pub fn placement(&self) -> bool {
        self.placement
    }

    /// Returns the axis names of this grid ([`PLACEMENT_AXES`] or [`TRANSLATION_AXES`]).
    #[must_use]
    pub fn names(&self) -> [&'static str; 9] {
        if self.placement {
            PLACEMENT_AXES
        } else {
            TRANSLATION_AXES
        }
    }

    /// Returns the value index of each axis for pose `i` (mixed radix, the last axis fastest).
    #[expect(
        clippy::cast_possible_truncation,
        reason = "an axis has at most MAX_AXIS_VALUES values"
    )]
    #[must_use]
    pub fn indices(&self, mut i: u64) -> [usize; 9] {
        let mut out = [0; 9];
        for k in (0..9).rev() {
            let n = self.axes[k].len() as u64;
            out[k] = (i % n) as usize;
            i /= n;
        }
        out
    }

    /// Returns the axis values of pose `i`.
    #[must_use]
    pub fn values(&self, i: u64) -> [f64; 9] {
        let idx = self.indices(i);
        std::array::from_fn(|k| self.axes[k][idx[k]])
    }

    /// Returns pose `i` as a batch item, measured by `source` (the sonar the grid was checked
    /// against). This is the definition the decoders are held to.
    ///
    /// # Errors
    /// As [`item_of`] (none for a grid checked by [`PoseGrid::new`] against `source`).
    pub fn item(&self, source: &Sonar, i: u64) -> Result<BatchItem> {
        item_of(source, &self.values(i), self.placement)
    }
}

/// Returns the batch item of one grid row `v` (the nine values in [`PoseGrid`] order). The item is
/// the measurement of the feature `(v[0], v[1])` by `source`, and the pose with roll/pitch/yaw
/// `v[6..9]` and the placement (or translation) `v[3..6]`.
///
/// # Errors
/// As [`Measurement::of`], [`RelativePose::placement`] and [`RelativePose::new`].
pub fn item_of(source: &Sonar, v: &[f64; 9], placement: bool) -> Result<BatchItem> {
    let rotation = Rotation::RollPitchYaw {
        roll: v[6],
        pitch: v[7],
        yaw: v[8],
    };
    let pose = if placement {
        RelativePose::placement(rotation, [v[0], v[1], v[2]], [v[3], v[4], v[5]])?
    } else {
        RelativePose::new(rotation, [v[3], v[4], v[5]])?
    };
    Ok(BatchItem {
        true_point: None,
        measurement: Measurement::of(source, v[0], v[1])?,
        pose,
    })
}

/// A sweep: one sonar pair, one sampling rule and an area grid (as a [`Batch`]'s), and poses from a
/// source. [`Backend::project_columns`](crate::Backend::project_columns) projects any range of its
/// poses into metric columns.
#[derive(Clone, Debug)]
pub struct PoseSweep<'a> {
    /// Sonar 1, which measured the features.
    pub source: Sonar,
    /// Sonar 2, where the features are looked for.
    pub target: Sonar,
    /// How the back-projected sets are sampled.
    pub sampling: Sampling,
    /// The cell side (m) of the projection-area grid (FLS target).
    pub area_grid: f64,
    /// The poses.
    pub poses: PoseSource<'a>,
}

impl PoseSweep<'_> {
    /// Returns the batch of poses `range`, their items in order. The per-item backends run it.
    ///
    /// # Errors
    /// As [`PoseSource::item`].
    pub fn batch(&self, range: std::ops::Range<u64>) -> Result<Batch> {
        Ok(Batch {
            items: range
                .map(|i| self.poses.item(&self.source, i))
                .collect::<Result<_>>()?,
            ..self.empty_batch()
        })
    }

    /// Computes the local precision of poses `range` of a grid, at each feature's true point, for
    /// range error `sigma` (m), on all cores. The model is `recover`'s first-order one
    /// ([`local_precision`](crate::local_precision::local_precision)). The rows of
    /// `range_per_elevation` and `sigma_elevation` are replaced, with NaN where there is no value.
    ///
    /// # Errors
    /// [`Error::Input`] for a list of poses (its items carry their own true points: their
    /// projections give the local precision, [`crate::Projection::local`]);
    /// [`Error::InvalidValue`] for a range past the grid's poses.
    pub fn local_precision_columns(
        &self,
        range: std::ops::Range<u64>,
        sigma: f64,
        range_per_elevation: &mut Vec<f64>,
        sigma_elevation: &mut Vec<f64>,
    ) -> Result<()> {
        let PoseSource::Grid(grid) = self.poses else {
            return Err(Error::input(
                "local precision",
                "needs a grid of poses: a list's projections carry their own (Projection::local), \
                 and pairs have no true points",
            ));
        };
        if range.start > range.end || range.end > grid.len() {
            return Err(Error::invalid(
                "pose range",
                format!("{}..{}", range.start, range.end),
                format!("must lie within the grid's {} poses", grid.len()),
            ));
        }
        let n = usize::try_from(range.end - range.start).expect("a block of poses in memory");
        let tables = GridTables::new(grid, &self.source);
        range_per_elevation.resize(n, 0.0);
        sigma_elevation.resize(n, 0.0);
        range_per_elevation
            .par_chunks_mut(1024)
            .zip(sigma_elevation.par_chunks_mut(1024))
            .enumerate()
            .for_each(|(b, (rpe, sig))| {
                // The feature's true point, prepared again only where the feature changes.
                let mut point: Option<([f64; 3], TruePoint)> = None;
                for (k, (rpe, sig)) in rpe.iter_mut().zip(sig).enumerate() {
                    let i = range.start + (b * 1024 + k) as u64;
                    let d = tables.decode(i);
                    let pose = RelativePose {
                        rotation: d.rotation,
                        translation: d.translation,
                    };
                    let v = grid.values(i);
                    let feature = [v[0], v[1], v[2]];
                    let prepared = match point {
                        Some((f, p)) if f.map(f64::to_bits) == feature.map(f64::to_bits) => p,
                        _ => TruePoint::new(&self.source, &self.target, feature),
                    };
                    point = Some((feature, prepared));
                    let lp = prepared.at(&pose, sigma);
                    *rpe = lp.range_per_elevation.unwrap_or(f64::NAN);
                    *sig = lp.sigma_elevation.unwrap_or(f64::NAN);
                }
            });
        Ok(())
    }

    pub(crate) fn empty_batch(&self) -> Batch {
        Batch {
            sigma_range: None,
            source: self.source.clone(),
            target: self.target.clone(),
            sampling: self.sampling,
            area_grid: self.area_grid,
            items: Vec::new(),
        }
    }

    /// Returns grid `grid` prepared for the fast path. The pair and sampling are checked, and the
    /// grid's features checked against sonar 1. There is one plan per distinct sample count of the
    /// feature's range axis.
    ///
    /// # Errors
    /// As [`Batch::checker`] and [`ItemChecker::check`](crate::projection::ItemChecker::check).
    pub(crate) fn prepare_grid<'g>(&self, grid: &'g PoseGrid) -> Result<PreparedGrid<'g>> {
        let batch = self.empty_batch();
        let checker = batch.checker()?;
        grid.check_features(&self.source)?;
        let layout = Layout::of(&self.target).with_area_grid(self.area_grid)?;
        let mut plans: Vec<(usize, usize)> = Vec::new();
        let mut plan_of_range = Vec::with_capacity(grid.axes[0].len());
        // Sample counts depend only on the measured range (auto sampling), so one item per range
        // value tells them.
        let stride: u64 = grid.axes[1..].iter().map(|a| a.len() as u64).product();
        for r in 0..grid.axes[0].len() as u64 {
            let counts = checker.check(&grid.item(&self.source, r * stride)?)?;
            let k = plans.iter().position(|&c| c == counts).unwrap_or_else(|| {
                plans.push(counts);
                plans.len() - 1
            });
            plan_of_range.push(u32::try_from(k).expect("plans are fewer than range values"));
        }
        Ok(PreparedGrid {
            grid,
            exact: self.sampling == Sampling::Exact,
            plans: plans
                .into_iter()
                .map(|(n_az, n_el)| SamplingPlan::with_counts(&self.source, n_az, n_el))
                .collect(),
            source: self.source.clone(),
            layout,
            plan_of_range,
            range_stride: stride,
        })
    }
}

/// A grid made ready for the fast path: sonar 2's layout, the distinct plans and the plan of
/// each feature range.
pub(crate) struct PreparedGrid<'a> {
    pub(crate) grid: &'a PoseGrid,
    /// Whether the grid's arcs are solved exactly ([`Sampling::Exact`]): its plans are then unused.
    pub(crate) exact: bool,
    pub(crate) source: Sonar,
    pub(crate) layout: Layout,
    pub(crate) plans: Vec<SamplingPlan>,
    pub(crate) plan_of_range: Vec<u32>,
    /// Poses a range value spans (the product of the other axes' lengths).
    pub(crate) range_stride: u64,
}

impl PreparedGrid<'_> {
    /// Returns the index of pose `i`'s range value. One division suffices: the range axis is the
    /// slowest.
    #[expect(clippy::cast_possible_truncation, reason = "an index into the range axis")]
    pub(crate) fn range_index(&self, i: u64) -> usize {
        (i / self.range_stride) as usize
    }
}

/// A grid's tables, built once in f64 so that decoding a pose takes no trigonometry. They hold the
/// axis rotations per roll, pitch and yaw value, the rotation about z by each feature azimuth (the
/// arc's base azimuth, an FLS source), and the cosines and sines of the spherical angles. Decoding
/// composes them in the operations [`item_of`] runs, so a decoded pose equals the item's bit for
/// bit.
pub(crate) struct GridTables<'a> {
    grid: &'a PoseGrid,
    rx: Vec<DMat3>,
    ry: Vec<DMat3>,
    rz: Vec<DMat3>,
    base: Vec<DMat3>,
    /// `(cos, sin)` of the feature's azimuth, elevation, and the place's azimuth, elevation.
    trig: [Vec<(f64, f64)>; 4],
    /// Poses per value of the feature's range axis.
    range_stride: u64,
}

/// One decoded pose: `R`, `t`, the measured range and the rotation about z by the base azimuth.
pub(crate) struct DecodedPose {
    pub(crate) rotation: DMat3,
    pub(crate) translation: DVec3,
    pub(crate) range: f64,
    pub(crate) base: DMat3,
    /// `(cos, sin)` of the feature's azimuth.
    pub(crate) azimuth: (f64, f64),
}

impl<'a> GridTables<'a> {
    pub(crate) fn new(grid: &'a PoseGrid, source: &Sonar) -> Self {
        let rad = |a: &[f64]| a.iter().map(|v| v.to_radians()).collect::<Vec<_>>();
        let cs = |a: &[f64]| {
            a.iter()
                .map(|v| {
                    let r = v.to_radians();
                    (r.cos(), r.sin())
                })
                .collect::<Vec<_>>()
        };
        let fls = source.kind == SonarKind::Fls;
        GridTables {
            grid,
            rx: rad(&grid.axes[6])
                .into_iter()
                .map(DMat3::from_rotation_x)
                .collect(),
            ry: rad(&grid.axes[7])
                .into_iter()
                .map(DMat3::from_rotation_y)
                .collect(),
            rz: rad(&grid.axes[8])
                .into_iter()
                .map(DMat3::from_rotation_z)
                .collect(),
            // The measurement's azimuth is the feature's for an FLS and 0 for a sidescan.
            base: grid.axes[1]
                .iter()
                .map(|&az| DMat3::from_rotation_z(if fls { az.to_radians() } else { 0.0 }))
                .collect(),
            trig: [
                cs(&grid.axes[1]),
                cs(&grid.axes[2]),
                cs(&grid.axes[4]),
                cs(&grid.axes[5]),
            ],
            range_stride: grid.axes[1..].iter().map(|a| a.len() as u64).product(),
        }
    }

    #[inline]
    #[expect(
        clippy::cast_possible_truncation,
        reason = "an axis has at most MAX_AXIS_VALUES values"
    )]
    pub(crate) fn range_index(&self, i: u64) -> usize {
        (i / self.range_stride) as usize
    }

    #[inline]
    pub(crate) fn decode(&self, i: u64) -> DecodedPose {
        let g = self.grid;
        let k = g.indices(i);
        let rotation = (self.rz[k[8]] * self.ry[k[7]] * self.rx[k[6]]).transpose();
        // `sph_to_cart` with the angles' cosines and sines from the tables.
        let sph =
            |r: f64, (ca, sa): (f64, f64), (ce, se): (f64, f64)| DVec3::new(r * ce * ca, r * ce * sa, r * se);
        let range = g.axes[0][k[0]];
        let translation = if g.placement {
            let p1 = sph(range, self.trig[0][k[1]], self.trig[1][k[2]]);
            let p2 = sph(g.axes[3][k[3]], self.trig[2][k[4]], self.trig[3][k[5]]);
            p2 - rotation * p1
        } else {
            DVec3::new(g.axes[3][k[3]], g.axes[4][k[4]], g.axes[5][k[5]])
        };
        DecodedPose {
            rotation,
            translation,
            range,
            base: self.base[k[1]],
            azimuth: self.trig[0][k[1]],
        }
    }
}

/// Returns `sph_to_cart` of `(r, az, el)` in degrees, for the grid's placement points in tests.
#[cfg(test)]
fn sph_deg(r: f64, az: f64, el: f64) -> DVec3 {
    crate::geometry::pose::sph_to_cart(r, az.to_radians(), el.to_radians())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(placement: bool) -> (PoseGrid, Sonar) {
        let source = Sonar::preset("paper-fls").unwrap();
        let axes = [
            vec![5.0, 8.5],
            vec![-10.0, 0.0, 7.3],
            vec![0.0, 3.0],
            if placement {
                vec![10.0, 20.0]
            } else {
                vec![-1.5, 0.25]
            },
            vec![0.0, -4.0],
            vec![1.0],
            vec![0.0, 33.3, 90.0, 179.0],
            vec![-90.0, 12.0, 45.0],
            vec![0.0, 1.0, -120.7],
        ];
        (PoseGrid::new(axes, placement, &source).unwrap(), source)
    }

    /// Every pose decoded from the tables is the item's pose, bit for bit, and the measurement's
    /// base rotation is the one the fast path builds from it.
    #[test]
    fn decoded_poses_are_the_items_bit_for_bit() {
        for placement in [true, false] {
            let (g, source) = grid(placement);
            let tables = GridTables::new(&g, &source);
            for i in 0..g.len() {
                let item = g.item(&source, i).unwrap();
                let d = tables.decode(i);
                assert_eq!(d.rotation, item.pose.rotation, "pose {i}");
                assert_eq!(d.translation, item.pose.translation, "pose {i}");
                assert_eq!(d.range, item.measurement.range);
                assert_eq!(
                    d.base,
                    DMat3::from_rotation_z(crate::sampling::base_azimuth(&source, &item.measurement))
                );
                if placement {
                    // The placement puts the feature where asked (an independent check).
                    let v = g.values(i);
                    let p2 = item.pose.apply(sph_deg(v[0], v[1], v[2]));
                    assert!((p2 - sph_deg(v[3], v[4], v[5])).length() < 1e-9);
                }
            }
        }
    }

    /// The index is mixed radix with the last axis fastest.
    #[test]
    fn indices_are_mixed_radix_last_fastest() {
        let (g, _) = grid(true);
        assert_eq!(g.len(), 2 * 3 * 2 * 2 * 2 * 4 * 3 * 3);
        assert_eq!(g.indices(0), [0; 9]);
        assert_eq!(g.indices(1), [0, 0, 0, 0, 0, 0, 0, 0, 1]);
        assert_eq!(g.indices(3), [0, 0, 0, 0, 0, 0, 0, 1, 0]);
        assert_eq!(g.indices(g.len() - 1), [1, 2, 1, 1, 1, 0, 3, 2, 2]);
    }

    /// Bad grids are refused naming the axis.
    #[test]
    fn bad_grids_name_the_axis() {
        let source = Sonar::preset("paper-fls").unwrap();
        let ok = || std::array::from_fn::<Vec<f64>, 9, _>(|k| vec![if k == 0 || k == 3 { 5.0 } else { 0.0 }]);
        let mut a = ok();
        a[7] = vec![f64::NAN];
        let e = PoseGrid::new(a, true, &source).unwrap_err();
        assert!(e.is_input() && e.to_string().contains("pitch"), "{e}");
        let mut a = ok();
        a[0] = vec![500.0];
        let e = PoseGrid::new(a, true, &source).unwrap_err();
        assert!(e.to_string().contains("grid axis range"), "{e}");
        let mut a = ok();
        a[3] = vec![2e6];
        let e = PoseGrid::new(a, true, &source).unwrap_err();
        assert!(e.to_string().contains("place_range"), "{e}");
        let mut a = ok();
        a[4] = vec![-2e6];
        let e = PoseGrid::new(a, false, &source).unwrap_err();
        assert!(e.to_string().contains("grid axis ty"), "{e}");
        let mut a = ok();
        a[8] = Vec::new();
        let e = PoseGrid::new(a, true, &source).unwrap_err();
        assert!(e.to_string().contains("yaw"), "{e}");
        let big: Vec<f64> = (0..1_000_000).map(f64::from).collect();
        let mut a = ok();
        a[6] = big.clone();
        a[7] = big.clone();
        a[8] = big;
        let e = PoseGrid::new(a, true, &source).unwrap_err();
        let e = e.to_string();
        assert!(e.contains("at most 1099511627776 poses"), "{e}");
        assert!(
            e.contains("roll 1000000 × pitch 1000000 × yaw 1000000 = 1.000e18 poses"),
            "{e}"
        );
    }
}
