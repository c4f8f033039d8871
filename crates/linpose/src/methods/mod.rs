//! The estimation methods, one folder each, and the registry that lists them.
//!
//! - [`linear`]: Okatani & Deguchi's linear model, the paper's method;
//! - [`eigenspace`]: Murase & Nayar's parametric eigenspace, the paper's baseline;
//! - [`refined`]: the eigenspace's manifold searched continuously, beyond the paper.
//!
//! Each folder defines its parameters (an [`crate::Estimator`]), its fitted model (a
//! [`crate::PoseModel`]) and its [`Method`] entry: its name, summary, settings and Table 1
//! storage, how a model file is read back, what its fit allocates (`footprint.rs`, the memory
//! plan's estimate), and, where it has them, a fit from images streamed from disk and a fit from
//! partial statistics (`partial.rs`). A new method is a new folder and one word in the
//! `registry!` line below: the command line (`--method` and its settings' flags), model files,
//! the memory plan, `train --shard` and `merge`, the experiment and its report, and the Python
//! package's lists find it there.

use crate::model::Method;

macro_rules! registry {
    ($($m:ident),+ $(,)?) => {
        $(pub mod $m;)+

        /// Every method linpose has, in the order reports list them.
        pub static METHODS: &[&Method] = &[$(&$m::METHOD),+];
    };
}

registry!(linear, eigenspace, refined);

/// The method called `name`.
pub(crate) fn find(name: &str) -> Option<&'static Method> {
    METHODS.iter().copied().find(|m| m.name == name)
}

impl Method {
    /// The method called `name` (as in [`METHODS`]), or an error naming those there are.
    pub fn from_name(name: &str) -> crate::Result<&'static Method> {
        find(name).ok_or_else(|| crate::Error::invalid("method", name, format!("known methods: {}", names())))
    }
}

/// The methods' names, comma-separated (for messages).
pub(crate) fn names() -> String {
    METHODS.iter().map(|m| m.name).collect::<Vec<_>>().join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_unique_and_models_name_their_method() {
        for (i, m) in METHODS.iter().enumerate() {
            assert!(METHODS[..i].iter().all(|o| o.name != m.name), "{} twice", m.name);
            assert!(std::ptr::eq(find(m.name).unwrap(), *m));
            // Every option is declared once.
            for (j, o) in m.options.iter().enumerate() {
                assert!(m.options[..j].iter().all(|p| p.name != o.name), "{}: option {} twice", m.name, o.name);
            }
            // Defaults are valid settings, and parameters name their own method.
            assert!(std::ptr::eq(m.default_spec().method(), *m));
        }
    }
}
