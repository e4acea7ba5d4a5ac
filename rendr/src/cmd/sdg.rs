//! `rendr sdg`: synthetic data generation.

use anyhow::{bail, Context};
use rnd_core::sdg::{self, Grid};
use rnd_std::nrrd::{self, Centering, Data, Encoding, Nrrd, WriteOptions};

use crate::args::{def, req, Args, CmdSpec};

pub static SPEC: CmdSpec = CmdSpec {
    name: "sdg",
    about: "synthetic data generation",
    info: "Samples a function of world (x,y,z) or index (i,j,k) position on a cell-centred \
           grid of -sz samples spanning a box of edge lengths -l, sheared (-sh), rotated \
           (-r, quaternion (1,x,y,z) normalized) and centred at -c. Functions (-w):\n  \
           0: -z (zramp)   1: x^2+y^2-z (paraboloid)   2: cube exp(-(x^8+y^8+z^8)/6)\n  \
           3: x   4: y   5,6,7: i, j, k (index)   8: impulse at index (s0/2,s1/2,s2/2)\n  \
           9: -(x^2+y^2+z^2)   10: Cayley cubic   11: constant 1   12: Marschner-Lobb\n  \
           13: sphere distance 1-|p|   14: slab, 1 where |z| < 0.5\n  \
           15: marker blobs (1 at origin, 0.66 at +x, 0.33 at +z)   16: 10 (1-|p|)\n\
           Short output (-t short) stores round(f * sval / fval) (-vs fval sval).",
    response_files: false,
    opts: &[
        def(
            &["w"],
            1,
            "0",
            "which",
            "which function to sample (see above)",
        ),
        def(
            &["sz"],
            3,
            "64 64 64",
            "s0 s1 s2",
            "number of samples on each axis",
        ),
        def(
            &["l"],
            3,
            "2 2 2",
            "l0 l1 l2",
            "edge lengths of the sampled box (world units)",
        ),
        def(&["sh"], 3, "0 0 0", "xy xz yz", "shear coefficients"),
        def(
            &["r"],
            3,
            "0 0 0",
            "x y z",
            "rotation: quaternion (1,x,y,z), normalized",
        ),
        def(
            &["c"],
            3,
            "0 0 0",
            "x y z",
            "world-space centre of the volume",
        ),
        def(
            &["t"],
            1,
            "real",
            "type",
            "output type: real (float) or short",
        ),
        def(
            &["vs"],
            2,
            "1 10000",
            "fval sval",
            "short output stores round(f * sval / fval)",
        ),
        req(&["o"], 1, "fout", "output volume (- = stdout)"),
    ],
    pos: &[],
};

pub fn run(a: &Args) -> anyhow::Result<()> {
    let which: u32 = a.get("w")?;
    let sizes = a.get_arr::<usize, 3>("sz")?;
    let grid = Grid {
        sizes,
        lengths: a.get_arr("l")?,
        shear: a.get_arr("sh")?,
        rot: a.get_arr("r")?,
        centre: a.get_arr("c")?,
    };
    let ty = a.get_str("t").unwrap_or_default().to_ascii_lowercase();
    let [fval, sval] = a.get_arr::<f64, 2>("vs")?;
    let short = match ty.as_str() {
        "real" | "float" => false,
        "short" => true,
        _ => bail!("-t: \"{ty}\" is not real or short"),
    };
    if short && !(fval.is_finite() && sval.is_finite() && fval != 0.0) {
        bail!("-vs: need finite values with fval != 0 (got {fval} {sval})");
    }
    let n = sizes.iter().try_fold(1usize, |x, &s| x.checked_mul(s));
    let need = n.and_then(|n| n.checked_mul(if short { 2 } else { 4 } + 8));
    match need {
        None => bail!(
            "-sz: {} x {} x {} samples is too many",
            sizes[0],
            sizes[1],
            sizes[2]
        ),
        Some(b) => rnd_std::check_memory(
            b as u64,
            &format!("-sz: {} x {} x {} samples", sizes[0], sizes[1], sizes[2]),
        )?,
    }
    let o = a.get_str("o").unwrap_or_default();
    let output = super::output(&o, a, &[]).context("-o")?;
    let (vals, itow) = sdg::generate(which, &grid)?;
    let data = if short {
        let mut clipped = 0usize;
        let v: Vec<i16> = vals
            .iter()
            .map(|&f| {
                let s = (f * sval / fval).round();
                if s < i16::MIN as f64 || s > i16::MAX as f64 {
                    clipped += 1;
                }
                s.clamp(i16::MIN as f64, i16::MAX as f64) as i16
            })
            .collect();
        if clipped > 0 {
            eprintln!("rendr sdg: warning: {clipped} values clipped to the 16-bit range (see -vs)");
        }
        Data::I16(v)
    } else {
        Data::F32(vals.iter().map(|&x| x as f32).collect())
    };
    let mut out = Nrrd::new(sizes.to_vec(), data)?;
    let h = &mut out.header;
    h.content = Some(super::content("sdg", a));
    h.space = Some("left-posterior-superior".into());
    h.space_directions = Some((0..3).map(|c| Some(itow.column3(c).to_vec())).collect());
    h.space_origin = Some(itow.column3(3).to_vec());
    h.centerings = Some(vec![Centering::Cell; 3]);
    h.kinds = Some(vec!["domain".into(); 3]);
    let opt = WriteOptions {
        encoding: Encoding::Gzip,
        ..Default::default()
    };
    output.commit(|w| nrrd::write_to(&out, opt, w))?;
    Ok(())
}
