"""A/B: skyrender localize per view, new (main) vs base (worktree), alternating order."""
import json, sys, os
sys.path.insert(0, "/work/main")
from skyrender.benchmarks.scale import run_measured, stats_line
views = json.load(open(sys.argv[1])); model = sys.argv[2]; out = sys.argv[3]
PY = "/work/main/.venv/bin/python"
rows = []
for i, v in enumerate(views):
    order = ("new", "base") if i % 2 == 0 else ("base", "new")
    row = {"view": os.path.basename(v["photo"])}
    for who in order:
        root = "/work/main" if who == "new" else "/work/w_base"
        r = run_measured(["env", f"PYTHONPATH={root}", PY, "-m", "skyrender", "localize", v["photo"], "--model", model,
                          "--height", "2", "--fov", f"{v['fov']:.4f}", "--preset", "render", "--json", "--stats"])
        d = json.loads(r["stdout"]); st = stats_line(r["stderr"])
        row[who] = {"seconds": d["seconds"], "wall_s": round(r["wall_s"], 3), "peak_gb": r["peak_gb"],
                    "status": d["status"], "answer": [d.get(k) for k in ("x", "y", "z", "pan", "tilt", "swing")],
                    "image_features": st["seconds"]["image_features"]}
    row["same"] = row["new"]["answer"] == row["base"]["answer"] and row["new"]["status"] == row["base"]["status"]
    rows.append(row)
    print(row["view"], {w: (row[w]["seconds"], row[w]["wall_s"], row[w]["image_features"]) for w in ("base", "new")}, "same" if row["same"] else "DIFFERENT", flush=True)
json.dump(rows, open(out, "w"), indent=1)
import numpy as np
for w in ("base", "new"):
    print(w, "median seconds", np.median([r[w]["seconds"] for r in rows]), "wall", np.median([r[w]["wall_s"] for r in rows]),
          "features", np.median([r[w]["image_features"] for r in rows]), "peak", max(r[w]["peak_gb"] for r in rows))
