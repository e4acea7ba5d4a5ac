//! Multi-threaded rendering: image rows are handed out in bands to scoped worker
//! threads, each with its own convolution state; every pixel is computed by the same
//! code whatever the thread count, so the output is bit-identical for every N (D13).

use std::io::{IsTerminal, Write};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

use rnd_core::convo::Convo;
use rnd_core::kernel::{Kernel, KernelName};
use rnd_core::render::{dispatch, AnyVolume, ConvoTask, RenderSpec};
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
pub fn render(
    spec: &RenderSpec<'_>,
    vol: AnyVolume<'_>,
    kernel: KernelName,
    threads: usize,
    progress: bool,
) -> Vec<f32> {
    struct Task<'s, 'a> {
        spec: &'s RenderSpec<'a>,
        threads: usize,
        progress: bool,
    }
    impl ConvoTask for Task<'_, '_> {
        type Output = Vec<f32>;
        fn run<V: Voxel, K: Kernel<S>, const S: usize>(self, vol: Volume<'_, V>) -> Vec<f32> {
            let spec = self.spec;
            let [w, h] = spec.size();
            let (w, h) = (w as usize, h as usize);
            let ch = spec.channels;
            let mut out = vec![0.0f32; w * h * ch];
            let t0 = Instant::now();
            let clock = || t0.elapsed().as_secs_f64() * 1000.0;
            let clock_ref: Option<&(dyn Fn() -> f64 + Sync)> =
                if spec.params.time { Some(&clock) } else { None };
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
            let skip = spec.skip_grid(&vol, K::NAME);
            let queue = Mutex::new(out.chunks_mut(w * ch * BAND).enumerate());
            let work = || {
                let mut convo = Convo::<V, K, S>::new(vol);
                loop {
                    let next = queue.lock().map(|mut q| q.next()).unwrap_or(None);
                    let Some((b, chunk)) = next else { break };
                    let rows = (b * BAND) as u32..((b + 1) * BAND).min(h) as u32;
                    spec.render_rows(
                        &mut convo,
                        skip.as_ref(),
                        rows,
                        chunk,
                        clock_ref.map(|c| c as &dyn Fn() -> f64),
                    );
                    report(done.fetch_add(1, Ordering::Relaxed) + 1);
                }
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
    dispatch(
        vol,
        kernel,
        Task {
            spec,
            threads,
            progress,
        },
    )
}
