//! The renderer's tuning constants: for each, what it trades and how its value was set. The
//! scene itself (the built-in objects' shapes, a mesh's default albedo, the camera's default
//! distance) and the limits on what is accepted are definitions, not trade-offs, and stay
//! beside their code.

/// Images rendered and written per parallel chunk of `synth`. A chunk is checked for failures
/// before the next starts, so a failure (a full disk) stops the render within a chunk; each
/// chunk costs a fork-join and a renderer per thread. A larger chunk balances the threads
/// better, a smaller one stops sooner. Chosen by hand; not measured.
pub(crate) const CHUNK: usize = 256;

/// Bisection steps of the occluders' common scale ([`super::occlude`]): each halves the
/// interval of scales, from twice the frame over the smallest half-size; 40 steps leave it far
/// below the scale at which one pixel more is covered, so the hidden share is as near the one
/// asked for as whole pixels allow. Each step counts the object's pixels under the occluders
/// once (a few thousand tests a view). Not tuned: more steps change nothing measurable.
pub(crate) const OCCLUDE_STEPS: usize = 40;

/// Photographs for backgrounds are kept reduced to at most this many times the views' larger
/// side on their smaller side ([`super::photos`]): a crop then spans from the view's own size up
/// to this many times it, enough variety of scale, while a folder of 12-megapixel photographs
/// for 128 x 128 views takes 1.4 MB a photograph rather than 36. Chosen, not measured.
pub(crate) const PHOTO_DETAIL: usize = 4;
