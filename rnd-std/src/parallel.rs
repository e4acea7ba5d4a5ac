//! Multi-threaded rendering: image rows are handed out in bands to scoped worker
//! threads, each with its own convolution state; every pixel is computed by the same
//! code whatever the thread count, so the output is bit-identical for every N (D13).

use std::io::{IsTerminal, Write};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

use rnd_core::kernel::{Kernel, KernelName};
use rnd_core::render::{dispatch, AnyVolume, ConvoTask, RenderSpec};
use rnd_core::skip::{SkipGrid, SkipPlan};
use rnd_core::volume::Volume;
use rnd_core::voxel::Voxel;

/// Rows per work unit.
const BAND: usize = 4;

/// Number of worker threads for `-nt` value `nt` (0 and 1 = the calling thread).
pub fn default_threads() -> usize {
    std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(1)
}

/// Renders the whole image with `threads` workers (≤ 1: on the calling thread); draws a
/// progress line on stderr when `progress` is set and stderr is a terminal.
///
/// # Errors
/// When the image needs more memory than this process may use ([`crate::mem_limit`])
/// or the system refuses it (checked before rendering starts).
pub fn render(
    spec: &RenderSpec<'_>,
    vol: AnyVolume<'_>,
    kernel: KernelName,
    threads: usize,
    progress: bool,
) -> crate::Result<Vec<f32>> {
    spec.check_volume(vol.sizes())?;
    let [w, h] = spec.size();
    let len = (w as u64)
        .checked_mul(h as u64)
        .and_then(|n| n.checked_mul(spec.channels() as u64))
        .filter(|&n| usize::try_from(n).is_ok())
        .ok_or_else(|| crate::Error::msg(format!("a {w} x {h} image is too large to address")))?;
    let what = format!(
        "a {w} x {h} image with {} channel{}",
        spec.channels(),
        if spec.channels() == 1 { "" } else { "s" }
    );
    crate::check_memory(len.saturating_mul(4), &what)?;
    let mut out: Vec<f32> = Vec::new();
    crate::try_reserve(&mut out, len as usize, &what)?;
    out.resize(len as usize, 0.0);
    struct Task<'s, 'a> {
        spec: &'s RenderSpec<'a>,
        threads: usize,
        progress: bool,
        out: Vec<f32>,
    }
    impl ConvoTask for Task<'_, '_> {
        type Output = Vec<f32>;
        fn run<V: Voxel, K: Kernel<S>, const S: usize>(self, vol: Volume<'_, V>) -> Vec<f32> {
            let spec = self.spec;
            let [w, h] = spec.size();
            let (w, h) = (w as usize, h as usize);
            let ch = spec.channels();
            let mut out = self.out;
            let t0 = Instant::now();
            let clock = || t0.elapsed().as_secs_f64() * 1000.0;
            let clock_ref: Option<&(dyn Fn() -> f64 + Sync)> = if spec.params().time {
                Some(&clock)
            } else {
                None
            };
            let show = self.progress && std::io::stderr().is_terminal();
            let done = AtomicUsize::new(0);
            let nbands = h.div_ceil(BAND);
            let report = |n: usize| {
                if show {
                    let mut e = std::io::stderr().lock();
                    let _ = write!(e, "\rrendr go: {:3}% ", 100 * n / nbands.max(1));
                    let _ = e.flush();
                }
            };
            // Bands of rows are handed out from one queue; with one thread the calling
            // thread drains it alone.
            let skip = spec
                .skip_plan(&vol, K::NAME)
                .map(|plan| build_skip_grid(plan, &vol, self.threads));
            let queue = Mutex::new(out.chunks_mut(w * ch * BAND).enumerate());
            let work = || loop {
                let next = queue.lock().map(|mut q| q.next()).unwrap_or(None);
                let Some((b, chunk)) = next else { break };
                let rows = (b * BAND) as u32..((b + 1) * BAND).min(h) as u32;
                spec.render_rows::<V, K, S>(
                    vol,
                    skip.as_ref(),
                    rows,
                    chunk,
                    clock_ref.map(|c| c as &dyn Fn() -> f64),
                );
                report(done.fetch_add(1, Ordering::Relaxed) + 1);
            };
            if self.threads <= 1 {
                work();
            } else {
                std::thread::scope(|s| {
                    for _ in 0..self.threads {
                        s.spawn(work);
                    }
                });
            }
            if show {
                eprint!("\r          \r");
            }
            out
        }
    }
    Ok(dispatch(
        vol,
        kernel,
        Task {
            spec,
            threads,
            progress,
            out,
        },
    ))
}

