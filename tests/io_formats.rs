//! Mesh file formats: exact round trips, clear errors on bad input, corpus replay, and (when
//! python's meshio is installed) a cross-check that another reader sees the same mesh.

use std::path::{Path, PathBuf};
use trussmesh::io::{
    fuzz_read_all, read_mesh, read_mesh_bytes, write_mesh, write_mesh_bytes, CellType, Format, MeshData,
};
use trussmesh::Error;

fn tri2d(labels: bool) -> MeshData {
    // A 3x3 grid of points on [0,1]x[0,0.7] with awkward floats, split into 8 triangles.
    let xs = [0.0, 1.0 / 3.0, 1.0];
    let ys = [-0.1, 0.35, 0.7];
    let mut points = Vec::new();
    for y in ys {
        for x in xs {
            points.push([x, y + 1e-17 * x, 0.0]);
        }
    }
    let mut cells = Vec::new();
    for j in 0..2 {
        for i in 0..2 {
            let a = j * 3 + i;
            cells.extend_from_slice(&[a, a + 1, a + 4, a, a + 4, a + 3]);
        }
    }
    points.push([2.5e-300, 1e21, 0.0]); // unused node with extreme values
    MeshData {
        dim: 2,
        cell_type: CellType::Triangle,
        points,
        cells,
        subdomain: labels.then(|| vec![1, 1, 2, 2, 7, 1, -3, 2]),
    }
}

fn surface3d(labels: bool) -> MeshData {
    // The surface of a tetrahedron, outward oriented.
    MeshData {
        dim: 3,
        cell_type: CellType::Triangle,
        points: vec![[0.0, 0.0, 0.1], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.1, 0.2, 1.0 / 7.0 + 1.0]],
        cells: vec![1, 2, 3, 0, 3, 2, 0, 1, 3, 0, 2, 1],
        subdomain: labels.then(|| vec![4, 4, 5, 6]),
    }
}

fn tets(labels: bool) -> MeshData {
    // Unit cube (slightly perturbed) cut into the six Kuhn tetrahedra around the 0-7 diagonal.
    let mut points = Vec::new();
    for k in 0..8 {
        let (x, y, z) = ((k & 1) as f64, ((k >> 1) & 1) as f64, ((k >> 2) & 1) as f64);
        points.push([x + 0.01 * z, y - 0.02 * x, 0.9 * z + 0.1]);
    }
    let paths = [[1, 2, 4], [1, 4, 2], [2, 1, 4], [2, 4, 1], [4, 1, 2], [4, 2, 1]];
    let mut cells = Vec::new();
    for p in paths {
        let a = 0;
        let b = a + p[0];
        let c = b + p[1];
        let mut t = [a, b, c, 7];
        let v = |i: usize| glam::DVec3::from_array(points[t[i]]);
        if (v(1) - v(0)).dot((v(2) - v(0)).cross(v(3) - v(0))) < 0.0 {
            t.swap(2, 3);
        }
        cells.extend_from_slice(&t);
    }
    MeshData { dim: 3, cell_type: CellType::Tetra, points, cells, subdomain: labels.then(|| vec![1, 2, 1, 2, 3, 1]) }
}

fn all_meshes() -> Vec<(&'static str, MeshData)> {
    let mut v = Vec::new();
    for l in [false, true] {
        v.push(("tri2d", tri2d(l)));
        v.push(("surface3d", surface3d(l)));
        v.push(("tets", tets(l)));
    }
    v
}

fn tmpdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("trussmesh-io-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn exact_round_trips_volume_formats() {
    for format in [Format::Json, Format::Vtu, Format::Msh, Format::Medit] {
        for (name, m) in all_meshes() {
            m.validate().unwrap();
            let bytes = write_mesh_bytes(&m, format).unwrap();
            let back = read_mesh_bytes(&bytes, format)
                .unwrap_or_else(|e| panic!("{format:?} {name}: {e}\n{}", String::from_utf8_lossy(&bytes)));
            assert_eq!(back, m, "{format:?} {name}");
            fuzz_read_all(&bytes);
        }
    }
}

