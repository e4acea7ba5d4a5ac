//! The bundled T1 MRI head, its skin shown by a transfer function built in code, lit
//! and composited `over`, on every core.  `cargo run --release --example head_lit
//! [VOLUME] [OUT.png]`
use rnd_std::parallel::{default_threads, render};
use rnd_std::prelude::*;

fn main() -> Result<()> {
    let mut args = std::env::args().skip(1);
    let head = concat!(env!("CARGO_MANIFEST_DIR"), "/../data/itk-t1-head.nrrd");
    let input = args.next().unwrap_or_else(|| head.into());
    let out = args.next().unwrap_or_else(|| "head-lit.png".into());
    let vol = load_volume(input.as_ref())?;
    // Skin: clear below 35, nearly opaque from 60 on, one warm colour.
    let colour = Txf::rgb(&[[0.0, 0.9, 0.75, 0.65], [255.0, 0.9, 0.75, 0.65]])?;
    let opacity = Txf::alpha(&[[0.0, 0.0], [35.0, 0.0], [60.0, 0.9], [255.0, 0.9]])?;
    let lut = Lut::builder(0.0, 255.0)
        .colour(&colour)
        .opacity(&opacity)
        .build()?;
    let lights = [
        Light::new([1.0; 3], [-1.0, 1.0, 2.0], LightSpace::View)?,
        Light::new([0.3, 0.3, 0.4], [1.0, -0.5, 0.5], LightSpace::View)?,
    ];
    // RAS world: look at the head's right side, from a little above.
    let cam = CameraSpec::framing(&vol.view().world_corners(), [1.0, 0.3, 0.3])
        .expect("a finite volume")
        .size(300, 300);
    let mut p = RenderParams::new(cam);
    (p.probe, p.blend, p.plane_sep, p.unit_step) = (Probe::RgbaLit, Blend::Over, 1.0, 2.0);
    let spec = RenderSpec::new(p, Some(&lut), None, &lights)?;
    let threads = default_threads();
    let data = render(&spec, vol.view(), KernelName::Bspln3, threads)?;
    let img = Image {
        data,
        channels: 4,
        size: [300, 300],
    };
    write_image(img, out.as_ref(), "lit head", Some((0.0, 1.0)))?;
    println!("wrote {out} ({threads} threads)");
    Ok(())
}
