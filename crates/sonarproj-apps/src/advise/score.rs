//! Scores a candidate rotation over the features: which ones both sonars see, their projection
//! metric and recovery sigma, the statistics of both, and the objective.

use std::sync::OnceLock;

use glam::DVec3;
use rayon::prelude::*;
use serde::Serialize;
use sonarproj::geometry::pose::{RelativePose, cart_to_sph, sph_to_cart};
use sonarproj::geometry::sonar::SonarKind;
use sonarproj::local_precision::{TruePoint, Viewpoint, resolve_sigma_range};
use sonarproj::occupancy::Layout;
use sonarproj::projection::{Backend, MetricColumns, PosePairs, PoseSource, PoseSweep};
use sonarproj::sampling::{Measurement, Sampling};
use sonarproj::stream::Stop;
use sonarproj::{Metric, Sonar};

use crate::advise::config::{AdviseConfig, Objective};
use crate::advise::features::{Features, draw_features};
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

/// The features a candidate is scored over: points in one sonar's frame, taken in order while
/// both sonars see them ([`crate::advise::Features`]).
pub struct Pool {
    /// Whether the pool's points are in sonar 2's frame (else sonar 1's).
    in_target: bool,
    /// The points the other sonar may see under some candidate, with their index in the draw.
    /// Points out of reach of every translation the rig gives are left out: they would be
    /// examined and never kept.
    points: Vec<(usize, DVec3)>,
    /// How many shared features to keep.
    want: usize,
    /// How many points were drawn (or given).
    drawn: usize,
    source: Layout,
    target: Layout,
    /// [`Outside`] of sonar 1's view and of sonar 2's.
    outside: [Outside; 2],
    /// Sonar 1 and sonar 2.
    sonars: (Sonar, Sonar),
    /// For a pool in sonar 1's frame, [`Known`] of its points ([`Pool::known`]), a chunk of
    /// [`KNOWN_CHUNK`] worked out the first time a candidate's walk hands one of them on (80
    /// bytes a point, so at most the pool's size times 80 when every chunk is reached); empty
    /// for a pool in sonar 2's frame, whose points move with the candidate.
    known: Vec<OnceLock<Box<[Option<Known>]>>>,
}

/// How many points of a pool [`Pool::known`] works out at once.
const KNOWN_CHUNK: usize = 4096;

/// A point of a pool in sonar 1's frame, with what scoring a candidate needs of it alone: the same
/// for every candidate that keeps it, so worked out once, bit for bit as for each candidate.
#[derive(Clone, Copy, Debug)]
struct Known {
    /// Its measurement by sonar 1.
    measurement: Measurement,
    /// Its true point, for the recovery sigma.
    truth: TruePoint,
}

/// A quick test of points far outside a sonar's field of view, free of trigonometry: a point it
/// refuses lies farther than [`Outside::MARGIN`] outside the view (relative in range, radians in
/// angle), so [`Layout::inside`] refuses it too, whatever the roundings of `atan2` and `asin`.
/// The points it lets through take the exact test. Most of a pool is far from a candidate's view,
/// so most points skip the trigonometry, and no decision changes.
#[derive(Clone, Copy, Debug)]
struct Outside {
    /// Squared range bounds, widened by the margin.
    r2_min: f64,
    r2_max: f64,
    /// `sin` and `cos` of the half azimuth aperture, when the azimuth is bounded (below π).
    azimuth: Option<(f64, f64)>,
    /// `sin²` and `cos²` of the half elevation aperture, when it is bounded (below π/2).
    elevation: Option<(f64, f64)>,
}

impl Outside {
    /// How far outside (relative range, or angle in radians) a refused point lies at least: far
    /// above the few roundings (about 1e-15 relative) of the tests below.
    const MARGIN: f64 = 1e-9;

    fn of(layout: &Layout) -> Outside {
        let m = Self::MARGIN;
        let (ha, he) = (layout.half_azimuth, layout.half_elevation);
        Outside {
            r2_min: (layout.range_min * (1.0 - m)).powi(2),
            r2_max: (layout.range_max * (1.0 + m)).powi(2),
            azimuth: (ha < std::f64::consts::PI).then(|| ha.sin_cos()),
            elevation: (he < std::f64::consts::FRAC_PI_2).then(|| (he.sin().powi(2), he.cos().powi(2))),
        }
    }

