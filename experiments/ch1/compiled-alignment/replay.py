"""Replay recorded ``align_skylines`` calls (``record_calls.py``) with two codes, each in its own process, and
compare their outputs to the bit (score, shift, offset, slope; the agreement is not asked for) and their seconds.

``python experiments/ch1/compiled-alignment/replay.py /tmp/calls.pkl /tmp/wt_old /work/main > replay.txt``
(the first code the previous one, in a worktree; each is replayed twice and its second, warm replay timed, so
numba's compilation is not counted; numba's cache has it from the first)
"""

import os
import pickle
import subprocess
import sys
import tempfile
import time

import numpy as np


def replay(calls_path: str, out_path: str) -> None:
    """In this process (the code on PYTHONPATH): every call's (score, a, b, c) and the seconds, pickled."""
    import inspect

    from skyrender.localizer import verification

    with open(calls_path, "rb") as f:
        calls = pickle.load(f)
    lean = "agreement" in inspect.signature(verification.align_skylines).parameters
    outputs, seconds = [], {}
    for args, kwargs in calls:
        kind = ("trusted" if kwargs.get("trust") is not None else "plain") + \
            (", blocked" if len(args[0]) * len(args[2]) >= verification.MIN_BLOCK_ELEMENTS and
             len(args[0]) > verification.ALIGN_BLOCK_ROWS else ", one block")
        start = time.perf_counter()
        result = verification.align_skylines(*args, **kwargs, **({"agreement": False} if lean else {}))
        seconds[kind] = seconds.get(kind, 0.0) + time.perf_counter() - start
        outputs.append((result[0], *result[2:]))
    with open(out_path, "wb") as f:
        pickle.dump((outputs, seconds, verification.__file__), f)


def main(calls_path: str, *codes: str) -> None:
    results = []
    for code in codes:
        out = tempfile.mktemp(suffix=".pkl")
        env = dict(os.environ, PYTHONPATH=os.path.abspath(code))
        for _ in range(2):  # the second replay warm
            subprocess.run([sys.executable, __file__, "--one", calls_path, out], env=env, check=True)
        with open(out, "rb") as f:
            results.append(pickle.load(f))
    (first, first_s, first_file), *rest = results
    print(f"{len(first)} recorded align_skylines calls, replayed in one process per code, warm:")
    for code, (_, seconds, path) in zip(codes, results):
        print(f"  {path}: {sum(seconds.values()):.2f} s  " + ", ".join(f"{k} {v:.2f} s" for k, v in sorted(seconds.items())))
    for code, (outputs, _, path) in zip(codes[1:], rest):
        differ = sum(any(not np.array_equal(x, y, equal_nan=True) for x, y in zip(o, f)) for o, f in zip(outputs, first))
        print(f"  calls whose score, shift, offset or slope differ in any bit, {path} against the first: {differ}")


if __name__ == "__main__":
    if sys.argv[1] == "--one":
        replay(sys.argv[2], sys.argv[3])
    else:
        main(*sys.argv[1:])
