//! `rendr lgen`: build a lookup table from colour and opacity transfer functions.

use std::path::Path;

use anyhow::{bail, Context};
use rnd_core::txf::Lut;
use rnd_std::nrrd::{self, Centering, Data, Nrrd, WriteOptions};

use crate::args::{def, opt, req, Args, CmdSpec};

pub static SPEC: CmdSpec = CmdSpec {
    name: "lgen",
    about: "generate a lookup table (LUT) from transfer functions",
    info: "Samples a colour txf (rgb or hsv) and an opacity txf (alpha) at the cell \
           centres of -l entries over [min, max] and writes a 4 x len RGBA LUT. Either txf \
           may be \"x\" for none (value 1). With -rs, each txf's own control-point domain is \
           stretched onto [min, max] instead. -oi also writes a picture of the LUT: colour \
           over a banded grey background, whose visibility shows transparency.",
    response_files: false,
    opts: &[
        req(
            &["i"],
            2,
            "cTxf aTxf",
            "colour and opacity control-point files (x = none)",
        ),
        def(
            &["rs"],
            2,
            "false false",
            "cRscl aRscl",
            "rescale colour / opacity txf domain to the LUT domain",
        ),
        def(&["l"], 1, "512", "len", "LUT length"),
        req(&["mm"], 2, "min max", "LUT domain"),
        req(&["o"], 1, "lut", "output LUT (NRRD)"),
        def(&["h"], 1, "100", "hght", "height of the -oi picture"),
        opt(
            &["oi"],
            1,
            "img",
            "also write an 8-bit RGB picture (PNG) of the LUT",
        ),
    ],
    pos: &[],
};

/// A picture of `lut`: `len` wide, `h` high, colour composited over a grey background of
/// horizontal sinusoidal bands (visible where opacity < 1).
pub fn lut_picture(lut: &Lut, h: usize) -> Vec<u8> {
    let len = lut.entries().len();
    picture(lut.entries(), len, h, |x, _| x)
}

/// A `w` × `h` picture whose pixel (x, y) (y down) shows entry `entry(x, y)` of `e`
/// composited over the banded grey background.
pub fn picture(
    e: &[[f32; 4]],
    w: usize,
    h: usize,
    entry: impl Fn(usize, usize) -> usize,
) -> Vec<u8> {
    let mut img = Vec::with_capacity(w * h * 3);
    for y in 0..h {
        let bg = 0.5 + 0.35 * (2.0 * std::f64::consts::PI * y as f64 / 20.0).sin();
        for x in 0..w {
            let c = e[entry(x, y)];
            let a = (c[3] as f64).clamp(0.0, 1.0);
            for k in 0..3 {
                let v = (c[k] as f64).clamp(0.0, 1.0) * a + bg * (1.0 - a);
                img.push(rnd_std::image_out::quantize(v, 0.0, 1.0));
            }
        }
    }
    img
}

pub fn run(a: &Args) -> anyhow::Result<()> {
    let files = a.get_n::<String>("i")?;
    let [crs, ars] = a.get_arr::<bool, 2>("rs")?;
    let len: usize = a.get("l")?;
    let [lo, hi] = a.get_arr::<f64, 2>("mm")?;
    let hgt: usize = a.get("h")?;
    if a.given("oi") {
        if hgt == 0 || hgt > 1 << 16 {
            bail!("-h: picture height {hgt} must be in 1..=65536");
        }
        // The picture is len x hgt RGB bytes (plus as much again while encoded).
        let bytes = (len as u64).saturating_mul(hgt as u64).saturating_mul(6);
        rnd_std::check_memory(bytes, &format!("a {len} x {hgt} LUT picture")).context("-oi")?;
    }
    // Outputs prepared first: neither may be an input, nor the other output.
    let inputs = [files[0].as_str(), files[1].as_str()];
    let (out, pic) = super::lut_outputs(a, &inputs)?;
    let load = |f: &str| -> anyhow::Result<_> {
        Ok(if f == "x" {
            None
        } else {
            Some(rnd_std::files::load_txf(Path::new(f))?)
        })
    };
    let ctxf = load(&files[0])?;
    let atxf = load(&files[1])?;
    if len == 0 {
        bail!("-l: LUT length must be > 0");
    }
    if len > 1 << 24 {
        bail!("-l: LUT length {len} is unreasonably large (max 16777216)");
    }
    if crs && ctxf.is_none() {
        bail!("-rs: can't rescale colour without a colour txf");
    }
    if ars && atxf.is_none() {
        bail!("-rs: can't rescale opacity without an opacity txf");
    }
    let mut b = Lut::builder(lo, hi).entries(len);
    if let Some(c) = &ctxf {
        b = if crs {
            b.colour_stretched(c)
        } else {
            b.colour(c)
        };
    }
    if let Some(t) = &atxf {
        b = if ars {
            b.opacity_stretched(t)
        } else {
            b.opacity(t)
        };
    }
    let lut = b.build()?;
    if ctxf.is_none() && atxf.is_none() {
        eprintln!(
            "rendr lgen: warning: no transfer functions (both \"x\"): r,g,b,a = 1 everywhere"
        );
    }
    let data: Vec<f32> = lut.entries().iter().flatten().copied().collect();
    let mut n = Nrrd::new(vec![4, len], Data::F32(data))?;
    let h = &mut n.header;
    h.content = Some(super::content("lgen", a));
    h.axis_mins = Some(vec![f64::NAN, lo]);
    h.axis_maxs = Some(vec![f64::NAN, hi]);
    h.centerings = Some(vec![Centering::Unknown, Centering::Cell]);
    h.kinds = Some(vec!["RGBA-color".into(), "???".into()]);
    if let Some(pic) = pic {
        let img = lut_picture(&lut, hgt);
        rnd_std::image_out::write_png_rgb_to(pic, &img, len, hgt)?;
    }
    out.commit(|w| nrrd::write_to(&n, WriteOptions::default(), w))?;
    Ok(())
}
