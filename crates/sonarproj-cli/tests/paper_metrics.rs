//! The paper's numbers as the authors computed them: `projection_area` against an independent
//! implementation of the authors' grid (their published `example_ss2fl.py` set-up, written here
//! from its description, not from sonarproj's code), and poses given as quaternions or matrices
//! giving the rows of roll, pitch, yaw.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use sonarproj_testkit as common;

/// The authors' sss→fls computation of one pose, in plain f64 and degrees as their code writes
/// it: the sidescan surface sampled at 0.1° (`linspace` over the aperture with an odd count),
/// moved by `R = (Rz Ry Rx)ᵀ` and the placement's `t`, clipped to the FLS's field of view, its
/// visible samples dropped to the image plane (`x = r cos az`, `y = r sin az`) and counted in
/// cells of `cell` m from `x0 = r_min cos(A/2)`, `y0 = −r_max sin(A/2)`. Returns the number of
/// occupied cells, and whether some visible sample lies within 1e-9 of a cell edge or a clip
/// bound (where two correct f64 programs may round differently).
fn authors_cells(
    (feature, place): (f64, f64),
    [roll, pitch, yaw]: [f64; 3],
    fls_elevation_aperture: f64,
    cell: f64,
) -> (usize, bool) {
    let (sss_az, sss_el, sss_step) = (130.0f64, 0.3f64, 0.1f64);
    let (r_min, r_max, fls_az) = (0.1f64, 10.0f64, 60.0f64);
    let linspace = |aperture: f64| -> Vec<f64> {
        // Python's round (ties to even) then an odd count, as the published code.
        #[expect(
            clippy::cast_possible_truncation,
            clippy::cast_sign_loss,
            reason = "a small count"
        )]
        let mut n = (aperture / sss_step).round_ties_even() as usize;
        if n.is_multiple_of(2) {
            n += 1;
        }
        (0..n)
            .map(|k| -aperture / 2.0 + aperture * k as f64 / (n - 1) as f64)
            .collect()
    };
    let sph = |r: f64, az: f64, el: f64| {
        let (a, e) = (az.to_radians(), el.to_radians());
        [r * e.cos() * a.cos(), r * e.cos() * a.sin(), r * e.sin()]
    };
    let (cx, sx) = (roll.to_radians().cos(), roll.to_radians().sin());
    let (cy, sy) = (pitch.to_radians().cos(), pitch.to_radians().sin());
    let (cz, sz) = (yaw.to_radians().cos(), yaw.to_radians().sin());
    let rx = [[1.0, 0.0, 0.0], [0.0, cx, -sx], [0.0, sx, cx]];
    let ry = [[cy, 0.0, sy], [0.0, 1.0, 0.0], [-sy, 0.0, cy]];
    let rz = [[cz, -sz, 0.0], [sz, cz, 0.0], [0.0, 0.0, 1.0]];
    let mul = |a: [[f64; 3]; 3], b: [[f64; 3]; 3]| {
        let mut m = [[0.0; 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                m[i][j] = (0..3).map(|k| a[i][k] * b[k][j]).sum();
            }
        }
        m
    };
    let active = mul(mul(rz, ry), rx);
    let r: [[f64; 3]; 3] = std::array::from_fn(|i| std::array::from_fn(|j| active[j][i]));
    let apply = |p: [f64; 3]| -> [f64; 3] { std::array::from_fn(|i| (0..3).map(|k| r[i][k] * p[k]).sum()) };
    // The placement: the true point (feature, 0, 0) of the sidescan appears at (place, 0, 0).
    let moved_true = apply(sph(feature, 0.0, 0.0));
    let t: [f64; 3] = std::array::from_fn(|i| sph(place, 0.0, 0.0)[i] - moved_true[i]);
    let x0 = r_min * (fls_az / 2.0).to_radians().cos();
    let y0 = -r_max * (fls_az / 2.0).to_radians().sin();
    let near = |v: f64| (v - v.round()).abs() < 1e-9;
    let (mut cells, mut ambiguous) = (std::collections::BTreeSet::new(), false);
    for az in linspace(sss_az) {
        for el in linspace(sss_el) {
            let p = apply(sph(feature, az, el));
            let q = [p[0] + t[0], p[1] + t[1], p[2] + t[2]];
            let range = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2]).sqrt();
            let azimuth = q[1].atan2(q[0]).to_degrees();
            let elevation = (q[2] / range).asin().to_degrees();
            let bounds = [
                range - r_min,
                range - r_max,
                azimuth.abs() - fls_az / 2.0,
                elevation.abs() - fls_elevation_aperture / 2.0,
            ];
            if bounds.iter().any(|b| b.abs() < 1e-9) {
                ambiguous = true;
            }
            let seen = range >= r_min
                && range <= r_max
                && azimuth.abs() <= fls_az / 2.0
                && elevation.abs() <= fls_elevation_aperture / 2.0;
            if !seen {
                continue;
            }
            let (x, y) = (
                range * azimuth.to_radians().cos(),
                range * azimuth.to_radians().sin(),
            );
            let (u, v) = ((x - x0) / cell, (y - y0) / cell);
            ambiguous |= near(u) || near(v);
            #[expect(clippy::cast_possible_truncation, reason = "cell indices within the grid")]
            cells.insert((u.floor() as i64, v.floor() as i64));
        }
    }
    (cells.len(), ambiguous)
}

