//! The audio decoder front: container probing, header checks and decoding (symphonia) up to 30 s.
//! The first byte picks the file extension, the hint the prober starts from.
#![no_main]
use libfuzzer_sys::fuzz_target;

#[path = "common.rs"]
mod common;

fuzz_target!(|data: &[u8]| {
    let Some((&pick, body)) = data.split_first() else {
        return;
    };
    let ext = ["wav", "ogg", "mp3", "flac"][pick as usize % 4];
    let path = common::scratch(&format!("audio.{ext}"), body);
    let _ = qean_audio::decode::decode_file(&path, 30.0);
});
