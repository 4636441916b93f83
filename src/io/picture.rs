//! Pictures of meshes: triangles coloured by quality with a quality histogram (2-D), or a shaded
//! oblique view (surfaces, and tet meshes cut in half so the inside shows). One scene is built
//! and then drawn either as SVG text (with labels) or rasterised by tiny-skia into a PNG.

use super::{cell_facets, sorted, CellType, MeshData};
use crate::quality::{tet_radius_ratio, triangle_q_from_lengths};
use crate::Error;
use glam::DVec3;
use std::collections::HashMap;
use std::path::Path;

type Rgb = [u8; 3];

/// A drawing primitive in picture coordinates (pixels, y down).
enum Prim {
    Poly {
        pts: Vec<[f32; 2]>,
        fill: Rgb,
        stroke: Option<(Rgb, f32)>,
    },
    Rect {
        x: f32,
        y: f32,
        w: f32,
        h: f32,
        fill: Rgb,
    },
    Line {
        a: [f32; 2],
        b: [f32; 2],
        color: Rgb,
        width: f32,
    },
    /// SVG only: tiny-skia has no fonts.
    Text {
        at: [f32; 2],
        size: f32,
        anchor: &'static str,
        text: String,
    },
}

struct Scene {
    w: f32,
    h: f32,
    prims: Vec<Prim>,
}

/// Red (bad) through yellow to green (good): the usual reading of a quality map.
fn quality_color(q: f64) -> Rgb {
    const STOPS: [(f64, Rgb); 5] = [
        (0.0, [165, 0, 38]),
        (0.3, [244, 109, 67]),
        (0.6, [254, 224, 139]),
        (0.8, [166, 217, 106]),
        (1.0, [26, 152, 80]),
    ];
    let q = if q.is_finite() { q.clamp(0.0, 1.0) } else { 0.0 };
    for w in STOPS.windows(2) {
        let ((q0, c0), (q1, c1)) = (w[0], w[1]);
        if q <= q1 {
            let t = (q - q0) / (q1 - q0);
            let mut c = [0u8; 3];
            for k in 0..3 {
                c[k] = (c0[k] as f64 + t * (c1[k] as f64 - c0[k] as f64)).round() as u8;
            }
            return c;
        }
    }
    STOPS[4].1
}

fn shade(c: Rgb, i: f64) -> Rgb {
    c.map(|v| (v as f64 * i.clamp(0.0, 1.0)).round() as u8)
}

fn tri_quality(p: [DVec3; 3]) -> f64 {
    triangle_q_from_lengths(p[1].distance(p[2]), p[2].distance(p[0]), p[0].distance(p[1]))
}

fn pt(m: &MeshData, i: usize) -> DVec3 {
    DVec3::from_array(m.points[i])
}

/// Quality of every cell: q for triangles, the radius ratio for tets.
fn qualities(m: &MeshData) -> Vec<f64> {
    (0..m.num_cells())
        .map(|i| {
            let c = m.cell(i);
            match m.cell_type {
                CellType::Triangle => tri_quality([pt(m, c[0]), pt(m, c[1]), pt(m, c[2])]),
                CellType::Tetra => tet_radius_ratio([pt(m, c[0]), pt(m, c[1]), pt(m, c[2]), pt(m, c[3])]),
            }
        })
        .collect()
}

/// Layout sizes derived from the picture width.
struct Layout {
    w: f32,
    margin: f32,
    title_h: f32,
    hist_h: f32,
    legend_w: f32,
}

impl Layout {
    fn new(w: f32) -> Self {
        Layout { w, margin: 0.03 * w, title_h: 0.06 * w, hist_h: 0.25 * w, legend_w: 0.16 * w }
    }
}

/// Projected triangles (screen coordinates before fitting), fill colour and whether to outline.
struct Flat {
    tris: Vec<([[f64; 2]; 3], Rgb)>,
}

