//! Scores a candidate rotation over the features: which ones both sonars see, their projection
//! metric and recovery sigma, the statistics of both, and the objective.

use rayon::prelude::*;
use serde::Serialize;
use sonarproj::Metric;
use sonarproj::geometry::pose::RelativePose;
use sonarproj::geometry::sonar::SonarKind;
use sonarproj::local_precision::{TruePoint, Viewpoint, resolve_sigma_range};
use sonarproj::projection::{Backend, MetricColumns, PosePairs, PoseSource, PoseSweep};
use sonarproj::sampling::Sampling;
use sonarproj::stream::Stop;

use crate::advise::config::{AdviseConfig, Objective};
use crate::advise::pool::{Known, Pool, Shared, shared_share};
use crate::error::Result;

/// Mean, median and 10th/90th percentiles of a set of values, with the standard errors of the
/// mean and the median over the draw of the values; `None` when empty (the errors also for a
/// single value). The mean sums in feature order. Percentiles interpolate linearly at
/// `q · (n − 1)`, like numpy.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Stats {
    /// The mean.
    pub mean: Option<f64>,
    /// The mean's standard error: the sample standard deviation over `√n`.
    pub mean_se: Option<f64>,
    /// The median.
    pub median: Option<f64>,
    /// The median's standard error, free of any assumed distribution: the width of the order
    /// statistics' 95 % interval for the median (1-based ranks `⌊n/2 − 1.96 √n / 2⌋` and
    /// `⌈n/2 + 1.96 √n / 2⌉ + 1`, within `1..=n`) over `2 × 1.96`.
    pub median_se: Option<f64>,
    /// The 10th percentile.
    pub p10: Option<f64>,
    /// The 90th percentile.
    pub p90: Option<f64>,
}

impl Stats {
    /// Returns the statistics of `values` (in feature order).
    #[must_use]
    pub fn of(values: &[f64]) -> Stats {
        if values.is_empty() {
            return Stats::default();
        }
        #[expect(clippy::cast_precision_loss, reason = "feature counts below 2^53")]
        let mean = values.iter().sum::<f64>() / values.len() as f64;
        let mut sorted = values.to_vec();
        sorted.sort_by(f64::total_cmp);
        #[expect(clippy::cast_precision_loss, reason = "feature counts below 2^53")]
        let quantile = |q: f64| {
            let pos = q * (sorted.len() - 1) as f64;
            #[expect(
                clippy::cast_possible_truncation,
                clippy::cast_sign_loss,
                reason = "within the values"
            )]
            let i = pos.floor() as usize;
            let j = (i + 1).min(sorted.len() - 1);
            sorted[i] + (pos - i as f64) * (sorted[j] - sorted[i])
        };
        let n = sorted.len();
        let (mean_se, median_se) = if n < 2 {
            (None, None)
        } else {
            #[expect(clippy::cast_precision_loss, reason = "feature counts below 2^53")]
            let nf = n as f64;
            let variance = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (nf - 1.0);
            let half = 1.96 * nf.sqrt() / 2.0;
            #[expect(
                clippy::cast_possible_truncation,
                clippy::cast_sign_loss,
                reason = "ranks within 1..=n"
            )]
            let rank = |r: f64| (r.clamp(1.0, nf) as usize) - 1;
            let (lo, hi) = (
                rank((nf / 2.0 - half).floor()),
                rank((nf / 2.0 + half).ceil() + 1.0),
            );
            (
                Some((variance / nf).sqrt()),
                Some((sorted[hi] - sorted[lo]) / (2.0 * 1.96)),
            )
        };
        Stats {
            mean: Some(mean),
            mean_se,
            median: Some(quantile(0.5)),
            median_se,
            p10: Some(quantile(0.1)),
            p90: Some(quantile(0.9)),
        }
    }
}

