"""What every estimator around a model of the Rust core shares: the fitted model (``model_``),
the images it reads, model files and pickling (through the model file's bytes)."""

from __future__ import annotations

import json
from typing import Any, Optional, Tuple

import numpy as np
from sklearn.exceptions import NotFittedError
from sklearn.utils.validation import validate_data

# Dtypes the Rust core reads as they are; others are converted to float64 first.
_DTYPES = (np.float64, np.float32, np.uint8, np.uint16)
_FAST = frozenset(np.dtype(t) for t in _DTYPES)


def _flatten(X: Any, image_shape: Optional[Tuple[int, int]]) -> Tuple[Any, Optional[Tuple[int, int]]]:
    """A 3-D image array as rows (a view when it can be), with its (h, w)."""
    if isinstance(X, np.ndarray) and X.ndim == 3:
        shape = (int(X.shape[1]), int(X.shape[2]))
        if image_shape is not None and tuple(image_shape) != shape:
            raise ValueError(f"X holds images of {shape[0]}x{shape[1]} (h x w) but image_shape is {tuple(image_shape)}")
        return X.reshape(X.shape[0], shape[0] * shape[1]), shape
    return X, None if image_shape is None else (int(image_shape[0]), int(image_shape[1]))


class CoreModel:
    """The fitted model of the Rust core an estimator wraps, the rows it reads, its model file
    and pickling. A subclass names the core's class that reads a model file's bytes
    (``_core``); it comes before scikit-learn's ``BaseEstimator`` among the bases."""

    _core: Any = None

    def _model(self) -> Any:
        model = self.__dict__.get("model_")
        if model is None:
            raise NotFittedError(
                f"This {type(self).__name__} instance is not fitted yet. Call 'fit' with appropriate arguments before using this estimator."
            )
        return model

    def _release(self) -> None:
        """Lets go of the fitted model before a new fit, so that the old model's memory is free
        for the new fit's (one model's worth at a time, not two). It is faster too: COIL-20
        object 1's 1.3 ms linear fit was 7.5-9.7% slower with the old model kept in five of six
        timed runs (level in the sixth), with the same page faults either way; why is not known. A fit that fails then leaves the estimator unfitted, as scikit-learn's own
        estimators that reset before fitting do."""
        self.__dict__.pop("model_", None)
        self.__dict__.pop("_serve", None)

    def _rows(self, X: Any) -> Any:
        """``X`` as images the core reads: rows of the model's features, or (n, h, w) arrays as
        they are (the core reads them as rows, so no view is made here). Arrays the core reads
        as they are skip scikit-learn's validation, which would cost more than estimating one
        image."""
        if type(X) is np.ndarray and X.dtype in _FAST and "feature_names_in_" not in self.__dict__:
            s = X.shape
            m = s[1] if len(s) == 2 else s[1] * s[2] if len(s) == 3 else None
            if m is not None:
                if m != self.n_features_in_:
                    raise ValueError(f"X has {m} features, but {type(self).__name__} is expecting {self.n_features_in_} features as input.")
                return X
        X, _ = _flatten(X, None)
        return validate_data(self, X, reset=False, dtype=_DTYPES, order="C")

    # -- model files and pickling --------------------------------------------------------------

    def save(self, path) -> int:
        """Writes the model file (the command line's format, which ``linpose predict`` and
        ``eval`` read; written atomically). Returns its size in bytes."""
        return self._model().save(str(path))

    def to_bytes(self) -> bytes:
        """The model file's bytes."""
        return self._model().to_bytes()

    def __getstate__(self):
        state = super().__getstate__()
        if "model_" in state:
            state = dict(state)
            state["model_"] = state["model_"].to_bytes()
            # Rebuilt from the model on unpickling (a pose estimator's one-call predict).
            state.pop("_serve", None)
        return state

    def __setstate__(self, state):
        if isinstance(state.get("model_"), (bytes, bytearray)):
            state = dict(state)
            state["model_"] = self._core.from_bytes(bytes(state["model_"]))
        super().__setstate__(state)

    # -- what the model learnt -----------------------------------------------------------------

    @property
    def settings_(self) -> dict:
        """The settings as given and as chosen (e.g. an automatic choice), and for the
        recogniser its calibration, from the model."""
        return json.loads(self._model().settings_json)

    @property
    def model_bytes_(self) -> int:
        """Bytes of the numbers the model stores to serve queries (the paper's Table 1)."""
        return self._model().model_bytes
