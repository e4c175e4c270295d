//! The scalar volume: a regular grid of cell-centred voxels with spacing, origin, name and units.
//! A volume of n voxels with spacing s spans n·s along that axis, and voxel i samples the point
//! origin + (i + 0.5)·s. Values are stored as f32 in x-fastest order, the layout of a C-ordered
//! NumPy array of shape (nz, ny, nx); NaN and ±Inf mark missing values.

use super::geometry::Geometry;
use crate::error::{Error, Result};

/// Axis-aligned bounding box in world units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub lo: [f64; 3],
    pub hi: [f64; 3],
}

impl Aabb {
    /// Whether `p` lies in the box (its faces included).
    pub(crate) fn contains(&self, p: [f64; 3]) -> bool {
        (0..3).all(|a| p[a] >= self.lo[a] && p[a] <= self.hi[a])
    }

    pub fn size(&self) -> [f64; 3] {
        [
            self.hi[0] - self.lo[0],
            self.hi[1] - self.lo[1],
            self.hi[2] - self.lo[2],
        ]
    }

    pub(crate) fn center(&self) -> [f64; 3] {
        [
            0.5 * (self.lo[0] + self.hi[0]),
            0.5 * (self.lo[1] + self.hi[1]),
            0.5 * (self.lo[2] + self.hi[2]),
        ]
    }

    pub(crate) fn diagonal(&self) -> f64 {
        let s = self.size();
        (s[0] * s[0] + s[1] * s[1] + s[2] * s[2]).sqrt()
    }

    /// Parametric entry and exit of the ray o + t·d (slab method); `None` when it misses.
    pub(crate) fn intersect(&self, o: [f64; 3], d: [f64; 3]) -> Option<(f64, f64)> {
        let mut t0 = f64::NEG_INFINITY;
        let mut t1 = f64::INFINITY;
        for a in 0..3 {
            let inv = 1.0 / d[a];
            let ta = (self.lo[a] - o[a]) * inv;
            let tb = (self.hi[a] - o[a]) * inv;
            // A ray parallel to a slab and outside it gives NaN here; treat it as a miss.
            let (near, far) = if ta <= tb { (ta, tb) } else { (tb, ta) };
            if near.is_nan() || far.is_nan() {
                if o[a] < self.lo[a] || o[a] > self.hi[a] {
                    return None;
                }
                continue;
            }
            t0 = t0.max(near);
            t1 = t1.min(far);
        }
        (t1 > t0).then_some((t0, t1))
    }
}

/// Summary statistics over the finite voxels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VolumeStats {
    pub min: f64,
    pub max: f64,
    /// Smallest strictly positive value, the natural lower end of a log scale.
    pub min_positive: Option<f64>,
    /// Smallest non-zero magnitude, the natural linear threshold of a symlog scale.
    pub min_abs_nonzero: Option<f64>,
    pub finite: usize,
    pub non_finite: usize,
}

impl VolumeStats {
    /// The statistics of no values: the identity of [`VolumeStats::merge`].
    pub(crate) const EMPTY: VolumeStats = VolumeStats {
        min: f64::INFINITY,
        max: f64::NEG_INFINITY,
        min_positive: None,
        min_abs_nonzero: None,
        finite: 0,
        non_finite: 0,
    };

    /// The statistics of `values`, serially (callers split large arrays and merge).
    pub(crate) fn of_values(values: &[f32]) -> VolumeStats {
        let mut s = VolumeStats::EMPTY;
        for &v in values {
            if !v.is_finite() {
                s.non_finite += 1;
                continue;
            }
            let v = v as f64;
            s.finite += 1;
            s.min = s.min.min(v);
            s.max = s.max.max(v);
            if v > 0.0 {
                s.min_positive = min_opt(s.min_positive, Some(v));
            }
            if v != 0.0 {
                s.min_abs_nonzero = min_opt(s.min_abs_nonzero, Some(v.abs()));
            }
        }
        s
    }

