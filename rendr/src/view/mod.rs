//! `rendr view`'s HTTP side: the security rules, the routes and the render requests.
//!
//! Every request must carry the session token (`?t=` in the URL, or the
//! `X-Rendr-Token` header), a `Host` header naming this server, and no `Origin` but
//! this server's own. A render request carries the whole parameter set: the `go`
//! option words (the same words the page prints as the command), the transfer
//! function's control points and the lights as text. The server keeps no state per
//! client besides the newest request number of each, which cancels older renders.

use std::collections::HashMap;
use std::io::Read;
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};

use anyhow::{bail, Context};
use rnd_core::txf::{Lut, Txf};
use rnd_std::image_out::{png_bytes, Image};
use serde::{Deserialize, Serialize};
use tiny_http::{Header, Method, Request, Response};

use crate::args::{parse, Args};

/// The largest request body (JSON) accepted, in bytes.
pub const MAX_BODY: usize = 256 << 10;
/// The largest image side a request may ask for, in pixels.
pub const MAX_SIDE: u32 = 2048;
/// The largest LUT a request may ask for.
pub const MAX_LUT: usize = 1 << 16;

/// The page and its assets, served from the binary.
const PAGE: &str = include_str!("page.html");
const SCRIPT: &str = include_str!("app.js");
const STYLE: &str = include_str!("app.css");

/// The `go` options a render request may carry (the rest name files or change what is
/// written, which only the command line may).
pub const REQUEST_OPTS: &[&str] = &[
    "k", "p", "b", "s", "s1s", "sz", "nt", "fr", "at", "up", "nc", "fc", "fov", "ortho", "ph",
    "dcn", "dcf", "us", "a1", "ov", "ref", "ess", "fast", "gmc", "q",
];

/// What the server was started with: the volume and the files its command line named.
pub struct Session {
    /// The volume path as given.
    pub path: String,
    /// The volume.
    pub vol: rnd_std::volume_io::VolumeBuf,
    /// The LUT of `-lut`, if given (used when a request has no transfer function).
    pub lut: Option<(String, Lut)>,
    /// The lights file of `-lit` (its text), if given.
    pub lights: Option<(String, String)>,
    /// The Levoy file of `-lev`, if given.
    pub lev: Option<(String, rnd_core::txf::Levoy)>,
    /// The page's first parameters: `go` option words.
    pub words: Vec<String>,
    /// The token every request must carry.
    pub token: String,
    /// Host names (with port) the `Host` header may give.
    pub hosts: Vec<String>,
    /// The port, when the server listens on every address (then any literal IP with
    /// this port is a valid `Host`).
    pub any_port: Option<u16>,
    /// The most threads a render may use.
    pub max_threads: usize,
    /// Value histogram (256 bins over [min, max]) and the range.
    pub hist: Vec<u64>,
    /// The volume's value range.
    pub range: (f64, f64),
    /// Newest request number per client, and the cancel flags of renders under way.
    pub running: Mutex<HashMap<String, Client>>,
}

/// One client's newest request number and the cancel flags of its renders under way
/// (with their request numbers).
pub type Client = (u64, Vec<(u64, Arc<AtomicBool>)>);

/// A render request (JSON).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RenderRequest {
    /// Client id (random, per page) and request number (grows per client).
    pub client: String,
    pub seq: u64,
    /// `go` option words.
    pub args: Vec<String>,
    /// Transfer function: colour and opacity control points (the text of
    /// `rendr lgen -i` files), LUT domain and length; none: the `-lut` of the command
    /// line, if any.
    pub txf: Option<TxfRequest>,
    /// Lights file text; none: the command line's `-lit`, if any.
    pub lights: Option<String>,
    /// `png` (default) or `nrrd`.
    pub format: Option<String>,
}

/// A transfer function as `rendr lgen` makes it.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TxfRequest {
    pub rgb: String,
    pub alpha: String,
    pub mm: [f64; 2],
    pub len: usize,
}