/// A candidate: roll, pitch, yaw (deg) and the offsets x, y, z (m) of the rig's origin or
/// translation ([`crate::advise::config::AXES`]).
pub type Params = [f64; 6];

/// The score of one candidate.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Score {
    /// Roll, pitch, yaw (deg).
    pub rotation: [f64; 3],
    /// The offset of the rig's origin or translation, x, y, z (m).
    pub offset: [f64; 3],
    /// The pose's translation `t` (m).
    pub translation: [f64; 3],
    /// The share of the pool sonar's view the other sonar sees: kept features over pool points
    /// examined. For given points, those sonar 2 sees over all.
    pub shared: f64,
    /// The standard error of `shared` over the draw: `√(shared (1 − shared) / examined)`.
    pub shared_se: f64,
    /// How many points of the pool were examined (the shared share's denominator).
    pub examined: usize,
    /// How many features were scored: those both sonars see.
    pub features: usize,
    /// The projection metric over the shared features (range span m, or projection area m²).
    pub metric: Stats,
    /// The recovery sigma (deg) over the shared features that have one.
    pub sigma: Stats,
    /// The objective's value, smaller is better. `None` when infeasible: shared features below
    /// `min_shared`, none at all, or no value to score.
    pub score: Option<f64>,
    /// The score's standard error over the feature draw ([`Objective`]'s documentation says how
    /// each is computed); `None` with the score, or with a single feature.
    pub score_se: Option<f64>,
    /// Whether the score lies within 2 standard errors (the best's `score_se`) of the best
    /// feasible score: the draw cannot tell it from the best. Set when the candidates are ranked.
    pub tied: bool,
}

impl Score {
    /// Returns the candidate this is the score of.
    #[must_use]
    pub fn params(&self) -> Params {
        let [r, p, y] = self.rotation;
        let [x, yy, z] = self.offset;
        [r, p, y, x, yy, z]
    }
}

/// Returns the name of the projection metric the advisor scores for sonar 2's kind.
#[must_use]
pub fn metric_name(config: &AdviseConfig) -> &'static str {
    match (config.target.kind, config.sampling) {
        (SonarKind::Sss, _) => "span",
        // The authors' area counts grid cells holding samples, which has no exact form; the
        // exact arc gives the polar pixels it meets (the same region in sonar 2's own cells).
        (SonarKind::Fls, Sampling::Exact) => "occupied_measure",
        (SonarKind::Fls, _) => "projection_area",
    }
}

/// Scores candidates over the features on a backend.
pub struct Scorer<'a> {
    config: &'a AdviseConfig,
    backend: &'a Backend,
    sigma_range: f64,
    pool: Pool,
    /// [`Scorer::blind_cost`] of sonar 2.
    blind: f64,
    /// Looked at before each batch of projections: set, the scoring ends with
    /// [`sonarproj::Error::Stopped`].
    stop: Stop<'a>,
}

/// A block of candidates on its way through [`Scorer::score_all`]: their features chosen and
/// paired with them, to be projected and then reduced.
struct Block {
    /// The candidates, as indices into the call's.
    range: std::ops::Range<usize>,
    /// Each candidate's points examined and shared features ([`Pool::shared`]).
    selections: Vec<(usize, Shared)>,
    /// Where each candidate's pairs start, and the end of the last.
    starts: Vec<usize>,
    pairs: PosePairs,
}

/// Returns how many pairs (candidate × feature) `backend` projects in one call with `sampling`. A
/// GPU's device takes four times the CPU's: a GPU call has a fixed cost (its setup and the wait
/// for its last chunk), and on an H200 sweep calls of 131 072 poses cost its host 1.7 times as
/// much a pose as calls of a million (BENCHMARKS.md, "Where a GPU projection call's host time
/// goes"). A GPU without f64 solves exact arcs with the CPU's twin, in the CPU's blocks. Three
/// blocks are in memory at once, about 90 bytes a pair each.
fn pairs_at_once(backend: &Backend, sampling: Sampling) -> usize {
    match backend {
        Backend::Gpu(g) if sampling != Sampling::Exact || g.solves_exact() => 1 << 18,
        Backend::Gpu(_) | Backend::Cpu | Backend::CpuFast => 1 << 16,
    }
}