    /// The statistics of `values` in parallel chunks.
    pub(crate) fn of_values_par(values: &[f32]) -> VolumeStats {
        use rayon::prelude::*;
        values
            .par_chunks(1 << 16)
            .map(VolumeStats::of_values)
            .reduce(|| VolumeStats::EMPTY, VolumeStats::merge)
    }

    /// The statistics of two sets of values together.
    pub(crate) fn merge(self, b: VolumeStats) -> VolumeStats {
        VolumeStats {
            min: self.min.min(b.min),
            max: self.max.max(b.max),
            min_positive: min_opt(self.min_positive, b.min_positive),
            min_abs_nonzero: min_opt(self.min_abs_nonzero, b.min_abs_nonzero),
            finite: self.finite + b.finite,
            non_finite: self.non_finite + b.non_finite,
        }
    }
}

fn min_opt(a: Option<f64>, b: Option<f64>) -> Option<f64> {
    match (a, b) {
        (Some(x), Some(y)) => Some(x.min(y)),
        (x, None) => x,
        (None, y) => y,
    }
}

/// How trilinear sampling treats missing (non-finite) voxels among a sample's eight neighbours.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Missing {
    /// Any missing neighbour makes the sample missing.
    #[default]
    Strict,
    /// The weights of the finite neighbours are renormalised to sum to one, so a missing voxel
    /// removes only its own share of each sample of the cells around it; a sample whose every
    /// weighted neighbour is missing is missing.
    Renormalise,
}

impl Missing {
    pub(crate) const NAMES: &'static [&'static str] = &["strict", "renormalise"];

    /// The rule named `name` (one of [`Missing::NAMES`]).
    pub fn parse(name: &str) -> Result<Missing> {
        match name {
            "strict" => Ok(Missing::Strict),
            "renormalise" => Ok(Missing::Renormalise),
            other => Err(Error::invalid(
                "missing",
                format!("unknown rule {other:?}; expected \"strict\" or \"renormalise\""),
            )),
        }
    }
}

#[derive(Clone, Debug)]
pub struct Volume {
    pub name: String,
    pub units: String,
    /// Voxel counts (nx, ny, nz).
    pub dims: [usize; 3],
    /// Voxel size along x, y, z in world units.
    pub spacing: [f64; 3],
    /// World position of the volume's lower corner (not of the first voxel centre).
    pub origin: [f64; 3],
    pub data: Vec<f32>,
    /// Where the voxels lie: a regular box unless a reader found other coordinates.
    pub geometry: Geometry,
}

/// Largest voxel count per axis accepted anywhere; far beyond any file a user has, small enough
/// that products cannot overflow.
pub(crate) const MAX_DIM: usize = 1 << 16;

impl Volume {
    /// Builds a volume after checking dims, spacing and data length.
    pub fn new(
        name: impl Into<String>,
        dims: [usize; 3],
        spacing: [f64; 3],
        origin: [f64; 3],
        data: Vec<f32>,
    ) -> Result<Self> {
        check_dims(&dims, "dims")?;
        for (a, s) in spacing.iter().enumerate() {
            if !(s.is_finite() && *s > 0.0) {
                return Err(Error::invalid(
                    format!("spacing[{a}]"),
                    format!("expected a finite value > 0, got {s}"),
                ));
            }
        }
        if origin.iter().any(|o| !o.is_finite()) {
            return Err(Error::invalid("origin", "expected finite coordinates"));
        }
        let n = dims[0] * dims[1] * dims[2];
        if data.len() != n {
            return Err(Error::invalid(
                "data",
                format!(
                    "expected {n} values for dims {}x{}x{}, got {}",
                    dims[0],
                    dims[1],
                    dims[2],
                    data.len()
                ),
            ));
        }
        Ok(Volume {
            name: name.into(),
            units: String::new(),
            dims,
            spacing,
            origin,
            data,
            geometry: Geometry::Regular,
        })
    }

