//! Fuzzes the txf / LUT / Levoy / light loaders on any array the reader accepts.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use rnd_std::files;

fuzz_target!(|data: &[u8]| {
    let p = Path::new("fuzz-input");
    let Ok(n) = rnd_std::nrrd::read_bytes(data, Path::new("/nonexistent")) else { return };
    if let Ok(t) = files::txf_from_nrrd(p, n.clone()) {
        let (lo, hi) = t.domain();
        let _ = t.eval((lo + hi) / 2.0);
        let _ = rnd_core::txf::Lut::generate(None, Some(&t), false, true, 16, 0.0, 1.0);
    }
    if let Ok(l) = files::lut_from_nrrd(p, n.clone()) {
        for v in [f32::NAN, f32::INFINITY, -1e30, 0.0, 1e30] {
            let _ = l.lookup(v);
        }
    }
    if let Ok(l) = files::levoy_from_nrrd(p, n.clone()) {
        let o = l.opacity(0.5, 1.0);
        assert!(!o.is_nan());
    }
    let _ = files::lights_from_nrrd(p, n);
});
