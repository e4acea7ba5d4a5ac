//! `rendr go`: render a volume.

use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};

use anyhow::{bail, Context};
use rnd_core::blend::Blend;
use rnd_core::kernel::KernelName;
use rnd_core::light::Phong;
use rnd_core::march::Loop;
use rnd_core::probe::Probe;
use rnd_core::render::{AnyVolume, RenderParams, RenderSpec, SampleInfo};
use rnd_std::image_out::{write_image_to, Image};

use crate::args::{def, flag, opt, parse_named, Args, CmdSpec};
use crate::fmt::{g6, list6};

/// The option table of `go` and the commands that render like it (`turn`): `-i`,
/// `-k`, the camera options and the render options [`params`] reads, then `$extra`.
macro_rules! go_opts {
    ($($extra:expr),* $(,)?) => {
        with_camera_opts!(
            [
                    $crate::args::req(&["i", "-input"], 1, "vol", "input volume: NRRD, NIfTI, MetaImage or DICOM (a series folder)"),
                    $crate::args::req(
                        &["k", "-kern"],
                        1,
                        "kernel",
                        "reconstruction kernel (see \"rendr klist\")",
                    ),
            ],
            [
                    $crate::args::def(
                        &["s", "-planesep"],
                        1,
                        "0.1",
                        "sep",
                        "distance between sampling planes (0: one sample on the near plane)",
                    ),
                    $crate::args::flag(
                        &["s1s", "-sampleonce"],
                        "take one sample on the near plane only",
                    ),
                    $crate::args::def(
                        &["p", "-probe"],
                        1,
                        "val",
                        "probe",
                        "what to measure at each sample",
                    ),
                    $crate::args::def(
                        &["b", "-blend"],
                        1,
                        "max",
                        "blend",
                        "how to combine the samples of a ray",
                    ),
                    $crate::args::def(
                        &["gmc"],
                        1,
                        "0",
                        "min gradmag",
                        "curvature probes (k1 k2 meancurv gausscurv): 0 where the gradient magnitude is at or below this",
                    ),
                    $crate::args::def(
                        &["ov", "-outsideval"],
                        1,
                        "0",
                        "val",
                        "value for rays with nothing to blend (may be nan)",
                    ),
                    $crate::args::opt(
                        &["nt"],
                        1,
                        "threads",
                        "number of threads (0 or 1: no extra threads; default: all cores)",
                    ),
                    $crate::args::def(
                        &["us"],
                        1,
                        "1",
                        "unitstep",
                        "unit step length for opacity correction (world units)",
                    ),
                    $crate::args::def(
                        &["a1"],
                        1,
                        "1",
                        "alphanear1",
                        "early ray termination opacity, in (0,1]; 1 = off",
                    ),
                    $crate::args::opt(
                        &["lut"],
                        1,
                        "lut",
                        "lookup table from \"rendr lgen\" or \"rendr lgen2\" (needed for rgba, rgbalit)",
                    ),
                    $crate::args::opt(
                        &["lev"],
                        1,
                        "levoy",
                        "Levoy iso-contour opacities (v r a per line)",
                    ),
                    $crate::args::opt(&["lit"], 1, "lights", "light file (needed for rgbalit)"),
                    $crate::args::def(
                        &["ph"],
                        4,
                        "0.2 0.8 0.1 150",
                        "ka kd ks p",
                        "Blinn-Phong ambient, diffuse, specular, exponent",
                    ),
                    $crate::args::def(
                        &["dcn"],
                        3,
                        "1 1 1",
                        "r g b",
                        "depth-cue colour at the near plane",
                    ),
                    $crate::args::def(
                        &["dcf"],
                        3,
                        "1 1 1",
                        "r g b",
                        "depth-cue colour at the far plane",
                    ),
                    $crate::args::def(
                        &["ess"],
                        1,
                        "true",
                        "bool",
                        "skip samples that cannot change the pixel: zero opacity under over, below the running maximum under max of v or gm (exact; false = convolve every sample)",
                    ),
                    $crate::args::def(
                        &["fast"],
                        1,
                        "true",
                        "bool",
                        "accelerated ray loop: sample only each ray's inside stretch, batched \
                         (exact; false = the plain one-sample loop)",
                    ),
                    $crate::args::def(
                        &["ref"],
                        1,
                        "true",
                        "bool",
                        "reference arithmetic: the course reference program's f32 operation \
                         order (camera, ray steps, kernel formulas, summation), which \
                         reproduces its images bit for bit where possible; false = the f64-geometry \
                         engine with separable sums, 1.65-2.2x quicker, within 1e-4 relative \
                         on nearly every pixel",
                    ),
                    $crate::args::opt(&["q"], 2, "min max", "quantization range for PNG output"),
                $($extra),*
            ]
        )
    };
}
pub(crate) use go_opts;

