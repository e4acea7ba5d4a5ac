//! `rendr view`'s server without a browser: its security rules (token, Host, Origin,
//! sizes, options that would name files) and that a render request gives the bytes of
//! the `rendr lgen` + `rendr go` commands the page prints for it.

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::process::{Child, Command, Stdio};

const RENDR: &str = env!("CARGO_BIN_EXE_rendr");

/// A running `rendr view`, killed when dropped.
struct Viewer {
    child: Child,
    addr: String,
    token: String,
}

impl Drop for Viewer {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn start(extra: &[&str]) -> Viewer {
    let mut child = Command::new(RENDR)
        .arg("view")
        .arg(rnd_tests::data("itk-t1-head.nrrd"))
        .args(["-port", "0"])
        .args(extra)
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .expect("rendr view starts");
    let mut line = String::new();
    BufReader::new(child.stdout.take().expect("stdout"))
        .read_line(&mut line)
        .expect("the URL line");
    let url = line
        .trim()
        .strip_prefix("rendr view: http://")
        .unwrap_or_else(|| panic!("unexpected first line {line:?}"));
    let (addr, token) = url.split_once("/?t=").expect("address and token");
    Viewer {
        child,
        addr: addr.to_string(),
        token: token.to_string(),
    }
}

/// Sends a raw request (adds Connection: close) and returns (status, body).
fn send(addr: &str, head: &str, body: &[u8]) -> (u16, Vec<u8>) {
    let mut s = TcpStream::connect(addr).expect("connect");
    let req = format!(
        "{head}\r\nContent-Length: {}\r\nConnection: close\r\n\r\n",
        body.len()
    );
    s.write_all(req.as_bytes()).unwrap();
    // The server may answer (and close) before reading a refused body.
    let _ = s.write_all(body);
    let mut out = Vec::new();
    let _ = s.read_to_end(&mut out);
    let text_end = out
        .windows(4)
        .position(|w| w == b"\r\n\r\n")
        .expect("a response head");
    let status_line = String::from_utf8_lossy(&out[..text_end]).to_string();
    let status: u16 = status_line
        .split_whitespace()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| panic!("bad status line {status_line:?}"));
    (status, out[text_end + 4..].to_vec())
}

fn get(v: &Viewer, path: &str, headers: &str) -> (u16, Vec<u8>) {
    let head = format!("GET {path} HTTP/1.1\r\nHost: {}{headers}", v.addr);
    send(&v.addr, &head, b"")
}

fn post(v: &Viewer, body: &str, headers: &str) -> (u16, Vec<u8>) {
    post_to(&v.addr, &v.token, body, headers)
}

