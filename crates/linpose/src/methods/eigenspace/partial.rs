//! The eigenspace fitted from partial statistics ([`crate::partial`]): its PCA is the
//! eigendecomposition of the Gram matrix of the centred unit-energy images, which follows from
//! X X^T (`manifold::pca`), so it is summed over shards of pixels whatever the sizes.

use super::EigenspaceParams;
use crate::dataset::Dataset;
use crate::model::partial_fit::{PartialFit, Split};
use crate::model::AnyModel;
use crate::Result;
use faer::Mat;

impl PartialFit for EigenspaceParams {
    fn split(&self, _n: usize, _m: usize) -> Result<Split> {
        Ok(Split::Pixels)
    }

    fn fit_from_gram(&self, train: &Dataset, gram: Mat<f64>) -> Result<AnyModel> {
        Ok(AnyModel::new(self.fit_with_gram(train, Some(gram))?))
    }
}
