//! The recognisers' tuning constants: what the linear recogniser's fit costs in memory, for the
//! memory plan ([`crate::memory`], whose documentation tables the measurements). (The universal
//! eigenspace's PCA and manifold cost what the eigenspace's do: `crate::manifold::tuning`.)

/// Bytes per N^2 of the linear recogniser of many objects: G, its shifted copy and factor (as
/// the linear model's `GRAM_SYSTEM_BYTES`) and the factor's inverse (another N x N), read from
/// the code; measured within 10% above on three objects of 1,440 images.
pub(crate) const LINEAR_RECOGNIZER_BYTES: f64 = 32.0;
