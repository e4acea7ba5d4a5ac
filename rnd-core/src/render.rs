//! Rendering: the validated, immutable [`RenderSpec`], the run-time → compile-time
//! dispatch on (voxel type, kernel), and the entry points that cast rays with the one
//! loop of [`crate::march`] in the arithmetic the spec names (`arith`).

use alloc::vec::Vec;

use crate::affine::Affine4;
use crate::arith::{correct_alpha, ln_transparency, Reference, F64};
use crate::blend::Blend;
use crate::brick::Own;
use crate::camera::{Camera, CameraSpec};
use crate::error::{Error, ErrorKind, Param, Result};
use crate::kernel::{Kernel, KernelName, KernelTask};
use crate::light::{Light, Phong, WorldLights};
use crate::march::{March, Out};
use crate::probe::Probe;
use crate::refarith::{self, RefCamera};
use crate::simd::Simd;
use crate::skip::{ReAim, SkipGrid, SkipKind, SkipPlan};
use crate::txf::{Levoy, Lut};
use crate::volume::Volume;
use crate::voxel::Voxel;

/// Volumes of more voxels than this get a pilot before their `max` value grid is built
/// ([`RenderSpec::pilot`]); smaller ones always get it (2^23: a 256 × 256 × 128 volume).
/// A gradient-magnitude grid gets a pilot on every volume.
pub const PILOT_VOXELS: usize = 1 << 23;

#[doc(hidden)]
pub use crate::arith::RayGeom;
pub use crate::march::{Loop, SampleInfo, Trace};
pub use crate::simd::SimdLevel;

/// How a caller casts a pilot's rays ([`RenderSpec::skip_pays`]): it is handed
/// `rays(part, parts)`, which casts the pilot rows `part`, `part + parts`, … and gives
/// their rays' results, and returns the results of every row, in any order (so it may
/// call `rays(i, n)` for each i < n on n threads).
pub type PilotCast<'c> = &'c dyn Fn(&(dyn Fn(u32, u32) -> Vec<f32> + Sync)) -> Vec<f32>;

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
    /// Cast with [`Loop::Batched`] (each ray's inside stretch found up front, samples
    /// convolved in batches) rather than [`Loop::OneSample`]. Exact: the output is
    /// bit-identical either way.
    pub fast_loop: bool,
    /// Compute in the course reference program's f32 arithmetic (`-ref`, the default;
    /// [`crate::refarith`]), which reproduces the reference's images. `false` selects
    /// the f64 engine (f64 geometry, separable SIMD sums): 1.65–2.2× quicker, within
    /// 1e-4 relative of the reference arithmetic on nearly every pixel (not where round-off
    /// moves a sample across a LUT bin boundary) but not its bits. The reference
    /// arithmetic needs volumes of at most [`refarith::MAX_AXIS`] samples per axis and a
    /// camera, lights and steps that f32 can hold ([`RenderSpec::new`] checks the last).
    pub reference: bool,
    /// The widest vector instructions to use (lowered to what the processor has; the
    /// same bits at every level).
    pub simd: SimdLevel,
    /// For the curvature probes (k1 k2 meancurv gausscurv): the gradient magnitude at or
    /// below which the isosurface is taken as undefined and the curvatures as 0 (`-gmc`,
    /// as Teem's; default 0).
    pub curv_min_grad: f64,
}

impl RenderParams {
    /// Parameters with the defaults of `rendr go` and the given camera: plane
    /// separation 0.1, probe value, blend max, outside value 0, unit step 1, no early
    /// termination, default Blinn-Phong, no depth cue, no time channel, skipping and
    /// the batched loop on, the reference arithmetic, the widest vector level.
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
            simd: SimdLevel::Avx512,
            curv_min_grad: 0.0,
        }
    }
}

/// A validated, immutable render description: the parameters (checked once, then
/// read-only), the camera frame, and the constants the chosen arithmetic prepares once
/// per render (its lights, opacity tables, f32 camera).
///
/// A lit `over` render: colour and opacity from a LUT, one light.
///
/// ```
/// use rnd_core::prelude::*;
///
/// // A ball of radius 10 in a 32³ grid; opacity 0.5 inside it.
/// let geom = Affine4::from_spacing([1.0; 3], [-15.5; 3]);
/// let vol = OwnedVolume::from_fn([32; 3], geom, |[i, j, k]| {
///     let r2: f32 = [i, j, k].iter().map(|&x| (x as f32 - 15.5).powi(2)).sum();
///     if r2 < 100.0 { 1.0 } else { 0.0 }
/// })
/// .unwrap();
/// let lut = Lut::new(0.0, 1.0, vec![[1.0, 1.0, 1.0, 0.0], [1.0, 0.5, 0.2, 0.5]]).unwrap();
/// let light = Light::new([1.0; 3], [0.0, 0.0, 1.0], LightSpace::View).unwrap();
/// let cam = CameraSpec::framing(&vol.view().world_corners(), [0.0, 0.0, 1.0]).unwrap().size(16, 16);
/// let mut p = RenderParams::new(cam);
/// (p.probe, p.blend, p.plane_sep) = (Probe::RgbaLit, Blend::Over, 0.5);
/// let spec = RenderSpec::new(p, Some(&lut), None, &[light]).unwrap();
/// assert_eq!(spec.channels(), 4);
/// let img = render(&spec, vol.view().into(), KernelName::Tent).unwrap();
/// let centre = &img[4 * (8 * 16 + 8)..][..4];
/// assert!(centre[3] > 0.9 && centre[0] > centre[2]); // opaque and orange
/// assert_eq!(&img[..4], &[0.0; 4]); // a corner ray misses the ball
/// ```
#[derive(Debug, Clone)]
pub struct RenderSpec<'a> {
    pub(crate) params: RenderParams,
    pub(crate) camera: Camera,
    pub(crate) lut: Option<&'a Lut>,
    pub(crate) levoy: Option<&'a Levoy>,
    /// World-space lights (colour, unit direction) in the arithmetic's own rounding.
    pub(crate) lights: Vec<([f32; 3], [f32; 3])>,
    pub(crate) channels: usize,
    pub(crate) need_grad: bool,
    /// Whether samples need second derivatives (curvature probes or LUT axes).
    pub(crate) second: bool,
    /// Whether the colour probe's LUT is 1-D over the value (its entry needs the value
    /// alone).
    pub(crate) lut_by_value: bool,
    /// `over` of a value-only LUT without Levoy opacity: a sample's opacity depends on
    /// its value alone, so the gradient is needed only where it is not zero.
    pub(crate) value_opacity: bool,
    pub(crate) once: bool,
    /// Sample numbers beyond this are past the far plane on every ray.
    pub(crate) kmax: u32,
    /// Whether the depth cue changes colours (not both ends 1, where each factor is
    /// 1 + τ · 0 = 1 exactly, τ being finite).
    pub(crate) depth_cue: bool,
    /// Corrected LUT opacities for one exponent, when every ray shares it (orthographic
    /// cameras without Levoy opacity).
    pub(crate) alpha_table: Option<(f32, Vec<f32>)>,
    /// What only the chosen arithmetic needs, prepared once.
    pub(crate) arith: Prepared,
    pub(crate) simd: Simd,
}

/// What one arithmetic prepares once per render, beyond what both do in their own
/// rounding (the world lights, the opacity table): the other's is never made.
#[derive(Debug, Clone)]
pub(crate) enum Prepared {
    /// The reference arithmetic: its f32 camera.
    Reference(RefCamera),
    /// The f64 arithmetic: ln(1 − α) of each LUT entry's clamped opacity (empty
    /// without a LUT, or for one of over 2^20 entries: then computed per sample).
    F64(Vec<f64>),
}

fn rerr(param: Param, msg: alloc::string::String) -> Error {
    Error::about(ErrorKind::Render, param, msg)
}