/// What the page learns first.
#[derive(Debug, Serialize)]
pub struct Info {
    pub volume: String,
    pub sizes: [usize; 3],
    pub voxel: &'static str,
    pub range: (f64, f64),
    pub hist: Vec<u64>,
    pub words: Vec<String>,
    pub corners: [[f64; 3]; 8],
    pub lut_file: Option<String>,
    pub lights_file: Option<String>,
    pub lights: Option<String>,
    pub lev_file: Option<String>,
    pub max_threads: usize,
    pub max_side: u32,
}

/// A failed request: its status and message.
pub struct Reply(pub u16, pub String);

impl<E: std::fmt::Display> From<E> for Reply {
    fn from(e: E) -> Self {
        Reply(400, e.to_string())
    }
}

fn header(name: &str, value: &str) -> Header {
    Header::from_bytes(name.as_bytes(), value.as_bytes()).expect("a valid header")
}

fn text(status: u16, msg: &str) -> Response<std::io::Cursor<Vec<u8>>> {
    Response::from_data(format!("{msg}\n").into_bytes())
        .with_status_code(status)
        .with_header(header("Content-Type", "text/plain; charset=utf-8"))
}

/// The request's header `name` (first one), if any.
fn get_header<'r>(rq: &'r Request, name: &'static str) -> Option<&'r str> {
    rq.headers()
        .iter()
        .find(|h| h.field.equiv(name))
        .map(|h| h.value.as_str())
}

/// The value of query parameter `key` in `url`.
fn query<'u>(url: &'u str, key: &str) -> Option<&'u str> {
    let q = url.split_once('?')?.1;
    q.split('&')
        .filter_map(|kv| kv.split_once('='))
        .find(|(k, _)| *k == key)
        .map(|(_, v)| v)
}

/// Equal strings, in time independent of where they differ.
fn same(a: &str, b: &str) -> bool {
    a.len() == b.len() && a.bytes().zip(b.bytes()).fold(0u8, |d, (x, y)| d | (x ^ y)) == 0
}

impl Session {
    /// The security checks every request passes first: `Host`, `Origin`, token.
    pub fn admit(&self, rq: &Request) -> Result<(), Reply> {
        // Bound to every address: a literal IP with this port is this server (DNS
        // rebinding needs a name).
        let any_ip = |h: &str| {
            self.any_port.is_some_and(|p| {
                h.parse::<std::net::SocketAddr>()
                    .is_ok_and(|a| a.port() == p)
            })
        };
        match get_header(rq, "Host") {
            Some(h) if self.hosts.iter().any(|x| x.eq_ignore_ascii_case(h)) || any_ip(h) => {}
            Some(h) => return Err(Reply(403, format!("Host \"{h}\" is not this server"))),
            None => return Err(Reply(403, "no Host header".into())),
        }
        if let Some(o) = get_header(rq, "Origin") {
            let ok = self
                .hosts
                .iter()
                .any(|h| o.eq_ignore_ascii_case(&format!("http://{h}")))
                || o.strip_prefix("http://").is_some_and(any_ip);
            if !ok {
                return Err(Reply(403, format!("Origin \"{o}\" is not this server")));
            }
        }
        let given = get_header(rq, "X-Rendr-Token").or_else(|| query(rq.url(), "t"));
        match given {
            Some(t) if same(t, &self.token) => Ok(()),
            Some(_) => Err(Reply(403, "wrong token".into())),
            None => Err(Reply(
                403,
                "no token (open the URL rendr view printed)".into(),
            )),
        }
    }

    /// Answers one request (never panics on what the client sends).
    pub fn handle(&self, mut rq: Request) {
        let resp = match self.admit(&rq).and_then(|()| self.route(&mut rq)) {
            Ok(r) => r,
            Err(Reply(status, msg)) => text(status, &msg),
        };
        // Always a Content-Length (never chunked), whatever the size.
        let resp = resp.with_chunked_threshold(usize::MAX);
        let _ = rq.respond(resp);
    }

