//! A batch of projections: one sonar pair, one sampling rule, many (measurement, pose) items.
//! Preparing it turns every measurement into a sampling plan, which both backends consume. Items
//! with the same sample counts share a plan.

use std::collections::HashMap;

use rayon::prelude::*;

use crate::error::Result;
use crate::geometry::pose::RelativePose;
use crate::geometry::sonar::Sonar;
use crate::local_precision::{LocalPrecision, local_precision, resolve_sigma_range};
use crate::metrics::Metrics;
use crate::occupancy::{Layout, Occupancy};
use crate::sampling::{Measurement, Sampling, SamplingPlan, auto_spacing, base_azimuth};

/// One projection to compute: what sonar 1 measured and where sonar 2 is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BatchItem {
    /// The measurement in sonar 1.
    pub measurement: Measurement,
    /// The pose mapping sonar-1 to sonar-2 coordinates.
    pub pose: RelativePose,
    /// The feature's true point in sonar 1, `[range m, azimuth deg, elevation deg]`, when known.
    /// Its projection then carries the local precision there ([`Projection::local`]).
    pub true_point: Option<[f64; 3]>,
}

/// Many projections between the same two sonars.
#[derive(Clone, Debug, PartialEq)]
pub struct Batch {
    /// Sonar 1, which measured the features.
    pub source: Sonar,
    /// Sonar 2, where the features are looked for.
    pub target: Sonar,
    /// How the back-projected sets are sampled.
    pub sampling: Sampling,
    /// The cell side (m) of the grid the projection area is counted in (FLS target). The paper's is
    /// [`PAPER_AREA_GRID`](crate::PAPER_AREA_GRID). See [`AreaGrid`](crate::occupancy::AreaGrid).
    pub area_grid: f64,
    /// The range error (m) the local precision of an item with a true point is computed for. `None`
    /// means [`default_sigma_range`](crate::local_precision::default_sigma_range).
    pub sigma_range: Option<f64>,
    /// The projections, in order.
    pub items: Vec<BatchItem>,
}

/// The result of one projection.
#[derive(Clone, Debug, PartialEq)]
pub struct Projection {
    /// The metrics (docs/conventions.md).
    pub metrics: Metrics,
    /// The occupancy buffer, when it was asked for.
    pub occupancy: Option<Occupancy>,
    /// The projection-area cells, when the occupancy was asked for. An FLS target only: the
    /// layout's [`AreaGrid`](crate::occupancy::AreaGrid), `nx` rows of `ny`.
    pub cells: Option<Occupancy>,
    /// The local precision at the item's true point, when the item gives one.
    pub local: LocalPrecision,
}

/// A batch made ready for a backend: sonar 2's layout and the distinct sampling plans. It is
/// hidden: the backends' own calls take it, and [`Backend`](crate::Backend) prepares it for its
/// callers.
#[doc(hidden)]
#[derive(Clone, Debug)]
pub struct PreparedBatch<'a> {
    pub(crate) batch: &'a Batch,
    /// Sonar 2's data layout.
    pub(crate) layout: Layout,
    pub(crate) plans: Vec<SamplingPlan>,
    plan_of: PlanOf,
    /// The range error (m) of the items' local precision.
    sigma: f64,
}

/// Which plan of [`PreparedBatch::plans`] each item has.
#[derive(Clone, Debug)]
enum PlanOf {
    /// Every item has the first. Step sampling: the counts do not depend on the item.
    First,
    /// For each item, the index of its plan. At 4 bytes an item, a million-pose batch touches few
    /// pages.
    Each(Vec<u32>),
}

