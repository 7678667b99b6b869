//! The vertices of a PLY point cloud (`x`, `y`, `z`), as nerfstudio's
//! `ns-process-data` writes a COLMAP capture's sparse points beside its
//! `transforms.json` (`ply_file_path`, in the frames' coordinates): ASCII,
//! or binary in either byte order, the `vertex` element's other properties
//! (colour, normals) and any later elements skipped.

use super::types::DataError;
use glam::DVec3;
use std::path::Path;

/// Largest PLY file read (bytes): a sparse cloud of several million points.
const MAX_PLY: u64 = 512 << 20;

/// The points of the PLY file at `path`.
pub fn read_ply_points(path: &Path) -> Result<Vec<DVec3>, DataError> {
    let bytes = crate::util::userfile::read_checked(path, MAX_PLY).map_err(|e| DataError::new(path, e.to_string()))?;
    parse_ply_points(&bytes).map_err(|e| DataError::new(path, format!("malformed PLY: {e}")))
}

/// What makes bytes not a PLY point cloud this reader takes.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum PlyError {
    /// No line `end_header` ends the header.
    #[error("no end_header line")]
    NoEndHeader,
    /// The header holds bytes that are not UTF-8 text.
    #[error("header is not text")]
    HeaderNotText,
    /// The first line is not `ply`.
    #[error("missing the 'ply' magic line")]
    NoMagic,
    /// No `format` line.
    #[error("no format line")]
    NoFormat,
    /// A `format` other than `ascii`, `binary_little_endian` and `binary_big_endian`.
    #[error("unknown format {0}")]
    UnknownFormat(String),
    /// No `vertex` element.
    #[error("no vertex element")]
    NoVertices,
    /// The vertex count is not a whole number.
    #[error("vertex count '{0}'")]
    BadCount(String),
    /// Another element comes before the vertices.
    #[error("an element before the vertices")]
    ElementBeforeVertices,
    /// A list property among the vertex's.
    #[error("a list property in the vertex element")]
    ListProperty,
    /// A property type PLY does not define.
    #[error("unknown property type {0}")]
    UnknownType(String),
    /// A coordinate the vertices lack (`x`, `y` or `z`).
    #[error("no vertex property {0}")]
    NoCoordinate(&'static str),
    /// ASCII vertex lines that are not UTF-8 text.
    #[error("vertex lines are not text")]
    BodyNotText,
    /// Fewer vertex lines than the header declares.
    #[error("{declared} vertices declared, {found} found")]
    MissingVertices {
        /// The header's count.
        declared: usize,
        /// The lines present.
        found: usize,
    },
    /// Fewer binary bytes than the declared vertices take.
    #[error("{declared} vertices declared, {bytes} bytes for them")]
    ShortBody {
        /// The header's count.
        declared: usize,
        /// The bytes after the header.
        bytes: usize,
    },
    /// An ASCII vertex whose coordinate is missing or not a number.
    #[error("vertex {0}: bad value")]
    BadValue(usize),
    /// A coordinate that is infinite or NaN.
    #[error("a vertex is not finite")]
    NotFinite,
}

#[derive(Clone, Copy, PartialEq)]
enum Encoding {
    Ascii,
    Little,
    Big,
}

