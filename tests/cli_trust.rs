//! Input and output you can trust (issue 26): outputs checked before the work, the memory
//! budget, hostile pictures, `stats` on invalid meshes, and every message in the user's terms.
//! Each case checks the exit code and the message.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

fn tmp(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join("cli_trust").join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

struct Run {
    code: i32,
    stdout: String,
    stderr: String,
    seconds: f64,
}

fn run(dir: &Path, args: &[&str]) -> Run {
    let start = Instant::now();
    let out = Command::new(env!("CARGO_BIN_EXE_trussmesh"))
        .args(args)
        .current_dir(dir)
        .output()
        .expect("cannot start trussmesh");
    Run {
        code: out.status.code().unwrap_or(-1),
        stdout: String::from_utf8_lossy(&out.stdout).into_owned(),
        stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
        seconds: start.elapsed().as_secs_f64(),
    }
}

/// Runs and checks exit code 2 and that stderr contains every piece.
fn refused(dir: &Path, args: &[&str], pieces: &[&str]) -> Run {
    let r = run(dir, args);
    assert_eq!(r.code, 2, "{args:?}: exit {} (wanted 2)\nstdout: {}\nstderr: {}", r.code, r.stdout, r.stderr);
    for p in pieces {
        assert!(r.stderr.contains(p), "{args:?}: stderr lacks {p:?}:\n{}", r.stderr);
    }
    assert!(
        !r.stderr.contains("panicked") && !r.stderr.contains("internal e") && !r.stderr.contains("internal f"),
        "{args:?}: {}",
        r.stderr
    );
    r
}

const CIRCLE: &str = "sqrt(x^2+y^2)-1";
const SPHERE: &str = "sqrt(x^2+y^2+z^2)-1";

// ---------------------------------------------------------------- PNG files, written here

fn crc32(bytes: &[u8]) -> u32 {
    let mut c = 0xffff_ffffu32;
    for &b in bytes {
        c ^= b as u32;
        for _ in 0..8 {
            c = if c & 1 != 0 { 0xedb8_8320 ^ (c >> 1) } else { c >> 1 };
        }
    }
    !c
}

fn chunk(out: &mut Vec<u8>, kind: &[u8; 4], data: &[u8]) {
    out.extend_from_slice(&(data.len() as u32).to_be_bytes());
    let mut body = kind.to_vec();
    body.extend_from_slice(data);
    out.extend_from_slice(&body);
    out.extend_from_slice(&crc32(&body).to_be_bytes());
}

/// Bits written least significant first, as deflate wants.
struct Bits {
    out: Vec<u8>,
    acc: u64,
    n: u32,
}

impl Bits {
    fn put(&mut self, value: u32, count: u32) {
        self.acc |= (value as u64) << self.n;
        self.n += count;
        while self.n >= 8 {
            self.out.push(self.acc as u8);
            self.acc >>= 8;
            self.n -= 8;
        }
    }
    /// A Huffman code, most significant bit first.
    fn code(&mut self, code: u32, len: u32) {
        let rev = (0..len).fold(0, |r, i| r | (((code >> i) & 1) << (len - 1 - i)));
        self.put(rev, len);
    }
    fn literal(&mut self, v: u32) {
        match v {
            0..=143 => self.code(0x30 + v, 8),
            144..=255 => self.code(0x190 + v - 144, 9),
            256..=279 => self.code(v - 256, 7),
            _ => self.code(0xc0 + v - 280, 8),
        }
    }
}

/// zlib data of `raw` with the fixed Huffman code: runs of one byte become matches at
/// distance 1 (enough for the flat pictures of these tests, 10^8 white pixels in 120 kB).
fn zlib(raw: &[u8]) -> Vec<u8> {
    const BASE: [u32; 29] = [
        3, 4, 5, 6, 7, 8, 9, 10, 11, 13, 15, 17, 19, 23, 27, 31, 35, 43, 51, 59, 67, 83, 99, 115, 131, 163, 195, 227,
        258,
    ];
    const EXTRA: [u32; 29] = [0, 0, 0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 2, 2, 2, 2, 3, 3, 3, 3, 4, 4, 4, 4, 5, 5, 5, 5, 0];
    let mut b = Bits { out: vec![0x78, 0x01], acc: 0, n: 0 };
    b.put(1, 1); // final block
    b.put(1, 2); // fixed Huffman
    let mut i = 0;
    while i < raw.len() {
        b.literal(raw[i] as u32);
        let mut run = 0;
        while i + 1 + run < raw.len() && raw[i + 1 + run] == raw[i] {
            run += 1;
        }
        let mut left = run;
        while left >= 3 {
            let len = left.min(258) as u32;
            let k = (0..29).rev().find(|&k| BASE[k] <= len).unwrap();
            b.literal(257 + k as u32);
            b.put(len - BASE[k], EXTRA[k]);
            b.code(0, 5); // distance 1
            left -= len as usize;
        }
        for _ in 0..left {
            b.literal(raw[i] as u32);
        }
        i += 1 + run;
    }
    b.literal(256);
    if b.n > 0 {
        b.out.push(b.acc as u8);
    }
    let (mut s1, mut s2) = (1u32, 0u32);
    for &x in raw {
        s1 = (s1 + x as u32) % 65521;
        s2 = (s2 + s1) % 65521;
    }
    b.out.extend_from_slice(&((s2 << 16) | s1).to_be_bytes());
    b.out
}

/// A grey PNG of `w` x `h` pixels, `grey(i, j)` from 0 to 255.
fn png(w: u32, h: u32, grey: impl Fn(u32, u32) -> u8) -> Vec<u8> {
    let mut raw = Vec::with_capacity(((w + 1) * h) as usize);
    for j in 0..h {
        raw.push(0);
        raw.extend((0..w).map(|i| grey(i, j)));
    }
    let mut out = vec![0x89, b'P', b'N', b'G', b'\r', b'\n', 0x1a, b'\n'];
    let mut head = w.to_be_bytes().to_vec();
    head.extend_from_slice(&h.to_be_bytes());
    head.extend_from_slice(&[8, 0, 0, 0, 0]); // 8-bit grey
    chunk(&mut out, b"IHDR", &head);
    chunk(&mut out, b"IDAT", &zlib(&raw));
    chunk(&mut out, b"IEND", &[]);
    out
}

/// 67 bytes whose header claims an RGBA picture of 100000 x 100000 pixels.
fn lying_png() -> Vec<u8> {
    let mut out = vec![0x89, b'P', b'N', b'G', b'\r', b'\n', 0x1a, b'\n'];
    let mut head = 100_000u32.to_be_bytes().to_vec();
    head.extend_from_slice(&100_000u32.to_be_bytes());
    head.extend_from_slice(&[8, 6, 0, 0, 0]);
    chunk(&mut out, b"IHDR", &head);
    chunk(&mut out, b"IDAT", &zlib(&[0; 16]));
    chunk(&mut out, b"IEND", &[]);
    out
}

fn disc(n: u32) -> impl Fn(u32, u32) -> u8 {
    move |i, j| {
        let (x, y) = (i as f64 - n as f64 / 2.0, j as f64 - n as f64 / 2.0);
        if x * x + y * y < (n as f64 / 3.0).powi(2) {
            255
        } else {
            0
        }
    }
}

#[test]
fn the_png_writer_of_these_tests_makes_pictures_the_library_reads() {
    let d = tmp("png_writer");
    std::fs::write(d.join("disc.png"), png(40, 30, disc(30))).unwrap();
    let (grey, w, h) = trussmesh::mesher::image::read_png_grey(&d.join("disc.png")).unwrap();
    assert_eq!((w, h), (40, 30));
    assert_eq!(grey[15 * 40 + 15], 1.0);
    assert_eq!(grey[0], 0.0);
    assert!(lying_png().len() < 100);
}

#[test]
fn the_png_seed_corpus_replays_through_the_fuzz_body() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/corpus/png");
    let mut n = 0;
    for e in std::fs::read_dir(dir).unwrap() {
        let bytes = std::fs::read(e.unwrap().path()).unwrap();
        trussmesh::mesher::image::fuzz_decode_png(&bytes);
        n += 1;
    }
    assert!(n >= 3);
    // Cut short anywhere, the pictures still decode or fail cleanly.
    let disc = png(30, 30, disc(30));
    for k in 0..disc.len() {
        trussmesh::mesher::image::fuzz_decode_png(&disc[..k]);
    }
}

