//! `rendr view`: explore a volume in the browser, then copy the exact `go` command.

use std::path::Path;

use anyhow::{bail, Context};
use rnd_core::camera::CameraSpec;

use crate::args::{def, flag, opt, Args, CmdSpec, Pos};
use crate::view::{Session, REQUEST_OPTS};

pub static SPEC: CmdSpec = CmdSpec {
    name: "view",
    about: "explore a volume interactively in the browser",
    info: "Starts a local web server for VOLUME and prints its URL (open it in a browser; \
           nothing is opened for you). The page shows the rendering and lets you orbit \
           (drag), pan (shift-drag or right-drag) and zoom (wheel), choose kernel, probe, \
           blend, step, size and threads, and edit the transfer function on the volume's \
           histogram and the lights; a coarse picture follows the mouse and the full one \
           comes when it rests. It prints the exact \"rendr lgen\" and \"rendr go\" \
           commands (with their control-point and light files, downloadable) that make the \
           full picture bit for bit. The go options given here are the first settings; \
           without a camera, one framing the volume is chosen. Security: the server \
           listens on 127.0.0.1 unless -host says otherwise, every request needs the \
           random token in the printed URL, Host and Origin headers must name this server, \
           and it reads only VOLUME and the files named here.",
    response_files: true,
    opts: &[
        def(&["k", "-kern"], 1, "bspln3", "kernel", "reconstruction kernel (see \"rendr klist\")"),
        opt(&["fr"], 3, "x y z", "look-from point (default: framing the volume)"),
        opt(&["at"], 3, "x y z", "look-at point"),
        opt(&["up"], 3, "x y z", "up direction"),
        opt(&["nc"], 1, "dist", "near clipping plane, relative to look-at"),
        opt(&["fc"], 1, "dist", "far clipping plane, relative to look-at"),
        opt(&["fov"], 1, "angle", "vertical field of view, in degrees"),
        def(&["sz"], 2, "256 256", "horz vert", "image size in pixels"),
        flag(&["ortho"], "orthographic instead of perspective projection"),
        opt(
            &["s", "-planesep"],
            1,
            "sep",
            "distance between sampling planes (default: half the smallest voxel spacing)",
        ),
        def(&["p", "-probe"], 1, "val", "probe", "what to measure at each sample"),
        def(&["b", "-blend"], 1, "max", "blend", "how to combine the samples of a ray"),
        def(&["gmc"], 1, "0", "min gradmag", "curvature probes: the gradient threshold"),
        def(&["ov", "-outsideval"], 1, "0", "val", "value for rays with nothing to blend"),
        opt(&["nt"], 1, "threads", "threads per render (default: up to 2; at most the cores)"),
        def(&["us"], 1, "1", "unitstep", "unit step length for opacity correction"),
        def(
            &["a1"],
            1,
            "0.99",
            "alphanear1",
            "early ray termination opacity, in (0,1] (go's default is 1, off; the printed command always says which)",
        ),
        opt(&["lut"], 1, "lut", "LUT to use until the page's transfer function is edited"),
        opt(&["lev"], 1, "levoy", "Levoy iso-contour opacities (v r a per line)"),
        opt(&["lit"], 1, "lights", "light file (the page's first lights)"),
        def(&["ph"], 4, "0.2 0.8 0.1 150", "ka kd ks p", "Blinn-Phong parameters"),
        def(&["dcn"], 3, "1 1 1", "r g b", "depth-cue colour at the near plane"),
        def(&["dcf"], 3, "1 1 1", "r g b", "depth-cue colour at the far plane"),
        def(&["ess"], 1, "true", "bool", "skip samples that cannot change the pixel (exact)"),
        def(&["fast"], 1, "true", "bool", "accelerated ray loop (exact)"),
        def(&["ref"], 1, "true", "bool", "reference arithmetic (false: the f64 engine)"),
        opt(&["q"], 2, "min max", "quantization range for the PNG pictures"),
        def(&["port"], 1, "0", "port", "TCP port (0: a free one)"),
        def(
            &["host"],
            1,
            "127.0.0.1",
            "addr",
            "address to listen on (anything but 127.0.0.1 or ::1 exposes the volume to the network)",
        ),
    ],
    pos: &[Pos {
        name: "VOLUME",
        arity: crate::args::Arity::Fixed(1),
        help: "the volume to explore: NRRD, NIfTI, MetaImage or DICOM (a series folder)",
    }],
};

