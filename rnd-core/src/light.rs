//! Directional lights, Blinn-Phong shading and depth cueing (SPEC §3.6, §9.4).

use alloc::vec::Vec;

use crate::camera::Camera;
use crate::error::{Error, ErrorKind, Result};
use crate::math::{self, v3};

/// One directional light as given in a light file.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Light {
    /// Colour, RGB (HSV files are converted on load).
    pub rgb: [f32; 3],
    /// Direction towards the light (any non-zero length); view space (u, v, n) when
    /// `view` is true, else world space.
    pub dir: [f64; 3],
    /// Whether `dir` is in view space.
    pub view: bool,
}

/// At most this many lights light a rendering (each costs a Blinn-Phong term at every
/// lit sample; the course's light files hold a handful).
pub const MAX_LIGHTS: usize = 256;

impl Light {
    /// Checks the light: finite colour and direction, non-zero direction.
    pub fn new(rgb: [f32; 3], dir: [f64; 3], view: bool) -> Result<Light> {
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
        Ok(Light { rgb, dir, view })
    }

    /// Unit world-space direction towards the light, for camera `cam`.
    pub fn world_dir(&self, cam: &Camera) -> [f64; 3] {
        let d = if self.view {
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

/// `x^p` for the specular term, `x` in [0, 1]: whole exponents up to 4096 (the usual
/// case) by repeated squaring in f64, rounded once to f32 (within 1 ulp of the exact
/// power, like `powf`, and several times faster); other exponents by `powf`.
#[inline]
fn spec_pow(x: f32, p: f32) -> f32 {
    let n = p as u32;
    if n as f32 != p || n > 4096 {
        return math::powf(x, p);
    }
    let (mut base, mut e, mut r) = (x as f64, n, 1.0f64);
    while e > 0 {
        if e & 1 == 1 {
            r *= base;
        }
        base *= base;
        e >>= 1;
    }
    r as f32
}

#[inline(always)]
fn dot3(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Blinn-Phong (one-sided; N = −g/|g|; specular not multiplied by the material).
/// `m` material colour, `g` world gradient, `vdir` unit direction from the sample to the
/// eye.
#[inline]
pub fn blinn_phong(
    ph: &Phong,
    lights: &WorldLights,
    m: [f32; 3],
    g: [f32; 3],
    vdir: [f32; 3],
) -> [f32; 3] {
    let amb = [ph.ka * m[0], ph.ka * m[1], ph.ka * m[2]];
    let gl = math::sqrtf(dot3(g, g));
    if lights.lights.is_empty() || (ph.kd == 0.0 && ph.ks == 0.0) || gl == 0.0 || !gl.is_finite() {
        return amb;
    }
    let nrm = [-g[0] / gl, -g[1] / gl, -g[2] / gl];
    let mut out = amb;
    for &(c, l) in &lights.lights {
        let ndl = dot3(nrm, l).max(0.0);
        let h = [l[0] + vdir[0], l[1] + vdir[1], l[2] + vdir[2]];
        let hl = math::sqrtf(dot3(h, h));
        let spec = if hl > 0.0 && ph.ks != 0.0 {
            let ndh = (dot3(nrm, h) / hl).max(0.0);
            ph.ks * spec_pow(ndh, ph.p)
        } else {
            0.0
        };
        for i in 0..3 {
            out[i] += c[i] * (ph.kd * ndl * m[i] + spec);
        }
    }
    out
}
