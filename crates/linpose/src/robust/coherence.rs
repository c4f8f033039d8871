//! How coherent a fit's explained pixels are: per binned pixel, the share of its 3 x 3
//! neighbourhood (itself included, pixels beyond the image counted unexplained) that the fit
//! explains.
//!
//! The hypothesis search (`search.rs`) weighs each pixel's vote by it. Occluders and clutter
//! are spatially coherent: the pixels a right pose leaves unexplained lie in whole regions (an
//! occluder, the background beyond the silhouette), where the share is low, and a pixel that
//! clutter matches by chance stands alone. A wrong pose of the object (the other side of a toy
//! car) fails on the details the two sides do not share, thin lines and specks inside regions it
//! explains, where the share is high. Counting every pixel alike, as Leonardis & Bischof's
//! description length does, lets chance matches in a large occluder outvote those details.

/// Fills `count` (the grid's pixels) with how many of each pixel's 3 x 3 neighbourhood `ok`
/// marks (0 to 9; the share is a ninth of it), on a grid of `width` columns; `rows` is
/// scratch.
pub(super) fn neighbourhood(ok: &[bool], width: usize, count: &mut [u8], rows: &mut Vec<u8>) {
    let n = ok.len();
    debug_assert_eq!(count.len(), n);
    if width == 0 || n == 0 {
        return;
    }
    rows.clear();
    rows.resize(n, 0);
    // Along the rows, then along the columns.
    for (r, o) in ok.chunks(width).zip(rows.chunks_mut(width)) {
        let w = r.len();
        for c in 0..w {
            o[c] = r[c] as u8 + (c > 0 && r[c - 1]) as u8 + (c + 1 < w && r[c + 1]) as u8;
        }
    }
    count.copy_from_slice(rows);
    for (below, above) in count[width.min(n)..].iter_mut().zip(&rows[..n.saturating_sub(width)]) {
        *below += above;
    }
    for (above, below) in count[..n.saturating_sub(width)].iter_mut().zip(&rows[width.min(n)..]) {
        *above += below;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_are_the_neighbourhood_s() {
        // 4 x 3, the top-left 2 x 2 block explained.
        let ok = [true, true, false, false, true, true, false, false, false, false, false, false];
        let mut count = vec![0u8; 12];
        neighbourhood(&ok, 4, &mut count, &mut Vec::new());
        assert_eq!(count, vec![4, 4, 2, 0, 4, 4, 2, 0, 2, 2, 1, 0]);
    }
}
