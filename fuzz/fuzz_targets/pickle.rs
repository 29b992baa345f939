//! AIST++ motion pickles: the pickle virtual machine, ndarray reconstruction and the motion checks.
#![no_main]
use libfuzzer_sys::fuzz_target;

#[path = "common.rs"]
mod common;

fuzz_target!(|data: &[u8]| {
    let _ = qean_io::pickle::loads(data);
    let path = common::scratch("motion.pkl", data);
    let _ = qean_motion::Motion::read_pkl(&path);
});
