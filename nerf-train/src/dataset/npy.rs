//! Minimal NPY (NumPy array file) reading and writing for 2-D f64/f32 arrays.

use super::types::DataError;
use std::path::Path;

/// Reads a 2-D `<f8` or `<f4` array (C or Fortran order); returns (rows,
/// cols, values) in C order (row after row).
pub fn read_npy_f64(path: &Path) -> Result<(usize, usize, Vec<f64>), DataError> {
    let bytes =
        crate::util::userfile::read_checked(path, 256 << 20).map_err(|e| DataError::new(path, e.to_string()))?;
    parse_npy_f64(path, &bytes)
}

/// [`read_npy_f64`] on the file's bytes (`path` names it in errors).
pub fn parse_npy_f64(path: &Path, bytes: &[u8]) -> Result<(usize, usize, Vec<f64>), DataError> {
    let bad = |m: &str| DataError::new(path, format!("malformed NPY: {m}"));
    if bytes.len() < 10 || &bytes[..6] != b"\x93NUMPY" {
        return Err(bad("missing magic"));
    }
    let (hlen, start) = match bytes[6] {
        1 => (u16::from_le_bytes([bytes[8], bytes[9]]) as usize, 10),
        2 | 3 if bytes.len() >= 12 => (u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]) as usize, 12),
        _ => return Err(bad("unsupported version")),
    };
    let header = bytes.get(start..start + hlen).ok_or_else(|| bad("header truncated"))?;
    let header = std::str::from_utf8(header).map_err(|_| bad("header is not text"))?;
    let descr = if header.contains("'<f8'") {
        8
    } else if header.contains("'<f4'") {
        4
    } else {
        return Err(bad("dtype must be little-endian float64 or float32"));
    };
    let fortran = header.contains("'fortran_order': True");
    let shape = header
        .split("'shape':")
        .nth(1)
        .and_then(|s| s.split('(').nth(1))
        .and_then(|s| s.split(')').next())
        .ok_or_else(|| bad("no shape"))?;
    let dims: Vec<usize> = shape
        .split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(|s| s.parse::<usize>())
        .collect::<Result<_, _>>()
        .map_err(|_| bad("shape is not a tuple of integers"))?;
    let (rows, cols) = match dims.as_slice() {
        [r, c] => (*r, *c),
        _ => return Err(bad("expected a 2-D array")),
    };
    let data = &bytes[start + hlen..];
    let need = rows.checked_mul(cols).and_then(|n| n.checked_mul(descr)).ok_or_else(|| bad("shape overflows"))?;
    if data.len() != need {
        return Err(bad(&format!("expected {need} data bytes, found {}", data.len())));
    }
    let vals: Vec<f64> = if descr == 8 {
        data.chunks_exact(8).map(|c| f64::from_le_bytes(c.try_into().unwrap())).collect()
    } else {
        data.chunks_exact(4).map(|c| f32::from_le_bytes(c.try_into().unwrap()) as f64).collect()
    };
    if fortran {
        // column after column on disk: element (r, c) at c·rows + r
        return Ok((rows, cols, (0..rows * cols).map(|i| vals[(i % cols) * rows + i / cols]).collect()));
    }
    Ok((rows, cols, vals))
}

/// Writes a C-order 2-D `<f8` array (NPY version 1.0), atomically.
pub fn write_npy_f64(path: &Path, rows: usize, cols: usize, vals: &[f64]) -> std::io::Result<()> {
    let mut header = format!("{{'descr': '<f8', 'fortran_order': False, 'shape': ({rows}, {cols}), }}");
    while (10 + header.len() + 1) % 64 != 0 {
        header.push(' ');
    }
    header.push('\n');
    let mut out = b"\x93NUMPY\x01\x00".to_vec();
    out.extend_from_slice(&(header.len() as u16).to_le_bytes());
    out.extend_from_slice(header.as_bytes());
    for v in vals {
        out.extend_from_slice(&v.to_le_bytes());
    }
    crate::util::atomic::write(path, &out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An NPY 1.0 file of `vals` (in the order given) with `header`'s order and shape.
    fn npy(order: &str, rows: usize, cols: usize, vals: &[f64]) -> Vec<u8> {
        let header = format!("{{'descr': '<f8', 'fortran_order': {order}, 'shape': ({rows}, {cols}), }}\n");
        let mut out = b"\x93NUMPY\x01\x00".to_vec();
        out.extend_from_slice(&(header.len() as u16).to_le_bytes());
        out.extend_from_slice(header.as_bytes());
        vals.iter().for_each(|v| out.extend_from_slice(&v.to_le_bytes()));
        out
    }

    #[test]
    fn fortran_order_reads_as_the_same_array_in_c_order() {
        let p = Path::new("poses_bounds.npy");
        // [[1, 2, 3], [4, 5, 6]]: row after row in C order, column after column in Fortran order
        let c = parse_npy_f64(p, &npy("False", 2, 3, &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0])).unwrap();
        let f = parse_npy_f64(p, &npy("True", 2, 3, &[1.0, 4.0, 2.0, 5.0, 3.0, 6.0])).unwrap();
        assert_eq!(c, (2, 3, vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0]));
        assert_eq!(f, c);
    }
}
