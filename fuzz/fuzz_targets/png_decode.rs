#![no_main]
use libfuzzer_sys::fuzz_target;
fuzz_target!(|data: &[u8]| { trussmesh::mesher::image::fuzz_decode_png(data); });
