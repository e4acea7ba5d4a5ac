//! Convolution throughput (divan): samples per second for each kernel × voxel type,
//! value only and value + gradient, at points along rays through a 128³ volume.
//! The `rays` group times whole rays of the renderer. Run with
//! `cargo bench -p rnd-tests --bench convo`.

use divan::{black_box, Bencher};
use rnd_core::affine::Affine4;
use rnd_core::convo::Convo;
use rnd_core::kernel::{BoxK, Bspln2, Bspln3, C4Hexic, Ctmr, Kernel, Tent};
use rnd_core::volume::Volume;
use rnd_core::voxel::Voxel;

const N: usize = 128;
const SAMPLES: usize = 4096;

fn main() {
    divan::main();
}

fn volume<V: Voxel>(conv: impl Fn(f32) -> V) -> Vec<V> {
    (0..N * N * N)
        .map(|i| {
            let (x, y, z) = ((i % N) as f32, ((i / N) % N) as f32, (i / (N * N)) as f32);
            conv(((x * 0.1).sin() + (y * 0.13).cos() * (z * 0.07).sin()) * 1000.0)
        })
        .collect()
}

/// Points along a diagonal ray, 0.1 voxel apart (consecutive samples share
/// neighbourhoods, as in rendering).
fn ray_points() -> Vec<[f64; 3]> {
    (0..SAMPLES)
        .map(|k| {
            let t = 8.0 + k as f64 * 0.1 * 0.577;
            [t, 10.0 + t * 0.5, 12.0 + t * 0.25]
        })
        .collect()
}

fn run<V: Voxel, K: Kernel<S>, const S: usize>(b: Bencher, data: &[V], grad: bool) {
    let vol = Volume::new(data, [N, N, N], Affine4::IDENTITY).unwrap();
    let pts = ray_points();
    b.counter(divan::counter::ItemsCount::new(SAMPLES))
        .bench_local(|| {
            let mut c = Convo::<V, K, S>::new(vol);
            let mut acc = 0.0f32;
            for p in &pts {
                let s = c.eval_index(black_box(*p), grad);
                acc += s.value + s.grad_i[0];
            }
            acc
        });
}

macro_rules! kernel_benches {
    ($($name:ident: $k:ty, $s:expr;)*) => {$(
        mod $name {
            use super::*;
            #[divan::bench(args = [false, true])]
            fn f32_voxels(b: Bencher, grad: bool) {
                let d = volume(|v| v);
                run::<f32, $k, $s>(b, &d, grad);
            }
            #[divan::bench(args = [false, true])]
            fn i16_voxels(b: Bencher, grad: bool) {
                let d = volume(|v| v as i16);
                run::<i16, $k, $s>(b, &d, grad);
            }
        }
    )*};
}

kernel_benches! {
    boxk: BoxK, 1;
    tent: Tent, 2;
    bspln2: Bspln2, 3;
    bspln3: Bspln3, 4;
    ctmr: Ctmr, 4;
    c4hexic: C4Hexic, 6;
}

/// Whole rays through the 128³ volume (the accelerated loop `go` uses: inside stretch,
/// batched convolution, probe and blend): value and gradient-magnitude MIPs, an
/// orthographic 32×32 image looking down z with samples 0.5 voxel apart, so every ray
/// takes the same number of inside samples. Items = inside samples.
mod rays {
    use super::*;
    use rnd_core::blend::Blend;
    use rnd_core::camera::CameraSpec;
    use rnd_core::kernel::KernelName;
    use rnd_core::probe::Probe;
    use rnd_core::render::{render, AnyVolume, RenderParams, RenderSpec};

    fn run_rays(b: Bencher, vol: AnyVolume<'_>, kernel: KernelName, probe: Probe) {
        let n = N as f64;
        let cam = CameraSpec {
            from: [n / 2.0, n / 2.0, 2.0 * n],
            at: [n / 2.0, n / 2.0, n / 2.0],
            up: [0.0, 1.0, 0.0],
            near: -n,
            far: n,
            fov: 10.0,
            size: [32, 32],
            orthographic: true,
        };
        let mut p = RenderParams::new(cam);
        p.plane_sep = 0.5;
        p.probe = probe;
        p.blend = Blend::Max;
        let spec = RenderSpec::new(p, None, None, &[]).unwrap();
        // Inside samples per ray: the kernel's inside range along z over the step.
        let s = kernel.support() as f64;
        let per_ray = ((n - s + 1.0) / 0.5) as usize;
        b.counter(divan::counter::ItemsCount::new(32 * 32 * per_ray))
            .bench_local(|| render(black_box(&spec), vol, kernel));
    }

    macro_rules! ray_benches {
        ($($name:ident: $k:expr;)*) => {$(
            mod $name {
                use super::*;
                #[divan::bench(args = [Probe::Value, Probe::GradMag])]
                fn f32_voxels(b: Bencher, probe: Probe) {
                    let d = volume(|v| v);
                    let vol = Volume::new(&d, [N, N, N], Affine4::IDENTITY).unwrap();
                    run_rays(b, AnyVolume::F32(vol), $k, probe);
                }
                #[divan::bench(args = [Probe::Value, Probe::GradMag])]
                fn i16_voxels(b: Bencher, probe: Probe) {
                    let d = volume(|v| v as i16);
                    let vol = Volume::new(&d, [N, N, N], Affine4::IDENTITY).unwrap();
                    run_rays(b, AnyVolume::I16(vol), $k, probe);
                }
            }
        )*};
    }

    ray_benches! {
        tent: KernelName::Tent;
        bspln3: KernelName::Bspln3;
        ctmr: KernelName::Ctmr;
        c4hexic: KernelName::C4hexic;
    }
}
