//! `rendr turn`: the frames of a turntable or of a camera path through key frames.

use std::path::Path;

use anyhow::{bail, Context};
use rnd_core::camera::CameraSpec;
use rnd_core::render::RenderSpec;
use rnd_std::image_out::{commit_bytes, encode_apng, encode_png, png_pixels, Image, PngColor};

use crate::args::{Args, CmdSpec};

pub static SPEC: CmdSpec = CmdSpec {
    name: "turn",
    about: "render the frames of a turntable or a camera path",
    info: "Renders -n frames as \"rendr go\" would, each with its own camera: turning the \
           look-from point and the up vector about -axis (through the look-at point; \
           default the up vector) by -deg degrees in all (frame i at i*deg/n), or, with \
           -key, moving along a path through key frames (linearly between them; the first \
           frame at the first key, the last at the last). Frames are written to \
           PREFIX-0000.png, PREFIX-0001.png, ... (or .nrrd with -f nrrd) after all have \
           rendered, with PREFIX-cams.txt giving each frame's camera as go options, so \
           \"rendr go\" with them writes the same frame bit for bit; -apng also writes \
           an animated PNG. Under \"mpirun -np N\" (a build with the cargo feature mpi) \
           frame i renders on process i mod N, each reading the whole volume, and \
           process 0 writes the files one process would write. The volume's skip grid \
           is built for a process's first frame and kept for its others (it does not \
           depend on the camera); RND_VERBOSE=1 prints each frame's render time. With \
           more than one frame the volume's samples are read into memory (one allocation \
           the system may back with huge pages: quicker frames than a map of the file \
           gives) unless they would take more than half the memory the process may use \
           or RENDR_MMAP=1.",
    response_files: true,
    opts: super::go::go_opts!(
        crate::args::req(&["n"], 1, "frames", "number of frames (1 to 100000)"),
        crate::args::def(
            &["deg"],
            1,
            "360",
            "angle",
            "turntable: the whole turn in degrees (frame i at i*angle/n)"
        ),
        crate::args::opt(
            &["axis"],
            3,
            "x y z",
            "turntable axis through the look-at point (default: the up vector)"
        ),
        crate::args::opt(
            &["key"],
            1,
            "keys",
            "camera path instead of a turn: key frames, one per line: fr(3) at(3) up(3) fov"
        ),
        crate::args::def(&["f"], 1, "png", "format", "frame format: png or nrrd"),
        crate::args::req(
            &["o"],
            1,
            "prefix",
            "frames PREFIX-0000.png ... and cameras PREFIX-cams.txt"
        ),
        crate::args::opt(
            &["apng"],
            1,
            "file",
            "also write the frames as an animated PNG"
        ),
        crate::args::def(&["fps"], 1, "25", "fps", "frame rate of the animated PNG"),
    ),
    pos: &[],
};

/// Rotates `v` about unit axis `k` by `ang` radians (Rodrigues).
fn rotate(v: [f64; 3], k: [f64; 3], ang: f64) -> [f64; 3] {
    let (c, s) = (ang.cos(), ang.sin());
    let kv = k[0] * v[0] + k[1] * v[1] + k[2] * v[2];
    let kxv = [
        k[1] * v[2] - k[2] * v[1],
        k[2] * v[0] - k[0] * v[2],
        k[0] * v[1] - k[1] * v[0],
    ];
    std::array::from_fn(|a| v[a] * c + kxv[a] * s + k[a] * kv * (1.0 - c))
}

/// One frame's camera: look-from, look-at, up, field of view.
type Cam = ([f64; 3], [f64; 3], [f64; 3], f64);

