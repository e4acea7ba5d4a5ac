//! `rendr ceval`: one convolution at a world point.

use std::path::Path;

use rnd_core::convo::{Convo, ConvoSample, SecondOrder};
use rnd_core::kernel::{Kernel, KernelName};
use rnd_core::render::{dispatch, ConvoTask};
use rnd_core::volume::Volume;
use rnd_core::voxel::Voxel;

use crate::args::{def, flag, parse_named, req, Args, CmdSpec};
use crate::fmt::{g9, list9};

pub static SPEC: CmdSpec = CmdSpec {
    name: "ceval",
    about: "evaluate convolution at a world-space point",
    info: "Reconstructs the volume's value (with -g true also its world-space gradient, \
           with -h true its world-space Hessian and the principal curvatures of the \
           isosurface) at one world point with the given kernel. Points where the kernel \
           support leaves the volume are reported as outside.",
    response_files: false,
    opts: &[
        req(
            &["i", "-input"],
            1,
            "vol",
            "input volume: NRRD, NIfTI, MetaImage or DICOM (a series folder)",
        ),
        req(&["w"], 3, "x y z", "world-space position"),
        flag(
            &["wtoi"],
            "only print the index-space position of the point",
        ),
        req(
            &["k", "-kern"],
            1,
            "kernel",
            "reconstruction kernel (see \"rendr klist\")",
        ),
        def(
            &["g"],
            1,
            "false",
            "bool",
            "also compute the world-space gradient",
        ),
        def(
            &["h"],
            1,
            "false",
            "bool",
            "also compute the world-space Hessian (9 values, row by row) and the principal \
             curvatures k1 >= k2 of the isosurface (normal -grad/|grad|, Teem's \
             convention; 0 where the gradient is 0), in f64",
        ),
    ],
    pos: &[],
};

/// Evaluates one point (used by tests through the binary, and by `run`).
struct Eval {
    pos: [f64; 3],
    grad: bool,
}

/// Value, gradient and Hessian at one point, in f64.
struct Second([f64; 3]);

impl ConvoTask for Second {
    type Output = Option<SecondOrder>;
    fn run<V: Voxel, K: Kernel<S>, const S: usize>(self, vol: Volume<'_, V>) -> Self::Output {
        Convo::<V, K, S>::new(vol).second_order_world(self.0)
    }
}

impl ConvoTask for Eval {
    type Output = ConvoSample;
    fn run<V: Voxel, K: Kernel<S>, const S: usize>(self, vol: Volume<'_, V>) -> ConvoSample {
        Convo::<V, K, S>::new(vol).eval_world(self.pos, self.grad)
    }
}

pub fn run(a: &Args) -> anyhow::Result<()> {
    let file = a.get_str("i").unwrap_or_default();
    let w = a.get_arr::<f64, 3>("w")?;
    let k: KernelName = parse_named("k", &a.get_str("k").unwrap_or_default())?;
    let grad: bool = a.get("g")?;
    let hess: bool = a.get("h")?;
    if !w.iter().all(|x| x.is_finite()) {
        anyhow::bail!("-w: position must be finite ({} {} {})", w[0], w[1], w[2]);
    }
    let vol = rnd_std::volume_io::load_volume(Path::new(&file))?;
    let wtoi = vol.itow().affine_inverse()?;
    let wl = format!("{},{},{}", g9(w[0]), g9(w[1]), g9(w[2]));
    if a.flag("wtoi") {
        outln!("{} = WtoI({}) in {file}", list9(&wtoi.point(w)), list9(&w));
        return Ok(());
    }
    let s = dispatch(vol.view(), k, Eval { pos: w, grad });
    if !s.inside {
        outln!(
            "outside =rndConvoEval(({wl}),{file}*{}): the {} support around index ({}) leaves the volume",
            k.title(),
            k.as_str(),
            list9(&s.pos_i)
        );
        if grad {
            outln!("outside =gradient");
        }
        if hess {
            outln!("outside =hessian");
            outln!("outside =kappa");
        }
        return Ok(());
    }
    outln!(
        "{} =rndConvoEval(({wl}),{file}*{})",
        g9(s.value as f64),
        k.title()
    );
    if grad {
        let g: Vec<f64> = s.grad_w.iter().map(|&x| x as f64).collect();
        outln!("{} =gradient", list9(&g));
    }
    if hess {
        // The same inside rule as the f32 sums above, so this is inside too.
        if let Some(so) = dispatch(vol.view(), k, Second(w)) {
            let h: Vec<f64> = so.hessian.iter().flatten().copied().collect();
            outln!("{} =hessian", list9(&h));
            outln!("{} =kappa", list9(&so.curvatures(0.0)));
        }
    }
    Ok(())
}