#[test]
fn exact_round_trips_obj_ply() {
    for format in [Format::Obj, Format::Ply] {
        for (name, m) in all_meshes() {
            let bytes = write_mesh_bytes(&m, format).unwrap();
            let back = read_mesh_bytes(&bytes, format).unwrap();
            if m.cell_type == CellType::Triangle {
                assert_eq!(back, m, "{format:?} {name}");
            } else {
                // A tet mesh is written as its boundary: 2 triangles per cube side.
                assert_eq!(back.num_cells(), 12, "{format:?} {name}");
                assert_eq!(back.cells.len(), 36);
                assert_eq!(back.subdomain, None);
            }
            fuzz_read_all(&bytes);
        }
    }
}

fn triangle_coords(m: &MeshData) -> Vec<[[f64; 3]; 3]> {
    (0..m.num_cells())
        .map(|i| {
            let c = m.cell(i);
            [m.points[c[0]], m.points[c[1]], m.points[c[2]]]
        })
        .collect()
}

#[test]
fn stl_round_trip_keeps_triangles_and_labels() {
    for (name, m) in all_meshes() {
        let bytes = write_mesh_bytes(&m, Format::Stl).unwrap();
        let back = read_mesh_bytes(&bytes, Format::Stl).unwrap();
        if m.cell_type == CellType::Triangle {
            // STL has no shared vertex list: compare triangle by triangle.
            assert_eq!(triangle_coords(&back), triangle_coords(&m), "{name}");
            assert_eq!(back.subdomain, m.subdomain, "{name}");
            assert_eq!(back.dim, m.dim);
        } else {
            assert_eq!(back.num_cells(), 12);
        }
        // Once read, a mesh is in STL's canonical form and survives exactly.
        let again = read_mesh_bytes(&write_mesh_bytes(&back, Format::Stl).unwrap(), Format::Stl).unwrap();
        assert_eq!(again, back);
        fuzz_read_all(&bytes);
    }
}

#[test]
fn files_on_disk_and_dispatch() {
    let d = tmpdir("disk");
    let m = tets(true);
    for f in [Format::Json, Format::Vtu, Format::Msh, Format::Medit] {
        let p = d.join(format!("cube.{}", f.extension()));
        write_mesh(&p, &m).unwrap();
        assert_eq!(read_mesh(&p).unwrap(), m, "{f:?}");
    }
    let m2 = tri2d(true);
    for f in Format::ALL {
        let p = d.join(format!("square.{}", f.extension().to_uppercase()));
        write_mesh(&p, &m2).unwrap();
        let back = read_mesh(&p).unwrap();
        assert_eq!(back.num_cells(), m2.num_cells(), "{f:?}");
    }
    match write_mesh(&d.join("x.xyz"), &m) {
        Err(Error::Invalid(msg)) => assert!(msg.contains("xyz"), "{msg}"),
        other => panic!("{other:?}"),
    }
    match read_mesh(&d.join("missing.msh")) {
        Err(Error::Io { path, .. }) => assert!(path.contains("missing.msh")),
        other => panic!("{other:?}"),
    }
    // Invalid meshes are refused before writing.
    let mut bad = tri2d(false);
    bad.cells[4] = 99;
    assert!(matches!(write_mesh_bytes(&bad, Format::Json), Err(Error::InvalidMesh(_))));
    std::fs::remove_dir_all(&d).ok();
}

fn parse_err(bytes: &[u8], format: Format) -> (usize, String) {
    match read_mesh_bytes(bytes, format) {
        Err(Error::Parse { line, message, .. }) => (line, message),
        other => panic!("{format:?}: expected a parse error, got {other:?} for\n{}", String::from_utf8_lossy(bytes)),
    }
}

/// Replaces the first occurrence of `from` (after `after`) with `to`.
fn edit(s: &str, after: &str, from: &str, to: &str) -> String {
    let base = s.find(after).unwrap_or_else(|| panic!("{after:?} not in file")) + after.len();
    let k = base + s[base..].find(from).unwrap_or_else(|| panic!("{from:?} not in file"));
    format!("{}{}{}", &s[..k], to, &s[k + from.len()..])
}

