//! Sort-last compositing of the partial images of a distributed render onto rank 0. Rank r
//! ray-casts the r-th slab of the volume along z, so the ranks are in slab order, and a partial
//! pixel holds the premultiplied colour and optical depth of the ray's segments in that slab;
//! the sign bit of the depth says whether the ray runs towards -z (then the higher slab is in
//! front). Two partials join with the over operator of emission–absorption,
//! `C = C_front + e^(-tau_front) C_back`, `tau = tau_front + tau_back`, which is associative, so
//! any grouping of neighbouring slabs gives the same image:
//!
//! * binary-swap (rank counts that are powers of two): log₂ N rounds, in each a rank swaps half
//!   of the image region it still owns with the partner whose slab block neighbours its own;
//! * direct-send (any rank count): the image is cut into N pieces, every rank sends piece j to
//!   rank j, which joins the N partials of its piece in slab order.
//!
//! Either ends with each rank owning a finished piece, gathered on rank 0.

use super::exchange::Exchange;
use crate::error::{Error, Result};
use std::ops::Range;

/// A partial or composited pixel: premultiplied colour and signed optical depth.
pub(crate) type Partial = [f32; 4];

/// How the partial images are composited.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scheme {
    BinarySwap,
    DirectSend,
}

impl Scheme {
    /// Binary-swap for powers of two, direct-send for other rank counts.
    pub(crate) fn for_ranks(n: usize) -> Scheme {
        if n.is_power_of_two() {
            Scheme::BinarySwap
        } else {
            Scheme::DirectSend
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Scheme::BinarySwap => "binary-swap",
            Scheme::DirectSend => "direct-send",
        }
    }

    pub fn parse(s: &str) -> Result<Scheme> {
        match s {
            "binary-swap" => Ok(Scheme::BinarySwap),
            "direct-send" => Ok(Scheme::DirectSend),
            _ => Err(Error::invalid(
                "scheme",
                format!("expected binary-swap or direct-send, got {s}"),
            )),
        }
    }
}

/// The lower slab's partial `lower` joined with the next slab's `upper`, in the ray's
/// visibility order.
pub fn join(lower: Partial, upper: Partial) -> Partial {
    let towards_minus_z = lower[3].is_sign_negative();
    let (front, back) = if towards_minus_z {
        (upper, lower)
    } else {
        (lower, upper)
    };
    let tau_front = f64::from(front[3].abs());
    let through = (-tau_front).exp();
    let c = |i: usize| (f64::from(front[i]) + through * f64::from(back[i])) as f32;
    let tau = front[3].abs() + back[3].abs();
    [c(0), c(1), c(2), tau.copysign(lower[3])]
}

/// The finished pixel of a composited ray: colour over `background` and alpha 1 - e^-tau, as
/// the single-process ray caster leaves it.
pub(crate) fn finish(p: Partial, background: [f64; 3]) -> [f32; 4] {
    let tau = f64::from(p[3].abs());
    let through = (-tau).exp();
    let c = |i: usize| (f64::from(p[i]) + through * background[i]) as f32;
    [c(0), c(1), c(2), (-(-tau).exp_m1()) as f32]
}

fn bytes(pixels: &[Partial]) -> &[u8] {
    bytemuck::cast_slice(pixels)
}

fn pixels(bytes: &[u8], expected: usize, from: usize) -> Result<Vec<Partial>> {
    if bytes.len() != expected * 16 {
        return Err(Error::invalid(
            "distributed",
            format!(
                "rank {from} sent {} bytes of partial image, expected {}",
                bytes.len(),
                expected * 16
            ),
        ));
    }
    Ok(bytemuck::pod_collect_to_vec(bytes))
}

/// Composites this rank's partial image with every other rank's (all the same size, one per
/// slab, rank order = slab order); rank 0 gets the composited image, the others `None`.
pub fn composite(
    ex: &dyn Exchange,
    mut image: Vec<Partial>,
    scheme: Scheme,
) -> Result<Option<Vec<Partial>>> {
    let n = ex.size();
    if n == 1 {
        return Ok(Some(image));
    }
    let owned = match scheme {
        Scheme::BinarySwap => {
            if !n.is_power_of_two() {
                return Err(Error::invalid(
                    "scheme",
                    format!("binary-swap needs a power-of-two rank count, not {n}"),
                ));
            }
            binary_swap(ex, &mut image)?
        }
        Scheme::DirectSend => direct_send(ex, &mut image)?,
    };
    gather(ex, image, owned)
}

