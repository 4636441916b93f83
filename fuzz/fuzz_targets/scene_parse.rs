#![no_main]
// The command line's own modules, as the binary builds them.
#[allow(dead_code)]
#[path = "../../src/cli/mod.rs"]
mod cli;
use libfuzzer_sys::fuzz_target;
fuzz_target!(|data: &[u8]| { cli::fuzz::fuzz_scene(data); });
