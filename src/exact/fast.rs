//! The fast twin of the exact solver: the same arc, pieces and metrics as [`super::visible_arc`],
//! with every bound written as a polynomial in `s = tan(φ/2)`. `cpu-fast` runs it on every core
//! (and the GPU backend of a device without f64; with f64 the GPU runs its WGSL twin,
//! `shaders/exact.wgsl`); on a pose grid each pose is decoded where it is solved ([`project_grid`]),
//! and pairs of poses and features are looked up in their tables ([`project_pairs`]).
//!
//! With `cos φ = (1 − s²)/(1 + s²)` and `sin φ = 2s/(1 + s²)`, a first-degree trigonometric
//! function `a + b cos φ + c sin φ` times `1 + s²` is the quadratic `(a + b) + 2c s + (a − b) s²`,
//! of the same sign. So the range and azimuth bounds, the axis planes, the stationary points and
//! the crossings of bin and beam edges are roots of quadratics, and the elevation bound
//! (`r² sin² e − z² ≥ 0`) those of a quartic: no root takes a trigonometric call. Pieces are
//! judged by the bounds' signs at inner points (the inequalities [`Layout::inside`] tests with
//! angles), the extremes come from points of the arc, and only the visible length (`atan`) and
//! the azimuths (`atan2`) take trigonometry.
//!
//! What makes it fast, besides the polynomials:
//! - Before any root, the arc's range, height and the azimuth bound's half-planes are bounded in
//!   closed form over the whole arc (a first-degree function's extremes lie at the ends or at one
//!   known point). An arc that clearly misses the field of view is answered at once, and a bound
//!   that clearly holds, or fails, all along the arc needs no roots. "Clearly" keeps a margin of
//!   1e-12 of the values compared, far above their rounding, so nothing visible is culled.
//! - The quartic's roots are bracketed by its turning points, and a thin fan's turning point is
//!   replaced by the height's zero, where the bound clearly holds (`fast_roots::quartic_roots`).
//! - Newton's method stops one evaluation earlier than the reference's (`fast_roots::SETTLE`).
//! - A piece whose middle is clearly in or out of view takes one point, not the reference's vote.
//! - The axis-plane cuts, which keep the azimuth continuous along a piece, are made only for a
//!   field of view that reaches behind sonar 2, where the azimuth can jump.
//!
//! Against the reference, lengths, ranges and azimuths agree to rounding (both find the same
//! roots, from different formulas), and cells agree but where a piece's end or an extreme sits on
//! a bin or beam edge: `tests/exact/main.rs` holds the two to that.

use std::f64::consts::{FRAC_PI_2, PI};

use glam::DVec3;
use rayon::prelude::*;

use super::fast_roots::{closed_form_roots, quadratic_roots, quartic_roots};
use super::roots::List;
use super::{Arc, VOTES, azimuth_of, by_vote, farthest_sign, rectangle, walk};
use crate::SonarKind;
use crate::metrics::{Extremes, Metrics};
use crate::occupancy::{Layout, Occupancy};
use crate::projection::columns::MetricColumns;
use crate::projection::pairs::PreparedPairs;
use crate::projection::poses::{GridTables, PreparedGrid};
use crate::projection::{Output, PreparedBatch, Projection};
use crate::stream::Stop;

/// The margin (relative) by which a bound must be missed over the whole arc for a cull.
const CULL_MARGIN: f64 = 1e-12;

/// Poses a thread takes at a time on a grid.
const POSE_BLOCK: usize = 256;

/// The metrics a caller keeps beyond the ranges: the visible fraction, the azimuths' extremes and
/// the cells cost the most.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Keep {
    /// The visible fraction (an `atan` a run of the arc); without, a seen arc's fraction is
    /// left at 1, the metrics' sign that it is seen.
    pub(crate) fraction: bool,
    pub(crate) azimuths: bool,
    pub(crate) cells: bool,
}

