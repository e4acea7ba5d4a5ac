//! This machine's floating-point peak on one core, to set rendr's sample rates against:
//! f32 fused multiply-adds (2 flops each) and separate multiplies and adds (the
//! operations rendr's bit-exact sums use: no FMA), in the widest vectors the processor
//! has, with enough independent chains to hide the latency. Prints one line per
//! measurement, in Gflop/s. Run with `cargo bench -p rnd-tests --bench peak`.

use std::time::Instant;

/// Independent accumulator chains (latency 4 × 2 ports ≤ 12).
const CHAINS: usize = 12;
/// Iterations of the inner loop per timing.
const ITERS: u64 = 20_000_000;

fn main() {
    #[cfg(target_arch = "x86_64")]
    {
        let (name, lanes) = if is_x86_feature_detected!("avx512f") {
            ("AVX-512", 16)
        } else if is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma") {
            ("AVX2", 8)
        } else {
            println!("peak: no AVX2+FMA on this processor; nothing measured");
            return;
        };
        for fused in [true, false] {
            let best = (0..5)
                .map(|_| {
                    let t = Instant::now();
                    let x = std::hint::black_box(run(lanes, fused));
                    std::hint::black_box(x);
                    t.elapsed().as_secs_f64()
                })
                .fold(f64::INFINITY, f64::min);
            // FMA: 2 flops per lane; mul + add: 2 operations (2 flops) per lane.
            let flops = ITERS as f64 * CHAINS as f64 * lanes as f64 * 2.0;
            println!(
                "peak {name} f32 {}: {:.1} Gflop/s on one core",
                if fused { "FMA" } else { "mul+add" },
                flops / best / 1e9
            );
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    println!("peak: only measured on x86_64");
}

#[cfg(target_arch = "x86_64")]
fn run(lanes: usize, fused: bool) -> f32 {
    // SAFETY: `main` checked that the processor has the features of the called function.
    unsafe {
        match (lanes, fused) {
            (16, true) => fma512(),
            (16, false) => muladd512(),
            (_, true) => fma256(),
            (_, false) => muladd256(),
        }
    }
}

macro_rules! peak_fn {
    ($name:ident, $feat:literal, $set:ident, $op:expr, $reduce:ident) => {
        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = $feat)]
        unsafe fn $name() -> f32 {
            use std::arch::x86_64::*;
            let a = $set(std::hint::black_box(0.999_9));
            let b = $set(std::hint::black_box(1e-7));
            let mut acc = [$set(1.0); CHAINS];
            for _ in 0..ITERS {
                for x in acc.iter_mut() {
                    *x = $op(*x, a, b);
                }
            }
            let mut s = 0.0;
            for x in acc {
                s += $reduce(x);
            }
            s
        }
    };
}

#[cfg(target_arch = "x86_64")]
fn first512(x: std::arch::x86_64::__m512) -> f32 {
    // SAFETY: avx512f was detected before any __m512 exists.
    unsafe { std::arch::x86_64::_mm512_cvtss_f32(x) }
}

#[cfg(target_arch = "x86_64")]
fn first256(x: std::arch::x86_64::__m256) -> f32 {
    // SAFETY: avx2 was detected before any __m256 exists.
    unsafe { std::arch::x86_64::_mm256_cvtss_f32(x) }
}

peak_fn!(
    fma512,
    "avx512f",
    _mm512_set1_ps,
    |x, a, b| _mm512_fmadd_ps(x, a, b),
    first512
);
peak_fn!(
    muladd512,
    "avx512f",
    _mm512_set1_ps,
    |x, a, b| _mm512_add_ps(_mm512_mul_ps(x, a), b),
    first512
);
peak_fn!(
    fma256,
    "avx2,fma",
    _mm256_set1_ps,
    |x, a, b| _mm256_fmadd_ps(x, a, b),
    first256
);
peak_fn!(
    muladd256,
    "avx2",
    _mm256_set1_ps,
    |x, a, b| _mm256_add_ps(_mm256_mul_ps(x, a), b),
    first256
);
