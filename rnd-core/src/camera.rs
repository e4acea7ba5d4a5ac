//! The camera: look-from / look-at / up, clipping planes, field of view, image size
//! and projection, and the derived view frame: n = (fr − at)/|fr − at| points back at
//! the eye, u = up × n (normalized) to the right, v = n × u up.

use crate::affine::Affine4;
use crate::error::{Error, ErrorKind, Param, Result};
use crate::math;
/// The f64 3-vector of the camera frame (re-exported from `glam`).
pub use glam::DVec3;

/// What a camera is made from: where it is, where it looks, its clipping planes, field
/// of view, image size and projection (in `rendr`: `-fr -at -up -nc -fc -fov -sz
/// -ortho`). Start from [`CameraSpec::looking_at`] or [`CameraSpec::framing`] and change
/// what differs; [`Camera::new`] checks it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraSpec {
    /// Look-from point (world).
    pub from: [f64; 3],
    /// Look-at point (world).
    pub at: [f64; 3],
    /// Up vector (world); need not be unit length or perpendicular to the view direction.
    pub up: [f64; 3],
    /// Near clipping plane, distance along the view direction relative to the look-at
    /// (negative = between look-at and eye).
    pub near: f64,
    /// Far clipping plane, relative to the look-at.
    pub far: f64,
    /// Full vertical field of view, degrees.
    pub fov: f64,
    /// Image size: horizontal, vertical samples.
    pub size: [u32; 2],
    /// Orthographic instead of perspective projection.
    pub orthographic: bool,
}

impl CameraSpec {
    /// A perspective camera at `from` looking at `at`, with the defaults a first
    /// picture wants: up +z (or +y when looking along z), a 20° field of view, a 256 ×
    /// 256 image, and near and far planes half the eye distance before and after the
    /// look-at point. Change any of it with the builder methods, then validate with
    /// [`Camera::new`] (or let [`crate::render::RenderSpec::new`] do it).
    ///
    /// ```
    /// use rnd_core::camera::{Camera, CameraSpec};
    ///
    /// let spec = CameraSpec::looking_at([0.0, -50.0, 0.0], [0.0; 3])
    ///     .fov(30.0)
    ///     .size(320, 240)
    ///     .clip(-20.0, 20.0);
    /// let cam = Camera::new(spec).unwrap();
    /// assert_eq!(cam.d, 50.0);
    /// assert_eq!(cam.spec.up, [0.0, 0.0, 1.0]);
    /// ```
    pub fn looking_at(from: [f64; 3], at: [f64; 3]) -> CameraSpec {
        let d = math::v3::len(math::v3::sub(from, at));
        let dir = math::v3::sub(at, from);
        let up = if dir[0] == 0.0 && dir[1] == 0.0 {
            [0.0, 1.0, 0.0]
        } else {
            [0.0, 0.0, 1.0]
        };
        CameraSpec {
            from,
            at,
            up,
            near: -d / 2.0,
            far: d / 2.0,
            fov: 20.0,
            size: [256, 256],
            orthographic: false,
        }
    }

    /// A camera that shows the whole box of world points `corners` (e.g. a volume's
    /// [`crate::volume::Volume::world_corners`]), looking at its centre from direction
    /// `towards_eye` (any non-zero length; the eye sits that way from the centre), with
    /// a 20° field of view, near and far planes just around the box and a 256 × 256
    /// image. `None` when the corners or the direction are not finite, there are no
    /// corners or the direction is zero.
    ///
    /// ```
    /// use rnd_core::camera::CameraSpec;
    ///
    /// let box_ = [[0.0, 0.0, 0.0], [10.0, 10.0, 10.0]];
    /// let spec = CameraSpec::framing(&box_, [0.0, 0.0, 1.0]).unwrap().orthographic(true);
    /// assert_eq!(spec.at, [5.0, 5.0, 5.0]);
    /// assert!(spec.from[2] > 10.0 && spec.near < 0.0 && spec.far > 0.0);
    /// ```
    pub fn framing(corners: &[[f64; 3]], towards_eye: [f64; 3]) -> Option<CameraSpec> {
        let first = *corners.first()?;
        let (mut lo, mut hi) = (first, first);
        for c in corners {
            for a in 0..3 {
                lo[a] = lo[a].min(c[a]);
                hi[a] = hi[a].max(c[a]);
            }
        }
        let centre: [f64; 3] = core::array::from_fn(|a| 0.5 * (lo[a] + hi[a]));
        let radius = corners
            .iter()
            .map(|c| math::v3::len(math::v3::sub(*c, centre)))
            .fold(0.0f64, f64::max)
            .max(1e-9);
        let len = math::v3::len(towards_eye);
        if !(len > 0.0 && len.is_finite() && radius.is_finite() && math::v3::finite(centre)) {
            return None;
        }
        let fov: f64 = 20.0;
        // The bounding sphere fits the vertical field of view with 5% to spare.
        let d = 1.05 * radius / math::sin(fov.to_radians() / 2.0);
        let from: [f64; 3] = core::array::from_fn(|a| centre[a] + towards_eye[a] / len * d);
        let mut spec = CameraSpec::looking_at(from, centre);
        spec.near = -radius;
        spec.far = radius;
        Some(spec)
    }

