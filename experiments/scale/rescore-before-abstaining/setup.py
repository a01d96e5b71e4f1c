import os, json, sys
from skyrender.benchmarks.scale import build, render_views, write_one_arc_second_tile, DEM_DIR, TILE
out = "/tmp/s22"
tile = os.path.join(DEM_DIR, TILE)
if not os.path.exists(f"{out}/model-tile"):
    print(build(tile, f"{out}/model-tile"), flush=True)
os.makedirs(f"{out}/tile", exist_ok=True)
views = render_views(tile, f"{out}/model-tile", 8, (35.0, 60.0), (1008, 756), f"{out}/tile", 0)
json.dump(views, open(f"{out}/views.json", "w"))
one = write_one_arc_second_tile(tile, f"{out}/N46E007_1arcsec.tif")
print(build(one, f"{out}/model-tile1"), flush=True)
