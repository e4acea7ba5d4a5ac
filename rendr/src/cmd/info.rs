//! `rendr info`: geometry and value range of volumes.

use std::path::Path;

use rnd_core::math::v3;

use crate::args::{Args, Arity, CmdSpec, Pos};
use crate::fmt::{g9, list9, matrix};

pub static SPEC: CmdSpec = CmdSpec {
    name: "info",
    about: "print information about volume datasets",
    info: "For each volume: sizes, voxel type, value range, index-to-world and \
           world-to-index matrices, sample spacings, angles between axes, the corners of the \
           cell-centred extent and the centre; plus any conversions that were needed to \
           render it (other types, spaces or centrings).",
    response_files: false,
    opts: &[],
    pos: &[Pos {
        name: "input",
        arity: Arity::Var(1),
        help: "volume file(s) (- = stdin)",
    }],
};

pub fn run(a: &Args) -> anyhow::Result<()> {
    for f in a.pos(0) {
        let v = rnd_std::volume_io::load_volume(Path::new(f))?;
        let [s0, s1, s2] = v.sizes();
        let (lo, hi) = v.min_max();
        outln!("==============================");
        outln!("{f}");
        if let Some(frame) = v.format.frame() {
            outln!(
                "read as {}; world coordinates in its {frame} frame ({})",
                v.format.name(),
                v.space.as_deref().unwrap_or("none")
            );
        }
        outln!(
            "{s0} by {s1} by {s2} volume with type {} voxels",
            v.type_name()
        );
        if v.file_type != "float" && v.file_type != "short" {
            outln!("(file holds {} samples)", v.file_type);
        }
        outln!("[{}, {}] is range of values", g9(lo), g9(hi));
        out!(
            "Image-to-World orientation matrix ItoW is:\n{}",
            matrix(&v.itow(), g9)
        );
        let wtoi = v.itow().affine_inverse()?;
        out!(
            "World-to-Image inverse of ItoW (via rnd_m4_affine_inv):\n{}",
            matrix(&wtoi, g9)
        );
        let cols: Vec<[f64; 3]> = (0..3).map(|c| v.itow().column3(c)).collect();
        let sp: Vec<f64> = cols.iter().map(|c| v3::len(*c)).collect();
        outln!("The spacings between samples are:");
        outln!(
            " {} (average {})",
            list9(&sp),
            g9(sp.iter().sum::<f64>() / 3.0)
        );
        let ang = |a: usize, b: usize| {
            let c = v3::dot(cols[a], cols[b]) / (sp[a] * sp[b]);
            rnd_core::math::acos(c.clamp(-1.0, 1.0)).to_degrees()
        };
        outln!("Angles (in degrees) between data axes are:");
        outln!(
            "{} (0/1), {} (0/2), {} (1/2)",
            g9(ang(0, 1)),
            g9(ang(0, 2)),
            g9(ang(1, 2))
        );
        outln!("The corners of the extent of the cell-centered samples are:");
        for k in 0..2 {
            for j in 0..2 {
                for i in 0..2 {
                    let ix = [
                        if i == 0 { -0.5 } else { s0 as f64 - 0.5 },
                        if j == 0 { -0.5 } else { s1 as f64 - 0.5 },
                        if k == 0 { -0.5 } else { s2 as f64 - 0.5 },
                    ];
                    outln!("   {}\t= ItoW({})", list9(&v.itow().point(ix)), list9(&ix));
                }
            }
        }
        let c = [
            (s0 as f64 - 1.0) / 2.0,
            (s1 as f64 - 1.0) / 2.0,
            (s2 as f64 - 1.0) / 2.0,
        ];
        outln!("The center of the volume is at:");
        outln!("{}\t= ItoW({})", list9(&v.itow().point(c)), list9(&c));
        if !v.notes.is_empty() {
            outln!("Conversions applied to make it renderable:");
            for n in &v.notes {
                outln!(" - {n}");
            }
        }
    }
    Ok(())
}
