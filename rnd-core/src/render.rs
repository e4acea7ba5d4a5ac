//! Ray casting: the validated [`RenderSpec`], one ray per pixel, and the run-time →
//! compile-time dispatch on (voxel type, kernel).
//!
//! Probing (what a sample measures) and blending (how samples combine, [`Accum`]) are
//! separate steps: `RenderSpec::probe` fills a probe vector, [`Accum::add`] blends it.

use alloc::vec::Vec;

use crate::blend::{Accum, Blend};
use crate::camera::{Camera, CameraSpec};
use crate::convo::{grad_to_world, locate, place, world_gmags, Convo, ConvoSample, Place};
use crate::error::{Error, ErrorKind, Result};
use crate::kernel::{BoxK, Bspln2, Bspln3, C4Hexic, Ctmr, Kernel, KernelName, Tent, Zero};
use crate::light::{blinn_phong, Light, Phong, WorldLights};
use crate::math;
use crate::probe::Probe;
use crate::refarith::{self, Block, Lanes, RefCamera, RefIndex, LANES};
use crate::skip::{SkipGrid, SkipPlan, COARSE_EMPTY, FINE_EMPTY};
use crate::txf::{Levoy, Lut};
use crate::volume::Volume;
use crate::voxel::Voxel;

/// Most samples one ray may take ((fcv − ncv) / plane separation).
pub const MAX_SAMPLES_PER_RAY: f64 = 1e7;

/// Everything `go` is asked to do, before validation.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderParams {
    /// Camera.
    pub camera: CameraSpec,
    /// Distance between sampling planes (`-s`); 0 = one sample on the near plane.
    pub plane_sep: f64,
    /// Take one sample on the near plane only (`-s1s`).
    pub sample_once: bool,
    /// What to measure.
    pub probe: Probe,
    /// How to combine.
    pub blend: Blend,
    /// Value of every channel for rays with nothing to blend (`-ov`).
    pub outside: f32,
    /// Unit step for opacity correction (`-us`), world units.
    pub unit_step: f64,
    /// Early ray termination threshold (`-a1`), in (0, 1]; 1 = off.
    pub alpha_near1: f32,
    /// Blinn-Phong parameters.
    pub phong: Phong,
    /// Depth-cue colour at the near plane.
    pub dcn: [f32; 3],
    /// Depth-cue colour at the far plane.
    pub dcf: [f32; 3],
    /// Append a per-ray time channel (ms).
    pub time: bool,
    /// Skip the convolution where the LUT opacity is zero for every reachable value
    /// (`over` only; exact).
    pub skip_empty: bool,
    /// Use the accelerated ray loop where it applies (probes read from the convolution):
    /// each ray's inside stretch is found up front and only it is sampled. Exact: the
    /// output is bit-identical to the plain loop.
    pub fast_loop: bool,
    /// Compute in the course reference program's f32 arithmetic (`-ref`, the default;
    /// [`crate::refarith`]), which reproduces the reference's images. `false` selects
    /// the f64 engine (f64 geometry, separable SIMD sums): 1.65–2.2× quicker, within
    /// 1e-4 relative of the reference arithmetic on nearly every pixel (not where round-off
    /// moves a sample across a LUT bin boundary) but not its bits. The reference
    /// arithmetic needs volumes of at most [`refarith::MAX_AXIS`] samples per axis and a
    /// camera, lights and steps that f32 can hold ([`RenderSpec::new`] checks the last).
    pub reference: bool,
}

impl RenderParams {
    /// Parameters with the SPEC §12 defaults and the given camera.
    pub fn new(camera: CameraSpec) -> Self {
        RenderParams {
            camera,
            plane_sep: 0.1,
            sample_once: false,
            probe: Probe::Value,
            blend: Blend::Max,
            outside: 0.0,
            unit_step: 1.0,
            alpha_near1: 1.0,
            phong: Phong::default(),
            dcn: [1.0; 3],
            dcf: [1.0; 3],
            time: false,
            skip_empty: true,
            fast_loop: true,
            reference: true,
        }
    }
}

/// A validated render description with everything the sample loop reads precomputed.
#[derive(Debug, Clone)]
pub struct RenderSpec<'a> {
    /// The parameters.
    pub params: RenderParams,
    /// The camera frame.
    pub camera: Camera,
    lut: Option<&'a Lut>,
    levoy: Option<&'a Levoy>,
    lights: WorldLights,
    /// Output channels per pixel (probe length, +1 with time).
    pub channels: usize,
    need_grad: bool,
    once: bool,
    /// Opacity-corrected LUT alphas for one correction exponent (see
    /// [`RenderSpec::colour`]), when every ray shares it (orthographic cameras).
    alpha_table: Option<(f32, Vec<f32>)>,
    /// ln(1 − α) of each LUT entry's clamped opacity (see [`correct_alpha`]).
    ln_transparency: Vec<f64>,
    /// Whether the depth cue changes colours (not both ends 1, where each factor is 1
    /// + τ · 0 = 1 exactly, τ being finite).
    depth_cue: bool,
    /// The f32 camera and lights of the reference arithmetic (`params.reference`).
    ref_cam: RefCamera,
    ref_lights: Vec<([f32; 3], [f32; 3])>,
}

fn rerr(msg: alloc::string::String) -> Error {
    Error::new(ErrorKind::Render, msg)
}

