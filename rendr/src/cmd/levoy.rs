//! `rendr levoy`: sample Levoy iso-contour opacity over (value, gradient magnitude).

use std::path::Path;

use anyhow::{bail, Context};
use rnd_std::nrrd::{self, Centering, Data, Nrrd, WriteOptions};

use crate::args::{def, req, Args, CmdSpec};

pub static SPEC: CmdSpec = CmdSpec {
    name: "levoy",
    about: "sample Levoy opacity functions on a value x gradient-magnitude grid",
    info: "Reads iso-contours (v r a per line: isovalue, thickness, max opacity) and \
           writes a 2-D float image of their combined opacity: value along axis 0 over \
           [min, max], gradient magnitude along axis 1 over [0, gmax], cell-centred.",
    response_files: false,
    opts: &[
        req(&["i"], 1, "fname", "Levoy file (- = stdin)"),
        req(&["mm"], 2, "min max", "value range"),
        req(&["gm"], 1, "gmax", "maximum gradient magnitude"),
        def(
            &["sz"],
            2,
            "256 256",
            "sv sg",
            "samples along value and gradient magnitude",
        ),
        req(&["o"], 1, "fname", "output image (NRRD)"),
    ],
    pos: &[],
};

pub fn run(a: &Args) -> anyhow::Result<()> {
    let f = a.get_str("i").unwrap_or_default();
    let [lo, hi] = a.get_arr::<f64, 2>("mm")?;
    let gmax: f64 = a.get("gm")?;
    let [sv, sg] = a.get_arr::<usize, 2>("sz")?;
    if !(lo.is_finite() && hi.is_finite() && lo < hi) {
        bail!("-mm: need finite min < max (got {lo} {hi})");
    }
    if !(gmax.is_finite() && gmax > 0.0) {
        bail!("-gm: need a finite gmax > 0 (got {gmax})");
    }
    if sv == 0 || sg == 0 || sv.saturating_mul(sg) > 1 << 26 {
        bail!("-sz: sizes {sv} {sg} must be > 0 with at most 2^26 samples");
    }
    let o = a.get_str("o").unwrap_or_default();
    let output = super::output(&o, a, &[f.as_str()]).context("-o")?;
    let lev = rnd_std::files::load_levoy(Path::new(&f))?;
    let mut out = Vec::with_capacity(sv * sg);
    for j in 0..sg {
        let g = gmax * (j as f64 + 0.5) / sg as f64;
        for i in 0..sv {
            let v = lo + (hi - lo) * (i as f64 + 0.5) / sv as f64;
            out.push(lev.opacity(v as f32, g as f32));
        }
    }
    let mut n = Nrrd::new(vec![sv, sg], Data::F32(out))?;
    let h = &mut n.header;
    h.content = Some(super::content("levoy", a));
    h.axis_mins = Some(vec![lo, 0.0]);
    h.axis_maxs = Some(vec![hi, gmax]);
    h.centerings = Some(vec![Centering::Cell, Centering::Cell]);
    output.commit(|w| nrrd::write_to(&n, WriteOptions::default(), w))?;
    Ok(())
}
