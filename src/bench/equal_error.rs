//! Peers at equal error (`hdrvis bench volume --peer vtk`): what a user trades when choosing a
//! faster tool. The peer is given hdrvis's transfer function as piecewise-linear colour and
//! opacity nodes; the optical model those nodes define (emission colour·σ, extinction σ =
//! −ln(1 − opacity) per voxel length) is resampled onto hdrvis's table, and its integral — the
//! f64 CPU reference, pre-integrated at 1/8 of the step — is the ground truth for the peer's
//! image and for hdrvis's own settings (precision × step × pre-integration, skipping as routed).
//! Error is measured twice: as a display sees it (share of pixels whose 8-bit sRGB codes at 0 EV
//! are within one level of the reference's) and as HDR data (percentiles of the relative error of
//! luminance over the six decades below the peak). The fastest hdrvis setting at least as good
//! as the peer on each measure gives the equal-error ratio.

use super::median;
use crate::error::{Error, Result};
use crate::model::colormap::encode_srgb8;
use crate::model::transfer::ResolvedTransfer;
use crate::model::{Scale, TransferFunction, Volume};
use crate::render::session::RenderSession;
use crate::render::{Precision, TfSampling, VolumeRenderOptions, VolumeSource};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// One node of the piecewise-linear functions a peer is given: at `value`, `colour` (linear RGB
/// in [0, 1]) and `alpha`, the opacity of one voxel length.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct PeerNode {
    pub value: f64,
    pub colour: [f64; 3],
    pub alpha: f64,
}

/// hdrvis's transfer function `tf` as a peer's nodes at `samples` (sorted values): colour is the
/// emission clamped to 1 (a peer's colours are display colours) and alpha = 1 − exp(−σ); with
/// `missing`, a first node at that stand-in value that emits and absorbs nothing.
pub(crate) fn peer_nodes(
    tf: &ResolvedTransfer,
    samples: &[f64],
    missing: Option<f64>,
) -> Vec<PeerNode> {
    let stand_in = missing.map(|value| PeerNode {
        value,
        colour: [0.0; 3],
        alpha: 0.0,
    });
    stand_in
        .into_iter()
        .chain(samples.iter().map(|&value| {
            let (e, s) = tf.eval(value);
            PeerNode {
                value,
                colour: e.map(|c| c.min(1.0)),
                alpha: -(-s).exp_m1(),
            }
        }))
        .collect()
}

/// The peer's colour and opacity at `v`: linear between nodes, the end nodes' beyond them.
fn peer_functions_at(nodes: &[PeerNode], v: f64) -> ([f64; 3], f64) {
    let i = nodes.partition_point(|n| n.value <= v);
    if i == 0 {
        return (nodes[0].colour, nodes[0].alpha);
    }
    if i == nodes.len() {
        let n = nodes[nodes.len() - 1];
        return (n.colour, n.alpha);
    }
    let (a, b) = (nodes[i - 1], nodes[i]);
    let f = (v - a.value) / (b.value - a.value);
    let lerp = |x: f64, y: f64| x + (y - x) * f;
    (
        [0, 1, 2].map(|c| lerp(a.colour[c], b.colour[c])),
        lerp(a.alpha, b.alpha),
    )
}

/// The optical model the peer's nodes define, as a transfer function hdrvis renders: extinction
/// σ = −ln(1 − alpha) and emission colour·σ per voxel length, on `scale` across the nodes' range
/// (4096 entries: within 1e-6 of the piecewise-linear functions).
pub(crate) fn peer_model(nodes: &[PeerNode], scale: Scale) -> Result<TransferFunction> {
    let (Some(first), Some(last)) = (nodes.first(), nodes.last()) else {
        return Err(Error::invalid("peer", "no transfer-function nodes"));
    };
    let table = ResolvedTransfer::from_functions(scale, [first.value, last.value], |v| {
        let (colour, alpha) = peer_functions_at(nodes, v);
        let sigma = -(-alpha.min(1.0 - 1e-12)).ln_1p();
        (colour.map(|c| c * sigma), sigma)
    })?;
    Ok(TransferFunction::Table(Arc::new(table)))
}

fn luminance(p: &[f64; 4]) -> f64 {
    0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2]
}