impl<'a> RenderSpec<'a> {
    /// Validates once: camera, step sizes, thresholds, probe/blend pairing and the
    /// files each probe needs.
    ///
    /// # Errors
    /// [`ErrorKind::Render`] (or [`ErrorKind::Light`]) naming what is wrong.
    pub fn new(
        params: RenderParams,
        lut: Option<&'a Lut>,
        levoy: Option<&'a Levoy>,
        lights: &[Light],
    ) -> Result<Self> {
        use alloc::format;
        let camera = Camera::new(params.camera)?;
        let num = crate::error::Num;
        let once = params.sample_once || params.plane_sep == 0.0;
        if !params.plane_sep.is_finite() || params.plane_sep < 0.0 {
            return Err(rerr(
                Param::PlaneSep,
                format!("plane separation {} must be >= 0", num(params.plane_sep)),
            ));
        }
        if !once {
            let per_ray = (camera.fcv - camera.ncv) / params.plane_sep;
            if !(per_ray <= MAX_SAMPLES_PER_RAY) {
                return Err(rerr(
                    Param::PlaneSep,
                    format!(
                        "plane separation {} gives {per_ray:.3e} samples per ray (limit {MAX_SAMPLES_PER_RAY:e})",
                        num(params.plane_sep)
                    ),
                ));
            }
        }
        if !(params.unit_step.is_finite() && params.unit_step > 0.0) {
            return Err(rerr(
                Param::UnitStep,
                format!("unit step {} must be finite and > 0", params.unit_step),
            ));
        }
        if !(params.alpha_near1 > 0.0 && params.alpha_near1 <= 1.0) {
            return Err(rerr(
                Param::AlphaNear1,
                format!("alpha_near1 {} must be in (0, 1]", params.alpha_near1),
            ));
        }
        let ph = params.phong;
        if ![ph.ka, ph.kd, ph.ks, ph.p].iter().all(|x| x.is_finite()) {
            return Err(rerr(
                Param::Phong,
                format!(
                    "Blinn-Phong parameters must be finite (got {} {} {} {})",
                    ph.ka, ph.kd, ph.ks, ph.p
                ),
            ));
        }
        if params
            .dcn
            .iter()
            .chain(params.dcf.iter())
            .any(|x| !x.is_finite())
        {
            return Err(rerr(
                Param::DepthCue,
                "depth-cue colours must be finite".into(),
            ));
        }
        if !(params.curv_min_grad >= 0.0 && params.curv_min_grad.is_finite()) {
            return Err(rerr(
                Param::CurvMinGrad,
                format!(
                    "curvature gradient threshold {} must be finite and >= 0",
                    num(params.curv_min_grad)
                ),
            ));
        }
        if ph.p < 0.0 {
            return Err(rerr(
                Param::Phong,
                format!("specular exponent {} must be >= 0", ph.p),
            ));
        }
        if params.blend == Blend::Over && !params.probe.is_colour() {
            return Err(rerr(
                Param::Blend,
                format!(
                    "blend over needs probe rgba or rgbalit (not {})",
                    params.probe
                ),
            ));
        }
        if params.probe.is_colour() && lut.is_none() {
            return Err(rerr(
                Param::Lut,
                format!("probe {} needs a LUT", params.probe),
            ));
        }
        if lights.len() > crate::light::MAX_LIGHTS {
            return Err(Error::about(
                ErrorKind::Light,
                Param::Lights,
                format!(
                    "{} lights; at most {} are allowed",
                    lights.len(),
                    crate::light::MAX_LIGHTS
                ),
            ));
        }
        if params.probe == Probe::RgbaLit && lights.is_empty() {
            return Err(rerr(Param::Lights, "probe rgbalit needs lights".into()));
        }
        let need_grad = params.probe == Probe::GradVec
            || params.probe == Probe::GradMag
            || params.probe == Probe::RgbaLit
            || (params.probe == Probe::Rgba && levoy.is_some())
            || (params.probe.is_colour() && lut.is_some_and(Lut::needs_gradient));
        // Second derivatives at each sample: a second-order probe, or a colour probe
        // whose LUT classifies by curvature.
        let second = params.probe.second_order()
            || (params.probe.is_colour() && lut.is_some_and(Lut::second_order));
        let lut_by_value = lut.is_some_and(Lut::by_value);
        let value_opacity = params.blend == Blend::Over && levoy.is_none() && lut_by_value;
        let channels = params.probe.length() + usize::from(params.time);
        let ref_cam = params.reference.then(|| RefCamera::new(&params.camera));
        let lights = if let Some(ref_cam) = &ref_cam {
            if !ref_cam.is_finite() {
                return Err(rerr(
                    Param::Reference,
                    format!(
                        "the camera (look-from {:?}, look-at {:?}) is beyond the reference's \
                         f32 arithmetic (there: eye distance {}, near plane {}, far plane {}); \
                         use the f64 arithmetic",
                        params.camera.from, params.camera.at, ref_cam.d, ref_cam.ncv, ref_cam.fcv
                    ),
                ));
            }
            let f32_ok = |x: f64| (x as f32).is_finite() && (x == 0.0 || x as f32 > 0.0);
            if !f32_ok(params.unit_step) || !f32_ok(params.plane_sep) {
                return Err(rerr(
                    Param::Reference,
                    format!(
                        "unit step {:?} / plane separation {:?} are beyond the reference's f32 \
                         arithmetic; use the f64 arithmetic",
                        params.unit_step, params.plane_sep
                    ),
                ));
            }
            let rl = ref_cam.lights(lights);
            if let Some(i) = rl
                .iter()
                .position(|(c, d)| !c.iter().chain(d.iter()).all(|x| x.is_finite()))
            {
                return Err(rerr(
                    Param::Reference,
                    format!(
                        "light {} (direction {:?}) is beyond the reference's f32 arithmetic; \
                         use the f64 arithmetic",
                        i + 1,
                        lights[i].dir
                    ),
                ));
            }
            rl
        } else {
            WorldLights::new(lights, &camera).lights
        };
        let depth_cue = params.dcn != [1.0; 3] || params.dcf != [1.0; 3];
        let kmax = ((camera.fcv - camera.ncv) / params.plane_sep.max(f64::MIN_POSITIVE))
            .min(MAX_SAMPLES_PER_RAY) as u32
            + 1;
        let simd = Simd::at_most(params.simd);
        let [w, h] = camera.spec.size;
        (w as usize)
            .checked_mul(h as usize)
            .and_then(|n| n.checked_mul(channels))
            .and_then(|n| n.checked_mul(4))
            .ok_or_else(|| too_large(w, h))?;
        let mut spec = RenderSpec {
            params,
            camera,
            lut,
            levoy,
            lights,
            channels,
            need_grad,
            second,
            lut_by_value,
            value_opacity,
            once,
            kmax,
            depth_cue,
            alpha_table: None,
            arith: match ref_cam {
                Some(c) => Prepared::Reference(c),
                None => Prepared::F64(match lut {
                    Some(lut) if lut.entries().len() <= 1 << 20 => lut
                        .entries()
                        .iter()
                        .map(|e| ln_transparency(e[3].clamp(0.0, 1.0)))
                        .collect(),
                    _ => Vec::new(),
                }),
            },
            simd,
        };
        // Orthographic rays all step the same length, so the corrected opacity of each
        // LUT entry can be computed once (not for Levoy, which scales alpha per sample).
        if let (Some(lut), None, true) = (lut, levoy, spec.camera.spec.orthographic) {
            if lut.entries().len() <= 1 << 16 {
                let entries = lut.entries().iter();
                spec.alpha_table = Some(match &spec.arith {
                    Prepared::Reference(c) => {
                        let ray =
                            c.ray(0, 0, spec.plane_sep() as f32, spec.params.unit_step as f32);
                        let ex = ray.alpha_exp;
                        let table = entries.map(|e| refarith::correct_alpha(e[3], ex));
                        (ex, table.collect())
                    }
                    Prepared::F64(_) => {
                        let ex = spec.ray_geom(0, 0).alpha_exp;
                        (ex, entries.map(|e| correct_alpha(e[3], ex)).collect())
                    }
                });
            }
        }
        Ok(spec)
    }

    /// The parameters, as validated.
    pub fn params(&self) -> &RenderParams {
        &self.params
    }

    /// The camera frame.
    pub fn camera(&self) -> &Camera {
        &self.camera
    }

    /// Output channels per pixel (probe length, +1 with time).
    pub fn channels(&self) -> usize {
        self.channels
    }

    /// Image width and height.
    pub fn size(&self) -> [u32; 2] {
        self.camera.spec.size
    }

    /// The vector level in use.
    #[doc(hidden)]
    pub fn simd(&self) -> Simd {
        self.simd
    }