fn flat_2d(m: &MeshData, q: &[f64]) -> Flat {
    Flat {
        tris: (0..m.num_cells())
            .map(|i| {
                let c = m.cell(i);
                let p = |k: usize| [m.points[c[k]][0], m.points[c[k]][1]];
                ([p(0), p(1), p(2)], quality_color(q[i]))
            })
            .collect(),
    }
}

/// The oblique orthographic view: triangles sorted far to near (painter's algorithm), Lambert
/// shaded. Tet meshes show the half with centroid x <= mid-x, cut faces coloured by tet quality.
fn flat_3d(m: &MeshData, q: &[f64]) -> Flat {
    let eye = DVec3::new(1.0, -1.3, 0.9).normalize();
    let fwd = -eye;
    let right = fwd.cross(DVec3::Z).normalize();
    let up = right.cross(fwd);
    let light = (eye + DVec3::new(0.2, 0.3, 0.8)).normalize();
    // (corner points, colour, two-sided)
    let mut faces: Vec<([DVec3; 3], Rgb, bool)> = Vec::new();
    match m.cell_type {
        CellType::Triangle => {
            for (i, &qi) in q.iter().enumerate().take(m.num_cells()) {
                let c = m.cell(i);
                faces.push(([pt(m, c[0]), pt(m, c[1]), pt(m, c[2])], quality_color(qi), true));
            }
        }
        CellType::Tetra => {
            let (lo, hi) =
                m.points.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| (a.min(p[0]), b.max(p[0])));
            let mid = 0.5 * (lo + hi);
            let mut total: HashMap<Vec<usize>, u32> = HashMap::new();
            let mut kept: HashMap<Vec<usize>, u32> = HashMap::new();
            let keep: Vec<bool> = (0..m.num_cells())
                .map(|i| m.cell(i).iter().map(|&v| m.points[v][0]).sum::<f64>() / 4.0 <= mid)
                .collect();
            for (i, &kept_cell) in keep.iter().enumerate() {
                for f in cell_facets(CellType::Tetra, m.cell(i)) {
                    let s = sorted(&f);
                    if kept_cell {
                        *kept.entry(s.clone()).or_insert(0) += 1;
                    }
                    *total.entry(s).or_insert(0) += 1;
                }
            }
            for i in (0..m.num_cells()).filter(|&i| keep[i]) {
                for f in cell_facets(CellType::Tetra, m.cell(i)) {
                    let s = sorted(&f);
                    if kept[&s] != 1 {
                        continue;
                    }
                    let color = if total[&s] == 1 { [170, 190, 220] } else { quality_color(q[i]) };
                    faces.push(([pt(m, f[0]), pt(m, f[1]), pt(m, f[2])], color, false));
                }
            }
        }
    }
    let mut drawn: Vec<(f64, [[f64; 2]; 3], Rgb)> = Vec::with_capacity(faces.len());
    for (p, color, two_sided) in faces {
        let n = (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero();
        let facing = n.dot(eye);
        if !two_sided && facing <= 0.0 {
            continue; // back face of a closed surface
        }
        let lambert = if two_sided { n.dot(light).abs() } else { n.dot(light).max(0.0) };
        let depth = (p[0] + p[1] + p[2]).dot(eye) / 3.0;
        let s = p.map(|x| [x.dot(right), x.dot(up)]);
        drawn.push((depth, s, shade(color, 0.3 + 0.7 * lambert)));
    }
    drawn.sort_by(|a, b| a.0.total_cmp(&b.0));
    Flat { tris: drawn.into_iter().map(|(_, s, c)| (s, c)).collect() }
}

