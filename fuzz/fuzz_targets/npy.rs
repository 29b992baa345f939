//! .npy arrays: magic, header dict, dtype, shape, data length.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = qean_io::npy::parse(data);
});