/// Builds the skip grid of `plan` with `threads` workers, each taking a run of whole
/// coarse slabs (the same grid as one thread builds).
pub fn build_skip_grid<V: Voxel>(
    plan: SkipPlan<'_>,
    vol: &Volume<'_, V>,
    threads: usize,
) -> SkipGrid {
    let n = plan.slabs();
    let t = threads.clamp(1, n.max(1));
    if t == 1 {
        return plan.build(vol);
    }
    let mut cells = plan.outputs();
    let ranges: Vec<std::ops::Range<usize>> = (0..t).map(|i| i * n / t..(i + 1) * n / t).collect();
    let parts = plan.split(&mut cells, &ranges);
    let plan_ref = &plan;
    std::thread::scope(|s| {
        for (r, part) in ranges.iter().cloned().zip(parts) {
            s.spawn(move || plan_ref.build_slabs(vol, r, part));
        }
    });
    plan.finish(cells)
}

#[cfg(test)]
mod tests {
    use super::build_skip_grid;
    use rnd_core::affine::Affine4;
    use rnd_core::kernel::KernelName;
    use rnd_core::skip::{SkipGrid, SkipKind, SkipPlan};
    use rnd_core::txf::Lut;
    use rnd_core::volume::Volume;

    /// Any number of workers builds the grid one thread builds, for sizes that are not
    /// multiples of the block sizes and slab counts that do not divide evenly.
    #[test]
    fn threaded_skip_grid_equals_one_thread() {
        let sizes = [37, 29, 45];
        let n = sizes[0] * sizes[1] * sizes[2];
        // Two blobs in an empty field, and some noise, so blocks of every kind occur.
        let data: Vec<f32> = (0..n)
            .map(|i| {
                let (x, y, z) = (i % 37, (i / 37) % 29, i / (37 * 29));
                let d1 =
                    (x as f32 - 9.0).powi(2) + (y as f32 - 8.0).powi(2) + (z as f32 - 10.0).powi(2);
                let d2 = (x as f32 - 28.0).powi(2)
                    + (y as f32 - 20.0).powi(2)
                    + (z as f32 - 36.0).powi(2);
                let noise = if (i * 7919) % 2003 == 0 {
                    0.5
                } else if i % 13 == 0 {
                    0.2
                } else {
                    0.0
                };
                (1.0 - d1 / 40.0).max(0.0) + (1.0 - d2 / 60.0).max(0.0) + noise
            })
            .collect();
        let itow = Affine4::from_columns([1., 0., 0.], [0., 1., 0.], [0., 0., 1.], [0.; 3]);
        let vol = Volume::new(&data, sizes, itow).unwrap();
        let e: Vec<[f32; 4]> = (0..64)
            .map(|i| [1.0, 1.0, 1.0, if i < 16 { 0.0 } else { 0.4 }])
            .collect();
        let lut = Lut::new(0.0, 1.0, e).unwrap();
        for k in [KernelName::Tent, KernelName::Bspln3, KernelName::C4hexic] {
            let one = SkipGrid::new(&vol, k, &lut);
            let ef = one.empty_fraction();
            assert!(ef > 0.0 && ef < 0.95, "{k:?}: {ef}");
            for t in 1..=7 {
                let many = build_skip_grid(SkipPlan::new(&vol, k, &lut), &vol, t);
                assert!(many == one, "{k:?} with {t} threads");
                for kind in [SkipKind::MaxValue, SkipKind::MaxGradMag] {
                    let plan = || SkipPlan::for_max(&vol, k, kind).expect("a max kind");
                    let one = plan().build(&vol);
                    let many = build_skip_grid(plan(), &vol, t);
                    assert!(many == one, "{k:?} {kind:?} with {t} threads");
                }
            }
        }
    }
}