/// Sonar 2's bounds as the solver tests them, and sonar 1's elevation interval: the constants the
/// fast twin and the GPU's exact stage (`shaders/exact.wgsl`) share, set once per batch.
#[derive(Clone, Copy, Debug)]
pub(crate) struct SolverConstants {
    /// `range_min²` (0 without a minimum range) and `range_max²`.
    pub(crate) r2_min: f64,
    pub(crate) r2_max: f64,
    /// `(sin h, cos h)` of the half azimuth aperture `h`, when it clips (`h < π`).
    pub(crate) azimuth: Option<(f64, f64)>,
    /// `sin² e` of the half elevation aperture `e`, when it clips (`e < π/2`).
    pub(crate) elevation: Option<f64>,
    /// Sonar 1's half elevation aperture `H`, `tan(H/2)`, `cos H`, `sin H`.
    pub(crate) half: f64,
    pub(crate) end: f64,
    pub(crate) cos_half: f64,
    pub(crate) sin_half: f64,
    /// Whether the field of view reaches behind sonar 2 (`x ≤ 0`: a half azimuth aperture of
    /// π/2 or more). Only then can a visible piece cross the `y = 0` plane behind, where the
    /// azimuth jumps, so only then are pieces cut at the axis planes, as the reference cuts them.
    pub(crate) behind: bool,
}

impl SolverConstants {
    /// Returns the constants of arcs of a sonar 1 whose half elevation aperture is `half` (rad)
    /// into `layout`.
    pub(crate) fn new(layout: &Layout, half: f64) -> Self {
        SolverConstants {
            behind: layout.half_azimuth >= FRAC_PI_2,
            r2_min: layout.range_min.powi(2),
            r2_max: layout.range_max.powi(2),
            azimuth: (layout.half_azimuth < PI).then(|| layout.half_azimuth.sin_cos()),
            elevation: (layout.half_elevation < FRAC_PI_2).then(|| layout.half_elevation.sin().powi(2)),
            half,
            end: (half / 2.0).tan(),
            cos_half: half.cos(),
            sin_half: half.sin(),
        }
    }
}

/// The fast twin's solver: the constants, sonar 2's beam edges and what the caller keeps.
pub(crate) struct Solver<'l> {
    layout: &'l Layout,
    k: SolverConstants,
    /// `(sin, cos)` of each beam edge, for more than one beam.
    edges: Vec<(f64, f64)>,
    /// For a sidescan, whose bins all measure their width: the sums of 0, 1, 2, … widths added one
    /// by one, as the reduce stage adds an occupancy buffer's bins (the same bits for any `n`).
    bin_sums: Option<Vec<f64>>,
    keep: Keep,
}

/// Which of sonar 2's bounds an arc may cross ([`Solver::screen`]): the others hold, or fail,
/// all along it, and need no roots.
#[derive(Clone, Copy, Debug)]
struct Screen {
    range_min: bool,
    range_max: bool,
    /// The azimuth bound's half-planes on the `y ≥ 0` and the `y ≤ 0` side.
    sides: [bool; 2],
    elevation: bool,
}

/// One arc's cells, gathered before they are counted (room reused from pose to pose).
#[derive(Default)]
pub(crate) struct Cells {
    cells: Vec<(usize, usize)>,
    /// Range-bin intervals of a one-beam layout.
    bins: Vec<(usize, usize)>,
}

/// `(1 + s²)(a + b cos φ + c sin φ)` as the coefficients of `1, s, s²`.
fn quadratic(a: f64, b: f64, c: f64) -> [f64; 3] {
    [a + b, 2.0 * c, a - b]
}

/// Returns the end of `[a, b]` where the quadratic `c` is nearer 0: where an edge that the ends'
/// cells say is crossed has no root inside, it sits on an end (a piece cut there, its root
/// rounded just outside).
fn nearer_end(c: [f64; 3], a: f64, b: f64) -> f64 {
    let at = |x: f64| ((c[2] * x + c[1]) * x + c[0]).abs();
    if at(a) <= at(b) { a } else { b }
}

