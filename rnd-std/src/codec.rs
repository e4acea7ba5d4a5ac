//! The compressed streams rendr reads and writes, each behind its cargo feature:
//! `gzip` (gzip and zlib streams: NRRD `gzip`, `.nii.gz`, MetaImage `.zraw`) and `bzip2`
//! (NRRD `bzip2`). Without the feature such data is refused with a message naming it.

use std::io::{Read, Write};

use crate::{Error, ErrorKind, Result};

#[allow(dead_code)] // unused when every codec is compiled in
fn missing(what: &str, feature: &str) -> Error {
    Error::msg(format!(
        "{what} data needs rnd-std's cargo feature \"{feature}\", which this build lacks"
    ))
    .with_kind(ErrorKind::Format)
}

/// A decoder of (possibly multi-member) gzip data read from `r`.
pub(crate) fn gunzip<'a>(r: impl Read + 'a) -> Result<Box<dyn Read + 'a>> {
    #[cfg(feature = "gzip")]
    return Ok(Box::new(flate2::read::MultiGzDecoder::new(r)));
    #[cfg(not(feature = "gzip"))]
    {
        let _ = r;
        Err(missing("gzip", "gzip"))
    }
}

/// A decoder of a zlib stream read from `r`.
#[cfg_attr(not(feature = "metaimage"), allow(dead_code))]
pub(crate) fn unzlib<'a>(r: impl Read + 'a) -> Result<Box<dyn Read + 'a>> {
    #[cfg(feature = "gzip")]
    return Ok(Box::new(flate2::read::ZlibDecoder::new(r)));
    #[cfg(not(feature = "gzip"))]
    {
        let _ = r;
        Err(missing("zlib-compressed", "gzip"))
    }
}

/// A decoder of (possibly multi-stream) bzip2 data read from `r`.
pub(crate) fn bunzip2<'a>(r: impl Read + 'a) -> Result<Box<dyn Read + 'a>> {
    #[cfg(feature = "bzip2")]
    return Ok(Box::new(bzip2::read::MultiBzDecoder::new(r)));
    #[cfg(not(feature = "bzip2"))]
    {
        let _ = r;
        Err(missing("bzip2", "bzip2"))
    }
}

/// Writes through `fill` into a gzip (level 6) stream on `w`, finishing the stream.
pub(crate) fn gzip_to(
    w: &mut dyn Write,
    fill: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<std::io::Result<()>> {
    #[cfg(feature = "gzip")]
    {
        let mut e = flate2::write::GzEncoder::new(w, flate2::Compression::new(6));
        Ok(fill(&mut e).and_then(|()| e.finish().map(|_| ())))
    }
    #[cfg(not(feature = "gzip"))]
    {
        let _ = (w, fill);
        Err(missing("gzip", "gzip"))
    }
}

/// Writes through `fill` into a bzip2 (level 6) stream on `w`, finishing the stream.
pub(crate) fn bzip2_to(
    w: &mut dyn Write,
    fill: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<std::io::Result<()>> {
    #[cfg(feature = "bzip2")]
    {
        let mut e = bzip2::write::BzEncoder::new(w, bzip2::Compression::new(6));
        Ok(fill(&mut e).and_then(|()| e.finish().map(|_| ())))
    }
    #[cfg(not(feature = "bzip2"))]
    {
        let _ = (w, fill);
        Err(missing("bzip2", "bzip2"))
    }
}
