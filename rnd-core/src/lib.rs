//! # rnd-core: the engine of the rendr volume renderer
//!
//! `no_std` (with `alloc`): no IO, no threads, no printing. Everything a ray caster
//! needs, generic over the voxel type (`f32` / `i16`, [`voxel::Voxel`]) and over the
//! reconstruction kernel with its support as a const generic ([`kernel::Kernel<S>`]).
//! [`prelude`] brings in what a program that renders or probes needs.
//!
//! How data moves:
//!
//! 1. A [`volume::Volume`] borrows samples (an [`volume::OwnedVolume`] holds them) and
//!    knows its index-to-world matrix ([`affine::Affine4`]).
//! 2. A [`camera::CameraSpec`] (look-from/look-at/up, clipping, FOV, image size; built
//!    with [`camera::CameraSpec::looking_at`] or [`camera::CameraSpec::framing`])
//!    becomes a view frame ([`camera::Camera`]).
//! 3. A [`render::RenderSpec`] validates all parameters once (probe, blend, LUT
//!    [`txf::Lut`], Levoy opacity [`txf::Levoy`], lights [`light::Light`]).
//! 4. [`render::render`] casts one ray per pixel: the run-time (voxel type, kernel name)
//!    becomes one monomorphized loop, which reconstructs the volume by separable 3-D
//!    convolution at each sample, measures the [`probe::Probe`] and reduces the samples
//!    to a pixel with the [`blend::Blend`].
//!
//! ```
//! use rnd_core::prelude::*;
//!
//! // A 4x4x4 volume of ones centred on the origin, viewed from +z.
//! let geom = Affine4::from_spacing([1.0; 3], [-1.5; 3]);
//! let vol = OwnedVolume::from_fn([4, 4, 4], geom, |_| 1.0f32).unwrap();
//! let cam = CameraSpec::looking_at([0., 0., 10.], [0., 0., 0.])
//!     .up([0., 1., 0.])
//!     .clip(-3.0, 3.0)
//!     .fov(10.0)
//!     .size(4, 4)
//!     .orthographic(true);
//! let spec = RenderSpec::new(RenderParams::new(cam), None, None, &[]).unwrap();
//! let img = render(&spec, vol.view().into(), KernelName::Tent).unwrap();
//! assert_eq!(img[0], 1.0); // max of the value along the central rays
//! ```
#![no_std]
#![deny(missing_docs)]
#![deny(clippy::missing_errors_doc, clippy::missing_panics_doc)]
#![deny(unsafe_code)]
#![deny(clippy::undocumented_unsafe_blocks)]

extern crate alloc;

pub mod affine;
pub(crate) mod arith;
pub mod blend;
pub mod brick;
pub mod camera;
pub mod classify;
pub mod convo;
pub mod error;
pub mod kernel;
pub mod light;
#[doc(hidden)]
pub mod march;
#[doc(hidden)]
pub mod math;
pub mod probe;
#[doc(hidden)]
pub mod refarith;
pub mod render;
pub mod sdg;
#[allow(unsafe_code)]
#[doc(hidden)]
pub mod simd;
#[doc(hidden)]
pub mod skip;
pub mod txf;
pub mod volume;
pub mod voxel;

pub use error::{Error, ErrorKind, Param, Result};

/// Deterministic pseudo-random inputs for the unit tests.
#[cfg(test)]
pub(crate) mod test_rng {
    /// A 64-bit linear congruential generator (Knuth's MMIX multiplier and increment).
    pub(crate) struct Lcg(pub(crate) u64);

    impl Lcg {
        /// The next state.
        fn step(&mut self) -> u64 {
            self.0 = self
                .0
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            self.0
        }

        /// A number in [0, 1): the state's top 24 bits.
        pub(crate) fn next(&mut self) -> f32 {
            (self.step() >> 40) as f32 / (1u64 << 24) as f32
        }

        /// A number in [−s/2, s/2), from the state's top 24 bits.
        pub(crate) fn centred(&mut self, s: f64) -> f64 {
            ((self.step() >> 40) as f64 / (1u64 << 24) as f64 - 0.5) * s
        }

        /// A number of varied magnitude, in [−10⁴, 10⁴): a number in [−1, 1) times a
        /// power of ten from 10⁻³ to 10⁴, so that round-off differs between orders of
        /// operations.
        pub(crate) fn varied(&mut self) -> f32 {
            let x = self.step();
            let u = (x >> 40) as f32 / (1u64 << 24) as f32;
            let e = ((x >> 20) & 7) as i32 - 3;
            (u * 2.0 - 1.0) * 10f32.powi(e)
        }
    }
}

/// The types and functions a program that renders or probes volumes uses, in one
/// `use rnd_core::prelude::*;`.
pub mod prelude {
    pub use crate::affine::Affine4;
    pub use crate::blend::Blend;
    pub use crate::camera::{Camera, CameraSpec};
    pub use crate::error::{Error, ErrorKind, Param, Result};
    pub use crate::kernel::KernelName;
    pub use crate::light::{Light, LightSpace, Phong};
    pub use crate::probe::Probe;
    #[cfg(not(test))] // see `RenderSpec::cast`
    pub use crate::render::render;
    pub use crate::render::{AnyVolume, Probed, RenderParams, RenderSpec};
    pub use crate::txf::{Levoy, Lut, LutBuilder, Txf, TxfSpace};
    pub use crate::volume::{OwnedVolume, Volume};
    pub use crate::voxel::Voxel;
}

/// The README's examples, run as doctests.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;