/// Returns `atan e − atan s`, half the elevation from `s` to `e` (both in `(−1, 1]`, so
/// `1 + s e > 0`), with one `atan`.
fn arc_angle(s: f64, e: f64) -> f64 {
    ((e - s) / (1.0 + s * e)).atan()
}

/// Returns the point of `arc` at `s = tan(φ/2)`.
#[inline]
fn point(arc: &Arc, s: f64) -> DVec3 {
    let k = 1.0 / (1.0 + s * s);
    arc.u * ((1.0 - s * s) * k) + arc.w * (2.0 * s * k) + arc.t
}

impl<'l> Solver<'l> {
    /// Returns the solver for arcs of a sonar 1 whose half elevation aperture is `half` (rad) into
    /// `layout`, keeping what `keep` says.
    pub(crate) fn new(layout: &'l Layout, half: f64, keep: Keep) -> Self {
        let edges = if layout.beams() > 1 {
            layout.beam_edges.iter().map(|e| e.sin_cos()).collect()
        } else {
            Vec::new()
        };
        let bin_sums = (layout.kind == SonarKind::Sss).then(|| {
            let w = layout.range_bin_width;
            std::iter::successors(Some(0.0), |&sum| Some(sum + w))
                .take(layout.range_bins * layout.beams() + 1)
                .collect()
        });
        Solver {
            layout,
            k: SolverConstants::new(layout, half),
            bin_sums,
            edges,
            keep,
        }
    }

    /// Returns the least and the largest value of `a + b cos φ + c sin φ` over `[−H, H]`.
    fn bounds(&self, a: f64, b: f64, c: f64) -> (f64, f64) {
        let m = (b * b + c * c).sqrt();
        let e0 = a + b * self.k.cos_half - c * self.k.sin_half;
        let e1 = a + b * self.k.cos_half + c * self.k.sin_half;
        // The largest value sits at the direction (b, c)/m, the least at its opposite.
        let hi = if b >= m * self.k.cos_half {
            a + m
        } else {
            e0.max(e1)
        };
        let lo = if -b >= m * self.k.cos_half {
            a - m
        } else {
            e0.min(e1)
        };
        (lo, hi)
    }

    /// Returns whether the arc's point at `s` lies in the field of view ([`Layout::inside`]'s
    /// bounds as inequalities without angles: bounds inclusive, the origin outside), and whether
    /// that verdict is clear: every bound held, or one failed, by more than 1e-9 of its terms.
    ///
    /// The point is taken times `k = 1 + s²`, which spares a division: the azimuth and elevation
    /// bounds do not change with a positive scale, and the range bounds are scaled by `k²`.
    #[inline]
    fn inside_scaled(&self, arc: &Arc, s: f64) -> (bool, bool) {
        const CLEAR: f64 = 1e-9;
        let k = 1.0 + s * s;
        let q = arc.u * (1.0 - s * s) + arc.w * (2.0 * s) + arc.t * k;
        let (r2, k2) = (q.length_squared(), k * k);
        // Each bound as (value, scale of its terms): held where the value is ≥ 0.
        let (lo, hi) = (self.k.r2_min * k2, self.k.r2_max * k2);
        let mut bounds = [(r2 - lo, r2 + lo), (hi - r2, hi + r2), (1.0, 1.0), (1.0, 1.0)];
        if let Some((sh, ch)) = self.k.azimuth {
            bounds[2] = (q.x * sh - q.y.abs() * ch, q.x.abs() + q.y.abs());
        }
        if let Some(se2) = self.k.elevation {
            let z2 = q.z * q.z;
            bounds[3] = (r2 * se2 - z2, r2 * se2 + z2);
        }
        let inside = r2 > 0.0 && bounds.iter().all(|&(v, _)| v >= 0.0);
        let clear = if inside {
            bounds.iter().all(|&(v, m)| v > CLEAR * m)
        } else {
            r2 > 0.0 && bounds.iter().any(|&(v, m)| v < -CLEAR * m)
        };
        (inside, clear)
    }

