//! Drawing one pose; the fast path's twin of `shaders/splat.wgsl`. Its blocks are culled eight at a
//! time, and each visited block goes through the lane stage. The visible samples' pixels are set a
//! word at a time. The exact azimuth extremes are taken only for the samples that may be one. A
//! sidescan target sampled finer than its bins is drawn by runs.

use glam::DVec3;

use super::lanes::{draw_lanes, draw_lanes_runs};
use super::scratch::{Scratch, Seen, set};
use super::tables::{Directions, ball_sides, pose_columns};
use super::{BALLS, Geometry, LANES, PoseArgs};
use crate::clip::{ATAN_ERROR, F64_WIDEN, KEY_TOLERANCE};
use crate::metrics::Extremes;

impl Scratch {
    /// Draws one pose, and returns the visible count and the extremes, with the pixels set in the
    /// occupancy buffer. `m` is `M = R · Rz(base azimuth) · range`, `t` the translation and `slack`
    /// the culling slack. `BEAMS` says sonar 2 has beams to find (an FLS, or a two-sided sidescan).
    /// Without, a sidescan's range bins may be drawn by runs. The azimuths' extremes are left empty
    /// (infinite) unless `azimuths`.
    #[inline(always)]
    pub(super) fn draw_pose<const BEAMS: bool>(
        &mut self,
        geo: &Geometry<'_>,
        dirs: &Directions,
        (m, t, range, slack): PoseArgs,
        azimuths: bool,
    ) -> (u64, Extremes) {
        if !BEAMS && range * dirs.max_step * (1.0 + F64_WIDEN) + slack < geo.layout.range_bin_width {
            return self.draw_runs(geo, dirs, (m, t, range, slack), azimuths);
        }
        let Scratch {
            occ,
            summary,
            seen,
            lanes,
            running,
            cells,
            cell_summary,
            ..
        } = self;
        let grid = BEAMS && geo.cells.is_some();
        // The last cell set: neighbouring samples mostly share one.
        let mut last_cell = usize::MAX;
        // Room for every sample of the plan, made before the pose loop. A push that may grow the
        // vector would be a call there, around which the loop's constants leave registers.
        if seen.len() < dirs.units.len() {
            seen.resize(dirs.units.len(), Seen::default());
        }
        let mut n_seen = 0;
        running.start_pose();
        let columns = pose_columns(m, t);
        #[expect(clippy::cast_sign_loss, reason = "beams are at least 1")]
        let beams = geo.beams as usize;
        let mut beam = 0;
        let (mut word, mut bits) = (0, 0);
        let (mut outside, mut inside) = (0, 0);
        for (b, units) in dirs.lanes.iter().enumerate() {
            if b % BALLS == 0 {
                (outside, inside) = ball_sides(geo, &columns, &dirs.ball_chunks[b / BALLS], range, slack);
            }
            if outside & (1 << (b % BALLS)) != 0 {
                continue;
            }
            let inside = inside & (1 << (b % BALLS)) != 0;
            let mut visible = draw_lanes::<BEAMS>(geo, &columns, units, inside, lanes, running);
            visible &= (1 << units.len) - 1;
            while visible != 0 {
                let k = visible.trailing_zeros() as usize;
                visible &= visible - 1;
                #[expect(clippy::cast_sign_loss, reason = "pixels are clamped to 0..")]
                let mut pixel = lanes.pixel[k] as usize;
                let (x, y) = (lanes.x[k], lanes.y[k]);
                if BEAMS && !lanes.sure[k] {
                    // The edge tests, walked from the guess (uniform beams) or the previous
                    // sample's beam, else from an exact atan2.
                    let p = DVec3::new(x, y, lanes.z[k]);
                    let (i, guess) = (pixel / beams, pixel % beams);
                    let from = if geo.inv_beam_width.is_some() { guess } else { beam };
                    beam = geo.beam_near(p, from).unwrap_or_else(|| geo.beam(p, y.atan2(x)));
                    pixel = i * beams + beam;
                }
                // Bits of one word gather in a register while the samples stay in it.
                if pixel / 32 != word {
                    set(occ, summary, word, bits);
                    (word, bits) = (pixel / 32, 0);
                }
                bits |= 1 << (pixel % 32);
                if grid {
                    #[expect(clippy::cast_sign_loss, reason = "cells are clamped to 0..")]
                    let c = lanes.cell[k] as usize;
                    if c != last_cell {
                        set(cells, cell_summary, c / 32, 1 << (c % 32));
                        last_cell = c;
                    }
                }
                seen[n_seen] = Seen {
                    x,
                    y,
                    key: lanes.key[k],
                };
                n_seen += 1;
            }
        }
        set(occ, summary, word, bits);
        // The extremes: ranges folded over the lanes, and exact azimuths for the samples that may
        // be an extreme, in sample order. The fold then equals the fold over every sample, since
        // the others' azimuths are strictly inside.
        let (range_min, range_max, key_min, key_max) = running.extremes();
        let mut extremes = Extremes {
            range_min,
            range_max,
            ..Extremes::default()
        };
        let (low, high) = if BEAMS {
            // Approximate azimuths: an exact azimuth lies within ATAN_ERROR of its guess.
            (key_min + 3.0 * ATAN_ERROR, key_max - 3.0 * ATAN_ERROR)
        } else {
            // y / x orders azimuths in (−90°, 90°), far beyond atan2's rounding.
            (
                key_min + KEY_TOLERANCE * key_min.abs(),
                key_max - KEY_TOLERANCE * key_max.abs(),
            )
        };
        for s in &seen[..if azimuths { n_seen } else { 0 }] {
            if !(s.key > low && s.key < high) {
                extremes.add_azimuth(s.y.atan2(s.x));
            }
        }
        (n_seen as u64, extremes)
    }

