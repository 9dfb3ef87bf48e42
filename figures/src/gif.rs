//! The animation's GIF encoding: one palette for the whole animation and
//! only what changed in each frame.
//!
//! Why not plotters' GIF backend: it quantises every frame on its own
//! (NeuQuant at speed 10), 31 ms of a frame's 32 ms here (the drawing is
//! under 1 ms), and stores each frame whole with its own palette. Here the
//! palette is learned once, from a few frames spread over the run, and
//! each pixel maps to it through a table of 32 levels per channel; a frame
//! after the first holds only the box of pixels that changed, the
//! unchanged ones inside it transparent, drawn over the last (the walls,
//! the floor and the grid are written once).

use std::fs::File;
use std::io::BufWriter;
use std::path::Path;

/// Palette entries for colours; the last index is transparency.
const COLOURS: usize = 255;
const TRANSPARENT: u8 = 255;
/// Levels per channel of the lookup table (5 bits).
const LEVELS: usize = 32;

/// A GIF being written, frame by frame, from RGB buffers.
pub struct GifWriter {
    encoder: gif::Encoder<BufWriter<File>>,
    size: (u16, u16),
    /// Palette index of each colour, by its 5-bit channels.
    lut: Vec<u8>,
    /// The indexed image as shown so far.
    shown: Vec<u8>,
    next: Vec<u8>,
    delay_cs: u16,
    first: bool,
}

fn lut_slot(r: u8, g: u8, b: u8) -> usize {
    ((r as usize >> 3) * LEVELS + (g as usize >> 3)) * LEVELS + (b as usize >> 3)
}

/// The palette: the `fixed` colours, then the rest learned from `samples`
/// (RGB frames) by NeuQuant over every fourth pixel. Fixed colours are the
/// ones a frame must show exactly however few its pixels (a force arrow,
/// the failure banner), which NeuQuant would fold into their neighbours.
fn learn(fixed: &[[u8; 3]], samples: &[Vec<u8>]) -> Vec<u8> {
    let mut rgba = Vec::new();
    for s in samples {
        for p in s.chunks_exact(3).step_by(4) {
            rgba.extend_from_slice(&[p[0], p[1], p[2], 255]);
        }
    }
    if rgba.is_empty() {
        rgba.extend_from_slice(&[255, 255, 255, 255]);
    }
    let fixed = &fixed[..fixed.len().min(COLOURS / 2)];
    let mut palette: Vec<u8> = fixed.iter().flatten().copied().collect();
    palette.extend(color_quant::NeuQuant::new(10, COLOURS - fixed.len(), &rgba).color_map_rgb());
    palette
}

impl GifWriter {
    /// Creates `path` for frames of `size` pixels shown `delay_ms` each,
    /// with a palette of the `fixed` colours and the rest learned from
    /// `samples` (frames like the ones to come, as RGB buffers of that
    /// size).
    pub fn create(
        path: &Path,
        size: (u32, u32),
        delay_ms: u32,
        fixed: &[[u8; 3]],
        samples: &[Vec<u8>],
    ) -> Result<GifWriter, String> {
        let (w, h) = (
            u16::try_from(size.0).map_err(|_| "the GIF is wider than 65,535 pixels")?,
            u16::try_from(size.1).map_err(|_| "the GIF is taller than 65,535 pixels")?,
        );
        let mut palette = learn(fixed, samples);
        palette.resize(3 * (COLOURS + 1), 0);
        let colours: Vec<[i32; 3]> = palette
            .chunks_exact(3)
            .take(COLOURS)
            .map(|c| [c[0] as i32, c[1] as i32, c[2] as i32])
            .collect();
        // The nearest palette colour to the middle of each table cell.
        let mut lut = vec![0u8; LEVELS * LEVELS * LEVELS];
        for r in 0..LEVELS {
            for g in 0..LEVELS {
                for b in 0..LEVELS {
                    let c = [(r * 8 + 4) as i32, (g * 8 + 4) as i32, (b * 8 + 4) as i32];
                    let nearest = colours
                        .iter()
                        .enumerate()
                        .min_by_key(|(_, p)| (0..3).map(|k| (p[k] - c[k]).pow(2)).sum::<i32>())
                        .map_or(0, |(i, _)| i as u8);
                    lut[(r * LEVELS + g) * LEVELS + b] = nearest;
                }
            }
        }
        let file = File::create(path).map_err(|e| e.to_string())?;
        let mut encoder =
            gif::Encoder::new(BufWriter::new(file), w, h, &palette).map_err(|e| e.to_string())?;
        encoder
            .set_repeat(gif::Repeat::Infinite)
            .map_err(|e| e.to_string())?;
        let pixels = w as usize * h as usize;
        Ok(GifWriter {
            encoder,
            size: (w, h),
            lut,
            shown: vec![TRANSPARENT; pixels],
            next: vec![0; pixels],
            delay_cs: u16::try_from(delay_ms.div_ceil(10)).unwrap_or(u16::MAX),
            first: true,
        })
    }

