//! Multi-threaded rendering: image rows are handed out in bands to scoped worker
//! threads (plain `std` threads, as many as the caller asks for; nothing global, no
//! pool), each with its own convolution state; every pixel is computed by the same code
//! whatever the thread count, so the output is bit-identical for every count. The
//! caller may watch progress and stop a render through a [`Control`].

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

use rnd_core::brick::{Own, Partial};
use rnd_core::kernel::{Kernel, KernelName};
use rnd_core::render::{dispatch, AnyVolume, ConvoTask, RenderSpec};
use rnd_core::skip::{AimPart, ReAim, SkipGrid, SkipKind, SkipPlan};
use rnd_core::volume::Volume;
use rnd_core::voxel::Voxel;
use rnd_core::Param;

use crate::{Error, ErrorKind};

/// Rows a thread takes at a time from its own run (see `bands`): the render casts them
/// strip by strip of columns (`RenderSpec::render_rows`), so that rays beside each other
/// in both directions run one after another.
const BAND: usize = 8;

/// The number of threads the system offers this process (at least 1).
pub fn default_threads() -> usize {
    std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(1)
}

/// How far a render has come: see [`Control::on_progress`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Progress {
    /// Image rows finished.
    pub rows_done: usize,
    /// Image rows in all.
    pub rows: usize,
}

/// What the caller of [`render_with`] watches and steers: a progress callback (called
/// from the worker threads after each band of rows) and a flag that stops the render
/// when set (checked before each band; the render then returns an error of kind
/// [`ErrorKind::Cancelled`]).
///
/// ```
/// use std::sync::atomic::AtomicBool;
/// use rnd_std::parallel::Control;
///
/// let stop = AtomicBool::new(false);
/// let show = |p: rnd_std::parallel::Progress| eprintln!("{}/{}", p.rows_done, p.rows);
/// let control = Control::new().on_progress(&show).cancel_flag(&stop);
/// # let _ = control;
/// ```
#[derive(Clone, Copy, Default)]
pub struct Control<'c> {
    progress: Option<&'c (dyn Fn(Progress) + Sync)>,
    cancel: Option<&'c AtomicBool>,
}

impl std::fmt::Debug for Control<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Control")
            .field("progress", &self.progress.is_some())
            .field("cancel", &self.cancel)
            .finish()
    }
}

impl<'c> Control<'c> {
    /// No progress reports, no cancellation.
    pub fn new() -> Self {
        Control::default()
    }
    /// Calls `f` after each band of rows (one to four) is finished (from the thread that
    /// finished it; calls may come from several threads, `rows_done` only grows).
    pub fn on_progress(mut self, f: &'c (dyn Fn(Progress) + Sync)) -> Self {
        self.progress = Some(f);
        self
    }
    /// Stops the render as soon as `flag` is set (between bands of rows).
    pub fn cancel_flag(mut self, flag: &'c AtomicBool) -> Self {
        self.cancel = Some(flag);
        self
    }
    fn cancelled(&self) -> bool {
        self.cancel.is_some_and(|c| c.load(Ordering::Relaxed))
    }
}

/// Renders the whole image with `threads` workers (≤ 1: on the calling thread): W·H·C
/// floats, row-major from the top row, C = [`RenderSpec::channels`]. The same bytes for
/// every thread count.
///
/// ```
/// use rnd_std::prelude::*;
///
/// let vol = OwnedVolume::from_fn([16; 3], Affine4::IDENTITY, |[i, j, k]| (i + j + k) as i16)
///     .unwrap();
/// let cam = CameraSpec::framing(&vol.view().world_corners(), [1.0, 2.0, 3.0]).unwrap().size(32, 32);
/// let spec = RenderSpec::new(RenderParams::new(cam), None, None, &[]).unwrap();
/// let one = rnd_std::parallel::render(&spec, vol.view().into(), KernelName::Ctmr, 1).unwrap();
/// let four = rnd_std::parallel::render(&spec, vol.view().into(), KernelName::Ctmr, 4).unwrap();
/// assert_eq!(one, four);
/// assert!(one.iter().any(|&v| v > 30.0));
/// ```
///
/// # Errors
/// As [`render_with`].
pub fn render(
    spec: &RenderSpec<'_>,
    vol: AnyVolume<'_>,
    kernel: KernelName,
    threads: usize,
) -> crate::Result<Vec<f32>> {
    render_with(spec, vol, kernel, threads, &Control::new())
}

/// [`render`], reporting progress to and stopping on request of `control`.
///
/// # Errors
/// [`ErrorKind::Core`] when the volume does not suit the arithmetic
/// ([`RenderSpec::check_volume`]); [`ErrorKind::Memory`] when the image needs more
/// memory than this process may use ([`crate::mem_limit`]) or the system refuses it
/// (both checked before rendering starts); [`ErrorKind::Cancelled`] when `control`'s
/// flag was set.
pub fn render_with(
    spec: &RenderSpec<'_>,
    vol: AnyVolume<'_>,
    kernel: KernelName,
    threads: usize,
    control: &Control<'_>,
) -> crate::Result<Vec<f32>> {
    render_kept(spec, vol, kernel, threads, control, None, None)
}

/// [`render_with`] of a loaded volume, keeping its skip grid for the next frame: a
/// render whose grid would be built from the same kind, kernel, LUT and bounds as the
/// last one kept takes that one instead of building it again (the grid depends on the
/// voxels, never on the camera, and is aimed at each frame's camera anew), so the
/// frames after the first of a turntable or a viewer skip that work. A large volume
/// whose rows alias in the cache renders without a skip grid (none applies, or the
/// `max` grid's pilot says it would not pay) from a padded copy it also keeps, where the
/// volume's [`crate::volume_io::Padding`] allows it
/// ([`crate::volume_io::VolumeBuf::render_view`]). The same image bits as
/// [`render_with`] (the same grid, the same samples); frames of the same volume may
/// render at once, each then building its own grid when another holds the kept one.
///
/// A volume mapped from its file ([`crate::volume_io::load_volume_mapped`]) shows the
/// file as it is: if another program changes the file while it is in use, the samples
/// change and the kept grid no longer fits them. Load such a file again instead.
///
/// ```
/// use rnd_std::prelude::*;
/// use rnd_std::volume_io::{VolumeBuf, VolumeData};
///
/// let vals: Vec<f32> = (0..16 * 16 * 16).map(|i| ((i % 16) * (i / 256)) as f32).collect();
/// let vol = VolumeBuf::new(VolumeData::F32(vals), [16, 16, 16], Affine4::IDENTITY).unwrap();
/// let cam = CameraSpec::framing(&vol.view().world_corners(), [1.0, 2.0, 3.0]).unwrap().size(24, 24);
/// let mut p = RenderParams::new(cam);
/// p.blend = Blend::Max;
/// let spec = RenderSpec::new(p, None, None, &[]).unwrap();
/// let ctl = rnd_std::parallel::Control::new();
/// let first = rnd_std::parallel::render_volume(&spec, &vol, KernelName::Bspln3, 1, &ctl).unwrap();
/// let again = rnd_std::parallel::render_volume(&spec, &vol, KernelName::Bspln3, 2, &ctl).unwrap();
/// let fresh = rnd_std::parallel::render_with(&spec, vol.view(), KernelName::Bspln3, 1, &ctl).unwrap();
/// assert!(first == again && again == fresh);
/// ```
///
/// # Errors
/// As [`render_with`].
pub fn render_volume(
    spec: &RenderSpec<'_>,
    vol: &crate::volume_io::VolumeBuf,
    kernel: KernelName,
    threads: usize,
    control: &Control<'_>,
) -> crate::Result<Vec<f32>> {
    // A padded copy pays where every ray reads its whole stretch of the volume: not
    // under a skip grid, where a render reads little of a large volume and copying all
    // of it costs more than the render saves (run 46: a 512 x 512 x 256 CT). So when the
    // volume would be padded, the `max` grid's pilot runs first (once: its answer is
    // handed on).
    let pilot = match spec.skip_kind() {
        Some(SkipKind::MaxValue | SkipKind::MaxGradMag) if vol.pads(kernel) => {
            Some(spec.skip_pays(vol.view(), kernel, &|rays| on_threads(rays, threads)))
        }
        _ => None,
    };
    let view = if spec.skip_kind().is_none() || pilot == Some(false) {
        vol.render_view(kernel, threads)
    } else {
        vol.view()
    };
    render_kept(
        spec,
        view,
        kernel,
        threads,
        control,
        Some(vol.grids()),
        pilot,
    )
}

