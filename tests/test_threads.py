"""BLAS is limited to one thread inside the fitting code, for every entry point: scipy loads its
own OpenBLAS lazily, so a limit entered before that import misses it."""

from __future__ import annotations

import subprocess
import sys
import textwrap


def test_identify_runs_with_one_blas_thread_in_a_fresh_interpreter() -> None:
    # a fresh process as a notebook user starts it: motorid imported, nothing else loaded first
    code = textwrap.dedent(
        """
        import json
        import motorid.identification.pipeline as ident
        from motorid._threads import blas_threads
        from motorid.trainer.experiment import run_experiment

        seen = []
        real = ident._paper_stage

        def spy(*args, **kwargs):
            seen.append(blas_threads())
            return real(*args, **kwargs)

        ident._paper_stage = spy
        e = run_experiment("second-order", seed=1, roles=("velocity",), validation=False)
        ident.identify_experiment(dict(e.captures), ident.IdentifySettings(method="pinv"))
        print(json.dumps({"inside": seen, "after": blas_threads()}))
        """
    )
    env = {k: v for k, v in __import__("os").environ.items()
           if k not in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")}
    env["OPENBLAS_NUM_THREADS"] = "2"  # as on a 2-core machine with nothing set
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True)
    import json

    data = json.loads(out.stdout.strip().splitlines()[-1])
    inside = data["inside"][0]
    # numpy's and scipy's OpenBLAS are both loaded and both limited inside the fit
    assert inside and all(n == 1 for n in inside.values()), inside
    assert set(inside) == set(data["after"]), (inside, data["after"])  # every loaded BLAS
    # the limit is released afterwards (the user's own code keeps its threads)
    assert any(n > 1 for n in data["after"].values()), data["after"]
