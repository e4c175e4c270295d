//! Unstructured meshes as data: nodes on the sphere (longitude, latitude in degrees) and cells as
//! rings of node indices ([`Mesh`]), a field on one ([`MeshField`]), each cell as a polygon in the
//! (longitude, latitude) plane with the pole and antimeridian rules that let it be drawn whole
//! ([`ring`]), and point location through a spatial index ([`locate`]). The readers that make
//! meshes from model files live in `datasets::conventions::mesh`.

pub(crate) mod locate;
pub(crate) mod ring;

use super::Grid;
use crate::error::{Error, Result};
use crate::model::numeric::finite_range;
use locate::MeshIndex;
use rayon::prelude::*;
use std::sync::{Arc, OnceLock};

/// Where a variable's values sit on its mesh.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Location {
    /// One value per cell, constant over it.
    Faces,
    /// One value per node, linear over the cells' triangles.
    Nodes,
}

/// Where a mesh lies: its latitudes (out to a pole when a cell goes round it), its longitudes in
/// whichever of [−180°, 180°) and [0°, 360°) keeps them in one piece, and whether it reaches a
/// pole (then it goes all round).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Extent {
    pub south: f64,
    pub north: f64,
    pub lon: (f64, f64),
    pub polar: bool,
}

/// A mesh: nodes on the sphere and cells as rings of node indices.
#[derive(Clone, Debug, PartialEq)]
pub struct Mesh {
    /// The convention it was read by ("UGRID", "ICON", "MPAS", "SCRIP", "FVCOM", ...).
    pub(crate) kind: String,
    /// Node longitudes and latitudes in degrees.
    pub(crate) lon: Vec<f64>,
    pub(crate) lat: Vec<f64>,
    /// Cell `f`'s nodes are `nodes[offsets[f]..offsets[f + 1]]`.
    pub(crate) offsets: Vec<usize>,
    pub(crate) nodes: Vec<usize>,
    pub(crate) location: Location,
    /// The dimension the variable's values run along (cells or nodes).
    pub(crate) dim: String,
    /// How a separate grid file was paired with the values when nothing but a count ties them.
    pub(crate) pairing: Option<String>,
}

impl Mesh {
    /// How many cells it has.
    pub fn faces(&self) -> usize {
        self.offsets.len() - 1
    }

    pub(crate) fn face(&self, f: usize) -> &[usize] {
        &self.nodes[self.offsets[f]..self.offsets[f + 1]]
    }

    /// How many nodes it has.
    pub fn nodes(&self) -> usize {
        self.lon.len()
    }

    /// The convention it was read by ("UGRID", "ICON", "MPAS", ...).
    pub fn kind(&self) -> &str {
        &self.kind
    }

    /// Bytes held by its node positions and cells.
    pub fn bytes(&self) -> usize {
        (self.lon.len() + self.lat.len() + self.offsets.len() + self.nodes.len()) * 8
    }

    /// How many values a variable on this mesh has.
    pub fn values(&self) -> usize {
        match self.location {
            Location::Faces => self.faces(),
            Location::Nodes => self.lon.len(),
        }
    }