    fn route(&self, rq: &mut Request) -> Result<Response<std::io::Cursor<Vec<u8>>>, Reply> {
        let path = rq.url().split('?').next().unwrap_or("").to_string();
        let asset = |body: &str, mime: &str| {
            Ok(Response::from_data(body.as_bytes().to_vec())
                .with_header(header("Content-Type", mime))
                .with_header(header("Cache-Control", "no-store")))
        };
        match (rq.method(), path.as_str()) {
            (Method::Get, "/") => asset(
                &PAGE.replace("TOKEN", &self.token),
                "text/html; charset=utf-8",
            ),
            (Method::Get, "/app.js") => asset(SCRIPT, "text/javascript; charset=utf-8"),
            (Method::Get, "/app.css") => asset(STYLE, "text/css; charset=utf-8"),
            (Method::Get, "/info") => {
                let json =
                    serde_json::to_vec(&self.info()).map_err(|e| Reply(500, e.to_string()))?;
                Ok(Response::from_data(json)
                    .with_header(header("Content-Type", "application/json")))
            }
            (Method::Post, "/render") => {
                let body = read_body(rq)?;
                let req: RenderRequest = serde_json::from_slice(&body)
                    .map_err(|e| Reply(400, format!("bad render request: {e}")))?;
                let (bytes, mime) = self.render(&req)?;
                Ok(Response::from_data(bytes)
                    .with_header(header("Content-Type", mime))
                    .with_header(header("Cache-Control", "no-store"))
                    .with_header(header("X-Rendr-Seq", &req.seq.to_string())))
            }
            (Method::Get | Method::Post, _) => Err(Reply(404, format!("no such page: {path}"))),
            _ => Err(Reply(405, "only GET and POST".into())),
        }
    }

    /// The page's first facts.
    pub fn info(&self) -> Info {
        Info {
            volume: self.path.clone(),
            sizes: self.vol.sizes(),
            voxel: self.vol.type_name(),
            range: self.range,
            hist: self.hist.clone(),
            words: self.words.clone(),
            corners: self.vol.view().world_corners(),
            lut_file: self.lut.as_ref().map(|l| l.0.clone()),
            lights_file: self.lights.as_ref().map(|l| l.0.clone()),
            lights: self.lights.as_ref().map(|l| l.1.clone()),
            lev_file: self.lev.as_ref().map(|l| l.0.clone()),
            max_threads: self.max_threads,
            max_side: MAX_SIDE,
        }
    }

