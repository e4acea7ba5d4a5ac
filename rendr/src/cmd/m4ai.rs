//! `rendr 4mi` (alias `m4ai`): invert a 4×4 affine matrix and check the result.

use std::path::Path;

use anyhow::{bail, Context};
use rnd_core::affine::Affine4;

use crate::args::{Args, Arity, CmdSpec, Pos};
use crate::fmt::{g9, matrix};

pub static SPEC: CmdSpec = CmdSpec {
    name: "4mi",
    about: "invert a 4x4 affine matrix (alias m4ai)",
    info: "Reads a 4x4 matrix (text or NRRD; bottom row 0 0 0 1), computes its affine \
           inverse, and prints A, the inverse Ai, the product A*Ai and the Frobenius norm \
           of A*Ai - I.",
    response_files: false,
    opts: &[],
    pos: &[Pos {
        name: "fname",
        arity: Arity::Fixed(1),
        help: "4x4 matrix file (text or NRRD; - = stdin)",
    }],
};

pub fn run(a: &Args) -> anyhow::Result<()> {
    let f = &a.pos(0)[0];
    let n = rnd_std::nrrd::read(Path::new(f))?;
    if n.sizes() != [4, 4] {
        bail!("{f}: need a 4x4 matrix, got sizes {:?}", n.sizes());
    }
    let v = n.data.to_f64();
    let m: [f64; 16] = v
        .try_into()
        .map_err(|_| anyhow::anyhow!("{f}: need 16 numbers"))?;
    let am = Affine4::from_rows(m);
    if !am.is_affine() {
        bail!("{f}: bottom row is not 0 0 0 1, so the matrix is not affine");
    }
    let ai = am
        .affine_inverse()
        .with_context(|| format!("{f}: can't invert"))?;
    let p = am.mul(&ai);
    out!("A =\n{}", matrix(&am, g9));
    out!("Ai =\n{}", matrix(&ai, g9));
    out!("A*Ai =\n{}", matrix(&p, g9));
    outln!(
        "{} = FrobeniusNorm(P-I)   (should be nearly zero)",
        g9(p.frobenius_from_identity())
    );
    Ok(())
}
