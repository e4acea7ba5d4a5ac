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

/// [`blinn_phong`] of the first `n` of `N` samples of one ray at once (materials `m`
/// and world gradients `g` channel by channel: `m[c][i]` is sample i's channel c; one
/// `to_eye`): channel c of sample i's colour, `[c][i]` of the result, is the bits
/// `blinn_phong` gives it (lanes from `n` on hold no colour). The same operations in
/// the same order, laid out sample by sample across lanes (square roots by vector
/// instructions, specular powers by [`crate::refarith::powf_lanes`]), out of line and
/// compiled for the widest level `simd` allows.
#[inline(never)]
pub(crate) fn blinn_phong_lanes<const N: usize>(
    simd: crate::simd::Simd,
    ph: &Phong,
    lights: &[([f32; 3], [f32; 3])],
    m: &[[f32; N]; 3],
    g: &[[f32; N]; 3],
    to_eye: [f32; 3],
    n: usize,
) -> [[f32; N]; 3] {
    crate::simd::wide(simd, {
        #[inline(always)]
        || shade_lanes(simd, ph, lights, m, g, to_eye, n)
    })
}

/// The body of [`blinn_phong_lanes`]. (Plain loops over lanes: `array::from_fn` and
/// `map` may stay out of line, compiled without the vector level.)
#[inline(always)]
fn shade_lanes<const N: usize>(
    simd: crate::simd::Simd,
    ph: &Phong,
    lights: &[([f32; 3], [f32; 3])],
    m: &[[f32; N]; 3],
    g: &[[f32; N]; 3],
    to_eye: [f32; 3],
    n: usize,
) -> [[f32; N]; 3] {
    let mut ambient = [[0.0f32; N]; 3];
    for i in 0..3 {
        for l in 0..N {
            ambient[i][l] = ph.ka * m[i][l];
        }
    }
    if lights.is_empty() || (ph.kd == 0.0 && ph.ks == 0.0) {
        return ambient;
    }
    let mut gl = [0.0f32; N];
    for l in 0..N {
        gl[l] = g[0][l] * g[0][l] + g[1][l] * g[1][l] + g[2][l] * g[2][l];
    }
    crate::simd::sqrt_lanes(simd, &mut gl);
    let mut nrm = [[0.0f32; N]; 3];
    for l in 0..N {
        let s = 1.0 / gl[l];
        for a in 0..3 {
            nrm[a][l] = s * -g[a][l];
        }
    }
    let mut out = ambient;
    let dot = |a: [f32; 3], b: [f32; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    // max(n·d, 0) of every lane.
    let along = |d: [f32; 3]| {
        let mut x = [0.0f32; N];
        for l in 0..N {
            x[l] = (nrm[0][l] * d[0] + nrm[1][l] * d[1] + nrm[2][l] * d[2]).max(0.0);
        }
        x
    };
    for &(c, lt) in lights {
        let ndl = along(lt);
        // The half vector is the ray's, the same for every sample.
        let h = [lt[0] + to_eye[0], lt[1] + to_eye[1], lt[2] + to_eye[2]];
        let hl = math::sqrtf(dot(h, h));
        let mut sp = [0.0f32; N];
        if hl > 0.0 {
            let s = 1.0 / hl;
            sp = crate::refarith::powf_lanes(&along([s * h[0], s * h[1], s * h[2]]), ph.p, n);
            for x in sp.iter_mut() {
                *x *= ph.ks;
            }
        }
        for i in 0..3 {
            for l in 0..N {
                out[i][l] += c[i] * (ph.kd * ndl[l] * m[i][l] + sp[l]);
            }
        }
    }
    // Ambient alone where the gradient is zero or not finite.
    for l in 0..N {
        let lit = gl[l] != 0.0 && gl[l].is_finite();
        for i in 0..3 {
            out[i][l] = if lit { out[i][l] } else { ambient[i][l] };
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::simd::{Simd, SimdLevel};
    use alloc::vec;

    /// `blinn_phong_lanes` gives every lane `blinn_phong`'s bits, at every vector level:
    /// random gradients and materials, zero, tiny, huge, infinite and NaN gradients,
    /// back-facing normals, one to three lights (one opposite the eye: no half vector),
    /// whole and fractional specular powers, zero coefficients.
    #[test]
    fn lanes_are_blinn_phong() {
        let mut s = 0x2545_f491_4f6c_dd1du64;
        let mut rnd = move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0
        };
        let eye = {
            let e = [0.3f32, -0.5, 0.81];
            let l = (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]).sqrt();
            e.map(|c| c / l)
        };
        let odd = [
            [0.0, 0.0, 0.0],
            [-0.0, 0.0, -0.0],
            [1e-30, 0.0, 0.0],
            [3e19, -2e19, 1e19],
            [f32::INFINITY, 0.0, 1.0],
            [f32::NAN, 1.0, 0.0],
        ];
        for (round, p) in [150.0f32, 1.0, 7.0, 12.5, 0.0, 70_000.0]
            .into_iter()
            .enumerate()
        {
            let mut lights = vec![([1.0, 0.9, 0.8], eye)];
            if round % 2 == 1 {
                lights.push(([0.5, 0.2, 1.0], [-eye[0], -eye[1], -eye[2]]));
            }
            if round >= 2 {
                lights.push(([0.3, 0.3, 0.3], [0.0, 0.6, 0.8]));
            }
            let phongs = [
                Phong {
                    p,
                    ..Phong::default()
                },
                Phong {
                    kd: 0.0,
                    ks: 0.0,
                    p,
                    ..Phong::default()
                },
                Phong {
                    kd: 0.0,
                    p,
                    ..Phong::default()
                },
            ];
            for ph in &phongs {
                for lt in [&lights[..], &[]] {
                    for batch in 0..40 {
                        let g: [[f32; 3]; 16] = core::array::from_fn(|l| {
                            if (batch + l) % 5 == 0 {
                                odd[(batch + l) % odd.len()]
                            } else {
                                [rnd() * 300.0, rnd() * 300.0, rnd() * 300.0]
                            }
                        });
                        let m: [[f32; 3]; 16] =
                            core::array::from_fn(|_| [rnd().abs(), rnd().abs(), rnd().abs()]);
                        let by_channel = |x: &[[f32; 3]; 16]| -> [[f32; 16]; 3] {
                            core::array::from_fn(|c| core::array::from_fn(|l| x[l][c]))
                        };
                        let (mc, gc) = (by_channel(&m), by_channel(&g));
                        for level in [SimdLevel::Baseline, SimdLevel::Avx2, SimdLevel::Avx512] {
                            let n = 16 - batch % 3;
                            let got =
                                blinn_phong_lanes(Simd::at_most(level), ph, lt, &mc, &gc, eye, n);
                            for l in 0..n {
                                let want = blinn_phong(ph, lt, m[l], g[l], eye);
                                let got = [got[0][l], got[1][l], got[2][l]];
                                assert_eq!(
                                    got.map(f32::to_bits),
                                    want.map(f32::to_bits),
                                    "lane {l}: g {:?}, p {p}",
                                    g[l]
                                );
                            }
                        }
                    }
                }
            }
        }
    }
}