    /// The cells' median size in degrees: the square root of a cell's area (its polygon in
    /// longitude and latitude, the longitudes shrunk by the cosine of its latitude), the step
    /// at which a grid samples each cell about once. Of at most 200 000 cells spread over the
    /// mesh; cells round a pole or at one are left out. `None` when every cell has zero area.
    pub(crate) fn median_size(&self) -> Option<f64> {
        let every = (self.faces() / 200_000).max(1);
        let mut sizes: Vec<f64> = (0..self.faces())
            .step_by(every)
            .filter_map(|f| {
                let ids = self.face(f);
                let first = self.lon[ids[0]];
                let mut pts = Vec::with_capacity(ids.len());
                for &n in ids {
                    let (lo, la) = (self.lon[n], self.lat[n]);
                    if !(lo.is_finite() && la.is_finite()) || ring::at_a_pole(la) {
                        return None;
                    }
                    pts.push([lo - 360.0 * ((lo - first) / 360.0).round(), la]);
                }
                let mean_lat = pts.iter().map(|p| p[1]).sum::<f64>() / pts.len() as f64;
                let twice: f64 = (0..pts.len())
                    .map(|k| {
                        let (a, b) = (pts[k], pts[(k + 1) % pts.len()]);
                        a[0] * b[1] - b[0] * a[1]
                    })
                    .sum();
                let area = 0.5 * twice.abs() * mean_lat.to_radians().cos();
                (area > 0.0).then(|| area.sqrt())
            })
            .collect();
        if sizes.is_empty() {
            return None;
        }
        let mid = sizes.len() / 2;
        Some(*sizes.select_nth_unstable_by(mid, f64::total_cmp).1)
    }

    /// Where the mesh lies ([`Extent`]); an error when no node has a finite position.
    pub(crate) fn extent(&self) -> Result<Extent> {
        let (mut south, mut north) = finite_range(&self.lat);
        if !(south.is_finite() && north.is_finite()) {
            return Err(Error::invalid(
                "mesh",
                "no cell has nodes at finite positions",
            ));
        }
        let caps: Vec<f64> = (0..self.faces())
            .into_par_iter()
            .filter_map(|f| ring::round_pole(self, f))
            .collect();
        for pole in &caps {
            (south, north) = (south.min(*pole), north.max(*pole));
        }
        // Nodes at a pole (ring::at_a_pole) place it at ±90°, as the rings do.
        if ring::at_a_pole(south) {
            south = -90.0;
        }
        if ring::at_a_pole(north) {
            north = 90.0;
        }
        let polar = !caps.is_empty() || south == -90.0 || north == 90.0;
        // The longitudes' ranges in [0°, 360°) and in [−180°, 180°), in one pass.
        let widen = |(lo, hi): (f64, f64), v: f64| (lo.min(v), hi.max(v));
        let join = |a: (f64, f64), b: (f64, f64)| (a.0.min(b.0), a.1.max(b.1));
        let empty = (f64::INFINITY, f64::NEG_INFINITY);
        let (west, centred) = self
            .lon
            .par_iter()
            .filter(|l| l.is_finite())
            .fold(
                || (empty, empty),
                |(w, c), l| {
                    let west = l.rem_euclid(360.0);
                    let centred = if west >= 180.0 { west - 360.0 } else { west };
                    (widen(w, west), widen(c, centred))
                },
            )
            .reduce(
                || (empty, empty),
                |(w1, c1), (w2, c2)| (join(w1, w2), join(c1, c2)),
            );
        let ((a, b), (c, d)) = (west, centred);
        let lon = if b - a < d - c { (a, b) } else { (c, d) };
        Ok(Extent {
            south,
            north,
            lon,
            polar,
        })
    }

    /// One line for `hdrvis info` and a grid's name: convention, cells, nodes, where the values
    /// sit.
    pub fn describe(&self) -> String {
        let on = match self.location {
            Location::Faces => "cells",
            Location::Nodes => "nodes",
        };
        let paired = self
            .pairing
            .as_ref()
            .map_or(String::new(), |p| format!("; {p}"));
        format!(
            "{} mesh of {} cells and {} nodes, values on its {on} ({}{paired})",
            self.kind,
            self.faces(),
            self.lon.len(),
            self.dim
        )
    }
}

