//! Cross-check of the convolution against Teem's `gprobe` (gage): values and world
//! gradients at random points of a real CT volume and of a rotated, sheared `sdg` volume.
//!
//! Known difference, not hidden: gage is happy to probe nearer the border than our
//! inside rule allows (it pads), so points are drawn where our kernel support is inside.

use std::path::Path;
use std::process::Command;

use rand_like::Lcg;
use rnd_core::convo::{Convo, ConvoSample, SecondOrder};
use rnd_core::kernel::{Kernel, KernelName};
use rnd_core::render::{dispatch, ConvoTask};
use rnd_core::sdg::{self, Grid};
use rnd_core::volume::Volume;
use rnd_core::voxel::Voxel;
use rnd_std::nrrd::{self, Centering, Data, Encoding, Nrrd, WriteOptions};

mod rand_like {
    /// A tiny deterministic generator for test points.
    pub struct Lcg(pub u64);
    impl Lcg {
        pub fn next(&mut self) -> f64 {
            self.0 = self
                .0
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (self.0 >> 11) as f64 / (1u64 << 53) as f64
        }
    }
}

/// World-space points to evaluate with value and gradient.
struct Many(Vec<[f64; 3]>);
impl ConvoTask for Many {
    type Output = Vec<ConvoSample>;
    fn run<V: Voxel, K: Kernel<S>, const S: usize>(self, vol: Volume<'_, V>) -> Self::Output {
        let mut c = Convo::<V, K, S>::new(vol);
        self.0.iter().map(|&p| c.eval_world(p, true)).collect()
    }
}

/// World-space points to evaluate to second order (f64).
struct Second(Vec<[f64; 3]>);
impl ConvoTask for Second {
    type Output = Vec<Option<SecondOrder>>;
    fn run<V: Voxel, K: Kernel<S>, const S: usize>(self, vol: Volume<'_, V>) -> Self::Output {
        let c = Convo::<V, K, S>::new(vol);
        self.0.iter().map(|&p| c.second_order_world(p)).collect()
    }
}

