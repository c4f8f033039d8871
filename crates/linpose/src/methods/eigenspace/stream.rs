//! Training the eigenspace on more images than memory holds ([`crate::Method::fit_streamed`]):
//! with more images than features (N > M), the eigenspace from the M x M scatter of the
//! unit-energy images ([`crate::manifold::scatter`]), read from disk block by block, then a
//! second pass over the images for their coordinates (N x L), the manifold's knots. Memory: the
//! scatter and its eigendecomposition (about 44 M^2 bytes), a block of images, the coordinates
//! and the manifold built from them, whatever the images take on disk: a million views of
//! 32 x 24 need under 2 GiB, where the images alone are 2.9 GiB as f32.
//!
//! The model is the in-memory fit's eigenspace and manifold (the same numbers up to rounding)
//! without the second look (`second_look`): that keeps every principal component of the training
//! views, N x min(N - 1, M / b^2) coordinates (a million views of 32 x 24: 767 coordinates each,
//! 2.9 GiB, and a surface through them eight times that), which is what a set this large cannot
//! hold. The streamed model is Murase & Nayar's own: the nearest point of the manifold, with
//! no ranked alternatives and no confidence.
//!
//! With N <= M the set is loaded and fitted in memory (the N x N Gram route holds the images
//! anyway), second look included.

use super::{EigenspaceModel, EigenspaceParams};
use crate::image_io::{read_features, ColorMode, ImageSpec};
use crate::manifest::Manifest;
use crate::manifold::pca::{all_alike, black};
use crate::manifold::scatter::Scatter;
use crate::manifold::tuning::SCATTER_BLOCK;
use crate::model::{AnyModel, Estimator, Settings};
use crate::{Error, Result};
use rayon::prelude::*;
use std::time::Instant;

/// [`crate::Method::fit_streamed`] for the eigenspace (see the module doc).
pub(crate) fn fit_streamed(manifest: &Manifest, color: ColorMode, settings: &Settings, progress: &(dyn Fn(u64) + Sync)) -> Result<(AnyModel, String)> {
    let params = EigenspaceParams::from_settings(settings)?;
    params.validate()?;
    let spec = manifest.first_image_spec(color)?;
    let (n, m) = (manifest.len(), spec.features());
    if n <= m {
        let t = Instant::now();
        let data = crate::Dataset::load(manifest.clone(), color, progress)?;
        let read_s = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let model = params.fit(&data)?;
        let how = format!("N <= M, so in memory through the N x N Gram matrix: reading {read_s:.3} s, fitting {:.3} s", t.elapsed().as_secs_f64());
        return Ok((AnyModel::new(model), how));
    }
    let (model, how) = fit_scatter(manifest, spec, &params, progress)?;
    Ok((AnyModel::new(model), how))
}

/// N > M: the scatter, its eigenimages, the coordinates, the model without a second look.
fn fit_scatter(manifest: &Manifest, spec: ImageSpec, params: &EigenspaceParams, progress: &(dyn Fn(u64) + Sync)) -> Result<(EigenspaceModel, String)> {
    let (n, m) = (manifest.len(), spec.features());
    if n < 2 {
        return Err(Error::Dataset { path: manifest.root().to_path_buf(), message: format!("the eigenspace needs at least 2 training images, got {n}") });
    }
    // The grid first: a training set that cannot make a manifold fails before any image is read.
    let grid = params.grid(manifest)?;
    let context = format!("the size of the data set's first image, {}", manifest.images()[0]);
    let mut block = vec![0f32; SCATTER_BLOCK.min(n) * m];
    let (mut read_s, t0) = (0.0, Instant::now());
    let mut scatter = Scatter::new(m);
    for start in (0..n).step_by(SCATTER_BLOCK) {
        let rows = read_block(manifest, spec, &context, start, &mut block, progress, &mut read_s)?;
        scatter.add(rows, |i| black(manifest, i))?;
    }
    let t1 = Instant::now();
    let eigen = scatter.eigen(params.dimension)?.ok_or_else(|| all_alike(manifest))?;
    let eigen_s = t1.elapsed().as_secs_f64();
    let l = eigen.dim();
    let mut coords = vec![0.0; n * l];
    for start in (0..n).step_by(SCATTER_BLOCK) {
        let rows = read_block(manifest, spec, &context, start, &mut block, progress, &mut read_s)?;
        let b = rows.len() / m;
        eigen.project(rows, &mut coords[start * l..(start + b) * l], |i| black(manifest, start + i))?;
    }
    let passes_s = t0.elapsed().as_secs_f64() - eigen_s;
    let t2 = Instant::now();
    let pca = eigen.into_pca(coords);
    let model = params.model(manifest, spec, &grid, &pca, None)?;
    let how = format!(
        "N > M, so the eigenspace from the M x M scatter of the unit-energy images, two passes over them (the scatter, then the coordinates): \
         {passes_s:.3} s (reading {read_s:.3} s of it), eigendecomposition {eigen_s:.3} s, manifold {:.3} s; no second look (it would keep N x {} coordinates)",
        t2.elapsed().as_secs_f64(),
        (n - 1).min(m)
    );
    Ok((model, how))
}

/// Images `start..` of `manifest` (at most a block's worth) decoded in parallel into `block`;
/// the rows read. `progress` is told of each image, `read_s` of the seconds.
fn read_block<'a>(
    manifest: &Manifest,
    spec: ImageSpec,
    context: &str,
    start: usize,
    block: &'a mut [f32],
    progress: &(dyn Fn(u64) + Sync),
    read_s: &mut f64,
) -> Result<&'a [f32]> {
    let m = spec.features();
    let b = (block.len() / m).min(manifest.len() - start);
    let t = Instant::now();
    block[..b * m].par_chunks_mut(m).enumerate().try_for_each_init(Vec::new, |row, (k, slot)| {
        row.clear();
        let path = manifest.image_path(start + k);
        read_features(&path, spec.color, Some((spec.width, spec.height)), context, row)?;
        if row.iter().any(|v| !v.is_finite()) {
            return Err(Error::Dataset { path, message: "image has a non-finite value".into() });
        }
        slot.copy_from_slice(row);
        progress(1);
        Ok(())
    })?;
    *read_s += t.elapsed().as_secs_f64();
    Ok(&block[..b * m])
}
