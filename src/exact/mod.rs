//! Exact geometry: where an imaging-sonar (FLS) feature's arc lies in sonar 2, without samples.
//!
//! Sonar 1 measures a feature at range `r` and azimuth `θ`; its elevation `φ` is lost. In sonar 2
//! the candidate points form the circle arc
//!
//! ```text
//! q(φ) = u cos φ + w sin φ + t,   u = R·r(cos θ, sin θ, 0),   w = R·r(0, 0, 1),
//! ```
//!
//! with `φ` over sonar 1's elevation aperture `[−H, H]` and `(R, t)` the pose. Each of sonar 2's
//! bounds is a simple function of `φ`:
//!
//! - the squared range `|q|² = |u|² + |t|² + 2 t·u cos φ + 2 t·w sin φ` is first-degree
//!   trigonometric, so the range bounds are crossed where a closed form says;
//! - the azimuth bound `x sin h − |y| cos h ≥ 0` is first-degree on each side of `y = 0`;
//! - the elevation bound `(x² + y²) sin² e − z² cos² e ≥ 0` is second-degree. With
//!   `s = tan(φ/2)` it becomes a polynomial of degree 4, whose roots are isolated exactly
//!   (`roots.rs`).
//!
//! All those crossings cut the arc into pieces. On each piece every bound keeps one side, so the
//! piece is visible or not as a whole: its middle point is tested with the definition
//! ([`Layout::inside`]). The visible pieces give the metrics:
//!
//! - the visible fraction is their total length over `2H` (the arc's radius is constant);
//! - the range extremes lie at piece ends or where `d|q|²/dφ = 0` (closed form);
//! - the azimuth extremes lie at piece ends or where `x y' − y x' = 0`. That expression is
//!   first-degree too: `(u_x w_y − u_y w_x) + (t_x w_y − t_y w_x) cos φ + (t_y u_x − t_x u_y) sin φ`;
//! - the cells (range bin, beam) are those the arc passes through. Between its range and azimuth
//!   stationary points both coordinates are monotone, so the arc walks a staircase of cells,
//!   crossing bin and beam edges in the order of their `φ`.
//!
//! What "exact" leaves out: a single point where the arc only touches a bound or an edge (a
//! tangency). It has no length and moves no extreme, so it decides no metric except, at most,
//! one cell touched at that point alone.

mod fast;
mod fast_roots;
mod roots;

pub(crate) use fast::{SolverConstants, project as project_fast, project_grid, project_pairs};

use std::f64::consts::{FRAC_PI_2, PI};

use glam::DVec3;

use rayon::prelude::*;

use crate::geometry::pose::{RelativePose, cart_to_sph};
use crate::metrics::{Extremes, Metrics};
use crate::occupancy::{Layout, Occupancy};
use crate::projection::{Output, PreparedBatch, Projection};
use crate::stream::Stop;
use roots::{List, Poly, monotone_root, poly_roots, trig_roots};

/// The arc of candidate points of one FLS measurement, in sonar 2's frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Arc {
    /// `R·r(cos θ, sin θ, 0)`: the point at elevation 0, less `t`.
    u: DVec3,
    /// `R·r(0, 0, 1)`.
    w: DVec3,
    /// The translation.
    t: DVec3,
    /// Half sonar 1's elevation aperture `H` (rad): the arc runs over `[−H, H]`.
    half: f64,
}

/// What of an arc sonar 2 sees.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct VisibleArc {
    /// The visible pieces as elevation intervals `[a, b]` (rad, in sonar 1), in increasing order.
    /// Neighbouring pieces may touch: pieces are also cut where the point crosses sonar 2's
    /// `x` or `y` axis plane, so that the azimuth is continuous along each.
    pub pieces: Vec<[f64; 2]>,
    /// Range and azimuth extremes (m, rad) over the visible pieces; infinite when none.
    pub extremes: Extremes,
    /// The visible length over the arc's whole length, in `[0, 1]`.
    pub visible_fraction: f64,
}

impl Arc {
    /// Returns the arc of a feature at `range` (m) and `azimuth` (rad) of sonar 1, whose half
    /// elevation aperture is `half_elevation` (rad), moved into sonar 2 by `pose`.
    #[must_use]
    pub fn new(range: f64, azimuth: f64, half_elevation: f64, pose: &RelativePose) -> Arc {
        let r = pose.rotation;
        Arc {
            u: r * DVec3::new(range * azimuth.cos(), range * azimuth.sin(), 0.0),
            w: r * DVec3::new(0.0, 0.0, range),
            t: pose.translation,
            half: half_elevation,
        }
    }

    /// Returns the point at elevation `phi` (rad), in sonar 2.
    #[must_use]
    pub fn at(&self, phi: f64) -> DVec3 {
        self.u * phi.cos() + self.w * phi.sin() + self.t
    }

