"""Record every ``align_skylines`` call of one CH1 photo's localization (fov unknown, no abstaining): its arguments,
pickled, for ``replay.py``.

``PYTHONPATH=<code> python experiments/ch1/compiled-alignment/record_calls.py ch1/IMG_5039_01024 /tmp/calls.pkl``
"""

import pickle
import sys
import tempfile


def main(photo: str, out: str) -> None:
    import skyrender.localizer.refinement as refinement
    import skyrender.localizer.verification as verification
    from skyrender.benchmarks import real_localize

    calls, original = [], verification.align_skylines

    def recorded(*args, **kwargs):
        kwargs.pop("agreement", None)  # the previous code has no such argument; replay.py asks for none
        calls.append((args, kwargs))
        return original(*args, **kwargs)

    verification.align_skylines = refinement.align_skylines = recorded
    sys.argv = ["real_localize", "--side", "train", "--fov", "unknown", "--no-abstain", "--photos", photo,
                "--tag", "record", "--out", tempfile.mkdtemp()]
    real_localize.main()
    with open(out, "wb") as f:
        pickle.dump(calls, f, protocol=4)
    print(f"{len(calls)} calls recorded to {out}")


if __name__ == "__main__":
    main(*sys.argv[1:3])