pub static SPEC: CmdSpec = CmdSpec {
    name: "go",
    about: "render a volume by ray casting",
    info: "Casts one ray per pixel from the near clipping plane through sampling planes -s \
           apart until past the far plane; at each sample the volume is reconstructed with \
           the kernel -k and the probe -p is measured; the blend -b reduces the samples of \
           a ray to the pixel. Output: NRRD of floats, channel axis first (sizes C W H), or \
           an 8-bit PNG when -o ends in .png (one channel quantized over its range or -q; \
           RGBA composited over black).\n\
           Probes: pv pw pi (positions: view, world, index), in (inside), v (value), gv \
           (gradient vector), gm (gradient magnitude), hess (world Hessian, 9 channels \
           row-major), k1 k2 (principal curvatures k1 >= k2 of the isosurface, normal = \
           -gradient/|gradient|, as Teem's gage), meancurv ((k1+k2)/2), gausscurv \
           (k1*k2), rgba (LUT colour and opacity), rgbalit (rgba lit by Blinn-Phong, \
           depth-cued). The LUT (-lut) classifies by the value (\"rendr lgen\"), or by the \
           quantity its axis label names, or by two of them (4 x N x M, \"rendr lgen2\"): \
           v, gm, k1, k2, meancurv, gausscurv (labels as Teem's miter writes them, \
           gage(scalar:gm), are read too). The second-order probes (hess and the curvatures) are summed in \
           f64 from the kernel's second derivative at the arithmetic's sample positions.\n\
           Blends, per channel over the ray's counted samples x1..xN (inside the volume \
           for the convolved probes; a ray with none gets -ov): max, min (NaN samples \
           ignored); sum (f32, in ray order); mean (sum/N); l2 (sqrt of the sum of x^2); \
           variance (sum of x^2 / N - mean^2, the population variance, in f64, at least \
           0); sd (sqrt of variance); median (middle of the sorted samples, the mean of \
           the two middle ones for even N; NaN sorts above +inf); over (front-to-back \
           compositing, needs rgba or rgbalit). min l2 variance sd median are Teem's \
           measures (teem-mrender -m min L2 variance stdv median).\n\
           Under \"mpirun -np N\" (a build with the cargo feature mpi) the volume is \
           rendered in N bricks, each process reading only its own (from a NRRD) and \
           casting every ray's stretch inside it; the partials are composited in ray \
           order and process 0 writes the image: max, min and median give the image of \
           one process bit for bit, sum, mean and over the same up to float rounding \
           (docs/SCALING.md); -db is refused there (run it without mpirun). With \
           RENDR_VERBOSE_BRICKS=1 (mpirun -x) each process prints the samples it holds \
           and whether it read them alone.\n\
           A NRRD whose samples are raw float or short in this machine's byte order is \
           used in place through a memory map of the file (no copy): do not change the \
           file while it renders, or set RENDR_MMAP=0 to read it into memory instead \
           (turn and view, which render many frames, read it by default where it takes at \
           most half the memory the process may use; RENDR_MMAP=1 maps it there too). \
           A volume of 16 MiB or more whose rows are a multiple of 512 bytes long, \
           rendered with a kernel of support 3 or more and no skip grid, is rendered \
           from a copy with padded rows on AMD processors (the same image; such rows \
           share the cache's sets; on the Intel processors measured the copy costs more \
           than it saves): for one frame (go) on AMD Zen 5 and later, where the copy \
           pays for itself within the frame, for many (turn, view) on any AMD; \
           RENDR_PAD=0 renders it as it is, RENDR_PAD=1 pads on any.",
    response_files: true,
    opts: go_opts!(
        flag(&["t"], "append a per-pixel time channel (milliseconds)"),
        flag(
            &["petc"],
            "press Enter to continue (wait before rendering; for profiling)",
        ),
        def(
            &["db"],
            2,
            "-1 -1",
            "h v",
            "trace only the ray through pixel (h, v), no image",
        ),
        def(
            &["sp"],
            1,
            "true",
            "bool",
            "show progress (only when stderr is a terminal)",
        ),
        opt(
            &["o"],
            1,
            "fout",
            "output image (.nrrd, or .png; - = NRRD on stdout)",
        ),
    ),
    pos: &[],
};

