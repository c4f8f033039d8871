//! The images of a training set added to [`NormalEquations`] block by block as they are read: a
//! reader thread decodes the next block while the current one is added, so reading overlaps the
//! sums (decoding is a few per cent of the work). The linear model's streamed fit and the
//! partial statistics of shards of images ([`crate::partial`]) both sum so.

use super::NormalEquations;
use crate::image_io::{read_features, ImageSpec};
use crate::kernels::levels::quantize;
use crate::kernels::syrk::KCP;
use crate::manifest::Manifest;
use crate::{Error, Result};
use std::sync::mpsc::sync_channel;
use std::time::Instant;

/// Images decoded per block (one 8-bit panel of the SYRK kernels).
pub(crate) const BLOCK: usize = 2 * KCP;

/// What [`accumulate_rows`] reads with: images `start..` of `manifest` (each of `spec`, else an
/// error naming `context`) decoded from disk into the rows of a block, `progress` told of each.
pub(crate) fn disk_reader<'a>(
    manifest: &'a Manifest,
    spec: ImageSpec,
    context: String,
    progress: &'a (dyn Fn(u64) + Sync),
) -> impl FnMut(usize, &mut [f32]) -> Result<()> + Send + 'a {
    let m = spec.features();
    let mut row = Vec::with_capacity(m);
    move |start, block| {
        for (k, slot) in block.chunks_exact_mut(m).enumerate() {
            row.clear();
            read_features(&manifest.image_path(start + k), spec.color, Some((spec.width, spec.height)), &context, &mut row)?;
            slot.copy_from_slice(&row);
            progress(1);
        }
        Ok(())
    }
}

/// A block of images on its way from the reader to the accumulation.
struct Block {
    start: usize,
    len: usize,
    /// Features, `len` rows of M.
    f: Vec<f32>,
    /// The same as 8-bit levels, when `exact`.
    q: Vec<u8>,
    /// Whether every feature is an 8-bit level (k as f32 / 255 exactly as image_io makes it).
    exact: bool,
}

/// Seconds a block-by-block accumulation spent: reading (on the reader thread), waiting for the
/// reader, and adding blocks to the sums.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct Timing {
    pub read_s: f64,
    pub wait_s: f64,
    pub accumulate_s: f64,
}

/// Adds images `range` of `manifest` (M features each), delivered block by block by
/// `read(start, block)` on a reader thread of its own, to `ne`, in order.
pub(crate) fn accumulate_rows(
    manifest: &Manifest,
    m: usize,
    range: std::ops::Range<usize>,
    block: usize,
    mut read: impl FnMut(usize, &mut [f32]) -> Result<()> + Send,
    ne: &mut NormalEquations,
) -> Result<Timing> {
    assert!(block > 0, "block size");
    let space = manifest.space();
    let k = space.encoded_len();
    let (first, end) = (range.start, range.end);
    let mut p = vec![0f64; block * k];
    let (mut wait_s, mut accumulate_s) = (0.0, 0.0);
    let bsize = block.min(end - first);

    let read_s = std::thread::scope(|scope| -> Result<f64> {
        let (full_tx, full_rx) = sync_channel::<Result<Block>>(1);
        let (free_tx, free_rx) = sync_channel::<Block>(2);
        for _ in 0..2 {
            free_tx.send(Block { start: 0, len: 0, f: vec![0.0; bsize * m], q: vec![0; bsize * m], exact: false }).expect("fresh channel");
        }
        let reader = scope.spawn(move || {
            let mut read_s = 0.0;
            let mut start = first;
            while start < end {
                let Ok(mut blk) = free_rx.recv() else { break };
                let b = block.min(end - start);
                let t = Instant::now();
                let res = read(start, &mut blk.f[..b * m]).and_then(|()| {
                    let f = &blk.f[..b * m];
                    if let Some(i) = f.iter().position(|v| !v.is_finite()) {
                        return Err(Error::Dataset { path: manifest.image_path(start + i / m), message: "image has a non-finite value".into() });
                    }
                    blk.exact = quantize(f, &mut blk.q[..b * m]);
                    Ok(())
                });
                read_s += t.elapsed().as_secs_f64();
                let failed = res.is_err();
                (blk.start, blk.len) = (start, b);
                if full_tx.send(res.map(|()| blk)).is_err() || failed {
                    break;
                }
                start += b;
            }
            read_s
        });
        let mut done = first;
        while done < end {
            let t = Instant::now();
            let Ok(blk) = full_rx.recv() else { break };
            let blk = blk?;
            wait_s += t.elapsed().as_secs_f64();
            let t = Instant::now();
            let (start, b) = (blk.start, blk.len);
            debug_assert_eq!(start, done);
            for i in 0..b {
                space.encode(manifest.pose(start + i), &mut p[i * k..(i + 1) * k]);
            }
            ne.add(&blk.f[..b * m], blk.exact.then(|| &blk.q[..b * m]), &p[..b * k]);
            accumulate_s += t.elapsed().as_secs_f64();
            done += b;
            let _ = free_tx.send(blk);
        }
        drop((full_rx, free_tx));
        Ok(reader.join().expect("the reader thread panicked"))
    })?;
    Ok(Timing { read_s, wait_s, accumulate_s })
}