    /// Returns whether the piece `[a, b]` (in `s`) is in view. No bound changes sign inside it,
    /// so a clear verdict at its middle settles it. Else three points vote, as in the reference,
    /// since a point where the arc only touches a bound may sit at the middle.
    fn piece_inside(&self, arc: &Arc, a: f64, b: f64) -> bool {
        let inside = |f: f64| self.inside_scaled(arc, a + f * (b - a));
        let (middle, clear) = inside(VOTES[0]);
        if clear {
            return middle;
        }
        by_vote(middle, |f| inside(f).0)
    }

    /// Returns the sign of `y` along the piece `[a, b]`, as the reference's `side_of`.
    fn side_of(arc: &Arc, a: f64, b: f64) -> f64 {
        farthest_sign(VOTES.map(|f| point(arc, a + f * (b - a)).y))
    }

    /// Returns `None` when the arc surely misses the field of view, else which bounds it may
    /// cross: from bounds of its range, its height and the azimuth's half-planes over the whole
    /// arc, each compared with a margin.
    fn screen(&self, arc: &Arc) -> Option<Screen> {
        // Surely below 0 (`lo`, `hi`: bounds of a function; `scale`: of its terms).
        let below = |hi: f64, scale: f64| hi < -CULL_MARGIN * scale;
        let above = |lo: f64, scale: f64| lo > CULL_MARGIN * scale;
        let (a, b, c) = arc.range_sq();
        let (r2_lo, r2_hi) = self.bounds(a, b, c);
        let scale = a.abs() + (b * b + c * c).sqrt();
        if below(r2_hi - self.k.r2_min, scale) || above(r2_lo - self.k.r2_max, scale) || r2_hi <= 0.0 {
            return None;
        }
        let mut screen = Screen {
            range_min: self.k.r2_min > 0.0 && !above(r2_lo - self.k.r2_min, scale),
            range_max: !below(r2_hi - self.k.r2_max, scale),
            sides: [false; 2],
            elevation: false,
        };
        if let Some((sh, ch)) = self.k.azimuth {
            let (x, y) = (arc.coord(0), arc.coord(1));
            let mut missed = [false; 2];
            for (k, side) in [1.0, -1.0].into_iter().enumerate() {
                let f = |p: f64, q: f64| p * sh - side * q * ch;
                let (fa, fb, fc) = (f(x.0, y.0), f(x.1, y.1), f(x.2, y.2));
                let (lo, hi) = self.bounds(fa, fb, fc);
                let scale = fa.abs() + (fb * fb + fc * fc).sqrt();
                missed[k] = below(hi, scale);
                screen.sides[k] = !missed[k] && !above(lo, scale);
            }
            // Within π/2 the bound is both half-planes; beyond, either.
            let missed = if ch > 0.0 {
                missed[0] || missed[1]
            } else {
                missed[0] && missed[1]
            };
            if missed {
                return None;
            }
        }
        if let Some(se2) = self.k.elevation {
            let (za, zb, zc) = arc.coord(2);
            let (z_lo, z_hi) = self.bounds(za, zb, zc);
            let z2_max = z_lo.powi(2).max(z_hi.powi(2));
            let z2_min = if z_lo <= 0.0 && z_hi >= 0.0 {
                0.0
            } else {
                z_lo.powi(2).min(z_hi.powi(2))
            };
            let scale = r2_hi * se2 + z2_max;
            // r² sin² e − z² over the arc lies in [r²_lo sin² e − z²_max, r²_hi sin² e − z²_min].
            if below(r2_hi * se2 - z2_min, scale) {
                return None;
            }
            screen.elevation = !above(r2_lo * se2 - z2_max, scale);
        }
        Some(screen)
    }

