//! Fuzzes the plain-text array parser.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(s) = std::str::from_utf8(data) {
        if let Ok(n) = rnd_std::nrrd::parse_text(s) {
            assert_eq!(n.data.len(), n.sizes().iter().product::<usize>());
        }
    }
});
