"""``skyrender model`` of N46E007 as a 1-arc-second GeoTIFF (``make bench-scale``'s ``tile1`` row: the 3"
posts kept, bilinear between), timed as that benchmark times it, with whichever skyrender the working
directory holds. ``python experiments/scale/one-column-horizons/build_one_arc_second.py OUT_DIR``"""
import os, sys, json
from skyrender.benchmarks import scale
out = os.path.join(os.path.dirname(sys.argv[1]) or ".", "N46E007_1arcsec.tif")
if not os.path.exists(out):
    scale.write_one_arc_second_tile(os.path.join(scale.DEM_DIR, scale.TILE), out)
print(json.dumps(scale.build(out, sys.argv[1])))