/// A PLY scalar type.
#[derive(Clone, Copy)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    /// The type a PLY header names, or `None` for an unknown one.
    fn of(t: &str) -> Option<Self> {
        Some(match t {
            "char" | "int8" => Self::I8,
            "uchar" | "uint8" => Self::U8,
            "short" | "int16" => Self::I16,
            "ushort" | "uint16" => Self::U16,
            "int" | "int32" => Self::I32,
            "uint" | "uint32" => Self::U32,
            "float" | "float32" => Self::F32,
            "double" | "float64" => Self::F64,
            _ => return None,
        })
    }

    /// Bytes per value.
    fn size(self) -> usize {
        match self {
            Self::I8 | Self::U8 => 1,
            Self::I16 | Self::U16 => 2,
            Self::I32 | Self::U32 | Self::F32 => 4,
            Self::F64 => 8,
        }
    }

    /// The value in `b` (`size` bytes, little-endian if `le`, else big-endian).
    fn read(self, b: &[u8], le: bool) -> f64 {
        let mut a = [0u8; 8];
        a[..b.len()].copy_from_slice(b);
        if !le {
            a[..b.len()].reverse();
        }
        let [a0, a1, a2, a3, ..] = a;
        match self {
            Self::I8 => a0 as i8 as f64,
            Self::U8 => a0 as f64,
            Self::I16 => i16::from_le_bytes([a0, a1]) as f64,
            Self::U16 => u16::from_le_bytes([a0, a1]) as f64,
            Self::I32 => i32::from_le_bytes([a0, a1, a2, a3]) as f64,
            Self::U32 => u32::from_le_bytes([a0, a1, a2, a3]) as f64,
            Self::F32 => f32::from_le_bytes([a0, a1, a2, a3]) as f64,
            Self::F64 => f64::from_le_bytes(a),
        }
    }
}

