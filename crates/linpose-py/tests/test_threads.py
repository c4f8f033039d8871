"""The interpreter lock is released while the core works, so other Python threads run.

A Python thread counts in a loop while another thread runs a large predict; with the lock held
for the call, the counter could not move until the call returned. It must move at a good share
of the rate it has alone. (Two Python threads are not faster than one on a large predict here:
the core already spreads one predict over every core with its own thread pool, and two calls
share that pool.)
"""

import threading
import time

import numpy as np
import pytest

import linpose


@pytest.fixture(scope="module")
def model_and_queries():
    X, y, params = linpose.synth("duck", azimuth="0:357:3", elevation="32:77:9", size=(160, 120))
    est = linpose.EigenspacePose(params=params).fit(X[::3], y[::3])
    return est, np.ascontiguousarray(np.tile(X, (12, 1, 1)))


def _count_while(work):
    done = threading.Event()
    count = 0

    def run():
        work()
        done.set()

    t = threading.Thread(target=run)
    start = time.perf_counter()
    t.start()
    while not done.is_set():
        count += 1
    elapsed = time.perf_counter() - start
    t.join()
    return count, elapsed


def _count_for(seconds):
    count, start = 0, time.perf_counter()
    while time.perf_counter() - start < seconds:
        count += 1
    return count


@pytest.mark.parametrize("call", ["predict", "predict_hypotheses"])
def test_other_threads_run_during_a_large_call(model_and_queries, call):
    est, Q = model_and_queries
    getattr(est, call)(Q[:10])
    shares = []
    for _ in range(3):
        during, elapsed = _count_while(lambda: getattr(est, call)(Q))
        alone = _count_for(elapsed)
        shares.append(during / max(alone, 1))
    # Held, the share would be about 0 (the loop runs only before and after the call).
    assert max(shares) > 0.3, shares


def test_other_threads_run_while_the_recogniser_fits_and_predicts():
    X, y = [], []
    for o in ("duck", "pot", "cap"):
        images, poses, params = linpose.synth(o, azimuth="0:357:3", elevation="40", size=(160, 120))
        X.append(images)
        y += [o] * len(images)
    X, y = np.concatenate(X), np.array(y)
    est = linpose.ObjectRecognizer()
    for work in (lambda: est.fit(X[::2], y[::2]), lambda: est.predict(np.tile(X, (4, 1, 1)))):
        shares = []
        for _ in range(3):
            during, elapsed = _count_while(work)
            shares.append(during / max(_count_for(elapsed), 1))
        assert max(shares) > 0.3, shares
