//! `rendr klist`: the reconstruction kernels.

use rnd_core::kernel::KernelName;

use crate::args::{Args, CmdSpec};

pub static SPEC: CmdSpec = CmdSpec {
    name: "klist",
    about: "list the available reconstruction kernels",
    info: "Lists every kernel usable with -k, its support (samples per axis) and its \
           derivatives.",
    response_files: false,
    opts: &[],
    pos: &[],
};

pub fn run(_a: &Args) -> anyhow::Result<()> {
    outln!(
        "Kernels are named case-insensitively with -k. The support S is the number of\n\
         samples per axis a convolution reads (S^3 voxels in 3-D); every kernel knows\n\
         its first and second derivative kernels (same support), used for gradients."
    );
    let w = KernelName::ALL
        .iter()
        .map(|k| k.title().len())
        .max()
        .unwrap_or(0);
    for k in KernelName::ALL {
        outln!(
            "=== {:w$} (support {}): {}",
            k.title(),
            k.support(),
            k.description()
        );
        outln!("      d{}, dd{}", k.title(), k.title());
    }
    Ok(())
}