/// Share of the lit pixels (some 8-bit sRGB code above 0 in either image, at 0 EV) whose codes
/// are within one level of the reference's in every colour channel; 1 when nothing is lit. The
/// black background every renderer gets right does not dilute the score.
pub(crate) fn display_score(got: &[[f64; 4]], reference: &[[f64; 4]]) -> f64 {
    let codes = |p: &[f64; 4]| [0, 1, 2].map(|c| encode_srgb8(p[c]));
    let (mut lit, mut close) = (0usize, 0usize);
    for (g, r) in got.iter().zip(reference) {
        let (a, b) = (codes(g), codes(r));
        if a.iter().chain(&b).all(|&v| v == 0) {
            continue;
        }
        lit += 1;
        close += usize::from((0..3).all(|c| a[c].abs_diff(b[c]) <= 1));
    }
    if lit == 0 {
        1.0
    } else {
        close as f64 / lit as f64
    }
}

/// The 50th, 90th and 99th percentiles (nearest rank) of |Y − Y_ref| / Y_ref, Rec. 709
/// luminance, over the pixels whose reference luminance lies within six decades of its peak.
pub(crate) fn hdr_percentiles(got: &[[f64; 4]], reference: &[[f64; 4]]) -> [f64; 3] {
    let peak = reference.iter().map(luminance).fold(0.0, f64::max);
    let mut errors: Vec<f64> = got
        .iter()
        .zip(reference)
        .filter(|(_, r)| peak > 0.0 && luminance(r) >= 1e-6 * peak)
        .map(|(g, r)| (luminance(g) - luminance(r)).abs() / luminance(r))
        .collect();
    if errors.is_empty() {
        return [0.0; 3];
    }
    errors.sort_by(f64::total_cmp);
    [0.5, 0.9, 0.99].map(|p| {
        let rank = (p * errors.len() as f64).ceil() as usize;
        errors[rank.clamp(1, errors.len()) - 1]
    })
}

/// A peer's 8-bit RGB image as linear radiance in [0, 1] (the values its compositing computed;
/// VTK writes them without a transfer curve), alpha 1.
pub(crate) fn read_peer_image(path: &Path, (w, h): (u32, u32)) -> Result<Vec<[f64; 4]>> {
    let img = image::open(path)
        .map_err(|e| Error::invalid("peer", format!("{}: {e}", path.display())))?
        .to_rgb8();
    if img.dimensions() != (w, h) {
        return Err(Error::invalid(
            "peer",
            format!(
                "{}: {}x{}, expected {w}x{h}",
                path.display(),
                img.width(),
                img.height()
            ),
        ));
    }
    Ok(img
        .pixels()
        .map(|p| {
            let [r, g, b] = p.0.map(|v| f64::from(v) / 255.0);
            [r, g, b, 1.0]
        })
        .collect())
}

/// One hdrvis setting on the peer's scene: its time and its error against the integral.
#[derive(Clone, Debug)]
pub struct SettingRow {
    pub setting: String,
    pub median_ms: f64,
    pub display: f64,
    pub hdr: [f64; 3],
}

/// A peer's image scored against the integral.
#[derive(Clone, Debug)]
pub struct PeerScore {
    pub name: String,
    pub median_ms: f64,
    pub display: f64,
    pub hdr: [f64; 3],
}

/// The equal-error comparison of one scene.
#[derive(Clone, Debug, Default)]
pub struct EqualError {
    pub sweep: Vec<SettingRow>,
    pub peers: Vec<PeerScore>,
    /// Milliseconds of the f64 reference (the integral) on the CPU.
    pub reference_ms: f64,
    /// Why the comparison did not run, if it did not.
    pub error: Option<String>,
}

impl EqualError {
    /// The fastest setting at least as good as `peer` on the display measure.
    pub fn fastest_at_display(&self, peer: &PeerScore) -> Option<&SettingRow> {
        self.fastest(|r| r.display >= peer.display)
    }

    /// The fastest setting whose 90th-percentile HDR error is at most `peer`'s and below 1 (a
    /// setting that loses the low decades never counts; a peer that does is beaten by any
    /// setting that keeps them).
    pub fn fastest_at_hdr(&self, peer: &PeerScore) -> Option<&SettingRow> {
        self.fastest(|r| r.hdr[1] <= peer.hdr[1] && r.hdr[1] < 1.0)
    }

