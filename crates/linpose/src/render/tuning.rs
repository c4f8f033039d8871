//! The renderer's tuning constants: for each, what it trades and how its value was set. The
//! scene itself (the built-in objects' shapes, a mesh's default albedo, the camera's default
//! distance) and the limits on what is accepted are definitions, not trade-offs, and stay
//! beside their code.

/// Images rendered and written per parallel chunk of `synth`. A chunk is checked for failures
/// before the next starts, so a failure (a full disk) stops the render within a chunk; each
/// chunk costs a fork-join and a renderer per thread. A larger chunk balances the threads
/// better, a smaller one stops sooner. Chosen by hand; not measured.
pub(crate) const CHUNK: usize = 256;