    /// Returns true when `q` surely lies outside the view.
    ///
    /// - Range: `r²` beyond the widened squared bounds.
    /// - Azimuth: `x sin h − |y| cos h = ρ sin(h − |az|)` (`ρ` the horizontal distance), below
    ///   `−MARGIN · r` means `|az| > h + MARGIN`.
    /// - Elevation: `z² cos² h − ρ² sin² h = r² sin(|el| − h) sin(|el| + h)`, above
    ///   `MARGIN · r²` means `|el| > h + MARGIN`.
    #[inline]
    fn surely(&self, q: DVec3) -> bool {
        let rho2 = q.x * q.x + q.y * q.y;
        let r2 = rho2 + q.z * q.z;
        if r2 > self.r2_max || r2 < self.r2_min {
            return true;
        }
        if let Some((s, c)) = self.azimuth
            && q.x * s - q.y.abs() * c < -Self::MARGIN * r2.sqrt()
        {
            return true;
        }
        matches!(self.elevation, Some((s2, c2)) if q.z * q.z * c2 - rho2 * s2 > Self::MARGIN * r2)
    }
}

/// The most points a drawn pool holds: a pool of `count` features draws a hundred times as many,
/// so a share down to 1 % still finds them all. A pool point takes 32 bytes, and in sonar 1's
/// frame up to 80 more once a candidate reaches it (its measurement and true point): 64 MB and
/// 160 MB at most.
pub const MAX_POOL: usize = 2_000_000;

/// The features one candidate is scored over.
#[derive(Clone, Debug, PartialEq)]
pub struct Selection {
    /// Points of the pool examined.
    pub examined: usize,
    /// The shared ones' true points in sonar 1, `[range m, azimuth deg, elevation deg]`.
    pub features: Vec<[f64; 3]>,
}

/// Returns the share `kept / examined` of the pool points examined that were kept (0 for none
/// examined).
#[expect(clippy::cast_precision_loss, reason = "pool sizes below 2^53")]
fn shared_share(kept: usize, examined: usize) -> f64 {
    if examined == 0 {
        0.0
    } else {
        kept as f64 / examined as f64
    }
}

impl Selection {
    /// Returns the share of the pool sonar's view the other sonar sees, from the examined points.
    #[must_use]
    pub fn shared(&self) -> f64 {
        shared_share(self.features.len(), self.examined)
    }
}

impl Pool {
    /// Returns the pool of `config`'s features.
    #[must_use]
    pub fn new(config: &AdviseConfig) -> Pool {
        let cart = |f: &[f64; 3]| sph_to_cart(f[0], f[1].to_radians(), f[2].to_radians());
        let (in_target, points, want): (bool, Vec<DVec3>, usize) = match &config.features {
            Features::Points(p) => (false, p.iter().map(cart).collect(), p.len()),
            Features::Drawn { count, seed } => {
                let in_target = config.target.elevation_aperture < config.source.elevation_aperture;
                let sonar = if in_target { &config.target } else { &config.source };
                let n = count.saturating_mul(100).clamp(*count, MAX_POOL.max(*count));
                let points = draw_features(sonar, n, *seed).iter().map(cart).collect();
                (in_target, points, *count)
            }
        };
        // The other sonar's range bounds the distance of a point it sees from its origin, and
        // the origins are at most `reach` apart whatever the rotation.
        let reach = config.reach();
        let other = if in_target { &config.source } else { &config.target };
        let drawn = points.len();
        let points: Vec<(usize, DVec3)> = points
            .into_iter()
            .enumerate()
            .filter(|(_, p): &(usize, DVec3)| {
                let d = p.length();
                d - reach <= other.range_max * (1.0 + 1e-9) && d + reach >= other.range_min * (1.0 - 1e-9)
            })
            .collect();
        let (source, target) = (Layout::of(&config.source), Layout::of(&config.target));
        let chunks = if in_target {
            0
        } else {
            points.len().div_ceil(KNOWN_CHUNK)
        };
        Pool {
            in_target,
            points,
            want,
            drawn,
            outside: [Outside::of(&source), Outside::of(&target)],
            source,
            target,
            sonars: (config.source.clone(), config.target.clone()),
            known: std::iter::repeat_with(OnceLock::new).take(chunks).collect(),
        }
    }

    /// Returns what scoring needs of the point at `position` in a pool in sonar 1's frame, or
    /// `None` where sonar 1's measurement check refuses it (on a bound, by rounding): what
    /// [`kept`] works out for it under each candidate. Its chunk is worked out on first use.
    fn known(&self, position: usize) -> Option<&Known> {
        let chunk = position / KNOWN_CHUNK;
        let known = self.known[chunk].get_or_init(|| {
            let end = ((chunk + 1) * KNOWN_CHUNK).min(self.points.len());
            self.points[chunk * KNOWN_CHUNK..end]
                .iter()
                .map(|&(_, p)| {
                    let f = in_degrees(cart_to_sph(p));
                    let (source, target) = &self.sonars;
                    Measurement::of(source, f[0], f[1]).ok().map(|measurement| Known {
                        measurement,
                        truth: TruePoint::new(source, target, f),
                    })
                })
                .collect()
        });
        known[position % KNOWN_CHUNK].as_ref()
    }