    /// Floats in the image (W·H·channels); [`RenderSpec::new`] made sure their bytes
    /// can be addressed.
    pub fn image_len(&self) -> usize {
        let [w, h] = self.size();
        w as usize * h as usize * self.channels
    }

    /// The checks that need the volume: the reference arithmetic compares index bounds
    /// in f32, exact only for axes of at most [`refarith::MAX_AXIS`] samples.
    ///
    /// # Errors
    /// [`ErrorKind::Volume`] when an axis is too long for the arithmetic.
    pub fn check_volume(&self, sizes: [usize; 3]) -> Result<()> {
        if let (true, Some(n)) = (
            self.params.reference,
            sizes.iter().find(|&&n| n > refarith::MAX_AXIS),
        ) {
            return Err(Error::about(
                ErrorKind::Volume,
                Param::Volume,
                alloc::format!(
                    "an axis of {n} samples is beyond the reference's exact f32 index \
                     arithmetic (at most {}); use the f64 arithmetic",
                    refarith::MAX_AXIS
                ),
            ));
        }
        Ok(())
    }

    /// What a skip grid records for this render, when one applies (`params.skip_empty`
    /// and an `over` render of a colour probe with a LUT, or a `max` render of the
    /// value or the gradient magnitude).
    #[doc(hidden)]
    pub fn skip_kind(&self) -> Option<SkipKind> {
        let p = &self.params;
        match (p.skip_empty, p.blend, p.probe) {
            (false, _, _) => None,
            (_, Blend::Over, pr) if pr.is_colour() && self.lut.is_some() => Some(SkipKind::Opacity),
            (_, Blend::Max, Probe::Value) => Some(SkipKind::MaxValue),
            (_, Blend::Max, Probe::GradMag) => Some(SkipKind::MaxGradMag),
            _ => None,
        }
    }

    /// The skip grid for `vol`, when one applies (see [`RenderSpec::skip_kind`]).
    #[doc(hidden)]
    pub fn skip_grid<V: Voxel>(&self, vol: &Volume<'_, V>, kernel: KernelName) -> Option<SkipGrid> {
        self.skip_plan(vol, kernel).map(|plan| plan.build(vol))
    }

    /// Aims `grid`, made for this render's volume `vol` and kernel `K`, at this
    /// render's camera: under `over`, each ray of an orthographic view then walks
    /// first the samples that can reach a block that is not empty (the same bits).
    #[doc(hidden)]
    pub fn aim<V: Voxel, K: Kernel<S>, const S: usize>(
        &self,
        vol: Volume<'_, V>,
        grid: &mut SkipGrid,
    ) {
        let a = self.with_march::<V, K, S, _>(vol, Some(&*grid), None, false, |m| m.aim());
        grid.set_aim(a);
    }

    /// [`RenderSpec::aim`] in parts, for several threads: the aim's model for `grid` (a
    /// grid of this render's kind made from `vol`, e.g. kept from another render), whose
    /// [`ReAim::part`]s of its fine blocks [`ReAim::finish`] puts together into the aim
    /// [`RenderSpec::aim`] gives.
    #[doc(hidden)]
    pub fn re_aim<V: Voxel, K: Kernel<S>, const S: usize>(
        &self,
        vol: Volume<'_, V>,
        grid: &SkipGrid,
    ) -> ReAim {
        let model = self.with_march::<V, K, S, _>(vol, Some(grid), None, false, |m| m.grid_model());
        ReAim::new(model, grid)
    }

