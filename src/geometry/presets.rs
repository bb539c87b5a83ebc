//! The preset sonars (docs/sonars.md): the paper's pair, makers' data sheets and simulators'
//! defaults, each row with its source, and the constructors that read them
//! ([`Sonar::preset`], [`Sonar::preset_names`], [`Sonar::preset_source`]).

use super::sonar::{BeamLayout, Sonar, SonarKind};

/// One row of the preset table: name, kind, range, apertures, range bins, beams, source.
type PresetRow = (
    &'static str,
    SonarKind,
    f64,
    f64,
    f64,
    f64,
    u32,
    u32,
    &'static str,
);

/// The presets (docs/sonars.md). Sources are kept beside each row.
const PRESETS: &[PresetRow] = &[
    // Paper Table I; layout ours: 1 cm range bins, 512 beams.
    (
        "paper-fls",
        SonarKind::Fls,
        0.1,
        10.0,
        60.0,
        12.0,
        990,
        512,
        "paper Table I",
    ),
    // Paper Table I; 1 cm range bins.
    (
        "paper-sss",
        SonarKind::Sss,
        0.1,
        30.0,
        130.0,
        0.3,
        2990,
        1,
        "paper Table I",
    ),
    // Blueprint Subsea Oculus M750d data sheet, 750 kHz mode: 0.1-120 m, 130° x 20°, 512 beams.
    // The maker's beams are not uniform, and its image height follows the range setting. We use
    // 512 uniform beams and 10 cm range bins. Give beam_edges in a sonar file to match a unit.
    (
        "oculus-m750d",
        SonarKind::Fls,
        0.1,
        120.0,
        130.0,
        20.0,
        1199,
        512,
        "Blueprint Subsea M750d sheet, 750 kHz",
    ),
    // Blueprint Subsea Oculus M1200d data sheet, 2.1 MHz mode: 0.1-30 m, 60° x 12°, 512 beams;
    // 1 cm range bins (ours).
    (
        "oculus-m1200d-hf",
        SonarKind::Fls,
        0.1,
        30.0,
        60.0,
        12.0,
        2990,
        512,
        "Blueprint Subsea M1200d sheet, 2.1 MHz",
    ),
    // HoloOcean ImagingSonar defaults: RangeMin 0.1, RangeMax 10, Azimuth 120, Elevation 20,
    // RangeBins 512, AzimuthBins 512.
    (
        "holoocean-imaging",
        SonarKind::Fls,
        0.1,
        10.0,
        120.0,
        20.0,
        512,
        512,
        "HoloOcean ImagingSonar defaults",
    ),
    // HoloOcean SidescanSonar as its example scenarios set it: RangeMin 0.5, RangeMax 35 (the
    // class defaults), Azimuth 170, Elevation 0.25, RangeBins 2000. The class default is 5 cm
    // bins, 690 values; `Sonar::from_holoocean` reads any configuration. Its one fan covers both
    // sides, and its frame is one row of RangeBins values: port far→near, then starboard
    // near→far, each side RangeBins / 2 bins over the whole range. In SidescanSonar.cpp, bin
    // X = (r − RangeMin) / RangeRes has port index RangeBins/2 − X/2 − 1 and starboard index
    // RangeBins/2 + X/2. So this preset has two sides of 1000 bins.
    (
        "holoocean-sidescan",
        SonarKind::Sss,
        0.5,
        35.0,
        170.0,
        0.25,
        1000,
        2,
        "HoloOcean SidescanSonar, RangeBins 2000 (two-sided: 2 x 1000 bins)",
    ),
];

impl Sonar {
    /// Returns the names of all presets, in table order.
    #[must_use]
    pub fn preset_names() -> Vec<&'static str> {
        PRESETS.iter().map(|p| p.0).collect()
    }

    /// Returns the preset called `name`, or `None`.
    #[must_use]
    pub fn preset(name: &str) -> Option<Sonar> {
        PRESETS.iter().find(|p| p.0 == name).map(
            |&(name, kind, range_min, range_max, az, el, range_bins, beams, _source)| Sonar {
                name: name.to_string(),
                kind,
                range_min,
                range_max,
                azimuth_aperture: az,
                elevation_aperture: el,
                range_bins,
                beams: BeamLayout::Uniform { count: beams },
            },
        )
    }

    /// Returns the source of a preset's numbers (maker's sheet, paper, simulator), or `None`.
    #[must_use]
    pub fn preset_source(name: &str) -> Option<&'static str> {
        PRESETS.iter().find(|p| p.0 == name).map(|p| p.8)
    }
}