    /// Returns the elevations (as `s`) where the arc may enter or leave the field of view, or
    /// cross sonar 2's `x = 0` or `y = 0` plane, with both ends; sorted, without repeats.
    fn cuts(&self, arc: &Arc, screen: Screen) -> List {
        let (lo, hi) = (-self.k.end, self.k.end);
        let mut cuts = List::default();
        cuts.push(lo);
        let (a, b, c) = arc.range_sq();
        if screen.range_min {
            quadratic_roots(quadratic(a - self.k.r2_min, b, c), lo, hi, &mut cuts);
        }
        if screen.range_max {
            quadratic_roots(quadratic(a - self.k.r2_max, b, c), lo, hi, &mut cuts);
        }
        let (x, y, z) = (arc.coord(0), arc.coord(1), arc.coord(2));
        let (qx, qy, qz) = (
            quadratic(x.0, x.1, x.2),
            quadratic(y.0, y.1, y.2),
            quadratic(z.0, z.1, z.2),
        );
        if self.k.behind {
            quadratic_roots(qx, lo, hi, &mut cuts);
            quadratic_roots(qy, lo, hi, &mut cuts);
        }
        if let Some((sh, ch)) = self.k.azimuth {
            for (k, side) in [1.0, -1.0].into_iter().enumerate() {
                if screen.sides[k] {
                    let f = |k: usize| qx[k] * sh - side * qy[k] * ch;
                    quadratic_roots([f(0), f(1), f(2)], lo, hi, &mut cuts);
                }
            }
        }
        if let (Some(se2), true) = (self.k.elevation, screen.elevation) {
            // (1 + s²)² (r² sin² e − z²) = sin² e (1 + s²) R(s) − Z(s)², R and Z the quadratics
            // of r² and z.
            let r = quadratic(a, b, c);
            let r1 = [r[0], r[1], r[0] + r[2], r[1], r[2]];
            let z2 = [
                qz[0] * qz[0],
                2.0 * qz[0] * qz[1],
                qz[1] * qz[1] + 2.0 * qz[0] * qz[2],
                2.0 * qz[1] * qz[2],
                qz[2] * qz[2],
            ];
            let g = std::array::from_fn(|k| se2 * r1[k] - z2[k]);
            // The height's zeros: a thin fan's bound turns near them.
            quartic_roots(&g, lo, hi, closed_form_roots(qz), &mut cuts);
        }
        cuts.push(hi);
        cuts.sort();
        cuts
    }

    /// Returns the stationary points (as `s`) of the range and, when `azimuths`, of the azimuth,
    /// over the whole arc.
    fn stationary(&self, arc: &Arc, azimuths: bool) -> List<4> {
        let (lo, hi) = (-self.k.end, self.k.end);
        let mut out = List::default();
        let mut add = |c: [f64; 3]| {
            // Unpolished: a stationary point off by δ moves its value by δ² only.
            for s in closed_form_roots(c) {
                if s > lo && s < hi {
                    out.push(s);
                }
            }
        };
        let (_, rb, rc) = arc.range_sq();
        // d|q|²/dφ = −b sin φ + c cos φ.
        add(quadratic(0.0, rc, -rb));
        if azimuths {
            let (u, w, t) = (arc.u, arc.w, arc.t);
            add(quadratic(
                u.x * w.y - u.y * w.x,
                t.x * w.y - t.y * w.x,
                t.y * u.x - t.x * u.y,
            ));
        }
        out.sort();
        out
    }