impl<'a> Scorer<'a> {
    /// Returns the scorer of `config`'s features on `backend`.
    ///
    /// # Errors
    /// An invalid sigma range (none for a checked advise file).
    pub fn new(config: &'a AdviseConfig, backend: &'a Backend) -> Result<Self> {
        let sigma_range = resolve_sigma_range(&config.source, &config.target, config.sigma_range)?;
        Ok(Scorer {
            config,
            backend,
            sigma_range,
            pool: Pool::new(config),
            blind: Self::blind_cost(&config.target),
            stop: Stop::NEVER,
        })
    }

    /// Returns this scorer, ending its scoring with [`sonarproj::Error::Stopped`] once `stop` is
    /// set (looked at before each batch of projections, a fraction of a second of work).
    #[must_use]
    pub fn until(self, stop: Stop<'a>) -> Self {
        Scorer { stop, ..self }
    }

    /// Returns the feature pool.
    #[must_use]
    pub fn pool(&self) -> &Pool {
        &self.pool
    }

    /// Returns the correspondence objective's value and its standard error over the pool points
    /// `examined`, of which the shared ones have `metrics`: the mean search cost of a point,
    /// its metric (at most the blind cost) when both sonars see it, else the blind cost.
    fn search_cost(&self, metrics: &[f64], examined: usize) -> (Option<f64>, Option<f64>) {
        let blind = self.blind;
        let n = examined.max(metrics.len());
        if n == 0 {
            return (None, None);
        }
        let unseen = n - metrics.len();
        #[expect(clippy::cast_precision_loss, reason = "pool sizes below 2^53")]
        let (nf, uf) = (n as f64, unseen as f64);
        let cost = |m: f64| m.min(blind);
        let mean = (metrics.iter().map(|&m| cost(m)).sum::<f64>() + uf * blind) / nf;
        if n < 2 {
            return (Some(mean), None);
        }
        let squares =
            metrics.iter().map(|&m| (cost(m) - mean).powi(2)).sum::<f64>() + uf * (blind - mean).powi(2);
        (Some(mean), Some((squares / (nf - 1.0) / nf).sqrt()))
    }

    /// Returns what searching for a match with no help costs in sonar 2's data: its whole range
    /// (m) for a sidescan, its whole field of view's area on the image plane (m²) for an FLS.
    #[must_use]
    pub fn blind_cost(target: &sonarproj::Sonar) -> f64 {
        match target.kind {
            SonarKind::Sss => target.range_max - target.range_min,
            SonarKind::Fls => {
                let aperture = target.azimuth_aperture.min(360.0).to_radians();
                aperture / 2.0 * (target.range_max.powi(2) - target.range_min.powi(2))
            }
        }
    }

    /// Returns the metric the advisor scores for sonar 2's kind ([`metric_name`]).
    fn metric(&self) -> Metric {
        match (self.config.target.kind, self.config.sampling) {
            (SonarKind::Sss, _) => Metric::Span,
            (SonarKind::Fls, Sampling::Exact) => Metric::OccupiedMeasure,
            (SonarKind::Fls, _) => Metric::ProjectionArea,
        }
    }

