//! Fuzzes a tiny render: camera, LUT, probe, blend, kernel and parameters come from the
//! input. Validation may refuse them; what it accepts must render without panicking and
//! give finite output unless NaN was asked for (outside value), and the accelerated loop
//! must give exactly the plain loop's image (the f64 engine, `-ref false`). The same for
//! the reference arithmetic (the default): finite output, and its batched loop gives the
//! one-sample loop's image; and `render_rows` and `cast` refuse outputs of the wrong
//! shape (a Render error) and fill those of the right one with the image's bits. Both
//! engines give the same bits at a narrower vector level and on i16 voxels holding the
//! same integers.
#![no_main]

use libfuzzer_sys::fuzz_target;
use rnd_core::affine::Affine4;
use rnd_core::blend::Blend;
use rnd_core::camera::CameraSpec;
use rnd_core::kernel::KernelName;
use rnd_core::light::{Light, LightSpace, Phong};
use rnd_core::probe::Probe;
use rnd_core::march::Loop;
use rnd_core::render::{AnyVolume, RenderParams, RenderSpec, SampleInfo, SimdLevel};
use rnd_core::classify::{LutAxis, Quantity};
use rnd_core::txf::{Levoy, Lut};
use rnd_core::volume::Volume;

struct Bytes<'a>(&'a [u8]);
impl Bytes<'_> {
    fn u8(&mut self) -> u8 {
        let (b, rest) = self.0.split_first().map(|(b, r)| (*b, r)).unwrap_or((0, &[]));
        self.0 = rest;
        b
    }
    fn f64(&mut self) -> f64 {
        let mut a = [0u8; 8];
        for x in &mut a {
            *x = self.u8();
        }
        let v = f64::from_le_bytes(a);
        // Mostly moderate numbers, sometimes anything (NaN, inf, huge).
        if self.u8() % 8 == 0 { v } else { (v.to_bits() % 20001) as f64 / 1000.0 - 10.0 }
    }
}

/// Every pixel through `RenderSpec::cast` with `Loop::OneSample` and a (no-op) trace.
fn traced(spec: &RenderSpec<'_>, vol: AnyVolume<'_>, kernel: KernelName) -> Vec<f32> {
    let [w, h] = spec.size();
    let len = spec.params().probe.length();
    let mut img = vec![0.0f32; (w * h) as usize * len];
    for (px, out) in img.chunks_mut(len).enumerate() {
        let mut ignore = |_: &SampleInfo| {};
        spec.cast(vol, kernel, px as u32 % w, px as u32 / w, out, Loop::OneSample, Some(&mut ignore))
            .expect("a pixel of the image");
    }
    img
}