#[test]
fn garbled_files_give_parse_errors() {
    let text = |m: &MeshData, f| String::from_utf8(write_mesh_bytes(m, f).unwrap()).unwrap();
    let check = |f: Format, s: String, want: &str| {
        let (line, msg) = parse_err(s.as_bytes(), f);
        let lower = msg.to_lowercase();
        assert!(lower.contains(want), "{f:?}: message {msg:?} should mention {want:?}");
        println!("{f:?} line {line}: {msg}");
    };
    let m2 = tri2d(true);
    let m3 = tets(true);

    let j = text(&m2, Format::Json);
    check(Format::Json, j.replace("1.0,", "1.0x,"), "expected");
    check(Format::Json, edit(&j, "cells", "[0,", "[99,"), "node 99");
    check(Format::Json, j.replace("\"triangle\"", "\"quad\""), "cell_type");
    check(Format::Json, j[..j.len() / 2].to_string(), "end of json");
    check(Format::Json, edit(&j, "points", "0.0", "1e999"), "finite");
    check(Format::Json, "[".repeat(10000), "deep");

    let v = text(&m3, Format::Vtu);
    check(Format::Vtu, edit(&v, "Points", "0.1", "zz"), "finite number");
    check(Format::Vtu, v.replace("NumberOfPoints=\"8\"", "NumberOfPoints=\"1000000000000000000\""), "numberofpoints");
    check(Format::Vtu, v.replace("format=\"ascii\"", "format=\"binary\""), "base64");
    check(Format::Vtu, v[..v.len() / 2].to_string(), "truncated");
    check(Format::Vtu, edit(&v, "connectivity", " 7", " 70"), "node 70");
    check(Format::Vtu, v.replace("<Points>", "<Points><Foo>"), "</foo>");

    let g = text(&m3, Format::Msh);
    check(Format::Msh, g.replace("$Nodes\n1 8 1 8", "$Nodes\n1 1000000000000000000 1 8"), "more than the rest");
    check(Format::Msh, g.replace("4.1 0 8", "2.2 0 8"), "version");
    check(Format::Msh, g.replace("4.1 0 8", "4.1 1 8"), "binary");
    check(Format::Msh, edit(&g, "$Elements", "\n1 ", "\n1 99 "), "");
    check(Format::Msh, g[..g.len() * 2 / 3].to_string(), "");
    check(Format::Msh, edit(&g, "$Nodes", "0.1", "nan"), "finite");

    let d = text(&m3, Format::Medit);
    check(Format::Medit, edit(&d, "Tetrahedra", "\n1 ", "\n100 "), "vertex 100");
    check(Format::Medit, d.replace("Vertices\n8", "Vertices\n800000000000"), "more than the rest");
    check(Format::Medit, d.replace("End", ""), "end");
    check(Format::Medit, d.replace("Dimension 3", "Dimension 4"), "dimension");

    let o = text(&m2, Format::Obj);
    check(Format::Obj, o.replace("f 1 ", "f 100 "), "out of range");
    check(Format::Obj, o.replace("v 0.0", "v abc"), "finite");
    check(Format::Obj, "v 1 2 3\n".to_string(), "no triangles");

    let s = text(&m2, Format::Stl);
    check(Format::Stl, s[..s[..s.len() / 2].rfind('\n').unwrap() + 1].to_string(), "end of file");
    check(Format::Stl, s.replacen("outer loop", "outer lop", 1), "loop");
    check(Format::Stl, "\u{1}\u{2}binary".to_string(), "binary");

    let p = text(&m2, Format::Ply);
    check(Format::Ply, p.replace("element vertex 10", "element vertex 10000000000000000"), "more than the file holds");
    check(Format::Ply, p.replace("format ascii", "format binary_little_endian"), "ascii");
    check(Format::Ply, p.replace("end_header", "end_hdr"), "");
    check(Format::Ply, p[..p.len() - 9].to_string(), "truncated");

    // Non-UTF-8 input is a parse error for every reader, with a line number.
    for f in Format::ALL {
        let (line, msg) = parse_err(b"solid x\n\xff\xfe", f);
        assert_eq!(line, 2, "{f:?}");
        assert!(msg.contains("UTF-8"));
    }
}

#[test]
fn truncations_and_flips_never_panic() {
    for (_, m) in all_meshes() {
        for f in Format::ALL {
            let bytes = write_mesh_bytes(&m, f).unwrap();
            let step = (bytes.len() / 150).max(1);
            for cut in (0..bytes.len()).step_by(step) {
                fuzz_read_all(&bytes[..cut]);
                let mut flipped = bytes.clone();
                flipped[cut] = match flipped[cut] {
                    b'0'..=b'8' => flipped[cut] + 1,
                    b'\n' => b' ',
                    b' ' => b'\n',
                    _ => b'-',
                };
                fuzz_read_all(&flipped);
            }
        }
    }
}