    /// The volume with its voxels placed by `geometry`, after checking that the axes match the
    /// voxel counts.
    pub fn with_geometry(mut self, geometry: Geometry) -> Result<Self> {
        let lengths: [usize; 3] = match &geometry {
            Geometry::Regular => self.dims,
            Geometry::Rectilinear(axes) => [axes[0].len(), axes[1].len(), axes[2].len()],
            Geometry::Spherical(g) => {
                g.check("geometry")?;
                let mut n = [0; 3];
                n[g.axis_of[0]] = g.radius.len();
                n[g.axis_of[1]] = g.latitude.len();
                n[g.axis_of[2]] = g.longitude.len();
                n
            }
        };
        if lengths != self.dims {
            return Err(Error::invalid(
                "geometry",
                format!(
                    "coordinate axes of lengths {lengths:?} do not match the voxel counts {:?}",
                    self.dims
                ),
            ));
        }
        self.geometry = geometry;
        Ok(self)
    }

    /// Builds a unit-spacing volume at the origin by evaluating `f(x, y, z)` at voxel centres.
    pub fn from_fn(
        name: &str,
        dims: [usize; 3],
        f: impl Fn(f64, f64, f64) -> f64 + Sync,
    ) -> Result<Self> {
        use rayon::prelude::*;
        check_dims(&dims, "dims")?;
        let [nx, ny, nz] = dims;
        let mut data = vec![0f32; nx * ny * nz];
        data.par_chunks_mut(nx * ny)
            .enumerate()
            .for_each(|(k, slab)| {
                for j in 0..ny {
                    for i in 0..nx {
                        slab[j * nx + i] = f(i as f64 + 0.5, j as f64 + 0.5, k as f64 + 0.5) as f32;
                    }
                }
            });
        Volume::new(name, dims, [1.0; 3], [0.0; 3], data)
    }

    pub(crate) fn voxel_count(&self) -> usize {
        self.dims[0] * self.dims[1] * self.dims[2]
    }

    pub fn index(&self, i: usize, j: usize, k: usize) -> usize {
        (k * self.dims[1] + j) * self.dims[0] + i
    }

    pub fn bounds(&self) -> Aabb {
        match &self.geometry {
            Geometry::Regular => {}
            Geometry::Rectilinear(axes) => {
                return Aabb {
                    lo: [axes[0].lo, axes[1].lo, axes[2].lo],
                    hi: [axes[0].hi, axes[1].hi, axes[2].hi],
                }
            }
            Geometry::Spherical(g) => {
                let (lo, hi) = g.bounds();
                return Aabb { lo, hi };
            }
        }
        let mut hi = [0.0; 3];
        for (a, h) in hi.iter_mut().enumerate() {
            *h = self.origin[a] + self.dims[a] as f64 * self.spacing[a];
        }
        Aabb {
            lo: self.origin,
            hi,
        }
    }

    /// The length of one "voxel" for step sizes and optical depths: the smallest spacing (of a
    /// shell, the smallest radial spacing).
    pub(crate) fn voxel_length(&self) -> f64 {
        match &self.geometry {
            Geometry::Regular => self.spacing.iter().cloned().fold(f64::INFINITY, f64::min),
            Geometry::Rectilinear(axes) => axes
                .iter()
                .map(|a| a.min_spacing())
                .fold(f64::INFINITY, f64::min),
            Geometry::Spherical(g) => g.length_scale(),
        }
    }

    /// Whether the voxels sit on the regular grid of `origin` and `spacing`.
    pub fn is_regular(&self) -> bool {
        matches!(self.geometry, Geometry::Regular)
    }

    pub fn stats(&self) -> VolumeStats {
        VolumeStats::of_values_par(&self.data)
    }

    /// Value at voxel (i, j, k) with indices clamped to the grid, as clamp-to-edge texturing does.
    #[cfg(test)]
    pub(crate) fn voxel_clamped(&self, i: i64, j: i64, k: i64) -> f32 {
        let c = |v: i64, n: usize| v.clamp(0, n as i64 - 1) as usize;
        self.data[self.index(c(i, self.dims[0]), c(j, self.dims[1]), c(k, self.dims[2]))]
    }