    /// Sets the up vector (any length; not parallel to the view direction).
    pub fn up(mut self, up: [f64; 3]) -> CameraSpec {
        self.up = up;
        self
    }
    /// Sets the vertical field of view, degrees (in (0, 160)).
    pub fn fov(mut self, degrees: f64) -> CameraSpec {
        self.fov = degrees;
        self
    }
    /// Sets the near and far clipping planes, as distances along the view direction
    /// from the look-at point (negative: towards the eye).
    pub fn clip(mut self, near: f64, far: f64) -> CameraSpec {
        self.near = near;
        self.far = far;
        self
    }
    /// Sets the image size in pixels.
    pub fn size(mut self, width: u32, height: u32) -> CameraSpec {
        self.size = [width, height];
        self
    }
    /// Chooses an orthographic (`true`) or perspective projection.
    pub fn orthographic(mut self, ortho: bool) -> CameraSpec {
        self.orthographic = ortho;
        self
    }
}

/// A validated camera with its derived frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    /// The inputs it was built from.
    pub spec: CameraSpec,
    /// Aspect ratio `size[0] / size[1]`.
    pub ar: f64,
    /// Distance |fr − at| (world units).
    pub d: f64,
    /// View-space basis in world: right.
    pub u: DVec3,
    /// View-space basis in world: up.
    pub v: DVec3,
    /// View-space basis in world: backward (from look-at towards the eye).
    pub n: DVec3,
    /// World-to-view transform.
    pub wtov: Affine4,
    /// View-to-world transform (columns u, v, n, fr).
    pub vtow: Affine4,
    /// Distance from the eye to the near plane (view units = world units).
    pub ncv: f64,
    /// Distance from the eye to the far plane.
    pub fcv: f64,
    /// Height of the image plane through the look-at (world units).
    pub hght: f64,
    /// Width of the image plane through the look-at.
    pub wdth: f64,
}

fn cam_err(param: Param, msg: alloc::string::String) -> Error {
    Error::about(ErrorKind::Camera, param, msg)
}