/// The skip grid a loaded volume keeps between renders ([`render_volume`]), and how many
/// grids were built for it. A copy of the volume starts with none kept; two volumes
/// compare equal whatever they keep.
#[derive(Debug, Default)]
pub(crate) struct KeptGrid {
    grid: Mutex<Option<SkipGrid>>,
    built: AtomicUsize,
}

impl Clone for KeptGrid {
    fn clone(&self) -> Self {
        KeptGrid::default()
    }
}

impl PartialEq for KeptGrid {
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

impl KeptGrid {
    /// The kept grid when `plan` builds it; else none, counting the grid the caller will
    /// build.
    fn take(&self, plan: &SkipPlan<'_>) -> Option<SkipGrid> {
        // (A poisoned lock only means another render panicked holding it: the slot is
        // still an Option, whatever it holds.)
        let kept = self
            .grid
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .take()
            .filter(|g| plan.builds(g));
        if kept.is_none() {
            self.built.fetch_add(1, Ordering::Relaxed);
        }
        kept
    }

    /// Keeps `grid` for the next render.
    fn keep(&self, grid: SkipGrid) {
        *self.grid.lock().unwrap_or_else(|e| e.into_inner()) = Some(grid);
    }

    /// How many grids renders of this volume have built.
    #[cfg(test)]
    pub(crate) fn built(&self) -> usize {
        self.built.load(Ordering::Relaxed)
    }
}

/// The first error of a render's workers (a worker that meets one stops; the others
/// stop at their next band).
#[derive(Default)]
struct FirstError(Mutex<Option<rnd_core::Error>>);

impl FirstError {
    /// Whether `r` is Ok; its error kept when it is the first.
    fn ok(&self, r: rnd_core::Result<()>) -> bool {
        if let (Err(e), Ok(mut f)) = (&r, self.0.lock()) {
            f.get_or_insert_with(|| e.clone());
        }
        r.is_ok()
    }

    /// The first error, if any.
    fn into_result(self) -> crate::Result<()> {
        match self.0.into_inner().ok().flatten() {
            Some(e) => Err(e.into()),
            None => Ok(()),
        }
    }
}

/// [`render_with`], taking the grid from and leaving it in `kept` when given; `pilot`,
/// when given, is what [`RenderSpec::skip_pays`] said for this render.
fn render_kept(
    spec: &RenderSpec<'_>,
    vol: AnyVolume<'_>,
    kernel: KernelName,
    threads: usize,
    control: &Control<'_>,
    kept: Option<&KeptGrid>,
    pilot: Option<bool>,
) -> crate::Result<Vec<f32>> {
    spec.check_volume(vol.grid())?;
    let [w, h] = spec.size();
    let image_err = |e: Error| Error {
        param: Some(Param::ImageSize),
        ..e
    };
    let len = spec.image_len();
    let what = format!(
        "a {w} x {h} image with {} channel{}",
        spec.channels(),
        if spec.channels() == 1 { "" } else { "s" }
    );
    crate::check_memory((len as u64).saturating_mul(4), &what).map_err(image_err)?;
    // (Not cleared here: each worker clears its own rows just before it casts them, see
    // `cleared`.)
    let mut out = Vec::new();
    crate::try_reserve(&mut out, len, &what).map_err(image_err)?;
    struct Task<'s, 'a, 'c> {
        spec: &'s RenderSpec<'a>,
        threads: usize,
        control: &'s Control<'c>,
        out: Vec<f32>,
        kept: Option<&'s KeptGrid>,
        pilot: Option<bool>,
    }
    impl ConvoTask for Task<'_, '_, '_> {
        type Output = crate::Result<Vec<f32>>;
        fn run<V: Voxel, K: Kernel<S>, const S: usize>(
            self,
            vol: Volume<'_, V>,
        ) -> crate::Result<Vec<f32>> {
            let spec = self.spec;
            let control = self.control;
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
            let plan = spec.skip_plan(&vol, K::NAME).filter(|_| {
                self.pilot.unwrap_or_else(|| {
                    spec.skip_pays(vol.into(), K::NAME, &|rays| on_threads(rays, self.threads))
                })
            });
            // The grid: the one kept, aimed at this render's camera (on one thread, or
            // by the render's own workers as they start: see `GridWork`), or one built
            // aimed (each run of the build placing its blocks) first on one thread, or by
            // the render's own workers as they start.
            let (mut ready, mut work) = (None, None);
            if let Some(plan) = plan {
                let aimed = |p| spec.aim_plan::<V, K, S>(vol, p);
                match self.kept.and_then(|k| k.take(&plan)) {
                    Some(mut g) if self.threads <= 1 => {
                        spec.aim::<V, K, S>(vol, &mut g);
                        ready = Some(g);
                    }
                    Some(mut g) => {
                        let re = spec.re_aim::<V, K, S>(vol, &g);
                        if re.blocks() == 0 {
                            re.finish(&mut g, Vec::new());
                            ready = Some(g);
                        } else {
                            work = Some(GridWork::aim(re, g, &vol, self.threads));
                        }
                    }
                    None if self.threads <= 1 => ready = Some(aimed(plan).build(&vol)),
                    None => work = Some(GridWork::new(aimed(plan), &vol, self.threads)),
                }
            }
            let mut none: [(); 0] = [];
            let w_ch = w * ch;
            let failed = FirstError::default();
            let done = bands(
                (&mut out.spare_capacity_mut()[..h * w_ch], w_ch),
                (&mut none, 0),
                h,
                self.threads,
                control,
                |mut rows, chunk, _| {
                    let mut chunk = cleared(chunk);
                    let clock = clock_ref.map(|c| c as &dyn Fn() -> f64);
                    let grid = || ready.as_ref().or_else(|| work.as_ref()?.grid());
                    if let Some(w) = &work {
                        w.help();
                        // Until another worker has put the grid together: a row at a
                        // time without it (slower, the same bits), then the rest with it.
                        while grid().is_none() && !rows.is_empty() {
                            let (row, rest) = chunk.split_at_mut(w_ch);
                            if !failed.ok(spec.render_rows(
                                vol.into(),
                                K::NAME,
                                None,
                                rows.start..rows.start + 1,
                                row,
                                clock,
                            )) {
                                return false;
                            }
                            (rows.start, chunk) = (rows.start + 1, rest);
                        }
                    }
                    rows.is_empty()
                        || failed.ok(spec.render_rows(
                            vol.into(),
                            K::NAME,
                            grid(),
                            rows,
                            chunk,
                            clock,
                        ))
                },
            );
            // (Kept even when cancelled: the grid does not depend on how far it got; a
            // grid left unfinished is not kept.)
            if let (Some(k), Some(g)) = (self.kept, ready.or_else(|| work?.into_grid())) {
                k.keep(g);
            }
            failed.into_result()?;
            if done == h {
                // SAFETY: `out` has room for `h * w_ch` floats (reserved above: the
                // image's `len`), and all of them are initialized: `bands` handed each
                // row to exactly one call, and `done == h` only when every call returned
                // true, each having first cleared its whole chunk (`cleared`).
                unsafe { out.set_len(h * w_ch) };
                Ok(out)
            } else {
                Err(cancelled())
            }
        }
    }
    if control.cancelled() {
        return Err(cancelled());
    }
    dispatch(
        vol,
        kernel,
        Task {
            spec,
            threads,
            control,
            out,
            kept,
            pilot,
        },
    )
}