    /// Returns the metrics of `arc`, setting its cells in `occupancy` when one is given (else
    /// counting them in `cells` when kept).
    pub(crate) fn solve(&self, arc: &Arc, cells: &mut Cells, occupancy: Option<&mut Occupancy>) -> Metrics {
        let Some(screen) = self.screen(arc) else {
            return Metrics::exact(0.0, Extremes::default(), (0, 0.0));
        };
        let cuts = self.cuts(arc, screen);
        let beams = self.layout.beams() > 1;
        let want_cells = self.keep.cells || occupancy.is_some();
        let azimuths = self.keep.azimuths || (want_cells && beams);
        let turns = self.stationary(arc, azimuths);
        let mut extremes = Extremes::default();
        let mut length = 0.0;
        let mut run: Option<[f64; 2]> = None;
        cells.cells.clear();
        cells.bins.clear();
        for w in cuts.as_slice().windows(2) {
            let [a, b] = [w[0], w[1]];
            if b <= a || !self.piece_inside(arc, a, b) {
                continue;
            }
            // Touching visible pieces make one run of the arc: one `atan` for its length.
            run = match run {
                Some([s, e]) if e == a => Some([s, b]),
                Some([s, e]) => {
                    if self.keep.fraction {
                        length += arc_angle(s, e);
                    }
                    Some([a, b])
                }
                None => Some([a, b]),
            };
            let side = if azimuths && self.k.behind {
                Self::side_of(arc, a, b)
            } else {
                0.0
            };
            // The piece's ends and inner turning points (4 at most), in order: the range and the
            // azimuth are monotone between them.
            let mut at = List::<6>::default();
            at.push(a);
            for &s in turns.as_slice() {
                if s > a && s < b {
                    at.push(s);
                }
            }
            at.push(b);
            let mut prev: Option<(f64, usize, f64, f64)> = None;
            let (mut piece_lo, mut piece_hi) = (f64::INFINITY, f64::NEG_INFINITY);
            for &s in at.as_slice() {
                let q = point(arc, s);
                let r = q.length();
                extremes.add_range(r);
                piece_lo = piece_lo.min(r);
                piece_hi = piece_hi.max(r);
                let az = if azimuths { azimuth_of(q, side) } else { 0.0 };
                if self.keep.azimuths {
                    extremes.add_azimuth(az);
                }
                if want_cells && beams {
                    let i = self.layout.range_bin(r);
                    if let Some((s0, i0, r0, az0)) = prev {
                        self.staircase(arc, (s0, i0, r0, az0), (s, i, r, az), &mut |i, j| {
                            cells.cells.push((i, j));
                        });
                    }
                    prev = Some((s, i, r, az));
                }
            }
            if want_cells && !beams {
                let (i0, i1) = (self.layout.range_bin(piece_lo), self.layout.range_bin(piece_hi));
                cells.bins.push((i0, i1));
            }
        }
        let fraction = match run {
            None => return Metrics::exact(0.0, Extremes::default(), (0, 0.0)),
            // The whole arc: 1, not its rounding through atan.
            Some([s, e]) if (s == -self.k.end && e == self.k.end) || !self.keep.fraction => 1.0,
            // φ = 2 atan s: each run's length over the arc's 2H.
            Some([s, e]) => ((length + arc_angle(s, e)) / self.k.half).min(1.0),
        };
        let summary = self.count_cells(cells, occupancy, beams);
        Metrics::exact(fraction, extremes, summary)
    }

    /// Returns `(occupied, occupied_measure)` of the cells [`Solver::solve`] gathered in `cells`,
    /// setting them in `occupancy` when one is given (its reduce stage then counts them); `(0, 0)`
    /// when the cells are not kept.
    fn count_cells(&self, cells: &mut Cells, occupancy: Option<&mut Occupancy>, beams: bool) -> (u64, f64) {
        if let Some(occ) = occupancy {
            for &(i, j) in &cells.cells {
                occ.set(i, j);
            }
            for &(i0, i1) in &cells.bins {
                (i0..=i1).for_each(|i| occ.set(i, 0));
            }
            crate::projection::reference::reduce::reduce(self.layout, occ)
        } else if !self.keep.cells {
            (0, 0.0)
        } else if !beams {
            // One beam: the union of the pieces' bin intervals, summed bin by bin in order as the
            // reduce stage sums an occupancy buffer.
            let bins = &mut cells.bins;
            bins.sort_unstable();
            let (mut count, mut measure, mut next) = (0, 0.0, 0);
            for &(i0, i1) in bins.iter() {
                let from = i0.max(next);
                if self.bin_sums.is_some() {
                    count += (i1 + 1).saturating_sub(from);
                } else {
                    for i in from..=i1 {
                        count += 1;
                        measure += self.layout.pixel_measure(i, 0);
                    }
                }
                next = next.max(i1 + 1);
            }
            if let Some(sums) = &self.bin_sums {
                measure = sums[count];
            }
            (count as u64, measure)
        } else {
            let c = &mut cells.cells;
            c.sort_unstable();
            c.dedup();
            let measure = c
                .iter()
                .fold(0.0, |sum, &(i, j)| sum + self.layout.pixel_measure(i, j));
            (c.len() as u64, measure)
        }
    }