fn build_scene(m: &MeshData, title: &str, width: f32) -> Result<Scene, Error> {
    m.validate()?;
    if m.num_cells() == 0 {
        return Err(Error::InvalidMesh("nothing to draw: the mesh has no cells".into()));
    }
    let q = qualities(m);
    let flat = if m.dim == 2 { flat_2d(m, &q) } else { flat_3d(m, &q) };
    let l = Layout::new(width);
    let mut prims = Vec::new();
    prims.push(Prim::Text {
        at: [l.margin, l.margin + 0.6 * l.title_h],
        size: 0.035 * l.w,
        anchor: "start",
        text: title.to_string(),
    });

    // Fit the drawing into the panel, keeping its aspect ratio (y up in the mesh, down on screen).
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for (t, _) in &flat.tris {
        for p in t {
            for k in 0..2 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
    }
    if flat.tris.is_empty() {
        lo = [0.0; 2];
        hi = [1.0; 2];
    }
    let span = [(hi[0] - lo[0]).max(1e-300), (hi[1] - lo[1]).max(1e-300)];
    let panel_w = (l.w - 2.0 * l.margin) as f64;
    let aspect = (span[1] / span[0]).clamp(0.25, 1.5);
    let panel_h = panel_w * aspect;
    let scale = (panel_w / span[0]).min(panel_h / span[1]);
    let x0 = l.margin as f64 + 0.5 * (panel_w - scale * span[0]);
    let y0 = (l.margin + l.title_h) as f64 + 0.5 * (panel_h - scale * span[1]);
    let ncells = flat.tris.len().max(1) as f32;
    let edge_w = (0.0015 * l.w * (2000.0 / ncells).sqrt().clamp(0.3, 1.0)).max(0.25);
    for (t, color) in &flat.tris {
        let pts =
            t.iter().map(|p| [(x0 + scale * (p[0] - lo[0])) as f32, (y0 + scale * (hi[1] - p[1])) as f32]).collect();
        prims.push(Prim::Poly { pts, fill: *color, stroke: Some(([40, 40, 50], edge_w)) });
    }
    // Internal boundaries: edges between triangles of different subdomains, drawn thick.
    if let (2, Some(labels)) = (m.dim, &m.subdomain) {
        let mut seen: std::collections::HashMap<(usize, usize), i32> = std::collections::HashMap::new();
        let mut interface = Vec::new();
        for (i, &label) in labels.iter().enumerate().take(m.num_cells()) {
            let c = m.cell(i);
            for k in 0..3 {
                let (a, b) = (c[k].min(c[(k + 1) % 3]), c[k].max(c[(k + 1) % 3]));
                match seen.insert((a, b), label) {
                    Some(l) if l != label => interface.push((a, b)),
                    _ => {}
                }
            }
        }
        interface.sort_unstable();
        let at = |i: usize| {
            let p = m.points[i];
            [(x0 + scale * (p[0] - lo[0])) as f32, (y0 + scale * (hi[1] - p[1])) as f32]
        };
        for (a, b) in interface {
            prims.push(Prim::Line { a: at(a), b: at(b), color: [20, 20, 120], width: 3.0 * edge_w });
        }
    }

    // Histogram of quality in 20 bins over [0, 1].
    let top = l.margin + l.title_h + panel_h as f32 + 0.05 * l.w;
    let hx0 = l.margin + 0.06 * l.w;
    let hw = l.w - 2.0 * l.margin - l.legend_w - 0.08 * l.w;
    let hh = l.hist_h;
    let mut bins = [0usize; 20];
    for &v in &q {
        bins[((v.clamp(0.0, 1.0) * 20.0) as usize).min(19)] += 1;
    }
    let maxb = *bins.iter().max().unwrap_or(&1) as f32;
    let bw = hw / 20.0;
    for (k, &b) in bins.iter().enumerate() {
        let h = hh * b as f32 / maxb.max(1.0);
        if b > 0 {
            prims.push(Prim::Rect {
                x: hx0 + k as f32 * bw + 0.05 * bw,
                y: top + hh - h,
                w: 0.9 * bw,
                h: h.max(1.0),
                fill: quality_color((k as f64 + 0.5) / 20.0),
            });
        }
    }
    let axis = [60, 60, 60];
    let aw = (0.002 * l.w).max(1.0);
    prims.push(Prim::Line { a: [hx0, top + hh], b: [hx0 + hw, top + hh], color: axis, width: aw });
    prims.push(Prim::Line { a: [hx0, top], b: [hx0, top + hh], color: axis, width: aw });
    let fs = 0.022 * l.w;
    for (v, s) in [(0.0, "0"), (0.5, "0.5"), (1.0, "1")] {
        let x = hx0 + v * hw;
        prims.push(Prim::Line { a: [x, top + hh], b: [x, top + hh + 0.01 * l.w], color: axis, width: aw });
        prims.push(Prim::Text { at: [x, top + hh + 0.035 * l.w], size: fs, anchor: "middle", text: s.into() });
    }
    prims.push(Prim::Text {
        at: [hx0 - 0.01 * l.w, top + 0.02 * l.w],
        size: fs,
        anchor: "end",
        text: maxb.to_string(),
    });
    let (name, count) = match m.cell_type {
        CellType::Triangle => ("q", "triangles"),
        CellType::Tetra => ("radius ratio", "tetrahedra"),
    };
    let min = q.iter().copied().fold(f64::INFINITY, f64::min);
    let mean = q.iter().sum::<f64>() / q.len() as f64;
    prims.push(Prim::Text {
        at: [hx0 + 0.5 * hw, top + hh + 0.07 * l.w],
        size: fs,
        anchor: "middle",
        text: format!("{} {count}, {name}: min {min:.3}, mean {mean:.3}", q.len()),
    });

    // Colour legend: a vertical bar from 0 (bottom) to 1 (top).
    let lx = l.w - l.margin - 0.5 * l.legend_w;
    let lw = 0.04 * l.w;
    let steps = 40;
    for k in 0..steps {
        let v = (k as f64 + 0.5) / steps as f64;
        let y = top + hh * (1.0 - (k + 1) as f32 / steps as f32);
        prims.push(Prim::Rect { x: lx, y, w: lw, h: hh / steps as f32 + 0.5, fill: quality_color(v) });
    }
    for (v, s) in [(0.0, "0"), (0.5, "0.5"), (1.0, "1")] {
        prims.push(Prim::Text {
            at: [lx + lw + 0.01 * l.w, top + hh * (1.0 - v) + 0.3 * fs],
            size: fs,
            anchor: "start",
            text: s.into(),
        });
    }
    prims.push(Prim::Text { at: [lx + 0.5 * lw, top - 0.015 * l.w], size: fs, anchor: "middle", text: name.into() });
    let h = top + hh + 0.1 * l.w;
    Ok(Scene { w: l.w, h, prims })
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

fn hex(c: Rgb) -> String {
    format!("#{:02x}{:02x}{:02x}", c[0], c[1], c[2])
}

fn svg_text(sc: &Scene) -> String {
    let mut s = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w:.0}\" height=\"{h:.0}\" viewBox=\"0 0 {w:.1} {h:.1}\" font-family=\"sans-serif\">\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n",
        w = sc.w,
        h = sc.h
    );
    for p in &sc.prims {
        match p {
            Prim::Poly { pts, fill, stroke } => {
                let ps: Vec<String> = pts.iter().map(|p| format!("{:.2},{:.2}", p[0], p[1])).collect();
                s.push_str(&format!("<polygon points=\"{}\" fill=\"{}\"", ps.join(" "), hex(*fill)));
                if let Some((c, w)) = stroke {
                    s.push_str(&format!(" stroke=\"{}\" stroke-width=\"{w:.2}\" stroke-linejoin=\"round\"", hex(*c)));
                }
                s.push_str("/>\n");
            }
            Prim::Rect { x, y, w, h, fill } => s.push_str(&format!(
                "<rect x=\"{x:.2}\" y=\"{y:.2}\" width=\"{w:.2}\" height=\"{h:.2}\" fill=\"{}\"/>\n",
                hex(*fill)
            )),
            Prim::Line { a, b, color, width } => s.push_str(&format!(
                "<line x1=\"{:.2}\" y1=\"{:.2}\" x2=\"{:.2}\" y2=\"{:.2}\" stroke=\"{}\" stroke-width=\"{width:.2}\"/>\n",
                a[0], a[1], b[0], b[1], hex(*color)
            )),
            Prim::Text { at, size, anchor, text } => s.push_str(&format!(
                "<text x=\"{:.2}\" y=\"{:.2}\" font-size=\"{size:.1}\" text-anchor=\"{anchor}\">{}</text>\n",
                at[0], at[1], esc(text)
            )),
        }
    }
    s.push_str("</svg>\n");
    s
}

