"""scikit-learn's own estimator checks, for every estimator.

Every check runs. A check that cannot apply to pose estimation is listed below with the reason,
and for it the test asserts that the estimator refuses the check's data with the library's own
message for that reason (so a listed check that starts to fail for another reason, or starts to
pass, is a test failure too).

The reasons:
- ``LinearPose()`` is the paper's exact minimum-norm fit through the N x N Gram matrix, which
  exists only for linearly independent images: at most as many images as pixels (N <= M). Most
  checks fit on tabular data with more samples than features, where the Gram matrix is singular;
  linpose refuses it and says to use ridge. ``LinearPose(ridge=1e-6)`` is checked as well and
  passes them.
- The check ``check_positive_only_tag_during_fit`` fits on the iris data, which has two identical
  rows (samples 101 and 142): linpose refuses a view listed twice for every method.
- ``EigenspacePose`` and ``RefinedPose`` interpolate a manifold through the training poses, which
  must form a grid with one image per point. Checks whose targets repeat a value (class labels,
  integer targets) or are random multi-column values give no such grid; linpose refuses them
  naming the repeated pose (or the missing grid point).
- ``ObjectRecognizer`` (either recogniser) on ``check_estimators_dtypes``: its random integer
  images include one of all zeros, and Murase & Nayar's eigenspaces scale every image to unit
  energy, which a black image does not have; linpose refuses it naming the image.
"""

import re

import pytest
from sklearn.utils.estimator_checks import estimator_checks_generator, parametrize_with_checks

import linpose

SINGULAR = r"Gram matrix is singular"
TWICE = r"are identical\); the same view is listed twice"
GRID = r"have the same training pose|needs one image per grid point|grid"
BLACK = r"the image is all black \(zero energy\)"

# Checks that fit random tabular data: more samples than features, and targets that are no pose
# grid (class labels, integers, random columns).
_FIT_RANDOM = [
    "check_fit_score_takes_y", "check_estimators_overwrite_params", "check_dont_overwrite_parameters",
    "check_estimators_fit_returns_self", "check_readonly_memmap_input", "check_positive_only_tag_during_fit",
    "check_estimators_dtypes", "check_dtype_object", "check_pipeline_consistency", "check_estimators_nan_inf",
    "check_estimators_pickle", "check_f_contiguous_array_estimator", "check_regressor_multioutput",
    "check_supervised_y_2d", "check_regressors_int", "check_methods_sample_order_invariance",
    "check_methods_subset_invariance", "check_fit2d_1feature", "check_dict_unchanged",
    "check_fit2d_predict1d",
]
# Checks, besides those, that fit LinearPose() on more samples than features.
_N_GT_M = [
    "check_n_features_in_after_fitting", "check_regressors_train", "check_regressor_data_not_an_array",
    "check_regressors_no_decision_function", "check_fit_idempotent", "check_fit_check_is_fitted",
    "check_n_features_in",
]
_N_GT_M = _FIT_RANDOM + _N_GT_M
EXPECTED = {
    "LinearPose()": {c: SINGULAR for c in _N_GT_M},
    "LinearPose(ridge=1e-06)": {"check_positive_only_tag_during_fit": TWICE},
    "EigenspacePose()": {c: GRID for c in _FIT_RANDOM},
    "RefinedPose()": {c: GRID for c in _FIT_RANDOM},
    "ObjectRecognizer()": {"check_estimators_dtypes": BLACK},
    "ObjectRecognizer(recognizer='linear')": {"check_estimators_dtypes": BLACK},
}
ESTIMATORS = [
    linpose.LinearPose(),
    linpose.LinearPose(ridge=1e-6),
    linpose.EigenspacePose(),
    linpose.RefinedPose(),
    linpose.ObjectRecognizer(),
    linpose.ObjectRecognizer(recognizer="linear"),
]


def _name(check):
    return getattr(check, "func", check).__name__


@parametrize_with_checks(ESTIMATORS)
def test_sklearn_compatible_estimator(estimator, check):
    reason = EXPECTED[repr(estimator)].get(_name(check))
    if reason is None:
        check(estimator)
        return
    with pytest.raises((ValueError, AssertionError)) as e:
        check(estimator)
    # The refusal is the library's, for the listed reason (an AssertionError of the check
    # carries it in its message, or in the exception it chained).
    text = str(e.value) + str(e.value.__cause__ or "") + str(e.value.__context__ or "")
    assert re.search(reason, text), f"{_name(check)} failed for another reason: {text[:500]}"


def test_every_listed_check_exists():
    """A listed check that scikit-learn renames or removes is noticed, not silently skipped."""
    known = {_name(c) for e in ESTIMATORS for _, c in estimator_checks_generator(e, legacy=True)}
    listed = {c for v in EXPECTED.values() for c in v}
    assert listed <= known, sorted(listed - known)
