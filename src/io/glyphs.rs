//! Text for the PNG pictures: one embedded font, laid out and rasterised by `ab_glyph` (pure
//! Rust, Apache-2.0) into a tiny-skia pixmap, so that a PNG carries the same words and numbers
//! as its SVG on any machine, with or without system fonts.
//!
//! The font is DejaVu Sans 2.37 cut down to Latin-1, Greek and a few symbols
//! (`assets/fonts/DejaVuSans-subset.ttf`, 47 kB). Its licence is the Bitstream Vera licence
//! (DejaVu's changes are in the public domain), a permissive font licence that allows
//! redistribution and embedding; the text is in `assets/fonts/LICENSE-DejaVu.txt`.

use ab_glyph::{Font, FontRef, Glyph, PxScale, ScaleFont};
use std::sync::OnceLock;
use tiny_skia::Pixmap;

static FONT_BYTES: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans-subset.ttf");

/// The embedded font (parsed once).
fn font() -> Option<&'static FontRef<'static>> {
    static FONT: OnceLock<Option<FontRef<'static>>> = OnceLock::new();
    FONT.get_or_init(|| FontRef::try_from_slice(FONT_BYTES).ok()).as_ref()
}

/// The font's scale for a CSS font size in pixels (the em square is `size` pixels tall, as in
/// the SVG's `font-size`).
fn scale_for(f: &FontRef<'static>, size: f32) -> PxScale {
    let em = f.units_per_em().unwrap_or(2048.0);
    PxScale::from(size * f.height_unscaled() / em)
}

/// Glyphs of `text` laid out from x = 0 on the baseline y = 0, and the advance width.
fn layout(f: &FontRef<'static>, size: f32, text: &str) -> (Vec<Glyph>, f32) {
    let sf = f.as_scaled(scale_for(f, size));
    let mut x = 0.0;
    let mut prev = None;
    let mut out = Vec::with_capacity(text.len());
    for c in text.chars() {
        // A character the cut-down font lacks is drawn as '?' rather than an empty box.
        let id = match sf.glyph_id(c) {
            id if id.0 == 0 && !c.is_whitespace() => sf.glyph_id('?'),
            id => id,
        };
        if let Some(p) = prev {
            x += sf.kern(p, id);
        }
        out.push(id.with_scale_and_position(sf.scale(), ab_glyph::point(x, 0.0)));
        x += sf.h_advance(id);
        prev = Some(id);
    }
    (out, x)
}

/// The advance width of `text` at `size` pixels (0 when the font cannot be read).
pub(crate) fn text_width(size: f32, text: &str) -> f32 {
    font().map_or(0.0, |f| layout(f, size, text).1)
}

/// Draws `text` in `color` with its baseline at `at`, anchored at its start, middle or end
/// ("start", "middle", "end" as in SVG's `text-anchor`). Coverage is blended over the opaque
/// pixels already there.
pub fn draw_text(pix: &mut Pixmap, at: [f32; 2], size: f32, anchor: &str, text: &str, color: [u8; 3]) {
    let Some(f) = font() else { return };
    let (glyphs, width) = layout(f, size, text);
    let dx = match anchor {
        "middle" => -0.5 * width,
        "end" => -width,
        _ => 0.0,
    };
    let (w, h) = (pix.width() as i64, pix.height() as i64);
    let data = pix.data_mut();
    for mut g in glyphs {
        g.position = ab_glyph::point(g.position.x + at[0] + dx, g.position.y + at[1]);
        let Some(outline) = f.outline_glyph(g) else { continue };
        let b = outline.px_bounds();
        outline.draw(|x, y, c| {
            let (px, py) = (b.min.x as i64 + x as i64, b.min.y as i64 + y as i64);
            if px < 0 || py < 0 || px >= w || py >= h {
                return;
            }
            let k = 4 * (py * w + px) as usize;
            let c = c.clamp(0.0, 1.0);
            for (ch, &tc) in data[k..k + 3].iter_mut().zip(color.iter()) {
                *ch = (*ch as f32 * (1.0 - c) + tc as f32 * c).round() as u8;
            }
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_embedded_font_draws_ink() {
        assert!(font().is_some(), "the embedded font must parse");
        assert!(text_width(20.0, "q min 0.512") > 50.0);
        let mut pix = Pixmap::new(200, 40).unwrap();
        pix.fill(tiny_skia::Color::WHITE);
        draw_text(&mut pix, [10.0, 30.0], 20.0, "start", "Bézier q ≤ 1", [0, 0, 0]);
        let dark = pix.data().chunks(4).filter(|p| p[0] < 128).count();
        assert!(dark > 100, "only {dark} dark pixels: the text was not drawn");
    }
}
