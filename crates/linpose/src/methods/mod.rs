//! The estimation methods, one folder each: [`linear`] (Okatani & Deguchi's linear model),
//! [`eigenspace`] (Murase & Nayar's parametric eigenspace, the paper's baseline) and [`refined`]
//! (the eigenspace's manifold searched continuously, beyond the paper).

pub mod eigenspace;
pub mod linear;
pub mod refined;
mod spec;

pub use spec::MethodSpec;