/// Key frames from the text of a key file (`#` comments; 10 numbers a line).
pub fn parse_keys(text: &str) -> Result<Vec<Cam>, String> {
    let mut keys = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line = line.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let v: Vec<f64> = line
            .split_whitespace()
            .map(|w| {
                w.parse::<f64>()
                    .map_err(|_| format!("line {}: \"{w}\" is not a number", i + 1))
            })
            .collect::<Result<_, _>>()?;
        if v.len() != 10 || v.iter().any(|x| !x.is_finite()) {
            return Err(format!(
                "line {}: need 10 finite numbers (fr at up fov), got {}",
                i + 1,
                v.len()
            ));
        }
        keys.push((
            [v[0], v[1], v[2]],
            [v[3], v[4], v[5]],
            [v[6], v[7], v[8]],
            v[9],
        ));
        if keys.len() > 100_000 {
            return Err("more than 100000 key frames".into());
        }
    }
    if keys.len() < 2 {
        return Err(format!("need at least 2 key frames, found {}", keys.len()));
    }
    Ok(keys)
}

/// The cameras of `n` frames: along `keys` if given, else turning `base` about `axis`
/// by `deg` degrees in all.
pub fn frame_cameras(
    n: usize,
    base: Cam,
    axis: [f64; 3],
    deg: f64,
    keys: Option<&[Cam]>,
) -> Vec<Cam> {
    (0..n)
        .map(|i| match keys {
            Some(k) => {
                let t = if n > 1 {
                    i as f64 * (k.len() - 1) as f64 / (n - 1) as f64
                } else {
                    0.0
                };
                let j = (t.floor() as usize).min(k.len() - 2);
                let u = t - j as f64;
                let lerp =
                    |a: [f64; 3], b: [f64; 3]| std::array::from_fn(|x| a[x] + (b[x] - a[x]) * u);
                let (a, b) = (k[j], k[j + 1]);
                (
                    lerp(a.0, b.0),
                    lerp(a.1, b.1),
                    lerp(a.2, b.2),
                    a.3 + (b.3 - a.3) * u,
                )
            }
            None => {
                let ang = (i as f64 * deg / n as f64).to_radians();
                let (fr, at, up, fov) = base;
                let off = std::array::from_fn(|x| fr[x] - at[x]);
                let r = rotate(off, axis, ang);
                (
                    std::array::from_fn(|x| at[x] + r[x]),
                    at,
                    rotate(up, axis, ang),
                    fov,
                )
            }
        })
        .collect()
}

/// A camera as `go` options (numbers that read back to the same values).
fn cam_words((fr, at, up, fov): &Cam) -> String {
    let v = |p: &[f64; 3]| format!("{} {} {}", p[0], p[1], p[2]);
    format!("-fr {} -at {} -up {} -fov {fov}", v(fr), v(at), v(up))
}

/// A rendered frame: its file's bytes and, for an animation, its 8-bit pixels.
#[derive(Default)]
struct Frame {
    file: Vec<u8>,
    anim: Vec<u8>,
}

/// What [`render()`] hands to [`write()`].
struct Rendered {
    n: usize,
    cams: Vec<Cam>,
    /// Per frame; `None` for frames another rank renders.
    frames: Vec<Option<Frame>>,
    colour: PngColor,
    size: [usize; 2],
    fps: u16,
    prefix: String,
    ext: &'static str,
    inputs: Vec<String>,
}