/// Binary-swap: returns the region of `image` this rank holds finished.
fn binary_swap(ex: &dyn Exchange, image: &mut [Partial]) -> Result<Range<usize>> {
    let (rank, n) = (ex.rank(), ex.size());
    let mut region = 0..image.len();
    let mut bit = 1;
    while bit < n {
        let partner = rank ^ bit;
        let mid = region.start + region.len() / 2;
        let (keep, give) = if rank & bit == 0 {
            (region.start..mid, mid..region.end)
        } else {
            (mid..region.end, region.start..mid)
        };
        let got = ex.send_recv(partner, bytes(&image[give]), partner)?;
        let got = pixels(&got, keep.len(), partner)?;
        // The partner's block of slabs lies wholly below or above this rank's.
        for (p, theirs) in image[keep.clone()].iter_mut().zip(got) {
            *p = if partner < rank {
                join(theirs, *p)
            } else {
                join(*p, theirs)
            };
        }
        region = keep;
        bit <<= 1;
    }
    Ok(region)
}

/// Piece `j` of `n` of an image of `len` pixels.
fn piece(j: usize, n: usize, len: usize) -> Range<usize> {
    j * len / n..(j + 1) * len / n
}

/// Direct-send: returns the piece of `image` this rank holds finished.
fn direct_send(ex: &dyn Exchange, image: &mut [Partial]) -> Result<Range<usize>> {
    let (rank, n) = (ex.rank(), ex.size());
    let mine = piece(rank, n, image.len());
    let mut partials: Vec<Vec<Partial>> = vec![Vec::new(); n];
    // Step s: send to rank + s, receive from rank - s, so every pair meets once.
    for s in 1..n {
        let to = (rank + s) % n;
        let from = (rank + n - s) % n;
        let got = ex.send_recv(to, bytes(&image[piece(to, n, image.len())]), from)?;
        partials[from] = pixels(&got, mine.len(), from)?;
    }
    partials[rank] = image[mine.clone()].to_vec();
    let mut joined = partials.remove(0);
    for upper in partials {
        for (p, u) in joined.iter_mut().zip(upper) {
            *p = join(*p, u);
        }
    }
    image[mine.clone()].copy_from_slice(&joined);
    Ok(mine)
}

/// Every rank's finished region sent to rank 0, which assembles the image.
fn gather(
    ex: &dyn Exchange,
    image: Vec<Partial>,
    owned: Range<usize>,
) -> Result<Option<Vec<Partial>>> {
    if ex.rank() != 0 {
        let mut msg = (owned.start as u64).to_le_bytes().to_vec();
        msg.extend_from_slice(bytes(&image[owned]));
        ex.send(0, &msg)?;
        return Ok(None);
    }
    let mut out = image;
    for from in 1..ex.size() {
        let msg = ex.recv(from)?;
        let bad = || {
            Error::invalid(
                "distributed",
                format!("rank {from} sent a malformed image piece"),
            )
        };
        let head: [u8; 8] = msg
            .get(..8)
            .and_then(|h| h.try_into().ok())
            .ok_or_else(bad)?;
        let start = u64::from_le_bytes(head) as usize;
        let body = &msg[8..];
        let len = body.len() / 16;
        if body.len() % 16 != 0 || start + len > out.len() {
            return Err(bad());
        }
        out[start..start + len].copy_from_slice(&pixels(body, len, from)?);
    }
    Ok(Some(out))
}

#[cfg(test)]
mod tests {
    use super::super::exchange::{broadcast, ChannelExchange};
    use super::*;

    /// The partials of `n` slabs of a homogeneous medium (emission e, absorption a per unit
    /// length) of total depth 1 cut into equal slabs, for a ray towards +z or -z.
    fn homogeneous(n: usize, e: f64, a: f64, towards_minus_z: bool) -> Vec<Partial> {
        let d = 1.0 / n as f64;
        let c = (e / a * (1.0 - (-a * d).exp())) as f32;
        let tau = (a * d) as f32;
        let sign = if towards_minus_z { -1.0 } else { 1.0 };
        vec![[c, c, c, tau * sign]; n]
    }