    /// Exact trilinear interpolation in f64 at world position `p`, cell-centred, clamp-to-edge.
    /// Any non-finite voxel among the eight neighbours makes the sample non-finite (missing).
    /// Gradient of the trilinear field at `p` by central differences one voxel apart along each
    /// axis (the shading normal; the shader takes the same differences).
    pub fn gradient(&self, p: [f64; 3]) -> [f64; 3] {
        let mut g = [0.0; 3];
        for (a, ga) in g.iter_mut().enumerate() {
            let h = self.spacing[a];
            let (mut lo, mut hi) = (p, p);
            lo[a] -= h;
            hi[a] += h;
            *ga = (self.sample_trilinear(hi) - self.sample_trilinear(lo)) / (2.0 * h);
        }
        g
    }

    /// The fractional voxel indices (cell centre i at i) of world point `p`, through the
    /// volume's geometry.
    pub(crate) fn fractional_indices(&self, p: [f64; 3]) -> [f64; 3] {
        match &self.geometry {
            Geometry::Regular => [0, 1, 2].map(|a| (p[a] - self.origin[a]) / self.spacing[a] - 0.5),
            Geometry::Rectilinear(axes) => [0, 1, 2].map(|a| axes[a].fractional_index(p[a])),
            Geometry::Spherical(g) => g.fractional_indices(p),
        }
    }

    /// Exact trilinear interpolation in f64 at world position `p` through any geometry:
    /// trilinear in index space, clamp-to-edge, the longitude of a full circle periodic.
    /// Non-finite like [`Self::sample_trilinear`].
    pub(crate) fn sample_world(&self, p: [f64; 3]) -> f64 {
        self.sample_world_with(p, Missing::Strict)
    }

    /// [`Self::sample_world`] with missing voxels treated as `missing` says.
    pub(crate) fn sample_world_with(&self, p: [f64; 3], missing: Missing) -> f64 {
        let g = self.fractional_indices(p);
        let wrap_axis = match &self.geometry {
            Geometry::Spherical(s) if s.lon_wraps => Some(s.axis_of[2]),
            _ => None,
        };
        self.interpolate(g, wrap_axis, missing)
    }

    /// Trilinear interpolation at fractional indices `g`, periodic along `wrap_axis`. With
    /// [`Missing::Renormalise`] the weights of the finite corners are divided by their sum; a
    /// missing corner of weight zero (a sample on the far face of its cell) changes nothing.
    fn interpolate(&self, g: [f64; 3], wrap_axis: Option<usize>, missing: Missing) -> f64 {
        let mut base = [0i64; 3];
        let mut frac = [0f64; 3];
        for a in 0..3 {
            let f = g[a].floor();
            base[a] = f as i64;
            frac[a] = g[a] - f;
        }
        let index = |a: usize, i: i64| -> usize {
            let n = self.dims[a] as i64;
            if wrap_axis == Some(a) {
                i.rem_euclid(n) as usize
            } else {
                i.clamp(0, n - 1) as usize
            }
        };
        let (mut acc, mut finite_weight, mut any_missing) = (0.0, 0.0, false);
        for corner in 0..8 {
            let di = corner & 1;
            let dj = (corner >> 1) & 1;
            let dk = (corner >> 2) & 1;
            let w = (if di == 1 { frac[0] } else { 1.0 - frac[0] })
                * (if dj == 1 { frac[1] } else { 1.0 - frac[1] })
                * (if dk == 1 { frac[2] } else { 1.0 - frac[2] });
            let v = self.data[self.index(
                index(0, base[0] + di as i64),
                index(1, base[1] + dj as i64),
                index(2, base[2] + dk as i64),
            )] as f64;
            if !v.is_finite() {
                match missing {
                    Missing::Strict => return f64::NAN,
                    Missing::Renormalise => {
                        any_missing |= w > 0.0;
                        continue;
                    }
                }
            }
            acc += w * v;
            finite_weight += w;
        }
        match (any_missing, finite_weight > 0.0) {
            // All finite: the plain sum, bit for bit the strict value.
            (false, _) => acc,
            (true, true) => acc / finite_weight,
            (true, false) => f64::NAN,
        }
    }