    /// Returns the scores of candidates `rotations`, in order, projecting many per call.
    /// Each one's shared features are projected, then their metrics and sigmas reduced.
    ///
    /// Candidates go a block at a time, so memory stays bounded, in a pipeline of three steps:
    /// while one block is projected, the block before is reduced and the features of the block
    /// after are chosen. On a GPU the host's two steps then run while the device projects.
    ///
    /// # Errors
    /// As [`AdviseConfig::pose_of`] and [`Backend::project_columns`].
    pub fn score_all(&self, rotations: &[Params]) -> Result<Vec<Score>> {
        let poses = rotations
            .par_iter()
            .map(|&r| self.config.pose_of(r))
            .collect::<sonarproj::Result<Vec<_>>>()?;
        let size =
            (pairs_at_once(self.backend, self.config.sampling) / self.pool.want().max(1)).clamp(1, 4096);
        let blocks: Vec<std::ops::Range<usize>> = (0..poses.len())
            .step_by(size)
            .map(|s| s..(s + size).min(poses.len()))
            .collect();
        let metric = self.metric();
        let mut columns = [MetricColumns::only(&[metric]), MetricColumns::only(&[metric])];
        let mut out = Vec::with_capacity(rotations.len());
        let mut next = blocks
            .first()
            .map(|b| self.choose(&poses, b.clone()))
            .transpose()?;
        // The block projected last, waiting to be reduced; its columns are the other set's.
        let mut projected: Option<Block> = None;
        for i in 0..blocks.len() {
            self.stop.check()?;
            let block = next.take().expect("chosen in the step before");
            let [a, b] = &mut columns;
            let (now, before) = if i % 2 == 0 { (a, b) } else { (b, a) };
            let (done, (scores, chosen)) = rayon::join(
                || self.project(&block, now),
                || {
                    let scores = projected
                        .as_ref()
                        .map(|p| self.reduce_block(rotations, &poses, p, before));
                    let chosen = blocks.get(i + 1).map(|b| self.choose(&poses, b.clone()));
                    (scores, chosen)
                },
            );
            done?;
            out.extend(scores.into_iter().flatten());
            next = chosen.transpose()?;
            projected = Some(block);
        }
        if let Some(p) = projected {
            out.extend(self.reduce_block(rotations, &poses, &p, &columns[(blocks.len() - 1) % 2]));
        }
        Ok(out)
    }

    /// Returns block `range` of `poses` with each candidate's features chosen ([`kept`]) and
    /// paired with it.
    fn choose(&self, poses: &[RelativePose], range: std::ops::Range<usize>) -> Result<Block> {
        let selections: Vec<(usize, Shared)> = poses[range.clone()]
            .par_iter()
            .map(|p| self.pool.shared(p))
            .collect();
        // Candidate c's features are pairs starts[c].. in order, each with a feature of its own.
        let total = selections.iter().map(|s| s.1.len()).sum();
        let mut starts = Vec::with_capacity(range.len() + 1);
        let mut pairs = Vec::with_capacity(total);
        let mut features = Vec::with_capacity(total);
        for (c, (_, shared)) in selections.iter().enumerate() {
            starts.push(pairs.len());
            let c = u32::try_from(c).expect("a block has at most 4096 candidates");
            pairs.extend(
                (pairs.len()..pairs.len() + shared.len())
                    .map(|f| [c, u32::try_from(f).expect("a block's features are below 2^32")]),
            );
            match shared {
                Shared::Pool(positions) => {
                    features.extend(positions.iter().map(|&k| self.known(k).measurement));
                }
                Shared::Own(kept) => features.extend(kept.iter().map(|x| x.1)),
            }
        }
        starts.push(pairs.len());
        let pairs = PosePairs::new(poses[range.clone()].to_vec(), features, pairs)?;
        Ok(Block {
            range,
            selections,
            starts,
            pairs,
        })
    }

    /// Returns what the pool knows of the kept point at `position` ([`Pool::shared`] keeps only
    /// points that have it).
    fn known(&self, position: usize) -> &Known {
        self.pool.known(position).expect("a kept point has a measurement")
    }

