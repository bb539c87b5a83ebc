//! Every picture drawn for people follows one convention — near range at the bottom, port on the
//! left — checked on the decoded PNG's pixels (the light grey of the empty field of view marks
//! each panel; coloured pixels are masks and occupied bins): the mask picture (fan and raw
//! layout, sidescan strips) and the occupancy picture, drawn from hand-made occupancies at known
//! ranges and azimuths. The command line's pictures are checked the same way in
//! `crates/sonarproj-cli/tests/cli.rs` and `mask.rs`.

use sonarproj_testkit as common;

use common::Picture;
use sonarproj::Sonar;
use sonarproj::masks::Mask;
use sonarproj::occupancy::{Layout, Occupancy};
use sonarproj_apps::report::mask_image;
use sonarproj_apps::report::occupancy_image::{self, Orientation};

/// Returns a mask of `layout` holding a 3 × 3 block (three bins for an SSS, on one side of a
/// two-sided one) around range `r` (m) and azimuth `az` (deg), in the order of the sonar's data
/// as the engine hands masks out.
fn mask_at(layout: &Layout, r: f64, az: f64) -> Mask {
    let mut occupancy = Occupancy::new(layout.range_bins, layout.beams());
    let (i, j) = (layout.range_bin(r), layout.beam(az.to_radians()));
    let side = |j: usize| {
        if layout.two_sided() {
            j..=j
        } else {
            j.saturating_sub(1)..=(j + 1).min(layout.beams() - 1)
        }
    };
    for i in i - 1..=i + 1 {
        for j in side(j) {
            occupancy.set(i, j);
        }
    }
    Mask {
        occupancy: layout.to_data_order(occupancy),
        counts: None,
        radius: 0.0,
        noise_radius: 0.0,
        cells: 1,
    }
}

/// Writes the picture of `masks` and reads it back.
fn drawn(layout: &Layout, masks: &[Mask]) -> Picture {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("m.png");
    let labels: Vec<String> = (1..=masks.len()).map(|k| k.to_string()).collect();
    mask_image::write_png(&path, layout, masks, ("test", &labels), None).unwrap();
    Picture::read(&path)
}

#[test]
fn fls_picture_puts_port_left_and_near_range_low_in_fan_and_raw_panel() {
    let layout = Layout::of(&Sonar::preset("holoocean-imaging").unwrap());
    // +azimuth is +y, port; 2 m of 10 is near, 8 m far.
    for (r, az, port, near) in [
        (2.0, 30.0, true, true),
        (8.0, -30.0, false, false),
        (8.0, 40.0, true, false),
    ] {
        let pic = drawn(&layout, &[mask_at(&layout, r, az)]);
        let panels = pic.panels();
        assert_eq!(panels.len(), 2, "the fan and the raw layout: {panels:?}");
        for (p, name) in panels.iter().zip(["fan", "raw layout"]) {
            pic.assert_side(*p, Some(port), near, &format!("{name}, feature at {r} m, {az}°"));
        }
    }
}

#[test]
fn sss_picture_puts_near_range_low_in_every_strip() {
    let layout = Layout::of(&Sonar::preset("paper-sss").unwrap());
    for (r, near) in [(5.0, true), (28.0, false)] {
        let pic = drawn(&layout, &[mask_at(&layout, r, 0.0)]);
        let panels = pic.panels();
        // Whole range: the feature's strip and the union; then the same zoomed.
        assert_eq!(panels.len(), 4, "{panels:?}");
        for p in &panels[..2] {
            pic.assert_side(*p, None, near, &format!("strip, feature at {r} m"));
        }
    }
}

#[test]
fn two_sided_sidescan_picture_puts_port_strips_left_and_near_range_low() {
    let layout = Layout::of(&Sonar::preset("holoocean-sidescan").unwrap());
    for (r, az, port, near) in [(5.0, 40.0, true, true), (30.0, -40.0, false, false)] {
        let pic = drawn(&layout, &[mask_at(&layout, r, az)]);
        let panels = pic.panels();
        // Whole range: the feature's port strip and the port union, then the same to
        // starboard; then all four zoomed.
        assert_eq!(panels.len(), 8, "{panels:?}");
        let (seen, empty) = if port { (0..2, 2..4) } else { (2..4, 0..2) };
        for p in &panels[seen] {
            pic.assert_side(*p, None, near, &format!("strip, feature at {r} m, {az}°"));
        }
        for p in &panels[empty] {
            assert!(
                pic.coloured(*p).is_empty(),
                "the other side's strip {p:?} is coloured"
            );
        }
    }
    // The occupancy picture: a port strip left of a starboard strip.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("o.png");
    let occ = mask_at(&layout, 20.0, -60.0).occupancy;
    occupancy_image::write(&path, &occ, &layout, "test", Orientation::default()).unwrap();
    let pic = Picture::read(&path);
    let panels = pic.panels();
    assert!(panels.len() >= 2, "{panels:?}");
    assert!(
        pic.coloured(panels[0]).is_empty(),
        "port strip coloured for a starboard point"
    );
    pic.assert_side(panels[1], None, false, "starboard strip, 20 m of 35");
}

#[test]
fn sss_picture_is_not_mostly_blank() {
    let layout = Layout::of(&Sonar::preset("paper-sss").unwrap());
    let masks = [mask_at(&layout, 5.0, 0.0), mask_at(&layout, 20.0, 0.0)];
    let pic = drawn(&layout, &masks);
    let panels = pic.panels();
    let area: usize = panels.iter().map(|p| (p.x1 - p.x0 + 1) * (p.y1 - p.y0 + 1)).sum();
    assert!(
        area * 5 >= pic.w * pic.h,
        "the strips take {area} of {} pixels",
        pic.w * pic.h
    );
}

/// Returns the occupancy of `layout` with the pixel at range `r` (m), azimuth `az` (deg).
fn one_pixel(layout: &Layout, r: f64, az: f64) -> Occupancy {
    let mut occ = Occupancy::new(layout.range_bins, layout.beams());
    occ.set(layout.range_bin(r), layout.beam(az.to_radians()));
    occ
}

#[test]
fn png_puts_port_left_and_near_range_low_whatever_the_npy_orientation() {
    let layout = Layout::of(&Sonar::preset("paper-fls").unwrap());
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("o.png");
    for (r, az, port, near) in [(2.0, 20.0, true, true), (8.0, -20.0, false, false)] {
        for flip in [false, true] {
            let o = Orientation {
                flip_range: flip,
                flip_beams: flip,
            };
            occupancy_image::write(&path, &one_pixel(&layout, r, az), &layout, "test", o).unwrap();
            let pic = Picture::read(&path);
            let panels = pic.panels();
            assert_eq!(panels.len(), 1, "{panels:?}");
            pic.assert_side(
                panels[0],
                Some(port),
                near,
                &format!("{r} m, {az}°, flips {flip}"),
            );
        }
    }
}

#[test]
fn sss_png_is_a_vertical_strip_with_near_range_low() {
    let layout = Layout::of(&Sonar::preset("paper-sss").unwrap());
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("o.png");
    for (r, near) in [(3.0, true), (27.0, false)] {
        occupancy_image::write(
            &path,
            &one_pixel(&layout, r, 0.0),
            &layout,
            "test",
            Orientation::default(),
        )
        .unwrap();
        let pic = Picture::read(&path);
        let panels = pic.panels();
        assert!(!panels.is_empty());
        let p = panels[0];
        assert!(p.y1 - p.y0 > 3 * (p.x1 - p.x0), "a vertical strip: {p:?}");
        pic.assert_side(p, None, near, &format!("{r} m"));
    }
}