// ---------------------------------------------------------------- outputs

#[test]
fn an_unwritable_output_is_refused_before_meshing_and_nothing_is_written() {
    let d = tmp("unwritable");
    // /proc takes no new files, not even from root.
    let r = refused(
        &d,
        &[
            "mesh",
            "--domain",
            CIRCLE,
            "--h0",
            "0.01",
            "--bbox",
            "-1,-1,1,1",
            "-o",
            "a.msh",
            "-o",
            "/proc/ro/b.vtu",
            "-o",
            "c.msh",
        ],
        &[
            "cannot write the output /proc/ro/b.vtu",
            "the directory /proc/ro cannot be made in /proc",
            "nothing was done",
        ],
    );
    assert!(r.seconds < 1.0, "took {} s: the check came after meshing", r.seconds);
    assert!(!d.join("a.msh").exists() && !d.join("c.msh").exists());
    refused(
        &d,
        &["mesh", "--domain", CIRCLE, "--h0", "0.1", "--bbox", "-1,-1,1,1", "-o", "/proc/b.vtu"],
        &["cannot write the output /proc/b.vtu: no file can be made in /proc"],
    );
    // A file where a directory should be.
    std::fs::write(d.join("plain"), "x").unwrap();
    refused(
        &d,
        &["mesh", "--domain", CIRCLE, "--h0", "0.1", "--bbox", "-1,-1,1,1", "-o", "plain/b.vtu"],
        &["cannot write the output plain/b.vtu: plain is not a directory"],
    );
    // A directory where the file should be.
    std::fs::create_dir_all(d.join("dir.vtu")).unwrap();
    refused(
        &d,
        &["surface", "--phi", SPHERE, "--bbox", "-2,-2,-2,2,2,2", "--h0", "0.3", "-o", "dir.vtu"],
        &["cannot write the output dir.vtu: it is a directory"],
    );
    // Every command checks its outputs first.
    std::fs::write(d.join("p.png"), png(40, 40, disc(40))).unwrap();
    refused(&d, &["image", "p.png", "-o", "/proc/x.vtu"], &["cannot write the output /proc/x.vtu"]);
    no_leftovers(&d);
}

#[test]
fn a_read_only_directory_is_refused_before_meshing() {
    let d = tmp("read_only");
    let ro = d.join("ro");
    std::fs::create_dir_all(&ro).unwrap();
    let mut perm = std::fs::metadata(&ro).unwrap().permissions();
    std::os::unix::fs::PermissionsExt::set_mode(&mut perm, 0o555);
    std::fs::set_permissions(&ro, perm).unwrap();
    if std::fs::write(ro.join("probe"), "x").is_ok() {
        // Root writes anywhere: the /proc case of the test above stands in for this one.
        eprintln!("skipped: this user can write into a read-only directory (root)");
        return;
    }
    let r = refused(
        &d,
        &[
            "mesh",
            "--domain",
            CIRCLE,
            "--h0",
            "0.01",
            "--bbox",
            "-1,-1,1,1",
            "-o",
            "a.msh",
            "-o",
            "ro/b.vtu",
            "-o",
            "c.msh",
        ],
        &["cannot write the output ro/b.vtu: no file can be made in ro", "nothing was done"],
    );
    assert!(r.seconds < 1.0);
    assert!(!d.join("a.msh").exists());
}