/// Checks everything, then renders the frames `i` with `i % size == rank`.
fn render(a: &Args, rank: usize, size: usize) -> anyhow::Result<Rendered> {
    let (mut params, kernel, threads) = super::go::params(a)?;
    let n: usize = a.get("n")?;
    if !(1..=100_000).contains(&n) {
        bail!("-n: {n} frames is not in 1..=100000");
    }
    let deg: f64 = a.get("deg")?;
    if !deg.is_finite() {
        bail!("-deg: need a finite angle");
    }
    let nrrd = match a.get_str("f").as_deref() {
        Some("png") => false,
        Some("nrrd") => true,
        Some(f) => bail!("-f: \"{f}\" is not png or nrrd"),
        None => false,
    };
    let fps: u16 = a
        .get_str("fps")
        .unwrap_or_default()
        .parse()
        .ok()
        .filter(|f| (1..=1000).contains(f))
        .context("-fps: need a frame rate in 1..=1000")?;
    let q = super::go::quant_range(a)?;
    let c = params.camera;
    let base: Cam = (c.from, c.at, c.up, c.fov);
    let axis = match a.given("axis") {
        true => a.get_arr::<f64, 3>("axis")?,
        false => c.up,
    };
    let len = (axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]).sqrt();
    if !(len > 0.0 && len.is_finite()) {
        bail!("-axis: need a finite non-zero direction");
    }
    let axis = axis.map(|x| x / len);
    let keys = match a.get_str("key") {
        Some(f) => {
            let text = rnd_std::files::read_text(Path::new(&f), 64 << 20)?;
            Some(parse_keys(&text).map_err(|e| anyhow::anyhow!("-key {f}: {e}"))?)
        }
        None => None,
    };
    let cams = frame_cameras(n, base, axis, deg, keys.as_deref());
    // Every frame's camera is checked before anything renders.
    for (i, cam) in cams.iter().enumerate() {
        let spec = CameraSpec {
            from: cam.0,
            at: cam.1,
            up: cam.2,
            fov: cam.3,
            ..c
        };
        rnd_core::camera::Camera::new(spec).with_context(|| format!("frame {i}'s camera"))?;
    }
    let prefix = a.get_str("o").unwrap_or_default();
    let apng = a.given("apng");
    let ext = if nrrd { "nrrd" } else { "png" };
    let name = |i: usize| format!("{prefix}-{i:04}.{ext}");
    let input = a.get_str("i").unwrap_or_default();
    let inputs: Vec<String> = std::iter::once(input.clone())
        .chain(
            ["lut", "lev", "lit", "key"]
                .iter()
                .filter_map(|f| a.get_str(f)),
        )
        .collect();
    let inputs: Vec<&str> = inputs.iter().map(String::as_str).collect();
    // The outputs' directory is checked now (the first frame's output, let go again).
    drop(super::output(&name(0), a, &inputs).context("-o")?);
    let [w, h] = c.size;
    if nrrd {
        let per = (w as u64) * (h as u64) * 4 * 16;
        rnd_std::check_memory(per.saturating_mul(n as u64), &format!("{n} NRRD frames"))
            .context("-n")?;
    }
    let (lut, lev, lights) = super::go::classification(a)?;
    let many = if n > 1 {
        super::go::Frames::Many
    } else {
        super::go::Frames::One
    };
    let vol =
        super::go::load_volume(Path::new(&input), threads, many).with_context(|| input.clone())?;
    let verbose = super::go::verbose();
    if verbose {
        eprintln!(
            "rendr turn: the volume's samples are {}",
            if vol.is_mapped() {
                "mapped from its file"
            } else {
                "held in memory"
            }
        );
    }
    let mut frames: Vec<Option<Frame>> = Vec::with_capacity(n);
    let mut colour = PngColor::Rgb;
    for (i, cam) in cams.iter().enumerate() {
        if i % size != rank {
            frames.push(None);
            continue;
        }
        (
            params.camera.from,
            params.camera.at,
            params.camera.up,
            params.camera.fov,
        ) = *cam;
        let spec = RenderSpec::new(
            params.clone(),
            lut.as_ref(),
            lev.as_ref(),
            lights.as_deref().unwrap_or(&[]),
        )?;
        spec.check_volume(vol.sizes())
            .with_context(|| input.clone())?;
        let control = rnd_std::parallel::Control::new();
        // (The volume keeps the skip grid of one frame for the next.)
        let t0 = std::time::Instant::now();
        let data = rnd_std::parallel::render_volume(&spec, &vol, kernel, threads, &control)
            .with_context(|| format!("frame {i}"))?;
        if verbose {
            eprintln!(
                "rendr turn: frame {i}: {} seconds to render (w/ {threads} threads)",
                crate::fmt::g6(t0.elapsed().as_secs_f64())
            );
        }
        let img = Image {
            data,
            channels: spec.channels(),
            size: [w as usize, h as usize],
        };
        let mut frame = Frame::default();
        if nrrd {
            let mut nr = rnd_std::nrrd::Nrrd::new(
                vec![img.channels, img.size[0], img.size[1]],
                rnd_std::nrrd::Data::F32(img.data.clone()),
            )?;
            nr.header.content = Some(format!(
                "{} (frame {i}: {})",
                super::content("turn", a),
                cam_words(cam)
            ));
            rnd_std::nrrd::write_to(&nr, Default::default(), &mut frame.file)?;
        }
        if !nrrd || apng {
            let (buf, col) = png_pixels(&img, q)?;
            colour = col;
            if !nrrd {
                frame.file = encode_png(&buf, img.size[0], img.size[1], col)?;
            }
            if apng {
                frame.anim = buf;
            }
        }
        frames.push(Some(frame));
    }
    Ok(Rendered {
        n,
        cams,
        frames,
        colour,
        size: [w as usize, h as usize],
        fps,
        prefix,
        ext,
        inputs: inputs.iter().map(|s| s.to_string()).collect(),
    })
}

