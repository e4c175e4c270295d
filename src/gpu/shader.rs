//! The one WGSL loader. Shaders live in `shaders/`, one file per pipeline, with shared pieces in
//! `shaders/shared/`. A tiny preprocessor resolves `#include "shared/x.wgsl"` and specialises a
//! shader with `#if NAME` / `#else` / `#endif` on a set of defines, so code for an absent feature
//! is not in the pipeline at all (override constants specialise the rest).

use crate::error::{Error, Result};

/// Every shader source, embedded at build time so the binary is self-contained.
pub(crate) const SOURCES: &[(&str, &str)] = &[
    ("volume.wgsl", include_str!("../../shaders/volume.wgsl")),
    (
        "volume_f64.wgsl",
        include_str!("../../shaders/volume_f64.wgsl"),
    ),
    (
        "surface_data.wgsl",
        include_str!("../../shaders/surface_data.wgsl"),
    ),
    (
        "surface_fringe.wgsl",
        include_str!("../../shaders/surface_fringe.wgsl"),
    ),
    (
        "shared/camera.wgsl",
        include_str!("../../shaders/shared/camera.wgsl"),
    ),
    (
        "volume_bricked.wgsl",
        include_str!("../../shaders/volume_bricked.wgsl"),
    ),
    (
        "shared/march.wgsl",
        include_str!("../../shaders/shared/march.wgsl"),
    ),
    (
        "shared/volume_params.wgsl",
        include_str!("../../shaders/shared/volume_params.wgsl"),
    ),
    (
        "shared/optics.wgsl",
        include_str!("../../shaders/shared/optics.wgsl"),
    ),
    (
        "shared/preintegrate.wgsl",
        include_str!("../../shaders/shared/preintegrate.wgsl"),
    ),
    (
        "volume_mapped.wgsl",
        include_str!("../../shaders/volume_mapped.wgsl"),
    ),
    (
        "shared/tonemap_common.wgsl",
        include_str!("../../shaders/shared/tonemap_common.wgsl"),
    ),
    (
        "tonemap/luminance_stats.wgsl",
        include_str!("../../shaders/tonemap/luminance_stats.wgsl"),
    ),
    (
        "tonemap/global.wgsl",
        include_str!("../../shaders/tonemap/global.wgsl"),
    ),
    (
        "tonemap/ward_histogram.wgsl",
        include_str!("../../shaders/tonemap/ward_histogram.wgsl"),
    ),
    (
        "tonemap/reinhard_local.wgsl",
        include_str!("../../shaders/tonemap/reinhard_local.wgsl"),
    ),
    (
        "tonemap/durand_bilateral.wgsl",
        include_str!("../../shaders/tonemap/durand_bilateral.wgsl"),
    ),
    (
        "tonemap/false_colour.wgsl",
        include_str!("../../shaders/tonemap/false_colour.wgsl"),
    ),
];

/// The pipeline shaders (not the shared pieces) with every define combination they are built
/// with, so tests can validate each variant.
#[cfg(test)]
pub(crate) const PIPELINES: &[(&str, &[&[&str]])] = &[
    (
        "volume.wgsl",
        &[
            &[],
            &["HW_FILTER"],
            &["SHADING"],
            &["HW_FILTER", "SHADING"],
            &["PREINTEGRATED"],
            &["HW_FILTER", "PREINTEGRATED"],
            &["SHADING", "PREINTEGRATED"],
            &["SLAB"],
            &["SLAB", "SHADING"],
            &["SKIPPING"],
            &["SKIPPING", "HW_FILTER", "SHADING"],
        ],
    ),
    ("volume_f64.wgsl", &[&[]]),
    ("volume_bricked.wgsl", &[&[], &["HW_FILTER"]]),
    ("tonemap/luminance_stats.wgsl", &[&[]]),
    ("tonemap/global.wgsl", &[&[]]),
    ("tonemap/ward_histogram.wgsl", &[&[]]),
    ("tonemap/reinhard_local.wgsl", &[&[]]),
    ("tonemap/durand_bilateral.wgsl", &[&[]]),
    ("tonemap/false_colour.wgsl", &[&[]]),
    (
        "volume_mapped.wgsl",
        &[
            &[],
            &["UNEVEN"],
            &["SPHERICAL"],
            &["SPHERICAL", "UNEVEN", "SEAM"],
            &["SPHERICAL", "SHADING"],
            &["SPHERICAL", "UNEVEN", "PREINTEGRATED"],
            &["PREINTEGRATED", "SHADING"],
            &["SPHERICAL", "SHELL", "CF_AXES", "HW_FILTER"],
            &["SPHERICAL", "SHELL", "PREINTEGRATED", "SHADING"],
            &["SPHERICAL", "SHELL", "SKIPPING", "PREINTEGRATED"],
            &["SPHERICAL", "UNEVEN", "SEAM", "SKIPPING", "SHADING"],
            &["SKIPPING", "UNEVEN"],
            &["RENORMALISE", "PREINTEGRATED"],
            &["SPHERICAL", "SHELL", "CF_AXES", "RENORMALISE", "SHADING"],
        ],
    ),
    ("surface_data.wgsl", &[&[]]),
    ("surface_fringe.wgsl", &[&[]]),
];

