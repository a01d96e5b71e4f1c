import os, json, sys
from skyrender.benchmarks.scale import build, render_views, DEM_DIR, TILE, MOSAIC
out = "/tmp/s22"
print(build("builtin:naval2000", f"{out}/model-synthetic"), flush=True)
os.makedirs(f"{out}/synthetic", exist_ok=True)
json.dump(render_views("builtin:naval2000", f"{out}/model-synthetic", 8, (60.0, 60.0), (1024, 640), f"{out}/synthetic", 0), open(f"{out}/views-synthetic.json", "w"))
tile = os.path.join(DEM_DIR, TILE)
os.makedirs(f"{out}/tile-seed1", exist_ok=True)
json.dump(render_views(tile, f"{out}/model-tile", 8, (35.0, 60.0), (1008, 756), f"{out}/tile-seed1", 1), open(f"{out}/views-seed1.json", "w"))
mosaic = ",".join(os.path.join(DEM_DIR, t) for t in MOSAIC)
print(build(mosaic, f"{out}/model-mosaic"), flush=True)
os.makedirs(f"{out}/mosaic", exist_ok=True)
json.dump(render_views(mosaic, f"{out}/model-mosaic", 4, (35.0, 60.0), (1008, 756), f"{out}/mosaic", 0), open(f"{out}/views-mosaic.json", "w"))
