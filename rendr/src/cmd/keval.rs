//! `rendr keval`: evaluate a kernel and its derivatives at a point.

use rnd_core::kernel::KernelName;

use crate::args::{def, flag, opt, parse_named, Args, Arity, CmdSpec, Pos};
use crate::fmt::g9;

pub static SPEC: CmdSpec = CmdSpec {
    name: "keval",
    about: "evaluate a kernel (and derivatives) at a position",
    info: "Prints Name(x) and, with -d, the derivatives dName(x), ddName(x). With -a, \
           then also the per-sample weights one convolution axis uses at fractional \
           position alpha, lowest index first (with -d, derivative weights too).",
    response_files: false,
    opts: &[
        flag(&["s"], "first print the kernel's support"),
        def(
            &["d"],
            1,
            "0",
            "derivs",
            "also print derivatives up to this order (0, 1 or 2)",
        ),
        opt(
            &["a"],
            1,
            "alpha",
            "print the convolution weights at fractional position alpha",
        ),
    ],
    pos: &[
        Pos {
            name: "kernel",
            arity: Arity::Fixed(1),
            help: "kernel name (see \"rendr klist\")",
        },
        Pos {
            name: "pos",
            arity: Arity::Fixed(1),
            help: "position at which to evaluate",
        },
    ],
};

pub fn run(a: &Args) -> anyhow::Result<()> {
    let k: KernelName = parse_named("kernel", &a.pos(0)[0])?;
    let x: f64 = a.pos(1)[0]
        .parse()
        .map_err(|_| anyhow::anyhow!("<pos>: can't parse \"{}\" as a real number", a.pos(1)[0]))?;
    if x.is_nan() {
        anyhow::bail!("<pos>: NaN is not a position");
    }
    let d: u32 = a.get("d")?;
    if d > 2 {
        anyhow::bail!("-d: {d} derivatives requested; only 0, 1 or 2 are known");
    }
    let alpha: Option<f64> = if a.given("a") {
        let al: f64 = a.get("a")?;
        if !al.is_finite() {
            anyhow::bail!("-a: alpha must be a finite fractional position (got {al})");
        }
        Some(al)
    } else {
        None
    };
    if a.flag("s") {
        outln!("support({}) = {}", k.title(), k.support());
    }
    let names = [String::new(), "d".to_string(), "dd".to_string()];
    for (i, pre) in names.iter().enumerate().take(d as usize + 1) {
        outln!("{pre}{}({})= {}", k.title(), g9(x), g9(k.eval(x, i as u32)));
    }
    if let Some(al) = alpha {
        let lo = k.lo();
        for (i, pre) in names.iter().enumerate().take(d as usize + 1) {
            let w: Vec<String> = (0..k.support() as i32)
                .map(|j| g9(k.eval(al - (lo + j) as f64, i as u32)))
                .collect();
            outln!(
                "{} = {pre}{} weights at alpha={}",
                w.join(" "),
                k.title(),
                g9(al)
            );
        }
    }
    Ok(())
}
