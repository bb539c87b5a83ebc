//! A viewer scene written as what reproduces it elsewhere: a `sonarproj project` command line,
//! a sweep file of one pose, and a Python snippet. The command adds `recover` and `mask` lines
//! when the scene has a second measurement or noise. Numbers are written in Rust's shortest
//! round-trip form, so each text gives back the same `f64`s.

use std::fmt::Write as _;

use sonarproj::{RelativePose, SonarKind};

use super::{Choice, Scene};

/// Returns how `c` is named on a command line: the preset name, or the file's path, quoted for
/// a POSIX shell when needed.
fn cli_sonar(c: &Choice) -> String {
    match &c.path {
        None => c.label.clone(),
        Some(p) => shell_quote(&p.to_string_lossy()),
    }
}

/// Returns `s` quoted for a POSIX shell when it holds anything but safe characters.
fn shell_quote(s: &str) -> String {
    let safe = |ch: char| ch.is_ascii_alphanumeric() || "/._-+,:=@%".contains(ch);
    if !s.is_empty() && s.chars().all(safe) {
        s.to_string()
    } else {
        format!("'{}'", s.replace('\'', r"'\''"))
    }
}

/// Returns the pose options shared by `project`, `recover` and `mask`.
fn pose_options(scene: &Scene) -> String {
    let r = scene.rotation;
    let mut s = format!("--roll {} --pitch {} --yaw {}", r.roll, r.pitch, r.yaw);
    match (scene.place, scene.translation) {
        (Some(p), _) => {
            let _ = write!(
                s,
                " --place-range {} --place-azimuth {} --place-elevation {}",
                p.range, p.azimuth, p.elevation
            );
        }
        (None, Some(t)) => {
            let _ = write!(s, " --translation {},{},{}", t[0], t[1], t[2]);
        }
        (None, None) => {}
    }
    s
}

/// Returns the command lines that reproduce `scene`: `project` (metrics and occupancy), then
/// `recover` with a second measurement and `mask` with noise. `pose` is the scene's pose.
/// `mask` places its first feature at elevation 0 (and azimuth 0 for a sidescan), so for any
/// other true point its line gives the translation itself.
#[must_use]
pub fn command(scene: &Scene, first: &Choice, second: &Choice, pose: &RelativePose) -> String {
    let f = scene.feature;
    let pair = format!("--from {} --to {}", cli_sonar(first), cli_sonar(second));
    let step = match (scene.exact, scene.step) {
        (true, _) => " --step exact".to_string(),
        (false, s) => s.map(|s| format!(" --step {s}")).unwrap_or_default(),
    };
    let pose_text = pose_options(scene);
    let mut out = format!(
        "sonarproj project {pair} --range {} --azimuth {} --elevation {} {pose_text}{step} \
         --occupancy occupancy.npy",
        f.range, f.azimuth, f.elevation
    );
    let measured = match first.sonar.kind {
        SonarKind::Fls => format!("{},{}", f.range, f.azimuth),
        SonarKind::Sss => format!("{}", f.range),
    };
    if let Some(s) = scene.second {
        let second_obs = match (second.sonar.kind, s.azimuth) {
            (SonarKind::Fls, Some(a)) => format!("{},{a}", s.range),
            _ => format!("{}", s.range),
        };
        let placement_feature = match (scene.place, first.sonar.kind) {
            (None, _) => String::new(),
            (Some(_), SonarKind::Fls) => format!(" --feature-elevation {}", f.elevation),
            (Some(_), SonarKind::Sss) => format!(
                " --feature-azimuth {} --feature-elevation {}",
                f.azimuth, f.elevation
            ),
        };
        let sigmas = scene
            .sigma
            .map(|g| {
                let mut t = String::new();
                if g.range != 0.0 {
                    let _ = write!(t, " --sigma-range {}", g.range);
                }
                if g.azimuth != 0.0 {
                    let _ = write!(t, " --sigma-azimuth {}", g.azimuth);
                }
                t
            })
            .unwrap_or_default();
        let _ = write!(
            out,
            "\nsonarproj recover {pair} --first {measured} --second {second_obs} {pose_text}\
             {placement_feature}{sigmas}"
        );
    }
    if let Some(g) = scene.sigma.filter(|g| {
        [g.roll, g.pitch, g.yaw, g.tx, g.ty, g.tz, g.range, g.azimuth]
            .iter()
            .any(|v| *v != 0.0)
    }) {
        let mut sig = format!(
            " --sigma-rotation {},{},{} --sigma-translation {},{},{} --sigma-range {}",
            g.roll, g.pitch, g.yaw, g.tx, g.ty, g.tz, g.range
        );
        if first.sonar.kind == SonarKind::Fls {
            let _ = write!(sig, " --sigma-azimuth {}", g.azimuth);
        }
        let mask_places_it = f.elevation == 0.0 && (first.sonar.kind == SonarKind::Fls || f.azimuth == 0.0);
        let mask_pose = if scene.place.is_none() || mask_places_it {
            pose_options(scene)
        } else {
            let r = scene.rotation;
            let t = pose.translation;
            format!(
                "--roll {} --pitch {} --yaw {} --translation {},{},{}",
                r.roll, r.pitch, r.yaw, t.x, t.y, t.z
            )
        };
        let _ = write!(
            out,
            "\nsonarproj mask {pair} --feature {measured} {mask_pose}{sig} --coverage {} --out mask.png",
            scene.coverage
        );
    }
    out
}