impl Camera {
    /// Checks the inputs and computes the frame (u, v, n, the eye distance d, the
    /// near and far plane distances from the eye d + nc and d + fc, and the image plane
    /// through the look-at point, of height 2·d·tan(fov/2)).
    ///
    /// # Errors
    /// [`ErrorKind::Camera`] naming the parameter ([`Param`]) that is not finite, out
    /// of range, or leaves no view (look-from = look-at, up parallel to the view).
    pub fn new(spec: CameraSpec) -> Result<Camera> {
        use alloc::format;
        let fr = DVec3::from_array(spec.from);
        let at = DVec3::from_array(spec.at);
        let up = DVec3::from_array(spec.up);
        for (param, x) in [
            (Param::CameraFrom, spec.from),
            (Param::CameraAt, spec.at),
            (Param::CameraUp, spec.up),
        ] {
            if !math::v3::finite(x) {
                return Err(cam_err(
                    param,
                    format!(
                        "{}: not all finite ({} {} {})",
                        param.as_str(),
                        x[0],
                        x[1],
                        x[2]
                    ),
                ));
            }
        }
        for (param, x) in [
            (Param::CameraNear, spec.near),
            (Param::CameraFar, spec.far),
            (Param::CameraFov, spec.fov),
        ] {
            if !x.is_finite() {
                return Err(cam_err(
                    param,
                    format!("{}: {x} is not finite", param.as_str()),
                ));
            }
        }
        if !(spec.fov > 0.0 && spec.fov < 160.0) {
            return Err(cam_err(
                Param::CameraFov,
                format!(
                    "field of view must be in (0, 160) degrees (got {})",
                    spec.fov
                ),
            ));
        }
        if spec.size[0] == 0 || spec.size[1] == 0 {
            return Err(cam_err(
                Param::ImageSize,
                format!(
                    "image sizes must be > 0 (got {} {})",
                    spec.size[0], spec.size[1]
                ),
            ));
        }
        if spec.near >= spec.far {
            return Err(cam_err(
                Param::CameraNear,
                format!(
                    "near clip {} must be less than far clip {}",
                    spec.near, spec.far
                ),
            ));
        }
        let diff = fr - at;
        let d = diff.length();
        if !(d > 0.0) || !d.is_finite() {
            return Err(cam_err(
                Param::CameraFrom,
                format!(
                    "look-from equals look-at ({} {} {})",
                    spec.from[0], spec.from[1], spec.from[2]
                ),
            ));
        }
        let n = diff / d;
        let uc = up.cross(n);
        let ul = uc.length();
        if !(ul > 1e-10 * up.length()) || up.length() == 0.0 {
            return Err(cam_err(
                Param::CameraUp,
                format!(
                    "up vector ({} {} {}) is zero or parallel to the view direction",
                    spec.up[0], spec.up[1], spec.up[2]
                ),
            ));
        }
        let u = uc / ul;
        let v = n.cross(u);
        let ncv = d + spec.near;
        let fcv = d + spec.far;
        if !spec.orthographic && ncv <= 0.0 {
            return Err(cam_err(
                Param::CameraNear,
                format!(
                    "near plane {} puts it at or behind the eye (look-from is {} from look-at)",
                    crate::error::Num(spec.near),
                    crate::error::Num(d)
                ),
            ));
        }
        if !(fcv > ncv) {
            return Err(cam_err(
                Param::CameraNear,
                format!(
                    "near and far planes coincide in floating point at distance {d} from the eye"
                ),
            ));
        }
        let hght = 2.0 * d * math::tan(spec.fov.to_radians() / 2.0);
        let ar = spec.size[0] as f64 / spec.size[1] as f64;
        let wdth = ar * hght;
        let vtow = Affine4::from_columns(u.to_array(), v.to_array(), n.to_array(), spec.from);
        let wtov = Affine4::from_rows([
            u.x,
            u.y,
            u.z,
            -u.dot(fr),
            v.x,
            v.y,
            v.z,
            -v.dot(fr),
            n.x,
            n.y,
            n.z,
            -n.dot(fr),
            0.,
            0.,
            0.,
            1.,
        ]);
        Ok(Camera {
            spec,
            ar,
            d,
            u,
            v,
            n,
            wtov,
            vtow,
            ncv,
            fcv,
            hght,
            wdth,
        })
    }

    /// Image-plane position (u, v) of the centre of pixel (hi, vi); vi = 0 is the top row
    /// (pixel centres at (hi + ½)/W and (vi + ½)/H across the image plane).
    #[inline]
    pub fn image_plane(&self, hi: u32, vi: u32) -> (f64, f64) {
        let us = -self.wdth / 2.0 + self.wdth * (hi as f64 + 0.5) / self.spec.size[0] as f64;
        let vs = self.hght / 2.0 - self.hght * (vi as f64 + 0.5) / self.spec.size[1] as f64;
        (us, vs)
    }

    /// Continuous pixel coordinates (hi, vi) at which world point `p` appears (the
    /// inverse of the ray set-up: pixel centres are at integer coordinates).
    pub fn project(&self, p: [f64; 3]) -> (f64, f64) {
        self.project_view(self.wtov.point(p))
    }

    /// [`Camera::project`] of a point already in view space.
    fn project_view(&self, v: [f64; 3]) -> (f64, f64) {
        let (u, w) = if self.spec.orthographic {
            (v[0], v[1])
        } else {
            (v[0] * self.d / -v[2], v[1] * self.d / -v[2])
        };
        let hi = (u + self.wdth / 2.0) / self.wdth * self.spec.size[0] as f64 - 0.5;
        let vi = (self.hght / 2.0 - w) / self.hght * self.spec.size[1] as f64 - 0.5;
        (hi, vi)
    }

