#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    trussmesh::testing::run_tet_ops(data);
});
