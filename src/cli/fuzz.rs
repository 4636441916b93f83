//! Fuzz bodies of the command line (run by fuzz/fuzz_targets/cli_args.rs and scene_parse.rs,
//! which include this module tree): argument and scene parsing and every check before the
//! work must return a value or an error for any input, never panic, and never touch a file.
//! The unit tests below run them on a few inputs, so that they build and run in `cargo test`.

#![allow(dead_code)]

use super::{Cli, Command};
use clap::Parser;

/// Splits `data` into arguments at NUL bytes (lossy UTF-8), parses them as a command line,
/// and for `mesh` checks the run as far as meshing (without reading a scene file).
pub fn fuzz_args(data: &[u8]) {
    let text = String::from_utf8_lossy(data);
    let argv = std::iter::once("trussmesh").chain(text.split('\0'));
    let Ok(cli) = Cli::try_parse_from(argv) else { return };
    if let Command::Mesh(args) = cli.command {
        if args.scene.is_some() {
            return;
        }
        if let Ok(spec) = args.spec() {
            if let Ok(job) = spec.resolve_with(false) {
                assert!(job.h0 > 0.0 && job.h0.is_finite());
                assert_eq!(job.bbox.len(), 2 * job.dim);
            }
        }
    }
}

/// Parses `data` as a scene file and checks the run as far as meshing.
pub fn fuzz_scene(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else { return };
    if let Ok(spec) = super::mesh::scene_spec(text, "<fuzz>") {
        if let Ok(job) = spec.resolve_with(false) {
            assert!(job.h0 > 0.0 && job.h0.is_finite());
            assert_eq!(job.bbox.len(), 2 * job.dim);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_fuzz_bodies_take_good_and_bad_input() {
        for args in [
            "mesh\0--domain\0x^2+y^2-1\0--h0\x000.1\0--bbox\0-1,-1,1,1\0-o\0a.vtu",
            "mesh\0--domain\0x\0--h0\0nan\0--bbox\0-1,-1,1,1\0-o\0a.vtu",
            "mesh\0--max-iter\0-1",
            "stats",
            "\u{0}\u{ff}",
        ] {
            fuzz_args(args.as_bytes());
        }
        for scene in [
            "domain = \"x^2+y^2-1\"\nh0 = 0.1\nbbox = [-1, -1, 1, 1]\noutput = [\"a.vtu\"]\n",
            "domain = \"x\"\nh0 = nan\nbbox = [-1, -1, 1, 1]\n",
            "domain = \"x\"\nh0 = [0.1]\nbbox = []\n",
            "[[[",
        ] {
            fuzz_scene(scene.as_bytes());
        }
        fuzz_scene(&[0xff, 0xfe]);
    }

    #[test]
    fn the_seed_corpora_replay() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/corpus");
        for (dir, body) in [("cli_args", fuzz_args as fn(&[u8])), ("scene", fuzz_scene)] {
            let mut n = 0;
            for e in std::fs::read_dir(root.join(dir)).unwrap() {
                body(&std::fs::read(e.unwrap().path()).unwrap());
                n += 1;
            }
            assert!(n >= 3, "{dir}: {n} files");
        }
    }
}
