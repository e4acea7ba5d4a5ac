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
///
/// [`Halves`] does the same for many samples with one eye direction, making each
/// light's half vector once.
pub fn blinn_phong(
    ph: &Phong,
    lights: &[([f32; 3], [f32; 3])],
    m: [f32; 3],
    g: [f32; 3],
    to_eye: [f32; 3],
) -> [f32; 3] {
    let lit = lights.iter().map(|&(c, l)| (c, l, half(l, to_eye)));
    shade(ph, lit, lights.is_empty(), m, g)
}

/// Lights with their half vectors for one direction to the eye: [`blinn_phong`]'s
/// results, bit for bit, without making the half vectors at every sample (the
/// direction is the same for every sample of a ray, and of every ray under an
/// orthographic camera).
#[derive(Debug, Clone, Default)]
pub struct Halves {
    /// The direction to the eye (bits) the half vectors are made for; None before any.
    eye: Option<[u32; 3]>,
    lit: Vec<HalfLit>,
}

/// A light's colour, unit direction and unit half vector (None where l + v is zero).
type HalfLit = ([f32; 3], [f32; 3], Option<[f32; 3]>);

impl Halves {
    /// For world (colour, unit direction) `lights`.
    pub fn new(lights: &[([f32; 3], [f32; 3])]) -> Self {
        Halves {
            eye: None,
            lit: lights.iter().map(|&(c, l)| (c, l, None)).collect(),
        }
    }

    /// [`blinn_phong`] with these lights; the half vectors are made again only when
    /// `to_eye` is not the last call's (the same bits: every number from it is the same).
    #[inline]
    pub fn shade(&mut self, ph: &Phong, m: [f32; 3], g: [f32; 3], to_eye: [f32; 3]) -> [f32; 3] {
        let bits = to_eye.map(f32::to_bits);
        if self.eye != Some(bits) {
            for (_, l, h) in &mut self.lit {
                *h = half(*l, to_eye);
            }
            self.eye = Some(bits);
        }
        shade(ph, self.lit.iter().copied(), self.lit.is_empty(), m, g)
    }
}

/// The unit half vector of light direction `l` and `to_eye`, None where their sum is 0.
#[inline]
fn half(l: [f32; 3], to_eye: [f32; 3]) -> Option<[f32; 3]> {
    let h = [l[0] + to_eye[0], l[1] + to_eye[1], l[2] + to_eye[2]];
    let hl = math::sqrtf(dot(h, h));
    (hl > 0.0).then(|| scale(1.0 / hl, h))
}

#[inline(always)]
fn dot(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[inline(always)]
fn scale(s: f32, a: [f32; 3]) -> [f32; 3] {
    [s * a[0], s * a[1], s * a[2]]
}

/// The sum of [`blinn_phong`] over (colour, direction, half vector) triples.
#[inline(always)]
fn shade(
    ph: &Phong,
    lit: impl Iterator<Item = HalfLit>,
    none: bool,
    m: [f32; 3],
    g: [f32; 3],
) -> [f32; 3] {
    let mut out = scale(ph.ka, m);
    let gl = math::sqrtf(dot(g, g));
    if none || (ph.kd == 0.0 && ph.ks == 0.0) || gl == 0.0 || !gl.is_finite() {
        return out;
    }
    let nrm = scale(1.0 / gl, [-g[0], -g[1], -g[2]]);
    let pow = crate::refarith::Power::new(ph.p);
    for (c, l, h) in lit {
        let ndl = dot(nrm, l).max(0.0);
        let sp = match h {
            Some(h) => ph.ks * pow.of(dot(nrm, h).max(0.0)),
            None => 0.0,
        };
        for i in 0..3 {
            out[i] += c[i] * (ph.kd * ndl * m[i] + sp);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The half vectors made once give [`blinn_phong`]'s bits, as the eye direction and
    /// the lights change (zero, non-finite and opposite-to-the-eye cases included).
    #[test]
    fn halves_shade_as_blinn_phong() {
        let mut seed = 7u64;
        let mut rnd = move || {
            seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
            ((seed >> 40) as f32 / (1u64 << 24) as f32) * 2.0 - 1.0
        };
        let unit = |v: [f32; 3]| scale(1.0 / math::sqrtf(dot(v, v)), v);
        for round in 0..200 {
            let to_eye = unit([rnd(), rnd(), rnd()]);
            let n = round % 4;
            let mut lights: Vec<_> = (0..n)
                .map(|_| ([rnd() + 1.0, rnd() + 1.0, 0.5], unit([rnd(), rnd(), rnd()])))
                .collect();
            if round % 5 == 1 && n > 0 {
                lights[0].1 = to_eye.map(|x| -x); // l + v = 0: no specular term
            }
            let ph = Phong {
                p: [150.0, 1.0, 2.5, 40.0][(round / 4) % 4],
                ks: if round % 7 == 3 { 0.0 } else { 0.1 },
                ..Phong::default()
            };
            let mut halves = Halves::new(&lights);
            let other = unit([rnd(), rnd(), rnd()]);
            for s in 0..50 {
                let m = [rnd().abs(), rnd().abs(), rnd().abs()];
                let g = match s {
                    0 => [0.0; 3],
                    1 => [f32::NAN, 0.0, 1.0],
                    2 => [f32::INFINITY, 0.0, 0.0],
                    _ => [rnd() * 100.0, rnd(), rnd() * 1e-3],
                };
                // The eye direction changes now and then, as from ray to ray.
                let eye = if s % 4 == 3 { other } else { to_eye };
                let want = blinn_phong(&ph, &lights, m, g, eye).map(f32::to_bits);
                let got = halves.shade(&ph, m, g, eye).map(f32::to_bits);
                assert_eq!(got, want);
            }
        }
    }
}
