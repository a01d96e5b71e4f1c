import os, json
from skyrender.benchmarks.scale import render_views, DEM_DIR, TILE
out = "/tmp/s22"
tile = os.path.join(DEM_DIR, TILE)
for seed in (2, 3):
    os.makedirs(f"{out}/tile-seed{seed}", exist_ok=True)
    json.dump(render_views(tile, f"{out}/model-tile", 8, (35.0, 60.0), (1008, 756), f"{out}/tile-seed{seed}", seed), open(f"{out}/views-seed{seed}.json", "w"))
os.makedirs(f"{out}/synthetic-seed1", exist_ok=True)
json.dump(render_views("builtin:naval2000", f"{out}/model-synthetic", 8, (60.0, 60.0), (1024, 640), f"{out}/synthetic-seed1", 1), open(f"{out}/views-synthetic-seed1.json", "w"))
