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
    let bytes = crate::userfile::read_checked(path, MAX_PLY).map_err(|e| DataError::new(path, e))?;
    parse_ply_points(&bytes).map_err(|e| DataError::new(path, format!("malformed PLY: {e}")))
}

#[derive(Clone, Copy, PartialEq)]
enum Encoding {
    Ascii,
    Little,
    Big,
}

/// Bytes of a PLY scalar type, or `None` for an unknown one.
fn type_size(t: &str) -> Option<usize> {
    Some(match t {
        "char" | "uchar" | "int8" | "uint8" => 1,
        "short" | "ushort" | "int16" | "uint16" => 2,
        "int" | "uint" | "int32" | "uint32" | "float" | "float32" => 4,
        "double" | "float64" => 8,
        _ => return None,
    })
}

/// The points of a PLY file's bytes.
pub fn parse_ply_points(bytes: &[u8]) -> Result<Vec<DVec3>, String> {
    // the header ends with the line `end_header` (LF or CR LF)
    let at = bytes.windows(10).position(|w| w == b"end_header").ok_or("no end_header line")?;
    let end = at + bytes[at..].iter().position(|&b| b == b'\n').ok_or("no end_header line")? + 1;
    let header = std::str::from_utf8(&bytes[..end]).map_err(|_| "header is not text")?;
    let mut lines = header.lines().map(str::trim);
    if lines.next() != Some("ply") {
        return Err("missing the 'ply' magic line".into());
    }
    let (mut encoding, mut count) = (None, None);
    // the vertex element's properties (name, bytes), and whether an element precedes it
    let (mut props, mut in_vertex, mut before) = (Vec::<(String, usize)>::new(), false, false);
    for l in lines {
        let t: Vec<&str> = l.split_whitespace().collect();
        match t.as_slice() {
            ["format", f, _] => {
                encoding = Some(match *f {
                    "ascii" => Encoding::Ascii,
                    "binary_little_endian" => Encoding::Little,
                    "binary_big_endian" => Encoding::Big,
                    other => return Err(format!("unknown format {other}")),
                })
            }
            ["element", name, n] => {
                in_vertex = *name == "vertex";
                if in_vertex {
                    count = Some(n.parse::<usize>().map_err(|_| format!("vertex count '{n}'"))?);
                } else if count.is_none() {
                    before = true;
                }
            }
            ["property", "list", ..] if in_vertex => return Err("a list property in the vertex element".into()),
            ["property", ty, name] if in_vertex => {
                let size = type_size(ty).ok_or_else(|| format!("unknown property type {ty}"))?;
                props.push((name.to_string(), size));
            }
            _ => {}
        }
    }
    let encoding = encoding.ok_or("no format line")?;
    let n = count.ok_or("no vertex element")?;
    if before {
        return Err("an element before the vertices".into());
    }
    let col = |c: &str| props.iter().position(|p| p.0 == c).ok_or_else(|| format!("no vertex property {c}"));
    let (ix, iy, iz) = (col("x")?, col("y")?, col("z")?);
    let body = &bytes[end..];
    let mut out = Vec::with_capacity(n.min(1 << 24));
    if encoding == Encoding::Ascii {
        let text = std::str::from_utf8(body).map_err(|_| "vertex lines are not text")?;
        let mut rows = text.lines().filter(|l| !l.trim().is_empty());
        for i in 0..n {
            let row: Vec<&str> =
                rows.next().ok_or_else(|| format!("{n} vertices declared, {i} found"))?.split_whitespace().collect();
            let v = |k: usize| {
                row.get(k).and_then(|s| s.parse::<f64>().ok()).ok_or_else(|| format!("vertex {i}: bad value"))
            };
            out.push(DVec3::new(v(ix)?, v(iy)?, v(iz)?));
        }
    } else {
        let offsets: Vec<usize> = props.iter().scan(0, |o, p| Some(std::mem::replace(o, *o + p.1))).collect();
        let stride: usize = props.iter().map(|p| p.1).sum();
        if body.len() / stride.max(1) < n {
            return Err(format!("{n} vertices declared, {} bytes for them", body.len()));
        }
        let value = |row: &[u8], k: usize| -> Result<f64, String> {
            let b = &row[offsets[k]..offsets[k] + props[k].1];
            let word =
                |a: [u8; 4]| if encoding == Encoding::Little { f32::from_le_bytes(a) } else { f32::from_be_bytes(a) };
            let long =
                |a: [u8; 8]| if encoding == Encoding::Little { f64::from_le_bytes(a) } else { f64::from_be_bytes(a) };
            match b.len() {
                4 => Ok(word(b.try_into().unwrap()) as f64),
                8 => Ok(long(b.try_into().unwrap())),
                _ => Err(format!("coordinate {} is not a float or double", props[k].0)),
            }
        };
        for row in body.chunks_exact(stride).take(n) {
            out.push(DVec3::new(value(row, ix)?, value(row, iy)?, value(row, iz)?));
        }
    }
    if out.iter().any(|p| !p.is_finite()) {
        return Err("a vertex is not finite".into());
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
    fn damaged_clouds_are_errors() {
        let short = format!("ply\nformat ascii 1.0\n{HEAD}1 2 3 0 0 0\n");
        assert!(parse_ply_points(short.as_bytes()).unwrap_err().contains("2 vertices declared, 1 found"));
        let no_z = "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nend_header\n1 2\n";
        assert!(parse_ply_points(no_z.as_bytes()).unwrap_err().contains("no vertex property z"));
        let truncated = format!("ply\nformat binary_little_endian 1.0\n{HEAD}").into_bytes();
        assert!(parse_ply_points(&truncated).unwrap_err().contains("bytes for them"));
        assert!(parse_ply_points(b"not a ply").is_err());
        let nan = format!("ply\nformat ascii 1.0\n{HEAD}1 2 nan 0 0 0\n1 2 3 0 0 0\n");
        assert!(parse_ply_points(nan.as_bytes()).unwrap_err().contains("not finite"));
    }
}