    /// `plan` (this render's [`RenderSpec::skip_plan`] for `vol` and `K`) aimed at this
    /// render's camera: the grid it builds comes aimed as [`RenderSpec::aim`] aims it,
    /// each run of the build placing its own blocks (so several threads building a grid
    /// share that work too). A plan that is not an opacity plan, or a view the aim does
    /// not serve, is returned as it is.
    #[doc(hidden)]
    pub fn aim_plan<V: Voxel, K: Kernel<S>, const S: usize>(
        &self,
        vol: Volume<'_, V>,
        plan: SkipPlan<'a>,
    ) -> SkipPlan<'a> {
        if plan.kind() != SkipKind::Opacity {
            return plan;
        }
        let nf = plan.fine_blocks();
        let model = self.with_march::<V, K, S, _>(vol, None, None, false, |m| m.aim_model(nf));
        plan.aimed(model)
    }

    /// [`RenderSpec::skip_grid`]'s plan, for building the grid in parts (e.g. on
    /// several threads; the same grid).
    #[doc(hidden)]
    pub fn skip_plan<V: Voxel>(
        &self,
        vol: &Volume<'_, V>,
        kernel: KernelName,
    ) -> Option<SkipPlan<'a>> {
        let plan = match (self.skip_kind()?, self.lut) {
            (SkipKind::Opacity, Some(lut)) => Some(SkipPlan::new(vol, kernel, lut)),
            (kind, _) => SkipPlan::for_max(vol, kernel, kind),
        };
        plan.map(|p| p.with_simd(self.simd))
    }

    /// Whether building this render's skip grid is likely to pay for itself: always for
    /// an opacity grid (`over`), and for a `max` grid unless a pilot says it would skip
    /// next to nothing (see [`RenderSpec::pilot`]). The image is the same bits either
    /// way (skipping is exact); only the time differs. `cast` casts the pilot's rays
    /// (see [`PilotCast`]; `&|rays| rays(0, 1)` on the calling thread).
    ///
    /// Not generic, as [`RenderSpec::cast`].
    #[cfg(not(test))] // as for `cast`
    pub fn skip_pays(&self, vol: AnyVolume<'_>, kernel: KernelName, cast: PilotCast<'_>) -> bool {
        struct Pilot<'s, 'a, 'c>(&'s RenderSpec<'a>, PilotCast<'c>);
        impl ConvoTask for Pilot<'_, '_, '_> {
            type Output = bool;
            fn run<V: Voxel, K: Kernel<S>, const S: usize>(self, vol: Volume<'_, V>) -> bool {
                self.0.pilot::<V, K, S>(vol, self.1)
            }
        }
        dispatch(vol, kernel, Pilot(self, cast))
    }

    /// [`RenderSpec::skip_pays`] for a volume and kernel known at compile time. A `max`
    /// grid costs a pass over every voxel, and saves only where a block's bound falls
    /// below a ray's running maximum. A pilot casts up to 16 × 16 rays spread over the
    /// image (no skipping; their results are the rays' maxima) and samples the bound of
    /// every eighth fine block along each axis ([`SkipPlan::sample_bounds`]): the grid
    /// is built when, averaged over the pilot rays, enough sampled blocks lie below the
    /// ray's maximum: one in 16 for the value, one in 2 for the gradient magnitude,
    /// whose bounds are looser (on a CT whose pilot found 35–41%, the gradient grid
    /// skipped next to nothing and cost its build, 4–10% of the render;
    /// bench/RESULTS.md run 69). A value grid on a volume of at most [`PILOT_VOXELS`]
    /// voxels is built without a pilot (it is cheap there); a gradient grid always has
    /// one.
    #[doc(hidden)]
    pub fn pilot<V: Voxel, K: Kernel<S>, const S: usize>(
        &self,
        vol: Volume<'_, V>,
        cast: PilotCast<'_>,
    ) -> bool {
        let kind = match self.skip_kind() {
            None => return false,
            Some(SkipKind::Opacity) => return true,
            Some(kind) => kind,
        };
        let sizes = vol.sizes();
        let voxels = sizes[0].saturating_mul(sizes[1]).saturating_mul(sizes[2]);
        if kind == SkipKind::MaxValue && voxels <= PILOT_VOXELS {
            return true;
        }
        self.pilot_says::<V, K, S>(vol, kind, cast)
    }

    /// The pilot of [`RenderSpec::pilot`] (any volume size).
    #[doc(hidden)]
    pub fn pilot_says<V: Voxel, K: Kernel<S>, const S: usize>(
        &self,
        vol: Volume<'_, V>,
        kind: SkipKind,
        cast: PilotCast<'_>,
    ) -> bool {
        let Some(plan) = SkipPlan::for_max(&vol, K::NAME, kind) else {
            return false;
        };
        let [w, h] = self.size();
        let (nx, ny) = (w.min(16), h.min(16));
        let outside = self.params.outside;
        // The maxima of pilot rows part, part + parts, …
        let rays = |part: u32, parts: u32| {
            let mut px = alloc::vec![0.0f32; self.channels()];
            let mut maxima = Vec::with_capacity((nx * ny) as usize);
            self.with_march::<V, K, S, ()>(vol, None, None, false, |m| {
                for b in (part..ny).step_by(parts.max(1) as usize) {
                    for a in 0..nx {
                        let (hi, vi) = ((2 * a + 1) * w / (2 * nx), (2 * b + 1) * h / (2 * ny));
                        m.cast(hi, vi, Out::Pixel(&mut px), Loop::Batched, None);
                        // (Rays that miss the volume give `outside`; they skip nothing.)
                        if !px[0].is_nan() && px[0].to_bits() != outside.to_bits() {
                            maxima.push(px[0]);
                        }
                    }
                }
            });
            maxima
        };
        let maxima = cast(&rays);
        let mut bounds = plan.sample_bounds(&vol, 8);
        if maxima.is_empty() || bounds.is_empty() {
            return false;
        }
        // Per pilot ray, the share of sampled blocks below its maximum (blocks it could
        // skip once its running maximum is there); the grid when they average 1/16 (the
        // value) or 1/2 (the gradient magnitude).
        bounds.sort_by(f32::total_cmp);
        let below: usize = maxima
            .iter()
            .map(|&q| bounds.partition_point(|&b| b < q))
            .sum();
        let need = if kind == SkipKind::MaxGradMag { 2 } else { 16 };
        below * need >= bounds.len() * maxima.len()
    }

    /// Whether the gradient is computed at each sample.
    pub fn needs_gradient(&self) -> bool {
        self.need_grad
    }

    /// The plane separation the rays use (0 when sampling once).
    fn plane_sep(&self) -> f64 {
        if self.once {
            0.0
        } else {
            self.params.plane_sep
        }
    }

    /// Geometry of the ray through pixel (hi, vi) in f64 (the `-db` header; the
    /// reference arithmetic rounds the same quantities to f32).
    #[doc(hidden)]
    pub fn ray_geom(&self, hi: u32, vi: u32) -> RayGeom {
        RayGeom::new(
            &self.camera,
            hi,
            vi,
            self.plane_sep(),
            self.params.unit_step,
        )
    }

    /// The pixels whose rays may meet the supports of `vol`'s samples: a rectangle
    /// `[h0, h1] × [v0, v1]` holding the image ([`Camera::reach`]) of the box of index
    /// positions where a support can be inside (one voxel beyond the samples on every
    /// side, for every kernel), widened by 2 voxels plus 10⁻⁴ of the magnitudes the
    /// arithmetics compute ray positions from (far more than either rounds by), and by
    /// as far as the arithmetic's own camera frame can move a sample from where the f64
    /// camera puts it ([`RenderSpec::frame_slack`]), then by a pixel. None when no
    /// bounded rectangle holds it (a perspective camera inside or beside the box).
    pub(crate) fn reach<V: Voxel>(&self, vol: &Volume<'_, V>) -> Option<[f64; 4]> {
        let cam = &self.camera;
        let m = &vol.wtoi().m;
        let norm = (0..3)
            .map(|r| m[4 * r].abs() + m[4 * r + 1].abs() + m[4 * r + 2].abs())
            .fold(0.0, f64::max);
        let shift = m[3].abs().max(m[7].abs()).max(m[11].abs());
        let from = cam.spec.from.iter().fold(0.0f64, |a, x| a.max(x.abs()));
        let world = from + cam.fcv.abs() + cam.wdth.abs() + cam.hght.abs();
        let (org, sz) = (vol.origin(), vol.sizes());
        let end = |a: usize| (org[a] + sz[a]) as f64;
        let index = end(0).max(end(1)).max(end(2));
        // A view-space position has |x| + |y| + |z| at most `reach_view`; a frame off by
        // `slack` per component moves it by at most 3 slack that much (world units).
        let depth = cam.ncv.abs().max(cam.fcv.abs());
        let reach_view = depth * (1.0 + (cam.wdth + cam.hght).abs() / (2.0 * cam.d))
            + (cam.wdth + cam.hght).abs();
        let frame = 3.0 * self.frame_slack() * reach_view * norm;
        let margin = 2.0 + 1e-4 * (norm * world + shift + index) + frame;
        let corners: [[f64; 3]; 8] = core::array::from_fn(|c| {
            vol.itow().point(core::array::from_fn(|a| {
                if c >> a & 1 == 1 {
                    end(a) + margin
                } else {
                    org[a] as f64 - 1.0 - margin
                }
            }))
        });
        let r = cam.reach(&corners)?;
        Some([r[0] - 1.0, r[1] + 1.0, r[2] - 1.0, r[3] + 1.0])
    }

    /// How far, per component, the chosen arithmetic's camera frame (u, v, n) lies from
    /// the f64 camera's: 0 for the f64 arithmetic. The reference computes its frame in
    /// f32, the course program's way: usually within a few ulps, but an up vector nearly
    /// along the view, or one whose cross product overflows f32 (its frame then has zero
    /// axes, every ray the central one), puts its rays elsewhere.
    fn frame_slack(&self) -> f64 {
        let Prepared::Reference(rc) = &self.arith else {
            return 0.0;
        };
        let c = &self.camera;
        [(rc.u, c.u), (rc.v, c.v), (rc.n, c.n)]
            .iter()
            .flat_map(|(a, b)| (0..3).map(move |i| (f64::from(a[i]) - b[i]).abs()))
            .fold(0.0, f64::max)
    }

    /// Runs `f` with the loop over `vol` in the spec's arithmetic (casting the stretches
    /// `own` gives, for a brick); `traced` when a trace will see the samples (which
    /// shows their values even where the probe does not need them).
    fn with_march<V: Voxel, K: Kernel<S>, const S: usize, R>(
        &self,
        vol: Volume<'_, V>,
        skip: Option<&SkipGrid>,
        own: Option<Own>,
        traced: bool,
        f: impl FnOnce(&dyn Cast) -> R,
    ) -> R {
        let (sizes, org) = (vol.sizes(), vol.origin().map(|o| o as i64));
        let reach = self.reach(&vol);
        // Only a grid made for this render and volume shape is used.
        let skip = skip.filter(|g| {
            self.skip_kind()
                .is_some_and(|kind| g.fits(kind, K::NAME, sizes))
        });
        match &self.arith {
            Prepared::Reference(cam) => {
                let mut a = Reference::<V, K, S>::new(
                    vol,
                    self.simd,
                    cam,
                    self.plane_sep() as f32,
                    self.params.unit_step as f32,
                );
                a.value = traced || !matches!(self.params.probe, Probe::GradMag | Probe::GradVec);
                f(&march::<_, K, S>(self, a, skip, sizes, org, own, reach))
            }
            Prepared::F64(ln_transparency) => {
                let a = F64::<V, K, S>::new(
                    vol,
                    self.simd,
                    &self.camera,
                    self.plane_sep(),
                    self.params.unit_step,
                    ln_transparency,
                );
                f(&march::<_, K, S>(self, a, skip, sizes, org, own, reach))
            }
        }
    }

    /// Casts the ray through pixel (hi, vi) of `vol` with kernel `kernel` and `mode`, and
    /// writes its probe-length result to the front of `out`; `trace`, when given, sees
    /// every sample. Both loops give the same bits.
    ///
    /// Not generic: the loops are compiled once, in this crate, for every voxel type,
    /// kernel and arithmetic, not again in each crate that renders.
    ///
    /// # Errors
    /// [`ErrorKind::Render`] when the pixel is not in the image or `out` is shorter than
    /// the probe; [`ErrorKind::Volume`] as [`RenderSpec::check_volume`].
    // Left out of this crate's unit-test build (which renders only through `rows_in`):
    // the loops for every voxel type, kernel and arithmetic are most of rnd-core's
    // build time, and the integration tests and the library itself build them anyway.
    #[cfg(not(test))]
    #[allow(clippy::too_many_arguments)]
    pub fn cast(
        &self,
        vol: AnyVolume<'_>,
        kernel: KernelName,
        hi: u32,
        vi: u32,
        out: &mut [f32],
        mode: Loop,
        trace: Trace<'_>,
    ) -> Result<()> {
        self.check_volume(vol.grid())?;
        let ([w, h], plen) = (self.size(), self.params.probe.length());
        if hi >= w || vi >= h || out.len() < plen {
            return Err(Error::new(
                ErrorKind::Render,
                alloc::format!(
                    "pixel ({hi}, {vi}) with room for {} floats: a {w} x {h} image's \
                     pixels take {plen}",
                    out.len()
                ),
            ));
        }
        let mut trace = trace;
        self.on_march(vol, kernel, None, None, trace.is_some(), &mut |m| {
            m.cast(hi, vi, Out::Pixel(&mut out[..plen]), mode, trace.take())
        });
        Ok(())
    }

    /// The checks of a call that renders image rows `rows` of `vol` into `items` items,
    /// `per_pixel` a pixel (`what` names them).
    #[cfg(not(test))] // as for `cast`
    fn check_rows(
        &self,
        vol: AnyVolume<'_>,
        rows: &core::ops::Range<u32>,
        items: usize,
        per_pixel: usize,
        what: &str,
    ) -> Result<()> {
        self.check_volume(vol.grid())?;
        let [w, h] = self.size();
        // (Saturating: rows beyond the image may be many; they are refused below.)
        let need = rows
            .len()
            .saturating_mul(w as usize)
            .saturating_mul(per_pixel);
        if rows.start > rows.end || rows.end > h || items != need {
            return Err(Error::new(
                ErrorKind::Render,
                alloc::format!(
                    "{items} {what} for rows {}..{} of a {w} x {h} image (rows must lie \
                     in 0..{h} and take {per_pixel} a pixel)",
                    rows.start,
                    rows.end
                ),
            ));
        }
        Ok(())
    }

    /// Renders image rows `rows` of `vol` with kernel `kernel` into `out` (`channels`
    /// floats per pixel, rows consecutive), skipping empty space by `skip` (a grid from
    /// [`RenderSpec::skip_grid`]; one made for another render or volume is ignored).
    /// `clock`, when given, returns milliseconds and fills the time channel.
    ///
    /// Not generic, as [`RenderSpec::cast`].
    ///
    /// # Errors
    /// [`ErrorKind::Render`] when `rows` are not rows of the image or `out` does not
    /// hold exactly their [`RenderSpec::channels`] floats a pixel; [`ErrorKind::Volume`]
    /// as [`RenderSpec::check_volume`].
    #[cfg(not(test))] // as for `cast`
    pub fn render_rows(
        &self,
        vol: AnyVolume<'_>,
        kernel: KernelName,
        skip: Option<&SkipGrid>,
        rows: core::ops::Range<u32>,
        out: &mut [f32],
        clock: Option<&dyn Fn() -> f64>,
    ) -> Result<()> {
        self.check_rows(vol, &rows, out.len(), self.channels, "floats")?;
        self.on_march(vol, kernel, skip, None, false, &mut |m| {
            self.cast_rows(m, rows.clone(), &mut *out, clock)
        });
        Ok(())
    }

    /// Renders, for each pixel of image rows `rows`, the [`Partial`](crate::brick::Partial)
    /// of the stretch of its ray that `own` gives (one brick of a sort-last render, see
    /// [`crate::brick`]), from `vol`, the brick's [`Volume::region`] with the ghost layers
    /// of [`crate::brick::ghosts`], into `out` (one per pixel, rows consecutive); under
    /// `median` also the samples blended into `samples` (one list per pixel, channel by
    /// channel; `samples` may be empty otherwise). `skip` as for
    /// [`RenderSpec::render_rows`] (a grid made from `vol`); `clock`, when given, returns
    /// milliseconds and times each pixel's stretch (`Partial::time`).
    ///
    /// Not generic, as [`RenderSpec::cast`].
    ///
    /// # Errors
    /// [`ErrorKind::Volume`] when a ray's computed positions could lie half a voxel or
    /// more from its exact line (coordinates too large for the ghost layers), or as
    /// [`RenderSpec::check_volume`]; [`ErrorKind::Render`] when `rows` are not rows of
    /// the image or `out` or `samples` has the wrong length.
    #[cfg(not(test))] // as for `cast`
    #[allow(clippy::too_many_arguments)]
    pub fn render_part_rows(
        &self,
        vol: AnyVolume<'_>,
        kernel: KernelName,
        skip: Option<&SkipGrid>,
        own: &Own,
        rows: core::ops::Range<u32>,
        out: &mut [crate::brick::Partial],
        samples: &mut [Vec<f32>],
        clock: Option<&dyn Fn() -> f64>,
    ) -> Result<()> {
        self.check_rows(vol, &rows, out.len(), 1, "partials")?;
        if self.params.blend.keeps_samples() {
            self.check_rows(vol, &rows, samples.len(), 1, "sample lists")?;
        }
        let w = self.size()[0] as usize;
        let mode = self.loop_mode();
        let mut none = Vec::new();
        let exact = self.on_march(vol, kernel, skip, Some(*own), false, &mut |m| {
            for (r, vi, hi) in pixels(rows.clone(), w) {
                let i = r * w + hi;
                let kept = samples.get_mut(i).unwrap_or(&mut none);
                let t0 = clock.map(|c| c());
                m.cast(hi as u32, vi, Out::Part(&mut out[i], kept), mode, None);
                if let (Some(c), Some(t0)) = (clock, t0) {
                    out[i].time = (c() - t0) as f32;
                }
            }
            !m.imprecise()
        });
        if exact {
            Ok(())
        } else {
            Err(Error::new(
                ErrorKind::Volume,
                "index coordinates too large to split the volume into bricks exactly \
                 (a ray's positions may lie half a voxel from its line)",
            ))
        }
    }

    /// [`RenderSpec::render_rows`] with the voxel type and kernel known.
    pub(crate) fn rows_in<V: Voxel, K: Kernel<S>, const S: usize>(
        &self,
        vol: Volume<'_, V>,
        skip: Option<&SkipGrid>,
        rows: core::ops::Range<u32>,
        out: &mut [f32],
        clock: Option<&dyn Fn() -> f64>,
    ) {
        debug_assert_eq!(
            out.len(),
            rows.len() * self.size()[0] as usize * self.channels
        );
        self.with_march::<V, K, S, ()>(vol, skip, None, false, |m| {
            self.cast_rows(m, rows, out, clock)
        });
    }

    /// The loop mode of [`RenderParams::fast_loop`].
    fn loop_mode(&self) -> Loop {
        if self.params.fast_loop {
            Loop::Batched
        } else {
            Loop::OneSample
        }
    }

    /// Casts the rays of image rows `rows` with `m` into `out` (as
    /// [`RenderSpec::render_rows`]).
    fn cast_rows(
        &self,
        m: &dyn Cast,
        rows: core::ops::Range<u32>,
        out: &mut [f32],
        clock: Option<&dyn Fn() -> f64>,
    ) {
        let (w, ch) = (self.size()[0] as usize, self.channels);
        let (plen, mode) = (self.params.probe.length(), self.loop_mode());
        // Rays that miss the volume all give one result: cast once, then copied (unless
        // each pixel's time is asked for).
        let reach = m.bare_reach().filter(|_| clock.is_none());
        m.aim_rows(rows.clone());
        let mut missed = None;
        for (r, vi, hi) in pixels(rows, w) {
            let at = (r * w + hi) * ch;
            if !crate::march::meets(reach, hi as u32, vi) {
                if let Some(j) = missed {
                    out.copy_within(j..j + plen, at);
                    continue;
                }
                missed = Some(at);
            }
            let px = &mut out[at..at + ch];
            let t0 = clock.map(|c| c());
            m.cast(hi as u32, vi, Out::Pixel(&mut px[..plen]), mode, None);
            if let (Some(c), Some(t0)) = (clock, t0) {
                px[plen] = (c() - t0) as f32;
            }
        }
    }

    /// [`RenderSpec::with_march`] for a volume and kernel known only at run time: `f`
    /// sees the loop (compiled here, for every voxel type and kernel).
    #[cfg(not(test))] // as for `cast`
    fn on_march<R>(
        &self,
        vol: AnyVolume<'_>,
        kernel: KernelName,
        skip: Option<&SkipGrid>,
        own: Option<Own>,
        traced: bool,
        f: &mut dyn FnMut(&dyn Cast) -> R,
    ) -> R {
        struct OnMarch<'f, 's, 'a, R> {
            spec: &'s RenderSpec<'a>,
            skip: Option<&'s SkipGrid>,
            own: Option<Own>,
            traced: bool,
            f: &'f mut dyn FnMut(&dyn Cast) -> R,
        }
        impl<R> ConvoTask for OnMarch<'_, '_, '_, R> {
            type Output = R;
            fn run<V: Voxel, K: Kernel<S>, const S: usize>(self, vol: Volume<'_, V>) -> R {
                let OnMarch {
                    spec,
                    skip,
                    own,
                    traced,
                    f,
                } = self;
                spec.with_march::<V, K, S, R>(vol, skip, own, traced, f)
            }
        }
        let task = OnMarch {
            spec: self,
            skip,
            own,
            traced,
            f,
        };
        dispatch(vol, kernel, task)
    }
}

