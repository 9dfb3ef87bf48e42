//! Text on the bitmaps, laid out right. plotters 0.3.7 draws each glyph of
//! its `ab_glyph` font at the pen position without the glyph's left side
//! bearing (`ab_glyph.rs`, `draw`: the outline's pixels are offset from its
//! bounds' corner, not from the pen), so a narrow glyph sits against the
//! one before it and a gap follows: "0. 001", "n _d", "l emke" (plotters
//! issue 576 and its neighbours). [`Kerned`] is a bitmap backend whose
//! `draw_text` places every glyph by its own bounds, with the font's
//! advances and kerning, and anchors and turns the line as plotters does;
//! everything else goes to the backend it wraps.

use ab_glyph::{point, Font, FontRef, ScaleFont};
use plotters::prelude::DrawingBackend;
use plotters_backend::text_anchor::{HPos, VPos};
use plotters_backend::{
    BackendColor, BackendCoord, BackendStyle, BackendTextStyle, DrawingErrorKind,
};

/// A backend that draws text with [`Kerned::draw_text`].
pub struct Kerned<B> {
    inner: B,
    font: FontRef<'static>,
}

impl<B: DrawingBackend> Kerned<B> {
    pub fn new(inner: B) -> Kerned<B> {
        // The font is compiled in (assets/), not outside data; `ensure_font`
        // and the tests parse it.
        let font = FontRef::try_from_slice(super::FONT_BYTES).expect("the embedded font parses");
        Kerned { inner, font }
    }
}

impl<B: DrawingBackend> DrawingBackend for Kerned<B> {
    type ErrorType = B::ErrorType;

