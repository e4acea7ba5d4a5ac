//! Helpers shared by rendr's cross-crate tests: where `../shared` is, whether Teem is
//! installed, and a naive reference convolution.
//!
//! Tests that need `../shared` or Teem call [`shared`] / [`teem`]: when the resource is
//! absent they print `skipped: ...` and return `None`, unless `RENDR_REQUIRE_SHARED=1` /
//! `RENDR_REQUIRE_TEEM=1` is set (CI), in which case absence is a failure.

use std::path::{Path, PathBuf};
use std::process::Command;

/// The workspace root.
pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("workspace root")
        .to_path_buf()
}

/// File `f` of the bundled `data/` directory.
pub fn data(f: &str) -> PathBuf {
    root().join("data").join(f)
}

fn required(var: &str) -> bool {
    std::env::var(var).is_ok_and(|v| v == "1")
}

/// `../shared` beside the repository root, or None (after printing "skipped").
pub fn shared(test: &str) -> Option<PathBuf> {
    let p = root().join("..").join("shared");
    if p.join("SPEC.md").exists() {
        return Some(p);
    }
    if required("RENDR_REQUIRE_SHARED") {
        panic!("{test}: ../shared is missing and RENDR_REQUIRE_SHARED=1");
    }
    eprintln!("skipped: {test}: ../shared is not present");
    None
}

/// Whether the Teem program `prog` (e.g. `teem-unu`) runs; prints "skipped" when not.
pub fn teem(test: &str, prog: &str) -> bool {
    let ok =
        Command::new(prog).arg("--version").output().is_ok() || Command::new(prog).output().is_ok();
    if ok {
        return true;
    }
    if required("RENDR_REQUIRE_TEEM") {
        panic!("{test}: {prog} is missing and RENDR_REQUIRE_TEEM=1 (apt-get install teem-apps)");
    }
    eprintln!("skipped: {test}: {prog} is not installed (apt-get install teem-apps)");
    false
}

/// A Python interpreter with the test-only writers (nibabel, SimpleITK, pydicom):
/// `$RENDR_PYTHON`, else `python3`; None (after printing "skipped") when it lacks them,
/// unless `RENDR_REQUIRE_WRITERS=1` (CI, whose `.ci/run` makes the environment).
pub fn writers(test: &str) -> Option<PathBuf> {
    let py = std::env::var_os("RENDR_PYTHON")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from("python3"));
    let ok = Command::new(&py)
        .args(["-c", "import nibabel, SimpleITK, pydicom, numpy"])
        .output()
        .is_ok_and(|o| o.status.success());
    if ok {
        return Some(py);
    }
    if required("RENDR_REQUIRE_WRITERS") {
        panic!(
            "{test}: {} lacks nibabel/SimpleITK/pydicom/numpy and RENDR_REQUIRE_WRITERS=1",
            py.display()
        );
    }
    eprintln!(
        "skipped: {test}: no Python with nibabel, SimpleITK, pydicom and numpy \
         (set RENDR_PYTHON; .ci/run makes one)"
    );
    None
}

/// A fresh temporary directory for one test.
pub fn tmpdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("rendr-test-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("create temp dir");
    d
}