#[test]
fn a_full_disk_fails_one_output_and_the_others_are_written() {
    let d = tmp("full_disk");
    std::os::unix::fs::symlink("/dev/full", d.join("full.msh")).unwrap();
    let r = run(
        &d,
        &[
            "mesh",
            "--domain",
            CIRCLE,
            "--h0",
            "0.2",
            "--bbox",
            "-1,-1,1,1",
            "-o",
            "a.msh",
            "-o",
            "full.msh",
            "-o",
            "c.json",
        ],
    );
    assert_eq!(r.code, 1, "{}", r.stderr);
    assert!(r.stderr.contains("cannot write the output full.msh: No space left on device"), "{}", r.stderr);
    assert!(r.stderr.contains("the other outputs were written: a.msh, c.json"), "{}", r.stderr);
    let a = trussmesh::io::read_mesh(&d.join("a.msh")).unwrap();
    let c = trussmesh::io::read_mesh(&d.join("c.json")).unwrap();
    assert!(a.num_cells() > 20);
    assert_eq!(a.num_cells(), c.num_cells());
    no_leftovers(&d);
}

#[test]
fn a_failed_run_leaves_an_existing_output_as_it_was() {
    let d = tmp("kept");
    std::fs::write(d.join("a.vtu"), "old").unwrap();
    refused(&d, &["mesh", "--domain", CIRCLE, "--h0", "0.1", "--bbox", "3,3,4,4", "-o", "a.vtu"], &["empty domain"]);
    assert_eq!(std::fs::read_to_string(d.join("a.vtu")).unwrap(), "old");
}

/// No temporary or probe file is left in `d`.
fn no_leftovers(d: &Path) {
    for e in std::fs::read_dir(d).unwrap() {
        let name = e.unwrap().file_name().to_string_lossy().into_owned();
        assert!(!name.contains("partial") && !name.contains("probe"), "left behind: {name}");
    }
}

// ---------------------------------------------------------------- pictures

#[test]
fn the_lying_png_header_exits_2_at_once_with_the_size_named() {
    let d = tmp("liar");
    std::fs::write(d.join("liar.png"), lying_png()).unwrap();
    let r = refused(
        &d,
        &["image", "liar.png", "-o", "out.vtu"],
        &["the picture liar.png, 100000 x 100000 pixels, would need about 750 GB of memory", "past the memory budget"],
    );
    assert!(r.seconds < 1.0, "took {} s", r.seconds);
    // The library refuses it too, before decoding, whatever the budget.
    let e = trussmesh::mesher::image::read_png_grey(&d.join("liar.png")).unwrap_err().to_string();
    assert!(e.contains("100000 x 100000 pixels") && e.contains("past the"), "{e}");
    // A header that is not a PNG's, and one cut short.
    std::fs::write(d.join("text.png"), "hello").unwrap();
    refused(&d, &["image", "text.png", "-o", "out.vtu"], &["text.png", "not a PNG picture"]);
    std::fs::write(d.join("cut.png"), &lying_png()[..20]).unwrap();
    refused(&d, &["image", "cut.png", "-o", "out.vtu"], &["cut.png", "the header chunk (IHDR) is missing"]);
    refused(&d, &["image", "missing.png", "-o", "out.vtu"], &["missing.png", "cannot read the picture"]);
}

#[test]
fn the_white_10000_square_picture_exits_2_at_once_with_the_size_named() {
    let d = tmp("white");
    let file = png(10_000, 10_000, |_, _| 255);
    assert!(file.len() < 1_000_000, "{} bytes", file.len());
    std::fs::write(d.join("white.png"), file).unwrap();
    let r = refused(
        &d,
        &["image", "white.png", "--max-memory", "6G", "-o", "out.vtu"],
        &[
            "the picture white.png, 10000 x 10000 pixels, would need about 7.52 GB of memory (1.00e8 pixels at about 75 bytes each)",
            "past the memory budget of 6.00 GB (--max-memory 6G)",
        ],
    );
    assert!(r.seconds < 1.0, "took {} s", r.seconds);
    // With the default budget, where a quarter of the machine's memory is less than that.
    let quarter = std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|t| t.lines().find(|l| l.starts_with("MemTotal:"))?.split_whitespace().nth(1)?.parse::<f64>().ok())
        .map(|kb| kb * 1024.0 / 4.0);
    match quarter {
        Some(q) if q < 7.5e9 => {
            let r = refused(
                &d,
                &["image", "white.png", "-o", "out.vtu"],
                &["10000 x 10000 pixels", "a quarter of this machine's"],
            );
            assert!(r.seconds < 1.0);
        }
        _ => eprintln!("the default budget here holds 10^8 pixels: only the explicit budget was tried"),
    }
    assert!(!d.join("out.vtu").exists());
}

#[test]
fn a_picture_whose_mesh_cannot_fit_is_refused_before_meshing() {
    let d = tmp("picture_mesh_budget");
    std::fs::write(d.join("w.png"), png(1000, 1000, |_, _| 255)).unwrap();
    let r = refused(
        &d,
        &["image", "w.png", "--h0", "1", "--max-ratio", "1", "--max-memory", "200M", "-o", "out.vtu"],
        &["the mesh of w.png would need about", "triangles at about 350 bytes each", "--max-memory 200M"],
    );
    assert!(r.seconds < 20.0);
}