/// Returns the metrics of `batch` CSV `input` as a header and rows of fields.
fn batch(args: &[&str], input: String) -> (Vec<String>, Vec<Vec<String>>) {
    let out = common::sonarproj()
        .args(["batch", "--step", "0.1"])
        .args(args)
        .write_stdin(input)
        .assert()
        .success()
        .get_output()
        .stdout
        .clone();
    let mut r = csv::Reader::from_reader(out.as_slice());
    let header = r.headers().unwrap().iter().map(String::from).collect();
    let rows = r
        .records()
        .map(|rec| rec.unwrap().iter().map(String::from).collect())
        .collect();
    (header, rows)
}

#[test]
fn the_authors_example_pose_gives_their_grid_area() {
    // Their example_ss2fl.py: the feature 15 m from the sidescan, 5 m from the FLS, roll 45°,
    // yaw 45°; their FLS has a 10° elevation aperture (the paper's Table I says 12°).
    let dir = tempfile::tempdir().unwrap();
    let fls10 = dir.path().join("fls10.toml");
    std::fs::write(
        &fls10,
        "kind = \"fls\"\nrange_min = 0.1\nrange_max = 10.0\nazimuth_aperture = 60.0\n\
         elevation_aperture = 10.0\nrange_bins = 990\nbeams = 512\n",
    )
    .unwrap();
    let (cells, ambiguous) = authors_cells((15.0, 5.0), [45.0, 0.0, 45.0], 10.0, 0.08);
    assert_eq!((cells, ambiguous), (37, false), "the independent count");
    for backend in common::cli_backends("cpu") {
        let out = common::sonarproj()
            .args(["project", "--from", "paper-sss", "--to"])
            .arg(&fls10)
            .args([
                "--range",
                "15",
                "--place-range",
                "5",
                "--roll",
                "45",
                "--yaw",
                "45",
            ])
            .args(["--step", "0.1", "--backend", backend])
            .assert()
            .success()
            .get_output()
            .stdout
            .clone();
        let m = &common::json(&out)["metrics"];
        assert_eq!(m["projection_area"], 0.2368, "{backend}: 37 cells of 0.0064 m²");
        assert_eq!(m["visible"], 202, "{backend}");
    }
}

#[test]
fn projection_area_is_the_authors_grid_count_on_random_paper_poses() {
    let mut rng = ChaCha8Rng::seed_from_u64(33);
    let mut input =
        String::from("range,azimuth,elevation,roll,pitch,yaw,place_range,place_azimuth,place_elevation\n");
    let mut poses = Vec::new();
    while poses.len() < 60 {
        // The paper's scenarios: the feature within the sidescan's range, placed within the
        // FLS's, any orientation (pitch within the code's (−90°, 90°]).
        let d1 = rng.random_range(1.0..29.0);
        let d2 = rng.random_range(0.5..9.5);
        let angles = [
            rng.random_range(-180.0..180.0),
            rng.random_range(-89.0..90.0),
            rng.random_range(-180.0..180.0),
        ];
        let (cells, ambiguous) = authors_cells((d1, d2), angles, 12.0, 0.08);
        // Poses the FLS sees little of say little; keep mostly seen ones, and some empty.
        if cells == 0 && poses.len() % 6 != 0 {
            continue;
        }
        input += &format!("{d1},0,0,{},{},{},{d2},0,0\n", angles[0], angles[1], angles[2]);
        poses.push((cells, ambiguous));
    }
    for backend in ["cpu", "cpu-fast"] {
        let (header, rows) = batch(
            &["--from", "paper-sss", "--to", "paper-fls", "--backend", backend],
            input.clone(),
        );
        let col = header.iter().position(|h| h == "projection_area").unwrap();
        let mut exact = 0;
        for (k, (row, &(cells, ambiguous))) in rows.iter().zip(&poses).enumerate() {
            let area: f64 = row[col].parse().unwrap();
            let counted = (area / 0.0064).round();
            assert!(
                (area - counted * 0.0064).abs() < 1e-12,
                "row {k}: {area} is not a cell count"
            );
            if !ambiguous {
                #[expect(clippy::cast_precision_loss, reason = "a few hundred cells")]
                let cells = cells as f64;
                assert_eq!(counted, cells, "{backend} row {k}: {row:?}");
                exact += 1;
            }
        }
        assert!(
            exact >= 55,
            "{backend}: only {exact} of 60 poses clear of every edge"
        );
        assert!(
            poses.iter().filter(|p| p.0 > 10).count() >= 20,
            "the poses must see something"
        );
    }
}

