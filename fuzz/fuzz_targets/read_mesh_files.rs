#![no_main]
use libfuzzer_sys::fuzz_target;
fuzz_target!(|data: &[u8]| { trussmesh::io::fuzz_read_all(data); });