    fn fastest(&self, ok: impl Fn(&SettingRow) -> bool) -> Option<&SettingRow> {
        self.sweep
            .iter()
            .filter(|r| ok(r))
            .min_by(|a, b| a.median_ms.total_cmp(&b.median_ms))
    }
}

/// The settings swept: compositing precision × step × point-sampled or pre-integrated.
fn settings(step: f64) -> Vec<(Precision, f64, TfSampling)> {
    let mut v = Vec::new();
    for precision in [Precision::U8, Precision::F16, Precision::F32] {
        for factor in [1.0, 2.0, 4.0] {
            for sampling in [TfSampling::Point, TfSampling::PreIntegrated] {
                v.push((precision, step * factor, sampling));
            }
        }
    }
    v
}

/// The peer's scene (its volume, stand-ins for missing values included, and the optical model
/// of its nodes under `options`' camera, size and step) rendered as the integral and with every
/// hdrvis setting (`runs` timed each), and each peer image (name, median ms, PNG) scored.
pub(crate) fn measure(
    session: &RenderSession,
    (volume, nodes, scale): (Arc<Volume>, &[PeerNode], Scale),
    options: &VolumeRenderOptions,
    runs: usize,
    peers: &[(String, f64, PathBuf)],
    log: &mut dyn FnMut(&str),
) -> Result<EqualError> {
    let mut o = options.clone();
    o.tf = peer_model(nodes, scale)?;
    log("equal error: the f64 integral of the peer's optical model ...");
    let mut reference_options = o.clone();
    reference_options.precision = Precision::F64;
    reference_options.tf_sampling = TfSampling::PreIntegrated;
    reference_options.step = options.step / 8.0;
    let t = std::time::Instant::now();
    let reference = crate::render::cpu_reference::render_volume_f64(&volume, &reference_options)?;
    let reference_ms = t.elapsed().as_secs_f64() * 1e3;
    let source = VolumeSource::Memory(volume);
    let mut sweep = Vec::new();
    for (precision, step, sampling) in settings(options.step) {
        (o.precision, o.step, o.tf_sampling) = (precision, step, sampling);
        let setting = super::accuracy::setting_name(precision, step, sampling);
        let (ms, got) = super::accuracy::time_volume(session, &source, &o, runs)?;
        let row = SettingRow {
            setting,
            median_ms: median(&ms),
            display: display_score(&got, &reference),
            hdr: hdr_percentiles(&got, &reference),
        };
        log(&format!(
            "equal error: {}: {:.1} ms, display {:.2} %, HDR p90 {:.1e}",
            row.setting,
            row.median_ms,
            100.0 * row.display,
            row.hdr[1]
        ));
        sweep.push(row);
    }
    let mut scores = Vec::new();
    for (name, median_ms, png) in peers {
        let got = read_peer_image(png, (options.width, options.height))?;
        scores.push(PeerScore {
            name: name.clone(),
            median_ms: *median_ms,
            display: display_score(&got, &reference),
            hdr: hdr_percentiles(&got, &reference),
        });
    }
    Ok(EqualError {
        sweep,
        peers: scores,
        reference_ms,
        error: None,
    })
}

/// One row of the equal-error table: what ran, its median ms, display share and HDR percentiles.
fn score_line(name: &str, median_ms: f64, display: f64, hdr: [f64; 3]) -> String {
    format!(
        "{name:<24} {median_ms:>9.1} {:>8.2}% {:>9.1e} {:>9.1e} {:>9.1e}\n",
        100.0 * display,
        hdr[0],
        hdr[1],
        hdr[2]
    )
}

