//! The linear model fitted from partial statistics ([`crate::partial`]): with more images than
//! pixels (N > M) from X^T X and X^T P summed over shards of images, the least-squares fit of the
//! streamed path ([`super::stream`]), which takes a fixed ridge and no centring; otherwise from
//! the Gram matrix summed over shards of pixels, centred about the mean image for a centred
//! model, with every setting the in-memory fit takes.

use super::ridge::RidgeRule;
use super::stream::solve_model;
use super::{LinearParams, METHOD};
use crate::dataset::Dataset;
use crate::image_io::ImageSpec;
use crate::model::partial_fit::{PartialFit, Split};
use crate::model::AnyModel;
use crate::normal_equations::NormalEquations;
use crate::pose::PoseSpace;
use crate::{Error, Result};
use faer::Mat;

impl PartialFit for LinearParams {
    fn split(&self, n: usize, m: usize) -> Result<Split> {
        let err = |why: String| Error::invalid("method", METHOD.name, why);
        if n <= m {
            return Ok(Split::Pixels);
        }
        if self.rule() != RidgeRule::Fixed {
            return Err(err(format!(
                "with more images than pixels ({n} > {m}) the linear model is summed over shards of images, which takes a fixed --ridge (0 for the minimum-norm least-squares fit): the leave-one-out and noise rules need the training set in memory"
            )));
        }
        if self.is_centered() {
            return Err(err(format!(
                "with more images than pixels ({n} > {m}) the linear model is summed over shards of images, which is uncentred (the paper's form)"
            )));
        }
        Ok(Split::Images)
    }

    fn centred(&self) -> bool {
        self.is_centered()
    }

    fn fit_from_gram(&self, train: &Dataset, gram: Mat<f64>) -> Result<AnyModel> {
        Ok(AnyModel::new(self.fit_with_gram(train, Some(gram))?))
    }

    fn fit_from_normal_equations(&self, ne: NormalEquations, space: &PoseSpace, poses: &[f64], spec: ImageSpec) -> Result<AnyModel> {
        Ok(AnyModel::new(solve_model(ne, space, poses, spec, self.ridge_lambda())?))
    }
}