/// The loop of `spec` over `sizes` samples from grid index `org` in arithmetic `a` with
/// kernel `K`.
fn march<'s, 'a, A: crate::arith::Arith, K: Kernel<S>, const S: usize>(
    spec: &'s RenderSpec<'a>,
    a: A,
    skip: Option<&'s SkipGrid>,
    sizes: [usize; 3],
    org: [i64; 3],
    own: Option<Own>,
    reach: Option<[f64; 4]>,
) -> March<'s, 'a, A> {
    March {
        spec,
        a,
        skip,
        sizes,
        org,
        own,
        imprecise: core::cell::Cell::new(false),
        support: S,
        lo: K::LO,
        hint: core::cell::Cell::new(None),
        idle: core::cell::Cell::new(0),
        wait: core::cell::Cell::new(0),
        kept: core::cell::Cell::new(crate::blend::Kept::new()),
        reach,
        win: core::cell::RefCell::new(None),
    }
}

/// One ray cast by a [`March`] in either arithmetic.
trait Cast {
    fn cast(&self, hi: u32, vi: u32, out: Out<'_>, mode: Loop, trace: Trace<'_>);
    /// For tests: [`March::check_run_bounds`].
    #[cfg(test)]
    fn check_run_bounds(&self, hi: u32, vi: u32, n: u32) -> usize;
    /// For tests: [`March::check_walk`].
    #[cfg(test)]
    fn check_walk(&self, hi: u32, vi: u32) -> usize;
    /// For tests: [`March::check_windows`].
    #[cfg(test)]
    fn check_windows(&self, hi: u32, vi: u32) -> usize;
    /// For tests: [`March::check_reach`].
    #[cfg(test)]
    fn check_reach(&self, hi: u32, vi: u32) -> usize;
    /// [`March::aim`].
    fn aim(&self) -> Option<crate::march::Aim>;
    /// [`March::aim_model`].
    fn aim_model(&self, nf: [usize; 3]) -> Option<crate::march::Aim>;
    /// [`March::grid_model`].
    fn grid_model(&self) -> Option<crate::march::Aim>;
    /// [`March::aim_rows`].
    fn aim_rows(&self, rows: core::ops::Range<u32>);
    /// [`March::bare_reach`].
    fn bare_reach(&self) -> Option<[f64; 4]>;
    /// Whether a brick's ray could not be cast exactly (see [`Own`]).
    #[cfg_attr(test, allow(dead_code))] // (bricks render outside the unit tests)
    fn imprecise(&self) -> bool;
}

