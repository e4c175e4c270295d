//! What the TUI's camera, opacity, lens, ν and mode keys do to a script's last render (volume
//! or surface) when the script declares no parameter for them: a [`SceneEdit`] (orbit, zoom,
//! decades of opacity, the window, a factor on ν, the colour mode) applied to that render's
//! options, so the render runs again from the session (data, upload and pipelines cached)
//! without re-running the script. The window is a volume's magnification window and a surface's
//! colour range; it steps in the scale's own space (decades for log10 and symlog). Also numbers
//! as the panel shows them.

use crate::model::text::{BarScale, ColourBar};
use crate::model::transfer::Scale;
use crate::model::{Camera, HdrImage, Lens, Projection, TransferFunction};
use crate::render::surface::{FringeMode, SurfaceOptions, SurfaceView};
use crate::render::{VolumeRenderOptions, VolumeSource};
use crate::script::{LastRender, LastSurfaceRender, LastVolumeRender};

/// Magnification of a window the TUI adds to a transfer function that has none.
pub(crate) const DEFAULT_LENS_FACTOR: f64 = 4.0;

/// The TUI's changes to the last render: rotations about the scene's centre (azimuth about
/// world +z, then elevation about the camera's horizontal), a magnification, decades added to a
/// volume's extinction, the window in data values (a volume's magnification window, a surface's
/// colour range), a factor on a surface's ν and its colour mode.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct SceneEdit {
    pub azimuth_deg: f64,
    pub elevation_deg: f64,
    pub zoom: f64,
    pub opacity_decades: f64,
    pub lens: Option<[f64; 2]>,
    pub nu_factor: f64,
    pub mode: Option<FringeMode>,
}

impl Default for SceneEdit {
    fn default() -> Self {
        SceneEdit {
            azimuth_deg: 0.0,
            elevation_deg: 0.0,
            zoom: 1.0,
            opacity_decades: 0.0,
            lens: None,
            nu_factor: 1.0,
            mode: None,
        }
    }
}

/// What the TUI's own keys can act on after a run: the last render's kind and where its window
/// lives.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct SceneKeys {
    /// `None` where there is no window to move: a volume's transfer function without a colour
    /// table, a surface in cyclic mode (its colours follow the phase).
    pub lens: Option<LensSpace>,
    pub target: KeyTarget,
}

/// The kind of render the keys edit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum KeyTarget {
    Volume,
    /// A surface in `mode` (the edit's, else the script's); `camera` when its view has one (a
    /// map view has none).
    Surface {
        mode: FringeMode,
        camera: bool,
    },
}

impl SceneKeys {
    /// The keys of `render` as edited by `edit`, whose picture is `image` (a surface's colour
    /// range is read from the colour bar the image records).
    pub(crate) fn of(render: &LastRender, edit: &SceneEdit, image: &HdrImage) -> SceneKeys {
        match render {
            LastRender::Volume(v) => SceneKeys {
                lens: LensSpace::of(v),
                target: KeyTarget::Volume,
            },
            LastRender::Surface(s) => {
                let mode = edit.mode.unwrap_or(s.options.mode);
                let bar =
                    ColourBar::of(image).filter(|b| mode != FringeMode::Cyclic && b.lo < b.hi);
                SceneKeys {
                    lens: bar.map(|b| LensSpace::of_bar(&b)),
                    target: KeyTarget::Surface {
                        mode,
                        camera: !matches!(s.options.view, SurfaceView::Map),
                    },
                }
            }
        }
    }
}

impl SceneEdit {
    pub(crate) fn is_identity(&self) -> bool {
        *self == SceneEdit::default()
    }

