//! Special functions and a small random generator shared by the generators and references:
//! the error function and its complement, associated Legendre functions in the normalisation of
//! spherical-harmonic convection codes, and SplitMix64.

use std::f64::consts::{PI, TAU};

/// The least and greatest finite value (infinite when there is none).
pub(crate) fn finite_range(values: &[f64]) -> (f64, f64) {
    values
        .iter()
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(*v), hi.max(*v))
        })
}

/// Associated Legendre function in the normalisation of CitcomS, the code of the Zhong et al.
/// (2008) benchmark, whose initial perturbation uses it: P_lm(x) = sqrt((2 - delta_m0) (2l + 1)
/// (l - m)! / (4 pi (l + m)!)) P_l^m(x), with the Condon-Shortley phase (-1)^m in P_l^m. The real
/// harmonics P_lm(cos theta) cos(m phi) and P_lm(cos theta) sin(m phi) then integrate to 1 in
/// square over the unit sphere. For (3, 2) this is 15 sqrt(7 / (240 pi)) x (1 - x^2), at most
/// 0.556 in magnitude, so the eps = 0.01 perturbation peaks at 0.0079 (with the sqrt(2) of
/// cos + sin).
pub(crate) fn normalized_legendre(degree: usize, order: usize, x: f64) -> f64 {
    if order > degree {
        return 0.0;
    }
    let sine = ((1.0 - x) * (1.0 + x)).max(0.0).sqrt();
    // Recurrence on functions already normalised to (2l + 1)(l - m)!/(l + m)! = 1 so that no
    // factorial overflows: start from the sectoral term and climb in degree.
    let mut sectoral = 1.0;
    for k in 1..=order {
        let k = k as f64;
        sectoral *= -sine * ((2.0 * k + 1.0) / (2.0 * k)).sqrt();
    }
    let mut previous = 0.0;
    let mut current = sectoral;
    let m = order as f64;
    for l in (order + 1)..=degree {
        let l = l as f64;
        let a = ((4.0 * l * l - 1.0) / (l * l - m * m)).sqrt();
        let b = ((2.0 * l + 1.0) * ((l - 1.0) * (l - 1.0) - m * m)
            / ((2.0 * l - 3.0) * (l * l - m * m)))
            .sqrt();
        let next = a * x * current - b * previous;
        previous = current;
        current = next;
    }
    let order_factor = if order == 0 { 1.0 } else { 2.0_f64.sqrt() };
    current * order_factor / (4.0 * PI).sqrt()
}

/// Error function, to better than 1e-13 absolute: the Maclaurin series below 3, and above it one
/// minus the continued fraction of erfc (Abramowitz & Stegun 7.1.5 and 7.1.14).
pub(crate) fn erf(x: f64) -> f64 {
    if x < 0.0 {
        return -erf(-x);
    }
    if x < 3.0 {
        let x2 = x * x;
        let mut term = x;
        let mut sum = x;
        let mut n = 0.0;
        while term.abs() > 1e-17 * sum.abs() {
            n += 1.0;
            term *= -x2 / n;
            sum += term / (2.0 * n + 1.0);
        }
        sum * 2.0 / PI.sqrt()
    } else {
        1.0 - erfc_continued_fraction(x)
    }
}

/// Complementary error function for x >= 0, keeping its relative accuracy in the far tail.
pub(crate) fn erfc(x: f64) -> f64 {
    if x >= 3.0 {
        erfc_continued_fraction(x)
    } else {
        1.0 - erf(x)
    }
}

fn erfc_continued_fraction(x: f64) -> f64 {
    // erfc(x) = exp(-x^2)/sqrt(pi) / (x + (1/2)/(x + 1/(x + (3/2)/(x + ...)))), summed from the
    // tail; 60 levels converge to round-off for x >= 3.
    let mut tail = x;
    for k in (1..=60).rev() {
        tail = x + (k as f64 * 0.5) / tail;
    }
    (-x * x).exp() / (PI.sqrt() * tail)
}

/// Small deterministic generator (SplitMix64, Steele, Lea & Flood 2014): enough quality for
/// placing a few dozen features and the fuzz corpus's mutations, and identical on every platform.
pub struct SplitMix64(pub u64);

impl SplitMix64 {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1) from the top 53 bits.
    pub(crate) fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    pub(crate) fn between(&mut self, low: f64, high: f64) -> f64 {
        low + (high - low) * self.unit()
    }

    pub(crate) fn direction(&mut self) -> [f64; 3] {
        let z = 2.0 * self.unit() - 1.0;
        let phi = TAU * self.unit();
        let s = (1.0 - z * z).max(0.0).sqrt();
        [s * phi.cos(), s * phi.sin(), z]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn erf_matches_tables() {
        // Abramowitz & Stegun, table 7.1, and erfc tail values.
        assert!((erf(0.5) - 0.520_499_877_813_046_5).abs() < 1e-14);
        assert!((erf(1.0) - 0.842_700_792_949_714_9).abs() < 1e-14);
        assert!((erf(2.0) - 0.995_322_265_018_952_7).abs() < 1e-14);
        assert!((erfc(3.0) / 2.209_049_699_858_544e-5 - 1.0).abs() < 1e-12);
        assert!((erfc(5.0) / 1.537_459_794_428_035e-12 - 1.0).abs() < 1e-12);
        assert!((erf(-1.0) + erf(1.0)).abs() < 1e-16);
    }

    #[test]
    fn legendre_normalisation_matches_citcoms_convention() {
        // Closed form for (3, 2): 15 sqrt(7 / (240 pi)) x (1 - x^2).
        for x in [-0.9, -0.3, 0.0, 0.2, 0.577, 0.99] {
            let closed = 15.0 * (7.0 / (240.0 * PI)).sqrt() * x * (1.0 - x * x);
            assert!((normalized_legendre(3, 2, x) - closed).abs() < 1e-14);
        }
        assert!((normalized_legendre(0, 0, 0.3) - 1.0 / (4.0 * PI).sqrt()).abs() < 1e-15);
        // Condon-Shortley phase: P_11 = -sqrt(3 / (4 pi)) sin(theta) in this normalisation.
        let sine = (1.0f64 - 0.36).sqrt();
        assert!((normalized_legendre(1, 1, 0.6) + (3.0 / (4.0 * PI)).sqrt() * sine).abs() < 1e-14);
        // Unit integral over the sphere of the real harmonic: pi (m > 0) or 2 pi (m = 0) times
        // the integral over x of P_lm^2; midpoint rule on a polynomial integrand.
        for (l, m) in [(3, 2), (4, 0), (4, 4), (12, 5)] {
            let steps = 20_000;
            let integral: f64 = (0..steps)
                .map(|s| {
                    let x = -1.0 + (s as f64 + 0.5) * 2.0 / steps as f64;
                    normalized_legendre(l, m, x).powi(2) * 2.0 / steps as f64
                })
                .sum();
            let azimuthal = if m == 0 { TAU } else { PI };
            assert!((integral * azimuthal - 1.0).abs() < 1e-6, "l={l} m={m}");
        }
    }
}