    /// Renders one request into PNG (or NRRD) bytes.
    pub fn render(&self, req: &RenderRequest) -> Result<(Vec<u8>, &'static str), Reply> {
        let a = request_args(&req.args)?;
        let (params, kernel, threads) = crate::cmd::go::params(&a)?;
        let q = crate::cmd::go::quant_range(&a)?;
        let [w, h] = params.camera.size;
        if w > MAX_SIDE || h > MAX_SIDE {
            return Err(Reply(
                413,
                format!("-sz: {w} x {h} is larger than {MAX_SIDE} x {MAX_SIDE}"),
            ));
        }
        let threads = threads.clamp(1, self.max_threads);
        let lut = match &req.txf {
            Some(t) => Some(txf_lut(t)?),
            None => self.lut.as_ref().map(|l| l.1.clone()),
        };
        let lights = match (&req.lights, &self.lights) {
            (Some(t), _) => parse_lights(t)?,
            (None, Some((p, t))) => {
                parse_lights(t).map_err(|Reply(s, m)| Reply(s, format!("{p}: {m}")))?
            }
            (None, None) => Vec::new(),
        };
        let lev = self.lev.as_ref().map(|l| &l.1);
        let spec = rnd_core::render::RenderSpec::new(params, lut.as_ref(), lev, &lights)?;
        spec.check_volume(self.vol.sizes())?;
        let flag = self.begin(&req.client, req.seq)?;
        let control = rnd_std::parallel::Control::new().cancel_flag(&flag);
        let data = rnd_std::parallel::render_volume(&spec, &self.vol, kernel, threads, &control);
        self.end(&req.client, req.seq);
        let data = data.map_err(|e| match e.kind {
            rnd_std::ErrorKind::Cancelled => Reply(409, "cancelled by a newer request".into()),
            _ => Reply(400, e.to_string()),
        })?;
        let img = Image {
            data,
            channels: spec.channels(),
            size: [w as usize, h as usize],
        };
        match req.format.as_deref() {
            None | Some("png") => Ok((
                png_bytes(&img, q).map_err(|e| Reply(500, e.to_string()))?,
                "image/png",
            )),
            Some("nrrd") => {
                let mut n = rnd_std::nrrd::Nrrd::new(
                    vec![img.channels, img.size[0], img.size[1]],
                    rnd_std::nrrd::Data::F32(img.data),
                )
                .map_err(|e| Reply(500, e.to_string()))?;
                n.header.content = Some(format!("rendr go {}", req.args.join(" ")));
                let mut out = Vec::new();
                rnd_std::nrrd::write_to(&n, Default::default(), &mut out)
                    .map_err(|e| Reply(500, e.to_string()))?;
                Ok((out, "application/octet-stream"))
            }
            Some(f) => Err(Reply(400, format!("format \"{f}\" is not png or nrrd"))),
        }
    }

    /// Registers a render of request `seq` of `client`, cancelling that client's older
    /// ones; refused when a newer one already came.
    fn begin(&self, client: &str, seq: u64) -> Result<Arc<AtomicBool>, Reply> {
        if client.is_empty() || client.len() > 64 {
            return Err(Reply(400, "client id must be 1 to 64 characters".into()));
        }
        let mut run = self
            .running
            .lock()
            .map_err(|_| Reply(500, "lock poisoned".into()))?;
        if run.len() > 1024 && !run.contains_key(client) {
            run.retain(|_, (_, v)| !v.is_empty());
        }
        let entry = run.entry(client.to_string()).or_insert((0, Vec::new()));
        if seq < entry.0 {
            return Err(Reply(409, "superseded by a newer request".into()));
        }
        entry.0 = seq;
        for (s, f) in &entry.1 {
            if *s < seq {
                f.store(true, Ordering::Relaxed);
            }
        }
        let flag = Arc::new(AtomicBool::new(false));
        entry.1.push((seq, flag.clone()));
        Ok(flag)
    }

    fn end(&self, client: &str, seq: u64) {
        if let Ok(mut run) = self.running.lock() {
            if let Some(e) = run.get_mut(client) {
                e.1.retain(|(s, _)| *s != seq);
            }
        }
    }
}

/// The body of `rq`, at most [`MAX_BODY`] bytes.
fn read_body(rq: &mut Request) -> Result<Vec<u8>, Reply> {
    if rq.body_length().is_some_and(|n| n > MAX_BODY) {
        return Err(Reply(
            413,
            format!("request body larger than {MAX_BODY} bytes"),
        ));
    }
    let mut body = Vec::new();
    rq.as_reader()
        .take(MAX_BODY as u64 + 1)
        .read_to_end(&mut body)
        .map_err(|e| Reply(400, format!("reading the request: {e}")))?;
    if body.len() > MAX_BODY {
        return Err(Reply(
            413,
            format!("request body larger than {MAX_BODY} bytes"),
        ));
    }
    Ok(body)
}