#[test]
fn quaternions_and_matrices_give_the_rows_of_roll_pitch_yaw() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let (mut rpy, mut quat, mut matrix) = (
        String::from("range,azimuth,elevation,roll,pitch,yaw,tx,ty,tz\n"),
        String::from("range,azimuth,qw,qx,qy,qz,tx,ty,tz\n"),
        String::from("range,azimuth,elevation,r11,r12,r13,r21,r22,r23,r31,r32,r33,tx,ty,tz\n"),
    );
    for _ in 0..40 {
        let (r, az) = (rng.random_range(1.0..9.0), rng.random_range(-25.0..25.0));
        let [roll, pitch, yaw]: [f64; 3] = std::array::from_fn(|_| rng.random_range(-180.0..180.0));
        let (place_r, place_az) = (rng.random_range(1.0..9.0), rng.random_range(-25.0..25.0));
        // R = (Rz Ry Rx)ᵀ = Rx(−roll) Ry(−pitch) Rz(−yaw), as a quaternion product of the
        // half-angle rotations, and as a matrix from it: written here independently of the
        // engine's conversions.
        let half = |a: f64| (-a).to_radians() / 2.0;
        let qx = [half(roll).cos(), half(roll).sin(), 0.0, 0.0];
        let qy = [half(pitch).cos(), 0.0, half(pitch).sin(), 0.0];
        let qz = [half(yaw).cos(), 0.0, 0.0, half(yaw).sin()];
        let hamilton = |a: [f64; 4], b: [f64; 4]| {
            [
                a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
                a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
                a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
                a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0],
            ]
        };
        let [w, x, y, z] = hamilton(hamilton(qx, qy), qz);
        let m = [
            [
                1.0 - 2.0 * (y * y + z * z),
                2.0 * (x * y - w * z),
                2.0 * (x * z + w * y),
            ],
            [
                2.0 * (x * y + w * z),
                1.0 - 2.0 * (x * x + z * z),
                2.0 * (y * z - w * x),
            ],
            [
                2.0 * (x * z - w * y),
                2.0 * (y * z + w * x),
                1.0 - 2.0 * (x * x + y * y),
            ],
        ];
        // The translation that puts the true point (r, az, 0) at (place_r, place_az, 0) of the
        // second FLS: t = p2 − R p1.
        let sph = |r: f64, a: f64| [r * a.to_radians().cos(), r * a.to_radians().sin(), 0.0];
        let (p1, p2) = (sph(r, az), sph(place_r, place_az));
        let [tx, ty, tz]: [f64; 3] =
            std::array::from_fn(|i| p2[i] - (0..3).map(|k| m[i][k] * p1[k]).sum::<f64>());
        rpy += &format!("{r},{az},0,{roll},{pitch},{yaw},{tx},{ty},{tz}\n");
        quat += &format!("{r},{az},{w},{x},{y},{z},{tx},{ty},{tz}\n");
        let flat: Vec<String> = m.iter().flatten().map(f64::to_string).collect();
        matrix += &format!("{r},{az},0,{},{tx},{ty},{tz}\n", flat.join(","));
    }
    let args = ["--from", "paper-fls", "--to", "paper-fls", "--backend", "cpu"];
    let metrics = |(header, rows): (Vec<String>, Vec<Vec<String>>)| -> Vec<Vec<f64>> {
        let first = header.iter().position(|h| h == "visible").unwrap();
        let last = header.iter().position(|h| h == "projection_area").unwrap();
        rows.iter()
            .map(|r| {
                r[first..=last]
                    .iter()
                    .map(|f| f.parse().unwrap_or(f64::NAN))
                    .collect()
            })
            .collect()
    };
    let a = metrics(batch(&args, rpy));
    assert!(
        a.iter().all(|r| r[0] > 0.0),
        "every pose sees its true point's arc"
    );
    for (name, b) in [
        ("quaternion", metrics(batch(&args, quat))),
        ("matrix", metrics(batch(&args, matrix))),
    ] {
        for (k, (x, y)) in a.iter().zip(&b).enumerate() {
            // The same rotation rounded differently: counts agree, values within 1e-9 m.
            assert_eq!(x[0], y[0], "{name} row {k}: visible");
            for (u, v) in x.iter().zip(y) {
                assert!(
                    (u.is_nan() && v.is_nan()) || (u - v).abs() <= 1e-9 * u.abs().max(1.0) || x[0] == 0.0,
                    "{name} row {k}: {x:?} vs {y:?}"
                );
            }
        }
    }
}
