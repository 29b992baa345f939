//! Test helpers for the audio parity tests: locating the shared tracks and reading .npy fixtures.
#![allow(dead_code)]

use std::path::{Path, PathBuf};

/// The shared music directory: `<repo>/../shared/data/music` (CI layout), else /work/shared/data/music.
pub fn music_dir() -> PathBuf {
    let rel = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/music");
    if rel.is_dir() {
        return rel;
    }
    PathBuf::from("/work/shared/data/music")
}

pub fn fixture_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures")
}

/// A little-endian, C-order .npy array of f4 or f8, as f64 with its shape.
pub fn read_npy(path: &Path) -> (Vec<usize>, Vec<f64>) {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    assert_eq!(
        &bytes[..6],
        b"\x93NUMPY",
        "{}: not a .npy file",
        path.display()
    );
    let (hlen, start) = if bytes[6] == 1 {
        (u16::from_le_bytes([bytes[8], bytes[9]]) as usize, 10)
    } else {
        (
            u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]) as usize,
            12,
        )
    };
    let header = std::str::from_utf8(&bytes[start..start + hlen]).unwrap();
    assert!(header.contains("'fortran_order': False"), "{header}");
    let shape_str = header.split("'shape': (").nth(1).unwrap();
    let shape_str = &shape_str[..shape_str.find(')').unwrap()];
    let shape: Vec<usize> = shape_str
        .split(',')
        .filter(|s| !s.trim().is_empty())
        .map(|s| s.trim().parse().unwrap())
        .collect();
    let data = &bytes[start + hlen..];
    let values: Vec<f64> = if header.contains("'<f4'") {
        data.chunks_exact(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]) as f64)
            .collect()
    } else if header.contains("'<f8'") {
        data.chunks_exact(8)
            .map(|c| f64::from_le_bytes(c.try_into().unwrap()))
            .collect()
    } else {
        panic!("unsupported dtype in {header}");
    };
    assert_eq!(values.len(), shape.iter().product::<usize>());
    (shape, values)
}

pub fn read_json(path: &Path) -> serde_json::Value {
    let s = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&s).unwrap()
}

pub fn usize_list(v: &serde_json::Value) -> Vec<usize> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_u64().unwrap() as usize)
        .collect()
}

/// Event lists agree per SPEC §2.8: same count, every event within 1 frame, at most 2% off by one.
/// Returns (events off by one, events off by more, count difference).
pub fn event_diff(ours: &[usize], theirs: &[usize]) -> (usize, usize, isize) {
    let dn = ours.len() as isize - theirs.len() as isize;
    let mut off1 = 0;
    let mut far = 0;
    for (a, b) in ours.iter().zip(theirs) {
        match a.abs_diff(*b) {
            0 => {}
            1 => off1 += 1,
            _ => far += 1,
        }
    }
    (off1, far, dn)
}