impl<'a> RenderSpec<'a> {
    /// Validates once: camera, step sizes, thresholds, probe/blend pairing and the
    /// files each probe needs.
    pub fn new(
        params: RenderParams,
        lut: Option<&'a Lut>,
        levoy: Option<&'a Levoy>,
        lights: &[Light],
    ) -> Result<Self> {
        use alloc::format;
        let camera = Camera::new(params.camera)?;
        let once = params.sample_once || params.plane_sep == 0.0;
        if !params.plane_sep.is_finite() || params.plane_sep < 0.0 {
            return Err(rerr(format!(
                "-s: plane separation {} must be >= 0",
                crate::error::Num(params.plane_sep)
            )));
        }
        if !once {
            let per_ray = (camera.fcv - camera.ncv) / params.plane_sep;
            if !(per_ray <= MAX_SAMPLES_PER_RAY) {
                return Err(rerr(format!(
                    "-s: plane separation {} gives {per_ray:.3e} samples per ray (limit {MAX_SAMPLES_PER_RAY:e})",
                    crate::error::Num(params.plane_sep)
                )));
            }
        }
        if !(params.unit_step.is_finite() && params.unit_step > 0.0) {
            return Err(rerr(format!(
                "-us: unit step {} must be finite and > 0",
                params.unit_step
            )));
        }
        if !(params.alpha_near1 > 0.0 && params.alpha_near1 <= 1.0) {
            return Err(rerr(format!(
                "-a1: alphaNear1 {} must be in (0, 1]",
                params.alpha_near1
            )));
        }
        let ph = params.phong;
        if ![ph.ka, ph.kd, ph.ks, ph.p].iter().all(|x| x.is_finite()) {
            return Err(rerr(format!(
                "-ph: need finite values (got {} {} {} {})",
                ph.ka, ph.kd, ph.ks, ph.p
            )));
        }
        if params
            .dcn
            .iter()
            .chain(params.dcf.iter())
            .any(|x| !x.is_finite())
        {
            return Err(rerr("-dcn/-dcf: depth-cue colours must be finite".into()));
        }
        if ph.p < 0.0 {
            return Err(rerr(format!(
                "-ph: specular exponent {} must be >= 0",
                ph.p
            )));
        }
        if params.blend == Blend::Over && !params.probe.is_colour() {
            return Err(rerr(format!(
                "-b over: with over blend, must probe rgba or rgbalit (not {})",
                params.probe
            )));
        }
        if params.probe.is_colour() && lut.is_none() {
            return Err(rerr(format!("-p {}: needs a LUT (-lut)", params.probe)));
        }
        if lights.len() > crate::light::MAX_LIGHTS {
            return Err(Error::new(
                ErrorKind::Light,
                alloc::format!(
                    "{} lights; at most {} are allowed",
                    lights.len(),
                    crate::light::MAX_LIGHTS
                ),
            ));
        }
        if params.probe == Probe::RgbaLit && lights.is_empty() {
            return Err(rerr("-p rgbalit: needs lights (-lit)".into()));
        }
        let need_grad = params.probe == Probe::GradVec
            || params.probe == Probe::GradMag
            || params.probe == Probe::RgbaLit
            || (params.probe == Probe::Rgba && levoy.is_some());
        let channels = params.probe.length() + usize::from(params.time);
        let ref_cam = RefCamera::new(&params.camera);
        let ref_lights = if params.reference {
            if !ref_cam.is_finite() {
                return Err(rerr(alloc::format!(
                    "the camera (look-from {:?}, look-at {:?}) is beyond the reference's \
                     f32 arithmetic (there: eye distance {}, near plane {}, far plane {}); \
                     use -ref false",
                    params.camera.fr,
                    params.camera.at,
                    ref_cam.d,
                    ref_cam.ncv,
                    ref_cam.fcv
                )));
            }
            let f32_ok = |x: f64| (x as f32).is_finite() && (x == 0.0 || x as f32 > 0.0);
            if !f32_ok(params.unit_step) || !f32_ok(params.plane_sep) {
                return Err(rerr(alloc::format!(
                    "-us {:?} / -s {:?} are beyond the reference's f32 arithmetic; use -ref false",
                    params.unit_step,
                    params.plane_sep
                )));
            }
            let rl = ref_cam.lights(lights);
            if let Some(i) = rl
                .iter()
                .position(|(c, d)| !c.iter().chain(d.iter()).all(|x| x.is_finite()))
            {
                return Err(rerr(alloc::format!(
                    "light {} (direction {:?}) is beyond the reference's f32 arithmetic; \
                     use -ref false",
                    i + 1,
                    lights[i].dir
                )));
            }
            rl
        } else {
            Vec::new()
        };
        let lights = WorldLights::new(lights, &camera);
        let depth_cue = params.dcn != [1.0; 3] || params.dcf != [1.0; 3];
        let mut spec = RenderSpec {
            params,
            camera,
            lut,
            levoy,
            lights,
            channels,
            need_grad,
            once,
            alpha_table: None,
            ln_transparency: Vec::new(),
            depth_cue,
            ref_cam,
            ref_lights,
        };
        if let Some(lut) = lut {
            if lut.entries().len() <= 1 << 20 {
                spec.ln_transparency = lut
                    .entries()
                    .iter()
                    .map(|e| ln_transparency(e[3].clamp(0.0, 1.0)))
                    .collect();
            }
        }
        // Orthographic rays all step the same length, so the corrected opacity of each
        // LUT entry can be computed once (not for Levoy, which scales alpha per sample).
        if let (Some(lut), None, true) = (lut, levoy, spec.camera.spec.ortho) {
            if lut.entries().len() <= 1 << 16 {
                let ex = spec.ray_geom(0, 0).alpha_exp;
                let t = lut
                    .entries()
                    .iter()
                    .map(|e| correct_alpha(e[3], ex))
                    .collect();
                spec.alpha_table = Some((ex, t));
            }
        }
        Ok(spec)
    }

    /// Image width and height.
    pub fn size(&self) -> [u32; 2] {
        self.camera.spec.size
    }

    /// The empty-space-skipping grid for `vol`, when it applies (an `over` render of a
    /// colour probe with `params.skip_empty`).
    pub fn skip_grid<V: Voxel>(&self, vol: &Volume<'_, V>, kernel: KernelName) -> Option<SkipGrid> {
        self.skip_plan(vol, kernel).map(|plan| plan.build(vol))
    }

    /// [`RenderSpec::skip_grid`]'s plan, for building the grid in parts (e.g. on
    /// several threads; the same grid).
    pub fn skip_plan<V: Voxel>(
        &self,
        vol: &Volume<'_, V>,
        kernel: KernelName,
    ) -> Option<SkipPlan<'a>> {
        let p = &self.params;
        match self.lut {
            Some(lut) if p.skip_empty && p.blend == Blend::Over && p.probe.is_colour() => {
                Some(SkipPlan::new(vol, kernel, lut))
            }
            _ => None,
        }
    }

    /// Whether the gradient is computed at each sample.
    pub fn needs_gradient(&self) -> bool {
        self.need_grad
    }
}

/// Geometry of one ray (all f64).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RayGeom {
    /// View-space start on the near plane.
    pub start_v: [f64; 3],
    /// View-space step between planes.
    pub step_v: [f64; 3],
    /// World-space start.
    pub start_w: [f64; 3],
    /// World-space step.
    pub step_w: [f64; 3],
    /// Length of one step (world units).
    pub step_len: f64,
    /// Opacity-correction exponent: step length over the unit step (`-us`).
    pub alpha_exp: f32,
    /// Unit direction from a sample towards the eye (world).
    pub to_eye: [f32; 3],
}

/// Everything known about one sample, for `-db` tracing.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SampleInfo {
    /// Sample number along the ray.
    pub k: u32,
    /// View-space position.
    pub pos_v: [f64; 3],
    /// World-space position.
    pub pos_w: [f64; 3],
    /// The convolution (index position, inside, value, gradients).
    pub convo: ConvoSample,
    /// The probe's value at this sample.
    pub probe: [f32; 4],
    /// Whether this sample was blended.
    pub counted: bool,
    /// The running blend after this sample.
    pub accum: Accum,
}