#[test]
fn corpus_replay() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/corpus/files");
    let mut n = 0;
    for e in std::fs::read_dir(&dir).unwrap() {
        let p = e.unwrap().path();
        let bytes = std::fs::read(&p).unwrap();
        fuzz_read_all(&bytes);
        n += 1;
    }
    assert!(n > 0, "no seed files in {}", dir.display());
}

/// Reads a hand-written Gmsh file with non-contiguous node tags and no physical groups.
#[test]
fn gmsh_style_file() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/corpus/files");
    let m = read_mesh(&dir.join("gmsh_sparse_tags.msh")).unwrap();
    assert_eq!(m.dim, 2);
    assert_eq!(m.points.len(), 4);
    assert_eq!(m.cells, vec![0, 1, 2, 0, 2, 3]);
    assert_eq!(m.subdomain, Some(vec![1, 1]));
}

/// Writes the seed corpus (run with `--ignored` after changing a writer).
#[test]
#[ignore]
fn regenerate_corpus() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/corpus/files");
    for (name, m) in all_meshes() {
        let tag = if m.subdomain.is_some() { "labels" } else { "plain" };
        for f in Format::ALL {
            let p = dir.join(format!("{name}_{tag}.{}", f.extension()));
            write_mesh(&p, &m).unwrap();
        }
    }
}

#[test]
fn meshio_reads_our_files() {
    let ok = std::process::Command::new("python3")
        .args(["-c", "import meshio"])
        .output()
        .map(|o| o.status.success())
        .unwrap_or(false);
    if !ok {
        println!("meshio not installed: skipping");
        return;
    }
    let d = tmpdir("meshio");
    for (name, m) in all_meshes() {
        for f in [Format::Vtu, Format::Msh, Format::Medit, Format::Obj, Format::Stl, Format::Ply] {
            let p = d.join(format!("{name}.{}", f.extension()));
            write_mesh(&p, &m).unwrap();
            let want_type = if m.cell_type == CellType::Tetra && !matches!(f, Format::Obj | Format::Stl | Format::Ply) {
                "tetra"
            } else {
                "triangle"
            };
            let script = format!(
                "import meshio, sys\nm = meshio.read(sys.argv[1])\nprint(len(m.points), sum(len(c.data) for c in m.cells if c.type == '{want_type}'))"
            );
            let out =
                std::process::Command::new("python3").args(["-c", &script, p.to_str().unwrap()]).output().unwrap();
            assert!(out.status.success(), "meshio failed on {}: {}", p.display(), String::from_utf8_lossy(&out.stderr));
            let text = String::from_utf8_lossy(&out.stdout);
            let nums: Vec<usize> = text.split_whitespace().map(|x| x.parse().unwrap()).collect();
            let ours = read_mesh(&p).unwrap();
            println!("meshio {name}.{}: {} points, {} {want_type}s", f.extension(), nums[0], nums[1]);
            assert_eq!(nums[1], ours.num_cells(), "{name} {f:?} cells");
            // STL repeats vertices per facet in meshio; the others list each point once.
            if f != Format::Stl {
                assert_eq!(nums[0], ours.points.len(), "{name} {f:?} points");
            }
        }
    }
    std::fs::remove_dir_all(&d).ok();
}

/// A k*k*k grid of Kuhn-split cubes with a little wobble: a tet mesh worth looking at.
fn cube_grid(k: usize) -> MeshData {
    let one = tets(false);
    let id = |i: usize, j: usize, l: usize| (l * (k + 1) + j) * (k + 1) + i;
    let mut points = Vec::new();
    for l in 0..=k {
        for j in 0..=k {
            for i in 0..=k {
                let w = 0.15 * (((i * 5 + j * 3 + l * 7) % 4) as f64 - 1.5) / k as f64;
                let inner = i % k != 0 && j % k != 0 && l % k != 0;
                let w = if inner { w } else { 0.0 };
                points.push([i as f64 / k as f64 + w, j as f64 / k as f64 - w, l as f64 / k as f64 + 0.5 * w]);
            }
        }
    }
    let mut cells = Vec::new();
    for l in 0..k {
        for j in 0..k {
            for i in 0..k {
                let corner = |c: usize| id(i + (c & 1), j + ((c >> 1) & 1), l + ((c >> 2) & 1));
                for t in 0..6 {
                    let mut c: Vec<usize> = one.cell(t).iter().map(|&c| corner(c)).collect();
                    let v = |a: usize| glam::DVec3::from_array(points[c[a]]);
                    if (v(1) - v(0)).dot((v(2) - v(0)).cross(v(3) - v(0))) < 0.0 {
                        c.swap(2, 3);
                    }
                    cells.extend(c);
                }
            }
        }
    }
    MeshData { dim: 3, cell_type: CellType::Tetra, points, cells, subdomain: None }
}