/// `-db`: prints the ray through pixel `px` and every sample of it (the one-sample loop).
fn trace_pixel(
    spec: &RenderSpec<'_>,
    vol: AnyVolume<'_>,
    kernel: KernelName,
    px: [u32; 2],
) -> anyhow::Result<()> {
    let [hi, vi] = px;
    let g = spec.ray_geom(hi, vi);
    outln!("pixel ({hi}, {vi}):");
    outln!(
        "  view-space ray initial pos {} step {}",
        list6(&g.start_v),
        list6(&g.step_v)
    );
    outln!(
        "  world-space ray initial pos {} step {}",
        list6(&g.start_w),
        list6(&g.step_w)
    );
    outln!("  length of ray step {}", g6(g.step_len));
    let plen = spec.params().probe.length();
    let mut out = vec![0.0f32; plen];
    let mut cb = |s: &SampleInfo| {
        let f = |v: &[f32]| {
            v.iter()
                .map(|&x| g6(x as f64))
                .collect::<Vec<_>>()
                .join(" ")
        };
        outln!(
            "  sample {}: view ({}) world ({}) index ({}) inside {}",
            s.k,
            list6(&s.pos_v),
            list6(&s.pos_w),
            list6(&s.convo.pos_i),
            u8::from(s.convo.inside)
        );
        if s.convo.inside {
            outln!(
                "    value {} gradient ({})",
                g6(s.convo.value as f64),
                f(&s.convo.grad_w)
            );
        }
        outln!(
            "    probe ({}){} -> blend ({}) count {}",
            f(&s.probe[..plen]),
            if s.counted { "" } else { " not counted" },
            f(&s.accum.acc[..plen]),
            s.accum.count
        );
    };
    spec.cast(
        vol,
        kernel,
        hi,
        vi,
        &mut out,
        Loop::OneSample,
        Some(&mut cb),
    )?;
    let r: Vec<f64> = out.iter().map(|&x| x as f64).collect();
    outln!("result: {}", list6(&r));
    Ok(())
}

pub fn run(a: &Args) -> anyhow::Result<()> {
    #[cfg(feature = "mpi")]
    if let Some(job) = crate::job::ranks() {
        return run_bricked(a, &job);
    }
    run_cached(a, &mut VolumeCache::default(), &[])
}

/// Every rank's `r` when all succeeded; when any failed, this rank's error (with its
/// rank) or, on the ranks that did not fail, `None` (they stop quietly).
#[cfg(feature = "mpi")]
fn agree<T>(job: &crate::job::Ranks, r: anyhow::Result<T>) -> anyhow::Result<Option<T>> {
    if !job.any(r.is_err()) {
        return r.map(Some);
    }
    match r {
        Err(e) => Err(e.context(format!("rank {} of {}", job.rank, job.size))),
        Ok(_) => Ok(None),
    }
}