    /// Runs `composite` on `n` threads, rank r starting from `partials[r]`.
    fn run(partials: Vec<Vec<Partial>>, scheme: Scheme) -> Vec<Partial> {
        let group = ChannelExchange::group(partials.len());
        std::thread::scope(|s| {
            let handles: Vec<_> = group
                .iter()
                .zip(partials)
                .map(|(ex, p)| s.spawn(move || composite(ex, p, scheme).unwrap()))
                .collect();
            let results: Vec<_> = handles.into_iter().map(|h| h.join().unwrap()).collect();
            assert!(results[1..].iter().all(Option::is_none));
            results.into_iter().next().unwrap().unwrap()
        })
    }

    #[test]
    fn joined_homogeneous_slabs_give_the_closed_form_of_the_whole_depth() {
        let (e, a) = (2.0, 3.0);
        let whole = e / a * (1.0 - f64::exp(-a));
        for n in [2, 3, 5] {
            for minus in [false, true] {
                let p = homogeneous(n, e, a, minus);
                let joined = p[1..].iter().fold(p[0], |acc, &u| join(acc, u));
                assert!(
                    (f64::from(joined[0]) - whole).abs() < 1e-6,
                    "{n}: {joined:?}"
                );
                assert!((f64::from(joined[3].abs()) - a).abs() < 1e-6);
                assert_eq!(joined[3].is_sign_negative(), minus);
            }
        }
    }

    #[test]
    fn visibility_order_follows_the_sign_of_the_depth() {
        // A bright, transparent lower slab and a dark, opaque upper slab: seen from below
        // (ray towards +z) the bright one is in front.
        let lower = [1.0, 1.0, 1.0, 0.0];
        let upper = [0.0, 0.0, 0.0, 10.0];
        assert_eq!(join(lower, upper)[0], 1.0);
        let towards_minus = join([1.0, 1.0, 1.0, -0.0], [0.0, 0.0, 0.0, -10.0]);
        assert!((towards_minus[0] - (-10.0f32).exp()).abs() < 1e-9);
        assert_eq!(towards_minus[3], -10.0);
        let f = finish([0.5, 0.5, 0.5, 2.0], [1.0, 0.0, 0.0]);
        assert!((f[0] - (0.5 + (-2.0f32).exp())).abs() < 1e-6);
        assert!((f[3] - (1.0 - (-2.0f32).exp())).abs() < 1e-6);
    }

    /// Pseudo-random partial images (a fixed LCG), half the pixels' rays towards -z.
    fn random_partials(n: usize, len: usize) -> Vec<Vec<Partial>> {
        let mut x = 12345u64;
        let mut next = move || {
            x = x
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (x >> 40) as f32 / (1u64 << 24) as f32
        };
        let mut out: Vec<Vec<Partial>> = vec![Vec::new(); n];
        for i in 0..len {
            let minus = i % 2 == 1;
            for part in out.iter_mut() {
                let tau = 2.0 * next();
                part.push([next(), next(), next(), if minus { -tau } else { tau }]);
            }
        }
        out
    }

    #[test]
    fn both_schemes_equal_the_sequential_join_in_slab_order() {
        for n in 1..=8 {
            let len = 1000 + n; // not a multiple of the rank count
            let partials = random_partials(n, len);
            let reference: Vec<Partial> = (0..len)
                .map(|i| (1..n).fold(partials[0][i], |acc, r| join(acc, partials[r][i])))
                .collect();
            let mut schemes = vec![Scheme::DirectSend];
            if n.is_power_of_two() {
                schemes.push(Scheme::BinarySwap);
            }
            for scheme in schemes {
                let got = run(partials.clone(), scheme);
                for (g, r) in got.iter().zip(&reference) {
                    for c in 0..4 {
                        assert!(
                            (g[c] - r[c]).abs() <= 2e-6 * r[c].abs().max(1.0),
                            "{n} {scheme:?}: {g:?} vs {r:?}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn binary_swap_refuses_other_rank_counts_and_broadcast_reaches_every_rank() {
        let group = ChannelExchange::group(3);
        let err = composite(&group[0], vec![[0.0; 4]; 4], Scheme::BinarySwap).unwrap_err();
        assert!(err.to_string().contains("power-of-two"), "{err}");
        for n in 1..=7 {
            let group = ChannelExchange::group(n);
            std::thread::scope(|s| {
                for ex in &group {
                    s.spawn(move || {
                        let data = if ex.rank() == 2 % n {
                            vec![7u8, 8, 9]
                        } else {
                            Vec::new()
                        };
                        assert_eq!(broadcast(ex, 2 % n, data).unwrap(), vec![7, 8, 9]);
                    });
                }
            });
        }
    }
}
