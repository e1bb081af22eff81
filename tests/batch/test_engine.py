"""The engine: a seed per task from its key, one BLAS thread in every worker, option errors."""

from __future__ import annotations

import sys

import numpy as np
import pytest

from motorid.batch import parallel_map, task_seed
from motorid.errors import OptionError


def _draw(_item):
    """What a task sees: its global-RNG draw and the BLAS threads of its process."""
    from motorid._threads import blas_threads

    return float(np.random.random()), blas_threads()


@pytest.fixture(autouse=True)
def _send_this_module_by_value():
    # worker processes cannot import a test module: send its functions by value
    from cloudpickle import register_pickle_by_value, unregister_pickle_by_value  # joblib's pickler

    register_pickle_by_value(sys.modules[__name__])
    yield
    unregister_pickle_by_value(sys.modules[__name__])


def test_seed_comes_from_the_key_not_the_worker_or_the_order():
    items = [(f"exp{i}", i) for i in range(6)]
    one = dict(parallel_map(_draw, items, jobs=1, seed=7))
    two = dict(parallel_map(_draw, items[::-1], jobs=2, seed=7))
    for key in one:
        expected = np.random.RandomState(task_seed(7, key)).random_sample()  # independent of the engine
        assert one[key][0] == expected == two[key][0]
    assert len({v[0] for v in one.values()}) == len(items)  # different keys, different seeds
    other = dict(parallel_map(_draw, items[:1], jobs=1, seed=8))
    assert other["exp0"][0] != one["exp0"][0]
    # one BLAS thread in the parent's sequential run and in each loky worker
    for _, threads in [*one.values(), *two.values()]:
        assert threads and set(threads.values()) == {1}


def test_bad_jobs_and_unreachable_scheduler_are_option_errors():
    with pytest.raises(OptionError, match="--jobs 0"):
        list(parallel_map(_draw, [("a", 1)], jobs=0))
    with pytest.raises(OptionError, match=r"--scheduler tcp://127\.0\.0\.1:9: cannot connect"):
        list(parallel_map(_draw, [("a", 1)], scheduler="tcp://127.0.0.1:9", connect_timeout_s=1))