    /// Adds a frame (`rgb`: the RGB buffer of a whole frame).
    pub fn frame(&mut self, rgb: &[u8]) -> Result<(), String> {
        let (w, h) = (self.size.0 as usize, self.size.1 as usize);
        if rgb.len() != 3 * w * h {
            return Err(format!("a frame of {} bytes, not {}", rgb.len(), 3 * w * h));
        }
        for (i, p) in rgb.chunks_exact(3).enumerate() {
            self.next[i] = self.lut[lut_slot(p[0], p[1], p[2])];
        }
        // The box of changed pixels (the whole image for the first frame).
        let (mut x0, mut y0, mut x1, mut y1) = (w, h, 0, 0);
        for y in 0..h {
            let row = y * w;
            for x in 0..w {
                if self.next[row + x] != self.shown[row + x] {
                    x0 = x0.min(x);
                    x1 = x1.max(x + 1);
                    y0 = y0.min(y);
                    y1 = y1.max(y + 1);
                }
            }
        }
        if x1 == 0 {
            // Nothing changed: one transparent pixel keeps the timing.
            (x0, y0, x1, y1) = (0, 0, 1, 1);
        }
        let mut buffer = Vec::with_capacity((x1 - x0) * (y1 - y0));
        for y in y0..y1 {
            for x in x0..x1 {
                let i = y * w + x;
                let (now, before) = (self.next[i], self.shown[i]);
                buffer.push(if now == before && !self.first {
                    TRANSPARENT
                } else {
                    now
                });
            }
        }
        let frame = gif::Frame {
            delay: self.delay_cs,
            dispose: gif::DisposalMethod::Keep,
            transparent: (!self.first).then_some(TRANSPARENT),
            left: x0 as u16,
            top: y0 as u16,
            width: (x1 - x0) as u16,
            height: (y1 - y0) as u16,
            buffer: std::borrow::Cow::Owned(buffer),
            ..gif::Frame::default()
        };
        self.encoder
            .write_frame(&frame)
            .map_err(|e| e.to_string())?;
        std::mem::swap(&mut self.shown, &mut self.next);
        self.first = false;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_read_back_as_drawn_to_within_the_palette() {
        let (w, h) = (40u32, 30u32);
        // A grey background with a red square that moves.
        let frame = |x: usize| {
            let mut rgb = vec![200u8; 3 * (w * h) as usize];
            for y in 10..20 {
                for xx in x..x + 10 {
                    let i = 3 * (y * w as usize + xx);
                    rgb[i..i + 3].copy_from_slice(&[210, 30, 30]);
                }
            }
            rgb
        };
        let frames: Vec<Vec<u8>> = [2, 12, 12, 25].iter().map(|&x| frame(x)).collect();
        let dir = std::env::temp_dir().join(format!("cosim-gif-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("t.gif");
        // The red is not in the sample: fixed, it is still exact.
        let grey = vec![200u8; 3 * (w * h) as usize];
        let mut g = GifWriter::create(&path, (w, h), 40, &[[210, 30, 30]], &[grey]).unwrap();
        for f in &frames {
            g.frame(f).unwrap();
        }
        drop(g);
        let mut options = gif::DecodeOptions::new();
        options.set_color_output(gif::ColorOutput::RGBA);
        let mut decoder = options
            .read_info(std::fs::File::open(&path).unwrap())
            .unwrap();
        // Compose the frames as a viewer does (each drawn over the last).
        let mut canvas = vec![0u8; 4 * (w * h) as usize];
        let mut k = 0;
        while let Some(f) = decoder.read_next_frame().unwrap() {
            assert_eq!(f.delay, 4);
            for y in 0..f.height as usize {
                for x in 0..f.width as usize {
                    let s = 4 * (y * f.width as usize + x);
                    if f.buffer[s + 3] == 0 {
                        continue;
                    }
                    let d = 4 * ((y + f.top as usize) * w as usize + x + f.left as usize);
                    canvas[d..d + 4].copy_from_slice(&f.buffer[s..s + 4]);
                }
            }
            for (i, p) in frames[k].chunks_exact(3).enumerate() {
                for c in 0..3 {
                    let got = canvas[4 * i + c] as i32;
                    let exact = p == [210, 30, 30] || p == [200, 200, 200];
                    let tolerance = if exact { 4 } else { 12 };
                    assert!(
                        (got - p[c] as i32).abs() <= tolerance,
                        "frame {k} pixel {i}"
                    );
                }
            }
            k += 1;
        }
        assert_eq!(k, frames.len());
        let _ = std::fs::remove_dir_all(&dir);
    }
}