impl RenderSpec<'_> {
    /// Geometry of the ray through pixel (hi, vi).
    pub fn ray_geom(&self, hi: u32, vi: u32) -> RayGeom {
        self.ray_geom_eye(hi, vi, true)
    }

    /// [`RenderSpec::ray_geom`], with `to_eye` left zero unless `eye` (only lighting
    /// uses it).
    #[inline]
    fn ray_geom_eye(&self, hi: u32, vi: u32, eye: bool) -> RayGeom {
        let cam = &self.camera;
        let ps = if self.once {
            0.0
        } else {
            self.params.plane_sep
        };
        let (start_v, step_v) = cam.ray(hi, vi, ps);
        let to_eye = if eye {
            // Direction to the eye from a unit-separation step (valid also when ps = 0).
            let (_, dir_v) = cam.ray(hi, vi, 1.0);
            let dir_w = cam.vtow.vector(dir_v);
            let dl = math::v3::len(dir_w);
            [
                (-dir_w[0] / dl) as f32,
                (-dir_w[1] / dl) as f32,
                (-dir_w[2] / dl) as f32,
            ]
        } else {
            [0.0; 3]
        };
        let step_w = cam.vtow.vector(step_v);
        let step_len = math::v3::len(step_w);
        RayGeom {
            start_v,
            step_v,
            start_w: cam.vtow.point(start_v),
            step_w,
            step_len,
            alpha_exp: (step_len / self.params.unit_step) as f32,
            to_eye,
        }
    }

    /// Computes the probe at one sample. Returns whether the sample is blended.
    #[inline(always)]
    fn probe(
        &self,
        pos_v: &[f64; 3],
        pos_w: &[f64; 3],
        cs: &ConvoSample,
        g: &RayGeom,
        out: &mut [f32; 4],
    ) -> bool {
        let p = &self.params;
        let f3 = |a: &[f64; 3], out: &mut [f32; 4]| {
            out[0] = a[0] as f32;
            out[1] = a[1] as f32;
            out[2] = a[2] as f32;
        };
        match p.probe {
            Probe::PosView => f3(pos_v, out),
            Probe::PosWorld => f3(pos_w, out),
            Probe::PosIndex => f3(&cs.pos_i, out),
            Probe::Inside => out[0] = if cs.inside { 1.0 } else { 0.0 },
            _ if !cs.inside => return false,
            Probe::Value => out[0] = cs.value,
            Probe::GradVec => out[..3].copy_from_slice(&cs.grad_w),
            Probe::GradMag => out[0] = gmag(&cs.grad_w),
            Probe::Rgba | Probe::RgbaLit => {
                let cam = &self.camera;
                let tau = || ((-pos_v[2] - cam.ncv) / (cam.fcv - cam.ncv)) as f32;
                return self.colour(cs.value, &cs.grad_w, g, tau, out);
            }
        }
        true
    }

    /// Early ray termination (`-a1`): under `over`, once the accumulated opacity passes
    /// alphaNear1 it is taken as 1 and the ray ends (true).
    #[inline(always)]
    fn opaque_end(&self, acc: &mut Accum) -> bool {
        let p = &self.params;
        if p.blend == Blend::Over && acc.acc[3] > p.alpha_near1 {
            acc.acc[3] = 1.0;
            true
        } else {
            false
        }
    }

    /// The corrected opacity of LUT entry `i` on ray `g` without Levoy opacity.
    #[inline(always)]
    fn lut_alpha(&self, lut: &Lut, i: usize, g: &RayGeom) -> f32 {
        match &self.alpha_table {
            Some((ex, t)) if *ex == g.alpha_exp => t[i],
            _ if i < self.ln_transparency.len() => {
                correct_alpha_ln(lut.entries()[i][3], self.ln_transparency[i], g.alpha_exp)
            }
            _ => correct_alpha(lut.entries()[i][3], g.alpha_exp),
        }
    }

    /// The rgba / rgbalit probe for value `v` and world gradient `gw`; `tau` gives the
    /// depth-cue position (0 at the near plane, 1 at the far plane) when lighting.
    #[inline(always)]
    fn colour(
        &self,
        v: f32,
        gw: &[f32; 3],
        g: &RayGeom,
        tau: impl FnOnce() -> f32,
        out: &mut [f32; 4],
    ) -> bool {
        let p = &self.params;
        let Some(lut) = self.lut else { return false };
        let i = lut.index(v as f64);
        let e = lut.entries()[i];
        let a = match self.levoy {
            None => self.lut_alpha(lut, i, g),
            Some(lev) => correct_alpha(e[3] * lev.opacity(v, gmag(gw)), g.alpha_exp),
        };
        if a == 0.0 && p.blend == Blend::Over {
            // Adds nothing under `over`: no need to light it.
            *out = [0.0; 4];
            return true;
        }
        let mut rgb = [e[0], e[1], e[2]];
        if p.probe == Probe::RgbaLit {
            rgb = blinn_phong(&p.phong, &self.lights, rgb, *gw, g.to_eye);
            if self.depth_cue {
                let tau = tau();
                for c in 0..3 {
                    rgb[c] *= p.dcn[c] + tau * (p.dcf[c] - p.dcn[c]);
                }
            }
        }
        *out = [rgb[0], rgb[1], rgb[2], a];
        true
    }

    /// Casts the ray through pixel (hi, vi) and writes its probe-length result to `out`
    /// (the time channel, if any, is the caller's). `trace`, when given, sees every
    /// sample.
    #[inline]
    pub fn cast<V: Voxel, K: Kernel<S>, const S: usize>(
        &self,
        convo: &mut Convo<'_, V, K, S>,
        hi: u32,
        vi: u32,
        out: &mut [f32],
        mut trace: Option<&mut dyn FnMut(&SampleInfo)>,
    ) {
        if self.params.reference {
            self.cast_ref(convo, None, hi, vi, out, trace.take());
        } else {
            self.cast_skip(convo, None, hi, vi, out, trace.take());
        }
    }

    /// [`RenderSpec::cast`] with optional empty-space skipping (`over` only; ignored
    /// otherwise): samples in blocks of `skip` marked empty are counted as inside with
    /// zero opacity, without convolving. The result is identical to the plain path.
    #[inline]
    pub fn cast_skip<V: Voxel, K: Kernel<S>, const S: usize>(
        &self,
        convo: &mut Convo<'_, V, K, S>,
        skip: Option<&SkipGrid>,
        hi: u32,
        vi: u32,
        out: &mut [f32],
        mut trace: Option<&mut dyn FnMut(&SampleInfo)>,
    ) {
        let p = &self.params;
        let skip = if p.blend == Blend::Over && p.probe.is_colour() {
            skip
        } else {
            None
        };
        let g = self.ray_geom(hi, vi);
        let wtoi = *convo.volume().wtoi();
        let start_i = wtoi.point(g.start_w);
        let step_i = wtoi.vector(g.step_w);
        let needs_convo = p.probe.needs_convo();
        let mut acc = Accum::new(p.blend, p.probe.length());
        let fcv = self.camera.fcv;
        let kmax = self.plane_limit();
        let mut k: u32 = 0;
        loop {
            let kf = k as f64;
            let at =
                |s: &[f64; 3], d: &[f64; 3]| [s[0] + kf * d[0], s[1] + kf * d[1], s[2] + kf * d[2]];
            let pos_v = at(&g.start_v, &g.step_v);
            if k > 0 && (-pos_v[2] > fcv || k > kmax) {
                break;
            }
            let pos_w = at(&g.start_w, &g.step_w);
            let pos_i = at(&start_i, &step_i);
            if let Some(sk) = skip {
                if let Some(lo) = convo.support_start(pos_i) {
                    if sk.empty_at(lo) {
                        // Inside, opacity 0: blending it changes nothing but the count.
                        acc.add(&[0.0; 4]);
                        if self.once {
                            break;
                        }
                        k += 1;
                        continue;
                    }
                }
            }
            let cs = if needs_convo {
                convo.eval_index(pos_i, self.need_grad)
            } else {
                ConvoSample {
                    pos_i,
                    ..ConvoSample::default()
                }
            };
            let mut pr = [0.0f32; 4];
            let counted = self.probe(&pos_v, &pos_w, &cs, &g, &mut pr);
            if counted {
                acc.add(&pr);
            }
            if let Some(t) = trace.as_deref_mut() {
                t(&SampleInfo {
                    k,
                    pos_v,
                    pos_w,
                    convo: cs,
                    probe: pr,
                    counted,
                    accum: acc,
                });
            }
            if self.once || self.opaque_end(&mut acc) {
                break;
            }
            k += 1;
        }
        acc.finish(p.outside, out);
    }

    /// [`RenderSpec::cast_skip`] in the reference program's f32 arithmetic
    /// ([`crate::refarith`]; `params.reference`). Skipping empty blocks (`over` only) is
    /// exact here too: such a sample has opacity 0, which leaves T and C unchanged.
    /// Without a trace, with `params.fast_loop` and a probe read from the convolution,
    /// samples go through the batched loop (sixteen at a time); otherwise one at a time.
    /// Both give the same bits.
    pub fn cast_ref<V: Voxel, K: Kernel<S>, const S: usize>(
        &self,
        convo: &Convo<'_, V, K, S>,
        skip: Option<&SkipGrid>,
        hi: u32,
        vi: u32,
        out: &mut [f32],
        mut trace: Option<&mut dyn FnMut(&SampleInfo)>,
    ) {
        if trace.is_none() && !self.once && self.fast_applies() {
            return if self.need_grad {
                self.cast_ref_lanes::<V, K, S, true>(convo, skip, hi, vi, out)
            } else {
                self.cast_ref_lanes::<V, K, S, false>(convo, skip, hi, vi, out)
            };
        }
        let p = &self.params;
        let vol = convo.volume();
        let over = p.blend == Blend::Over;
        let skip = if over && p.probe.is_colour() {
            skip
        } else {
            None
        };
        let cam = &self.ref_cam;
        let ps = if self.once { 0.0 } else { p.plane_sep as f32 };
        let ray = cam.ray(hi, vi, ps, p.unit_step as f32);
        let wtoi = RefIndex::new(vol.itow());
        let needs_convo = p.probe.needs_convo();
        let mut acc = Accum::new(p.blend, p.probe.length());
        // `over`: premultiplied colour in acc[..3] and the transparency T.
        let mut transp = 1.0f32;
        let mut memo: AlphaMemo = None;
        let kmax = self.plane_limit();
        let mut k: u32 = 0;
        loop {
            let kf = k as f32;
            let pv: [f32; 3] = core::array::from_fn(|a| ray.start[a] + kf * ray.step[a]);
            if k > 0 && (-pv[2] > cam.fcv || k > kmax) {
                break;
            }
            let pw = cam.to_world(pv, 1.0);
            let pi = wtoi.point(pw);
            let empty = match skip {
                Some(sk) => {
                    refarith::support_start::<V, K, S>(vol, pi).is_some_and(|n| sk.empty_at(n))
                }
                None => false,
            };
            let sample = if needs_convo && !empty {
                refarith::convolve::<V, K, S>(vol, pi, self.need_grad)
            } else {
                None
            };
            let inside = empty
                || sample.is_some()
                || (!needs_convo && refarith::support_start::<V, K, S>(vol, pi).is_some());
            let grad_w = sample.map_or([0.0; 3], |s| wtoi.gradient(s.grad_i));
            let value = sample.map_or(0.0, |s| s.value);
            let mut pr = [0.0f32; 4];
            let counted = match p.probe {
                Probe::PosView => {
                    pr[..3].copy_from_slice(&pv);
                    true
                }
                Probe::PosWorld => {
                    pr[..3].copy_from_slice(&pw);
                    true
                }
                Probe::PosIndex => {
                    pr[..3].copy_from_slice(&pi);
                    true
                }
                Probe::Inside => {
                    pr[0] = if inside { 1.0 } else { 0.0 };
                    true
                }
                _ if !inside => false,
                _ if empty => true,
                _ => self.probe_ref(value, grad_w, &ray, pv[2], &mut memo, &mut pr),
            };
            if counted {
                blend_ref(&mut acc, &mut transp, &pr);
            }
            if let Some(t) = trace.as_deref_mut() {
                let wide = |a: [f32; 3]| a.map(f64::from);
                t(&SampleInfo {
                    k,
                    pos_v: wide(pv),
                    pos_w: wide(pw),
                    convo: ConvoSample {
                        pos_i: wide(pi),
                        inside,
                        value,
                        grad_i: sample.map_or([0.0; 3], |s| s.grad_i),
                        grad_w,
                    },
                    probe: pr,
                    counted,
                    accum: acc,
                });
            }
            if self.once || self.opaque_end(&mut acc) {
                break;
            }
            k += 1;
        }
        acc.finish(p.outside, out);
    }

    /// The probes counted only inside (v, gv, gm, rgba, rgbalit) in reference
    /// arithmetic, for value `v` and world gradient `g` at view depth `z`; whether the
    /// sample is blended.
    #[inline(always)]
    fn probe_ref(
        &self,
        v: f32,
        g: [f32; 3],
        ray: &refarith::RefRay,
        z: f32,
        memo: &mut AlphaMemo,
        out: &mut [f32; 4],
    ) -> bool {
        match self.params.probe {
            Probe::Value => out[0] = v,
            Probe::GradVec => out[..3].copy_from_slice(&g),
            Probe::GradMag => out[0] = math::sqrtf(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]),
            _ => return self.colour_ref(v, g, ray, z, memo, out),
        }
        true
    }

    /// [`RenderSpec::cast_ref`] for the probes counted only inside, without a trace:
    /// the samples whose support is inside (and not in an empty skip block) go through
    /// the convolution [`Lanes`] at a time, then are probed and blended in order. Same
    /// bits as the one-sample loop: each lane computes what `refarith::convolve`
    /// does, and a sample in an empty block only adds to the count (its opacity is 0),
    /// so it may be counted before the samples ahead of it are blended.
    fn cast_ref_lanes<V: Voxel, K: Kernel<S>, const S: usize, const G: bool>(
        &self,
        convo: &Convo<'_, V, K, S>,
        skip: Option<&SkipGrid>,
        hi: u32,
        vi: u32,
        out: &mut [f32],
    ) {
        #[cfg(target_arch = "x86_64")]
        if crate::avx::avx2_enabled() {
            // SAFETY: the processor and operating system support AVX2.
            return unsafe { self.cast_ref_lanes_avx2::<V, K, S, G>(convo, skip, hi, vi, out) };
        }
        self.cast_ref_lanes_body::<V, K, S, G>(convo, skip, hi, vi, out)
    }

    /// [`RenderSpec::cast_ref_lanes`] compiled for AVX2 (the positions of a block in
    /// one register per coordinate; the same operations, no fused multiply-add).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn cast_ref_lanes_avx2<V: Voxel, K: Kernel<S>, const S: usize, const G: bool>(
        &self,
        convo: &Convo<'_, V, K, S>,
        skip: Option<&SkipGrid>,
        hi: u32,
        vi: u32,
        out: &mut [f32],
    ) {
        self.cast_ref_lanes_body::<V, K, S, G>(convo, skip, hi, vi, out)
    }

    #[inline(always)]
    fn cast_ref_lanes_body<V: Voxel, K: Kernel<S>, const S: usize, const G: bool>(
        &self,
        convo: &Convo<'_, V, K, S>,
        skip: Option<&SkipGrid>,
        hi: u32,
        vi: u32,
        out: &mut [f32],
    ) {
        let p = &self.params;
        let vol = convo.volume();
        let skip = skip.filter(|_| p.blend == Blend::Over);
        let cam = &self.ref_cam;
        let ray = cam.ray(hi, vi, p.plane_sep as f32, p.unit_step as f32);
        let wtoi = RefIndex::new(vol.itow());
        let mut acc = Accum::new(p.blend, p.probe.length());
        let mut transp = 1.0f32;
        let kmax = self.plane_limit();
        let mut lanes = Lanes::<S>::default();
        let mut depth = [0.0f32; LANES];
        let mut res = [[0.0f32; 4]; LANES];
        // Convolves, probes and blends the batch in order; true when the ray ends early.
        let mut memo: AlphaMemo = None;
        let mut flush = |lanes: &mut Lanes<S>,
                         depth: &[f32; LANES],
                         acc: &mut Accum,
                         transp: &mut f32,
                         memo: &mut AlphaMemo|
         -> bool {
            lanes.convolve::<V, K, G>(vol, &mut res);
            let n = lanes.len();
            lanes.clear();
            for (r, &z) in res.iter().zip(depth).take(n) {
                let gw = if G {
                    wtoi.gradient([r[1], r[2], r[3]])
                } else {
                    [0.0; 3]
                };
                let mut pr = [0.0f32; 4];
                if self.probe_ref(r[0], gw, &ray, z, memo, &mut pr) {
                    blend_ref(acc, transp, &pr);
                    if self.opaque_end(acc) {
                        return true;
                    }
                }
            }
            false
        };
        // Samples before `first` or after `last` are outside: they change nothing (these
        // probes count inside only), and the far plane ends the ray at the same place
        // (positions move monotonically along the ray, so if a skipped sample is past
        // it, so is every sample from `first` on).
        let Some((first, last)) = refarith::inside_span::<V, K, S>(cam, &ray, &wtoi, vol, kmax)
        else {
            acc.finish(p.outside, out);
            return;
        };
        let mut k0 = first;
        'ray: while k0 <= last {
            let b = Block::new::<V, K, S>(cam, &ray, &wtoi, vol, k0);
            // Whether sample l ends the ray (past the far plane or the sample bound). A
            // block with no sample inside and none ending the ray changes nothing.
            let past = |l: usize| {
                let k = k0 + l as u32;
                (k > 0) & ((-b.z[l] > cam.fcv) | (k > kmax))
            };
            if !b.inside.iter().any(|&x| x) && !(0..LANES).any(past) {
                k0 += LANES as u32;
                continue;
            }
            for l in 0..LANES {
                if past(l) {
                    break 'ray;
                }
                if !b.inside[l] {
                    continue;
                }
                let (n, al) = b.lane(l);
                if skip.is_some_and(|sk| sk.empty_at(n)) {
                    blend_ref(&mut acc, &mut transp, &[0.0; 4]);
                    continue;
                }
                depth[lanes.len()] = b.z[l];
                lanes.push_placed(vol, n, al);
                if lanes.is_full() && flush(&mut lanes, &depth, &mut acc, &mut transp, &mut memo) {
                    acc.finish(p.outside, out);
                    return;
                }
            }
            k0 += LANES as u32;
        }
        if !lanes.is_empty() {
            flush(&mut lanes, &depth, &mut acc, &mut transp, &mut memo);
        }
        acc.finish(p.outside, out);
    }

    /// The rgba / rgbalit probe in reference arithmetic for value `v` and world gradient
    /// `g` at view depth `z`; false without a LUT.
    #[inline]
    fn colour_ref(
        &self,
        v: f32,
        g: [f32; 3],
        ray: &refarith::RefRay,
        z: f32,
        memo: &mut AlphaMemo,
        out: &mut [f32; 4],
    ) -> bool {
        let p = &self.params;
        let Some(lut) = self.lut else { return false };
        let e = lut.entries()[lut.index(v as f64)];
        let mut a = e[3];
        if let Some(lev) = self.levoy {
            a *= lev.opacity(v, math::sqrtf(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]));
        }
        // The ray's exponent is fixed, so the last result serves equal opacities.
        let a = match *memo {
            Some((bits, r)) if bits == a.to_bits() => r,
            _ => {
                let r = refarith::correct_alpha(a, ray.alpha_exp);
                *memo = Some((a.to_bits(), r));
                r
            }
        };
        let mut rgb = [e[0], e[1], e[2]];
        if a != 0.0 && p.probe == Probe::RgbaLit {
            rgb = refarith::blinn_phong(&p.phong, &self.ref_lights, rgb, g, ray.to_eye);
            if self.depth_cue {
                let cam = &self.ref_cam;
                let tau = (-z - cam.ncv) / (cam.fcv - cam.ncv);
                for c in 0..3 {
                    rgb[c] *= p.dcn[c] + tau * (p.dcf[c] - p.dcn[c]);
                }
            }
        }
        *out = [rgb[0], rgb[1], rgb[2], a];
        true
    }

    /// Whether [`RenderSpec::cast_fast`] applies: asked for, and a probe that is only
    /// counted inside the volume.
    fn fast_applies(&self) -> bool {
        self.params.fast_loop && self.probe_counts_inside_only()
    }

    /// Whether the probe is blended only at samples inside the volume.
    fn probe_counts_inside_only(&self) -> bool {
        matches!(
            self.params.probe,
            Probe::Value | Probe::GradVec | Probe::GradMag | Probe::Rgba | Probe::RgbaLit
        )
    }

    /// Sample numbers beyond this are past the far plane on every ray; the bound also
    /// ends rays whose positions stop changing in floating point (a camera very far
    /// away).
    fn plane_limit(&self) -> u32 {
        let cam = &self.camera;
        ((cam.fcv - cam.ncv) / self.params.plane_sep.max(f64::MIN_POSITIVE))
            .min(MAX_SAMPLES_PER_RAY) as u32
            + 1
    }

    /// The number of samples the plain loop takes on ray `g` before the far plane ends
    /// it: it samples k = 0, 1, … up to (not including) the first k > 0 whose view depth
    /// is past the far plane or that exceeds the sample bound.
    fn ray_end(&self, g: &RayGeom) -> u32 {
        if self.once {
            return 1;
        }
        let cam = &self.camera;
        let kmax = self.plane_limit();
        // -z(k) never decreases (the step points away from the eye), so the stopping
        // condition is false … false true … true over k = 1 ..= kmax + 1.
        let (s, d) = (g.start_v[2], g.step_v[2]);
        let guess = ceil_estimate((-cam.fcv - s) / d);
        first_true_near(1, kmax + 1, guess, |k| -(s + k as f64 * d) > cam.fcv)
    }

    /// Samples k in [lo, hi) of ray `g` (of `kend` samples) are exactly those whose
    /// kernel support is inside the volume, or None when the ray's index-space geometry
    /// is unusual (non-finite or huge), for the plain loop to handle.
    fn inside_span<K: Kernel<S>, const S: usize>(
        sizes: [usize; 3],
        start_i: &[f64; 3],
        step_i: &[f64; 3],
        kend: u32,
    ) -> Option<(u32, u32)> {
        const BIG: f64 = 1e14;
        let (mut lo, mut hi) = (0u32, kend);
        for a in 0..3 {
            let (s, d) = (start_i[a], step_i[a]);
            if !(s.abs() < BIG && d.abs() < BIG) {
                return None;
            }
            // -1 below the inside range on this axis, 0 in it, +1 above; monotone in k
            // because x(k) = s + k d is (rounding is monotone) and so is the floor.
            let class = |k: u32| -> i32 {
                match place::<K, S>(s + k as f64 * d, sizes[a] as i64) {
                    Place::Below => -1,
                    Place::Inside(..) => 0,
                    Place::Above => 1,
                }
            };
            // The positions where the class changes: the support start floor(x + off)
            // + LO reaches 0 at x = tlo and passes size − S at x = thi; the samples
            // nearest them are the estimates the searches start from.
            let off = if S.is_multiple_of(2) { 0.0 } else { 0.5 };
            let tlo = -(K::LO as f64) - off;
            let thi = sizes[a] as f64 - S as f64 - K::LO as f64 + 1.0 - off;
            let near = |t: f64| ceil_estimate((t - s) / d);
            let (a0, a1) = if d > 0.0 {
                (
                    first_true_near(0, kend, near(tlo), |k| class(k) >= 0),
                    first_true_near(0, kend, near(thi), |k| class(k) > 0),
                )
            } else if d < 0.0 {
                (
                    first_true_near(0, kend, near(thi), |k| class(k) <= 0),
                    first_true_near(0, kend, near(tlo), |k| class(k) < 0),
                )
            } else if class(0) == 0 {
                (0, kend)
            } else {
                (0, 0)
            };
            lo = lo.max(a0);
            hi = hi.min(a1);
        }
        Some((lo, hi.max(lo)))
    }

    /// The last sample in [k, k1) of the ray `start_i + k step_i` (index space) whose
    /// support start lies in box `bx` (`[first, last]` per axis), which holds sample k's;
    /// `faces` are the ray's [`BoxFaces`]. An estimate from the box's faces is checked
    /// with the exact sample positions (support starts are monotone along the ray on
    /// each axis, so the samples between two members are members), then one sample less
    /// (round-off in the estimate), then bisected down.
    #[inline]
    fn box_run_end<K: Kernel<S>, const S: usize>(
        bx: &[[i64; 2]; 3],
        start_i: &[f64; 3],
        step_i: &[f64; 3],
        faces: &BoxFaces,
        k: u32,
        k1: u32,
    ) -> u32 {
        let in_box = |j: u32| {
            let jf = j as f64;
            let p = core::array::from_fn(|a| start_i[a] + jf * step_i[a]);
            let n = locate::<K, S>(p).0;
            (0..3).all(|a| bx[a][0] <= n[a] && n[a] <= bx[a][1])
        };
        // The crossing of the exit face on each axis the ray moves along; the least is
        // where the ray leaves the box.
        let mut est = (k1 - 1) as f64;
        for a in 0..3 {
            if let Some(side) = faces.side[a] {
                est = est.min((bx[a][side] as f64 + faces.off[a]) * faces.inv[a]);
            }
        }
        // Largest whole number below est (or k).
        let est = if est > k as f64 + 1.0 {
            let t = est as u32;
            let t = if t as f64 == est { t - 1 } else { t };
            t.min(k1 - 1)
        } else {
            k
        };
        if in_box(est) {
            est
        } else if est > k + 1 && in_box(est - 1) {
            est - 1
        } else {
            first_true(k + 1, est, |j| !in_box(j)) - 1
        }
    }

    /// [`RenderSpec::cast_skip`], with the same result bit for bit, faster for the
    /// probes counted only inside the volume (value, gradient, colour): the ray's inside
    /// stretch is found by bisection on the exact per-sample conditions and only its
    /// samples are taken, in batches, without per-sample bounds tests or unused
    /// positions. Other probes go to the plain loop.
    pub fn cast_fast<V: Voxel, K: Kernel<S>, const S: usize>(
        &self,
        convo: &mut Convo<'_, V, K, S>,
        skip: Option<&SkipGrid>,
        hi: u32,
        vi: u32,
        out: &mut [f32],
    ) {
        if !self.probe_counts_inside_only() {
            return self.cast_skip(convo, skip, hi, vi, out, None);
        }
        if self.need_grad {
            self.cast_fast_g::<V, K, S, true>(convo, skip, hi, vi, out);
        } else {
            self.cast_fast_g::<V, K, S, false>(convo, skip, hi, vi, out);
        }
    }

    /// [`RenderSpec::cast_fast`] with whether the gradient is needed known at compile
    /// time.
    #[inline(always)]
    fn cast_fast_g<V: Voxel, K: Kernel<S>, const S: usize, const G: bool>(
        &self,
        convo: &mut Convo<'_, V, K, S>,
        skip: Option<&SkipGrid>,
        hi: u32,
        vi: u32,
        out: &mut [f32],
    ) {
        let p = &self.params;
        let g = self.ray_geom_eye(hi, vi, p.probe == Probe::RgbaLit);
        let wtoi = *convo.volume().wtoi();
        let start_i = wtoi.point(g.start_w);
        let step_i = wtoi.vector(g.step_w);
        let kend = self.ray_end(&g);
        let sizes = convo.volume().sizes();
        let Some((k0, k1)) = Self::inside_span::<K, S>(sizes, &start_i, &step_i, kend) else {
            return self.cast_skip(convo, skip, hi, vi, out, None);
        };
        let over = p.blend == Blend::Over;
        // The skip grid (over only) with this ray's box-face constants.
        let skip = skip
            .filter(|_| over)
            .map(|sk| (sk, BoxFaces::new::<K, S>(&start_i, &step_i)));
        let mut acc = Accum::new(p.blend, p.probe.length());
        let cam = &self.camera;
        let pos = |k: u32| {
            let kf = k as f64;
            locate::<K, S>([
                start_i[0] + kf * step_i[0],
                start_i[1] + kf * step_i[1],
                start_i[2] + kf * step_i[2],
            ])
        };
        // Probes and blends one convolved sample; true when the ray is finished.
        let gmat = convo.grad_matrix();
        let take = |acc: &mut Accum, k: u32, r: [f32; 4]| -> bool {
            let (v, gw) = if G {
                (r[0], grad_to_world(&gmat, [r[1], r[2], r[3]]))
            } else {
                (r[0], [0.0; 3])
            };
            let mut pr = [0.0f32; 4];
            match p.probe {
                Probe::Value => pr[0] = v,
                Probe::GradMag => pr[0] = gmag(&gw),
                Probe::GradVec => pr[..3].copy_from_slice(&gw),
                _ => {
                    let tau = || {
                        let z = g.start_v[2] + k as f64 * g.step_v[2];
                        ((-z - cam.ncv) / (cam.fcv - cam.ncv)) as f32
                    };
                    if !self.colour(v, &gw, &g, tau, &mut pr) {
                        return false;
                    }
                }
            }
            acc.add(&pr);
            self.opaque_end(acc)
        };
        // Batches of LANES samples (convolved phase by phase, see Convo::sums_n),
        // blended in order. Samples in empty blocks are not convolved: blending them
        // (opacity 0 under `over`) changes nothing but the count, so they are counted
        // where they are met and the batch is filled with the next samples.
        const LANES: usize = 8;
        let scalars = p.blend != Blend::Over && matches!(p.probe, Probe::Value | Probe::GradMag);
        // Under `over` without Levoy opacity a sample's opacity depends on its value
        // alone, so the gradient is needed only where it is not zero.
        let value_first = G && over && self.levoy.is_none() && p.probe.is_colour();
        let mut k = k0;
        let mut nb = [[0i64; 3]; LANES];
        let mut al = [[0.0f64; 3]; LANES];
        let mut ks = [0u32; LANES];
        let mut res = [[0.0f32; 4]; LANES];
        while k < k1 {
            let mut m = 0;
            if !over && k1 - k >= LANES as u32 {
                // A whole batch of consecutive samples: positions computed with the sums.
                convo.sums_run::<G, LANES>(&start_i, &step_i, k, &mut res);
                if scalars {
                    // One channel under max/sum/mean: no early end, no colour.
                    let xs: [f32; LANES] = match p.probe {
                        Probe::GradMag => world_gmags(&gmat, &res),
                        _ => res.map(|r| r[0]),
                    };
                    acc.add_scalars(&xs);
                } else if (0..LANES).any(|i| take(&mut acc, k + i as u32, res[i])) {
                    break;
                }
                k += LANES as u32;
                continue;
            }
            while m < LANES && k < k1 {
                let (n, a) = pos(k);
                if let Some((sk, faces)) = &skip {
                    let flags = sk.flags_at(n);
                    if flags & COARSE_EMPTY != 0 {
                        // Every sample up to the last one in the empty box around this
                        // block is empty too.
                        let bx = sk.empty_box(n);
                        let last = Self::box_run_end::<K, S>(&bx, &start_i, &step_i, faces, k, k1);
                        acc.add_transparent(last - k + 1);
                        k = last + 1;
                        continue;
                    }
                    if flags & FINE_EMPTY != 0 {
                        // Transparent by the fine grid: counted, not convolved.
                        acc.add_transparent(1);
                        k += 1;
                        continue;
                    }
                }
                (nb[m], al[m], ks[m]) = (n, a, k);
                m += 1;
                k += 1;
            }
            if let (true, Some(lut)) = (value_first, self.lut) {
                // Values first; the gradient (and lighting) only for samples that are
                // not transparent. The value is the same bits with or without the
                // gradient, and a transparent sample only counts.
                convo.sums_first::<false, LANES>(&nb, &al, m, &mut res);
                let mut finished = false;
                for i in 0..m {
                    if self.lut_alpha(lut, lut.index(res[i][0] as f64), &g) == 0.0 {
                        acc.add_transparent(1);
                    } else if take(&mut acc, ks[i], convo.sums::<true>(nb[i], al[i])) {
                        finished = true;
                        break;
                    }
                }
                if finished {
                    break;
                }
                continue;
            }
            convo.sums_first::<G, LANES>(&nb, &al, m, &mut res);
            if (0..m).any(|i| take(&mut acc, ks[i], res[i])) {
                break;
            }
        }
        acc.finish(p.outside, out);
    }

    /// Renders image rows `rows` into `out` (`channels` floats per pixel, rows
    /// consecutive). `clock`, when given, returns milliseconds and fills the time channel.
    pub fn render_rows<V: Voxel, K: Kernel<S>, const S: usize>(
        &self,
        convo: &mut Convo<'_, V, K, S>,
        skip: Option<&SkipGrid>,
        rows: core::ops::Range<u32>,
        out: &mut [f32],
        clock: Option<&dyn Fn() -> f64>,
    ) {
        let w = self.size()[0] as usize;
        let ch = self.channels;
        let plen = self.params.probe.length();
        let fast = self.fast_applies();
        debug_assert_eq!(out.len(), rows.len() * w * ch);
        for (r, vi) in rows.enumerate() {
            for hi in 0..w {
                let px = &mut out[(r * w + hi) * ch..(r * w + hi + 1) * ch];
                let t0 = clock.map(|c| c());
                if self.params.reference {
                    self.cast_ref(convo, skip, hi as u32, vi, &mut px[..plen], None);
                } else if fast {
                    self.cast_fast(convo, skip, hi as u32, vi, &mut px[..plen]);
                } else {
                    self.cast_skip(convo, skip, hi as u32, vi, &mut px[..plen], None);
                }
                if let (Some(c), Some(t0)) = (clock, t0) {
                    px[plen] = (c() - t0) as f32;
                }
            }
        }
    }
}