/// `chunk` cleared to zeros, as the floats it now holds. A render's workers clear their
/// own rows of its image just before casting them: the rows are then in cache when cast,
/// and no thread clears the whole image before the others start (`alloc_zeroed` did
/// that on the calling thread, 0.12-0.15 ms for a 256 x 256 RGBA image, once the
/// allocator served it from its heap rather than a fresh mapping).
fn cleared(chunk: &mut [std::mem::MaybeUninit<f32>]) -> &mut [f32] {
    for x in chunk.iter_mut() {
        x.write(0.0);
    }
    // SAFETY: `MaybeUninit<f32>` has the size, alignment and layout of `f32`, and every
    // element of `chunk` was written just above: reading it as `[f32]` (for as long as
    // the borrow of `chunk`) reads initialized floats.
    unsafe { &mut *(std::ptr::from_mut(chunk) as *mut [f32]) }
}

/// One brick's part of a sort-last render: [`render_part_with`]'s partials, one per
/// pixel, and under `median` the samples each blended (one list per pixel, channel by
/// channel; empty otherwise).
#[derive(Debug, Clone, Default)]
pub struct Parts {
    /// The partial blend of each pixel's stretch, rows consecutive.
    pub partials: Vec<Partial>,
    /// Under `median`: each pixel's samples.
    pub samples: Vec<Vec<f32>>,
}

/// One brick's part of a sort-last render (see [`rnd_core::brick`]): for every pixel the
/// [`Partial`] of the stretch of its ray that `own` gives, from `vol`, the brick's
/// [`Volume::region`] with its ghost layers, on `threads` threads (the same partials for
/// every thread count). Empty space is skipped as in [`render`], with a grid built from
/// the region; with the spec's time channel each partial carries its stretch's time.
///
/// # Errors
/// As [`render_with`], and as [`RenderSpec::render_part_rows`].
pub fn render_part_with(
    spec: &RenderSpec<'_>,
    vol: AnyVolume<'_>,
    kernel: KernelName,
    own: &Own,
    threads: usize,
    control: &Control<'_>,
) -> crate::Result<Parts> {
    spec.check_volume(vol.grid())?;
    let [w, h] = spec.size();
    let (w, h) = (w as usize, h as usize);
    let len = w.saturating_mul(h);
    let what = format!("the partials of a {w} x {h} image");
    let median = spec.params().blend.keeps_samples();
    let per_pixel = std::mem::size_of::<Partial>() + if median { 24 } else { 0 };
    let bytes = (len as u64).saturating_mul(per_pixel as u64);
    crate::check_memory(bytes, &what).map_err(|e| Error {
        param: Some(Param::ImageSize),
        ..e
    })?;
    let mut parts = Parts::default();
    crate::try_reserve(&mut parts.partials, len, &what)?;
    let probe_len = spec.params().probe.length();
    parts
        .partials
        .resize(len, Partial::empty(spec.params().blend, probe_len));
    if median {
        crate::try_reserve(&mut parts.samples, len, &what)?;
        parts.samples.resize(len, Vec::new());
    }
    struct Task<'s, 'a, 'c> {
        spec: &'s RenderSpec<'a>,
        own: Own,
        threads: usize,
        control: &'s Control<'c>,
        parts: Parts,
    }
    impl ConvoTask for Task<'_, '_, '_> {
        type Output = crate::Result<Parts>;
        fn run<V: Voxel, K: Kernel<S>, const S: usize>(
            self,
            vol: Volume<'_, V>,
        ) -> crate::Result<Parts> {
            let (spec, control, own) = (self.spec, self.control, &self.own);
            let [w, h] = spec.size().map(|x| x as usize);
            let Parts {
                mut partials,
                mut samples,
            } = self.parts;
            let t0 = Instant::now();
            let clock = || t0.elapsed().as_secs_f64() * 1000.0;
            let timed = spec.params().time;
            let failed = FirstError::default();
            // (No pilot for a brick: its rays' maxima are the whole volume's.)
            let skip = spec
                .skip_plan(&vol, K::NAME)
                .map(|plan| build_skip_grid(plan, &vol, self.threads));
            // Each pixel's sample list (none without the median).
            let per_row = if samples.is_empty() { 0 } else { w };
            let done = bands(
                (&mut partials, w),
                (&mut samples, per_row),
                h,
                self.threads,
                control,
                |rows, chunk, kept| {
                    let clock = timed.then_some(&clock as &dyn Fn() -> f64);
                    let r = spec.render_part_rows(
                        vol.into(),
                        K::NAME,
                        skip.as_ref(),
                        own,
                        rows,
                        chunk,
                        kept,
                        clock,
                    );
                    failed.ok(r)
                },
            );
            failed.into_result()?;
            if done == h {
                Ok(Parts { partials, samples })
            } else {
                Err(cancelled())
            }
        }
    }
    if control.cancelled() {
        return Err(cancelled());
    }
    dispatch(
        vol,
        kernel,
        Task {
            spec,
            own: *own,
            threads,
            control,
            parts,
        },
    )
}