#[test]
fn pictures() {
    let d = tmpdir("pictures");
    // A finer planar mesh: a perturbed grid so the quality colours vary.
    let n = 12;
    let mut points = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            let (x, y) = (i as f64 / n as f64, j as f64 / n as f64 * 0.6);
            let wob = if i % n != 0 && j % n != 0 { 0.02 * ((i * 7 + j * 3) % 5) as f64 } else { 0.0 };
            points.push([x + wob, y - 0.5 * wob, 0.0]);
        }
    }
    let mut cells = Vec::new();
    for j in 0..n {
        for i in 0..n {
            let a = j * (n + 1) + i;
            cells.extend_from_slice(&[a, a + 1, a + n + 2, a, a + n + 2, a + n + 1]);
        }
    }
    let m2 = MeshData { dim: 2, cell_type: CellType::Triangle, points, cells, subdomain: None };
    for (name, m) in [("plane", m2), ("surface", surface3d(false)), ("tets", tets(true)), ("cube", cube_grid(4))] {
        let svg = d.join(format!("{name}.svg"));
        let png = d.join(format!("{name}.png"));
        trussmesh::io::write_svg(&svg, &m, &format!("{name} <test> & more")).unwrap();
        trussmesh::io::write_png(&png, &m, name, 600).unwrap();
        let s = std::fs::read_to_string(&svg).unwrap();
        assert!(s.starts_with("<svg") && s.contains("&lt;test&gt; &amp; more") && s.contains("<polygon"));
        let b = std::fs::read(&png).unwrap();
        assert_eq!(&b[1..4], b"PNG");
        if let Ok(keep) = std::env::var("TRUSSMESH_KEEP_PICTURES") {
            std::fs::copy(&png, Path::new(&keep).join(format!("{name}.png"))).unwrap();
            std::fs::copy(&svg, Path::new(&keep).join(format!("{name}.svg"))).unwrap();
        }
    }
    let empty = MeshData { dim: 2, cell_type: CellType::Triangle, points: vec![], cells: vec![], subdomain: None };
    assert!(trussmesh::io::write_png(&d.join("e.png"), &empty, "", 400).is_err());
    // The PNG carries the SVG's text: with a title, the band above the drawing (the top 0.085
    // of the width) holds ink, and the bottom rows (the summary line under the histogram, the
    // last 0.05 of the width) too; without a title, the title band is blank.
    let m = tets(true);
    let dark_rows = |title: &str, from_top: bool, band: f32| {
        let b = trussmesh::io::png_bytes(&m, title, 600).unwrap();
        let pix = tiny_skia::Pixmap::decode_png(&b).unwrap();
        let (w, h) = (pix.width() as usize, pix.height() as usize);
        let rows = (band * w as f32) as usize;
        let (y0, y1) = if from_top { (0, rows) } else { (h - rows, h) };
        pix.data()[4 * w * y0..4 * w * y1].chunks(4).filter(|p| p[0] < 100 && p[1] < 100 && p[2] < 100).count()
    };
    let (titled, untitled) = (dark_rows("a titled tet", true, 0.085), dark_rows("", true, 0.085));
    let summary = dark_rows("", false, 0.05);
    println!("dark pixels: title band {titled} (untitled {untitled}), summary band {summary}");
    assert!(titled > 150 && untitled == 0, "title band: {titled} dark pixels with a title, {untitled} without");
    assert!(summary > 150, "summary band: {summary} dark pixels");
    std::fs::remove_dir_all(&d).ok();
}