/// The last opacity corrected on a ray (its bits) and the result, in reference mode.
type AlphaMemo = Option<(u32, f32)>;

/// Blends probe `pr` in reference arithmetic: `over` keeps the transparency `transp`
/// (C += T·α·rgb, T ·= 1 − α, opacity 1 − T), the other blends as [`Accum::add`].
#[inline(always)]
fn blend_ref(acc: &mut Accum, transp: &mut f32, pr: &[f32; 4]) {
    if acc.blend == Blend::Over {
        let a = pr[3];
        for c in 0..3 {
            acc.acc[c] += *transp * a * pr[c];
        }
        *transp *= 1.0 - a;
        acc.acc[3] = 1.0 - *transp;
        acc.count += 1;
    } else {
        acc.add(pr);
    }
}

/// Per-ray constants of [`RenderSpec::box_run_end`]: on each axis the ray moves along,
/// which face of a box of support starts it leaves by (0 first, 1 last), and the sample
/// number where it crosses a face is estimated as `(face + off) · inv`.
#[derive(Debug, Clone, Copy)]
struct BoxFaces {
    side: [Option<usize>; 3],
    off: [f64; 3],
    inv: [f64; 3],
}

impl BoxFaces {
    /// The constants for the index-space ray `start_i + k step_i`. Support start n =
    /// floor(x + o) + LO (o = 0.5 for odd supports, else 0), so starts [f, l] are the
    /// positions x in [f − LO − o, l + 1 − LO − o). The estimates need not be exact (they
    /// are checked).
    #[inline]
    fn new<K: Kernel<S>, const S: usize>(start_i: &[f64; 3], step_i: &[f64; 3]) -> Self {
        let o = if S.is_multiple_of(2) { 0.0 } else { 0.5 };
        let mut f = BoxFaces {
            side: [None; 3],
            off: [0.0; 3],
            inv: [0.0; 3],
        };
        for a in 0..3 {
            let (s, d) = (start_i[a], step_i[a]);
            if d > 0.0 {
                f.side[a] = Some(1);
                f.off[a] = 1.0 - K::LO as f64 - o - s;
            } else if d < 0.0 {
                f.side[a] = Some(0);
                f.off[a] = -(K::LO as f64) - o - s;
            }
            f.inv[a] = 1.0 / d;
        }
        f
    }
}

