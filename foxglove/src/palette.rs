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

/// The colour of body (or series) `i`, RGB, in turn.
pub fn color(i: usize) -> [u8; 3] {
    PALETTE[i % PALETTE.len()]
}