#[test]
fn pictures_that_cannot_be_meshed_are_named_for_what_they_are() {
    let d = tmp("pictures");
    std::fs::write(d.join("grey.png"), png(100, 100, |_, _| 128)).unwrap();
    std::fs::write(d.join("checker.png"), png(100, 100, |i, j| if (i + j) % 2 == 0 { 0 } else { 255 })).unwrap();
    std::fs::write(d.join("dot.png"), png(100, 100, |i, j| if i == 50 && j == 50 { 255 } else { 0 })).unwrap();
    std::fs::write(d.join("black.png"), png(50, 50, |_, _| 30)).unwrap();
    std::fs::write(d.join("disc.png"), png(120, 120, disc(120))).unwrap();
    for (file, extra, pieces) in [
        ("grey.png", vec![], vec!["the picture has no contrast at the threshold 0.5", "0.502 to 0.502"]),
        ("checker.png", vec![], vec!["of the picture's pixels lie on an edge", "finer than a few pixels"]),
        (
            "dot.png",
            vec![],
            vec!["the 1 pixel brighter than the threshold 0.5 forms features under 3 pixels across", "smoothing"],
        ),
        (
            "black.png",
            vec![],
            vec!["no pixel of the picture is brighter than the threshold 0.5", "0.118 to 0.118", "--invert"],
        ),
        (
            "disc.png",
            vec!["--threshold", "0"],
            vec![
                "the threshold 0 must lie strictly between 0 and 1",
                "no pixel is darker than 0, so nothing lies outside",
            ],
        ),
        (
            "disc.png",
            vec!["--threshold", "1"],
            vec!["the threshold 1 must lie strictly between 0 and 1", "the mask would be empty"],
        ),
    ] {
        let mut args = vec!["image", file];
        args.extend(extra);
        args.extend(["-o", "out.vtu"]);
        let r = refused(&d, &args, &pieces);
        assert!(!r.stderr.contains("distance function"), "{}", r.stderr);
    }
    // The picture that can be meshed still is.
    let r = run(&d, &["image", "disc.png", "-o", "disc.vtu", "-q"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert!(trussmesh::io::read_mesh(&d.join("disc.vtu")).unwrap().num_cells() > 50);
}

// ---------------------------------------------------------------- the memory budget

#[test]
fn a_planar_mesh_past_the_budget_exits_2_before_meshing() {
    let d = tmp("budget2");
    // About 1.5 x 10^7 triangles in the unit circle.
    let r = refused(
        &d,
        &["mesh", "--domain", CIRCLE, "--h0", "0.000695", "--bbox", "-1,-1,1,1", "--max-memory", "2G", "-o", "a.vtu"],
        &[
            "the 2-D mesh would need about 5.",
            "(about 1.50e7 triangles at about 350 bytes each)",
            "2.00 GB (--max-memory 2G)",
            "larger --h0",
        ],
    );
    assert!(r.seconds < 2.0, "took {} s", r.seconds);
    // The same request within a larger budget gets past the check (capped to a few
    // iterations would still mesh 10^7 triangles, so only the smaller one is run).
    let r = run(
        &d,
        &["mesh", "--domain", CIRCLE, "--h0", "0.1", "--bbox", "-1,-1,1,1", "--max-memory", "2G", "-o", "b.vtu", "-q"],
    );
    assert_eq!(r.code, 0, "{}", r.stderr);
    // 10^-8 asks for 7 x 10^16 triangles: the number and the bytes are given as such.
    refused(
        &d,
        &["mesh", "--domain", CIRCLE, "--h0", "1e-8", "--bbox", "-1,-1,1,1", "-o", "a.vtu"],
        &["EB of memory (about 7.25e16 triangles"],
    );
    // 1e-300: the box is 2e300 h0 wide.
    refused(
        &d,
        &["mesh", "--domain", CIRCLE, "--h0", "1e-300", "--bbox", "-1,-1,1,1", "-o", "a.vtu"],
        &["--bbox is 2.00 wide along axis x, 2.00e300 times h0 = 1e-300"],
    );
}

#[test]
fn volume_and_surface_meshes_past_the_budget_exit_2_before_meshing() {
    let d = tmp("budget3");
    let r = refused(
        &d,
        &[
            "mesh",
            "--dim",
            "3",
            "--domain",
            SPHERE,
            "--h0",
            "0.01",
            "--bbox",
            "-1,-1,-1,1,1,1",
            "--max-memory",
            "1G",
            "-o",
            "a.vtu",
        ],
        &["the 3-D mesh would need about", "tetrahedra at about 550 bytes each", "--max-memory 1G"],
    );
    assert!(r.seconds < 2.0);
    let r = refused(
        &d,
        &[
            "surface",
            "--phi",
            SPHERE,
            "--bbox",
            "-1.2,-1.2,-1.2,1.2,1.2,1.2",
            "--h0",
            "0.001",
            "--max-memory",
            "1G",
            "-o",
            "s.obj",
        ],
        &["the surface mesh would need about", "triangles for a surface of area about 12.", "--max-memory 1G"],
    );
    assert!(r.seconds < 2.0);
    refused(
        &d,
        &["mesh", "--domain", CIRCLE, "--h0", "0.1", "--bbox", "-1,-1,1,1", "--max-memory", "lots", "-o", "a.vtu"],
        &["\"lots\" is not an amount of memory"],
    );
    // A scene file takes the budget too.
    std::fs::write(
        d.join("s.toml"),
        format!(
            "domain = \"{CIRCLE}\"\nh0 = 0.001\nbbox = [-1, -1, 1, 1]\nmax_memory = \"100M\"\noutput = [\"a.vtu\"]\n"
        ),
    )
    .unwrap();
    refused(&d, &["mesh", "s.toml"], &["past the memory budget of 100 MB (--max-memory 100M)"]);
}

// ---------------------------------------------------------------- stats on invalid meshes

fn mesh_json(d: &Path, name: &str, dim: usize, cell: &str, points: &str, cells: &str) -> String {
    let file = format!("{name}.json");
    std::fs::write(
        d.join(&file),
        format!("{{\"dim\": {dim}, \"cell_type\": \"{cell}\", \"points\": {points}, \"cells\": {cells}}}"),
    )
    .unwrap();
    file
}

#[test]
fn stats_says_a_mesh_is_invalid_before_any_figure() {
    let d = tmp("stats_invalid");
    let square = "[[0,0],[1,0],[1,1],[0,1]]";
    let cases: Vec<(String, &str)> = vec![
        (
            mesh_json(&d, "one_reversed", 2, "triangle", square, "[[0,2,1],[0,2,3]]"),
            "1 triangle is clockwise (reversed): triangle 0 (nodes 0, 2, 1)",
        ),
        (
            mesh_json(&d, "all_reversed", 2, "triangle", square, "[[0,2,1],[0,3,2]]"),
            "every triangle is clockwise (reversed): the whole mesh is reversed",
        ),
        (
            mesh_json(&d, "duplicate", 2, "triangle", square, "[[0,1,2],[0,2,3],[2,3,0]]"),
            "1 triangle is given twice: triangle 2 (nodes 2, 3, 0) repeats triangle 1",
        ),
        (
            mesh_json(
                &d,
                "overlap",
                2,
                "triangle",
                "[[0,0],[1,0],[0,1],[0.2,0.2],[2,0.2],[0.2,2]]",
                "[[0,1,2],[3,4,5]]",
            ),
            "1 pair of triangles overlaps: triangle 0 (nodes 0, 1, 2) and triangle 1 (nodes 3, 4, 5)",
        ),
        (
            mesh_json(&d, "fin", 2, "triangle", "[[0,0],[1,0],[0.5,1],[0.5,-1],[0.6,2]]", "[[0,1,2],[1,0,3],[0,1,4]]"),
            "1 edge bounds more than two triangles (a fin): edge (0, 1) bounds triangles 0, 1, 2",
        ),
        (
            mesh_json(&d, "bowtie", 2, "triangle", "[[0,0],[1,0],[1,1],[-1,0],[-1,-1]]", "[[0,1,2],[0,3,4]]"),
            "1 node is not manifold (a bowtie: the mesh is pinched there): node 0 joins 2 separate fans of triangles",
        ),
        (
            mesh_json(&d, "negative_tet", 3, "tetra", "[[0,0,0],[1,0,0],[0,1,0],[0,0,1]]", "[[0,2,1,3]]"),
            "the only tetrahedron is negatively oriented",
        ),
        (
            mesh_json(&d, "all_equal", 2, "triangle", "[[0.5,0.5],[0.5,0.5],[0.5,0.5]]", "[[0,1,2]]"),
            "the only triangle has zero area (it is flat or its nodes coincide)",
        ),
    ];
    for (file, problem) in &cases {
        // Without --check: exit 0, and the verdict comes before the figures.
        let r = run(&d, &["stats", file]);
        assert_eq!(r.code, 0, "{file}: {}", r.stderr);
        let verdict = r.stdout.find("INVALID MESH").unwrap_or_else(|| panic!("{file}: no verdict\n{}", r.stdout));
        let counts = r.stdout.find("mesh: ").unwrap();
        assert!(verdict < counts, "{file}: the verdict comes after the figures\n{}", r.stdout);
        assert!(r.stdout.contains(problem), "{file}: lacks {problem:?}\n{}", r.stdout);
        // With --check: exit 2 and the problem in the message.
        refused(&d, &["stats", file, "--check"], &[&format!("{file} is not a valid mesh: "), problem]);
        // In JSON too.
        let r = run(&d, &["stats", file, "--json"]);
        let v: serde_json::Value = serde_json::from_str(&r.stdout).unwrap();
        assert_eq!(v["valid"], false, "{file}");
        assert!(v["problems"][0].as_str().is_some(), "{file}");
    }
    // All points equal: no figures of angles that cannot be measured.
    let r = run(&d, &["stats", "all_equal.json"]);
    assert!(!r.stdout.contains("angles: 180.00 to 0.00") && r.stdout.contains("no quality figures"), "{}", r.stdout);
    // A good mesh says so, and passes --check.
    let good = mesh_json(&d, "good", 2, "triangle", square, "[[0,1,2],[0,2,3]]");
    let r = run(&d, &["stats", &good, "--check"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert!(r.stdout.contains("valid: consistently oriented"), "{}", r.stdout);
    // A mesh of the mesher is valid.
    let r = run(&d, &["mesh", "--domain", CIRCLE, "--h0", "0.1", "--bbox", "-1,-1,1,1", "-o", "c.vtu", "-q"]);
    assert_eq!(r.code, 0);
    assert_eq!(run(&d, &["stats", "c.vtu", "--check"]).code, 0);
    let r = run(
        &d,
        &["mesh", "--dim", "3", "--domain", SPHERE, "--h0", "0.3", "--bbox", "-1,-1,-1,1,1,1", "-o", "b.msh", "-q"],
    );
    assert_eq!(r.code, 0);
    let r = run(&d, &["stats", "b.msh", "--check"]);
    assert_eq!(r.code, 0, "{}{}", r.stdout, r.stderr);
}

// ---------------------------------------------------------------- messages

#[test]
fn messages_name_the_real_cause() {
    let d = tmp("messages");
    let m = |extra: &[&str]| {
        let mut a = vec!["mesh", "--domain", CIRCLE, "--h0", "0.1", "--bbox", "-1,-1,1,1", "-o", "a.vtu"];
        a.extend_from_slice(extra);
        a.into_iter().map(String::from).collect::<Vec<_>>()
    };
    let refuse = |args: Vec<String>, pieces: &[&str]| {
        let a: Vec<&str> = args.iter().map(String::as_str).collect();
        refused(&d, &a, pieces)
    };
    // A relative size that grows a hundredfold.
    let mut a = m(&[]);
    a.extend(["--size".into(), "1+100*x^2".into()]);
    let r = refuse(a, &["--size \"1+100*x^2\" grows from 1.00 to 100 inside the domain", "100 x h0 = 10.0 across"]);
    assert!(!r.stderr.contains("h0 is too large"));
    // A box past the largest number.
    refused(
        &d,
        &["mesh", "--domain", CIRCLE, "--h0", "0.1", "--bbox", "-1e308,-1,1e308,1", "-o", "a.vtu"],
        &["--bbox is too wide along axis x: from -1.00e308 to 1.00e308 is more than the largest number"],
    );
    // A 3-D box thinner than h0, and an intersection of two boxes that overlap in a slab 0.007
    // thick, thinner than the sampling sees (the start's nodes inside lie in one plane).
    let thin: [(&str, &str, &[&str]); 2] = [
        (
            "dbox(x,y,z,0,1,0,1,0,0.05)",
            "0,0,0,1,1,0.05",
            &["the domain is about 0.0492 across along z, less than h0 = 0.1: no tetrahedron fits across it"],
        ),
        (
            "dintersect(dbox(x,y,z,0.034,0.641,-0.337,0.206,-0.515,0.255),dbox(x,y,z,-0.158,0.311,0.199,0.952,-0.245,0.426))",
            "-1.5,-1.5,-1.5,1.5,1.5,1.5",
            &["the domain is thinner than h0 = 0.1 across", "give a smaller --h0"],
        ),
    ];
    for (domain, bbox, pieces) in thin {
        let r = refused(
            &d,
            &["mesh", "--dim", "3", "--domain", domain, "--h0", "0.1", "--bbox", bbox, "-o", "a.vtu"],
            pieces,
        );
        assert!(!r.stderr.contains("coplanar"));
    }
    // An h0 larger than the domain.
    refused(
        &d,
        &["mesh", "--domain", CIRCLE, "--h0", "5", "--bbox", "-1,-1,1,1", "-o", "a.vtu"],
        &["the domain is about 2.00 across along x, less than h0 = 5"],
    );
    // Counts that are negative or not whole.
    refused(
        &d,
        &["mesh", "--domain", CIRCLE, "--h0", "0.1", "--bbox", "-1,-1,1,1", "--max-iter", "-1", "-o", "a.vtu"],
        &["--max-iter", "-1 is negative: give a whole number from 0 up"],
    );
    let r = refused(
        &d,
        &["mesh", "--domain", CIRCLE, "--h0", "0.1", "--bbox", "-1,-1,1,1", "--seed", "1.5", "-o", "a.vtu"],
        &["\"1.5\" is not a whole number"],
    );
    assert!(!r.stderr.contains("'-- "));
    refused(&d, &["remesh", "x.vtu", "--size", "1", "--max-iter", "-5", "-o", "a.vtu"], &["-5 is negative"]);
    // 3-D fixed points print as the user wrote them.
    let r = refused(
        &d,
        &[
            "mesh",
            "--dim",
            "3",
            "--domain",
            SPHERE,
            "--h0",
            "0.3",
            "--bbox",
            "-6,-6,-6,6,6,6",
            "--fix",
            "5,5,5",
            "-o",
            "a.vtu",
        ],
        &["the fixed point (5, 5, 5) lies outside the domain (d = 7.6603 there)"],
    );
    assert!(!r.stderr.contains("DVec3"));
    refused(
        &d,
        &[
            "mesh",
            "--dim",
            "3",
            "--domain",
            SPHERE,
            "--h0",
            "0.3",
            "--bbox",
            "-1,-1,-1,1,1,1",
            "--fix",
            "5,5,5",
            "-o",
            "a.vtu",
        ],
        &["fixed point (5, 5, 5) lies outside the box"],
    );
}

#[test]
fn scene_numbers_that_are_not_numbers_are_named() {
    let d = tmp("scene_numbers");
    for (h0, pieces) in [
        ("nan", vec!["h0 = nan", "NaN is not a finite number"]),
        ("inf", vec!["h0 = inf", "inf is not a finite number"]),
        ("[0.1]", vec!["h0 = [0.1]", "expected a number (such as 0.1) or a constant expression in a string"]),
        ("\"x\"", vec!["h0 must be a constant, not \"x\""]),
    ] {
        std::fs::write(
            d.join("s.toml"),
            format!("domain = \"{CIRCLE}\"\nh0 = {h0}\nbbox = [-1, -1, 1, 1]\noutput = [\"a.vtu\"]\n"),
        )
        .unwrap();
        let r = refused(&d, &["mesh", "s.toml"], &pieces);
        assert!(!r.stderr.contains("untagged enum") && !r.stderr.contains("unknown variable 'NaN'"), "{}", r.stderr);
    }
}

#[test]
fn a_surface_h0_larger_than_the_surface_is_named() {
    let d = tmp("surface_h0");
    let r = refused(
        &d,
        &["surface", "--phi", SPHERE, "--bbox", "-1.2,-1.2,-1.2,1.2,1.2,1.2", "--h0", "5", "-o", "s.obj"],
        &["h0 = 5 is too large for the surface", "its inside spans about 1.99 x 1.99 x 1.99", "give an --h0 below"],
    );
    assert!(!r.stderr.contains("positive everywhere"));
    // A box with no surface in it is still named as such.
    refused(
        &d,
        &["surface", "--phi", SPHERE, "--bbox", "3,3,3,4,4,4", "--h0", "0.1", "-o", "s.obj"],
        &["phi is positive everywhere in the bounding box"],
    );
}

#[test]
fn remesh_names_the_problem_of_an_invalid_mesh() {
    let d = tmp("remesh_invalid");
    let file = mesh_json(&d, "rev", 2, "triangle", "[[0,0],[1,0],[1,1],[0,1]]", "[[0,1,2],[0,3,2]]");
    let r = refused(
        &d,
        &["remesh", &file, "--size", "0.2", "-o", "out.vtu"],
        &["the mesh to remesh, rev.json, is invalid: 1 triangle is clockwise (reversed): triangle 1 (nodes 0, 3, 2)"],
    );
    assert!(!r.stderr.contains("invariant") && !r.stderr.contains("1v1"), "{}", r.stderr);
    let good = mesh_json(&d, "good", 2, "triangle", "[[0,0],[1,0],[1,1],[0,1]]", "[[0,1,2],[0,2,3]]");
    refused(&d, &["remesh", &good, "--size", "x-2", "-o", "out.vtu"], &["--size \"x-2\" is -2 at node 0 (0, 0)"]);
}

// ---------------------------------------------------------------- flags that did nothing

#[test]
fn flags_that_would_be_ignored_are_refused() {
    let d = tmp("ignored_flags");
    let sphere = ["surface", "--phi", SPHERE, "--bbox", "-1.2,-1.2,-1.2,1.2,1.2,1.2", "--h0", "0.2", "-o", "s.obj"];
    let with = |extra: &[&'static str]| sphere.iter().chain(extra).copied().collect::<Vec<_>>();
    refused(&d, &with(&["--hmax", "1"]), &["--hmax", "--curvature"]);
    refused(&d, &with(&["--gradient", "0.5"]), &["--gradient", "--curvature"]);
    refused(&d, &with(&["--no-sharp"]), &["--no-sharp", "--input"]);
    refused(&d, &with(&["--feature-angle", "30"]), &["--feature-angle", "--input"]);
    std::fs::write(d.join("p.json"), "{\"patches\": []}").unwrap();
    refused(
        &d,
        &["surface", "--bezier", "p.json", "--curvature", "3", "--h0", "0.1", "-o", "s.obj"],
        &["--curvature", "--bezier"],
    );
    refused(
        &d,
        &["surface", "--bezier", "p.json", "--bbox", "0,0,0,1,1,1", "--h0", "0.1", "-o", "s.obj"],
        &["--bbox", "--bezier"],
    );
    refused(
        &d,
        &["mesh", "--domain", CIRCLE, "--h0", "0.1", "--bbox", "-1,-1,1,1", "--internal", "x-5", "-o", "a.vtu"],
        &["--internal \"x-5\" is negative everywhere inside the domain", "separates nothing"],
    );
    std::fs::write(
        d.join("m.json"),
        "{\"dim\": 2, \"cell_type\": \"triangle\", \"points\": [[0,0],[1,0],[0,1]], \"cells\": [[0,1,2]]}",
    )
    .unwrap();
    refused(&d, &["stats", "m.json", "--implicit"], &["--implicit", "--domain"]);
    // The flags with their partner still work.
    let r = run(&d, &with(&["--curvature", "3", "--hmax", "0.4", "--gradient", "0.5", "-q"]));
    assert_eq!(r.code, 0, "{}", r.stderr);
    let r = run(
        &d,
        &["mesh", "--domain", CIRCLE, "--h0", "0.1", "--bbox", "-1,-1,1,1", "--internal", "x", "-o", "i.vtu", "-q"],
    );
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert!(trussmesh::io::read_mesh(&d.join("i.vtu")).unwrap().subdomain.is_some());
}

#[test]
fn a_long_expression_is_parsed_in_linear_time_and_its_cost_is_named() {
    // 25,000 terms: the parse takes milliseconds, twice the terms about twice the time.
    let terms =
        |n: usize| (0..n).map(|i| format!("{}*sin(x*{i}+y)", 1.0 + i as f64 * 1e-3)).collect::<Vec<_>>().join(" + ");
    let time = |src: &str| {
        let t = Instant::now();
        let e = trussmesh::expr::Expr::parse(src).unwrap();
        (t.elapsed(), e.ops())
    };
    let (small, ops_small) = time(&terms(25_000));
    let (large, ops_large) = time(&terms(100_000));
    assert!(ops_large > 3 * ops_small);
    assert!(large < Duration::from_secs(2), "100,000 terms took {large:?}");
    assert!(large.as_secs_f64() < 20.0 * small.as_secs_f64().max(1e-3), "{small:?} then {large:?}");
    // The command line warns that evaluating it over the survey takes minutes (the fixed
    // point outside the domain then stops the run before the survey).
    let d = tmp("long_expression");
    std::fs::write(
        d.join("s.toml"),
        format!(
            "domain = \"sqrt(x^2+y^2) - 1 + 1e-9*({})\"\nh0 = 0.004\nbbox = [-6, -6, 6, 6]\nfix = [[5, 5]]\noutput = [\"a.vtu\"]\n",
            terms(100_000)
        ),
    )
    .unwrap();
    let r = refused(&d, &["mesh", "s.toml"], &["the fixed point (5, 5) lies outside the domain"]);
    assert!(r.stderr.contains("warning: one evaluation of --domain takes about"), "{}", r.stderr);
    assert!(r.stderr.contains("the survey of the box alone evaluates it 2.62e5 times"), "{}", r.stderr);
    assert!(r.seconds < 10.0, "took {} s", r.seconds);
}

// ---------------------------------------------------------------- the table of docs/cli.md

/// Splits a command into words (single quotes, no expansion).
fn words(line: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut cur = String::new();
    let (mut quoted, mut any) = (false, false);
    for c in line.chars() {
        match c {
            '\'' => {
                quoted = !quoted;
                any = true;
            }
            c if c.is_whitespace() && !quoted => {
                if any {
                    out.push(std::mem::take(&mut cur));
                    any = false;
                }
            }
            c => {
                cur.push(c);
                any = true;
            }
        }
    }
    if any {
        out.push(cur);
    }
    out
}

/// The files the table's examples name.
fn table_fixtures(d: &Path) {
    std::fs::write(d.join("plain.txt"), "not a picture").unwrap();
    std::os::unix::fs::symlink("/dev/full", d.join("full.msh")).unwrap();
    std::fs::write(d.join("liar.png"), lying_png()).unwrap();
    std::fs::write(d.join("white.png"), png(10_000, 10_000, |_, _| 255)).unwrap();
    std::fs::write(d.join("grey.png"), png(100, 100, |_, _| 128)).unwrap();
    std::fs::write(d.join("checker.png"), png(100, 100, |i, j| if (i + j) % 2 == 0 { 0 } else { 255 })).unwrap();
    std::fs::write(d.join("dot.png"), png(100, 100, |i, j| if i == 50 && j == 50 { 255 } else { 0 })).unwrap();
    std::fs::write(d.join("disc.png"), png(120, 120, disc(120))).unwrap();
    for (name, h0) in [("nan", "nan"), ("array", "[0.1]")] {
        std::fs::write(
            d.join(format!("{name}.toml")),
            format!("domain = \"{CIRCLE}\"\nh0 = {h0}\nbbox = [-1, -1, 1, 1]\noutput = [\"a.vtu\"]\n"),
        )
        .unwrap();
    }
    let square = "[[0,0],[1,0],[1,1],[0,1]]";
    mesh_json(d, "good", 2, "triangle", square, "[[0,1,2],[0,2,3]]");
    mesh_json(d, "one_reversed", 2, "triangle", square, "[[0,2,1],[0,2,3]]");
    mesh_json(d, "all_reversed", 2, "triangle", square, "[[0,2,1],[0,3,2]]");
    mesh_json(d, "duplicate", 2, "triangle", square, "[[0,1,2],[0,2,3],[2,3,0]]");
    mesh_json(d, "overlap", 2, "triangle", "[[0,0],[1,0],[0,1],[0.2,0.2],[2,0.2],[0.2,2]]", "[[0,1,2],[3,4,5]]");
    mesh_json(d, "fin", 2, "triangle", "[[0,0],[1,0],[0.5,1],[0.5,-1],[0.6,2]]", "[[0,1,2],[1,0,3],[0,1,4]]");
    mesh_json(d, "bowtie", 2, "triangle", "[[0,0],[1,0],[1,1],[-1,0],[-1,-1]]", "[[0,1,2],[0,3,4]]");
    mesh_json(d, "negative_tet", 3, "tetra", "[[0,0,0],[1,0,0],[0,1,0],[0,0,1]]", "[[0,2,1,3]]");
    mesh_json(d, "all_equal", 2, "triangle", "[[0.5,0.5],[0.5,0.5],[0.5,0.5]]", "[[0,1,2]]");
}

#[test]
fn the_table_of_bad_input_in_docs_cli_md_is_what_the_program_does() {
    let text = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/cli.md")).unwrap();
    let section = text.split("## Bad input: exit codes and messages").nth(1).expect("the section");
    let rows: Vec<&str> = section.lines().filter(|l| l.starts_with("| ") && l.contains("| `trussmesh ")).collect();
    assert!(rows.len() >= 40, "only {} rows", rows.len());
    let d = tmp("docs_table");
    table_fixtures(&d);
    for row in rows {
        let cols: Vec<&str> = row.trim_matches('|').split(" | ").map(str::trim).collect();
        assert_eq!(cols.len(), 4, "{row}");
        let command = cols[1].split('`').nth(1).unwrap();
        let argv = words(command);
        assert_eq!(argv[0], "trussmesh", "{row}");
        let args: Vec<&str> = argv[1..].iter().map(String::as_str).collect();
        let code: i32 = cols[2].parse().unwrap();
        let r = run(&d, &args);
        assert_eq!(r.code, code, "{command}: exit {} (the table says {code})\n{}", r.code, r.stderr);
        let mut at = 0;
        for piece in cols[3].split("...").filter(|p| !p.is_empty()) {
            let found = r.stderr[at..]
                .find(piece)
                .unwrap_or_else(|| panic!("{command}: the message lacks {piece:?} (after byte {at}):\n{}", r.stderr));
            at += found + piece.len();
        }
        assert!(r.seconds < 30.0, "{command}: {} s", r.seconds);
    }
}