impl PreparedBatch<'_> {
    /// Sets each projection's local precision at its item's true point, for the items that give
    /// one, on all cores. Every backend's projections carry it through [`crate::Backend`].
    pub(crate) fn add_local_precision(&self, projections: &mut [Projection]) {
        let b = self.batch;
        if b.items.iter().all(|item| item.true_point.is_none()) {
            return;
        }
        projections.par_iter_mut().zip(&b.items).for_each(|(p, item)| {
            if let Some(point) = item.true_point {
                p.local = local_precision(&b.source, &b.target, point, &item.pose, self.sigma);
            }
        });
    }

    /// Returns the batch this preparation is of.
    #[must_use]
    pub fn batch(&self) -> &Batch {
        self.batch
    }

    /// Returns whether the batch is solved exactly ([`Sampling::Exact`]). It then has no plans.
    #[must_use]
    pub fn is_exact(&self) -> bool {
        self.batch.sampling == Sampling::Exact
    }

    /// Returns sonar 2's data layout.
    #[must_use]
    pub fn layout(&self) -> &Layout {
        &self.layout
    }

    /// Returns the sampling plan of item `k`.
    ///
    /// # Panics
    /// When `k` is not an item index of the batch.
    #[must_use]
    pub fn plan(&self, k: usize) -> &SamplingPlan {
        &self.plans[self.plan_index(k)]
    }

    /// Returns the index in [`PreparedBatch::plans`] of item `k`'s plan.
    ///
    /// # Panics
    /// When `k` is not an item index of the batch.
    #[must_use]
    pub fn plan_index(&self, k: usize) -> usize {
        match &self.plan_of {
            PlanOf::First => {
                assert!(
                    k < self.batch.items.len(),
                    "item {k} of {}",
                    self.batch.items.len()
                );
                0
            }
            PlanOf::Each(plan_of) => plan_of[k] as usize,
        }
    }

    /// Returns the samples drawn over all items.
    #[must_use]
    pub fn total_samples(&self) -> usize {
        match &self.plan_of {
            PlanOf::First => self
                .plans
                .first()
                .map_or(0, |p| p.total() * self.batch.items.len()),
            PlanOf::Each(plan_of) => plan_of.iter().map(|&p| self.plans[p as usize].total()).sum(),
        }
    }

    /// Returns the distinct sampling plans. Items with equal sample counts share one.
    #[must_use]
    pub fn plans(&self) -> &[SamplingPlan] {
        &self.plans
    }

    /// Returns the azimuth (rad) that item `k`'s plan offsets are added to.
    ///
    /// # Panics
    /// When `k` is not an item index of the batch.
    #[must_use]
    pub fn base_azimuth(&self, k: usize) -> f64 {
        base_azimuth(&self.batch.source, &self.batch.items[k].measurement)
    }
}

/// The checks of items against one sonar pair and sampling, validated once when it was made
/// ([`Batch::checker`]). [`Batch::prepare`] checks its items with one. A reader that streams items
/// through small batches checks each row as it comes.
#[derive(Clone, Copy, Debug)]
pub struct ItemChecker<'a> {
    batch: &'a Batch,
    sampling: Sampling,
    /// The range error (m) of the local precision.
    sigma: f64,
    spacing: Option<f64>,
}

impl ItemChecker<'_> {
    /// Returns `item`'s sample counts `(azimuths, elevations)` when it could be an item of the
    /// batch. Its measurement must be valid for sonar 1, its pose valid, and its sampling plan
    /// within [`MAX_SAMPLES_PER_POSE`](crate::sampling::MAX_SAMPLES_PER_POSE).
    ///
    /// # Errors
    /// [`Error::InvalidValue`](crate::Error::InvalidValue) for an invalid measurement or pose,
    /// or a plan that would draw too many samples.
    pub fn check(&self, item: &BatchItem) -> Result<(usize, usize)> {
        self.validate(item)?;
        self.counts(item)
    }

    /// Returns `Ok` when `item`'s measurement is valid for sonar 1, its pose valid, and its true
    /// point (if any) finite.
    fn validate(&self, item: &BatchItem) -> Result<()> {
        item.measurement.validate(&self.batch.source)?;
        item.pose.validate()?;
        if let Some(p) = item.true_point {
            for (v, name) in p
                .iter()
                .zip(["true point range", "true point azimuth", "true point elevation"])
            {
                crate::error::finite(name, *v)?;
            }
        }
        Ok(())
    }

    /// Returns the sample counts of `item`'s plan, refused past the per-pose limit.
    fn counts(&self, item: &BatchItem) -> Result<(usize, usize)> {
        self.measurement_counts(&item.measurement)
    }

    /// Returns the sample counts of the plan of measurement `m`, refused past the per-pose limit.
    pub(crate) fn measurement_counts(&self, m: &Measurement) -> Result<(usize, usize)> {
        let b = self.batch;
        SamplingPlan::counts(&b.source, &b.target, m, self.sampling, self.spacing)
    }
}

