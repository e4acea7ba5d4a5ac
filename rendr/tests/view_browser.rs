//! `rendr view` in a real browser (Debian's chromium through chromedriver, driven over
//! WebDriver by fantoccini): the first picture is drawn, dragging orbits, moving a
//! transfer-function point changes the picture, and the command the page prints, run
//! with the files it offers, writes the page's full picture byte for byte.
//!
//! Skipped (with a "skipped:" line) without chromedriver and chromium, unless
//! `RENDR_REQUIRE_BROWSER=1` (CI, whose `.ci/run` installs them). With
//! `RENDR_VIEW_SCREENSHOT=file.png` it also saves a screenshot of the page (README).

use std::io::{BufRead, BufReader};
use std::net::{TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use fantoccini::actions::{InputSource, MouseActions, PointerAction, MOUSE_BUTTON_LEFT};
use fantoccini::{Client, ClientBuilder, Locator};
use serde_json::{json, Value};

const RENDR: &str = env!("CARGO_BIN_EXE_rendr");

/// A child process killed when dropped.
struct Kill(Child);

impl Drop for Kill {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn which(prog: &str) -> Option<PathBuf> {
    std::env::var_os("PATH").and_then(|p| {
        std::env::split_paths(&p)
            .map(|d| d.join(prog))
            .find(|f| f.is_file())
    })
}

/// chromedriver and the browser, or None after printing "skipped".
fn browser() -> Option<(PathBuf, PathBuf)> {
    let driver = which("chromedriver");
    let chrome = which("chromium").or_else(|| which("chromium-browser"));
    match (driver, chrome) {
        (Some(d), Some(c)) => Some((d, c)),
        _ if std::env::var("RENDR_REQUIRE_BROWSER").is_ok_and(|v| v == "1") => {
            panic!("chromium and chromedriver are missing and RENDR_REQUIRE_BROWSER=1 (apt-get install chromium chromium-driver)")
        }
        _ => {
            eprintln!("skipped: view_browser: chromium/chromedriver not installed (apt-get install chromium chromium-driver)");
            None
        }
    }
}

fn free_port() -> u16 {
    TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .map(|a| a.port())
        .expect("a free port")
}

/// The page's picture: whether it is the full one, its request number and a digest of
/// its pixels (with how many bytes are not zero).
async fn picture(c: &Client) -> (bool, u64, u64, u64) {
    let v = c
        .execute(
            "const c = document.getElementById('image');
             const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
             let h = 0, nz = 0;
             for (let i = 0; i < d.length; i++) { h = (h * 31 + d[i]) >>> 0; if (d[i] && i % 4 != 3) nz++; }
             return [c.dataset.full === '1', Number(c.dataset.seq || 0), h, nz];",
            vec![],
        )
        .await
        .expect("reading the canvas");
    let a = v.as_array().expect("an array");
    (
        a[0].as_bool().unwrap_or(false),
        a[1].as_u64().unwrap_or(0),
        a[2].as_u64().unwrap_or(0),
        a[3].as_u64().unwrap_or(0),
    )
}

/// Waits for a full picture newer than request `after`; returns its digest.
async fn full_after(c: &Client, after: u64) -> (u64, u64, u64) {
    let t0 = Instant::now();
    loop {
        let (full, seq, h, nz) = picture(c).await;
        if full && seq > after {
            return (seq, h, nz);
        }
        if t0.elapsed() > Duration::from_secs(60) {
            let st = c
                .execute(
                    "return document.getElementById('status').textContent",
                    vec![],
                )
                .await
                .unwrap_or(Value::Null);
            panic!("no full picture after request {after} within 60 s (status: {st})");
        }
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
}

/// A drag with the left button from `(x, y)` (offsets from the element's centre) by
/// `(dx, dy)` in `steps` moves.
async fn drag(c: &Client, id: &str, (x, y): (f64, f64), (dx, dy): (f64, f64), steps: u32) {
    let el = c.find(Locator::Id(id)).await.expect("the element");
    let mut m = MouseActions::new("mouse".into())
        .then(PointerAction::MoveToElement {
            element: el,
            duration: None,
            x,
            y,
        })
        .then(PointerAction::Down {
            button: MOUSE_BUTTON_LEFT,
        });
    for _ in 0..steps {
        m = m.then(PointerAction::MoveBy {
            duration: Some(Duration::from_millis(30)),
            x: dx / steps as f64,
            y: dy / steps as f64,
        });
    }
    m = m.then(PointerAction::Up {
        button: MOUSE_BUTTON_LEFT,
    });
    c.perform_actions(m).await.expect("the drag");
}

async fn session(c: &Client, url: &str, dir: &Path) {
    c.goto(url).await.expect("the page loads");
    // The first full picture is drawn, and it is not empty.
    let (s1, h1, nz1) = full_after(c, 0).await;
    assert!(
        nz1 > 1000,
        "the first picture is nearly black ({nz1} bytes lit)"
    );
    if let Some(shot) = std::env::var_os("RENDR_VIEW_SCREENSHOT") {
        let img = c.screenshot().await.expect("a screenshot");
        std::fs::write(shot, img).expect("writing the screenshot");
    }
    // Dragging on the picture orbits: a new full picture, different.
    drag(c, "image", (0.0, 0.0), (60.0, 15.0), 6).await;
    let (s2, h2, _) = full_after(c, s1).await;
    assert_ne!(h1, h2, "orbiting did not change the picture");
    // Moving the third opacity point down (from 0.6 to about 0.2) changes the picture.
    let alpha0 = c
        .execute("return txfText().alpha", vec![])
        .await
        .expect("txfText");
    let (x, y) = {
        let v = c
            .execute(
                "const p = txf.alpha[2]; return [txfX(p[0]) - 256, (160 - p[1] * 160) - 80];",
                vec![],
            )
            .await
            .expect("a point");
        (v[0].as_f64().unwrap(), v[1].as_f64().unwrap())
    };
    drag(c, "txf", (x, y), (0.0, 64.0), 4).await;
    let (s3, h3, _) = full_after(c, s2).await;
    let alpha1 = c
        .execute("return txfText().alpha", vec![])
        .await
        .expect("txfText");
    assert_ne!(alpha0, alpha1, "the opacity points did not move");
    assert_ne!(h2, h3, "moving an opacity point did not change the picture");
    let _ = s3;
    // Copy the command (the page's button), then take it and the files the page offers.
    c.find(Locator::Id("copy"))
        .await
        .expect("the copy button")
        .click()
        .await
        .expect("click");
    let got = c
        .execute_async(
            "const done = arguments[arguments.length - 1];
             const text = async (id) => (await fetch(document.getElementById(id).href)).text();
             (async () => {
               const png = await (await fetch(document.getElementById('dl-png').href)).arrayBuffer();
               done({
                 command: document.getElementById('command').value,
                 drawn: document.getElementById('image').dataset.command,
                 rgb: await text('dl-rgb'), alpha: await text('dl-alpha'),
                 lights: await text('dl-lights'), png: Array.from(new Uint8Array(png)),
               });
             })().catch((e) => done({ error: String(e) }));",
            vec![],
        )
        .await
        .expect("the command and files");
    assert!(got.get("error").is_none(), "{got}");
    let command = got["command"].as_str().expect("the command").to_string();
    assert_eq!(
        Some(command.as_str()),
        got["drawn"].as_str(),
        "the command is the full picture's"
    );
    for f in ["rgb", "alpha", "lights"] {
        std::fs::write(dir.join(format!("{f}.txt")), got[f].as_str().unwrap()).unwrap();
    }
    let png: Vec<u8> = got["png"]
        .as_array()
        .expect("png bytes")
        .iter()
        .map(|b| b.as_u64().unwrap() as u8)
        .collect();
    // Run it, as printed, with this build's binary.
    let script = command
        .replace("rendr lgen ", &format!("'{RENDR}' lgen "))
        .replace("rendr go ", &format!("'{RENDR}' go "));
    let out = Command::new("sh")
        .args(["-c", &script])
        .current_dir(dir)
        .output()
        .expect("sh");
    assert!(
        out.status.success(),
        "{command}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let cli = std::fs::read(dir.join("rendr.png")).expect("rendr.png");
    assert!(
        cli == png,
        "rendr go's PNG ({} bytes) differs from the page's full picture ({} bytes)\n{command}",
        cli.len(),
        png.len()
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_page_orbits_edits_and_prints_the_exact_command() {
    let Some((driver, chrome)) = browser() else {
        return;
    };
    let dir = std::env::temp_dir().join(format!("rendr-test-{}-browser", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    // The viewer, on the bundled head: lit `over`, a small picture.
    let mut child = Command::new(RENDR)
        .arg("view")
        .arg(rnd_tests::data("itk-t1-head.nrrd"))
        .args([
            "-port", "0", "-p", "rgbalit", "-b", "over", "-s", "1", "-us", "2",
        ])
        .arg("-sz")
        .args(match std::env::var_os("RENDR_VIEW_SCREENSHOT") {
            Some(_) => ["380", "380"],
            None => ["160", "120"],
        })
        .args(["-nt", "2"])
        .args([
            "-fr", "323", "-12.5", "260", "-at", "-127", "-162.5", "110", "-up", "0", "0", "1",
        ])
        .args(["-nc", "-150", "-fc", "150", "-fov", "30"])
        .arg("-lit")
        .arg(rnd_tests::data("head-lights.txt"))
        .stdout(Stdio::piped())
        .spawn()
        .expect("rendr view");
    let mut line = String::new();
    BufReader::new(child.stdout.take().unwrap())
        .read_line(&mut line)
        .unwrap();
    let _viewer = Kill(child);
    let url = line
        .trim()
        .strip_prefix("rendr view: ")
        .expect("the URL")
        .to_string();
    // chromedriver on a free port.
    let port = free_port();
    let _driver = Kill(
        Command::new(&driver)
            .arg(format!("--port={port}"))
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("chromedriver"),
    );
    let t0 = Instant::now();
    while TcpStream::connect(("127.0.0.1", port)).is_err() {
        assert!(
            t0.elapsed() < Duration::from_secs(20),
            "chromedriver did not start"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
    let caps = json!({
        "goog:chromeOptions": {
            "binary": chrome,
            "args": ["--headless=new", "--no-sandbox", "--disable-gpu",
                     "--disable-dev-shm-usage", "--window-size=1200,900"]
        }
    });
    let caps = caps.as_object().unwrap().clone();
    let c = ClientBuilder::new(hyper_util::client::legacy::connect::HttpConnector::new())
        .capabilities(caps)
        .connect(&format!("http://127.0.0.1:{port}"))
        .await
        .expect("a WebDriver session");
    // Close the browser whatever happens, then report.
    let r = tokio::spawn({
        let c = c.clone();
        let dir = dir.clone();
        async move { session(&c, &url, &dir).await }
    })
    .await;
    let _ = c.close().await;
    if let Err(e) = r {
        std::panic::resume_unwind(e.into_panic());
    }
    let _ = std::fs::remove_dir_all(&dir);
}