/// The equal-error tables of `hdrvis bench volume --peer`: each scene's settings, then each
/// peer's error and hdrvis's fastest settings at the same error.
pub fn format_equal_error(scenes: &[(String, &EqualError)]) -> String {
    let mut out = String::new();
    if scenes.is_empty() {
        return out;
    }
    out.push_str(
        "peers at equal error: every image scored against the f64 integral of the peer's optical \
         model (pre-integrated, 1/8 of the step) on the peer's volume; display: pixels whose 8-bit \
         sRGB codes at 0 EV are within one level of the reference's; HDR: percentiles of the \
         relative error of luminance over six decades below the peak\n",
    );
    for (scene, eq) in scenes {
        if let Some(e) = &eq.error {
            out.push_str(&format!("{scene}: not compared: {e}\n"));
            continue;
        }
        out.push_str(&format!(
            "{scene} (reference: {:.0} ms on the CPU)\n{:<24} {:>9} {:>9} {:>9} {:>9} {:>9}\n",
            eq.reference_ms, "setting", "median ms", "display", "HDR p50", "HDR p90", "HDR p99"
        ));
        for r in &eq.sweep {
            out.push_str(&score_line(&r.setting, r.median_ms, r.display, r.hdr));
        }
        for p in &eq.peers {
            out.push_str(&score_line(&p.name, p.median_ms, p.display, p.hdr));
        }
        for p in &eq.peers {
            let verdict = |s: Option<&SettingRow>| match s {
                Some(s) => format!("{} ({:.2}x)", s.setting, p.median_ms / s.median_ms),
                None => "no setting reaches it".to_string(),
            };
            let fails = if p.hdr[1] >= 1.0 {
                " (the peer loses the low decades: p90 >= 1)"
            } else {
                ""
            };
            out.push_str(&format!(
                "  {}: equal display error: {}; equal HDR error (p90){fails}: {}\n",
                p.name,
                verdict(eq.fastest_at_display(p)),
                verdict(eq.fastest_at_hdr(p))
            ));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grey(v: f64) -> [f64; 4] {
        [v, v, v, 1.0]
    }

    #[test]
    fn identical_images_score_fully_and_a_known_error_shows_in_the_percentiles() {
        let reference: Vec<_> = (0..100).map(|i| grey(0.01 * (i + 1) as f64)).collect();
        assert_eq!(display_score(&reference, &reference), 1.0);
        assert_eq!(hdr_percentiles(&reference, &reference), [0.0; 3]);
        // Ten pixels 20 % too bright, the rest exact: p50 0, p90 0 (rank 90 of 100), p99 0.2.
        let got: Vec<_> = reference
            .iter()
            .enumerate()
            .map(|(i, p)| if i % 10 == 0 { grey(p[0] * 1.2) } else { *p })
            .collect();
        let [p50, p90, p99] = hdr_percentiles(&got, &reference);
        assert_eq!((p50, p90), (0.0, 0.0));
        assert!((p99 - 0.2).abs() < 1e-12, "{p99}");
    }

    #[test]
    fn an_8_bit_linear_image_fails_the_low_decades() {
        // Luminance over six decades, log-spaced; stored as a peer stores it (linear 8-bit).
        let reference: Vec<_> = (0..600)
            .map(|i| grey(10f64.powf(-6.0 + i as f64 / 100.0)))
            .collect();
        let got: Vec<_> = reference
            .iter()
            .map(|p| grey((p[0] * 255.0).round() / 255.0))
            .collect();
        let [p50, p90, p99] = hdr_percentiles(&got, &reference);
        // Below 1/510 (3.3 of the six decades, 55 % of the pixels) the peer has 0: error 1.
        assert_eq!(p50, 1.0);
        assert_eq!(p90, 1.0);
        assert_eq!(p99, 1.0);
        // On a display, linear 8-bit quantisation loses more than one sRGB level only in the
        // dark, where one linear step spans several sRGB codes.
        let score = display_score(&got, &reference);
        let codes: Vec<_> = reference
            .iter()
            .zip(&got)
            .map(|(r, g)| (encode_srgb8(r[0]), encode_srgb8(g[0])))
            .filter(|&(r, g)| r > 0 || g > 0)
            .collect();
        let exact =
            codes.iter().filter(|(r, g)| r.abs_diff(*g) <= 1).count() as f64 / codes.len() as f64;
        assert_eq!(score, exact);
        assert!(score > 0.3 && score < 0.9, "{score}");
    }

    #[test]
    fn the_equal_error_setting_is_the_fastest_at_least_as_good_and_never_a_failing_one() {
        let row = |setting: &str, median_ms, display, p90| SettingRow {
            setting: setting.into(),
            median_ms,
            display,
            hdr: [0.0, p90, 1.0],
        };
        let eq = EqualError {
            sweep: vec![
                row("u8 step 4", 100.0, 0.3, 1.0),
                row("f32 step 4", 200.0, 0.6, 0.5),
                row("f32 step 1", 800.0, 1.0, 1e-4),
            ],
            ..Default::default()
        };
        let peer = |display, p90| PeerScore {
            name: "peer".into(),
            median_ms: 1000.0,
            display,
            hdr: [0.0, p90, 1.0],
        };
        let pick = |s: Option<&SettingRow>| s.map(|r| r.setting.clone());
        // A peer that fails the HDR measure is matched by the fastest setting that does not.
        let failing = peer(0.2, 1.0);
        assert_eq!(
            pick(eq.fastest_at_display(&failing)),
            Some("u8 step 4".into())
        );
        assert_eq!(pick(eq.fastest_at_hdr(&failing)), Some("f32 step 4".into()));
        let good = peer(0.9, 1e-3);
        assert_eq!(
            pick(eq.fastest_at_display(&good)),
            Some("f32 step 1".into())
        );
        assert_eq!(pick(eq.fastest_at_hdr(&good)), Some("f32 step 1".into()));
        assert_eq!(pick(eq.fastest_at_hdr(&peer(1.0, 1e-6))), None);
        let table = format_equal_error(&[(
            "scene".into(),
            &EqualError {
                peers: vec![failing],
                ..eq.clone()
            },
        )]);
        assert!(
            table.contains("peer: equal display error: u8 step 4 (10.00x)"),
            "{table}"
        );
        assert!(table.contains("f32 step 4 (5.00x)"), "{table}");
    }

    #[test]
    fn the_peer_model_is_its_nodes_optical_model() {
        let nodes = [
            PeerNode {
                value: 0.0,
                colour: [0.0; 3],
                alpha: 0.0,
            },
            PeerNode {
                value: 1.0,
                colour: [1.0, 0.5, 0.25],
                alpha: 0.5,
            },
        ];
        let TransferFunction::Table(t) = peer_model(&nodes, Scale::Linear).unwrap() else {
            panic!("a table");
        };
        // At 0.5: colour (0.5, 0.25, 0.125), alpha 0.25, so sigma = ln(4/3), emission colour·sigma.
        let (e, s) = t.eval(0.5);
        let sigma = (4.0f64 / 3.0).ln();
        assert!((s - sigma).abs() < 1e-6, "{s}");
        for (c, want) in [0.5, 0.25, 0.125].iter().enumerate() {
            assert!((e[c] - want * sigma).abs() < 1e-6, "{e:?}");
        }
        // Beyond the nodes: the end nodes' values.
        assert!((t.eval(2.0).1 - 2f64.ln()).abs() < 1e-12);
        assert_eq!(t.eval(-1.0), ([0.0; 3], 0.0));
    }

    #[test]
    fn a_constant_box_under_the_peer_model_composites_as_the_peer_does() {
        // Colour c and opacity alpha per voxel length everywhere: a ray through L voxels gathers
        // c (1 - (1 - alpha)^L), the peer's front-to-back sum, exactly.
        use crate::model::{Axis, Camera};
        let (c, alpha) = ([0.8, 0.4, 0.2], 0.3);
        let node = |value| PeerNode {
            value,
            colour: c,
            alpha,
        };
        let vol = Volume::new("constant", [8, 8, 8], [1.0; 3], [0.0; 3], vec![0.5; 512]).unwrap();
        let tf = peer_model(&[node(0.0), node(1.0)], Scale::Linear).unwrap();
        let mut o = VolumeRenderOptions::new(Camera::axis(Axis::Z, &vol.bounds()), tf);
        (o.width, o.height, o.step) = (4, 4, 0.5);
        let img = crate::render::cpu_reference::render_volume_f64(&vol, &o).unwrap();
        let through = 1.0 - (1.0 - alpha).powi(8);
        for p in &img {
            for k in 0..3 {
                assert!((p[k] - c[k] * through).abs() < 1e-9, "{p:?}");
            }
            assert!((p[3] - through).abs() < 1e-9, "{p:?}");
        }
    }
}