    /// The render's options with this edit: camera turned and zoomed, opacity and window set.
    pub(crate) fn apply(&self, base: &LastVolumeRender) -> VolumeRenderOptions {
        let mut o = base.options.clone();
        let pivot = base.source.bounds().center();
        let turned = orbit_camera(&o.camera, pivot, self.azimuth_deg, self.elevation_deg);
        o.camera = zoom_camera(&turned, self.zoom);
        o.tf = add_opacity_decades(&o.tf, self.opacity_decades);
        if let (Some([lo, hi]), TransferFunction::Lut(l)) = (self.lens, &mut o.tf) {
            let factor = l.lens.map_or(DEFAULT_LENS_FACTOR, |x| x.factor);
            l.lens = Some(Lens { lo, hi, factor });
        }
        o
    }
}

impl SceneEdit {
    /// The surface render's options with this edit: ν scaled, the mode and colour range set
    /// (a cyclic mode takes no range), the camera of a 3-D view turned and zoomed.
    pub(crate) fn apply_surface(&self, base: &LastSurfaceRender) -> SurfaceOptions {
        let mut o = base.options.clone();
        o.nu.iter_mut().for_each(|nu| *nu *= self.nu_factor);
        if let Some(mode) = self.mode {
            o.mode = mode;
        }
        if o.mode == FringeMode::Cyclic {
            (o.domain, o.centre) = (None, None);
        } else if let Some([lo, hi]) = self.lens {
            (o.domain, o.centre) = (Some((lo, hi)), None);
        }
        let (az, el) = (self.azimuth_deg, self.elevation_deg);
        o.view = match o.view {
            SurfaceView::Map => SurfaceView::Map,
            SurfaceView::Orbit {
                azimuth,
                elevation,
                fov,
            } => SurfaceView::Orbit {
                azimuth: azimuth + az,
                elevation: (elevation + el).clamp(-89.0, 89.0),
                fov: zoom_fov(fov, self.zoom),
            },
            SurfaceView::Globe(c) => {
                SurfaceView::Globe(zoom_camera(&orbit_camera(&c, [0.0; 3], az, el), self.zoom))
            }
            SurfaceView::Camera(c) => {
                let pivot = looked_at(&c);
                SurfaceView::Camera(zoom_camera(&orbit_camera(&c, pivot, az, el), self.zoom))
            }
        };
        o
    }
}

/// The point a surface's free camera looks at: where its view axis meets the surface's floor
/// (z = 0), or one unit ahead when it looks level or up.
fn looked_at(c: &Camera) -> [f64; 3] {
    let t = if c.forward[2] < -1e-6 {
        -c.eye[2] / c.forward[2]
    } else {
        1.0
    };
    std::array::from_fn(|i| c.eye[i] + t * c.forward[i])
}

/// A vertical field of view `fov_deg` magnified `zoom` times.
fn zoom_fov(fov_deg: f64, zoom: f64) -> f64 {
    2.0 * ((0.5 * fov_deg.to_radians()).tan() / zoom)
        .atan()
        .to_degrees()
}

/// `v` rotated by `angle` radians about the unit axis `k` (Rodrigues).
fn rotate(v: [f64; 3], k: [f64; 3], angle: f64) -> [f64; 3] {
    let (s, c) = angle.sin_cos();
    let kxv = [
        k[1] * v[2] - k[2] * v[1],
        k[2] * v[0] - k[0] * v[2],
        k[0] * v[1] - k[1] * v[0],
    ];
    let kv = k[0] * v[0] + k[1] * v[1] + k[2] * v[2];
    std::array::from_fn(|i| v[i] * c + kxv[i] * s + k[i] * kv * (1.0 - c))
}

/// The camera moved rigidly around `pivot`: `azimuth_deg` about world +z, then `elevation_deg`
/// upwards about its own horizontal axis (for an orbit camera: the orbit's angles change by
/// these amounts).
pub(crate) fn orbit_camera(
    c: &Camera,
    pivot: [f64; 3],
    azimuth_deg: f64,
    elevation_deg: f64,
) -> Camera {
    let turn = |v: [f64; 3], k: [f64; 3], a: f64| rotate(v, k, a);
    let rel = std::array::from_fn(|i| c.eye[i] - pivot[i]);
    let z = [0.0, 0.0, 1.0];
    let az = azimuth_deg.to_radians();
    let (rel, forward, right, up) = (
        turn(rel, z, az),
        turn(c.forward, z, az),
        turn(c.right, z, az),
        turn(c.up, z, az),
    );
    // Turning the view direction towards `up` lowers the eye: raising it is the opposite turn.
    let el = -elevation_deg.to_radians();
    let rel = turn(rel, right, el);
    Camera {
        eye: std::array::from_fn(|i| pivot[i] + rel[i]),
        forward: turn(forward, right, el),
        right,
        up: turn(up, right, el),
        projection: c.projection,
    }
}

