import time, numpy as np
from skyrender.render import Terrain, render_skylines
from skyrender.render import skyline as sk
from skyrender.render.skyline import strided_skylines
from skyrender.camera import Intrinsics
from skyrender.benchmarks import real_localize as rl
rng=np.random.default_rng(1)
dem=rl.place_dem(46.5572,7.8352)[0]; t=Terrain(dem); cx,cy=dem.centre
P=3000
xy=np.column_stack([cx+rng.uniform(-20000,20000,P), cy+rng.uniform(-20000,20000,P)])
z=dem.ground(xy[:,0],xy[:,1])+2
poses=np.column_stack([xy,z,rng.uniform(0,360,P),rng.uniform(-5,20,P),rng.uniform(-5,5,P)])
K=Intrinsics.from_fov(50,1024,768)
cases={'verify (stride 4, tol 0.5, distance)': lambda: strided_skylines(t,poses,K,4,0.5,with_distance=True),
       'local_search (stride 2, tol 0.1)': lambda: strided_skylines(t,poses[:1000],K,2,0.1),
       'least squares (1 pose, full, tol 0.05) x50': lambda: [render_skylines(t,poses[i],K,tol=0.05) for i in range(50)]}
for name,f in cases.items():
    ts={'two-pass':[], 'whole':[]}
    for r in range(4):
        for mode in (('two-pass','whole') if r%2 else ('whole','two-pass')):
            sk.COARSE_COLUMNS = 4 if mode=='two-pass' else None
            t0=time.perf_counter(); f(); ts[mode].append(time.perf_counter()-t0)
    a,b=np.median(ts['whole'][1:]),np.median(ts['two-pass'][1:])
    print(f'{name}: whole {a:.2f} s, two-pass {b:.2f} s, {b/a:.2f}x')