    /// Returns the half elevation aperture `H` (rad).
    #[must_use]
    pub fn half(&self) -> f64 {
        self.half
    }

    /// `|q|² = a + b cos φ + c sin φ`, as `(a, b, c)`.
    fn range_sq(&self) -> (f64, f64, f64) {
        (
            self.u.length_squared() + self.t.length_squared(),
            2.0 * self.t.dot(self.u),
            2.0 * self.t.dot(self.w),
        )
    }

    /// Coordinate `k` as `(constant, cos φ, sin φ)` terms.
    fn coord(&self, k: usize) -> (f64, f64, f64) {
        (self.t[k], self.u[k], self.w[k])
    }

    /// Coordinate `k` times `1 + s²`, as a polynomial in `s = tan(φ/2)`:
    /// `(t + u) + 2w s + (t − u) s²` (from `cos φ = (1 − s²)/(1 + s²)`, `sin φ = 2s/(1 + s²)`).
    fn coord_poly(&self, k: usize) -> Poly {
        let (t, u, w) = self.coord(k);
        Poly([t + u, 2.0 * w, t - u, 0.0, 0.0])
    }
}

/// Returns the elevations (rad) in `[−H, H]` where the arc may enter or leave sonar 2's field of
/// view, or cross its `x = 0` or `y = 0` plane, with both ends; sorted, without repeats.
fn cuts(arc: &Arc, layout: &Layout) -> List {
    let (lo, hi) = (-arc.half, arc.half);
    let mut cuts = List::default();
    cuts.push(lo);
    let (a, b, c) = arc.range_sq();
    if layout.range_min > 0.0 {
        trig_roots(a - layout.range_min.powi(2), b, c, lo, hi, &mut cuts);
    }
    trig_roots(a - layout.range_max.powi(2), b, c, lo, hi, &mut cuts);
    for k in [0, 1] {
        let (c0, cu, cw) = arc.coord(k);
        trig_roots(c0, cu, cw, lo, hi, &mut cuts);
    }
    if layout.half_azimuth < PI {
        let (sh, ch) = layout.half_azimuth.sin_cos();
        let (x, y) = (arc.coord(0), arc.coord(1));
        for side in [1.0, -1.0] {
            // x sin h − side · y cos h: the azimuth bound on the side where side · y ≥ 0.
            let f = |p: f64, q: f64| p * sh - side * q * ch;
            trig_roots(f(x.0, y.0), f(x.1, y.1), f(x.2, y.2), lo, hi, &mut cuts);
        }
    }
    if layout.half_elevation < FRAC_PI_2 {
        let (se, ce) = layout.half_elevation.sin_cos();
        let (px, py, pz) = (arc.coord_poly(0), arc.coord_poly(1), arc.coord_poly(2));
        let rho2 = px.times(&px).plus_scaled(1.0, &py.times(&py));
        let g = Poly::default()
            .plus_scaled(se * se, &rho2)
            .plus_scaled(-(ce * ce), &pz.times(&pz));
        let mut s = List::default();
        poly_roots(&g, (lo / 2.0).tan(), (hi / 2.0).tan(), &mut s);
        for &s in s.as_slice() {
            cuts.push((2.0 * s.atan()).clamp(lo, hi));
        }
    }
    cuts.push(hi);
    cuts.sort();
    cuts
}

/// Returns the azimuth (rad) of the arc at `phi` as seen from a piece whose `y` has the sign of
/// `side`: a point on the `y = 0` plane behind sonar 2 reads `+π` from `y > 0` and `−π` from
/// `y < 0`, the limits along the piece.
fn azimuth_from(arc: &Arc, phi: f64, side: f64) -> f64 {
    azimuth_of(arc.at(phi), side)
}

/// Returns the azimuth (rad) of the arc's point `q` as [`azimuth_from`] reads it from a piece
/// whose `y` has the sign of `side`.
fn azimuth_of(q: DVec3, side: f64) -> f64 {
    // In front of sonar 2 (x ≥ 0) the azimuth is continuous across y = 0: nothing to force.
    let y = if q.x >= 0.0 || side == 0.0 || q.y * side > 0.0 {
        q.y
    } else {
        0.0f64.copysign(side)
    };
    y.atan2(q.x)
}

/// Returns the sign of `y` along the piece `[a, b]`, where it does not change sign (pieces are
/// cut where it does) but may touch 0: the sign at whichever of three inner points lies
/// farthest from `y = 0`.
fn side_of(arc: &Arc, a: f64, b: f64) -> f64 {
    farthest_sign(VOTES.map(|f| arc.at(a + f * (b - a)).y))
}

/// Where in a piece `[a, b]` (as fractions of it) its verdicts are taken: the middle, then two
/// points that no symmetry of the piece maps onto the middle or each other.
const VOTES: [f64; 3] = [0.5, 0.309_017, 0.723_607];

