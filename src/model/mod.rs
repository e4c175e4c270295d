//! Data and maths only: volumes, cameras, transfer functions, colour maps and HDR images. Nothing
//! here knows about wgpu, Rhai or the terminal; the renderers, the scripts and the CLI all build on
//! these types.

pub mod arithmetic;
pub mod bricks;
pub(crate) mod camera;
pub mod colormap;
pub mod contour;
pub mod cut;
pub mod figure;
pub mod geometry;
pub(crate) mod grid;
pub mod grid_sampler;
pub(crate) mod image;
pub mod map_projection;
pub mod mesh;
pub mod numeric;
pub(crate) mod resample;
pub mod rotated_pole;
pub mod section;
pub(crate) mod stencil;
pub mod transfer;
pub(crate) mod vec3;
pub(crate) mod volume;

pub use camera::{Axis, Camera, Projection};
pub use cut::{Cut, CutFaces, CutPlane, DepthRings, MAX_CUT_PLANES};
pub(crate) use figure::map_frame;
pub use figure::text;
pub use geometry::{CoordAxis, Geometry, SphericalGrid};
pub use grid::{CoordKind, Grid, GridCoords};
pub use grid_sampler::GridSampler;
pub use image::HdrImage;
pub use map_projection::{LonLatBox, MapProjection, ProjectionKind, Projector};
pub use resample::resample_to_box;
pub use rotated_pole::RotatedPole;
pub use transfer::{Lens, LutTransfer, Scale, TransferFunction};
pub use volume::{Aabb, Missing, Volume, VolumeStats};