/// Opacity `a` clamped to [0, 1] and corrected for a step of `ex` unit steps:
/// 1 − (1 − a)^ex (0 and 1 are kept as they are), computed as 1 − exp(ex · ln(1 − a)) in
/// f64 and rounded once to f32.
#[inline]
fn correct_alpha(a: f32, ex: f32) -> f32 {
    correct_alpha_ln(a, ln_transparency(a.clamp(0.0, 1.0)), ex)
}

/// ln(1 − a) for an opacity `a` in [0, 1] (−∞ for a = 1).
#[inline]
fn ln_transparency(a: f32) -> f64 {
    math::ln((1.0 - a) as f64)
}

/// [`correct_alpha`] given `l` = ln(1 − clamp(a)), e.g. from a per-LUT-entry table.
#[inline]
fn correct_alpha_ln(a: f32, l: f64, ex: f32) -> f32 {
    let a = a.clamp(0.0, 1.0);
    if a == 0.0 || a == 1.0 {
        a
    } else if l == 0.0 {
        // 1 − a rounds to 1 in f32: no opacity for any step (also an infinite one, where
        // the product below would be ∞ · 0).
        0.0
    } else {
        (1.0 - math::exp(ex as f64 * l)) as f32
    }
}

/// About ⌈x⌉ (exact for |x| < 2^63; NaN stays NaN), cheaper than a library ceil: for
/// the estimates that [`first_true_near`] starts from, which need not be exact.
#[inline(always)]
fn ceil_estimate(x: f64) -> f64 {
    if !x.is_finite() {
        return x;
    }
    let t = x as i64 as f64;
    if t < x {
        t + 1.0
    } else {
        t
    }
}