/// The camera magnified `zoom` times about the image centre: a narrower field of view, or a
/// smaller orthographic window.
pub(crate) fn zoom_camera(c: &Camera, zoom: f64) -> Camera {
    let projection = match c.projection {
        Projection::Perspective { fov_y_deg } => Projection::Perspective {
            fov_y_deg: zoom_fov(fov_y_deg, zoom),
        },
        Projection::Orthographic {
            half_width,
            half_height,
        } => Projection::Orthographic {
            half_width: half_width / zoom,
            half_height: half_height / zoom,
        },
    };
    Camera { projection, ..*c }
}

/// `tf` with its extinction multiplied by 10^`decades` (log10 opacity points kept in [-30, 30]).
pub(crate) fn add_opacity_decades(tf: &TransferFunction, decades: f64) -> TransferFunction {
    tf.with_factors(1.0, 10f64.powf(decades))
}

/// Where a transfer function's magnification window lives: its scale (a symlog threshold
/// resolved), the data domain in scaled units and the window it has, if any.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct LensSpace {
    pub scale: Scale,
    pub scaled_domain: [f64; 2],
    pub window: Option<[f64; 2]>,
}

impl LensSpace {
    /// The lens space of a render's transfer function; `None` for one without a colour table
    /// (emission–absorption) or one that does not resolve.
    pub(crate) fn of(render: &LastVolumeRender) -> Option<LensSpace> {
        let TransferFunction::Lut(l) = &render.options.tf else {
            return None;
        };
        // The domain and a symlog threshold come from the data only when the function gives none.
        let stats = match (&l.domain, &render.source) {
            (Some(_), _) => crate::model::VolumeStats::EMPTY,
            (None, VolumeSource::Memory(v)) => v.stats(),
            (None, VolumeSource::Bricked(b)) => b.stats,
        };
        let mapping = render.options.tf.resolve(&stats).ok()?.mapping;
        let width = if mapping.inv_range > 0.0 {
            1.0 / mapping.inv_range
        } else {
            1.0
        };
        Some(LensSpace {
            scale: mapping.scale,
            scaled_domain: [mapping.s_lo, mapping.s_lo + width],
            window: l.lens.map(|x| [x.lo, x.hi]),
        })
    }

    /// The lens space of a surface's colour bar: its scale and range, the range the window.
    pub(crate) fn of_bar(bar: &ColourBar) -> LensSpace {
        let scale = match bar.scale {
            BarScale::Linear => Scale::Linear,
            BarScale::Log10 => Scale::Log10,
            BarScale::Symlog { linthresh } => Scale::Symlog { linthresh },
        };
        LensSpace {
            scale,
            scaled_domain: [scale.apply(bar.lo), scale.apply(bar.hi)],
            window: Some([bar.lo, bar.hi]),
        }
    }

    /// The window to start from: the function's own, else the middle fifth of the domain.
    pub(crate) fn start(&self) -> [f64; 2] {
        self.window.unwrap_or_else(|| {
            let [a, b] = self.scaled_domain;
            let w = b - a;
            [
                self.scale.invert(a + 0.4 * w),
                self.scale.invert(a + 0.6 * w),
            ]
        })
    }
}