fn post_to(addr: &str, token: &str, body: &str, headers: &str) -> (u16, Vec<u8>) {
    let head = format!(
        "POST /render?t={token} HTTP/1.1\r\nHost: {addr}\r\nContent-Type: application/json{headers}"
    );
    send(addr, &head, body.as_bytes())
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

fn json_str(s: &str) -> String {
    let mut o = String::from("\"");
    for c in s.chars() {
        match c {
            '"' => o.push_str("\\\""),
            '\\' => o.push_str("\\\\"),
            '\n' => o.push_str("\\n"),
            c => o.push(c),
        }
    }
    o.push('"');
    o
}

fn render_body(seq: u64, args: &[&str], txf: Option<(&str, &str)>, lights: Option<&str>) -> String {
    let args: Vec<String> = args.iter().map(|a| json_str(a)).collect();
    let txf = match txf {
        Some((rgb, alpha)) => format!(
            "{{\"rgb\":{},\"alpha\":{},\"mm\":[0,255],\"len\":256}}",
            json_str(rgb),
            json_str(alpha)
        ),
        None => "null".into(),
    };
    let lights = lights.map_or("null".into(), json_str);
    format!(
        "{{\"client\":\"test\",\"seq\":{seq},\"args\":[{}],\"txf\":{txf},\"lights\":{lights}}}",
        args.join(",")
    )
}

const MIP: &[&str] = &[
    "-k", "tent", "-p", "v", "-b", "max", "-s", "1", "-sz", "40", "30", "-nt", "1", "-fr", "323",
    "-12.5", "260", "-at", "-127", "-162.5", "110", "-up", "0", "0", "1", "-nc", "-150", "-fc",
    "150", "-fov", "30",
];

#[test]
fn every_request_needs_the_token_and_this_server_as_host_and_origin() {
    let v = start(&[]);
    let t = &v.token;
    // The page, its assets and the volume's facts, with the token.
    for p in ["/", "/app.js", "/app.css", "/info"] {
        let (s, body) = get(&v, &format!("{p}?t={t}"), "");
        assert_eq!(s, 200, "{p}: {}", text(&body));
    }
    let (_, page) = get(&v, &format!("/?t={t}"), "");
    assert!(
        text(&page).contains(&format!("app.js?t={t}")),
        "the page carries the token"
    );
    let (_, info) = get(&v, &format!("/info?t={t}"), "");
    let info = text(&info);
    assert!(info.contains("\"sizes\":[128,128,62]"), "{info}");
    assert!(info.contains("\"range\":[0.0,255.0]"), "{info}");
    // The token in a header serves too.
    let (s, _) = get(&v, "/info", &format!("\r\nX-Rendr-Token: {t}"));
    assert_eq!(s, 200);
    // No token, a wrong one, one of the right length but wrong.
    let wrong = "0".repeat(t.len());
    for q in [
        "/info".to_string(),
        "/info?t=abc".into(),
        format!("/info?t={wrong}"),
        "/".into(),
    ] {
        let (s, body) = get(&v, &q, "");
        assert_eq!(s, 403, "{q}: {}", text(&body));
        assert!(text(&body).contains("token"), "{}", text(&body));
    }
    // A foreign Host (DNS rebinding) and a foreign Origin (another site's page).
    let head = format!("GET /info?t={t} HTTP/1.1\r\nHost: attacker.example:80");
    let (s, body) = send(&v.addr, &head, b"");
    assert_eq!(s, 403);
    assert!(text(&body).contains("Host"), "{}", text(&body));
    let (s, body) = get(
        &v,
        &format!("/info?t={t}"),
        "\r\nOrigin: http://attacker.example",
    );
    assert_eq!(s, 403);
    assert!(text(&body).contains("Origin"), "{}", text(&body));
    let (s, _) = get(
        &v,
        &format!("/info?t={t}"),
        &format!("\r\nOrigin: http://{}", v.addr),
    );
    assert_eq!(s, 200, "the page's own origin");
    // Nothing but the page, its assets, info and render: no file paths.
    for p in [
        "/../data/head.txt",
        "/etc/passwd",
        "/data/itk-t1-head.nrrd",
        "/render",
    ] {
        let (s, _) = get(&v, &format!("{p}?t={t}"), "");
        assert_eq!(s, 404, "{p}");
    }
    let head = format!("DELETE /info?t={t} HTTP/1.1\r\nHost: {}", v.addr);
    assert_eq!(send(&v.addr, &head, b"").0, 405);
}

#[test]
fn bad_render_requests_get_4xx_with_a_message() {
    let v = start(&[]);
    // A good one first: the server works.
    let (s, png) = post(&v, &render_body(1, MIP, None, None), "");
    assert_eq!(s, 200, "{}", text(&png));
    assert_eq!(&png[1..4], b"PNG");
    // Options that name files or outputs, and option files.
    for bad in [
        &["-lut", "/etc/passwd"][..],
        &["-lit", "data/head-lights.txt"],
        &["-lev", "x.txt"],
        &["-i", "/etc/passwd"],
        &["-o", "/tmp/x.png"],
        &["-db", "1", "1"],
        &["@/etc/passwd"],
    ] {
        let mut args = MIP.to_vec();
        args.extend_from_slice(bad);
        let (s, body) = post(&v, &render_body(2, &args, None, None), "");
        assert_eq!(s, 400, "{bad:?}: {}", text(&body));
        assert!(
            text(&body).contains("not allowed"),
            "{bad:?}: {}",
            text(&body)
        );
    }
    // Bad values: the go parser's messages, naming the option.
    let mut args = MIP.to_vec();
    args[1] = "nokernel";
    let (s, body) = post(&v, &render_body(3, &args, None, None), "");
    assert_eq!(s, 400);
    assert!(text(&body).contains("nokernel"), "{}", text(&body));
    // A quantization range go refuses is refused here too, before any render.
    for q in [["5", "1"], ["0", "NaN"]] {
        let mut args = MIP.to_vec();
        args.extend_from_slice(&["-q", q[0], q[1]]);
        let (s, body) = post(&v, &render_body(3, &args, None, None), "");
        assert_eq!(s, 400, "-q {q:?}: {}", text(&body));
        assert!(
            text(&body).contains("-q: need finite min < max"),
            "{}",
            text(&body)
        );
    }
    // Too large an image, too large a body, malformed JSON, an unknown field.
    let mut args = MIP.to_vec();
    (args[9], args[10]) = ("4096", "4096");
    let (s, body) = post(&v, &render_body(4, &args, None, None), "");
    assert_eq!(s, 413, "{}", text(&body));
    let big = format!("{{\"pad\":\"{}\"}}", "x".repeat(300 << 10));
    assert_eq!(post(&v, &big, "").0, 413);
    assert_eq!(post(&v, "{not json", "").0, 400);
    let (s, body) = post(
        &v,
        "{\"client\":\"a\",\"seq\":1,\"args\":[],\"evil\":1}",
        "",
    );
    assert_eq!(s, 400, "{}", text(&body));
    // A colour probe without a transfer function or lights: the library's message.
    let mut args = MIP.to_vec();
    args[3] = "rgbalit";
    let (s, body) = post(&v, &render_body(5, &args, None, None), "");
    assert_eq!(s, 400, "{}", text(&body));
    // A bad control-point text names its file.
    let (s, body) = post(
        &v,
        &render_body(
            6,
            &args,
            Some(("#space:=rgb\n0 1 1\n", "#space:=alpha\n0 0\n1 1\n")),
            None,
        ),
        "",
    );
    assert_eq!(s, 400);
    assert!(text(&body).contains("rgb.txt"), "{}", text(&body));
    // An older request than one already seen from the same client is refused.
    assert_eq!(post(&v, &render_body(10, MIP, None, None), "").0, 200);
    assert_eq!(post(&v, &render_body(9, MIP, None, None), "").0, 409);
    // The server is still up.
    assert_eq!(post(&v, &render_body(11, MIP, None, None), "").0, 200);
}

#[test]
fn a_render_request_gives_the_bytes_of_its_commands() {
    let v = start(&[]);
    let dir = std::env::temp_dir().join(format!("rendr-test-{}-view", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let rgb = std::fs::read_to_string(rnd_tests::data("skin-rgb.txt")).unwrap();
    let alpha = std::fs::read_to_string(rnd_tests::data("skin-alpha.txt")).unwrap();
    let lights = std::fs::read_to_string(rnd_tests::data("head-lights.txt")).unwrap();
    let args: Vec<&str> = [
        "-k", "bspln3", "-p", "rgbalit", "-b", "over", "-s", "1", "-us", "2", "-sz", "64", "48",
        "-nt", "2", "-fr", "323", "-12.5", "260", "-at", "-127", "-162.5", "110", "-up", "0", "0",
        "1", "-nc", "-150", "-fc", "150", "-fov", "30",
    ]
    .to_vec();
    let (s, png) = post(
        &v,
        &render_body(1, &args, Some((&rgb, &alpha)), Some(&lights)),
        "",
    );
    assert_eq!(s, 200, "{}", text(&png));
    // The commands the page prints for it, run with the files it offers.
    std::fs::write(dir.join("rgb.txt"), &rgb).unwrap();
    std::fs::write(dir.join("alpha.txt"), &alpha).unwrap();
    std::fs::write(dir.join("lights.txt"), &lights).unwrap();
    let ok = |c: &mut Command| assert!(c.current_dir(&dir).status().unwrap().success());
    ok(Command::new(RENDR).args([
        "lgen",
        "-i",
        "rgb.txt",
        "alpha.txt",
        "-mm",
        "0",
        "255",
        "-l",
        "256",
        "-o",
        "lut.nrrd",
    ]));
    ok(Command::new(RENDR)
        .args(["go", "-i"])
        .arg(rnd_tests::data("itk-t1-head.nrrd"))
        .args(["-lut", "lut.nrrd", "-lit", "lights.txt"])
        .args(&args)
        .args(["-o", "rendr.png"]));
    let cli = std::fs::read(dir.join("rendr.png")).unwrap();
    assert!(cli == png, "the viewer's PNG differs from rendr go's");
    // NRRD: the same floats as go's NRRD.
    let body = render_body(2, &args, Some((&rgb, &alpha)), Some(&lights))
        .replace("\"lights\":", "\"format\":\"nrrd\",\"lights\":");
    let (s, nrrd) = post(&v, &body, "");
    assert_eq!(s, 200, "{}", text(&nrrd));
    std::fs::write(dir.join("view.nrrd"), &nrrd).unwrap();
    ok(Command::new(RENDR)
        .args(["go", "-i"])
        .arg(rnd_tests::data("itk-t1-head.nrrd"))
        .args(["-lut", "lut.nrrd", "-lit", "lights.txt"])
        .args(&args)
        .args(["-o", "go.nrrd"]));
    let floats = |f: &str| {
        let b = std::fs::read(dir.join(f)).unwrap();
        let at = b
            .windows(2)
            .position(|w| w == b"\n\n")
            .expect("a NRRD header")
            + 2;
        b[at..].to_vec()
    };
    assert!(floats("view.nrrd") == floats("go.nrrd"), "NRRD data differ");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_command_lines_fail_before_serving() {
    let out = Command::new(RENDR)
        .args(["view", "/nonexistent/vol.nrrd"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = text(&out.stderr);
    assert!(err.contains("/nonexistent/vol.nrrd"), "{err}");
    let out = Command::new(RENDR)
        .arg("view")
        .arg(rnd_tests::data("itk-t1-head.nrrd"))
        .args(["-fr", "1", "2", "3"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(text(&out.stderr).contains("-fov"), "{}", text(&out.stderr));
    let out = Command::new(RENDR)
        .arg("view")
        .arg(rnd_tests::data("itk-t1-head.nrrd"))
        .args(["-k", "wobbly"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(
        text(&out.stderr).contains("wobbly"),
        "{}",
        text(&out.stderr)
    );
}

#[test]
fn the_command_line_lut_and_lights_serve_requests_without_their_own() {
    let (lut, lit) = (
        rnd_tests::data("head-lut.nrrd"),
        rnd_tests::data("head-lights.txt"),
    );
    let v = start(&["-lut", lut.to_str().unwrap(), "-lit", lit.to_str().unwrap()]);
    let (_, info) = get(&v, &format!("/info?t={}", v.token), "");
    let info = text(&info);
    let lut = rnd_tests::data("head-lut.nrrd").canonicalize().unwrap();
    assert!(
        info.contains(&format!("\"lut_file\":\"{}\"", lut.display())),
        "the LUT is named absolutely: {info}"
    );
    let mut args = MIP.to_vec();
    (args[1], args[3], args[5]) = ("bspln3", "rgbalit", "over");
    let (s, png) = post(&v, &render_body(1, &args, None, None), "");
    assert_eq!(s, 200, "{}", text(&png));
    let dir = std::env::temp_dir().join(format!("rendr-test-{}-view-lut", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let st = Command::new(RENDR)
        .args(["go", "-i"])
        .arg(rnd_tests::data("itk-t1-head.nrrd"))
        .arg("-lut")
        .arg(&lut)
        .arg("-lit")
        .arg(rnd_tests::data("head-lights.txt"))
        .args(&args)
        .arg("-o")
        .arg(dir.join("go.png"))
        .status()
        .unwrap();
    assert!(st.success());
    assert!(std::fs::read(dir.join("go.png")).unwrap() == png);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_newer_request_cancels_an_older_render_under_way() {
    let v = start(&[]);
    // A slow render (about 1.4 G samples unskipped on one thread), then a newer request.
    let mut slow = MIP.to_vec();
    (slow[7], slow[9], slow[10]) = ("0.2", "1024", "1024");
    slow.extend_from_slice(&["-ess", "false"]);
    let (addr, token) = (v.addr.clone(), v.token.clone());
    let body = render_body(1, &slow, None, None);
    let t0 = std::time::Instant::now();
    let first = std::thread::spawn(move || (post_to(&addr, &token, &body, ""), t0.elapsed()));
    std::thread::sleep(std::time::Duration::from_millis(400));
    let (s, _) = post(&v, &render_body(2, MIP, None, None), "");
    assert_eq!(s, 200);
    let ((s, body), took) = first.join().unwrap();
    assert_eq!(s, 409, "{}", text(&body));
    // Stopped while rendering (not refused on arrival: it came first).
    assert!(text(&body).contains("cancelled"), "{}", text(&body));
    assert!(took.as_secs_f64() < 10.0, "cancelled only after {took:?}");
}
