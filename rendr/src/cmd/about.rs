//! `rendr about`: what rendr is and how it was built.

use crate::args::{Args, CmdSpec};

pub static SPEC: CmdSpec = CmdSpec {
    name: "about",
    about: "information about this program and how it was built",
    info: "Prints what rendr is, its version, and facts about this build.",
    response_files: false,
    opts: &[],
    pos: &[],
};

pub fn run(_a: &Args) -> anyhow::Result<()> {
    let verbose = std::env::var("RND_VERBOSE")
        .ok()
        .and_then(|v| v.parse::<i32>().ok())
        .unwrap_or(0);
    outln!(
        "rendr {}: a direct volume renderer.\n\
         \n\
         rendr casts one ray per pixel through a 3-D scalar volume (16-bit or float\n\
         voxels, NRRD files), reconstructs values and gradients by separable 3-D\n\
         convolution (box, tent, bspln2, bspln3, ctmr, c4hexic), and reduces what\n\
         each ray probes (positions, value, gradient, LUT colour, Blinn-Phong lit\n\
         colour) with a blend (max, sum, mean, over). It re-implements the \"rendr\"\n\
         of the UChicago SciVis 2017 course (project 3 \"p3rendr\", and project 4,\n\
         multi-threaded and fast) in Rust, and works in pipelines with Teem's unu.\n\
         \n\
         Commands: run \"rendr\" alone for the list; \"rendr <cmd> --help\" for options.\n\
         \n\
         Build: {} build, {}-bit {}, debug assertions {}. go computes like the\n\
         reference, all in f32 (\"real == float\"), in its order of operations;\n\
         with -ref false, geometry in f64 and convolution and blending in f32.\n\
         Threads available: {}. Verbosity (RND_VERBOSE): {verbose}.\n\
         Vector paths in use: {} (same images with any; RND_AVX2=0 or RND_AVX512=0\n\
         turn the wider ones off). Raw NRRD volumes are mapped, not copied, for\n\
         one frame and read into memory for many (turn, view; RENDR_MMAP=0 reads\n\
         and RENDR_MMAP=1 maps always); large ones whose rows share cache\n\
         sets render from a copy with padded rows on AMD processors, where it was\n\
         measured to pay: for many frames on any AMD (here: {}), for one on Zen 5\n\
         and later (here: {}) (RENDR_PAD=0: never; RENDR_PAD=1: on any).",
        env!("CARGO_PKG_VERSION"),
        if cfg!(debug_assertions) {
            "debug"
        } else {
            "release"
        },
        usize::BITS,
        std::env::consts::ARCH,
        if cfg!(debug_assertions) { "on" } else { "off" },
        rnd_std::parallel::default_threads(),
        rnd_core::simd::Simd::at_most(rnd_std::simd_level_from_env()).describe(),
        if rnd_std::volume_io::padding_helps_here() {
            "yes"
        } else {
            "no"
        },
        if rnd_std::volume_io::padding_pays_in_one_frame_here() {
            "yes"
        } else {
            "no"
        },
    );
    Ok(())
}
