//! Proof that `rnd-core` builds without `std`.
//!
//! This crate is `#![no_std]` and defines its own panic handler. If any crate in its
//! dependency graph (i.e. `rnd-core` or one of its dependencies) pulled in `std`, the
//! check would fail with "found duplicate lang item `panic_impl`". CI checks it alone with
//! `cargo check --manifest-path nostd-check/Cargo.toml`.
#![no_std]

/// Touches a few core items so the dependency is really linked.
pub fn smoke() -> f64 {
    let k = rnd_core::kernel::KernelName::Bspln3;
    k.eval(0.0, 0)
}

#[panic_handler]
fn panic(_info: &core::panic::PanicInfo) -> ! {
    loop {}
}