    /// Hands `cell` the cells of the arc between two points where its range and azimuth are both
    /// monotone: `(s, range bin, range, azimuth)` at each end.
    fn staircase(
        &self,
        arc: &Arc,
        (a, i0, _, az0): (f64, usize, f64, f64),
        (b, i1, _, az1): (f64, usize, f64, f64),
        cell: &mut dyn FnMut(usize, usize),
    ) {
        let layout = self.layout;
        let (j0, j1) = (layout.beam(az0), layout.beam(az1));
        if i0 == i1 || j0 == j1 {
            rectangle((i0, i1), (j0, j1), cell);
            return;
        }
        // Both change: the edges are crossed in the order of their roots, each the one root on
        // [a, b] of a quadratic (the range's, or the beam edge's plane in front of sonar 2).
        let (ra, rb, rc) = arc.range_sq();
        let (x, y) = (arc.coord(0), arc.coord(1));
        let mut events: Vec<(f64, bool)> = Vec::new();
        for i in i0.min(i1) + 1..=i0.max(i1) {
            let e2 = layout.range_edge(i).powi(2);
            let c = quadratic(ra - e2, rb, rc);
            let mut roots = List::<2>::default();
            quadratic_roots(c, a, b, &mut roots);
            let root = roots.as_slice().first().copied();
            events.push((root.unwrap_or_else(|| nearer_end(c, a, b)), true));
        }
        for j in j0.min(j1) + 1..=j0.max(j1) {
            let (se, ce) = self.edges[j];
            let f = |p: f64, q: f64| p * se - q * ce;
            let c = quadratic(f(x.0, y.0), f(x.1, y.1), f(x.2, y.2));
            let mut roots = List::<2>::default();
            quadratic_roots(c, a, b, &mut roots);
            // The plane holds the edge's direction and its opposite: the root in front.
            let root = roots.as_slice().iter().copied().find(|&s| {
                let q = point(arc, s);
                q.x * ce + q.y * se > 0.0
            });
            events.push((root.unwrap_or_else(|| nearer_end(c, a, b)), false));
        }
        walk((i0, i1), (j0, j1), &mut events, cell);
    }
}

/// Returns the projections of every item of `prepared` (an exact batch), on all cores, each with
/// its occupancy buffer for [`Output::WithOccupancy`]; `None` once `stop` is set (asked before
/// each item).
pub(crate) fn project(
    prepared: &PreparedBatch<'_>,
    output: Output,
    stop: Stop<'_>,
) -> Option<Vec<Projection>> {
    let batch = prepared.batch();
    let layout = prepared.layout();
    let solver = Solver::new(
        layout,
        batch.source.half_elevation(),
        Keep {
            fraction: true,
            azimuths: true,
            cells: true,
        },
    );
    (0..batch.items.len())
        .into_par_iter()
        .map_init(Cells::default, |cells, k| {
            if stop.is_set() {
                return None;
            }
            let item = &batch.items[k];
            let arc = Arc::new(
                item.measurement.range,
                item.measurement.azimuth.to_radians(),
                batch.source.half_elevation(),
                &item.pose,
            );
            let mut occupancy =
                (output == Output::WithOccupancy).then(|| Occupancy::new(layout.range_bins, layout.beams()));
            let metrics = solver.solve(&arc, cells, occupancy.as_mut());
            Some(Projection {
                metrics,
                occupancy: occupancy.map(|o| layout.to_data_order(o)),
                cells: None,
                local: Default::default(),
            })
        })
        .collect()
}

