//! Probing an `i16` volume for value and gradient with `rnd-core` alone (no IO crate):
//! f = 3x − 2y + z sampled on a 16³ grid of 0.5 mm voxels, reconstructed between the
//! samples by several kernels.  `cargo run --release -p rnd-core --example probe_i16`
use rnd_core::prelude::*;

fn main() -> Result<()> {
    let geom = Affine4::from_spacing([0.5; 3], [0.0; 3]);
    let f = |p: [f64; 3]| 3.0 * p[0] - 2.0 * p[1] + p[2];
    let vol = OwnedVolume::from_fn([16; 3], geom, |[i, j, k]| {
        // Samples at world (i, j, k) / 2; 2 f is an integer there.
        (2.0 * f([i as f64 / 2.0, j as f64 / 2.0, k as f64 / 2.0])) as i16
    })?;
    let any = AnyVolume::from(vol.view());
    let point = [3.25, 2.125, 4.0];
    println!("exact: value {} gradient [6, -4, 2]", 2.0 * f(point));
    for kernel in [KernelName::Tent, KernelName::Ctmr, KernelName::Bspln3] {
        match any.probe(kernel, point) {
            Some(p) => println!("{kernel}: value {} gradient {:?}", p.value, p.gradient),
            None => println!("{kernel}: outside"),
        }
    }
    // Near the edge the kernel's support leaves the volume: no value there.
    assert!(any.probe(KernelName::Bspln3, [7.4, 1.0, 1.0]).is_none());
    Ok(())
}
