//! Every estimation method by name, behind one enum, so the CLI and the experiment can hold
//! "a method with its settings" without caring which.

use crate::dataset::Dataset;
use crate::methods::eigenspace::EigenspaceParams;
use crate::methods::linear::LinearParams;
use crate::methods::refined::RefinedParams;
use crate::model::{AnyModel, Estimator};
use crate::Result;

/// A method with its settings.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum MethodSpec {
    /// Okatani & Deguchi's linear model.
    Linear(LinearParams),
    /// Murase & Nayar's parametric eigenspace.
    Eigenspace(EigenspaceParams),
    /// The eigenspace searched continuously on its spline manifold (beyond the paper).
    Refined(RefinedParams),
}

impl MethodSpec {
    /// The method's name, as in model files and on the command line.
    pub fn name(&self) -> &'static str {
        match self {
            MethodSpec::Linear(_) => crate::methods::linear::METHOD,
            MethodSpec::Eigenspace(_) => crate::methods::eigenspace::METHOD,
            MethodSpec::Refined(_) => crate::methods::refined::METHOD,
        }
    }

    /// Fits the method on `train`.
    pub fn fit(&self, train: &Dataset) -> Result<AnyModel> {
        Ok(match self {
            MethodSpec::Linear(p) => p.fit(train)?.into(),
            MethodSpec::Eigenspace(p) => p.fit(train)?.into(),
            MethodSpec::Refined(p) => p.fit(train)?.into(),
        })
    }
}