    /// Draws one pose into an SSS whose range bins are wider than the step from any sample of the
    /// plan to the next. The results are those of [`Scratch::draw_pose`].
    /// 1. Moved by the pose, a step keeps its length `range · |u' − u|`. The caller checks it
    ///    against the bin width, with the culling slack as margin.
    /// 2. So two consecutive samples' ranges differ by less than a bin, and their bins are equal or
    ///    adjacent.
    /// 3. So a run of consecutive visible samples covers exactly the bins from its nearest sample's
    ///    to its farthest's.
    ///
    /// When the visible samples form one run (an arc crossing the sonar's sheet once), the bins are
    /// those of the two ends of the range. Otherwise each visible sample's bin is taken.
    #[inline(always)]
    pub(super) fn draw_runs(
        &mut self,
        geo: &Geometry<'_>,
        dirs: &Directions,
        (m, t, range, slack): PoseArgs,
        azimuths: bool,
    ) -> (u64, Extremes) {
        let Scratch {
            occ,
            summary,
            running,
            runs,
            span,
            ..
        } = self;
        let blocks = dirs.lanes.len();
        if runs.visible.len() < blocks {
            for v in [&mut runs.x, &mut runs.y, &mut runs.key, &mut runs.r2] {
                v.resize(blocks * LANES, 0.0);
            }
            runs.visible.resize(blocks, 0);
        }
        running.start_pose();
        let columns = pose_columns(m, t);
        let (mut outside, mut inside) = (0, 0);
        let (mut n_seen, mut first, mut last) = (0, usize::MAX, 0);
        for (b, units) in dirs.lanes.iter().enumerate() {
            if b % BALLS == 0 {
                (outside, inside) = ball_sides(geo, &columns, &dirs.ball_chunks[b / BALLS], range, slack);
            }
            if outside & (1 << (b % BALLS)) != 0 {
                runs.visible[b] = 0;
                continue;
            }
            let inside = inside & (1 << (b % BALLS)) != 0;
            let visible =
                draw_lanes_runs(geo, &columns, units, inside, runs, b, running) & ((1 << units.len) - 1);
            runs.visible[b] = visible;
            n_seen += visible.count_ones() as usize;
            if visible != 0 {
                first = first.min(b * LANES + visible.trailing_zeros() as usize);
                last = b * LANES + 31 - visible.leading_zeros() as usize;
            }
        }
        if n_seen == 0 {
            return (0, Extremes::default());
        }
        let (r2_min, r2_max, key_min, key_max) = running.extremes();
        let mut extremes = Extremes {
            range_min: r2_min.sqrt(),
            range_max: r2_max.sqrt(),
            ..Extremes::default()
        };
        if last - first + 1 == n_seen {
            // One run: every bin from the nearest sample's to the farthest's.
            let lo = geo.range_bin(extremes.range_min, r2_min);
            let hi = geo.range_bin(extremes.range_max, r2_max);
            #[expect(clippy::cast_sign_loss, reason = "bins are clamped to 0..")]
            let bins = (lo as usize, hi as usize);
            *span = Some(bins);
        } else {
            let (mut word, mut bits) = (usize::MAX, 0);
            for (b, &visible) in runs.visible[..blocks].iter().enumerate() {
                let mut visible = visible;
                while visible != 0 {
                    let k = b * LANES + visible.trailing_zeros() as usize;
                    visible &= visible - 1;
                    let r2 = runs.r2[k];
                    #[expect(clippy::cast_sign_loss, reason = "bins are clamped to 0..")]
                    let pixel = geo.range_bin(r2.sqrt(), r2) as usize;
                    if pixel / 32 != word {
                        if word != usize::MAX {
                            set(occ, summary, word, bits);
                        }
                        (word, bits) = (pixel / 32, 0);
                    }
                    bits |= 1 << (pixel % 32);
                }
            }
            set(occ, summary, word, bits);
        }
        // Exact azimuths for the samples that may be an extreme, in sample order.
        let (low, high) = (
            key_min + KEY_TOLERANCE * key_min.abs(),
            key_max - KEY_TOLERANCE * key_max.abs(),
        );
        for (b, &visible) in runs.visible[..if azimuths { blocks } else { 0 }]
            .iter()
            .enumerate()
        {
            if visible == 0 {
                continue;
            }
            let keys = &runs.key[b * LANES..][..LANES];
            let mut near = 0u32;
            for (k, &key) in keys.iter().enumerate() {
                near |= u32::from(!((key > low) & (key < high))) << k;
            }
            near &= visible;
            while near != 0 {
                let k = b * LANES + near.trailing_zeros() as usize;
                near &= near - 1;
                extremes.add_azimuth(runs.y[k].atan2(runs.x[k]));
            }
        }
        (n_seen as u64, extremes)
    }
}