/// Runs `prog args...`, panicking with its stderr when it fails; returns stdout.
pub fn run(prog: &str, args: &[&str]) -> String {
    let out = Command::new(prog)
        .args(args)
        .output()
        .unwrap_or_else(|e| panic!("{prog}: {e}"));
    assert!(
        out.status.success(),
        "{prog} {args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// Naive convolution: evaluates the kernel for every voxel of the support, no
/// separability, no caching, all in f64. Returns (inside, value, world gradient).
pub fn naive_convo<V: rnd_core::voxel::Voxel>(
    vol: &rnd_core::volume::Volume<'_, V>,
    k: rnd_core::kernel::KernelName,
    pos_w: [f64; 3],
) -> (bool, f64, [f64; 3]) {
    let x = vol.wtoi().point(pos_w);
    let s = k.support() as i64;
    let sizes = vol.sizes();
    let mut lo = [0i64; 3];
    for a in 0..3 {
        let n = if s % 2 == 0 {
            x[a].floor()
        } else {
            (x[a] + 0.5).floor()
        } as i64;
        lo[a] = n + k.lo() as i64;
        if lo[a] < 0 || lo[a] + s > sizes[a] as i64 {
            return (false, 0.0, [0.0; 3]);
        }
    }
    let (mut v, mut g) = (0.0, [0.0; 3]);
    for kk in lo[2]..lo[2] + s {
        for jj in lo[1]..lo[1] + s {
            for ii in lo[0]..lo[0] + s {
                let Some(d) = vol.get(ii as usize, jj as usize, kk as usize) else {
                    return (false, 0.0, [0.0; 3]);
                };
                let d = d.to_f32() as f64;
                let (dx, dy, dz) = (x[0] - ii as f64, x[1] - jj as f64, x[2] - kk as f64);
                let (kx, ky, kz) = (k.eval(dx, 0), k.eval(dy, 0), k.eval(dz, 0));
                v += d * kx * ky * kz;
                g[0] += d * k.eval(dx, 1) * ky * kz;
                g[1] += d * kx * k.eval(dy, 1) * kz;
                g[2] += d * kx * ky * k.eval(dz, 1);
            }
        }
    }
    let w = vol.wtoi();
    let gw = [
        w.at(0, 0) * g[0] + w.at(1, 0) * g[1] + w.at(2, 0) * g[2],
        w.at(0, 1) * g[0] + w.at(1, 1) * g[1] + w.at(2, 1) * g[2],
        w.at(0, 2) * g[0] + w.at(1, 2) * g[1] + w.at(2, 2) * g[2],
    ];
    (true, v, gw)
}

/// A copy of `../shared`'s CT (which records no spacing, so world = index for us) with
/// identity space directions and origin, written to `dir`: Teem's gage needs an
/// orientation to put the same world frame on it. None (after "skipped") without
/// `../shared`.
pub fn ct_in_space(test: &str, dir: &Path) -> Option<PathBuf> {
    use rnd_std::nrrd::{self, Centering, Encoding, WriteOptions};
    let sh = shared(test)?;
    let mut n = nrrd::read(&sh.join("volumes/imageio-stent-ct.nrrd")).expect("read the CT");
    n.header.space = Some("left-posterior-superior".into());
    n.header.space_directions = Some(
        (0..3)
            .map(|a| Some((0..3).map(|c| f64::from(u8::from(a == c))).collect()))
            .collect(),
    );
    n.header.space_origin = Some(vec![0.0; 3]);
    n.header.centerings = Some(vec![Centering::Cell; 3]);
    let ct = dir.join("ct.nrrd");
    nrrd::write(
        &n,
        &ct,
        WriteOptions {
            encoding: Encoding::Gzip,
            ..Default::default()
        },
    )
    .expect("write the CT copy");
    Some(ct)
}

/// Casts the ray through pixel `px` of `spec` over `vol` with `kernel` in the
/// one-sample loop and returns every sample the trace saw.
pub fn trace(
    spec: &rnd_core::render::RenderSpec<'_>,
    vol: rnd_core::render::AnyVolume<'_>,
    kernel: rnd_core::kernel::KernelName,
    px: [u32; 2],
) -> Vec<rnd_core::march::SampleInfo> {
    let mut all = Vec::new();
    let mut cb = |s: &rnd_core::march::SampleInfo| all.push(*s);
    let mut out = [0.0f32; rnd_core::blend::MAX_CHANNELS];
    let [h, v] = px;
    spec.cast(
        vol,
        kernel,
        h,
        v,
        &mut out,
        rnd_core::march::Loop::OneSample,
        Some(&mut cb),
    )
    .expect("a pixel of the image");
    all
}