/// Runs `band` over the rows of an image of `h` rows whose `out` holds `per_row` items a
/// row and `aux` `aux_per_row` (0: `aux` may be empty), on `threads` threads, the calling
/// thread one of them (with one, it takes them all in order), reporting progress to
/// `control`; stops when it is cancelled or a call returns false. Returns the rows done.
///
/// Each thread owns a contiguous run of the rows and works down it [`BAND`] rows at a
/// time, so that its next rows lie beside its last and find the volume's voxels they
/// share still in the core's caches (bands handed out in turn from one queue cost the
/// 256³ volume ~7% more processor time at two threads). A thread whose run is done
/// takes single rows from the far end of the longest run left, and a thread takes at
/// most half of what is left of its own run, so that the threads finish within about a
/// row of each other (a whole last band taken while another thread had nothing left
/// kept that one waiting up to [`BAND`] rows: ~1.5 ms of a 28 ms CT render at two
/// threads).
fn bands<T: Send, U: Send>(
    (out, per_row): (&mut [T], usize),
    (aux, aux_per_row): (&mut [U], usize),
    h: usize,
    threads: usize,
    control: &Control<'_>,
    band: impl Fn(core::ops::Range<u32>, &mut [T], &mut [U]) -> bool + Sync,
) -> usize {
    /// Rows not yet taken, and their items.
    struct Run<'o, T, U> {
        rows: core::ops::Range<usize>,
        out: &'o mut [T],
        aux: &'o mut [U],
    }
    impl<'o, T, U> Run<'o, T, U> {
        /// Splits `n` rows (at most all) and their items off the front, or the back.
        fn split(&mut self, n: usize, front: bool, per: (usize, usize)) -> Run<'o, T, U> {
            let n = n.min(self.rows.len());
            let (o, x) = (std::mem::take(&mut self.out), std::mem::take(&mut self.aux));
            let (no, nx) = ((n * per.0).min(o.len()), (n * per.1).min(x.len()));
            if front {
                let ((o1, o2), (x1, x2)) = (o.split_at_mut(no), x.split_at_mut(nx));
                let rows = self.rows.start..self.rows.start + n;
                (self.rows.start, self.out, self.aux) = (rows.end, o2, x2);
                Run {
                    rows,
                    out: o1,
                    aux: x1,
                }
            } else {
                let (ol, xl) = (o.len() - no, x.len() - nx);
                let ((o1, o2), (x1, x2)) = (o.split_at_mut(ol), x.split_at_mut(xl));
                let rows = self.rows.end - n..self.rows.end;
                (self.rows.end, self.out, self.aux) = (rows.start, o1, x1);
                Run {
                    rows,
                    out: o2,
                    aux: x2,
                }
            }
        }
    }
    let per = (per_row, aux_per_row);
    let done = AtomicUsize::new(0);
    let t = threads.clamp(1, h.max(1));
    let mut all = Run {
        rows: 0..h,
        out,
        aux,
    };
    let runs: Vec<_> = (0..t)
        .map(|i| all.split((i + 1) * h / t - i * h / t, true, per))
        .collect();
    let runs = Mutex::new(runs);
    // The next rows for thread `me`: BAND (at most half of what is left, rounded up) from
    // the front of its run, or one from the back of the longest other.
    let next = |me: usize| {
        let mut runs = runs.lock().ok()?;
        let left = runs[me].rows.len();
        if left > 0 {
            return Some(runs[me].split(BAND.min(left.div_ceil(2)), true, per));
        }
        let i = (0..runs.len()).max_by_key(|&i| runs[i].rows.len())?;
        (!runs[i].rows.is_empty()).then(|| runs[i].split(1, false, per))
    };
    let work = |me: usize| loop {
        if control.cancelled() {
            break;
        }
        let Some(Run { rows, out, aux }) = next(me) else {
            break;
        };
        let n = rows.len();
        if !band(rows.start as u32..rows.end as u32, out, aux) {
            break;
        }
        let rows_done = done.fetch_add(n, Ordering::Relaxed) + n;
        if let Some(f) = control.progress {
            f(Progress { rows_done, rows: h });
        }
    };
    if t <= 1 {
        work(0);
    } else {
        std::thread::scope(|s| {
            for me in 1..t {
                let work = &work;
                spawn_apart(s, t, move || work(me));
            }
            std::thread::yield_now();
            work(0);
        });
    }
    done.load(Ordering::Relaxed)
}

/// The pilot's rays (see [`rnd_core::render::PilotCast`]) cast on `threads` threads,
/// each taking every `threads`-th pilot row, the calling thread one of them (its rows
/// are cast while the others start).
fn on_threads(rays: &(dyn Fn(u32, u32) -> Vec<f32> + Sync), threads: usize) -> Vec<f32> {
    let n = threads.clamp(1, 16) as u32;
    if n == 1 {
        return rays(0, 1);
    }
    std::thread::scope(|s| {
        let parts: Vec<_> = (1..n)
            .map(|i| spawn_apart(s, n as usize, move || rays(i, n)))
            .collect();
        std::thread::yield_now();
        let mut all = rays(0, n);
        // (A part whose thread failed gives no maxima: the verdict is only about time.)
        for p in parts {
            all.extend(p.join().unwrap_or_default());
        }
        all
    })
}

/// Spawns `f` on `scope` as one of `workers` threads (the calling thread one of them,
/// working too): a worker that starts on the CPU the caller was on when spawning it
/// moves once to another CPU it may run on, when there are at least as many of those as
/// workers (see [`cpu::leave`]). The caller then yields once (`std::thread::yield_now`),
/// so that a worker queued behind it gets to run and move.
///
/// Why (RESULTS.md, run 66): Linux places a new thread on the CPU whose recent load
/// looks least, which is now and then the busy caller's own; the worker then waits for
/// the next scheduler tick to run at all (~3-4 ms) and the two share one CPU until the
/// load balancer parts them (up to ~13 ms seen), while the other CPU idles: a third of
/// the CT's 2-thread lit `over` renders started so, taking 14-21 ms instead of 13.
fn spawn_apart<'scope, T: Send + 'scope>(
    scope: &'scope std::thread::Scope<'scope, '_>,
    workers: usize,
    f: impl FnOnce() -> T + Send + 'scope,
) -> std::thread::ScopedJoinHandle<'scope, T> {
    let here = cpu::current();
    scope.spawn(move || {
        cpu::leave(here, workers);
        f()
    })
}

/// Where the calling thread runs, and moving off a CPU (Linux; elsewhere nothing).
mod cpu {
    /// The CPU the calling thread is on, if the system says.
    #[cfg(target_os = "linux")]
    pub(super) fn current() -> Option<usize> {
        // SAFETY: sched_getcpu takes no arguments and only returns a number (-1 when it
        // cannot tell).
        usize::try_from(unsafe { libc::sched_getcpu() }).ok()
    }

