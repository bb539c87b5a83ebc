//! Poses paired with features: a sweep's items as indices into a table of poses and a table of
//! measurements, so that many features seen from many poses (a rig advisor's candidates, each
//! scored over its own features) cost no item object each. [`PosePairs::item`] defines item `k`;
//! the fast path, its exact twin and the GPU compose the same pose from the tables, bit for bit,
//! and a test holds them to projecting the items themselves.

use std::collections::HashMap;

use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::geometry::pose::RelativePose;
use crate::geometry::sonar::Sonar;
use crate::occupancy::Layout;
use crate::projection::BatchItem;
use crate::projection::poses::PoseSweep;
use crate::sampling::{Measurement, Sampling, SamplingPlan, base_azimuth};

/// Poses paired with features: item `k` is feature `features[pairs[k][1]]`, measured by sonar 1,
/// looked for in sonar 2 placed by `poses[pairs[k][0]]`. A pose or a feature may take part in
/// any number of pairs, in any order.
#[derive(Clone, Debug, PartialEq)]
pub struct PosePairs {
    poses: Vec<RelativePose>,
    features: Vec<Measurement>,
    pairs: Vec<[u32; 2]>,
}

impl PosePairs {
    /// Returns the pairs `pairs` (pose index, feature index) of `poses` and `features`. The poses
    /// and the measurements are checked against the sonars when a sweep over them is projected.
    ///
    /// # Errors
    /// [`Error::InvalidValue`] naming the first pair whose pose or feature index is past its
    /// table, or a table longer than `u32` indices reach.
    pub fn new(poses: Vec<RelativePose>, features: Vec<Measurement>, pairs: Vec<[u32; 2]>) -> Result<Self> {
        for (name, len) in [("poses", poses.len()), ("features", features.len())] {
            if u32::try_from(len).is_err() {
                return Err(Error::invalid(
                    name,
                    format!("{len} entries"),
                    format!("must have at most {} entries", u32::MAX),
                ));
            }
        }
        for (k, &[p, f]) in pairs.iter().enumerate() {
            for (what, index, len) in [("pose", p, poses.len()), ("feature", f, features.len())] {
                if index as usize >= len {
                    return Err(Error::invalid(
                        format!("pairs[{k}] {what} index"),
                        index,
                        format!("must be below the {len} {what}s"),
                    ));
                }
            }
        }
        Ok(PosePairs {
            poses,
            features,
            pairs,
        })
    }

    /// Returns the number of pairs.
    #[must_use]
    pub fn len(&self) -> u64 {
        self.pairs.len() as u64
    }

    /// Returns whether there are no pairs.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.pairs.is_empty()
    }

    /// Returns the poses.
    #[must_use]
    pub fn poses(&self) -> &[RelativePose] {
        &self.poses
    }

    /// Returns the features' measurements.
    #[must_use]
    pub fn features(&self) -> &[Measurement] {
        &self.features
    }

    /// Returns the pairs, (pose index, feature index) each.
    #[must_use]
    pub fn pairs(&self) -> &[[u32; 2]] {
        &self.pairs
    }

    /// Returns pair `k` as a batch item, or `None` past the end.
    #[must_use]
    pub fn item(&self, k: u64) -> Option<BatchItem> {
        let [p, f] = *self.pairs.get(usize::try_from(k).ok()?)?;
        Some(BatchItem {
            true_point: None,
            measurement: self.features[f as usize],
            pose: self.poses[p as usize],
        })
    }
}

/// Pairs made ready for the fast path and the GPU: sonar 2's layout, the distinct plans, and each
/// feature's plan and base azimuth (rad).
pub(crate) struct PreparedPairs<'a> {
    pub(crate) pairs: &'a PosePairs,
    /// Whether the pairs' arcs are solved exactly ([`Sampling::Exact`]): the plans are then unused.
    pub(crate) exact: bool,
    pub(crate) source: Sonar,
    pub(crate) layout: Layout,
    pub(crate) plans: Vec<SamplingPlan>,
    pub(crate) plan_of_feature: Vec<u32>,
    pub(crate) base_of_feature: Vec<f64>,
}

impl PreparedPairs<'_> {
    /// Returns pair `k`'s pose, the measured range, the base azimuth (rad) and the plan index.
    #[inline]
    pub(crate) fn pose(&self, k: usize) -> (&RelativePose, f64, f64, usize) {
        let [p, f] = self.pairs.pairs[k];
        let f = f as usize;
        (
            &self.pairs.poses[p as usize],
            self.pairs.features[f].range,
            self.base_of_feature[f],
            self.plan_of_feature[f] as usize,
        )
    }
}

impl PoseSweep<'_> {
    /// Returns `pairs` prepared for the fast path and the GPU. The pair of sonars and the sampling
    /// are checked, each pose once and each feature once (an error names its index in its table),
    /// and one plan is made per distinct sample count of the features.
    ///
    /// # Errors
    /// As [`Batch::checker`](crate::Batch::checker) and [`ItemChecker::check`](crate::projection::ItemChecker::check),
    /// in the context of `poses[i]` or `features[i]`.
    pub(crate) fn prepare_pairs<'p>(&self, pairs: &'p PosePairs) -> Result<PreparedPairs<'p>> {
        let batch = self.empty_batch();
        let checker = batch.checker()?;
        let layout = Layout::of(&self.target).with_area_grid(self.area_grid)?;
        for (i, pose) in pairs.poses.iter().enumerate() {
            pose.validate().map_err(|e| e.in_context(format!("poses[{i}]")))?;
        }
        // Each feature checked and its plan counted on all cores. An invalid feature is named;
        // a plan too large is the sampling's fault, not the feature's. On a failure the features
        // are gone through again in order, so the error is the first one's, whichever thread
        // met one first.
        let check = |i: usize, m: &Measurement| -> Result<(usize, usize)> {
            m.validate(&self.source)
                .map_err(|e| e.in_context(format!("features[{i}]")))?;
            checker.measurement_counts(m)
        };
        let Ok(counts) = pairs
            .features
            .par_iter()
            .enumerate()
            .map(|(i, m)| check(i, m))
            .collect::<Result<Vec<_>>>()
        else {
            return Err(pairs
                .features
                .iter()
                .enumerate()
                .find_map(|(i, m)| check(i, m).err())
                .expect("a feature failed its check"));
        };
        // One plan per distinct count. Neighbouring features mostly share one, so the last is
        // tried before the map.
        let mut plans = Vec::new();
        let mut index: HashMap<(usize, usize), u32> = HashMap::new();
        let mut last: Option<((usize, usize), u32)> = None;
        let plan_of_feature = counts
            .into_iter()
            .map(|key| match last {
                Some((l, k)) if l == key => k,
                _ => {
                    let k = *index.entry(key).or_insert_with(|| {
                        plans.push(SamplingPlan::with_counts(&self.source, key.0, key.1));
                        u32::try_from(plans.len() - 1).expect("fewer plans than features")
                    });
                    last = Some((key, k));
                    k
                }
            })
            .collect();
        Ok(PreparedPairs {
            pairs,
            exact: self.sampling == Sampling::Exact,
            source: self.source.clone(),
            layout,
            plans,
            plan_of_feature,
            base_of_feature: pairs
                .features
                .iter()
                .map(|m| base_azimuth(&self.source, m))
                .collect(),
        })
    }
}
