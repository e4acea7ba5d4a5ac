//! Directional lights, Blinn-Phong shading of a material colour m (ka·m + Σ over lights
//! of colour c: c·(kd·max(0, N·L)·m + ks·max(0, N·H)^p), N = −∇f/|∇f|, L towards the
//! light, H the half-way vector of L and the direction to the eye) and depth cueing
//! (colours scaled from `dcn` at the near plane to `dcf` at the far plane).

use alloc::vec::Vec;

use crate::camera::Camera;
use crate::error::{Error, ErrorKind, Result};
use crate::math::{self, v3};

/// The frame a light's direction is given in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum LightSpace {
    /// View space: (u, v, n) = right, up and backward (towards the eye) of the camera, so
    /// the light moves with the camera.
    View,
    /// World space: fixed to the volume's world.
    World,
}

/// One directional light.
///
/// ```
/// use rnd_core::light::{Light, LightSpace};
///
/// // A white light over the viewer's right shoulder, moving with the camera.
/// let key = Light::new([1.0; 3], [1.0, 1.0, 1.0], LightSpace::View).unwrap();
/// assert_eq!(key.space, LightSpace::View);
/// assert!(Light::new([1.0; 3], [0.0; 3], LightSpace::World).is_err());
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Light {
    /// Colour, RGB (HSV files are converted on load).
    pub rgb: [f32; 3],
    /// Direction towards the light (any non-zero length), in `space`.
    pub dir: [f64; 3],
    /// The frame of `dir`.
    pub space: LightSpace,
}

/// At most this many lights light a rendering (each costs a Blinn-Phong term at every
/// lit sample; the course's light files hold a handful).
pub const MAX_LIGHTS: usize = 256;

impl Light {
    /// Checks the light: finite colour and direction, non-zero direction.
    ///
    /// # Errors
    /// [`ErrorKind::Light`] for a non-finite number or a zero direction.
    pub fn new(rgb: [f32; 3], dir: [f64; 3], space: LightSpace) -> Result<Light> {
        if rgb.iter().any(|c| !c.is_finite()) || !v3::finite(dir) {
            return Err(Error::new(
                ErrorKind::Light,
                "light has a non-finite number",
            ));
        }
        if v3::len(dir) == 0.0 {
            return Err(Error::new(
                ErrorKind::Light,
                "light direction has zero length",
            ));
        }
        Ok(Light { rgb, dir, space })
    }

    /// Unit world-space direction towards the light, for camera `cam`.
    pub fn world_dir(&self, cam: &Camera) -> [f64; 3] {
        let d = if self.space == LightSpace::View {
            let w = cam.u * self.dir[0] + cam.v * self.dir[1] + cam.n * self.dir[2];
            w.to_array()
        } else {
            self.dir
        };
        v3::normalize(d)
    }
}

/// Blinn-Phong parameters `-ph ka kd ks p`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Phong {
    /// Ambient coefficient.
    pub ka: f32,
    /// Diffuse coefficient.
    pub kd: f32,
    /// Specular coefficient.
    pub ks: f32,
    /// Specular exponent.
    pub p: f32,
}

impl Default for Phong {
    fn default() -> Self {
        Phong {
            ka: 0.2,
            kd: 0.8,
            ks: 0.1,
            p: 150.0,
        }
    }
}

/// Lights resolved for one camera: colours and unit world directions (f32).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct WorldLights {
    /// (colour, unit world direction towards the light).
    pub lights: Vec<([f32; 3], [f32; 3])>,
}

impl WorldLights {
    /// Resolves `lights` for `cam`.
    pub fn new(lights: &[Light], cam: &Camera) -> Self {
        let lights = lights
            .iter()
            .map(|l| {
                let d = l.world_dir(cam);
                (l.rgb, [d[0] as f32, d[1] as f32, d[2] as f32])
            })
            .collect();
        WorldLights { lights }
    }
}

/// Blinn-Phong shading of material colour `m` at a sample with world gradient `g`, for
/// `to_eye` the unit direction to the eye and `lights` world (colour, unit direction)
/// pairs, in the course reference's operation order (both arithmetics use it): the
/// normal n = −g·(1/|g|), one-sided diffuse max(n·l, 0), the half vector
/// h = (l + v)·(1/|l + v|), specular ks·max(n·h, 0)^p not multiplied by the material
/// colour: `ka m + Σ c (kd (n·l) m + ks (n·h)^p)`. Ambient only where the gradient is
/// zero or not finite; no specular term where l + v is zero.
pub fn blinn_phong(
    ph: &Phong,
    lights: &[([f32; 3], [f32; 3])],
    m: [f32; 3],
    g: [f32; 3],
    to_eye: [f32; 3],
) -> [f32; 3] {
    let dot = |a: [f32; 3], b: [f32; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let scale = |s: f32, a: [f32; 3]| [s * a[0], s * a[1], s * a[2]];
    let mut out = scale(ph.ka, m);
    let gl = math::sqrtf(dot(g, g));
    if lights.is_empty() || (ph.kd == 0.0 && ph.ks == 0.0) || gl == 0.0 || !gl.is_finite() {
        return out;
    }
    let nrm = scale(1.0 / gl, [-g[0], -g[1], -g[2]]);
    for &(c, l) in lights {
        let ndl = dot(nrm, l).max(0.0);
        let h = [l[0] + to_eye[0], l[1] + to_eye[1], l[2] + to_eye[2]];
        let hl = math::sqrtf(dot(h, h));
        let sp = if hl > 0.0 {
            let ndh = dot(nrm, scale(1.0 / hl, h)).max(0.0);
            ph.ks * crate::refarith::powf(ndh, ph.p)
        } else {
            0.0
        };
        for i in 0..3 {
            out[i] += c[i] * (ph.kd * ndl * m[i] + sp);
        }
    }
    out
}
