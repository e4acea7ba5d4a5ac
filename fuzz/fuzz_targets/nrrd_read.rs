//! Fuzzes the NRRD / plain-text array reader and volume construction: any bytes must
//! give a value or an error, never a panic, hang or huge allocation.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let dir = std::env::temp_dir();
    if let Ok(n) = rnd_std::nrrd::read_bytes(data, &dir) {
        let _ = rnd_std::volume_io::volume_from_nrrd(n);
    }
});
