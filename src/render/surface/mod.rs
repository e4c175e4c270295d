//! Interference-based surface rendering (Yuan et al. 2008, section 2.1) in two GPU steps. Step 1,
//! the data pass (`shaders/surface_data.wgsl`), renders a grid in map view or in a lit 3-D
//! perspective view with relief and writes up to four properties per pixel into float targets in
//! one pass. Step 2, the fringe pass (`shaders/surface_fringe.wgsl`), turns one property into
//! I = (1 + cos 2πν·d)/2 with a colour lookup. [`SurfaceRenderer`] caches step-1 targets keyed by
//! (grid identity, view, size, properties, relief), so changing ν, the colour mode or the colour
//! map re-runs only step 2.
//!
//! Phase precision: per node the host computes d − d_ref in f64 (d_ref = the middle of the
//! property's range) and uploads it as hi = f32(d − d_ref) and rest = f32((d − d_ref) − hi). ν is
//! split on the host into ν₁ + ν₂ + ν₃ with 12 significant bits in ν₁ and ν₂; the shader splits hi
//! into h₁ + h₂ of 12 significant bits each by masking mantissa bits. The four products νᵢ·hⱼ
//! (i, j ≤ 2) are then exact in f32, their fractions are taken separately, and the small terms
//! ν₂h₂ + ν₃·hi + ν·rest and frac(ν·d_ref) (computed in f64 on the host) are added before a last
//! fraction; the cosine sees an argument in [−π, π]. This holds to ~1e-6 of a period for ν·d up
//! to ~10¹⁰ at pixels on grid nodes (map view at the default size); between nodes the values are
//! interpolated in f32 relative to d_ref. For comparison, [`PhaseMethod::Naive`] specialises the
//! fringe pass to what a straightforward implementation does (d as one f32, cos 2πν·d in f32);
//! `hdrvis bench accuracy` measures both.
//!
//! Antialiasing: fringes denser than the pixels would alias into moiré, so the fringe pass also
//! writes the fringe averaged over the pixel's footprint — a Gaussian of σ = 0.5 pixel along the
//! data's gradient, (1 + cos 2πν·d · exp(−2π²ν²σ²|∇d|²))/2 for a field linear across it, with ∇d
//! in data units per pixel from central differences of the neighbouring pixels (the screen-space
//! derivative in 3-D views). The colours use it unless `antialias` is off; the point value stays
//! in the `fringe` channel and the filtered one is `fringe_filtered` ([`fringe_filtered_f64`] and
//! [`pixel_gradient`] are the f64 forms).
//!
//! Geographic grids (longitude along x, latitude along y): the map keeps the equirectangular
//! aspect of [`crate::model::Grid::map_aspect`], and [`SurfaceView::Globe`] drapes the field on
//! the unit sphere of the Earth-centred frame ([`GlobeFrame`]) for any camera.
//!
//! Map and globe views of longitude/latitude grids can carry Natural Earth coastlines and a
//! graticule (`overlay`), drawn into the HDR image after the fringe pass.
//!
//! With `HDRVIS_SURFACE_PROFILE` set, each fringe pass prints its stage times to stderr.
//!
//! The rooms: `options` (what a render is asked for), `phase` (the f64
//! fringe maths), `globe` and `geometry` (where the surface lies), `params` (what the passes
//! are given), `gpu` (the renderer), `mesh` (meshes drawn cell by cell: their pixels
//! located on the host), `legend` (colour domain, colour bar and legend) and `overlay`
//! (coastlines, graticules and cell edges).

mod geometry;
mod globe;
mod gpu;
mod legend;
mod located;
mod marks;
mod mesh;
mod options;
pub(crate) mod overlay;
mod params;
mod phase;
mod projected;
mod projector;

pub(crate) use geometry::SurfaceGeometry;
pub(crate) use globe::GlobeFrame;
pub use gpu::SurfaceRenderer;
pub(crate) use gpu::SurfaceTiming;
pub(crate) use legend::{colorbar, legend_in, legend_type, MAX_COLORBAR_HEIGHT};
pub use legend::{legend, resolution_label, LEGEND_BAR_HEIGHT};
pub use marks::{ContourLevels, ContourStyle, VectorStyle};
pub(crate) use mesh::mesh_extent_grid;
pub(crate) use options::check_graticule;
pub(crate) use options::default_size;
pub use options::CoastlineStyle;
pub use options::{FringeMode, MissingColour, PhaseMethod, SurfaceOptions, SurfaceView};
pub use phase::{fringe_f64, fringe_filtered_f64, pixel_gradient};

/// Most nodes along an uneven axis's evenly spaced stand-in (3-D views place nodes by index),
/// and along a host-placed map's default axes.
pub(crate) const MAX_EVEN_NODES: usize = 8192;

/// Most properties one data pass writes (one RGBA32F target component each).
pub(crate) const MAX_PROPERTIES: usize = 4;
/// Entries in the colour lookup table.
pub const LUT_SIZE: usize = 256;

/// Direction towards the light of the 3-D views (normalised where used) and the ambient share:
/// shade = ambient + (1 − ambient)·max(n·l, 0). Shared by the data pass and its CPU reference.
pub(crate) const LIGHT_DIRECTION: [f64; 3] = [-0.4, -0.5, 0.77];
pub(crate) const LIGHT_AMBIENT: f64 = 0.3;

#[cfg(test)]
mod tests {
    use super::options::check_nu;
    use super::phase::split_nu;

    #[test]
    fn nu_split_is_exact_and_short() {
        for nu in [8.0, 1.0 / 3.0, 12345.678901, 1e-7] {
            let [a, b, c] = split_nu(nu);
            assert_eq!(a.to_bits() & 0xFFF, 0);
            assert_eq!(b.to_bits() & 0xFFF, 0);
            let sum = a as f64 + b as f64 + c as f64;
            assert!((sum - nu).abs() <= nu * 1e-14, "{nu}: {sum}");
        }
    }

    #[test]
    fn bad_nu_is_an_error() {
        for nu in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            assert!(check_nu(nu).is_err());
        }
    }
}