/// Returns `s` in double quotes, escaping `"`, `\\` and control characters (`\\uXXXX`). The
/// result is both a TOML basic string and a Python string literal.
fn quoted(s: &str) -> String {
    let mut out = String::from("\"");
    for ch in s.chars() {
        match ch {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            c if c.is_control() => {
                let _ = write!(out, "\\u{:04X}", u32::from(c));
            }
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

/// Returns a sweep file of the one pose of `scene` (`sonarproj sweep --config FILE`). It is the
/// place to start a grid: turn any value into a list or a `{ start, stop, step }` range.
#[must_use]
pub fn sweep_toml(scene: &Scene, first: &Choice, second: &Choice) -> String {
    let name = |c: &Choice| match &c.path {
        None => quoted(&c.label),
        Some(p) => quoted(&p.to_string_lossy()),
    };
    let f = scene.feature;
    let r = scene.rotation;
    let mut out = format!(
        "# One pose from `sonarproj view`; turn any value into a list [a, b] or a range\n\
         # {{ start = a, stop = b, step = s }} to sweep it.\n\
         from = {}\nto = {}\n",
        name(first),
        name(second)
    );
    if scene.exact {
        let _ = writeln!(out, "step = \"exact\"");
    } else if let Some(s) = scene.step {
        let _ = writeln!(out, "step = {s}");
    }
    let _ = write!(
        out,
        "\n[feature]\nrange = {}\nazimuth = {}\nelevation = {}\n",
        f.range, f.azimuth, f.elevation
    );
    match (scene.place, scene.translation) {
        (Some(p), _) => {
            let _ = write!(
                out,
                "\n[place]\nrange = {}\nazimuth = {}\nelevation = {}\n",
                p.range, p.azimuth, p.elevation
            );
        }
        (None, Some(t)) => {
            let _ = write!(out, "\n[translation]\nx = {}\ny = {}\nz = {}\n", t[0], t[1], t[2]);
        }
        (None, None) => {}
    }
    let _ = write!(
        out,
        "\n[rotation]\nroll = {}\npitch = {}\nyaw = {}\n",
        r.roll, r.pitch, r.yaw
    );
    out
}

/// Returns `v` as a Python float literal. Scenes are checked, so `inf`/`nan` cannot occur.
fn py(v: f64) -> String {
    let s = format!("{v}");
    if s.contains(['.', 'e', 'E']) {
        s
    } else {
        format!("{s}.0")
    }
}

/// Returns a Python snippet that computes `scene` with the `sonarproj` package and prints the
/// metrics the viewer shows.
#[must_use]
pub fn python(scene: &Scene, first: &Choice, second: &Choice) -> String {
    let sonar = |c: &Choice| match &c.path {
        None => format!("sonarproj.Sonar.preset({})", quoted(&c.label)),
        Some(p) => format!("sonarproj.Sonar.from_toml({})", quoted(&p.to_string_lossy())),
    };
    let f = scene.feature;
    let r = scene.rotation;
    let rpy = format!("roll={}, pitch={}, yaw={}", py(r.roll), py(r.pitch), py(r.yaw));
    let pose = match (scene.place, scene.translation) {
        (Some(p), _) => format!(
            "sonarproj.Pose.placement(({}, {}, {}), ({}, {}, {}), {rpy})",
            py(f.range),
            py(f.azimuth),
            py(f.elevation),
            py(p.range),
            py(p.azimuth),
            py(p.elevation)
        ),
        (None, Some(t)) => format!(
            "sonarproj.Pose({rpy}, t=({}, {}, {}))",
            py(t[0]),
            py(t[1]),
            py(t[2])
        ),
        (None, None) => "None  # no translation given".to_string(),
    };
    let measured = match first.sonar.kind {
        SonarKind::Fls => format!("({}, {})", py(f.range), py(f.azimuth)),
        SonarKind::Sss => py(f.range),
    };
    let step = match (scene.exact, scene.step) {
        (true, _) => ", step=\"exact\"".to_string(),
        (false, s) => s.map(|s| format!(", step={}", py(s))).unwrap_or_default(),
    };
    let mut out = format!(
        "import sonarproj\n\n\
         first = {}\n\
         second = {}\n\
         pose = {pose}\n\
         result = sonarproj.project(first, second, pose, {measured}{step}, occupancy=True)\n\
         for name in (\"visible\", \"total\", \"range_min\", \"range_max\", \"span\", \"occupied\", \"occupied_measure\"):\n    \
             print(name, result[name])\n\
         occupancy = result[\"occupancy\"]  # uint8, row 0 = range_min, column 0 = starboard-most beam\n",
        sonar(first),
        sonar(second),
    );
    if let Some(s) = scene.second {
        let obs = match (second.sonar.kind, s.azimuth) {
            (SonarKind::Fls, Some(a)) => format!("({}, {})", py(s.range), py(a)),
            _ => py(s.range),
        };
        let _ = write!(
            out,
            "recovered = sonarproj.recover(first, second, pose, {measured}, {obs})\n\
             for c in recovered[\"candidates\"][:3]:\n    print(c[\"rank\"], c[\"point_first\"], c[\"in_view\"])\n"
        );
    }
    out
}