/// Returns the sign of whichever of `y` lies farthest from 0 (+1 when all are 0: the signum of
/// +0).
fn farthest_sign(y: [f64; 3]) -> f64 {
    let far = y
        .into_iter()
        .fold(0.0f64, |m, v| if v.abs() > m.abs() { v } else { m });
    far.signum()
}

/// Returns the piece's verdict from `first`, the verdict at its middle, and `inside` at the other
/// points of [`VOTES`]: two agreeing votes settle it, a third breaks a tie.
fn by_vote(first: bool, inside: impl Fn(f64) -> bool) -> bool {
    match (first, inside(VOTES[1])) {
        (x, y) if x == y => x,
        _ => inside(VOTES[2]),
    }
}

/// Returns the elevations in `[a, b]` where the range or the azimuth is stationary.
fn stationary(arc: &Arc, a: f64, b: f64, out: &mut List) {
    let (_, rb, rc) = arc.range_sq();
    // d|q|²/dφ = −b sin φ + c cos φ.
    trig_roots(0.0, rc, -rb, a, b, out);
    let (u, w, t) = (arc.u, arc.w, arc.t);
    trig_roots(
        u.x * w.y - u.y * w.x,
        t.x * w.y - t.y * w.x,
        t.y * u.x - t.x * u.y,
        a,
        b,
        out,
    );
}

/// Returns whether the piece `[a, b]` between two cuts is in view. No bound is crossed inside
/// it, so the verdict is the same at every point but those where the arc only touches a bound.
/// Such a point may sit anywhere, even at the middle (a symmetric pose puts it there), so three
/// points vote: a touching point is isolated and can spoil one vote at most.
fn piece_inside(arc: &Arc, layout: &Layout, a: f64, b: f64) -> bool {
    let inside = |f: f64| {
        let (r, az, el) = cart_to_sph(arc.at(a + f * (b - a)));
        layout.inside(r, az, el)
    };
    by_vote(inside(VOTES[0]), inside)
}

/// Returns what of `arc` lies in `layout`'s field of view.
#[must_use]
pub fn visible_arc(arc: &Arc, layout: &Layout) -> VisibleArc {
    let mut out = VisibleArc {
        extremes: Extremes::default(),
        ..VisibleArc::default()
    };
    let mut length = 0.0;
    for w in cuts(arc, layout).as_slice().windows(2) {
        let [a, b] = [w[0], w[1]];
        if !piece_inside(arc, layout, a, b) {
            continue;
        }
        out.pieces.push([a, b]);
        length += b - a;
        let side = side_of(arc, a, b);
        let mut inner = List::default();
        inner.push(a);
        inner.push(b);
        stationary(arc, a, b, &mut inner);
        for &phi in inner.as_slice() {
            out.extremes
                .add(arc.at(phi).length(), azimuth_from(arc, phi, side));
        }
    }
    out.visible_fraction = (length / (2.0 * arc.half)).min(1.0);
    out
}

/// Sets in `occupancy` every cell (range bin, beam) of `layout` that the visible pieces of `arc`
/// pass through (`visible`: [`visible_arc`]'s answer for the same arc and layout).
pub fn visible_cells(arc: &Arc, layout: &Layout, visible: &VisibleArc, occupancy: &mut Occupancy) {
    each_cell(arc, layout, visible, &mut |i, j| occupancy.set(i, j));
}

/// Hands `cell` every cell (range bin, beam) the visible pieces pass through, some more than
/// once (where the arc turns back, or pieces meet).
fn each_cell(arc: &Arc, layout: &Layout, visible: &VisibleArc, cell: &mut dyn FnMut(usize, usize)) {
    for &[a, b] in &visible.pieces {
        let side = side_of(arc, a, b);
        let mut cut = List::default();
        cut.push(a);
        stationary(arc, a, b, &mut cut);
        cut.push(b);
        cut.sort();
        for w in cut.as_slice().windows(2) {
            if w[1] > w[0] {
                staircase(arc, layout, side, w[0], w[1], cell);
            }
        }
    }
}