fn gprobe(vol: &Path, pts: &Path, q: &str, k: &str, out: &Path) -> Vec<f64> {
    // Teem has no `tentdd`. Tent's second derivative is 0 between its knots, which is
    // what gage's `zero` kernel gives: the Hessian's diagonal is 0 in both and its mixed
    // entries come from the first derivatives (`tentd` × `tentd`), so they agree.
    let k22 = if k == "tent" {
        "zero".to_string()
    } else {
        format!("{k}dd")
    };
    let o = Command::new("teem-gprobe")
        .args(["-i", vol.to_str().unwrap(), "-k", "scalar", "-q", q])
        .args(["-k00", k, "-k11", &format!("{k}d"), "-k22", &k22])
        .args(["-pi", pts.to_str().unwrap(), "-psi", "false"])
        .args(["-o", out.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "gprobe: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    nrrd::read(out).unwrap().data.to_f64()
}

fn check(name: &str, file: &Path, pts: Vec<[f64; 3]>, dir: &Path) {
    let vol = rnd_std::volume_io::load_volume(file).unwrap();
    let (lo, hi) = vol.min_max();
    let scale = hi.abs().max(lo.abs()).max(1e-12);
    let ptxt = dir.join(format!("{name}-pts.txt"));
    let lines: Vec<String> = pts
        .iter()
        .map(|p| format!("{} {} {}", p[0], p[1], p[2]))
        .collect();
    std::fs::write(&ptxt, lines.join("\n") + "\n").unwrap();
    for k in [
        KernelName::Tent,
        KernelName::Bspln3,
        KernelName::Ctmr,
        KernelName::C4hexic,
    ] {
        let ours = dispatch(vol.view(), k, Many(pts.clone()));
        let v = gprobe(file, &ptxt, "v", k.as_str(), &dir.join("v.nrrd"));
        let gv = gprobe(file, &ptxt, "gv", k.as_str(), &dir.join("gv.nrrd"));
        assert_eq!(v.len(), pts.len());
        let gscale = ours
            .iter()
            .map(|s| {
                s.grad_w
                    .iter()
                    .fold(0.0f64, |m, &g| m.max((g as f64).abs()))
            })
            .fold(0.0, f64::max)
            .max(1e-12);
        check_second(name, file, &ptxt, k, &vol, &pts, dir);
        for (i, s) in ours.iter().enumerate() {
            assert!(s.inside, "{name}: point {i} {:?} should be inside", pts[i]);
            assert!(
                (s.value as f64 - v[i]).abs() <= 1e-5 * scale,
                "{name} {k} point {i}: ours {} gage {}",
                s.value,
                v[i]
            );
            for c in 0..3 {
                let g = gv[3 * i + c];
                assert!(
                    (s.grad_w[c] as f64 - g).abs() <= 1e-5 * gscale + 1e-4 * g.abs(),
                    "{name} {k} point {i} grad[{c}]: ours {:?} gage {:?}",
                    s.grad_w,
                    &gv[3 * i..3 * i + 3]
                );
            }
        }
    }
}

/// The Hessian and the curvatures against gage's `hess`, `k1`, `k2`, `meancurv` and
/// `gausscurv`.
fn check_second(
    name: &str,
    file: &Path,
    ptxt: &Path,
    k: KernelName,
    vol: &rnd_std::volume_io::VolumeBuf,
    pts: &[[f64; 3]],
    dir: &Path,
) {
    let ours: Vec<SecondOrder> = dispatch(vol.view(), k, Second(pts.to_vec()))
        .into_iter()
        .map(|s| s.expect("inside"))
        .collect();
    let hess = gprobe(file, ptxt, "hess", k.as_str(), &dir.join("h.nrrd"));
    let k1 = gprobe(file, ptxt, "k1", k.as_str(), &dir.join("k1.nrrd"));
    let k2 = gprobe(file, ptxt, "k2", k.as_str(), &dir.join("k2.nrrd"));
    let mc = gprobe(file, ptxt, "meancurv", k.as_str(), &dir.join("mc.nrrd"));
    let gc = gprobe(file, ptxt, "gausscurv", k.as_str(), &dir.join("gc.nrrd"));
    let hscale = hess.iter().fold(0.0f64, |m, x| m.max(x.abs())).max(1e-12);
    let gscale = ours
        .iter()
        .map(|s| s.gradient.iter().fold(0.0f64, |m, g| m.max(g.abs())))
        .fold(0.0, f64::max);
    let mut compared = 0;
    for (i, s) in ours.iter().enumerate() {
        for (c, h) in s.hessian.iter().flatten().enumerate() {
            let want = hess[9 * i + c];
            assert!(
                (h - want).abs() <= 1e-5 * hscale,
                "{name} {k} point {i} hess[{c}]: ours {h} gage {want}"
            );
        }
        // gage computes in f32 here: agreement to its rounding.
        // Curvature is ill-conditioned where the gradient nearly vanishes; compare
        // where it is at least 5% of the largest.
        let g = s.gradient;
        if (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt() < 0.05 * gscale {
            continue;
        }
        compared += 1;
        let [a, b] = s.curvatures(0.0);
        let kscale = a.abs().max(b.abs()).max(k1[i].abs()).max(1e-12);
        assert!(
            (a - k1[i]).abs() <= 1e-4 * kscale && (b - k2[i]).abs() <= 1e-4 * kscale,
            "{name} {k} point {i}: kappa ours {a} {b} gage {} {}",
            k1[i],
            k2[i]
        );
        // Mean curvature (κ1 + κ2)/2 and Gaussian curvature κ1κ2, as go's probes
        // meancurv and gausscurv compute them.
        let (m, g) = (0.5 * (a + b), a * b);
        assert!(
            (m - mc[i]).abs() <= 1e-4 * kscale && (g - gc[i]).abs() <= 2e-4 * kscale * kscale,
            "{name} {k} point {i}: mean/Gaussian curvature ours {m} {g} gage {} {}",
            mc[i],
            gc[i]
        );
    }
    assert!(
        compared >= pts.len() / 2,
        "{name} {k}: only {compared} curvatures compared"
    );
}

#[test]
fn convolution_agrees_with_gprobe() {
    if !rnd_tests::teem("convolution_agrees_with_gprobe", "teem-gprobe") {
        return;
    }
    let dir = rnd_tests::tmpdir("gprobe");
    let mut rng = Lcg(12345);
    // 1. A rotated, sheared float volume from sdg (world-space probing).
    let grid = Grid {
        sizes: [30, 34, 38],
        lengths: [3.0, 3.5, 4.0],
        shear: [0.1, -0.2, 0.15],
        rot: [0.5, 0.6, -0.3],
        centre: [0.1, -0.1, 0.3],
    };
    let (vals, itow) = sdg::generate(12, &grid).unwrap();
    let mut n = Nrrd::new(
        grid.sizes.to_vec(),
        Data::F32(vals.iter().map(|&v| v as f32).collect()),
    )
    .unwrap();
    n.header.space = Some("left-posterior-superior".into());
    n.header.space_directions = Some((0..3).map(|c| Some(itow.column3(c).to_vec())).collect());
    n.header.space_origin = Some(itow.column3(3).to_vec());
    n.header.centerings = Some(vec![Centering::Cell; 3]);
    let f = dir.join("ml.nrrd");
    nrrd::write(
        &n,
        &f,
        WriteOptions {
            encoding: Encoding::Gzip,
            ..Default::default()
        },
    )
    .unwrap();
    let pts: Vec<[f64; 3]> = (0..40)
        .map(|_| {
            itow.point(std::array::from_fn(|a| {
                3.0 + rng.next() * (grid.sizes[a] as f64 - 7.0)
            }))
        })
        .collect();
    check("sdg-ml", &f, pts, &dir);
    // 2. The real CT volume (no spacing recorded: index = world).
    if let Some(ct) = rnd_tests::ct_in_space("convolution_agrees_with_gprobe (CT part)", &dir) {
        let sizes = [128.0, 128.0, 256.0];
        let pts: Vec<[f64; 3]> = (0..40)
            .map(|_| std::array::from_fn(|a| 3.0 + rng.next() * (sizes[a] - 7.0)))
            .collect();
        check("stent-ct", &ct, pts, &dir);
    }
}