    /// Projects `block`'s pairs into `columns` (the one metric scored).
    fn project(&self, block: &Block, columns: &mut MetricColumns) -> Result<()> {
        let sweep = PoseSweep {
            source: self.config.source.clone(),
            target: self.config.target.clone(),
            sampling: self.config.sampling,
            area_grid: self.config.area_grid,
            poses: PoseSource::Pairs(&block.pairs),
        };
        self.backend
            .project_columns(&sweep, 0..block.pairs.len(), columns, self.stop)?;
        Ok(())
    }

    /// Returns the scores of `block`'s candidates from its projected `columns`.
    fn reduce_block(
        &self,
        rotations: &[Params],
        poses: &[RelativePose],
        block: &Block,
        columns: &MetricColumns,
    ) -> Vec<Score> {
        let column = columns.column(self.metric());
        (0..block.range.len())
            .into_par_iter()
            .map(|c| {
                // No projection area (none visible) scores as none seen: 0.
                let metrics: Vec<f64> = (block.starts[c]..block.starts[c + 1])
                    .map(|k| column.f64(k).unwrap_or(0.0))
                    .collect();
                let (examined, shared) = &block.selections[c];
                let i = block.range.start + c;
                let c = self.config;
                let viewpoint = Viewpoint::of(&poses[i]);
                let sigma = |t: &TruePoint| t.seen_from(&viewpoint, self.sigma_range).sigma_elevation;
                let sigmas: Vec<f64> = match shared {
                    Shared::Pool(positions) => positions
                        .iter()
                        .filter_map(|&k| sigma(&self.known(k).truth))
                        .collect(),
                    Shared::Own(kept) => kept
                        .iter()
                        .filter_map(|&(f, _)| sigma(&TruePoint::new(&c.source, &c.target, f)))
                        .collect(),
                };
                self.reduce(rotations[i], &poses[i], *examined, &metrics, &sigmas)
            })
            .collect()
    }

    /// Returns the score of candidate `params` at `pose`, from the pool points `examined` and its
    /// shared features' `metrics` (one each) and recovery `sigmas` (those that have one).
    fn reduce(
        &self,
        params: Params,
        pose: &RelativePose,
        examined: usize,
        metrics: &[f64],
        sigmas: &[f64],
    ) -> Score {
        let c = self.config;
        let fraction = shared_share(metrics.len(), examined);
        let (metric, sigma) = (Stats::of(metrics), Stats::of(sigmas));
        let cost = self.search_cost(metrics, examined);
        let (value, se) = match c.objective {
            Objective::Correspondence => cost,
            Objective::Ambiguity => (metric.mean, metric.mean_se),
            Objective::Recovery => (sigma.median, sigma.median_se),
            Objective::Mix {
                weight,
                metric_scale,
                sigma_scale,
            } => {
                let (a, b) = (weight / metric_scale, (1.0 - weight) / sigma_scale);
                let value = cost.0.zip(sigma.median).map(|(m, s)| a * m + b * s);
                // The two parts' errors as if independent; a missing one (a single value) as 0.
                let se = match (cost.1, sigma.median_se) {
                    (None, None) => None,
                    (m, s) => Some((a * m.unwrap_or(0.0)).hypot(b * s.unwrap_or(0.0))),
                };
                (value, se)
            }
        };
        #[expect(clippy::cast_precision_loss, reason = "pool sizes below 2^53")]
        let shared_se = if examined == 0 {
            0.0
        } else {
            (fraction * (1.0 - fraction) / examined as f64).sqrt()
        };
        // Every part is finite (bounded inputs); a score that still is not is no score.
        let feasible = !metrics.is_empty() && fraction >= c.min_shared && value.is_none_or(f64::is_finite);
        Score {
            rotation: [params[0], params[1], params[2]],
            offset: [params[3], params[4], params[5]],
            translation: pose.translation.to_array(),
            shared: fraction,
            shared_se,
            examined,
            features: metrics.len(),
            metric,
            sigma,
            score: value.filter(|_| feasible),
            score_se: se.filter(|_| feasible && value.is_some()),
            tied: false,
        }
    }
}