impl Batch {
    /// Returns the checker of items for this batch's sonars and sampling. It validates them once,
    /// however many items are checked.
    ///
    /// # Errors
    /// [`Error::InvalidValue`](crate::Error::InvalidValue) for an invalid sonar, sampling or
    /// area grid.
    pub fn checker(&self) -> Result<ItemChecker<'_>> {
        self.source.validate().map_err(|e| e.in_context("sonar 1"))?;
        self.target.validate().map_err(|e| e.in_context("sonar 2"))?;
        let sampling = self.sampling.validated_for(&self.source)?;
        crate::occupancy::AreaGrid::over(&Layout::of(&self.target), self.area_grid)?;
        let sigma = resolve_sigma_range(&self.source, &self.target, self.sigma_range)?;
        Ok(ItemChecker {
            batch: self,
            sampling,
            sigma,
            // Computed once for every plan that auto sampling counts.
            spacing: matches!(sampling, Sampling::Auto).then(|| auto_spacing(&self.target)),
        })
    }

    /// Returns the batch prepared for a backend: sampling checked, one plan per distinct sample
    /// count.
    ///
    /// # Errors
    /// [`Error::InvalidValue`](crate::Error::InvalidValue) for an invalid sonar, sampling,
    /// measurement or pose (each checked here: the fields are public and may be set by hand,
    /// and item `k`'s errors name it), or a plan that would draw too many samples.
    #[doc(hidden)]
    pub fn prepare(&self) -> Result<PreparedBatch<'_>> {
        let checker = self.checker()?;
        let layout = Layout::of(&self.target).with_area_grid(self.area_grid)?;
        // Every item is checked on all cores. On a failure, `first_error` names the first failing
        // item in order, as a check item by item would.
        let check = |k: usize, item: &BatchItem| -> Result<(usize, usize)> {
            // An invalid item is named. A plan too large is the sampling's fault, not the item's.
            checker
                .validate(item)
                .map_err(|e| e.in_context(format!("item {k}")))?;
            checker.counts(item)
        };
        let first_error = || {
            let first = self
                .items
                .iter()
                .enumerate()
                .find_map(|(k, item)| check(k, item).err());
            first.expect("an item failed its check")
        };
        if let Sampling::Exact = checker.sampling {
            // Nothing is sampled: no plans, every item validated on all cores.
            if !self.items.par_iter().all(|item| checker.validate(item).is_ok()) {
                return Err(first_error());
            }
            return Ok(PreparedBatch {
                batch: self,
                layout: layout.clone(),
                plans: Vec::new(),
                plan_of: PlanOf::First,
                sigma: checker.sigma,
            });
        }
        if let Sampling::Step(_) = checker.sampling {
            // Step sampling counts do not depend on the item, so they are counted once, with the
            // first item's check. Every item is then validated on all cores; nothing is kept per
            // item.
            let plans = match self.items.first() {
                None => Vec::new(),
                Some(item) => {
                    let (n_az, n_el) = check(0, item)?;
                    vec![SamplingPlan::with_counts(&self.source, n_az, n_el)]
                }
            };
            if !self.items.par_iter().all(|item| checker.validate(item).is_ok()) {
                return Err(first_error());
            }
            return Ok(PreparedBatch {
                batch: self,
                layout: layout.clone(),
                plans,
                plan_of: PlanOf::First,
                sigma: checker.sigma,
            });
        }
        // Sample counts packed in one word (each is at most MAX_SAMPLES_PER_POSE < 2^32).
        let pack = |(n_az, n_el): (usize, usize)| (n_az as u64) << 32 | n_el as u64;
        let Ok(keys) = self
            .items
            .par_iter()
            .enumerate()
            .map(|(k, item)| check(k, item).map(pack))
            .collect::<Result<Vec<u64>>>()
        else {
            return Err(first_error());
        };
        // Plans are drawn once per distinct sample count, not once per item. Neighbouring items
        // mostly share one, so the last is tried before the map.
        let mut plans = Vec::new();
        let mut index: HashMap<u64, u32> = HashMap::new();
        let mut last: Option<(u64, u32)> = None;
        let plan_of = keys
            .into_iter()
            .map(|key| {
                let k = match last {
                    Some((l, k)) if l == key => k,
                    _ => *index.entry(key).or_insert_with(|| {
                        #[expect(clippy::cast_possible_truncation, reason = "unpacking `pack`")]
                        let (n_az, n_el) = ((key >> 32) as usize, key as u32 as usize);
                        plans.push(SamplingPlan::with_counts(&self.source, n_az, n_el));
                        u32::try_from(plans.len() - 1).expect("fewer plans than items")
                    }),
                };
                last = Some((key, k));
                k
            })
            .collect();
        Ok(PreparedBatch {
            batch: self,
            layout,
            plans,
            plan_of: PlanOf::Each(plan_of),
            sigma: checker.sigma,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::pose::Rotation;

    /// Returns an item measuring `(range, azimuth)` (m, deg), its pose unrotated and shifted 1 m
    /// along x.
    fn item(range: f64, azimuth: f64) -> BatchItem {
        BatchItem {
            true_point: None,
            measurement: Measurement { range, azimuth },
            pose: RelativePose::new(
                Rotation::RollPitchYaw {
                    roll: 0.0,
                    pitch: 0.0,
                    yaw: 0.0,
                },
                [1.0, 0.0, 0.0],
            )
            .unwrap(),
        }
    }

    fn fls_to_sss(sampling: Sampling, items: Vec<BatchItem>) -> Batch {
        Batch {
            sigma_range: None,
            source: Sonar::preset("paper-fls").unwrap(),
            target: Sonar::preset("paper-sss").unwrap(),
            sampling,
            area_grid: crate::PAPER_AREA_GRID,
            items,
        }
    }

    /// Items are checked on all cores, yet the error names the first invalid item, as a check item
    /// by item would. Plans are shared by items with equal sample counts, in any order.
    #[test]
    fn prepare_names_the_first_invalid_item_and_shares_plans() {
        let items = (0..5000).map(|k| item(1.0 + f64::from(k % 7), 0.0)).collect();
        let mut batch = fls_to_sss(Sampling::Auto, items);
        let prepared = batch.prepare().unwrap();
        // Auto sampling counts depend on the range: 7 ranges, 7 plans, each item on its own.
        assert_eq!(prepared.plans().len(), 7);
        for k in [0, 1, 6, 7, 4999] {
            assert_eq!(prepared.plan(k), prepared.plan(k % 7), "item {k}");
            assert_ne!(
                prepared.plan_index(k),
                prepared.plan_index((k + 1) % 7),
                "item {k}"
            );
        }
        for bad in [4100, 2500, 3000] {
            batch.items[bad].measurement.range = f64::NAN;
        }
        let err = batch.prepare().unwrap_err().to_string();
        assert!(err.contains("item 2500") && !err.contains("item 3000"), "{err}");
    }

    /// Step sampling counts once and keeps nothing per item, with the same answers. Every item has
    /// the one plan, and the error names the first invalid item. A plan too large is refused as the
    /// sampling's fault, unless item 0 is invalid: a check item by item meets that first.
    #[test]
    fn step_sampling_shares_one_plan_and_names_the_first_invalid_item() {
        let mut batch = fls_to_sss(Sampling::Step(0.5), vec![item(5.0, 10.0); 3000]);
        let prepared = batch.prepare().unwrap();
        assert_eq!(prepared.plans().len(), 1);
        // 12° in 0.5° steps: 24 steps, even, so 25 samples.
        assert_eq!(prepared.plan(2999).total(), 25);
        assert_eq!(prepared.total_samples(), 3000 * 25);
        assert!((0..3000).all(|k| prepared.plan_index(k) == 0));
        let empty = Batch {
            items: Vec::new(),
            ..batch.clone()
        };
        let prepared = empty.prepare().unwrap();
        assert_eq!((prepared.plans().len(), prepared.total_samples()), (0, 0));

        for bad in [2000, 700, 2500] {
            batch.items[bad].measurement.azimuth = 90.0;
        }
        let err = batch.prepare().unwrap_err().to_string();
        assert!(err.contains("item 700") && err.contains("azimuth"), "{err}");

        // A step too fine for the per-pose limit: the sampling is named, not an item...
        batch.sampling = Sampling::Step(1e-9);
        let err = batch.prepare().unwrap_err().to_string();
        assert!(err.contains("sampling") && !err.contains("item"), "{err}");
        // ... unless item 0 is itself invalid.
        batch.items[0].measurement.range = f64::NAN;
        let err = batch.prepare().unwrap_err().to_string();
        assert!(err.contains("item 0") && err.contains("range"), "{err}");
    }
}