    /// Returns whether the pool is drawn over sonar 2's view (else sonar 1's).
    #[must_use]
    pub fn in_target(&self) -> bool {
        self.in_target
    }

    /// Returns the pool's features both sonars see under `pose`, in order, up to the count asked.
    #[must_use]
    pub fn select(&self, pose: &RelativePose) -> Selection {
        let mut features = Vec::with_capacity(self.want);
        let examined = self.scan(pose, |_, p1, seen| {
            features.push(in_degrees(if self.in_target { seen } else { cart_to_sph(p1) }));
        });
        Selection { examined, features }
    }

    /// Walks the pool's points in order under `pose` and hands `take` each one both sonars see,
    /// up to the count asked: its position in the pool, the point in sonar 1's frame, and its
    /// range, azimuth and elevation (rad) as the sonar the pool is not drawn over sees it.
    /// Returns how many points of the draw were examined.
    fn scan(&self, pose: &RelativePose, mut take: impl FnMut(usize, DVec3, (f64, f64, f64))) -> usize {
        let inverse = pose.rotation.transpose();
        let (mut examined, mut taken) = (0, 0);
        for (position, &(index, p)) in self.points.iter().enumerate() {
            if taken == self.want {
                break;
            }
            // Every point of the draw up to this one counts as examined. Those left out of the
            // pool could not have been kept.
            examined = index + 1;
            // The other sonar sees it; the point in sonar 1 is the feature.
            let (p1, seen, layout, outside) = if self.in_target {
                let p1 = inverse * (p - pose.translation);
                (p1, p1, &self.source, &self.outside[0])
            } else {
                (p, pose.apply(p), &self.target, &self.outside[1])
            };
            if outside.surely(seen) {
                continue;
            }
            let (r, az, el) = cart_to_sph(seen);
            if !layout.inside(r, az, el) {
                continue;
            }
            take(position, p1, (r, az, el));
            taken += 1;
        }
        // Short of the count: the whole draw was examined.
        if taken < self.want {
            examined = self.drawn;
        }
        examined
    }

    /// Returns the pool points examined for `pose`, and its shared features: [`kept`]'s, with
    /// what a pool in sonar 1's frame knows of its points taken from [`Pool::known`].
    fn shared(&self, pose: &RelativePose) -> (usize, Shared) {
        if self.in_target {
            let (examined, kept) = kept(&self.sonars.0, self, pose);
            return (examined, Shared::Own(kept));
        }
        let mut kept = Vec::with_capacity(self.want);
        let examined = self.scan(pose, |position, _, _| {
            if self.known(position).is_some() {
                kept.push(position);
            }
        });
        (examined, Shared::Pool(kept))
    }
}

