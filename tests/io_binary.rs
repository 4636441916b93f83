//! Binary mesh files: VTU with appended raw data and Gmsh 4.1 binary read back exactly, agree
//! with their text forms, survive truncation and bit flips, and (when python's meshio is
//! installed) open in another reader both ways.

use std::path::PathBuf;
use trussmesh::io::{
    fuzz_read_all, read_mesh, read_mesh_bytes, write_mesh_bytes_with, write_mesh_with, CellType, Encoding, Format,
    MeshData,
};

/// A planar grid of `k` x `k` squares, each cut in two, with one label per row.
fn grid(k: usize, labels: bool) -> MeshData {
    let mut points = Vec::with_capacity((k + 1) * (k + 1));
    for j in 0..=k {
        for i in 0..=k {
            let (x, y) = (i as f64 / k as f64, j as f64 / k as f64);
            points.push([x + 1e-3 * (7.0 * y).sin() / k as f64, y + 1.0 / 3.0, 0.0]);
        }
    }
    let mut cells = Vec::with_capacity(6 * k * k);
    let mut sub = Vec::with_capacity(2 * k * k);
    for j in 0..k {
        for i in 0..k {
            let a = j * (k + 1) + i;
            cells.extend_from_slice(&[a, a + 1, a + k + 2, a, a + k + 2, a + k + 1]);
            sub.extend_from_slice(&[(j % 5) as i32 - 2, (j % 5) as i32 - 2]);
        }
    }
    MeshData { dim: 2, cell_type: CellType::Triangle, points, cells, subdomain: labels.then_some(sub) }
}

/// Six tetrahedra per cube of a `k`^3 grid (Kuhn split), positively oriented.
fn tet_grid(k: usize, labels: bool) -> MeshData {
    let id = |i: usize, j: usize, l: usize| (l * (k + 1) + j) * (k + 1) + i;
    let mut points = Vec::new();
    for l in 0..=k {
        for j in 0..=k {
            for i in 0..=k {
                points.push([i as f64 / k as f64, j as f64 / k as f64 + 0.1, l as f64 / k as f64 / 7.0]);
            }
        }
    }
    let mut cells = Vec::new();
    let mut sub = Vec::new();
    let paths = [[1, 2, 4], [1, 4, 2], [2, 1, 4], [2, 4, 1], [4, 1, 2], [4, 2, 1]];
    for l in 0..k {
        for j in 0..k {
            for i in 0..k {
                let corner = |b: usize| id(i + (b & 1), j + ((b >> 1) & 1), l + ((b >> 2) & 1));
                for p in paths {
                    let (b1, b2) = (p[0], p[0] + p[1]);
                    let mut t = [corner(0), corner(b1), corner(b2), corner(7)];
                    let v = |q: usize| glam::DVec3::from_array(points[q]);
                    if (v(t[1]) - v(t[0])).dot((v(t[2]) - v(t[0])).cross(v(t[3]) - v(t[0]))) < 0.0 {
                        t.swap(2, 3);
                    }
                    cells.extend_from_slice(&t);
                    sub.push(1 + (i % 3) as i32);
                }
            }
        }
    }
    MeshData { dim: 3, cell_type: CellType::Tetra, points, cells, subdomain: labels.then_some(sub) }
}

fn meshes() -> Vec<(&'static str, MeshData)> {
    let mut v = Vec::new();
    for l in [false, true] {
        v.push(("grid", grid(7, l)));
        v.push(("tets", tet_grid(3, l)));
    }
    v
}

fn tmpdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("trussmesh-iobin-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn binary_round_trips_are_exact_and_agree_with_text() {
    for format in [Format::Vtu, Format::Msh] {
        for (name, m) in meshes() {
            let bin = write_mesh_bytes_with(&m, format, Encoding::Binary).unwrap();
            let text = write_mesh_bytes_with(&m, format, Encoding::Ascii).unwrap();
            let from_bin = read_mesh_bytes(&bin, format).unwrap_or_else(|e| panic!("{format:?} {name}: {e}"));
            assert_eq!(from_bin, m, "{format:?} {name}: binary round trip");
            assert_eq!(read_mesh_bytes(&text, format).unwrap(), from_bin, "{format:?} {name}: text and binary differ");
            println!("{format:?} {name}: text {} bytes, binary {} bytes", text.len(), bin.len());
        }
    }
}

#[test]
fn auto_switches_to_binary_at_the_documented_size() {
    let small = grid(10, false);
    let auto = write_mesh_bytes_with(&small, Format::Vtu, Encoding::Auto).unwrap();
    assert!(String::from_utf8(auto).unwrap().contains("format=\"ascii\""));
    // 2 k^2 >= 100,000 cells.
    let large = grid(224, false);
    assert!(large.num_cells() >= Encoding::AUTO_BINARY_CELLS);
    let auto = write_mesh_bytes_with(&large, Format::Vtu, Encoding::Auto).unwrap();
    assert!(auto.windows(17).any(|w| w == b"format=\"appended\""));
    assert_eq!(read_mesh_bytes(&auto, Format::Vtu).unwrap(), large);
    // Formats without a binary form refuse an explicit request and name the ones that have it.
    let e = write_mesh_bytes_with(&small, Format::Json, Encoding::Binary).unwrap_err().to_string();
    assert!(e.contains(".json") && e.contains(".vtu"), "{e}");
}

