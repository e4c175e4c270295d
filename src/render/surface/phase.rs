//! The f64 fringe maths: ν split for exact f32 phase products, the point and
//! footprint-filtered fringe references and the per-pixel gradient the fringe pass takes.

/// ν split into 12 + 12 significant bits and an f32 remainder (see the module notes).
pub(crate) fn split_nu(nu: f64) -> [f32; 3] {
    let lead = |x: f64| f32::from_bits((x as f32).to_bits() & 0xFFFF_F000);
    let a = lead(nu);
    let b = lead(nu - a as f64);
    let c = (nu - a as f64 - b as f64) as f32;
    [a, b, c]
}

/// The f64 reference: (1 + cos 2πν·d)/2 with the phase reduced before the cosine.
pub fn fringe_f64(nu: f64, d: f64) -> f64 {
    let ph = (nu * d).rem_euclid(1.0);
    0.5 + 0.5 * (std::f64::consts::TAU * (ph - ph.round())).cos()
}

/// Width of the pixel footprint the antialiased fringe averages over: a Gaussian of this σ, in
/// pixels, along the data's gradient.
pub(crate) const FOOTPRINT_SIGMA: f64 = 0.5;

/// The f64 reference of the antialiased fringe: the point fringe's contrast scaled by
/// exp(−2π²ν²σ²|∇d|²), the average of (1 + cos 2πν·d)/2 over a Gaussian footprint of σ =
/// [`FOOTPRINT_SIGMA`] pixel for a field linear across it; `gradient` is |∇d| in data units per
/// pixel.
pub fn fringe_filtered_f64(nu: f64, d: f64, gradient: f64) -> f64 {
    let s = nu * FOOTPRINT_SIGMA * gradient;
    let contrast = (-2.0 * std::f64::consts::PI.powi(2) * s * s).exp();
    0.5 + (fringe_f64(nu, d) - 0.5) * contrast
}

/// |∇d| at pixel (x, y) of a `width`-wide row-major plane (data units per pixel), as the fringe
/// pass takes it: central differences of the neighbours along each axis, one-sided where one
/// neighbour is missing (NaN) or off the image, 0 along an axis where both are.
pub fn pixel_gradient(values: &[f64], width: usize, x: usize, y: usize) -> f64 {
    let height = values.len() / width;
    let at = |x: usize, y: usize| values[y * width + x];
    let centre = at(x, y);
    let axis = |before: Option<f64>, after: Option<f64>| {
        let (b, a) = (
            before.filter(|v| v.is_finite()),
            after.filter(|v| v.is_finite()),
        );
        match (b, a) {
            (Some(b), Some(a)) => 0.5 * (a - b),
            (None, Some(a)) => a - centre,
            (Some(b), None) => centre - b,
            (None, None) => 0.0,
        }
    };
    let gx = axis(
        (x > 0).then(|| at(x - 1, y)),
        (x + 1 < width).then(|| at(x + 1, y)),
    );
    let gy = axis(
        (y > 0).then(|| at(x, y - 1)),
        (y + 1 < height).then(|| at(x, y + 1)),
    );
    gx.hypot(gy)
}
