//! Body colours (Tableau 10): body `i` has the same colour in the figures, the
//! animation, the recordings and the live view.

const PALETTE: [[u8; 3]; 10] = [
    [31, 119, 180],
    [255, 127, 14],
    [44, 160, 44],
    [214, 39, 40],
    [148, 103, 189],
    [140, 86, 75],
    [227, 119, 194],
    [127, 127, 127],
    [188, 189, 34],
    [23, 190, 207],
];

/// Tableau 20's light companions of [`PALETTE`], for series 10 to 19.
const LIGHT: [[u8; 3]; 10] = [
    [174, 199, 232],
    [255, 187, 120],
    [152, 223, 138],
    [255, 152, 150],
    [197, 176, 213],
    [196, 156, 148],
    [247, 182, 210],
    [199, 199, 199],
    [219, 219, 141],
    [158, 218, 229],
];

/// The colour of body (or series) `i`, RGB: Tableau 10, then its light
/// companions (Tableau 20), then the first ten at 60 % (a 24-contact
/// legend had ten colours for 24 names); after 30 they repeat.
pub fn color(i: usize) -> [u8; 3] {
    let k = i % 10;
    match (i / 10) % 3 {
        0 => PALETTE[k],
        1 => LIGHT[k],
        _ => PALETTE[k].map(|c| (f64::from(c) * 0.6).round() as u8),
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn thirty_series_have_thirty_colours() {
        let mut c: Vec<[u8; 3]> = (0..30).map(super::color).collect();
        c.sort();
        c.dedup();
        assert_eq!(c.len(), 30);
        assert_eq!(super::color(30), super::color(0));
    }
}