/// Parses request words as `go` options, allowing only [`REQUEST_OPTS`].
pub fn request_args(words: &[String]) -> Result<Args, Reply> {
    if words.len() > 200 {
        return Err(Reply(413, "too many option words".into()));
    }
    for w in words {
        if w.starts_with('@') {
            return Err(Reply(
                400,
                format!("option files (\"{w}\") are not allowed here"),
            ));
        }
        if let Some(name) = w.strip_prefix('-') {
            let looks_option = name.chars().next().is_some_and(|c| c.is_ascii_alphabetic())
                && name.parse::<f64>().is_err();
            if looks_option && !REQUEST_OPTS.contains(&name) {
                return Err(Reply(
                    400,
                    format!("option -{name} is not allowed in a view request"),
                ));
            }
        }
    }
    let mut argv = vec!["-i".to_string(), "(view volume)".to_string()];
    argv.extend(words.iter().cloned());
    parse(&crate::cmd::go::SPEC, &argv).map_err(|e| Reply(400, e.to_string()))
}

/// The LUT `rendr lgen -i rgb alpha -mm lo hi -l len` makes of `t`.
pub fn txf_lut(t: &TxfRequest) -> Result<Lut, Reply> {
    if t.len == 0 || t.len > MAX_LUT {
        return Err(Reply(
            400,
            format!("LUT length {} must be in 1..={MAX_LUT}", t.len),
        ));
    }
    let load = |name: &str, text: &str| -> Result<Txf, Reply> {
        let n = rnd_std::nrrd::read_bytes(text.as_bytes(), Path::new("."))
            .map_err(|e| Reply(400, format!("{name}: {e}")))?;
        rnd_std::files::txf_from_nrrd(Path::new(name), n).map_err(|e| Reply(400, e.to_string()))
    };
    let c = load("rgb.txt", &t.rgb)?;
    let a = load("alpha.txt", &t.alpha)?;
    let lut = Lut::builder(t.mm[0], t.mm[1])
        .entries(t.len)
        .colour(&c)
        .opacity(&a)
        .build()?;
    Ok(lut)
}

/// Lights from the text of a lights file.
pub fn parse_lights(t: &str) -> Result<Vec<rnd_core::light::Light>, Reply> {
    let n = rnd_std::nrrd::read_bytes(t.as_bytes(), Path::new("."))
        .map_err(|e| Reply(400, format!("lights.txt: {e}")))?;
    rnd_std::files::lights_from_nrrd(Path::new("lights.txt"), n)
        .map_err(|e| Reply(400, e.to_string()))
}

/// A random token of 128 bits, in hex, from the system's generator.
pub fn random_token() -> anyhow::Result<String> {
    let mut b = [0u8; 16];
    std::fs::File::open("/dev/urandom")
        .and_then(|mut f| f.read_exact(&mut b))
        .context("reading /dev/urandom for the session token")?;
    Ok(b.iter().map(|x| format!("{x:02x}")).collect())
}

/// Histogram of the volume's values: 256 bins over [min, max] (NaN not counted).
pub fn histogram(vol: &rnd_std::volume_io::VolumeBuf) -> (Vec<u64>, (f64, f64)) {
    let (lo, hi) = vol.min_max();
    let mut h = vec![0u64; 256];
    let mut add = |v: f64| {
        if v.is_finite() && hi > lo {
            let i = ((v - lo) / (hi - lo) * 256.0) as usize;
            h[i.min(255)] += 1;
        }
    };
    match vol.data() {
        rnd_std::volume_io::Samples::F32(d) => d.iter().for_each(|&v| add(v as f64)),
        rnd_std::volume_io::Samples::I16(d) => d.iter().for_each(|&v| add(v as f64)),
    }
    (h, (lo, hi))
}

/// Serves `session` on `server` with `workers` threads until the process ends.
pub fn serve(server: tiny_http::Server, session: Session, workers: usize) -> anyhow::Result<()> {
    let server = Arc::new(server);
    let session = Arc::new(session);
    let mut handles = Vec::new();
    for _ in 0..workers.max(1) {
        let (server, session) = (server.clone(), session.clone());
        handles.push(std::thread::spawn(move || {
            while let Ok(rq) = server.recv() {
                session.handle(rq);
            }
        }));
    }
    for h in handles {
        if h.join().is_err() {
            bail!("a server thread stopped");
        }
    }
    Ok(())
}
