//! `rendr lgen2`: build a 2-D lookup table from primitives over two quantities.

use std::path::Path;

use anyhow::{bail, Context};
use rnd_core::classify::{LutAxis, Quantity};
use rnd_core::txf::Lut;
use rnd_std::nrrd::{self, WriteOptions};

use crate::args::{def, opt, req, Args, CmdSpec};

pub static SPEC: CmdSpec = CmdSpec {
    name: "lgen2",
    about: "generate a 2-D lookup table from primitives over two quantities",
    info: "Builds an RGBA LUT over two quantities (-q: v, gm, k1, k2, meancurv, gausscurv; \
           default value x gradient magnitude) from the primitives of a text file, one per \
           line: \"box x0 x1 y0 y1\", \"gauss cx cy sx sy\", \"triangle v0 w g1 g0\" (Kniss: \
           |v - v0| < w gm/g1, gm >= g0), \"arch va vb top width\" (the boundary between \
           values va and vb: gm along 4 top t(1-t), t = (v-va)/(vb-va), within width), \
           \"levoy v0 r\" (Levoy's iso-contour, |v - v0| < r gm), each followed by \"r g b a\"; \
           x and y are the first and second quantity; # starts a comment. At each entry's \
           centre the primitives are composited in file order, each over the ones before \
           (opacities combine as 1 - prod(1 - a)). Writes a 4 x N x M float NRRD whose axes \
           carry their domains and Teem's labels (gage(scalar:v), ...), so teem-miter -txf \
           reads it too; go -lut reads it for probes rgba and rgbalit. -oi also writes a \
           picture: the first quantity to the right, the second upwards, over grey bands.",
    response_files: false,
    opts: &[
        req(&["p"], 1, "prims", "primitives file"),
        def(&["q"], 2, "v gm", "q1 q2", "the quantities of the two axes"),
        req(
            &["mm"],
            4,
            "min1 max1 min2 max2",
            "the domains of the two axes",
        ),
        def(&["l"], 2, "256 256", "len1 len2", "entries along each axis"),
        req(&["o"], 1, "lut", "output LUT (NRRD)"),
        opt(
            &["oi"],
            1,
            "img",
            "also write an 8-bit RGB picture (PNG) of the LUT",
        ),
    ],
    pos: &[],
};

/// Most entries along one axis, and in all.
const MAX_AXIS: usize = 1 << 16;
const MAX_ENTRIES: usize = 1 << 24;

pub fn run(a: &Args) -> anyhow::Result<()> {
    let prims = a.get_str("p").unwrap_or_default();
    let qs = a.get_n::<String>("q")?;
    let quant = |s: &str| -> anyhow::Result<Quantity> { s.parse::<Quantity>().context("-q") };
    let (q0, q1) = (quant(&qs[0])?, quant(&qs[1])?);
    let [lo0, hi0, lo1, hi1] = a.get_arr::<f64, 4>("mm")?;
    let [n0, n1] = a.get_arr::<usize, 2>("l")?;
    for n in [n0, n1] {
        if n == 0 || n > MAX_AXIS {
            bail!("-l: {n} entries along an axis; it must be in 1..={MAX_AXIS}");
        }
    }
    if n0 * n1 > MAX_ENTRIES {
        bail!("-l: {n0} x {n1} entries is more than {MAX_ENTRIES}");
    }
    if q0 == q1 {
        bail!("-q: both axes are {q0}");
    }
    // Outputs prepared first: neither may be the input, nor the other output.
    let (out, pic) = super::lut_outputs(a, &[prims.as_str()])?;
    let list = rnd_std::files::load_primitives(Path::new(&prims))?;
    let axes = [
        LutAxis::new(q0, lo0, hi0, n0),
        LutAxis::new(q1, lo1, hi1, n1),
    ];
    let lut = Lut::from_primitives(axes, &list).with_context(|| format!("-p {prims}"))?;
    if list.is_empty() {
        eprintln!("rendr lgen2: warning: {prims} has no primitives: the LUT is transparent");
    }
    let n = rnd_std::files::lut_to_nrrd(&lut, Some(super::content("lgen2", a)))?;
    if let Some(pic) = pic {
        // The second quantity grows upwards.
        let img = super::lgen::picture(lut.entries(), n0, n1, |x, y| x + n0 * (n1 - 1 - y));
        rnd_std::image_out::write_png_rgb_to(pic, &img, n0, n1)?;
    }
    out.commit(|w| nrrd::write_to(&n, WriteOptions::default(), w))?;
    Ok(())
}