/// Development aid: with `HDRVIS_SHADER_DIR` set, shaders are read from that folder at run time
/// instead of the copies embedded at build time, so a shader can be tuned without rebuilding.
pub(crate) const SHADER_DIR_ENV: &str = "HDRVIS_SHADER_DIR";

fn source(name: &str) -> Result<std::borrow::Cow<'static, str>> {
    if let Ok(dir) = std::env::var(SHADER_DIR_ENV) {
        let path = std::path::Path::new(&dir).join(name);
        return std::fs::read_to_string(&path)
            .map(Into::into)
            .map_err(|e| Error::io(&path, e));
    }
    SOURCES
        .iter()
        .find(|(n, _)| *n == name)
        .map(|(_, s)| (*s).into())
        .ok_or_else(|| Error::Gpu(format!("shader {name} is not embedded")))
}

/// Returns the preprocessed source of `name` with `defines` set.
pub fn load(name: &str, defines: &[&str]) -> Result<String> {
    let mut out = String::new();
    expand(name, defines, &mut out, 0)?;
    Ok(out)
}

fn expand(name: &str, defines: &[&str], out: &mut String, depth: usize) -> Result<()> {
    if depth > 8 {
        return Err(Error::Gpu(format!("{name}: #include nested too deeply")));
    }
    // Each entry says whether the enclosing branch is being emitted.
    let mut stack: Vec<bool> = Vec::new();
    for (n, line) in source(name)?.lines().enumerate() {
        let trimmed = line.trim_start();
        let active = stack.iter().all(|&a| a);
        if let Some(rest) = trimmed.strip_prefix("#if ") {
            stack.push(defines.contains(&rest.trim()));
        } else if trimmed.starts_with("#else") {
            let top = stack
                .last_mut()
                .ok_or_else(|| Error::Gpu(format!("{name}:{}: #else without #if", n + 1)))?;
            *top = !*top;
        } else if trimmed.starts_with("#endif") {
            stack
                .pop()
                .ok_or_else(|| Error::Gpu(format!("{name}:{}: #endif without #if", n + 1)))?;
        } else if let Some(rest) = trimmed.strip_prefix("#include ") {
            if active {
                expand(rest.trim().trim_matches('"'), defines, out, depth + 1)?;
            }
        } else if active {
            out.push_str(line);
            out.push('\n');
        }
    }
    if !stack.is_empty() {
        return Err(Error::Gpu(format!("{name}: unterminated #if")));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_pipeline_variant_parses_and_validates_with_naga() {
        for (name, variants) in PIPELINES {
            for defines in *variants {
                let src = load(name, defines).unwrap();
                let module = naga::front::wgsl::parse_str(&src)
                    .unwrap_or_else(|e| panic!("{name} {defines:?}: {}", e.emit_to_string(&src)));
                naga::valid::Validator::new(
                    naga::valid::ValidationFlags::all(),
                    naga::valid::Capabilities::all(),
                )
                .validate(&module)
                .unwrap_or_else(|e| panic!("{name} {defines:?}: {e:?}"));
            }
        }
    }

    #[test]
    fn conditionals_select_branches() {
        let plain = load("volume.wgsl", &[]).unwrap();
        let hw = load("volume.wgsl", &["HW_FILTER"]).unwrap();
        assert!(hw.contains("textureSampleLevel") && !plain.contains("textureSampleLevel"));
        assert!(!plain.contains("#include") && !plain.contains("#if"));
    }
}
