"""Where do CH1 cameras stand in their terrain: on ridges, on slopes or in valleys? (a diagnostic)

``python experiments/ch1/stance-tpi/tpi.py > tpi.txt`` (from the repository root)

For each of the 73 training-side photos (the rows of ``../confidence-train-rows.json``: fov given, no abstention), the
topographic position of the true camera and of the answer: the SRTM3 ground there less the mean ground 250, 500 and
1,000 m around it (24 directions each), and its percentile among 400 random points of the place's DEM window.
"""
import json, math, numpy as np
from skyrender.benchmarks.real_localize import places_of, place_dem
from skyrender.datasets.real_photos import items_on_side
rows={r['photo']:r for r in json.load(open('experiments/ch1/confidence-train-rows.json'))['rows']}
items=[it for s in ('train','dev') for it in items_on_side(s) if it.key in rows]
place_of, centres = places_of(items)
ang=np.linspace(0,2*np.pi,24,endpoint=False)
def tpi(dem,x,y,r):
    g0=dem.ground(np.array([x]),np.array([y]))[0]
    xs=x+np.outer(r,np.cos(ang)).ravel(); ys=y+np.outer(r,np.sin(ang)).ravel()
    g=dem.ground(xs,ys)
    return g0-np.nanmean(g)
rng=np.random.default_rng(0)
out=[]
cur=None
for it in sorted(items,key=lambda i:place_of[i.key]):
    pl=place_of[it.key]
    if pl!=cur:
        dem,_=place_dem(*centres[pl]); cur=pl
        x0,x1,y0,y1=dem.extent
        # random reference points in the inner window
        rx=rng.uniform(x0+5000,x1-5000,400); ry=rng.uniform(y0+5000,y1-5000,400)
        ref=np.array([tpi(dem,a,b,np.array([250,500,1000])) for a,b in zip(rx,ry)])
    r=rows[it.key]; t=r['truth_xy']
    best=min(r['refined_poses'],key=lambda q:q[-1]); e=math.hypot(best[0]-t[0],best[1]-t[1])
    tt=tpi(dem,t[0],t[1],np.array([250,500,1000])); ta=tpi(dem,best[0],best[1],np.array([250,500,1000]))
    out.append((it.key,pl,e<1000,tt,ta,float(np.mean(ref<tt)),float(np.mean(ref<ta))))
    print(f"{it.key:32s} {pl:12s} right={e<1000!s:5s} tpi_truth {tt:7.1f} pct {np.mean(ref<tt):.2f} | tpi_answer {ta:7.1f} pct {np.mean(ref<ta):.2f}",flush=True)
pt=np.array([o[5] for o in out]); pa=np.array([o[6] for o in out]); right=np.array([o[2] for o in out])
print('truth percentile: median',np.median(pt),'quartiles',np.percentile(pt,[25,75]))
print('wrong answers percentile: median',np.median(pa[~right]),'quartiles',np.percentile(pa[~right],[25,75]))
print('right answers percentile: median',np.median(pa[right]))
