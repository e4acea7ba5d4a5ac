//! # rnd-core: the engine of the rendr volume renderer
//!
//! `#![no_std]` (with `alloc`): no IO, no threads, no printing. Everything a ray caster
//! needs, generic over the voxel type (`f32` / `i16`, [`voxel::Voxel`]) and over the
//! reconstruction kernel with its support as a const generic ([`kernel::Kernel<S>`]).
//!
//! How data moves:
//!
//! 1. A [`volume::Volume`] borrows samples and knows its index-to-world matrix
//!    ([`affine::Affine4`]).
//! 2. A [`camera::Camera`] turns look-from/look-at/up/FOV into a view frame.
//! 3. A [`render::RenderSpec`] validates all parameters once (probe, blend, LUT
//!    [`txf::Lut`], Levoy opacity [`txf::Levoy`], lights [`light::Light`]).
//! 4. [`render::dispatch`] turns the run-time (voxel type, kernel name) into one
//!    monomorphized call; below it a [`convo::Convo`] evaluates the separable 3-D
//!    convolution at each ray sample, the [`probe::Probe`] says what is measured, and a
//!    [`blend::Accum`] reduces the samples to a pixel.
//!
//! ```
//! use rnd_core::{affine::Affine4, camera::CameraSpec, kernel::KernelName};
//! use rnd_core::render::{render, AnyVolume, RenderParams, RenderSpec};
//! use rnd_core::volume::Volume;
//!
//! // A 4x4x4 volume of ones centred on the origin, viewed from +z.
//! let data = vec![1.0f32; 64];
//! let itow = Affine4::from_columns([1., 0., 0.], [0., 1., 0.], [0., 0., 1.], [-1.5, -1.5, -1.5]);
//! let vol = Volume::new(&data, [4, 4, 4], itow).unwrap();
//! let cam = CameraSpec { fr: [0., 0., 10.], at: [0., 0., 0.], up: [0., 1., 0.], nc: -3.,
//!     fc: 3., fov: 10., size: [4, 4], ortho: true };
//! let spec = RenderSpec::new(RenderParams::new(cam), None, None, &[]).unwrap();
//! let img = render(&spec, AnyVolume::F32(vol), KernelName::Tent).unwrap();
//! assert_eq!(img[0], 1.0); // max of the value along the central rays
//! ```
#![no_std]
#![warn(missing_docs)]
#![deny(unsafe_code)]
#![deny(clippy::undocumented_unsafe_blocks)]

extern crate alloc;

pub mod affine;
pub(crate) mod arith;
pub mod blend;
pub mod camera;
pub mod convo;
pub mod error;
pub mod kernel;
pub mod light;
pub mod march;
pub mod math;
pub mod probe;
pub mod refarith;
pub mod render;
pub mod sdg;
#[allow(unsafe_code)]
pub mod simd;
pub mod skip;
pub mod txf;
pub mod volume;
pub mod voxel;

pub use error::{Error, ErrorKind, Result};