    fn get_size(&self) -> (u32, u32) {
        self.inner.get_size()
    }
    fn ensure_prepared(&mut self) -> Result<(), DrawingErrorKind<B::ErrorType>> {
        self.inner.ensure_prepared()
    }
    fn present(&mut self) -> Result<(), DrawingErrorKind<B::ErrorType>> {
        self.inner.present()
    }
    fn draw_pixel(
        &mut self,
        point: BackendCoord,
        color: BackendColor,
    ) -> Result<(), DrawingErrorKind<B::ErrorType>> {
        self.inner.draw_pixel(point, color)
    }
    fn draw_line<S: BackendStyle>(
        &mut self,
        from: BackendCoord,
        to: BackendCoord,
        style: &S,
    ) -> Result<(), DrawingErrorKind<B::ErrorType>> {
        self.inner.draw_line(from, to, style)
    }
    fn draw_rect<S: BackendStyle>(
        &mut self,
        upper_left: BackendCoord,
        bottom_right: BackendCoord,
        style: &S,
        fill: bool,
    ) -> Result<(), DrawingErrorKind<B::ErrorType>> {
        self.inner.draw_rect(upper_left, bottom_right, style, fill)
    }
    fn draw_path<S: BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        path: I,
        style: &S,
    ) -> Result<(), DrawingErrorKind<B::ErrorType>> {
        self.inner.draw_path(path, style)
    }
    fn draw_circle<S: BackendStyle>(
        &mut self,
        center: BackendCoord,
        radius: u32,
        style: &S,
        fill: bool,
    ) -> Result<(), DrawingErrorKind<B::ErrorType>> {
        self.inner.draw_circle(center, radius, style, fill)
    }
    fn fill_polygon<S: BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        vert: I,
        style: &S,
    ) -> Result<(), DrawingErrorKind<B::ErrorType>> {
        self.inner.fill_polygon(vert, style)
    }
    fn blit_bitmap(
        &mut self,
        pos: BackendCoord,
        (iw, ih): (u32, u32),
        src: &[u8],
    ) -> Result<(), DrawingErrorKind<B::ErrorType>> {
        self.inner.blit_bitmap(pos, (iw, ih), src)
    }
    fn estimate_text_size<S: BackendTextStyle>(
        &self,
        text: &str,
        style: &S,
    ) -> Result<(u32, u32), DrawingErrorKind<B::ErrorType>> {
        self.inner.estimate_text_size(text, style)
    }

    fn draw_text<S: BackendTextStyle>(
        &mut self,
        text: &str,
        style: &S,
        pos: BackendCoord,
    ) -> Result<(), DrawingErrorKind<B::ErrorType>> {
        let color = style.color();
        if color.alpha == 0.0 {
            return Ok(());
        }
        // The anchor from the line's box, as plotters' own draw_text takes
        // it (its layout box is the advances and kerning, as here).
        let ((min_x, min_y), (max_x, max_y)) = style
            .layout_box(text)
            .map_err(|e| DrawingErrorKind::FontError(Box::new(e)))?;
        let (width, height) = (max_x - min_x, max_y - min_y);
        let dx = match style.anchor().h_pos {
            HPos::Left => 0,
            HPos::Right => -width,
            HPos::Center => -width / 2,
        };
        let dy = match style.anchor().v_pos {
            VPos::Top => 0,
            VPos::Center => -height / 2,
            VPos::Bottom => -height,
        };
        let trans = style.transform();
        let (w, h) = self.get_size();
        let size = style.size() as f32;
        let font = self.font.as_scaled(size);
        let mut pen = 0f32;
        let mut prev = None;
        for c in text.chars() {
            let id = font.glyph_id(c);
            if let Some(p) = prev {
                pen += font.kern(p, id);
            }
            prev = Some(id);
            // The glyph at the pen (its baseline at 0): its outline's
            // bounds hold its side bearing.
            let glyph = id.with_scale_and_position(size, point(pen, 0.0));
            pen += font.h_advance(id);
            let Some(outline) = self.font.outline_glyph(glyph) else {
                continue;
            };
            let bounds = outline.px_bounds();
            // plotters' vertical placement: half the size below the top.
            let (gx, gy) = (bounds.min.x as i32, (size / 2.0 + bounds.min.y) as i32);
            let mut pixels = Vec::new();
            outline.draw(|x, y, coverage| pixels.push((x as i32, y as i32, coverage)));
            for (x, y, coverage) in pixels {
                let (x, y) = trans.transform(gx + x + dx - min_x, gy + y + dy - min_y);
                let (x, y) = (pos.0 + x, pos.1 + y);
                if x >= 0 && x < w as i32 && y >= 0 && y < h as i32 && coverage > 0.0 {
                    let c = BackendColor {
                        alpha: color.alpha * f64::from(coverage.min(1.0)),
                        rgb: color.rgb,
                    };
                    self.inner.draw_pixel((x, y), c)?;
                }
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::Kerned;
    use plotters::prelude::*;

    /// The runs of blank columns between the inked ones of "0.001" drawn
    /// at 40 px, left to right.
    fn gaps(kerned: bool) -> Vec<usize> {
        crate::ensure_font().expect("font");
        let (w, h) = (300u32, 80u32);
        let mut rgb = vec![255u8; 3 * (w * h) as usize];
        {
            let style = (crate::FONT, 40).into_font().color(&BLACK);
            let text = Text::new("0.001", (10, 10), style);
            if kerned {
                let area =
                    Kerned::new(BitMapBackend::with_buffer(&mut rgb, (w, h))).into_drawing_area();
                area.draw(&text).expect("draw");
                area.present().expect("present");
            } else {
                let area = BitMapBackend::with_buffer(&mut rgb, (w, h)).into_drawing_area();
                area.draw(&text).expect("draw");
                area.present().expect("present");
            }
        }
        let inked: Vec<bool> = (0..w as usize)
            .map(|x| (0..h as usize).any(|y| rgb[3 * (y * w as usize + x)] < 128))
            .collect();
        let first = inked.iter().position(|&i| i).expect("ink");
        let last = inked.iter().rposition(|&i| i).expect("ink");
        let (mut gaps, mut run) = (Vec::new(), 0);
        for &i in &inked[first..=last] {
            if i {
                if run > 0 {
                    gaps.push(run);
                }
                run = 0;
            } else {
                run += 1;
            }
        }
        gaps
    }

    /// The point of "0.001" sits between its neighbours: the blank before
    /// it and after it differ by a pixel or two (the glyphs' own side
    /// bearings). plotters' own drawing puts it against the first "0" and
    /// leaves the gap after it ("0. 001").
    #[test]
    fn a_number_is_drawn_without_a_gap_after_its_point() {
        let (ours, theirs) = (gaps(true), gaps(false));
        assert_eq!(ours.len(), 4, "{ours:?}");
        assert!(ours[0].abs_diff(ours[1]) <= 1, "ours: {ours:?}");
        assert!(
            theirs[1] >= theirs[0] + 3,
            "plotters': {theirs:?} ours: {ours:?}"
        );
        assert!(ours[1] < theirs[1], "ours: {ours:?}, plotters': {theirs:?}");
    }
}
