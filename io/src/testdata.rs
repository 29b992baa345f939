//! Test helpers: where the shared real data lives (`../shared/data` beside the repository), and
//! hand-assembled files whose every header field a test can get wrong on purpose.

use std::path::PathBuf;

/// The shared data directory: `$QEAN_SHARED_DATA`, else `<repo>/../shared/data`, else `/work/shared/data`.
pub fn shared_dir() -> PathBuf {
    if let Ok(p) = std::env::var("QEAN_SHARED_DATA") {
        return PathBuf::from(p);
    }
    let repo = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..");
    let beside = repo.join("../shared/data");
    if beside.is_dir() {
        return beside;
    }
    PathBuf::from("/work/shared/data")
}

/// A canonical WAV: RIFF header, `fmt ` chunk (format tag `tag`: 1 = PCM) and a `data` chunk that claims
/// `data_len` bytes and holds `data`.
pub fn wav_bytes(
    tag: u16,
    rate: u32,
    channels: u16,
    bits: u16,
    data: &[u8],
    data_len: u32,
) -> Vec<u8> {
    let block = channels as u32 * bits as u32 / 8;
    let mut v = Vec::new();
    v.extend_from_slice(b"RIFF");
    v.extend_from_slice(&(36 + data.len() as u32).to_le_bytes());
    v.extend_from_slice(b"WAVEfmt ");
    v.extend_from_slice(&16u32.to_le_bytes());
    v.extend_from_slice(&tag.to_le_bytes());
    v.extend_from_slice(&channels.to_le_bytes());
    v.extend_from_slice(&rate.to_le_bytes());
    v.extend_from_slice(&(rate.wrapping_mul(block)).to_le_bytes());
    v.extend_from_slice(&(block as u16).to_le_bytes());
    v.extend_from_slice(&bits.to_le_bytes());
    v.extend_from_slice(b"data");
    v.extend_from_slice(&data_len.to_le_bytes());
    v.extend_from_slice(data);
    v
}

/// A version-1 .npy: its header dict written as given (`descr` like `<f4`, `shape` like `(10, 24, 3)`),
/// padded to 64 bytes, then `data` as is.
pub fn npy_bytes(descr: &str, shape: &str, data: &[u8]) -> Vec<u8> {
    let mut header = format!("{{'descr': '{descr}', 'fortran_order': False, 'shape': {shape}, }}");
    while (10 + header.len() + 1) % 64 != 0 {
        header.push(' ');
    }
    header.push('\n');
    let mut v = b"\x93NUMPY\x01\x00".to_vec();
    v.extend_from_slice(&(header.len() as u16).to_le_bytes());
    v.extend_from_slice(header.as_bytes());
    v.extend_from_slice(data);
    v
}