/// `go` under MPI, sort-last: rank r renders brick r of the k-d decomposition
/// (`rnd_core::brick`) from the brick and its ghost layers only; the partials are
/// exchanged so that each rank composites, in ray order, a band of image rows; rank 0
/// gathers the bands and writes the image (prepared before anything is read, as in one
/// process). Any rank's failure stops every rank, with its message, and nothing is
/// written.
#[cfg(feature = "mpi")]
fn run_bricked(a: &Args, job: &crate::job::Ranks) -> anyhow::Result<()> {
    use rnd_core::brick::{decompose, ghosts, Own, Partial};
    let (n, rank) = (job.size, job.rank);
    // Options, output (rank 0) and classification, checked on every rank.
    let setup = (|| {
        let (params, kernel, threads) = params(a)?;
        let db = a.get_arr::<i32, 2>("db")?;
        if db[0] >= 0 || db[1] >= 0 {
            bail!("-db traces a ray in one process: run it without mpirun");
        }
        let q = quant_range(a)?;
        let out = a.get_str("o").context("missing -o (output file)")?;
        let input = a.get_str("i").unwrap_or_default();
        let inputs: Vec<String> = std::iter::once(input.clone())
            .chain(["lut", "lev", "lit"].iter().filter_map(|f| a.get_str(f)))
            .collect();
        let inputs: Vec<&str> = inputs.iter().map(String::as_str).collect();
        let output = match rank {
            0 => Some(super::output(&out, a, &inputs).context("-o")?),
            _ => None,
        };
        Ok((params, kernel, threads, q, PathBuf::from(input), output))
    })();
    let Some((params, kernel, threads, q, input, output)) = agree(job, setup)? else {
        return Ok(());
    };
    let cls = classification(a);
    let Some((lut, lev, lights)) = agree(job, cls)? else {
        return Ok(());
    };
    let spec = RenderSpec::new(
        params,
        lut.as_ref(),
        lev.as_ref(),
        lights.as_deref().unwrap_or(&[]),
    )
    .map_err(anyhow::Error::from);
    let Some(spec) = agree(job, spec)? else {
        return Ok(());
    };
    // This rank's brick, read (only it and its ghost layers, from a NRRD) and rendered.
    let parts = (|| {
        let (below, above) = ghosts(kernel);
        let mut own = None;
        let region = rnd_std::volume_io::load_volume_region(&input, threads, |grid| {
            let brick = decompose(grid, n)?[rank];
            own = Some(Own::of(&brick, grid));
            Ok(brick.grown(below, above, grid))
        })?;
        spec.check_volume(region.grid)
            .with_context(|| input.display().to_string())?;
        let own = own.context("no brick was chosen")?;
        if std::env::var_os("RENDR_VERBOSE_BRICKS").is_some() {
            // One write of the whole line, so that mpirun does not splice another
            // rank's output into it.
            let line = format!(
                "rendr go: rank {rank} of {n}: samples {:?}..{:?} of {:?}{}\n",
                region.region.lo,
                region.region.hi,
                region.grid,
                if region.partial_read {
                    ", read alone"
                } else {
                    ", cut from the whole volume"
                }
            );
            let _ = std::io::stderr().write_all(line.as_bytes());
        }
        let control = rnd_std::parallel::Control::new();
        let parts = rnd_std::parallel::render_part_with(
            &spec,
            region.view()?,
            kernel,
            &own,
            threads,
            &control,
        )?;
        anyhow::Ok(parts)
    })();
    let Some(parts) = agree(job, parts)? else {
        return Ok(());
    };
    // Rank j composites rows band(j); each rank sends it the partials of those rows.
    let [w, h] = spec.size().map(|x| x as usize);
    let band = |j: usize| (j * h / n) * w..((j + 1) * h / n) * w;
    let (blend, len) = (spec.params().blend, spec.params().probe.length());
    let sends: Vec<Vec<u8>> = (0..n)
        .map(|j| {
            let mut b = Vec::with_capacity(band(j).len() * Partial::record_len(blend, len));
            for i in band(j) {
                let samples = parts.samples.get(i).map_or(&[][..], Vec::as_slice);
                parts.partials[i].encode(samples, &mut b);
            }
            b
        })
        .collect();
    drop(parts);
    let mine = (|| {
        let got = job.exchange(&sends)?;
        let ch = spec.channels();
        let plen = spec.params().probe.length();
        let mut at = vec![0usize; got.len()];
        let mut px = Vec::with_capacity(n);
        let mut samples = Vec::with_capacity(n);
        let mut out = Vec::with_capacity(band(rank).len() * ch * 4);
        let mut pixel = vec![0.0f32; ch];
        for _ in band(rank) {
            px.clear();
            samples.clear();
            for (g, at) in got.iter().zip(&mut at) {
                let (p, s, used) = g
                    .get(*at..)
                    .and_then(|b| Partial::decode(b, blend, len))
                    .context("a rank sent too few partials")?;
                *at += used;
                px.push(p);
                samples.push(s);
            }
            let whole_ray = Partial::composite_all(&mut px, spec.params().reference)?;
            let lists: Vec<&[f32]> = samples.iter().map(Vec::as_slice).collect();
            whole_ray.finish(spec.params().outside, &lists, &mut pixel[..plen]);
            if ch > plen {
                // The time channel: the milliseconds of every rank's stretch.
                pixel[plen] = whole_ray.time;
            }
            for x in &pixel {
                out.extend_from_slice(&x.to_le_bytes());
            }
        }
        anyhow::Ok(out)
    })();
    drop(sends);
    let Some(mine) = agree(job, mine)? else {
        return Ok(());
    };
    if rank != 0 {
        job.send_to_root(&mine);
        return Ok(());
    }
    let mut data = Vec::with_capacity(w * h * spec.channels());
    for j in 0..n {
        let b = if j == 0 {
            mine.clone()
        } else {
            job.receive_from(j)
        };
        data.extend(
            b.chunks_exact(4)
                .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])),
        );
    }
    if data.len() != w * h * spec.channels() {
        bail!("the ranks sent {} floats for a {w} x {h} image", data.len());
    }
    let img = Image {
        data,
        channels: spec.channels(),
        size: [w, h],
    };
    let output = output.context("missing -o (output file)")?;
    write_image_to(img, output, &super::content("go", a), q).context("writing the image")?;
    Ok(())
}

