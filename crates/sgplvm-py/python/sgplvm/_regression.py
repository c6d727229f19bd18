"""The direct GP regression (``sgplvm.GPRegression``): numpy in, numpy out, over the native
Rust regression — the yardstick the shared model is measured against."""

from __future__ import annotations

from typing import Optional

import numpy as np

from . import _sgplvm
from ._model import ArrayLike, _as_frames, _as_matrix, _integer, _max_seconds


class GPRegression:
    """A direct GP regression from input frames to output frames (RBF-ARD kernel, Gaussian
    noise, outputs centred; hyperparameters by maximum marginal likelihood, as GPy's
    ``GPRegression``): the yardstick the paper measures the shared model against, a mapping
    straight from human to robot joints.

    >>> gp = sgplvm.GPRegression().fit(H_train, R_train)   # doctest: +SKIP
    >>> R_hat = gp.predict(H_test)                          # doctest: +SKIP
    """

    def __init__(self, max_iters: int = 1000) -> None:
        self.max_iters = _integer(max_iters, "max_iters", 0)
        self._native: Optional[_sgplvm.NativeRegression] = None

    def fit(self, X: ArrayLike, Y: ArrayLike, max_seconds: Optional[float] = None) -> "GPRegression":
        """Trains on inputs ``X`` (n × D_x) and outputs ``Y`` (n × D_y). Returns ``self``.

        Data far from unit scale is standardised (by a power of two, exactly), as the shared
        model's is. ``max_seconds`` bounds the wall-clock time of training: when it runs out
        the best hyperparameters so far are kept (:attr:`stop_reason` is ``"time_limit"``).
        Ctrl-C stops training within about a second and raises ``KeyboardInterrupt``; the
        regression keeps the best hyperparameters reached (:attr:`stop_reason`
        ``"interrupted"``, or the reason training had stopped for if the signal came as it
        ended)."""
        x, y, seconds = _as_matrix(X, "X"), _as_matrix(Y, "Y"), _max_seconds(max_seconds)
        try:
            self._native = _sgplvm.NativeRegression.fit(x, y, self.max_iters, seconds)
        except BaseException as e:
            native = getattr(e, "_sgplvm_native", None)
            if native is not None:
                self._native = native
            raise
        return self

    @property
    def stop_reason(self) -> Optional[str]:
        """Why training stopped: ``"gradient_tolerance"``, ``"relative_tolerance"``,
        ``"max_iterations"``, ``"line_search"``, ``"time_limit"`` (``max_seconds`` ran out),
        ``"evaluation_limit"`` or ``"interrupted"`` (Ctrl-C)."""
        return self._require().stop_reason

    def predict(self, X: ArrayLike) -> np.ndarray:
        """Posterior mean (n × D_y) at input frames ``X`` (n × D_x, or one frame of D_x)."""
        frames, single = _as_frames(X, "X")
        mean = self._require().predict(frames)
        return mean[0] if single else mean

    @property
    def kernel(self) -> dict:
        """The trained hyperparameters: ``variance``, ``lengthscale`` (one per input column)
        and ``noise``."""
        return self._require().kernel()

    def _require(self) -> "_sgplvm.NativeRegression":
        if self._native is None:
            raise RuntimeError("GPRegression is not fitted yet: call fit() first")
        return self._native