/// A field on a mesh, as `load_mesh` reads it: one value per cell or per node (as the mesh's
/// location says), its name and units, how the file's other dimensions were chosen, and the
/// mesh's spatial index ([`MeshIndex`]), built once when the field is made and shared by its
/// copies. `render_surface` draws it cell by cell.
#[derive(Clone)]
pub struct MeshField {
    pub(crate) mesh: Arc<Mesh>,
    pub(crate) values: Arc<Vec<f64>>,
    pub(crate) name: String,
    pub(crate) units: String,
    /// How each dimension other than the mesh's was chosen.
    pub(crate) notes: Vec<String>,
    pub(crate) index: Arc<MeshIndex>,
    /// The field sampled onto latitude and longitude at its cells' median size, once a 3-D view
    /// asked for it; shared by copies.
    pub(crate) sampled: Arc<OnceLock<Arc<Grid>>>,
    extent: Extent,
    id: u64,
}

impl MeshField {
    /// `values` (one per cell or node) on `mesh`, its index built; an error when the count is
    /// not the mesh's or no node has a finite position.
    pub(crate) fn new(
        mesh: Mesh,
        values: Vec<f64>,
        name: &str,
        units: &str,
        notes: Vec<String>,
    ) -> Result<MeshField> {
        if values.len() != mesh.values() {
            return Err(Error::invalid(
                name,
                format!(
                    "{} values on the {}; expected {}",
                    values.len(),
                    mesh.describe(),
                    mesh.values()
                ),
            ));
        }
        let extent = mesh.extent()?;
        let index = Arc::new(MeshIndex::new(&mesh, &extent));
        Ok(MeshField {
            sampled: Arc::new(OnceLock::new()),
            extent,
            mesh: Arc::new(mesh),
            values: Arc::new(values),
            name: name.to_string(),
            units: units.to_string(),
            notes,
            index,
            id: crate::model::grid::next_id(),
        })
    }

    pub fn name(&self) -> &str {
        &self.name
    }

    pub fn units(&self) -> &str {
        &self.units
    }

    pub fn mesh(&self) -> &Mesh {
        &self.mesh
    }

    /// One value per cell or node (NaN where missing).
    pub fn values(&self) -> &[f64] {
        &self.values
    }

    /// Where its mesh lies.
    pub(crate) fn extent(&self) -> Extent {
        self.extent
    }

    /// Identifies this field (its copies share it) for caches.
    pub fn id(&self) -> u64 {
        self.id
    }

    /// The least and greatest finite value, or `None` when every value is missing.
    pub fn range(&self) -> Option<(f64, f64)> {
        let (lo, hi) = finite_range(&self.values);
        (lo <= hi).then_some((lo, hi))
    }

    /// The value at `lon`, `lat` degrees (the cell's, or linear over its triangle for node
    /// data), or `None` outside every cell.
    pub fn value_at(&self, lon: f64, lat: f64) -> Option<f64> {
        let mut scratch = locate::Scratch::default();
        self.index
            .locate(&self.mesh, &self.values, [lon, lat], &mut scratch)
            .map(|(_, v)| v)
    }

    /// [`Self::value_at`] at every point (NaN outside), on every core.
    pub(crate) fn values_at(&self, points: &[[f64; 2]]) -> Vec<f64> {
        self.index.values_at(&self.mesh, &self.values, points)
    }

    /// One line: the variable, how it was chosen, and its mesh.
    pub fn describe(&self) -> String {
        let chosen = if self.notes.is_empty() {
            String::new()
        } else {
            format!(" at {}", self.notes.join(", "))
        };
        format!("{}{chosen} on the {}", self.name, self.mesh.describe())
    }
}

impl std::fmt::Debug for MeshField {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "MeshField({})", self.describe())
    }
}

/// A mesh of `cells` (node indices) over the given nodes, for tests.
#[cfg(test)]
pub(crate) fn test_mesh(
    lon: Vec<f64>,
    lat: Vec<f64>,
    cells: &[&[usize]],
    location: Location,
) -> Mesh {
    let mut offsets = vec![0];
    let mut nodes = Vec::new();
    for c in cells {
        nodes.extend_from_slice(c);
        offsets.push(nodes.len());
    }
    Mesh {
        kind: "test".into(),
        lon,
        lat,
        offsets,
        nodes,
        location,
        dim: "cell".into(),
        pairing: None,
    }
}
