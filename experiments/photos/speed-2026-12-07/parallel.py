"""How much do ``select``'s two lines gain from running side by side on this machine's 2 cores?

Each of ``hybrid`` and ``gmm`` (``select``'s budget, the photo's features, edges and network probability made once)
is timed alone, then both together on two threads (as ``select`` runs them), then on two forked processes (no shared
interpreter lock), 3 times each, on CH1 ``04032011388`` (1024 x 768).

``python experiments/photos/speed-2026-12-07/parallel.py``
"""
import multiprocessing as mp
import time

from skyrender.blocks import concurrently, one_thread
from skyrender.features import skyline as S
from skyrender.features.cables import remove_cables
from skyrender.features.photo_io import load_photo

image = load_photo("../shared/data/photos/ch1/04032011388_01024/photo.jpg")
params = S.SkylineParams(method="select")
image, _ = remove_cables(image, params.cables)
features, edges = S._features_and_edges(image, params)
p_net = S.net_probability(image, params.net_weights, net_width=params.net_width)


def timed(method: str) -> float:
    t = time.perf_counter()
    S._extract(image, features, edges, method, params, p_net)
    return time.perf_counter() - t


def in_process(method: str, queue) -> None:
    with one_thread():
        queue.put((method, timed(method)))


if __name__ == "__main__":
    for _ in range(3):
        with one_thread():
            alone = {m: timed(m) for m in ("hybrid", "gmm")}
            t = time.perf_counter()
            threads = dict(zip(("hybrid", "gmm"), concurrently(lambda: timed("hybrid"), lambda: timed("gmm"))))
            wall_threads = time.perf_counter() - t
        ctx = mp.get_context("fork")
        queue = ctx.Queue()
        t = time.perf_counter()
        procs = [ctx.Process(target=in_process, args=(m, queue)) for m in ("hybrid", "gmm")]
        for p in procs:
            p.start()
        for p in procs:
            p.join()
        wall_procs = time.perf_counter() - t
        procs_t = dict(queue.get() for _ in procs)
        print("alone " + ", ".join(f"{m} {v:.3f} s" for m, v in alone.items())
              + f" (sum {sum(alone.values()):.3f}) | threads " + ", ".join(f"{m} {v:.3f}" for m, v in threads.items())
              + f", wall {wall_threads:.3f} | processes " + ", ".join(f"{m} {v:.3f}" for m, v in procs_t.items())
              + f", wall {wall_procs:.3f} (with the forks)", flush=True)