    /// Gradient in world space by central differences one voxel length apart along each
    /// world axis, through any geometry.
    pub(crate) fn gradient_world(&self, p: [f64; 3]) -> [f64; 3] {
        if self.is_regular() {
            return self.gradient(p);
        }
        let h = self.voxel_length();
        let mut g = [0.0; 3];
        for (a, ga) in g.iter_mut().enumerate() {
            let (mut lo, mut hi) = (p, p);
            lo[a] -= h;
            hi[a] += h;
            *ga = (self.sample_world(hi) - self.sample_world(lo)) / (2.0 * h);
        }
        g
    }

    pub(crate) fn sample_trilinear(&self, p: [f64; 3]) -> f64 {
        self.interpolate(self.fractional_indices(p), None, Missing::Strict)
    }
}

/// One line for people: name, geometry, shape, units, value range and, for shells, the radii
/// and angles they span.
impl std::fmt::Display for Volume {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let [nx, ny, nz] = self.dims;
        write!(
            f,
            "Volume \"{}\" {} {nx}x{ny}x{nz}",
            self.name,
            self.geometry.name()
        )?;
        if !self.units.is_empty() {
            write!(f, ", units {}", self.units)?;
        }
        let s = self.stats();
        if s.finite > 0 {
            write!(f, ", range [{:.6e}, {:.6e}]", s.min, s.max)?;
        }
        if s.non_finite > 0 {
            write!(f, ", {} missing", s.non_finite)?;
        }
        match &self.geometry {
            Geometry::Regular => {
                let b = self.bounds();
                write!(f, ", box {:?} to {:?}", b.lo, b.hi)
            }
            Geometry::Rectilinear(_) => {
                let b = self.bounds();
                write!(f, ", rectilinear box {:?} to {:?}", b.lo, b.hi)
            }
            Geometry::Spherical(g) => write!(f, ", {g}"),
        }
    }
}

/// Rejects zero or absurd dimensions, and volumes larger than the memory this machine has,
/// before anything is allocated.
pub(crate) fn check_dims(dims: &[usize], field: &str) -> Result<()> {
    check_shape(dims, field)?;
    let bytes = dims.iter().product::<usize>() as u64 * 4;
    check_allocation(bytes, field)
}

/// Rejects zero or absurd dimensions without asking whether the voxels fit in memory (bricked
/// volumes stream them).
pub(crate) fn check_shape(dims: &[usize], field: &str) -> Result<()> {
    for (a, &n) in dims.iter().enumerate() {
        if n == 0 || n > MAX_DIM {
            return Err(Error::invalid(
                field,
                format!("axis {a} has {n} voxels; expected 1 to {MAX_DIM}"),
            ));
        }
    }
    Ok(())
}

/// Refuses an allocation that would exceed the memory currently available to this process: the
/// least of the machine's available memory (`/proc/meminfo`), what its cgroup may still take
/// (v2 `memory.max` less `memory.current`) and what its address-space and data limits leave
/// (`ulimit -v`, `-d`, less what it holds); elsewhere than Linux it allows everything. A refusal
/// is a one-line error instead of an abort part-way through the allocation.
pub(crate) fn check_allocation(bytes: u64, what: &str) -> Result<()> {
    if let Some(avail) = available_memory_bytes() {
        if bytes > avail {
            return Err(Error::invalid(
                what,
                format!(
                    "needs {:.1} GiB but only {:.1} GiB of memory is available",
                    bytes as f64 / (1u64 << 30) as f64,
                    avail as f64 / (1u64 << 30) as f64
                ),
            ));
        }
    }
    Ok(())
}

/// The memory this process may still allocate (see [`check_allocation`]); `None` where unknown.
pub(crate) fn available_memory_bytes() -> Option<u64> {
    [meminfo_available(), cgroup_available(), rlimit_available()]
        .into_iter()
        .flatten()
        .min()
}

