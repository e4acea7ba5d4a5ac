//! Fuzzes the readers of the other volume formats (NIfTI-1/2, plain or gzip; MetaImage;
//! DICOM, through dicom-object and dicom-pixeldata) behind format recognition: any
//! file must load or give an error, never a panic, hang or huge allocation.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    // A folder of its own: a DICOM file is read with the series beside it.
    let dir = std::env::temp_dir().join(format!("rendr-fuzz-formats-{}", std::process::id()));
    if std::fs::create_dir_all(&dir).is_err() {
        return;
    }
    let path = dir.join("volume");
    if std::fs::write(&path, data).is_ok() {
        if let Ok(l) = rnd_std::formats::read(&path, 1) {
            let _ = rnd_std::volume_io::volume_from_nrrd(l.nrrd);
        }
    }
});