/// The window [lo, hi] (data values) moved by `shift` of its width and widened by `grow` of its
/// width on each side, both measured in the scale's own units (decades for log10 and symlog);
/// `None` when the result is not a valid window (not finite, empty, or not above 0 on log10).
pub(crate) fn step_window(
    [lo, hi]: [f64; 2],
    scale: Scale,
    shift: f64,
    grow: f64,
) -> Option<[f64; 2]> {
    let (a, b) = (scale.apply(lo), scale.apply(hi));
    let w = (b - a).abs().max(1e-12);
    let (a, b) = (a + (shift - grow) * w, b + (shift + grow) * w);
    let (lo, hi) = (scale.invert(a), scale.invert(b));
    let valid = lo.is_finite() && hi.is_finite() && lo < hi && (scale != Scale::Log10 || lo > 0.0);
    valid.then_some([lo, hi])
}

/// A number as the panel shows it: four significant digits, in scientific notation below 1e-3
/// and from 1e5 on (`-1.25e13`, not `-12499999999999`).
pub(crate) fn format_number(v: f64) -> String {
    let a = v.abs();
    if !v.is_finite() || v == 0.0 {
        return format!("{v}");
    }
    if (1e-3..1e5).contains(&a) {
        let decimals = (3 - a.log10().floor() as i32).max(0) as usize;
        let s = format!("{v:.decimals$}");
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        }
    } else {
        let s = format!("{v:.3e}");
        let (mantissa, exponent) = s.split_once('e').unwrap_or((&s, "0"));
        let mantissa = mantissa.trim_end_matches('0').trim_end_matches('.');
        format!("{mantissa}e{exponent}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{Aabb, LutTransfer};

    fn close(a: [f64; 3], b: [f64; 3], tol: f64) -> bool {
        (0..3).all(|i| (a[i] - b[i]).abs() <= tol)
    }

    #[test]
    fn orbiting_an_orbit_camera_adds_to_its_angles() {
        let bounds = Aabb {
            lo: [-1.0, -2.0, -0.5],
            hi: [3.0, 2.0, 1.5],
        };
        let start = Camera::orbit(&bounds, 30.0, 20.0, 35.0).unwrap();
        for (daz, del) in [(15.0, 10.0), (-45.0, -35.0), (180.0, 50.0)] {
            let turned = orbit_camera(&start, bounds.center(), daz, del);
            let expect = Camera::orbit(&bounds, 30.0 + daz, 20.0 + del, 35.0).unwrap();
            for (got, want) in [
                (turned.eye, expect.eye),
                (turned.forward, expect.forward),
                (turned.right, expect.right),
                (turned.up, expect.up),
            ] {
                assert!(close(got, want, 1e-9), "{daz} {del}: {got:?} vs {want:?}");
            }
        }
    }

    #[test]
    fn a_surface_edit_scales_nu_sets_mode_and_range_and_turns_3d_views() {
        use crate::model::grid::test_grid;
        use crate::model::CoordKind;
        use crate::script::SurfaceField;
        let axis = |n: usize| (0..n).map(|i| i as f64).collect::<Vec<_>>();
        let grid = test_grid((axis(4), axis(3)), [CoordKind::Plain; 2], |x, y| x + y);
        let base = |options| LastSurfaceRender {
            field: SurfaceField::Grid(std::sync::Arc::new(grid.clone())),
            options,
        };
        let map = base(SurfaceOptions {
            nu: vec![2.0, 4.0],
            mode: FringeMode::Modulated,
            domain: Some((0.0, 5.0)),
            centre: Some(1.0),
            ..SurfaceOptions::default()
        });
        let edit = SceneEdit {
            nu_factor: 1.25,
            lens: Some([1.0, 3.0]),
            azimuth_deg: 30.0,
            ..SceneEdit::default()
        };
        let o = edit.apply_surface(&map);
        assert_eq!(o.nu, vec![2.5, 5.0]);
        assert_eq!((o.domain, o.centre), (Some((1.0, 3.0)), None));
        assert!(
            matches!(o.view, SurfaceView::Map),
            "a map has no camera to turn"
        );
        // Cyclic colours follow the phase: a range would be refused, so none is kept.
        let cyclic = SceneEdit {
            mode: Some(FringeMode::Cyclic),
            ..edit.clone()
        };
        let o = cyclic.apply_surface(&map);
        assert_eq!(
            (o.mode, o.domain, o.centre),
            (FringeMode::Cyclic, None, None)
        );
        assert!(o.validate_colour_range().is_ok());
        // An orbit adds to its angles (elevation kept below the pole) and narrows its view.
        let orbit = base(SurfaceOptions {
            view: SurfaceView::Orbit {
                azimuth: -60.0,
                elevation: 80.0,
                fov: 40.0,
            },
            ..SurfaceOptions::default()
        });
        let turn = SceneEdit {
            azimuth_deg: 15.0,
            elevation_deg: 20.0,
            zoom: 1.25,
            ..SceneEdit::default()
        };
        let SurfaceView::Orbit {
            azimuth,
            elevation,
            fov,
        } = turn.apply_surface(&orbit).view
        else {
            panic!("an orbit stays an orbit")
        };
        assert_eq!((azimuth, elevation), (-45.0, 89.0));
        // tan(20°) / 1.25 = 0.291176; atan -> 16.2343°, doubled.
        assert!((fov - 32.4686).abs() < 1e-3, "{fov}");
        // A globe turns about the Earth's centre: the eye keeps its distance, and 90° of
        // azimuth takes an eye over 0°E to 90°E.
        let eye = [3.0, 0.0, 0.0];
        let globe = Camera::look_at(eye, [0.0; 3], [0.0, 0.0, 1.0], 30.0).unwrap();
        let o = SceneEdit {
            azimuth_deg: 90.0,
            ..SceneEdit::default()
        }
        .apply_surface(&base(SurfaceOptions {
            view: SurfaceView::Globe(globe),
            ..SurfaceOptions::default()
        }));
        let SurfaceView::Globe(c) = o.view else {
            panic!("a globe stays a globe")
        };
        assert!(close(c.eye, [0.0, 3.0, 0.0], 1e-12), "{:?}", c.eye);
        assert!(close(c.forward, [0.0, -1.0, 0.0], 1e-12), "{:?}", c.forward);
    }

    #[test]
    fn zoom_magnifies_both_projections() {
        let bounds = Aabb {
            lo: [0.0; 3],
            hi: [2.0, 4.0, 1.0],
        };
        let ortho = zoom_camera(&Camera::axis(crate::model::Axis::Z, &bounds), 2.0);
        assert_eq!(
            ortho.projection,
            Projection::Orthographic {
                half_width: 0.5,
                half_height: 1.0
            }
        );
        let persp = zoom_camera(&Camera::orbit(&bounds, 0.0, 0.0, 60.0).unwrap(), 1.25);
        let Projection::Perspective { fov_y_deg } = persp.projection else {
            panic!("perspective expected");
        };
        // tan(30°) / 1.25 = 0.461880; atan -> 24.7913°, doubled.
        assert!((fov_y_deg - 49.582_6).abs() < 1e-3, "{fov_y_deg}");
    }

    #[test]
    fn opacity_adds_decades_to_the_extinction() {
        let lut = TransferFunction::Lut(LutTransfer {
            opacity: vec![[0.0, -1.5], [1.0, 29.9]],
            ..LutTransfer::default()
        });
        let TransferFunction::Lut(l) = add_opacity_decades(&lut, 0.25) else {
            unreachable!()
        };
        assert_eq!(l.opacity, vec![[0.0, -1.25], [1.0, 30.0]]);
        let ea = TransferFunction::emission_absorption(1.0, 2.0).unwrap();
        let TransferFunction::EmissionAbsorption { absorption, .. } =
            add_opacity_decades(&ea, -1.0)
        else {
            unreachable!()
        };
        assert!((absorption - 0.2).abs() < 1e-15);
    }

    #[test]
    fn the_lens_moves_in_decades_on_log_scales() {
        // log10: [1e2, 1e4] is two decades wide; a quarter-width shift is half a decade.
        let [lo, hi] = step_window([1e2, 1e4], Scale::Log10, 0.25, 0.0).unwrap();
        assert!((lo - 10f64.powf(2.5)).abs() < 1e-9 && (hi - 10f64.powf(4.5)).abs() < 1e-6);
        // Moving left never reaches 0 or below: 20 steps left stay positive decades.
        let mut w = [1e2, 1e4];
        for _ in 0..20 {
            w = step_window(w, Scale::Log10, -0.25, 0.0).unwrap();
        }
        assert!(
            (w[0].log10() - (2.0 - 10.0)).abs() < 1e-9 && w[0] > 0.0,
            "{w:?}"
        );
        // Widening by 1/8 of the width on each side: [1, 1e4] -> 10^-0.5 .. 10^4.5.
        let [lo, hi] = step_window([1.0, 1e4], Scale::Log10, 0.0, 0.125).unwrap();
        assert!(
            (lo - 10f64.powf(-0.5)).abs() < 1e-12 && (hi / 10f64.powf(4.5) - 1.0).abs() < 1e-12
        );
        // The case: `<` then `w` on a log scale kept a valid (positive) window.
        let left = step_window([1e12, 1e13], Scale::Log10, -0.25, 0.0).unwrap();
        let wider = step_window(left, Scale::Log10, 0.0, 0.125).unwrap();
        assert!(wider[0] > 0.0 && wider[0] < wider[1]);
        assert!((wider[0].log10() - 11.625).abs() < 1e-9, "{wider:?}");
        // symlog (threshold 1): scaled value log10(1 + |v|); [0, 9] is [0, 1] scaled and
        // moves to [0.25, 1.25] scaled = [10^0.25 - 1, 10^1.25 - 1].
        let s = Scale::Symlog { linthresh: 1.0 };
        let [lo, hi] = step_window([0.0, 9.0], s, 0.25, 0.0).unwrap();
        assert!((lo - (10f64.powf(0.25) - 1.0)).abs() < 1e-12);
        assert!((hi - (10f64.powf(1.25) - 1.0)).abs() < 1e-12);
        // symlog crosses zero symmetrically: [-9, 9] shifted left by a quarter of 2 decades.
        let [lo, hi] = step_window([-9.0, 9.0], s, -0.25, 0.0).unwrap();
        assert!(
            (lo + (10f64.powf(1.5) - 1.0)).abs() < 1e-9
                && (hi - (10f64.powf(0.5) - 1.0)).abs() < 1e-12
        );
        // Linear: plain arithmetic.
        let [lo, hi] = step_window([0.4, 0.6], Scale::Linear, 0.25, 0.0).unwrap();
        assert!((lo - 0.45).abs() < 1e-15 && (hi - 0.65).abs() < 1e-15);
        // Overflow is refused rather than stored.
        assert_eq!(step_window([1e300, 1e307], Scale::Log10, 0.25, 0.0), None);
    }

    #[test]
    fn scale_inversion_round_trips() {
        for s in [
            Scale::Linear,
            Scale::Log10,
            Scale::Symlog { linthresh: 1e-3 },
        ] {
            for v in [1e-6, 0.3, 7.0, 1.25e13] {
                let back = s.invert(s.apply(v));
                assert!((back / v - 1.0).abs() < 1e-12, "{s:?} {v} -> {back}");
            }
        }
        let s = Scale::Symlog { linthresh: 0.5 };
        assert!((s.invert(s.apply(-3.0)) + 3.0).abs() < 1e-12);
    }

    #[test]
    fn numbers_show_four_digits_and_switch_to_exponents() {
        assert_eq!(format_number(-12_499_999_999_999.0), "-1.25e13");
        assert_eq!(format_number(1.25e13), "1.25e13");
        assert_eq!(format_number(0.02), "0.02");
        assert_eq!(format_number(0.1 + 0.2), "0.3");
        assert_eq!(format_number(35.0), "35");
        assert_eq!(format_number(12345.678), "12346");
        assert_eq!(format_number(3.0e-5), "3e-5");
        assert_eq!(format_number(-0.000_123_456), "-1.235e-4");
        assert_eq!(format_number(0.0), "0");
    }
}