    /// Moves the calling thread, one of `workers`, off CPU `cpu` when it is on it and
    /// may run on another: its allowed set without `cpu` for a moment (the kernel moves
    /// it at once), then the whole set again, so it may run anywhere it could before.
    /// Nothing when the thread is elsewhere, `cpu` is unknown, fewer CPUs are allowed
    /// than there are workers (they must share some CPU anyway) or only one, or the
    /// system refuses: this only saves time.
    #[cfg(target_os = "linux")]
    pub(super) fn leave(cpu: Option<usize>, workers: usize) {
        let Some(cpu) = cpu.filter(|&c| current() == Some(c)) else {
            return;
        };
        let size = std::mem::size_of::<libc::cpu_set_t>();
        if cpu >= 8 * size {
            return;
        }
        let Some(all) = allowed() else {
            return;
        };
        let mut others = all;
        // SAFETY: plain bit operations on sets we own; `cpu` is below the set's size in
        // bits (checked above), so CPU_CLR's index is in bounds.
        let allowed = unsafe {
            libc::CPU_CLR(cpu, &mut others);
            libc::CPU_COUNT(&all)
        };
        if allowed < 2 || (allowed as usize) < workers {
            return;
        }
        // SAFETY: sched_setaffinity reads `size` bytes, the size of `others` and of
        // `all`, both valid sets on this stack; thread 0 is the calling thread.
        unsafe {
            if libc::sched_setaffinity(0, size, &others) == 0 {
                libc::sched_setaffinity(0, size, &all);
            }
        }
    }

    /// The CPUs the calling thread may run on, if the system says.
    #[cfg(target_os = "linux")]
    pub(super) fn allowed() -> Option<libc::cpu_set_t> {
        let size = std::mem::size_of::<libc::cpu_set_t>();
        // SAFETY: cpu_set_t is an array of integers: all zeros is a valid (empty) set.
        let mut set: libc::cpu_set_t = unsafe { std::mem::zeroed() };
        // SAFETY: sched_getaffinity writes at most `size` bytes, the size of `set`, into
        // `set`, which lives on this stack for the call; thread 0 is the calling thread.
        let got = unsafe { libc::sched_getaffinity(0, size, &mut set) };
        (got == 0).then_some(set)
    }

    #[cfg(not(target_os = "linux"))]
    pub(super) fn current() -> Option<usize> {
        None
    }

    #[cfg(not(target_os = "linux"))]
    pub(super) fn leave(_: Option<usize>, _: usize) {}
}

fn cancelled() -> Error {
    Error::msg("the render was cancelled").with_kind(ErrorKind::Cancelled)
}

/// Builds the skip grid of `plan` with `threads` workers, which take runs of coarse
/// slabs ([`SkipPlan::build_run`]) from one queue (the same grid as one thread builds).
pub fn build_skip_grid<V: Voxel>(
    plan: SkipPlan<'_>,
    vol: &Volume<'_, V>,
    threads: usize,
) -> SkipGrid {
    if threads <= 1 {
        return plan.build(vol);
    }
    let work = GridWork::new(plan.clone(), vol, threads);
    std::thread::scope(|s| {
        for _ in 0..threads.min(work.runs) {
            s.spawn(|| work.help());
        }
    });
    // (Every run is built once the workers are done, so the grid is there; were it not,
    // one thread builds it.)
    work.into_grid().unwrap_or_else(|| plan.build(vol))
}

/// A skip grid that several workers build together, run by run (about four runs of
/// coarse slabs a worker, taken from one queue), or a kept grid they aim anew together
/// (runs of its fine blocks, [`ReAim`]): each worker of a render helps before each band
/// of rows it casts, and casts rows one at a time without the grid while another worker
/// still builds or aims the last runs (the same bits: skipping is exact). So neither
/// takes a thread start of its own, and a worker that starts late (on the 2-vCPU machine
/// of bench/RESULTS.md run 59 a spawned thread often starts 0.1–0.8 ms after it was
/// spawned) holds nobody up.
struct GridWork<'p, 'v, 'd, V: Voxel> {
    job: Job<'p>,
    vol: &'v Volume<'d, V>,
    /// The runs not yet taken, the last first.
    todo: Mutex<Vec<std::ops::Range<usize>>>,
    /// How many runs there are.
    runs: usize,
    grid: std::sync::OnceLock<SkipGrid>,
}

/// What [`GridWork`]'s runs make.
// (One a render: the variants' sizes do not matter.)
#[allow(clippy::large_enum_variant)]
enum Job<'p> {
    /// A grid from its plan: the whole grid, each run copied in by the worker that built
    /// it, and how many runs are in it, until the last is (then the worker that put it
    /// puts the grid together, aimed when the plan is).
    Build(SkipPlan<'p>, Mutex<(rnd_core::skip::SkipAssembly, usize)>),
    /// A kept grid's aim: the parts made, and the grid, until the last part is in (then
    /// the worker that made it aims the grid).
    Aim(ReAim, Mutex<(Vec<AimPart>, Option<SkipGrid>)>),
}

impl<'p, 'v, 'd, V: Voxel> GridWork<'p, 'v, 'd, V> {
    fn new(plan: SkipPlan<'p>, vol: &'v Volume<'d, V>, threads: usize) -> Self {
        let whole = plan.assembly();
        let n = plan.slabs();
        Self::with_runs(Job::Build(plan, Mutex::new((whole, 0))), n, vol, threads)
    }

    /// `grid` aimed by `re` (its [`RenderSpec::re_aim`]) in runs of its fine blocks.
    fn aim(re: ReAim, grid: SkipGrid, vol: &'v Volume<'d, V>, threads: usize) -> Self {
        let n = re.blocks();
        Self::with_runs(
            Job::Aim(re, Mutex::new((Vec::new(), Some(grid)))),
            n,
            vol,
            threads,
        )
    }

    /// `job` in about four runs a worker of `0 .. n`.
    fn with_runs(job: Job<'p>, n: usize, vol: &'v Volume<'d, V>, threads: usize) -> Self {
        let k = (4 * threads).clamp(1, n.max(1));
        let todo: Vec<_> = (0..k).rev().map(|i| i * n / k..(i + 1) * n / k).collect();
        GridWork {
            job,
            vol,
            runs: todo.len(),
            todo: Mutex::new(todo),
            grid: std::sync::OnceLock::new(),
        }
    }

    /// Makes runs until none is left to take, putting each into the whole; the worker
    /// that puts the last finishes the grid for everyone.
    fn help(&self) {
        while let Some(r) = self.todo.lock().ok().and_then(|mut q| q.pop()) {
            match &self.job {
                Job::Build(plan, done) => {
                    let run = plan.build_run(self.vol, r);
                    let Ok(mut done) = done.lock() else {
                        return;
                    };
                    let (whole, n) = &mut *done;
                    // (A run this plan built always fits it: `put` cannot fail here, and
                    // if it did, no grid would be made and the rows rendered without one.)
                    if plan.put(whole, run) {
                        *n += 1;
                    }
                    if *n == self.runs {
                        let whole = std::mem::take(whole);
                        drop(done);
                        if let Some(g) = plan.assemble(whole) {
                            let _ = self.grid.set(g);
                        }
                    }
                }
                Job::Aim(re, done) => {
                    let part = re.part(r);
                    let Ok(mut done) = done.lock() else {
                        return;
                    };
                    let (parts, grid) = &mut *done;
                    parts.push(part);
                    if parts.len() == self.runs {
                        let (parts, grid) = (std::mem::take(parts), grid.take());
                        drop(done);
                        if let Some(mut g) = grid {
                            re.finish(&mut g, parts);
                            let _ = self.grid.set(g);
                        }
                    }
                }
            }
        }
    }

    /// The grid, once the last run is in.
    fn grid(&self) -> Option<&SkipGrid> {
        self.grid.get()
    }