#[test]
fn a_million_triangles_read_back_exactly() {
    let m = grid(708, true); // 1,002,528 triangles
    assert!(m.num_cells() > 1_000_000);
    for format in [Format::Vtu, Format::Msh] {
        let t = std::time::Instant::now();
        let bytes = write_mesh_bytes_with(&m, format, Encoding::Binary).unwrap();
        let written = t.elapsed();
        let back = read_mesh_bytes(&bytes, format).unwrap();
        let text = write_mesh_bytes_with(&m, format, Encoding::Ascii).unwrap();
        // VTU indices are 32-bit; Gmsh's binary form stores every index as an 8-byte size_t.
        let most = if format == Format::Vtu { text.len() / 2 } else { text.len() };
        assert!(bytes.len() < most, "{format:?}: binary {} bytes, text {}", bytes.len(), text.len());
        println!(
            "{format:?}: {} triangles, {:.1} MB, written in {:.3} s (speed: see benches/io.rs)",
            m.num_cells(),
            bytes.len() as f64 / 1e6,
            written.as_secs_f64()
        );
        assert!(back == m, "{format:?}: the million-triangle mesh changed on the way");
    }
}

#[test]
fn truncated_or_flipped_binary_files_give_errors_not_panics() {
    for format in [Format::Vtu, Format::Msh] {
        for (name, m) in meshes() {
            let bytes = write_mesh_bytes_with(&m, format, Encoding::Binary).unwrap();
            let step = (bytes.len() / 200).max(1);
            let mut errors = 0; // truncated prefixes accepted
            for cut in (0..bytes.len()).step_by(step) {
                fuzz_read_all(&bytes[..cut]);
                if cut + 32 < bytes.len() && read_mesh_bytes(&bytes[..cut], format).is_ok() {
                    errors += 1;
                }
                let mut flipped = bytes.clone();
                flipped[cut] ^= 0x5a;
                fuzz_read_all(&flipped);
            }
            // Every prefix short of the closing tags is missing data the header promised.
            assert_eq!(errors, 0, "{format:?} {name}: a truncated file was accepted");
        }
    }
}

#[test]
fn binary_errors_name_the_problem() {
    let m = grid(3, false);
    let bytes = write_mesh_bytes_with(&m, Format::Msh, Encoding::Binary).unwrap();
    let at = bytes.windows(7).position(|w| w == b"$Nodes\n").unwrap() + 7;
    let mut bad = bytes.clone();
    bad[at..at + 8].copy_from_slice(&u64::MAX.to_le_bytes());
    let e = read_mesh_bytes(&bad, Format::Msh).unwrap_err().to_string();
    assert!(e.contains("number of node blocks") && e.contains("byte"), "{e}");
    let vtu = write_mesh_bytes_with(&m, Format::Vtu, Encoding::Binary).unwrap();
    let cut = vtu.windows(15).rposition(|w| w == b"</AppendedData>").unwrap();
    let e = read_mesh_bytes(&vtu[..cut], Format::Vtu).unwrap_err().to_string();
    assert!(e.contains("AppendedData"), "{e}");
}

fn have_meshio() -> bool {
    std::process::Command::new("python3")
        .args(["-c", "import meshio"])
        .output()
        .map(|o| o.status.success())
        .unwrap_or(false)
}

/// meshio reads our binary files, and we read the binary files meshio writes (inline base64
/// VTU, Gmsh 4.1 binary).
#[test]
fn meshio_reads_and_writes_binary() {
    if !have_meshio() {
        println!("meshio not installed: skipping");
        return;
    }
    let d = tmpdir("meshio");
    for (name, m) in meshes() {
        let want = if m.cell_type == CellType::Tetra { "tetra" } else { "triangle" };
        for ext in ["vtu", "msh"] {
            let ours = d.join(format!("{name}.{ext}"));
            write_mesh_with(&ours, &m, Encoding::Binary).unwrap();
            let theirs = d.join(format!("{name}_meshio.{ext}"));
            let write = if ext == "vtu" {
                "meshio.write(sys.argv[2], m, binary=True, compression=None)"
            } else {
                "meshio.write(sys.argv[2], m, file_format='gmsh', binary=True)"
            };
            let script = format!(
                "import meshio, sys, numpy as np\nm = meshio.read(sys.argv[1])\n\
                 print(len(m.points), sum(len(c.data) for c in m.cells if c.type == '{want}'))\n\
                 cells = np.concatenate([c.data for c in m.cells if c.type == '{want}'])\n\
                 m = meshio.Mesh(m.points, [('{want}', cells)])\n{write}"
            );
            let out = std::process::Command::new("python3")
                .args(["-c", &script, ours.to_str().unwrap(), theirs.to_str().unwrap()])
                .output()
                .unwrap();
            assert!(out.status.success(), "meshio on {}: {}", ours.display(), String::from_utf8_lossy(&out.stderr));
            let nums: Vec<usize> =
                String::from_utf8_lossy(&out.stdout).split_whitespace().map(|x| x.parse().unwrap()).collect();
            assert_eq!(nums, vec![m.points.len(), m.num_cells()], "{name}.{ext}: meshio saw other counts");
            let back = read_mesh(&theirs).unwrap_or_else(|e| panic!("meshio's {}: {e}", theirs.display()));
            assert_eq!(back.points, m.points, "{name}.{ext}: meshio's binary points");
            // Gmsh files group cells by label: compare the cells as a set.
            let sorted = |c: &[usize]| {
                let mut v: Vec<&[usize]> = c.chunks(m.cell_type.nodes()).collect();
                v.sort();
                v.into_iter().flatten().copied().collect::<Vec<usize>>()
            };
            assert_eq!(sorted(&back.cells), sorted(&m.cells), "{name}.{ext}: meshio's binary cells");
            println!("{name}.{ext}: meshio read ours and we read meshio's ({} cells)", m.num_cells());
        }
    }
    std::fs::remove_dir_all(&d).ok();
}