/// The last volume loaded (used by `mgo`, so consecutive renderings of one volume read
/// it once). Only one is kept: memory stays that of the largest volume, however many
/// lines name how many volumes.
#[derive(Default)]
pub struct VolumeCache {
    last: Option<(PathBuf, std::rc::Rc<rnd_std::volume_io::VolumeBuf>)>,
}

impl VolumeCache {
    /// The volume in `path`: the cached one when it is the same name, else loaded
    /// (after the previous one is let go).
    pub fn get(
        &mut self,
        path: &Path,
        threads: usize,
    ) -> anyhow::Result<std::rc::Rc<rnd_std::volume_io::VolumeBuf>> {
        if let Some((p, v)) = &self.last {
            if p == path {
                return Ok(v.clone());
            }
        }
        self.last = None;
        let v = std::rc::Rc::new(load_volume(path, threads, Frames::One)?);
        if path.as_os_str() != "-" {
            self.last = Some((path.to_path_buf(), v.clone()));
        }
        Ok(v)
    }
}

/// How many frames a command renders from one loaded volume: what decides whether its
/// raw samples are mapped or read ([`load_volume`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Frames {
    /// One (`go`, `mgo`, `turn -n 1`): the file's samples are used in place.
    One,
    /// Several (`turn`, `view`): the samples are read into memory.
    Many,
}