/// [`first_true`] starting from `guess`, an estimate of the answer: the predicate is
/// tried at the estimate and next to it (a close estimate settles it in two calls), and
/// bisection covers what that leaves open, so any estimate gives the exact answer.
fn first_true_near(lo: u32, hi: u32, guess: f64, pred: impl Fn(u32) -> bool) -> u32 {
    if !(guess.is_finite() && lo < hi) {
        return first_true(lo, hi, pred);
    }
    let g = guess.clamp(lo as f64, hi as f64) as u32;
    if g == hi {
        // The answer is in [lo, hi]: hi unless pred holds at hi − 1.
        return if pred(hi - 1) {
            first_true(lo, hi - 1, pred)
        } else {
            hi
        };
    }
    if pred(g) {
        // The answer is in [lo, g].
        if g == lo || !pred(g - 1) {
            g
        } else {
            first_true(lo, g - 1, pred)
        }
    } else if g + 1 == hi || pred(g + 1) {
        // The answer is in [g + 1, hi] and holds at g + 1 or there is no more room.
        g + 1
    } else {
        first_true(g + 2, hi, pred)
    }
}

/// The first k in [lo, hi) where `pred` holds, for a predicate that is false then true
/// over the range; `hi` when it never holds.
fn first_true(mut lo: u32, mut hi: u32, pred: impl Fn(u32) -> bool) -> u32 {
    while lo < hi {
        let mid = lo + (hi - lo) / 2;
        if pred(mid) {
            hi = mid;
        } else {
            lo = mid + 1;
        }
    }
    lo
}

