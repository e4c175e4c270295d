//! Cameras: perspective and orthographic, built from look-at, orbit or an axis-aligned view that
//! frames a bounding box exactly. A camera turns a pixel (i, j) of a W×H image into a world ray; the
//! GPU ray caster and the CPU reference both use this definition, so they trace the same rays.

use super::vec3::{add_scaled, cross, dot, norm, normalize, sub};
use super::volume::Aabb;
use crate::error::{Error, Result};

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Projection {
    /// Vertical field of view in degrees; the horizontal one follows from the image's aspect.
    Perspective { fov_y_deg: f64 },
    /// Half the visible width and height in world units; the image fills exactly that window.
    Orthographic { half_width: f64, half_height: f64 },
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Axis {
    X,
    Y,
    Z,
}

impl Axis {
    pub fn parse(s: &str) -> Result<Axis> {
        match s {
            "x" | "X" => Ok(Axis::X),
            "y" | "Y" => Ok(Axis::Y),
            "z" | "Z" => Ok(Axis::Z),
            _ => Err(Error::invalid(
                "axis",
                format!("expected \"x\", \"y\" or \"z\", got {s:?}"),
            )),
        }
    }
}

/// A camera with an orthonormal frame: rays leave `eye` along `forward`, image x grows along
/// `right`, image rows go from `up` (row 0) downwards.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub eye: [f64; 3],
    pub forward: [f64; 3],
    pub right: [f64; 3],
    pub up: [f64; 3],
    pub projection: Projection,
}

fn check_finite(field: &str, v: &[f64]) -> Result<()> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(Error::invalid(
            field,
            format!("expected finite numbers, got {v:?}"),
        ))
    }
}

impl Camera {
    /// The same camera in the frame of a rotated-pole grid (turned about the planet's centre).
    pub(crate) fn turned(&self, pole: &super::RotatedPole) -> Camera {
        Camera {
            eye: pole.turn(self.eye),
            forward: pole.turn(self.forward),
            right: pole.turn(self.right),
            up: pole.turn(self.up),
            projection: self.projection,
        }
    }

    /// A perspective camera at `eye` looking at `target`, with `up` giving the vertical.
    pub fn look_at(
        eye: [f64; 3],
        target: [f64; 3],
        up: [f64; 3],
        fov_y_deg: f64,
    ) -> Result<Camera> {
        check_finite("camera.eye", &eye)?;
        check_finite("camera.target", &target)?;
        check_finite("camera.up", &up)?;
        if !(fov_y_deg.is_finite() && fov_y_deg > 0.0 && fov_y_deg < 180.0) {
            return Err(Error::invalid(
                "camera.fov",
                format!("expected degrees in (0, 180), got {fov_y_deg}"),
            ));
        }
        let (forward, right, up) = frame(eye, target, up)?;
        Ok(Camera {
            eye,
            forward,
            right,
            up,
            projection: Projection::Perspective { fov_y_deg },
        })
    }