impl<A: crate::arith::Arith> Cast for March<'_, '_, A> {
    fn cast(&self, hi: u32, vi: u32, out: Out<'_>, mode: Loop, trace: Trace<'_>) {
        March::cast(self, hi, vi, out, mode, trace)
    }
    #[cfg(test)]
    fn check_run_bounds(&self, hi: u32, vi: u32, n: u32) -> usize {
        March::check_run_bounds(self, hi, vi, n)
    }
    #[cfg(test)]
    fn check_walk(&self, hi: u32, vi: u32) -> usize {
        March::check_walk(self, hi, vi)
    }
    #[cfg(test)]
    fn check_windows(&self, hi: u32, vi: u32) -> usize {
        March::check_windows(self, hi, vi)
    }
    #[cfg(test)]
    fn check_reach(&self, hi: u32, vi: u32) -> usize {
        March::check_reach(self, hi, vi)
    }
    fn aim(&self) -> Option<crate::march::Aim> {
        March::aim(self)
    }
    fn aim_model(&self, nf: [usize; 3]) -> Option<crate::march::Aim> {
        March::aim_model(self, nf)
    }
    fn grid_model(&self) -> Option<crate::march::Aim> {
        March::grid_model(self)
    }
    fn aim_rows(&self, rows: core::ops::Range<u32>) {
        March::aim_rows(self, rows)
    }
    fn bare_reach(&self) -> Option<[f64; 4]> {
        March::bare_reach(self)
    }
    fn imprecise(&self) -> bool {
        self.imprecise.get()
    }
}

/// A volume of either voxel type.
#[derive(Debug, Clone, Copy)]
pub enum AnyVolume<'a> {
    /// 32-bit float voxels.
    F32(Volume<'a, f32>),
    /// Signed 16-bit voxels.
    I16(Volume<'a, i16>),
}

impl<'a, V: Voxel> From<Volume<'a, V>> for AnyVolume<'a> {
    fn from(v: Volume<'a, V>) -> Self {
        V::any(v)
    }
}

/// The reconstruction at one point: see [`AnyVolume::probe`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Probed {
    /// The point's index-space position.
    pub index: [f64; 3],
    /// Reconstructed value.
    pub value: f32,
    /// Gradient in world space (per world unit).
    pub gradient: [f32; 3],
}

impl AnyVolume<'_> {
    /// Samples held per axis (see [`Volume::sizes`]).
    pub fn sizes(&self) -> [usize; 3] {
        match self {
            AnyVolume::F32(v) => v.sizes(),
            AnyVolume::I16(v) => v.sizes(),
        }
    }

    /// Samples of the whole grid per axis (see [`Volume::grid`]).
    pub fn grid(&self) -> [usize; 3] {
        match self {
            AnyVolume::F32(v) => v.grid(),
            AnyVolume::I16(v) => v.grid(),
        }
    }

    /// Index-to-world.
    pub fn itow(&self) -> &Affine4 {
        match self {
            AnyVolume::F32(v) => v.itow(),
            AnyVolume::I16(v) => v.itow(),
        }
    }

    /// The world positions of the eight corner samples (see
    /// [`crate::camera::CameraSpec::framing`]).
    pub fn world_corners(&self) -> [[f64; 3]; 8] {
        crate::volume::corners(self.itow(), self.grid())
    }

    /// Reconstructs the value and world-space gradient at world point `world` with
    /// `kernel`, in f64 geometry with f32 sums (the arithmetic of `rendr ceval`).
    ///
    /// The inside rule: the point is mapped to index space; it is inside when, on every
    /// axis, the kernel's whole support around it lies on samples of the volume (so a
    /// support-4 kernel needs one sample of margin before the point and two after; the
    /// box kernel only the nearest sample). `None` outside, or at a non-finite point.
    ///
    /// ```
    /// use rnd_core::affine::Affine4;
    /// use rnd_core::kernel::KernelName;
    /// use rnd_core::render::AnyVolume;
    /// use rnd_core::volume::OwnedVolume;
    ///
    /// // f = 2x + 3y - z on a unit grid: the tent kernel reproduces it exactly.
    /// let vol = OwnedVolume::from_fn([8, 8, 8], Affine4::IDENTITY, |[i, j, k]| {
    ///     (2 * i as i32 + 3 * j as i32 - k as i32) as i16
    /// })
    /// .unwrap();
    /// let p = AnyVolume::from(vol.view()).probe(KernelName::Tent, [2.5, 3.25, 4.0]).unwrap();
    /// assert_eq!(p.value, 2.0 * 2.5 + 3.0 * 3.25 - 4.0);
    /// assert_eq!(p.gradient, [2.0, 3.0, -1.0]);
    /// assert!(AnyVolume::from(vol.view()).probe(KernelName::Tent, [7.5, 0.0, 0.0]).is_none());
    /// ```
    pub fn probe(&self, kernel: KernelName, world: [f64; 3]) -> Option<Probed> {
        struct At([f64; 3]);
        impl ConvoTask for At {
            type Output = crate::convo::ConvoSample;
            fn run<V: Voxel, K: Kernel<S>, const S: usize>(
                self,
                vol: Volume<'_, V>,
            ) -> crate::convo::ConvoSample {
                crate::convo::Convo::<V, K, S>::new(vol).eval_world(self.0, true)
            }
        }
        if !world.iter().all(|x| x.is_finite()) {
            return None;
        }
        let s = dispatch(*self, kernel, At(world));
        s.inside.then_some(Probed {
            index: s.pos_i,
            value: s.value,
            gradient: s.grad_w,
        })
    }
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
    struct WithKernel<'v, T>(AnyVolume<'v>, T);
    impl<T: ConvoTask> KernelTask for WithKernel<'_, T> {
        type Output = T::Output;
        fn run<K: Kernel<S>, const S: usize>(self) -> T::Output {
            match self.0 {
                AnyVolume::F32(v) => self.1.run::<_, K, S>(v),
                AnyVolume::I16(v) => self.1.run::<_, K, S>(v),
            }
        }
    }
    kernel.with(WithKernel(vol, task))
}

