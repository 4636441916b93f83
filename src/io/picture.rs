//! Pictures of meshes: triangles coloured by quality with a quality histogram (2-D), or a shaded
//! oblique view (surfaces, and tet meshes cut in half so the inside shows). One scene is built
//! and then drawn either as SVG text or rasterised by tiny-skia into a PNG, with the same text
//! (title, colour-bar numbers, histogram axes, the measure's name) drawn from an embedded font.

use super::measure::Measure;
use super::{cell_facets, sorted, CellType, MeshData};
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
    /// Text on the baseline `at`; in PNGs drawn from the embedded font (see `glyphs`).
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

fn pt(m: &MeshData, i: usize) -> DVec3 {
    DVec3::from_array(m.points[i])
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

/// Projected triangles (screen coordinates before fitting) with their fill colours, and the
/// sharp edges to draw over them; both far to near.
struct Flat {
    tris: Vec<([[f64; 2]; 3], Rgb)>,
    /// (index into `tris` after which the edge is drawn, its two projected ends).
    edges: Vec<(usize, [[f64; 2]; 2])>,
}

fn flat_2d(m: &MeshData, q: &Measure) -> Flat {
    Flat {
        tris: (0..m.num_cells())
            .map(|i| {
                let c = m.cell(i);
                let p = |k: usize| [m.points[c[k]][0], m.points[c[k]][1]];
                ([p(0), p(1), p(2)], quality_color(q.fraction(q.values[i])))
            })
            .collect(),
        edges: Vec::new(),
    }
}

/// The oblique orthographic view: triangles sorted far to near (painter's algorithm), Lambert
/// shaded. Tet meshes show the half with centroid x <= mid-x, cut faces coloured by tet quality.
fn flat_3d(m: &MeshData, q: &Measure, sharp: &[[usize; 2]]) -> Flat {
    let eye = DVec3::new(1.0, -1.3, 0.9).normalize();
    let fwd = -eye;
    let right = fwd.cross(DVec3::Z).normalize();
    let up = right.cross(fwd);
    let light = (eye + DVec3::new(0.2, 0.3, 0.8)).normalize();
    // (corner points, colour, two-sided)
    let mut faces: Vec<([DVec3; 3], Rgb, bool)> = Vec::new();
    match m.cell_type {
        CellType::Triangle => {
            for (i, &qi) in q.values.iter().enumerate().take(m.num_cells()) {
                let c = m.cell(i);
                faces.push(([pt(m, c[0]), pt(m, c[1]), pt(m, c[2])], quality_color(q.fraction(qi)), true));
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
                    let color = if total[&s] == 1 { [170, 190, 220] } else { quality_color(q.fraction(q.values[i])) };
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
    // Sharp edges go in the painter's order just after the faces at their depth (nudged toward
    // the eye by a tenth of their length, so that their own two faces do not cover them).
    let depths: Vec<f64> = drawn.iter().map(|d| d.0).collect();
    let mut edges: Vec<(f64, [[f64; 2]; 2])> = sharp
        .iter()
        .map(|&[a, b]| {
            let (pa, pb) = (pt(m, a), pt(m, b));
            let depth = 0.5 * (pa + pb).dot(eye) + 0.1 * pa.distance(pb);
            (depth, [pa, pb].map(|x| [x.dot(right), x.dot(up)]))
        })
        .collect();
    edges.sort_by(|a, b| a.0.total_cmp(&b.0));
    let edges = edges.into_iter().map(|(d, e)| (depths.partition_point(|&x| x <= d), e)).collect();
    Flat { tris: drawn.into_iter().map(|(_, s, c)| (s, c)).collect(), edges }
}

/// Edges of a surface mesh where the normals of the two triangles turn by more than
/// `angle_deg`, or that bound one triangle only: the creases a picture draws.
pub fn sharp_edges(m: &MeshData, angle_deg: f64) -> Vec<[usize; 2]> {
    if m.cell_type != CellType::Triangle || m.dim != 3 {
        return Vec::new();
    }
    let normal = |i: usize| {
        let c = m.cell(i);
        (pt(m, c[1]) - pt(m, c[0])).cross(pt(m, c[2]) - pt(m, c[0])).normalize_or_zero()
    };
    let mut first: HashMap<[usize; 2], usize> = HashMap::new();
    let mut out = Vec::new();
    let cos = angle_deg.to_radians().cos();
    for i in 0..m.num_cells() {
        let c = m.cell(i);
        for k in 0..3 {
            let e = [c[k].min(c[(k + 1) % 3]), c[k].max(c[(k + 1) % 3])];
            match first.remove(&e) {
                Some(j) if normal(i).dot(normal(j)) < cos => out.push(e),
                Some(_) => {}
                None => {
                    first.insert(e, i);
                }
            }
        }
    }
    out.extend(first.into_keys());
    out.sort_unstable();
    out
}

fn build_scene(m: &MeshData, title: &str, measure: &Measure, width: f32) -> Result<Scene, Error> {
    m.validate()?;
    if m.num_cells() == 0 {
        return Err(Error::InvalidMesh("nothing to draw: the mesh has no cells".into()));
    }
    if measure.values.len() != m.num_cells() {
        return Err(Error::Invalid(format!(
            "the measure {:?} has {} values for {} cells",
            measure.name,
            measure.values.len(),
            m.num_cells()
        )));
    }
    let q = measure;
    let flat = if m.dim == 2 {
        flat_2d(m, q)
    } else {
        let sharp = if m.cell_type == CellType::Triangle { sharp_edges(m, 40.0) } else { Vec::new() };
        flat_3d(m, q, &sharp)
    };
    let l = Layout::new(width);
    let mut prims = Vec::new();
    prims.push(title_text(&l, title));

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
    let at2 = |p: [f64; 2]| [(x0 + scale * (p[0] - lo[0])) as f32, (y0 + scale * (hi[1] - p[1])) as f32];
    let mut next_edge = flat.edges.iter().peekable();
    for (k, (t, color)) in flat.tris.iter().enumerate() {
        while let Some((_, e)) = next_edge.next_if(|(after, _)| *after <= k) {
            prims.push(Prim::Line { a: at2(e[0]), b: at2(e[1]), color: [15, 15, 25], width: 2.5 * edge_w });
        }
        let pts = t.iter().map(|&p| at2(p)).collect();
        prims.push(Prim::Poly { pts, fill: *color, stroke: Some(([40, 40, 50], edge_w)) });
    }
    for (_, e) in next_edge {
        prims.push(Prim::Line { a: at2(e[0]), b: at2(e[1]), color: [15, 15, 25], width: 2.5 * edge_w });
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
        let at = |i: usize| at2([m.points[i][0], m.points[i][1]]);
        for (a, b) in interface {
            prims.push(Prim::Line { a: at(a), b: at(b), color: [20, 20, 120], width: 3.0 * edge_w });
        }
    }
    let top = l.margin + l.title_h + panel_h as f32 + 0.05 * l.w;
    legend(&mut prims, &l, q, top, m.cell_type);
    let h = top + l.hist_h + 0.1 * l.w;
    Ok(Scene { w: l.w, h, prims })
}

/// The title, in a smaller font when it is long and cut short (with "...") when even that
/// does not fit the picture's width (widths from the embedded font's metrics, for SVG too).
fn title_text(l: &Layout, title: &str) -> Prim {
    let avail = l.w - 2.0 * l.margin;
    let full = 0.035 * l.w;
    let small = 0.02 * l.w;
    let width = super::glyphs::text_width(full, title);
    let size = if width > avail { (full * avail / width).max(small) } else { full };
    let mut text = title.to_string();
    if super::glyphs::text_width(size, &text) > avail {
        let chars: Vec<char> = title.chars().collect();
        let (mut lo, mut hi) = (0, chars.len());
        while lo < hi {
            let mid = (lo + hi).div_ceil(2);
            let t: String = chars[..mid].iter().collect::<String>() + "...";
            if super::glyphs::text_width(size, &t) <= avail {
                lo = mid;
            } else {
                hi = mid - 1;
            }
        }
        text = chars[..lo].iter().collect::<String>() + "...";
    }
    Prim::Text { at: [l.margin, l.margin + 0.6 * l.title_h], size, anchor: "start", text }
}

/// The histogram of the measure (20 bins over its range, with both axes numbered and named),
/// the summary line and the colour bar, from `top` down.
fn legend(prims: &mut Vec<Prim>, l: &Layout, q: &Measure, top: f32, ct: CellType) {
    let hx0 = l.margin + 0.08 * l.w;
    let hw = l.w - 2.0 * l.margin - l.legend_w - 0.1 * l.w;
    let hh = l.hist_h;
    let mut bins = [0usize; 20];
    for &v in &q.values {
        bins[((q.fraction(v) * 20.0) as usize).min(19)] += 1;
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
    let ticks = [0.0, 0.25, 0.5, 0.75, 1.0].map(|t| (t, q.label(q.lo + t as f64 * (q.hi - q.lo))));
    for (t, s) in &ticks {
        let x = hx0 + t * hw;
        prims.push(Prim::Line { a: [x, top + hh], b: [x, top + hh + 0.01 * l.w], color: axis, width: aw });
        prims.push(Prim::Text { at: [x, top + hh + 0.035 * l.w], size: fs, anchor: "middle", text: s.clone() });
    }
    // The count axis: 0 and the tallest bin, ticked, and named.
    for (v, y) in [(0.0, top + hh), (maxb, top)] {
        prims.push(Prim::Line { a: [hx0 - 0.01 * l.w, y], b: [hx0, y], color: axis, width: aw });
        prims.push(Prim::Text {
            at: [hx0 - 0.015 * l.w, y + 0.35 * fs],
            size: fs,
            anchor: "end",
            text: format!("{v}"),
        });
    }
    let count = match ct {
        CellType::Triangle => "triangles",
        CellType::Tetra => "tetrahedra",
    };
    prims.push(Prim::Text {
        at: [hx0 - 0.015 * l.w, top + 0.5 * hh + 0.35 * fs],
        size: 0.8 * fs,
        anchor: "end",
        text: "count".into(),
    });
    let min = q.values.iter().copied().fold(f64::INFINITY, f64::min);
    let mean = q.values.iter().sum::<f64>() / q.values.len() as f64;
    let name = &q.name;
    prims.push(Prim::Text {
        at: [hx0 + 0.5 * hw, top + hh + 0.07 * l.w],
        size: fs,
        anchor: "middle",
        text: format!("{} {count} by {name}: min {}, mean {}", q.values.len(), q.label(min), q.label(mean)),
    });

    // Colour bar: a vertical bar from lo (bottom) to hi (top), numbered, the measure named above.
    let lx = l.w - l.margin - 0.6 * l.legend_w;
    let lw = 0.04 * l.w;
    let steps = 40;
    for k in 0..steps {
        let v = (k as f64 + 0.5) / steps as f64;
        let y = top + hh * (1.0 - (k + 1) as f32 / steps as f32);
        prims.push(Prim::Rect { x: lx, y, w: lw, h: hh / steps as f32 + 0.5, fill: quality_color(v) });
    }
    for (t, s) in ticks.iter().step_by(2) {
        let y = top + hh * (1.0 - t);
        prims.push(Prim::Line { a: [lx + lw, y], b: [lx + lw + 0.008 * l.w, y], color: axis, width: aw });
        prims.push(Prim::Text {
            at: [lx + lw + 0.012 * l.w, y + 0.35 * fs],
            size: fs,
            anchor: "start",
            text: s.clone(),
        });
    }
    // The name centred over the bar, or ending at the margin when it is wider than the room.
    let name_x = (lx + 0.5 * lw + 0.5 * super::glyphs::text_width(fs, name)).min(l.w - l.margin);
    prims.push(Prim::Text { at: [name_x, top - 0.015 * l.w], size: fs, anchor: "end", text: name.clone() });
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

fn hex(c: Rgb) -> String {
    format!("#{:02x}{:02x}{:02x}", c[0], c[1], c[2])
}

fn svg_text(sc: &Scene) -> String {
    let mut s = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w:.0}\" height=\"{h:.0}\" viewBox=\"0 0 {w:.1} {h:.1}\" font-family=\"DejaVu Sans, Verdana, sans-serif\">\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n",
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
/// histogram, a colour legend and the title. The quality is q for triangles and the smallest
/// dihedral angle for tetrahedra ([`Measure::default_for`]).
pub fn write_svg(path: &Path, mesh: &MeshData, title: &str) -> Result<(), Error> {
    super::write_file(path, &svg_bytes(mesh, title)?)
}

/// The picture of [`write_svg`] as the bytes of an SVG file.
pub fn svg_bytes(mesh: &MeshData, title: &str) -> Result<Vec<u8>, Error> {
    svg_bytes_by(mesh, title, &Measure::default_for(mesh))
}

/// The SVG picture coloured by `measure` (one value per cell), such as [`Measure::metric_q`].
pub fn svg_bytes_by(mesh: &MeshData, title: &str, measure: &Measure) -> Result<Vec<u8>, Error> {
    let sc = build_scene(mesh, title, measure, 800.0)?;
    Ok(svg_text(&sc).into_bytes())
}

/// Writes the same picture as [`write_svg`] as a PNG `width_px` wide, with the same text.
pub fn write_png(path: &Path, mesh: &MeshData, title: &str, width_px: u32) -> Result<(), Error> {
    super::write_file(path, &png_bytes(mesh, title, width_px)?)
}

/// The picture of [`write_png`] as the bytes of a PNG file.
pub fn png_bytes(mesh: &MeshData, title: &str, width_px: u32) -> Result<Vec<u8>, Error> {
    png_bytes_by(mesh, title, &Measure::default_for(mesh), width_px)
}

/// The PNG picture coloured by `measure` (one value per cell).
pub fn png_bytes_by(mesh: &MeshData, title: &str, measure: &Measure, width_px: u32) -> Result<Vec<u8>, Error> {
    use tiny_skia::{Color, FillRule, Paint, PathBuilder, Pixmap, Rect, Stroke, Transform};
    if !(64..=16384).contains(&width_px) {
        return Err(Error::Invalid(format!("PNG width {width_px} must be in 64..=16384 pixels")));
    }
    let sc = build_scene(mesh, title, measure, width_px as f32)?;
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
            Prim::Text { at, size, anchor, text } => {
                super::glyphs::draw_text(&mut pix, *at, *size, anchor, text, [20, 20, 20]);
            }
        }
    }
    pix.encode_png().map_err(|e| Error::internal(format!("cannot encode the PNG picture: {e}")))
}