/// Writes the frames (all rendered), the cameras and the animation.
fn write(a: &Args, r: Rendered) -> anyhow::Result<()> {
    let inputs: Vec<&str> = r.inputs.iter().map(String::as_str).collect();
    let name = |i: usize| format!("{}-{i:04}.{}", r.prefix, r.ext);
    let mut anim = Vec::new();
    for (i, f) in r.frames.into_iter().enumerate() {
        let f = f.with_context(|| format!("frame {i} is missing"))?;
        let out = super::output(&name(i), a, &inputs).context("-o")?;
        commit_bytes(out, &f.file)?;
        anim.push(f.anim);
    }
    let mut cams_txt = String::from("# rendr turn: each frame's camera as rendr go options\n");
    for (i, cam) in r.cams.iter().enumerate() {
        cams_txt.push_str(&format!("{} {}\n", name(i), cam_words(cam)));
    }
    let out = super::output(&format!("{}-cams.txt", r.prefix), a, &inputs).context("-o")?;
    commit_bytes(out, cams_txt.as_bytes())?;
    if let Some(f) = a.get_str("apng") {
        let [w, h] = r.size;
        let bytes = encode_apng(&anim, w, h, r.colour, r.fps).context("-apng")?;
        let out = super::output(&f, a, &inputs).context("-apng")?;
        commit_bytes(out, &bytes)?;
    }
    let _ = r.n;
    Ok(())
}

pub fn run(a: &Args) -> anyhow::Result<()> {
    #[cfg(feature = "mpi")]
    if let Some(job) = crate::job::ranks() {
        return run_ranks(a, &job);
    }
    write(a, render(a, 0, 1)?)
}

/// `turn` under MPI: frame i renders on rank i mod N; rank 0 gathers and writes them
/// once every rank has succeeded (a failing rank stops the job with its message and
/// nothing is written).
#[cfg(feature = "mpi")]
fn run_ranks(a: &Args, job: &crate::job::Ranks) -> anyhow::Result<()> {
    let r = render(a, job.rank, job.size);
    if job.any(r.is_err()) {
        // The failing ranks report; the others stop quietly.
        return match r {
            Err(e) => Err(e.context(format!("rank {} of {}", job.rank, job.size))),
            Ok(_) => Ok(()),
        };
    }
    let mut r = r?;
    let apng = a.given("apng");
    if job.rank == 0 {
        for i in 0..r.n {
            let from = i % job.size;
            if from != 0 {
                let file = job.receive_from(from);
                let anim = if apng {
                    job.receive_from(from)
                } else {
                    Vec::new()
                };
                r.frames[i] = Some(Frame { file, anim });
            }
        }
        write(a, r)
    } else {
        for f in r.frames.iter().flatten() {
            job.send_to_root(&f.file);
            if apng {
                job.send_to_root(&f.anim);
            }
        }
        Ok(())
    }
}
