//! BVH motion files (the reader that `qean eval` uses for .bvh dances).
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        if let Ok(m) = qean_motion::bvh::parse(text, 0.01) {
            let _ = m.smpl_positions();
        }
    }
});
