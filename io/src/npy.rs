//! NumPy `.npy` files (format versions 1–3): read any numeric dtype into an [`NdArray`], write f32/f64.

use std::path::Path;

use crate::error::{Error, Result};
use crate::fsutil::atomic_write;
use crate::pickle::{fortran_to_c, ArrayRef, DType, NdArray};

const MAGIC: &[u8] = b"\x93NUMPY";
/// Largest header we accept; real headers are < 200 bytes.
const MAX_HEADER: usize = 1 << 16;

/// Parse `.npy` bytes. Errors are plain messages (the caller adds the file name).
pub fn parse(bytes: &[u8]) -> std::result::Result<NdArray, String> {
    if bytes.len() < 10 || &bytes[..6] != MAGIC {
        return Err("not a .npy file (bad magic)".into());
    }
    let major = bytes[6];
    let (hlen, start) = match major {
        1 => (u16::from_le_bytes([bytes[8], bytes[9]]) as usize, 10),
        2 | 3 => {
            if bytes.len() < 12 {
                return Err("truncated header".into());
            }
            (
                u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]) as usize,
                12,
            )
        }
        v => return Err(format!("unsupported .npy version {v}")),
    };
    if hlen > MAX_HEADER || start + hlen > bytes.len() {
        return Err("truncated or oversized header".into());
    }
    let header = std::str::from_utf8(&bytes[start..start + hlen])
        .map_err(|_| "header is not text".to_string())?;
    let descr = header_value(header, "descr").ok_or("header lacks 'descr'")?;
    let descr = descr.trim_matches(|c| c == '\'' || c == '"');
    let (dtype, big) = DType::parse(descr).ok_or_else(|| format!("unsupported dtype '{descr}'"))?;
    let fortran = header_value(header, "fortran_order").ok_or("header lacks 'fortran_order'")?;
    let fortran = match fortran.trim() {
        "True" => true,
        "False" => false,
        other => return Err(format!("bad fortran_order '{other}'")),
    };
    let shape_txt = header_value(header, "shape").ok_or("header lacks 'shape'")?;
    let shape_txt = shape_txt
        .trim()
        .trim_start_matches('(')
        .trim_end_matches(')');
    let mut shape = Vec::new();
    for part in shape_txt
        .split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
    {
        shape.push(
            part.trim_end_matches('L')
                .parse::<usize>()
                .map_err(|_| format!("bad shape entry '{part}'"))?,
        );
    }
    let count = shape
        .iter()
        .try_fold(1usize, |a, &d| a.checked_mul(d))
        .ok_or("shape overflows")?;
    let need = count.checked_mul(dtype.size()).ok_or("shape overflows")?;
    let body = &bytes[start + hlen..];
    if body.len() < need {
        return Err(format!(
            "truncated: shape {shape:?} of {} needs {need} data bytes, file has {}",
            dtype.code(),
            body.len()
        ));
    }
    let mut data = dtype.decode(&body[..need], big.unwrap_or(false));
    if fortran && shape.len() > 1 {
        data = fortran_to_c(&data, &shape);
    }
    Ok(NdArray::new(shape, dtype, data))
}

/// Find `'key': value` in a header dict literal; the value runs to the next top-level comma or brace.
fn header_value<'a>(header: &'a str, key: &str) -> Option<&'a str> {
    let pat1 = format!("'{key}'");
    let pat2 = format!("\"{key}\"");
    let at = header.find(&pat1).or_else(|| header.find(&pat2))? + pat1.len();
    let rest = header[at..].trim_start().strip_prefix(':')?;
    let mut depth = 0i32;
    for (i, c) in rest.char_indices() {
        match c {
            '(' | '[' => depth += 1,
            ')' | ']' => depth -= 1,
            ',' | '}' if depth == 0 => return Some(rest[..i].trim()),
            _ => {}
        }
    }
    None
}

/// Read a `.npy` file.
pub fn read(path: &Path) -> Result<NdArray> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    parse(&bytes).map_err(|m| Error::at(path, m))
}

/// Serialise an array as `.npy` (version 1, little-endian, C order).
pub fn to_bytes(shape: &[usize], data: ArrayRef<'_>) -> Vec<u8> {
    let (descr, payload): (&str, Vec<u8>) = match data {
        ArrayRef::F32(v) => ("<f4", v.iter().flat_map(|x| x.to_le_bytes()).collect()),
        ArrayRef::F64(v) => ("<f8", v.iter().flat_map(|x| x.to_le_bytes()).collect()),
    };
    let shape_txt = match shape.len() {
        1 => format!("({},)", shape[0]),
        _ => format!(
            "({})",
            shape
                .iter()
                .map(|d| d.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        ),
    };
    let mut header =
        format!("{{'descr': '{descr}', 'fortran_order': False, 'shape': {shape_txt}, }}");
    // Pad so that magic + 4 + header (ending in '\n') is a multiple of 64.
    let total = MAGIC.len() + 4 + header.len() + 1;
    header.push_str(&" ".repeat((64 - total % 64) % 64));
    header.push('\n');
    let mut out = Vec::with_capacity(10 + header.len() + payload.len());
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&[1, 0]);
    out.extend_from_slice(&(header.len() as u16).to_le_bytes());
    out.extend_from_slice(header.as_bytes());
    out.extend_from_slice(&payload);
    out
}

/// Write an f32 array atomically.
pub fn write_f32(path: &Path, shape: &[usize], data: &[f32]) -> Result<()> {
    check_len(path, shape, data.len())?;
    atomic_write(path, &to_bytes(shape, ArrayRef::F32(data)))
}

/// Write an f64 array atomically.
pub fn write_f64(path: &Path, shape: &[usize], data: &[f64]) -> Result<()> {
    check_len(path, shape, data.len())?;
    atomic_write(path, &to_bytes(shape, ArrayRef::F64(data)))
}

fn check_len(path: &Path, shape: &[usize], n: usize) -> Result<()> {
    if shape.iter().product::<usize>() != n {
        return Err(Error::at(
            path,
            format!("internal: shape {shape:?} does not match {n} values"),
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_and_alignment() {
        let data: Vec<f32> = (0..24).map(|i| i as f32 / 3.0).collect();
        let b = to_bytes(&[2, 3, 4], ArrayRef::F32(&data));
        let hlen = u16::from_le_bytes([b[8], b[9]]) as usize;
        assert_eq!((10 + hlen) % 64, 0);
        let a = parse(&b).unwrap();
        assert_eq!(a.shape, vec![2, 3, 4]);
        assert_eq!(a.dtype, DType::F4);
        let back: Vec<f32> = a.data.iter().map(|&x| x as f32).collect();
        assert_eq!(back, data);
        let b1 = to_bytes(&[5], ArrayRef::F64(&[1., 2., 3., 4., 5.]));
        assert_eq!(parse(&b1).unwrap().shape, vec![5]);
    }

    #[test]
    fn truncated_and_garbage() {
        let b = to_bytes(&[4, 4], ArrayRef::F64(&[0.5; 16]));
        for n in [0, 5, 9, 20, b.len() - 1] {
            assert!(parse(&b[..n]).is_err(), "{n}");
        }
        assert!(parse(b"hello world, not numpy").is_err());
        // A header declaring an absurd shape must fail without allocating.
        let mut evil = to_bytes(&[1], ArrayRef::F64(&[0.0]));
        let h = String::from_utf8_lossy(&evil[10..]).replace("(1,)", "(99999999999999,)");
        evil.truncate(10);
        evil.extend_from_slice(h.as_bytes());
        assert!(parse(&evil).is_err());
    }
}
