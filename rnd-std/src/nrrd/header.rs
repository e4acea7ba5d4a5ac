//! NRRD header fields.

use std::fmt;

/// NRRD scalar types.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ScalarType {
    /// signed char
    I8,
    /// unsigned char
    U8,
    /// short
    I16,
    /// unsigned short
    U16,
    /// int
    I32,
    /// unsigned int
    U32,
    /// long long
    I64,
    /// unsigned long long
    U64,
    /// float
    F32,
    /// double
    F64,
}

impl ScalarType {
    /// Every type.
    pub const ALL: [ScalarType; 10] = [
        ScalarType::I8,
        ScalarType::U8,
        ScalarType::I16,
        ScalarType::U16,
        ScalarType::I32,
        ScalarType::U32,
        ScalarType::I64,
        ScalarType::U64,
        ScalarType::F32,
        ScalarType::F64,
    ];
    /// Bytes per sample.
    pub fn size(self) -> usize {
        match self {
            ScalarType::I8 | ScalarType::U8 => 1,
            ScalarType::I16 | ScalarType::U16 => 2,
            ScalarType::I32 | ScalarType::U32 | ScalarType::F32 => 4,
            ScalarType::I64 | ScalarType::U64 | ScalarType::F64 => 8,
        }
    }
    /// Canonical NRRD name (as Teem writes it).
    pub fn as_str(self) -> &'static str {
        match self {
            ScalarType::I8 => "signed char",
            ScalarType::U8 => "unsigned char",
            ScalarType::I16 => "short",
            ScalarType::U16 => "unsigned short",
            ScalarType::I32 => "int",
            ScalarType::U32 => "unsigned int",
            ScalarType::I64 => "long long int",
            ScalarType::U64 => "unsigned long long int",
            ScalarType::F32 => "float",
            ScalarType::F64 => "double",
        }
    }
    /// Parses any NRRD spelling.
    pub fn parse(s: &str) -> Option<ScalarType> {
        let s = s.trim().to_ascii_lowercase();
        Some(match s.as_str() {
            "signed char" | "int8" | "int8_t" | "char" => ScalarType::I8,
            "uchar" | "unsigned char" | "uint8" | "uint8_t" => ScalarType::U8,
            "short" | "short int" | "signed short" | "signed short int" | "int16" | "int16_t" => {
                ScalarType::I16
            }
            "ushort" | "unsigned short" | "unsigned short int" | "uint16" | "uint16_t" => {
                ScalarType::U16
            }
            "int" | "signed int" | "int32" | "int32_t" => ScalarType::I32,
            "uint" | "unsigned int" | "uint32" | "uint32_t" => ScalarType::U32,
            "longlong"
            | "long long"
            | "long long int"
            | "signed long long"
            | "signed long long int"
            | "int64"
            | "int64_t" => ScalarType::I64,
            "ulonglong"
            | "unsigned long long"
            | "unsigned long long int"
            | "uint64"
            | "uint64_t" => ScalarType::U64,
            "float" => ScalarType::F32,
            "double" => ScalarType::F64,
            _ => return None,
        })
    }
    /// True for float and double.
    pub fn is_float(self) -> bool {
        matches!(self, ScalarType::F32 | ScalarType::F64)
    }
}

impl fmt::Display for ScalarType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// Data encodings.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Encoding {
    /// Raw bytes.
    Raw,
    /// Whitespace-separated numbers.
    Ascii,
    /// Two hex digits per byte.
    Hex,
    /// gzip-compressed raw.
    Gzip,
    /// bzip2-compressed raw.
    Bzip2,
}

impl Encoding {
    /// Every encoding.
    pub const ALL: [Encoding; 5] = [
        Encoding::Raw,
        Encoding::Ascii,
        Encoding::Hex,
        Encoding::Gzip,
        Encoding::Bzip2,
    ];
    /// Name as written in headers.
    pub fn as_str(self) -> &'static str {
        match self {
            Encoding::Raw => "raw",
            Encoding::Ascii => "ascii",
            Encoding::Hex => "hex",
            Encoding::Gzip => "gzip",
            Encoding::Bzip2 => "bzip2",
        }
    }
    /// Parses any spelling.
    pub fn parse(s: &str) -> Option<Encoding> {
        Some(match s.trim().to_ascii_lowercase().as_str() {
            "raw" => Encoding::Raw,
            "ascii" | "text" | "txt" => Encoding::Ascii,
            "hex" => Encoding::Hex,
            "gzip" | "gz" => Encoding::Gzip,
            "bzip2" | "bz2" => Encoding::Bzip2,
            _ => return None,
        })
    }
}

