//! Writing 16-bit PCM WAV files (the synthetic dataset's music). Decoding lives in `audio`.

use std::path::Path;

use crate::error::Result;
use crate::fsutil::atomic_write;

/// Encode mono f64 samples in [−1, 1] as a 16-bit PCM WAV file image.
pub fn encode_pcm16(samples: &[f64], sample_rate: u32) -> Vec<u8> {
    let data_len = (samples.len() * 2) as u32;
    let mut out = Vec::with_capacity(44 + samples.len() * 2);
    out.extend_from_slice(b"RIFF");
    out.extend_from_slice(&(36 + data_len).to_le_bytes());
    out.extend_from_slice(b"WAVEfmt ");
    out.extend_from_slice(&16u32.to_le_bytes());
    out.extend_from_slice(&1u16.to_le_bytes()); // PCM
    out.extend_from_slice(&1u16.to_le_bytes()); // mono
    out.extend_from_slice(&sample_rate.to_le_bytes());
    out.extend_from_slice(&(sample_rate * 2).to_le_bytes());
    out.extend_from_slice(&2u16.to_le_bytes());
    out.extend_from_slice(&16u16.to_le_bytes());
    out.extend_from_slice(b"data");
    out.extend_from_slice(&data_len.to_le_bytes());
    for &s in samples {
        let v = (s.clamp(-1.0, 1.0) * 32767.0).round() as i16;
        out.extend_from_slice(&v.to_le_bytes());
    }
    out
}

/// Write mono samples as a 16-bit PCM WAV file, atomically.
pub fn write_pcm16(path: &Path, samples: &[f64], sample_rate: u32) -> Result<()> {
    atomic_write(path, &encode_pcm16(samples, sample_rate))
}

#[cfg(test)]
mod tests {
    #[test]
    fn header_layout() {
        let b = super::encode_pcm16(&[0.0, 0.5, -1.0], 30720);
        assert_eq!(&b[0..4], b"RIFF");
        assert_eq!(b.len(), 44 + 6);
        assert_eq!(u32::from_le_bytes(b[24..28].try_into().unwrap()), 30720);
        assert_eq!(i16::from_le_bytes([b[46], b[47]]), 16384);
        assert_eq!(i16::from_le_bytes([b[48], b[49]]), -32767);
    }
}
