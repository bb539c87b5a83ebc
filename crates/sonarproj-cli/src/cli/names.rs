//! How the command line names the inputs that errors and notices are about ([`Param`]): its
//! flags, and for the GPU options the environment variables they come from.

use sonarproj::error::Param;
use sonarproj::gpu::options::{ADAPTER, PRECISION, WORKGROUP};
use sonarproj_apps::params;

/// Returns the command line's name of `param`.
pub(crate) fn name(param: Param) -> String {
    let name = match param {
        p if p == ADAPTER => "WGPU_ADAPTER_NAME: GPU adapter",
        p if p == PRECISION => "SONARPROJ_GPU_PRECISION: GPU precision",
        p if p == WORKGROUP => "SONARPROJ_GPU_WORKGROUP: GPU workgroup",
        p if p == params::OUT => "--out",
        p if p == params::SWEEP_DIR => "DIR",
        p if p == params::CHUNK_POSES => "--chunk-poses",
        p if p == params::FORMAT => "--format",
        p if p == params::BACKEND => "--backend",
        p if p == params::CONFIG => "--config",
        p if p == params::SHARD => "--shard",
        p if p == params::ANGLE_STEP => "--angle-step",
        p if p == params::OCCUPANCY => "--occupancy",
        p if p == params::FEATURE => "--feature",
        p if p == sonarproj::recovery::SIGMA_RANGE => "--sigma-range",
        p if p == sonarproj::recovery::SIGMA_AZIMUTH => "--sigma-azimuth",
        other => other.name(),
    };
    name.to_string()
}

#[cfg(test)]
mod tests {
    /// Every param of the applications has a flag of its own.
    #[test]
    fn every_param_has_a_flag() {
        for p in sonarproj_apps::params::ALL {
            let flag = super::name(p);
            assert!(flag.starts_with("--") || flag == "DIR", "{}: {flag}", p.name());
        }
    }
}