/// The `key:` line of a `/proc` status-like text, in bytes (its value is in kB).
fn proc_kib(text: &str, key: &str) -> Option<u64> {
    let line = text.lines().find(|l| l.starts_with(key))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

fn meminfo_available() -> Option<u64> {
    proc_kib(
        &std::fs::read_to_string("/proc/meminfo").ok()?,
        "MemAvailable:",
    )
}

/// What this process's cgroup (v2) may still take: `memory.max` less `memory.current`.
fn cgroup_available() -> Option<u64> {
    let cgroups = std::fs::read_to_string("/proc/self/cgroup").ok()?;
    let path = cgroups.lines().find_map(|l| l.strip_prefix("0::"))?;
    let dir = std::path::Path::new("/sys/fs/cgroup").join(path.trim_start_matches('/'));
    let read = |name: &str| std::fs::read_to_string(dir.join(name)).ok();
    let max: u64 = read("memory.max")?.trim().parse().ok()?; // "max": no limit
    let current: u64 = read("memory.current")?.trim().parse().ok()?;
    Some(max.saturating_sub(current))
}

/// What the address-space and data-segment limits leave beside what the process holds.
fn rlimit_available() -> Option<u64> {
    use rustix::process::{getrlimit, Resource};
    let left = |resource, held: Option<u64>| {
        getrlimit(resource)
            .current
            .map(|limit| limit.saturating_sub(held.unwrap_or(0)))
    };
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    let address_space = left(Resource::As, proc_kib(&status, "VmSize:"));
    let data = left(Resource::Data, proc_kib(&status, "VmData:"));
    [address_space, data].into_iter().flatten().min()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bounds_and_voxel_centres() {
        let v = Volume::new(
            "v",
            [4, 2, 3],
            [0.5, 1.0, 2.0],
            [1.0, 0.0, -3.0],
            vec![0.0; 24],
        )
        .unwrap();
        let b = v.bounds();
        assert_eq!(b.lo, [1.0, 0.0, -3.0]);
        assert_eq!(b.hi, [3.0, 2.0, 3.0]);
        assert_eq!(v.voxel_length(), 0.5);
    }

    #[test]
    fn trilinear_reproduces_linear_fields_and_voxel_values() {
        let v = Volume::from_fn("ramp", [5, 6, 7], |x, y, z| 2.0 * x - y + 0.5 * z).unwrap();
        // At voxel centres it returns the voxel; between them, linear fields are exact.
        assert!((v.sample_trilinear([2.5, 3.5, 4.5]) - (5.0 - 3.5 + 2.25)).abs() < 1e-12);
        assert!((v.sample_trilinear([1.7, 2.2, 3.9]) - (3.4 - 2.2 + 1.95)).abs() < 1e-6);
    }

    #[test]
    fn refuses_zero_and_absurd_dims() {
        assert!(Volume::new("v", [0, 1, 1], [1.0; 3], [0.0; 3], vec![]).is_err());
        let err = check_dims(&[60000, 60000, 60000], "dims").unwrap_err();
        assert!(err.to_string().contains("GiB"), "{err}");
    }

    #[test]
    fn stats_skip_missing_values() {
        let v = Volume::new(
            "v",
            [4, 1, 1],
            [1.0; 3],
            [0.0; 3],
            vec![f32::NAN, -2.0, 1e-20, 5.0],
        )
        .unwrap();
        let s = v.stats();
        assert_eq!((s.min, s.max, s.non_finite, s.finite), (-2.0, 5.0, 1, 3));
        assert_eq!(s.min_positive, Some(1e-20f32 as f64));
    }

    #[test]
    fn ray_box_intersection() {
        let b = Aabb {
            lo: [0.0; 3],
            hi: [2.0; 3],
        };
        assert_eq!(
            b.intersect([1.0, 1.0, 5.0], [0.0, 0.0, -1.0]),
            Some((3.0, 5.0))
        );
        assert_eq!(b.intersect([3.0, 1.0, 5.0], [0.0, 0.0, -1.0]), None);
    }
}