    /// An orthographic camera looking from `eye` towards `target` showing a window of
    /// `2·half_width × 2·half_height` world units.
    pub fn ortho_look_at(
        eye: [f64; 3],
        target: [f64; 3],
        up: [f64; 3],
        half_width: f64,
        half_height: f64,
    ) -> Result<Camera> {
        check_finite("camera.eye", &eye)?;
        check_finite("camera.target", &target)?;
        check_finite("camera.up", &up)?;
        for (f, v) in [
            ("camera.half_width", half_width),
            ("camera.half_height", half_height),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(Error::invalid(
                    f,
                    format!("expected a finite value > 0, got {v}"),
                ));
            }
        }
        let (forward, right, up) = frame(eye, target, up)?;
        Ok(Camera {
            eye,
            forward,
            right,
            up,
            projection: Projection::Orthographic {
                half_width,
                half_height,
            },
        })
    }

    /// A perspective camera orbiting `bounds`: azimuth about +z from +x, elevation above the
    /// x–y plane, at a distance that fits the bounding sphere in the field of view.
    pub fn orbit(
        bounds: &Aabb,
        azimuth_deg: f64,
        elevation_deg: f64,
        fov_y_deg: f64,
    ) -> Result<Camera> {
        Camera::orbit_sphere(
            bounds.center(),
            0.5 * bounds.diagonal(),
            azimuth_deg,
            elevation_deg,
            fov_y_deg,
        )
    }

    /// A perspective camera orbiting `center` at azimuth/elevation (degrees, z up), far enough
    /// that a sphere of `radius` about it fills the vertical field of view with a 5 % margin.
    pub fn orbit_sphere(
        center: [f64; 3],
        radius: f64,
        azimuth_deg: f64,
        elevation_deg: f64,
        fov_y_deg: f64,
    ) -> Result<Camera> {
        check_finite("camera.azimuth", &[azimuth_deg])?;
        check_finite("camera.elevation", &[elevation_deg])?;
        if !(fov_y_deg.is_finite() && fov_y_deg > 0.0 && fov_y_deg < 180.0) {
            return Err(Error::invalid(
                "camera.fov",
                format!("expected degrees in (0, 180), got {fov_y_deg}"),
            ));
        }
        let distance = radius / (0.5 * fov_y_deg.to_radians()).sin() * 1.05;
        let (az, el) = (
            azimuth_deg.to_radians(),
            elevation_deg.clamp(-89.9, 89.9).to_radians(),
        );
        let dir = [el.cos() * az.cos(), el.cos() * az.sin(), el.sin()];
        Camera::look_at(
            add_scaled(center, dir, distance),
            center,
            [0.0, 0.0, 1.0],
            fov_y_deg,
        )
    }

    /// A perspective camera above latitude `lat_deg`, longitude `lon_deg` (Earth-centred frame:
    /// +x toward 0°N 0°E, +z north) at `distance` from `centre`, looking at it with north up
    /// (at the poles, +y up as in the axis view along z).
    pub fn geo(
        centre: [f64; 3],
        lat_deg: f64,
        lon_deg: f64,
        distance: f64,
        fov_y_deg: f64,
    ) -> Result<Camera> {
        check_finite("camera.lat", &[lat_deg, lon_deg])?;
        if !(-90.0..=90.0).contains(&lat_deg) {
            return Err(Error::invalid(
                "camera.lat",
                format!("expected degrees in [-90, 90], got {lat_deg}"),
            ));
        }
        if !(distance.is_finite() && distance > 0.0) {
            return Err(Error::invalid(
                "camera.distance",
                format!("expected a distance > 0, got {distance}"),
            ));
        }
        let (sl, cl) = lat_deg.to_radians().sin_cos();
        let (so, co) = lon_deg.to_radians().sin_cos();
        let dir = [cl * co, cl * so, sl];
        let up = if lat_deg.abs() > 89.9 {
            [0.0, 1.0, 0.0]
        } else {
            [0.0, 0.0, 1.0]
        };
        Camera::look_at(add_scaled(centre, dir, distance), centre, up, fov_y_deg)
    }

    /// The orthographic view along an axis that frames `bounds` exactly: pixel centres sit at
    /// (i + 0.5)/W of the extent. "x" looks from +x (right = +y, up = +z), "y" from −y
    /// (right = +x, up = +z), "z" from +z (right = +x, up = +y).
    pub fn axis(axis: Axis, bounds: &Aabb) -> Camera {
        let s = bounds.size();
        let c = bounds.center();
        let (forward, right, up) = match axis {
            Axis::X => ([-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]),
            Axis::Y => ([0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]),
            Axis::Z => ([0.0, 0.0, -1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
        };
        let extent = |v: [f64; 3]| (v[0] * s[0] + v[1] * s[1] + v[2] * s[2]).abs();
        let depth = extent(forward);
        Camera {
            eye: add_scaled(c, forward, -(0.5 * depth + 1.0 + 0.01 * bounds.diagonal())),
            forward,
            right,
            up,
            projection: Projection::Orthographic {
                half_width: 0.5 * extent(right),
                half_height: 0.5 * extent(up),
            },
        }
    }

    /// The image size that shows this orthographic view with square pixels: the sides given are
    /// kept, a missing one follows the window's aspect, and with neither the longer side is
    /// `long_side` pixels. A perspective view keeps what is given (`long_side` square otherwise).
    pub(crate) fn square_pixel_size(
        &self,
        width: Option<u32>,
        height: Option<u32>,
        long_side: u32,
    ) -> (u32, u32) {
        let Projection::Orthographic {
            half_width,
            half_height,
        } = self.projection
        else {
            return (width.unwrap_or(long_side), height.unwrap_or(long_side));
        };
        let aspect = half_width / half_height;
        let side = |v: f64| v.round().clamp(1.0, u32::MAX as f64) as u32;
        match (width, height) {
            (Some(w), Some(h)) => (w, h),
            (Some(w), None) => (w, side(w as f64 / aspect)),
            (None, Some(h)) => (side(h as f64 * aspect), h),
            (None, None) if aspect >= 1.0 => (long_side, side(long_side as f64 / aspect)),
            (None, None) => (side(long_side as f64 * aspect), long_side),
        }
    }

    /// This orthographic view widened along one side to the image's aspect, the window centred
    /// (letterboxing): pixels stay square and the background shows beside the data instead of
    /// the data being stretched. A perspective view is returned as it is.
    pub(crate) fn letterboxed(mut self, width: u32, height: u32) -> Camera {
        if let Projection::Orthographic {
            half_width,
            half_height,
        } = &mut self.projection
        {
            let image_aspect = width as f64 / height.max(1) as f64;
            if *half_width / *half_height < image_aspect {
                *half_width = *half_height * image_aspect;
            } else {
                *half_height = *half_width / image_aspect;
            }
        }
        self
    }

    /// The projection as the ray-casting shaders take it, the terms of [`Camera::ray`]:
    /// `(1, tan of the horizontal half-angle, tan of the vertical half-angle, 0)` for perspective,
    /// `(0, half width, half height, 0)` for orthographic.
    pub(crate) fn shader_projection(&self, width: u32, height: u32) -> [f64; 4] {
        match self.projection {
            Projection::Perspective { fov_y_deg } => {
                let ty = (0.5 * fov_y_deg.to_radians()).tan();
                [1.0, ty * width as f64 / height as f64, ty, 0.0]
            }
            Projection::Orthographic {
                half_width,
                half_height,
            } => [0.0, half_width, half_height, 0.0],
        }
    }

    /// The world ray through the centre of pixel (px, py) of a `width × height` image.
    pub fn ray(&self, px: u32, py: u32, width: u32, height: u32) -> ([f64; 3], [f64; 3]) {
        self.ray_at([px as f64 + 0.5, py as f64 + 0.5], width, height)
    }

    /// The world ray through the point `at` of a `width × height` image, in continuous pixel
    /// coordinates (x right, y down; pixel (i, j) covers [i, i + 1] × [j, j + 1]).
    pub fn ray_at(&self, at: [f64; 2], width: u32, height: u32) -> ([f64; 3], [f64; 3]) {
        self.rays(width, height)(at)
    }

    /// [`Self::ray_at`] for many points of one image: the projection's constants worked out once.
    pub(crate) fn rays(
        &self,
        width: u32,
        height: u32,
    ) -> impl Fn([f64; 2]) -> ([f64; 3], [f64; 3]) + '_ {
        let (w, h) = (width as f64, height as f64);
        let ty = match self.projection {
            Projection::Perspective { fov_y_deg } => (0.5 * fov_y_deg.to_radians()).tan(),
            Projection::Orthographic { .. } => 0.0,
        };
        let tx = ty * w / h;
        move |at: [f64; 2]| {
            let sx = 2.0 * at[0] / w - 1.0;
            let sy = 1.0 - 2.0 * at[1] / h;
            match self.projection {
                Projection::Orthographic {
                    half_width,
                    half_height,
                } => {
                    let o = add_scaled(
                        add_scaled(self.eye, self.right, sx * half_width),
                        self.up,
                        sy * half_height,
                    );
                    (o, self.forward)
                }
                Projection::Perspective { .. } => {
                    let d = add_scaled(
                        add_scaled(self.forward, self.right, sx * tx),
                        self.up,
                        sy * ty,
                    );
                    (self.eye, normalize(d))
                }
            }
        }
    }

    /// Where world point `p` appears in a `width × height` image: continuous pixel coordinates
    /// (x right, y down, pixel (i, j) covering [i, i + 1] × [j, j + 1]), the inverse of
    /// [`Camera::ray`]; `None` for a point behind a perspective eye.
    pub fn project(&self, p: [f64; 3], width: u32, height: u32) -> Option<[f64; 2]> {
        let v = sub(p, self.eye);
        let (x, y) = (dot(v, self.right), dot(v, self.up));
        let [_, hx, hy, _] = self.shader_projection(width, height);
        let (sx, sy) = match self.projection {
            Projection::Orthographic { .. } => (x / hx, y / hy),
            Projection::Perspective { .. } => {
                let z = dot(v, self.forward);
                if z <= 1e-12 {
                    return None;
                }
                (x / (z * hx), y / (z * hy))
            }
        };
        Some([
            0.5 * (sx + 1.0) * width as f64,
            0.5 * (1.0 - sy) * height as f64,
        ])
    }

    /// One-line description for image metadata.
    pub fn describe(&self) -> String {
        let p = match self.projection {
            Projection::Perspective { fov_y_deg } => format!("perspective fov {fov_y_deg}"),
            Projection::Orthographic {
                half_width,
                half_height,
            } => format!("orthographic {}x{}", 2.0 * half_width, 2.0 * half_height),
        };
        use super::transfer::plain_list;
        format!(
            "{p}; eye {}; forward {}; up {}",
            plain_list(&self.eye),
            plain_list(&self.forward),
            plain_list(&self.up)
        )
    }
}