/// Writes the metric columns of poses `range` of `grid` (an exact sweep, prepared by
/// [`PreparedGrid`]) into `out`, each pose decoded from its index where it is solved; `None` once
/// `stop` is set (asked before each block of poses).
pub(crate) fn project_grid(
    prepared: &PreparedGrid<'_>,
    range: std::ops::Range<u64>,
    out: &mut MetricColumns,
    stop: Stop<'_>,
) -> Option<()> {
    let tables = GridTables::new(prepared.grid, &prepared.source);
    let half = prepared.source.half_elevation();
    solve_into(&prepared.layout, half, range, out, stop, |i| {
        let d = tables.decode(i);
        let (ca, sa) = d.azimuth;
        Arc {
            u: d.rotation * DVec3::new(d.range * ca, d.range * sa, 0.0),
            w: d.rotation * DVec3::new(0.0, 0.0, d.range),
            t: d.translation,
            half,
        }
    })
}

/// Writes the metric columns of pairs `range` of `prepared` (an exact sweep's pairs, prepared by
/// [`PreparedPairs`]) into `out`, each pair's arc made from its pose and feature as a batch item's
/// is ([`project`]), so the metrics are an item's bit for bit; `None` once `stop` is set (asked
/// before each block of pairs).
pub(crate) fn project_pairs(
    prepared: &PreparedPairs<'_>,
    range: std::ops::Range<u64>,
    out: &mut MetricColumns,
    stop: Stop<'_>,
) -> Option<()> {
    debug_assert!(prepared.exact, "pairs prepared for sampling");
    let half = prepared.source.half_elevation();
    solve_into(&prepared.layout, half, range, out, stop, |k| {
        // An imaging sonar 1's base azimuth is its measured azimuth in radians, an item's.
        let (pose, range, azimuth, _) = prepared.pose(usize::try_from(k).expect("a pair index in memory"));
        Arc::new(range, azimuth, half, pose)
    })
}

/// Writes the metric columns of poses `range` into `out`, solving the arc `arc(i)` of each pose
/// index `i` on all cores, a block of poses at a time; only the metrics `out` keeps are worked
/// out. `None` once `stop` is set (asked before each block).
fn solve_into(
    layout: &Layout,
    half: f64,
    range: std::ops::Range<u64>,
    out: &mut MetricColumns,
    stop: Stop<'_>,
    arc: impl Fn(u64) -> Arc + Sync,
) -> Option<()> {
    let count = usize::try_from(range.end - range.start).expect("a block of poses in memory");
    out.resize(count);
    let keep = Keep {
        fraction: out.keeps(crate::Metric::VisibleFraction),
        azimuths: out.keeps(crate::Metric::AzimuthMin) || out.keeps(crate::Metric::AzimuthMax),
        cells: out.keeps(crate::Metric::Occupied) || out.keeps(crate::Metric::OccupiedMeasure),
    };
    let solver = Solver::new(layout, half, keep);
    let blocks = out.slices(0..count).chunks(POSE_BLOCK);
    let done: Vec<bool> = blocks
        .into_par_iter()
        .enumerate()
        .map_init(Cells::default, |cells, (b, mut slots)| {
            if stop.is_set() {
                return false;
            }
            let first = range.start + (b * POSE_BLOCK) as u64;
            for k in 0..slots.len() {
                slots.set(k, &solver.solve(&arc(first + k as u64), cells, None));
            }
            true
        })
        .collect();
    done.into_iter().all(|d| d).then_some(())
}