    /// The grid, if the last run was put in (a kept grid also when not: only its aim
    /// waited, which each render makes anew).
    fn into_grid(self) -> Option<SkipGrid> {
        let g = self.grid.into_inner();
        match self.job {
            Job::Aim(_, done) => g.or_else(|| done.into_inner().ok()?.1),
            Job::Build(..) => g,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::build_skip_grid;
    use rnd_core::affine::Affine4;
    use rnd_core::kernel::KernelName;
    use rnd_core::skip::{SkipGrid, SkipKind, SkipPlan};
    use rnd_core::txf::Lut;
    use rnd_core::volume::Volume;

    /// Every row is rendered exactly once, into its own items of both slices, by any
    /// number of threads (more threads than rows included), whatever the image height.
    #[test]
    fn bands_cover_every_row_once() {
        use std::sync::atomic::{AtomicUsize, Ordering};
        for h in [1usize, 3, 4, 5, 17, 64, 130] {
            for t in 1..=7 {
                for aux_per_row in [0, 2] {
                    let mut out = vec![0u32; h * 3];
                    let mut aux = vec![0u32; h * aux_per_row];
                    let rows_seen = AtomicUsize::new(0);
                    let control = super::Control::new();
                    let done = super::bands(
                        (&mut out, 3),
                        (&mut aux, aux_per_row),
                        h,
                        t,
                        &control,
                        |rows, o, x| {
                            assert_eq!(o.len(), rows.len() * 3);
                            assert_eq!(x.len(), rows.len() * aux_per_row);
                            for (i, v) in o.iter_mut().enumerate() {
                                *v += rows.start * 3 + i as u32 + 1;
                            }
                            for (i, v) in x.iter_mut().enumerate() {
                                *v += rows.start * aux_per_row as u32 + i as u32 + 1;
                            }
                            rows_seen.fetch_add(rows.len(), Ordering::Relaxed);
                            true
                        },
                    );
                    assert_eq!(done, h, "h {h}, {t} threads");
                    assert_eq!(rows_seen.into_inner(), h);
                    assert!(out.iter().enumerate().all(|(i, &v)| v == i as u32 + 1));
                    assert!(aux.iter().enumerate().all(|(i, &v)| v == i as u32 + 1));
                }
            }
        }
    }

    /// A thread works down its run [`super::BAND`] rows at a time, but never takes more
    /// than half of what is left (rounded up), so that another thread, done with its own
    /// run, still finds rows to take from the back of it.
    #[test]
    fn bands_shrink_to_half_of_what_is_left() {
        let bands_of = |h: usize| {
            let seen = std::sync::Mutex::new(Vec::new());
            let mut out = vec![0u8; h];
            let control = super::Control::new();
            let done = super::bands(
                (&mut out, 1),
                (&mut [0u8; 0], 0),
                h,
                1,
                &control,
                |r, _, _| {
                    seen.lock().unwrap().push(r.len());
                    true
                },
            );
            assert_eq!(done, h);
            seen.into_inner().unwrap()
        };
        assert_eq!(super::BAND, 8);
        assert_eq!(bands_of(20), [8, 6, 3, 2, 1]);
        assert_eq!(bands_of(40), [8, 8, 8, 8, 4, 2, 1, 1]);
        assert_eq!(bands_of(1), [1]);
    }

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

    /// The pilot's rays on any number of threads: every part once, whichever thread
    /// cast it.
    #[test]
    fn pilot_parts_are_each_cast_once() {
        let rays = |part: u32, parts: u32| -> Vec<f32> {
            (part..16)
                .step_by(parts as usize)
                .map(|r| r as f32)
                .collect()
        };
        for t in [0, 1, 2, 3, 5, 16, 40] {
            let mut got = super::on_threads(&rays, t);
            got.sort_by(f32::total_cmp);
            assert_eq!(
                got,
                (0..16).map(|r| r as f32).collect::<Vec<_>>(),
                "{t} threads"
            );
        }
    }

    /// Test voxels: 0 to 96 in a scattered order.
    fn voxels(sizes: [usize; 3]) -> Vec<f32> {
        (0..sizes.iter().product::<usize>())
            .map(|i| ((i * 7919) % 97) as f32)
            .collect()
    }

    /// `t` workers helping with `work` at once.
    fn help(work: &super::GridWork<'_, '_, '_, f32>, t: usize) {
        std::thread::scope(|s| {
            for _ in 0..t {
                s.spawn(|| work.help());
            }
        });
    }

    /// Workers helping with a grid at once put it together, the grid one thread builds;
    /// before any helps there is none.
    #[test]
    fn grid_work_is_put_together_once() {
        let sizes = [19, 23, 70];
        let data = voxels(sizes);
        let vol = Volume::new(&data, sizes, Affine4::IDENTITY).unwrap();
        let plan = SkipPlan::for_max(&vol, KernelName::Bspln3, SkipKind::MaxValue).unwrap();
        let one = plan.clone().build(&vol);
        for t in [1, 2, 3, 8] {
            let work = super::GridWork::new(plan.clone(), &vol, t);
            assert!(work.grid().is_none());
            help(&work, t);
            assert!(work.grid() == Some(&one), "{t} workers");
            assert!(work.into_grid() == Some(one.clone()));
        }
    }

    /// A kept grid aimed anew by any number of workers ([`super::GridWork::aim`]) is
    /// aimed as one thread aims it ([`RenderSpec::aim`]), in either arithmetic.
    #[test]
    fn kept_grids_are_aimed_by_the_workers() {
        use rnd_core::blend::Blend;
        use rnd_core::camera::CameraSpec;
        use rnd_core::kernel::Tent;
        use rnd_core::probe::Probe;
        use rnd_core::render::{RenderParams, RenderSpec};
        let sizes = [20, 18, 24];
        let data = voxels(sizes);
        let vol = Volume::new(&data, sizes, Affine4::IDENTITY).unwrap();
        let e: Vec<[f32; 4]> = (0..50)
            .map(|i| [1.0, 0.5, 0.2, if i < 30 { 0.0 } else { 0.4 }])
            .collect();
        let lut = Lut::new(0.0, 97.0, e).unwrap();
        let mut aimed = 0;
        for eye in [[1.0, 2.0, 3.0], [0.0, 0.0, 1.0], [-2.0, 1.0, 0.5]] {
            for reference in [true, false] {
                let cam = CameraSpec::framing(&vol.world_corners(), eye)
                    .unwrap()
                    .size(40, 36)
                    .orthographic(true);
                let mut p = RenderParams::new(cam);
                (p.blend, p.probe, p.reference) = (Blend::Over, Probe::Rgba, reference);
                let spec = RenderSpec::new(p, Some(&lut), None, &[]).unwrap();
                let kept = spec.skip_plan(&vol, KernelName::Tent).unwrap().build(&vol);
                let mut want = kept.clone();
                spec.aim::<f32, Tent, 2>(vol, &mut want);
                assert!(want != kept, "not aimed: {eye:?}");
                aimed += 1;
                for t in [1, 2, 3, 8] {
                    let re = spec.re_aim::<f32, Tent, 2>(vol, &kept);
                    let work = super::GridWork::aim(re, kept.clone(), &vol, t);
                    assert!(work.grid().is_none());
                    help(&work, t);
                    assert!(work.grid() == Some(&want), "{eye:?}, {t} workers");
                    assert!(work.into_grid() == Some(want.clone()));
                }
            }
        }
        assert_eq!(aimed, 6);
    }

    /// `cpu::leave` moves the calling thread off the CPU it is on, to another it may
    /// run on, and leaves it the set of CPUs it had (so it may come back later); not
    /// when there are more workers than CPUs it may run on.
    #[test]
    #[cfg(target_os = "linux")]
    fn workers_leave_the_callers_cpu() {
        let allowed = || super::cpu::allowed().expect("sched_getaffinity answers on Linux");
        let before = allowed();
        // SAFETY: counts the bits of a set we own.
        let n = unsafe { libc::CPU_COUNT(&before) } as usize;
        if n < 2 {
            eprintln!("skipped: this thread may run on one CPU only");
            return;
        }
        // More workers than CPUs: it stays (the scheduler may still move it on its own,
        // so once in a few tries is enough).
        let stayed = (0..5).any(|_| {
            let here = super::cpu::current();
            super::cpu::leave(here, n + 1);
            super::cpu::current() == here
        });
        assert!(stayed, "a thread among more workers than CPUs stays");
        // (The scheduler may move the thread back at any time after; so a few tries.)
        let mut moved = false;
        for _ in 0..5 {
            let here = super::cpu::current().expect("sched_getcpu answers on Linux");
            super::cpu::leave(Some(here), n);
            let after = allowed();
            // SAFETY: compares two sets we own.
            let same = unsafe { libc::CPU_EQUAL(&before, &after) };
            assert!(same, "the set is as before");
            if super::cpu::current() != Some(here) {
                moved = true;
                break;
            }
        }
        assert!(moved, "the thread left its CPU");
    }

    /// A render's image (reserved uninitialized, each worker clearing its own rows just
    /// before casting them) holds exactly what its rows render to on cleared memory, on
    /// any thread count, even where the allocator hands back memory full of NaNs: the
    /// image's corners, whose rays miss the volume, hold zeros. (The rows write every
    /// float of their pixels, so the clearing is what makes the memory floats before it
    /// is lent as such, not what the pixels end up holding; a wrong length given to the
    /// image, or a row left out, fails here.)
    #[test]
    fn images_start_cleared() {
        use rnd_core::blend::Blend;
        use rnd_core::camera::CameraSpec;
        use rnd_core::probe::Probe;
        use rnd_core::render::{RenderParams, RenderSpec};
        let sizes = [12, 10, 11];
        let data: Vec<f32> = (0..sizes.iter().product::<usize>())
            .map(|i| ((i * 37) % 101) as f32)
            .collect();
        let vol = Volume::new(&data, sizes, Affine4::IDENTITY).unwrap();
        let lut = Lut::new(
            0.0,
            100.0,
            (0..50)
                .map(|i| [1.0, 0.5, 0.2, if i < 30 { 0.0 } else { 0.4 }])
                .collect(),
        )
        .unwrap();
        let corners = vol.world_corners();
        let ctl = super::Control::new();
        for (blend, lut) in [(Blend::Over, Some(&lut)), (Blend::Max, None)] {
            // An oblique view, framed with room to spare: the image's corners miss the
            // volume.
            let cam = CameraSpec::framing(&corners, [1.0, -2.0, 1.5])
                .unwrap()
                .size(33, 29);
            let mut p = RenderParams::new(cam);
            (p.blend, p.sample_once) = (blend, false);
            p.probe = if lut.is_some() {
                Probe::Rgba
            } else {
                Probe::Value
            };
            let sp = RenderSpec::new(p, lut, None, &[]).unwrap();
            let [_, h] = sp.size();
            let mut want = vec![0.0f32; sp.image_len()];
            sp.render_rows(vol.into(), KernelName::Tent, None, 0..h, &mut want, None)
                .unwrap();
            let ch = sp.channels();
            assert!(want[..ch]
                .iter()
                .chain(&want[want.len() - ch..])
                .all(|&x| x == 0.0));
            assert!(want.iter().any(|&x| x > 0.0));
            for threads in [1, 2, 3] {
                // Memory of the image's size, full of NaNs, given back to the allocator
                // just before the render asks for its image.
                drop(vec![f32::NAN; sp.image_len()]);
                let got =
                    super::render_with(&sp, vol.into(), KernelName::Tent, threads, &ctl).unwrap();
                let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(&got), bits(&want), "{blend:?}, {threads} threads");
            }
        }
    }

    /// A loaded volume keeps its skip grid between renders: the frames after the first
    /// build none while the kind, kernel, LUT and bounds stay (whatever the camera and
    /// thread count), one when any changes, and every frame has the bits of a render
    /// that builds its own grid. A copy of the volume keeps nothing.
    #[test]
    fn volumes_keep_their_grids_between_frames() {
        use crate::volume_io::{VolumeBuf, VolumeData};
        use rnd_core::blend::Blend;
        use rnd_core::camera::CameraSpec;
        use rnd_core::probe::Probe;
        use rnd_core::render::{RenderParams, RenderSpec};
        let sizes = [24, 20, 22];
        let data: Vec<i16> = (0..sizes.iter().product::<usize>())
            .map(|i| {
                let (x, y, z) = (i % 24, (i / 24) % 20, i / 480);
                let d = (x as i32 - 12).pow(2) + (y as i32 - 9).pow(2) + (z as i32 - 11).pow(2);
                (1000 - 12 * d).max(0) as i16 + (i % 17) as i16
            })
            .collect();
        let vol = VolumeBuf::new(VolumeData::I16(data), sizes, Affine4::IDENTITY).unwrap();
        let lut = |a: f32| {
            let e: Vec<[f32; 4]> = (0..100)
                .map(|i| [1.0, 0.5, 0.2, if i < 40 { 0.0 } else { a }])
                .collect();
            Lut::new(0.0, 1000.0, e).unwrap()
        };
        let (l1, l2) = (lut(0.3), lut(0.6));
        let corners = vol.view().world_corners();
        fn spec<'l>(
            corners: &[[f64; 3]],
            lut: Option<&'l Lut>,
            eye: [f64; 3],
            blend: Blend,
        ) -> RenderSpec<'l> {
            let cam = CameraSpec::framing(corners, eye).unwrap().size(40, 36);
            let mut p = RenderParams::new(cam);
            p.blend = blend;
            p.probe = if lut.is_some() {
                Probe::Rgba
            } else {
                Probe::Value
            };
            p.sample_once = false;
            RenderSpec::new(p, lut, None, &[]).unwrap()
        }
        let ctl = super::Control::new();
        let mut built = 0;
        let frames = [
            (
                Some(&l1),
                [1.0, 2.0, 3.0],
                Blend::Over,
                KernelName::Tent,
                true,
            ),
            (
                Some(&l1),
                [-2.0, 1.0, 0.5],
                Blend::Over,
                KernelName::Tent,
                false,
            ),
            (
                Some(&l1),
                [0.0, 0.0, 1.0],
                Blend::Over,
                KernelName::Tent,
                false,
            ),
            (
                Some(&l2),
                [0.0, 0.0, 1.0],
                Blend::Over,
                KernelName::Tent,
                true,
            ),
            (
                Some(&l2),
                [0.0, 0.0, 1.0],
                Blend::Over,
                KernelName::Bspln3,
                true,
            ),
            (None, [1.0, 0.0, 0.0], Blend::Max, KernelName::Bspln3, true),
            (None, [1.0, 1.0, 0.0], Blend::Max, KernelName::Bspln3, false),
            (
                Some(&l2),
                [0.0, 0.0, 1.0],
                Blend::Over,
                KernelName::Bspln3,
                true,
            ),
        ];
        for (i, &(lut, eye, blend, k, builds)) in frames.iter().enumerate() {
            let sp = spec(&corners, lut, eye, blend);
            assert!(sp.skip_kind().is_some(), "frame {i} has a grid");
            let kept = super::render_volume(&sp, &vol, k, 1 + i % 3, &ctl).unwrap();
            built += usize::from(builds);
            assert_eq!(vol.grids().built(), built, "frame {i}");
            let own = super::render_with(&sp, vol.view(), k, 1, &ctl).unwrap();
            assert!(kept == own, "frame {i}");
            assert!(kept.iter().any(|&x| x > 0.0), "frame {i} shows something");
        }
        let copy = vol.clone();
        assert_eq!(copy.grids().built(), 0);
        let sp = spec(&corners, Some(&l2), [0.0, 0.0, 1.0], Blend::Over);
        super::render_volume(&sp, &copy, KernelName::Bspln3, 1, &ctl).unwrap();
        assert_eq!((copy.grids().built(), vol.grids().built()), (1, built));
    }

    /// A volume whose rows alias (256 floats, 512 shorts; 16 MiB) renders without a
    /// skip grid from a copy with padded rows, made once and kept, giving the bits of
    /// the unpadded volume for bspln3 value and gradient MIPs and lit `over`, on one and
    /// three threads; with a skip grid (these volumes always get the `max` grid, being
    /// below the pilot's size) no copy is made; tent, and padding turned off, render
    /// the volume as it is.
    #[test]
    fn padded_copies_render_the_same_bits() {
        use crate::volume_io::{
            padding_helps_here, padding_pays_in_one_frame_here, Padding, VolumeBuf, VolumeData,
            ROW_PAD_BYTES,
        };
        use rnd_core::blend::Blend;
        use rnd_core::camera::CameraSpec;
        use rnd_core::light::{Light, LightSpace};
        use rnd_core::probe::Probe;
        use rnd_core::render::{AnyVolume, RenderParams, RenderSpec};
        let f = |i: usize, s: [usize; 3]| {
            let (x, y, z) = (i % s[0], i / s[0] % s[1], i / (s[0] * s[1]));
            let r = |c: usize, n: usize| (c as f32 - n as f32 / 2.0) / n as f32;
            let d = r(x, s[0]).powi(2) + r(y, s[1]).powi(2) + 4.0 * r(z, s[2]).powi(2);
            (1.0 - 4.0 * d).max(0.0) * (1.0 + 0.3 * ((x + 3 * y + 7 * z) % 5) as f32)
        };
        let (sf, ss) = ([256, 256, 64], [512, 256, 64]);
        let n = |s: [usize; 3]| s[0] * s[1] * s[2];
        let vols = [
            VolumeData::F32((0..n(sf)).map(|i| f(i, sf)).collect()),
            VolumeData::I16((0..n(ss)).map(|i| (1000.0 * f(i, ss)) as i16).collect()),
        ];
        let light = [Light::new([1.0; 3], [1.0, 2.0, 3.0], LightSpace::View).unwrap()];
        let ctl = super::Control::new();
        for ((data, sizes), scale) in vols.into_iter().zip([sf, ss]).zip([1.0, 1000.0]) {
            let entries = vec![[1.0, 1.0, 1.0, 0.0], [1.0, 0.5, 0.2, 0.6]];
            let lut = Lut::new(0.0, scale, entries).unwrap();
            let geom = Affine4::from_spacing([1.0, 1.0, 4.0], [-128.0; 3]);
            let mut vol = VolumeBuf::new(data, sizes, geom).unwrap();
            // (On any processor: `Auto` pads only where it pays.)
            vol.set_padding(Padding::Always);
            let row = |v: AnyVolume<'_>| match v {
                AnyVolume::F32(v) => (v.row_stride(), 4),
                AnyVolume::I16(v) => (v.row_stride(), 2),
            };
            let corners = vol.view().world_corners();
            let mut copied = false;
            for (skip, probe, blend) in [
                (true, Probe::Value, Blend::Max),
                (true, Probe::RgbaLit, Blend::Over),
                (false, Probe::Value, Blend::Max),
                (false, Probe::GradMag, Blend::Max),
                (false, Probe::RgbaLit, Blend::Over),
            ] {
                let cam = CameraSpec::framing(&corners, [1.0, -3.0, 0.5])
                    .unwrap()
                    .size(40, 32);
                let mut p = RenderParams::new(cam);
                (p.probe, p.blend, p.plane_sep, p.skip_empty) = (probe, blend, 1.5, skip);
                let sp = RenderSpec::new(p, Some(&lut), None, &light).unwrap();
                let plain =
                    super::render_with(&sp, vol.view(), KernelName::Bspln3, 1, &ctl).unwrap();
                assert!(plain.iter().any(|&x| x > 0.0), "{probe} shows something");
                for threads in [1, 3] {
                    let padded =
                        super::render_volume(&sp, &vol, KernelName::Bspln3, threads, &ctl).unwrap();
                    assert!(
                        padded
                            .iter()
                            .zip(&plain)
                            .all(|(a, b)| a.to_bits() == b.to_bits()),
                        "{sizes:?} {probe}, {threads} threads"
                    );
                }
                // The first render without a grid makes the copy.
                copied |= !skip;
                assert_eq!(
                    vol.has_padded_copy(),
                    copied,
                    "{sizes:?} {probe} skip {skip}"
                );
            }
            let (stride, bytes) = row(vol.render_view(KernelName::Bspln3, 2));
            assert_eq!(stride, sizes[0] + ROW_PAD_BYTES / bytes, "{sizes:?}");
            assert_eq!(row(vol.render_view(KernelName::Tent, 2)).0, sizes[0]);
            vol.set_padding(Padding::Never);
            assert_eq!(row(vol.render_view(KernelName::Bspln3, 2)).0, sizes[0]);
            vol.set_padding(Padding::Auto);
            let auto = row(vol.render_view(KernelName::Bspln3, 2)).0;
            assert_eq!(auto > sizes[0], padding_helps_here(), "{sizes:?}");
            vol.set_padding(Padding::AutoOneFrame);
            let once = row(vol.render_view(KernelName::Bspln3, 2)).0;
            assert_eq!(
                once > sizes[0],
                padding_pays_in_one_frame_here(),
                "{sizes:?}"
            );
            // (Pads in one frame only where it pads at all.)
            assert!(!padding_pays_in_one_frame_here() || padding_helps_here());
        }
    }
}