/// The error for an image whose size in bytes does not fit in `usize`.
fn too_large(w: u32, h: u32) -> Error {
    Error::about(
        ErrorKind::Memory,
        Param::ImageSize,
        alloc::format!("a {w} x {h} image is too large to address"),
    )
}

/// Renders the whole image on the calling thread into a new buffer (W·H·channels floats,
/// row-major from the top).
///
/// # Errors
/// [`ErrorKind::Volume`] when the volume fails [`RenderSpec::check_volume`];
/// [`ErrorKind::Memory`] when the image cannot be allocated.
#[cfg(not(test))] // as for `RenderSpec::cast`
pub fn render(spec: &RenderSpec<'_>, vol: AnyVolume<'_>, kernel: KernelName) -> Result<Vec<f32>> {
    struct Whole<'s, 'a>(&'s RenderSpec<'a>, Vec<f32>);
    impl ConvoTask for Whole<'_, '_> {
        type Output = Vec<f32>;
        fn run<V: Voxel, K: Kernel<S>, const S: usize>(self, vol: Volume<'_, V>) -> Vec<f32> {
            let Whole(spec, mut out) = self;
            let skip = spec
                .skip_plan(&vol, K::NAME)
                .filter(|_| spec.pilot::<V, K, S>(vol, &|rays| rays(0, 1)))
                .map(|plan| {
                    let mut g = plan.build(&vol);
                    spec.aim::<V, K, S>(vol, &mut g);
                    g
                });
            spec.rows_in::<V, K, S>(vol, skip.as_ref(), 0..spec.size()[1], &mut out, None);
            out
        }
    }
    spec.check_volume(vol.grid())?;
    let [w, h] = spec.size();
    let len = spec.image_len();
    let mut out = Vec::new();
    out.try_reserve_exact(len).map_err(|_| {
        Error::about(
            ErrorKind::Memory,
            Param::ImageSize,
            alloc::format!("no memory for a {w} x {h} image ({len} floats)"),
        )
    })?;
    out.resize(len, 0.0);
    Ok(dispatch(vol, kernel, Whole(spec, out)))
}

/// Columns of a strip in [`pixels`].
const STRIP: usize = 16;