/// The page's first `go` words: the options of `a` that a request may carry (given or
/// defaulted), with a camera framing `vol` where `a` gives none.
fn first_words(a: &Args, vol: &rnd_std::volume_io::VolumeBuf) -> anyhow::Result<Vec<String>> {
    let mut words = Vec::new();
    let itow = vol.itow();
    let spacing = (0..3)
        .map(|c| {
            let v = itow.column3(c);
            (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
        })
        .fold(f64::INFINITY, f64::min);
    let cam = CameraSpec::framing(&vol.view().world_corners(), [0.0, -1.0, 0.0])
        .map(|c| c.up([0.0, 0.0, 1.0]));
    let camera_given = ["fr", "at", "up", "nc", "fc", "fov"]
        .iter()
        .filter(|o| a.given(o))
        .count();
    if camera_given != 0 && camera_given != 6 {
        bail!("give all of -fr -at -up -nc -fc -fov, or none (a camera framing the volume)");
    }
    for &name in REQUEST_OPTS {
        if name == "s1s" {
            continue;
        }
        if name == "ortho" {
            if a.flag("ortho") {
                words.push("-ortho".to_string());
            }
            continue;
        }
        let vals: Option<Vec<String>> = match (name, camera_given, &cam) {
            ("fr" | "at" | "up" | "nc" | "fc" | "fov", 0, Some(c)) => Some(match name {
                "fr" => c.from.iter().map(|x| x.to_string()).collect(),
                "at" => c.at.iter().map(|x| x.to_string()).collect(),
                "up" => c.up.iter().map(|x| x.to_string()).collect(),
                "nc" => vec![c.near.to_string()],
                "fc" => vec![c.far.to_string()],
                _ => vec![c.fov.to_string()],
            }),
            ("s", _, _) if !a.given("s") => Some(vec![if spacing.is_finite() && spacing > 0.0 {
                (spacing / 2.0).to_string()
            } else {
                "0.5".to_string()
            }]),
            ("nt", _, _) if !a.given("nt") => Some(vec![rnd_std::parallel::default_threads()
                .clamp(1, 2)
                .to_string()]),
            _ => a.get_n::<String>(name).ok(),
        };
        if let Some(v) = vals {
            words.push(format!("-{name}"));
            words.extend(v);
        }
    }
    Ok(words)
}

pub fn run(a: &Args) -> anyhow::Result<()> {
    let path = a.pos(0)[0].clone();
    let host: String = a.get_str("host").unwrap_or_default();
    let port: u16 = a
        .get_str("port")
        .unwrap_or_default()
        .parse()
        .map_err(|_| anyhow::anyhow!("-port: need a TCP port number 0..=65535"))?;
    let threads = rnd_std::parallel::default_threads();
    let vol = super::go::load_volume(Path::new(&path), threads, super::go::Frames::Many)
        .with_context(|| path.clone())?;
    let words = first_words(a, &vol)?;
    // The first settings must render: their errors name the option now.
    let first = crate::view::request_args(&words).map_err(|e| anyhow::anyhow!(e.1))?;
    super::go::params(&first)?;
    // Files are named absolutely in the printed command (it may run elsewhere).
    let full = |f: &str| {
        std::fs::canonicalize(f)
            .map(|p| p.display().to_string())
            .unwrap_or_else(|_| f.to_string())
    };
    let lut = a
        .get_str("lut")
        .map(|f| Ok::<_, anyhow::Error>((full(&f), rnd_std::files::load_lut(Path::new(&f))?)))
        .transpose()?;
    let lev = a
        .get_str("lev")
        .map(|f| Ok::<_, anyhow::Error>((full(&f), rnd_std::files::load_levoy(Path::new(&f))?)))
        .transpose()?;
    let lights = match a.get_str("lit") {
        Some(f) => {
            let text = rnd_std::files::read_text(Path::new(&f), 1 << 20)?;
            crate::view::parse_lights(&text).map_err(|e| anyhow::anyhow!("{f}: {}", e.1))?;
            Some((f, text))
        }
        None => None,
    };
    let server = tiny_http::Server::http((host.as_str(), port))
        .map_err(|e| anyhow::anyhow!("-host/-port: can't listen on {host}:{port}: {e}"))?;
    let addr = server
        .server_addr()
        .to_ip()
        .context("the server's address")?;
    let token = crate::view::random_token()?;
    let mut hosts = vec![addr.to_string()];
    if addr.ip().is_loopback() {
        hosts.push(format!("localhost:{}", addr.port()));
    }
    let (hist, range) = crate::view::histogram(&vol);
    let volume = full(&path);
    let session = Session {
        path: volume,
        vol,
        lut,
        lights,
        lev,
        words,
        token: token.clone(),
        hosts,
        any_port: addr.ip().is_unspecified().then_some(addr.port()),
        max_threads: threads,
        hist,
        range,
        running: Default::default(),
    };
    if !addr.ip().is_loopback() {
        eprintln!(
            "rendr view: warning: listening on {addr}: other machines can reach this server \
             (they still need the token)"
        );
    }
    println!("rendr view: http://{addr}/?t={token}");
    use std::io::Write;
    let _ = std::io::stdout().flush();
    crate::view::serve(server, session, 2)
}
