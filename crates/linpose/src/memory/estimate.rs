//! What each path allocates: the training images (and their normalised copies), the process and
//! its decoding threads ([`super::tuning`]), and what the method's fit allocates beside them,
//! which the method says itself ([`crate::model::footprint`]). Each estimate is a sum of named
//! parts (the largest names it), and where a fit's stages free one stage's arrays before the next
//! allocates its own, the larger stage only.

use super::tuning::*;
use super::Job;
use crate::model::footprint::{Parts, Sizes};

/// What a path needs: bytes, and its largest part in words.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Estimate {
    /// Peak resident bytes, an upper bound by design (see the memory module's tuning constants).
    pub bytes: u64,
    /// The largest part, e.g. "N x N Gram of 100800 images".
    pub what: String,
}

/// The estimate of `parts`, with the process and its decoding threads, named by the parts
/// (`name` when there are none).
fn estimate(parts: Parts, job: &Job, name: &str) -> Estimate {
    let what = parts.what().unwrap_or_else(|| name.to_string());
    let parts = parts
        .add(OVERHEAD_BYTES as f64, "the process")
        .add(job.n as f64 * IMAGE_ENTRY_BYTES as f64, "the manifest")
        .add((job.threads * job.m) as f64 * THREAD_FEATURE_BYTES as f64, "decoding");
    let bytes = parts.total().ceil();
    Estimate { bytes: if bytes >= u64::MAX as f64 { u64::MAX } else { bytes as u64 }, what }
}

fn f(n: usize) -> f64 {
    n as f64
}

/// The training images as f32 (and their normalised copy).
fn images(job: &Job) -> Parts {
    let (n, m) = (f(job.n), f(job.m));
    let p = Parts::default().add(4.0 * n * m, format!("{} images of {} features as f32", job.n, job.m));
    let p = if job.normalize { p.add(4.0 * n * m, "the normalised images") } else { p };
    if job.choose_stage {
        p.add(4.0 * n * m, "the held-out folds' normalised views (choosing the normalisation)")
    } else {
        p
    }
}

/// The in-memory path: the images loaded, then the method's fit.
pub(crate) fn in_memory(job: &Job) -> Estimate {
    let parts = match &job.objects {
        Some(_) => objects(job),
        None => images(job).stage(job.fit.fit(&job.sizes()), Parts::default()),
    };
    estimate(parts, job, "the images")
}

/// A data set of many objects (in memory only): the objects' images, a concatenated copy, the
/// recogniser's fit on all of them (which it says itself), and beside it the objects' pose
/// models, as many at once as there are threads.
fn objects(job: &Job) -> Parts {
    let o = job.objects.as_ref().expect("a job of many objects");
    let (t, m) = (f(job.n), f(job.m));
    let recogniser = (o.recognizer.kind.footprint)(&job.sizes(), o.count, &o.recognizer);
    let one = Sizes { n: o.largest, ..job.sizes() };
    let at_once = f(job.threads.min(o.count).max(1));
    let per_object = job.fit.fit(&one).total();
    images(job).add(4.0 * t * m, "the images concatenated").stage(recogniser, Parts::default()).add(at_once * per_object, "the objects' pose models")
}

/// The streamed path (a method that streams, with settings it streams with): what the method's
/// streamed fit allocates, or, where it loads the set, what the in-memory path needs.
pub(crate) fn streamed(job: &Job) -> Estimate {
    match job.fit.streamed(&job.sizes()) {
        Some(parts) => estimate(parts, job, "the streamed fit"),
        None => estimate(images(job).stage(job.fit.fit(&job.sizes()), Parts::default()), job, "the images"),
    }
}
