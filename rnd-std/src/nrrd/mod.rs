//! NRRD files (attached and detached headers; raw, ascii, hex, gzip, bzip2; both endians;
//! every scalar type) and plain-text numeric arrays.
//!
//! [`read`] accepts either: a file not starting with the `NRRD` magic is read as a
//! plain-text table (one row per line, numbers separated by whitespace or commas, `#` comments). Sizes are checked against the data (and the machine's
//! memory) before anything is allocated.

mod header;
pub(crate) mod read;
mod text;
mod write;

pub use header::{Centering, Encoding, Endian, Header, ScalarType};
pub use read::{
    centering, data_limit_bytes, input_files, read, read_bytes, read_region, read_with_threads,
    HEADER_MAX, SKIP_MAX, TEXT_MAX,
};
pub use text::{parse_text, write_text};
pub use write::{
    check_header, volume_nrrd, write, write_to, write_volume, WriteOptions, CONTENT_MAX,
};

/// Samples of any NRRD scalar type.
#[derive(Debug, Clone, PartialEq)]
pub enum Data {
    /// signed char
    I8(Vec<i8>),
    /// unsigned char
    U8(Vec<u8>),
    /// short
    I16(Vec<i16>),
    /// unsigned short
    U16(Vec<u16>),
    /// int
    I32(Vec<i32>),
    /// unsigned int
    U32(Vec<u32>),
    /// long long
    I64(Vec<i64>),
    /// unsigned long long
    U64(Vec<u64>),
    /// float
    F32(Vec<f32>),
    /// double
    F64(Vec<f64>),
}

macro_rules! each_data {
    ($d:expr, $v:ident => $e:expr) => {
        match $d {
            $crate::nrrd::Data::I8($v) => $e,
            $crate::nrrd::Data::U8($v) => $e,
            $crate::nrrd::Data::I16($v) => $e,
            $crate::nrrd::Data::U16($v) => $e,
            $crate::nrrd::Data::I32($v) => $e,
            $crate::nrrd::Data::U32($v) => $e,
            $crate::nrrd::Data::I64($v) => $e,
            $crate::nrrd::Data::U64($v) => $e,
            $crate::nrrd::Data::F32($v) => $e,
            $crate::nrrd::Data::F64($v) => $e,
        }
    };
}
pub(crate) use each_data;

impl Data {
    /// Number of samples.
    pub fn len(&self) -> usize {
        each_data!(self, v => v.len())
    }
    /// True when there are no samples.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// The scalar type.
    pub fn scalar_type(&self) -> ScalarType {
        match self {
            Data::I8(_) => ScalarType::I8,
            Data::U8(_) => ScalarType::U8,
            Data::I16(_) => ScalarType::I16,
            Data::U16(_) => ScalarType::U16,
            Data::I32(_) => ScalarType::I32,
            Data::U32(_) => ScalarType::U32,
            Data::I64(_) => ScalarType::I64,
            Data::U64(_) => ScalarType::U64,
            Data::F32(_) => ScalarType::F32,
            Data::F64(_) => ScalarType::F64,
        }
    }
    /// Sample `i` as f64, or `None` when there is no sample `i` (`i >= len()`).
    ///
    /// ```
    /// use rnd_std::nrrd::Data;
    /// let d = Data::I16(vec![-3, 7]);
    /// assert_eq!(d.get_f64(1), Some(7.0));
    /// assert_eq!(d.get_f64(2), None);
    /// ```
    #[allow(clippy::unnecessary_cast)] // the macro covers f32/f64 too
    pub fn get_f64(&self, i: usize) -> Option<f64> {
        each_data!(self, v => v.get(i).map(|&x| x as f64))
    }
    /// The samples in order, each as f64 (exact for every type but 64-bit
    /// integers beyond 2^53, which round).
    #[allow(clippy::unnecessary_cast)] // the macro covers f32/f64 too
    pub fn iter_f64(&self) -> Box<dyn Iterator<Item = f64> + '_> {
        each_data!(self, v => Box::new(v.iter().map(|&x| x as f64)))
    }
    /// All samples as f64.
    pub fn to_f64(&self) -> Vec<f64> {
        self.iter_f64().collect()
    }
    /// The samples in order as text: f32 samples by their own shortest digits (0.1,
    /// not the 0.10000000149011612 of their f64 widening), every other type widened
    /// to f64 and written by `f64_text`.
    pub(crate) fn texts<'a>(
        &'a self,
        f64_text: fn(f64) -> String,
    ) -> Box<dyn Iterator<Item = String> + 'a> {
        match self {
            Data::F32(v) => Box::new(v.iter().map(|x| x.to_string())),
            d => Box::new(d.iter_f64().map(f64_text)),
        }
    }
    /// All samples as f32 (rounded for wider types).
    #[allow(clippy::unnecessary_cast)] // the macro covers f32/f64 too
    pub fn to_f32(&self) -> Vec<f32> {
        match self {
            Data::F32(v) => v.clone(),
            _ => each_data!(self, v => v.iter().map(|&x| x as f32).collect()),
        }
    }
}

/// A NRRD array: header plus samples.
#[derive(Debug, Clone, PartialEq)]
pub struct Nrrd {
    /// Header (per-axis information, key/values...). `header.sizes` match the data.
    pub header: Header,
    /// The samples, fastest axis first.
    pub data: Data,
}

impl Nrrd {
    /// A new array with a plain header for `sizes`; fails when the sizes do not match.
    ///
    /// # Errors
    /// [`crate::ErrorKind::Format`] when the sizes do not match the samples.
    pub fn new(sizes: Vec<usize>, data: Data) -> crate::Result<Nrrd> {
        let n = sizes.iter().try_fold(1usize, |a, &s| a.checked_mul(s));
        if n != Some(data.len()) {
            return Err(crate::Error::msg(format!(
                "sizes {sizes:?} do not match {} samples",
                data.len()
            )));
        }
        let mut header = Header::new(data.scalar_type(), sizes);
        header.encoding = Encoding::Raw;
        Ok(Nrrd { header, data })
    }
    /// Sizes, fastest axis first.
    pub fn sizes(&self) -> &[usize] {
        &self.header.sizes
    }
}