/// Writes an SVG picture: the 2-D mesh coloured by quality (or the shaded 3-D view), a quality
/// histogram, a colour legend and the title.
pub fn write_svg(path: &Path, mesh: &MeshData, title: &str) -> Result<(), Error> {
    super::write_file(path, &svg_bytes(mesh, title)?)
}

/// The picture of [`write_svg`] as the bytes of an SVG file.
pub fn svg_bytes(mesh: &MeshData, title: &str) -> Result<Vec<u8>, Error> {
    let sc = build_scene(mesh, title, 800.0)?;
    Ok(svg_text(&sc).into_bytes())
}

/// Writes the same picture as [`write_svg`] as a PNG `width_px` wide, without text.
pub fn write_png(path: &Path, mesh: &MeshData, title: &str, width_px: u32) -> Result<(), Error> {
    super::write_file(path, &png_bytes(mesh, title, width_px)?)
}

/// The picture of [`write_png`] as the bytes of a PNG file.
pub fn png_bytes(mesh: &MeshData, title: &str, width_px: u32) -> Result<Vec<u8>, Error> {
    use tiny_skia::{Color, FillRule, Paint, PathBuilder, Pixmap, Rect, Stroke, Transform};
    if !(64..=16384).contains(&width_px) {
        return Err(Error::Invalid(format!("PNG width {width_px} must be in 64..=16384 pixels")));
    }
    let sc = build_scene(mesh, title, width_px as f32)?;
    let height = (sc.h.ceil() as u32).clamp(1, 32768);
    let mut pix = Pixmap::new(width_px, height)
        .ok_or_else(|| Error::Invalid(format!("cannot make a {width_px}x{height} picture")))?;
    pix.fill(Color::WHITE);
    let paint_of = |c: Rgb| {
        let mut p = Paint::default();
        p.set_color_rgba8(c[0], c[1], c[2], 255);
        p.anti_alias = true;
        p
    };
    let id = Transform::identity();
    for p in &sc.prims {
        match p {
            Prim::Poly { pts, fill, stroke } => {
                let mut pb = PathBuilder::new();
                pb.move_to(pts[0][0], pts[0][1]);
                for q in &pts[1..] {
                    pb.line_to(q[0], q[1]);
                }
                pb.close();
                if let Some(path) = pb.finish() {
                    pix.fill_path(&path, &paint_of(*fill), FillRule::Winding, id, None);
                    if let Some((c, w)) = stroke {
                        let st = Stroke { width: *w, ..Stroke::default() };
                        pix.stroke_path(&path, &paint_of(*c), &st, id, None);
                    }
                }
            }
            Prim::Rect { x, y, w, h, fill } => {
                if let Some(r) = Rect::from_xywh(*x, *y, *w, *h) {
                    pix.fill_rect(r, &paint_of(*fill), id, None);
                }
            }
            Prim::Line { a, b, color, width } => {
                let mut pb = PathBuilder::new();
                pb.move_to(a[0], a[1]);
                pb.line_to(b[0], b[1]);
                if let Some(path) = pb.finish() {
                    let st = Stroke { width: *width, ..Stroke::default() };
                    pix.stroke_path(&path, &paint_of(*color), &st, id, None);
                }
            }
            Prim::Text { .. } => {}
        }
    }
    pix.encode_png().map_err(|e| Error::internal(format!("cannot encode the PNG picture: {e}")))
}
