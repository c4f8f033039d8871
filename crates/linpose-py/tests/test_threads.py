"""The interpreter lock is released while the core works, so other Python threads run.

Shown by order, not by a clock: a call runs in a second thread, with the interpreter's switch
interval made so long that the lock never changes hands on its own, so this thread runs again
only when the other one gives the lock up. A profile hook in that thread keeps its stack of calls.
When this thread next runs, the other one must be inside linpose's compiled core
(`linpose._linpose`): had the core held the lock, this thread could run only after the call
returned or the thread ended. `test_a_held_lock_is_seen` shows the check failing on a C function
that keeps the lock.
"""

import os
import sys
import threading

import numpy as np
import pytest

import linpose


_PACKAGE = os.path.dirname(linpose.__file__)


def _in_core(fn):
    """Whether a C function is linpose's compiled core's (a module function or a method)."""
    own = getattr(fn, "__self__", None)
    return getattr(fn, "__module__", None) == "linpose._linpose" or type(own).__module__ == "linpose._linpose"


def _lock_given_up_inside_the_core(work, marked=_in_core):
    """Runs work() in another thread; where that thread was when this one got the lock back (None:
    it had ended), and how many calls of C functions that `marked` names (the core's) it made.

    A profile hook keeps the thread's stack of calls: Python frames, and C functions called as
    functions (the profiler sees those). It is inside the core when the innermost is a marked C
    function, or a frame of linpose's own Python code that is not running bytecode (which gives the
    lock up only on a forced switch, turned off here) but in a call the profiler does not see: a
    compiled object called (the core's `Serve`)."""
    stack, state = [], {"calls": 0}

    def profile(frame, event, arg):
        if event == "call":
            stack.append(("py", frame.f_code.co_filename))
        elif event == "return" and stack:
            stack.pop()
        elif event == "c_call":
            stack.append(("c", marked(arg)))
            state["calls"] += marked(arg)
        elif event in ("c_return", "c_exception") and stack:
            stack.pop()

    def is_core(top):
        return top == ("c", True) or (top[0] == "py" and top[1].startswith(_PACKAGE))

    def run():
        sys.setprofile(profile)
        try:
            work()
        finally:
            sys.setprofile(None)

    old = sys.getswitchinterval()
    sys.setswitchinterval(1000.0)
    try:
        t = threading.Thread(target=run)
        # start() waits for the thread to begin, giving up the lock; it returns once the lock
        # comes back, which (no switch being forced) is when the other thread gives it up. Where
        # that was not inside the core (numpy may give the lock up on the way there), this thread
        # gives the lock up itself and looks again the next time it has it, until the other
        # thread ends.
        t.start()
        while True:
            top = stack[-1] if t.is_alive() and stack else None
            if top is None or is_core(top):
                break
            os.sched_yield()
        # This thread must not hold the lock while the other one finishes: join() gives it up.
        t.join()
    finally:
        sys.setswitchinterval(old)
    inside = top is not None
    return inside, state["calls"], top


@pytest.fixture(scope="module")
def model_and_queries():
    X, y, params = linpose.synth("duck", azimuth="0:357:3", elevation="32:77:9", size=(160, 120))
    est = linpose.EigenspacePose(params=params).fit(X[::3], y[::3])
    return est, X, y, params, np.ascontiguousarray(np.tile(X, (4, 1, 1)))


@pytest.mark.parametrize("call", ["predict", "predict_hypotheses"])
def test_other_threads_run_during_a_large_call(model_and_queries, call):
    est, _, _, _, Q = model_and_queries
    inside, calls, top = _lock_given_up_inside_the_core(lambda: getattr(est, call)(Q))
    assert inside, f"{call}: this thread ran again only at {top}, not inside the core (the lock was held)"


def test_other_threads_run_while_a_pose_model_fits(model_and_queries):
    _, X, y, params, _ = model_and_queries
    inside, calls, top = _lock_given_up_inside_the_core(lambda: linpose.EigenspacePose(params=params).fit(X, y))
    assert inside, f"fit: this thread ran again only at {top}, not inside the core (the lock was held)"


def test_other_threads_run_while_the_recogniser_fits_and_predicts():
    X, y = [], []
    for o in ("duck", "pot", "cap"):
        images, poses, params = linpose.synth(o, azimuth="0:357:3", elevation="40", size=(160, 120))
        X.append(images)
        y += [o] * len(images)
    X, y = np.concatenate(X), np.array(y)
    est = linpose.ObjectRecognizer()
    for name, work in (("fit", lambda: est.fit(X[::2], y[::2])), ("predict", lambda: est.predict(np.tile(X, (4, 1, 1))))):
        inside, calls, top = _lock_given_up_inside_the_core(work)
        assert inside, f"{name}: this thread ran again only at {top}, not inside the core (the lock was held)"


def test_a_held_lock_is_seen():
    """The check can fail: a C function that keeps the lock to its end (the built-in sum over a
    range) is never found running when this thread gets the lock back."""
    inside, calls, top = _lock_given_up_inside_the_core(lambda: [sum(range(200_000)) for _ in range(20)], lambda f: f is sum)
    assert calls == 20 and not inside and top is None, (calls, inside, top)