/// The volume in `path` for rendering (go, turn, view). Raw NRRD samples are used in
/// place from a map of the file (`load_volume_mapped`) for one frame, and for many read
/// into memory (`load_volume_threads`: one allocation advised to the system's huge pages)
/// when they take at most half the memory this process may use (`rnd_std::mem_limit`):
/// the map costs nothing up front, but its 4 KiB pages make each frame slower where a
/// frame's rays range over many pages (the 256³ bench volume's MIPs on the Intel Xeon:
/// frames 1.17–1.35× quicker read; bench/RESULTS.md run 58), and a larger volume stays
/// mapped. `RENDR_MMAP=0` reads and `RENDR_MMAP=1` maps whatever the frames. Rendered
/// from a copy with padded rows where that pays (`VolumeBuf::render_view`;
/// `Padding::AutoOneFrame` for one frame, `Padding::Auto` for many), unless the
/// environment says `RENDR_PAD=0` (never) or `RENDR_PAD=1` (on any processor).
pub fn load_volume(
    path: &Path,
    threads: usize,
    frames: Frames,
) -> anyhow::Result<rnd_std::volume_io::VolumeBuf> {
    use rnd_std::volume_io::{load_volume_mapped, load_volume_threads, Padding, Samples};
    let mut vol = match std::env::var_os("RENDR_MMAP") {
        Some(v) if v == "0" => load_volume_threads(path, threads)?,
        Some(v) if v == "1" => load_volume_mapped(path, threads)?,
        _ if frames == Frames::One => load_volume_mapped(path, threads)?,
        _ => {
            // Mapped first (which costs next to nothing and tells the size), then read
            // where it fits.
            let v = load_volume_mapped(path, threads)?;
            let bytes = match v.data() {
                Samples::F32(d) => std::mem::size_of_val(d),
                Samples::I16(d) => std::mem::size_of_val(d),
            } as u64;
            let fits = rnd_std::mem_limit().is_none_or(|m| bytes <= m / 2);
            if v.is_mapped() && fits {
                drop(v);
                load_volume_threads(path, threads)?
            } else {
                v
            }
        }
    };
    vol.set_padding(match std::env::var_os("RENDR_PAD") {
        Some(v) if v == "0" => Padding::Never,
        Some(v) if v == "1" => Padding::Always,
        _ if frames == Frames::One => Padding::AutoOneFrame,
        _ => Padding::Auto,
    });
    Ok(vol)
}

/// Whether `RND_VERBOSE` asks for render times (a number above 0).
pub(crate) fn verbose() -> bool {
    std::env::var("RND_VERBOSE")
        .ok()
        .and_then(|v| v.parse::<i32>().ok())
        .is_some_and(|v| v > 0)
}

/// The render parameters, kernel and thread count the options of `a` ask for (the
/// `go` options that neither name files nor choose outputs; shared with `view`).
pub fn params(a: &Args) -> anyhow::Result<(RenderParams, KernelName, usize)> {
    let camera = super::cam::camera_spec(a)?;
    let kernel: KernelName = parse_named("k", &a.get_str("k").unwrap_or_default())?;
    let probe: Probe = parse_named("p", &a.get_str("p").unwrap_or_default())?;
    let blend: Blend = parse_named("b", &a.get_str("b").unwrap_or_default())?;
    let [ka, kd, ks, p] = a.get_arr::<f32, 4>("ph")?;
    let mut params = RenderParams::new(camera);
    params.plane_sep = a.get("s")?;
    params.sample_once = a.flag("s1s");
    params.probe = probe;
    params.blend = blend;
    params.outside = a.get("ov")?;
    params.unit_step = a.get("us")?;
    params.alpha_near1 = a.get("a1")?;
    params.phong = Phong { ka, kd, ks, p };
    params.dcn = a.get_arr("dcn")?;
    params.dcf = a.get_arr("dcf")?;
    params.time = a.flag("t");
    params.skip_empty = a.get("ess")?;
    params.fast_loop = a.get("fast")?;
    params.reference = a.get("ref")?;
    params.curv_min_grad = a.get("gmc")?;
    params.simd = rnd_std::simd_level_from_env();
    let threads = match a.given("nt") {
        true => a.get::<usize>("nt")?,
        false => rnd_std::parallel::default_threads(),
    };
    if threads > 1024 {
        bail!("-nt: {threads} threads is more than the limit of 1024");
    }
    Ok((params, kernel, threads))
}

/// The PNG quantization range `-q` asks for (checked: finite, min < max), if given.
pub fn quant_range(a: &Args) -> anyhow::Result<Option<(f64, f64)>> {
    if !a.given("q") {
        return Ok(None);
    }
    let [lo, hi] = a.get_arr::<f64, 2>("q")?;
    if !(lo.is_finite() && hi.is_finite() && lo < hi) {
        bail!("-q: need finite min < max (got {lo} {hi})");
    }
    Ok(Some((lo, hi)))
}

/// The LUT (`-lut`), Levoy opacities (`-lev`) and lights (`-lit`) the options name.
pub type Classification = (
    Option<rnd_core::txf::Lut>,
    Option<rnd_core::txf::Levoy>,
    Option<Vec<rnd_core::light::Light>>,
);