    /// Continuous pixel coordinates `[h0, h1, v0, v1]` of a rectangle holding the image
    /// of the convex hull of `pts` (world): a ray through a pixel outside it does not
    /// meet the hull (in exact arithmetic; callers add their own margins). None when a
    /// point is not well in front of the eye (perspective), where the image may be
    /// unbounded, or is not finite.
    pub fn reach(&self, pts: &[[f64; 3]]) -> Option<[f64; 4]> {
        let mut r = [
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ];
        for &p in pts {
            let v = self.wtov.point(p);
            // (A central projection keeps convexity only for points in front of the
            // eye; a point near the eye plane would also magnify every rounding.)
            let front = -v[2] > 1e-6 * (v[0].abs() + v[1].abs() + v[2].abs());
            if !self.spec.orthographic && !front {
                return None;
            }
            let (h, w) = self.project_view(v);
            if !(h.is_finite() && w.is_finite()) {
                return None;
            }
            r = [r[0].min(h), r[1].max(h), r[2].min(w), r[3].max(w)];
        }
        Some(r)
    }

    /// View-space start on the near plane and per-plane step for pixel (hi, vi), for a
    /// plane separation `plane_sep`: perspective rays start where the line from the eye
    /// through the pixel's image-plane point meets the near plane; orthographic rays
    /// start at that point moved onto the near plane.
    #[inline]
    pub fn ray(&self, hi: u32, vi: u32, plane_sep: f64) -> ([f64; 3], [f64; 3]) {
        let (us, vs) = self.image_plane(hi, vi);
        if self.spec.orthographic {
            ([us, vs, -self.ncv], [0.0, 0.0, -plane_sep])
        } else {
            let s = self.ncv / self.d;
            (
                [us * s, vs * s, -self.ncv],
                [plane_sep * us / self.d, plane_sep * vs / self.d, -plane_sep],
            )
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec() -> CameraSpec {
        CameraSpec {
            from: [6., 12., 5.],
            at: [0., 0., 0.],
            up: [0., 0., 1.],
            near: -2.56304,
            far: 2.56304,
            fov: 16.,
            size: [300, 300],
            orthographic: false,
        }
    }

    /// `reach` holds the projections of the points given (and so of their hull), and
    /// is None for a perspective camera with a point behind the eye.
    #[test]
    fn reach_holds_the_points() {
        let pts = [[1.0, 2.0, -1.0], [-2.0, 0.5, 1.5], [0.0, -1.0, 0.0]];
        for ortho in [false, true] {
            let c = Camera::new(CameraSpec {
                orthographic: ortho,
                ..spec()
            })
            .unwrap();
            let r = c.reach(&pts).unwrap();
            for p in pts {
                let (h, v) = c.project(p);
                assert!(
                    h >= r[0] && h <= r[1] && v >= r[2] && v <= r[3],
                    "{p:?} {r:?}"
                );
            }
            // Behind the eye at (6, 12, 5), looking towards the origin.
            let behind = c.reach(&[[0.0; 3], [12.0, 24.0, 10.0]]);
            assert_eq!(behind.is_none(), !ortho);
        }
    }

    #[test]
    fn spec_13_1() {
        let c = Camera::new(spec()).unwrap();
        assert!((c.ncv - 11.7547811).abs() < 1e-6);
        assert!((c.fcv - 16.8808611).abs() < 1e-6);
        assert!((c.hght - 4.02447705).abs() < 1e-7);
        assert!((c.u.x + 0.894427191).abs() < 1e-9);
        let p = c.wtov.point(c.vtow.point([1.0, 2.0, 3.0]));
        assert!((p[2] - 3.0).abs() < 1e-12);
    }

    #[test]
    fn project_inverts_ray() {
        for ortho in [false, true] {
            let mut sp = spec();
            sp.orthographic = ortho;
            sp.size = [31, 17];
            let c = Camera::new(sp).unwrap();
            for (hi, vi) in [(0, 0), (30, 16), (7, 11)] {
                let (s, d) = c.ray(hi, vi, 0.25);
                for k in [0.0, 3.0] {
                    let p = c
                        .vtow
                        .point([s[0] + k * d[0], s[1] + k * d[1], s[2] + k * d[2]]);
                    let (h, v) = c.project(p);
                    assert!((h - hi as f64).abs() < 1e-9 && (v - vi as f64).abs() < 1e-9);
                }
            }
        }
    }

    #[test]
    fn bad_cameras() {
        let mut s = spec();
        s.at = s.from;
        assert_eq!(Camera::new(s).unwrap_err().kind, ErrorKind::Camera);
        let mut s = spec();
        s.up = [6., 12., 5.];
        assert!(Camera::new(s).unwrap_err().msg.contains("parallel"));
        let mut s = spec();
        s.fov = 160.0;
        assert!(Camera::new(s).is_err());
        let mut s = spec();
        s.size = [0, 3];
        assert!(Camera::new(s).is_err());
    }
}