fn frame(eye: [f64; 3], target: [f64; 3], up: [f64; 3]) -> Result<([f64; 3], [f64; 3], [f64; 3])> {
    let f = sub(target, eye);
    if norm(f) == 0.0 {
        return Err(Error::invalid(
            "camera.target",
            "must differ from camera.eye",
        ));
    }
    let forward = normalize(f);
    let r = cross(forward, up);
    if norm(r) < 1e-12 * norm(up).max(1e-300) {
        return Err(Error::invalid(
            "camera.up",
            "must not be parallel to the view direction",
        ));
    }
    let right = normalize(r);
    Ok((forward, right, cross(right, forward)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn project_inverts_ray() {
        let b = Aabb {
            lo: [0.0, 0.0, 0.0],
            hi: [20.0, 25.0, 5.0],
        };
        let persp = Camera::geo([0.0; 3], 30.0, 40.0, 3.0, 35.0).unwrap();
        for cam in [persp, Camera::axis(Axis::Z, &b)] {
            let (o, d) = cam.ray(3, 5, 16, 12);
            let p = add_scaled(o, d, 2.0);
            let [x, y] = cam.project(p, 16, 12).unwrap();
            assert!((x - 3.5).abs() < 1e-9 && (y - 5.5).abs() < 1e-9, "{x} {y}");
        }
        assert!(persp
            .project(add_scaled(persp.eye, persp.forward, -1.0), 16, 12)
            .is_none());
    }

    #[test]
    fn axis_views_keep_the_aspect_of_the_box() {
        let b = Aabb {
            lo: [0.0, 0.0, 0.0],
            hi: [20.0, 25.0, 5.0],
        };
        let cam = Camera::axis(Axis::Z, &b);
        assert_eq!(cam.square_pixel_size(None, None, 512), (410, 512));
        assert_eq!(cam.square_pixel_size(Some(40), None, 512), (40, 50));
        assert_eq!(cam.square_pixel_size(None, Some(100), 512), (80, 100));
        // 100 x 100 pixels of a 20 x 25 box: 4 units per... 0.25 units per pixel both ways.
        let wide = cam.letterboxed(100, 100);
        let (left, _) = wide.ray(0, 50, 100, 100);
        let (right, _) = wide.ray(99, 50, 100, 100);
        let (top, _) = wide.ray(50, 0, 100, 100);
        let (bottom, _) = wide.ray(50, 99, 100, 100);
        let per_px_x = (right[0] - left[0]) / 99.0;
        let per_px_y = (top[1] - bottom[1]) / 99.0;
        assert!((per_px_x - 0.25).abs() < 1e-12 && (per_px_y - 0.25).abs() < 1e-12);
        // The box is centred: 10 pixels of background each side of its 80.
        assert!((left[0] - (-2.5 + 0.125)).abs() < 1e-12, "{left:?}");
    }

    #[test]
    fn axis_view_frames_bounds_exactly() {
        let b = Aabb {
            lo: [0.0, 0.0, 0.0],
            hi: [4.0, 2.0, 8.0],
        };
        let cam = Camera::axis(Axis::Z, &b);
        let (o, d) = cam.ray(0, 0, 4, 2);
        assert_eq!(d, [0.0, 0.0, -1.0]);
        assert!((o[0] - 0.5).abs() < 1e-12 && (o[1] - 1.5).abs() < 1e-12);
        let (o, _) = cam.ray(3, 1, 4, 2);
        assert!((o[0] - 3.5).abs() < 1e-12 && (o[1] - 0.5).abs() < 1e-12);
        let cam = Camera::axis(Axis::X, &b);
        let (o, d) = cam.ray(0, 0, 2, 8);
        assert_eq!(d, [-1.0, 0.0, 0.0]);
        assert!((o[1] - 0.5).abs() < 1e-12 && (o[2] - 7.5).abs() < 1e-12);
    }

    #[test]
    fn geo_camera_looks_at_the_centre_with_north_up() {
        let c = Camera::geo([0.0; 3], 0.0, 90.0, 3.0, 30.0).unwrap();
        assert!((c.eye[1] - 3.0).abs() < 1e-12 && c.eye[0].abs() < 1e-12);
        assert!((c.forward[1] + 1.0).abs() < 1e-12 && (c.up[2] - 1.0).abs() < 1e-12);
        let pole = Camera::geo([0.0; 3], 90.0, 0.0, 2.0, 30.0).unwrap();
        assert!((pole.forward[2] + 1.0).abs() < 1e-12 && (pole.right[0] - 1.0).abs() < 1e-12);
        assert!(Camera::geo([0.0; 3], 91.0, 0.0, 2.0, 30.0).is_err());
    }

    #[test]
    fn look_at_rejects_non_finite_and_degenerate() {
        assert!(Camera::look_at([f64::NAN, 0.0, 0.0], [0.0; 3], [0.0, 0.0, 1.0], 30.0).is_err());
        assert!(Camera::look_at([0.0, 0.0, 5.0], [0.0; 3], [0.0, 0.0, 1.0], 30.0).is_err());
        assert!(Camera::look_at([5.0, 0.0, 0.0], [0.0; 3], [0.0, 0.0, 1.0], 0.0).is_err());
    }

    #[test]
    fn orbit_looks_at_centre() {
        let b = Aabb {
            lo: [0.0; 3],
            hi: [2.0; 3],
        };
        let cam = Camera::orbit(&b, 30.0, 20.0, 40.0).unwrap();
        let (o, d) = cam.ray(50, 50, 101, 101);
        // The central ray passes through the box centre.
        let t = (1.0 - o[0]) / d[0];
        assert!((o[1] + t * d[1] - 1.0).abs() < 1e-9 && (o[2] + t * d[2] - 1.0).abs() < 1e-9);
    }
}