/// The points of a PLY file's bytes.
pub fn parse_ply_points(bytes: &[u8]) -> Result<Vec<DVec3>, PlyError> {
    // the header ends with the line `end_header` (LF or CR LF)
    let mut end = 0;
    loop {
        let next = bytes[end..].iter().position(|&b| b == b'\n').ok_or(PlyError::NoEndHeader)? + end + 1;
        let line = &bytes[end..next];
        end = next;
        if line.trim_ascii() == b"end_header" {
            break;
        }
    }
    let header = std::str::from_utf8(&bytes[..end]).map_err(|_| PlyError::HeaderNotText)?;
    let mut lines = header.lines().map(str::trim);
    if lines.next() != Some("ply") {
        return Err(PlyError::NoMagic);
    }
    let (mut encoding, mut count) = (None, None);
    // the vertex element's properties (name, type), and whether an element precedes it
    let (mut props, mut in_vertex, mut before) = (Vec::<(String, Scalar)>::new(), false, false);
    for l in lines {
        let t: Vec<&str> = l.split_whitespace().collect();
        match t.as_slice() {
            ["format", f, _] => {
                encoding = Some(match *f {
                    "ascii" => Encoding::Ascii,
                    "binary_little_endian" => Encoding::Little,
                    "binary_big_endian" => Encoding::Big,
                    other => return Err(PlyError::UnknownFormat(other.to_string())),
                })
            }
            ["element", name, n] => {
                in_vertex = *name == "vertex";
                if in_vertex {
                    count = Some(n.parse::<usize>().map_err(|_| PlyError::BadCount(n.to_string()))?);
                } else if count.is_none() {
                    before = true;
                }
            }
            ["property", "list", ..] if in_vertex => return Err(PlyError::ListProperty),
            ["property", ty, name] if in_vertex => {
                let ty = Scalar::of(ty).ok_or_else(|| PlyError::UnknownType(ty.to_string()))?;
                props.push((name.to_string(), ty));
            }
            _ => {}
        }
    }
    let encoding = encoding.ok_or(PlyError::NoFormat)?;
    let n = count.ok_or(PlyError::NoVertices)?;
    if before {
        return Err(PlyError::ElementBeforeVertices);
    }
    let col = |c: &'static str| props.iter().position(|p| p.0 == c).ok_or(PlyError::NoCoordinate(c));
    let (ix, iy, iz) = (col("x")?, col("y")?, col("z")?);
    let body = &bytes[end..];
    let mut out = Vec::with_capacity(n.min(1 << 24));
    if encoding == Encoding::Ascii {
        let text = std::str::from_utf8(body).map_err(|_| PlyError::BodyNotText)?;
        let mut rows = text.lines().filter(|l| !l.trim().is_empty());
        for i in 0..n {
            let row: Vec<&str> =
                rows.next().ok_or(PlyError::MissingVertices { declared: n, found: i })?.split_whitespace().collect();
            let v = |k: usize| row.get(k).and_then(|s| s.parse::<f64>().ok()).ok_or(PlyError::BadValue(i));
            out.push(DVec3::new(v(ix)?, v(iy)?, v(iz)?));
        }
    } else {
        let offsets: Vec<usize> = props.iter().scan(0, |o, p| Some(std::mem::replace(o, *o + p.1.size()))).collect();
        let stride: usize = props.iter().map(|p| p.1.size()).sum();
        if body.len() / stride.max(1) < n {
            return Err(PlyError::ShortBody { declared: n, bytes: body.len() });
        }
        let le = encoding == Encoding::Little;
        let value = |row: &[u8], k: usize| props[k].1.read(&row[offsets[k]..offsets[k] + props[k].1.size()], le);
        for row in body.chunks_exact(stride).take(n) {
            out.push(DVec3::new(value(row, ix), value(row, iy), value(row, iz)));
        }
    }
    if out.iter().any(|p| !p.is_finite()) {
        return Err(PlyError::NotFinite);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    const HEAD: &str = "element vertex 2\nproperty float x\nproperty float y\nproperty float z\n\
                        property uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n";

    #[test]
    fn ascii_and_binary_clouds_read_the_same_points() {
        let want = vec![DVec3::new(1.0, -2.0, 0.5), DVec3::new(0.25, 3.0, -4.0)];
        // nerfstudio's sparse_pc.ply: ASCII, colour after the coordinates
        let ascii = format!("ply\nformat ascii 1.0\n{HEAD}1 -2 0.5 10 20 30\n0.25 3 -4 1 2 3\n");
        assert_eq!(parse_ply_points(ascii.as_bytes()).unwrap(), want);
        assert_eq!(parse_ply_points(ascii.replace('\n', "\r\n").as_bytes()).unwrap(), want, "CR LF lines");
        for (format, le) in [("binary_little_endian", true), ("binary_big_endian", false)] {
            let mut b = format!("ply\nformat {format} 1.0\ncomment made by a test\n{HEAD}").into_bytes();
            for p in &want {
                for c in p.to_array() {
                    b.extend_from_slice(&if le { (c as f32).to_le_bytes() } else { (c as f32).to_be_bytes() });
                }
                b.extend_from_slice(&[7, 8, 9]);
            }
            assert_eq!(parse_ply_points(&b).unwrap(), want, "{format}");
        }
    }

    #[test]
    fn binary_coordinates_of_any_type_after_other_properties_read() {
        let head = "ply\nformat binary_little_endian 1.0\ncomment end_header is a word here\nelement vertex 1\n\
                    property uchar flag\nproperty double x\nproperty int y\nproperty short z\nend_header\n";
        let mut b = head.as_bytes().to_vec();
        b.push(1);
        b.extend_from_slice(&0.125f64.to_le_bytes());
        b.extend_from_slice(&(-7i32).to_le_bytes());
        b.extend_from_slice(&300i16.to_le_bytes());
        assert_eq!(parse_ply_points(&b).unwrap(), vec![DVec3::new(0.125, -7.0, 300.0)]);
    }

    #[test]
    fn damaged_clouds_are_errors() {
        let short = format!("ply\nformat ascii 1.0\n{HEAD}1 2 3 0 0 0\n");
        assert_eq!(parse_ply_points(short.as_bytes()), Err(PlyError::MissingVertices { declared: 2, found: 1 }));
        let no_z = "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nend_header\n1 2\n";
        assert_eq!(parse_ply_points(no_z.as_bytes()), Err(PlyError::NoCoordinate("z")));
        let truncated = format!("ply\nformat binary_little_endian 1.0\n{HEAD}").into_bytes();
        assert_eq!(parse_ply_points(&truncated), Err(PlyError::ShortBody { declared: 2, bytes: 0 }));
        assert_eq!(parse_ply_points(b"not a ply"), Err(PlyError::NoEndHeader));
        let nan = format!("ply\nformat ascii 1.0\n{HEAD}1 2 nan 0 0 0\n1 2 3 0 0 0\n");
        assert_eq!(parse_ply_points(nan.as_bytes()), Err(PlyError::NotFinite));
        assert_eq!(PlyError::MissingVertices { declared: 2, found: 1 }.to_string(), "2 vertices declared, 1 found");
    }
}