#[inline(always)]
fn gmag(g: &[f32; 3]) -> f32 {
    math::sqrtf(g[0] * g[0] + g[1] * g[1] + g[2] * g[2])
}

/// A volume of either voxel type.
#[derive(Debug, Clone, Copy)]
pub enum AnyVolume<'a> {
    /// 32-bit float voxels.
    F32(Volume<'a, f32>),
    /// Signed 16-bit voxels.
    I16(Volume<'a, i16>),
}

/// Work to run on a concrete (voxel, kernel) pair; see [`dispatch`].
pub trait ConvoTask {
    /// What the task returns.
    type Output;
    /// Runs with the volume and kernel types known at compile time.
    fn run<V: Voxel, K: Kernel<S>, const S: usize>(self, vol: Volume<'_, V>) -> Self::Output;
}

/// The one run-time dispatch point: (voxel type, kernel name) → monomorphized code.
pub fn dispatch<T: ConvoTask>(vol: AnyVolume<'_>, kernel: KernelName, task: T) -> T::Output {
    macro_rules! by_kernel {
        ($v:expr) => {
            match kernel {
                KernelName::Zero => task.run::<_, Zero, 1>($v),
                KernelName::Box => task.run::<_, BoxK, 1>($v),
                KernelName::Tent => task.run::<_, Tent, 2>($v),
                KernelName::Bspln2 => task.run::<_, Bspln2, 3>($v),
                KernelName::Bspln3 => task.run::<_, Bspln3, 4>($v),
                KernelName::Ctmr => task.run::<_, Ctmr, 4>($v),
                KernelName::C4hexic => task.run::<_, C4Hexic, 6>($v),
            }
        };
    }
    match vol {
        AnyVolume::F32(v) => by_kernel!(v),
        AnyVolume::I16(v) => by_kernel!(v),
    }
}

/// Renders the whole image on the calling thread into a new buffer (W·H·channels floats,
/// row-major from the top).
pub fn render(spec: &RenderSpec<'_>, vol: AnyVolume<'_>, kernel: KernelName) -> Vec<f32> {
    struct Whole<'s, 'a>(&'s RenderSpec<'a>);
    impl ConvoTask for Whole<'_, '_> {
        type Output = Vec<f32>;
        fn run<V: Voxel, K: Kernel<S>, const S: usize>(self, vol: Volume<'_, V>) -> Vec<f32> {
            let [w, h] = self.0.size();
            let mut out = alloc::vec![0.0f32; w as usize * h as usize * self.0.channels];
            let skip = self.0.skip_grid(&vol, K::NAME);
            let mut convo = Convo::<V, K, S>::new(vol);
            self.0
                .render_rows(&mut convo, skip.as_ref(), 0..h, &mut out, None);
            out
        }
    }
    dispatch(vol, kernel, Whole(spec))
}

#[cfg(test)]
mod tests {
    use super::{first_true, first_true_near};

    /// Starting from any estimate (far off, on either side, at the ends, not finite) the
    /// search finds what plain bisection finds, for every threshold of a monotone
    /// predicate.
    #[test]
    fn first_true_near_is_exact_from_any_estimate() {
        for (lo, hi) in [(0u32, 0u32), (0, 1), (0, 7), (1, 40), (3, 300)] {
            for t in lo..=hi + 1 {
                let pred = |k: u32| k >= t;
                let want = first_true(lo, hi, pred);
                let guesses = (0..=hi + 3).map(|g| g as f64 - 1.5).chain([
                    f64::NAN,
                    f64::INFINITY,
                    f64::NEG_INFINITY,
                    -1e300,
                    1e300,
                ]);
                for g in guesses {
                    assert_eq!(
                        first_true_near(lo, hi, g, pred),
                        want,
                        "[{lo}, {hi}) t {t} g {g}"
                    );
                    let g = g.round();
                    assert_eq!(
                        first_true_near(lo, hi, g, pred),
                        want,
                        "[{lo}, {hi}) t {t} g {g}"
                    );
                }
            }
        }
    }
}
