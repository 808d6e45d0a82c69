//! URDF robot models.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    let _ = pbd::control_basis::RobotModel::from_urdf_str(&text);
});
