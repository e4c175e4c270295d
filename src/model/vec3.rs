//! Small helpers on 3-vectors of f64 (`[f64; 3]`): difference, scaled sum, dot and cross
//! products, length and normalisation, a tangent frame, for cameras, geometry, generators,
//! meshes and CPU references.

pub(crate) fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// a + s·b.
pub(crate) fn add_scaled(a: [f64; 3], b: [f64; 3], s: f64) -> [f64; 3] {
    [a[0] + s * b[0], a[1] + s * b[1], a[2] + s * b[2]]
}

pub(crate) fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

pub(crate) fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// Euclidean length.
pub(crate) fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

/// `a` divided by its length (NaN for the zero vector).
pub(crate) fn normalize(a: [f64; 3]) -> [f64; 3] {
    let n = norm(a);
    [a[0] / n, a[1] / n, a[2] / n]
}

/// Two unit vectors perpendicular to the unit vector `p` and to each other, `p × e1 = e2`: a
/// right-handed frame of the plane tangent to the sphere at `p`.
pub(crate) fn tangent_basis(p: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    let helper = if p[2].abs() < 0.9 {
        [0.0, 0.0, 1.0]
    } else {
        [1.0, 0.0, 0.0]
    };
    let e1 = normalize(add_scaled(helper, p, -dot(helper, p)));
    (e1, cross(p, e1))
}
