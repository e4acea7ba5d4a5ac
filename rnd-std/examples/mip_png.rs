//! A volume made in memory (two Gaussian blobs on a 64³ grid), rendered as a maximum
//! intensity projection to a PNG.  `cargo run --release --example mip_png [OUT.png]`
use rnd_std::prelude::*;

fn main() -> Result<()> {
    let out = std::env::args().nth(1).unwrap_or_else(|| "mip.png".into());
    // 1 mm voxels, the grid centred on the world origin.
    let geom = Affine4::from_spacing([1.0; 3], [-31.5; 3]);
    let blob = |p: [f32; 3], c: [f32; 3], s: f32| {
        let d2: f32 = (0..3).map(|a| (p[a] - c[a]).powi(2)).sum();
        (-d2 / (2.0 * s * s)).exp()
    };
    let vol = OwnedVolume::from_fn([64; 3], geom, |[i, j, k]| {
        let p = [i as f32, j as f32, k as f32];
        blob(p, [24.0, 30.0, 32.0], 8.0) + 0.6 * blob(p, [42.0, 36.0, 28.0], 5.0)
    })?;
    // Frame the whole volume, seen from the front, slightly above.
    let cam = CameraSpec::framing(&vol.view().world_corners(), [0.3, -1.0, 0.4])
        .expect("a finite volume")
        .size(256, 256);
    let mut params = RenderParams::new(cam);
    (params.probe, params.blend, params.plane_sep) = (Probe::Value, Blend::Max, 0.5);
    let spec = RenderSpec::new(params, None, None, &[])?;
    let data = render(&spec, vol.view().into(), KernelName::Bspln3)?;
    let img = Image {
        data,
        channels: 1,
        size: [256, 256],
    };
    write_image(img, out.as_ref(), "MIP of two blobs", Some((0.0, 1.0)))?;
    println!("wrote {out}");
    Ok(())
}