/// Returns `[range, azimuth, elevation]` (m, deg, deg) of a point's range and angles (rad).
fn in_degrees((r, az, el): (f64, f64, f64)) -> [f64; 3] {
    [r, az.to_degrees(), el.to_degrees()]
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

/// A candidate's points of the pool examined, and its shared features with their measurements.
pub type Kept = (usize, Vec<([f64; 3], Measurement)>);

/// Returns the pool points examined for `pose`, and the shared features with their `source`
/// measurements. A point on a bound that the measurement check refuses by rounding is left out.
#[must_use]
pub fn kept(source: &sonarproj::Sonar, pool: &Pool, pose: &RelativePose) -> Kept {
    let sel = pool.select(pose);
    let mut kept = Vec::with_capacity(sel.features.len());
    kept.extend(
        sel.features
            .iter()
            .filter_map(|f| Measurement::of(source, f[0], f[1]).ok().map(|m| (*f, m))),
    );
    (sel.examined, kept)
}

/// A candidate's shared features ([`kept`]'s).
enum Shared {
    /// Of a pool in sonar 1's frame: the features' positions in the pool, their [`Pool::known`].
    Pool(Vec<usize>),
    /// Of a pool in sonar 2's frame: the features with their measurements.
    Own(Vec<([f64; 3], Measurement)>),
}

impl Shared {
    /// Returns how many features are shared.
    fn len(&self) -> usize {
        match self {
            Shared::Pool(positions) => positions.len(),
            Shared::Own(kept) => kept.len(),
        }
    }
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
        let size = (pairs_at_once(self.backend, self.config.sampling) / self.pool.want.max(1)).clamp(1, 4096);
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

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;
    use sonarproj::Sonar;

    /// Returns points about `layout`'s view: on its bounds, just inside and outside them (by
    /// 1e-12 to 1e-6, relative or in radians), and anywhere, at random.
    fn points_about(layout: &Layout, rng: &mut ChaCha8Rng) -> Vec<DVec3> {
        let (ha, he) = (layout.half_azimuth, layout.half_elevation);
        let ranges = [
            layout.range_min,
            layout.range_max,
            0.5 * (layout.range_min + layout.range_max),
        ];
        let mut out = Vec::new();
        for _ in 0..20_000 {
            let nudge = |v: f64, rng: &mut ChaCha8Rng| {
                let d = [0.0, 1e-12, 1e-10, 5e-10, 1e-9, 2e-9, 1e-6, 0.1][rng.random_range(0..8)];
                v + if rng.random::<bool>() { d } else { -d }
            };
            let r = if rng.random::<bool>() {
                nudge(ranges[rng.random_range(0..3)], rng)
                    * if rng.random::<bool>() { 1.0 } else { 1.0 + 1e-9 }
            } else {
                rng.random_range(0.0..2.0 * layout.range_max)
            };
            let az = match rng.random_range(0..3) {
                0 => nudge(ha, rng),
                1 => -nudge(ha, rng),
                _ => rng.random_range(-std::f64::consts::PI..std::f64::consts::PI),
            };
            let el = match rng.random_range(0..3) {
                0 => nudge(he, rng),
                1 => -nudge(he, rng),
                _ => rng.random_range(-std::f64::consts::FRAC_PI_2..std::f64::consts::FRAC_PI_2),
            };
            out.push(sph_to_cart(r.max(0.0), az, el));
        }
        // The origin, points on the axes, and values no view holds.
        out.extend([DVec3::ZERO, DVec3::X, DVec3::NEG_X, DVec3::Z, DVec3::NEG_Z]);
        out.extend([f64::NAN, f64::INFINITY, 1e300].map(|v| DVec3::new(v, 0.0, 0.0)));
        out
    }

    /// Returns the presets, and sonars wider than any: azimuth apertures of 200°, 359.9° and
    /// 360°, elevation apertures of 170°, 179.99° and 180°, a range from 0.
    fn sonars() -> Vec<Sonar> {
        let mut out: Vec<Sonar> = Sonar::preset_names()
            .iter()
            .map(|n| Sonar::preset(n).unwrap())
            .collect();
        let base = Sonar::preset("paper-fls").unwrap();
        for (az, el) in [(200.0, 170.0), (359.9, 179.99), (360.0, 180.0), (90.0, 180.0)] {
            let mut s = base.clone();
            (s.name, s.azimuth_aperture, s.elevation_aperture, s.range_min) =
                (format!("wide {az} x {el}"), az, el, 0.0);
            out.push(s);
        }
        out
    }

    /// What the quick test refuses, the exact test refuses, for every preset's view; and it does
    /// refuse points plainly outside in range, azimuth and elevation.
    #[test]
    fn the_quick_test_refuses_only_what_the_exact_test_refuses() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        for sonar in sonars() {
            let name = &sonar.name;
            let layout = Layout::of(&sonar);
            let outside = Outside::of(&layout);
            let mut refused = 0;
            for q in points_about(&layout, &mut rng) {
                let (r, az, el) = cart_to_sph(q);
                if outside.surely(q) {
                    assert!(!layout.inside(r, az, el), "{name}: {q:?} refused but inside");
                    refused += 1;
                }
            }
            assert!(refused > 1000, "{name}: {refused} refused");
            let (ha, he) = (layout.half_azimuth, layout.half_elevation);
            let mid = 0.5 * (layout.range_min + layout.range_max);
            assert!(
                outside.surely(sph_to_cart(layout.range_max * 1.01, 0.0, 0.0)),
                "{name}: range"
            );
            if ha < 3.0 {
                assert!(
                    outside.surely(sph_to_cart(mid, ha + 0.01, 0.0)),
                    "{name}: azimuth"
                );
            }
            if he < 1.5 {
                assert!(
                    outside.surely(sph_to_cart(mid, 0.0, -he - 0.01)),
                    "{name}: elevation"
                );
            }
        }
    }

    /// A pool in sonar 1's frame hands each candidate the points, measurements and true points
    /// that [`kept`] works out under it, bit for bit: drawn pools, and given points on the
    /// bounds of sonar 1's view, some nudged just outside, which its measurement check refuses
    /// (as a rounding might), and drawn points moved just past its range. A pool
    /// in sonar 2's frame hands out `kept`'s own.
    #[test]
    fn what_the_pool_knows_is_what_each_candidate_works_out() {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        // Points on the bounds of sonar 1's view.
        let on_bounds = |sonar: &Sonar| {
            let (ha, he) = (sonar.azimuth_aperture / 2.0, sonar.elevation_aperture / 2.0);
            let points: Vec<String> = (0..400)
                .map(|i| {
                    let r = [sonar.range_min, sonar.range_max, 1.0 + f64::from(i) * 0.02][i as usize % 3];
                    format!(
                        "[{r}, {}, {}]",
                        [ha, -ha][i as usize % 2],
                        [he, -he, 0.0][i as usize / 3 % 3]
                    )
                })
                .collect();
            format!("points = [{}]", points.join(", "))
        };
        let (mut from_pool, mut refused, mut refused_taken) = (0, 0, 0);
        for (from, to) in [
            ("paper-fls", "paper-fls"),
            ("paper-sss", "paper-fls"),
            ("paper-fls", "paper-sss"),
        ] {
            let features = [
                "count = 300\nseed = 3".to_string(),
                on_bounds(&Sonar::preset(from).unwrap()),
            ];
            for f in &features {
                let text = format!(
                    "from = \"{from}\"\nto = \"{to}\"\nobjective = \"correspondence\"\n[features]\n{f}\n\
                     [rig]\norigin = [0.3, -0.2, 0.1]\n[search]\nroll = {{ start = 0, stop = 0, step = 1 }}\n"
                );
                let c = AdviseConfig::parse("test.toml", &text, std::path::Path::new(".")).unwrap();
                let mut pool = Pool::new(&c);
                let range_max = c.source.range_max;
                for (i, (_, p)) in pool.points.iter_mut().enumerate() {
                    if f.starts_with("points") {
                        // Nudged off the range bounds, as rounding might: some just outside.
                        *p *= [1.0, 1.0 + 1e-12, 1.0 - 1e-12][i % 3];
                    } else if i % 7 == 0 {
                        // A drawn point moved just past sonar 1's range: sonar 2 may see it,
                        // the measurement check refuses it, and it counts towards the features
                        // asked for all the same.
                        *p *= range_max * (1.0 + 1e-9) / p.length();
                    }
                }
                for _ in 0..40 {
                    let params = [
                        rng.random_range(-40.0..40.0),
                        rng.random_range(-40.0..40.0),
                        rng.random_range(-40.0..40.0),
                        rng.random_range(-0.5..0.5),
                        rng.random_range(-0.5..0.5),
                        rng.random_range(-0.5..0.5),
                    ];
                    let pose = c.pose_of(params).unwrap();
                    let viewpoint = Viewpoint::of(&pose);
                    let (examined, shared) = pool.shared(&pose);
                    let (want_examined, want) = kept(&c.source, &pool, &pose);
                    assert_eq!(examined, want_examined, "{from}→{to} {f}");
                    // A walk that stops before the end of the draw took the count asked, the
                    // refused points among them.
                    if examined < pool.drawn {
                        assert_eq!(pool.select(&pose).features.len(), pool.want);
                        refused_taken += pool.want - shared.len();
                    }
                    match shared {
                        Shared::Pool(positions) => {
                            assert!(!pool.in_target);
                            assert_eq!(positions.len(), want.len(), "{from}→{to} {f}");
                            for (&k, (f, m)) in positions.iter().zip(&want) {
                                let known = pool.known(k).unwrap();
                                assert_eq!(known.measurement, *m);
                                assert_eq!(
                                    known.truth.seen_from(&viewpoint, 0.01),
                                    TruePoint::new(&c.source, &c.target, *f).seen_from(&viewpoint, 0.01)
                                );
                            }
                            from_pool += positions.len();
                        }
                        Shared::Own(own) => {
                            assert!(pool.in_target);
                            assert_eq!(own, want);
                        }
                    }
                }
                // Counted after the walks, which worked out the chunks they reached.
                refused += (0..pool.known.len() * KNOWN_CHUNK)
                    .take(pool.points.len())
                    .filter(|&k| pool.known(k).is_none())
                    .count();
            }
        }
        assert!(from_pool > 5_000, "{from_pool} features from the pool");
        assert!(refused > 0, "no point refused by the measurement check");
        assert!(
            refused_taken > 0,
            "no refused point counted towards a walk's count"
        );
    }
}