/// Byte order.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Endian {
    /// Little-endian.
    Little,
    /// Big-endian.
    Big,
}

/// Sample centring of an axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Centering {
    /// Not given (`???` or `none`).
    Unknown,
    /// Cell-centred.
    Cell,
    /// Node-centred.
    Node,
}

impl Centering {
    /// Name as written in headers.
    pub fn as_str(self) -> &'static str {
        match self {
            Centering::Unknown => "???",
            Centering::Cell => "cell",
            Centering::Node => "node",
        }
    }
}

/// Everything a NRRD header can say that rendr uses; other fields are kept verbatim in
/// `other`.
#[derive(Debug, Clone, PartialEq)]
pub struct Header {
    /// Magic version (1..=5) read; written as 4.
    pub version: u8,
    /// Sample type.
    pub scalar: ScalarType,
    /// Sizes, fastest axis first (`dimension` = len).
    pub sizes: Vec<usize>,
    /// Data encoding.
    pub encoding: Encoding,
    /// Byte order of the data.
    pub endian: Endian,
    /// `content:` text.
    pub content: Option<String>,
    /// `space:` name (e.g. `left-posterior-superior`).
    pub space: Option<String>,
    /// `space dimension:` (when given without `space`).
    pub space_dimension: Option<usize>,
    /// Per-axis direction vectors (`None` for `none`).
    pub space_directions: Option<Vec<Option<Vec<f64>>>>,
    /// `space origin:`.
    pub space_origin: Option<Vec<f64>>,
    /// `spacings:` (NaN for absent).
    pub spacings: Option<Vec<f64>>,
    /// `axis mins:`.
    pub axis_mins: Option<Vec<f64>>,
    /// `axis maxs:`.
    pub axis_maxs: Option<Vec<f64>>,
    /// `centerings:`.
    pub centerings: Option<Vec<Centering>>,
    /// `kinds:` (verbatim words).
    pub kinds: Option<Vec<String>>,
    /// `labels:`.
    pub labels: Option<Vec<String>>,
    /// `key:=value` pairs in order.
    pub key_values: Vec<(String, String)>,
    /// Other fields (name, value) kept verbatim.
    pub other: Vec<(String, String)>,
    /// Comment lines (without `#`).
    pub comments: Vec<String>,
}

impl Header {
    /// A bare header for a type and sizes.
    pub fn new(scalar: ScalarType, sizes: Vec<usize>) -> Self {
        Header {
            version: 4,
            scalar,
            sizes,
            encoding: Encoding::Raw,
            endian: Endian::Little,
            content: None,
            space: None,
            space_dimension: None,
            space_directions: None,
            space_origin: None,
            spacings: None,
            axis_mins: None,
            axis_maxs: None,
            centerings: None,
            kinds: None,
            labels: None,
            key_values: Vec::new(),
            other: Vec::new(),
            comments: Vec::new(),
        }
    }
    /// Dimension.
    pub fn dimension(&self) -> usize {
        self.sizes.len()
    }
    /// Number of samples (None on overflow).
    pub fn count(&self) -> Option<usize> {
        self.sizes.iter().try_fold(1usize, |a, &s| a.checked_mul(s))
    }
    /// Value of key `k` in the key/value pairs.
    pub fn key(&self, k: &str) -> Option<&str> {
        self.key_values
            .iter()
            .rev()
            .find(|(a, _)| a == k)
            .map(|(_, v)| v.as_str())
    }
    /// Space dimension, from `space` or `space dimension`.
    pub fn space_dim(&self) -> Option<usize> {
        if let Some(d) = self.space_dimension {
            return Some(d);
        }
        let s = self.space.as_deref()?;
        Some(match s {
            "right-anterior-superior-time"
            | "left-anterior-superior-time"
            | "left-posterior-superior-time"
            | "scanner-xyz-time"
            | "3D-right-handed-time"
            | "3D-left-handed-time" => 4,
            _ => 3,
        })
    }
}
