//! `rendr convert`: any volume rendr reads, written as NRRD with its geometry.

use anyhow::Context;
use rnd_std::nrrd::{self, Encoding, WriteOptions};

use crate::args::{def, Args, Arity, CmdSpec, Pos};

pub static SPEC: CmdSpec = CmdSpec {
    name: "convert",
    about: "write a NIfTI, MetaImage, DICOM or NRRD volume as NRRD",
    info: "Reads a volume in any format rendr reads (recognised by content: NRRD, NIfTI-1/2 \
           .nii/.nii.gz/.hdr+.img, MetaImage .mha/.mhd, a DICOM series directory or one of \
           its files) and writes it as one NRRD file with its geometry: \"space\" names the \
           file's world frame (NIfTI: right-anterior-superior; MetaImage and DICOM: \
           left-posterior-superior), \"space directions\" and \"space origin\" its \
           index-to-world transform, so Teem's tools and `rendr go` see the same volume. \
           Samples keep the file's type, except that a NIfTI or DICOM rescale (slope, \
           intercept) is applied: integer samples that it keeps integral within 16 bits \
           become short, others float. The source format and what the reader decided are kept as key/value pairs \
           (\"rendr source format\", \"rendr source notes\").",
    response_files: false,
    opts: &[def(
        &["e"],
        1,
        "raw",
        "enc",
        "data encoding of the output: raw, gzip or bzip2",
    )],
    pos: &[
        Pos {
            name: "input",
            arity: Arity::Fixed(1),
            help: "volume file or DICOM directory (- = stdin)",
        },
        Pos {
            name: "output",
            arity: Arity::Fixed(1),
            help: "output NRRD file (- = stdout)",
        },
    ],
};

pub fn run(a: &Args) -> anyhow::Result<()> {
    let input = a.pos(0)[0].clone();
    let out = a.pos(1)[0].clone();
    let enc = a.get_str("e").unwrap_or_default();
    let encoding = match Encoding::parse(&enc) {
        Some(e @ (Encoding::Raw | Encoding::Gzip | Encoding::Bzip2)) => e,
        _ => anyhow::bail!("-e: \"{enc}\" is not raw, gzip or bzip2"),
    };
    let output = super::output(&out, a, &[&input]).context("output")?;
    let l = rnd_std::formats::read(std::path::Path::new(&input), 1)?;
    let mut n = l.nrrd;
    let h = &mut n.header;
    h.content = Some(super::content("convert", a));
    h.key_values
        .push(("rendr source format".into(), l.format.name().into()));
    if !l.notes.is_empty() {
        h.key_values
            .push(("rendr source notes".into(), l.notes.join("; ")));
    }
    output.commit(|w| {
        nrrd::write_to(
            &n,
            WriteOptions {
                encoding,
                ..Default::default()
            },
            w,
        )
    })?;
    Ok(())
}