fuzz_target!(|data: &[u8]| {
    let mut b = Bytes(data);
    let camera = CameraSpec {
        from: [b.f64(), b.f64(), b.f64()],
        at: [b.f64(), b.f64(), b.f64()],
        up: [b.f64(), b.f64(), b.f64()],
        near: b.f64(),
        far: b.f64(),
        fov: b.f64() * 10.0,
        size: [1 + (b.u8() % 6) as u32, 1 + (b.u8() % 6) as u32],
        orthographic: b.u8() % 2 == 0,
    };
    let mut p = RenderParams::new(camera);
    // First the f64 engine (`-ref false`), then the reference arithmetic (the default).
    p.reference = false;
    p.plane_sep = b.f64().abs() / 10.0;
    p.sample_once = b.u8() % 7 == 0;
    p.probe = Probe::ALL[b.u8() as usize % Probe::ALL.len()];
    p.blend = Blend::ALL[b.u8() as usize % Blend::ALL.len()];
    p.outside = b.f64() as f32;
    p.unit_step = b.f64();
    p.alpha_near1 = b.f64() as f32;
    p.phong = Phong { ka: b.f64() as f32, kd: b.f64() as f32, ks: b.f64() as f32, p: b.f64() as f32 };
    p.dcn = [b.f64() as f32; 3];
    p.dcf = [b.f64() as f32; 3];
    p.time = false;
    let lut = Lut::new(b.f64(), b.f64(), (0..4).map(|_| [b.f64() as f32, 0.5, 0.2, b.f64() as f32]).collect()).ok();
    let lev = Levoy::new(vec![[b.f64() as f32, b.f64() as f32, b.f64() as f32]]).ok();
    let lights: Vec<Light> = Light::new([1.0, 0.9, 0.8], [b.f64(), b.f64(), b.f64()], if b.u8() % 2 == 0 { LightSpace::View } else { LightSpace::World }).into_iter().collect();
    let kernel = KernelName::ALL[(b.u8() % 7) as usize];
    // Sometimes a LUT over other quantities, or over two (read last, so that older
    // inputs keep their meaning).
    let lut = match b.u8() % 3 {
        0 => lut,
        dims => {
            let axis = |b: &mut Bytes| {
                let q = Quantity::ALL[b.u8() as usize % Quantity::ALL.len()];
                LutAxis::new(q, b.f64(), b.f64(), 1 + b.u8() as usize % 5)
            };
            let axes: Vec<LutAxis> = (0..dims).map(|_| axis(&mut b)).collect();
            let n = axes.iter().map(|a| a.len).product();
            Lut::with_axes(&axes, (0..n).map(|_| [b.f64() as f32, 0.5, 0.2, b.f64() as f32]).collect()).ok()
        }
    };
    // Don't let the fuzzer ask for millions of samples per ray.
    if p.plane_sep > 0.0 && (p.camera.far - p.camera.near) / p.plane_sep > 2000.0 {
        return;
    }
    let data: Vec<f32> = (0..6 * 7 * 8).map(|i| ((i * 37) % 11) as f32 / 10.0).collect();
    let itow = Affine4::from_columns([0.5, 0.0, 0.1], [0.0, 0.4, 0.0], [0.0, 0.1, 0.3], [-1.0, -1.0, -1.0]);
    let vol = Volume::new(&data, [6, 7, 8], itow).unwrap();
    let Ok(spec) = RenderSpec::new(p.clone(), lut.as_ref(), lev.as_ref(), &lights) else { return };
    let img = render(&spec, AnyVolume::F32(vol), kernel);
    assert_eq!(img.len(), (p.camera.size[0] * p.camera.size[1]) as usize * spec.channels());
    if p.outside.is_finite() {
        assert!(img.iter().all(|v| !v.is_nan()), "NaN output for {p:?}");
    }
    // The accelerated loop and empty-space skipping give the plain loop's bits.
    let mut q = p.clone();
    q.fast_loop = false;
    q.skip_empty = false;
    let plain_spec = RenderSpec::new(q, lut.as_ref(), lev.as_ref(), &lights).expect("same validation");
    let plain = render(&plain_spec, AnyVolume::F32(vol), kernel);
    assert!(
        img.iter().zip(&plain).all(|(a, b)| a.to_bits() == b.to_bits()),
        "fast {img:?} vs plain {plain:?} for {p:?} {kernel}"
    );
    // The same samples with padded rows (NaN padding, so a read of it would show).
    let padded: Vec<f32> = data.chunks(6).flat_map(|r| r.iter().copied().chain([f32::NAN; 3])).collect();
    let pvol = Volume::padded(&padded, [6, 7, 8], 9, itow).unwrap();
    let pimg = render(&spec, AnyVolume::F32(pvol), kernel);
    assert!(
        img.iter().zip(&pimg).all(|(a, b)| a.to_bits() == b.to_bits()),
        "padded {pimg:?} vs {img:?} for {p:?} {kernel}"
    );
    // Reference arithmetic: may refuse what f32 cannot hold; otherwise finite output,
    // and the batched loop equals the one-sample loop.
    let mut r = p.clone();
    r.reference = true;
    let Ok(ref_spec) = RenderSpec::new(r, lut.as_ref(), lev.as_ref(), &lights) else { return };
    let lanes = render(&ref_spec, AnyVolume::F32(vol), kernel);
    if p.outside.is_finite() {
        assert!(lanes.iter().all(|v| !v.is_nan()), "-ref: NaN output for {p:?}");
    }
    let planes = render(&ref_spec, AnyVolume::F32(pvol), kernel);
    assert!(
        lanes.iter().zip(&planes).all(|(a, b)| a.to_bits() == b.to_bits()),
        "-ref padded {planes:?} vs {lanes:?} for {p:?} {kernel}"
    );
    let one = traced(&ref_spec, AnyVolume::F32(vol), kernel);
    assert!(
        lanes.iter().zip(&one).all(|(a, b)| a.to_bits() == b.to_bits()),
        "-ref lanes {lanes:?} vs one-sample {one:?} for {p:?} {kernel}"
    );
    // Rows and a pixel asked for with outputs of random shapes (read last, so that older
    // inputs keep their meaning): refused with a Render error when misshapen, never a
    // panic; otherwise the image's own bits.
    let ([w, h], ch) = (ref_spec.size(), ref_spec.channels());
    let (r0, r1) = (b.u8() as u32 % (h + 2), b.u8() as u32 % (h + 2));
    let want = r1.saturating_sub(r0) as usize * w as usize * ch;
    let len = [want, want.saturating_sub(1), want + 1][b.u8() as usize % 3];
    let mut rows = vec![0.0f32; len];
    let r = ref_spec.render_rows(AnyVolume::F32(vol), kernel, None, r0..r1, &mut rows, None);
    let fits = r0 <= r1 && r1 <= h && len == want;
    assert_eq!(r.is_ok(), fits, "rows {r0}..{r1} into {len} floats: {r:?}");
    if fits {
        let img = &lanes[r0 as usize * w as usize * ch..r1 as usize * w as usize * ch];
        assert!(img.iter().zip(&rows).all(|(a, b)| a.to_bits() == b.to_bits()), "rows {r0}..{r1}");
    }
    let (hi, vi) = (b.u8() as u32 % (w + 2), b.u8() as u32 % (h + 2));
    let mut room = vec![0.0f32; b.u8() as usize % (ch + 2)];
    let r = ref_spec.cast(AnyVolume::F32(vol), kernel, hi, vi, &mut room, Loop::Batched, None);
    let fits = hi < w && vi < h && room.len() >= ch;
    assert_eq!(r.is_ok(), fits, "pixel ({hi}, {vi}) into {} floats: {r:?}", room.len());
    if fits {
        let px = &lanes[(vi * w + hi) as usize * ch..][..ch];
        assert!(px.iter().zip(&room).all(|(a, b)| a.to_bits() == b.to_bits()), "pixel ({hi}, {vi})");
    }
    if let Err(e) = r {
        assert_eq!(e.kind, rnd_core::ErrorKind::Render, "{e}");
    }
    // A narrower vector path (read last, as above) gives the reference arithmetic's and
    // the f64 engine's bits, on f32 voxels and on i16 voxels holding the same integers
    // (each voxel becomes the same f32 before any arithmetic).
    let level = [SimdLevel::Baseline, SimdLevel::Avx2][b.u8() as usize % 2];
    let ints: Vec<i16> = (0..6 * 7 * 8).map(|i| ((i * 37) % 11) as i16 * 97 - 480).collect();
    let floats: Vec<f32> = ints.iter().map(|&v| v as f32).collect();
    let fvol = AnyVolume::F32(Volume::new(&floats, [6, 7, 8], itow).unwrap());
    let ivol = AnyVolume::I16(Volume::new(&ints, [6, 7, 8], itow).unwrap());
    for wide in [&ref_spec, &spec] {
        let mut q = wide.params().clone();
        q.simd = level;
        let reference = q.reference;
        let narrow = RenderSpec::new(q, lut.as_ref(), lev.as_ref(), &lights).expect("same validation");
        let want = render(wide, fvol, kernel);
        for (got, what) in [
            (render(&narrow, fvol, kernel), "f32 voxels, the narrower level"),
            (render(wide, ivol, kernel), "i16 voxels, the widest level"),
            (render(&narrow, ivol, kernel), "i16 voxels, the narrower level"),
        ] {
            assert!(
                want.iter().zip(&got).all(|(a, b)| a.to_bits() == b.to_bits()),
                "{what} ({level:?}): {got:?} vs f32 at the widest {want:?} for {p:?} {kernel} (reference {reference})"
            );
        }
    }
});

/// The whole image on this thread (these scenes are small and valid).
fn render(spec: &RenderSpec<'_>, vol: AnyVolume<'_>, k: KernelName) -> Vec<f32> {
    rnd_core::render::render(spec, vol, k).expect("a small valid scene renders")
}