/// The pixels of image rows `rows` of an image `w` pixels wide, as (row in `rows`, image
/// row, column), in the order they are cast: strip by strip of [`STRIP`] columns, each
/// strip row by row, every other row right to left (so that each ray follows a
/// neighbour: under `max` a ray starts from where the last found its maximum). The
/// rays of a strip of a few rows read much the same voxels, so these stay in the
/// core's second-level cache between them, where whole image rows of a large volume
/// would not (cachegrind, a 264 × 256 × 256 float volume, 256² rays along its second
/// axis, 8 rows at a time: 1.8 M misses of a 512 KiB cache instead of 4.6 M). The
/// order changes no bit of the image.
fn pixels(rows: core::ops::Range<u32>, w: usize) -> impl Iterator<Item = (usize, u32, usize)> {
    (0..w).step_by(STRIP).flat_map(move |x0| {
        rows.clone().enumerate().flat_map(move |(r, vi)| {
            let (n, back) = ((x0 + STRIP).min(w) - x0, r % 2 == 1);
            (0..n).map(move |i| (r, vi, x0 + if back { n - 1 - i } else { i }))
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::blend::Blend;
    use crate::kernel::{Bspln2, Bspln3, Tent};

    /// `pixels` gives every pixel of the rows once, strips of `STRIP` columns in order,
    /// each pixel of a strip beside the one before (every other row reversed).
    #[test]
    fn pixels_cover_each_pixel_once() {
        for (rows, w) in [
            (3..7u32, 37usize),
            (0..1, 1),
            (5..5, 9),
            (2..4, 16),
            (0..2, 17),
        ] {
            let got: Vec<_> = pixels(rows.clone(), w).collect();
            assert_eq!(got.len(), rows.len() * w);
            let mut seen = alloc::vec![false; rows.len() * w];
            for &(r, vi, hi) in &got {
                assert_eq!(vi, rows.start + r as u32);
                assert!(hi < w && !core::mem::replace(&mut seen[r * w + hi], true));
            }
            // Strip by strip (a strip's pixels before any of the next strip's), and
            // within a strip each pixel beside the one before.
            for p in got.windows(2) {
                let ((r0, _, h0), (r1, _, h1)) = (p[0], p[1]);
                if h0 / STRIP == h1 / STRIP {
                    assert!(
                        r0.abs_diff(r1) + h0.abs_diff(h1) == 1,
                        "{rows:?} {w}: {p:?}"
                    );
                } else {
                    assert!(h0 / STRIP < h1 / STRIP, "{rows:?} {w}: {p:?}");
                }
            }
        }
    }

    /// Renders' cameras for the checks below: both arithmetics, perspective and
    /// orthographic, along an axis and obliquely, a step of 0.37 (`max` of the value, or
    /// `over` of a LUT that is transparent below 100); `f` runs on each ray's
    /// [`Cast`] and the sum of what it gives is returned.
    fn each_ray<K: Kernel<S>, const S: usize>(
        vol: Volume<'_, f32>,
        over: bool,
        f: impl Fn(&dyn Cast, u32, u32) -> usize,
    ) -> usize {
        let lut = test_lut();
        let mut sum = 0;
        for (_, spec) in test_specs(over, &lut) {
            let g = spec.skip_grid(&vol, K::NAME).unwrap();
            sum += spec.with_march::<f32, K, S, usize>(vol, Some(&g), None, false, |m| {
                (0..20)
                    .flat_map(|vi| (0..24).map(move |hi| (hi, vi)))
                    .map(|(hi, vi)| f(m, hi, vi))
                    .sum()
            });
        }
        sum
    }

    /// The LUT of the `over` renders of [`test_specs`]: 0 opacity below 96, more above.
    fn test_lut() -> crate::txf::Lut {
        crate::txf::Lut::new(
            0.0,
            256.0,
            (0..8)
                .map(|i| [1.0, 0.5, 0.2, (i / 3) as f32 * 0.3])
                .collect(),
        )
        .unwrap()
    }

    /// 24 × 20 renders, each with whether its camera is orthographic: both arithmetics,
    /// orthographic and perspective, from three sides; `over` of the colour from `lut`
    /// or `max` of the value.
    fn test_specs(over: bool, lut: &crate::txf::Lut) -> Vec<(bool, RenderSpec<'_>)> {
        let mut out = Vec::new();
        for (reference, ortho) in [(true, true), (true, false), (false, true), (false, false)] {
            for from in [[0.0, -40.0, 0.5], [31.0, -17.0, 23.0], [-9.0, 13.0, -35.0]] {
                let mut p = RenderParams::new(CameraSpec {
                    from,
                    at: [0.3, -0.2, 0.1],
                    up: [0.0, 0.0, 1.0],
                    near: -15.0,
                    far: 15.0,
                    fov: 40.0,
                    size: [24, 20],
                    orthographic: ortho,
                });
                (p.blend, p.probe) = if over {
                    (Blend::Over, Probe::Rgba)
                } else {
                    (Blend::Max, Probe::Value)
                };
                p.reference = reference;
                p.plane_sep = 0.37;
                out.push((
                    ortho,
                    RenderSpec::new(p, over.then_some(lut), None, &[]).unwrap(),
                ));
            }
        }
        out
    }

    /// A volume of 21 × 18 × 23 values in 0 .. 257, whole and held from grid index
    /// (2, 1, 3) on (as a brick holds its part); `f` runs on each.
    fn on_volumes(f: impl Fn(Volume<'_, f32>)) {
        let sizes = [21usize, 18, 23];
        let data: Vec<f32> = (0..sizes.iter().product::<usize>())
            .map(|i| ((i * 7919) % 257) as f32)
            .collect();
        let itow = crate::affine::Affine4::from_columns(
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
            [-10.0, -8.5, -11.0],
        );
        let whole = Volume::new(&data, sizes, itow).unwrap();
        // A region held from grid index (2, 1, 3) on, as a brick holds its part.
        let b = crate::brick::Brick {
            lo: [2, 1, 3],
            hi: [17, 16, 19],
        };
        let mut held = Vec::new();
        for z in b.lo[2]..b.hi[2] {
            for y in b.lo[1]..b.hi[1] {
                let row = sizes[0] * (y + sizes[1] * z);
                held.extend_from_slice(&data[row + b.lo[0]..row + b.hi[0]]);
            }
        }
        let part = Volume::region(&held, sizes, b, itow).unwrap();
        f(whole);
        f(part);
    }

    /// Under `max`, a run of samples that [`March`] bounds whole (and may count
    /// unconvolved) has every sample inside, each bounded by the run's bound, for
    /// supports 2, 3 and 4 (see [`each_ray`] and [`on_volumes`]).
    #[test]
    fn run_bounds_hold_every_sample() {
        let runs =
            |m: &dyn Cast, hi, vi| m.check_run_bounds(hi, vi, 16) + m.check_run_bounds(hi, vi, 8);
        on_volumes(|vol| {
            assert!(each_ray::<Tent, 2>(vol, false, runs) > 1000);
            assert!(each_ray::<Bspln2, 3>(vol, false, runs) > 1000);
            assert!(each_ray::<Bspln3, 4>(vol, false, runs) > 1000);
        });
    }

    /// A ray through a pixel outside the rectangle where rays may meet the volume
    /// (`RenderSpec::reach`) has no sample inside, in either arithmetic, for supports
    /// 1 to 6 (see [`each_ray`] and [`on_volumes`]); and some rays are outside it.
    #[test]
    fn rays_outside_reach_miss() {
        use crate::kernel::{BoxK, C4Hexic};
        let miss = |m: &dyn Cast, hi, vi| m.check_reach(hi, vi);
        on_volumes(|vol| {
            assert!(each_ray::<BoxK, 1>(vol, false, miss) > 100);
            assert!(each_ray::<Tent, 2>(vol, false, miss) > 100);
            assert!(each_ray::<Bspln2, 3>(vol, false, miss) > 100);
            assert!(each_ray::<Bspln3, 4>(vol, true, miss) > 100);
            assert!(each_ray::<C4Hexic, 6>(vol, false, miss) > 100);
        });
    }

    /// Under `over`, every sample whose support start lies in a fine block that is not
    /// empty lies in its ray's window, for rays that follow the windows' model
    /// (orthographic views; see [`each_ray`] and [`on_volumes`]).
    #[test]
    fn windows_hold_every_sample_not_empty() {
        let win = |m: &dyn Cast, hi, vi| m.check_windows(hi, vi);
        on_volumes(|vol| {
            assert!(each_ray::<Tent, 2>(vol, true, win) > 10_000);
            assert!(each_ray::<Bspln3, 4>(vol, true, win) > 10_000);
        });
    }

    /// A plan aimed at the camera ([`RenderSpec::aim_plan`]) builds the grid that
    /// [`RenderSpec::aim`] aims, its aim included, whether built whole or in runs of
    /// coarse slabs put together in any order; orthographic views get an aim (with
    /// blocks placed), perspective ones none, both arithmetics alike.
    #[test]
    fn aimed_plans_build_the_aimed_grid() {
        use crate::kernel::Bspln3;
        let lut = test_lut();
        let aimed_views = core::cell::Cell::new(0);
        on_volumes(|vol| {
            for (ortho, spec) in test_specs(true, &lut) {
                let plan = spec.skip_plan(&vol, KernelName::Bspln3).unwrap();
                let mut want = plan.clone().build(&vol);
                spec.aim::<f32, Bspln3, 4>(vol, &mut want);
                assert_eq!(want.aim().is_some(), ortho);
                if let Some(a) = want.aim() {
                    assert!(!a.is_empty(), "no block placed");
                    aimed_views.set(aimed_views.get() + 1);
                }
                let plan = spec.aim_plan::<f32, Bspln3, 4>(vol, plan);
                assert!(plan.clone().build(&vol) == want);
                let n = plan.slabs();
                for cuts in [&[0, n][..], &[0, 1, n], &[0, n / 2, n - 1, n]] {
                    let mut runs: Vec<_> = cuts
                        .windows(2)
                        .map(|c| plan.build_run(&vol, c[0]..c[1]))
                        .collect();
                    runs.reverse();
                    assert!(plan.finish(runs) == Some(want.clone()), "cuts {cuts:?}");
                }
            }
        });
        assert_eq!(aimed_views.get(), 12);
    }

    /// A grid aimed anew in parts ([`RenderSpec::re_aim`]), cut anywhere and put in any
    /// order, is aimed as [`RenderSpec::aim`] aims it, whatever it was aimed at before;
    /// parts that leave a block out leave it unaimed.
    #[test]
    fn grids_aimed_in_parts_are_aimed_whole() {
        use crate::kernel::Bspln3;
        let lut = test_lut();
        let aimed_views = core::cell::Cell::new(0);
        on_volumes(|vol| {
            let specs = test_specs(true, &lut);
            for (i, (_, spec)) in specs.iter().enumerate() {
                let plan = spec.skip_plan(&vol, KernelName::Bspln3).unwrap();
                let mut want = plan.build(&vol);
                spec.aim::<f32, Bspln3, 4>(vol, &mut want);
                // Kept from the view before (aimed at it, or not aimed).
                let (_, before) = &specs[(i + specs.len() - 1) % specs.len()];
                let mut kept = want.clone();
                before.aim::<f32, Bspln3, 4>(vol, &mut kept);
                let re = spec.re_aim::<f32, Bspln3, 4>(vol, &kept);
                let n = re.blocks();
                assert_eq!(n > 0, want.aim().is_some());
                if n == 0 {
                    re.finish(&mut kept, Vec::new());
                    assert!(kept == want);
                    continue;
                }
                aimed_views.set(aimed_views.get() + 1);
                for cuts in [&[0, n][..], &[0, 1, n], &[0, n / 3, n / 2, n - 1, n]] {
                    let mut parts: Vec<_> = cuts.windows(2).map(|c| re.part(c[0]..c[1])).collect();
                    parts.reverse();
                    let mut got = kept.clone();
                    re.finish(&mut got, parts);
                    assert!(got == want, "cuts {cuts:?}");
                }
                // A block left out: no aim.
                let mut got = kept.clone();
                re.finish(
                    &mut got,
                    alloc::vec![re.part(0..n / 2), re.part(n / 2 + 1..n)],
                );
                assert!(got.aim().is_none());
            }
        });
        assert_eq!(aimed_views.get(), 12);
    }

    /// Under `over`, every sample of a stretch that the walk through the fine blocks
    /// gives is inside, with its support start in the walk's block, for supports 2, 3
    /// and 4 (see [`each_ray`] and [`on_volumes`]).
    #[test]
    fn walks_hold_every_sample() {
        let walk = |m: &dyn Cast, hi, vi| m.check_walk(hi, vi);
        on_volumes(|vol| {
            assert!(each_ray::<Tent, 2>(vol, true, walk) > 10_000);
            assert!(each_ray::<Bspln2, 3>(vol, true, walk) > 10_000);
            assert!(each_ray::<Bspln3, 4>(vol, true, walk) > 10_000);
        });
    }
}
