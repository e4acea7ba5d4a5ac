//! `rendr teval`: evaluate a control-point transfer function.

use std::path::Path;

use rnd_core::txf::TxfSpace;

use crate::args::{Args, Arity, CmdSpec, Pos};
use crate::fmt::{g9, list9};

pub static SPEC: CmdSpec = CmdSpec {
    name: "teval",
    about: "evaluate a transfer function at a value",
    info: "Prints the RGB colour (rgb or hsv txf; hsv converted to RGB) or the opacity \
           (alpha txf) at one value: clamped beyond the ends, linear between control points.",
    response_files: false,
    opts: &[],
    pos: &[
        Pos {
            name: "txf",
            arity: Arity::Fixed(1),
            help: "control-point file (#space:=rgb, hsv or alpha)",
        },
        Pos {
            name: "val",
            arity: Arity::Fixed(1),
            help: "value at which to evaluate",
        },
    ],
};

pub fn run(a: &Args) -> anyhow::Result<()> {
    let f = &a.pos(0)[0];
    let vs = &a.pos(1)[0];
    let v: f64 = vs
        .parse()
        .map_err(|_| anyhow::anyhow!("<val>: can't parse \"{vs}\" as a real number"))?;
    let t = rnd_std::files::load_txf(Path::new(f))?;
    let out = t.eval(v);
    let shown = if t.space() == TxfSpace::Alpha {
        list9(&out[..1])
    } else {
        list9(&out)
    };
    outln!("{shown} = {f}({})", g9(v));
    Ok(())
}