/// Sets the cells of the arc over `[a, b]`, where its range and azimuth are both monotone.
fn staircase(arc: &Arc, layout: &Layout, side: f64, a: f64, b: f64, cell: &mut dyn FnMut(usize, usize)) {
    let range = |phi: f64| arc.at(phi).length();
    let azimuth = |phi: f64| azimuth_from(arc, phi, side);
    let (i0, i1) = (layout.range_bin(range(a)), layout.range_bin(range(b)));
    let (j0, j1) = (layout.beam(azimuth(a)), layout.beam(azimuth(b)));
    if i0 == i1 || j0 == j1 {
        rectangle((i0, i1), (j0, j1), cell);
        return;
    }
    // Both change: the order in which bin and beam edges are crossed decides the cells. Each
    // crossing is the one root of a monotone function on [a, b].
    let crossing = |f: &dyn Fn(f64) -> f64| monotone_root(f, a, b).unwrap_or(a);
    let mut events: Vec<(f64, bool)> = Vec::new();
    for i in i0.min(i1) + 1..=i0.max(i1) {
        let edge = layout.range_edge(i);
        events.push((crossing(&|phi| range(phi) - edge), true));
    }
    for j in j0.min(j1) + 1..=j0.max(j1) {
        let edge = layout.beam_edges[j];
        events.push((crossing(&|phi| azimuth(phi) - edge), false));
    }
    walk((i0, i1), (j0, j1), &mut events, cell);
}

/// Hands `cell` every cell of the rectangle of range bins `i0..=i1` and beams `j0..=j1` (either
/// order): the cells of a stretch where one of the two does not change.
fn rectangle((i0, i1): (usize, usize), (j0, j1): (usize, usize), cell: &mut dyn FnMut(usize, usize)) {
    for i in i0.min(i1)..=i0.max(i1) {
        for j in j0.min(j1)..=j0.max(j1) {
            cell(i, j);
        }
    }
}

/// Hands `cell` the cells a stretch walks from `(i0, j0)` to `(i1, j1)`, given its crossings of
/// bin edges (`true`) and beam edges (`false`) at their positions along the arc, in any order.
fn walk(
    (i0, i1): (usize, usize),
    (j0, j1): (usize, usize),
    events: &mut [(f64, bool)],
    cell: &mut dyn FnMut(usize, usize),
) {
    events.sort_by(|x, y| x.0.total_cmp(&y.0));
    let (mut i, mut j) = (i0, j0);
    cell(i, j);
    for &(_, is_range) in events.iter() {
        if is_range {
            i = if i1 > i0 { i + 1 } else { i - 1 };
        } else {
            j = if j1 > j0 { j + 1 } else { j - 1 };
        }
        cell(i, j);
    }
}

/// Returns the projections of every item of `prepared` (an exact batch: [`PreparedBatch::is_exact`]),
/// on all cores when `all_cores`, each with its occupancy buffer for [`Output::WithOccupancy`];
/// `None` once `stop` is set (asked before each item).
pub(crate) fn project(
    prepared: &PreparedBatch<'_>,
    output: Output,
    all_cores: bool,
    stop: Stop<'_>,
) -> Option<Vec<Projection>> {
    let one = |cells: &mut Vec<(usize, usize)>, k: usize| {
        (!stop.is_set()).then(|| project_item(prepared, k, output, cells))
    };
    let n = prepared.batch().items.len();
    if all_cores {
        (0..n).into_par_iter().map_init(Vec::new, one).collect()
    } else {
        let mut cells = Vec::new();
        (0..n).map(|k| one(&mut cells, k)).collect()
    }
}

/// Returns item `k`'s projection (`cells`: room for its cells, reused between items).
fn project_item(
    prepared: &PreparedBatch<'_>,
    k: usize,
    output: Output,
    cells: &mut Vec<(usize, usize)>,
) -> Projection {
    let batch = prepared.batch();
    let item = &batch.items[k];
    let layout = prepared.layout();
    let arc = Arc::new(
        item.measurement.range,
        item.measurement.azimuth.to_radians(),
        batch.source.half_elevation(),
        &item.pose,
    );
    let seen = visible_arc(&arc, layout);
    let (summary, occupancy) = if output == Output::WithOccupancy {
        let mut occupancy = Occupancy::new(layout.range_bins, layout.beams());
        visible_cells(&arc, layout, &seen, &mut occupancy);
        let summary = crate::projection::reference::reduce::reduce(layout, &occupancy);
        (summary, Some(layout.to_data_order(occupancy)))
    } else {
        (reduce_cells(&arc, layout, &seen, cells), None)
    };
    Projection {
        metrics: Metrics::exact(seen.visible_fraction, seen.extremes, summary),
        occupancy,
        cells: None,
        local: Default::default(),
    }
}

/// Returns `(occupied, occupied_measure)` of the visible arc's cells without an occupancy
/// buffer: the cells sorted as the buffer orders its pixels, so the sum is the reduce stage's to
/// the last bit.
fn reduce_cells(
    arc: &Arc,
    layout: &Layout,
    seen: &VisibleArc,
    cells: &mut Vec<(usize, usize)>,
) -> (u64, f64) {
    cells.clear();
    each_cell(arc, layout, seen, &mut |i, j| cells.push((i, j)));
    cells.sort_unstable();
    cells.dedup();
    let measure = cells
        .iter()
        .fold(0.0, |sum, &(i, j)| sum + layout.pixel_measure(i, j));
    (cells.len() as u64, measure)
}
