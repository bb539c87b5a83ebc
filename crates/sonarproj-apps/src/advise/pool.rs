//! The feature pool a candidate is scored over: points drawn (or given) in one sonar's frame,
//! walked in order under a candidate's pose for those both sonars see, with a quick test that
//! refuses points far outside a view without trigonometry, and, for a pool in sonar 1's frame,
//! each point's measurement and true point worked out once for all candidates.

use std::sync::OnceLock;

use glam::DVec3;
use sonarproj::Sonar;
use sonarproj::geometry::pose::{RelativePose, cart_to_sph, sph_to_cart};
use sonarproj::local_precision::TruePoint;
use sonarproj::occupancy::Layout;
use sonarproj::sampling::Measurement;

use crate::advise::config::AdviseConfig;
use crate::advise::features::{Features, draw_features};

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
pub(super) struct Known {
    /// Its measurement by sonar 1.
    pub(super) measurement: Measurement,
    /// Its true point, for the recovery sigma.
    pub(super) truth: TruePoint,
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
pub(super) fn shared_share(kept: usize, examined: usize) -> f64 {
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
    pub(super) fn known(&self, position: usize) -> Option<&Known> {
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

    /// Returns how many shared features a candidate is scored over, at most.
    #[must_use]
    pub fn want(&self) -> usize {
        self.want
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
    pub(super) fn shared(&self, pose: &RelativePose) -> (usize, Shared) {
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
pub(super) enum Shared {
    /// Of a pool in sonar 1's frame: the features' positions in the pool, their [`Pool::known`].
    Pool(Vec<usize>),
    /// Of a pool in sonar 2's frame: the features with their measurements.
    Own(Vec<([f64; 3], Measurement)>),
}

impl Shared {
    /// Returns how many features are shared.
    pub(super) fn len(&self) -> usize {
        match self {
            Shared::Pool(positions) => positions.len(),
            Shared::Own(kept) => kept.len(),
        }
    }
}
#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;
    use sonarproj::Sonar;
    use sonarproj::local_precision::Viewpoint;

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