/// Reads the files of `-lut`, `-lev` and `-lit` (those given).
pub fn classification(a: &Args) -> anyhow::Result<Classification> {
    let lut = a
        .get_str("lut")
        .map(|f| rnd_std::files::load_lut(Path::new(&f)))
        .transpose()?;
    let lev = a
        .get_str("lev")
        .map(|f| rnd_std::files::load_levoy(Path::new(&f)))
        .transpose()?;
    let lights = a
        .get_str("lit")
        .map(|f| rnd_std::files::load_lights(Path::new(&f)))
        .transpose()?;
    Ok((lut, lev, lights))
}

/// `go` with volumes taken from (and added to) `cache`; `extra_inputs` are files the
/// output must not overwrite besides this command's own (`mgo`'s command file).
pub fn run_cached(
    a: &Args,
    cache: &mut VolumeCache,
    extra_inputs: &[String],
) -> anyhow::Result<()> {
    let (params, kernel, threads) = params(a)?;
    let db = a.get_arr::<i32, 2>("db")?;
    let debug = db[0] >= 0 || db[1] >= 0;
    let progress: bool = a.get("sp")?;
    let q = quant_range(a)?;
    let out: Option<PathBuf> = a.get_str("o").map(PathBuf::from);
    if out.is_none() && !debug {
        bail!("missing -o (output file), needed unless -db is given");
    }
    let input = PathBuf::from(a.get_str("i").unwrap_or_default());
    let inputs: Vec<String> = std::iter::once(input.to_string_lossy().into_owned())
        .chain(["lut", "lev", "lit"].iter().filter_map(|f| a.get_str(f)))
        .chain(extra_inputs.iter().cloned())
        .collect();
    let inputs: Vec<&str> = inputs.iter().map(String::as_str).collect();
    // The output is prepared before anything is read or rendered (and with -db there
    // is none).
    let output = match (&out, debug) {
        (Some(o), false) => Some(super::output(&o.to_string_lossy(), a, &inputs).context("-o")?),
        _ => None,
    };
    let (lut, lev, lights) = classification(a)?;
    let spec = RenderSpec::new(
        params,
        lut.as_ref(),
        lev.as_ref(),
        lights.as_deref().unwrap_or(&[]),
    )?;
    let vol = cache.get(&input, threads)?;
    spec.check_volume(vol.sizes())
        .with_context(|| input.display().to_string())?;
    if debug {
        let [w, h] = spec.size();
        if db[0] < 0 || db[1] < 0 || db[0] as u32 >= w || db[1] as u32 >= h {
            bail!(
                "-db: pixel ({} {}) is not inside the {w} x {h} image",
                db[0],
                db[1]
            );
        }
        return trace_pixel(&spec, vol.view(), kernel, [db[0] as u32, db[1] as u32]);
    }
    if a.flag("petc") {
        eprint!("rendr go: press Enter to continue ");
        // One line, read byte by byte up to a bound (stdin may be endless).
        use std::io::Read;
        for b in std::io::stdin().lock().bytes().take(1 << 16) {
            if !matches!(b, Ok(c) if c != b'\n') {
                break;
            }
        }
    }
    let [w, h] = spec.size();
    let t0 = std::time::Instant::now();
    let show = progress && std::io::stderr().is_terminal();
    let report = |p: rnd_std::parallel::Progress| {
        let mut e = std::io::stderr().lock();
        let _ = write!(e, "\rrendr go: {:3}% ", 100 * p.rows_done / p.rows.max(1));
        let _ = e.flush();
    };
    let mut control = rnd_std::parallel::Control::new();
    if show {
        control = control.on_progress(&report);
    }
    let data = rnd_std::parallel::render_volume(&spec, &vol, kernel, threads, &control)?;
    if show {
        eprint!("\r          \r");
    }
    if verbose() {
        eprintln!(
            "rendr go: {} seconds to render (w/ {threads} threads)",
            g6(t0.elapsed().as_secs_f64())
        );
    }
    let img = Image {
        data,
        channels: spec.channels(),
        size: [w as usize, h as usize],
    };
    let Some(output) = output else {
        bail!("missing -o (output file)");
    };
    write_image_to(img, output, &super::content("go", a), q).context("writing the image")?;
    Ok(())
}
